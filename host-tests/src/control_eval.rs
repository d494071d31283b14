//! `sledid control`: the sled twin in closed loop with the library's controllers — the baseline PID
//! (`sledid::control::pid`) or the gain-scheduled controller (`sledid::control::scheduled`) fed by
//! the identifier through `sledid::ident::step::step`, the firmware's per-sample function — and the
//! settling statistics the issue asks for, a JSON summary and a plot of a few step responses.
//!
//! The scheduled controller is tuned on a *nominal* plant ([`scheduled_design_for`]): the
//! `--plant` file's (the default sled without one). `--perturb` ([`Perturbation`]) runs the loop on
//! that plant with its mass, friction or quantum scaled, which the controller was not tuned on.
//! The default twin's baseline is the paper's kind of badly tuned loop, which oscillates while
//! settling (`host-tests/plants/paper_sled.json` writes it out); `host-tests/plants/well_damped.json`
//! is the same sled under the earlier, well-damped baseline (see the README beside them).
//!
//! # Measures (per seek; the error is `target − y` in quanta, as in `twin::analysis`)
//! - settling time: from the seek's first sample until |e| ≤ 1 for the rest of the seek; a seek
//!   that never settles counts as `unsettled` and enters the statistics with its whole length (a
//!   lower bound of its settling time);
//! - overshoot: beyond the target after the first entry into |e| ≤ 1;
//! - `limit_cycle_pulses`: runs of |u| above the breakaway voltage in the last half of each dwell
//!   (`twin::analysis`, the same window for both controllers); `hold_pulses`: such runs while the
//!   scheduled controller is in Hold;
//! - `reference_bound_ms`: when the reference itself comes within 1 quantum of the target for
//!   good — no controller that follows the reference settles earlier (by more than the overshoot
//!   of a faster-than-reference seek, which the reference does not ask for).

use serde::Serialize;
use sledid::control::{ControlFlags, InverseInputMap, Redesign, Region, ScheduledDesign};
use sledid::ident::step::IdentifierDesign;
use sledid::servo::{ServoDesign, ServoOptions, SledServo, SledServoState, VELOCITY_N};
use std::path::Path;

use crate::reference::control::{FixedPid, baseline_design, position_from_quanta};
use crate::twin::{PlantParams, SledController, Twin, TwinParams};

/// Which controller closes the loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// The paper's badly tuned PID (the parameters' `controller` gains) in fixed point.
    Baseline,
    /// The gain-scheduled controller with the on-line identifier.
    Scheduled,
}

/// The identifier feeding the scheduled controller `design`: the library's
/// [`sledid::servo::velocity_identifier`] from the design's prior and the Coulomb level of its
/// compensation ([`ServoDesign::new`]), the one the firmware runs too.
pub fn identifier_design(design: &ScheduledDesign) -> IdentifierDesign<VELOCITY_N> {
    ServoDesign::new(*design).velocity
}

/// The velocity model (a, b) of a plant from its physics (viscous pole, drive gain; friction
/// ignored): `a = e^{−b_v·Ts/m}`, `b = (1 − a)·k_f·u_fs/b_v·Ts/q` quanta per sample per full scale.
pub fn physical_model(plant: &PlantParams) -> (f64, f64) {
    let a = (-plant.viscous_n_s_per_m * plant.ts_s / plant.mass_kg).exp();
    let v_fs_m_per_s = plant.force_per_volt_n_per_v * plant.u_max_v / plant.viscous_n_s_per_m;
    (a, (1.0 - a) * v_fs_m_per_s * plant.ts_s / plant.quantum_m)
}

/// The scheduled design for a twin, tuned on the default sled ([`PlantParams::default`]):
/// [`scheduled_design_for`] with that sled as the nominal plant.
pub fn scheduled_design(params: &TwinParams) -> Result<ScheduledDesign, String> {
    scheduled_design_for(params, &PlantParams::default())
}

