//! Widening multiplies and the reciprocal, written so they are cheap on every Cortex-M core.
//!
//! On Armv7-M (M3/M4) `u32 × u32 → u64` is one `UMULL` and a leading-zero count one `CLZ`; on
//! Armv6-M (M0/M0+) the compiler would call `__aeabi_lmul` (a 64×64 multiply) and `__clzsi2`.
//! [`mul_u32_wide`] builds the product from four 16×16 `MULS` there instead, [`leading_zeros_u32`]
//! counts by a de Bruijn multiply and [`bit_len_u64`] by binary search. Both paths of each return
//! exactly the same result, so outputs are bit-identical on every target (the tests assert the
//! paths agree).
//!
//! Armv6-M is recognised by `target_has_atomic = "32"` being absent: it is the only Arm profile
//! without exclusive load/store, and Rust exposes no `thumb2`/`v7` target-feature cfg on stable.
//!
//! # Accuracy
//! Multiplies are exact. [`recip_q63`] returns `floor(2^63 / m)` or one less (error < 2 units in
//! 2³², asserted in the tests below over a sweep of mantissas).

#![deny(clippy::float_arithmetic)]

/// True when compiling for Armv6-M (no `UMULL`/`SMULL`/`CLZ`): see the module doc. A constant, so
/// the untaken branch below is removed at compile time.
const ARMV6M: bool = cfg!(all(target_arch = "arm", not(target_has_atomic = "32")));

/// Exact `a · b` as `u64`.
#[inline(always)]
pub fn mul_u32_wide(a: u32, b: u32) -> u64 {
    if ARMV6M {
        mul_u32_wide_by_halves(a, b)
    } else {
        u64::from(a) * u64::from(b)
    }
}

/// Bit length of `x` (0 for 0, 64 for values ≥ 2⁶³): `64 − x.leading_zeros()`.
#[inline(always)]
pub fn bit_len_u64(x: u64) -> i32 {
    if ARMV6M {
        bit_len_u64_by_search(x)
    } else {
        64 - x.leading_zeros() as i32
    }
}

/// Leading zeros of a 32-bit `x` (32 for 0): one `CLZ` on Armv7-M; on Armv6-M (where
/// `leading_zeros` calls `__clzsi2`) [`leading_zeros_by_de_bruijn`], with no branch but the one
/// for 0.
#[inline(always)]
pub fn leading_zeros_u32(x: u32) -> u32 {
    if ARMV6M {
        leading_zeros_by_de_bruijn(x)
    } else {
        x.leading_zeros()
    }
}

/// The de Bruijn multiplier of [`leading_zeros_by_de_bruijn`]: (2^k − 1)·`DE_BRUIJN_LZ` >> 27 is a
/// different index for each k in 1..=32 (asserted in the tests).
const DE_BRUIJN_LZ: u32 = 0x07C4_ACDD;

/// 32 − k at index (2^k − 1)·[`DE_BRUIJN_LZ`] >> 27, k = 1..=32. Built at compile time.
#[allow(clippy::indexing_slicing)] // compile-time evaluation: the index is below 32 by the shift
const LZ_OF_SMEAR: [u8; 32] = {
    let mut t = [0u8; 32];
    let mut k = 1;
    while k <= 32 {
        let v = if k == 32 { u32::MAX } else { (1u32 << k) - 1 };
        t[(v.wrapping_mul(DE_BRUIJN_LZ) >> 27) as usize] = (32 - k) as u8;
        k += 1;
    }
    t
};

/// Leading zeros of a 32-bit `x` (32 for 0) without `CLZ` and without a search: the bits below
/// the leading one are set by five shift-ORs (x's bit length k ≥ 1 gives 2^k − 1), whose product
/// with a de Bruijn constant indexes a 32-entry table (the Armv6-M path of
/// [`leading_zeros_u32`]; the binary search it replaced took a taken branch a step). The same
/// result as `x.leading_zeros()` for every `x` (tested).
#[inline(always)]
pub fn leading_zeros_by_de_bruijn(x: u32) -> u32 {
    let mut v = x;
    v |= v >> 1;
    v |= v >> 2;
    v |= v >> 4;
    v |= v >> 8;
    v |= v >> 16;
    let lz = LZ_OF_SMEAR
        .get((v.wrapping_mul(DE_BRUIJN_LZ) >> 27) as usize)
        .copied()
        .unwrap_or(0);
    if x == 0 { 32 } else { u32::from(lz) }
}

