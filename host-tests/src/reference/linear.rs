//! ARX and OE estimators in `f64`, mirroring [`sledid::ident::linear`] decision for decision.

use super::rls::RlsF64;
use sledid::Status;
use sledid::ident::linear::{LinearDesign, Structure};

/// Float64 twin of `sledid::ident::linear::LinearConfig` + `LinearState`.
#[derive(Clone, Debug)]
pub struct LinearF64<const N: usize> {
    /// The RLS core.
    pub rls: RlsF64<N>,
    structure: Structure,
    na: usize,
    nk: usize,
    radius: Option<f64>,
    /// y(t−1−i) (or ŷ for OE).
    y_lag: Vec<f64>,
    /// u(t−i).
    u_lag: Vec<f64>,
    psi_lag: [[f64; N]; 2],
    /// Round the internal signals (ŷ history, ψ) to the I16F16 grid, as the fixed-point path stores
    /// them: isolates the kernel's arithmetic from the signal format's resolution.
    pub signal_grid: bool,
}

fn grid(x: f64) -> f64 {
    (x * 65_536.0).round() / 65_536.0
}

/// What one step produced.
#[derive(Clone, Copy, Debug)]
pub struct EstimateF64 {
    /// ŷ(t) = φᵀθ(t−1).
    pub y_hat: f64,
    /// y − ŷ.
    pub eps: f64,
    /// Flags.
    pub status: Status,
}

/// Roots of the denominator inside |z| ≤ ρ (first/second order), as `sledid::ident::stability`.
pub fn stable(den: &[f64], rho: f64) -> bool {
    match den {
        [] => true,
        [f1] => f1.abs() <= rho,
        [f1, f2, ..] => f2.abs() <= rho * rho && rho * f1.abs() <= rho * rho + f2,
    }
}

impl<const N: usize> LinearF64<N> {
    /// From the same design the fixed-point estimator is built from.
    pub fn new(design: &LinearDesign<N>) -> Self {
        Self {
            rls: RlsF64::new(&design.rls, design.theta0),
            structure: design.structure,
            na: design.na,
            nk: design.nk,
            radius: design.stability_margin.map(|m| 1.0 - m),
            y_lag: vec![0.0; N],
            u_lag: vec![0.0; N + sledid::ident::linear::MAX_DELAY],
            psi_lag: [[0.0; N]; 2],
            signal_grid: false,
        }
    }

    /// θ.
    pub fn theta(&self) -> &[f64; N] {
        &self.rls.theta
    }

    fn regressor(&self) -> [f64; N] {
        let mut phi = [0.0; N];
        for (i, p) in phi.iter_mut().enumerate() {
            *p = if i < self.na {
                -self.y_lag[i]
            } else {
                self.u_lag[self.nk + i - self.na]
            };
        }
        phi
    }

    /// One sample (conditioned y, u).
    pub fn step(&mut self, y: f64, u: f64) -> EstimateF64 {
        self.step_forced(y, u, None)
    }

    /// As [`Self::step`], with the update/skip decision optionally forced (see
    /// [`RlsF64::update_forced`]).
    pub fn step_forced(&mut self, y: f64, u: f64, force: Option<bool>) -> EstimateF64 {
        self.u_lag.rotate_right(1);
        self.u_lag[0] = u;
        let phi = self.regressor();
        let theta_old = self.rls.theta;
        let y_hat = if self.signal_grid {
            grid(self.rls.predict(&phi))
        } else {
            self.rls.predict(&phi)
        };
        let eps = y - y_hat;
        let psi = match self.structure {
            Structure::Arx | Structure::OutputErrorPseudoLinear => phi,
            Structure::OutputErrorPredictionError => {
                let mut psi = phi;
                for (k, p) in psi.iter_mut().enumerate() {
                    for (lag, f) in self
                        .psi_lag
                        .iter()
                        .zip(theta_old.iter().take(self.na.min(2)))
                    {
                        *p -= f * lag[k];
                    }
                }
                if self.signal_grid {
                    psi.iter_mut().for_each(|p| *p = grid(*p));
                }
                self.psi_lag.swap(0, 1);
                self.psi_lag[0] = psi;
                psi
            }
        };
        let mut status = self.rls.update_forced(&psi, eps, force);
        if let Some(rho) = self.radius {
            let new = self.rls.theta;
            if !stable(&new[..self.na], rho) {
                status |= Status::PROJECTED;
                let mut accepted = theta_old;
                for h in 1..=4 {
                    let scale = 0.5f64.powi(h);
                    let mut trial = theta_old;
                    for i in 0..N {
                        trial[i] = theta_old[i] + (new[i] - theta_old[i]) * scale;
                    }
                    if stable(&trial[..self.na], rho) {
                        accepted = trial;
                        break;
                    }
                }
                self.rls.theta = accepted;
            }
        }
        let lagged = match self.structure {
            Structure::Arx => y,
            _ if self.signal_grid => grid(self.rls.predict(&phi)),
            _ => self.rls.predict(&phi),
        };
        self.y_lag.rotate_right(1);
        self.y_lag[0] = lagged;
        EstimateF64 { y_hat, eps, status }
    }
}
