//! Settling and limit-cycle statistics of a twin recording, per seek.
//!
//! The error here is `e = target − y` in counts (an integer): once the reference has arrived
//! it equals the controller's error exactly.
//! The limit cycle is looked at in the last [`LIMIT_CYCLE_WINDOW_FRACTION`] of each dwell, and
//! only once the seek has settled (`|e| ≤ 1` for the rest of it) and the sled's true motion has
//! first stopped or reversed there: a limit cycle is what the loop does at the target — the
//! paper's ±1-quantum hunting stays within `|e| ≤ 1` and reverses at every swing, so it is counted
//! from its first reversal — while a sled too slow to arrive in the first half of the dwell is
//! still seeking, and its final, monotone approach is not hunting.

use serde::{Deserialize, Serialize};

use super::Twin;

/// Fraction of each dwell, at its end, in which the limit cycle is measured.
pub const LIMIT_CYCLE_WINDOW_FRACTION: f64 = 0.5;

/// Settling and limit-cycle statistics of one seek.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeekStats {
    /// Target, counts.
    pub target_counts: i64,
    /// Step length (target minus the previous target), counts.
    pub step_counts: i64,
    /// Time from the step to the first sample with `|e| ≤ 1`, s.
    pub first_within_one_s: Option<f64>,
    /// Time from the step until `|e| ≤ 1` holds for the rest of the seek, s.
    pub settling_time_s: Option<f64>,
    /// Largest overshoot beyond the target in the step's direction after the first crossing
    /// into `|e| ≤ 1`, counts.
    pub overshoot_counts: i64,
    /// The limit cycle in the last part of the dwell.
    pub limit_cycle: LimitCycleStats,
}

/// The closed loop at a constant reference.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimitCycleStats {
    /// Length of the window, s.
    pub window_s: f64,
    /// Largest `|e|` in the window, counts.
    pub max_abs_error_counts: i64,
    /// Fraction of the window with `e ≠ 0`.
    pub off_target_fraction: f64,
    /// Sign changes of `e` (ignoring zeros) in the window.
    pub sign_changes: usize,
    /// Twice the mean time between sign changes, s (`None` below two changes).
    pub period_s: Option<f64>,
    /// RMS drive voltage in the window, V.
    pub u_rms_v: f64,
    /// Largest `|u|` in the window, V.
    pub u_peak_v: f64,
    /// Runs of samples whose `|u|` exceeds the breakaway voltage `static_n / force_per_volt`.
    pub pulses: usize,
    /// Mean length of those runs, s.
    pub mean_pulse_s: Option<f64>,
}

/// The statistics of every ended seek of `twin`.
pub fn seek_stats(twin: &Twin) -> Vec<SeekStats> {
    let params = twin.params();
    let ts_s = params.plant.ts_s;
    let breakaway_v = params.plant.static_n / params.plant.force_per_volt_n_per_v;
    let samples = twin.samples();
    let mut previous_target = 0;
    let mut stats = Vec::new();
    for seek in twin.seeks() {
        let (Some(arrival), Some(end)) = (seek.arrival_index, seek.end_index) else {
            continue;
        };
        let Some(seek_samples) = samples.get(seek.start_index..end) else {
            continue;
        };
        let target = seek.target_counts;
        let step_counts = target - previous_target;
        previous_target = target;
        let errors: Vec<i64> = seek_samples.iter().map(|s| target - s.y_counts).collect();
        let first_within = errors.iter().position(|e| e.abs() <= 1);
        let last_outside = errors.iter().rposition(|e| e.abs() > 1);
        let settled_index = match last_outside {
            Some(i) if i + 1 < errors.len() => Some(i + 1),
            Some(_) => None,
            None => Some(0),
        };
        let direction = step_counts.signum();
        let overshoot_counts = first_within
            .and_then(|first| errors.get(first..))
            .and_then(|tail| tail.iter().map(|e| -e * direction).max())
            .unwrap_or(0)
            .max(0);
        let dwell = end.saturating_sub(arrival);
        let window = (dwell as f64 * LIMIT_CYCLE_WINDOW_FRACTION).round() as usize;
        let settled = settled_index.map_or(end, |i| seek.start_index + i);
        // The first stop or reversal of the true motion once settled.
        let stopped = samples
            .get(settled..end)
            .unwrap_or(&[])
            .windows(3)
            .position(|w| (w[1].x_m - w[0].x_m) * (w[2].x_m - w[1].x_m) <= 0.0)
            .map_or(end, |i| settled + i);
        let window_start = end.saturating_sub(window).max(stopped);
        let window_errors = errors
            .get(window_start.saturating_sub(seek.start_index)..)
            .unwrap_or(&[]);
        let window_u: Vec<f64> = samples
            .get(window_start..end)
            .unwrap_or(&[])
            .iter()
            .map(|s| s.u_v)
            .collect();
        stats.push(SeekStats {
            target_counts: target,
            step_counts,
            first_within_one_s: first_within.map(|i| i as f64 * ts_s),
            settling_time_s: settled_index.map(|i| i as f64 * ts_s),
            overshoot_counts,
            limit_cycle: limit_cycle_stats(window_errors, &window_u, ts_s, breakaway_v),
        });
    }
    stats
}

/// Limit-cycle statistics of a window of integer errors and drive voltages.
pub fn limit_cycle_stats(
    errors_counts: &[i64],
    u_v: &[f64],
    ts_s: f64,
    breakaway_v: f64,
) -> LimitCycleStats {
    let length = errors_counts.len().max(1) as f64;
    let mut last_sign = 0;
    let mut change_indices = Vec::new();
    for (i, e) in errors_counts.iter().enumerate() {
        let sign = e.signum();
        if sign != 0 {
            if last_sign != 0 && sign != last_sign {
                change_indices.push(i);
            }
            last_sign = sign;
        }
    }
    let period_s = match (change_indices.first(), change_indices.last()) {
        (Some(first), Some(last)) if change_indices.len() >= 2 => {
            Some(2.0 * (last - first) as f64 * ts_s / (change_indices.len() - 1) as f64)
        }
        _ => None,
    };
    let mut pulses = 0;
    let mut pulse_samples = 0;
    let mut in_pulse = false;
    for u in u_v {
        let strong = u.abs() > breakaway_v;
        if strong {
            pulse_samples += 1;
            if !in_pulse {
                pulses += 1;
            }
        }
        in_pulse = strong;
    }
    LimitCycleStats {
        window_s: errors_counts.len() as f64 * ts_s,
        max_abs_error_counts: errors_counts.iter().map(|e| e.abs()).max().unwrap_or(0),
        off_target_fraction: errors_counts.iter().filter(|&&e| e != 0).count() as f64 / length,
        sign_changes: change_indices.len(),
        period_s,
        u_rms_v: (u_v.iter().map(|u| u * u).sum::<f64>() / u_v.len().max(1) as f64).sqrt(),
        u_peak_v: u_v.iter().fold(0.0, |peak: f64, u| peak.max(u.abs())),
        pulses,
        mean_pulse_s: (pulses > 0).then(|| pulse_samples as f64 * ts_s / pulses as f64),
    }
}
