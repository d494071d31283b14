//! The one definition the firmware (`src/bin/firmware.rs`) and its host replay
//! (`host-tests/tests/firmware_qemu.rs`) share, so they cannot drift: the loop design (controller,
//! identifiers), the layout of the embedded recording (`fixtures/emps_excerpt.bin`), the
//! per-sample run with its output checksum, the redesign rule, and the result line the firmware
//! prints.
//!
//! Both include this file with `#[path = …] mod fw_config;` (it is not a library module: it is
//! the firmware's configuration, not part of the identification library). It lives in a
//! sub-directory of `src/bin` so that cargo does not take it for a binary of its own.
//!
//! # The step: the whole loop in shadow mode
//! Each record goes through [`sledid::servo::SledServo::step_shadow`]`(r, y, u_recorded)`:
//! the gain-scheduled controller (with its supervisor) computes its drive beside the rig's own
//! controller (returned and checksummed, not applied: QEMU has no plant), and its ARX(1,1)
//! velocity identifier learns from the recorded drive, the one that explains y. This is the
//! servo's whole step (controller + ARX estimator + supervisor); the paper's Wiener model is not
//! in the interrupt (nothing in the loop reads it: `sledid::servo`).
//!
//! The firmware used to run an EMPS ARX(2,2) identifier on increments; it is folded into the
//! loop, not kept beside it: the loop's ARX(1,1) velocity identifier is the ARX estimator of the
//! budget line, and a second ARX instance (RLS at N = 4, a third monomorphised kernel of ≈ 5 KB)
//! would add flash to an image already above the 32 KiB budget and ≈ 4,500 cycles per sample on
//! M4F to a step already above its cycle budget (`BENCHMARKS.md`).
//!
//! # Redesign rule (deterministic)
//! The slow-rate gain redesign (f32) is not in the interrupt, and the interrupt never waits for
//! it: a redesign requested by sample k is posted as a job ([`sledid::servo::handover`]), the
//! main loop computes it, and the step of sample k + L adopts it — or, not delivered in time,
//! keeps the old gains and flags `HANDOVER_MISSED`. [`replay`], the host's run of the same rule,
//! computes every job between two samples, so the two agree whenever the firmware meets L.
//!
//! # Units and constants (EMPS rig, `shared/data` README)
//! Positions in encoder quanta ([`QUANTUM_M`]), u as a fraction of [`U_FULL_SCALE_V`], the
//! recording's sample period [`EMPS_TS_S`] = 1 ms (the controller's and the models' time unit;
//! the firmware replays one record per sled period, [`SAMPLE_PERIOD_NS`]). Baseline: the rig's
//! cascade PID, `PidDesign::position_velocity_cascade(1 ms, 10 V, kp 160.18 1/s, kv 243.45 V/(m/s)
//! × 5·10⁻⁸ m)`. See [`design`] for the priors.
//!
//! # Fixture layout
//! [`FIXTURE_SAMPLES`] records, delta-encoded with variable length ([`recording`]: three zigzag
//! varints per record, Δ²y in whole quanta, Δ³r in raw [`sledid::PositionI48F16`], Δ²u in raw
//! [`sledid::SignalI16F16`]), no header. [`recording::encode`] refuses a sample that does not fit (y off
//! the grid or beyond `i32` quanta, r beyond ±2⁴⁷ raw, \|u\| ≥ 5 V), so [`recording::Cursor`]
//! returns exactly the samples that were encoded.
//!
//! # Checksum
//! FNV-1a 64 (offset basis `0xcbf29ce484222325`, prime `0x100000001b3`) over, for every sample in
//! order, the little-endian bytes of the [`SledServoOutput`] fields:
//!
//! | bytes | field |
//! |---|---|
//! | 4 | u, the controller's drive (`i32` raw I16F16) |
//! | 1 | region (`Region::index`: 0 seek, 1 settle, 2 hold) |
//! | 2 | controller flags (`ControlFlags` bits, `u16`) |
//! | 4 × 4 | velocity identifier: y, u, ŷ, ε (`i32` raw each) |
//! | 2 × 4 | velocity identifier θ = [a₁, b₁] (`i32` raw I12F20) |
//! | 2 | velocity identifier status bits (`u16`) |
//!
//! 33 bytes per sample.