/// The scheduled design for the twin `params`, tuned on the plant `nominal`: the nominal plant's
/// physical velocity model as the prior, its Coulomb friction as the compensated input map, the
/// baseline PID of `params` as the fallback. Only the sampling period, rail and quantum of
/// `params.plant` are used (the units the controller works in), not its mass or friction: on a
/// perturbed plant the controller still believes the nominal physics.
pub fn scheduled_design_for(
    params: &TwinParams,
    nominal: &PlantParams,
) -> Result<ScheduledDesign, String> {
    let p = &params.plant;
    let nominal = PlantParams {
        ts_s: p.ts_s,
        u_max_v: p.u_max_v,
        quantum_m: p.quantum_m,
        ..nominal.clone()
    };
    let mut d = ScheduledDesign::new(baseline_design(&params.controller, p.ts_s, p.u_max_v));
    d.prior_model = Some(physical_model(&nominal));
    let coulomb_fs = nominal.coulomb_n / nominal.force_per_volt_n_per_v / nominal.u_max_v;
    d.compensation =
        Some(InverseInputMap::coulomb(coulomb_fs, 0.9, 0.05).map_err(|e| e.to_string())?);
    Ok(d)
}

/// The firmware's whole per-sample step ([`sledid::servo`]: scheduled controller, its
/// velocity identifier) behind the twin's controller
/// interface; the redesign runs after the sample that requests it, as the firmware's main loop
/// would before the next interrupt.
pub struct ScheduledLoop {
    /// The loop configuration (its controller gains swapped by redesigns).
    pub config: SledServo,
    /// The loop state.
    pub state: SledServoState,
    u_full_scale_v: f64,
    /// Per sample: the region and flags.
    pub trace: Vec<(Region, ControlFlags)>,
    /// Every redesign outcome.
    pub redesigns: Vec<Redesign>,
}

impl ScheduledLoop {
    /// From a design and the identifier's design, the servo's default options.
    pub fn new(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
    ) -> Result<Self, String> {
        Self::with_options(design, identifier, ServoOptions::default())
    }

    /// As [`Self::new`], with the servo's options (hand-over latency, identification).
    pub fn with_options(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
        options: ServoOptions,
    ) -> Result<Self, String> {
        let config = ServoDesign {
            controller: *design,
            velocity: *identifier,
            options,
        }
        .build()
        .map_err(|e| e.to_string())?;
        Ok(Self {
            state: config.new_state(),
            config,
            u_full_scale_v: design.baseline.u_full_scale_v,
            trace: Vec::new(),
            redesigns: Vec::new(),
        })
    }

    /// The identifier's θ now.
    pub fn theta(&self) -> [f64; VELOCITY_N] {
        self.state.identifier().model().theta().map(|p| p.to_f64())
    }
}

impl SledController for ScheduledLoop {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let (r, y) = (
            position_from_quanta(r_counts),
            position_from_quanta(y_counts),
        );
        let out = self.config.step(&mut self.state, r, y);
        // The background's turn between two samples (the hand-over adopts it at k + L).
        if let Some(design) = self.config.run_background(&mut self.state) {
            self.redesigns.push(design.outcome);
        }
        self.trace.push((out.region, out.control));
        out.u.to_f64() * self.u_full_scale_v
    }
}

/// Median, 90th percentile and maximum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Spread {
    /// Median.
    pub median: f64,
    /// 90th percentile (nearest rank).
    pub p90: f64,
    /// Maximum.
    pub max: f64,
}

impl Spread {
    /// Of `values` (0 for none).
    pub fn of(values: &[f64]) -> Self {
        let mut v: Vec<f64> = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| {
            let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len().max(1)) - 1;
            v.get(i).copied().unwrap_or(0.0)
        };
        Self {
            median: if v.is_empty() {
                0.0
            } else if v.len() % 2 == 1 {
                v.get(v.len() / 2).copied().unwrap_or(0.0)
            } else {
                (v.get(v.len() / 2 - 1).copied().unwrap_or(0.0)
                    + v.get(v.len() / 2).copied().unwrap_or(0.0))
                    / 2.0
            },
            p90: at(0.9),
            max: v.last().copied().unwrap_or(0.0),
        }
    }
}

/// Redesign outcomes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RedesignCounts {
    /// Gains placed.
    pub applied: usize,
    /// No trusted update since the last design.
    pub skipped: usize,
    /// Model refused by the supervisor.
    pub rejected: usize,
}

