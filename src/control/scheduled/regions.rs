//! The regions of a step response and the selector that chooses between them, with hysteresis.
//!
//! The paper (§3, Figure 4; §6) splits a step response into the seek, where the sled follows a
//! moving reference, the end of the step, where "the oscillations … limit the access time", and
//! the ±1-quantum limit cycle at the constant reference, which the lens loop absorbs — and
//! concludes that different models, and so different controllers, belong to different parts of
//! a step. [`RegionSelector::select`] makes that split per sample from integers only:
//!
//! ```text
//! moving  = |r(k) − r(k−1)| > m                          (reference phase)
//! Seek    ← moving  or  |e| > S_leave
//! Settle  ← (from Seek)   not moving and |e| ≤ S_enter
//!           (from Hold)   |e_h| > H_leave,   e_h ← e_h + (e − e_h)/16  (restarted at e on entry)
//! Hold    ← (from Settle) |e| ≤ H_enter and the sled may be held  (super::rest: at rest, on the
//!                         target cell or well inside the band)
//! ```
//! with `H_enter ≤ H_leave < S_enter ≤ S_leave`: a region is left only across a wider band than
//! the one it was entered through. Hold is left on the low-passed error e_h, not on a reading: a
//! sled resting where noise makes the reading flicker into the next cell averages to its true
//! error, which is inside the band.
//!
//! # Formats
//! Every threshold is an I16F16 raw value in quanta (per sample for m and v_H), compared with the
//! same-format error e, two-sample position difference and reference increment: no arithmetic,
//! only comparisons of absolute values (`unsigned_abs`, so `i32::MIN` is safe).

#![deny(clippy::float_arithmetic)]

use crate::control::ConfigError;
use crate::num::fixed::SignalI16F16;
use crate::num::float_bits::from_fixed;
use crate::words::{WordReader, WordWriter, Words};

/// The part of a step response the controller is in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Region {
    /// Large error or moving reference: track the reference (feedforward + fast PD).
    #[default]
    Seek,
    /// A few quanta of error at a constant reference: the model-based PID with compensation.
    Settle,
    /// At rest within the dead band: output held, integrator frozen (no limit cycle).
    Hold,
}

impl Region {
    /// 0, 1, 2 (for traces and plots).
    pub const fn index(self) -> u8 {
        match self {
            Self::Seek => 0,
            Self::Settle => 1,
            Self::Hold => 2,
        }
    }

    /// The name.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Seek => "seek",
            Self::Settle => "settle",
            Self::Hold => "hold",
        }
    }
}

/// The region thresholds in quanta (per sample for speeds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionDesign {
    /// S_enter: Seek → Settle once the reference is constant and |e| ≤ this.
    pub settle_enter_quanta: f64,
    /// S_leave: back to Seek when |e| > this.
    pub settle_leave_quanta: f64,
    /// H_enter: Settle → Hold when |e| ≤ this and the sled is at rest.
    pub hold_enter_quanta: f64,
    /// H_leave: Hold → Settle when |e| > this.
    pub hold_leave_quanta: f64,
    /// m: the reference is moving while |r(k) − r(k−1)| > this, quanta per sample.
    pub moving_quanta: f64,
}

impl Default for RegionDesign {
    fn default() -> Self {
        Self {
            settle_enter_quanta: 24.0,
            settle_leave_quanta: 48.0,
            hold_enter_quanta: 1.0,
            hold_leave_quanta: 1.5,
            moving_quanta: 0.0,
        }
    }
}

/// The quantised thresholds (`Copy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RegionSelector {
    settle_enter: u32,
    settle_leave: u32,
    hold_enter: u32,
    hold_leave: u32,
    moving: u32,
}

impl RegionDesign {
    /// Validates and quantises.
    ///
    /// # Errors
    /// [`ConfigError::RegionThreshold`] naming the first value that is not finite, negative, out of
    /// the I16F16 range, or out of order (`H_enter ≤ H_leave < S_enter ≤ S_leave`).
    pub fn build(&self) -> Result<RegionSelector, ConfigError> {
        let q = |v: f64| match SignalI16F16::from_f64(v) {
            Ok(s) if s.raw() >= 0 => Ok(s.raw().unsigned_abs()),
            _ => Err(ConfigError::RegionThreshold(v)),
        };
        let s = RegionSelector {
            settle_enter: q(self.settle_enter_quanta)?,
            settle_leave: q(self.settle_leave_quanta)?,
            hold_enter: q(self.hold_enter_quanta)?,
            hold_leave: q(self.hold_leave_quanta)?,
            moving: q(self.moving_quanta)?,
        };
        s.validate()?;
        Ok(s)
    }
}

impl RegionSelector {
    /// The invariants [`Self::select`]'s hysteresis relies on, checked by [`RegionDesign::build`]
    /// and by the decoding of configuration words alike: every threshold in `[0, 2³¹)` and
    /// `H_enter ≤ H_leave < S_enter ≤ S_leave`.
    ///
    /// # Errors
    /// [`ConfigError::RegionThreshold`] with the first threshold out of range or out of order
    /// (quanta).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let quanta = |raw: u32| from_fixed(i64::from(raw), 16);
        let all = [
            self.settle_enter,
            self.settle_leave,
            self.hold_enter,
            self.hold_leave,
            self.moving,
        ];
        if let Some(&bad) = all.iter().find(|&&t| t > i32::MAX as u32) {
            return Err(ConfigError::RegionThreshold(quanta(bad)));
        }
        if self.settle_leave < self.settle_enter {
            return Err(ConfigError::RegionThreshold(quanta(self.settle_leave)));
        }
        if self.hold_leave < self.hold_enter {
            return Err(ConfigError::RegionThreshold(quanta(self.hold_leave)));
        }
        if self.settle_enter <= self.hold_leave {
            return Err(ConfigError::RegionThreshold(quanta(self.settle_enter)));
        }
        Ok(())
    }
}

