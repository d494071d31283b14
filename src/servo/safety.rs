//! The safety layer: below every controller, the servo cuts the drive to 0 and latches
//! ([`super::ServoFlags::SAFE_STOP`], a [`StopReason`]) when the loop can no longer be trusted to
//! keep the sled in its travel. Only an explicit reset ([`super::ServoConfig::reset_safe_stop`])
//! releases it.
//!
//! # Triggers (per sample; e = r − y, Δy = y(k) − y(k−1), quanta)
//! ```text
//! runaway   N consecutive samples with |e| growing by a quantum or more (|e(k)| ≥ |e(k−1)| + 1: an
//!           oscillation through the target, |e| shrinking at each crossing, never counts) as the
//!           reading moves away
//!           (e·Δy < 0: not a reference outrunning a slow sled) while the drive pushes toward the
//!           reference (u·e > 0) or |Δe| > v_away, |e| growing in the second half of
//!           them at least as much as in the first and by at least N/2 quanta (a sled braking
//!           from an overshoot slows down, one creeping under friction gains less than a quantum
//!           per two samples, one that leads a moving reference sees |e| shrink; one whose sensor
//!           or drive is reversed runs off at growing or constant speed)
//! travel    y + max(Δy, 0)·T_coast + m > travel_max   or   y + min(Δy, 0)·T_coast − m < travel_min
//!           (the reading plus the distance the sled coasts with the drive cut, plus a margin)
//! lost      more than K consecutive samples without a valid position (sample-and-hold bridges fewer)
//! stall     S consecutive samples with |u| ≥ u_stall without the reading changing (a stuck
//!           sensor or a blocked sled: a free sled moves a quantum within a few samples of a drive
//!           above its breakaway)
//! fallbacks more than M entries into the controller's fallback within W samples
//! ```
//! # Before the fallbacks' stop: one recovery per window
//! The entry that would make the fallbacks' stop is the servo's to recover from first
//! ([`SafetyConfig::fallback_recovery`]): a loop that keeps entering its fallback is switching
//! between an identified design and its prior's, not driving a sled off its travel (the other
//! triggers watch that). The servo then calibrates again, or without calibration stops
//! identifying and keeps its prior's design (`super::ServoFlags::IDENTIFICATION_SUSPENDED`); the
//! remembered entries are forgotten. One recovery per W samples: M + 1 entries within W of a
//! recovery still stop — the last resort.
//! ```text
//! recover   an entry now would stop, and no recovery in the last W samples
//! ```
//! A reversed sensor or a reversed drive is a runaway (the sled moves away from the target with the
//! drive toward it); a seek commanded past the travel stops at the soft end stop; a loop made
//! unstable by a mass step runs away or reaches the travel; a sensor stuck while the drive is at
//! its limit stalls.
//!
//! # Formats
//! Positions I48F16 raw (`i64`), speeds and Δy I16F16 raw, T_coast whole samples (`u16`, rounded
//! up; the coast Δy·T_coast computed at 1/16 quantum), counts `u16`/`u32`. Integer comparisons
//! only; no 64-bit multiply (a library call on the M0+).

#![deny(clippy::float_arithmetic)]

use crate::control::ConfigError;
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::SignalI16F16;
use crate::num::float_bits::from_fixed;
use crate::words::{WordReader, WordWriter, Words};

/// Why the servo stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StopReason {
    /// Moving away from the target with the drive toward it (reversed sensor or drive, unstable
    /// loop).
    Runaway,
    /// The sled would coast past a soft end stop.
    Travel,
    /// No valid position for too long.
    SensorLost,
    /// Full drive without the reading changing (stuck sensor, blocked sled).
    Stall,
    /// The controller fell back too often.
    Fallbacks,
    /// Power-on calibration refused the sled (it does not respond like one): the servo does not
    /// seek on a guess.
    Calibration(super::calibration::Refusal),
}

impl StopReason {
    /// A code for logs and the firmware's result line: 1 … 5, calibration's refusals 6 … 11.
    pub const fn code(self) -> u8 {
        match self {
            Self::Runaway => 1,
            Self::Travel => 2,
            Self::SensorLost => 3,
            Self::Stall => 4,
            Self::Fallbacks => 5,
            Self::Calibration(r) => 6 + r.index(),
        }
    }

