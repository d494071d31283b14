//! The servo: the firmware's whole per-sample step — a position controller and the on-line
//! identifier it is designed from — one function, called by the firmware's timer interrupt, by
//! `sledid control`'s closed loop on the twin, and by the bench image.
//!
//! # One sample k (positions in quanta, u in full scale)
//! ```text
//! hand-over: a redesign due at k is adopted (or, not delivered, dropped and flagged)   handover
//! u(k)      = controller(r(k), y(k), report(k−1))           any crate::control::Controller
//! report(k) = identifier(y(k), u(k), r(k))                  any crate::ident::step::Identifier,
//!                                                           adapting only while the sled moves
//! the controller asks for a redesign → a job posted, due at k + L
//! ```
//! The paper's conclusion is that different models belong to different parts of a step response:
//! the velocity model identified while the sled moves (where the data are informative) places the
//! seek and settle laws, whose regions switch per sample; near the target the controller works
//! from rest, cell and band rules on the readings (`crate::control::scheduled::rest`). The paper's
//! nonlinear models (eq. 5–7, Wiener) run beside a recording in `replay` and the study; the one
//! that runs beside the servo is the friction neuron of [`health`], fed by the interrupt through
//! a queue and identified in the background against the calibration's Coulomb level.
//!
//! # Configuration and state
//! [`ServoConfig`] is validated and immutable while the loop runs; everything the loop changes —
//! histories, the controller's gains and latches, the identifier's θ and P, the redesign in flight —
//! is in [`ServoState`]. The slow-rate redesign is not part of the step: the step posts a job
//! ([`ServoState::take_job`]), the background runs [`ServoConfig::redesign`] and hands the result
//! back ([`ServoState::deliver`]), and the step of sample k + L adopts it ([`handover`]).
//!
//! # Seams
//! [`ServoConfig`] is generic over its controller `C` ([`Controller`]) and its identifier `I`
//! ([`Identifier`]); [`ServoDesign`] builds the product's composition ([`SledServo`]: the
//! scheduled controller on the ARX(1,1) velocity identifier). [`ServoConfig::new`] composes any
//! other pair.

use crate::control::{
    ControlFlags, ControlInput, Controller, ModelReport, Region, ScheduledConfig, ScheduledDesign,
};
use crate::error::ConfigError;
use crate::ident::conditioning::Conditioning;
use crate::ident::linear::{LinearConfig, LinearDesign, Structure};
use crate::ident::rls::{AntiWindup, RlsDesign};
use crate::ident::step::{Identifier, IdentifierConfig, IdentifierDesign, StepOutput};
use crate::num::boundary::{PositionI48F16, Sample};
use crate::num::fixed::{ParamI12F20, SignalI16F16};
use crate::words::{WordReader, WordWriter, Words};

pub mod calibration;
pub mod hal;
pub mod handover;
pub mod health;
pub mod safety;

pub use calibration::{
    CalibratedModel, CalibrationConfig, CalibrationDesign, CalibrationRecord, CalibrationState,
    Refusal,
};
pub use handover::{Handover, HandoverEvent, Posted, Ticket};
pub use safety::{SafetyConfig, SafetyDesign, SafetyState, StopReason};

/// Parameters of the controller's identifier (ARX(1,1) on velocity with a Coulomb term).
pub const VELOCITY_N: usize = crate::ident::linear::parameter_count(1, 1, true);

/// The product's identifier: ARX(1,1) with a Coulomb term on the velocity.
pub type VelocityIdentifier = IdentifierConfig<VELOCITY_N, LinearConfig<VELOCITY_N>>;

/// The product's servo: the scheduled controller on the velocity identifier.
pub type SledServo = ServoConfig<ScheduledConfig, VelocityIdentifier>;

/// The state of [`SledServo`].
pub type SledServoState = ServoState<ScheduledConfig, VelocityIdentifier>;

/// What one sample of [`SledServo`] produced.
pub type SledServoOutput = ServoOutput<StepOutput<VELOCITY_N>>;

/// User-facing settings of the product's servo.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoDesign {
    /// The gain-scheduled controller (its baseline PID is the fallback).
    pub controller: ScheduledDesign,
    /// The identifier the controller's gains are placed from.
    pub velocity: IdentifierDesign<VELOCITY_N, LinearDesign<VELOCITY_N>>,
    /// The servo's own settings (hand-over latency, identification).
    pub options: ServoOptions,
    /// The safety layer below the controller.
    pub safety: SafetyDesign,
    /// Power-on calibration before the first seek (`None`: the servo starts from the prior).
    pub calibration: Option<CalibrationDesign>,
}

/// Whether the identifier learns on-line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Identification {
    /// The identifier adapts while the sled moves; redesigns follow it (the product).
    #[default]
    OnLine,
    /// The identifier never adapts: the controller keeps the prior's design (the ablation that
    /// shows what identification earns) — or, with power-on calibration, the calibrated model's.
    FrozenAtPrior,
}

/// The servo's own settings, in engineering units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoOptions {
    /// L: a redesign requested by sample k is adopted at sample k + L (≥ 1).
    pub handover_latency_samples: u16,
    /// On-line or frozen at the prior.
    pub identification: Identification,
    /// The identifier adapts only while |y(k) − y(k−1)| and |y(k−1) − y(k−2)| are both at least
    /// this, quanta per sample: at low speed the first-differenced quantisation noise (its
    /// successive differences are negatively correlated) biases the velocity pole down.
    pub identify_min_speed_quanta: f64,
}

