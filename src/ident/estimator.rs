//! What the per-sample step needs from a model estimator, so one [`crate::ident::step::step`] drives the
//! linear models ([`crate::ident::linear`], eq. 1–2) and the paper's nonlinear ones ([`crate::ident::nonlinear`],
//! eq. 5–7, Wiener, friction feedback) alike.
//!
//! Every estimator follows the crate's split: a `…Design` in engineering units builds a validated,
//! quantised configuration (`&self` in the per-sample call) and a state it mutates.

use crate::error::ConfigError;
use crate::ident::status::Status;
use crate::num::fixed::{ParamI12F20, SignalI16F16};

/// What one sample of estimation produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// The a priori prediction (ARX), or the simulated output (OE, nonlinear models), ŷ(t) = φ(t)ᵀθ(t−1).
    pub y_hat: SignalI16F16,
    /// ε(t) = y(t) − ŷ(t).
    pub eps: SignalI16F16,
    /// What the estimator did.
    pub status: Status,
}

/// A validated model estimator with N parameters.
pub trait Estimator<const N: usize> {
    /// Everything one sample mutates.
    type State;

    /// A fresh state at the configured initial parameters.
    fn new_state(&self) -> Self::State;

    /// One sample of conditioned output y(t) and input u(t): ŷ(t), ε(t), the update, the flags.
    /// Never panics.
    fn step(&self, state: &mut Self::State, y: SignalI16F16, u: SignalI16F16) -> Estimate;

    /// The current estimate θ.
    fn theta<'a>(&self, state: &'a Self::State) -> &'a [ParamI12F20; N];

    /// Whether the estimator's covariance P is still positive definite (for the UD-factored RLS
    /// of [`crate::ident::rls`]: every dⱼ > 0), the invariant the fuzz target checks after every
    /// sample. An estimator without a covariance returns `true`.
    fn covariance_positive_definite(&self, state: &Self::State) -> bool;

    /// Holds (false) or enables (true) adaptation.
    fn set_enabled(&self, state: &mut Self::State, enabled: bool);

    /// Restarts the estimate from `theta` with P = p₀·I (a model known from elsewhere, e.g. the
    /// servo's power-on calibration); the signal history and the enable state are kept.
    fn seed(&self, state: &mut Self::State, theta: &[ParamI12F20; N]);
}

/// User-facing settings of a model estimator: validate and quantise into an [`Estimator`].
pub trait EstimatorDesign<const N: usize> {
    /// The validated configuration.
    type Config: Estimator<N>;

    /// Validates and quantises.
    ///
    /// # Errors
    /// A [`ConfigError`] naming the parameter that is out of range.
    fn build(&self) -> Result<Self::Config, ConfigError>;
}
