//! Time-axis validation and jitter statistics, computed while streaming.

use super::error::RecordingErrorKind;

/// Statistics of the time steps between consecutive rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepStatistics {
    /// Number of steps (rows − 1).
    pub count: usize,
    /// Smallest step, seconds.
    pub min_step_s: f64,
    /// Largest step, seconds.
    pub max_step_s: f64,
    /// Mean step, `(t_last − t_first) / count`, seconds.
    pub mean_step_s: f64,
    /// Largest `|step − Ts|`, seconds (the timing jitter bound).
    pub max_abs_jitter_s: f64,
}

/// What the reader found once the whole file was read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordingSummary {
    /// Number of data rows (= samples) read.
    pub rows: usize,
    /// The sampling period the rows were checked against, seconds.
    pub ts_s: f64,
    /// Step statistics; `None` for a single-row recording.
    pub steps: Option<StepStatistics>,
}

/// Checks each new time stamp (strictly increasing, no gap) and accumulates [`StepStatistics`].
#[derive(Debug, Clone)]
pub(crate) struct TimingTracker {
    ts_s: f64,
    gap_factor: f64,
    first_s: Option<f64>,
    previous_s: Option<f64>,
    steps: usize,
    min_step_s: f64,
    max_step_s: f64,
    max_abs_jitter_s: f64,
}

impl TimingTracker {
    /// A tracker for sampling period `ts_s` that flags steps above `gap_factor × ts_s`.
    pub(crate) fn new(ts_s: f64, gap_factor: f64) -> Self {
        TimingTracker {
            ts_s,
            gap_factor,
            first_s: None,
            previous_s: None,
            steps: 0,
            min_step_s: f64::INFINITY,
            max_step_s: f64::NEG_INFINITY,
            max_abs_jitter_s: 0.0,
        }
    }

    /// Validates time stamp `t_s` against the previous one and updates the statistics.
    pub(crate) fn observe(&mut self, t_s: f64) -> Result<(), RecordingErrorKind> {
        if let Some(previous_s) = self.previous_s {
            let step_s = t_s - previous_s;
            if step_s <= 0.0 {
                return Err(RecordingErrorKind::TimeNotIncreasing {
                    previous_s,
                    current_s: t_s,
                });
            }
            if step_s > self.gap_factor * self.ts_s {
                return Err(RecordingErrorKind::TimeGap {
                    step_s,
                    ts_s: self.ts_s,
                    gap_factor: self.gap_factor,
                });
            }
            self.steps += 1;
            self.min_step_s = self.min_step_s.min(step_s);
            self.max_step_s = self.max_step_s.max(step_s);
            self.max_abs_jitter_s = self.max_abs_jitter_s.max((step_s - self.ts_s).abs());
        }
        self.first_s.get_or_insert(t_s);
        self.previous_s = Some(t_s);
        Ok(())
    }

    /// The summary of everything observed, for a recording of `rows` rows.
    pub(crate) fn summary(&self, rows: usize) -> RecordingSummary {
        let steps = match (self.first_s, self.previous_s) {
            (Some(first_s), Some(last_s)) if self.steps > 0 => Some(StepStatistics {
                count: self.steps,
                min_step_s: self.min_step_s,
                max_step_s: self.max_step_s,
                mean_step_s: (last_s - first_s) / self.steps as f64,
                max_abs_jitter_s: self.max_abs_jitter_s,
            }),
            _ => None,
        };
        RecordingSummary {
            rows,
            ts_s: self.ts_s,
            steps,
        }
    }
}

/// The median of the strictly positive steps of `times`, or `None` if there is none.
pub(crate) fn median_positive_step(times: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = times
        .windows(2)
        .map(|pair| pair[1] - pair[0])
        .filter(|step| *step > 0.0)
        .collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    let middle = steps.len() / 2;
    Some(if steps.len() % 2 == 1 {
        steps[middle]
    } else {
        0.5 * (steps[middle - 1] + steps[middle])
    })
}
