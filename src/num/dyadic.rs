//! Positive dyadic numbers `m · 2^e` with a normalised 32-bit mantissa: the wide-range scalars of the
//! UD estimator (the diagonal factor D of the covariance, the Bierman innovation variances α and their
//! reciprocals), held in integers.
//!
//! # Why
//! The RLS covariance of closed-loop sled data spans about 2^50 (from P₀ = 10⁴·I to trace ≈ 10⁻¹⁵ when
//! converged, `shared/findings.md`) and grows without bound under forgetting when the excitation
//! vanishes. No single fixed-point format holds that. A per-number exponent does, and costs one
//! count-leading-zeros per operation: the value keeps 32 significant bits over any magnitude.
//!
//! # Formats
//! | quantity | representation | range | step |
//! |---|---|---|---|
//! | [`Dyadic`] | `mant · 2^exp`, `mant` in `[2^31, 2^32)` or 0 | `[2^(EXP_MIN+31), 2^(EXP_MAX+32))` | 2⁻³² relative |
//!
//! # Scaling and overflow
//! Exponents saturate at [`EXP_MIN`]/[`EXP_MAX`] (|e| ≤ 2¹⁴, so ≈ 10^±4900: far beyond any covariance
//! that still means something); [`Dyadic::is_saturated`] tells. `mul_trunc` and `add_trunc` truncate
//! toward zero (error < 2⁻³¹ relative); [`Dyadic::recip`] is within one unit of `2^63 / mant`.
//!
//! # Accuracy
//! Relative error of `mul`/`add` ≤ 2⁻³¹, `recip` ≤ 2⁻³¹, asserted against `f64` by the unit tests below.
//!
//! # Cost
//! `mul_trunc` is one 32×32→64 multiply and a one-bit normalisation; `add_trunc` an alignment shift and a
//! leading-zero count; `recip` a 256-entry table lookup and two Newton steps (no division
//! instruction, no 64-bit division). Multiplies and bit counts go through [`crate::num::wide`], so Armv6-M
//! does not call `__aeabi_lmul`/`__clzsi2`.

use crate::num::float_bits::decode_f64;

/// Smallest exponent; values below `2^(EXP_MIN+31)` flush to the smallest positive number or zero.
pub const EXP_MIN: i32 = -16_384;
/// Largest exponent; larger values saturate to the largest representable number.
pub const EXP_MAX: i32 = 16_384;

/// A non-negative number `mant · 2^exp` with `mant == 0` or `2^31 ≤ mant < 2^32`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dyadic {
    mant: u32,
    exp: i32,
}

impl Dyadic {
    /// Zero.
    pub const ZERO: Self = Self { mant: 0, exp: 0 };
    /// One.
    pub const ONE: Self = Self {
        mant: 1 << 31,
        exp: -31,
    };
    /// The largest representable value (saturation).
    pub const MAX: Self = Self {
        mant: u32::MAX,
        exp: EXP_MAX,
    };
    /// The smallest positive value.
    pub const MIN_POSITIVE: Self = Self {
        mant: 1 << 31,
        exp: EXP_MIN,
    };

    /// The mantissa: 0 or in `[2^31, 2^32)`.
    pub const fn mant(self) -> u32 {
        self.mant
    }

    /// The binary exponent.
    pub const fn exp(self) -> i32 {
        self.exp
    }

    /// True for zero.
    pub const fn is_zero(self) -> bool {
        self.mant == 0
    }

    /// True when the exponent reached its upper limit (the value is not trustworthy).
    pub const fn is_saturated(self) -> bool {
        self.exp >= EXP_MAX
    }

    /// `m · 2^exp` for any 64-bit `m`, normalised (truncating the bits below the 32 kept).
    #[inline]
    pub fn from_u64(m: u64, exp: i32) -> Self {
        if m == 0 {
            return Self::ZERO;
        }
        let lz = (64 - crate::num::wide::bit_len_u64(m)) as u32;
        let top = ((m << lz) >> 32) as u32;
        Self::clamped(top, exp.saturating_add(32 - lz as i32))
    }

    /// `m · 2^exp` for a 32-bit `m`.
    #[inline]
    pub fn from_u32(m: u32, exp: i32) -> Self {
        if m == 0 {
            return Self::ZERO;
        }
        let lz = (32 - crate::num::wide::bit_len_u64(u64::from(m))) as u32;
        Self::clamped(m << lz, exp.saturating_sub(lz as i32))
    }

    /// `mant · 2^exp` for a mantissa already in `[2^31, 2^32)` (or 0), exponent limits applied: the
    /// exit of kernels that work on raw mantissas and exponents.
    #[inline(always)]
    pub(crate) const fn from_normalised(mant: u32, exp: i32) -> Self {
        if mant == 0 {
            Self::ZERO
        } else {
            Self::clamped(mant, exp)
        }
    }

