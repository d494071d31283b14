//! Power-on calibration: a bounded identification experiment, run by the servo's own per-sample
//! step before the first seek, that measures what the seek and settle laws need — the velocity
//! model's pole and gain in quanta, the Coulomb level in both directions, the breakaway drive —
//! and seeds the identifier and the first design with it, as disk drives calibrate at power-up
//! instead of seeking on a nominal model.
//!
//! # The experiment ([`experiment`]: a state machine in the servo's state, nothing waits)
//! ```text
//! rest      wait until the reading is unchanged for `rest_samples` (at most `rest_samples_max`)
//! breakaway per direction d = +, −: u = d·u₀·rᵏ, each level held h samples, until the reading has
//!           moved `moved` quanta (u_bk(d) = that level; a reversed motion or no motion up to
//!           `breakaway_max` refuses)
//! pushes    from rest, u = d·U until D quanta (or `push_samples_max`), then u = −d·U (braking,
//!           recorded while the sled still advances), then rest: +U₀, −U₀, +U₁, −U₁ with
//!           U₀ = κ·u_bk(d) and U₁ = U₀·clamp(D / distance of the U₀ push, 2, 16) (a sled that is slow
//!           at U₀ is pushed harder the second time)
//! ```
//! The record (four pushes, ≤ [`SEGMENT_LEN`] readings each) goes to the background through a
//! hand-over like a redesign's; [`fit()`] returns the velocity model, and the servo adopts it at the
//! due sample: θ seeds the identifier, the controller's first design is placed from it.
//!
//! # The fit ([`mod@fit`], f32 in the background; float64 reference in `host-tests`)
//! Per sample, the velocity v (quanta per sample) of a first-order sled with ZOH drive u and
//! Coulomb level u_c(d) (the continuous model sampled exactly; a = e^{−λ}):
//! ```text
//! v(j+1) = a·v(j) + (1 − a)·K·(u(j) − u_c(d)·d)
//! x(j+1) = x(j) + v(j)·(1 − a)/λ + K·(u(j) − u_c(d)·d)·(1 − (1 − a)/λ)
//! ```
//! from rest at an unknown offset y₀ ∈ cell (a pseudo-observation y₀ = 0 of weight 1). For a
//! given λ the readings are linear in (K, K·u_c(+), K·u_c(−), y₀ per push): least squares; λ by a
//! log grid and a golden-section refinement of the residual. The servo's ARX(1,1) velocity model
//! (`super::velocity_identifier`) is then θ = [−a, b, b·u_c] with b = (1 − a)·K and u_c the mean
//! of both directions' levels.
//!
//! # Refusals
//! A sled that does not respond like a sled ends calibration with a [`Refusal`] and the safety
//! layer's stop ([`super::StopReason::Calibration`]): no motion up to `breakaway_max` (stuck,
//! disconnected), motion against the drive (reversed sensor or drive), more than
//! `travel_quanta` from the start, more than `samples_max` samples, a gain b outside
//! [`gain_min`, `gain_max`] (the family's range × 4 by default) or a fit that leaves more than
//! max(`rms_max`, `rms_per_step` · v_max) quanta of residual, v_max the record's largest step
//! between two readings (quanta per sample: a fit's timing error of a fraction of a sample is a
//! residual that grows with the speed). The servo does not start seeking on a guess.

pub mod experiment;
pub mod fit;
pub mod watch;

use crate::error::ConfigError;
use crate::num::fixed::SignalI16F16;
use crate::words::{WordReader, WordWriter, Words};

pub use experiment::{CalibrationRecord, CalibrationState, SEGMENT_LEN, SEGMENTS, Segment};
pub use fit::{CalibratedModel, fit};
pub use watch::CalibrationWatch;

/// Why calibration refused the sled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// No motion up to the largest breakaway drive (stuck sled or sensor, disconnected drive).
    Stuck,
    /// The sled moved against the drive (reversed sensor or drive).
    Reversed,
    /// The experiment went further than its travel from the start.
    Travel,
    /// The experiment took more than its samples.
    Timeout,
    /// The identified gain is outside the accepted range, or the controller refused the model.
    Gain,
    /// The readings do not follow a sled's model (residual above the limit).
    Fit,
}

impl Refusal {
    /// 0 … 5, for codes.
    pub const fn index(self) -> u8 {
        match self {
            Self::Stuck => 0,
            Self::Reversed => 1,
            Self::Travel => 2,
            Self::Timeout => 3,
            Self::Gain => 4,
            Self::Fit => 5,
        }
    }

    /// The name, for reports.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Stuck => "calibration_stuck",
            Self::Reversed => "calibration_reversed",
            Self::Travel => "calibration_travel",
            Self::Timeout => "calibration_timeout",
            Self::Gain => "calibration_gain",
            Self::Fit => "calibration_fit",
        }
    }
}

