//! The servo judged on the plant family (`sledid control-family`): every plant of a seeded
//! [`family`](super::family) runs the same seeks under four controllers, each designed from the
//! same prior (the nominal sled, quantum included), never from the plant:
//!
//! | variant | what runs |
//! |---|---|
//! | `baseline` | the paper's badly tuned PID |
//! | `identified` | the servo: scheduled controller, on-line identification, friction identified and compensated |
//! | `frozen` | the same servo with identification frozen at the prior (the ablation) |
//! | `linear_only` | the servo identifying on-line, its input compensation left at the prior's (linear-only scheduling) |
//!
//! Each plant's seek window is the twin's 0.3 s, or three times the plant's own 2,000-track
//! minimum-time seek where that is longer ([`dwell_for_plant`], as the seek pass's): a window
//! shorter than the plant's fastest seek would count its physics as the servo's unsettled seeks.
//!
//! Plants run in parallel (rayon); the statistics are over plants, not over a few seeds.
//! [`FamilyStats`] holds what the servo issue's targets name; `BENCHMARKS.md` (control family)
//! carries the table and the command.

use indicatif::ProgressBar;
use rayon::prelude::*;
use serde::Serialize;
use sledid::servo::{Identification, ServoOptions};

use super::design::{design_from_prior, physical_model};
use super::family::{FamilyRanges, PlantFactors};
use super::run::run_with_options;
use super::seek::run::dwell_for_plant;
use super::summary::ControlSummary;
use crate::twin::{PlantParams, TwinParams};

/// What to run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FamilyOptions {
    /// Plants.
    pub plants: u64,
    /// The family's seed (plant i is stream i of it: the same plant whatever `plants`).
    pub seed: u64,
    /// Seeks per plant and controller.
    pub seeks: u32,
    /// Seed of every run's seeks and sensor noise.
    pub run_seed: u64,
    /// The family's ranges.
    pub ranges: FamilyRanges,
    /// The plant every servo is designed from.
    pub prior: PlantParams,
    /// Each plant's servo designed from that plant itself instead of `prior` (the seek pass:
    /// isolates the seek law from the prior's error).
    pub exact_prior: bool,
    /// The seek pass's servos never adapt (identification frozen at the prior).
    pub frozen: bool,
    /// The seek pass's seek mode calibrates at power-on.
    pub calibrate: bool,
}

impl FamilyOptions {
    /// The plant a servo on `plant` is designed from: `plant` itself with `exact_prior`, else
    /// `prior`.
    pub fn prior_for<'a>(&'a self, plant: &'a PlantParams) -> &'a PlantParams {
        if self.exact_prior { plant } else { &self.prior }
    }
}

impl Default for FamilyOptions {
    fn default() -> Self {
        Self {
            plants: 200,
            seed: 1,
            seeks: 100,
            run_seed: 1,
            ranges: FamilyRanges::default(),
            prior: PlantParams::default(),
            exact_prior: false,
            frozen: false,
            calibrate: false,
        }
    }
}

/// One controller's run on one plant, in brief.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RunBrief {
    /// Median settling time, ms (an unsettled seek counts with its whole length).
    pub settling_median_ms: f64,
    /// 90th percentile of the settling time, ms.
    pub settling_p90_ms: f64,
    /// Seeks that never settled.
    pub unsettled: usize,
    /// Limit-cycle pulses over all seeks.
    pub limit_cycle_pulses: usize,
    /// Fine steps that landed, over all seeks (not pulses).
    pub fine_steps: usize,
    /// Largest |target − y| read while holding, quanta (0 without Hold).
    pub hold_error_max_quanta: f64,
    /// Largest |target − x| of the true position while holding, quanta.
    pub hold_true_error_max_quanta: f64,
    /// Entries into the fallback.
    pub fallbacks: usize,
    /// Redesigns applied.
    pub redesigns_applied: usize,
    /// The safety layer stopped the servo.
    pub safe_stop: bool,
    /// The servo suspended identification (the fallbacks' recovery: its prior's design kept).
    pub identification_suspended: bool,
}

