//! RLS in `f64`, in two forms: the textbook covariance update (re-symmetrised) and Bierman's UD
//! update (the algorithm the fixed-point kernel implements).
//!
//! The textbook form is what most tools implement; on badly scaled regressors (differenced EMPS:
//! |Δy| ~ 10³ counts, |Δu| ~ 10⁻⁴ of full scale) its `P − ggᵀ/α` cancels catastrophically even in
//! float64 (`host-tests/tests/integration/emps_vs_f64.rs` shows it 17 % away from the exact batch solution). The
//! UD form is the reference the fixed-point path is held to.

// The reference mirrors the equations index for index (Uᵢⱼ, κᵢ): readability over iterator style.
#![allow(clippy::needless_range_loop)]

use sledid::Status;
use sledid::ident::rls::AntiWindup;

/// Which covariance update the reference uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CovarianceForm {
    /// `P ← (P − K ψᵀP)/λ`, re-symmetrised.
    Textbook,
    /// P = UDUᵀ, Bierman's update (as the fixed-point kernel).
    Bierman,
}

/// RLS with forgetting, in float64.
#[derive(Clone, Debug)]
pub struct RlsF64<const N: usize> {
    /// The covariance update used.
    pub form: CovarianceForm,
    /// Unit upper-triangular U (Bierman form only).
    pub u: [[f64; N]; N],
    /// Diagonal D (Bierman form only).
    pub d: [f64; N],
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
    /// Set when an update capped some dⱼ ([`AntiWindup::FactorCap`]).
    capped: bool,
}

impl<const N: usize> RlsF64<N> {
    /// θ = `theta0`, P = p0·I.
    pub fn new(design: &sledid::ident::rls::RlsDesign, theta0: [f64; N]) -> Self {
        let mut p = [[0.0; N]; N];
        for (i, row) in p.iter_mut().enumerate() {
            row[i] = design.p0;
        }
        Self {
            form: CovarianceForm::Bierman,
            u: [[0.0; N]; N],
            d: [design.p0; N],
            theta: theta0,
            p,
            lambda: design.lambda,
            dead_zone: design.dead_zone,
            excitation_threshold: design.excitation_threshold,
            anti_windup: design.anti_windup,
            enabled: true,
            last_overridden: false,
            capped: false,
        }
    }

    /// ψᵀθ.
    pub fn predict(&self, psi: &[f64; N]) -> f64 {
        psi.iter().zip(self.theta.iter()).map(|(a, b)| a * b).sum()
    }

    /// The covariance P (formed from U and D in the Bierman form).
    pub fn covariance(&self) -> [[f64; N]; N] {
        match self.form {
            CovarianceForm::Textbook => self.p,
            CovarianceForm::Bierman => {
                let mut p = [[0.0; N]; N];
                for (i, row) in p.iter_mut().enumerate() {
                    for (j, x) in row.iter_mut().enumerate() {
                        // P_ij = Σ_k U_ik d_k U_jk with U unit upper-triangular.
                        *x = (i.max(j)..N)
                            .map(|k| {
                                let uik = if k == i { 1.0 } else { self.u[i][k] };
                                let ujk = if k == j { 1.0 } else { self.u[j][k] };
                                uik * self.d[k] * ujk
                            })
                            .sum();
                    }
                }
                p
            }
        }
    }

    /// trace(P).
    pub fn trace(&self) -> f64 {
        let p = self.covariance();
        (0..N).map(|i| p[i][i]).sum()
    }

    /// The largest diagonal element of P.
    pub fn max_diagonal(&self) -> f64 {
        let p = self.covariance();
        (0..N).map(|i| p[i][i]).fold(f64::MIN, f64::max)
    }

    fn scale(&mut self, k: f64) {
        for row in &mut self.p {
            for x in row {
                *x *= k;
            }
        }
        for d in &mut self.d {
            *d *= k;
        }
    }

    /// ψᵀPψ without changing anything.
    fn excitation(&self, psi: &[f64; N]) -> f64 {
        match self.form {
            CovarianceForm::Textbook => {
                let mut s = 0.0;
                for (row, pi) in self.p.iter().zip(psi.iter()) {
                    s += pi * row.iter().zip(psi.iter()).map(|(a, b)| a * b).sum::<f64>();
                }
                s
            }
            CovarianceForm::Bierman => {
                let f = self.ut_psi(psi);
                f.iter().zip(self.d.iter()).map(|(f, d)| d * f * f).sum()
            }
        }
    }

    fn ut_psi(&self, psi: &[f64; N]) -> [f64; N] {
        let mut f = *psi;
        for (j, fj) in f.iter_mut().enumerate() {
            for i in 0..j {
                *fj += self.u[i][j] * psi[i];
            }
        }
        f
    }

    /// Bierman's update; returns the gain K.
    fn bierman(&mut self, psi: &[f64; N]) -> [f64; N] {
        let f = self.ut_psi(psi);
        let mut kappa = [0.0; N];
        let mut alpha_prev = self.lambda;
        for j in 0..N {
            let v = self.d[j] * f[j];
            let alpha = alpha_prev + v * f[j];
            let r = alpha_prev / alpha;
            let g = v / alpha;
            self.d[j] *= r / self.lambda;
            if let Some(cap) = self.anti_windup.factor_cap() {
                let cap = cap.to_f64();
                if self.d[j] > cap {
                    self.d[j] = cap;
                    self.capped = true;
                }
            }
            for i in 0..j {
                let u_old = self.u[i][j];
                self.u[i][j] -= f[j] * kappa[i];
                kappa[i] = kappa[i] * r + u_old * g;
            }
            kappa[j] = g;
            alpha_prev = alpha;
        }
        kappa
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
        let s = self.excitation(psi);
        let own = self.gate(psi, eps, s);
        self.last_overridden = force.is_some_and(|f| f != own.is_ok());
        match (own, force) {
            (Err(flag), None) => return flag,
            (_, Some(false)) => return Status::DEAD_ZONE,
            _ => {}
        }
        self.capped = false;
        if self.form == CovarianceForm::Bierman {
            let k = self.bierman(psi);
            for (th, ki) in self.theta.iter_mut().zip(k.iter()) {
                *th += ki * eps;
            }
        } else {
            let mut p_psi = [0.0; N];
            for (pp, row) in p_psi.iter_mut().zip(self.p.iter()) {
                *pp = row.iter().zip(psi.iter()).map(|(a, b)| a * b).sum();
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
        }
        let mut status = Status::UPDATED;
        if self.capped {
            status |= Status::COVARIANCE_BOUNDED;
        }
        match self.anti_windup {
            AntiWindup::None | AntiWindup::FactorCap { .. } => {}
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
