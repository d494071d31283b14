//! The one definition the firmware (`src/bin/firmware.rs`) and its host replay
//! (`host-tests/tests/firmware_qemu.rs`) share, so they cannot drift: the identifier design, the
//! layout of the embedded recording (`fixtures/emps_excerpt.bin`), the per-sample run with its
//! output checksum, and the result line the firmware prints.
//!
//! Both include this file with `#[path = …] mod fw_config;` (it is not a library module: it is
//! the firmware's configuration, not part of the identification library). It lives in a
//! sub-directory of `src/bin` so that cargo does not take it for a binary of its own.
//!
//! # Fixture layout
//! [`FIXTURE_SAMPLES`] records of [`RECORD_BYTES`] bytes, little-endian, no header:
//!
//! | bytes | field | format |
//! |---|---|---|
//! | 0..4 | y, measured position | whole quanta, `i32` (the encoder's positions are on its grid) |
//! | 4..10 | r, reference position | [`PositionI48F16`] raw, 48-bit two's complement (quanta × 2¹⁶) |
//! | 10..12 | u, drive | [`SignalI16F16`] raw, `i16` (fraction of [`U_FULL_SCALE_V`] × 2¹⁶, so \|u\| < 5 V) |
//!
//! 12 bytes instead of the 20 of the in-memory `Sample` (`i64`, `i64`, `i32`): [`encode`] refuses a
//! sample that does not fit (y off the grid, r beyond ±2⁴⁷ raw, \|u\| ≥ 5 V), so [`decode`] returns
//! exactly the sample that was encoded.
//!
//! # Checksum
//! FNV-1a 64 (offset basis `0xcbf29ce484222325`, prime `0x100000001b3`) over, for every sample in
//! order, the little-endian bytes of the [`StepOutput`] fields: y, u, ŷ, ε (`i32` raw each), θ
//! (`N` × `i32` raw) and the status bits (`u16`): 34 bytes per sample for N = 4.

use core::fmt;

use sledid::conditioning::Conditioning;
use sledid::error::ConfigError;
use sledid::linear::{LinearDesign, Structure};
use sledid::rls::{AntiWindup, RlsDesign};
use sledid::step::{IdentifierConfig, IdentifierDesign, IdentifierState, StepOutput};
use sledid::{PositionI48F16, Sample, SignalI16F16};

/// Number of parameters: ARX(na = 2, nb = 2), θ = [a₁, a₂, b₁, b₂].
pub const N: usize = 4;

/// The sled's sample period (Ts = 0.455 ms), ns: the firmware's SysTick period. The EMPS excerpt
/// was recorded at 1 ms; the firmware replays it one record per sled sample period.
pub const SAMPLE_PERIOD_NS: u32 = 455_000;

/// Sensor quantum of the EMPS encoder, m (one [`PositionI48F16`] unit).
pub const QUANTUM_M: f64 = 5e-8;

/// Full-scale drive, V (one [`SignalI16F16`] unit of u).
pub const U_FULL_SCALE_V: f64 = 10.0;

/// Records in the fixture: the first 640 rows of `DATA_EMPS.csv` (sized so that the firmware image,
/// fixture included, fits the 32 KiB flash budget; see `BENCHMARKS.md`).
pub const FIXTURE_SAMPLES: usize = 640;

/// Bytes per fixture record: y (`i32` quanta), r (48-bit raw), u (`i16` raw), little-endian.
pub const RECORD_BYTES: usize = 12;

/// What starts the firmware's result line (followed by a space and the [`Summary`]).
pub const RESULT_PREFIX: &str = "sledid-fw result:";

/// The identifier the firmware runs: increments (Δy, Δu) of the EMPS excerpt, ARX(2, 2), nk = 1,
/// λ = 0.995, P₀ = 100·I, trace(P) ≤ 100, a dead zone of ¼ quantum on |ε|, denominator kept in
/// |z| ≤ 1.
pub fn design() -> IdentifierDesign<N> {
    let mut model = LinearDesign::<N>::new(Structure::Arx, 2, 2);
    model.rls = RlsDesign {
        lambda: 0.995,
        p0: 100.0,
        dead_zone: 0.25,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    };
    IdentifierDesign::new(Conditioning::Differenced, model)
}

