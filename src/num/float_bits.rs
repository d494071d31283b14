//! The one bit-level decoder of `f64` the design-time conversions share ([`super::fixed`],
//! [`super::dyadic`], [`super::gain`]): they quantise from the bits with integer operations
//! only, so that a configuration built on a core without a double-precision FPU needs no
//! soft-float multiply.

/// A finite `f64` as `(negative, m, e)` with `|x| = m · 2^e` exactly: a normal x has
/// `m = 2⁵² + fraction ∈ [2⁵², 2⁵³)` and `e = biased − 1075`; a subnormal x has `m = fraction`
/// and `e = −1074`; zero has `m = 0`. NaN and ±∞ are not finite: the callers check first (their
/// bits decode as a huge m·2^e, never a panic).
pub const fn decode_f64(x: f64) -> (bool, u64, i32) {
    let bits = x.to_bits();
    let negative = bits >> 63 != 0;
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1 << 52) - 1);
    if biased == 0 {
        (negative, fraction, -1074)
    } else {
        (negative, fraction | (1 << 52), biased - 1075)
    }
}

/// `raw · 2^−frac_bits` as an `f64` (for error values and diagnostics), without a floating-point
/// multiply or divide: the integer is converted, then its exponent field lowered. Exact for
/// |raw| < 2⁵³ and `frac_bits ≤ 64`; rounded to 53 bits beyond.
pub fn from_fixed(raw: i64, frac_bits: u32) -> f64 {
    let x = raw as f64;
    if raw == 0 || frac_bits > 64 {
        return x;
    }
    let bits = x.to_bits();
    // |raw| ≥ 1 has a biased exponent ≥ 1023 > 64: lowering it stays a normal number.
    f64::from_bits(bits - (u64::from(frac_bits) << 52))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[allow(clippy::float_arithmetic)]
    fn decodes_exactly() {
        for x in [1.0, -0.75, 1e-310, 5e-324, f64::MAX, 0.1, -3.0e-9] {
            let (neg, m, e) = decode_f64(x);
            assert_eq!(neg, x < 0.0);
            // m · 2^e rebuilt exactly in two steps (e may exceed f64's exponent range alone).
            let v = m as f64 * 2f64.powi(e / 2) * 2f64.powi(e - e / 2);
            assert_eq!(v, x.abs(), "{x:e}");
        }
        assert_eq!(decode_f64(0.0).1, 0);
        assert_eq!(from_fixed(3 << 15, 16), 1.5);
        assert_eq!(from_fixed(-(1 << 20), 20), -1.0);
        assert_eq!(from_fixed(0, 16), 0.0);
        assert_eq!(from_fixed(i64::MIN, 64), -0.5);
        assert_eq!(decode_f64(-0.0), (true, 0, -1074));
    }
}
