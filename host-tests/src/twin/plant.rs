//! The sled plant: a mass with viscous, Coulomb and static friction driven by a saturating
//! amplifier, integrated exactly between events.
//!
//! # Model
//! With the drive force `F = k_f · sat(u)` held constant over a sample (zero-order hold):
//! ```text
//! moving (v ≠ 0):  m·dv/dt = F − b·v − F_c·sign(v)
//! at rest (v = 0): stays at rest while |F| ≤ F_s, otherwise starts moving in the direction of F
//! ```
//! This is Karnopp's stick/slip model. Between events (the drive changing at a sample instant,
//! the velocity reaching zero) the force is constant and the motion is an exact exponential, so
//! the plant is integrated in closed form rather than with fixed sub-steps: the instant the
//! velocity reaches zero is solved for, the sled is stopped exactly there, and the stick
//! condition decides whether it stays stuck or starts the other way. The velocity cannot chatter
//! around zero and no sub-step size has to be chosen. Within one hold interval there are at most
//! three phases (moving, stopped, moving the other way) because after a reversal the drive
//! exceeds the breakaway force and the sled accelerates.
//!
//! For a phase of length `t` with net force `F_d = F − F_c·s` (`s` the direction of motion),
//! `a₀ = (F_d − b·v₀)/m` and `z = b·t/m`:
//! ```text
//! v(t) = v₀ + a₀·t·φ₁(z),     φ₁(z) = (1 − e^{−z})/z
//! x(t) = x₀ + v₀·t + a₀·t²·φ₂(z),  φ₂(z) = (z − 1 + e^{−z})/z²
//! ```
//! which stays accurate for `b → 0`. A decelerating phase (`s·F_d < 0`) reaches zero velocity at
//! `t₀ = (m·|v₀|/|F_d|) · ln(1 + w)/w` with `w = b·|v₀|/|F_d|`.

use super::params::PlantParams;

/// The sled's mechanical state and physical constants; see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct SledPlant {
    /// Moving mass, kg.
    mass_kg: f64,
    /// Drive force per volt, N/V.
    force_per_volt_n_per_v: f64,
    /// Viscous friction, N·s/m.
    viscous_n_s_per_m: f64,
    /// Coulomb friction, N.
    coulomb_n: f64,
    /// Static friction, N.
    static_n: f64,
    /// Amplifier saturation, V.
    u_max_v: f64,
    /// True position, m.
    position_m: f64,
    /// True velocity, m/s; exactly 0 while the sled sticks.
    velocity_m_per_s: f64,
}

/// A hold interval has at most three phases (see the module documentation); one spare.
const MAX_PHASES_PER_HOLD: usize = 4;

/// Below this `z = b·t/m` the series expansions of φ₁ and φ₂ are used.
const SERIES_THRESHOLD: f64 = 1e-4;

impl SledPlant {
    /// Changes the moving mass (a plant change for fault tests), kg; ignored unless finite and > 0.
    pub fn set_mass_kg(&mut self, mass_kg: f64) {
        if mass_kg.is_finite() && mass_kg > 0.0 {
            self.mass_kg = mass_kg;
        }
    }

    /// Scales the moving mass by `factor` (a plant change); ignored unless finite and > 0.
    pub fn scale_mass(&mut self, factor: f64) {
        self.set_mass_kg(self.mass_kg * factor);
    }

    /// Scales Coulomb and static friction by `factor` (a plant change); ignored unless finite, ≥ 0.
    pub fn scale_friction(&mut self, factor: f64) {
        if factor.is_finite() && factor >= 0.0 {
            self.coulomb_n *= factor;
            self.static_n *= factor;
        }
    }

    /// Changes the amplifier saturation, V (an actuator fault); ignored unless finite and > 0.
    pub fn set_u_max_v(&mut self, u_max_v: f64) {
        if u_max_v.is_finite() && u_max_v > 0.0 {
            self.u_max_v = u_max_v;
        }
    }

    /// The moving mass, kg.
    pub fn mass_kg(&self) -> f64 {
        self.mass_kg
    }