    /// `mant · 2^exp` as it is: the caller guarantees `2^31 ≤ mant` and `EXP_MIN ≤ exp ≤ EXP_MAX`
    /// (the RLS kernel's store, after its own clamps).
    #[inline(always)]
    pub(crate) const fn from_parts(mant: u32, exp: i32) -> Self {
        Self { mant, exp }
    }

    /// Applies the exponent limits to a normalised mantissa.
    const fn clamped(mant: u32, exp: i32) -> Self {
        if exp > EXP_MAX {
            Self::MAX
        } else if exp < EXP_MIN {
            Self::MIN_POSITIVE
        } else {
            Self { mant, exp }
        }
    }

    /// Multiplies by `2^k` (exact, saturating).
    #[must_use]
    pub const fn shl(self, k: i32) -> Self {
        if self.mant == 0 {
            return self;
        }
        Self::clamped(self.mant, self.exp.saturating_add(k))
    }

    /// `self · rhs`, truncated to 32 significant bits.
    #[must_use]
    #[inline]
    pub fn mul_trunc(self, rhs: Self) -> Self {
        if self.mant == 0 || rhs.mant == 0 {
            return Self::ZERO;
        }
        // Both mantissas in [2^31, 2^32): the product is in [2^62, 2^64), one bit to normalise.
        let p = crate::num::wide::mul_u32_wide(self.mant, rhs.mant);
        // Exponents are clamped to ±2^14 by every constructor: the sum cannot overflow.
        let e = self.exp + rhs.exp;
        if p >> 63 != 0 {
            Self::clamped((p >> 32) as u32, e + 32)
        } else {
            Self::clamped((p >> 31) as u32, e + 31)
        }
    }

    /// `self + rhs`, truncated to 32 significant bits.
    #[must_use]
    #[inline]
    pub fn add_trunc(self, rhs: Self) -> Self {
        if rhs.mant == 0 {
            return self;
        }
        if self.mant == 0 {
            return rhs;
        }
        let (hi, lo) = if self.exp >= rhs.exp {
            (self, rhs)
        } else {
            (rhs, self)
        };
        let d = hi.exp.abs_diff(lo.exp);
        // Each term below 2^63, so the sum fits in 64 bits; hi_w ≥ 2^62, so the sum is in
        // [2^62, 2^64): normalising it is a one-bit decision, no leading-zero count.
        let hi_w = (hi.mant as u64) << 31;
        let lo_w = if d >= 64 {
            0
        } else {
            ((lo.mant as u64) << 31) >> d
        };
        let sum = hi_w + lo_w;
        if sum >> 63 != 0 {
            Self::clamped((sum >> 32) as u32, hi.exp + 1)
        } else {
            Self::clamped((sum >> 31) as u32, hi.exp)
        }
    }

    /// `self − rhs` if `self ≥ rhs`, else zero (truncated to 32 significant bits).
    #[must_use]
    pub fn saturating_sub(self, rhs: Self) -> Self {
        if rhs.mant == 0 {
            return self;
        }
        if !rhs.lt(self) {
            return Self::ZERO;
        }
        let d = self.exp.abs_diff(rhs.exp);
        let hi_w = (self.mant as u64) << 31;
        let lo_w = if d >= 64 {
            0
        } else {
            ((rhs.mant as u64) << 31) >> d
        };
        Self::from_u64(hi_w - lo_w, self.exp - 31)
    }

    /// `self < rhs`.
    pub const fn lt(self, rhs: Self) -> bool {
        if self.mant == 0 {
            return rhs.mant != 0;
        }
        if rhs.mant == 0 {
            return false;
        }
        if self.exp != rhs.exp {
            return self.exp < rhs.exp;
        }
        self.mant < rhs.mant
    }

    /// `1 / self` to within one unit of the kept bits ([`crate::num::wide::recip_q63`]: table seed and two
    /// Newton steps, no division); the reciprocal of zero saturates.
    #[must_use]
    #[inline]
    pub fn recip(self) -> Self {
        if self.mant == 0 {
            return Self::MAX;
        }
        // 1/(m·2^e) = (2^63/m)·2^(−63−e).
        Self::from_u64(crate::num::wide::recip_q63(self.mant), -63 - self.exp)
    }

    /// The value as an unsigned U0F32 fraction, saturating at `u32::MAX` for values ≥ 1.
    pub const fn to_u0f32_saturating(self) -> u32 {
        if self.mant == 0 {
            return 0;
        }
        // raw = mant · 2^(exp + 32)
        let s = self.exp + 32;
        if s > 0 {
            u32::MAX
        } else if s == 0 {
            self.mant
        } else if s <= -32 {
            0
        } else {
            self.mant >> (-s) as u32
        }
    }

