//! The float64 twins the replay runs beside the fixed-point path ([`Reference`]): a linear model's
//! and a nonlinear model's, each with the simulation its final θ is scored by.

use sledid::ident::nonlinear::NonlinearStructure;

use crate::reference::batch::simulate;
use crate::reference::linear::LinearF64;
use crate::reference::nonlinear::{self as nl64, NonlinearF64};

/// The float64 twin run beside the fixed-point path, and the simulation its final θ is scored by.
pub(super) trait Reference<const N: usize> {
    /// One conditioned sample (y, u) in the estimator's units.
    fn step(&mut self, y: f64, u: f64);
    /// The current θ.
    fn theta(&self) -> Vec<f64>;
    /// The model at `theta` simulated from rest on `u`.
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64>;
}

/// The float64 twin of a linear model.
pub(super) struct LinearReference<const N: usize> {
    pub(super) model: LinearF64<N>,
    pub(super) na: usize,
}

impl<const N: usize> Reference<N> for LinearReference<N> {
    fn step(&mut self, y: f64, u: f64) {
        self.model.step(y, u);
    }
    fn theta(&self) -> Vec<f64> {
        self.model.theta().to_vec()
    }
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64> {
        simulate(theta, u, self.na, 1)
    }
}

/// The float64 twin of one of the paper's nonlinear models.
pub(super) struct NonlinearReference<const N: usize> {
    pub(super) model: NonlinearF64<N>,
    pub(super) structure: NonlinearStructure,
}

impl<const N: usize> Reference<N> for NonlinearReference<N> {
    fn step(&mut self, y: f64, u: f64) {
        let _ = self.model.step_forced(y, u, None);
    }
    fn theta(&self) -> Vec<f64> {
        self.model.theta().to_vec()
    }
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64> {
        nl64::simulate(self.structure, theta, u)
    }
}
