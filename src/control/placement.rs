//! Indirect self-tuning: the identified model → a first-order velocity model → controller gains by
//! pole placement. Runs at a slow rate (once per settle phase, outside the sample interrupt) and
//! may use `f32` with [`libm`]; the per-sample path only applies the quantised [`ModelGains`].
//!
//! # Model
//! The identifier (`crate::ident::step`, [`crate::ident::conditioning::Conditioning::DifferencedOutput`])
//! estimates ARX on the velocity `Δy` (quanta per sample) against the drive u (fraction of full
//! scale), the paper's first-order structure (eq. 1 with `A = 1 + a₁q⁻¹`, `B = b₁q⁻¹`) on the
//! sled without its integrator:
//!
//! ```text
//! na = 1:  Δy(k+1) = a·Δy(k) + b·u(k),   a = −a₁, b = b₁ (+ b₂ …)
//! na = 2:  a = the dominant real root of z² + a₁z + a₂,  b = (1 − a)·B(1)/A(1)   (same DC gain)
//! ```
//! so from u to the position `G(z) = b·z / ((z − a)(z − 1))`.
//!
//! # Pole placement (closed forms)
//! Seek, PD with reference feedforward, `u = Kp·e + Kd·(v_r − v) + u_ff`, both poles at p_s:
//! `(z − a)(z − 1) + b·Kp·z + b·Kd·(z − 1) = (z − p_s)²` gives
//! ```text
//! b·Kd = a − p_s²,   b·Kp = (1 − p_s)²,   u_ff = ((1 − a)·v_r + Δv_r) / b     (model inverse)
//! ```
//! Settle, PID `u = Kp·e − Kd·v + I`, `I(k) = I(k−1) + Ki·e(k)`, three poles at p_z:
//! `(z − a)(z − 1)² + b·[Kp·z(z − 1) + Ki·z² + Kd·(z − 1)²] = (z − p_z)³`, with s₁ = 3p_z,
//! s₂ = 3p_z², s₃ = p_z³:
//! ```text
//! b·Kd = a − s₃,   b·Kp = 1 + 2s₃ − s₂,   b·Ki = 2 + a − s₁ − b·Kp − b·Kd
//! ```
//! (`host-tests/src/reference/scheduled.rs` checks these against the closed-loop poles in f64.)
//!
//! # Supervisor checks (indirect STR safety net)
//! A model is refused — and the controller falls back to the baseline gains — when the pole is
//! complex, at or below −1 or above 1, when b has the wrong sign (a reversed sensor or drive) or
//! lies outside `[gain_min, gain_max]`, or when a gain does not fit the [`Gain`] format. A pole in
//! (−1, pole_min) is projected up to pole_min (same DC gain), one in (pole_max, 1] down to
//! pole_max (same b).

use super::ConfigError;
use super::seek::SeekPlan;
use crate::num::fixed::ParamI12F20;
use crate::num::gain::Gain;
use crate::words::{WordReader, WordWriter, Words};

/// Closed-loop pole choices (z-plane radii, real).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlacementDesign {
    /// p_s: the seek PD's double pole, in [0, 1).
    pub seek_pole: f64,
    /// p_z: the settle PID's triple pole, in [0, 1).
    pub settle_pole: f64,
    /// Reference feedforward through the model inverse in the seek.
    pub feedforward: bool,
    /// p_o: the velocity observer's pole bound, in [0, 1): the observer gain is the smallest
    /// that puts its pole (1 − l)·a at or below p_o.
    pub observer_pole: f64,
    /// l_min: the observer gain's floor, in (0, 1]: how much of each measured position
    /// difference the estimate takes even when the model alone would be fast enough (it corrects
    /// the model's errors: friction, a drifting estimate).
    pub observer_gain_min: f64,
}

impl Default for PlacementDesign {
    fn default() -> Self {
        Self {
            seek_pole: 0.4,
            settle_pole: 0.7,
            feedforward: true,
            observer_pole: 0.5,
            observer_gain_min: 0.25,
        }
    }
}

