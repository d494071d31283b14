//! The per-sample step: the one function the firmware's timer interrupt, the host replay, the
//! closed-loop twin and the tests all call, so what is tested is what runs.
//!
//! `step(config, state, sample) → StepOutput`: condition the raw sample (centre on the reference or
//! difference, [`crate::regressor::Conditioning`]), run the identifier (ARX or OE, [`crate::linear`]),
//! and report ŷ, ε, θ and the status flags. Never panics, never returns an error.

use crate::boundary::Sample;
use crate::conditioning::{Conditioning, ConditioningState};
use crate::error::ConfigError;
use crate::fixed::{ParamI12F20, SignalI16F16};
use crate::linear::{LinearConfig, LinearDesign, LinearState};
use crate::status::Status;

/// User-facing settings of the identifier.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifierDesign<const N: usize> {
    /// How raw samples are conditioned.
    pub conditioning: Conditioning,
    /// The linear model estimator.
    pub model: LinearDesign<N>,
}

impl<const N: usize> IdentifierDesign<N> {
    /// Validates and quantises.
    ///
    /// # Errors
    /// The model's [`ConfigError`].
    pub fn build(&self) -> Result<IdentifierConfig<N>, ConfigError> {
        Ok(IdentifierConfig {
            conditioning: self.conditioning,
            model: self.model.build()?,
        })
    }
}

/// Validated identifier configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentifierConfig<const N: usize> {
    conditioning: Conditioning,
    model: LinearConfig<N>,
}

/// Everything the identifier mutates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IdentifierState<const N: usize> {
    conditioning: ConditioningState,
    model: LinearState<N>,
}

/// What one step produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepOutput<const N: usize> {
    /// Conditioned output y_c(t) (y − r, Δy or y).
    pub y: SignalI16F16,
    /// Conditioned input u_c(t).
    pub u: SignalI16F16,
    /// ŷ(t), in the conditioned coordinates.
    pub y_hat: SignalI16F16,
    /// ε(t) = y_c(t) − ŷ(t).
    pub eps: SignalI16F16,
    /// θ after this sample.
    pub theta: [ParamI12F20; N],
    /// What happened.
    pub status: Status,
}

impl<const N: usize> IdentifierConfig<N> {
    /// A fresh state.
    pub fn new_state(&self) -> IdentifierState<N> {
        IdentifierState {
            conditioning: ConditioningState::default(),
            model: self.model.new_state(),
        }
    }

    /// The model configuration.
    pub fn model(&self) -> &LinearConfig<N> {
        &self.model
    }

    /// The conditioning.
    pub fn conditioning(&self) -> Conditioning {
        self.conditioning
    }
}

impl<const N: usize> IdentifierState<N> {
    /// The model estimator's state.
    pub fn model(&self) -> &LinearState<N> {
        &self.model
    }

    /// Holds (false) or enables (true) adaptation.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.model.set_enabled(enabled);
    }
}

/// One sample through the identifier. Never panics.
pub fn step<const N: usize>(
    config: &IdentifierConfig<N>,
    state: &mut IdentifierState<N>,
    sample: &Sample,
) -> StepOutput<N> {
    let mut sat = false;
    let Some((y, u)) = config
        .conditioning
        .apply(&mut state.conditioning, sample, &mut sat)
    else {
        return StepOutput {
            y: SignalI16F16::ZERO,
            u: SignalI16F16::ZERO,
            y_hat: SignalI16F16::ZERO,
            eps: SignalI16F16::ZERO,
            theta: *state.model.theta(),
            status: Status::WARMUP,
        };
    };
    let est = config.model.step(&mut state.model, y, u);
    let mut status = est.status;
    status.set_if(Status::SATURATED, sat);
    StepOutput {
        y,
        u,
        y_hat: est.y_hat,
        eps: est.eps,
        theta: *state.model.theta(),
        status,
    }
}
