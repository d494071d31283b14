//! Configuration words: a validated, quantised configuration as a flat array of `u32`, so that a
//! target can take a configuration computed on the host instead of building it from its `f64`
//! design (the `…Design::build` functions pull soft-float `f64` arithmetic into an image for a
//! core without a double-precision FPU, and their temporaries are the deepest stack frame of a
//! firmware's start-up).
//!
//! The host writes the words from the built configuration (`to_words`/`put`), the target reads
//! them back (`from_words`/`take`) with integer checks only: every field must be a valid value of
//! its type, and every invariant the per-sample code relies on (the checks of the matching
//! `build`, where they are not about floats) is checked again. A word that fails gives
//! [`ConfigError::Words`] with its index; decoding never panics. Tested here (primitives), in
//! `host-tests/tests/sled_loop.rs` (a design with every optional part round-trips) and in
//! `host-tests/tests/firmware_qemu.rs` (the firmware's words are up to date; truncated, extended
//! and corrupted words are refused, never with a panic).
//!
//! The RLS settings are the one exception: [`crate::ident::rls::RlsConfig`] has no raw constructor, so
//! the words carry the [`RlsDesign`] (its `f64` fields as bits) and `take` builds it
//! ([`RlsDesign::build`], comparisons and a few conversions: no `f64` division).
//!
//! # Encoding
//! | field | words |
//! |---|---|
//! | `u32`, `i32` (two's complement), `u16`, `u8`, `usize` (< 2³²), I12F20/I16F16 raw | 1 |
//! | `bool` | 1: 0 or 1 |
//! | `i64`, `f64` (IEEE-754 bits) | 2, low word first |
//! | `[T; N]` | N × T |
//! | `Option<T>` | 1 (0 `None`, 1 `Some`), then T if `Some` |
//! | enum | 1 (the variant's index, in declaration order), then the variant's fields |
//! | struct | its fields in declaration order (each type's `Words` impl lists them) |

use crate::error::ConfigError;
use crate::ident::rls::{AntiWindup, RlsDesign};
use crate::num::fixed::{ParamI12F20, SignalI16F16};

/// Writes configuration words into a caller's buffer.
#[derive(Debug)]
pub struct WordWriter<'a> {
    out: &'a mut [u32],
    len: usize,
}

impl<'a> WordWriter<'a> {
    /// A writer at the start of `out`.
    pub fn new(out: &'a mut [u32]) -> Self {
        Self { out, len: 0 }
    }

    /// Appends one word.
    ///
    /// # Errors
    /// [`ConfigError::Words`] (at the buffer's length) when the buffer is full.
    pub fn word(&mut self, w: u32) -> Result<(), ConfigError> {
        let slot = self
            .out
            .get_mut(self.len)
            .ok_or(ConfigError::Words { at: self.len })?;
        *slot = w;
        self.len += 1;
        Ok(())
    }

    /// Words written so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Nothing written yet.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Reads configuration words. A word that is missing or fails a check is remembered (the first
/// one) rather than returned at once: the readers of the `Words` impls are straight-line code
/// (small on target), and [`Self::finish`] reports the error at the end.
#[derive(Debug)]
pub struct WordReader<'a> {
    words: &'a [u32],
    at: usize,
    error: Option<usize>,
}

impl<'a> WordReader<'a> {
    /// A reader at the start of `words`.
    pub fn new(words: &'a [u32]) -> Self {
        Self {
            words,
            at: 0,
            error: None,
        }
    }

    /// The next word; 0 past the end (and the error is remembered).
    #[inline(never)]
    pub fn word(&mut self) -> u32 {
        let w = match self.words.get(self.at) {
            Some(&w) => w,
            None => {
                self.latch(self.at);
                0
            }
        };
        self.at = self.at.saturating_add(1);
        w
    }

    /// Remembers a failure at word `at` unless an earlier one is remembered already.
    fn latch(&mut self, at: usize) {
        if self.error.is_none() {
            self.error = Some(at);
        }
    }

    /// Marks the word read last as bad (the field that failed its check).
    pub fn fail(&mut self) {
        self.latch(self.at.saturating_sub(1));
    }

    /// Marks the word read last as bad unless `ok`.
    #[inline(never)]
    pub fn check(&mut self, ok: bool) {
        if !ok {
            self.fail();
        }
    }

    /// `Err` with the first bad word so far, if any.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first bad word.
    pub fn status(&self) -> Result<(), ConfigError> {
        match self.error {
            Some(at) => Err(ConfigError::Words { at }),
            None => Ok(()),
        }
    }

    /// Ends the reading: no bad word, and every word consumed.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first bad word, else at the first word left over.
    pub fn finish(self) -> Result<(), ConfigError> {
        self.status()?;
        if self.at == self.words.len() {
            Ok(())
        } else {
            Err(ConfigError::Words { at: self.at })
        }
    }
}

/// A type with a configuration-word encoding (module doc).
pub trait Words: Sized {
    /// Appends `self`'s words.
    ///
    /// # Errors
    /// [`ConfigError::Words`] when the buffer is full or a value has no encoding (a `usize` of
    /// 2³² or more).
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError>;

    /// Reads a value and checks it. On a word that is missing, invalid or fails a check, the
    /// reader remembers it and the value returned is a placeholder, to be discarded: only a
    /// reader whose [`WordReader::status`] is `Ok` returns valid values.
    fn take(r: &mut WordReader<'_>) -> Self;
}

impl Words for u32 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(*self)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        r.word()
    }
}

impl Words for i32 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(*self as u32)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        r.word() as i32
    }
}