/// Limits on the identified model (the allowed region) and on the estimator's health.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SupervisorDesign {
    /// Smallest velocity pole a placed from: a smaller estimate in (−1, pole_min) is projected up
    /// to it, keeping the model's DC gain b/(1 − a) (a sled's velocity pole e^{−Ts·b_v/m} is
    /// positive; a negative estimate is the bias of first-differenced quantisation noise on a fast
    /// plant). An estimate at or below −1 is refused.
    pub pole_min: f64,
    /// Largest velocity pole a placed from (< 1): an estimate in (pole_max, 1] — a heavy sled with
    /// little damping, whose pole the quantised data cannot tell from 1 — is projected down to
    /// it, keeping b (the gain the closed loop's bandwidth meets); one above 1 (an unstable
    /// velocity model) is refused.
    pub pole_max: f64,
    /// Smallest accepted b, quanta per sample per full scale (> 0: the sign check).
    pub gain_min: f64,
    /// Largest accepted b.
    pub gain_max: f64,
    /// Largest accepted running mean of |ε|, quanta per sample.
    pub eps_limit_quanta: f64,
    /// Samples the supervisor distrusts the model after a bad estimator flag.
    pub untrusted_hold_samples: u16,
}

impl Default for SupervisorDesign {
    fn default() -> Self {
        Self {
            pole_min: 0.0,
            pole_max: 0.995,
            // The family's slowest sled (mass ×6, viscous ×25, force ×0.5, quantum ×2) has b = 0.76
            // quanta per sample: 1.0 refused it as a prior.
            gain_min: 0.25,
            gain_max: 1000.0,
            eps_limit_quanta: 8.0,
            untrusted_hold_samples: 256,
        }
    }
}

impl PlacementDesign {
    /// Checks the poles.
    ///
    /// # Errors
    /// [`ConfigError::ClosedLoopPole`] for a pole not in [0, 1).
    pub fn validate(&self) -> Result<(), ConfigError> {
        for p in [self.seek_pole, self.settle_pole, self.observer_pole] {
            if !(p.is_finite() && (0.0..1.0).contains(&p)) {
                return Err(ConfigError::ClosedLoopPole(p));
            }
        }
        let l = self.observer_gain_min;
        if !(l.is_finite() && l > 0.0 && l <= 1.0) {
            return Err(ConfigError::ClosedLoopPole(l));
        }
        Ok(())
    }
}

impl SupervisorDesign {
    /// Checks the limits.
    ///
    /// # Errors
    /// [`ConfigError::SupervisorLimit`] naming the first bad value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = ConfigError::SupervisorLimit;
        if !(self.pole_min.is_finite() && self.pole_min >= 0.0) {
            return Err(bad(self.pole_min));
        }
        if !(self.pole_max.is_finite() && self.pole_max < 1.0 && self.pole_max > self.pole_min) {
            return Err(bad(self.pole_max));
        }
        if !(self.gain_min.is_finite() && self.gain_min > 0.0) {
            return Err(bad(self.gain_min));
        }
        if !(self.gain_max.is_finite() && self.gain_max > self.gain_min) {
            return Err(bad(self.gain_max));
        }
        if !(self.eps_limit_quanta.is_finite()
            && self.eps_limit_quanta > 0.0
            && self.eps_limit_quanta < 32_768.0)
        {
            return Err(bad(self.eps_limit_quanta));
        }
        Ok(())
    }
}

/// Why a model was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Rejection {
    /// The denominator has complex (or no real) roots.
    ComplexPole,
    /// The velocity pole a lies outside the allowed region.
    PoleOutside(f32),
    /// b ≤ 0: the sign of the gain is wrong (reversed sensor or drive).
    GainSign(f32),
    /// b outside `[gain_min, gain_max]`.
    GainRange(f32),
    /// A gain does not fit the fixed-point format.
    GainFormat,
    /// The estimator's flags or prediction error distrust the model.
    Untrusted,
    /// θ has fewer entries than the orders say.
    ModelOrder,
}

/// The first-order velocity model `Δy(k+1) = a·Δy(k) + b·u(k)`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VelocityModel {
    /// Pole a.
    pub a: f32,
    /// Gain b, quanta per sample per full scale.
    pub b: f32,
    /// Coulomb friction u_c the drive loses while the sled moves, fraction of full scale (0
    /// where the model has no Coulomb term).
    pub coulomb_fs: f32,
}

