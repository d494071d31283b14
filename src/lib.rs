//! `sledid`: on-line identification of a CD player's position sled, in fixed point, for
//! microcontrollers — and the per-sample step that the firmware, the host replay and the tests share.
//!
//! The problem and the models come from *Nonlinear Identification of the Position Sled Dynamics of a
//! CD Player* (closed-loop step-response data, Ts = 0.455 ms, coarse position quantisation). See the
//! module docs for the equations each implements.
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

pub mod boundary;
pub mod conditioning;
pub mod control;
pub mod decimate;
pub mod dyadic;
pub mod error;
pub mod estimator;
pub mod fixed;
pub mod linear;
pub mod neuron;
pub mod nonlinear;
pub mod regressor;
pub mod rls;
pub mod sled_loop;
pub mod stability;
pub mod status;
pub mod step;
pub mod wide;
pub mod words;

pub use boundary::{PositionI48F16, Sample, Scaling};
pub use error::{BoundaryError, ConfigError};
pub use fixed::{ParamI12F20, SignalI16F16};
pub use status::Status;