impl Default for ServoOptions {
    fn default() -> Self {
        Self {
            handover_latency_samples: 1,
            identification: Identification::OnLine,
            identify_min_speed_quanta: 2.0,
        }
    }
}

/// The validated, quantised [`ServoOptions`] (`Copy`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServoSettings {
    latency: u32,
    adapt: bool,
    min_speed_i16f16: u32,
}

impl ServoOptions {
    /// Validates and quantises.
    ///
    /// # Errors
    /// [`ConfigError::HandoverLatency`] for L = 0, [`ConfigError::IdentifySpeed`] for a speed
    /// gate that is negative, not finite or beyond the I16F16 range.
    pub fn build(&self) -> Result<ServoSettings, ConfigError> {
        let speed = SignalI16F16::from_f64(self.identify_min_speed_quanta)
            .ok()
            .filter(|s| s.raw() >= 0)
            .ok_or(ConfigError::IdentifySpeed(self.identify_min_speed_quanta))?;
        let s = ServoSettings {
            latency: u32::from(self.handover_latency_samples),
            adapt: self.identification == Identification::OnLine,
            min_speed_i16f16: speed.raw().unsigned_abs(),
        };
        s.validate()?;
        Ok(s)
    }
}

impl ServoSettings {
    /// `1 ≤ L ≤ 65,535`, a speed gate in `[0, 2³¹)`: checked by [`ServoOptions::build`] and by the
    /// decoding of configuration words alike.
    ///
    /// # Errors
    /// [`ConfigError::HandoverLatency`] or [`ConfigError::IdentifySpeed`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(1..=u32::from(u16::MAX)).contains(&self.latency) {
            return Err(ConfigError::HandoverLatency(0));
        }
        if self.min_speed_i16f16 > i32::MAX as u32 {
            return Err(ConfigError::IdentifySpeed(f64::NAN));
        }
        Ok(())
    }
}

/// Words: L, adapt, the speed gate (I16F16 raw).
impl Words for ServoSettings {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.latency.put(w)?;
        self.adapt.put(w)?;
        self.min_speed_i16f16.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            latency: u32::take(r),
            adapt: bool::take(r),
            min_speed_i16f16: u32::take(r),
        }
    }
}

/// The controller's identifier as the servo expects it: ARX(1, 1) with a Coulomb term on the
/// velocity Δy against u, `Δy(k) = a·Δy(k−1) + b·u(k−1) − c·sign(Δy(k−1))` (the first-order
/// velocity model `crate::control::placement` places gains from, and the friction c = b·u_c the
/// compensation is built from), started from the velocity model `prior` = (a, b) and the Coulomb
/// level `coulomb_fs` (fraction of full scale), λ = 0.995, P₀ = 10·I, dead zone ¼ quantum,
/// trace(P) ≤ 100, outlier gate 40 quanta per sample (16 in a row).
pub fn velocity_identifier(
    prior: (f64, f64),
    coulomb_fs: f64,
) -> IdentifierDesign<VELOCITY_N, LinearDesign<VELOCITY_N>> {
    let mut model = LinearDesign::<VELOCITY_N>::new(Structure::Arx, 1, 1);
    model.coulomb = true;
    model.theta0 = [-prior.0, prior.1, prior.1 * coulomb_fs];
    model.rls = RlsDesign {
        lambda: 0.995,
        p0: 10.0,
        dead_zone: 0.25,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        outlier_threshold: 40.0,
        outlier_limit: 16,
        ..RlsDesign::default()
    };
    IdentifierDesign::new(Conditioning::DifferencedOutput, model)
}

/// Validated configuration of a servo (`Copy` when its parts are): immutable while it runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoConfig<C, I> {
    controller: C,
    identifier: I,
    settings: ServoSettings,
    safety: SafetyConfig,
    calibration: Option<CalibrationConfig>,
}

/// The background's answer to calibration's record: the model, θ for the identifier and the
/// controller's first design from it, or why the sled is refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Calibrated<D> {
    /// The sled's model.
    Model {
        /// What the fit found.
        model: CalibratedModel,
        /// The identifier's θ from it.
        theta: [ParamI12F20; VELOCITY_N],
        /// The controller's design placed from θ.
        design: D,
    },
    /// The sled does not respond like one.
    Refused(Refusal),
}

/// The background's work ([`ServoState`]'s hand-over): a redesign's job, or calibration's fit.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Work<J> {
    /// Place the controller's design.
    Redesign(J),
    /// Fit calibration's record (held in calibration's state).
    Fit,
}

/// The background's answer ([`ServoState`]'s hand-over): a redesign's design, or the fit's.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Answer<D> {
    /// A redesign's design.
    Redesign(D),
    /// Calibration's model (or refusal) with the first design.
    Fit(Calibrated<D>),
}

