//! The paper's nonlinear models (eq. 5, 6, 7, the Wiener model of Fig. 16, and the friction-feedback
//! structure its conclusion proposes) as on-line, fixed-point recursive prediction-error estimators.
//!
//! # The recursion (recursive Gauss–Newton on the simulation error, Ljung 1999, §11.2)
//! With the structure's simulation step ([`structure`]) `s(t) = F(θ; s(t−1), s(t−2), u(t−1),
//! u(t−2))`, `ŷ(t) = H(θ; s(t))`, per sample:
//! ```text
//! ŷ(t) = H(F(θ(t−1); …))                                   simulated output (a priori)
//! ψₛ(t) = ∂F/∂θ + ∂F/∂s₁·ψₛ(t−1) + ∂F/∂s₂·ψₛ(t−2)           sensitivity of the state
//! ψ(t)  = ∂H/∂θ + ∂H/∂s·ψₛ(t)                              gradient of the simulated output
//! ε(t)  = y(t) − ŷ(t)
//! θ(t) = θ(t−1) + P(t)ψ(t)ε(t),  P by Bierman's UD update   ([`crate::ident::rls`], its anti-windup)
//! ```
//! then the stability projection keeps the linear denominator θ[..na] inside |z| ≤ ρ
//! ([`crate::ident::stability::project_denominator`]). The simulated state is kept a priori (computed with
//! θ(t−1)): the sensitivities describe exactly the sequence that was simulated.
//!
//! For eq. 6 and the friction model the feedback coefficients ∂F/∂s depend on the neuron
//! (−f₁ + w·a·(1 − tanh²)): when they leave the pole region the sensitivity filter would diverge,
//! so that sample is filtered by the (projected, stable) linear denominator alone
//! ([`Status::GRADIENT_LIMITED`]).
//!
//! # Initialisation (the paper's, after Sjöberg)
//! [`NonlinearDesign::from_linear`] starts from the linear model (OE1 or OE2): output weights w = 0,
//! so the model equals the linear one and is stable; input weights 1/range so no neuron starts
//! saturated; the two Hammerstein biases at ±0.5 so the two neurons differ.
//!
//! # Formats
//! Signals (s, ŷ, ε, ψ) I16F16 in the conditioned units (y in quanta, u in full-scale units), θ
//! I12F20, feedback coefficients I12F20; the neuron as [`crate::ident::neuron::term`]. Every narrowing saturates and sets
//! [`Status::SATURATED`].

#![deny(clippy::float_arithmetic)]

pub mod structure;

pub use structure::{Lags, NonlinearStructure};

use crate::error::ConfigError;
use crate::ident::estimator::Estimate;
use crate::ident::estimator::{Estimator, EstimatorDesign};
use crate::ident::neuron::INITIAL_BIAS_SPREAD;
use crate::ident::rls::{RlsConfig, RlsDesign, RlsState};
use crate::ident::stability::{PoleRadius, project_denominator};
use crate::ident::status::Status;
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::mul_i32_wide;
use crate::words::{WordReader, WordWriter, Words};

/// The expected ranges of the neurons' inputs, for the initial input weights (conditioned units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputRanges {
    /// Largest expected |u| (full-scale units).
    pub u: f64,
    /// Largest expected |ŷ| (quanta).
    pub y: f64,
    /// Largest expected |ŷ(t−1) − ŷ(t−2)| (quanta per sample).
    pub dy: f64,
}

/// User-facing settings of a nonlinear model estimator with N parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NonlinearDesign<const N: usize> {
    /// The structure; N must equal its [`NonlinearStructure::parameter_count`].
    pub structure: NonlinearStructure,
    /// Initial θ in the structure's layout ([`structure`]).
    pub theta0: [f64; N],
    /// The recursive least-squares settings (forgetting, anti-windup, gates).
    pub rls: RlsDesign,
    /// The denominator's roots are kept in |z| ≤ 1 − margin, margin ∈ [0, 0.5).
    pub stability_margin: f64,
}

