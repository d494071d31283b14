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

impl ClosedLoopSpec {
    /// The loop the matched-plant tests run a [`NonlinearPlant`] in: no linear plant (the
    /// nonlinear plant brings its own), kp 0.15, dither 0.3, a step of up to ±30 quanta every 60
    /// samples.
    pub fn matched_plant(samples: usize, seed: u64) -> Self {
        Self {
            a: vec![],
            b: vec![],
            kp: 0.15,
            dither: 0.3,
            step_every: 60,
            step_max: 30.0,
            samples,
            seed,
        }
    }
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
        rec.record(spec, &mut rng, r, y);
    }
    rec
}

impl ClosedLoopRecord {
    /// The sensor and the controller of one sample: quantises y, computes the dithered,
    /// saturated proportional drive, records everything; returns u.
    fn record(&mut self, spec: &ClosedLoopSpec, rng: &mut ChaCha8Rng, r: f64, y: f64) -> f64 {
        let yq = y.round();
        let dither = if spec.dither > 0.0 {
            rng.gen_range(-spec.dither..=spec.dither)
        } else {
            0.0
        };
        let u = (spec.kp * (r - yq) + dither).clamp(-1.0, 1.0);
        self.r.push(r);
        self.u.push(u);
        self.y.push(yq);
        self.y_true.push(y);
        u
    }
}

/// The kind of nonlinearity of a [`nonlinear_closed_loop`] plant, one per nonlinear structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NonlinearPlant {
    /// Soft saturation at the input (Hammerstein): `x(t) = 0.9x(t−1) + 4·0.5 tanh(u(t−1)/0.5)`.
    InputSaturation,
    /// Soft saturation at the output (Wiener): `x(t) = 0.9x(t−1) + 4u(t−1)`,
    /// `y = x + 6 tanh(x/8)` (a stiffer sensor response around zero).
    OutputMap,
    /// Second-order position dynamics with Coulomb-like friction on the velocity:
    /// `x(t) = 1.6x(t−1) − 0.64x(t−2) + 0.6u(t−1) − 0.25 tanh((x(t−1) − x(t−2))/0.2)`.
    Friction,
    /// Input saturation acting on a second-order plant (eq. 7):
    /// `x(t) = 1.5x(t−1) − 0.6x(t−2) + 0.5 tanh(u(t−1)/0.5) + 0.2u(t−2)`.
    SecondOrderInput,
}

impl NonlinearPlant {
    /// The true static nonlinearity in the coordinates the matching structure estimates (the
    /// neurons' part for input and friction plants, the whole output map for the Wiener plant).
    pub fn true_map(self, x: f64) -> f64 {
        match self {
            Self::InputSaturation => 2.0 * (x / 0.5).tanh(),
            Self::OutputMap => x + 6.0 * (x / 8.0).tanh(),
            Self::Friction => -0.25 * (x / 0.2).tanh(),
            Self::SecondOrderInput => 0.5 * (x / 0.5).tanh(),
        }
    }

    fn next(self, x: [f64; 2], u: [f64; 2]) -> f64 {
        match self {
            Self::InputSaturation => 0.9 * x[0] + self.true_map(u[0]),
            Self::OutputMap => 0.9 * x[0] + 4.0 * u[0],
            Self::Friction => 1.6 * x[0] - 0.64 * x[1] + 0.6 * u[0] + self.true_map(x[0] - x[1]),
            Self::SecondOrderInput => 1.5 * x[0] - 0.6 * x[1] + self.true_map(u[0]) + 0.2 * u[1],
        }
    }

    fn output(self, x: f64) -> f64 {
        match self {
            Self::OutputMap => self.true_map(x),
            _ => x,
        }
    }
}

/// A nonlinear plant in closed loop under the proportional controller of [`closed_loop`] (random
/// steps every `step_every` samples up to ±`step_max` quanta, uniform dither), output quantised to
/// one quantum.
pub fn nonlinear_closed_loop(plant: NonlinearPlant, spec: &ClosedLoopSpec) -> ClosedLoopRecord {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let mut rec = ClosedLoopRecord::default();
    let (mut x, mut u_lag, mut r) = ([0.0f64; 2], [0.0f64; 2], 0.0);
    for t in 0..spec.samples {
        if t % spec.step_every == 0 && t > 0 {
            r = rng.gen_range(-spec.step_max..=spec.step_max).round();
        }
        let xt = plant.next(x, u_lag);
        x = [xt, x[0]];
        let y = plant.output(xt);
        let u = rec.record(spec, &mut rng, r, y);
        u_lag = [u, u_lag[0]];
    }
    rec
}