/// User-facing settings of the experiment, in quanta, samples and fractions of full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationDesign {
    /// u₀: the breakaway search's first drive, fraction of full scale.
    pub breakaway_start_fs: f64,
    /// r: each level is r times the last (1 < r ≤ 4).
    pub breakaway_ratio: f64,
    /// h: samples each level is held.
    pub breakaway_hold_samples: u16,
    /// The largest breakaway drive tried; no motion up to it refuses (stuck).
    pub breakaway_max_fs: f64,
    /// Quanta the reading must move for motion to count (≥ 1: a reading flickering at a cell
    /// boundary is not motion).
    pub moved_quanta: f64,
    /// κ: the first push's drive over the breakaway drive (> 1).
    pub push_over_breakaway: f64,
    /// D: a push brakes after this many quanta.
    pub push_quanta: f64,
    /// A push brakes after this many samples at the latest.
    pub push_samples_max: u16,
    /// Samples without a reading change that count as rest.
    pub rest_samples: u16,
    /// The longest wait for rest (a reading flickering at a boundary never rests): then on.
    pub rest_samples_max: u16,
    /// The whole experiment's samples (the budget: 330 samples ≈ 150 ms at Ts).
    pub samples_max: u16,
    /// The furthest the experiment may move from where it starts, quanta.
    pub travel_quanta: f64,
    /// The smallest gain b accepted, quanta per sample per full scale.
    pub gain_min: f64,
    /// The largest gain b accepted.
    pub gain_max: f64,
    /// The largest RMS residual of the fit accepted on a slow sled, quanta.
    pub rms_max: f64,
    /// The largest RMS residual accepted on a fast sled, per quantum of the record's largest
    /// step between two readings (the residual limit is the larger of the two).
    pub rms_per_step: f64,
    /// The fit's hand-over latency: the record is posted at sample k, the model adopted at k + L.
    pub fit_latency_samples: u16,
}

impl Default for CalibrationDesign {
    /// u₀ 0.2 % of full scale, r 1.5, h 2, up to 40 %, motion 2 quanta, κ 1.5, D 40 quanta, 32
    /// samples per push, rest 3 samples (64 at most; braked at the breakaway drive after 3), 330 samples, ±200 quanta, b in
    /// [0.19, 1,040] (the family's 0.76 … 260, `host-tests/src/control/family.rs`, × 4), RMS 1.5
    /// quanta or 0.1 of the largest step between readings (measured over the family, its
    /// wider family and their corners, 2 noise seeds each, 2026-11-27: every fit accepted had
    /// ≤ 0.19 × its largest step on slow records (≤ 6 quanta per sample, where 1.5 quanta
    /// decides) and ≤ 0.094 on fast ones; the family's fast, sticky corner leaves 2.2–2.4
    /// quanta at 35–36 quanta per sample with its gain within 13 %), the fit due 64 samples
    /// after the record.
    fn default() -> Self {
        Self {
            breakaway_start_fs: 0.002,
            breakaway_ratio: 1.5,
            breakaway_hold_samples: 2,
            breakaway_max_fs: 0.4,
            moved_quanta: 2.0,
            push_over_breakaway: 1.5,
            push_quanta: 40.0,
            push_samples_max: 32,
            rest_samples: 3,
            rest_samples_max: 64,
            samples_max: 330,
            travel_quanta: 200.0,
            gain_min: 0.19,
            gain_max: 1040.0,
            rms_max: 1.5,
            rms_per_step: 0.1,
            fit_latency_samples: 64,
        }
    }
}

/// The validated, quantised [`CalibrationDesign`] (`Copy`): drives and distances I16F16 raw
/// (fractions of full scale, quanta), the ratios I16F16 raw, the fit's limits `f32` (the
/// background's format).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationConfig {
    pub(crate) start_i16f16: i32,
    pub(crate) ratio_i16f16: i32,
    pub(crate) hold: u16,
    pub(crate) breakaway_max_i16f16: i32,
    pub(crate) moved_i16f16: i32,
    pub(crate) push_ratio_i16f16: i32,
    pub(crate) push_i16f16: i32,
    pub(crate) push_samples: u16,
    pub(crate) rest: u16,
    pub(crate) rest_max: u16,
    pub(crate) samples_max: u16,
    pub(crate) travel_i16f16: i32,
    pub(crate) gain_min: f32,
    pub(crate) gain_max: f32,
    pub(crate) rms_max: f32,
    pub(crate) rms_per_step: f32,
    pub(crate) latency: u16,
}

fn signal(x: f64, lo: f64, hi: f64) -> Result<i32, ConfigError> {
    if !(lo..=hi).contains(&x) {
        return Err(ConfigError::Calibration(x));
    }
    SignalI16F16::from_f64(x)
        .map(SignalI16F16::raw)
        .map_err(|_| ConfigError::Calibration(x))
}

#[allow(clippy::cast_possible_truncation)] // the limits are checked to be f32-representable
fn limit(x: f64, lo: f64, hi: f64) -> Result<f32, ConfigError> {
    if !(lo..=hi).contains(&x) {
        return Err(ConfigError::Calibration(x));
    }
    Ok(x as f32)
}

