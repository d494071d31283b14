//! Linear test plants of known parameters, run in closed loop with a quantised output: the simplest
//! data on which the estimators must agree with their float64 references.
//!
//! `y(t) = −a₁y(t−1) − … + b₁u(t−1) + …` in sensor quanta, u a fraction of full scale, measured
//! `y_q = round(y)`. A proportional controller tracks random step references; a small dither on u
//! is optional. Deterministic from a seed.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A closed-loop recording of a known linear plant.
#[derive(Clone, Debug, Default)]
pub struct ClosedLoopRecord {
    /// Reference, quanta.
    pub r: Vec<f64>,
    /// Drive, fraction of full scale.
    pub u: Vec<f64>,
    /// Quantised measured output, quanta (integers).
    pub y: Vec<f64>,
    /// True (unquantised) output, quanta.
    pub y_true: Vec<f64>,
}

/// Settings of [`closed_loop`].
#[derive(Clone, Debug)]
pub struct ClosedLoopSpec {
    /// Denominator [a₁, …].
    pub a: Vec<f64>,
    /// Numerator [b₁, …] (delay 1).
    pub b: Vec<f64>,
    /// Proportional gain, full scale per quantum of error.
    pub kp: f64,
    /// Uniform dither amplitude added to u (fraction of full scale).
    pub dither: f64,
    /// Samples between reference steps.
    pub step_every: usize,
    /// Largest step, quanta.
    pub step_max: f64,
    /// Number of samples.
    pub samples: usize,
    /// Seed.
    pub seed: u64,
}

/// Simulates the plant in closed loop.
pub fn closed_loop(spec: &ClosedLoopSpec) -> ClosedLoopRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let mut rec = ClosedLoopRecord::default();
    let (na, nb) = (spec.a.len(), spec.b.len());
    let mut r = 0.0;
    for t in 0..spec.samples {
        if t % spec.step_every == 0 && t > 0 {
            r += rng.gen_range(-spec.step_max..=spec.step_max).round();
        }
        let mut y = 0.0;
        for i in 1..=na {
            if i <= t {
                y -= spec.a[i - 1] * rec.y_true[t - i];
            }
        }
        for i in 1..=nb {
            if i <= t {
                y += spec.b[i - 1] * rec.u[t - i];
            }
        }
        let yq = y.round();
        let dither = if spec.dither > 0.0 {
            rng.gen_range(-spec.dither..=spec.dither)
        } else {
            0.0
        };
        let u = (spec.kp * (r - yq) + dither).clamp(-1.0, 1.0);
        rec.r.push(r);
        rec.u.push(u);
        rec.y.push(yq);
        rec.y_true.push(y);
    }
    rec
}
