//! A plant the controller was not tuned on: a nominal plant with its mass, friction and quantum
//! scaled (`sledid control --perturb`, the seven variants of the earlier issue).

use serde::Serialize;

use crate::twin::TwinParams;

pub fn perturbed(params: &TwinParams, mass: f64, friction: f64, quantum: f64) -> TwinParams {
    let mut p = params.clone();
    p.plant.mass_kg *= mass;
    p.plant.coulomb_n *= friction;
    p.plant.static_n *= friction;
    p.plant.quantum_m *= quantum;
    p
}

/// Scale factors of a plant the controller was not tuned on (`--perturb`): mass, friction
/// (Coulomb and static together) and sensor quantum, each 1 when not given.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Perturbation {
    /// Mass factor.
    pub mass: f64,
    /// Friction factor.
    pub friction: f64,
    /// Quantum factor.
    pub quantum: f64,
}

impl Default for Perturbation {
    fn default() -> Self {
        Self {
            mass: 1.0,
            friction: 1.0,
            quantum: 1.0,
        }
    }
}

impl Perturbation {
    /// Parses `mass=0.7,friction=1.5,quantum=2` (any subset, any order).
    ///
    /// # Errors
    /// An unknown key, a missing `=`, or a factor that is not finite and > 0.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut p = Self::default();
        for item in text.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| format!("--perturb: `{item}` is not KEY=FACTOR"))?;
            let factor: f64 = value
                .trim()
                .parse()
                .map_err(|e| format!("--perturb: `{item}`: {e}"))?;
            if !(factor.is_finite() && factor > 0.0) {
                return Err(format!(
                    "--perturb: `{item}`: the factor must be finite and > 0"
                ));
            }
            match key.trim() {
                "mass" => p.mass = factor,
                "friction" => p.friction = factor,
                "quantum" => p.quantum = factor,
                other => {
                    return Err(format!(
                        "--perturb: unknown key `{other}` (mass, friction, quantum)"
                    ));
                }
            }
        }
        Ok(p)
    }

    /// The seven plants issue 5's targets name: nominal, mass ×0.7 and ×1.3, friction (Coulomb
    /// and static) ×0.5 and ×1.5, quantum ×0.5 and ×2.
    pub const ISSUE_PLANTS: [(&'static str, Perturbation); 7] = [
        ("nominal", Self::scale(1.0, 1.0, 1.0)),
        ("mass ×0.7", Self::scale(0.7, 1.0, 1.0)),
        ("mass ×1.3", Self::scale(1.3, 1.0, 1.0)),
        ("friction ×0.5", Self::scale(1.0, 0.5, 1.0)),
        ("friction ×1.5", Self::scale(1.0, 1.5, 1.0)),
        ("quantum ×0.5", Self::scale(1.0, 1.0, 0.5)),
        ("quantum ×2", Self::scale(1.0, 1.0, 2.0)),
    ];

    const fn scale(mass: f64, friction: f64, quantum: f64) -> Self {
        Self {
            mass,
            friction,
            quantum,
        }
    }

    /// `params` scaled by these factors ([`perturbed`]).
    pub fn apply(&self, params: &TwinParams) -> TwinParams {
        perturbed(params, self.mass, self.friction, self.quantum)
    }
}