/// Everything one sample (or an adopted redesign) mutates.
pub struct ServoState<C: Controller, I: Identifier> {
    /// Sample index k (wraps after 2³² samples, 22.6 days at Ts).
    k: u32,
    controller: C::State,
    identifier: I::State,
    report: ModelReport,
    /// The last position read (held through a lost reading).
    last_y: PositionI48F16,
    y1: i64,
    y2: i64,
    /// The background's work in flight and its answer: a redesign, or calibration's fit (its job
    /// is only the ticket: the record stays in [`Self::calibration`] — the experiment leaves it
    /// alone while it waits for the fit — and is read from there when the background takes the
    /// job, not held twice). Never both at once — a fit is posted only while calibrating, where
    /// no redesign is posted, and a re-calibration drops the redesign in flight — so they share
    /// one hand-over and one result slot.
    handover: Handover<Work<C::Job>, Answer<C::Design>>,
    /// The work in flight (or last posted) is calibration's fit: a redesign's design is refused
    /// for it, and a fit's answer for a redesign.
    fitting: bool,
    safety: SafetyState,
    /// The controller was in its fallback on the last sample.
    in_fallback: bool,
    /// The fallbacks' recovery (`safety`, "Before the fallbacks' stop") asks for a calibration
    /// from the next sample.
    recalibrate: bool,
    /// The fallbacks' recovery of a servo without calibration: the identifier no longer adapts
    /// and no redesign is posted; the controller runs its prior's design.
    suspended: bool,
    /// Power-on calibration's progress (finished from the start without one).
    calibration: CalibrationState,
    /// What calibration found, once adopted.
    calibrated: Option<CalibratedModel>,
    /// Calibrations adopted since power-on.
    calibrations: u32,
    /// Re-calibrations that ran out of samples after every push had ended: the previous model
    /// kept.
    inconclusive: u16,
    /// When to calibrate again.
    watch: calibration::CalibrationWatch,
}

/// What the servo itself did in one sample (beside the controller's [`ControlFlags`]).
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServoFlags(u8);

impl ServoFlags {
    /// No flag.
    pub const NONE: Self = Self(0);
    /// A redesign job was posted this sample (due at k + L).
    pub const REDESIGN_POSTED: Self = Self(1 << 0);
    /// A redesign was adopted before this sample's step.
    pub const REDESIGN_ADOPTED: Self = Self(1 << 1);
    /// A redesign due this sample was not delivered in time: the old values stay.
    pub const HANDOVER_MISSED: Self = Self(1 << 2);
    /// The safety layer has cut the drive ([`ServoOutput::stop`] says why); latched until
    /// [`ServoConfig::reset_safe_stop`].
    pub const SAFE_STOP: Self = Self(1 << 3);
    /// Power-on calibration owns the drive (the reference is not followed yet).
    pub const CALIBRATING: Self = Self(1 << 4);
    /// The command in progress has not settled (±1 quantum for 10 ms) within the time its
    /// calibrated model allows, or its reading left ±1 quantum after it had settled (off track;
    /// `calibration::watch`): what a drive reports to its host as a seek error. Raised every such
    /// sample, until it settles (again) or a new command arrives.
    pub const SEEK_ERROR: Self = Self(1 << 5);
    /// The servo, without calibration, recovered from the fallbacks' stop by keeping its prior's
    /// design: the identifier no longer adapts (`safety`, "Before the fallbacks' stop"). Raised
    /// every sample from then on.
    pub const IDENTIFICATION_SUSPENDED: Self = Self(1 << 6);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 7] = [
        (Self::REDESIGN_POSTED, "redesign_posted"),
        (Self::REDESIGN_ADOPTED, "redesign_adopted"),
        (Self::HANDOVER_MISSED, "handover_missed"),
        (Self::SAFE_STOP, "safe_stop"),
        (Self::CALIBRATING, "calibrating"),
        (Self::SEEK_ERROR, "seek_error"),
        (Self::IDENTIFICATION_SUSPENDED, "identification_suspended"),
    ];
}

crate::flag_set_impl!(ServoFlags, u8);

/// What one sample produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ServoOutput<O> {
    /// The drive u(k), fraction of full scale.
    pub u: SignalI16F16,
    /// The controller's region.
    pub region: Region,
    /// The controller's flags (`FALLBACK` when the supervisor distrusts the model).
    pub control: ControlFlags,
    /// The servo's own flags (redesign hand-over, safe stop).
    pub servo: ServoFlags,
    /// Why the drive is cut, while it is (latched).
    pub stop: Option<StopReason>,
    /// The identifier's output (for the velocity identifier: ŷ, ε, θ, status).
    pub identifier: O,
}

impl ServoDesign {
    /// The default servo around `controller`: the velocity identifier from the controller's
    /// prior (or a = 0.8, b = 20 without one) and the Coulomb level of its compensation (−w of
    /// the map's neuron, the drive it loses at speed; 0 without one), the default options.
    pub fn new(controller: ScheduledDesign) -> Self {
        let coulomb_fs = controller
            .compensation
            .map_or(0.0, |m| -m.neuron().w().to_f64())
            .max(0.0);
        // The sled coasts a/(1 − a) samples per unit of speed once the drive is cut; 1.25× that,
        // plus two samples, for a model that may be off. (2× stopped heavy, lightly damped sleds
        // of the family — a ≈ 0.97, a 2,000-track seek at 160 quanta per sample — on their exact
        // model, 5,000 quanta short of the soft end stop: `control-family --prior exact`.)
        let coast_samples = controller
            .prior_model
            .map_or(SafetyDesign::default().coast_samples, |(a, _)| {
                1.25 * a.clamp(0.0, 0.99) / (1.0 - a.clamp(0.0, 0.99)) + 2.0
            });
        Self {
            velocity: velocity_identifier(
                controller.prior_model.unwrap_or((0.8, 20.0)),
                coulomb_fs,
            ),
            controller,
            options: ServoOptions::default(),
            safety: SafetyDesign {
                coast_samples,
                // Far above the prior's breakaway drive (its Coulomb level, stiction ×3, ×8): a
                // sled sticking harder than that is held by more than friction.
                stall_drive_fs: (24.0 * coulomb_fs).clamp(0.1, 0.5),
                ..SafetyDesign::default()
            },
            calibration: None,
        }
    }

    /// This servo with power-on calibration ([`CalibrationDesign::default`]).
    #[must_use]
    pub fn with_calibration(mut self) -> Self {
        self.calibration = Some(CalibrationDesign::default());
        self
    }

