//! The paper's nonlinear models in `f64`: the simulation step of every structure with its exact
//! derivatives ([`evaluate`], the function [`sledid::ident::nonlinear::structure::evaluate`] approximates),
//! and [`NonlinearF64`], the recursive prediction-error estimator mirroring
//! [`sledid::ident::nonlinear::NonlinearConfig::step`] decision for decision.

use super::linear::stable;
use super::rls::RlsF64;
use sledid::Status;
use sledid::ident::nonlinear::{NonlinearDesign, NonlinearStructure};

/// One neuron `w·tanh(Σ aᵢxᵢ + c)`: g, ∂g/∂w, ∂g/∂aᵢ, ∂g/∂c, ∂g/∂xᵢ.
fn term(w: f64, a: &[f64], c: f64, x: &[f64]) -> (f64, f64, Vec<f64>, f64, Vec<f64>) {
    let z: f64 = a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>() + c;
    let t = z.tanh();
    let ws = w * (1.0 - t * t);
    (
        w * t,
        t,
        x.iter().map(|x| ws * x).collect(),
        ws,
        a.iter().map(|a| ws * a).collect(),
    )
}

/// One simulation step and its derivatives (see `sledid::ident::nonlinear::structure`).
#[derive(Clone, Debug, PartialEq)]
pub struct EvalF64 {
    /// s(t).
    pub s: f64,
    /// ŷ(t).
    pub y_hat: f64,
    /// ∂F/∂θ.
    pub ds_dtheta: Vec<f64>,
    /// ∂F/∂s(t−1), ∂F/∂s(t−2).
    pub ds_dlag: [f64; 2],
    /// ∂H/∂s.
    pub dy_ds: f64,
    /// ∂H/∂θ.
    pub dy_dtheta: Vec<f64>,
}

/// F and H of `structure` at θ with s(t−1), s(t−2) = `s`, u(t−1), u(t−2) = `u`.
pub fn evaluate(structure: NonlinearStructure, theta: &[f64], s: [f64; 2], u: [f64; 2]) -> EvalF64 {
    let n = theta.len();
    let na = structure.na();
    let mut phi = vec![0.0; n];
    phi[0] = -s[0];
    if na == 2 {
        phi[1] = -s[1];
    }
    phi[na] = u[0];
    if na == 2 {
        phi[na + 1] = u[1];
    }
    let linear: f64 = theta.iter().zip(&phi).map(|(t, p)| t * p).sum();
    let mut ds_dlag = [-theta[0], if na == 2 { -theta[1] } else { 0.0 }];
    let mut dy_ds = 1.0;
    let mut dy_dtheta = vec![0.0; n];
    let mut g = 0.0;
    let mut y_hat = None;
    let th = theta;
    match structure {
        NonlinearStructure::Hammerstein => {
            for k in 0..2 {
                let i = 2 + 3 * k;
                let (gk, dw, da, dc, _) = term(th[i], &[th[i + 1]], th[i + 2], &[u[0]]);
                g += gk;
                phi[i] = dw;
                phi[i + 1] = da[0];
                phi[i + 2] = dc;
            }
        }
        NonlinearStructure::NoeOutputInput => {
            let (gk, dw, da, dc, dx) = term(th[2], &[th[3], th[4]], th[5], &[s[0], u[0]]);
            g = gk;
            phi[2] = dw;
            phi[3] = da[0];
            phi[4] = da[1];
            phi[5] = dc;
            ds_dlag[0] += dx[0];
        }
        NonlinearStructure::Noe221 => {
            let (gk, dw, da, dc, _) = term(th[4], &[th[5]], th[6], &[u[0]]);
            g = gk;
            phi[4] = dw;
            phi[5] = da[0];
            phi[6] = dc;
        }
        NonlinearStructure::FrictionFeedback => {
            let (gk, dw, da, dc, dx) = term(th[4], &[th[5]], th[6], &[s[0] - s[1]]);
            g = gk;
            phi[4] = dw;
            phi[5] = da[0];
            phi[6] = dc;
            ds_dlag[0] += dx[0];
            ds_dlag[1] -= dx[0];
        }
        NonlinearStructure::Wiener => {
            let (gk, dw, da, dc, dx) = term(th[2], &[th[3]], th[4], &[linear]);
            y_hat = Some(linear + gk);
            dy_dtheta[2] = dw;
            dy_dtheta[3] = da[0];
            dy_dtheta[4] = dc;
            dy_ds += dx[0];
        }
    }
    let s_new = linear + g;
    EvalF64 {
        s: s_new,
        y_hat: y_hat.unwrap_or(s_new),
        ds_dtheta: phi,
        ds_dlag,
        dy_ds,
        dy_dtheta,
    }
}

