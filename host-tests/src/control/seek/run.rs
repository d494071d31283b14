//! One controller on a schedule of seek commands: per seek its distance, access time and the
//! minimum-time bound of the true plant from where the sled started; over the run the spreads
//! of `sledid seek`'s `summary.json`.

use serde::Serialize;
use sledid::control::ScheduledDesign;
use sledid::servo::{CalibrationDesign, Identification, ServoOptions};

use super::access::{Quantiles, access_samples, min_dwell_samples};
use crate::control::run::{CalibrationBrief, ControlRun, run_servo_with_faults};
use crate::control::summary::fine_step_marks;
use crate::twin::{
    PlantParams, ReferenceProfile, SeekDistribution, Twin, TwinParams, min_time_seek,
};

/// Seeks of at least this many tracks are "long" (the issue's ≥ 200-track statistic).
pub const LONG_SEEK_TRACKS: i64 = 200;
/// Every seek window lasts at least this many times the bound of the longest seek, plus
/// [`super::access::MIN_DWELL_S`] (a slow sled gets the time to settle that its own physics
/// needs).
pub const DWELL_BOUND_FACTOR: f64 = 3.0;

/// The controller under test and the reference it is fed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SeekController {
    /// The paper's baseline PID fed the step (the target itself).
    Baseline,
    /// The scheduled servo of this design fed the step: a seek command read as the target by its
    /// seek mode ([`seek_design`]); without one, the scheduled law simply fed the step.
    Seek(ScheduledDesign),
    /// The scheduled servo following the paper's 30 ms S-curve to the target (`sledid control`,
    /// today's reference-following mode).
    Reference(ScheduledDesign),
}

impl SeekController {
    /// The reference profile this controller is fed.
    pub fn profile(&self) -> ReferenceProfile {
        match self {
            Self::Baseline | Self::Seek(_) => ReferenceProfile::Step,
            Self::Reference(_) => ReferenceProfile::SCurve,
        }
    }

    /// A short name for reports.
    pub fn label(&self) -> &'static str {
        match self {
            Self::Baseline => "baseline_step",
            Self::Seek(_) => "seek",
            Self::Reference(_) => "reference_following",
        }
    }

    /// The scheduled design, if the servo runs.
    pub fn design(&self) -> Option<&ScheduledDesign> {
        match self {
            Self::Baseline => None,
            Self::Seek(d) | Self::Reference(d) => Some(d),
        }
    }
}

/// The design the seek mode runs, from the design of a prior (`control::design_from_prior`): the
/// library's time-optimal seeks (`design.with_time_optimal_seeks()`); every seek-mode run —
/// `sledid seek`, the family's seek pass, the tests — goes through here.
pub fn seek_design(design: ScheduledDesign) -> ScheduledDesign {
    design.with_time_optimal_seeks()
}

/// The seek schedule.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SeekOptions {
    /// Seeks.
    pub seeks: u32,
    /// Shortest seek, tracks.
    pub min_tracks: u32,
    /// Longest seek, tracks (log-uniform in between, random sign, within the travel).
    pub max_tracks: u32,
    /// Seed of the seeks and the sensor noise.
    pub seed: u64,
    /// Shortest dwell after the command (step) or after the S-curve's arrival, s; lengthened
    /// to [`DWELL_BOUND_FACTOR`] × the bound of the longest seek + 10 ms on slow sleds.
    pub dwell_s: f64,
    /// The servo's identifier never adapts (`Identification::FrozenAtPrior`): with the plant's
    /// exact model as the prior, this isolates the seek law from what identification does.
    pub frozen: bool,
    /// The seek mode calibrates at power-on before the first seek
    /// (`sledid::servo::calibration`; its samples are not counted as access time) and then holds
    /// the calibrated model: the on-line ARX(1,1) velocity estimate leaves out the ZOH's u(k−1)
    /// term and drifts from it (measured, `control-family --passes seek --calibrate`, seeds 1 / 7:
    /// p95 3.22 / 5.30 and clean 93.0 / 93.0 % adapting after calibration against 2.50 / 2.50 and
    /// 97.0 / 98.5 % holding).
    pub calibrate: bool,
}

