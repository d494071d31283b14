//! Controller gains and coefficients: [`Gain`] (an I16F16 signal → an I32F32 term with a 31-bit
//! mantissa and its own shift), the I32F32 accumulator of controller terms and its limits, U1F31
//! filter coefficients, and their design-time quantisation from `f64`.
//!
//! # Formats
//! | quantity | format | range | step |
//! |---|---|---|---|
//! | gain | [`Gain`]: `i32` mantissa, \|m\| ∈ [2³⁰, 2³¹), shift `s ≤ 62` | (0, 2¹⁵) output per input unit | 2⁻³¹ relative |
//! | term, sum, limit | `i64` I32F32 (limits on the I16F16 grid) | ±2³¹ | 2⁻³² |
//! | filter coefficient | U1F31 `u32` | [0, 1] | 4.7·10⁻¹⁰ |

#![deny(clippy::float_arithmetic)]

use crate::error::ConfigError;
use crate::num::fixed::shr_round_i64;
use crate::num::float_bits::decode_f64;
use crate::num::wide::{mul_i32_u32_wide, mul_i32_wide, mul_u32_wide};
use crate::words::{WordReader, WordWriter, Words};

/// Fraction bits of the I32F32 accumulator of the controller terms.
pub const ACC_FRAC_BITS: u32 = 32;
/// 1.0 in U1F31 (the filter coefficients).
pub const ONE_U1F31: u32 = 1 << 31;

/// A gain from an I16F16 signal to an I32F32 term: `value = m · 2^−(16 + s)`, the mantissa
/// normalised to |m| ∈ [2³⁰, 2³¹) (31 significant bits whatever the magnitude), `s ∈ 0..=62`.
///
/// `apply(x) = round(x · m / 2^s)`: exact product, one rounding. Range (0, 2¹⁵); gains below
/// 2⁻⁴⁸ lose significant bits (there the term is below 2⁻³² u_fs per quantum anyway).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gain {
    m: i32,
    s: u32,
}

impl Gain {
    /// Zero.
    pub const ZERO: Self = Self { m: 0, s: 0 };
    /// Largest shift.
    const MAX_SHIFT: u32 = 62;

    /// Quantises `g` (I32F32 output units per I16F16 input unit); `None` for NaN, ±∞ or |g| ≥ 2¹⁵.
    ///
    /// `m = round(g·2¹⁶·2^s)` with the smallest `s ≤ 62` that puts |m| in [2³⁰, 2³¹), computed from
    /// the bits of `g` (exponent and 53-bit mantissa) with integer shifts only: it runs in the
    /// slow-rate redesign on cores without a double-precision FPU, where a loop of soft-float `f64`
    /// multiplications would cost far more (`bench_sched_redesign` in BENCHMARKS.md).
    pub fn from_f64(g: f64) -> Option<Self> {
        if !g.is_finite() {
            return None;
        }
        let (negative, mant, e2) = decode_f64(g);
        if mant == 0 {
            return Some(Self::ZERO);
        }
        // |g| = mant · 2^(e − 1075): e is the biased exponent (1 for a subnormal).
        let e = e2 + 1075;
        // x·2^s = mant · 2^(e − 1075 + 16 + s); for a normal mant ∈ [2^52, 2^53) the integer
        // part lies in [2^30, 2^31) when the exponent is −22: s = 1037 − e.
        let s = 1037 - e;
        if s < 0 {
            return None; // |x| ≥ 2^31
        }
        let s = s.min(Self::MAX_SHIFT as i32);
        let right = (1075 - 16 - s - e) as u32; // ≥ 22
        // round half up: floor(mant / 2^right + 1/2); right ≥ 64 gives 0.
        let m = if right >= 64 {
            0
        } else {
            ((u128::from(mant) + (1u128 << (right - 1))) >> right) as i64
        };
        let (m, s) = if m >= 1 << 31 {
            // Rounded up to 2^31: one bit less of shift.
            if s == 0 {
                return None;
            }
            (1i64 << 30, s - 1)
        } else {
            (m, s)
        };
        let m = m as i32; // < 2^31
        Some(Self {
            m: if negative { -m } else { m },
            s: s as u32,
        })
    }

