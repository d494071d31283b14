//! Float64 reference implementations of every estimator in the library, written the textbook way,
//! so the fixed-point path has something exact to be measured against.
//!
//! - [`rls::RlsF64`]: the covariance-form RLS `P ← (P − K ψᵀP)/λ`, re-symmetrised every update, with
//!   the same gates (dead zone, excitation, hold) and covariance limits as [`sledid::ident::rls`].
//! - [`linear::LinearF64`]: ARX / OE (pseudo-linear and prediction-error) with the same regressors,
//!   the same a-priori/a-posteriori convention and the same stability projection as [`sledid::ident::linear`].
//! - [`nonlinear::NonlinearF64`]: the paper's nonlinear models (eq. 5–7, Wiener, friction feedback)
//!   recursively, mirroring [`sledid::ident::nonlinear`]; [`nonlinear_batch`]: their Levenberg–Marquardt
//!   fit on the simulation error.
//! - [`scheduled::ScheduledF64`]: the gain-scheduled controller (regions, supervisor, transfers,
//!   pole placement, exact inverse input map) against which `sledid::control::scheduled` is measured.
//! - [`units`]: a model identified in normalised units ([`sledid::Normalisation`]) mapped to the
//!   user's units and back, exactly.
//! - [`batch`]: batch least squares and simulation of a linear model (the exact optimum and the
//!   simulation RMS reported by the study).

pub mod batch;
pub mod calibration;
pub mod control;
pub mod decimate;
pub mod health;
pub mod linear;
pub mod neuron;
pub mod nonlinear;
pub mod nonlinear_batch;
pub mod rls;
pub mod scheduled;
pub mod seek;
pub mod seek_gain;
pub mod units;