/// `DIR/summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControlSummary {
    /// Which controller.
    pub controller: ControllerKind,
    /// Seed of the seeks and the noise.
    pub seed: u64,
    /// Seeks evaluated.
    pub seeks: usize,
    /// The plant.
    pub plant: PlantParams,
    /// Settling time, ms.
    pub settling_ms: Spread,
    /// Settling time counted from the reference's arrival at the target, ms (≥ 0).
    pub settling_after_arrival_ms: Spread,
    /// When the reference itself is within 1 quantum of the target for good, ms.
    pub reference_bound_ms: Spread,
    /// Overshoot, quanta (`p90` included).
    pub overshoot_quanta: Spread,
    /// Pulses above breakaway in the last half of every dwell.
    pub limit_cycle_pulses: usize,
    /// Pulses above breakaway while in Hold (scheduled only).
    pub hold_pulses: usize,
    /// Seeks that never settled.
    pub unsettled: usize,
    /// Entries into the fallback (scheduled only).
    pub fallbacks: usize,
    /// Samples in the fallback.
    pub fallback_samples: usize,
    /// Redesign outcomes (scheduled only).
    pub redesigns: RedesignCounts,
    /// Largest |u| applied, V.
    pub u_peak_v: f64,
}

impl ControlSummary {
    /// The header of [`Self::table_row`].
    pub const TABLE_HEADER: &'static str = "| plant | controller | settling median / p90 / max (ms) | after arrival, median (ms) | reference bound (ms) | overshoot median / max (quanta) | limit-cycle pulses | hold pulses | unsettled | fallbacks |\n|---|---|---|---|---|---|---|---|---|---|";

    /// One Markdown table row (the columns of [`Self::TABLE_HEADER`]) for the plant `name`.
    pub fn table_row(&self, name: &str) -> String {
        format!(
            "| {name} | {:?} | {:.1} / {:.1} / {:.1} | {:.1} | {:.1} | {:.0} / {:.0} | {} | {} | {} | {} |",
            self.controller,
            self.settling_ms.median,
            self.settling_ms.p90,
            self.settling_ms.max,
            self.settling_after_arrival_ms.median,
            self.reference_bound_ms.median,
            self.overshoot_quanta.median,
            self.overshoot_quanta.max,
            self.limit_cycle_pulses,
            self.hold_pulses,
            self.unsettled,
            self.fallbacks
        )
    }
}

/// A finished closed-loop run.
pub struct ControlRun {
    /// The twin with its recording.
    pub twin: Twin,
    /// Per sample region and flags (scheduled only).
    pub trace: Vec<(Region, ControlFlags)>,
    /// The summary.
    pub summary: ControlSummary,
    /// Every redesign outcome, in order (scheduled only).
    pub redesigns: Vec<Redesign>,
}

/// Runs `seeks` random seeks of `params` with `kind` in the loop, the scheduled controller
/// tuned on the default sled ([`scheduled_design`]).
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    kind: ControllerKind,
) -> Result<ControlRun, String> {
    run_tuned(params, &PlantParams::default(), seed, seeks, kind)
}

/// Runs `seeks` random seeks of `params` with `kind` in the loop, the scheduled controller tuned
/// on the plant `nominal` ([`scheduled_design_for`]).
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_tuned(
    params: &TwinParams,
    nominal: &PlantParams,
    seed: u64,
    seeks: u32,
    kind: ControllerKind,
) -> Result<ControlRun, String> {
    match kind {
        ControllerKind::Baseline => run_with(params, seed, seeks, None),
        ControllerKind::Scheduled => {
            let design = scheduled_design_for(params, nominal)?;
            run_with(params, seed, seeks, Some(&design))
        }
    }
}

/// Runs `seeks` random seeks of `params` with the baseline (`design` = `None`) or the scheduled
/// controller of `design` in the loop.
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_with(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    design: Option<&ScheduledDesign>,
) -> Result<ControlRun, String> {
    run_with_options(params, seed, seeks, design, ServoOptions::default())
}

