//! Per-sample status flags: every decision the per-sample path takes shows here.

/// The machinery every flag set of the crate shares (`bits`, `contains`, `insert`, `|`, a `Debug`
/// listing the set flags by name): one definition for [`Status`] and the controller's flags. The
/// type must be a tuple struct over `$repr` with an associated `NAMES: [(Self, &str); _]`.
#[macro_export]
macro_rules! flag_set_impl {
    ($name:ident, $repr:ty) => {
        impl $name {
            /// The raw bits.
            pub const fn bits(self) -> $repr {
                self.0
            }

            /// From raw bits.
            pub const fn from_bits(bits: $repr) -> Self {
                Self(bits)
            }

            /// True when every flag of `other` is set.
            pub const fn contains(self, other: Self) -> bool {
                self.0 & other.0 == other.0
            }

            /// True when any flag of `other` is set.
            pub const fn intersects(self, other: Self) -> bool {
                self.0 & other.0 != 0
            }

            /// Sets the flags of `other`.
            pub fn insert(&mut self, other: Self) {
                self.0 |= other.0;
            }

            /// Sets the flags of `other` when `cond` holds.
            pub fn set_if(&mut self, other: Self, cond: bool) {
                if cond {
                    self.0 |= other.0;
                }
            }

            /// The union.
            #[must_use]
            pub const fn union(self, other: Self) -> Self {
                Self(self.0 | other.0)
            }
        }

        impl core::ops::BitOr for $name {
            type Output = Self;
            fn bitor(self, rhs: Self) -> Self {
                self.union(rhs)
            }
        }

        impl core::ops::BitOrAssign for $name {
            fn bitor_assign(&mut self, rhs: Self) {
                self.insert(rhs);
            }
        }

        impl core::fmt::Debug for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                let mut first = true;
                f.write_str(concat!(stringify!($name), "("))?;
                for (flag, name) in Self::NAMES {
                    if self.contains(flag) {
                        if !first {
                            f.write_str("|")?;
                        }
                        f.write_str(name)?;
                        first = false;
                    }
                }
                f.write_str(")")
            }
        }
    };
}

/// A set of status flags returned by every per-sample update.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status(u16);

impl Status {
    /// No flag.
    pub const NONE: Self = Self(0);
    /// The parameters and covariance were updated this sample.
    pub const UPDATED: Self = Self(1 << 0);
    /// Update skipped: |ε| within the dead zone (quantisation / limit cycle).
    pub const DEAD_ZONE: Self = Self(1 << 1);
    /// Update skipped: φᵀPφ below the excitation threshold (or a zero regressor).
    pub const LOW_EXCITATION: Self = Self(1 << 2);
    /// Update skipped: the estimator is on hold (disabled by the user).
    pub const HELD: Self = Self(1 << 3);
    /// The covariance was scaled down by the trace / diagonal limit (anti-windup acted).
    pub const COVARIANCE_BOUNDED: Self = Self(1 << 4);
    /// A covariance factor reached its exponent limit (the covariance has wound up beyond use).
    pub const COVARIANCE_SATURATED: Self = Self(1 << 5);
    /// A fixed-point quantity saturated (θ, U, a gain, ŷ or ε).
    pub const SATURATED: Self = Self(1 << 6);
    /// The stability projection rejected or shortened the parameter step.
    pub const PROJECTED: Self = Self(1 << 7);
    /// The estimator was reset this sample.
    pub const RESET: Self = Self(1 << 8);
    /// The input sample was rejected at the boundary (NaN, out of range) and replaced.
    pub const INPUT_REJECTED: Self = Self(1 << 9);
    /// The constant-trace regularisation rescaled the covariance.
    pub const TRACE_NORMALISED: Self = Self(1 << 10);
    /// No model step this sample: the conditioning stage is priming (first sample of a differenced
    /// stream).
    pub const WARMUP: Self = Self(1 << 11);
    /// Update skipped (or, after too many in a row, accepted) because |ε| exceeded the outlier gate.
    pub const OUTLIER: Self = Self(1 << 12);
    /// The position sensor looks stuck (no change while driven): the estimator is held.
    pub const SENSOR_STUCK: Self = Self(1 << 13);
    /// A nonlinear model's sensitivity filter left the stability region: the gradient was filtered
    /// by the (projected) linear denominator alone this sample.
    pub const GRADIENT_LIMITED: Self = Self(1 << 14);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 15] = [
        (Self::UPDATED, "updated"),
        (Self::DEAD_ZONE, "dead_zone"),
        (Self::LOW_EXCITATION, "low_excitation"),
        (Self::HELD, "held"),
        (Self::COVARIANCE_BOUNDED, "covariance_bounded"),
        (Self::COVARIANCE_SATURATED, "covariance_saturated"),
        (Self::SATURATED, "saturated"),
        (Self::PROJECTED, "projected"),
        (Self::RESET, "reset"),
        (Self::INPUT_REJECTED, "input_rejected"),
        (Self::TRACE_NORMALISED, "trace_normalised"),
        (Self::WARMUP, "warmup"),
        (Self::OUTLIER, "outlier"),
        (Self::SENSOR_STUCK, "sensor_stuck"),
        (Self::GRADIENT_LIMITED, "gradient_limited"),
    ];
}

flag_set_impl!(Status, u16);
