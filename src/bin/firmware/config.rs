//! The one definition the firmware (`src/bin/firmware.rs`) and the host (`host-tests/src/pil`,
//! `host-tests/tests/firmware_qemu.rs`) share, so that they cannot drift: the parts the images are
//! built for, the configuration words, the processor-in-the-loop (PIL) link's frames, the
//! interrupt's body ([`Ticker`]) and the result line.
//!
//! Both include this file with `#[path = …] mod fw_config;` (it is the firmware's, not part of the
//! identification library). It lives in a sub-directory of `src/bin` so that cargo does not take
//! it for a binary of its own.
//!
//! # The loop, per sample period (processor in the loop)
//! ```text
//! host → target   DownFrame { command, r(k), y(k) }       r, y raw I48F16 (quanta × 2¹⁶)
//! target          Ticker::step: the servo's step behind sledid::servo::hal::ControlLoop
//!                 (position in: FrameSensor; drive out: PwmDirection over embedded-hal 1.0)
//! target → host   UpFrame { k, u(k), flags(k), duty, direction }
//! host            the twin's sled advances one period under u(k)
//! ```
//! The host runs the same [`Ticker`] on the same configuration words beside the target and
//! compares every [`UpFrame`] (`host-tests/src/pil`).
//!
//! # Redesign hand-over (L = [`SledServo::handover_latency`], from the words)
//! A redesign requested by sample k is posted as a job; the firmware's main loop (the
//! background) computes it and hands the result to the interrupt, which adopts it at sample
//! k + L ([`sledid::servo::handover`]). A result not delivered by then is dropped: the old gains
//! stay and the step flags `HANDOVER_MISSED`. The host's reference delivers every job at once
//! (or, for a job the host told the target to hold back by [`Command::delay`] ≥ L periods, not
//! at all), so the two agree exactly whenever the target's background meets L.
//!
//! # Up frame
//! [`UpFrame::to_bytes`] (16 bytes, little-endian): k (`u32`), u (`i32`, raw I16F16 full
//! scale), the flags word ([`flags_word`]: controller flags in bits 0–15, servo flags in 16–23,
//! region index in 24–31), the PWM duty (`u16`), the direction pin (`u8`, 1 = high, u ≥ 0) and
//! a zero byte. The host compares every one; the interrupt keeps no checksum of them (it would
//! cost ≈ 300 cycles a sample for a check the host already makes).

use core::borrow::Borrow;
use core::convert::Infallible;
use core::fmt;

use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use sledid::control::Redesign;
use sledid::control::scheduled::{RedesignJob, RedesignResult};
use sledid::error::ConfigError;
use sledid::servo::hal::{ControlLoop, DriveError, PositionSensor, PwmDirection};
use sledid::servo::{Posted, ServoFlags, SledServo, SledServoOutput, SledServoState, Ticket};
use sledid::{PositionI48F16, Status};

include!("loop_words.rs");

#[path = "recording.rs"]
#[allow(dead_code)] // the bench image's and the host's
pub mod recording;

/// The sled's sample period (Ts = 0.455 ms), ns: the SysTick period the images program.
pub const SAMPLE_PERIOD_NS: u32 = 455_000;

/// A microcontroller an image is built for: its core and clock set the SysTick reload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    /// The part.
    pub name: &'static str,
    /// Core clock, Hz.
    pub core_clock_hz: u32,
}

impl Part {
    /// SysTick reload value for one sample period on the core clock (the counter runs reload + 1
    /// cycles per period).
    pub const fn syst_reload(self) -> u32 {
        let cycles = self.core_clock_hz as u64 * SAMPLE_PERIOD_NS as u64 / 1_000_000_000;
        assert!(cycles > 1 && cycles <= 1 << 24, "SysTick reload is 24 bits");
        (cycles - 1) as u32
    }
}

/// The Cortex-M4F image (`thumbv7em-none-eabihf`): an STM32F411CE (the "Black Pill" board's
/// part) run at 72 MHz, 32,760 cycles per period. The board image (`boards/stm32f411`) is the
/// same part.
#[allow(dead_code)] // each image uses its own
pub const PART_M4F: Part = Part {
    name: "STM32F411CE Cortex-M4F @ 72 MHz",
    core_clock_hz: 72_000_000,
};

