//! The paper's linear model structures as recursive estimators: ARX (eq. 1) and output error (eq. 2),
//! the latter both as a pseudo-linear regression and as a recursive prediction-error (Gauss–Newton)
//! method, with a stability projection on the denominator.
//!
//! ```text
//! ARX:  y(t) = −a₁y(t−1) − … − a_na y(t−na) + b₁u(t−nk) + … + b_nb u(t−nk−nb+1) + e(t)      (eq. 1)
//! OE:   ŷ(t) = −f₁ŷ(t−1) − … − f_nf ŷ(t−nf) + b₁u(t−nk) + …,   y(t) = ŷ(t) + e(t)        (eq. 2)
//! ```
//! θ = [a₁ … a_na, b₁ … b_nb] (or f instead of a). ARX may carry a Coulomb friction term
//! (`coulomb`): θ = [a…, b…, c] with the regressor entry −sign(y(t−1)), so that on a differenced
//! (velocity) output `Δy(t) = −a₁Δy(t−1) + b₁u(t−1) − c·sign(Δy(t−1))`: the drive loses
//! u_c = c/Σb to friction while the sled moves. Friction does not push, so c ≥ 0 is kept by
//! projecting in the metric of P⁻¹ (θ ← θ − P·e_c·c/P_cc, which moves the parameters c is
//! confounded with — the gain, while the drive saturates in the direction of motion — by what c
//! gave up; with c last in θ and P = U·D·Uᵀ, P·e_c/P_cc is U's last column). Per sample, with
//! φ(t) the regressor of lagged
//! outputs (measured y for ARX, simulated ŷ for OE) and inputs:
//! - ARX and OE pseudo-linear regression (PLR): update with ψ = φ;
//! - OE prediction-error (RPEM): update with the gradient of the simulated output,
//!   ψ(t) = φ(t) / F̂(q), i.e. ψ(t) = φ(t) − f̂₁ψ(t−1) − f̂₂ψ(t−2).
//!
//! ε(t) = y(t) − φ(t)ᵀθ(t−1) (a priori); the OE history stores the a posteriori simulated output
//! φ(t)ᵀθ(t). After each update, if the denominator leaves |z| ≤ ρ the step is halved up to four times
//! and otherwise undone ([`Status::PROJECTED`]); P keeps its update (Ljung 1999, §11.3).

use crate::error::ConfigError;
use crate::ident::estimator::{Estimate, Estimator, EstimatorDesign};
use crate::ident::regressor::History;
pub use crate::ident::regressor::MAX_DELAY;
use crate::ident::rls::{RlsConfig, RlsDesign, RlsState};
use crate::ident::stability::{PoleRadius, project_denominator};
use crate::ident::status::Status;
use crate::num::fixed::{ParamI12F20, SignalI16F16};
use crate::words::{WordReader, WordWriter, Words};

/// Which linear structure is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Structure {
    /// ARX (eq. 1): linear regression on measured outputs.
    Arx,
    /// Output error (eq. 2), pseudo-linear regression on simulated outputs.
    OutputErrorPseudoLinear,
    /// Output error (eq. 2), recursive prediction-error method (regressor filtered by 1/F̂).
    OutputErrorPredictionError,
}

/// Number of parameters θ of a linear structure: na + nb (+ 1 with a Coulomb term), the N of its
/// [`LinearDesign`] (saturating: an overflowing order matches no N).
pub const fn parameter_count(na: usize, nb: usize, coulomb: bool) -> usize {
    na.saturating_add(nb).saturating_add(coulomb as usize)
}

/// User-facing settings of a linear model estimator with N = [`parameter_count`]`(na, nb,
/// coulomb)` parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearDesign<const N: usize> {
    /// The structure.
    pub structure: Structure,
    /// Denominator order (1 or 2 when a stability margin is set).
    pub na: usize,
    /// Numerator order.
    pub nb: usize,
    /// Input delay in samples (0 ..= 8).
    pub nk: usize,
    /// A Coulomb term: θ's last entry c, regressor −sign(y(t−1)) (ARX only).
    pub coulomb: bool,
    /// Initial parameters [a…, b…] (and c) (e.g. the linear model a nonlinear one starts from).
    pub theta0: [f64; N],
    /// The recursive least-squares settings.
    pub rls: RlsDesign,
    /// Stability margin: the denominator's roots are kept in |z| ≤ 1 − margin. `None` disables the
    /// projection (ARX only; output-error structures require it).
    pub stability_margin: Option<f64>,
}