/// The quantised gains of the seek and settle laws (`Copy`). Each acts on an I16F16 signal in
/// quanta (per sample) and gives an I32F32 term in full scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelGains {
    /// Seek Kp on e.
    pub kp_seek: Gain,
    /// Seek Kd on the one-sample difference (r(k) − r(k−1)) − (y(k) − y(k−1)).
    pub kd_seek: Gain,
    /// Feedforward (1 − a)/b on r(k) − r(k−1).
    pub kv_ff: Gain,
    /// Feedforward 1/b on the reference's second difference.
    pub ka_ff: Gain,
    /// Settle Kp on e.
    pub kp_settle: Gain,
    /// Settle Kd on y(k) − y(k−1) (subtracted).
    pub kd_settle: Gain,
    /// Settle Ki (per sample) on e.
    pub ki_settle: Gain,
    /// Samples the readings must stay within one quantum before Hold cuts the drive: twice the
    /// velocity's coasting time a/(1 − a), at least 4 (a sled still creeping would coast on).
    pub rest_samples: u16,
    /// Speed below which the sled counts as at rest, I16F16 raw quanta per sample: its coasting
    /// distance v·a/(1 − a) is then under 0.3 quantum.
    pub rest_speed_i16f16: i32,
    /// Velocity observer: (1 − l)·a on the last estimate.
    pub obs_a: Gain,
    /// Velocity observer: (1 − l)·b on the last drive (quanta per sample per full scale).
    pub obs_b: Gain,
    /// Velocity observer: l on the measured position difference.
    pub obs_l: Gain,
    /// The time-optimal seek's plan ([`super::seek`]; [`SeekPlan::NONE`] for reference-following
    /// seeks).
    pub seek: SeekPlan,
    /// A breakaway throws the model's sled ([`breakaway_throws`]): a reference-following fine
    /// step on a sled that a breakaway has thrown past the target is pulsed
    /// ([`super::scheduled`], "Settle of a time-optimal seek").
    pub breakaway_throws: bool,
}

impl ModelGains {
    /// Every gain a valid [`Gain`].
    ///
    /// # Errors
    /// [`ConfigError::InitialModel`] (the gains are a model's) otherwise.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let all = [
            self.kp_seek,
            self.kd_seek,
            self.kv_ff,
            self.ka_ff,
            self.kp_settle,
            self.kd_settle,
            self.ki_settle,
            self.obs_a,
            self.obs_b,
            self.obs_l,
        ];
        if !all.iter().all(|g| g.is_valid()) {
            return Err(ConfigError::InitialModel(f64::NAN));
        }
        // The observer's gain l is a fraction of the innovation, in [0, 1].
        let l = self.obs_l.to_f64();
        if !(0.0..=1.0).contains(&l) {
            return Err(ConfigError::InitialModel(l));
        }
        self.seek.validate()
    }

    /// Every gain zero (no model: the baseline runs).
    pub const ZERO: Self = Self {
        kp_seek: Gain::ZERO,
        kd_seek: Gain::ZERO,
        kv_ff: Gain::ZERO,
        ka_ff: Gain::ZERO,
        kp_settle: Gain::ZERO,
        kd_settle: Gain::ZERO,
        ki_settle: Gain::ZERO,
        rest_samples: 4,
        rest_speed_i16f16: 0,
        obs_a: Gain::ZERO,
        obs_b: Gain::ZERO,
        obs_l: Gain::ZERO,
        seek: SeekPlan::NONE,
        breakaway_throws: false,
    };
}

/// b·u_c, quanta per sample, from which a breakaway throws a sled: at least 1/8 quantum per
/// sample (module doc of [`super::scheduled::rest`], "A sticking sled's breakaway").
pub const BREAKAWAY_THROW_COULOMB_STEP: f32 = 0.125;

/// What Coulomb friction takes off a sample's velocity, b·u_c (gain `b` in quanta per sample per
/// full scale, the Coulomb level `u_c` in full scale), is at least
/// [`BREAKAWAY_THROW_COULOMB_STEP`]: a sled sticking at 2–3× that level, broken away by a drive
/// held for a sample, moves about (s − 1)·b·u_c — a cell or more on the light, sticky sleds
/// (b·u_c 0.25–0.8 quantum per sample over the families' plants that overshot), a fraction of
/// one on the heavy ones (under 0.09).
#[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
pub fn breakaway_throws(model: VelocityModel, u_c: f32) -> bool {
    model.b * u_c >= BREAKAWAY_THROW_COULOMB_STEP
}