impl Words for u16 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(u32::from(*self))
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let v = r.word();
        r.check(v <= u32::from(u16::MAX));
        v as u16
    }
}

impl Words for u8 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(u32::from(*self))
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let v = r.word();
        r.check(v <= u32::from(u8::MAX));
        v as u8
    }
}

impl Words for usize {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        let v = u32::try_from(*self).map_err(|_| ConfigError::Words { at: w.len() })?;
        w.word(v)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let v = r.word();
        // A 16-bit usize cannot hold every u32: such a value is refused.
        Self::try_from(v).unwrap_or_else(|_| {
            r.fail();
            0
        })
    }
}

impl Words for bool {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(u32::from(*self))
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let v = r.word();
        r.check(v <= 1);
        v == 1
    }
}

impl Words for u64 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(*self as u32)?;
        w.word((*self >> 32) as u32)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let lo = r.word();
        let hi = r.word();
        u64::from(lo) | (u64::from(hi) << 32)
    }
}

impl Words for i64 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        (*self as u64).put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        u64::take(r) as i64
    }
}

impl Words for f64 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.to_bits().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        f64::from_bits(u64::take(r))
    }
}

impl Words for ParamI12F20 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.raw().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self::from_raw(i32::take(r))
    }
}

impl Words for SignalI16F16 {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.raw().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self::from_raw(i32::take(r))
    }
}

impl<T: Words + Copy + Default, const N: usize> Words for [T; N] {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.iter().try_for_each(|t| t.put(w))
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let mut out = [T::default(); N];
        for t in &mut out {
            *t = T::take(r);
        }
        out
    }
}

impl<T: Words> Words for Option<T> {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        match self {
            None => w.word(0),
            Some(t) => {
                w.word(1)?;
                t.put(w)
            }
        }
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        bool::take(r).then(|| T::take(r))
    }
}

impl Words for AntiWindup {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        match *self {
            Self::None => w.word(0),
            Self::TraceLimit { max } => {
                w.word(1)?;
                max.put(w)
            }
            Self::DiagonalLimit { max } => {
                w.word(2)?;
                max.put(w)
            }
            Self::ConstantTrace { trace } => {
                w.word(3)?;
                trace.put(w)
            }
        }
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        match r.word() {
            0 => Self::None,
            1 => Self::TraceLimit { max: f64::take(r) },
            2 => Self::DiagonalLimit { max: f64::take(r) },
            3 => Self::ConstantTrace {
                trace: f64::take(r),
            },
            _ => {
                r.fail();
                Self::None
            }
        }
    }
}

/// The design itself (validated when it is built: see the module doc).
impl Words for RlsDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.lambda.put(w)?;
        self.p0.put(w)?;
        self.dead_zone.put(w)?;
        self.excitation_threshold.put(w)?;
        self.anti_windup.put(w)?;
        self.outlier_threshold.put(w)?;
        self.outlier_limit.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            lambda: f64::take(r),
            p0: f64::take(r),
            dead_zone: f64::take(r),
            excitation_threshold: f64::take(r),
            anti_windup: AntiWindup::take(r),
            outlier_threshold: f64::take(r),
            outlier_limit: u16::take(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<T: Words + PartialEq + core::fmt::Debug>(v: T, words: usize) {
        let mut buf = [0u32; 16];
        let mut w = WordWriter::new(&mut buf);
        v.put(&mut w).unwrap();
        assert_eq!(w.len(), words);
        let mut r = WordReader::new(&buf[..words]);
        assert_eq!(T::take(&mut r), v);
        r.finish().unwrap();
        // One word short fails at the missing word.
        let mut r = WordReader::new(&buf[..words - 1]);
        T::take(&mut r);
        assert_eq!(r.finish(), Err(ConfigError::Words { at: words - 1 }));
    }

    #[test]
    fn primitives_round_trip() {
        round_trip(u32::MAX, 1);
        round_trip(i32::MIN, 1);
        round_trip(u16::MAX, 1);
        round_trip(true, 1);
        round_trip(i64::MIN + 3, 2);
        round_trip(-0.995f64, 2);
        round_trip(Some([ParamI12F20::from_raw(-7), ParamI12F20::MAX]), 3);
        round_trip(AntiWindup::TraceLimit { max: 100.0 }, 3);
        round_trip(
            RlsDesign {
                anti_windup: AntiWindup::ConstantTrace { trace: 2.5 },
                ..RlsDesign::default()
            },
            14,
        );
    }

    fn first_bad<T: Words>(words: &[u32]) -> Result<(), ConfigError> {
        let mut r = WordReader::new(words);
        T::take(&mut r);
        r.finish()
    }

    #[test]
    fn invalid_values_are_refused() {
        let at = |at| Err(ConfigError::Words { at });
        assert_eq!(first_bad::<bool>(&[2]), at(0));
        assert_eq!(first_bad::<u16>(&[1 << 16]), at(0));
        assert_eq!(first_bad::<u8>(&[256]), at(0));
        assert_eq!(first_bad::<Option<u32>>(&[7, 1]), at(0));
        assert_eq!(first_bad::<AntiWindup>(&[4]), at(0));
        // The first bad word is the one reported.
        assert_eq!(first_bad::<[bool; 3]>(&[1, 3, 5]), at(1));
        // Left-over words.
        assert_eq!(first_bad::<u32>(&[1, 2]), at(1));
        // A full buffer.
        let mut buf = [0u32; 1];
        let mut w = WordWriter::new(&mut buf);
        assert_eq!(3i64.put(&mut w), Err(ConfigError::Words { at: 1 }));
    }
}