impl<const N: usize> LinearDesign<N> {
    /// A first- or second-order design with defaults: θ₀ = 0, nk = 1, margin 0 (|poles| ≤ 1).
    pub fn new(structure: Structure, na: usize, nb: usize) -> Self {
        Self {
            structure,
            na,
            nb,
            nk: 1,
            coulomb: false,
            theta0: [0.0; N],
            rls: RlsDesign::default(),
            stability_margin: Some(0.0),
        }
    }

    /// Validates and quantises.
    ///
    /// # Errors
    /// A [`ConfigError`] naming the parameter: orders, delay, margin, θ₀ (out of format or unstable),
    /// a Coulomb term off ARX, or any RLS setting.
    pub fn build(&self) -> Result<LinearConfig<N>, ConfigError> {
        let order_err = ConfigError::ModelOrder {
            na: self.na,
            nb: self.nb,
            n: N,
        };
        if self.na == 0 || self.nb == 0 || parameter_count(self.na, self.nb, self.coulomb) != N {
            return Err(order_err);
        }
        if self.coulomb && self.structure != Structure::Arx {
            return Err(ConfigError::CoulombTerm);
        }
        if self.nk > MAX_DELAY {
            return Err(ConfigError::Delay(self.nk));
        }
        let is_oe = self.structure != Structure::Arx;
        let radius = match self.stability_margin {
            Some(m) => Some(PoleRadius::from_margin(m)?),
            None if is_oe => return Err(ConfigError::StabilityMargin(f64::NAN)),
            None => None,
        };
        if radius.is_some() && self.na > 2 {
            return Err(order_err);
        }
        let mut theta0 = [ParamI12F20::ZERO; N];
        for (q, &x) in theta0.iter_mut().zip(self.theta0.iter()) {
            *q = ParamI12F20::from_f64(x).map_err(|_| ConfigError::InitialModel(x))?;
        }
        if let (Some(r), Some(den)) = (radius, theta0.get(..self.na))
            && !r.contains(den)
        {
            let f1 = self.theta0.first().copied().unwrap_or(0.0);
            return Err(ConfigError::InitialModel(f1));
        }
        let config = LinearConfig {
            structure: self.structure,
            na: self.na,
            nk: self.nk,
            coulomb: self.coulomb,
            theta0,
            rls: self.rls.build()?,
            radius,
        };
        config.validate()?;
        Ok(config)
    }
}

impl<const N: usize> LinearConfig<N> {
    /// The invariants the estimator relies on, checked by [`LinearDesign::build`] and by the
    /// decoding of configuration words alike: `1 ≤ na < N` (`< N − 1` with a Coulomb term, ARX
    /// only), `nk ≤ MAX_DELAY`, a pole radius for OE (and only orders ≤ 2 with one), and θ₀'s
    /// denominator inside it.
    ///
    /// # Errors
    /// [`ConfigError::ModelOrder`], [`ConfigError::CoulombTerm`], [`ConfigError::Delay`],
    /// [`ConfigError::StabilityMargin`] or [`ConfigError::InitialModel`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        let na = self.na;
        let inputs = N.saturating_sub(usize::from(self.coulomb));
        if !(1..inputs).contains(&na) {
            return Err(ConfigError::ModelOrder {
                na,
                nb: inputs.saturating_sub(na),
                n: N,
            });
        }
        if self.coulomb && self.structure != Structure::Arx {
            return Err(ConfigError::CoulombTerm);
        }
        if self.nk > MAX_DELAY {
            return Err(ConfigError::Delay(self.nk));
        }
        match (self.radius, self.theta0.get(..na)) {
            (Some(radius), Some(den)) => {
                radius.validate()?;
                if na > 2 {
                    return Err(ConfigError::ModelOrder {
                        na,
                        nb: inputs - na,
                        n: N,
                    });
                }
                if !radius.contains(den) {
                    let f1 = self.theta0.first().map_or(f64::NAN, |p| p.to_f64());
                    return Err(ConfigError::InitialModel(f1));
                }
                Ok(())
            }
            (None, _) if self.structure == Structure::Arx => Ok(()),
            _ => Err(ConfigError::StabilityMargin(f64::NAN)),
        }
    }
}