    /// The name, for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Runaway => "runaway",
            Self::Travel => "travel",
            Self::SensorLost => "sensor_lost",
            Self::Stall => "stall",
            Self::Fallbacks => "fallbacks",
            Self::Calibration(r) => r.name(),
        }
    }
}

/// Most fallback entries the window remembers.
pub const FALLBACK_LIMIT_MAX: usize = 7;

/// User-facing settings, in quanta and samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafetyDesign {
    /// Soft end stop below, quanta (absolute position).
    pub travel_min_quanta: f64,
    /// Soft end stop above, quanta.
    pub travel_max_quanta: f64,
    /// T_coast: samples the sled coasts per quantum per sample of speed once the drive is cut
    /// (a/(1 − a) of its velocity model; more is safer), in [0, 2,048], rounded up to whole samples.
    pub coast_samples: f64,
    /// m: fixed margin before the end stops, quanta.
    pub travel_margin_quanta: f64,
    /// N: consecutive samples moving away from the target that make a runaway.
    pub runaway_samples: u16,
    /// v_away: a speed away from the target that counts without the drive's direction, quanta per
    /// sample.
    pub runaway_speed_quanta: f64,
    /// K: consecutive samples without a position that are still bridged.
    pub lost_samples: u16,
    /// S: consecutive samples with a drive of at least `stall_drive_fs` without a reading change.
    pub stall_samples: u16,
    /// u_stall, fraction of full scale (a few times the sled's breakaway drive).
    pub stall_drive_fs: f64,
    /// M: fallback entries allowed within the window (≤ 7).
    pub fallback_limit: u8,
    /// W: the window, samples.
    pub fallback_window_samples: u32,
}

impl Default for SafetyDesign {
    /// No end stops (±10¹² quanta), T_coast 16 samples, m 16 quanta, N 16, v_away 64 quanta per
    /// sample, K 16, S 32 at u_stall 0.05, more than 4 fallbacks in 8,192 samples.
    fn default() -> Self {
        Self {
            travel_min_quanta: -1.0e12,
            travel_max_quanta: 1.0e12,
            coast_samples: 16.0,
            travel_margin_quanta: 16.0,
            runaway_samples: 16,
            runaway_speed_quanta: 64.0,
            lost_samples: 16,
            stall_samples: 32,
            stall_drive_fs: 0.05,
            fallback_limit: 4,
            fallback_window_samples: 8192,
        }
    }
}

impl SafetyDesign {
    /// Validates and quantises.
    ///
    /// # Errors
    /// [`ConfigError::Safety`] naming the value: end stops not finite or not ordered, negative
    /// margins or coasting, a zero count, more than 7 fallbacks.
    #[allow(clippy::float_arithmetic)] // design time
    pub fn build(&self) -> Result<SafetyConfig, ConfigError> {
        let bad = ConfigError::Safety;
        let pos = |q: f64| {
            if q.is_finite() && q.abs() < 1.3e14 {
                Ok((q * 65_536.0) as i64)
            } else {
                Err(bad(q))
            }
        };
        let speed = |q: f64| {
            SignalI16F16::from_f64(q)
                .ok()
                .filter(|s| s.raw() >= 0)
                .map(|s| s.raw())
                .ok_or(bad(q))
        };
        let config = SafetyConfig {
            travel_min: pos(self.travel_min_quanta)?,
            travel_max: pos(self.travel_max_quanta)?,
            // Whole samples, rounded up (more is safer).
            coast_samples: if (0.0..=f64::from(COAST_SAMPLES_MAX)).contains(&self.coast_samples) {
                libm::ceil(self.coast_samples) as u16
            } else {
                return Err(bad(self.coast_samples));
            },
            margin: pos(self.travel_margin_quanta)?,
            runaway_samples: self.runaway_samples,
            runaway_speed: speed(self.runaway_speed_quanta)?,
            lost_samples: self.lost_samples,
            stall_samples: self.stall_samples,
            stall_drive: speed(self.stall_drive_fs)?,
            fallback_limit: self.fallback_limit,
            fallback_window: self.fallback_window_samples,
        };
        config.validate()?;
        Ok(config)
    }
}