/// θ = [a₁ … a_na, b₁ …] → the velocity model, with the supervisor's checks.
///
/// # Errors
/// The [`Rejection`] that refused the model.
#[allow(clippy::float_arithmetic)] // slow-rate design, not the per-sample path
pub fn reduce(
    theta: &[ParamI12F20],
    na: usize,
    limits: &SupervisorDesign,
) -> Result<VelocityModel, Rejection> {
    let f = |i: usize| theta.get(i).map(|p| p.to_f32());
    let b_sum: f32 = theta.iter().skip(na).map(|p| p.to_f32()).sum();
    if theta.len() <= na {
        return Err(Rejection::ModelOrder);
    }
    let (a, b) = match (na, f(0), f(1)) {
        (1, Some(a1), _) => (-a1, b_sum),
        (2, Some(a1), Some(a2)) => {
            let disc = a1 * a1 - 4.0 * a2;
            if disc < 0.0 {
                return Err(Rejection::ComplexPole);
            }
            let root = libm::sqrtf(disc);
            let (r1, r2) = ((-a1 + root) / 2.0, (-a1 - root) / 2.0);
            let a = if libm::fabsf(r1) >= libm::fabsf(r2) {
                r1
            } else {
                r2
            };
            let a_poly = 1.0 + a1 + a2;
            if libm::fabsf(a_poly) < 1e-6 {
                return Err(Rejection::PoleOutside(a));
            }
            (a, (1.0 - a) * b_sum / a_poly)
        }
        _ => return Err(Rejection::ModelOrder),
    };
    if !(a.is_finite() && a > -1.0 && a <= 1.0) {
        return Err(Rejection::PoleOutside(a));
    }
    let floor = limits.pole_min as f32;
    let ceiling = limits.pole_max as f32;
    let (a, b) = if a < floor {
        // Same DC gain b/(1 − a): b' = b·(1 − floor)/(1 − a), 1 − a > 0.
        (floor, b * (1.0 - floor) / (1.0 - a))
    } else if a > ceiling {
        (ceiling, b)
    } else {
        (a, b)
    };
    if b.is_nan() || b <= 0.0 {
        return Err(Rejection::GainSign(b));
    }
    if f64::from(b) < limits.gain_min || f64::from(b) > limits.gain_max {
        return Err(Rejection::GainRange(b));
    }
    Ok(VelocityModel {
        a,
        b,
        coulomb_fs: 0.0,
    })
}

/// The seek and settle gains placing the poles of [`PlacementDesign`] for `model`.
///
/// # Errors
/// [`Rejection::GainFormat`] when a gain does not fit [`Gain`].
#[allow(clippy::float_arithmetic)] // slow-rate design, not the per-sample path
pub fn place(model: VelocityModel, placement: &PlacementDesign) -> Result<ModelGains, Rejection> {
    let VelocityModel { a, b, .. } = model;
    let ps = placement.seek_pole as f32;
    let pz = placement.settle_pole as f32;
    let (s1, s2, s3) = (3.0 * pz, 3.0 * pz * pz, pz * pz * pz);
    let bkd_settle = a - s3;
    let bkp_settle = 1.0 + 2.0 * s3 - s2;
    let bki_settle = 2.0 + a - s1 - bkp_settle - bkd_settle;
    let g = |x: f32| Gain::from_f64(f64::from(x / b)).ok_or(Rejection::GainFormat);
    let ff = placement.feedforward;
    // Observer gain: (1 − l)·a ≤ p_o, l ≥ l_min.
    let po = placement.observer_pole as f32;
    let l_min = placement.observer_gain_min as f32;
    let l = if a > po { 1.0 - po / a } else { 0.0 }.max(l_min).min(1.0);
    let unit = |x: f32| Gain::from_f64(f64::from(x)).ok_or(Rejection::GainFormat);
    Ok(ModelGains {
        kp_seek: g((1.0 - ps) * (1.0 - ps))?,
        kd_seek: g(a - ps * ps)?,
        kv_ff: if ff { g(1.0 - a)? } else { Gain::ZERO },
        ka_ff: if ff { g(1.0)? } else { Gain::ZERO },
        kp_settle: g(bkp_settle)?,
        kd_settle: g(bkd_settle)?,
        ki_settle: g(bki_settle.max(0.0))?,
        rest_samples: rest_samples(a),
        rest_speed_i16f16: rest_speed_i16f16(a),
        obs_a: unit((1.0 - l) * a)?,
        obs_b: Gain::from_f64(f64::from((1.0 - l) * b)).ok_or(Rejection::GainFormat)?,
        obs_l: unit(l)?,
        seek: SeekPlan::NONE,
        breakaway_throws: false,
    })
}

