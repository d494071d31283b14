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
//! | model parameter θ | [`ParamI12F20`] (the RLS state keeps it in I16F48, `i64`) | quanta per unit of regressor | ±2,048 | 9.5·10⁻⁷ |
//! | covariance factor U (off-diagonal) | `i32` I8F24 in [`crate::ident::rls`] | ratio of parameter units | ±128 | 6·10⁻⁸ |
//! | covariance factor D, α, 1/α | [`crate::num::dyadic::Dyadic`] | parameter² per signal² | 2^±16384 | 2⁻³² relative |
//!
//! Positions enter as counts *relative to the reference or differenced* (see [`crate::ident::conditioning`]):
//! the findings of the float64 study are that regressors in absolute counts give cond(ΦᵀΦ) ≈ 3·10¹¹ and
//! break 32-bit arithmetic, while centred ones keep float32 within 3·10⁻⁴ of float64. Absolute
//! positions therefore never reach the estimator; their range is the boundary's problem, where
//! out-of-range values are rejected with [`BoundaryError`].
//!
//! # Scaling and overflow
//! Conversions from `f64` reject NaN, ±∞ and values outside the format with a [`BoundaryError`].
//! Inside the path every narrowing is saturating and reported (`Status::SATURATED`).

use crate::error::{BoundaryError, ConfigError};
use crate::num::float_bits::decode_f64;
use crate::words::{WordReader, WordWriter, Words};

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