impl RunBrief {
    fn of(s: &ControlSummary) -> Self {
        Self {
            settling_median_ms: s.settling_ms.median,
            settling_p90_ms: s.settling_ms.p90,
            unsettled: s.unsettled,
            limit_cycle_pulses: s.limit_cycle_pulses,
            fine_steps: s.fine_steps,
            hold_error_max_quanta: s.hold_error_quanta.max,
            hold_true_error_max_quanta: s.hold_true_error_quanta.max,
            fallbacks: s.fallbacks,
            redesigns_applied: s.redesigns.applied,
            safe_stop: s.safe_stop.is_some(),
            identification_suspended: s.identification_suspended_at.is_some(),
        }
    }

    /// No limit-cycle pulse and no unsettled seek.
    pub fn clean(&self) -> bool {
        self.unsettled == 0 && self.limit_cycle_pulses == 0
    }
}

/// One plant's results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlantResult {
    /// Index in the family.
    pub index: u64,
    /// Its factors.
    pub factors: PlantFactors,
    /// [`PlantFactors::prior_error`]: the prior's gain or time-constant error, relative.
    pub prior_error: f64,
    /// Coulomb friction relative to the prior's (in drive units: Coulomb force over force
    /// constant).
    pub friction_ratio: f64,
    /// The paper's PID.
    pub baseline: RunBrief,
    /// The servo.
    pub identified: RunBrief,
    /// The servo frozen at the prior.
    pub frozen: RunBrief,
    /// The servo without friction identification.
    pub linear_only: RunBrief,
    /// Samples of one run.
    pub samples: u64,
}

impl PlantResult {
    /// The servo's median settling over the baseline's.
    pub fn ratio_to_baseline(&self) -> f64 {
        self.identified.settling_median_ms / self.baseline.settling_median_ms
    }

    /// The servo's median settling over the frozen servo's.
    pub fn ratio_to_frozen(&self) -> f64 {
        self.identified.settling_median_ms / self.frozen.settling_median_ms
    }
}

/// A plant "far from the prior": gain or pole more than this far off, relative.
pub const OFF_PRIOR: f64 = 0.3;
/// A "high-friction" plant: Coulomb friction (drive units) at least this many times the prior's.
pub const HIGH_FRICTION: f64 = 1.5;
/// "No worse than frozen" up to this ratio of median settling (one sample of 0.455 ms in ≈ 30 ms
/// is 1.5 %; the medians of two runs on the same seeks differ by whole samples).
pub const NO_WORSE: f64 = 1.02;

/// The family's statistics (what the servo issue's targets name).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FamilyStats {
    /// Plants.
    pub plants: usize,
    /// Fraction of plants with 0 pulses and 0 unsettled seeks under the servo.
    pub clean: f64,
    /// The same under the frozen servo.
    pub clean_frozen: f64,
    /// The same under the baseline.
    pub clean_baseline: f64,
    /// Fraction of plants whose servo median settling is ≤ 0.7× the baseline's.
    pub ratio_le_0_7: f64,
    /// Plants where the servo's median settling is more than [`NO_WORSE`]× the frozen servo's.
    pub worse_than_frozen: usize,
    /// Plants with a prior more than [`OFF_PRIOR`] off.
    pub off_prior: usize,
    /// Fraction of those whose servo settles ≥ 20 % faster (median) than the frozen servo.
    pub off_prior_gain_20: f64,
    /// Largest holding error read in Hold over every plant, quanta.
    pub hold_error_max_quanta: f64,
    /// Largest true holding error in Hold over every plant, quanta.
    pub hold_true_error_max_quanta: f64,
    /// Plants with friction ≥ [`HIGH_FRICTION`]× the prior's.
    pub high_friction: usize,
    /// Over those: geometric mean of the median settling, identified friction / linear-only.
    pub high_friction_settling_ratio: f64,
    /// Over those: pulses + unsettled seeks, identified friction.
    pub high_friction_events: usize,
    /// Over those: pulses + unsettled seeks, linear-only.
    pub high_friction_events_linear: usize,
    /// Runs (any servo variant) the safety layer stopped: false stops on ordinary seeks.
    pub safe_stops: usize,
    /// Of those, runs of the servo itself (identified).
    pub safe_stops_servo: usize,
    /// Runs of the servo (identified) that suspended identification instead of the fallbacks'
    /// stop, and of the linear-only variant.
    pub suspended: [usize; 2],
    /// Samples the servo variants stepped in all.
    pub servo_samples: u64,
}

