//! The fixed-point formats of the per-sample path and the conversions from engineering units.
//!
//! Formats are spelled `IxFy` (sign counted in the integer bits): `I16F16` is an `i32` whose value is
//! `raw / 2^16`. Every stored signal and parameter is a newtype named after its format, so a mix-up is
//! a compile error, not a silent rescaling.
//!
//! # Range analysis
//! Signals are normalised at the boundary (this module) so that the whole path works on numbers of
//! order one to a few thousand:
//!
//! | quantity | type | unit after normalisation | range | step |
//! |---|---|---|---|---|
//! | position y, reference r, error r − y | [`SignalI16F16`] | sensor quanta (tracks) | ±32,768 | 1.5·10⁻⁵ |
//! | drive u | [`SignalI16F16`] | fraction of full scale (u / u_max) | ±32,768 (±1 in spec) | 1.5·10⁻⁵ |
//! | model parameter θ | [`ParamI12F20`] | quanta per unit of regressor | ±2,048 | 9.5·10⁻⁷ |
//! | covariance factor U (off-diagonal) | `i32` I8F24 in [`crate::rls`] | ratio of parameter units | ±128 | 6·10⁻⁸ |
//! | covariance factor D, α, 1/α | [`crate::dyadic::Dyadic`] | parameter² per signal² | 2^±16384 | 2⁻³² relative |
//!
//! Positions enter as counts *relative to the reference or differenced* (see [`crate::regressor`]):
//! the findings of the float64 study are that regressors in absolute counts give cond(ΦᵀΦ) ≈ 3·10¹¹ and
//! break 32-bit arithmetic, while centred ones keep float32 within 3·10⁻⁴ of float64. Absolute
//! positions therefore never reach the estimator; their range is the boundary's problem, where
//! out-of-range values are rejected with [`BoundaryError`].
//!
//! # Scaling and overflow
//! Conversions from `f64` reject NaN, ±∞ and values outside the format with a [`BoundaryError`].
//! Inside the path every narrowing is saturating and reported (`Status::SATURATED`).

use crate::error::BoundaryError;

/// A signal sample in I16F16: `value = raw / 2^16`, range [−32768, 32768), step 2⁻¹⁶ ≈ 1.5·10⁻⁵.
///
/// Unit: sensor quanta for positions, fraction of full scale for the drive (see the module table).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SignalI16F16(i32);

/// A model parameter in I12F20: `value = raw / 2^20`, range [−2048, 2048), step 2⁻²⁰ ≈ 9.5·10⁻⁷.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamI12F20(i32);

/// Fraction bits of [`SignalI16F16`].
pub const SIGNAL_FRAC_BITS: u32 = 16;
/// Fraction bits of [`ParamI12F20`].
pub const PARAM_FRAC_BITS: u32 = 20;

macro_rules! fixed_newtype {
    ($t:ident, $frac:expr, $what:literal) => {
        impl $t {
            /// Zero.
            pub const ZERO: Self = Self(0);
            /// The largest value.
            pub const MAX: Self = Self(i32::MAX);
            /// The smallest value.
            pub const MIN: Self = Self(i32::MIN);

            /// From the raw integer (the value times `2^frac`).
            pub const fn from_raw(raw: i32) -> Self {
                Self(raw)
            }

            /// The raw integer (the value times `2^frac`).
            pub const fn raw(self) -> i32 {
                self.0
            }

            /// From an integer number of units (saturating).
            pub const fn from_int(units: i32) -> Self {
                Self(units.saturating_mul(1 << $frac))
            }

            /// From `f64`, rounded to the nearest step.
            ///
            /// # Errors
            /// [`BoundaryError::NotFinite`] for NaN/±∞, [`BoundaryError::OutOfRange`] outside the format.
            pub fn from_f64(x: f64) -> Result<Self, BoundaryError> {
                if !x.is_finite() {
                    return Err(BoundaryError::NotFinite { quantity: $what });
                }
                let scaled = x * (1u64 << $frac) as f64;
                let lo = i32::MIN as f64;
                let hi = i32::MAX as f64;
                if !(lo..=hi).contains(&scaled) {
                    let lim = (1u64 << (31 - $frac)) as f64;
                    return Err(BoundaryError::OutOfRange {
                        quantity: $what,
                        value: x,
                        min: -lim,
                        max: lim,
                    });
                }
                // Round half away from zero without `f64::round` (not in core).
                let r = if scaled >= 0.0 {
                    scaled + 0.5
                } else {
                    scaled - 0.5
                };
                Ok(Self(
                    (r as i64).clamp(i32::MIN as i64, i32::MAX as i64) as i32
                ))
            }

            /// To `f64` (exact).
            pub fn to_f64(self) -> f64 {
                f64::from(self.0) / (1u64 << $frac) as f64
            }

            /// To `f32`: the same value as `to_f64() as f32` (one rounding of the raw integer to
            /// 24 bits, then an exact division by a power of two), without `f64` arithmetic.
            #[allow(clippy::float_arithmetic)]
            pub fn to_f32(self) -> f32 {
                self.0 as f32 / (1u64 << $frac) as f32
            }

            /// Saturating sum.
            #[must_use]
            pub const fn saturating_add(self, rhs: Self) -> Self {
                Self(self.0.saturating_add(rhs.0))
            }

            /// Saturating difference.
            #[must_use]
            pub const fn saturating_sub(self, rhs: Self) -> Self {
                Self(self.0.saturating_sub(rhs.0))
            }
        }
    };
}

