//! A seeded family of sleds around the nominal one, wide enough for real drives: what the servo is
//! developed and judged on, instead of a few hand-picked variants.
//!
//! Each plant scales the nominal sled ([`PlantParams::default`]) by factors drawn independently
//! from a ChaCha8 stream of the family's seed (plant `i` uses stream `i`, so plant `i` is the same
//! whatever the family's size):
//!
//! | factor | range | draw | what it scales |
//! |---|---|---|---|
//! | mass | 0.5–6 × | log-uniform | `mass_kg` |
//! | viscous friction | 0.5–25 × | log-uniform | `viscous_n_s_per_m` (the motor's back-EMF damping) |
//! | force constant | 0.5–2.5 × | log-uniform | `force_per_volt_n_per_v` |
//! | Coulomb friction | 0–2 × | uniform | `coulomb_n` |
//! | stiction | 1.2–3 × Coulomb | uniform | `static_n` (of the plant's own Coulomb friction; at least the nominal ratio's floor when Coulomb is 0) |
//! | quantum | 0.5–2 × | log-uniform | `quantum_m` |
//! | sensor noise | 0–0.1 quantum | uniform | `noise_m` (of the plant's own quantum) |
//!
//! The sampling period and the drive's rail stay nominal. The baseline controller of every plant
//! is the paper's loop ([`crate::twin::PidParams::default`]), the same gains on every sled.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::twin::{PlantParams, TwinParams};

/// The factors of one plant of the family, relative to the nominal sled.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PlantFactors {
    /// Mass factor.
    pub mass: f64,
    /// Viscous friction factor.
    pub viscous: f64,
    /// Force-constant factor.
    pub force: f64,
    /// Coulomb friction factor.
    pub coulomb: f64,
    /// Static friction as a multiple of the plant's Coulomb friction.
    pub stiction_ratio: f64,
    /// Quantum factor.
    pub quantum: f64,
    /// Sensor noise, standard deviation in quanta of this plant.
    pub noise_quanta: f64,
}

/// A corner of the family ([`FamilyRanges::corner`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corner {
    /// The fastest sled in quanta, with the most friction and noise.
    FastSticky,
    /// The fastest sled in quanta, without Coulomb friction or noise.
    FastFree,
    /// The slowest sled in quanta, with the most friction and noise.
    SlowSticky,
    /// The slowest sled in quanta, without Coulomb friction or noise.
    SlowFree,
}

impl Corner {
    /// Every corner.
    pub const ALL: [Self; 4] = [
        Self::FastSticky,
        Self::FastFree,
        Self::SlowSticky,
        Self::SlowFree,
    ];

    /// `fast-sticky`, `fast-free`, `slow-sticky`, `slow-free`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::FastSticky => "fast-sticky",
            Self::FastFree => "fast-free",
            Self::SlowSticky => "slow-sticky",
            Self::SlowFree => "slow-free",
        }
    }
}

/// The ranges of the family (the module table).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FamilyRanges {
    /// Mass factor, log-uniform.
    pub mass: (f64, f64),
    /// Viscous friction factor, log-uniform.
    pub viscous: (f64, f64),
    /// Force-constant factor, log-uniform.
    pub force: (f64, f64),
    /// Coulomb friction factor, uniform.
    pub coulomb: (f64, f64),
    /// Stiction over Coulomb, uniform.
    pub stiction_ratio: (f64, f64),
    /// Quantum factor, log-uniform.
    pub quantum: (f64, f64),
    /// Sensor noise in quanta, uniform.
    pub noise_quanta: (f64, f64),
}

impl Default for FamilyRanges {
    fn default() -> Self {
        Self {
            mass: (0.5, 6.0),
            viscous: (0.5, 25.0),
            force: (0.5, 2.5),
            coulomb: (0.0, 2.0),
            stiction_ratio: (1.2, 3.0),
            quantum: (0.5, 2.0),
            noise_quanta: (0.0, 0.1),
        }
    }
}

impl FamilyRanges {
    /// The wider family of issue 22: every range doubled at both ends on a log scale (mass
    /// 0.25–12, viscous 0.25–50, force 0.25–5, quantum 0.25–4 ×), Coulomb friction 0–4 ×,
    /// stiction 1.2–6 × Coulomb, noise 0–0.2 quantum — where the servo is not expected to work,
    /// only to say so (a refusal or a stop, never an unflagged failure).
    pub fn wide() -> Self {
        Self {
            mass: (0.25, 12.0),
            viscous: (0.25, 50.0),
            force: (0.25, 5.0),
            coulomb: (0.0, 4.0),
            stiction_ratio: (1.2, 6.0),
            quantum: (0.25, 4.0),
            noise_quanta: (0.0, 0.2),
        }
    }

    /// The factors of `corner` of the family: every factor at the end of its range that makes the
    /// sled fastest or slowest in quanta (force over mass and quantum; the least or the most
    /// viscous damping), with the most friction (Coulomb and stiction at their maxima, the most
    /// sensor noise) or none (Coulomb 0, the lowest stiction, no noise).
    pub fn corner(&self, corner: Corner) -> PlantFactors {
        let (fast, sticky) = match corner {
            Corner::FastSticky => (true, true),
            Corner::FastFree => (true, false),
            Corner::SlowSticky => (false, true),
            Corner::SlowFree => (false, false),
        };
        let end = |(lo, hi): (f64, f64), high: bool| if high { hi } else { lo };
        PlantFactors {
            mass: end(self.mass, !fast),
            viscous: end(self.viscous, !fast),
            force: end(self.force, fast),
            coulomb: end(self.coulomb, sticky),
            stiction_ratio: end(self.stiction_ratio, sticky),
            quantum: end(self.quantum, !fast),
            noise_quanta: end(self.noise_quanta, sticky),
        }
    }

