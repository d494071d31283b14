//! The processor-in-the-loop link: the two FIFOs, the host's down frame (command, r, y) and the
//! target's up frame (k, u, flags, duty, direction), byte for byte (layouts on each type).

use sledid::PositionI48F16;
use sledid::servo::{ServoFlags, SledServoOutput};

/// The link's host → target FIFO, in QEMU's working directory (the firmware opens it through
/// semihosting).
pub const LINK_DOWN: &core::ffi::CStr = c"pil-down";
/// The link's target → host FIFO.
pub const LINK_UP: &core::ffi::CStr = c"pil-up";

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
    pub const fn new(kind: Kind) -> Self {
        Self(match kind {
            Kind::Sample => 0,
            Kind::Lost => 1,
            Kind::End => 2,
        })
    }

    /// With [`Command::stall`] set.
    #[must_use]
    pub const fn with_stall(self) -> Self {
        Self(self.0 | Self::STALL)
    }

    /// With [`Command::delay`] = `periods`.
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
    pub const END: Self = Self {
        command: Command::new(Kind::End),
        r: PositionI48F16::from_raw(0),
        y: PositionI48F16::from_raw(0),
    };

    /// The frame's bytes.
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
    /// The duty the PWM channel was set to (of [`crate::PWM_MAX_DUTY`]).
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
    pub fn servo_flags(&self) -> ServoFlags {
        ServoFlags::from_bits((self.flags >> 16) as u8)
    }

    /// The region index of [`Self::flags`] (0 seek, 1 settle, 2 hold).
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