    /// Validates and quantises every part.
    ///
    /// # Errors
    /// The first part's [`ConfigError`], or [`ConfigError::CoulombTerm`] /
    /// [`ConfigError::ModelOrder`] when the controller reads θ otherwise than the identifier
    /// writes it.
    pub fn build(&self) -> Result<SledServo, ConfigError> {
        let mut config = ServoConfig::new(
            self.controller.build()?,
            self.velocity.build()?,
            self.options.build()?,
            self.safety.build()?,
        );
        config.calibration = self.calibration.map(|c| c.build()).transpose()?;
        config.check_model()?;
        Ok(config)
    }

    /// Builds every part and writes the configuration words ([`crate::words`]) into `out`: the
    /// velocity identifier's ([`IdentifierDesign::put_words`]), the servo's settings, then the
    /// controller's
    /// ([`ScheduledConfig`]; last, so that [`ServoConfig::from_words`] can decode the largest part
    /// straight into its result instead of into a copy on the stack). Returns the number of words
    /// written.
    ///
    /// # Errors
    /// The first part's [`ConfigError`], or [`ConfigError::Words`] when `out` is too short
    /// ([`SERVO_WORDS_MAX`] always suffices).
    pub fn to_words(&self, out: &mut [u32]) -> Result<usize, ConfigError> {
        let built = self.build()?;
        let len = out.len();
        let payload = out.get_mut(2..).ok_or(ConfigError::Words { at: len })?;
        let mut w = WordWriter::new(payload);
        let at = crate::words::in_frame;
        self.velocity.put_words(&mut w).map_err(at)?;
        built.settings.put(&mut w).map_err(at)?;
        built.safety.put(&mut w).map_err(at)?;
        built.calibration.put(&mut w).map_err(at)?;
        built.controller.put(&mut w).map_err(at)?;
        let payload_len = w.len();
        crate::words::seal(out, payload_len)
    }
}

/// A buffer size that holds the words of any [`ServoDesign`]: at most 279 (3 of framing, the
/// velocity identifier with a stuck-sensor check and a pole radius, the servo's settings, safety
/// layer and power-on calibration, the controller with both maps and time-optimal seeks;
/// `host-tests/tests/integration/sled_loop.rs` counts them).
pub const SERVO_WORDS_MAX: usize = 279;

impl<C: Controller, I: Identifier> ServoConfig<C, I> {
    /// Composes a servo from built parts: any controller on any identifier, with the servo's own
    /// settings and safety layer.
    pub fn new(
        controller: C,
        identifier: I,
        settings: ServoSettings,
        safety: SafetyConfig,
    ) -> Self {
        Self {
            controller,
            identifier,
            settings,
            safety,
            calibration: None,
        }
    }

    /// This servo with power-on calibration `calibration` (`None`: without).
    #[must_use]
    pub fn with_calibration(mut self, calibration: Option<CalibrationConfig>) -> Self {
        self.calibration = calibration;
        self
    }

    /// Power-on calibration's configuration, if the servo calibrates.
    pub fn calibration(&self) -> Option<&CalibrationConfig> {
        self.calibration.as_ref()
    }

    /// The safety layer's configuration.
    pub fn safety(&self) -> &SafetyConfig {
        &self.safety
    }

    /// Releases a latched safe stop: the controller restarts from its initial state (its
    /// integrators and regions would otherwise resume from before the stop), the identifier keeps
    /// what it learnt. The only way out of a safe stop.
    pub fn reset_safe_stop(&self, state: &mut ServoState<C, I>) {
        state.safety = state.safety.reset();
        state.controller = self.controller.new_state();
        state.in_fallback = false;
        if !state.calibration.is_done() {
            // A refused (or interrupted) calibration runs again from where the sled is.
            state.calibration = self.fresh_calibration();
            state.handover = Handover::new();
        }
    }

    fn fresh_calibration(&self) -> CalibrationState {
        if self.calibration.is_some() {
            CalibrationState::new()
        } else {
            CalibrationState::finished()
        }
    }

    /// A fresh state.
    pub fn new_state(&self) -> ServoState<C, I> {
        ServoState {
            k: 0,
            controller: self.controller.new_state(),
            identifier: self.identifier.new_state(),
            report: ModelReport::default(),
            last_y: PositionI48F16::default(),
            y1: 0,
            y2: 0,
            handover: Handover::new(),
            fitting: false,
            safety: SafetyState::new(),
            in_fallback: false,
            recalibrate: false,
            suspended: false,
            calibration: self.fresh_calibration(),
            calibrated: None,
            calibrations: 0,
            inconclusive: 0,
            watch: calibration::CalibrationWatch::default(),
        }
    }

    /// The controller configuration.
    pub fn controller(&self) -> &C {
        &self.controller
    }

    /// The identifier configuration.
    pub fn identifier(&self) -> &I {
        &self.identifier
    }

    /// L: samples from a redesign's request to its adoption.
    pub fn handover_latency(&self) -> u32 {
        self.settings.latency
    }

    /// The background's work on a posted job (outside the sample interrupt; it may take up to L
    /// sample periods).
    pub fn redesign(&self, posted: &Posted<C::Job>) -> C::Design {
        self.controller.redesign(&posted.job)
    }