fixed_newtype!(SignalI16F16, SIGNAL_FRAC_BITS, "signal (I16F16)");
fixed_newtype!(ParamI12F20, PARAM_FRAC_BITS, "parameter (I12F20)");

/// Arithmetic shift right by `s` with round-half-up; `s ≥ 63` gives 0.
#[inline(always)]
pub const fn shr_round_i64(x: i64, s: u32) -> i64 {
    if s == 0 {
        x
    } else if s >= 63 {
        0
    } else {
        // floor(x / 2^s) plus the first dropped bit: round half up, no overflow possible.
        (x >> s) + ((x >> (s - 1)) & 1)
    }
}

/// `x · 2^s` for a signed shift `s` (left when positive, rounded right when negative), saturating.
#[inline(always)]
pub const fn shift_round_i64(x: i64, s: i32) -> i64 {
    if s >= 0 {
        if s >= 63 {
            return if x > 0 {
                i64::MAX
            } else if x < 0 {
                i64::MIN
            } else {
                0
            };
        }
        let limit = i64::MAX >> s;
        if x > limit {
            i64::MAX
        } else if x < -limit {
            i64::MIN
        } else {
            x << s
        }
    } else {
        shr_round_i64(x, s.unsigned_abs())
    }
}

/// Narrows to `i32`, saturating; the flag is set when it saturated.
#[inline(always)]
pub const fn sat_i32(x: i64, saturated: &mut bool) -> i32 {
    if x > i32::MAX as i64 {
        *saturated = true;
        i32::MAX
    } else if x < i32::MIN as i64 {
        *saturated = true;
        i32::MIN
    } else {
        x as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn to_f32_is_to_f64_rounded_once() {
        // Edges, values that need rounding (more than 24 significant bits, ties included) and a
        // pseudo-random sweep of raw values.
        let edges = [
            0,
            1,
            -1,
            i32::MAX,
            i32::MIN,
            (1 << 24) + 1,
            (1 << 24) + 3,
            -(1 << 25) - 2,
        ];
        let mut x = 0x1234_5678_u32;
        let sweep = core::iter::repeat_with(move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as i32
        });
        let raws = edges.into_iter().chain(sweep.take(100_000));
        for raw in raws {
            let p = ParamI12F20::from_raw(raw);
            assert_eq!(p.to_f32().to_bits(), (p.to_f64() as f32).to_bits(), "{raw}");
            let s = SignalI16F16::from_raw(raw);
            assert_eq!(s.to_f32().to_bits(), (s.to_f64() as f32).to_bits(), "{raw}");
        }
    }

    #[test]
    fn conversions_reject_bad_values() {
        assert!(SignalI16F16::from_f64(f64::NAN).is_err());
        assert!(SignalI16F16::from_f64(f64::NEG_INFINITY).is_err());
        assert!(SignalI16F16::from_f64(32768.0).is_err());
        assert!(SignalI16F16::from_f64(-32768.0).is_ok());
        assert!(ParamI12F20::from_f64(2048.0).is_err());
        assert_eq!(SignalI16F16::from_f64(1.5).unwrap().raw(), 3 << 15);
        assert_eq!(SignalI16F16::from_f64(-1.5).unwrap().raw(), -(3 << 15));
        assert_eq!(ParamI12F20::from_f64(-0.25).unwrap().to_f64(), -0.25);
        assert_eq!(SignalI16F16::from_int(40_000), SignalI16F16::MAX);
    }

    #[test]
    fn shifts_round_and_saturate() {
        assert_eq!(shr_round_i64(3, 1), 2);
        assert_eq!(shr_round_i64(-3, 1), -1);
        assert_eq!(shr_round_i64(i64::MAX, 1), 1 << 62);
        assert_eq!(shr_round_i64(-5, 70), 0);
        assert_eq!(shift_round_i64(1, 62), 1 << 62);
        assert_eq!(shift_round_i64(2, 62), i64::MAX);
        assert_eq!(shift_round_i64(-2, 62), i64::MIN);
        assert_eq!(shift_round_i64(5, -1), 3);
        let mut s = false;
        assert_eq!(sat_i32(1 << 40, &mut s), i32::MAX);
        assert!(s);
    }
}
