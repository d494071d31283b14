//! Stability projection: keeps the roots of the estimated denominator F̂(q) (or Â(q)) inside a circle
//! of radius ρ = 1 − margin, as the recursive prediction-error method requires (Ljung, *System
//! Identification*, 1999, §11.3: the model's predictor filter 1/F̂ must be stable).
//!
//! For `F(q) = 1 + f₁q⁻¹ + f₂q⁻²` the roots of `z² + f₁z + f₂` lie in |z| ≤ ρ iff (Jury, scaled by ρ)
//! `|f₂| ≤ ρ²` and `ρ·|f₁| ≤ ρ² + f₂`; for first order `|f₁| ≤ ρ`.
//!
//! # Formats
//! f in I12F20 ([`ParamI12F20`]); ρ in I12F20; the tests are exact in `i64` (I24F40 products).
//! The projection's trial steps are taken on θ's I16F48 (`i64`) and tested on their I12F20
//! read-out.
//!
//! # Accuracy
//! Until 2026-12-08 the trial steps were floored in I12F20 and written back through the read-out,
//! dropping θ's low 28 bits at every projected sample; what keeping them changed against the
//! float64 reference is measured in [BENCHMARKS.md](../../BENCHMARKS.md) (issue 24's seventh
//! pass, "Scale invariance on the twin's records").

#![deny(clippy::float_arithmetic)]

use crate::error::ConfigError;
use crate::ident::rls::{RlsState, theta_read_out};
use crate::ident::status::Status;
use crate::num::fixed::ParamI12F20;
use crate::num::float_bits::from_fixed;
use crate::words::{WordReader, WordWriter, Words};

/// Radius ρ of the allowed pole region, I12F20.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PoleRadius(ParamI12F20);

impl PoleRadius {
    /// ρ = 1 − `margin`, margin ∈ [0, 0.5).
    ///
    /// # Errors
    /// [`ConfigError::StabilityMargin`] outside [0, 0.5).
    pub fn from_margin(margin: f64) -> Result<Self, ConfigError> {
        if !(0.0..0.5).contains(&margin) {
            return Err(ConfigError::StabilityMargin(margin));
        }
        #[allow(clippy::float_arithmetic)]
        let rho = 1.0 - margin;
        ParamI12F20::from_f64(rho)
            .map(Self)
            .map_err(|_| ConfigError::StabilityMargin(margin))
    }

    /// ρ ∈ [½, 1] (a margin in [0, ½), as [`Self::from_margin`] makes it), checked by it and by the
    /// decoding of configuration words alike.
    ///
    /// # Errors
    /// [`ConfigError::StabilityMargin`] (the margin 1 − ρ) otherwise.
    pub fn validate(self) -> Result<(), ConfigError> {
        if (1 << 19..=1 << 20).contains(&self.0.raw()) {
            Ok(())
        } else {
            Err(ConfigError::StabilityMargin(from_fixed(
                (1 << 20) - i64::from(self.0.raw()),
                20,
            )))
        }
    }

    /// True when the denominator with coefficients `f` (f₁, then f₂ if present) has all its roots in
    /// |z| ≤ ρ. Orders above 2 are not checked (returns true); the designs reject them.
    pub fn contains(self, f: &[ParamI12F20]) -> bool {
        let rho = i64::from(self.0.raw());
        let one = 1i64 << 20;
        match f {
            [] => true,
            [f1] => i64::from(f1.raw()).abs() <= rho,
            [f1, f2, ..] => {
                let f1 = i64::from(f1.raw());
                let f2 = i64::from(f2.raw());
                let rho2 = rho * rho; // I24F40
                (f2 * one).abs() <= rho2 && rho * f1.abs() <= rho2 + f2 * one
            }
        }
    }
}