    /// The background's whole turn at once (the host's, between two samples): takes the posted
    /// job, if any, redesigns and delivers. Returns the design delivered.
    pub fn run_background(&self, state: &mut ServoState<C, I>) -> Option<C::Design> {
        if let Some(posted) = state.take_calibration_job() {
            let answer = self.calibrate(&posted.job);
            state.deliver_calibration(posted.ticket, answer);
        }
        let posted = state.take_job()?;
        let design = self.redesign(&posted);
        state.deliver(posted.ticket, design);
        Some(design)
    }

    /// The background's work on calibration's record: the fit ([`calibration::fit()`]), θ, and the
    /// controller's design placed from it (a model the controller refuses is refused as
    /// [`Refusal::Gain`]). Outside the sample interrupt. [`Self::fit_calibration`], then
    /// [`Self::calibrated`].
    pub fn calibrate(&self, record: &CalibrationRecord) -> Calibrated<C::Design> {
        self.calibrated(self.fit_calibration(record))
    }

    /// The first half of [`Self::calibrate`]: the fit of calibration's record alone. A target
    /// runs it in a frame of its own, so that the record is off the stack before the design
    /// below is placed.
    pub fn fit_calibration(&self, record: &CalibrationRecord) -> Result<CalibratedModel, Refusal> {
        let Some(config) = &self.calibration else {
            return Err(Refusal::Fit);
        };
        calibration::fit(config, record)
    }

    /// The second half of [`Self::calibrate`]: from the fit's answer, θ and the controller's
    /// design placed from it (a model the controller refuses is refused as [`Refusal::Gain`]).
    /// [`Self::first_design_job`], the controller's redesign, then [`Self::calibrated_answer`].
    pub fn calibrated(&self, fitted: Result<CalibratedModel, Refusal>) -> Calibrated<C::Design> {
        let design = self
            .first_design_job(&fitted)
            .map(|job| self.controller.redesign(&job));
        self.calibrated_answer(fitted, design.as_ref())
    }

    /// [`Self::calibrated`]'s job: the controller's first design placed from the θ of the fit's
    /// model (`None`: no model, or no θ from it — refused). A target runs the redesign and
    /// [`Self::calibrated_answer`] in frames side by side, so that the answer is not on the
    /// stack under the redesign.
    pub fn first_design_job(&self, fitted: &Result<CalibratedModel, Refusal>) -> Option<C::Job> {
        let theta = fitted.as_ref().ok()?.theta()?;
        Some(self.controller.place_job(&theta))
    }

    /// [`Self::calibrated`]'s answer from the fit and the design placed by
    /// [`Self::first_design_job`]'s job (`None` without one): the model, θ and the design, or
    /// the refusal (the fit's, or [`Refusal::Gain`] without θ or a placed design).
    pub fn calibrated_answer(
        &self,
        fitted: Result<CalibratedModel, Refusal>,
        design: Option<&C::Design>,
    ) -> Calibrated<C::Design> {
        let model = match fitted {
            Ok(m) => m,
            Err(r) => return Calibrated::Refused(r),
        };
        match (model.theta(), design) {
            (Some(theta), Some(design)) if C::placed(design) => Calibrated::Model {
                model,
                theta,
                design: *design,
            },
            _ => Calibrated::Refused(Refusal::Gain),
        }
    }

    /// One sample: reference r(k) and measurement y(k) in, drive u(k) out. Never panics.
    pub fn step(
        &self,
        state: &mut ServoState<C, I>,
        r: PositionI48F16,
        y: PositionI48F16,
    ) -> ServoOutput<I::Output> {
        self.step_with_drive(state, r, Some(y), None)
    }

    /// A sample whose position could not be read: the last position read is held
    /// (sample-and-hold), the supervisor sees [`crate::ident::status::Status::INPUT_REJECTED`] (which distrusts
    /// the model), the identifier holds θ and P. The loop goes on. Never panics.
    pub fn step_lost(
        &self,
        state: &mut ServoState<C, I>,
        r: PositionI48F16,
    ) -> ServoOutput<I::Output> {
        self.step_with_drive(state, r, None, None)
    }

    /// Shadow mode, for commissioning beside a controller already in charge: the servo computes
    /// its drive u(k) (returned, not applied), but the identifiers learn from `u_applied`, the
    /// drive the plant really received — the only input that explains y. Never panics.
    pub fn step_shadow(
        &self,
        state: &mut ServoState<C, I>,
        r: PositionI48F16,
        y: PositionI48F16,
        u_applied: SignalI16F16,
    ) -> ServoOutput<I::Output> {
        self.step_with_drive(state, r, Some(y), Some(u_applied))
    }

    fn step_with_drive(
        &self,
        state: &mut ServoState<C, I>,
        r: PositionI48F16,
        measured: Option<PositionI48F16>,
        u_applied: Option<SignalI16F16>,
    ) -> ServoOutput<I::Output> {
        if let Some(reason) = state.safety.stopped() {
            // Latched: the drive stays cut, nothing steps until the reset.
            state.k = state.k.wrapping_add(1);
            return ServoOutput {
                u: SignalI16F16::ZERO,
                region: Region::Hold,
                control: ControlFlags::NONE,
                servo: ServoFlags::SAFE_STOP,
                stop: Some(reason),
                identifier: self.identifier.reject(&mut state.identifier),
            };
        }
        let y = measured.unwrap_or(state.last_y);
        state.last_y = y;
        if let Some(cal) = &self.calibration
            && state.calibration.is_running()
        {
            return self.calibration_step(cal, state, measured, u_applied);
        }
        self.running_step(state, r, y, measured, u_applied)
    }