impl<const N: usize> NonlinearDesign<N> {
    /// The paper's initialisation from a linear model `linear` = [f₁ (f₂) b₁ (b₂)] (2·na entries):
    /// every w = 0, input weights 1/range (the two-input neuron: 0.5/range each), the Hammerstein
    /// biases at ∓[`INITIAL_BIAS_SPREAD`], other biases 0. A `linear` of the wrong length or a
    /// range that is not finite and positive gives NaN entries, which [`Self::build`] rejects.
    #[allow(clippy::float_arithmetic)] // design time, not the per-sample path
    pub fn from_linear(structure: NonlinearStructure, linear: &[f64], ranges: InputRanges) -> Self {
        let mut theta0 = [f64::NAN; N];
        let inv = |r: f64| {
            if r.is_finite() && r > 0.0 {
                1.0 / r
            } else {
                f64::NAN
            }
        };
        let na = structure.na();
        let neuron: &[f64] = match structure {
            NonlinearStructure::Hammerstein => &[
                0.0,
                inv(ranges.u),
                -INITIAL_BIAS_SPREAD,
                0.0,
                inv(ranges.u),
                INITIAL_BIAS_SPREAD,
            ],
            NonlinearStructure::NoeOutputInput => {
                &[0.0, 0.5 * inv(ranges.y), 0.5 * inv(ranges.u), 0.0]
            }
            NonlinearStructure::Noe221 => &[0.0, inv(ranges.u), 0.0],
            NonlinearStructure::Wiener => &[0.0, inv(ranges.y), 0.0],
            NonlinearStructure::FrictionFeedback => &[0.0, inv(ranges.dy), 0.0],
        };
        if linear.len() == 2 * na && 2 * na + neuron.len() == N {
            for (t, v) in theta0.iter_mut().zip(linear.iter().chain(neuron.iter())) {
                *t = *v;
            }
        }
        Self {
            structure,
            theta0,
            rls: RlsDesign::default(),
            stability_margin: 0.0,
        }
    }

    /// Validates and quantises.
    ///
    /// # Errors
    /// [`ConfigError::ParameterCount`] when N does not match the structure,
    /// [`ConfigError::StabilityMargin`], [`ConfigError::InitialModel`] (θ₀ out of format, NaN or
    /// an unstable denominator), or any RLS setting's error.
    pub fn build(&self) -> Result<NonlinearConfig<N>, ConfigError> {
        let expected = self.structure.parameter_count();
        if expected != N {
            return Err(ConfigError::ParameterCount { expected, n: N });
        }
        let radius = PoleRadius::from_margin(self.stability_margin)?;
        let mut theta0 = [ParamI12F20::ZERO; N];
        for (q, &x) in theta0.iter_mut().zip(self.theta0.iter()) {
            *q = ParamI12F20::from_f64(x).map_err(|_| ConfigError::InitialModel(x))?;
        }
        let config = NonlinearConfig {
            structure: self.structure,
            theta0,
            rls: self.rls.build()?,
            radius,
        };
        config.validate()?;
        Ok(config)
    }
}

/// Validated configuration of a nonlinear model estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NonlinearConfig<const N: usize> {
    structure: NonlinearStructure,
    theta0: [ParamI12F20; N],
    rls: RlsConfig,
    radius: PoleRadius,
}

/// Everything a nonlinear model estimator mutates.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NonlinearState<const N: usize> {
    rls: RlsState<N>,
    lags: Lags,
    /// ψₛ(t−1), ψₛ(t−2).
    psi_s_lag: [[SignalI16F16; N]; 2],
}

