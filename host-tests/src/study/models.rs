//! The paper's linear model structures and their estimation, in f64.
//!
//! ```text
//! ARX (eq. 1):  A(q) y(t) = B(q) u(t) + e(t)
//! OE  (eq. 2):  y(t) = B(q)/F(q) u(t) + e(t)
//! A(q) = 1 + a1 q⁻¹ + … + an q⁻ⁿ,  F(q) likewise,  B(q) = b1 q⁻¹ + … + bn q⁻ⁿ   (nk = 1, nb = na = n)
//! ```
//! Orders 1 and 2 (the paper's models). ARX minimises the one-step prediction error by linear least
//! squares; OE minimises the simulation error (eq. 3) by Levenberg–Marquardt with the analytic
//! gradient of the simulated output (the sensitivity recursions below), started from the ARX fit
//! and kept stable: a step whose poles leave the unit circle is rejected like a step that
//! increases the criterion.
//!
//! # Initial conditions
//! Every simulation starts from the measured outputs: `ŷ(t) = y(t)` for `t < n`, and the criterion
//! sums `t = n … N−1`. The sensitivities of those fixed initial values are zero:
//! ```text
//! ∂ŷ(t)/∂f_k = −ŷ(t−k) − Σᵢ fᵢ ∂ŷ(t−i)/∂f_k,   ∂ŷ(t)/∂b_k = u(t−k) − Σᵢ fᵢ ∂ŷ(t−i)/∂b_k
//! ```

use serde::Serialize;

use super::results::{OeInit, Structure};
use crate::reference::batch::{least_squares, levenberg_marquardt, normal_equations};

/// Largest pole modulus an unstable ARX fit is projected to before it initialises OE.
pub const PROJECTION_RADIUS: f64 = 0.99;
/// Levenberg–Marquardt iteration limit.
pub const LM_MAX_ITERATIONS: usize = 200;
/// LM stops when a successful step lowers the SSE by less than this fraction.
pub const LM_RELATIVE_TOLERANCE: f64 = 1e-12;

/// A structure and its order n (1 or 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct ModelSpec {
    /// ARX or OE.
    pub structure: Structure,
    /// na = nb = n (nf = nb = n for OE); nk = 1.
    pub order: usize,
}

impl ModelSpec {
    /// The paper's four linear models: ARX1, ARX2, OE1, OE2.
    pub const PAPER: [ModelSpec; 4] = [
        ModelSpec::new(Structure::Arx, 1),
        ModelSpec::new(Structure::Arx, 2),
        ModelSpec::new(Structure::Oe, 1),
        ModelSpec::new(Structure::Oe, 2),
    ];

    /// A model of `order` (clamped to 1..=2).
    pub const fn new(structure: Structure, order: usize) -> Self {
        let order = if order < 1 {
            1
        } else if order > 2 {
            2
        } else {
            order
        };
        Self { structure, order }
    }

    /// `ARX1`, `OE2`, …
    pub fn name(&self) -> String {
        let s = match self.structure {
            Structure::Arx => "ARX",
            Structure::Oe => "OE",
        };
        format!("{s}{}", self.order)
    }

    /// Number of estimated parameters (2n).
    pub fn parameter_count(&self) -> usize {
        sledid::ident::linear::parameter_count(self.order, self.order, false)
    }
}

/// A fitted model: the denominator (A or F without its leading 1) and B.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearModel {
    /// Structure and order.
    pub spec: ModelSpec,
    /// a1…an (ARX) or f1…fn (OE).
    pub den: Vec<f64>,
    /// b1…bn.
    pub num: Vec<f64>,
}

impl LinearModel {
    /// θ = [a1…an | f1…fn, b1…bn].
    pub fn theta(&self) -> Vec<f64> {
        self.den.iter().chain(&self.num).copied().collect()
    }

    /// Names of θ's entries: `a1`, `b1`, … or `f1`, `b1`, ….
    pub fn parameter_names(&self) -> Vec<String> {
        let d = match self.spec.structure {
            Structure::Arx => 'a',
            Structure::Oe => 'f',
        };
        (1..=self.den.len())
            .map(|i| format!("{d}{i}"))
            .chain((1..=self.num.len()).map(|i| format!("b{i}")))
            .collect()
    }

    /// Poles: roots of `zⁿ + d1 zⁿ⁻¹ + … + dn`, as `[re, im]`.
    pub fn poles(&self) -> Vec<[f64; 2]> {
        monic_roots(&self.den)
    }

    /// Finite zeros: roots of `b1 zⁿ⁻¹ + … + bn` (none for n = 1 or b1 = 0).
    pub fn zeros(&self) -> Vec<[f64; 2]> {
        match self.num.split_first() {
            Some((&b1, rest)) if b1 != 0.0 => {
                let c: Vec<f64> = rest.iter().map(|b| b / b1).collect();
                monic_roots(&c)
            }
            _ => Vec::new(),
        }
    }

