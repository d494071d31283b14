//! The encoding of the bench image's recorded closed-loop run (`fixtures/pil_trace.bin`, the
//! frames `count_insns.py` feeds the interrupt's body): delta-encoded records of variable
//! length, read in order by a [`Cursor`].
//!
//! The positions of a recording change smoothly: the measured position y (whole encoder quanta)
//! has small second differences, the reference r (a planned trajectory, raw I48F16) piecewise
//! constant second differences, the drive u (raw I16F16) small second differences. Each record
//! is three zigzag LEB128 varints, little-endian groups of 7 bits with the top bit set on all but
//! the last byte, zigzag mapping `v ↦ 2v` (v ≥ 0), `−2v − 1` (v < 0):
//!
//! | varint | value |
//! |---|---|
//! | 1 | Δ²y(k), whole quanta |
//! | 2 | Δ³r(k), raw I48F16 (quanta × 2¹⁶) |
//! | 3 | Δ²u(k), raw I16F16 (full scale × 2¹⁶) |
//!
//! with every value before the first record taken as zero (so the first record carries y(0),
//! r(0) and u(0) themselves). Differences wrap (in `i32` for y and u, in `i64` for r), so
//! [`encode`] and [`Cursor::next`] are exact inverses for every sample the layout holds: y a whole number of quanta in `i32`,
//! |r| < 2⁴⁷ raw, u in `i16` raw (|u| < ½ full scale); [`encode`] refuses any other. The PIL
//! trace (power-on calibration and 3 seeks of the twin, u = 0) takes ≈ 3 bytes per record
//! instead of 12.
//!
//! The bench steps one record per call, in order: decoding is one [`Cursor::next`]
//! (≈ 3 varints and a few additions).

use sledid::{PositionI48F16, Sample, SignalI16F16};

/// Fraction bits of a [`PositionI48F16`] (y is stored in whole quanta).
const POSITION_FRAC_BITS: u32 = 16;

/// Largest |r| raw the layout holds (exclusive): 2⁴⁷.
const R_LIMIT: i64 = 1 << 47;

/// Longest varint of an `i64` (⌈64 / 7⌉ bytes).
const VARINT_MAX_BYTES: usize = 10;

/// The decoding state: the read position, and the values and differences of the last record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Cursor {
    /// Byte offset of the next record.
    at: usize,
    /// Records decoded so far.
    index: usize,
    /// y(k−1), Δy(k−1), whole quanta (differences wrap in `i32`).
    y: [i32; 2],
    /// r(k−1), Δr(k−1), Δ²r(k−1), raw I48F16 (differences wrap in `i64`).
    r: [i64; 3],
    /// u(k−1), Δu(k−1), raw I16F16 (differences wrap in `i32`).
    u: [i32; 2],
}

/// The zigzag LEB128 varint at `bytes[*at..]`; advances `at`. `None` if it is cut off or longer
/// than [`VARINT_MAX_BYTES`]. One-byte varints (|v| < 64, most of a smooth recording's
/// differences) take the short path.
#[inline(always)]
fn varint(bytes: &[u8], at: &mut usize) -> Option<i64> {
    let b = *bytes.get(*at)?;
    *at += 1;
    let z = if b & 0x80 == 0 {
        u64::from(b)
    } else {
        varint_tail(bytes, at, u64::from(b & 0x7f))?
    };
    Some((z >> 1) as i64 ^ -((z & 1) as i64))
}

/// The bytes after the first of a longer varint: `z` holds the first 7 bits.
#[inline(never)]
fn varint_tail(bytes: &[u8], at: &mut usize, mut z: u64) -> Option<u64> {
    for k in 1..VARINT_MAX_BYTES {
        let b = *bytes.get(*at)?;
        *at += 1;
        // k ≤ 9: the shift is at most 63 (the tenth byte's high bits fall off).
        z |= u64::from(b & 0x7f) << (7 * k);
        if b & 0x80 == 0 {
            return Some(z);
        }
    }
    None
}