/// [`run_with`] with the servo's options.
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_with_options(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    design: Option<&ScheduledDesign>,
    options: ServoOptions,
) -> Result<ControlRun, String> {
    let mut params = params.clone();
    params.reference.seek_count = seeks;
    params.reference.targets_tracks = None;
    let mut twin = Twin::new(params.clone(), seed).map_err(|e| e.to_string())?;
    let p = &params.plant;
    let (trace, redesigns, kind) = match design {
        None => {
            let design = baseline_design(&params.controller, p.ts_s, p.u_max_v);
            let mut c = FixedPid::new(&design).map_err(|e| e.to_string())?;
            twin.set_controller_label("baseline_fixed_pid");
            twin.run(&mut c);
            (Vec::new(), Vec::new(), ControllerKind::Baseline)
        }
        Some(design) => {
            let mut c = ScheduledLoop::with_options(design, &identifier_design(design), options)?;
            twin.set_controller_label("scheduled");
            twin.run(&mut c);
            (c.trace, c.redesigns, ControllerKind::Scheduled)
        }
    };
    let summary = summarize(&twin, &trace, &redesigns, kind, seed);
    Ok(ControlRun {
        twin,
        trace,
        summary,
        redesigns,
    })
}

fn summarize(
    twin: &Twin,
    trace: &[(Region, ControlFlags)],
    redesigns: &[Redesign],
    kind: ControllerKind,
    seed: u64,
) -> ControlSummary {
    let plant = twin.params().plant.clone();
    let ts_ms = plant.ts_s * 1e3;
    let breakaway_v = plant.static_n / plant.force_per_volt_n_per_v;
    let stats = twin.seek_stats();
    let samples = twin.samples();
    let (mut settle, mut after, mut bound, mut over) = (vec![], vec![], vec![], vec![]);
    let mut unsettled = 0;
    for (seek, st) in twin.seeks().iter().zip(&stats) {
        let (Some(arrival), Some(end)) = (seek.arrival_index, seek.end_index) else {
            continue;
        };
        let length_ms = (end - seek.start_index) as f64 * ts_ms;
        let s_ms = st.settling_time_s.map_or_else(
            || {
                unsettled += 1;
                length_ms
            },
            |s| s * 1e3,
        );
        settle.push(s_ms);
        after.push((s_ms - (arrival - seek.start_index) as f64 * ts_ms).max(0.0));
        let last_far = samples
            .get(seek.start_index..end)
            .unwrap_or(&[])
            .iter()
            .rposition(|s| (s.r_m / plant.quantum_m - seek.target_counts as f64).abs() > 1.0);
        bound.push(last_far.map_or(0.0, |i| (i + 1) as f64 * ts_ms));
        over.push(st.overshoot_counts as f64);
    }
    let mut hold_pulses = 0;
    let mut in_pulse = false;
    for (s, (region, _)) in samples.iter().zip(trace) {
        let strong = *region == Region::Hold && s.u_v.abs() > breakaway_v;
        hold_pulses += usize::from(strong && !in_pulse);
        in_pulse = strong;
    }
    let mut fallbacks = 0;
    let mut was = false;
    for (_, f) in trace {
        let now = f.contains(ControlFlags::FALLBACK);
        fallbacks += usize::from(now && !was);
        was = now;
    }
    let mut counts = RedesignCounts::default();
    for r in redesigns {
        match r {
            Redesign::Applied(_) => counts.applied += 1,
            Redesign::Skipped => counts.skipped += 1,
            Redesign::Rejected(_) => counts.rejected += 1,
        }
    }
    ControlSummary {
        controller: kind,
        seed,
        seeks: settle.len(),
        plant,
        settling_ms: Spread::of(&settle),
        settling_after_arrival_ms: Spread::of(&after),
        reference_bound_ms: Spread::of(&bound),
        overshoot_quanta: Spread::of(&over),
        limit_cycle_pulses: stats.iter().map(|s| s.limit_cycle.pulses).sum(),
        hold_pulses,
        unsettled,
        fallbacks,
        fallback_samples: trace
            .iter()
            .filter(|(_, f)| f.contains(ControlFlags::FALLBACK))
            .count(),
        redesigns: counts,
        u_peak_v: samples.iter().fold(0.0, |m: f64, s| m.max(s.u_v.abs())),
    }
}