/// Words: p_s, p_z (`f64` bits), feedforward (validity: [`PlacementDesign::validate`]).
impl Words for PlacementDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.seek_pole.put(w)?;
        self.settle_pole.put(w)?;
        self.feedforward.put(w)?;
        self.observer_pole.put(w)?;
        self.observer_gain_min.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            seek_pole: f64::take(r),
            settle_pole: f64::take(r),
            feedforward: bool::take(r),
            observer_pole: f64::take(r),
            observer_gain_min: f64::take(r),
        }
    }
}

/// Words: pole min/max, gain min/max, ε limit (`f64` bits), hold samples (validity:
/// [`SupervisorDesign::validate`]).
impl Words for SupervisorDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.pole_min,
            self.pole_max,
            self.gain_min,
            self.gain_max,
            self.eps_limit_quanta,
        ]
        .put(w)?;
        self.untrusted_hold_samples.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [pole_min, pole_max, gain_min, gain_max, eps_limit_quanta] = <[f64; 5]>::take(r);
        Self {
            pole_min,
            pole_max,
            gain_min,
            gain_max,
            eps_limit_quanta,
            untrusted_hold_samples: u16::take(r),
        }
    }
}

/// `0.3·(1 − a)/a` quanta per sample (at most ¼), I16F16 raw, at least one LSB.
#[allow(clippy::float_arithmetic)] // slow-rate design
fn rest_speed_i16f16(a: f32) -> i32 {
    let v = if a > 0.0 { 0.3 * (1.0 - a) / a } else { 0.25 };
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 0.25) };
    ((v * 65_536.0) as i32).max(1)
}

/// `clamp(⌈2a/(1 − a)⌉, 4, 255)` samples.
#[allow(clippy::float_arithmetic)] // slow-rate design
fn rest_samples(a: f32) -> u16 {
    let coast = 2.0 * a / (1.0 - a).max(1e-3);
    if coast.is_nan() || coast < 4.0 {
        4
    } else if coast >= 255.0 {
        255
    } else {
        (coast as u16) + 1
    }
}

