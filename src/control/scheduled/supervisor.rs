//! The scheduled controller's supervision types: the estimator flags that distrust the model
//! ([`DISTRUST`]), the identifier's report the supervisor reads ([`ModelReport`]) and the outcome
//! of a slow-rate redesign ([`Redesign`]). The logic is in [`super`]; what the controller reports
//! each sample (`FALLBACK` when the baseline drives) is [`crate::control::ControlFlags`].

use crate::control::placement::{Rejection, VelocityModel};
use crate::ident::status::Status;
pub use crate::ident::step::ModelReport;

/// Estimator flags that make the supervisor distrust the model.
pub const DISTRUST: Status = Status::from_bits(
    Status::COVARIANCE_SATURATED.bits()
        | Status::SATURATED.bits()
        | Status::SENSOR_STUCK.bits()
        | Status::INPUT_REJECTED.bits()
        | Status::OUTLIER.bits(),
);

/// What one redesign did.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Redesign {
    /// New gains placed for this model.
    Applied(VelocityModel),
    /// No trusted estimator update since the last design: gains kept.
    Skipped,
    /// The supervisor refused the model: the baseline runs until a model is accepted.
    Rejected(Rejection),
}