/// Fraction bits of a [`PositionI48F16`] (y is stored in whole quanta).
const POSITION_FRAC_BITS: u32 = 16;

/// Decodes one record (the first [`RECORD_BYTES`] bytes of `bytes`); `None` if it is shorter.
pub fn decode(bytes: &[u8]) -> Option<Sample> {
    let (y, rest) = bytes.split_first_chunk::<4>()?;
    let (r, rest) = rest.split_first_chunk::<6>()?;
    let (u, _) = rest.split_first_chunk::<2>()?;
    // r: sign-extend the 48-bit field (placed in the top of an i64, shifted back arithmetically).
    let mut r8 = [0u8; 8];
    if let Some(top) = r8.get_mut(2..) {
        top.copy_from_slice(r);
    }
    Some(Sample {
        y: PositionI48F16::from_raw(i64::from(i32::from_le_bytes(*y)) << POSITION_FRAC_BITS),
        u: SignalI16F16::from_raw(i32::from(i16::from_le_bytes(*u))),
        r: PositionI48F16::from_raw(i64::from_le_bytes(r8) >> 16),
    })
}

/// Encodes one record (the inverse of [`decode`]); `None` when the sample does not fit the layout
/// (module doc). Used by the host test that writes and checks the fixture, not by the firmware.
#[allow(dead_code)]
pub fn encode(sample: &Sample) -> Option<[u8; RECORD_BYTES]> {
    let y_raw = sample.y.raw();
    if y_raw & ((1 << POSITION_FRAC_BITS) - 1) != 0 {
        return None;
    }
    let y = i32::try_from(y_raw >> POSITION_FRAC_BITS).ok()?;
    let r_raw = sample.r.raw();
    if !(-(1i64 << 47)..1i64 << 47).contains(&r_raw) {
        return None;
    }
    let u = i16::try_from(sample.u.raw()).ok()?;
    let mut out = [0u8; RECORD_BYTES];
    let fields = y
        .to_le_bytes()
        .into_iter()
        .chain(r_raw.to_le_bytes().into_iter().take(6))
        .chain(u.to_le_bytes());
    for (dst, b) in out.iter_mut().zip(fields) {
        *dst = b;
    }
    Some(out)
}

/// Record `index` of a fixture (constant time); `None` past its end.
pub fn record(fixture: &[u8], index: usize) -> Option<Sample> {
    let start = index.checked_mul(RECORD_BYTES)?;
    decode(fixture.get(start..)?)
}

/// FNV-1a, 64 bits, over a byte stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a64(u64);

impl Fnv1a64 {
    /// The FNV-1a 64 offset basis.
    const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    /// The FNV-1a 64 prime.
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    /// The hash of nothing.
    pub const fn new() -> Self {
        Self(Self::OFFSET_BASIS)
    }

    /// Folds `bytes` in.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = Self::mul_prime(self.0 ^ u64::from(b));
        }
    }

    /// `h · PRIME mod 2⁶⁴` with 32-bit multiplies only: PRIME = 2⁴⁰ + 0x1b3, and every partial
    /// product of a 16-bit limb by 0x1b3 fits in 25 bits. Cortex-M0 has no 32×32→64 multiply, so
    /// the plain `wrapping_mul` costs a `__aeabi_lmul` call per byte (≈ 60 cycles).
    #[inline(always)]
    fn mul_prime(h: u64) -> u64 {
        const LOW: u32 = (Fnv1a64::PRIME & 0xffff_ffff) as u32;
        const _: () = assert!(Fnv1a64::PRIME == (1 << 40) + LOW as u64 && LOW < 1 << 16);
        let lo = h as u32;
        let hi = (h >> 32) as u32;
        let lo_lo = u64::from((lo & 0xffff) * LOW); // < 2^32: 16 × 9 bits
        let lo_hi = u64::from((lo >> 16) * LOW) << 16; // < 2^48
        let hi_part = u64::from(hi.wrapping_mul(LOW)) << 32; // only its low 32 bits survive
        (h << 40)
            .wrapping_add(hi_part)
            .wrapping_add(lo_hi)
            .wrapping_add(lo_lo)
    }

    /// Folds in one step's outputs (see the module doc for the byte order).
    pub fn write_output(&mut self, out: &StepOutput<N>) {
        for raw in [out.y.raw(), out.u.raw(), out.y_hat.raw(), out.eps.raw()] {
            self.write(&raw.to_le_bytes());
        }
        for t in &out.theta {
            self.write(&t.raw().to_le_bytes());
        }
        self.write(&out.status.bits().to_le_bytes());
    }

    /// The hash so far.
    pub const fn value(self) -> u64 {
        self.0
    }
}

