//! The boundary between engineering units and the fixed-point path: positions in metres become
//! [`PositionI48F16`] sensor quanta, the drive in volts becomes a fraction of full scale in
//! [`SignalI16F16`]. NaN, ±∞ and out-of-range values are rejected here with a [`BoundaryError`].
//!
//! # Normalisation
//! The user's units (a sensor quantum, a full-scale drive) say nothing about the size of the
//! signals, and the fixed-point formats downstream are absolute: a neuron's input weight of
//! 1/range in I12F20 keeps 20 − log₂(range) significant bits, a sensitivity w·x·s grows with the
//! square of the range. [`Normalisation`] takes the signals' largest magnitudes in the user's
//! units and [`Scaling::normalised`] converts at this boundary into units in which those ranges
//! are fixed targets the formats were sized for:
//!
//! ```text
//! y_n = y / (quantum · k_y),   k_y = range_y / Y_TARGET
//! u_n = u / (full_scale · k_u), k_u = range_u / U_TARGET
//! ```
//!
//! The same recording in any unit enters the fixed-point path as the same samples (to the last
//! bit but for the rounding of one division), so everything identified from it is the same model,
//! which maps back to the user's units by the factors k (`sledid_host::reference::units`). A
//! caller that knows the ranges in the quantities' own units (metres, volts: the replay, from a
//! first pass over the file) builds the normalised units from them with [`Scaling::for_ranges_to`]
//! — bit for bit the same whatever unit the user named — and [`Normalisation::for_ranges_to`]
//! gives the factors k to report in the user's units.

use crate::error::{BoundaryError, ConfigError};
use crate::num::fixed::SignalI16F16;

/// An absolute position in sensor quanta, I48F16 in an `i64`: `value = raw / 2^16`, range ±1.4·10¹⁴
/// quanta (±2.2·10⁸ m at 1.6 µm per track), step 2⁻¹⁶ quanta. Encoder counts convert exactly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PositionI48F16(i64);

impl PositionI48F16 {
    /// From the raw integer (quanta × 2¹⁶).
    pub const fn from_raw(raw: i64) -> Self {
        Self(raw)
    }

    /// The raw integer (quanta × 2¹⁶).
    pub const fn raw(self) -> i64 {
        self.0
    }

    /// From whole sensor counts (exact, saturating).
    pub const fn from_counts(counts: i64) -> Self {
        Self(counts.saturating_mul(1 << 16))
    }

    /// `self − rhs` narrowed to a signal (I16F16), saturating; the flag is set when it saturated.
    pub const fn offset_from(self, rhs: Self, saturated: &mut bool) -> SignalI16F16 {
        SignalI16F16::from_raw(crate::num::fixed::sat_i32(
            self.0.saturating_sub(rhs.0),
            saturated,
        ))
    }

    /// To quanta as `f64`.
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / 65_536.0
    }
}

/// One raw sample in the fixed-point domain: the input of the per-sample step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Measured position y, quanta.
    pub y: PositionI48F16,
    /// Drive u, fraction of full scale.
    pub u: SignalI16F16,
    /// Reference r, quanta.
    pub r: PositionI48F16,
}

/// The normalised position range: |y_n| ≤ Y_TARGET. Sized for the nonlinear models' formats
/// (module doc of `crate::ident::nonlinear`, I16F16 signals and I12F20 weights of about 1/range);
/// the accuracy it gives is measured in `host-tests/tests/integration/nonlinear_units.rs`.
pub const Y_TARGET: f64 = 32.0;
/// The normalised drive range: |u_n| ≤ U_TARGET.
pub const U_TARGET: f64 = 1.0;

/// The unit changes that put the signals' ranges at fixed targets (module doc):
/// `y_n = y / k_y`, `u_n = u / k_u`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normalisation {
    y_factor: f64,
    u_factor: f64,
}

impl Normalisation {
    /// No change of unit.
    pub const NONE: Self = Self {
        y_factor: 1.0,
        u_factor: 1.0,
    };

    /// The normalisation for signals whose largest magnitudes are `y_range` (in units of the
    /// quantum) and `u_range` (full scales): they become [`Y_TARGET`] and [`U_TARGET`].
    ///
    /// # Errors
    /// [`ConfigError::SignalRange`] with the first range that is not finite and > 0 or whose
    /// factor is not a normal number.
    ///
    /// ```
    /// use sledid::num::boundary::Normalisation;
    /// let n = Normalisation::for_ranges(320.0, 0.25).unwrap();
    /// assert_eq!((n.y_factor(), n.u_factor()), (10.0, 0.25));
    /// assert!(Normalisation::for_ranges(0.0, 1.0).is_err());
    /// ```
    pub fn for_ranges(y_range: f64, u_range: f64) -> Result<Self, ConfigError> {
        Self::for_ranges_to(y_range, u_range, Y_TARGET, U_TARGET)
    }