impl Default for SeekOptions {
    fn default() -> Self {
        Self {
            seeks: 100,
            min_tracks: 20,
            max_tracks: 2000,
            seed: 1,
            dwell_s: 0.3,
            frozen: false,
            calibrate: false,
        }
    }
}

impl SeekOptions {
    /// Parses `MIN:MAX` (tracks, `1 ≤ MIN ≤ MAX`) into the distance range.
    ///
    /// # Errors
    /// Names `--distances` and what is wrong.
    pub fn parse_distances(text: &str) -> Result<(u32, u32), String> {
        let bad = |why: &str| {
            format!("--distances {text:?}: {why} (expected MIN:MAX tracks, e.g. 20:2000)")
        };
        let (lo, hi) = text.split_once(':').ok_or_else(|| bad("no ':'"))?;
        let parse = |s: &str| s.trim().parse::<u32>().map_err(|e| bad(&e.to_string()));
        let (lo, hi) = (parse(lo)?, parse(hi)?);
        if lo == 0 || lo > hi {
            return Err(bad("need 1 ≤ MIN ≤ MAX"));
        }
        Ok((lo, hi))
    }

    /// The twin of `plant` with this schedule and `profile`: log-uniform distances, the dwell of
    /// [`SeekOptions::dwell_s`] lengthened for a slow sled, a travel of at least the longest seek.
    ///
    /// # Errors
    /// A plant or schedule the twin refuses (naming the parameter), or a sled the rail cannot
    /// move over the longest seek.
    pub fn twin_params(
        &self,
        plant: &TwinParams,
        profile: ReferenceProfile,
    ) -> Result<TwinParams, String> {
        let mut p = plant.clone();
        p.reference.seek_count = self.seeks;
        p.reference.seek_min_tracks = self.min_tracks;
        p.reference.seek_max_tracks = self.max_tracks;
        p.reference.travel_tracks = p.reference.travel_tracks.max(self.max_tracks);
        p.reference.targets_tracks = None;
        p.reference.seek_distribution = SeekDistribution::LogUniform;
        p.reference.profile = profile;
        p.validate().map_err(|e| e.to_string())?;
        p.reference.dwell_s = dwell_for_plant(&p.plant, self.max_tracks, self.dwell_s)?;
        p.validate().map_err(|e| e.to_string())?;
        Ok(p)
    }
}

/// The seek window a plant needs: `dwell_s`, or [`DWELL_BOUND_FACTOR`] × the minimum-time bound
/// of a `max_tracks` seek + [`super::access::MIN_DWELL_S`] where that is longer (a window
/// shorter than the plant's own fastest seek measures the plant, not the servo).
///
/// # Errors
/// The plant's rail cannot complete a `max_tracks` seek.
pub fn dwell_for_plant(plant: &PlantParams, max_tracks: u32, dwell_s: f64) -> Result<f64, String> {
    let longest = min_time_seek(plant, 0.0, i64::from(max_tracks)).ok_or_else(|| {
        format!(
            "the plant's rail cannot complete a {max_tracks}-track seek (plant.force_per_volt_n_per_v × plant.u_max_v ≤ plant.static_n?)"
        )
    })?;
    Ok(dwell_s.max(DWELL_BOUND_FACTOR * longest.time_s + super::access::MIN_DWELL_S))
}

/// One seek of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SeekRow {
    /// Seek number in the schedule.
    pub index: usize,
    /// Target minus the previous target, tracks (signed).
    pub distance_tracks: i64,
    /// Access time, ms (the seek's whole length if unsettled: a lower bound).
    pub access_ms: f64,
    /// Whether the reading stayed within ±1 quantum for at least 10 ms.
    pub settled: bool,
    /// The minimum-time bound from where the sled started (at rest there), ms; `None` if the
    /// reading was already in the band at the command or the rail cannot move the sled.
    pub bound_ms: Option<f64>,
    /// `access_ms / bound_ms`.
    pub ratio: Option<f64>,
    /// Overshoot beyond the target after the first entry into ±1 quantum, quanta.
    pub overshoot_quanta: i64,
    /// Pulses above breakaway in the last half of the dwell, from settling and the first stop
    /// on, fine steps that landed not counted (`twin::analysis`, "Pulses and fine steps").
    pub limit_cycle_pulses: usize,
    /// Fine steps that moved the sled into the target cell, in the same window.
    pub fine_steps: usize,
    /// The servo reported a seek error during this seek (`ServoFlags::SEEK_ERROR`).
    pub seek_error: bool,
}