impl<const N: usize> NonlinearConfig<N> {
    /// The invariants the estimator relies on, checked by [`NonlinearDesign::build`] and by the
    /// decoding of configuration words alike: N the structure's parameter count, a valid pole
    /// radius, θ₀'s denominator inside it.
    ///
    /// # Errors
    /// [`ConfigError::ParameterCount`], [`ConfigError::StabilityMargin`] or
    /// [`ConfigError::InitialModel`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        let expected = self.structure.parameter_count();
        if expected != N {
            return Err(ConfigError::ParameterCount { expected, n: N });
        }
        self.radius.validate()?;
        let na = self.structure.na();
        if !self
            .theta0
            .get(..na)
            .is_some_and(|den| self.radius.contains(den))
        {
            let f1 = self.theta0.first().map_or(f64::NAN, |p| p.to_f64());
            return Err(ConfigError::InitialModel(f1));
        }
        Ok(())
    }

    /// A fresh state at θ₀, P = p₀·I, zero history.
    pub fn new_state(&self) -> NonlinearState<N> {
        NonlinearState {
            rls: RlsState::new(&self.rls, self.theta0),
            lags: Lags::default(),
            psi_s_lag: [[SignalI16F16::ZERO; N]; 2],
        }
    }

    /// The structure.
    pub fn structure(&self) -> NonlinearStructure {
        self.structure
    }

    /// The RLS configuration.
    pub fn rls(&self) -> &RlsConfig {
        &self.rls
    }

    /// Resets θ to θ₀ and P to p₀·I; keeps the simulated state.
    pub fn reset(&self, st: &mut NonlinearState<N>) -> Status {
        st.rls.reset(&self.rls, self.theta0);
        st.psi_s_lag = [[SignalI16F16::ZERO; N]; 2];
        Status::RESET
    }

    /// One sample: conditioned output y(t) and input u(t). Never panics.
    pub fn step(&self, st: &mut NonlinearState<N>, y: SignalI16F16, u: SignalI16F16) -> Estimate {
        let theta_old = *st.rls.theta();
        let theta_old_i16f48 = *st.rls.theta_i16f48();
        let ev = structure::evaluate(self.structure, &theta_old, &st.lags);
        let mut sat = ev.saturated;
        let (coeffs, limited) = self.filter_coefficients(&theta_old, ev.ds_dlag_i12f20);
        let mut psi_s = ev.ds_dtheta;
        for (k, p) in psi_s.iter_mut().enumerate() {
            let mut acc_i28f36 = i64::from(p.raw()) << 20;
            for (lag, c) in st.psi_s_lag.iter().zip(coeffs.iter()) {
                let prev = lag.get(k).map_or(0, |x| x.raw());
                acc_i28f36 = acc_i28f36.saturating_add(mul_i32_wide(*c, prev));
            }
            *p = SignalI16F16::from_raw(sat_i32(shr_round_i64(acc_i28f36, 20), &mut sat));
        }
        let mut psi = psi_s;
        if self.structure == NonlinearStructure::Wiener {
            for (p, d) in psi.iter_mut().zip(ev.dy_dtheta.iter()) {
                let acc_i28f36 =
                    mul_i32_wide(ev.dy_ds_i12f20, p.raw()).saturating_add(i64::from(d.raw()) << 20);
                *p = SignalI16F16::from_raw(sat_i32(shr_round_i64(acc_i28f36, 20), &mut sat));
            }
        }
        let eps = SignalI16F16::from_raw(sat_i32(
            i64::from(y.raw()) - i64::from(ev.y_hat.raw()),
            &mut sat,
        ));
        let mut status = self.rls.update(&mut st.rls, &psi, eps);
        status |= project_denominator(
            self.radius,
            self.structure.na(),
            &mut st.rls,
            &theta_old_i16f48,
        );
        st.psi_s_lag.swap(0, 1);
        if let Some(first) = st.psi_s_lag.first_mut() {
            *first = psi_s;
        }
        st.lags.s = [ev.s, st.lags.s[0]];
        st.lags.u = [u, st.lags.u[0]];
        status.set_if(Status::SATURATED, sat);
        status.set_if(Status::GRADIENT_LIMITED, limited);
        Estimate {
            y_hat: ev.y_hat,
            eps,
            status,
        }
    }

    /// The sensitivity filter's coefficients: ∂F/∂s if the filter 1 − c₁q⁻¹ − c₂q⁻² is inside the
    /// pole region, else the linear part's −f (stable by the projection) and `true`.
    fn filter_coefficients(&self, theta: &[ParamI12F20; N], c: [i32; 2]) -> ([i32; 2], bool) {
        let na = self.structure.na();
        let den = [
            ParamI12F20::from_raw(c[0].saturating_neg()),
            ParamI12F20::from_raw(c[1].saturating_neg()),
        ];
        if den.get(..na).is_some_and(|d| self.radius.contains(d)) {
            return (c, false);
        }
        let f = |i: usize| theta.get(i).map_or(0, |p| p.raw().saturating_neg());
        let linear = [f(0), if na == 2 { f(1) } else { 0 }];
        (linear, linear != c)
    }
}

