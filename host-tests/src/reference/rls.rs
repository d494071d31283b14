//! Textbook covariance-form RLS in `f64`.

use sledid::Status;
use sledid::rls::AntiWindup;

/// RLS with forgetting on a full, re-symmetrised covariance matrix.
#[derive(Clone, Debug)]
pub struct RlsF64<const N: usize> {
    /// Estimate.
    pub theta: [f64; N],
    /// Covariance.
    pub p: [[f64; N]; N],
    /// Forgetting factor.
    pub lambda: f64,
    /// Dead zone on |ε| (0 disables).
    pub dead_zone: f64,
    /// Minimum ψᵀPψ (0 disables).
    pub excitation_threshold: f64,
    /// Covariance limit.
    pub anti_windup: AntiWindup,
    /// False: on hold.
    pub enabled: bool,
    /// True when the last update's forced decision differed from this reference's own.
    pub last_overridden: bool,
}

impl<const N: usize> RlsF64<N> {
    /// θ = `theta0`, P = p0·I.
    pub fn new(design: &sledid::rls::RlsDesign, theta0: [f64; N]) -> Self {
        let mut p = [[0.0; N]; N];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = design.p0;
        }
        Self {
            theta: theta0,
            p,
            lambda: design.lambda,
            dead_zone: design.dead_zone,
            excitation_threshold: design.excitation_threshold,
            anti_windup: design.anti_windup,
            enabled: true,
            last_overridden: false,
        }
    }

    /// ψᵀθ.
    pub fn predict(&self, psi: &[f64; N]) -> f64 {
        psi.iter().zip(self.theta.iter()).map(|(a, b)| a * b).sum()
    }

    /// trace(P).
    pub fn trace(&self) -> f64 {
        (0..N).map(|i| self.p[i][i]).sum()
    }

    /// The largest diagonal element of P.
    pub fn max_diagonal(&self) -> f64 {
        (0..N).map(|i| self.p[i][i]).fold(f64::MIN, f64::max)
    }

    fn scale(&mut self, k: f64) {
        for row in &mut self.p {
            for x in row {
                *x *= k;
            }
        }
    }

    /// One update with regressor ψ and a-priori error ε; same flags as the fixed-point kernel.
    pub fn update(&mut self, psi: &[f64; N], eps: f64) -> Status {
        self.update_forced(psi, eps, None)
    }

    /// The gate decision this reference takes on its own: `Err(flag)` to skip.
    fn gate(&self, psi: &[f64; N], eps: f64, s: f64) -> Result<(), Status> {
        if !self.enabled {
            return Err(Status::HELD);
        }
        if self.dead_zone > 0.0 && eps.abs() <= self.dead_zone {
            return Err(Status::DEAD_ZONE);
        }
        // Below half a step of I16F16 a regressor is zero for the fixed-point path too.
        if psi.iter().all(|&x| x.abs() < 0.5 / 65_536.0) || s < self.excitation_threshold {
            return Err(Status::LOW_EXCITATION);
        }
        Ok(())
    }

    /// As [`Self::update`], but `force = Some(update?)` overrides the gate decision (used to lock the
    /// reference to the fixed-point path's decisions, so a comparison measures arithmetic only).
    pub fn update_forced(&mut self, psi: &[f64; N], eps: f64, force: Option<bool>) -> Status {
        let mut p_psi = [0.0; N];
        for (pp, row) in p_psi.iter_mut().zip(self.p.iter()) {
            *pp = row.iter().zip(psi.iter()).map(|(a, b)| a * b).sum();
        }
        let s: f64 = psi.iter().zip(p_psi.iter()).map(|(a, b)| a * b).sum();
        let own = self.gate(psi, eps, s);
        self.last_overridden = force.is_some_and(|f| f != own.is_ok());
        match (own, force) {
            (Err(flag), None) => return flag,
            (_, Some(false)) => return Status::DEAD_ZONE,
            _ => {}
        }
        let alpha = self.lambda + s;
        for (th, pp) in self.theta.iter_mut().zip(p_psi.iter()) {
            *th += pp / alpha * eps;
        }
        for (row, pi) in self.p.iter_mut().zip(p_psi.iter()) {
            for (x, pj) in row.iter_mut().zip(p_psi.iter()) {
                *x = (*x - pi * pj / alpha) / self.lambda;
            }
        }
        for i in 0..N {
            for j in (i + 1)..N {
                let m = 0.5 * (self.p[i][j] + self.p[j][i]);
                self.p[i][j] = m;
                self.p[j][i] = m;
            }
        }
        let mut status = Status::UPDATED;
        match self.anti_windup {
            AntiWindup::None => {}
            AntiWindup::TraceLimit { max } => {
                let tr = self.trace();
                if tr > max {
                    self.scale(max / tr);
                    status |= Status::COVARIANCE_BOUNDED;
                }
            }
            AntiWindup::DiagonalLimit { max } => {
                let m = self.max_diagonal();
                if m > max {
                    self.scale(max / m);
                    status |= Status::COVARIANCE_BOUNDED;
                }
            }
            AntiWindup::ConstantTrace { trace } => {
                let tr = self.trace();
                self.scale(trace / tr);
                status |= Status::TRACE_NORMALISED;
            }
        }
        status
    }
}