    /// From a finite non-negative `f64` (exact for normal numbers: the low bits of the f64 mantissa
    /// are truncated). `None` for NaN, infinities and negative numbers.
    pub fn from_f64(x: f64) -> Option<Self> {
        if !x.is_finite() || x < 0.0 {
            return None;
        }
        if x == 0.0 {
            return Some(Self::ZERO);
        }
        let (_, m, e) = decode_f64(x);
        Some(Self::from_u64(m, e))
    }

    /// To `f64` (rounded to 53 bits; exact for exponents within f64's range, else 0 or ∞).
    pub fn to_f64(self) -> f64 {
        if self.mant == 0 {
            return 0.0;
        }
        // mant · 2^exp = (mant / 2^31) · 2^(exp + 31), with mant/2^31 in [1, 2).
        let e = self.exp + 31;
        if e > 1023 {
            return f64::INFINITY;
        }
        if e < -1022 {
            return 0.0;
        }
        let frac = ((self.mant as u64) << 21) & ((1u64 << 52) - 1);
        f64::from_bits((((e + 1023) as u64) << 52) | frac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn f64_round_trip_is_exact_to_32_bits() {
        for &x in &[1.0, 0.995, 1e4, 1e-15, 3.0e-300, 7.5e300, 0.1, 123456.789] {
            let d = Dyadic::from_f64(x).unwrap();
            assert!(rel(d.to_f64(), x) < 2f64.powi(-31), "{x}");
        }
        assert_eq!(Dyadic::from_f64(0.0), Some(Dyadic::ZERO));
        assert_eq!(Dyadic::from_f64(-1.0), None);
        assert_eq!(Dyadic::from_f64(f64::NAN), None);
        assert_eq!(Dyadic::from_f64(f64::INFINITY), None);
        assert_eq!(Dyadic::ONE.to_f64(), 1.0);
    }

    #[test]
    fn recip_is_within_one_unit_for_edge_and_sampled_mantissas() {
        let mut m: u32 = 1 << 31;
        let mut checked = 0;
        loop {
            let d = Dyadic { mant: m, exp: -31 };
            let r = d.recip();
            let exact = (1u64 << 63) / u64::from(m);
            // 1 / (m · 2^-31) = floor(2^63 / m) · 2^(−63 + 31) to the kept bits.
            let back = Dyadic::from_u64(exact, -63 + 31);
            assert!(
                rel(r.to_f64(), back.to_f64()) <= 2f64.powi(-31),
                "m = {m:#x}"
            );
            checked += 1;
            if m >= u32::MAX - 7_919_993 {
                break;
            }
            m += 7_919_993;
        }
        assert!(checked > 250);
        let top = Dyadic {
            mant: u32::MAX,
            exp: 0,
        }
        .recip();
        assert!(rel(top.to_f64(), 1.0 / f64::from(u32::MAX)) < 1e-9);
        assert_eq!(Dyadic::ZERO.recip(), Dyadic::MAX);
    }

    #[test]
    fn mul_add_sub_against_f64() {
        let xs = [1e-12, 3.3e-5, 0.5, 0.999, 1.0, 2.0, 7.7e3, 1.1e9, 4.2e17];
        for &a in &xs {
            for &b in &xs {
                let da = Dyadic::from_f64(a).unwrap();
                let db = Dyadic::from_f64(b).unwrap();
                assert!(rel(da.mul_trunc(db).to_f64(), a * b) < 2f64.powi(-30));
                assert!(rel(da.add_trunc(db).to_f64(), a + b) < 2f64.powi(-30));
                if a > b {
                    let s = da.saturating_sub(db).to_f64();
                    assert!((s - (a - b)).abs() <= 2f64.powi(-30) * a, "{a} - {b}");
                } else {
                    assert_eq!(da.saturating_sub(db), Dyadic::ZERO);
                }
                assert_eq!(da.lt(db), a < b);
            }
        }
    }

    #[test]
    fn saturation_and_zero() {
        assert!(Dyadic::MAX.mul_trunc(Dyadic::MAX).is_saturated());
        assert_eq!(
            Dyadic::MIN_POSITIVE.mul_trunc(Dyadic::MIN_POSITIVE),
            Dyadic::MIN_POSITIVE
        );
        assert_eq!(Dyadic::ZERO.mul_trunc(Dyadic::ONE), Dyadic::ZERO);
        assert_eq!(Dyadic::ZERO.add_trunc(Dyadic::ONE), Dyadic::ONE);
        assert_eq!(Dyadic::ONE.to_u0f32_saturating(), u32::MAX);
        assert_eq!(
            Dyadic::from_f64(0.5).unwrap().to_u0f32_saturating(),
            1 << 31
        );
        assert_eq!(Dyadic::from_u64(1 << 40, 0).shl(-40), Dyadic::ONE);
    }
}