/// `summary.json`'s statistics of one controller's run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeekSummary {
    /// [`SeekController::label`].
    pub controller: &'static str,
    /// Seeks.
    pub seeks: usize,
    /// Access time, ms (unsettled seeks with their whole length).
    pub access_ms: Quantiles,
    /// Access time over the bound, over the seeks that have a bound.
    pub ratio: Quantiles,
    /// Median of the ratio over the seeks of at least [`LONG_SEEK_TRACKS`].
    pub ratio_long_median: f64,
    /// The bound, ms.
    pub bound_ms: Quantiles,
    /// Overshoot, quanta.
    pub overshoot_quanta: Quantiles,
    /// Limit-cycle pulses over every seek.
    pub limit_cycle_pulses: usize,
    /// Fine steps that landed, over every seek.
    pub fine_steps: usize,
    /// Seeks that did not stay within ±1 quantum for 10 ms before their end.
    pub unsettled: usize,
    /// Unsettled seeks the servo reported (a seek error during the seek).
    pub unsettled_reported: usize,
    /// Settled seeks the servo reported all the same (a late settle, or a false alarm).
    pub settled_reported: usize,
    /// Failing seeks (unsettled, or with a limit-cycle pulse) the servo did not report.
    pub failing_unreported: usize,
    /// Seeks without a bound (already in the band at the command).
    pub without_bound: usize,
    /// The dwell the run used, s.
    pub dwell_s: f64,
    /// The safety layer's stop, if it latched one: where and why.
    pub safe_stop: Option<SafeStop>,
    /// Power-on calibration, when the servo calibrated.
    pub calibration: Option<CalibrationBrief>,
    /// Calibrations adopted over the run (power-on's and every re-calibration).
    pub calibrations: u32,
    /// Re-calibrations that ran out of samples after every push had ended: the previous model
    /// kept instead of the stop.
    pub calibrations_inconclusive: u16,
    /// The friction health verdict against power-on calibration (`sledid::servo::health`, run
    /// over the recorded samples from the first seek on), when the servo calibrated.
    pub health: Option<crate::reference::health::HealthBrief>,
}

/// A latched safe stop of a run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SafeStop {
    /// `StopReason::name`.
    pub reason: &'static str,
    /// The sample it latched at.
    pub sample: usize,
    /// The seek it latched in (index in the schedule).
    pub seek: usize,
    /// The reading there, quanta.
    pub position_quanta: i64,
}

impl SafeStop {
    /// The stop of `run`, if any.
    pub fn of(run: &ControlRun) -> Option<Self> {
        let (sample, reason) = run.first_stop?;
        let seek = run
            .twin
            .seeks()
            .iter()
            .rposition(|s| s.start_index <= sample)
            .unwrap_or(0);
        Some(Self {
            reason: reason.name(),
            sample,
            seek,
            position_quanta: run.twin.samples().get(sample).map_or(0, |s| s.y_counts),
        })
    }
}

impl SeekSummary {
    /// One line: access time, access / bound, overshoot, pulses, unsettled seeks and the stop.
    pub fn line(&self) -> String {
        let mut recal = if self.calibrations > 1 {
            format!(", calibrated again {}×", self.calibrations - 1)
        } else {
            String::new()
        };
        if self.calibrations_inconclusive > 0 {
            recal.push_str(&format!(
                ", {} re-calibration(s) without a model (the previous one kept)",
                self.calibrations_inconclusive
            ));
        }
        let stop = self.safe_stop.map_or(String::new(), |st| {
            format!(
                "; SAFE STOP ({}) at sample {}, seek {}, reading {} quanta",
                st.reason, st.sample, st.seek, st.position_quanta
            )
        });
        let health = self
            .health
            .map_or(String::new(), |h| format!("; {}", h.line()));
        format!(
            "{}: access median / p95 / max {:.2} / {:.2} / {:.2} ms, access / bound median / p95 / max {:.2} / {:.2} / {:.2} (≥ 200 tracks: {:.2}), overshoot max {:.0} quanta, pulses {} (fine steps {}), unsettled {} ({} reported as seek errors; settled but reported {}){recal}{health}{stop}",
            self.controller,
            self.access_ms.median,
            self.access_ms.p95,
            self.access_ms.max,
            self.ratio.median,
            self.ratio.p95,
            self.ratio.max,
            self.ratio_long_median,
            self.overshoot_quanta.max,
            self.limit_cycle_pulses,
            self.fine_steps,
            self.unsettled,
            self.unsettled_reported,
            self.settled_reported
        )
    }