impl CalibrationDesign {
    /// Validates and quantises.
    ///
    /// # Errors
    /// [`ConfigError::Calibration`] with the first value out of its range: drives in (0, 1],
    /// the ratios in (1, 4] and (1, 16], distances in [1, 4,096] quanta, counts ≥ 1 (a push at
    /// most [`SEGMENT_LEN`] − 16 samples), the gain range ordered within (0, 2,048), the RMS limit
    /// in (0, 64] quanta, its share of the largest step in [0, 1].
    pub fn build(&self) -> Result<CalibrationConfig, ConfigError> {
        let count = |n: u16, max: u16| {
            if (1..=max).contains(&n) {
                Ok(n)
            } else {
                Err(ConfigError::Calibration(f64::from(n)))
            }
        };
        let c = CalibrationConfig {
            start_i16f16: signal(self.breakaway_start_fs, 1e-4, 1.0)?,
            ratio_i16f16: signal(self.breakaway_ratio, 1.01, 4.0)?,
            hold: count(self.breakaway_hold_samples, 64)?,
            breakaway_max_i16f16: signal(self.breakaway_max_fs, self.breakaway_start_fs, 1.0)?,
            moved_i16f16: signal(self.moved_quanta, 1.0, 64.0)?,
            push_ratio_i16f16: signal(self.push_over_breakaway, 1.01, 16.0)?,
            push_i16f16: signal(self.push_quanta, 1.0, 4096.0)?,
            push_samples: count(self.push_samples_max, (SEGMENT_LEN - 16) as u16)?,
            rest: count(self.rest_samples, 256)?,
            rest_max: count(self.rest_samples_max, 4096)?,
            samples_max: count(self.samples_max, u16::MAX)?,
            travel_i16f16: signal(self.travel_quanta, 1.0, 16384.0)?,
            gain_min: limit(self.gain_min, 1e-6, 2047.0)?,
            gain_max: limit(self.gain_max, self.gain_min, 2047.0)?,
            rms_max: limit(self.rms_max, 1e-3, 64.0)?,
            rms_per_step: limit(self.rms_per_step, 0.0, 1.0)?,
            latency: count(self.fit_latency_samples, 4096)?,
        };
        if c.rest > c.rest_max {
            return Err(ConfigError::Calibration(f64::from(self.rest_samples)));
        }
        Ok(c)
    }
}

impl CalibrationConfig {
    /// The invariants [`CalibrationDesign::build`] establishes (checked again on decoded words).
    ///
    /// # Errors
    /// [`ConfigError::Calibration`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        let one = 1 << 16;
        let ok = (1..=one).contains(&self.start_i16f16)
            && self.ratio_i16f16 > one
            && self.ratio_i16f16 <= 4 * one
            && self.hold >= 1
            && (self.start_i16f16..=one).contains(&self.breakaway_max_i16f16)
            && self.moved_i16f16 >= one
            && self.push_ratio_i16f16 > one
            && self.push_ratio_i16f16 <= 16 * one
            && self.push_i16f16 >= one
            && (1..=(SEGMENT_LEN - 16) as u16).contains(&self.push_samples)
            && self.rest >= 1
            && self.rest <= self.rest_max
            && self.samples_max >= 1
            && self.travel_i16f16 >= one
            && self.gain_min > 0.0
            && self.gain_max >= self.gain_min
            && self.gain_max < 2048.0
            && self.rms_max > 0.0
            && self.rms_max <= 64.0
            && self.rms_per_step >= 0.0
            && self.rms_per_step <= 1.0
            && self.latency >= 1;
        if ok {
            Ok(())
        } else {
            Err(ConfigError::Calibration(f64::NAN))
        }
    }

    /// L of the fit's hand-over, samples.
    pub fn latency(&self) -> u32 {
        u32::from(self.latency)
    }
}

/// Words: every field, drives and distances as I16F16 raw, the fit's limits as `f32` bits.
impl Words for CalibrationConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.start_i16f16.put(w)?;
        self.ratio_i16f16.put(w)?;
        self.hold.put(w)?;
        self.breakaway_max_i16f16.put(w)?;
        self.moved_i16f16.put(w)?;
        self.push_ratio_i16f16.put(w)?;
        self.push_i16f16.put(w)?;
        self.push_samples.put(w)?;
        self.rest.put(w)?;
        self.rest_max.put(w)?;
        self.samples_max.put(w)?;
        self.travel_i16f16.put(w)?;
        self.gain_min.to_bits().put(w)?;
        self.gain_max.to_bits().put(w)?;
        self.rms_max.to_bits().put(w)?;
        self.rms_per_step.to_bits().put(w)?;
        self.latency.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            start_i16f16: i32::take(r),
            ratio_i16f16: i32::take(r),
            hold: u16::take(r),
            breakaway_max_i16f16: i32::take(r),
            moved_i16f16: i32::take(r),
            push_ratio_i16f16: i32::take(r),
            push_i16f16: i32::take(r),
            push_samples: u16::take(r),
            rest: u16::take(r),
            rest_max: u16::take(r),
            samples_max: u16::take(r),
            travel_i16f16: i32::take(r),
            gain_min: f32::from_bits(u32::take(r)),
            gain_max: f32::from_bits(u32::take(r)),
            rms_max: f32::from_bits(u32::take(r)),
            rms_per_step: f32::from_bits(u32::take(r)),
            latency: u16::take(r),
        }
    }
}