/// The Cortex-M0 image (`thumbv6m-none-eabi`): an ATSAMD21G18 (Cortex-M0+) at 48 MHz, 21,840
/// cycles per period.
#[allow(dead_code)] // each image uses its own
pub const PART_M0PLUS: Part = Part {
    name: "ATSAMD21G18 Cortex-M0+ @ 48 MHz",
    core_clock_hz: 48_000_000,
};

/// The link's host → target FIFO, in QEMU's working directory (the firmware opens it through
/// semihosting).
pub const LINK_DOWN: &core::ffi::CStr = c"pil-down";
/// The link's target → host FIFO.
pub const LINK_UP: &core::ffi::CStr = c"pil-up";

/// Full scale of the PIL drive's PWM channel: a 20 kHz PWM on a 72 MHz timer clock, as on the
/// board image.
pub const PWM_MAX_DUTY: u16 = 3_600;

/// What starts the firmware's result line (followed by a space and the [`Summary`]).
pub const RESULT_PREFIX: &str = "sledid-fw result:";
/// What starts the firmware's timing line (key=value pairs, see `src/bin/firmware.rs`).
pub const TIMING_PREFIX: &str = "sledid-fw timing:";

/// The configuration the firmware runs: [`LOOP_WORDS`] (generated on the host) decoded and
/// checked by [`SledServo::from_words`].
///
/// # Errors
/// The words' [`ConfigError`] (none for the committed words; the tests decode them).
#[allow(dead_code)] // the firmware decodes into its static storage: `config_into`
pub fn config() -> Result<SledServo, ConfigError> {
    SledServo::from_words(&LOOP_WORDS)
}

/// [`config`] decoded into `slot` ([`SledServo::from_words_into`]: without a copy of the
/// controller's part on the stack); `None` in `slot` on an error.
///
/// # Errors
/// As [`config`].
#[allow(dead_code)] // the firmware's; the host decodes with `config`
pub fn config_into(slot: &mut Option<SledServo>) -> Result<(), ConfigError> {
    SledServo::from_words_into(&LOOP_WORDS, slot)
}

/// What a down frame asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A sample: r(k) and y(k).
    Sample,
    /// A sample whose position could not be read: r(k) only (the step holds the last position).
    Lost,
    /// The run is over: the target stops stepping and reports.
    End,
}

/// The command word of a [`DownFrame`]: bits 0–1 the [`Kind`] (0 sample, 1 lost, 2 end), bit 2
/// [`Command::stall`], bits 8–15 [`Command::delay`]; every other bit zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Command(u32);

impl Command {
    const KIND_MASK: u32 = 0b11;
    const STALL: u32 = 1 << 2;
    const DELAY_SHIFT: u32 = 8;
    const KNOWN: u32 = Self::KIND_MASK | Self::STALL | (0xff << Self::DELAY_SHIFT);

    /// A command of `kind`, no stall, no delay.
    #[allow(dead_code)] // the host's (and the bench's)
    pub const fn new(kind: Kind) -> Self {
        Self(match kind {
            Kind::Sample => 0,
            Kind::Lost => 1,
            Kind::End => 2,
        })
    }

    /// With [`Command::stall`] set.
    #[allow(dead_code)] // the host's
    #[must_use]
    pub const fn with_stall(self) -> Self {
        Self(self.0 | Self::STALL)
    }

    /// With [`Command::delay`] = `periods`.
    #[allow(dead_code)] // the host's
    #[must_use]
    pub const fn with_delay(self, periods: u8) -> Self {
        Self((self.0 & !(0xff << Self::DELAY_SHIFT)) | ((periods as u32) << Self::DELAY_SHIFT))
    }

    /// The kind; `None` for an unknown kind or a reserved bit set.
    pub const fn kind(self) -> Option<Kind> {
        if self.0 & !Self::KNOWN != 0 {
            return None;
        }
        match self.0 & Self::KIND_MASK {
            0 => Some(Kind::Sample),
            1 => Some(Kind::Lost),
            2 => Some(Kind::End),
            _ => None,
        }
    }