/// Everything `control-family` measured.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FamilyReport {
    /// What ran.
    pub options: FamilyOptions,
    /// Per plant.
    pub plants: Vec<PlantResult>,
    /// Over the plants.
    pub stats: FamilyStats,
}

/// Runs one plant under the four controllers.
///
/// # Errors
/// A design or run error, naming the plant.
pub fn evaluate_plant(options: &FamilyOptions, index: u64) -> Result<PlantResult, String> {
    let factors = options.ranges.draw(options.seed, index);
    let mut params = factors.twin(&TwinParams::default());
    let at = |e: String| format!("plant {index} ({}): {e}", factors.label());
    let r = &params.reference;
    params.reference.dwell_s =
        dwell_for_plant(&params.plant, r.seek_max_tracks, r.dwell_s).map_err(at)?;
    let design = design_from_prior(&params, options.prior_for(&params.plant)).map_err(at)?;
    let mut linear = design;
    linear.identify_friction = false;
    let frozen = ServoOptions {
        identification: Identification::FrozenAtPrior,
        ..ServoOptions::default()
    };
    let samples = std::cell::Cell::new(0u64);
    let run = |d: Option<&sledid::control::ScheduledDesign>, o: ServoOptions| {
        run_with_options(&params, options.run_seed, options.seeks, d, o)
            .map(|r| {
                samples.set(r.twin.samples().len() as u64);
                RunBrief::of(&r.summary)
            })
            .map_err(at)
    };
    let plant = &params.plant;
    let friction = |p: &PlantParams| p.coulomb_n / p.force_per_volt_n_per_v;
    Ok(PlantResult {
        index,
        factors,
        prior_error: factors.prior_error(physical_model),
        friction_ratio: friction(plant) / friction(options.prior_for(plant)),
        baseline: run(None, ServoOptions::default())?,
        identified: run(Some(&design), ServoOptions::default())?,
        frozen: run(Some(&design), frozen)?,
        linear_only: run(Some(&linear), ServoOptions::default())?,
        samples: samples.get(),
    })
}

/// Runs the family in parallel, ticking `progress` once per plant.
///
/// # Errors
/// The first plant's error.
pub fn evaluate(
    options: &FamilyOptions,
    progress: Option<&ProgressBar>,
) -> Result<FamilyReport, String> {
    let plants: Vec<PlantResult> = (0..options.plants)
        .into_par_iter()
        .map(|i| {
            let r = evaluate_plant(options, i);
            if let Some(p) = progress {
                p.inc(1);
            }
            r
        })
        .collect::<Result<_, _>>()?;
    let stats = stats(&plants);
    Ok(FamilyReport {
        options: options.clone(),
        plants,
        stats,
    })
}

fn fraction(plants: &[PlantResult], f: impl Fn(&PlantResult) -> bool) -> f64 {
    plants.iter().filter(|p| f(p)).count() as f64 / plants.len().max(1) as f64
}

