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

pub mod control;
pub mod error;
pub mod ident;
pub mod num;
pub mod servo;
pub mod words;

pub use error::{BoundaryError, ConfigError};
pub use ident::status::Status;
pub use num::boundary::{Normalisation, PositionI48F16, Sample, Scaling};
pub use num::fixed::{ParamI12F20, SignalI16F16};
