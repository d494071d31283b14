//! The scheduled controller's reporting and supervision types: the per-sample flags
//! ([`ScheduledFlags`], with [`ScheduledFlags::FALLBACK`] saying when the baseline drives), the
//! identifier's report the supervisor reads ([`ModelReport`], [`DISTRUST`]) and the outcome of a
//! slow-rate redesign ([`Redesign`]). The logic is in [`super`].

use crate::control::placement::{Rejection, VelocityModel};
use crate::ident::status::Status;
use crate::num::fixed::SignalI16F16;

/// What the scheduled controller did in one sample.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScheduledFlags(u16);

impl ScheduledFlags {
    /// No flag.
    pub const NONE: Self = Self(0);
    /// The output was clamped to ±u_max.
    pub const OUTPUT_SATURATED: Self = Self(1 << 0);
    /// The integrator reached ±I_max.
    pub const INTEGRATOR_LIMITED: Self = Self(1 << 1);
    /// Conditional integration held the integrator.
    pub const INTEGRATION_HELD: Self = Self(1 << 2);
    /// A fixed-point narrowing saturated.
    pub const ARITHMETIC_SATURATED: Self = Self(1 << 3);
    /// The baseline PID drives the sled: the model is not trusted.
    pub const FALLBACK: Self = Self(1 << 4);
    /// The region changed this sample.
    pub const REGION_CHANGED: Self = Self(1 << 5);
    /// A transfer could not be bumpless (integrator clamp).
    pub const TRANSFER_LIMITED: Self = Self(1 << 6);
    /// The first sample after `new`/`reset` (histories primed).
    pub const FIRST_SAMPLE: Self = Self(1 << 7);
    /// The supervisor distrusts the estimator this sample (flags or prediction error).
    pub const MODEL_UNTRUSTED: Self = Self(1 << 8);
    /// Seek → Settle: a redesign is due ([`ScheduledConfig::redesign`](super::ScheduledConfig::redesign), slow rate).
    pub const REDESIGN_REQUESTED: Self = Self(1 << 9);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 10] = [
        (Self::OUTPUT_SATURATED, "output_saturated"),
        (Self::INTEGRATOR_LIMITED, "integrator_limited"),
        (Self::INTEGRATION_HELD, "integration_held"),
        (Self::ARITHMETIC_SATURATED, "arithmetic_saturated"),
        (Self::FALLBACK, "fallback"),
        (Self::REGION_CHANGED, "region_changed"),
        (Self::TRANSFER_LIMITED, "transfer_limited"),
        (Self::FIRST_SAMPLE, "first_sample"),
        (Self::MODEL_UNTRUSTED, "model_untrusted"),
        (Self::REDESIGN_REQUESTED, "redesign_requested"),
    ];
}

crate::flag_set_impl!(ScheduledFlags, u16);

/// Estimator flags that make the supervisor distrust the model.
pub const DISTRUST: Status = Status::from_bits(
    Status::COVARIANCE_SATURATED.bits()
        | Status::SATURATED.bits()
        | Status::SENSOR_STUCK.bits()
        | Status::INPUT_REJECTED.bits()
        | Status::OUTLIER.bits(),
);

/// What the identifier reported this sample (from [`crate::ident::step::StepOutput`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelReport {
    /// The estimator's flags.
    pub status: Status,
    /// Its prediction error ε, quanta per sample.
    pub eps: SignalI16F16,
}

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
