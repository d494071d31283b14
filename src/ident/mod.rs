//! On-line identification.

pub mod conditioning;
pub mod decimate;
pub mod estimator;
pub mod linear;
pub mod neuron;
pub mod nonlinear;
pub(crate) mod regressor;
pub mod rls;
pub mod stability;
pub mod status;
pub mod step;