    /// A sled at rest at position 0, with the constants of `params` (assumed validated).
    pub fn new(params: &PlantParams) -> Self {
        Self {
            mass_kg: params.mass_kg,
            force_per_volt_n_per_v: params.force_per_volt_n_per_v,
            viscous_n_s_per_m: params.viscous_n_s_per_m,
            coulomb_n: params.coulomb_n,
            static_n: params.static_n,
            u_max_v: params.u_max_v,
            position_m: 0.0,
            velocity_m_per_s: 0.0,
        }
    }

    /// Puts the sled at rest at `position_m`.
    pub fn reset(&mut self, position_m: f64) {
        self.position_m = position_m;
        self.velocity_m_per_s = 0.0;
    }

    /// True position, m.
    pub fn position_m(&self) -> f64 {
        self.position_m
    }

    /// True velocity, m/s.
    pub fn velocity_m_per_s(&self) -> f64 {
        self.velocity_m_per_s
    }

    /// Whether the sled is at rest (held by static friction unless the drive breaks it loose).
    pub fn is_at_rest(&self) -> bool {
        self.velocity_m_per_s == 0.0
    }

    /// The voltage the amplifier actually applies for a commanded `u_v`: clamped to ±`u_max_v`;
    /// a NaN command applies 0 V.
    pub fn saturate_v(&self, u_v: f64) -> f64 {
        if u_v.is_nan() {
            0.0
        } else {
            u_v.clamp(-self.u_max_v, self.u_max_v)
        }
    }

    /// Holds the command `u_v` for `duration_s` and advances the sled; returns the applied
    /// (saturated) voltage.
    pub fn advance(&mut self, u_v: f64, duration_s: f64) -> f64 {
        let applied_v = self.saturate_v(u_v);
        let drive_n = self.force_per_volt_n_per_v * applied_v;
        let mut remaining_s = duration_s;
        for _ in 0..MAX_PHASES_PER_HOLD {
            if remaining_s <= 0.0 {
                break;
            }
            let direction = if self.velocity_m_per_s == 0.0 {
                if drive_n.abs() <= self.static_n {
                    break; // stuck for the rest of the hold
                }
                drive_n.signum()
            } else {
                self.velocity_m_per_s.signum()
            };
            let net_n = drive_n - self.coulomb_n * direction;
            if direction * net_n < 0.0 {
                let stop_s = self.time_to_stop_s(net_n);
                if stop_s < remaining_s {
                    self.move_for(net_n, stop_s);
                    self.velocity_m_per_s = 0.0;
                    remaining_s -= stop_s;
                    continue;
                }
            }
            self.move_for(net_n, remaining_s);
            if self.velocity_m_per_s * direction <= 0.0 {
                // Rounding at the very end of a decelerating phase: the sled has stopped.
                self.velocity_m_per_s = 0.0;
            }
            remaining_s = 0.0;
        }
        applied_v
    }

    /// Time until the velocity reaches zero under the constant net force `net_n` opposing it.
    fn time_to_stop_s(&self, net_n: f64) -> f64 {
        let speed = self.velocity_m_per_s.abs();
        let opposing_n = net_n.abs();
        let w = self.viscous_n_s_per_m * speed / opposing_n;
        let ln1p_over_w = if w < SERIES_THRESHOLD {
            1.0 - w / 2.0 + w * w / 3.0
        } else {
            w.ln_1p() / w
        };
        self.mass_kg * speed / opposing_n * ln1p_over_w
    }

    /// Moves for `duration_s` under the constant net force `net_n` (drive minus Coulomb) and
    /// the viscous friction, with the exact solution.
    fn move_for(&mut self, net_n: f64, duration_s: f64) {
        let v0 = self.velocity_m_per_s;
        let a0 = (net_n - self.viscous_n_s_per_m * v0) / self.mass_kg;
        let z = self.viscous_n_s_per_m * duration_s / self.mass_kg;
        let (phi1, phi2) = if z < SERIES_THRESHOLD {
            (1.0 - z / 2.0 + z * z / 6.0, 0.5 - z / 6.0 + z * z / 24.0)
        } else {
            let em1 = (-z).exp_m1();
            (-em1 / z, (z + em1) / (z * z))
        };
        self.position_m += v0 * duration_s + a0 * duration_s * duration_s * phi2;
        self.velocity_m_per_s = v0 + a0 * duration_s * phi1;
    }
}