/// Validated configuration of a linear model estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinearConfig<const N: usize> {
    structure: Structure,
    na: usize,
    nk: usize,
    coulomb: bool,
    theta0: [ParamI12F20; N],
    rls: RlsConfig,
    radius: Option<PoleRadius>,
}

/// Everything a linear model estimator mutates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinearState<const N: usize> {
    rls: RlsState<N>,
    history: History<N>,
    psi_lag: [[SignalI16F16; N]; 2],
}

impl<const N: usize> LinearConfig<N> {
    /// A fresh state at θ₀, P = p₀·I, zero history.
    pub fn new_state(&self) -> LinearState<N> {
        LinearState {
            rls: RlsState::new(&self.rls, self.theta0),
            history: History::default(),
            psi_lag: [[SignalI16F16::ZERO; N]; 2],
        }
    }

    /// The RLS configuration.
    pub fn rls(&self) -> &RlsConfig {
        &self.rls
    }

    /// The structure.
    pub fn structure(&self) -> Structure {
        self.structure
    }

    /// Denominator order.
    pub fn na(&self) -> usize {
        self.na
    }

    /// Input delay.
    pub fn nk(&self) -> usize {
        self.nk
    }

    /// θ ends with a Coulomb term.
    pub fn coulomb(&self) -> bool {
        self.coulomb
    }

    /// Resets θ to θ₀ and P to p₀·I, keeps the signal history.
    pub fn reset(&self, st: &mut LinearState<N>) -> Status {
        st.rls.reset(&self.rls, self.theta0);
        st.psi_lag = [[SignalI16F16::ZERO; N]; 2];
        Status::RESET
    }

    /// One sample: conditioned output y(t) and input u(t). Never panics.
    pub fn step(&self, st: &mut LinearState<N>, y: SignalI16F16, u: SignalI16F16) -> Estimate {
        st.history.push_input(u);
        let mut phi = st.history.regressor(self.na, self.nk);
        if self.coulomb
            && let Some(last) = phi.last_mut()
        {
            // −sign(y(t−1)): the friction opposes the last motion (0 at rest). Not while the
            // input is at full scale: the drive then saturates in the direction of motion, u and
            // the sign are collinear and the friction cannot be told from the gain (the gain
            // absorbs it meanwhile: b − c for |u| = 1).
            let saturated = st.history.input_lag(self.nk).raw().unsigned_abs() >= 1 << 16;
            *last = match st.history.output_lag(1).raw().signum() {
                _ if saturated => SignalI16F16::ZERO,
                1 => SignalI16F16::from_int(-1),
                -1 => SignalI16F16::from_int(1),
                _ => SignalI16F16::ZERO,
            };
        }
        let mut sat = false;
        let theta_old = *st.rls.theta();
        let theta_old_i16f48 = *st.rls.theta_i16f48();
        let y_hat = RlsConfig::predict(&theta_old, &phi, &mut sat);
        let eps = y.saturating_sub(y_hat);
        let psi = match self.structure {
            Structure::Arx | Structure::OutputErrorPseudoLinear => phi,
            Structure::OutputErrorPredictionError => self.filtered_gradient(st, &phi, &theta_old),
        };
        let mut status = self.rls.update(&mut st.rls, &psi, eps);
        status |= self.project(st, &theta_old_i16f48);
        if self.coulomb {
            status |= project_friction(&mut st.rls);
        }
        let lagged = match self.structure {
            Structure::Arx => y,
            _ => RlsConfig::predict(st.rls.theta(), &phi, &mut sat),
        };
        st.history.push_output(lagged);
        status.set_if(Status::SATURATED, sat);
        Estimate { y_hat, eps, status }
    }