/// `trunc(fl(x·2^frac ± ½))` (the sign of x; `fl` rounding to nearest, ties to even, as `f64`
/// arithmetic does) for a finite `x` with |x·2^frac| ≤ 2³¹, from the bits of `x` with integer
/// operations only: `|x·2^frac| + ½` is formed exactly as an integer over a power of two, rounded
/// to 53 significant bits, then truncated. Equal to the `f64` expression for every such x
/// (`from_f64_equals_the_float_expression`).
fn round_half_away_f64(x: f64, frac: u32) -> i64 {
    let (negative, m, e) = decode_f64(x);
    let e = i64::from(e);
    if m == 0 {
        return 0;
    }
    // |x·2^frac| = m · 2^−s. For a normal m ≥ 2^52 and |x·2^frac| ≤ 2^31, s ≥ 21; a subnormal
    // x gives s > 1000.
    let s = -(e + i64::from(frac));
    if s <= 0 {
        // Only beyond the documented range (|x·2^frac| ≥ 2^52): saturate, as `as i64` would.
        return if negative { i64::MIN } else { i64::MAX };
    }
    if s > 60 {
        // |x·2^frac| < 2^53 · 2^−61 = 2^−8: |x·2^frac| + ½ rounds to below 1.
        return 0;
    }
    // |x·2^frac| + ½ = n · 2^−s exactly, n < 2^53 + 2^59.
    let n = m + (1 << (s - 1));
    let len = 64 - n.leading_zeros();
    let n = if len > 53 {
        // n to 53 significant bits, to nearest, ties to even.
        let d = len - 53;
        let q = n >> d;
        let rem = n & ((1 << d) - 1);
        let half = 1 << (d - 1);
        let q = if rem > half || (rem == half && q & 1 == 1) {
            q + 1
        } else {
            q
        };
        q << d
    } else {
        n
    };
    let magnitude = (n >> s) as i64; // ≤ 2^31: fits
    if negative { -magnitude } else { magnitude }
}

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

            /// From `f64`, rounded to the nearest step: `x·2^frac ± ½` truncated, as if in `f64`
            /// (half away from zero; the `f64` addition itself rounds, so the one value below ½ a
            /// step that is closest to it, ½ − 2⁻⁵⁴ steps, rounds up). Computed from the bits of
            /// `x` with integer operations only (`round_half_away_f64`), so that a core without
            /// a double-precision FPU links no soft-float arithmetic for it.
            ///
            /// # Errors
            /// [`BoundaryError::NotFinite`] for NaN/±∞, [`BoundaryError::OutOfRange`] outside the format.
            pub fn from_f64(x: f64) -> Result<Self, BoundaryError> {
                /// The smallest accepted `x`: `i32::MIN` steps (exact).
                #[allow(clippy::float_arithmetic)] // evaluated when compiling
                const LO: f64 = i32::MIN as f64 / (1u64 << $frac) as f64;
                /// The largest accepted `x`: `i32::MAX` steps (exact).
                #[allow(clippy::float_arithmetic)] // evaluated when compiling
                const HI: f64 = i32::MAX as f64 / (1u64 << $frac) as f64;
                if !x.is_finite() {
                    return Err(BoundaryError::NotFinite { quantity: $what });
                }
                // x·2^frac is exact for every x in range, so the range is checked on x itself.
                if !(LO..=HI).contains(&x) {
                    let lim = (1u64 << (31 - $frac)) as f64;
                    return Err(BoundaryError::OutOfRange {
                        quantity: $what,
                        value: x,
                        min: -lim,
                        max: lim,
                    });
                }
                let r = round_half_away_f64(x, $frac);
                Ok(Self(
                    r.max(i64::from(i32::MIN)).min(i64::from(i32::MAX)) as i32
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

/// Words: the raw value.
impl Words for ParamI12F20 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.raw().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self::from_raw(i32::take(r))
    }
}

/// Words: the raw value.
impl Words for SignalI16F16 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.raw().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self::from_raw(i32::take(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The former `from_f64`: `x·2^frac ± ½` in `f64`, truncated.
    #[allow(clippy::float_arithmetic)]
    fn from_f64_float<const FRAC: u32>(x: f64) -> Result<i32, ()> {
        let scaled = x * (1u64 << FRAC) as f64;
        if !x.is_finite() || !(i32::MIN as f64..=i32::MAX as f64).contains(&scaled) {
            return Err(());
        }
        let r = if scaled >= 0.0 {
            scaled + 0.5
        } else {
            scaled - 0.5
        };
        Ok((r as i64).clamp(i32::MIN as i64, i32::MAX as i64) as i32)
    }

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn from_f64_equals_the_float_expression() {
        let check = |x: f64| {
            let s = SignalI16F16::from_f64(x)
                .map(SignalI16F16::raw)
                .map_err(|_| ());
            assert_eq!(
                s,
                from_f64_float::<16>(x),
                "I16F16 {x:e} ({:#x})",
                x.to_bits()
            );
            let p = ParamI12F20::from_f64(x)
                .map(ParamI12F20::raw)
                .map_err(|_| ());
            assert_eq!(
                p,
                from_f64_float::<20>(x),
                "I12F20 {x:e} ({:#x})",
                x.to_bits()
            );
        };
        // Edges: zeros, subnormals, the range bounds and their neighbours, infinities, NaN, and
        // ½ − 2⁻⁵⁴ (the value the f64 addition rounds up to a whole step).
        let edges = [
            0.0,
            f64::from_bits(1),
            f64::MIN_POSITIVE,
            32_768.0,
            2_048.0,
            32_767.999_984_741_21,
            2_047.999_999_046_325_7,
            f64::INFINITY,
            f64::NAN,
            f64::MAX,
            0.5,
            0.499_999_999_999_999_94,
            0.499_999_999_999_999_94 / 65_536.0,
            0.499_999_999_999_999_94 / 1_048_576.0,
        ];
        for x in edges {
            for y in [
                x,
                f64::from_bits(x.to_bits() + 1),
                f64::from_bits(x.to_bits().wrapping_sub(1)),
            ] {
                check(y);
                check(-y);
            }
        }
        let mut z = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            z ^= z << 13;
            z ^= z >> 7;
            z ^= z << 17;
            z
        };
        for _ in 0..200_000 {
            let r = next();
            // Random bit patterns (every exponent), random values in range, and half steps
            // (k + ½) · 2^−frac and just below whole steps, nudged by a few ulps.
            check(f64::from_bits(r));
            check((r >> 11) as f64 / (1u64 << 53) as f64 * 65_536.0 - 32_768.0);
            let k = f64::from(r as i32 >> 4);
            for frac in [16, 20] {
                let step = (1u64 << frac) as f64;
                for v in [(k + 0.5) / step, k / step] {
                    for d in [-2i64, -1, 0, 1, 2] {
                        check(f64::from_bits((v.to_bits() as i64 + d) as u64));
                    }
                }
            }
        }
    }

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