/// Leading zeros of a 32-bit `x` expected to be nearly normalised (`x ≥ 2^28` in the RLS
/// kernel's products): one `CLZ` on Armv7-M; on Armv6-M up to four compares before the general
/// search. The same result as [`leading_zeros_u32`] for every `x`.
#[inline(always)]
pub fn leading_zeros_near(x: u32) -> u32 {
    if ARMV6M {
        if x >= 1 << 31 {
            0
        } else if x >= 1 << 30 {
            1
        } else if x >= 1 << 29 {
            2
        } else if x >= 1 << 28 {
            3
        } else {
            leading_zeros_far(x)
        }
    } else {
        x.leading_zeros()
    }
}

/// [`leading_zeros_u32`] for code off the per-sample path (covariance bounds, gates): on Armv6-M
/// the one out-of-line copy of the search instead of one in line per use (flash); on Armv7-M one
/// `CLZ`. The same result.
#[inline(always)]
pub fn leading_zeros_compact(x: u32) -> u32 {
    if ARMV6M {
        leading_zeros_far(x)
    } else {
        x.leading_zeros()
    }
}

/// [`mul_u32_wide`] for code off the per-sample path (covariance bounds, gates, rare branches):
/// on Armv6-M one shared out-of-line copy of the product by halves instead of one in line per
/// use (flash); on Armv7-M the one `UMULL` in line. The same result.
#[inline(always)]
pub fn mul_u32_wide_compact(a: u32, b: u32) -> u64 {
    if ARMV6M {
        mul_u32_wide_shared(a, b)
    } else {
        u64::from(a) * u64::from(b)
    }
}

/// [`mul_i32_wide`] off the per-sample path, as [`mul_u32_wide_compact`].
#[inline(always)]
pub fn mul_i32_wide_compact(a: i32, b: i32) -> i64 {
    if ARMV6M {
        let p = mul_u32_wide_shared(a.unsigned_abs(), b.unsigned_abs()) as i64;
        if (a < 0) != (b < 0) { -p } else { p }
    } else {
        i64::from(a) * i64::from(b)
    }
}

/// The out-of-line product of [`mul_u32_wide_compact`] on Armv6-M.
#[inline(never)]
fn mul_u32_wide_shared(a: u32, b: u32) -> u64 {
    mul_u32_wide_by_halves(a, b)
}

/// [`leading_zeros_u32`] out of line: the rare end of [`leading_zeros_near`] (one copy in the
/// image instead of one per use).
#[inline(never)]
fn leading_zeros_far(x: u32) -> u32 {
    leading_zeros_u32(x)
}

/// `y >> s` (arithmetic) for `1 ≤ s ≤ 63` (outside that range the result is unspecified, not
/// UB). On Armv6-M a variable 64-bit shift is a library call (`__aeabi_lasr`), so it is built
/// there from 32-bit shifts of the two halves; both paths give the same result (tests).
#[inline(always)]
pub fn shr_i64(y: i64, s: u32) -> i64 {
    if ARMV6M {
        shr_i64_by_halves(y, s)
    } else {
        y.wrapping_shr(s)
    }
}

/// `y >> s` (arithmetic) for `1 ≤ s ≤ 63` from 32-bit shifts of the halves (the Armv6-M path of
/// [`shr_i64`]).
#[inline(always)]
pub fn shr_i64_by_halves(y: i64, s: u32) -> i64 {
    let (hi, lo) = ((y >> 32) as i32, y as u32);
    if s < 32 {
        let lo_out = (lo >> s) | ((hi as u32).wrapping_shl(32 - s));
        let hi_out = hi >> s;
        (i64::from(hi_out) << 32) | i64::from(lo_out)
    } else {
        i64::from(hi.wrapping_shr(s - 32))
    }
}

/// Bit length by binary search on 32-bit halves (the Armv6-M path of [`bit_len_u64`]).
#[inline]
pub fn bit_len_u64_by_search(x: u64) -> i32 {
    let (mut v, mut n) = if x >> 32 != 0 {
        ((x >> 32) as u32, 32)
    } else {
        (x as u32, 0)
    };
    if v >> 16 != 0 {
        v >>= 16;
        n += 16;
    }
    if v >> 8 != 0 {
        v >>= 8;
        n += 8;
    }
    if v >> 4 != 0 {
        v >>= 4;
        n += 4;
    }
    if v >> 2 != 0 {
        v >>= 2;
        n += 2;
    }
    if v >> 1 != 0 {
        v >>= 1;
        n += 1;
    }
    n + v as i32
}