    /// The factors of plant `index` of the family of `seed`.
    pub fn draw(&self, seed: u64, index: u64) -> PlantFactors {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index);
        let mut log_uniform = |(lo, hi): (f64, f64)| {
            let u: f64 = rng.r#gen();
            (lo.ln() + u * (hi.ln() - lo.ln())).exp()
        };
        let mass = log_uniform(self.mass);
        let viscous = log_uniform(self.viscous);
        let force = log_uniform(self.force);
        let quantum = log_uniform(self.quantum);
        let mut uniform = |(lo, hi): (f64, f64)| lo + rng.r#gen::<f64>() * (hi - lo);
        PlantFactors {
            mass,
            viscous,
            force,
            coulomb: uniform(self.coulomb),
            stiction_ratio: uniform(self.stiction_ratio),
            quantum,
            noise_quanta: uniform(self.noise_quanta),
        }
    }
}

impl PlantFactors {
    /// The nominal sled scaled by these factors.
    pub fn plant(&self) -> PlantParams {
        let n = PlantParams::default();
        let coulomb_n = n.coulomb_n * self.coulomb;
        // A plant without Coulomb friction still sticks a little: the stiction ratio then applies
        // to 10 % of the nominal Coulomb friction.
        let static_n = coulomb_n.max(0.1 * n.coulomb_n) * self.stiction_ratio;
        let quantum_m = n.quantum_m * self.quantum;
        PlantParams {
            mass_kg: n.mass_kg * self.mass,
            force_per_volt_n_per_v: n.force_per_volt_n_per_v * self.force,
            viscous_n_s_per_m: n.viscous_n_s_per_m * self.viscous,
            coulomb_n,
            static_n,
            quantum_m,
            noise_m: self.noise_quanta * quantum_m,
            ..n
        }
    }

    /// The twin of this plant: `base` (reference, baseline controller) with this plant.
    pub fn twin(&self, base: &TwinParams) -> TwinParams {
        TwinParams {
            plant: self.plant(),
            ..base.clone()
        }
    }

    /// How far the nominal prior's velocity model is from this plant's: the larger of the
    /// relative errors of the gain b and of the pole's time constant (a = e^{−Ts/τ}), from the
    /// plants' physics (friction ignored).
    pub fn prior_error(&self, model: impl Fn(&PlantParams) -> (f64, f64)) -> f64 {
        let (a0, b0) = model(&PlantParams::default());
        let (a1, b1) = model(&self.plant());
        let tau = |a: f64| -1.0 / a.max(1e-12).ln();
        let gain = (b0 - b1).abs() / b1.abs();
        let pole = (tau(a0) - tau(a1)).abs() / tau(a1);
        gain.max(pole)
    }

    /// A short label: the factors that differ from 1 by more than 10 %.
    pub fn label(&self) -> String {
        format!(
            "m{:.2} v{:.2} k{:.2} c{:.2} s{:.1} q{:.2} n{:.2}",
            self.mass,
            self.viscous,
            self.force,
            self.coulomb,
            self.stiction_ratio,
            self.quantum,
            self.noise_quanta
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every factor stays in its range, spreads over it (its extremes' deciles are reached), and a
    /// plant does not depend on the family's size. Trips on a swapped range or a shared stream.
    #[test]
    fn draws_cover_the_ranges_and_are_stable() {
        let r = FamilyRanges::default();
        let draws: Vec<PlantFactors> = (0..400).map(|i| r.draw(7, i)).collect();
        let check =
            |name: &str, get: &dyn Fn(&PlantFactors) -> f64, (lo, hi): (f64, f64), log: bool| {
                let t = |x: f64| if log { x.ln() } else { x };
                let (tl, th) = (t(lo), t(hi));
                let frac: Vec<f64> = draws.iter().map(|d| (t(get(d)) - tl) / (th - tl)).collect();
                assert!(frac.iter().all(|f| (0.0..=1.0).contains(f)), "{name}");
                assert!(
                    frac.iter().any(|&f| f < 0.1) && frac.iter().any(|&f| f > 0.9),
                    "{name}"
                );
            };
        check("mass", &|d| d.mass, r.mass, true);
        check("viscous", &|d| d.viscous, r.viscous, true);
        check("force", &|d| d.force, r.force, true);
        check("coulomb", &|d| d.coulomb, r.coulomb, false);
        check("stiction", &|d| d.stiction_ratio, r.stiction_ratio, false);
        check("quantum", &|d| d.quantum, r.quantum, true);
        check("noise", &|d| d.noise_quanta, r.noise_quanta, false);
        assert_eq!(r.draw(7, 3), draws[3]);
        assert_ne!(r.draw(8, 3), draws[3]);
        let p = draws[5].plant();
        assert!(p.static_n > p.coulomb_n && p.validate().is_ok());
    }
}