    /// The statistics of `rows`.
    pub fn of(controller: &'static str, rows: &[SeekRow], dwell_s: f64) -> Self {
        let pick =
            |f: &dyn Fn(&SeekRow) -> Option<f64>| rows.iter().filter_map(f).collect::<Vec<f64>>();
        let long = pick(&|r| {
            r.ratio
                .filter(|_| r.distance_tracks.abs() >= LONG_SEEK_TRACKS)
        });
        Self {
            controller,
            seeks: rows.len(),
            access_ms: Quantiles::of(&pick(&|r| Some(r.access_ms))),
            ratio: Quantiles::of(&pick(&|r| r.ratio)),
            ratio_long_median: Quantiles::of(&long).median,
            bound_ms: Quantiles::of(&pick(&|r| r.bound_ms)),
            overshoot_quanta: Quantiles::of(&pick(&|r| Some(r.overshoot_quanta as f64))),
            limit_cycle_pulses: rows.iter().map(|r| r.limit_cycle_pulses).sum(),
            fine_steps: rows.iter().map(|r| r.fine_steps).sum(),
            unsettled: rows.iter().filter(|r| !r.settled).count(),
            unsettled_reported: rows.iter().filter(|r| !r.settled && r.seek_error).count(),
            settled_reported: rows.iter().filter(|r| r.settled && r.seek_error).count(),
            failing_unreported: rows
                .iter()
                .filter(|r| (!r.settled || r.limit_cycle_pulses > 0) && !r.seek_error)
                .count(),
            without_bound: rows.iter().filter(|r| r.bound_ms.is_none()).count(),
            dwell_s,
            safe_stop: None,
            calibration: None,
            calibrations: 0,
            calibrations_inconclusive: 0,
            health: None,
        }
    }
}

/// A finished run: the closed loop and its seek rows.
pub struct SeekRun {
    /// The controller that ran.
    pub controller: SeekController,
    /// The closed-loop run (twin recording, servo trace).
    pub run: ControlRun,
    /// Per seek.
    pub rows: Vec<SeekRow>,
    /// Over the run.
    pub summary: SeekSummary,
}

/// Runs `controller` on `plant` (its `plant` section and baseline gains; the schedule comes
/// from `options`) and measures every seek.
///
/// # Errors
/// Twin, schedule or controller configuration errors (naming the parameter).
pub fn run_seeks(
    plant: &TwinParams,
    controller: &SeekController,
    options: &SeekOptions,
) -> Result<SeekRun, String> {
    run_seeks_with_faults(plant, controller, options, &[])
}

/// [`run_seeks`] with `faults` injected into the servo's loop (`sledid seek --inject`; the
/// baseline runs without them).
///
/// # Errors
/// As [`run_seeks`].
pub fn run_seeks_with_faults(
    plant: &TwinParams,
    controller: &SeekController,
    options: &SeekOptions,
    faults: &[crate::control::inject::ServoFault],
) -> Result<SeekRun, String> {
    let params = options.twin_params(plant, controller.profile())?;
    let calibration = (options.calibrate && matches!(controller, SeekController::Seek(_)))
        .then(CalibrationDesign::default);
    let run = run_servo_with_faults(
        &params,
        options.seed,
        options.seeks,
        controller.design(),
        ServoOptions {
            identification: if options.frozen || calibration.is_some() {
                Identification::FrozenAtPrior
            } else {
                Identification::OnLine
            },
            ..ServoOptions::default()
        },
        calibration,
        faults,
    )?;
    let rows = rows(&run);
    let health = controller.design().and_then(|d| {
        let cal = run.calibration.as_ref()?;
        let samples: Vec<(i64, f64)> = run
            .twin
            .samples()
            .get(cal.samples..)?
            .iter()
            .map(|s| (s.y_counts, s.u_v / d.baseline.u_full_scale_v))
            .collect();
        crate::reference::health::health_brief(cal.model.as_ref()?, &samples)
    });
    let summary = SeekSummary {
        health,
        safe_stop: SafeStop::of(&run),
        calibration: run.calibration.map(|c| c.brief(params.plant.ts_s)),
        calibrations: run.calibrations,
        calibrations_inconclusive: run.calibrations_inconclusive,
        ..SeekSummary::of(controller.label(), &rows, params.reference.dwell_s)
    };
    Ok(SeekRun {
        controller: *controller,
        run,
        rows,
        summary,
    })
}