/// `x` saturated to `i32`.
#[inline(always)]
fn sat_i32(x: i64) -> i32 {
    x.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
}

/// The longest coast T_coast, samples (a velocity pole up to a = 0.999).
pub const COAST_SAMPLES_MAX: u16 = 2048;

/// Validated configuration (`Copy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafetyConfig {
    travel_min: i64,
    travel_max: i64,
    /// T_coast in whole samples (≤ [`COAST_SAMPLES_MAX`]).
    coast_samples: u16,
    margin: i64,
    runaway_samples: u16,
    runaway_speed: i32,
    lost_samples: u16,
    stall_samples: u16,
    /// u_stall, I16F16 raw full scale.
    stall_drive: i32,
    fallback_limit: u8,
    fallback_window: u32,
}

impl SafetyConfig {
    /// min + m < max − m, m ≥ 0, T_coast a valid non-negative gain, counts ≥ 1, M ∈ 1..=7, W ≥ 1.
    ///
    /// # Errors
    /// [`ConfigError::Safety`] naming the value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let q = |raw: i64| from_fixed(raw, 16);
        if self.margin < 0 {
            return Err(ConfigError::Safety(q(self.margin)));
        }
        let inner = self.travel_max.saturating_sub(self.margin);
        if self.travel_min.saturating_add(self.margin) >= inner {
            return Err(ConfigError::Safety(q(self.travel_max)));
        }
        if self.coast_samples > COAST_SAMPLES_MAX {
            return Err(ConfigError::Safety(f64::from(self.coast_samples)));
        }
        if self.runaway_speed < 0 || self.stall_drive < 0 {
            return Err(ConfigError::Safety(q(i64::from(self.runaway_speed))));
        }
        let counts = [self.runaway_samples, self.lost_samples, self.stall_samples];
        if counts.contains(&0) || self.fallback_window == 0 {
            return Err(ConfigError::Safety(0.0));
        }
        if !(1..=FALLBACK_LIMIT_MAX as u8).contains(&self.fallback_limit) {
            return Err(ConfigError::Safety(f64::from(self.fallback_limit)));
        }
        Ok(())
    }

    /// Whether the controller's fallback entered this sample (before [`Self::check`], on the
    /// same sample) is the servo's to recover from instead of the fallbacks' stop: one more entry
    /// would stop, and no recovery in the last W samples. Then the recovery is recorded and the
    /// remembered entries are forgotten: the caller passes `fallback_entered = false` to
    /// [`Self::check`] and recovers.
    pub fn fallback_recovery(&self, state: &mut SafetyState) -> bool {
        let k = state.k;
        let allowed = state
            .recovered_at
            .is_none_or(|at| k.wrapping_sub(at) >= self.fallback_window);
        if state.latched.is_some() || !self.entry_would_stop(state) || !allowed {
            return false;
        }
        state.recovered_at = Some(k);
        state.fallbacks = [None; FALLBACK_LIMIT_MAX + 1];
        true
    }

    /// Whether a fallback entry on this sample (k) makes M + 1 within W: the entry remembered at
    /// slot M − 1, which this entry's shift would make the oldest kept, is less than W old.
    fn entry_would_stop(&self, state: &SafetyState) -> bool {
        let limit = usize::from(self.fallback_limit);
        matches!(
            state.fallbacks.get(limit.saturating_sub(1)),
            Some(Some(oldest)) if state.k.wrapping_sub(*oldest) < self.fallback_window
        )
    }

    /// One sample's check, after the controller's step: the reading `y` (`None`: lost), its
    /// target `r`, the drive `u`, whether the drive is at its limit, whether the controller
    /// entered its fallback this sample. Returns the reason when the servo must stop; the state
    /// latches it.
    pub fn check(
        &self,
        state: &mut SafetyState,
        r: PositionI48F16,
        y: Option<PositionI48F16>,
        u: SignalI16F16,
        saturated: bool,
        fallback_entered: bool,
    ) -> Option<StopReason> {
        if let Some(reason) = state.latched {
            return Some(reason);
        }
        let reason = self.judge(state, r, y, u, saturated, fallback_entered);
        state.k = state.k.wrapping_add(1);
        state.latched = reason;
        reason
    }

    /// The sled at `y` (I48F16 raw) coasting `coast` (I48F16 raw, signed) ends within a margin of
    /// an end stop or past it.
    #[inline(always)]
    fn beyond_travel(&self, y: i64, coast: i64) -> bool {
        let ahead = y.saturating_add(coast.max(0)).saturating_add(self.margin);
        let behind = y.saturating_add(coast.min(0)).saturating_sub(self.margin);
        ahead > self.travel_max || behind < self.travel_min
    }

    fn judge(
        &self,
        state: &mut SafetyState,
        r: PositionI48F16,
        y: Option<PositionI48F16>,
        u: SignalI16F16,
        saturated: bool,
        fallback_entered: bool,
    ) -> Option<StopReason> {
        if fallback_entered {
            // The oldest remembered entry falls out; M + 1 within W stops.
            let stops = self.entry_would_stop(state);
            // A shift by one slot, k in front (`rotate_right(1)` then k would link a 1.3–1.6 KB
            // `memmove` into an image for these few words).
            let mut carry = Some(state.k);
            for slot in &mut state.fallbacks {
                carry = core::mem::replace(slot, carry);
            }
            if stops {
                return Some(StopReason::Fallbacks);
            }
        }
        let Some(y) = y else {
            state.lost = state.lost.saturating_add(1);
            return (state.lost > self.lost_samples).then_some(StopReason::SensorLost);
        };
        state.lost = 0;
        let previous = state.last_y.replace(y.raw());
        // e = r − y as I16F16, saturated at ±32,768 quanta (a runaway trips long before; a
        // saturated e stops growing, and the travel check, on the full position, stays).
        let e = sat_i32(r.raw().saturating_sub(y.raw()));
        let Some(previous) = previous else {
            state.last_e = e;
            // The first reading: the travel check without a speed.
            return self.beyond_travel(y.raw(), 0).then_some(StopReason::Travel);
        };
        let dy_i16f16 = sat_i32(y.raw().saturating_sub(previous));
        // Stall: a strong drive, no reading change.
        let stall_drive = state.stall_drive.unwrap_or(self.stall_drive);
        let strong = saturated || u.raw().unsigned_abs() >= stall_drive.unsigned_abs();
        state.stall = if strong && dy_i16f16 == 0 {
            state.stall.saturating_add(1)
        } else {
            0
        };
        if state.stall >= self.stall_samples {
            return Some(StopReason::Stall);
        }
        if dy_i16f16 == 0 {
            // The reading has not moved (most samples of a settle or hold): the travel check
            // passed at this reading with a speed ≥ 0 last sample, and nothing moves away.
            state.last_e = e;
            state.runaway = 0;
            return None;
        }
        // Travel: where the sled would come to rest with the drive cut now. Δy·T_coast in 1/16
        // quantum (|Δy >> 12| < 2¹⁹, T ≤ 2¹¹: no overflow, no 64-bit multiply — a library call
        // on the M0+), back to I48F16.
        let coast = i64::from((dy_i16f16 >> 12).wrapping_mul(i32::from(self.coast_samples))) << 12;
        if self.beyond_travel(y.raw(), coast) {
            return Some(StopReason::Travel);
        }
        // Runaway: |e| growing with the drive toward the reference, or fast.
        let last_e = core::mem::replace(&mut state.last_e, e);
        let de = e.saturating_sub(last_e);
        // |e| growing because the reading moves away (not because a reference outruns the sled).
        // Signs compared, not multiplied.
        let same_sign = |a: bool, b: bool, x: i32| (a && x > 0) || (b && x < 0);
        let (e_pos, e_neg) = (e > 0, e < 0);
        let away = same_sign(e_neg, e_pos, dy_i16f16);
        // |e| itself growing by a quantum: an oscillation through the target (e changing sign,
        // |e| shrinking on the crossing) is not a runaway.
        let growing = away && e.unsigned_abs() >= last_e.unsigned_abs().saturating_add(1 << 16);
        let pushing = same_sign(e_pos, e_neg, u.raw());
        let fast = de.unsigned_abs() > self.runaway_speed.unsigned_abs();
        if !(growing && (pushing || fast)) {
            state.runaway = 0;
            return None;
        }
        if state.runaway == 0 {
            state.runaway_from = last_e;
        }
        state.runaway = state.runaway.saturating_add(1);
        if state.runaway == self.runaway_samples / 2 {
            state.runaway_half = e;
        }
        if state.runaway < self.runaway_samples {
            return None;
        }
        let first = state.runaway_half.abs_diff(state.runaway_from);
        let second = e.abs_diff(state.runaway_half);
        let enough = u32::from(self.runaway_samples / 2) << 16;
        if second >= first && second >= enough {
            return Some(StopReason::Runaway);
        }
        // Braking or creeping: watch the next N samples afresh.
        state.runaway = 0;
        None
    }
}