use core::borrow::Borrow;
use core::fmt;

use sledid::control::scheduled::{RedesignJob, RedesignResult};
use sledid::control::{PidDesign, Redesign, ScheduledDesign};
use sledid::error::ConfigError;
use sledid::servo::{
    Posted, ServoDesign, SledServo, SledServoOutput, SledServoState, Ticket, VELOCITY_N,
};

include!("loop_words.rs");

#[path = "recording.rs"]
pub mod recording;

pub use recording::Cursor;
use sledid::Sample;

/// Parameters of the velocity identifier: ARX(1,1), θ = [a₁, b₁].
pub const N: usize = VELOCITY_N;

/// The sled's sample period (Ts = 0.455 ms), ns: the firmware's SysTick period. The EMPS excerpt
/// was recorded at 1 ms; the firmware replays it one record per sled sample period.
pub const SAMPLE_PERIOD_NS: u32 = 455_000;

/// The EMPS recording's (and its controller's) sample period, s.
pub const EMPS_TS_S: f64 = 1e-3;

/// EMPS position-loop gain kp, 1/s (`shared/data` README).
pub const EMPS_KP_PER_S: f64 = 160.18;

/// EMPS velocity-loop gain kv, V/(m/s) (`shared/data` README).
pub const EMPS_KV_V_S_PER_M: f64 = 243.45;

/// Sensor quantum of the EMPS encoder, m (one [`sledid::PositionI48F16`] unit).
pub const QUANTUM_M: f64 = 5e-8;

/// Full-scale drive, V (one [`sledid::SignalI16F16`] unit of u).
pub const U_FULL_SCALE_V: f64 = 10.0;

/// Records in the fixture: the first 640 rows of `DATA_EMPS.csv` (2,157 B delta-encoded; the
/// image is above its 32 KiB flash budget with or without them, see `BENCHMARKS.md`).
pub const FIXTURE_SAMPLES: usize = 640;

/// What starts the firmware's result line (followed by a space and the [`Summary`]).
pub const RESULT_PREFIX: &str = "sledid-fw result:";

/// Prior velocity model (a, b) of the EMPS rig: the least-squares ARX(1,1) fit
/// `Δy(k+1) = a·Δy(k) + b·u(k)` (Δy in quanta per 1 ms sample, u in full scale) over all 24,841
/// rows of `DATA_EMPS.csv`: a = 0.99594, b = 69.363 (residual RMS 2.31 quanta per sample). The
/// 640-row excerpt alone gives a = 0.99468, b = 70.50.
pub const EMPS_VELOCITY_PRIOR: (f64, f64) = (0.995_943, 69.362_5);

/// Largest velocity pole the supervisor accepts for EMPS. The default (0.98) is the sled's, at
/// 0.455 ms; the EMPS rig's mechanical time constant is ≈ 0.25 s, a pole of 0.996 at 1 ms, so the
/// default would refuse the rig's own model. 0.999 (τ = 1 s) still refuses an integrator.
pub const EMPS_POLE_MAX: f64 = 0.999;

/// The rig's controller as the baseline (and fallback) of the scheduled controller.
pub fn baseline() -> PidDesign {
    PidDesign::position_velocity_cascade(
        EMPS_TS_S,
        U_FULL_SCALE_V,
        EMPS_KP_PER_S,
        EMPS_KV_V_S_PER_M * QUANTUM_M,
    )
}

/// The whole loop the firmware runs:
/// - controller: `ScheduledDesign::new(baseline())` (default regions, poles, supervisor limits
///   except [`EMPS_POLE_MAX`]), prior [`EMPS_VELOCITY_PRIOR`], no input compensation to start
///   with (the friction is identified and compensated after the first accepted redesign);
/// - velocity identifier: ARX(1,1) with a Coulomb term on Δy against u (`DifferencedOutput`),
///   θ₀ = [−a, b, 0] of the prior, λ = 0.995, P₀ = 10·I, dead zone ¼ quantum, trace(P) ≤ 100, outlier gate 40 quanta
///   (16 in a row) — `sledid::servo::velocity_identifier`.
pub fn design() -> ServoDesign {
    let mut controller = ScheduledDesign::new(baseline());
    controller.supervisor.pole_max = EMPS_POLE_MAX;
    controller.prior_model = Some(EMPS_VELOCITY_PRIOR);

    let velocity = sledid::servo::velocity_identifier(EMPS_VELOCITY_PRIOR, 0.0);

    ServoDesign {
        controller,
        velocity,
        options: sledid::servo::ServoOptions::default(),
        safety: sledid::servo::SafetyDesign::default(),
    }
}