/// The static nonlinearity a structure identifies, as a function of its input: the input map
/// u ↦ b₁u + g(u) of eq. 5 and eq. 7 (what u(t−1) contributes), the Wiener output map
/// x ↦ x + g(x), the friction force v ↦ g(v). `None` for eq. 6 (two inputs).
pub fn static_map(structure: NonlinearStructure, theta: &[f64], x: f64) -> Option<f64> {
    let g = |i: usize| theta[i] * (theta[i + 1] * x + theta[i + 2]).tanh();
    match structure {
        NonlinearStructure::Hammerstein => Some(theta[1] * x + g(2) + g(5)),
        NonlinearStructure::Noe221 => Some(theta[2] * x + g(4)),
        NonlinearStructure::FrictionFeedback => Some(g(4)),
        NonlinearStructure::Wiener => Some(x + g(2)),
        NonlinearStructure::NoeOutputInput => None,
    }
}

/// Float64 twin of `sledid::ident::nonlinear::NonlinearConfig` + `NonlinearState`.
#[derive(Clone, Debug)]
pub struct NonlinearF64<const N: usize> {
    /// The RLS core.
    pub rls: RlsF64<N>,
    structure: NonlinearStructure,
    rho: f64,
    s: [f64; 2],
    u: [f64; 2],
    psi_s_lag: [[f64; N]; 2],
}

impl<const N: usize> NonlinearF64<N> {
    /// From the same design the fixed-point estimator is built from.
    pub fn new(design: &NonlinearDesign<N>) -> Self {
        Self {
            rls: RlsF64::new(&design.rls, design.theta0),
            structure: design.structure,
            rho: 1.0 - design.stability_margin,
            s: [0.0; 2],
            u: [0.0; 2],
            psi_s_lag: [[0.0; N]; 2],
        }
    }

    /// θ.
    pub fn theta(&self) -> &[f64; N] {
        &self.rls.theta
    }

    /// One sample; `force` locks the update decision (see [`RlsF64::update_forced`]).
    pub fn step_forced(&mut self, y: f64, u: f64, force: Option<bool>) -> (f64, f64, Status) {
        let na = self.structure.na();
        let theta_old = self.rls.theta;
        let ev = evaluate(self.structure, &theta_old, self.s, self.u);
        let mut status = Status::NONE;
        let den = [-ev.ds_dlag[0], -ev.ds_dlag[1]];
        let coeffs = if stable(&den[..na], self.rho) {
            ev.ds_dlag
        } else {
            let lin = [-theta_old[0], if na == 2 { -theta_old[1] } else { 0.0 }];
            if lin != ev.ds_dlag {
                status |= Status::GRADIENT_LIMITED;
            }
            lin
        };
        let psi_s: [f64; N] = std::array::from_fn(|k| {
            ev.ds_dtheta[k] + coeffs[0] * self.psi_s_lag[0][k] + coeffs[1] * self.psi_s_lag[1][k]
        });
        let psi: [f64; N] = if self.structure == NonlinearStructure::Wiener {
            std::array::from_fn(|k| ev.dy_dtheta[k] + ev.dy_ds * psi_s[k])
        } else {
            psi_s
        };
        let eps = y - ev.y_hat;
        status |= self.rls.update_forced(&psi, eps, force);
        let new = self.rls.theta;
        if !stable(&new[..na], self.rho) {
            status |= Status::PROJECTED;
            let mut accepted = theta_old;
            for h in 1..=4 {
                let scale = 0.5f64.powi(h);
                let trial: [f64; N] =
                    std::array::from_fn(|i| theta_old[i] + (new[i] - theta_old[i]) * scale);
                if stable(&trial[..na], self.rho) {
                    accepted = trial;
                    break;
                }
            }
            self.rls.theta = accepted;
        }
        self.psi_s_lag = [psi_s, self.psi_s_lag[0]];
        self.s = [ev.s, self.s[0]];
        self.u = [u, self.u[0]];
        (ev.y_hat, eps, status)
    }
}

/// The simulated output of `structure` at fixed θ, started from rest (s = 0, u = 0 before t = 0),
/// with the same timing as the recursive estimator: ŷ(t) uses u(t−1), u(t−2).
pub fn simulate(structure: NonlinearStructure, theta: &[f64], u: &[f64]) -> Vec<f64> {
    let (mut s, mut ul) = ([0.0; 2], [0.0; 2]);
    u.iter()
        .map(|&ut| {
            let ev = evaluate(structure, theta, s, ul);
            s = [ev.s, s[0]];
            ul = [ut, ul[0]];
            ev.y_hat
        })
        .collect()
}