/// Appends the zigzag LEB128 varint of `v` to `out`.
fn put_varint(v: i64, out: &mut impl FnMut(u8)) {
    let mut z = ((v << 1) ^ (v >> 63)) as u64;
    while z >= 0x80 {
        out((z as u8) | 0x80);
        z >>= 7;
    }
    out(z as u8);
}

impl Cursor {
    /// At the first record.
    pub const fn new() -> Self {
        Self {
            at: 0,
            index: 0,
            y: [0; 2],
            r: [0; 3],
            u: [0; 2],
        }
    }

    /// Records decoded so far: the index of the next one.
    #[allow(dead_code)] // not by the host build of the firmware binary
    pub fn index(&self) -> usize {
        self.index
    }

    /// The next record of `bytes`, `None` at its end or on a record that is cut off, malformed
    /// or outside the layout (the cursor then stays where it was). Never panics.
    pub fn next(&mut self, bytes: &[u8]) -> Option<Sample> {
        let mut at = self.at;
        // Δ²y and Δ²u wrap in i32 (as `encode` computes them), Δ³r in i64.
        let ddy = varint(bytes, &mut at)? as i32;
        let dddr = varint(bytes, &mut at)?;
        let ddu = varint(bytes, &mut at)? as i32;
        let dy = self.y[1].wrapping_add(ddy);
        let y = self.y[0].wrapping_add(dy);
        let ddr = self.r[2].wrapping_add(dddr);
        let dr = self.r[1].wrapping_add(ddr);
        let r = self.r[0].wrapping_add(dr);
        let du = self.u[1].wrapping_add(ddu);
        let u = self.u[0].wrapping_add(du);
        let u_raw = i16::try_from(u).ok()?;
        if !(-R_LIMIT..R_LIMIT).contains(&r) {
            return None;
        }
        *self = Self {
            at,
            index: self.index.saturating_add(1),
            y: [y, dy],
            r: [r, dr, ddr],
            u: [u, du],
        };
        Some(Sample {
            y: PositionI48F16::from_raw(i64::from(y) << POSITION_FRAC_BITS),
            u: SignalI16F16::from_raw(i32::from(u_raw)),
            r: PositionI48F16::from_raw(r),
        })
    }
}

/// Encodes `samples` into `out`, byte by byte (the inverse of [`Cursor::next`]); `None` when a
/// sample does not fit the layout (module doc), after the bytes of the samples before it. Used
/// by the host test that writes and checks the fixture, not by the firmware.
#[allow(dead_code)]
pub fn encode<'a>(
    samples: impl IntoIterator<Item = &'a Sample>,
    mut out: impl FnMut(u8),
) -> Option<()> {
    let (mut y, mut r, mut u) = ([0i32; 2], [0i64; 3], [0i32; 2]);
    for s in samples {
        let y_raw = s.y.raw();
        if y_raw & ((1 << POSITION_FRAC_BITS) - 1) != 0 {
            return None;
        }
        let y_now = i32::try_from(y_raw >> POSITION_FRAC_BITS).ok()?;
        let r_now = s.r.raw();
        if !(-R_LIMIT..R_LIMIT).contains(&r_now) {
            return None;
        }
        let u_now = i32::from(i16::try_from(s.u.raw()).ok()?);
        let dy = y_now.wrapping_sub(y[0]);
        let dr = r_now.wrapping_sub(r[0]);
        let ddr = dr.wrapping_sub(r[1]);
        let du = u_now.wrapping_sub(u[0]);
        put_varint(i64::from(dy.wrapping_sub(y[1])), &mut out);
        put_varint(ddr.wrapping_sub(r[2]), &mut out);
        put_varint(i64::from(du.wrapping_sub(u[1])), &mut out);
        (y, r, u) = ([y_now, dy], [r_now, dr, ddr], [u_now, du]);
    }
    Some(())
}