    /// Fault injection: the interrupt, after answering, spins until the next sample period has
    /// begun (an overrun the target must count).
    pub const fn stall(self) -> bool {
        self.0 & Self::STALL != 0
    }

    /// Fault injection: a redesign job posted by this sample is handed back by the background
    /// only after the interrupt has stepped this many more samples (0: at once). With
    /// `delay ≥ L` the hand-over misses.
    pub const fn delay(self) -> u8 {
        (self.0 >> Self::DELAY_SHIFT) as u8
    }

    /// The raw word.
    pub const fn bits(self) -> u32 {
        self.0
    }
}

/// Host → target, once per sample period: 20 bytes, little-endian (command `u32`, r `i64`, y
/// `i64`, both raw I48F16).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DownFrame {
    /// What to do.
    pub command: Command,
    /// The reference r(k).
    pub r: PositionI48F16,
    /// The measured position y(k) (ignored unless the kind is [`Kind::Sample`]).
    pub y: PositionI48F16,
}

/// Bytes of a [`DownFrame`].
pub const DOWN_FRAME_BYTES: usize = 20;
/// Bytes of an [`UpFrame`].
pub const UP_FRAME_BYTES: usize = 16;

impl DownFrame {
    /// The end of the run.
    #[allow(dead_code)] // the host's
    pub const END: Self = Self {
        command: Command::new(Kind::End),
        r: PositionI48F16::from_raw(0),
        y: PositionI48F16::from_raw(0),
    };

    /// The frame's bytes.
    #[allow(dead_code)] // the host's
    pub fn to_bytes(self) -> [u8; DOWN_FRAME_BYTES] {
        let [c0, c1, c2, c3] = self.command.bits().to_le_bytes();
        let [r0, r1, r2, r3, r4, r5, r6, r7] = self.r.raw().to_le_bytes();
        let [y0, y1, y2, y3, y4, y5, y6, y7] = self.y.raw().to_le_bytes();
        [
            c0, c1, c2, c3, r0, r1, r2, r3, r4, r5, r6, r7, y0, y1, y2, y3, y4, y5, y6, y7,
        ]
    }

    /// The frame of `bytes`; `None` when its command is not a [`Command`].
    pub fn from_bytes(b: &[u8; DOWN_FRAME_BYTES]) -> Option<Self> {
        let [
            c0,
            c1,
            c2,
            c3,
            r0,
            r1,
            r2,
            r3,
            r4,
            r5,
            r6,
            r7,
            y0,
            y1,
            y2,
            y3,
            y4,
            y5,
            y6,
            y7,
        ] = *b;
        let command = Command(u32::from_le_bytes([c0, c1, c2, c3]));
        command.kind()?;
        Some(Self {
            command,
            r: PositionI48F16::from_raw(i64::from_le_bytes([r0, r1, r2, r3, r4, r5, r6, r7])),
            y: PositionI48F16::from_raw(i64::from_le_bytes([y0, y1, y2, y3, y4, y5, y6, y7])),
        })
    }
}

/// Target → host, once per sample period (layout in the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpFrame {
    /// The sample index the step ran as.
    pub k: u32,
    /// The drive u(k), raw I16F16 (fraction of full scale).
    pub u_raw: i32,
    /// [`flags_word`] of the step's output.
    pub flags: u32,
    /// The duty the PWM channel was set to (of [`PWM_MAX_DUTY`]).
    pub duty: u16,
    /// The direction pin (high: u ≥ 0).
    pub forward: bool,
}

impl UpFrame {
    /// The frame's bytes.
    pub fn to_bytes(self) -> [u8; UP_FRAME_BYTES] {
        let [k0, k1, k2, k3] = self.k.to_le_bytes();
        let [u0, u1, u2, u3] = self.u_raw.to_le_bytes();
        let [f0, f1, f2, f3] = self.flags.to_le_bytes();
        let [d0, d1] = self.duty.to_le_bytes();
        [
            k0,
            k1,
            k2,
            k3,
            u0,
            u1,
            u2,
            u3,
            f0,
            f1,
            f2,
            f3,
            d0,
            d1,
            u8::from(self.forward),
            0,
        ]
    }

