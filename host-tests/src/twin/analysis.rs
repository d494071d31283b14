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
//!
//! # Pulses and fine steps
//! A pulse is a run of samples whose `|u|` exceeds the breakaway voltage. When the controller
//! marks its samples (`fine_step`, e.g. the scheduled controller's `FINE_STEP` flag), a fine step
//! that moves the sled into the target cell is not hunting and is counted apart:
//! ```text
//! fine step: the pulses from one that carries a marked sample (a new mark's first sample starts a
//!            new one) until the readings stay in the target cell for FINE_STEP_LANDED_SAMPLES in a
//!            row without a pulse, or the window ends in the target cell: one fine step
//! otherwise: a fine step that does not land there — its pulses are limit-cycle pulses
//! ```
//! Every pulse of an unmarked recording (the baseline's) is a limit-cycle pulse.

use serde::{Deserialize, Serialize};
use sledid::control::scheduled::rest::STILL_SAMPLES;

use super::Twin;

/// Fraction of each dwell, at its end, in which the limit cycle is measured.
pub const LIMIT_CYCLE_WINDOW_FRACTION: f64 = 0.5;

/// Readings in the target cell in a row, without a pulse, by which a fine step has landed: the
/// scheduled controller's still count ([`STILL_SAMPLES`]).
pub const FINE_STEP_LANDED_SAMPLES: usize = STILL_SAMPLES as usize;

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
    /// Runs of samples whose `|u|` exceeds the breakaway voltage `static_n / force_per_volt`,
    /// fine steps that landed not counted (module doc, "Pulses and fine steps").
    pub pulses: usize,
    /// Mean length of those runs, s.
    pub mean_pulse_s: Option<f64>,
    /// Fine steps that moved the sled into the target cell (module doc).
    pub fine_steps: usize,
}

/// The statistics of every ended seek of `twin`, every pulse a limit-cycle pulse.
pub fn seek_stats(twin: &Twin) -> Vec<SeekStats> {
    seek_stats_marked(twin, &[])
}

/// The statistics of every ended seek of `twin`; `fine_step[k]`: the controller marked sample `k`
/// a fine step (samples past the slice's end are unmarked).
pub fn seek_stats_marked(twin: &Twin, fine_step: &[bool]) -> Vec<SeekStats> {
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
        let window_fine = fine_step.get(window_start..end).unwrap_or(&[]);
        stats.push(SeekStats {
            target_counts: target,
            step_counts,
            first_within_one_s: first_within.map(|i| i as f64 * ts_s),
            settling_time_s: settled_index.map(|i| i as f64 * ts_s),
            overshoot_counts,
            limit_cycle: limit_cycle_stats(
                window_errors,
                &window_u,
                window_fine,
                ts_s,
                breakaway_v,
            ),
        });
    }
    stats
}

/// Limit-cycle statistics of a window of integer errors and drive voltages; `fine_step[i]`: the
/// controller marked sample `i` a fine step (module doc, "Pulses and fine steps").
pub fn limit_cycle_stats(
    errors_counts: &[i64],
    u_v: &[f64],
    fine_step: &[bool],
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
    let (pulses, pulse_samples, fine_steps) =
        count_pulses(errors_counts, u_v, fine_step, breakaway_v);
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
        fine_steps,
    }
}

/// One run of samples above the breakaway voltage: `[start, end)`, and where the fine step it
/// belongs to began (the first sample of the mark's stretch), if a sample of it is marked.
struct Pulse {
    start: usize,
    end: usize,
    fine_start: Option<usize>,
}