impl RegionSelector {
    /// H_enter, I16F16 raw (the hold band's half-width).
    pub fn hold_band_raw(&self) -> i32 {
        self.hold_enter.min(i32::MAX as u32) as i32
    }

    /// S_enter, I16F16 raw quanta: the band a seek hands over to Settle in.
    pub fn settle_band_raw(&self) -> u32 {
        self.settle_enter
    }

    /// The region for this sample from the previous one, the error e = r − y and the reference
    /// increment r(k) − r(k−1) (I16F16 raw, quanta), whether the sled may be held now
    /// ([`super::rest`]), and Hold's low-passed error `hold_error` (I16F16 raw quanta; updated
    /// here).
    pub fn select(
        &self,
        previous: Region,
        e: i32,
        dr1: i32,
        holdable: bool,
        hold_error: &mut i32,
    ) -> Region {
        let abs_e = e.unsigned_abs();
        if dr1.unsigned_abs() > self.moving || abs_e > self.settle_leave {
            return Region::Seek;
        }
        match previous {
            Region::Seek if abs_e <= self.settle_enter => Region::Settle,
            Region::Seek => Region::Seek,
            Region::Settle if abs_e <= self.hold_enter && holdable => {
                *hold_error = e;
                Region::Hold
            }
            Region::Settle => Region::Settle,
            Region::Hold => {
                *hold_error = hold_error.saturating_add(e.saturating_sub(*hold_error) >> 4);
                if hold_error.unsigned_abs() > self.hold_leave {
                    Region::Settle
                } else {
                    Region::Hold
                }
            }
        }
    }
}

/// Words: settle enter/leave, hold enter/leave, moving (I16F16 raw, quanta; validity:
/// [`RegionSelector::validate`]).
impl Words for RegionSelector {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.settle_enter,
            self.settle_leave,
            self.hold_enter,
            self.hold_leave,
            self.moving,
        ]
        .put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [settle_enter, settle_leave, hold_enter, hold_leave, moving] = <[u32; 5]>::take(r);
        Self {
            settle_enter,
            settle_leave,
            hold_enter,
            hold_leave,
            moving,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Q: i32 = 1 << 16;

    /// The transitions and their hysteresis; Hold left only on its low-passed error. Trips on a
    /// swapped threshold, a missing hysteresis, or Hold left on a single flickering reading.
    #[test]
    fn hysteresis_and_phases() {
        let s = RegionDesign::default().build().unwrap();
        let mut h = 0;
        // A moving reference is a seek whatever the error.
        assert_eq!(s.select(Region::Hold, 0, Q, true, &mut h), Region::Seek);
        // Constant reference, 30 quanta: stays in seek (> S_enter) but a settle at 30 stays.
        assert_eq!(
            s.select(Region::Seek, 30 * Q, 0, true, &mut h),
            Region::Seek
        );
        assert_eq!(
            s.select(Region::Settle, 30 * Q, 0, true, &mut h),
            Region::Settle
        );
        assert_eq!(
            s.select(Region::Seek, 20 * Q, 0, true, &mut h),
            Region::Settle
        );
        assert_eq!(
            s.select(Region::Settle, 49 * Q, 0, true, &mut h),
            Region::Seek
        );
        // Hold needs a holdable sled inside the band.
        assert_eq!(
            s.select(Region::Settle, 0, 0, false, &mut h),
            Region::Settle
        );
        assert_eq!(
            s.select(Region::Settle, 2 * Q, 0, true, &mut h),
            Region::Settle
        );
        assert_eq!(s.select(Region::Settle, -Q, 0, true, &mut h), Region::Hold);
        assert_eq!(h, -Q, "e_h restarts at e");
        // Readings two cells off leave Hold only once e_h crosses 1.5: after 11 readings of −2
        // from −1 (e_h = −2 + (15/16)^n, floored).
        for k in 0..10 {
            let held = s.select(Region::Hold, -2 * Q, 0, false, &mut h);
            assert_eq!(held, Region::Hold, "reading {k}");
        }
        assert_eq!(
            s.select(Region::Hold, -2 * Q, 0, false, &mut h),
            Region::Settle
        );
        let mut h = 0;
        assert_eq!(
            s.select(Region::Hold, i32::MIN, 0, true, &mut h),
            Region::Seek
        );
    }

    #[test]
    fn build_checks_order_and_range() {
        let ok = RegionDesign::default();
        for bad in [
            RegionDesign {
                settle_leave_quanta: 10.0,
                ..ok
            },
            RegionDesign {
                hold_enter_quanta: 2.0,
                ..ok
            },
            RegionDesign {
                hold_leave_quanta: 30.0,
                ..ok
            },
            RegionDesign {
                moving_quanta: -1.0,
                ..ok
            },
            RegionDesign {
                settle_enter_quanta: f64::NAN,
                ..ok
            },
        ] {
            assert!(matches!(bad.build(), Err(ConfigError::RegionThreshold(_))));
        }
    }
}
