//! Batch prediction-error fit of the paper's nonlinear models: Levenberg–Marquardt on the
//! simulation error (eq. 3), with the analytic sensitivities of [`super::nonlinear::evaluate`],
//! started from the linear model as the paper does (w = 0: the start is the linear model's SSE).
//!
//! ```text
//! V(θ) = Σ_{t ≥ na} (y(t) − ŷ(t; θ))² + δ·‖θ − θ₀‖²     (δ = `ridge`, 0 = the paper's criterion)
//! ψₛ(t) = ∂F/∂θ + ∂F/∂s₁ ψₛ(t−1) + ∂F/∂s₂ ψₛ(t−2),   ψ(t) = ∂H/∂θ + ∂H/∂s ψₛ(t)
//! ```
//! Like the linear study, the simulation starts from the measured outputs (s(t) = y(t), t < na,
//! with zero sensitivities). A trial step is rejected like an increase of V when the linear
//! denominator leaves the unit circle or the simulation is not finite. The ridge term is the
//! over-fitting guard: it pulls the extra parameters toward the linear model on short records.

use super::batch::{levenberg_marquardt, normal_equations};
use super::linear::stable;
use super::nonlinear::evaluate;
use sledid::ident::nonlinear::NonlinearStructure;

/// Iteration limit.
pub const MAX_ITERATIONS: usize = 300;
/// Stop when an accepted step lowers V by less than this fraction.
pub const RELATIVE_TOLERANCE: f64 = 1e-10;
/// Largest pole modulus accepted for the linear part.
pub const MAX_POLE: f64 = 0.999;

/// A fitted nonlinear model and how the search went.
#[derive(Clone, Debug, PartialEq)]
pub struct NonlinearFit {
    /// The structure.
    pub structure: NonlinearStructure,
    /// θ at the minimum found.
    pub theta: Vec<f64>,
    /// Simulation SSE at θ₀ (the linear model).
    pub sse_init: f64,
    /// Simulation SSE at the end.
    pub sse_final: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Whether the search stopped on its tolerance.
    pub converged: bool,
}

/// [s(t−1), s(t−2)] and [u(t−1), u(t−2)] for t ≥ 1, zero before the record.
fn lags(s: &[f64], u: &[f64], t: usize) -> ([f64; 2], [f64; 2]) {
    let at = |v: &[f64], k: usize| t.checked_sub(k).map_or(0.0, |i| v[i]);
    ([at(s, 1), at(s, 2)], [at(u, 1), at(u, 2)])
}

/// Simulated output from the measured initial outputs, and its gradient ψ(t) = ∂ŷ(t)/∂θ.
pub fn simulate_with_gradient(
    structure: NonlinearStructure,
    theta: &[f64],
    y: &[f64],
    u: &[f64],
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = theta.len();
    let na = structure.na();
    let len = y.len().min(u.len());
    let mut yhat = vec![0.0; len];
    let mut psi = vec![vec![0.0; n]; len];
    let mut s = vec![0.0; len];
    let mut psi_s = vec![vec![0.0; n]; len];
    for t in 0..len {
        if t < na {
            yhat[t] = y[t];
            s[t] = y[t];
            continue;
        }
        let (s_lag, u_lag) = lags(&s, u, t);
        let ev = evaluate(structure, theta, s_lag, u_lag);
        s[t] = ev.s;
        yhat[t] = ev.y_hat;
        for k in 0..n {
            let p2 = if t >= 2 { psi_s[t - 2][k] } else { 0.0 };
            psi_s[t][k] = ev.ds_dtheta[k] + ev.ds_dlag[0] * psi_s[t - 1][k] + ev.ds_dlag[1] * p2;
            psi[t][k] = if structure == NonlinearStructure::Wiener {
                ev.dy_dtheta[k] + ev.dy_ds * psi_s[t][k]
            } else {
                psi_s[t][k]
            };
        }
    }
    (yhat, psi)
}

/// The simulated output alone (same initial conditions and arithmetic as
/// [`simulate_with_gradient`], without the sensitivities: the criterion's hot path).
pub fn simulate_from_measured(
    structure: NonlinearStructure,
    theta: &[f64],
    y: &[f64],
    u: &[f64],
) -> Vec<f64> {
    let na = structure.na();
    let len = y.len().min(u.len());
    let mut yhat = vec![0.0; len];
    let mut s = vec![0.0; len];
    for t in 0..len {
        if t < na {
            yhat[t] = y[t];
            s[t] = y[t];
            continue;
        }
        let (s_lag, u_lag) = lags(&s, u, t);
        let ev = evaluate(structure, theta, s_lag, u_lag);
        s[t] = ev.s;
        yhat[t] = ev.y_hat;
    }
    yhat
}

fn criterion(
    structure: NonlinearStructure,
    theta: &[f64],
    theta0: &[f64],
    ridge: f64,
    y: &[f64],
    u: &[f64],
) -> f64 {
    let na = structure.na();
    let yhat = simulate_from_measured(structure, theta, y, u);
    let sse: f64 = (na..yhat.len()).map(|t| (y[t] - yhat[t]).powi(2)).sum();
    let pen: f64 = theta.iter().zip(theta0).map(|(a, b)| (a - b).powi(2)).sum();
    sse + ridge * pen
}

/// Levenberg–Marquardt from θ₀ (see the module documentation). `None` when θ₀ has the wrong
/// length or an unstable denominator, or the data are too short.
pub fn fit(
    structure: NonlinearStructure,
    theta0: &[f64],
    ridge: f64,
    y: &[f64],
    u: &[f64],
) -> Option<NonlinearFit> {
    fit_from(structure, theta0, theta0, ridge, y, u)
}

/// [`fit`] started from `start` with the ridge pulling toward `theta0` (the linear model): the
/// multi-start fits of the study start elsewhere but keep the ridge's anchor. `sse_init` is the
/// SSE at `start`.
pub fn fit_from(
    structure: NonlinearStructure,
    start: &[f64],
    theta0: &[f64],
    ridge: f64,
    y: &[f64],
    u: &[f64],
) -> Option<NonlinearFit> {
    let n = structure.parameter_count();
    let na = structure.na();
    if start.len() != n
        || theta0.len() != n
        || !stable(&start[..na], MAX_POLE)
        || y.len().min(u.len()) <= n + na
    {
        return None;
    }
    let sse_of = |th: &[f64]| {
        let yhat = simulate_from_measured(structure, th, y, u);
        (na..yhat.len())
            .map(|t| (y[t] - yhat[t]).powi(2))
            .sum::<f64>()
    };
    let sse_init = sse_of(start);
    let lm = levenberg_marquardt(
        start.to_vec(),
        MAX_ITERATIONS,
        RELATIVE_TOLERANCE,
        1e-9,
        |th| {
            let (yhat, psi) = simulate_with_gradient(structure, th, y, u);
            let (mut h, mut g) = normal_equations(y, &yhat, &psi, na, n);
            for i in 0..n {
                g[i] -= ridge * (th[i] - theta0[i]);
                h[i][i] += ridge;
            }
            (h, g)
        },
        |th| criterion(structure, th, theta0, ridge, y, u),
        |th| stable(&th[..na], MAX_POLE),
    );
    let (theta, iterations, converged) = (lm.theta, lm.iterations, lm.converged);
    let sse_final = sse_of(&theta);
    Some(NonlinearFit {
        structure,
        theta,
        sse_init,
        sse_final,
        iterations,
        converged,
    })
}