/// What the safety layer remembers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SafetyState {
    k: u32,
    last_y: Option<i64>,
    lost: u16,
    stall: u16,
    runaway: u16,
    /// e on the last sample, I16F16 raw quanta (saturated at ±32,768 quanta).
    last_e: i32,
    /// e when the runaway count started and at its half, I16F16 raw.
    runaway_from: i32,
    runaway_half: i32,
    fallbacks: [Option<u32>; FALLBACK_LIMIT_MAX + 1],
    /// The sample of the last recovery from the fallbacks' stop ([`SafetyConfig::fallback_recovery`]).
    recovered_at: Option<u32>,
    latched: Option<StopReason>,
    /// u_stall measured on this sled (power-on calibration), I16F16 raw; `None`: the
    /// configuration's.
    stall_drive: Option<i32>,
}

impl SafetyState {
    /// Latches a stop decided above the layer (calibration's refusal); an earlier stop stays.
    pub fn latch(&mut self, reason: StopReason) {
        self.latched.get_or_insert(reason);
    }

    /// Nothing seen, not stopped.
    pub const fn new() -> Self {
        Self {
            k: 0,
            last_y: None,
            lost: 0,
            stall: 0,
            runaway: 0,
            last_e: 0,
            runaway_from: 0,
            runaway_half: 0,
            fallbacks: [None; FALLBACK_LIMIT_MAX + 1],
            recovered_at: None,
            latched: None,
            stall_drive: None,
        }
    }

