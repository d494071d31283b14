//! Real-time pacing on the host: waiting for absolute deadlines, and telling the replay's own lateness
//! apart from the machine's.
//!
//! A paced replay spins on the monotonic clock until each sample's deadline. Between two clock reads
//! of that spin nothing of ours runs, so a gap between them longer than [`STALL_US`] is time the
//! thread did not get: the OS or, on a virtual machine, its host took the core. [`StallTracker`]
//! counts those gaps while the replay waits, and [`probe`] measures them with no replay at all, so a
//! user can see whether a machine can hold a given Ts before blaming the code (`sledid pacing-probe`).

use std::time::{Duration, Instant};

/// A clock gap at least this long inside a spin is a stall of the thread, µs (the spin's own
/// iterations take well under a microsecond; Ts = 455 µs).
pub const STALL_US: f64 = 100.0;

/// Gaps between consecutive clock reads of a spin that no code of ours explains.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Stalls {
    /// Gaps of at least [`STALL_US`].
    pub count: usize,
    /// The longest gap, µs (any length).
    pub max_us: f64,
    /// Total time lost in gaps of at least [`STALL_US`], µs.
    pub lost_us: f64,
}

/// Records stalls while spinning.
#[derive(Clone, Copy, Debug, Default)]
pub struct StallTracker {
    stalls: Stalls,
}

impl StallTracker {
    /// Spins until `deadline`, recording gaps between consecutive clock reads. Returns the time it
    /// woke (the last clock read, ≥ `deadline`) and whether a stall happened during this wait.
    pub fn spin_until(&mut self, deadline: Instant) -> (Instant, bool) {
        let mut prev = Instant::now();
        let mut stalled = false;
        while prev < deadline {
            std::hint::spin_loop();
            let now = Instant::now();
            stalled |= self.gap(now - prev);
            prev = now;
        }
        (prev, stalled)
    }

    /// Records one gap; true when it is a stall.
    fn gap(&mut self, gap: Duration) -> bool {
        let us = gap.as_secs_f64() * 1e6;
        self.stalls.max_us = self.stalls.max_us.max(us);
        if us >= STALL_US {
            self.stalls.count += 1;
            self.stalls.lost_us += us;
            true
        } else {
            false
        }
    }

    /// What was recorded.
    pub fn stalls(&self) -> Stalls {
        self.stalls
    }
}

/// What [`probe`] measured.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ProbeReport {
    /// Spin duration, s.
    pub seconds: f64,
    /// Clock reads taken.
    pub reads: u64,
    /// Gaps of at least [`STALL_US`].
    pub stalls: Stalls,
    /// Gaps of at least the sampling period asked about.
    pub gaps_over_ts: usize,
    /// The sampling period asked about, s.
    pub ts_s: f64,
}

impl ProbeReport {
    /// Stalls of at least Ts per minute: each is at least one overrun of a replay paced at Ts.
    pub fn gaps_over_ts_per_minute(&self) -> f64 {
        if self.seconds > 0.0 {
            self.gaps_over_ts as f64 * 60.0 / self.seconds
        } else {
            0.0
        }
    }
}

/// Spins on the clock for `seconds` doing nothing else and reports the gaps: the stalls a paced
/// replay at `ts_s` would suffer on this machine whatever its per-sample cost.
pub fn probe(seconds: f64, ts_s: f64) -> ProbeReport {
    let mut tracker = StallTracker::default();
    let start = Instant::now();
    let end = start + Duration::from_secs_f64(seconds.max(0.0));
    let mut prev = start;
    let mut reads = 0u64;
    let mut over_ts = 0usize;
    let ts_us = ts_s * 1e6;
    while prev < end {
        let now = Instant::now();
        let gap = now - prev;
        tracker.gap(gap);
        if gap.as_secs_f64() * 1e6 >= ts_us {
            over_ts += 1;
        }
        prev = now;
        reads += 1;
    }
    ProbeReport {
        seconds: (prev - start).as_secs_f64(),
        reads,
        stalls: tracker.stalls(),
        gaps_over_ts: over_ts,
        ts_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gaps_are_classified_at_the_threshold() {
        let mut t = StallTracker::default();
        assert!(!t.gap(Duration::from_micros(99)));
        assert!(t.gap(Duration::from_micros(100)));
        assert!(t.gap(Duration::from_millis(3)));
        let s = t.stalls();
        assert_eq!(s.count, 2);
        assert!((s.max_us - 3000.0).abs() < 1e-9);
        assert!((s.lost_us - 3100.0).abs() < 1e-9);
    }

    #[test]
    fn spin_waits_for_the_deadline_and_reports_what_it_counted() {
        let mut t = StallTracker::default();
        let deadline = Instant::now() + Duration::from_millis(5);
        let (woke, stalled) = t.spin_until(deadline);
        assert!(woke >= deadline);
        // Whether this machine stalled during the 5 ms is not ours to assert; the two outputs agree.
        assert_eq!(stalled, t.stalls().count > 0);
        // A deadline in the past returns at once: no wait, nothing recorded.
        let before = t.stalls();
        let (woke, stalled) = t.spin_until(deadline);
        assert!(woke >= deadline && !stalled);
        assert_eq!(t.stalls(), before);
    }

    #[test]
    fn probe_runs_for_the_time_asked_and_counts_consistently() {
        let r = probe(0.05, 0.000455);
        assert!(r.seconds >= 0.05 && r.seconds < 1.0, "{r:?}");
        assert!(r.reads > 100);
        assert!(r.stalls.count >= r.gaps_over_ts);
        assert!(r.gaps_over_ts_per_minute() >= 0.0);
    }
}