    /// Whether every pole lies strictly inside the unit circle.
    pub fn is_stable(&self) -> bool {
        is_stable(&self.den)
    }

    /// Simulation from the input only, started from the measured `y(0…n−1)`.
    pub fn simulate(&self, u: &[f64], y: &[f64]) -> Vec<f64> {
        simulate(&self.den, &self.num, u, y)
    }

    /// One-step prediction: ARX uses the measured past outputs; the OE predictor is its
    /// simulation (its noise model is 1). `ŷ(t) = y(t)` for `t < n`.
    pub fn predict(&self, u: &[f64], y: &[f64]) -> Vec<f64> {
        match self.spec.structure {
            Structure::Oe => self.simulate(u, y),
            Structure::Arx => {
                let n = self.den.len();
                (0..y.len())
                    .map(|t| {
                        if t < n {
                            return y[t];
                        }
                        let ar: f64 = (1..=n).map(|i| -self.den[i - 1] * y[t - i]).sum();
                        ar + lagged_input(&self.num, u, t)
                    })
                    .collect()
            }
        }
    }
}

/// `Σ_j b_j u(t − j)` for j = 1…nb (terms before sample 0 are 0).
fn lagged_input(num: &[f64], u: &[f64], t: usize) -> f64 {
    num.iter()
        .enumerate()
        .filter(|(j, _)| *j < t)
        .map(|(j, b)| b * u[t - j - 1])
        .sum()
}

/// `ŷ(t) = −Σ dᵢ ŷ(t−i) + Σ bⱼ u(t−j)` for `t ≥ n`, `ŷ(t) = y_init(t)` before.
pub fn simulate(den: &[f64], num: &[f64], u: &[f64], y_init: &[f64]) -> Vec<f64> {
    let n = den.len();
    let mut yhat = vec![0.0; u.len()];
    for t in 0..u.len() {
        yhat[t] = if t < n {
            y_init.get(t).copied().unwrap_or(0.0)
        } else {
            let ar: f64 = (1..=n).map(|i| -den[i - 1] * yhat[t - i]).sum();
            ar + lagged_input(num, u, t)
        };
    }
    yhat
}

/// Sum of squared differences over `start..`.
pub fn sse_from(y: &[f64], yhat: &[f64], start: usize) -> f64 {
    y.iter()
        .zip(yhat)
        .skip(start)
        .map(|(a, b)| (a - b).powi(2))
        .sum()
}

/// RMS of `y − ŷ` over `start..`.
pub fn rms_from(y: &[f64], yhat: &[f64], start: usize) -> f64 {
    let n = y.len().min(yhat.len()).saturating_sub(start).max(1);
    (sse_from(y, yhat, start) / n as f64).sqrt()
}

/// Roots of the monic `zⁿ + c1 zⁿ⁻¹ + … + cn` for n ≤ 2 (empty for higher n, not used here).
pub fn monic_roots(c: &[f64]) -> Vec<[f64; 2]> {
    match *c {
        [c1] => vec![[-c1, 0.0]],
        [c1, c2] => {
            let half = -c1 / 2.0;
            let disc = half * half - c2;
            if disc >= 0.0 {
                let s = disc.sqrt();
                vec![[half + s, 0.0], [half - s, 0.0]]
            } else {
                let s = (-disc).sqrt();
                vec![[half, s], [half, -s]]
            }
        }
        _ => Vec::new(),
    }
}

/// Whether every root of `zⁿ + d1 zⁿ⁻¹ + …` is strictly inside the unit circle.
pub fn is_stable(den: &[f64]) -> bool {
    den.iter().all(|d| d.is_finite()) && monic_roots(den).iter().all(|p| p[0].hypot(p[1]) < 1.0)
}

/// The denominator with every root of modulus above `radius` pulled in to `radius`, same angle.
pub fn project_stable(den: &[f64], radius: f64) -> Vec<f64> {
    let clamp = |p: [f64; 2]| {
        let m = p[0].hypot(p[1]);
        if m > radius {
            [p[0] * radius / m, p[1] * radius / m]
        } else {
            p
        }
    };
    let r: Vec<[f64; 2]> = monic_roots(den).into_iter().map(clamp).collect();
    match r[..] {
        [p] => vec![-p[0]],
        // (z − p1)(z − p2): p1, p2 real or a conjugate pair, so the products are real.
        [p1, p2] => vec![-(p1[0] + p2[0]), p1[0] * p2[0] - p1[1] * p2[1]],
        _ => den.to_vec(),
    }
}