    /// ψ(t) = φ(t) − f̂₁ψ(t−1) − f̂₂ψ(t−2) (only the first `na` ≤ 2 coefficients act).
    fn filtered_gradient(
        &self,
        st: &mut LinearState<N>,
        phi: &[SignalI16F16; N],
        theta: &[ParamI12F20; N],
    ) -> [SignalI16F16; N] {
        let mut psi = *phi;
        let mut sat = false;
        for (k, p) in psi.iter_mut().enumerate() {
            let mut acc_i28f36 = i64::from(p.raw()) << 20;
            for (lag, f) in st.psi_lag.iter().zip(theta.iter().take(self.na.min(2))) {
                let prev = lag.get(k).map_or(0, |x| i64::from(x.raw()));
                acc_i28f36 = acc_i28f36.saturating_sub(i64::from(f.raw()) * prev);
            }
            let raw = crate::num::fixed::shr_round_i64(acc_i28f36, 20);
            *p = SignalI16F16::from_raw(crate::num::fixed::sat_i32(raw, &mut sat));
        }
        st.psi_lag.swap(0, 1);
        if let Some(first) = st.psi_lag.first_mut() {
            *first = psi;
        }
        psi
    }

    /// Keeps the denominator inside the allowed pole region ([`project_denominator`]).
    fn project(&self, st: &mut LinearState<N>, theta_old_i16f48: &[i64; N]) -> Status {
        match self.radius {
            Some(radius) => project_denominator(radius, self.na, &mut st.rls, theta_old_i16f48),
            None => Status::NONE,
        }
    }
}

/// θ's last entry c (the Coulomb term) kept ≥ 0: θ ← θ − U[:, N−1]·c when c < 0 (the projection
/// onto c = 0 in the metric of P⁻¹; U's last column is P·e_c/P_cc, its last entry 1).
fn project_friction<const N: usize>(rls: &mut RlsState<N>) -> Status {
    let mut theta = *rls.theta();
    let c = match theta.last() {
        Some(c) if c.raw() < 0 => i64::from(c.raw()),
        _ => return Status::NONE,
    };
    // U's last column, column-major storage: u[N−1][i] = Uᵢ,N−1 (I8F24).
    let last_col = rls.u_i8f24().last().copied().unwrap_or([0; N]);
    for (t, u) in theta.iter_mut().zip(last_col.iter()) {
        // I8F24 × I12F20 → I20F44, back to I12F20 (|u·c| < 2⁶²).
        let raw = i64::from(t.raw())
            - crate::num::fixed::shr_round_i64(i64::from(*u) * c, crate::ident::rls::U_FRAC_BITS);
        *t = ParamI12F20::from_raw(raw.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32);
    }
    if let Some(last) = theta.last_mut() {
        // U's diagonal is 1 (implicit): c − 1·c = 0 exactly.
        *last = ParamI12F20::ZERO;
    }
    rls.set_theta(theta);
    Status::PROJECTED
}

impl<const N: usize> LinearState<N> {
    /// The current estimate θ = [a… or f…, b…].
    pub fn theta(&self) -> &[ParamI12F20; N] {
        self.rls.theta()
    }

    /// The estimator state (θ, UD factors).
    pub fn rls(&self) -> &RlsState<N> {
        &self.rls
    }

    /// Holds (false) or enables (true) adaptation.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.rls.set_enabled(enabled);
    }
}

impl<const N: usize> EstimatorDesign<N> for LinearDesign<N> {
    type Config = LinearConfig<N>;

    fn build(&self) -> Result<LinearConfig<N>, ConfigError> {
        LinearDesign::build(self)
    }
}

impl<const N: usize> Estimator<N> for LinearConfig<N> {
    type State = LinearState<N>;

    fn new_state(&self) -> LinearState<N> {
        LinearConfig::new_state(self)
    }

    fn step(&self, state: &mut LinearState<N>, y: SignalI16F16, u: SignalI16F16) -> Estimate {
        LinearConfig::step(self, state, y, u)
    }