/// Words: the seven gains in declaration order, the rest samples.
impl Words for ModelGains {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.kp_seek,
            self.kd_seek,
            self.kv_ff,
            self.ka_ff,
            self.kp_settle,
            self.kd_settle,
            self.ki_settle,
            self.obs_a,
            self.obs_b,
            self.obs_l,
        ]
        .put(w)?;
        self.rest_samples.put(w)?;
        self.rest_speed_i16f16.put(w)?;
        self.seek.put(w)?;
        self.breakaway_throws.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [
            kp_seek,
            kd_seek,
            kv_ff,
            ka_ff,
            kp_settle,
            kd_settle,
            ki_settle,
            obs_a,
            obs_b,
            obs_l,
        ] = <[Gain; 10]>::take(r);
        let rest_samples = u16::take(r);
        let rest_speed_i16f16 = i32::take(r);
        Self {
            kp_seek,
            kd_seek,
            kv_ff,
            ka_ff,
            kp_settle,
            kd_settle,
            ki_settle,
            rest_samples,
            rest_speed_i16f16,
            obs_a,
            obs_b,
            obs_l,
            seek: SeekPlan::take(r),
            breakaway_throws: bool::take(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64) -> ParamI12F20 {
        ParamI12F20::from_f64(x).unwrap()
    }

    #[test]
    fn reduction_of_first_and_second_order_models() {
        let l = SupervisorDesign::default();
        let m = reduce(&[p(-0.83), p(23.7)], 1, &l).unwrap();
        assert!((m.a - 0.83).abs() < 1e-5 && (m.b - 23.7).abs() < 1e-4);
        // (z − 0.8)(z − 0.1) = z² − 0.9z + 0.08; B(1) = 10, A(1) = 0.18: DC gain 55.6, b = 11.1.
        let m = reduce(&[p(-0.9), p(0.08), p(6.0), p(4.0)], 2, &l).unwrap();
        assert!((m.a - 0.8).abs() < 1e-4, "{m:?}");
        assert!((m.b - 0.2 * 10.0 / 0.18).abs() < 1e-2, "{m:?}");
        assert_eq!(
            reduce(&[p(-0.83), p(-23.7)], 1, &l),
            Err(Rejection::GainSign(-23.7))
        );
        assert!(matches!(
            reduce(&[p(-1.2), p(23.7)], 1, &l),
            Err(Rejection::PoleOutside(_))
        ));
        assert_eq!(
            reduce(&[p(0.0), p(0.5), p(1.0), p(1.0)], 2, &l),
            Err(Rejection::ComplexPole)
        );
        assert!(matches!(
            reduce(&[p(-0.8), p(5000.0 / 4.0)], 1, &l),
            Err(Rejection::GainRange(_))
        ));
        assert_eq!(reduce(&[p(-0.8)], 1, &l), Err(Rejection::ModelOrder));
    }

    #[test]
    fn observer_and_rest_settings_follow_the_model_and_designs_are_checked() {
        // The closed-loop poles themselves are found independently of these formulas in
        // `host-tests/tests/integration/placement_poles.rs`; here the observer's gain (pole (1 − l)·a ≤ p_o,
        // l ≥ l_min) and the rest settings.
        let d = PlacementDesign::default();
        for (a, l) in [(0.83f32, 1.0 - 0.5 / 0.83f64), (0.3, 0.25), (0.05, 0.25)] {
            let g = place(
                VelocityModel {
                    a,
                    b: 23.7,
                    coulomb_fs: 0.0,
                },
                &d,
            )
            .unwrap();
            assert!((g.obs_l.to_f64() - l).abs() < 1e-6, "{a}");
            assert!(g.obs_a.to_f64() <= d.observer_pole + 1e-6, "{a}");
            assert!((g.obs_b.to_f64() - (1.0 - l) * 23.7).abs() < 1e-4);
        }
        let slow = place(
            VelocityModel {
                a: 0.97,
                b: 5.0,
                coulomb_fs: 0.0,
            },
            &d,
        )
        .unwrap();
        assert_eq!(slow.rest_samples, 65); // ⌈2·0.97/0.03⌉
        assert!(slow.rest_speed_i16f16 < (0.3 * 0.03 / 0.97 * 65_536.0) as i32 + 2);
        for bad in [
            PlacementDesign {
                settle_pole: 1.0,
                ..d
            },
            PlacementDesign {
                observer_pole: -0.1,
                ..d
            },
            PlacementDesign {
                observer_gain_min: 0.0,
                ..d
            },
        ] {
            assert!(bad.validate().is_err());
        }
        assert!(
            SupervisorDesign {
                pole_max: 0.1,
                pole_min: 0.2,
                ..SupervisorDesign::default()
            }
            .validate()
            .is_err()
        );
    }

    /// Trips on the comparison inverted, u_c left out of it, or a threshold that takes in the
    /// heavy, gliding sleds: the identified models of the families' plants whose breakaway threw
    /// them past the target (b·u_c 0.25–0.77 quantum per sample) throw, the heavy ones (under
    /// 0.09) and the frictionless do not (`BENCHMARKS.md`, "The holding error ≤ 1 quantum").
    #[test]
    fn a_light_sticky_model_throws_and_a_heavy_one_does_not() {
        let m = |a: f32, b: f32| VelocityModel {
            a,
            b,
            coulomb_fs: 0.0,
        };
        // Seed 1 plant 114 (m1.76, c1.64): b·u_c ≈ 0.25.
        assert!(breakaway_throws(m(0.934, 38.95), 0.0065));
        // Seed 7 plant 1 (m5.88, c0.12): b·u_c ≈ 0.063.
        assert!(!breakaway_throws(m(0.987, 7.04), 0.009));
        assert!(!breakaway_throws(m(0.7, 60.0), 0.0), "frictionless");
        assert!(!breakaway_throws(m(0.7, 60.0), -0.01), "a negative level");
    }
}