impl Default for Fnv1a64 {
    fn default() -> Self {
        Self::new()
    }
}

/// One replay of the identifier: configuration, state, and the checksum of everything it produced.
/// The firmware's SysTick handler and the host replay both step this, one sample at a time.
#[derive(Clone, Debug)]
pub struct Run {
    /// The validated configuration of [`design`].
    pub(crate) config: IdentifierConfig<N>,
    /// The identifier's state.
    pub(crate) state: IdentifierState<N>,
    checksum: Fnv1a64,
    samples: u32,
    updates: u32,
}

impl Run {
    /// A fresh run of [`design`].
    ///
    /// # Errors
    /// The design's [`ConfigError`] (none for the committed design; the tests build it).
    pub fn new() -> Result<Self, ConfigError> {
        let config = design().build()?;
        Ok(Self {
            state: config.new_state(),
            config,
            checksum: Fnv1a64::new(),
            samples: 0,
            updates: 0,
        })
    }

    /// One sample through [`sledid::step::step`], folded into the checksum. Never panics.
    #[inline(never)]
    pub fn step(&mut self, sample: &Sample) -> StepOutput<N> {
        let out = identify(&self.config, &mut self.state, sample);
        self.checksum.write_output(&out);
        self.samples = self.samples.wrapping_add(1);
        if out.status.contains(sledid::Status::UPDATED) {
            self.updates = self.updates.wrapping_add(1);
        }
        out
    }

    /// What the run has produced so far.
    pub fn summary(&self) -> Summary {
        let mut theta_raw = [0i32; N];
        for (dst, t) in theta_raw.iter_mut().zip(self.state.model().theta()) {
            *dst = t.raw();
        }
        Summary {
            samples: self.samples,
            updates: self.updates,
            checksum: self.checksum.value(),
            theta_raw,
        }
    }
}

/// The per-sample step alone ([`sledid::step::step`] on this design's `N`), kept out of line so
/// that it exists once in the image and `count_insns.py` can measure it apart from the checksum.
#[inline(never)]
pub fn identify(
    config: &IdentifierConfig<N>,
    state: &mut IdentifierState<N>,
    sample: &Sample,
) -> StepOutput<N> {
    sledid::step::step(config, state, sample)
}

/// The outcome of a run: what the firmware prints and the host test compares, field by field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Summary {
    /// Samples stepped.
    pub samples: u32,
    /// Samples on which θ and P were updated.
    pub updates: u32,
    /// FNV-1a 64 of every output (module doc).
    pub checksum: u64,
    /// Final θ = [a₁, a₂, b₁, b₂], raw I12F20.
    pub theta_raw: [i32; N],
}

impl fmt::Display for Summary {
    /// `samples=… updates=… checksum=0x…(16 hex digits) theta=[a1,a2,b1,b2]` (raw I12F20).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "samples={} updates={} checksum={:#018x} theta=[",
            self.samples, self.updates, self.checksum
        )?;
        for (k, t) in self.theta_raw.iter().enumerate() {
            if k > 0 {
                f.write_str(",")?;
            }
            write!(f, "{t}")?;
        }
        f.write_str("]")
    }
}
