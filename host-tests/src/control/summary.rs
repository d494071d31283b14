//! The statistics of a closed-loop run, per seek and over the run (module doc of
//! [`crate::control`] for the measures).

use serde::Serialize;
use sledid::control::{ControlFlags, Redesign, Region};

use crate::twin::{PlantParams, Twin};

/// Which controller closed the loop of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// The paper's badly tuned PID (the parameters' `controller` gains) in fixed point.
    Baseline,
    /// The gain-scheduled controller with the on-line identifier.
    Scheduled,
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
    /// Pulses above breakaway in the last half of every dwell, fine steps that landed not
    /// counted (`twin::analysis`, "Pulses and fine steps").
    pub limit_cycle_pulses: usize,
    /// Fine steps that moved the sled into the target cell in the last half of every dwell.
    pub fine_steps: usize,
    /// Pulses above breakaway while in Hold (scheduled only).
    pub hold_pulses: usize,
    /// |target − y| read on every sample in Hold, quanta (scheduled only; zeros without Hold).
    pub hold_error_quanta: Spread,
    /// |target − x| of the sled's true position on every sample in Hold, quanta (what the lens
    /// loop has to take up).
    pub hold_true_error_quanta: Spread,
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
    /// The servo's safe stop, if it stopped: reason, sample, reading.
    pub safe_stop: Option<String>,
    /// The sample the servo suspended identification at, if it did (the fallbacks' recovery
    /// without calibration: its prior's design from there on).
    pub identification_suspended_at: Option<usize>,
}

impl ControlSummary {
    /// The header of [`Self::table_row`].
    pub const TABLE_HEADER: &'static str = "| plant | controller | settling median / p90 / max (ms) | after arrival, median (ms) | reference bound (ms) | overshoot median / max (quanta) | limit-cycle pulses | fine steps (landed) | hold pulses | unsettled | fallbacks |\n|---|---|---|---|---|---|---|---|---|---|---|";

    /// One Markdown table row (the columns of [`Self::TABLE_HEADER`]) for the plant `name`.
    pub fn table_row(&self, name: &str) -> String {
        format!(
            "| {name} | {:?} | {:.1} / {:.1} / {:.1} | {:.1} | {:.1} | {:.0} / {:.0} | {} | {} | {} | {} | {} |",
            self.controller,
            self.settling_ms.median,
            self.settling_ms.p90,
            self.settling_ms.max,
            self.settling_after_arrival_ms.median,
            self.reference_bound_ms.median,
            self.overshoot_quanta.median,
            self.overshoot_quanta.max,
            self.limit_cycle_pulses,
            self.fine_steps,
            self.hold_pulses,
            self.unsettled,
            self.fallbacks
        )
    }
}

/// Per sample of a controller's trace: the sample is part of a fine step (`FINE_STEP`), for
/// `twin::analysis`'s count of fine steps apart from limit-cycle pulses.
pub fn fine_step_marks(trace: &[(Region, ControlFlags)]) -> Vec<bool> {
    trace
        .iter()
        .map(|(_, f)| f.contains(ControlFlags::FINE_STEP))
        .collect()
}

pub(crate) fn summarize(
    twin: &Twin,
    trace: &[(Region, ControlFlags)],
    redesigns: &[Redesign],
    kind: ControllerKind,
    seed: u64,
) -> ControlSummary {
    let plant = twin.params().plant.clone();
    let ts_ms = plant.ts_s * 1e3;
    let breakaway_v = plant.static_n / plant.force_per_volt_n_per_v;
    let stats = twin.seek_stats_marked(&fine_step_marks(trace));
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
    let holding = || {
        samples
            .iter()
            .zip(trace)
            .filter(|(_, (region, _))| *region == Region::Hold)
            .map(|(s, _)| s)
    };
    let hold_errors: Vec<f64> = holding()
        .map(|s| (s.target_counts - s.y_counts).abs() as f64)
        .collect();
    let hold_true_errors: Vec<f64> = holding()
        .map(|s| (s.target_counts as f64 - s.x_m / plant.quantum_m).abs())
        .collect();
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
        fine_steps: stats.iter().map(|s| s.limit_cycle.fine_steps).sum(),
        hold_pulses,
        hold_error_quanta: Spread::of(&hold_errors),
        hold_true_error_quanta: Spread::of(&hold_true_errors),
        unsettled,
        fallbacks,
        fallback_samples: trace
            .iter()
            .filter(|(_, f)| f.contains(ControlFlags::FALLBACK))
            .count(),
        redesigns: counts,
        u_peak_v: samples.iter().fold(0.0, |m: f64, s| m.max(s.u_v.abs())),
        safe_stop: None,
        identification_suspended_at: None,
    }
}
