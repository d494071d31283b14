//! Access time of one seek from its readings, and the spread statistics of the seek reports.
//!
//! # Access time
//! With the seek's readings `y(k)` from its command `k₀` (the sample the target changes) to its
//! end `k_e` (exclusive) and the target `T`, in quanta:
//! ```text
//! k_a = min { k ≥ k₀ : |y(i) − T| ≤ 1 for every i in [k, k_e) }
//! access = (k_a − k₀)·Ts        if (k_e − k_a)·Ts ≥ MIN_DWELL_S,   else unsettled
//! ```
//! The data can be read once the reading has stayed within one track for [`MIN_DWELL_S`]; a seek
//! whose remaining dwell is shorter, or that never gets there, is *unsettled* and enters the
//! statistics with its whole length `(k_e − k₀)·Ts`, a lower bound of its access time.

use serde::Serialize;

/// The dwell within ±1 quantum that makes a seek settled, s (issue 14: at least 10 ms).
pub const MIN_DWELL_S: f64 = 0.010;

/// Samples of [`MIN_DWELL_S`] at the sampling period `ts_s` (rounded up).
pub fn min_dwell_samples(ts_s: f64) -> usize {
    (MIN_DWELL_S / ts_s - 1e-9).ceil().max(1.0) as usize
}

/// `k_a − k₀` of the module documentation for the readings `readings_counts` of one seek (from
/// its command to its end) and its target: `None` if the reading never stays within ±1 quantum
/// or does so for fewer than `min_dwell` samples at the end.
pub fn access_samples(
    readings_counts: &[i64],
    target_counts: i64,
    min_dwell: usize,
) -> Option<usize> {
    let settled = readings_counts
        .iter()
        .rposition(|y| (y - target_counts).abs() > 1)
        .map_or(0, |i| i + 1);
    (readings_counts.len().saturating_sub(settled) >= min_dwell.max(1)).then_some(settled)
}

/// Median, 95th percentile and maximum of a set of values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Quantiles {
    /// Median (the mean of the two middle values for an even count).
    pub median: f64,
    /// 95th percentile, nearest rank: the value of rank ⌈0.95·n⌉.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

impl Quantiles {
    /// Of `values` (all 0 for none; NaN sorts last).
    pub fn of(values: &[f64]) -> Self {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            return Self::default();
        }
        let at = |i: usize| v.get(i.min(n - 1)).copied().unwrap_or(0.0);
        Self {
            median: if n % 2 == 1 {
                at(n / 2)
            } else {
                0.5 * (at(n / 2 - 1) + at(n / 2))
            },
            p95: at(((0.95 * n as f64).ceil() as usize).max(1) - 1),
            max: at(n - 1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The access sample is the first after the last reading outside ±1; the dwell after it must
    /// be long enough; a seek that ends outside is unsettled. Trips on an off-by-one at either end.
    #[test]
    fn access_is_the_first_sample_of_the_final_stay_within_one_quantum() {
        let t = 100;
        let y = [0, 40, 90, 102, 99, 101, 100, 100, 100, 100];
        assert_eq!(access_samples(&y, t, 1), Some(4));
        assert_eq!(access_samples(&y, t, 6), Some(4));
        assert_eq!(access_samples(&y, t, 7), None);
        assert_eq!(access_samples(&[100, 100, 101], t, 3), Some(0));
        assert_eq!(access_samples(&[100, 100, 98], t, 1), None);
        assert_eq!(access_samples(&[], t, 1), None);
        assert_eq!(min_dwell_samples(0.455e-3), 22); // 21.98 samples rounded up
        assert_eq!(min_dwell_samples(0.001), 10);
    }

    /// Nearest-rank p95 and the two-middle median, on values given out of order.
    #[test]
    fn quantiles_by_rank() {
        let v: Vec<f64> = (1..=20).rev().map(f64::from).collect();
        let q = Quantiles::of(&v);
        assert_eq!((q.median, q.p95, q.max), (10.5, 19.0, 20.0));
        let q = Quantiles::of(&[3.0, 1.0, 2.0]);
        assert_eq!((q.median, q.p95, q.max), (2.0, 3.0, 3.0));
        assert_eq!(Quantiles::of(&[]), Quantiles::default());
    }
}