    /// The float loop `from_f64` replaced, kept to check it bit for bit.
    #[cfg(test)]
    #[allow(clippy::float_arithmetic)]
    fn from_f64_by_loop(g: f64) -> Option<Self> {
        if !g.is_finite() {
            return None;
        }
        if g == 0.0 {
            return Some(Self::ZERO);
        }
        let mut x = if g < 0.0 { -g } else { g } * 65_536.0;
        if x >= 2_147_483_648.0 {
            return None;
        }
        let mut s = 0;
        while x < 1_073_741_824.0 && s < Self::MAX_SHIFT {
            x *= 2.0;
            s += 1;
        }
        let mut m = (x + 0.5) as i64;
        if m >= 1 << 31 {
            if s == 0 {
                return None;
            }
            m = 1 << 30;
            s -= 1;
        }
        let m = m as i32;
        Some(Self {
            m: if g < 0.0 { -m } else { m },
            s,
        })
    }

    /// The value (exact for a valid gain; an invalid shift ≥ 64 reads as 0, never a panic).
    #[allow(clippy::float_arithmetic)] // diagnostics, not the per-sample path
    pub fn to_f64(self) -> f64 {
        // m / 2¹⁶ / 2^s as one product with 2^−(16 + s), built from its bits: both are exact
        // (|m| < 2³¹, 16 + s ≤ 79: no rounding, no subnormal), so the value is the quotient's to
        // the bit — and an image that reads a gain needs no soft-float `f64` division.
        if self.s >= 64 {
            return 0.0;
        }
        f64::from(self.m) * f64::from_bits((1023 - 16 - u64::from(self.s)) << 52)
    }

    /// A quantised gain as [`Self::from_f64`] makes them: `s ≤ 62`, `m ≠ i32::MIN` (so |m| < 2³¹).
    pub const fn is_valid(self) -> bool {
        self.s <= Self::MAX_SHIFT && self.m != i32::MIN
    }

    /// The mantissa and the shift.
    pub const fn parts(self) -> (i32, u32) {
        (self.m, self.s)
    }

    /// `x · value` in I32F32 for an I16F16 `x`, rounded half up; |result| < 2⁶².
    #[inline(always)]
    pub fn apply(self, x: i32) -> i64 {
        // |x·m| < 2^31 · 2^31: exact in i64; the shift only reduces it. (A one-shift rounding,
        // `(p + (2^s >> 1)) >> s`, measured 3 % slower on M4F and 2 % faster on M0+.)
        shr_round_i64(mul_i32_wide(x, self.m), self.s)
    }
}

/// `round(x · c / 2³¹)` for any `i64` x and a U1F31 coefficient `c ≤ 2³¹` (|result| ≤ |x|).
#[inline(always)]
pub fn mul_i64_u1f31(x: i64, c: u32) -> i64 {
    // x = hi·2^32 + lo, lo unsigned: x·c / 2^31 = 2·hi·c + lo·c / 2^31, the first part exact.
    let hi = (x >> 32) as i32;
    let lo = x as u32;
    let hi_part = mul_i32_u32_wide(hi, c); // |·| ≤ 2^62
    let lo_part = mul_u32_wide(lo, c); // < 2^63
    let floor = (hi_part << 1) + (lo_part >> 31) as i64; // = floor(x·c/2^31), |·| ≤ |x| + 1 < 2^63
    floor + ((lo_part >> 30) & 1) as i64 // round half up: stays within [floor, ceil]
}

/// Words: m, s (validity: [`Gain::is_valid`]).
impl Words for Gain {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.m.put(w)?;
        self.s.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            m: i32::take(r),
            s: u32::take(r),
        }
    }
}

/// Largest I32F32 limit a `build` produces: `i32::MAX · 2¹⁶` (it must round into I16F16).
pub const LIMIT_I32F32_MAX: i64 = (i32::MAX as i64) << 16;