    /// The stall rule's drive from a measurement of this sled (power-on calibration: 3× its
    /// larger breakaway drive, I16F16 raw full scale), never above the configuration's (which must
    /// hold for every sled the prior may meet) nor below 1 % of full scale.
    pub fn set_stall_drive(&mut self, config: &SafetyConfig, drive_i16f16: i32) {
        let floor = (1i32 << 16) / 100;
        self.stall_drive = Some(drive_i16f16.clamp(floor, config.stall_drive.max(floor)));
    }

    /// A fresh state (nothing seen, not stopped) that keeps what was measured on the sled.
    pub const fn reset(&self) -> Self {
        let mut s = Self::new();
        s.stall_drive = self.stall_drive;
        s
    }

    /// The latched stop, if any.
    pub const fn stopped(&self) -> Option<StopReason> {
        self.latched
    }
}

/// Words: end stops, margin (I48F16 raw), T_coast, counts, v_away, M, W.
impl Words for SafetyConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.travel_min.put(w)?;
        self.travel_max.put(w)?;
        self.margin.put(w)?;
        self.coast_samples.put(w)?;
        self.runaway_samples.put(w)?;
        self.runaway_speed.put(w)?;
        self.lost_samples.put(w)?;
        self.stall_samples.put(w)?;
        self.stall_drive.put(w)?;
        self.fallback_limit.put(w)?;
        self.fallback_window.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            travel_min: i64::take(r),
            travel_max: i64::take(r),
            margin: i64::take(r),
            coast_samples: u16::take(r),
            runaway_samples: u16::take(r),
            runaway_speed: i32::take(r),
            lost_samples: u16::take(r),
            stall_samples: u16::take(r),
            stall_drive: i32::take(r),
            fallback_limit: u8::take(r),
            fallback_window: u32::take(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(q: i64) -> PositionI48F16 {
        PositionI48F16::from_counts(q)
    }

    fn cfg() -> SafetyConfig {
        SafetyDesign {
            travel_min_quanta: -1000.0,
            travel_max_quanta: 1000.0,
            coast_samples: 5.0,
            ..SafetyDesign::default()
        }
        .build()
        .unwrap()
    }

    #[test]
    fn the_design_is_checked() {
        let d = SafetyDesign::default();
        for bad in [
            SafetyDesign {
                travel_min_quanta: d.travel_max_quanta,
                ..d
            },
            SafetyDesign {
                fallback_limit: 8,
                ..d
            },
            SafetyDesign {
                coast_samples: f64::NAN,
                ..d
            },
            SafetyDesign {
                lost_samples: 0,
                ..d
            },
        ] {
            assert!(
                matches!(bad.build(), Err(ConfigError::Safety(_))),
                "{bad:?}"
            );
        }
        assert!(d.build().is_ok());
    }

    #[test]
    fn each_trigger_latches() {
        let c = cfg();
        let full = SignalI16F16::from_int(1);
        // Travel: at 900 moving +30 per sample, the coast (150) passes 1000 − 16.
        let mut s = SafetyState::new();
        assert_eq!(
            c.check(&mut s, p(0), Some(p(870)), full, false, false),
            None
        );
        assert_eq!(
            c.check(&mut s, p(0), Some(p(900)), full, false, false),
            Some(StopReason::Travel)
        );
        // Latched whatever follows.
        assert_eq!(
            c.check(&mut s, p(0), Some(p(0)), SignalI16F16::ZERO, false, false),
            Some(StopReason::Travel)
        );
        // Lost: the 17th missing sample.
        let mut s = SafetyState::new();
        for k in 0..16 {
            assert_eq!(c.check(&mut s, p(0), None, full, false, false), None, "{k}");
        }
        assert_eq!(
            c.check(&mut s, p(0), None, full, false, false),
            Some(StopReason::SensorLost)
        );
        // Runaway: target ahead, drive toward it, reading moving away.
        let mut s = SafetyState::new();
        let mut stop = None;
        for k in 0..40 {
            stop = c.check(&mut s, p(500), Some(p(-k)), full, false, false);
            if stop.is_some() {
                assert_eq!(k, 16, "the 16th sample moving away");
                break;
            }
        }
        assert_eq!(stop, Some(StopReason::Runaway));
        // Stall: full drive, no change.
        let mut s = SafetyState::new();
        let mut n = 0;
        while c
            .check(&mut s, p(500), Some(p(3)), full, true, false)
            .is_none()
        {
            n += 1;
        }
        assert_eq!(s.stopped(), Some(StopReason::Stall));
        assert_eq!(n, 32);
        // Fallbacks: the fifth entry within the window.
        let mut s = SafetyState::new();
        for k in 0..4 {
            assert_eq!(
                c.check(&mut s, p(0), Some(p(0)), full, false, true),
                None,
                "{k}"
            );
        }
        assert_eq!(
            c.check(&mut s, p(0), Some(p(0)), full, false, true),
            Some(StopReason::Fallbacks)
        );
    }

    /// The fallbacks' recovery: granted on the entry that would stop (the M + 1-th within W),
    /// never before it, which then does not count and the earlier entries are forgotten; a second
    /// run of M + 1 entries within W of the recovery stops; after W the next one recovers again.
    /// Trips on a recovery granted early, one that keeps the remembered entries, a second
    /// recovery within W (the stop never reached), or none granted after W.
    #[test]
    fn the_fallbacks_stop_is_recovered_from_once_per_window() {
        let c = cfg();
        let mut s = SafetyState::new();
        // One sample at rest without drive (nothing else may stop), perhaps a fallback entry; the
        // servo's order: the recovery, then the check.
        let sample = |s: &mut SafetyState, entered: bool| {
            let recover = entered && c.fallback_recovery(s);
            let u = SignalI16F16::ZERO;
            (
                recover,
                c.check(s, p(0), Some(p(0)), u, false, entered && !recover),
            )
        };
        for k in 0..4 {
            assert_eq!(sample(&mut s, true), (false, None), "entry {k}");
        }
        // The fifth entry within W would stop: recovered instead.
        assert_eq!(sample(&mut s, true), (true, None));
        // The remembered entries are gone: four more pass, the fifth within W stops.
        for k in 0..4 {
            assert_eq!(
                sample(&mut s, true),
                (false, None),
                "entry {k} after the recovery"
            );
        }
        assert_eq!(sample(&mut s, true), (false, Some(StopReason::Fallbacks)));
        // After W samples without entries, a new run recovers again.
        let mut s = SafetyState::new();
        for _ in 0..4 {
            sample(&mut s, true);
        }
        assert!(sample(&mut s, true).0);
        for _ in 0..8192 {
            assert_eq!(sample(&mut s, false), (false, None));
        }
        for _ in 0..4 {
            assert_eq!(sample(&mut s, true), (false, None));
        }
        assert_eq!(
            sample(&mut s, true),
            (true, None),
            "a window after the first recovery"
        );
    }

    /// A loop oscillating through its target (a period-4 cycle of ±17 / ±27 quanta, the drive
    /// pushing toward the target every sample, as a prior several times off the sled's gain
    /// drives it) is bounded, not a runaway, also when a new seek command moves the target away
    /// from the sled mid-cycle: |e| shrinks at every crossing. A runaway test on the sign of Δe
    /// alone counted every sample of the cycle and stopped the loop at the next command (family
    /// seed 1, plant 95, in seek mode).
    #[test]
    fn an_oscillation_through_the_target_is_not_a_runaway() {
        let c = cfg();
        let mut s = SafetyState::new();
        let mut target = 0i64;
        for k in 0..4_000usize {
            // The sled swings about `centre`; every 64 samples a new command 91 quanta away
            // (the sled follows it from the next sample on).
            let centre = target;
            if k % 64 == 0 && k > 0 {
                target += if (k / 64) % 2 == 0 { -91 } else { 91 };
            }
            let swing = [17, 27, -17, -27][k % 4];
            let y = centre - swing;
            let e = target - y;
            let u = SignalI16F16::from_raw(if e > 0 { 1 << 16 } else { -(1 << 16) });
            assert_eq!(
                c.check(&mut s, p(target), Some(p(y)), u, false, false),
                None,
                "{k}"
            );
        }
    }

    #[test]
    fn ordinary_motion_does_not_stop() {
        let c = SafetyDesign {
            coast_samples: 5.0,
            ..SafetyDesign::default()
        }
        .build()
        .unwrap();
        let mut s = SafetyState::new();
        // A seek toward the target, then an overshoot braked within a few samples, a heavy sled's
        // long overshoot braked over 60 samples (moving away, slowing down), spaced fallbacks.
        for k in 0..60i64 {
            let y = (k * 10).min(500);
            assert_eq!(
                c.check(
                    &mut s,
                    p(500),
                    Some(p(y)),
                    SignalI16F16::from_int(1),
                    k < 30,
                    false
                ),
                None,
                "{k}"
            );
        }
        for y in [505, 508, 509, 507, 503, 501, 500] {
            assert_eq!(
                c.check(
                    &mut s,
                    p(500),
                    Some(p(y)),
                    SignalI16F16::from_int(-1),
                    false,
                    false
                ),
                None
            );
        }
        let mut y = 500i64;
        for k in 0..60i64 {
            y += 60 - k;
            assert_eq!(
                c.check(
                    &mut s,
                    p(500),
                    Some(p(y)),
                    SignalI16F16::from_int(-1),
                    true,
                    false
                ),
                None,
                "braking {k}"
            );
        }
        for _ in 0..40 {
            y -= 1;
            c.check(
                &mut s,
                p(500),
                Some(p(y)),
                SignalI16F16::from_int(-1),
                false,
                false,
            );
        }
        for k in 0..20_000u32 {
            let entered = k % 4096 == 0;
            assert_eq!(
                c.check(
                    &mut s,
                    p(500),
                    Some(p(500)),
                    SignalI16F16::ZERO,
                    false,
                    entered
                ),
                None
            );
        }
    }
}