/// ARX of `order` by least squares over `t = n … N−1`.
pub fn fit_arx(order: usize, y: &[f64], u: &[f64]) -> Option<LinearModel> {
    let spec = ModelSpec::new(Structure::Arx, order);
    let n = spec.order;
    let phi: Vec<Vec<f64>> = (n..y.len())
        .map(|t| {
            (1..=n)
                .map(|i| -y[t - i])
                .chain((1..=n).map(|j| u[t - j]))
                .collect()
        })
        .collect();
    let theta = least_squares(&phi, y.get(n..)?)?;
    Some(LinearModel {
        spec,
        den: theta[..n].to_vec(),
        num: theta[n..].to_vec(),
    })
}

/// An OE fit and how the search went.
#[derive(Clone, Debug, PartialEq)]
pub struct OeFit {
    /// The model at the minimum found.
    pub model: LinearModel,
    /// The starting point.
    pub init: OeInit,
    /// Simulation SSE at the starting point.
    pub sse_init: f64,
    /// Simulation SSE at the end.
    pub sse_final: f64,
    /// Accepted LM steps.
    pub iterations: usize,
    /// Trial steps rejected because their poles left the unit circle.
    pub rejected_unstable: usize,
    /// Whether LM stopped on its tolerance (not on the iteration limit).
    pub converged: bool,
}

/// B by least squares for a fixed denominator: `y − free response = Σ bⱼ (q⁻ʲ/F) u`.
pub fn refit_num(den: &[f64], y: &[f64], u: &[f64]) -> Option<Vec<f64>> {
    let n = den.len();
    let free = simulate(den, &vec![0.0; n], u, y);
    let zeros = vec![0.0; n];
    let basis: Vec<Vec<f64>> = (0..n)
        .map(|j| {
            let mut e = vec![0.0; n];
            e[j] = 1.0;
            simulate(den, &e, u, &zeros)
        })
        .collect();
    let phi: Vec<Vec<f64>> = (n..y.len())
        .map(|t| basis.iter().map(|x| x[t]).collect())
        .collect();
    let target: Vec<f64> = (n..y.len()).map(|t| y[t] - free[t]).collect();
    least_squares(&phi, &target)
}

/// Simulated output and its sensitivities ∂ŷ/∂θ (θ = [f…, b…]) for `t ≥ n`.
fn sensitivities(den: &[f64], num: &[f64], u: &[f64], y: &[f64]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = den.len();
    let yhat = simulate(den, num, u, y);
    let mut psi = vec![vec![0.0; 2 * n]; u.len()];
    for t in n..u.len() {
        for k in 0..2 * n {
            let direct = if k < n {
                -yhat[t - k - 1]
            } else {
                u[t - (k - n) - 1]
            };
            let feedback: f64 = (1..=n).map(|i| den[i - 1] * psi[t - i][k]).sum();
            psi[t][k] = direct - feedback;
        }
    }
    (yhat, psi)
}

/// OE of `order` by Levenberg–Marquardt on the simulation SSE, started from `arx` (see the module
/// documentation). `None` if the data are too short or singular.
pub fn fit_oe(order: usize, y: &[f64], u: &[f64], arx: &LinearModel) -> Option<OeFit> {
    let spec = ModelSpec::new(Structure::Oe, order);
    let n = spec.order;
    if y.len() <= 2 * n + n || arx.den.len() != n {
        return None;
    }
    let (den0, num0, init) = if arx.is_stable() {
        (arx.den.clone(), arx.num.clone(), OeInit::Arx)
    } else {
        let den = project_stable(&arx.den, PROJECTION_RADIUS);
        let num = refit_num(&den, y, u)?;
        (den, num, OeInit::ProjectedArx)
    };
    let theta0: Vec<f64> = den0.iter().chain(&num0).copied().collect();
    let cost = |th: &[f64]| sse_from(y, &simulate(&th[..n], &th[n..], u, y), n);
    let sse_init = cost(&theta0);
    let lm = levenberg_marquardt(
        theta0,
        LM_MAX_ITERATIONS,
        LM_RELATIVE_TOLERANCE,
        1e-12,
        |th| {
            let (yhat, psi) = sensitivities(&th[..n], &th[n..], u, y);
            normal_equations(y, &yhat, &psi, n, 2 * n)
        },
        cost,
        |th| is_stable(&th[..n]),
    );
    let theta = lm.theta;
    Some(OeFit {
        model: LinearModel {
            spec,
            den: theta[..n].to_vec(),
            num: theta[n..].to_vec(),
        },
        init,
        sse_init,
        sse_final: lm.cost,
        iterations: lm.iterations,
        rejected_unstable: lm.rejected_infeasible,
        converged: lm.converged,
    })
}