/// `x` limited to `[−limit, limit]`: `x.clamp(−limit, limit)` for every `limit ≥ 0` (the limits
/// are built non-negative), without `clamp`'s panic for an empty range (a negative `limit` gives
/// `limit`). Never panics, links no formatting code. `limit` must not be `i64::MIN`.
#[inline(always)]
pub fn clamp_sym_i64(x: i64, limit: i64) -> i64 {
    x.max(limit.wrapping_neg()).min(limit)
}

/// [`clamp_sym_i64`] for `i32`.
#[inline(always)]
pub fn clamp_sym_i32(x: i32, limit: i32) -> i32 {
    x.max(limit.wrapping_neg()).min(limit)
}

/// `round(x · 2³²)` for `0 ≤ x < 2¹⁵` (an I32F32 limit), at most `i32::MAX · 2¹⁶` so that it
/// rounds into I16F16; `None` otherwise, NaN included.
#[allow(clippy::float_arithmetic)] // design time, not the per-sample path
pub fn i32f32_from_f64(x: f64) -> Option<i64> {
    if !(0.0..32_768.0).contains(&x) {
        return None;
    }
    let raw = (x * 4_294_967_296.0 + 0.5) as i64; // ≤ 2^47
    (raw <= LIMIT_I32F32_MAX).then_some(raw)
}

/// A first-order smoothing pole `e^{−2π·f·Ts}` in U1F31, 0 for `f = 0` (off); `None` unless
/// `f = 0` or `0 < f·Ts < ½`.
#[allow(clippy::float_arithmetic)] // design time, not the per-sample path
pub fn pole_u1f31(corner_hz: f64, ts_s: f64) -> Option<u32> {
    if corner_hz == 0.0 {
        return Some(0);
    }
    if !(corner_hz.is_finite() && corner_hz > 0.0 && corner_hz * ts_s < 0.5) {
        return None;
    }
    let pole = exp_neg(2.0 * core::f64::consts::PI * corner_hz * ts_s);
    Some(((pole * f64::from(ONE_U1F31)) + 0.5) as u32) // pole ∈ (e^−π, 1): ≤ 2^31
}