impl<const N: usize> NonlinearState<N> {
    /// The current estimate θ (layout in [`structure`]).
    pub fn theta(&self) -> &[ParamI12F20; N] {
        self.rls.theta()
    }

    /// The estimator state (θ, UD factors).
    pub fn rls(&self) -> &RlsState<N> {
        &self.rls
    }

    /// The simulated state and inputs the next sample starts from.
    pub fn lags(&self) -> &Lags {
        &self.lags
    }

    /// Holds (false) or enables (true) adaptation.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.rls.set_enabled(enabled);
    }
}

impl<const N: usize> EstimatorDesign<N> for NonlinearDesign<N> {
    type Config = NonlinearConfig<N>;

    fn build(&self) -> Result<NonlinearConfig<N>, ConfigError> {
        NonlinearDesign::build(self)
    }
}

impl<const N: usize> Estimator<N> for NonlinearConfig<N> {
    type State = NonlinearState<N>;

    fn new_state(&self) -> NonlinearState<N> {
        NonlinearConfig::new_state(self)
    }

    fn step(&self, state: &mut NonlinearState<N>, y: SignalI16F16, u: SignalI16F16) -> Estimate {
        NonlinearConfig::step(self, state, y, u)
    }

    fn theta<'a>(&self, state: &'a NonlinearState<N>) -> &'a [ParamI12F20; N] {
        state.theta()
    }

    fn covariance_positive_definite(&self, state: &NonlinearState<N>) -> bool {
        state.rls().is_positive_definite()
    }

    fn set_enabled(&self, state: &mut NonlinearState<N>, enabled: bool) {
        state.set_enabled(enabled);
    }

    fn seed(&self, state: &mut NonlinearState<N>, theta: &[ParamI12F20; N]) {
        state.rls.reset(&self.rls, *theta);
    }
}

impl<const N: usize> NonlinearDesign<N> {
    /// Builds the design and appends its configuration words ([`crate::words`]): structure, θ₀
    /// (raw I12F20), the pole radius, then the quantised RLS settings ([`RlsConfig`]'s words).
    ///
    /// # Errors
    /// [`Self::build`]'s errors, or [`ConfigError::Words`] when `w`'s buffer is full.
    pub fn put_words(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        let c = self.build()?;
        c.structure.put(w)?;
        c.theta0.put(w)?;
        c.radius.put(w)?;
        c.rls.put(w)
    }
}

impl<const N: usize> NonlinearConfig<N> {
    /// Reads the words of [`NonlinearDesign::put_words`] with [`NonlinearDesign::build`]'s checks
    /// (N parameters for the structure, a stable θ₀ inside the pole radius) and the RLS
    /// settings' ([`RlsConfig::validate`]): no `f64` arithmetic.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first bad word, or the first setting out of range.
    pub fn take_words(r: &mut WordReader<'_>) -> Result<Self, ConfigError> {
        let structure = NonlinearStructure::take(r);
        let theta0 = <[ParamI12F20; N]>::take(r);
        let radius = PoleRadius::take(r);
        let rls = RlsConfig::take(r);
        r.status()?;
        rls.validate()?;
        let config = Self {
            structure,
            theta0,
            rls,
            radius,
        };
        config.validate()?;
        Ok(config)
    }
}