    fn theta<'a>(&self, state: &'a LinearState<N>) -> &'a [ParamI12F20; N] {
        state.theta()
    }

    fn covariance_positive_definite(&self, state: &LinearState<N>) -> bool {
        state.rls().is_positive_definite()
    }

    fn set_enabled(&self, state: &mut LinearState<N>, enabled: bool) {
        state.set_enabled(enabled);
    }

    fn seed(&self, state: &mut LinearState<N>, theta: &[ParamI12F20; N]) {
        state.rls.reset(&self.rls, *theta);
    }
}

/// Words: the variant's index (`Arx` 0, `OutputErrorPseudoLinear` 1, `OutputErrorPredictionError`
/// 2).
impl Words for Structure {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(match self {
            Self::Arx => 0,
            Self::OutputErrorPseudoLinear => 1,
            Self::OutputErrorPredictionError => 2,
        })
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        match r.word() {
            0 => Self::Arx,
            1 => Self::OutputErrorPseudoLinear,
            2 => Self::OutputErrorPredictionError,
            _ => {
                r.fail();
                Self::Arx
            }
        }
    }
}

impl<const N: usize> LinearDesign<N> {
    /// Builds the design and appends its configuration words ([`crate::words`]): structure, na,
    /// nk, the Coulomb term, θ₀ (raw I12F20), the pole radius if any, then the quantised RLS
    /// settings ([`RlsConfig`]'s words).
    ///
    /// # Errors
    /// [`Self::build`]'s errors, or [`ConfigError::Words`] when `w`'s buffer is full.
    pub fn put_words(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        let c = self.build()?;
        c.structure.put(w)?;
        c.na.put(w)?;
        c.nk.put(w)?;
        c.coulomb.put(w)?;
        c.theta0.put(w)?;
        c.radius.put(w)?;
        c.rls.put(w)
    }
}