    /// The frame of `bytes` (the host's side).
    #[allow(dead_code)] // the host's
    pub fn from_bytes(b: &[u8; UP_FRAME_BYTES]) -> Self {
        let [
            k0,
            k1,
            k2,
            k3,
            u0,
            u1,
            u2,
            u3,
            f0,
            f1,
            f2,
            f3,
            d0,
            d1,
            dir,
            _,
        ] = *b;
        Self {
            k: u32::from_le_bytes([k0, k1, k2, k3]),
            u_raw: i32::from_le_bytes([u0, u1, u2, u3]),
            flags: u32::from_le_bytes([f0, f1, f2, f3]),
            duty: u16::from_le_bytes([d0, d1]),
            forward: dir != 0,
        }
    }

    /// The servo flags of [`Self::flags`].
    #[allow(dead_code)] // the host's
    pub fn servo_flags(&self) -> ServoFlags {
        ServoFlags::from_bits((self.flags >> 16) as u8)
    }

    /// The region index of [`Self::flags`] (0 seek, 1 settle, 2 hold).
    #[allow(dead_code)] // the host's
    pub fn region_index(&self) -> u8 {
        (self.flags >> 24) as u8
    }
}

/// The flags word of one output: controller flags (bits 0–15), servo flags (16–23), region
/// index (24–31).
pub fn flags_word(out: &SledServoOutput) -> u32 {
    u32::from(out.control.bits())
        | u32::from(out.servo.bits()) << 16
        | u32::from(out.region.index()) << 24
}

/// The PIL's position input: the y of the frame being stepped (`None`: lost).
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameSensor {
    /// The reading of this sample, whole quanta.
    pub counts: Option<i64>,
}

/// A reading the frame did not carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoReading;

impl PositionSensor for FrameSensor {
    type Error = NoReading;
    fn read_counts(&mut self) -> Result<i64, NoReading> {
        self.counts.ok_or(NoReading)
    }
}

/// The PIL's PWM channel: keeps the duty it was set to (a board's timer compare register).
#[derive(Clone, Copy, Debug, Default)]
pub struct PilPwm {
    /// The duty set last.
    pub duty: u16,
}

impl PwmErrorType for PilPwm {
    type Error = Infallible;
}

impl SetDutyCycle for PilPwm {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.duty = duty;
        Ok(())
    }
}

/// The PIL's direction pin: keeps its level (a board's GPIO output register).
#[derive(Clone, Copy, Debug, Default)]
pub struct PilPin {
    /// The level set last.
    pub high: bool,
}

impl PinErrorType for PilPin {
    type Error = Infallible;
}

impl OutputPin for PilPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.high = true;
        Ok(())
    }
}

/// The interrupt's body, one call per sample period: the frame's position through the servo's
/// step behind [`ControlLoop`] (position in, drive out over embedded-hal 1.0), the answer, and
/// the run's totals. The firmware's SysTick handler and the host's reference run step the same
/// code on the same words.
///
/// `C` holds the configuration: the host owns it (`SledServo`); the firmware borrows it from its
/// own static storage, so that the configuration and the ticker are each built in place.
pub struct Ticker<C> {
    config: C,
    state: SledServoState,
    control: ControlLoop<FrameSensor, PwmDirection<PilPwm, PilPin>>,
    totals: Summary,
}

impl<C: Borrow<SledServo>> Ticker<C> {
    /// A fresh run of a built configuration (infallible, so that the firmware can construct it
    /// in place).
    #[inline(always)]
    pub fn new(config: C) -> Self {
        Self {
            state: config.borrow().new_state(),
            config,
            control: ControlLoop::new(
                FrameSensor::default(),
                PwmDirection {
                    pwm: PilPwm::default(),
                    direction: PilPin::default(),
                },
            ),
            totals: Summary::default(),
        }
    }

    /// The configuration.
    #[allow(dead_code)] // the host's (and the bench's)
    pub fn config(&self) -> &SledServo {
        self.config.borrow()
    }

    /// The servo's state.
    #[allow(dead_code)] // the host's
    pub fn state(&self) -> &SledServoState {
        &self.state
    }

