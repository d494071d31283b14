//! The replay's pacing: sample k starts at its absolute deadline `start + k·period` (no drift),
//! and each sample's lateness, work time and overrun are kept for [`Deadlines`].

use std::time::{Duration, Instant};

use super::{Deadlines, percentile};
use crate::pacing::StallTracker;

/// Paces the samples of one replay against absolute deadlines and keeps their statistics.
pub(super) struct Pacer {
    /// One sample period at the replay's rate.
    period: Duration,
    /// Sample 0's deadline.
    start: Instant,
    /// When the current sample's wait ended.
    woke: Instant,
    /// Lateness of each sample's start against its deadline, µs.
    lateness_us: Vec<f64>,
    /// Time from waking to the end of each sample's work, µs.
    work_us: Vec<f64>,
    /// Samples whose work ended after the next sample's deadline.
    overruns: usize,
    /// Of those, the ones in a backlog a stall of the machine began.
    overruns_after_stall: usize,
    /// Stalls seen while waiting.
    stalls: StallTracker,
    /// Whether the last sample ended after the next deadline (a backlog).
    in_backlog: bool,
    /// Whether a stall began the current backlog.
    backlog_from_stall: bool,
}

impl Pacer {
    /// Pacing at `period` per sample, sample 0 due at `start`.
    pub(super) fn new(period: Duration, start: Instant) -> Self {
        Self {
            period,
            start,
            woke: Instant::now(),
            lateness_us: Vec::new(),
            work_us: Vec::new(),
            overruns: 0,
            overruns_after_stall: 0,
            stalls: StallTracker::default(),
            in_backlog: false,
            backlog_from_stall: false,
        }
    }

    /// The deadline of sample `k`.
    fn deadline(&self, k: usize) -> Instant {
        self.start + self.period * k as u32
    }

    /// Waits for sample `k`'s deadline and records how late the wait ended.
    pub(super) fn wait_for(&mut self, k: usize) {
        let deadline = self.deadline(k);
        // Absolute deadlines, no drift. A sleeping thread can wake milliseconds late on a loaded
        // or virtualised host (measured: 155 overruns in 10⁵ samples at Ts = 0.455 ms when
        // sleeping to 150 µs before each deadline), so sleep only to 1 ms before it and spin the
        // rest: at sub-millisecond Ts the replay spins, holding one core — as the MCU would.
        let now = Instant::now();
        if deadline > now + Duration::from_millis(2) {
            std::thread::sleep(deadline - now - Duration::from_millis(1));
        }
        let stalled;
        (self.woke, stalled) = self.stalls.spin_until(deadline);
        self.backlog_from_stall = if self.in_backlog {
            self.backlog_from_stall || stalled
        } else {
            stalled
        };
        self.lateness_us
            .push((self.woke - deadline).as_secs_f64() * 1e6);
    }

    /// Sample `k`'s work ended now: its work time, and an overrun when it ended after the next
    /// sample's deadline.
    pub(super) fn done(&mut self, k: usize) {
        let end = Instant::now();
        self.work_us.push((end - self.woke).as_secs_f64() * 1e6);
        self.in_backlog = end > self.deadline(k + 1);
        if self.in_backlog {
            self.overruns += 1;
            self.overruns_after_stall += usize::from(self.backlog_from_stall);
        }
    }

    /// The statistics of the samples paced.
    pub(super) fn deadlines(&self) -> Deadlines {
        let mut sorted = self.lateness_us.clone();
        sorted.sort_by(f64::total_cmp);
        let mut work = self.work_us.clone();
        work.sort_by(f64::total_cmp);
        Deadlines {
            p50_us: percentile(&sorted, 0.5),
            p99_us: percentile(&sorted, 0.99),
            max_us: sorted.last().copied().unwrap_or(0.0),
            overruns: self.overruns,
            overruns_after_stall: self.overruns_after_stall,
            stalls: self.stalls.stalls(),
            work_p50_us: percentile(&work, 0.5),
            work_p99_us: percentile(&work, 0.99),
            work_max_us: work.last().copied().unwrap_or(0.0),
        }
    }
}