/// The configuration the firmware runs: [`LOOP_WORDS`] (generated on the host from [`design`])
/// decoded and checked by [`SledServo::from_words`], without the `f64` build of [`design`].
///
/// # Errors
/// The words' [`ConfigError`] (none for the committed words; the tests decode them).
#[allow(dead_code)] // the firmware itself decodes into its static storage: `config_into`
pub fn config() -> Result<SledServo, ConfigError> {
    SledServo::from_words(&LOOP_WORDS)
}

/// [`config`] decoded into `slot` ([`SledServo::from_words_into`]: without a copy of the
/// controller's part on the stack); `None` in `slot` on an error.
///
/// # Errors
/// As [`config`].
#[allow(dead_code)] // the firmware's; the host replays from `design`
pub fn config_into(slot: &mut Option<SledServo>) -> Result<(), ConfigError> {
    SledServo::from_words_into(&LOOP_WORDS, slot)
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
    pub fn write_output(&mut self, out: &SledServoOutput) {
        self.write(&out.u.raw().to_le_bytes());
        self.write(&[out.region.index()]);
        self.write(&out.control.bits().to_le_bytes());
        let v = &out.identifier;
        for raw in [v.y.raw(), v.u.raw(), v.y_hat.raw(), v.eps.raw()] {
            self.write(&raw.to_le_bytes());
        }
        for t in &v.theta {
            self.write(&t.raw().to_le_bytes());
        }
        self.write(&v.status.bits().to_le_bytes());
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

/// One replay of the loop: configuration, state, and the checksum of everything it produced.
/// The firmware's SysTick handler and the host replay both step this, one sample at a time.
///
/// `C` holds the configuration: the host owns it (`SledServo`, the default); the firmware
/// borrows it from its own static storage (`&'static mut SledServo`), so that the run and the
/// configuration are each built in place, one after the other, not in one stack frame.
#[derive(Clone, Debug)]
pub struct Run<C = SledServo> {
    /// The validated configuration of [`design`] (its controller gains swapped by redesigns).
    pub(crate) config: C,
    /// The loop's state.
    pub(crate) state: SledServoState,
    checksum: Fnv1a64,
    samples: u32,
    updates: u32,
    applied: u16,
    rejected: u16,
    skipped: u16,
}

impl Run {
    /// A fresh run of [`design`], built from `f64` (the host's replay: the firmware decodes
    /// [`config`] instead, so the QEMU test also checks that the words give the design).
    ///
    /// # Errors
    /// The design's [`ConfigError`] (none for the committed design; the tests build it).
    #[allow(dead_code)] // the firmware starts from `config()`
    pub fn new() -> Result<Self, ConfigError> {
        Ok(Self::from_config(design().build()?))
    }
}

impl<C: Borrow<SledServo>> Run<C> {
    /// A fresh run of a built configuration (infallible, so that the firmware can construct it
    /// in place).
    #[inline(always)]
    pub fn from_config(config: C) -> Self {
        Self {
            state: config.borrow().new_state(),
            config,
            checksum: Fnv1a64::new(),
            samples: 0,
            updates: 0,
            applied: 0,
            rejected: 0,
            skipped: 0,
        }
    }

    /// One sample through the loop in shadow mode, folded into the checksum. Never panics.
    #[inline(never)]
    pub fn step(&mut self, sample: &Sample) -> SledServoOutput {
        let out = loop_step(self.config.borrow(), &mut self.state, sample);
        self.checksum.write_output(&out);
        self.samples = self.samples.wrapping_add(1);
        if out.identifier.status.contains(sledid::Status::UPDATED) {
            self.updates = self.updates.wrapping_add(1);
        }
        out
    }

    /// The background's side: the job a step posted, once.
    pub fn take_job(&mut self) -> Option<Posted<RedesignJob>> {
        self.state.take_job()
    }

    /// The background's side: the finished redesign for a job (counted by outcome when the
    /// hand-over accepts it).
    pub fn deliver(&mut self, ticket: Ticket, design: RedesignResult) -> bool {
        let accepted = self.state.deliver(ticket, design);
        if accepted {
            let count = match design.outcome {
                Redesign::Applied(_) => &mut self.applied,
                Redesign::Rejected(_) => &mut self.rejected,
                Redesign::Skipped => &mut self.skipped,
            };
            *count = count.wrapping_add(1);
        }
        accepted
    }

    /// The host's background turn between two samples: the posted job, if any, redesigned and
    /// delivered. Returns its outcome.
    pub fn background(&mut self) -> Option<Redesign> {
        let posted = self.take_job()?;
        let design = self.config.borrow().redesign(&posted);
        self.deliver(posted.ticket, design);
        Some(design.outcome)
    }

    /// What the run has produced so far.
    pub fn summary(&self) -> Summary {
        let mut theta_raw = [0i32; N];
        for (dst, t) in theta_raw
            .iter_mut()
            .zip(self.state.identifier().model().theta())
        {
            *dst = t.raw();
        }
        Summary {
            samples: self.samples,
            updates: self.updates,
            redesigns: [self.applied, self.rejected, self.skipped],
            fallback: self.state.controller().fallback(),
            checksum: self.checksum.value(),
            theta_raw,
        }
    }
}

/// The host's replay of a fixture under the [redesign rule](self#redesign-rule-deterministic):
/// what the firmware must report.
///
/// # Errors
/// The design's [`ConfigError`].
#[allow(dead_code)] // the firmware steps the run from its interrupt instead
pub fn replay(fixture: &[u8]) -> Result<Summary, ConfigError> {
    let mut run = Run::new()?;
    let mut cursor = Cursor::new();
    while let Some(sample) = cursor.next(fixture) {
        run.step(&sample);
        run.background();
    }
    Ok(run.summary())
}

/// The per-sample step alone ([`SledServo::step_shadow`] with the recorded drive), kept out of
/// line so that it exists once in the image and `count_insns.py` can measure it apart from the
/// checksum.
#[inline(never)]
pub fn loop_step(
    config: &SledServo,
    state: &mut SledServoState,
    sample: &Sample,
) -> SledServoOutput {
    config.step_shadow(state, sample.r, sample.y, sample.u)
}

/// The outcome of a run: what the firmware prints and the host test compares, field by field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Summary {
    /// Samples stepped.
    pub samples: u32,
    /// Samples on which the velocity identifier updated θ and P.
    pub updates: u32,
    /// Redesigns [applied, rejected, skipped].
    pub redesigns: [u16; 3],
    /// The baseline PID drives at the end (no accepted model).
    pub fallback: bool,
    /// FNV-1a 64 of every output (module doc).
    pub checksum: u64,
    /// Final velocity θ = [a₁, b₁], raw I12F20.
    pub theta_raw: [i32; N],
}

/// `[a, b, c]`: a slice as defmt prints it.
fn write_list<T: fmt::Display>(f: &mut fmt::Formatter<'_>, items: &[T]) -> fmt::Result {
    f.write_str("[")?;
    for (k, t) in items.iter().enumerate() {
        if k > 0 {
            f.write_str(", ")?;
        }
        write!(f, "{t}")?;
    }
    f.write_str("]")
}

impl fmt::Display for Summary {
    /// `samples=… updates=… redesigns=[applied, rejected, skipped] fallback=…
    /// checksum=0x…(16 hex digits) theta=[a1, b1]` (raw I12F20), exactly the firmware's defmt
    /// line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "samples={} updates={} redesigns=",
            self.samples, self.updates
        )?;
        write_list(f, &self.redesigns)?;
        write!(
            f,
            " fallback={} checksum={:#018x} theta=",
            self.fallback, self.checksum
        )?;
        write_list(f, &self.theta_raw)
    }
}