/// `e^{−x}` for `0 ≤ x ≤ 4` without `std`: `(e^{−x/1024})^1024`, the small argument by its Taylor
/// series to 8th order; relative error ≈ 10⁻¹³ (the squarings double it ten times).
#[allow(clippy::float_arithmetic)] // design time, not the per-sample path
pub fn exp_neg(x: f64) -> f64 {
    let y = -x / 1024.0;
    let mut term = 1.0;
    let mut sum = 1.0;
    let mut k = 1.0;
    while k <= 8.0 {
        term *= y / k;
        sum += term;
        k += 1.0;
    }
    for _ in 0..10 {
        sum *= sum;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gains_quantise_with_31_significant_bits() {
        for g in [
            1.0, -1.0, 0.003, 1.95e-4, 1.217e-3, 0.0182, 12_345.678, -3.0e-9,
        ] {
            let q = Gain::from_f64(g).unwrap();
            let (m, s) = q.parts();
            assert!(m.unsigned_abs() >= 1 << 30, "{g}: m = {m}");
            assert!(s <= 62);
            assert!(((q.to_f64() - g) / g).abs() < 1e-9, "{g}");
        }
        assert_eq!(Gain::from_f64(0.0), Some(Gain::ZERO));
        assert_eq!(Gain::from_f64(32_768.0), None);
        assert_eq!(Gain::from_f64(f64::NAN), None);
        assert!(Gain::from_f64(32_767.99).is_some());
        // Apply: 0.5 × 3 quanta = 1.5 in I32F32.
        let half = Gain::from_f64(0.5).unwrap();
        assert_eq!(half.apply(3 << 16), 3 << 31);
        assert_eq!(half.apply(-(3 << 16)), -(3 << 31));
        let big = Gain::from_f64(32_767.0).unwrap();
        assert!(big.apply(i32::MIN).unsigned_abs() < 1 << 62);
        // Tiny gains underflow to their rounding, never panic.
        let tiny = Gain::from_f64(1e-30).unwrap();
        assert_eq!(tiny.apply(i32::MAX), 0);
    }

    #[test]
    fn gain_from_bits_equals_the_float_loop() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let fixed = [
            0.0,
            -0.0,
            1.0,
            32_768.0,
            32_767.999_999,
            -32_767.999_999_9,
            1e-30,
            -1e-14,
            3.0e-9,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            (1u64 << 31) as f64 / 65_536.0 - 1e-12,
            0.999_999_999_9,
        ];
        let check = |v: f64| assert_eq!(Gain::from_f64(v), Gain::from_f64_by_loop(v), "{v:e}");
        fixed.iter().for_each(|&v| check(v));
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = f64::from_bits(x);
            check(v);
            // And a value in the gains' usual range, with random low bits.
            check(((x >> 11) as f64 / (1u64 << 53) as f64) * 1e-3);
            check(-((x >> 11) as f64 / (1u64 << 53) as f64) * 1e-3 * 0.013);
        }
    }

    #[test]
    fn wide_coefficient_product_rounds_and_never_overflows() {
        let half = ONE_U1F31 / 2;
        assert_eq!(mul_i64_u1f31(10, half), 5);
        assert_eq!(mul_i64_u1f31(3, half), 2);
        assert_eq!(mul_i64_u1f31(-3, half), -1);
        assert_eq!(mul_i64_u1f31(i64::MAX, ONE_U1F31), i64::MAX);
        assert_eq!(mul_i64_u1f31(i64::MIN, ONE_U1F31), i64::MIN);
        assert_eq!(mul_i64_u1f31(i64::MIN, 0), 0);
        let x = 0x1234_5678_9abc_def0_i64;
        let c = 0x6000_0001_u32;
        let exact = (i128::from(x) * i128::from(c) + (1 << 30)) >> 31;
        assert_eq!(i128::from(mul_i64_u1f31(x, c)), exact);
        assert_eq!(
            i128::from(mul_i64_u1f31(-x, c)),
            (-i128::from(x) * i128::from(c) + (1 << 30)) >> 31
        );
    }

    /// `to_f64`'s product with 2^−(16 + s) is the former quotient m / 65,536 / 2^s to the bit,
    /// over mantissas of every magnitude and sign and every shift (invalid ones read 0).
    #[test]
    fn to_f64_is_the_quotient_to_the_bit() {
        let mut x: u32 = 0x2545_F491;
        for s in 0..70u32 {
            for i in 0..400 {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                let m = match i {
                    0 => 0,
                    1 => i32::MAX,
                    2 => i32::MIN + 1,
                    3 => -1,
                    _ => (x as i32) >> (i % 31),
                };
                let g = Gain { m, s };
                let want = 1u64
                    .checked_shl(s)
                    .map_or(0.0, |d| f64::from(m) / 65_536.0 / d as f64);
                assert_eq!(g.to_f64().to_bits(), want.to_bits(), "m {m} s {s}");
            }
        }
    }

    #[test]
    fn exp_and_poles() {
        assert!((exp_neg(1.0) - 0.367_879_441_171_442_33).abs() < 1e-13);
        assert!((exp_neg(0.0) - 1.0).abs() < 1e-15);
        assert!((exp_neg(3.0) - 0.049_787_068_367_863_944).abs() < 1e-14);
        assert_eq!(pole_u1f31(0.0, 1e-3), Some(0));
        assert_eq!(i32f32_from_f64(1.5), Some(3 << 31));
        assert_eq!(i32f32_from_f64(32_768.0 - 1e-9), None);
        assert_eq!(i32f32_from_f64(-1e-300), None);
        assert_eq!(i32f32_from_f64(f64::NAN), None);
        assert_eq!(pole_u1f31(500.0, 1e-3), None);
        assert_eq!(pole_u1f31(-1.0, 1e-3), None);
        assert_eq!(pole_u1f31(f64::NAN, 1e-3), None);
        let beta = pole_u1f31(1000.0, 0.455e-3).unwrap();
        let expect = 0.057_334_696_510_890_12; // e^{−2π·0.455}
        assert!((f64::from(beta) / f64::from(ONE_U1F31) - expect).abs() < 1e-9);
    }
}