    /// A sample once calibration is over (or without one): the hand-over, the watch, the
    /// controller, the safety layer and the identifier. Out of line: its frame (the controller's
    /// step inlined) is not on the stack under a sample of calibration — the interrupt that
    /// lands on top of the background's fit and first design.
    #[inline(never)]
    fn running_step(
        &self,
        state: &mut ServoState<C, I>,
        r: PositionI48F16,
        y: PositionI48F16,
        measured: Option<PositionI48F16>,
        u_applied: Option<SignalI16F16>,
    ) -> ServoOutput<I::Output> {
        let mut servo = ServoFlags::NONE;
        let mut report = state.report;
        if measured.is_none() {
            report
                .status
                .insert(crate::ident::status::Status::INPUT_REJECTED);
        }
        match state.handover.due(state.k) {
            // A fit is never in flight here (it is posted and adopted while calibrating).
            HandoverEvent::Idle | HandoverEvent::Adopt(Answer::Fit(_)) => {}
            HandoverEvent::Adopt(Answer::Redesign(d)) => {
                self.controller.adopt(&mut state.controller, d);
                servo.insert(ServoFlags::REDESIGN_ADOPTED);
            }
            HandoverEvent::Missed => servo.insert(ServoFlags::HANDOVER_MISSED),
        }
        if let Some(cal) = &self.calibration
            && (state.watch.step(r.raw(), y.raw()) || core::mem::take(&mut state.recalibrate))
        {
            // The sled no longer follows the calibrated model (or the fallbacks' recovery):
            // calibrate again from here. A redesign in flight is dropped: its due sample would
            // pass during the experiment, where the hand-over is not stepped, and it would block
            // every later redesign (its late delivery is refused).
            state.calibration = CalibrationState::new();
            state.handover = Handover::new();
            return self.calibration_step(cal, state, measured, u_applied);
        }
        servo.set_if(ServoFlags::SEEK_ERROR, state.watch.seek_error());
        let input = ControlInput { r, y, report };
        let mut out = self.controller.step(&mut state.controller, &input);
        let falling_back = out.flags.contains(ControlFlags::FALLBACK);
        let entered = falling_back && !state.in_fallback;
        // The entry that would stop the loop for its fallbacks: first a recovery (calibrate
        // again; without calibration, identification suspended on the prior's design).
        let recover = entered && self.safety.fallback_recovery(&mut state.safety);
        let stop = self.safety.check(
            &mut state.safety,
            r,
            measured,
            out.u,
            out.flags.contains(ControlFlags::OUTPUT_SATURATED),
            entered && !recover,
        );
        state.in_fallback = falling_back;
        if stop.is_some() {
            out.u = SignalI16F16::ZERO;
            servo.insert(ServoFlags::SAFE_STOP);
        }
        state.watch.drive(out.u.raw());
        let u_plant = u_applied.unwrap_or(out.u);
        // Identify from motion only: at low speed the first-differenced quantisation noise
        // (negatively correlated from one difference to the next) biases the velocity pole down.
        let gate = u64::from(self.settings.min_speed_i16f16);
        let moving = y.raw().abs_diff(state.y1) >= gate && state.y1.abs_diff(state.y2) >= gate;
        (state.y2, state.y1) = (state.y1, y.raw());
        self.identifier.set_adapting(
            &mut state.identifier,
            moving && self.settings.adapt && !state.suspended,
        );
        let identified = match measured {
            Some(y) => self
                .identifier
                .identify(&mut state.identifier, &Sample { y, u: u_plant, r }),
            None => self.identifier.reject(&mut state.identifier),
        };
        state.report = I::report(&identified);
        if recover {
            if self.calibration.is_some() {
                state.recalibrate = true;
            } else {
                // The prior's design and θ again, a redesign in flight dropped, nothing learnt
                // from here (a sled whose identified models keep being distrusted).
                state.suspended = true;
                state.controller = self.controller.new_state();
                state.identifier = self.identifier.new_state();
                state.handover = Handover::new();
            }
        }
        servo.set_if(ServoFlags::IDENTIFICATION_SUSPENDED, state.suspended);
        if state.handover.is_free() && !state.suspended {
            let theta = self.identifier.theta(&state.identifier);
            if let Some(job) = self.controller.redesign_job(&mut state.controller, theta) {
                state.handover.post(
                    Work::Redesign(job),
                    state.k.wrapping_add(self.settings.latency),
                );
                state.fitting = false;
                servo.insert(ServoFlags::REDESIGN_POSTED);
            }
        }
        state.k = state.k.wrapping_add(1);
        ServoOutput {
            u: out.u,
            region: out.region,
            control: out.flags,
            servo,
            stop,
            identifier: identified,
        }
    }