/// Keeps the denominator θ[..na] of the estimate just made inside |z| ≤ ρ: if the update left the
/// region, the step θ(t) − θ(t−1) is halved up to four times and otherwise undone
/// ([`Status::PROJECTED`]); P keeps its update (Ljung 1999, §11.3). Every structure whose θ starts
/// with its denominator (the linear OE models and the paper's nonlinear models) shares this.
///
/// The steps are taken on θ's full precision (`theta_old_i16f48`: θ(t−1) raw I16F48, as
/// [`RlsState::theta_i16f48`] held it before the update), θ(t−1) + round(step / 2ʰ), and tested on
/// their I12F20 read-out: a projected sample keeps θ's low bits, as the float64 reference does.
pub fn project_denominator<const N: usize>(
    radius: PoleRadius,
    na: usize,
    st: &mut RlsState<N>,
    theta_old_i16f48: &[i64; N],
) -> Status {
    if st.theta().get(..na).is_none_or(|den| radius.contains(den)) {
        return Status::NONE;
    }
    let theta_new = *st.theta_i16f48();
    let mut sat = false;
    let mut accepted = *theta_old_i16f48;
    for halvings in 1..=4u32 {
        let mut trial = *theta_old_i16f48;
        for ((t, n), o) in trial
            .iter_mut()
            .zip(theta_new.iter())
            .zip(theta_old_i16f48.iter())
        {
            // Round half up of step / 2^h.
            let step = n.saturating_sub(*o);
            *t = o.saturating_add((step >> (halvings - 1)).saturating_add(1) >> 1);
        }
        let mut den = [ParamI12F20::ZERO; 2];
        for (d, t) in den.iter_mut().zip(trial.iter()) {
            *d = theta_read_out(*t, &mut sat);
        }
        if den.get(..na.min(2)).is_some_and(|den| radius.contains(den)) {
            accepted = trial;
            break;
        }
    }
    sat |= st.set_theta_i16f48(accepted);
    let mut status = Status::PROJECTED;
    status.set_if(Status::SATURATED, sat);
    status
}

/// Words: ρ raw I12F20 (validity: [`PoleRadius::validate`]).
impl Words for PoleRadius {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.0.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self(ParamI12F20::take(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64) -> ParamI12F20 {
        ParamI12F20::from_f64(x).unwrap()
    }

    /// A projected step is taken on θ's I16F48: θ(t−1) = 0.5 + 2⁻⁴⁰, an update to 1.5 leaves
    /// |z| ≤ 1, the first halving lands on 1 + 2⁻⁴¹ (read out as 1.0: inside) and keeps those low
    /// bits. Trips on steps taken on the I12F20 read-out (θ = 1.0 exactly, as before 2026-12-08)
    /// or floored; the other parameter moves by the same halving.
    #[test]
    fn a_projected_step_keeps_the_low_bits_of_theta() {
        use crate::ident::rls::RlsDesign;
        let cfg = RlsDesign::default().build().unwrap();
        let mut st = RlsState::<2>::new(&cfg, [ParamI12F20::ZERO; 2]);
        let one = 1i64 << 48;
        let old = [one / 2 + 256, one / 4 + 3];
        st.set_theta_i16f48([3 * one / 2, one / 4 + 4]);
        let r = PoleRadius::from_margin(0.0).unwrap();
        assert_eq!(project_denominator(r, 1, &mut st, &old), Status::PROJECTED);
        // Steps 2⁴⁸ − 256 and 1, halved and rounded half up: 2⁴⁷ − 128 and 1.
        assert_eq!(*st.theta_i16f48(), [one + 128, one / 4 + 4]);
        assert_eq!(st.theta()[0], p(1.0));
        // An update that stays inside is left as it is.
        st.set_theta_i16f48([one / 2, 7]);
        assert_eq!(project_denominator(r, 1, &mut st, &old), Status::NONE);
        assert_eq!(*st.theta_i16f48(), [one / 2, 7]);
    }

    #[test]
    fn first_and_second_order_regions() {
        let r = PoleRadius::from_margin(0.0).unwrap();
        assert!(r.contains(&[p(-0.99)]));
        assert!(r.contains(&[p(-1.0)]));
        assert!(!r.contains(&[p(-1.03)]));
        // (z − 0.9)(z − 0.8) = z² − 1.7z + 0.72: stable.
        assert!(r.contains(&[p(-1.7), p(0.72)]));
        // (z − 1.1)(z − 0.5) = z² − 1.6z + 0.55: unstable.
        assert!(!r.contains(&[p(-1.6), p(0.55)]));
        // Complex pair of radius √0.81 = 0.9: stable for ρ = 1, not for ρ = 0.85.
        assert!(r.contains(&[p(-1.0), p(0.81)]));
        let r85 = PoleRadius::from_margin(0.15).unwrap();
        assert!(!r85.contains(&[p(-1.0), p(0.81)]));
        assert!(PoleRadius::from_margin(0.5).is_err());
        assert!(PoleRadius::from_margin(f64::NAN).is_err());
    }
}