/// (limit-cycle pulses, their samples, fine steps that landed) of a window (module doc).
fn count_pulses(
    errors_counts: &[i64],
    u_v: &[f64],
    fine_step: &[bool],
    breakaway_v: f64,
) -> (usize, usize, usize) {
    let marked = |i: usize| fine_step.get(i).copied().unwrap_or(false);
    let mut runs: Vec<Pulse> = Vec::new();
    for (i, u) in u_v.iter().enumerate() {
        if u.abs() <= breakaway_v {
            continue;
        }
        match runs.last_mut() {
            Some(run) if run.end == i => run.end = i + 1,
            _ => runs.push(Pulse {
                start: i,
                end: i + 1,
                fine_start: None,
            }),
        }
    }
    for run in &mut runs {
        run.fine_start = (run.start..run.end).find(|&i| marked(i)).map(|first| {
            let mut begin = first;
            while begin > 0 && marked(begin - 1) {
                begin -= 1;
            }
            begin
        });
    }
    // Landed between `from` and `to`: FINE_STEP_LANDED_SAMPLES readings in the target cell in a
    // row, or (at the window's end) the last reading in it.
    let landed = |from: usize, to: usize| {
        let gap = errors_counts.get(from..to).unwrap_or(&[]);
        let mut in_cell = 0;
        for e in gap {
            in_cell = if *e == 0 { in_cell + 1 } else { 0 };
            if in_cell >= FINE_STEP_LANDED_SAMPLES {
                return true;
            }
        }
        to >= errors_counts.len() && in_cell > 0
    };
    let (mut pulses, mut pulse_samples, mut fine_steps) = (0, 0, 0);
    // The fine step under way: where it began, its pulses and their samples.
    let mut open: Option<(usize, usize, usize)> = None;
    let mut previous_end = 0;
    for run in &runs {
        if open.is_some() && landed(previous_end, run.start) {
            fine_steps += 1;
            open = None;
        }
        let samples = run.end - run.start;
        open = match (run.fine_start, open) {
            (Some(begin), Some((open_begin, n, m))) if begin == open_begin => {
                Some((begin, n + 1, m + samples))
            }
            (Some(begin), Some((_, n, m))) => {
                pulses += n;
                pulse_samples += m;
                Some((begin, 1, samples))
            }
            (Some(begin), None) => Some((begin, 1, samples)),
            (None, Some((begin, n, m))) => Some((begin, n + 1, m + samples)),
            (None, None) => {
                pulses += 1;
                pulse_samples += samples;
                None
            }
        };
        previous_end = run.end;
    }
    if let Some((_, n, m)) = open {
        if landed(previous_end, errors_counts.len()) {
            fine_steps += 1;
        } else {
            pulses += n;
            pulse_samples += m;
        }
    }
    (pulses, pulse_samples, fine_steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BREAKAWAY_V: f64 = 0.1;

    /// (pulses, fine steps) of a window written as one character per sample: `.` no drive,
    /// `P` a strong drive, `F` a strong drive marked a fine step, `f` a marked weak drive; the
    /// readings' errors are `errors`.
    fn classify(drive: &str, errors: &[i64]) -> (usize, usize) {
        assert_eq!(drive.len(), errors.len());
        let u: Vec<f64> = drive
            .chars()
            .map(|c| if matches!(c, 'P' | 'F') { 1.0 } else { 0.0 })
            .collect();
        let fine: Vec<bool> = drive.chars().map(|c| matches!(c, 'F' | 'f')).collect();
        let s = limit_cycle_stats(errors, &u, &fine, 1e-3, BREAKAWAY_V);
        (s.pulses, s.fine_steps)
    }

    /// A fine step that lands (its own pulses and the braking after it) is one fine step; one
    /// that lands a cell past is two pulses (trips on fine steps counted without landing).
    #[test]
    fn a_fine_step_that_lands_is_not_a_pulse() {
        let landed = [1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        assert_eq!(classify("ffFF.P.......", &landed), (0, 1));
        let past = [1, 1, 1, 0, -1, -1, -1, -1, -1, -1, -1, -1, -1];
        assert_eq!(classify("ffFF.P.......", &past), (2, 0));
    }

    /// Landing needs FINE_STEP_LANDED_SAMPLES readings in the target cell before the next pulse
    /// (trips on a shorter count, e.g. one sample in the cell on the way through), or the window
    /// ending in it (trips if the window's end is not looked at).
    #[test]
    fn landing_is_eight_readings_in_the_cell_or_the_window_ending_there() {
        let through = [1, 1, 0, 0, 0, 0, 0, 0, 0, -1, -1, -1];
        assert_eq!(classify("FF.......P..", &through), (2, 0));
        let stays = [1, 1, 0, 0, 0, 0, 0, 0, 0, 0, -1, -1];
        assert_eq!(classify("FF........P.", &stays), (1, 1));
        assert_eq!(classify("fFF..", &[1, 1, 1, 0, 0]), (0, 1));
        assert_eq!(classify("fFF..", &[1, 1, 1, 0, -1]), (1, 0));
    }

    /// A second mark starts a second fine step: the first, which did not land, is pulses (trips
    /// if marks are merged); unmarked pulses are pulses (the baseline's hunting).
    #[test]
    fn a_new_mark_is_a_new_fine_step_and_unmarked_pulses_are_pulses() {
        let two = [1, 1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        assert_eq!(classify("FF.FF.........", &two), (1, 1));
        let hunt = [1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 0, 0, 0, 0];
        assert_eq!(classify("P.P.P.........", &hunt), (3, 0));
    }
}