    /// A sample of power-on calibration: the experiment's drive (the reference is not followed),
    /// the safety layer armed around where the experiment started, the identifier stepped without
    /// adapting, the record posted to the background, the fit adopted at its due sample.
    fn calibration_step(
        &self,
        cal: &CalibrationConfig,
        state: &mut ServoState<C, I>,
        measured: Option<PositionI48F16>,
        u_applied: Option<SignalI16F16>,
    ) -> ServoOutput<I::Output> {
        let mut servo = ServoFlags::CALIBRATING;
        match state.handover.due(state.k) {
            // A redesign is never in flight here (none is posted while calibrating, and a
            // re-calibration drops the one in flight).
            HandoverEvent::Idle | HandoverEvent::Adopt(Answer::Redesign(_)) => {}
            HandoverEvent::Adopt(Answer::Fit(Calibrated::Model {
                model,
                theta,
                design,
            })) => {
                self.identifier.seed(&mut state.identifier, theta);
                state.controller = self.controller.new_state();
                self.controller.adopt(&mut state.controller, design);
                state.calibration.finish();
                state.watch = state.watch.adopt(model);
                // The stall rule at 3× the breakaway measured on this sled (the configuration's
                // is set for every sled the prior may meet: 24× its Coulomb level).
                let [bk_pos, bk_neg] = state.calibration.record().breakaway_i16f16;
                state
                    .safety
                    .set_stall_drive(&self.safety, bk_pos.max(bk_neg).saturating_mul(3));
                state.calibrated = Some(*model);
                state.calibrations = state.calibrations.saturating_add(1);
                servo.insert(ServoFlags::REDESIGN_ADOPTED);
            }
            HandoverEvent::Adopt(&Answer::Fit(Calibrated::Refused(r))) => {
                state.calibration.refuse(r);
                self.refused(state, r);
            }
            HandoverEvent::Missed => {
                // The fit missed its sample: the record (complete, the experiment waits) is
                // posted again.
                servo.insert(ServoFlags::HANDOVER_MISSED);
                post_fit(cal, state);
            }
        }
        let (u_raw, event) = state
            .calibration
            .step(cal, measured.map(PositionI48F16::raw));
        let mut u = SignalI16F16::from_raw(u_raw);
        match event {
            calibration::experiment::Event::Recorded => post_fit(cal, state),
            calibration::experiment::Event::Refused(r) => self.refused(state, r),
            calibration::experiment::Event::None => {}
        }
        // A refusal latched above is the check's answer (a latched stop is returned as is).
        let home = PositionI48F16::from_raw(state.calibration.home());
        let stop = self
            .safety
            .check(&mut state.safety, home, measured, u, false, false);
        if stop.is_some() {
            u = SignalI16F16::ZERO;
            servo.insert(ServoFlags::SAFE_STOP);
        }
        if let Some(y) = measured {
            (state.y2, state.y1) = (state.y1, y.raw());
        }
        self.identifier.set_adapting(&mut state.identifier, false);
        let identified = match measured {
            Some(y) => self.identifier.identify(
                &mut state.identifier,
                &Sample {
                    y,
                    u: u_applied.unwrap_or(u),
                    r: y,
                },
            ),
            None => self.identifier.reject(&mut state.identifier),
        };
        state.report = I::report(&identified);
        state.k = state.k.wrapping_add(1);
        ServoOutput {
            u,
            region: Region::Hold,
            control: ControlFlags::NONE,
            servo,
            stop,
            identifier: identified,
        }
    }

    /// Calibration refused the sled for `r`. At power-on, or for what a sled does not do (stuck,
    /// reversed, out of its travel, a gain outside the range, a record that does not fit, a push
    /// that did not end in time): the stop. A re-calibration that ran out of samples after every
    /// push had ended (resting for its last, quiet start) found no fault (`calibration::watch`,
    /// "A re-calibration without a model"): the previous model stands, counted as a fruitless
    /// re-calibration, and the law resumes with its gains from a fresh signal history.
    fn refused(&self, state: &mut ServoState<C, I>, r: Refusal) {
        let complete = state.calibration.record().complete();
        match (state.calibrated, r) {
            (Some(previous), Refusal::Timeout) if complete => {
                state.calibration.finish();
                state.watch = state.watch.adopt(&previous);
                self.controller.restart(&mut state.controller);
                state.inconclusive = state.inconclusive.saturating_add(1);
            }
            _ => state.safety.latch(StopReason::Calibration(r)),
        }
    }
}

/// Posts calibration's record to the background fit, due `cal.latency()` samples from now (on
/// the record's completion, and again when the fit missed its sample).
fn post_fit<C: Controller, I: Identifier>(cal: &CalibrationConfig, state: &mut ServoState<C, I>) {
    if state
        .handover
        .post(Work::Fit, state.k.wrapping_add(cal.latency()))
    {
        state.fitting = true;
    }
}

impl<C: Controller, I: Identifier> ServoState<C, I> {
    /// The next sample's index k.
    pub fn sample_index(&self) -> u32 {
        self.k
    }

    /// The background's side of the hand-over: the job posted by a step, once.
    pub fn take_job(&mut self) -> Option<Posted<C::Job>> {
        self.handover.take_job_if(|w| match w {
            Work::Redesign(job) => Some(*job),
            Work::Fit => None,
        })
    }

    /// The background's side of the hand-over: the finished redesign for `ticket`; false when
    /// that job is no longer in flight (its due sample has passed).
    pub fn deliver(&mut self, ticket: Ticket, design: C::Design) -> bool {
        !self.fitting && self.handover.deliver(ticket, Answer::Redesign(design))
    }

    /// True while a redesign is in flight (posted, not yet due).
    pub fn redesign_in_flight(&self) -> bool {
        !self.fitting && !self.handover.is_free()
    }

    /// The controller's state.
    pub fn controller(&self) -> &C::State {
        &self.controller
    }

    /// The identifier's state.
    pub fn identifier(&self) -> &I::State {
        &self.identifier
    }

    /// The latched safe stop, if any.
    pub fn safe_stop(&self) -> Option<StopReason> {
        self.safety.stopped()
    }

    /// Power-on calibration's progress.
    pub fn calibration(&self) -> &CalibrationState {
        &self.calibration
    }

    /// Calibrations adopted since power-on (power-on's and every re-calibration).
    pub fn calibrations(&self) -> u32 {
        self.calibrations
    }

    /// Re-calibrations that ran out of samples after every push had ended, the previous model
    /// kept instead of the stop.
    pub fn inconclusive_calibrations(&self) -> u16 {
        self.inconclusive
    }

