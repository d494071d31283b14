//! One closed-loop run on the twin: the baseline PID or the servo's per-sample step (controller,
//! identifier, background redesign and hand-over) behind the twin's controller interface.

use sledid::control::{ControlFlags, Redesign, Region, ScheduledDesign};
use sledid::ident::step::IdentifierDesign;
use sledid::servo::{
    SafetyDesign, ServoDesign, ServoOptions, SledServo, SledServoState, StopReason, VELOCITY_N,
};

use super::design::{identifier_design, scheduled_design_for};
use super::summary::{ControlSummary, ControllerKind, summarize};
use crate::reference::control::{FixedPid, baseline_design, position_from_quanta};
use crate::twin::{PlantParams, SledController, Twin, TwinParams};

/// The servo (the library's per-sample step: controller, identifier, safety layer, redesign
/// hand-over) behind the twin's controller interface; the redesign runs after the sample that
/// requests it, as the firmware's main loop would before the next interrupt.
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
    /// The first safe stop: sample index and reason.
    pub first_stop: Option<(usize, StopReason)>,
}

impl ScheduledLoop {
    /// From a design and the identifier's design, the servo's default options.
    pub fn new(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
    ) -> Result<Self, String> {
        Self::with_options(design, identifier, ServoOptions::default())
    }

    /// As [`Self::new`], with the servo's options (hand-over latency, identification) and its
    /// default safety layer for this design ([`ServoDesign::new`]).
    pub fn with_options(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
        options: ServoOptions,
    ) -> Result<Self, String> {
        Self::with_safety(
            design,
            identifier,
            options,
            ServoDesign::new(*design).safety,
        )
    }

    /// As [`Self::with_options`], with the safety layer `safety`.
    pub fn with_safety(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
        options: ServoOptions,
        safety: SafetyDesign,
    ) -> Result<Self, String> {
        let config = ServoDesign {
            controller: *design,
            velocity: *identifier,
            options,
            safety,
        }
        .build()
        .map_err(|e| e.to_string())?;
        Ok(Self {
            state: config.new_state(),
            config,
            u_full_scale_v: design.baseline.u_full_scale_v,
            trace: Vec::new(),
            redesigns: Vec::new(),
            first_stop: None,
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
        if let (None, Some(reason)) = (self.first_stop, out.stop) {
            self.first_stop = Some((self.trace.len(), reason));
        }
        self.trace.push((out.region, out.control));
        out.u.to_f64() * self.u_full_scale_v
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
    /// The servo's first safe stop (sample, reason), if any.
    pub first_stop: Option<(usize, StopReason)>,
}

impl ControlRun {
    /// Per seek of the twin's schedule (in order, ended or not), the fine steps the scheduled
    /// controller started in it: samples flagged `FINE_STEP` whose previous sample was not (0
    /// for the baseline, which has no trace).
    pub fn fine_steps_per_seek(&self) -> Vec<usize> {
        let on = |k: usize| {
            self.trace
                .get(k)
                .is_some_and(|(_, f)| f.contains(ControlFlags::FINE_STEP))
        };
        self.twin
            .seeks()
            .iter()
            .map(|seek| {
                let end = seek.end_index.unwrap_or(self.trace.len());
                (seek.start_index.max(1)..end)
                    .filter(|&k| on(k) && !on(k - 1))
                    .count()
            })
            .collect()
    }
}

/// The servo's safety layer on the twin `params`: [`ServoDesign::new`]'s for `design`, with soft
/// end stops half the twin's travel beyond the farthest target it commands (quanta of the plant)
/// — farther where the prior's sled, cut off at its top speed b·u_max/(1 − a), would coast past
/// them (T_coast · top speed + the margin beyond the travel): a sled of the family with a ≈ 0.98
/// coasts 10,000 quanta from top speed, and the layer would otherwise stop it for arriving at top
/// speed on a healthy seek.
pub fn twin_safety(params: &TwinParams, design: &ScheduledDesign) -> SafetyDesign {
    let safety = ServoDesign::new(*design).safety;
    let half = 0.5 * f64::from(params.reference.travel_tracks);
    let top_coast = design.prior_model.map_or(0.0, |(a, b)| {
        let u_max = design.baseline.u_limit_v / design.baseline.u_full_scale_v;
        safety.coast_samples * b * u_max / (1.0 - a.clamp(0.0, 0.99))
    });
    let travel = (3.0 * half).max(half + top_coast + safety.travel_margin_quanta);
    SafetyDesign {
        travel_min_quanta: -travel,
        travel_max_quanta: travel,
        ..safety
    }
}

/// Runs `seeks` random seeks of `params` with `kind` in the loop, the scheduled controller
/// tuned on the default sled ([`super::design::scheduled_design`]).
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
    let (trace, redesigns, first_stop, kind) = match design {
        None => {
            let design = baseline_design(&params.controller, p.ts_s, p.u_max_v);
            let mut c = FixedPid::new(&design).map_err(|e| e.to_string())?;
            twin.set_controller_label("baseline_fixed_pid");
            twin.run(&mut c);
            (Vec::new(), Vec::new(), None, ControllerKind::Baseline)
        }
        Some(design) => {
            let mut c = ScheduledLoop::with_safety(
                design,
                &identifier_design(design),
                options,
                twin_safety(&params, design),
            )?;
            twin.set_controller_label("scheduled");
            twin.run(&mut c);
            (
                c.trace,
                c.redesigns,
                c.first_stop,
                ControllerKind::Scheduled,
            )
        }
    };
    let mut summary = summarize(&twin, &trace, &redesigns, kind, seed);
    summary.safe_stop = first_stop.map(|(_, reason)| format!("{reason:?}"));
    Ok(ControlRun {
        twin,
        trace,
        summary,
        redesigns,
        first_stop,
    })
}