/// The statistics of `plants`.
pub fn stats(plants: &[PlantResult]) -> FamilyStats {
    let off: Vec<&PlantResult> = plants
        .iter()
        .filter(|p| p.prior_error > OFF_PRIOR)
        .collect();
    let high: Vec<&PlantResult> = plants
        .iter()
        .filter(|p| p.friction_ratio >= HIGH_FRICTION)
        .collect();
    let log_ratio: f64 = high
        .iter()
        .map(|p| (p.identified.settling_median_ms / p.linear_only.settling_median_ms).ln())
        .sum();
    let events = |b: &RunBrief| b.unsettled + b.limit_cycle_pulses;
    FamilyStats {
        plants: plants.len(),
        clean: fraction(plants, |p| p.identified.clean()),
        clean_frozen: fraction(plants, |p| p.frozen.clean()),
        clean_baseline: fraction(plants, |p| p.baseline.clean()),
        ratio_le_0_7: fraction(plants, |p| p.ratio_to_baseline() <= 0.7),
        worse_than_frozen: plants
            .iter()
            .filter(|p| p.ratio_to_frozen() > NO_WORSE)
            .count(),
        off_prior: off.len(),
        off_prior_gain_20: off.iter().filter(|p| p.ratio_to_frozen() <= 0.8).count() as f64
            / off.len().max(1) as f64,
        hold_error_max_quanta: plants
            .iter()
            .map(|p| p.identified.hold_error_max_quanta)
            .fold(0.0, f64::max),
        hold_true_error_max_quanta: plants
            .iter()
            .map(|p| p.identified.hold_true_error_max_quanta)
            .fold(0.0, f64::max),
        high_friction: high.len(),
        high_friction_settling_ratio: (log_ratio / high.len().max(1) as f64).exp(),
        high_friction_events: high.iter().map(|p| events(&p.identified)).sum(),
        high_friction_events_linear: high.iter().map(|p| events(&p.linear_only)).sum(),
        safe_stops: plants
            .iter()
            .map(|p| {
                usize::from(p.identified.safe_stop)
                    + usize::from(p.frozen.safe_stop)
                    + usize::from(p.linear_only.safe_stop)
            })
            .sum(),
        safe_stops_servo: plants.iter().filter(|p| p.identified.safe_stop).count(),
        suspended: [
            plants
                .iter()
                .filter(|p| p.identified.identification_suspended)
                .count(),
            plants
                .iter()
                .filter(|p| p.linear_only.identification_suspended)
                .count(),
        ],
        servo_samples: plants.iter().map(|p| 3 * p.samples).sum(),
    }
}

/// The per-plant Markdown table: one row per plant, the four controllers' median settling,
/// pulses and unsettled seeks.
pub fn plant_table(report: &FamilyReport) -> String {
    let mut t = String::from(
        "| plant | factors | prior error | baseline ms (pulses/unsettled) | identified ms (p/u) | frozen ms (p/u) | linear-only ms (p/u) | identified / baseline | identified / frozen |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let cell = |b: &RunBrief| {
        format!(
            "{:.1} ({}/{})",
            b.settling_median_ms, b.limit_cycle_pulses, b.unsettled
        )
    };
    for p in &report.plants {
        t += &format!(
            "| {} | {} | {:.2} | {} | {} | {} | {} | {:.2} | {:.2} |\n",
            p.index,
            p.factors.label(),
            p.prior_error,
            cell(&p.baseline),
            cell(&p.identified),
            cell(&p.frozen),
            cell(&p.linear_only),
            p.ratio_to_baseline(),
            p.ratio_to_frozen()
        );
    }
    t
}

/// The summary table (the targets against what was measured).
pub fn stats_table(s: &FamilyStats) -> String {
    format!(
        "| measure | value |\n|---|---|\n\
         | plants | {} |\n\
         | clean (0 pulses, 0 unsettled): servo / frozen / baseline | {:.1} % / {:.1} % / {:.1} % |\n\
         | median settling ≤ 0.7× baseline | {:.1} % |\n\
         | servo slower than frozen (> {NO_WORSE}×) | {} plants |\n\
         | prior > {:.0} % off: plants, ≥ 20 % faster than frozen | {}, {:.1} % |\n\
         | largest holding error in Hold: read / true | {:.0} / {:.2} quanta |\n\
         | friction ≥ {HIGH_FRICTION}× prior: plants, settling identified / linear-only (geo. mean), events identified / linear-only | {}, {:.3}, {} / {} |\n\
         | safe stops over {} servo samples (all variants / the servo) | {} / {} |\n\
         | identification suspended (the fallbacks' recovery): the servo / linear-only | {} / {} |\n",
        s.plants,
        100.0 * s.clean,
        100.0 * s.clean_frozen,
        100.0 * s.clean_baseline,
        100.0 * s.ratio_le_0_7,
        s.worse_than_frozen,
        100.0 * OFF_PRIOR,
        s.off_prior,
        100.0 * s.off_prior_gain_20,
        s.hold_error_max_quanta,
        s.hold_true_error_max_quanta,
        s.high_friction,
        s.high_friction_settling_ratio,
        s.high_friction_events,
        s.high_friction_events_linear,
        s.servo_samples,
        s.safe_stops,
        s.safe_stops_servo,
        s.suspended[0],
        s.suspended[1]
    )
}