    /// What calibration found, once adopted.
    pub fn calibrated(&self) -> Option<&CalibratedModel> {
        self.calibrated.as_ref()
    }

    /// The background's side of calibration's hand-over: the record, once (a copy of the one in
    /// [`Self::calibration`], complete and unchanged while the fit is in flight).
    pub fn take_calibration_job(&mut self) -> Option<Posted<CalibrationRecord>> {
        let ticket = self.take_fit_ticket()?;
        Some(Posted {
            ticket,
            job: *self.calibration.record(),
        })
    }

    /// [`Self::take_calibration_job`] into `record` (a copy straight from the state, no
    /// temporary on the way): the ticket, or `None` (and `record` untouched) without a job.
    pub fn take_calibration_job_into(&mut self, record: &mut CalibrationRecord) -> Option<Ticket> {
        let ticket = self.take_fit_ticket()?;
        *record = *self.calibration.record();
        Some(ticket)
    }

    /// The background's side of calibration's hand-over: the answer for `ticket`.
    pub fn deliver_calibration(&mut self, ticket: Ticket, answer: Calibrated<C::Design>) -> bool {
        self.fitting && self.handover.deliver(ticket, Answer::Fit(answer))
    }

    /// The fit's job (its ticket), once.
    fn take_fit_ticket(&mut self) -> Option<Ticket> {
        let posted = self.handover.take_job_if(|w| match w {
            Work::Fit => Some(()),
            Work::Redesign(_) => None,
        })?;
        Some(posted.ticket)
    }
}

impl<C: Controller, I: Identifier> Clone for ServoState<C, I>
where
    C::State: Clone,
    I::State: Clone,
{
    fn clone(&self) -> Self {
        Self {
            k: self.k,
            controller: self.controller.clone(),
            identifier: self.identifier.clone(),
            report: self.report,
            last_y: self.last_y,
            y1: self.y1,
            y2: self.y2,
            handover: self.handover,
            fitting: self.fitting,
            safety: self.safety,
            in_fallback: self.in_fallback,
            recalibrate: self.recalibrate,
            suspended: self.suspended,
            calibration: self.calibration,
            calibrated: self.calibrated,
            calibrations: self.calibrations,
            inconclusive: self.inconclusive,
            watch: self.watch,
        }
    }
}

impl<C: Controller, I: Identifier> core::fmt::Debug for ServoState<C, I>
where
    C::State: core::fmt::Debug,
    I::State: core::fmt::Debug,
    C::Job: core::fmt::Debug,
    C::Design: core::fmt::Debug,
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ServoState")
            .field("k", &self.k)
            .field("controller", &self.controller)
            .field("identifier", &self.identifier)
            .field("handover", &self.handover)
            .finish_non_exhaustive()
    }
}

impl SledServo {
    /// The configuration from the words of [`ServoDesign::to_words`], computed on the host: every
    /// field checked as the parts' `build` functions check them (integer checks; only the two RLS
    /// designs are built from their `f64` settings, see [`crate::words`]). The decimator is the
    /// servo's fixed half-band filter.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first word that is missing, invalid or fails its check (or
    /// the first word left over), or an RLS design's error.
    pub fn from_words(words: &[u32]) -> Result<Self, ConfigError> {
        let mut slot = None;
        Self::from_words_into(words, &mut slot)?;
        slot.ok_or(ConfigError::Words { at: 0 })
    }

    /// [`Self::from_words`] into `slot` (`None` on an error), for a caller with static storage
    /// for the configuration: the controller's part, the largest, is decoded straight into it
    /// rather than into a copy on the stack.
    ///
    /// # Errors
    /// As [`Self::from_words`].
    pub fn from_words_into(words: &[u32], slot: &mut Option<Self>) -> Result<(), ConfigError> {
        *slot = None;
        let payload = crate::words::open(words)?;
        let mut r = WordReader::new(payload);
        let identifier = IdentifierConfig::take_words(&mut r)?;
        let settings = ServoSettings::take(&mut r);
        let safety = SafetyConfig::take(&mut r);
        let calibration = <Option<CalibrationConfig> as Words>::take(&mut r);
        // `insert` builds the value in the slot (`*slot = Some(…)` measured 64 B more stack).
        let _config = slot.insert(Self {
            controller: ScheduledConfig::take(&mut r),
            identifier,
            settings,
            safety,
            calibration,
        });
        let done = r
            .finish()
            .map_err(crate::words::in_frame)
            .and_then(|()| slot.as_ref().map_or(Ok(()), Self::validate));
        if done.is_err() {
            *slot = None;
        }
        done
    }

    /// Every part's invariants (the same `validate` their `build`s run).
    ///
    /// # Errors
    /// The part's [`ConfigError`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.settings.validate()?;
        self.safety.validate()?;
        if let Some(c) = &self.calibration {
            c.validate()?;
        }
        self.identifier.validate()?;
        self.controller.validate()?;
        self.check_model()
    }

    /// The controller reads θ as the identifier writes it: the same na, a Coulomb term on both
    /// or neither.
    ///
    /// # Errors
    /// [`ConfigError::CoulombTerm`] or [`ConfigError::ModelOrder`].
    fn check_model(&self) -> Result<(), ConfigError> {
        let model = self.identifier.model();
        if model.coulomb() != self.controller.model_coulomb() {
            return Err(ConfigError::CoulombTerm);
        }
        if model.na() != self.controller.model_na() {
            return Err(ConfigError::ModelOrder {
                na: self.controller.model_na(),
                nb: 1,
                n: VELOCITY_N,
            });
        }
        Ok(())
    }
}