/// Exact `a · b` from four 16×16-bit products (the Armv6-M path of [`mul_u32_wide`]).
#[inline(always)]
pub fn mul_u32_wide_by_halves(a: u32, b: u32) -> u64 {
    let (al, ah) = (a & 0xFFFF, a >> 16);
    let (bl, bh) = (b & 0xFFFF, b >> 16);
    let ll = al * bl;
    let lh = al * bh;
    let hl = ah * bl;
    let hh = ah * bh;
    // mid < 2^33: the carry of the middle terms goes into the high word.
    let mid = u64::from(lh) + u64::from(hl);
    (u64::from(hh) << 32) + (mid << 16) + u64::from(ll)
}

/// Exact `a · b` as `i64` for signed `a` and unsigned `b`.
#[inline(always)]
pub fn mul_i32_u32_wide(a: i32, b: u32) -> i64 {
    if ARMV6M {
        let p = mul_u32_wide_by_halves(a.unsigned_abs(), b) as i64; // < 2^63
        if a < 0 { -p } else { p }
    } else {
        // One SMULL-class multiply on Armv7-M; |a·b| < 2^63.
        i64::from(a) * i64::from(b)
    }
}

/// Exact `a · b` as `i64` for signed operands: one `SMULL` on Armv7-M; on Armv6-M
/// [`mul_i32_wide_signed_halves`] (four `MULS`, no branch).
#[inline(always)]
pub fn mul_i32_wide(a: i32, b: i32) -> i64 {
    if ARMV6M {
        mul_i32_wide_signed_halves(a, b)
    } else {
        // One SMULL on Armv7-M; |a·b| ≤ 2^62.
        i64::from(a) * i64::from(b)
    }
}

/// Exact `a · b` from the absolute values' four 16×16 products and a sign fix-up (the previous
/// Armv6-M path of [`mul_i32_wide`], kept as the tests' second reference).
#[inline(always)]
pub fn mul_i32_wide_by_halves(a: i32, b: i32) -> i64 {
    let p = mul_u32_wide_by_halves(a.unsigned_abs(), b.unsigned_abs()) as i64;
    if (a < 0) != (b < 0) { -p } else { p }
}

/// The Armv6-M path of [`mul_i32_wide`], callable on every target so the tests can compare paths:
/// four 16×16 products of the signed high and unsigned low halves summed in 32-bit words, with no
/// absolute values, no 64-bit negation and no branch ([`mul_i32_wide_by_halves`] takes absolute
/// values: RLS n = 4 update on the M0+ 5,255 → 5,030 est. cycles). a = a_h·2^16 + a_l with a_h = a >> 16 signed and a_l < 2^16; |a_h·b_l|, |a_l·b_h| < 2^31
/// and a_h·b_h ≤ 2^30, so every partial product and partial sum fits an `i32`.
#[inline(always)]
pub fn mul_i32_wide_signed_halves(a: i32, b: i32) -> i64 {
    let (hi, t, ll) = signed_partials(a, b);
    let lo = ((t as u32) << 16) | (ll & 0xFFFF);
    (i64::from(hi + (t >> 16)) << 32) | i64::from(lo)
}

/// `round(a·b / 2^32)` (half up) for signed operands: `SMMULR` on Armv7E-M; on Armv6-M the
/// partial products of [`mul_i32_wide_signed_halves`] without the low word. |a·b| ≤ 2^62: the
/// result always fits. The same result on every target (tested).
#[inline(always)]
pub fn mul_hi_round_i32(a: i32, b: i32) -> i32 {
    if ARMV6M {
        let (hi, t, _) = signed_partials(a, b);
        // The low word's top bit is bit 15 of t: rounding adds it to the high word.
        hi + ((t + 0x8000) >> 16)
    } else {
        ((i64::from(a) * i64::from(b) + (1 << 31)) >> 32) as i32
    }
}