/// A copy of `params` with the mass, friction (Coulomb and static) and quantum scaled.
pub fn perturbed(params: &TwinParams, mass: f64, friction: f64, quantum: f64) -> TwinParams {
    let mut p = params.clone();
    p.plant.mass_kg *= mass;
    p.plant.coulomb_n *= friction;
    p.plant.static_n *= friction;
    p.plant.quantum_m *= quantum;
    p
}

/// Scale factors of a plant the controller was not tuned on (`--perturb`): mass, friction
/// (Coulomb and static together) and sensor quantum, each 1 when not given.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Perturbation {
    /// Mass factor.
    pub mass: f64,
    /// Friction factor.
    pub friction: f64,
    /// Quantum factor.
    pub quantum: f64,
}

impl Default for Perturbation {
    fn default() -> Self {
        Self {
            mass: 1.0,
            friction: 1.0,
            quantum: 1.0,
        }
    }
}

impl Perturbation {
    /// Parses `mass=0.7,friction=1.5,quantum=2` (any subset, any order).
    ///
    /// # Errors
    /// An unknown key, a missing `=`, or a factor that is not finite and > 0.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut p = Self::default();
        for item in text.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| format!("--perturb: `{item}` is not KEY=FACTOR"))?;
            let factor: f64 = value
                .trim()
                .parse()
                .map_err(|e| format!("--perturb: `{item}`: {e}"))?;
            if !(factor.is_finite() && factor > 0.0) {
                return Err(format!(
                    "--perturb: `{item}`: the factor must be finite and > 0"
                ));
            }
            match key.trim() {
                "mass" => p.mass = factor,
                "friction" => p.friction = factor,
                "quantum" => p.quantum = factor,
                other => {
                    return Err(format!(
                        "--perturb: unknown key `{other}` (mass, friction, quantum)"
                    ));
                }
            }
        }
        Ok(p)
    }

    /// The seven plants issue 5's targets name: nominal, mass ×0.7 and ×1.3, friction (Coulomb
    /// and static) ×0.5 and ×1.5, quantum ×0.5 and ×2.
    pub const ISSUE_PLANTS: [(&'static str, Perturbation); 7] = [
        ("nominal", Self::scale(1.0, 1.0, 1.0)),
        ("mass ×0.7", Self::scale(0.7, 1.0, 1.0)),
        ("mass ×1.3", Self::scale(1.3, 1.0, 1.0)),
        ("friction ×0.5", Self::scale(1.0, 0.5, 1.0)),
        ("friction ×1.5", Self::scale(1.0, 1.5, 1.0)),
        ("quantum ×0.5", Self::scale(1.0, 1.0, 0.5)),
        ("quantum ×2", Self::scale(1.0, 1.0, 2.0)),
    ];

    const fn scale(mass: f64, friction: f64, quantum: f64) -> Self {
        Self {
            mass,
            friction,
            quantum,
        }
    }

    /// `params` scaled by these factors ([`perturbed`]).
    pub fn apply(&self, params: &TwinParams) -> TwinParams {
        perturbed(params, self.mass, self.friction, self.quantum)
    }
}

/// `sledid control`: runs, writes `DIR/summary.json` and `DIR/step_responses.png`, prints the
/// summary.
///
/// The scheduled controller is tuned on the plant of `plant` (the default sled without one); with
/// `perturb` the loop runs on that plant scaled, which the controller was not tuned on.
///
/// # Errors
/// Parameter, run, file or plot errors.
pub fn control_cmd(
    plant: Option<&Path>,
    perturb: Option<Perturbation>,
    kind: ControllerKind,
    seeks: u32,
    seed: u64,
    out: &Path,
) -> Result<(), String> {
    let nominal = match plant {
        Some(p) => TwinParams::from_json_file(p).map_err(|e| e.to_string())?,
        None => TwinParams::default(),
    };
    let params = perturb.unwrap_or_default().apply(&nominal);
    params.validate().map_err(|e| e.to_string())?;
    let run = run_tuned(&params, &nominal.plant, seed, seeks, kind)?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let json = serde_json::to_string_pretty(&run.summary).map_err(|e| e.to_string())?;
    let path = out.join("summary.json");
    std::fs::write(&path, json.clone() + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    crate::control_plot::plot_steps(&run, &out.join("step_responses.png"), 4)?;
    println!("{json}\n→ {}", out.display());
    Ok(())
}