    /// [`Self::for_ranges`] with the targets given (for measuring them).
    ///
    /// # Errors
    /// As [`Self::for_ranges`], and [`ConfigError::SignalRange`] for a target that is not finite
    /// and > 0.
    #[allow(clippy::float_arithmetic)] // design time
    pub fn for_ranges_to(
        y_range: f64,
        u_range: f64,
        y_target: f64,
        u_target: f64,
    ) -> Result<Self, ConfigError> {
        let factor = |r: f64, t: f64| {
            let ok = |x: f64| x.is_finite() && x > 0.0;
            if !ok(r) {
                return Err(ConfigError::SignalRange(r));
            }
            if !ok(t) {
                return Err(ConfigError::SignalRange(t));
            }
            let k = r / t;
            if k.is_normal() {
                Ok(k)
            } else {
                Err(ConfigError::SignalRange(r))
            }
        };
        Ok(Self {
            y_factor: factor(y_range, y_target)?,
            u_factor: factor(u_range, u_target)?,
        })
    }

    /// From the factors k_y, k_u themselves.
    ///
    /// # Errors
    /// [`ConfigError::SignalRange`] with the first factor that is not a normal number > 0.
    pub fn from_factors(y_factor: f64, u_factor: f64) -> Result<Self, ConfigError> {
        for k in [y_factor, u_factor] {
            if !(k.is_normal() && k > 0.0) {
                return Err(ConfigError::SignalRange(k));
            }
        }
        Ok(Self { y_factor, u_factor })
    }

    /// k_y: the normalised position unit is the quantum × k_y.
    pub fn y_factor(&self) -> f64 {
        self.y_factor
    }

    /// k_u: the normalised drive unit is the full scale × k_u.
    pub fn u_factor(&self) -> f64 {
        self.u_factor
    }
}

/// The conversion from engineering units: sensor quantum (m) and full-scale drive (V).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    quantum_m: f64,
    u_full_scale_v: f64,
}

impl Scaling {
    /// A scaling with the sensor quantum in metres and the full-scale drive in volts.
    ///
    /// # Errors
    /// [`ConfigError::Quantum`] / [`ConfigError::FullScale`] for non-finite or non-positive values.
    pub fn new(quantum_m: f64, u_full_scale_v: f64) -> Result<Self, ConfigError> {
        if !(quantum_m.is_finite() && quantum_m > 0.0) {
            return Err(ConfigError::Quantum(quantum_m));
        }
        if !(u_full_scale_v.is_finite() && u_full_scale_v > 0.0) {
            return Err(ConfigError::FullScale(u_full_scale_v));
        }
        Ok(Self {
            quantum_m,
            u_full_scale_v,
        })
    }

    /// The normalised units themselves, from ranges in the quantities' own units (m, V): quantum
    /// `y_range_m / y_target`, full scale `u_range_v / u_target` — the same [`Scaling`] whatever
    /// unit a user would have named (module doc).
    ///
    /// # Errors
    /// [`ConfigError::SignalRange`] with the first range or target that is not finite and > 0, or
    /// [`ConfigError::Quantum`] / [`ConfigError::FullScale`] for a unit that is not.
    #[allow(clippy::float_arithmetic)] // design time
    pub fn for_ranges_to(
        y_range_m: f64,
        u_range_v: f64,
        y_target: f64,
        u_target: f64,
    ) -> Result<Self, ConfigError> {
        for x in [y_range_m, u_range_v, y_target, u_target] {
            if !(x.is_finite() && x > 0.0) {
                return Err(ConfigError::SignalRange(x));
            }
        }
        Self::new(y_range_m / y_target, u_range_v / u_target)
    }

    /// The same conversion into the normalised units of `n`: quantum × k_y, full scale × k_u.
    ///
    /// # Errors
    /// [`ConfigError::Quantum`] / [`ConfigError::FullScale`] when a normalised unit is no longer
    /// a finite positive number.
    #[allow(clippy::float_arithmetic)] // design time
    pub fn normalised(&self, n: Normalisation) -> Result<Self, ConfigError> {
        Self::new(
            self.quantum_m * n.y_factor,
            self.u_full_scale_v * n.u_factor,
        )
    }

    /// The sensor quantum, m.
    pub fn quantum_m(&self) -> f64 {
        self.quantum_m
    }

    /// The full-scale drive, V.
    pub fn u_full_scale_v(&self) -> f64 {
        self.u_full_scale_v
    }

