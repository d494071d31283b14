//! Position control of the sled in fixed point: the paper's loop (Section 3, Figure 2) closed by
//! the baseline PID/lead, and the gain-scheduled controller the paper's conclusion asks for
//! ("different models, and then also different controllers, at different parts of a step
//! response", §6), its gains placed from the identified model.
//!
//! | module | what |
//! |---|---|
//! | [`pid`] | the baseline PID/lead: law, formats, accuracy |
//! | [`integrator`] | conditional integration (the anti-windup every integrating law shares) |
//! | [`placement`] | slow-rate design: identified θ → velocity model → pole placement (f32, `libm`) |
//! | [`compensation`] | inverse of a Hammerstein input map (the paper's tanh neuron), as a table |
//! | [`seek`] | time-optimal seeks: the braking curve of the identified model and the PTOS law |
//! | [`scheduled`] | the scheduled law: [`scheduled::regions`] (seek / settle / hold), transfers, [`scheduled::supervisor`] and fallback |
//! | [`flags`] | what a controller reports each sample |
//!
//! # The seam: [`Controller`]
//! Every law the servo ([`crate::servo`]) can run implements [`Controller`]: a validated,
//! immutable configuration (`&self`) stepped once per sample on its own state, plus an optional
//! slow-rate redesign that the servo runs in the background and hands over at a fixed sample
//! (`redesign_job` → `redesign` → `adopt`). A new controller is a new module here and an impl of
//! the trait; the servo does not change.

#![deny(clippy::float_arithmetic)]

pub mod compensation;
pub mod flags;
pub mod integrator;
pub mod pid;
pub mod placement;
pub mod scheduled;
pub mod seek;

pub use compensation::InverseInputMap;
pub use flags::ControlFlags;
pub use pid::{DerivativeOn, PidConfig, PidDesign, PidFlags, PidOutput, PidState};
pub use placement::{ModelGains, PlacementDesign, Rejection, SupervisorDesign, VelocityModel};
pub use scheduled::regions::{Region, RegionDesign, RegionSelector};
pub use scheduled::supervisor::{DISTRUST, ModelReport, Redesign};
pub use scheduled::{ScheduledConfig, ScheduledDesign, ScheduledState, SeekMode};
pub use seek::{BrakingCurve, SeekPlan, TimeOptimalDesign};

/// Controller design errors are the library's [`ConfigError`] (one enum names every parameter).
pub use crate::error::ConfigError;

use crate::num::boundary::PositionI48F16;
use crate::num::fixed::{ParamI12F20, SignalI16F16};

/// What a controller sees in one sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ControlInput {
    /// The reference r(k), quanta.
    pub r: PositionI48F16,
    /// The measured position y(k), quanta.
    pub y: PositionI48F16,
    /// The identifier's report of the previous sample (what the supervisor judges the model by).
    pub report: ModelReport,
}

/// The result of one controller step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControlOutput {
    /// The drive, fraction of full scale, |u| ≤ u_max.
    pub u: SignalI16F16,
    /// The part of the step response the law is in (a law without regions reports `Seek`).
    pub region: Region,
    /// What happened.
    pub flags: ControlFlags,
}

/// A position control law the servo can run: configuration immutable at run time, everything the
/// loop changes (histories, integrators, latches, the gains in use) in [`Controller::State`].
pub trait Controller {
    /// Everything one sample, or an adopted redesign, mutates.
    type State;
    /// What a slow-rate redesign needs, copied out of the state when it is requested.
    type Job: Copy;
    /// What a redesign produces, handed back to [`Controller::adopt`].
    type Design: Copy;

    /// A fresh state (the prior's gains, if any).
    fn new_state(&self) -> Self::State;

    /// One sample. The only data path; never panics; |u| ≤ u_max for every input.
    fn step(&self, state: &mut Self::State, input: &ControlInput) -> ControlOutput;

    /// After a step: the redesign job if the law asks for one now (the request is then cleared),
    /// from the identifier's current estimate θ.
    fn redesign_job(&self, state: &mut Self::State, theta: &[ParamI12F20]) -> Option<Self::Job>;

    /// The redesign itself: a pure function of the configuration and the job, run outside the
    /// sample interrupt (it may take many sample periods).
    fn redesign(&self, job: &Self::Job) -> Self::Design;

    /// Applies a finished redesign at its hand-over sample.
    fn adopt(&self, state: &mut Self::State, design: &Self::Design);

    /// The job that places gains from `theta` whatever the supervisor's record (the servo's
    /// power-on calibration: a model measured by an experiment, not learnt on-line).
    fn place_job(&self, theta: &[ParamI12F20]) -> Self::Job;

    /// Whether a finished redesign placed gains (a refused model is not adopted as calibrated).
    fn placed(design: &Self::Design) -> bool;

    /// The loop was interrupted (a re-calibration that ended without a new model): the signal
    /// history is forgotten — the next sample primes the law as the first one did — and the
    /// gains in use are kept. The default does nothing (a law without history).
    fn restart(&self, _state: &mut Self::State) {}
}