/// a·b = (`hi` + (`t` >> 16))·2^32 + (`t` mod 2^16)·2^16 + (`ll` mod 2^16), 0 ≤ t < 3·2^16.
#[inline(always)]
fn signed_partials(a: i32, b: i32) -> (i32, i32, u32) {
    let (ah, al) = (a >> 16, a & 0xFFFF);
    let (bh, bl) = (b >> 16, b & 0xFFFF);
    let ll = (al as u32) * (bl as u32);
    let m1 = ah * bl;
    let m2 = al * bh;
    let t = (ll >> 16) as i32 + (m1 & 0xFFFF) + (m2 & 0xFFFF);
    (ah * bh + (m1 >> 16) + (m2 >> 16), t, ll)
}

/// The high word of `a · b`, `floor(a·b / 2^32)`: one `UMULL` on Armv7-M, four 16×16 products on
/// Armv6-M. Exact on every target.
#[inline(always)]
pub fn mul_hi_u32(a: u32, b: u32) -> u32 {
    (mul_u32_wide(a, b) >> 32) as u32
}

/// The Armv6-M path of [`mul_hi_u32`], callable on every target so the tests can compare paths.
/// (Written through the 64-bit sum of the partial products: LLVM recognises a high word summed
/// from 32-bit halves as a 64-bit multiply and calls `__aeabi_lmul` for it on Armv6-M.)
#[inline(always)]
pub fn mul_hi_u32_by_halves(a: u32, b: u32) -> u32 {
    (mul_u32_wide_by_halves(a, b) >> 32) as u32
}

/// `floor(a·b / 2^32)` for signed operands (`SMMUL` on Armv7E-M).
#[inline(always)]
pub fn mul_hi_i32(a: i32, b: i32) -> i32 {
    (mul_i32_wide(a, b) >> 32) as i32
}

/// Seed table: `T[i] ≈ 2^15 · 512 / (256 + i + ½)`, 1/m̄ in U1F15 for the mantissa interval
/// starting at `(256 + i) / 512`. Built at compile time.
#[allow(clippy::indexing_slicing)] // compile-time evaluation: i < 256 by the loop bound
const RECIP_SEED_U1F15: [u16; 256] = {
    let mut t = [0u16; 256];
    let mut i = 0;
    while i < 256 {
        let den = 512 + 2 * i as u32 + 1;
        t[i] = (((1u32 << 25) + den / 2) / den) as u16;
        i += 1;
    }
    t
};

/// `≈ 2^63 / m` for a normalised mantissa `2^31 ≤ m < 2^32` (result in `(2^31, 2^32]`):
/// a 256-entry seed (9 bits) and two Newton–Raphson steps, no division instruction.
#[inline]
pub fn recip_q63(m: u32) -> u64 {
    let idx = ((m >> 23) & 0xFF) as usize;
    let seed = RECIP_SEED_U1F15.get(idx).copied().unwrap_or(0x8000);
    let mut x = u32::from(seed) << 16; // ≈ 2^31·2^32/m, < 2^32 for every seed
    for _ in 0..2 {
        // e = 2^63 − m·x, |e| < 2^55 after the seed and < 2^46 after one step.
        let e = (1u64 << 63).wrapping_sub(mul_u32_wide(m, x)) as i64;
        // x += x·e / 2^63, with e/2^31 in i32 range.
        let e_hi = (e >> 31) as i32;
        let corr = mul_i32_u32_wide(e_hi, x) >> 32;
        // |corr| ≤ x·|e|/2^63 < x/2^8: the sum stays positive, and only its upper end needs a
        // clamp (it reaches 2^32 for m near 2^31).
        x = (i64::from(x) + corr).min(i64::from(u32::MAX)) as u32;
    }
    u64::from(x)
}

/// `≈ 2^63 / m` for a normalised mantissa `2^31 ≤ m < 2^32`, within 3 units of the floor (result
/// ≤ `u32::MAX`): the same 256-entry seed as [`recip_q63`] and two Newton steps in 32-bit
/// arithmetic — each one unsigned high-word multiply (the residual e = (1 − m·x/2^63)·2^31, below
/// 2^23 after the seed) and one signed high-word multiply (the correction x·e/2^31). No division,
/// no 64-bit add: the reciprocal of the RLS kernel's column chain.
#[inline(always)]
pub fn recip_u32(m: u32) -> u32 {
    let idx = ((m >> 23) & 0xFF) as usize;
    let mut x = u32::from(RECIP_SEED_U1F15.get(idx).copied().unwrap_or(0x8000)) << 16;
    for _ in 0..2 {
        let p = (mul_u32_wide(m, x) >> 32) as u32;
        let e = (1u32 << 31).wrapping_sub(p) as i32;
        // x·e/2^31 = hi32((4e)·(x/2)): |4e| < 2^25, x/2 < 2^31.
        let corr = (mul_i32_wide(e << 2, (x >> 1) as i32) >> 32) as i32;
        // Newton's iterate stays below 2^63/m ≤ 2^32 but for the truncations of a few units:
        // only the last step can wrap past 2^32 (m within a few units of 2^31), to below 2^30.
        x = x.wrapping_add_signed(corr);
    }
    if x < 1 << 30 { u32::MAX } else { x }
}