    /// Converts a position in metres to quanta.
    ///
    /// # Errors
    /// [`BoundaryError`] for NaN/±∞ or a value beyond ±2⁴⁷ quanta.
    pub fn position(&self, pos_m: f64) -> Result<PositionI48F16, BoundaryError> {
        const QUANTITY: &str = "position (I48F16 quanta)";
        if !pos_m.is_finite() {
            return Err(BoundaryError::NotFinite { quantity: QUANTITY });
        }
        let raw = pos_m / self.quantum_m * 65_536.0;
        let lim = (1u64 << 62) as f64;
        if !(-lim..lim).contains(&raw) {
            return Err(BoundaryError::OutOfRange {
                quantity: QUANTITY,
                value: pos_m,
                min: -lim / 65_536.0 * self.quantum_m,
                max: lim / 65_536.0 * self.quantum_m,
            });
        }
        let r = if raw >= 0.0 { raw + 0.5 } else { raw - 0.5 };
        Ok(PositionI48F16(r as i64))
    }

    /// Converts a drive in volts to a fraction of full scale.
    ///
    /// # Errors
    /// [`BoundaryError`] for NaN/±∞ or |u| ≥ 32768 × full scale.
    pub fn drive(&self, u_v: f64) -> Result<SignalI16F16, BoundaryError> {
        SignalI16F16::from_f64(u_v / self.u_full_scale_v).map_err(|e| match e {
            BoundaryError::OutOfRange { quantity, .. } => BoundaryError::OutOfRange {
                quantity,
                value: u_v,
                min: -32_768.0 * self.u_full_scale_v,
                max: 32_768.0 * self.u_full_scale_v,
            },
            other => other,
        })
    }

    /// Converts one sample (y and r in metres, u in volts).
    ///
    /// # Errors
    /// The first [`BoundaryError`] among y, u, r.
    pub fn sample(&self, y_m: f64, u_v: f64, r_m: f64) -> Result<Sample, BoundaryError> {
        Ok(Sample {
            y: self.position(y_m)?,
            u: self.drive(u_v)?,
            r: self.position(r_m)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converts_and_rejects() {
        let s = Scaling::new(5e-8, 10.0).unwrap();
        let smp = s.sample(0.2, -2.5, 0.2000001).unwrap();
        assert_eq!(smp.y.raw(), 4_000_000 << 16);
        assert_eq!(smp.u.to_f64(), -0.25);
        let mut sat = false;
        assert_eq!(smp.y.offset_from(smp.r, &mut sat).to_f64(), -2.0);
        assert!(!sat);
        assert!(s.sample(f64::NAN, 0.0, 0.0).is_err());
        assert!(s.sample(0.0, f64::INFINITY, 0.0).is_err());
        assert!(s.sample(0.0, 1e9, 0.0).is_err());
        assert!(s.position(1e30).is_err());
        assert_eq!(Scaling::new(0.0, 1.0), Err(ConfigError::Quantum(0.0)));
        assert_eq!(Scaling::new(1.0, -1.0), Err(ConfigError::FullScale(-1.0)));
        // Far apart positions saturate the signal, and say so.
        let _ =
            PositionI48F16::from_counts(1 << 20).offset_from(PositionI48F16::default(), &mut sat);
        assert!(sat);
    }

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn normalisation_puts_the_ranges_at_their_targets_in_any_unit() {
        let n = Normalisation::for_ranges(300.0, 0.15).unwrap();
        let s0 = Scaling::new(1e-3, 1.0).unwrap().normalised(n).unwrap();
        // The largest sample lands on the targets exactly.
        let top = s0.sample(0.3, 0.15, 0.0).unwrap();
        assert_eq!(top.y.to_f64(), Y_TARGET);
        assert_eq!(top.u.to_f64(), U_TARGET);
        // The same signals in another unit give the same samples.
        for unit in [1e-3 / 1024.0, 1e-3 * 1024.0, 3.7e-3, 1e-7] {
            let nk = Normalisation::for_ranges(0.3 / unit, 0.15 * 3.0).unwrap();
            let sk = Scaling::new(unit, 1.0 / 3.0)
                .unwrap()
                .normalised(nk)
                .unwrap();
            for (y, u) in [(0.3, 0.15), (-0.1234, 0.05), (0.0, -0.15)] {
                let (a, b) = (s0.sample(y, u, 0.0).unwrap(), sk.sample(y, u, 0.0).unwrap());
                assert!((a.y.raw() - b.y.raw()).abs() <= 1, "unit {unit}: y {y}");
                assert!((a.u.raw() - b.u.raw()).abs() <= 1, "unit {unit}: u {u}");
            }
        }
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-320] {
            assert!(Normalisation::for_ranges(bad, 1.0).is_err(), "{bad}");
            assert!(Normalisation::for_ranges(1.0, bad).is_err(), "{bad}");
        }
        assert!(Normalisation::for_ranges_to(1.0, 1.0, 0.0, 1.0).is_err());
        assert_eq!(Normalisation::NONE.y_factor(), 1.0);
        assert_eq!(
            Normalisation::from_factors(2.0, 0.5).unwrap().u_factor(),
            0.5
        );
        assert!(Normalisation::from_factors(-2.0, 0.5).is_err());
        assert!(Normalisation::from_factors(2.0, f64::NAN).is_err());
    }
}