impl<const N: usize> LinearConfig<N> {
    /// Reads the words of [`LinearDesign::put_words`] with [`LinearDesign::build`]'s checks
    /// (orders, delay, a pole radius for OE and a stable θ₀ inside it) and the RLS settings'
    /// ([`RlsConfig::validate`]): no `f64` arithmetic.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first bad word, or the first setting out of range.
    pub fn take_words(r: &mut WordReader<'_>) -> Result<Self, ConfigError> {
        let structure = Structure::take(r);
        let na = usize::take(r);
        let nk = usize::take(r);
        let coulomb = bool::take(r);
        let theta0 = <[ParamI12F20; N]>::take(r);
        let radius = <Option<PoleRadius> as Words>::take(r);
        let rls = RlsConfig::take(r);
        r.status()?;
        rls.validate()?;
        let config = Self {
            structure,
            na,
            nk,
            coulomb,
            theta0,
            rls,
            radius,
        };
        config.validate()?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(x: f64) -> SignalI16F16 {
        SignalI16F16::from_f64(x).unwrap()
    }

    /// A first-order plant y(t) = 0.9 y(t−1) + 0.5 u(t−1) with a square-wave input.
    fn run(structure: Structure) -> [f64; 2] {
        let cfg = LinearDesign::<2>::new(structure, 1, 1).build().unwrap();
        let mut st = cfg.new_state();
        let (mut y, mut u_prev) = (0.0, 0.0);
        for t in 0..3000 {
            let u = if (t / 37) % 2 == 0 { 1.0 } else { -1.0 };
            y = 0.9 * y + 0.5 * u_prev;
            u_prev = u;
            let _ = cfg.step(&mut st, s(y), s(u));
        }
        // The sample at t used y(t) computed from u(t−1): the step sees (y(t), u(t)).
        let th = st.theta();
        [th[0].to_f64(), th[1].to_f64()]
    }

    #[test]
    fn every_structure_recovers_a_first_order_plant() {
        for structure in [
            Structure::Arx,
            Structure::OutputErrorPseudoLinear,
            Structure::OutputErrorPredictionError,
        ] {
            let th = run(structure);
            assert!((th[0] + 0.9).abs() < 2e-3, "{structure:?} {th:?}");
            assert!((th[1] - 0.5).abs() < 2e-3, "{structure:?} {th:?}");
        }
    }

    #[test]
    fn design_rejects_bad_orders_and_unstable_start() {
        let mut d = LinearDesign::<2>::new(Structure::Arx, 1, 1);
        assert!(d.build().is_ok());
        d.na = 2;
        assert!(matches!(d.build(), Err(ConfigError::ModelOrder { .. })));
        d.na = 1;
        d.nk = 9;
        assert_eq!(d.build(), Err(ConfigError::Delay(9)));
        d.nk = 1;
        d.theta0 = [-1.5, 0.0];
        assert!(matches!(d.build(), Err(ConfigError::InitialModel(_))));
        let mut oe = LinearDesign::<2>::new(Structure::OutputErrorPseudoLinear, 1, 1);
        oe.stability_margin = None;
        assert!(matches!(oe.build(), Err(ConfigError::StabilityMargin(_))));
    }

    /// A velocity plant with Coulomb friction, v(t) = 0.8·v(t−1) + 2·(u(t−1) − 0.1·sign v(t−1)):
    /// the Coulomb term recovers c = 0.2 beside a and b; without it the estimate is biased.
    #[test]
    fn a_coulomb_term_recovers_the_friction() {
        let run = |coulomb: bool| {
            let mut d = LinearDesign::<3>::new(Structure::Arx, 1, 1 + usize::from(!coulomb));
            d.coulomb = coulomb;
            let cfg = d.build().unwrap();
            let mut st = cfg.new_state();
            let (mut v, mut u_prev) = (0.0f64, 0.0);
            for t in 0..4000 {
                let u = 0.3 * (t as f64 * 0.05).sin() + if (t / 50) % 2 == 0 { 0.2 } else { -0.2 };
                v = 0.8 * v + 2.0 * (u_prev - 0.1 * v.signum() * f64::from(v != 0.0));
                u_prev = u;
                let _ = cfg.step(&mut st, s(v), s(u));
            }
            st.theta().map(|p| p.to_f64())
        };
        let th = run(true);
        assert!((th[0] + 0.8).abs() < 5e-3, "{th:?}");
        assert!((th[1] - 2.0).abs() < 5e-3, "{th:?}");
        assert!((th[2] - 0.2).abs() < 5e-3, "{th:?}");
        // ARX(1, 2) without the term cannot explain the friction: its gain is off (measured
        // b₁ = 2.032, a₁ = −0.811).
        let plain = run(false);
        assert!((plain[1] - 2.0).abs() > 2e-2, "{plain:?}");
    }

    #[test]
    fn a_coulomb_term_needs_arx_and_its_parameter() {
        let mut d = LinearDesign::<3>::new(Structure::Arx, 1, 1);
        d.coulomb = true;
        assert!(d.build().is_ok());
        d.nb = 2;
        assert!(matches!(d.build(), Err(ConfigError::ModelOrder { .. })));
        d.nb = 1;
        d.structure = Structure::OutputErrorPseudoLinear;
        assert_eq!(d.build(), Err(ConfigError::CoulombTerm));
    }

    #[test]
    fn projection_keeps_the_pole_inside() {
        let mut d = LinearDesign::<2>::new(Structure::Arx, 1, 1);
        d.stability_margin = Some(0.05);
        let cfg = d.build().unwrap();
        let mut st = cfg.new_state();
        // An unstable plant: y(t) = 1.02 y(t−1) + u(t−1).
        let (mut y, mut u_prev) = (0.0f64, 0.0);
        let mut projected = 0;
        for t in 0..400 {
            let u = if (t / 9) % 2 == 0 { 0.5 } else { -0.5 };
            y = (1.02 * y + u_prev).clamp(-1000.0, 1000.0);
            u_prev = u;
            let e = cfg.step(&mut st, s(y), s(u));
            if e.status.contains(Status::PROJECTED) {
                projected += 1;
            }
            assert!(st.theta()[0].to_f64().abs() <= 0.95 + 1e-6);
        }
        assert!(projected > 0);
    }
}
