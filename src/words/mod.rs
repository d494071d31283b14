//! Configuration words: a validated, quantised configuration as a flat array of `u32`, so that a
//! target can take a configuration computed on the host instead of building it from its `f64`
//! design (the `…Design::build` functions pull soft-float `f64` arithmetic into an image for a
//! core without a double-precision FPU, and their temporaries are the deepest stack frame of a
//! firmware's start-up).
//!
//! # Frame
//! ```text
//! [WORDS_VERSION, payload length n, payload (n words), CRC-32 of the n + 2 words before it]
//! ```
//! [`seal`] writes the frame around a payload, [`open`] checks version, length and CRC-32
//! ([`crc32`]) before anything is decoded: a configuration corrupted in flash or in transfer —
//! every single-bit error among them — is refused as a whole.
//!
//! # Validation: one copy
//! The host writes the words from the built configuration (`to_words`/`put`); the target reads
//! them back (`from_words`/`take`). `take` checks only the encoding (a `bool` is 0 or 1, an enum's
//! index names a variant); the configuration's invariants are then checked by the same
//! `validate` its `…Design::build` runs after quantising, so the target refuses exactly what the
//! host's build would have refused, with the same [`ConfigError`] naming the parameter. An
//! encoding error gives [`ConfigError::Words`] with the word's index in the frame; decoding never
//! panics. Tested here (primitives), in `host-tests/tests/integration/sled_loop.rs` (a design with every
//! optional part round-trips) and in `host-tests/tests/integration/firmware_qemu.rs` (the firmware's words are
//! up to date; every truncation, extension and single-bit flip is refused; re-sealed invalid
//! values are refused by the build's checks; never a panic).
//!
//! The RLS settings carry the quantised [`crate::ident::rls::RlsConfig`] (λ, p₀ and the limits as
//! mantissa and exponent), checked by its `validate`: no `f64` on target for them.
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

pub mod crc32;

use crc32::crc32_words;

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

/// The format of the configuration words, first word of every frame: `"SLW"` and the format
/// revision (3: version, length and CRC-32 framing; the latch-free controller configuration).
pub const WORDS_VERSION: u32 = 0x534C_5703;

/// Words of a frame beyond its payload: version, payload length, CRC-32.
pub const FRAME_OVERHEAD: usize = 3;

/// Frames a payload written at `out[2..2 + payload_len]`: version, length, payload, then the
/// CRC-32 of everything before it. Returns the frame's length.
///
/// # Errors
/// [`ConfigError::Words`] when `out` cannot hold the frame.
pub fn seal(out: &mut [u32], payload_len: usize) -> Result<usize, ConfigError> {
    let total = payload_len + FRAME_OVERHEAD;
    let len_word = u32::try_from(payload_len).map_err(|_| ConfigError::Words { at: 1 })?;
    let Some(frame) = out.get_mut(..total) else {
        return Err(ConfigError::Words { at: out.len() });
    };
    if let [version, len, ..] = frame {
        *version = WORDS_VERSION;
        *len = len_word;
    }
    let (body, crc) = frame.split_at_mut(total - 1);
    if let Some(c) = crc.first_mut() {
        *c = crc32_words(body);
    }
    Ok(total)
}

/// `e` with a payload index turned into an index into its frame (the payload follows the
/// version and length words); other errors as they are.
pub fn in_frame(e: ConfigError) -> ConfigError {
    match e {
        ConfigError::Words { at } => ConfigError::Words { at: at + 2 },
        e => e,
    }
}

/// `value`'s words as a sealed frame in `out` ([`seal`]); returns the frame's length.
///
/// # Errors
/// [`ConfigError::Words`] when `out` cannot hold the frame, or `value`'s own `put` error.
pub fn put_frame<T: Words>(value: &T, out: &mut [u32]) -> Result<usize, ConfigError> {
    let len = out.len();
    let payload = out.get_mut(2..).ok_or(ConfigError::Words { at: len })?;
    let mut w = WordWriter::new(payload);
    value.put(&mut w).map_err(in_frame)?;
    let payload_len = w.len();
    seal(out, payload_len)
}

/// A frame of [`put_frame`] decoded: [`open`], `T::take`, every word consumed. The value's own
/// invariants are the caller's to check (its `validate`).
///
/// # Errors
/// [`open`]'s errors, or [`ConfigError::Words`] at the first bad or left-over word (an index into
/// the frame).
pub fn take_frame<T: Words>(words: &[u32]) -> Result<T, ConfigError> {
    let payload = open(words)?;
    let mut r = WordReader::new(payload);
    let value = T::take(&mut r);
    r.finish().map_err(in_frame)?;
    Ok(value)
}

/// The payload of a frame written by [`seal`], after checking its version, its length and its
/// CRC-32 (every single-bit error, and every burst of up to 32 bits, is caught).
///
/// # Errors
/// [`ConfigError::WordsVersion`] for another format, [`ConfigError::Words`] at the length word
/// when the frame is shorter or longer than it says, [`ConfigError::WordsChecksum`] when the CRC
/// does not match.
pub fn open(words: &[u32]) -> Result<&[u32], ConfigError> {
    let version = words.first().copied().unwrap_or(0);
    if version != WORDS_VERSION {
        return Err(ConfigError::WordsVersion(version));
    }
    let payload_len = words.get(1).copied().ok_or(ConfigError::Words { at: 1 })? as usize;
    if payload_len.checked_add(FRAME_OVERHEAD) != Some(words.len()) {
        return Err(ConfigError::Words { at: 1 });
    }
    let (body, crc) = words.split_at(words.len() - 1);
    if crc.first().copied() != Some(crc32_words(body)) {
        return Err(ConfigError::WordsChecksum);
    }
    Ok(body.get(2..).unwrap_or(&[]))
}

/// A type with a configuration-word encoding (module doc).
pub trait Words: Sized {
    /// Appends `self`'s words.
    ///
    /// # Errors
    /// [`ConfigError::Words`] when the buffer is full or a value has no encoding (a `usize` of
    /// 2³² or more).
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError>;

    /// Reads a value. Only the encoding is checked here (a `bool` is 0 or 1, an enum's index
    /// names a variant, a `u16` fits): the configuration's own invariants are checked once the
    /// whole configuration is read, by the same `validate` its `build` runs. On a word that is
    /// missing or invalid the reader remembers it and the value returned is a placeholder, to be
    /// discarded: only a reader whose [`WordReader::status`] is `Ok` returns valid values.
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
        round_trip(Some([-7i32, i32::MAX]), 3);
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