    /// One sample period on `frame` (of kind [`Kind::Sample`] or [`Kind::Lost`]): the answer.
    /// A redesign the step asks for waits in the state for [`Self::take_job`]. Never panics.
    #[inline(never)]
    pub fn step(&mut self, frame: &DownFrame) -> UpFrame {
        let lost = frame.command.kind() != Some(Kind::Sample);
        self.control.sensor.counts = (!lost).then_some(frame.y.raw() >> 16);
        let k = self.state.sample_index();
        let out = match self
            .control
            .tick(self.config.borrow(), &mut self.state, frame.r)
        {
            Ok(out) => out,
            Err(DriveError::First(e) | DriveError::Second(e)) => match e {},
        };
        let drive = &self.control.drive;
        let up = UpFrame {
            k,
            u_raw: out.u.raw(),
            flags: flags_word(&out),
            duty: drive.pwm.duty,
            forward: drive.direction.high,
        };
        let t = &mut self.totals;
        t.samples = t.samples.wrapping_add(1);
        t.lost = t.lost.wrapping_add(u32::from(lost));
        t.updates = t
            .updates
            .wrapping_add(u32::from(out.identifier.status.contains(Status::UPDATED)));
        for (count, flag) in t.handover.iter_mut().zip([
            ServoFlags::REDESIGN_POSTED,
            ServoFlags::REDESIGN_ADOPTED,
            ServoFlags::HANDOVER_MISSED,
        ]) {
            *count = count.wrapping_add(u32::from(out.servo.contains(flag)));
        }
        up
    }

    /// The background's side: the redesign job a step posted, once.
    pub fn take_job(&mut self) -> Option<Posted<RedesignJob>> {
        self.state.take_job()
    }

    /// The background's result for a job (counted by outcome when the hand-over accepts it:
    /// false when its due sample has passed).
    pub fn deliver(&mut self, ticket: Ticket, design: RedesignResult) -> bool {
        let accepted = self.state.deliver(ticket, design);
        if accepted {
            let i = match design.outcome {
                Redesign::Applied(_) => 0,
                Redesign::Rejected(_) => 1,
                Redesign::Skipped => 2,
            };
            if let Some(count) = self.totals.redesigns.get_mut(i) {
                *count = count.wrapping_add(1);
            }
        }
        accepted
    }

    /// What the run has produced so far.
    pub fn summary(&self) -> Summary {
        let mut s = self.totals;
        for (dst, t) in s
            .theta_raw
            .iter_mut()
            .zip(self.state.identifier().model().theta())
        {
            *dst = t.raw();
        }
        s
    }
}

/// Parameters of the velocity identifier reported in the result line.
pub const THETA_N: usize = sledid::servo::VELOCITY_N;

/// The outcome of a run: what the firmware prints and the host's reference must equal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Samples stepped.
    pub samples: u32,
    /// Of which without a position ([`Kind::Lost`]).
    pub lost: u32,
    /// Samples on which the velocity identifier updated θ and P.
    pub updates: u32,
    /// Hand-overs: jobs posted, results adopted, hand-overs missed (servo flags).
    pub handover: [u32; 3],
    /// Results accepted by the hand-over: [applied, rejected, skipped].
    pub redesigns: [u32; 3],
    /// Handlers that ended after the next period had begun (the target's count; the host
    /// expects one per overrun it asked for, [`Command::stall`]).
    pub overruns: u32,
    /// Final velocity θ, raw I12F20.
    pub theta_raw: [i32; THETA_N],
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
    /// `samples=… lost=… updates=… handover=[posted, adopted, missed] redesigns=[applied,
    /// rejected, skipped] overruns=… theta=[…]` (raw I12F20), exactly the firmware's defmt
    /// line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "samples={} lost={} updates={} handover=",
            self.samples, self.lost, self.updates
        )?;
        write_list(f, &self.handover)?;
        f.write_str(" redesigns=")?;
        write_list(f, &self.redesigns)?;
        write!(f, " overruns={} theta=", self.overruns)?;
        write_list(f, &self.theta_raw)
    }
}