/// `floor(a·b / 2^32)` for `|a| < 2^24` and `0 ≤ b < 2^30 + 2^16` (the Newton correction of
/// [`recip_q61`]): `SMMUL` on Armv7E-M; on Armv6-M four 16×16 products summed in 32 bits (the
/// general signed path takes absolute values and a 64-bit negation). Exact under the bounds, so
/// both paths agree (tested over the reciprocal's operands).
#[inline(always)]
pub fn mul_hi_i32_newton(a: i32, b: i32) -> i32 {
    if ARMV6M {
        let (ah, al) = (a >> 16, a & 0xFFFF);
        let (bh, bl) = (b >> 16, b & 0xFFFF);
        // a·b = ah·bh·2^32 + (ah·bl + al·bh)·2^16 + al·bl; |ah·bl| < 2^24, al·bh < 2^30 and
        // al·bl < 2^32: the middle sum with the carry of the low product stays below 2^31.
        let low = ((al as u32) * (bl as u32)) >> 16;
        let mid = ah * bl + al * bh + low as i32;
        ah * bh + (mid >> 16)
    } else {
        mul_hi_i32(a, b)
    }
}

/// `≈ 2^61 / w` for a normalised `2^31 ≤ w < 2^32` (result in `(2^29, 2^30 + 3)`): the 256-entry
/// seed of [`recip_q63`] and two Newton steps in 32-bit arithmetic, each one unsigned and one
/// signed high-word multiply (`UMULL`, `SMMLA` on Armv7E-M). The result is at most 2 above
/// `2^61/w` and 2 below its floor (tested): below 2^31, so it is a positive `i32` in every step
/// and needs no clamp. No division: the RLS kernel's reciprocal of `1 + q`.
#[inline(always)]
pub fn recip_q61(w: u32) -> u32 {
    let idx = ((w >> 23) & 0xFF) as usize;
    // T[i]·2^14 ≈ 2^61/w for w in the i-th interval (< 2^30).
    let mut x = u32::from(RECIP_SEED_U1F15.get(idx).copied().unwrap_or(0x8000)) << 14;
    for _ in 0..2 {
        // w·x/2^32 ≈ 2^29: e = 2^29 − p is the relative error in units of 2^−29, |e| < 2^21
        // after the seed; 8e = −8p mod 2^32 fits an i32.
        let p = mul_hi_u32(w, x);
        let e8 = p.wrapping_mul(8).wrapping_neg() as i32;
        // x += x·e/2^29 = hi32(8e·x); x < 2^31 is a positive i32.
        x = x.wrapping_add_signed(mul_hi_i32_newton(e8, x as i32));
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_equal_the_native_product() {
        let vals = [
            0u32,
            1,
            2,
            0xFFFF,
            0x1_0000,
            0x8000_0000,
            0xFFFF_FFFF,
            0x1234_5678,
            0xDEAD_BEEF,
        ];
        for &a in &vals {
            for &b in &vals {
                assert_eq!(mul_u32_wide_by_halves(a, b), u64::from(a) * u64::from(b));
                assert_eq!(mul_u32_wide(a, b), u64::from(a) * u64::from(b));
                assert_eq!(mul_u32_wide_compact(a, b), u64::from(a) * u64::from(b));
            }
        }
        assert_eq!(mul_i32_wide(i32::MIN, i32::MIN), 1 << 62);
        for &a in &[0i32, 1, -1, i32::MAX, i32::MIN, 12345, -98765, 0x4000_0000] {
            for &b in &[0i32, 1, -1, i32::MAX, i32::MIN, -7, 65536] {
                assert_eq!(
                    mul_i32_wide_by_halves(a, b),
                    i64::from(a) * i64::from(b),
                    "{a} {b}"
                );
                assert_eq!(mul_i32_wide(a, b), i64::from(a) * i64::from(b));
                assert_eq!(mul_i32_wide_compact(a, b), i64::from(a) * i64::from(b));
            }
        }
        for x in [
            0u64,
            1,
            2,
            3,
            0xFF,
            0x100,
            0xFFFF_FFFF,
            0x1_0000_0000,
            u64::MAX,
            1 << 63,
            12345 << 20,
        ] {
            assert_eq!(
                bit_len_u64_by_search(x),
                64 - x.leading_zeros() as i32,
                "{x:#x}"
            );
            assert_eq!(bit_len_u64(x), 64 - x.leading_zeros() as i32);
            let x32 = x as u32;
            assert_eq!(leading_zeros_u32(x32), x32.leading_zeros(), "{x32:#x}");
            assert_eq!(leading_zeros_compact(x32), x32.leading_zeros(), "{x32:#x}");
            for k in 0..32 {
                let y = x32 >> k;
                assert_eq!(leading_zeros_near(y), y.leading_zeros(), "{y:#x}");
            }
            assert_eq!(
                (32 - bit_len_u64_by_search(u64::from(x32))) as u32,
                x32.leading_zeros()
            );
        }
        // The de Bruijn count: every bit length (each smear value has its own index), with
        // every pattern below the leading one.
        let mut seen = [false; 32];
        for k in 1..=32u32 {
            let v = u32::MAX >> (32 - k);
            let idx = (v.wrapping_mul(DE_BRUIJN_LZ) >> 27) as usize;
            assert!(!seen[idx], "k = {k}");
            seen[idx] = true;
        }
        let mut r: u32 = 0x9E37_79B9;
        for k in 0..=32u32 {
            let top = if k == 0 { 0 } else { 1u32 << (k - 1) };
            for _ in 0..1000 {
                r ^= r << 13;
                r ^= r >> 17;
                r ^= r << 5;
                let x = top | (r & top.wrapping_sub(1));
                assert_eq!(leading_zeros_by_de_bruijn(x), x.leading_zeros(), "{x:#x}");
            }
        }
        assert_eq!(leading_zeros_by_de_bruijn(0), 32);
        assert_eq!(leading_zeros_by_de_bruijn(u32::MAX), 0);
        assert_eq!(mul_i32_wide(-3, 5), -15);
        assert_eq!(
            mul_i32_u32_wide(i32::MIN, u32::MAX),
            -(i64::from(u32::MAX) << 31)
        );
    }

    #[test]
    fn split_shift_equals_the_64_bit_one() {
        let xs = [
            0i64,
            1,
            -1,
            2,
            -3,
            (1 << 62),
            -(1 << 62),
            0x0123_4567_89ab_cdef,
            -0x0123_4567_89ab_cdef,
            (1 << 40) + 12345,
            -(1 << 33) - 1,
        ];
        for &x in &xs {
            for s in 1..=62u32 {
                let y = x + (1 << (s - 1));
                assert_eq!(shr_i64_by_halves(y, s), y >> s, "{y} >> {s}");
                assert_eq!(shr_i64(y, s), y >> s, "{y} >> {s}");
            }
        }
    }

    #[test]
    fn reciprocal_u32_is_within_three_units_of_the_floor() {
        let mut m: u32 = 1 << 31;
        let mut worst = 0i64;
        loop {
            let exact = ((1u64 << 63) / u64::from(m)).min(u64::from(u32::MAX)) as i64;
            worst = worst.max((i64::from(recip_u32(m)) - exact).abs());
            match m.checked_add(654_321) {
                Some(next) => m = next,
                None => break,
            }
        }
        for i in 0..256u64 {
            for m in [(256 + i) << 23, ((257 + i) << 23) - 1] {
                let exact = ((1u64 << 63) / m).min(u64::from(u32::MAX)) as i64;
                worst = worst.max((i64::from(recip_u32(m as u32)) - exact).abs());
            }
        }
        assert!(worst <= 3, "{worst}");
    }

    #[test]
    fn reciprocal_is_within_one_unit_of_the_floor() {
        let mut m: u32 = 1 << 31;
        let mut n = 0;
        loop {
            let exact = (1u64 << 63) / u64::from(m);
            let got = recip_q63(m);
            assert!(
                exact - got <= 1 && got <= exact,
                "m = {m:#x}: {got} vs {exact}"
            );
            n += 1;
            match m.checked_add(1_234_567) {
                Some(next) => m = next,
                None => break,
            }
        }
        assert!(n > 1700);
        assert!((1u64 << 63) / u64::from(u32::MAX) - recip_q63(u32::MAX) <= 1);
        // The seed is worst at the ends of its 256 intervals: check both ends of each.
        for i in 0..256u64 {
            for m in [(256 + i) << 23, ((257 + i) << 23) - 1] {
                let m = m as u32;
                let exact = (1u64 << 63) / u64::from(m);
                let got = recip_q63(m);
                assert!(exact - got <= 1 && got <= exact, "m = {m:#x}");
            }
        }
    }

    #[test]
    fn signed_halves_equal_the_native_product() {
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        let edge = [
            0i32,
            1,
            -1,
            0xFFFF,
            -0xFFFF,
            0x1_0000,
            -0x1_0000,
            0x7FFF_FFFF,
            i32::MIN,
            i32::MIN + 1,
            0x8000,
            -0x8000,
        ];
        let check = |a: i32, b: i32| {
            let p = i64::from(a) * i64::from(b);
            assert_eq!(mul_i32_wide_signed_halves(a, b), p, "{a} {b}");
            assert_eq!(mul_i32_wide(a, b), p, "{a} {b}");
            assert_eq!(
                mul_hi_round_i32(a, b),
                ((p + (1 << 31)) >> 32) as i32,
                "{a} {b}"
            );
            let (hi, t, _) = signed_partials(a, b);
            assert_eq!(hi + ((t + 0x8000) >> 16), ((p + (1 << 31)) >> 32) as i32);
        };
        for &a in &edge {
            for &b in &edge {
                check(a, b);
            }
        }
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            check(x as i32, (x >> 32) as i32);
            check((x as i32) >> (x % 31), (x >> 40) as i32);
        }
    }

    #[test]
    fn high_word_by_halves_is_exact() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let edge = [
            0u32,
            1,
            0xFFFF,
            0x1_0000,
            0x8000_0000,
            0xFFFF_FFFF,
            0xFFFF_0001,
        ];
        for &a in &edge {
            for &b in &edge {
                assert_eq!(
                    mul_hi_u32_by_halves(a, b),
                    ((u64::from(a) * u64::from(b)) >> 32) as u32
                );
            }
        }
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (a, b) = (x as u32, (x >> 32) as u32);
            assert_eq!(
                mul_hi_u32_by_halves(a, b),
                ((u64::from(a) * u64::from(b)) >> 32) as u32
            );
            assert_eq!(
                mul_hi_u32(a, b),
                ((u64::from(a) * u64::from(b)) >> 32) as u32
            );
            let (sa, sb) = (a as i32, b as i32);
            assert_eq!(
                mul_hi_i32(sa, sb),
                ((i64::from(sa) * i64::from(sb)) >> 32) as i32
            );
        }
    }

    #[test]
    fn reciprocal_q61_is_within_two_units() {
        let check = |w: u32| {
            // The Newton steps' operands meet mul_hi_i32_newton's bounds (|e8| < 2^24,
            // x < 2^30 + 2^16), where its two paths agree.
            let idx = ((w >> 23) & 0xFF) as usize;
            let mut x = u32::from(RECIP_SEED_U1F15[idx]) << 14;
            for _ in 0..2 {
                let e8 = mul_hi_u32(w, x).wrapping_mul(8).wrapping_neg() as i32;
                assert!(
                    e8.unsigned_abs() < 1 << 24 && x < (1 << 30) + (1 << 16),
                    "{w:#x}"
                );
                let exact = ((i64::from(e8) * i64::from(x)) >> 32) as i32;
                assert_eq!(mul_hi_i32_newton(e8, x as i32), exact);
                x = x.wrapping_add_signed(exact);
            }
            let exact = (1u64 << 61) / u64::from(w);
            let got = u64::from(recip_q61(w));
            assert!(
                got + 2 >= exact && got <= exact + 2,
                "w = {w:#x}: {got} vs {exact}"
            );
            assert!(got < 1 << 31);
        };
        let mut w: u32 = 1 << 31;
        loop {
            check(w);
            match w.checked_add(65_521) {
                Some(next) => w = next,
                None => break,
            }
        }
        for i in 0..256u32 {
            for k in 0..4 {
                check(((256 + i) << 23) + k);
                check(((257 + i) << 23).wrapping_sub(1 + k).max(1 << 31));
            }
        }
        check(u32::MAX);
    }
}
