//! The per-sample flags every [`super::Controller`] reports.

/// What a controller did in one sample (the bits a law does not use stay clear).
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ControlFlags(u16);

impl ControlFlags {
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
    /// Seek → Settle: a redesign is due (the servo hands the job to the background).
    pub const REDESIGN_REQUESTED: Self = Self(1 << 9);

    /// Settle: a fine step toward the target cell (at rest near the band's edge).
    pub const FINE_STEP: Self = Self(1 << 10);
    /// Settle: coasting into the band, damping only.
    pub const COASTING: Self = Self(1 << 11);
    /// A fine step's reading toward the target restarted the integrator
    /// (`scheduled::rest`: the sled broke away; the settle law brakes it).
    pub const INTEGRATOR_RESTARTED: Self = Self(1 << 12);
    /// Settle, coasting: this reading is a still sled's flicker, or (reference-following) a slow
    /// sled's return after a kick — not motion; nothing damps (`scheduled::rest`, "A resting
    /// sled's flicker", "A kick's return").
    pub const FLICKER: Self = Self(1 << 13);
    /// A pulsed fine step's off-sample (a sticky seek plan, or a sled whose breakaway has
    /// thrown it past the target): nothing drives, the integrator runs on (`scheduled`,
    /// "Settle of a time-optimal seek"; `scheduled::rest`, "A sticking sled's breakaway").
    pub const PULSE_OFF: Self = Self(1 << 14);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 15] = [
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
        (Self::FINE_STEP, "fine_step"),
        (Self::COASTING, "coasting"),
        (Self::INTEGRATOR_RESTARTED, "integrator_restarted"),
        (Self::FLICKER, "flicker"),
        (Self::PULSE_OFF, "pulse_off"),
    ];
}

crate::flag_set_impl!(ControlFlags, u16);