/// The rows of every ended seek of `run`, with the servo's seek errors.
pub fn rows(run: &ControlRun) -> Vec<SeekRow> {
    let errors = run.seek_error_per_seek();
    let mut rows = rows_marked(&run.twin, &fine_step_marks(&run.trace));
    for row in &mut rows {
        row.seek_error = errors.get(row.index).copied().unwrap_or(false);
    }
    rows
}

/// The rows of every ended seek of a twin recording, whatever controller closed its loop (every
/// pulse a limit-cycle pulse).
pub fn rows_of(twin: &Twin) -> Vec<SeekRow> {
    rows_marked(twin, &[])
}

/// The same, with the samples the controller marked as fine steps counted apart.
fn rows_marked(twin: &Twin, fine_step: &[bool]) -> Vec<SeekRow> {
    let plant = &twin.params().plant;
    let ts_ms = plant.ts_s * 1e3;
    let min_dwell = min_dwell_samples(plant.ts_s);
    let samples = twin.samples();
    // `seek_stats` has one entry per ended seek, in order: the seeks kept below.
    let mut stats = twin.seek_stats_marked(fine_step).into_iter();
    let mut previous_target = 0;
    let mut rows = Vec::new();
    for (index, seek) in twin.seeks().iter().enumerate() {
        let target = seek.target_counts;
        let distance = target - previous_target;
        previous_target = target;
        let Some(end) = seek.end_index else {
            continue;
        };
        let Some(window) = samples.get(seek.start_index..end) else {
            continue;
        };
        let Some(start) = window.first() else {
            continue;
        };
        let readings: Vec<i64> = window.iter().map(|s| s.y_counts).collect();
        let access = access_samples(&readings, target, min_dwell);
        let access_ms = access.unwrap_or(window.len()) as f64 * ts_ms;
        let bound_ms = min_time_seek(plant, start.x_m, target)
            .filter(|b| b.samples > 0)
            .map(|b| b.samples as f64 * ts_ms);
        let st = stats.next();
        rows.push(SeekRow {
            index,
            distance_tracks: distance,
            access_ms,
            settled: access.is_some(),
            bound_ms,
            ratio: bound_ms.map(|b| access_ms / b),
            overshoot_quanta: st.as_ref().map_or(0, |s| s.overshoot_counts),
            limit_cycle_pulses: st.as_ref().map_or(0, |s| s.limit_cycle.pulses),
            fine_steps: st.as_ref().map_or(0, |s| s.limit_cycle.fine_steps),
            seek_error: false,
        });
    }
    rows
}

/// The bound of `plant` from rest at 0 on a log grid of 61 distances from `min` to `max` tracks:
/// (distance in tracks, bound in ms), for the seek-time-versus-distance plot.
pub fn bound_curve(plant: &PlantParams, min: u32, max: u32) -> Vec<(f64, f64)> {
    let (lo, hi) = (f64::from(min.max(1)).ln(), f64::from(max.max(1)).ln());
    let n = 60;
    let mut curve: Vec<(f64, f64)> = (0..=n)
        .map(|i| (lo + (hi - lo) * f64::from(i) / f64::from(n)).exp().round() as i64)
        .filter_map(|d| min_time_seek(plant, 0.0, d).map(|b| (d as f64, b.time_s * 1e3)))
        .filter(|b| b.1 > 0.0)
        .collect();
    curve.dedup_by(|a, b| a.0 == b.0);
    curve
}
