//! One tanh neuron with K inputs, `g(x) = w·tanh(a₁x₁ + … + a_K x_K + c)`, evaluated with every
//! derivative a nonlinear model's recursive prediction-error update needs (K = 1 is the neuron of
//! eq. 5, 7, the Wiener and friction models; K = 2 the neuron of eq. 6 on (ŷ(t−1), u(t−1))).
//!
//! With `t = tanh z`, `s = 1 − t²`:
//! ```text
//! ∂g/∂w = t    ∂g/∂aᵢ = w·s·xᵢ    ∂g/∂c = w·s    ∂g/∂xᵢ = w·s·aᵢ
//! ```
//!
//! # Formats (as [`crate::ident::neuron`], whose tanh table this uses)
//! | quantity | format | note |
//! |---|---|---|
//! | xᵢ, g, ∂g/∂w, ∂g/∂aᵢ, ∂g/∂c | I16F16 | ∂g/∂aᵢ saturates (flagged) |
//! | w, aᵢ, c | I12F20 | θ entries |
//! | z | I8F24, the `i32` range | Σ aᵢxᵢ in I28F36 saturating, then c |
//! | t, s | I2F30 | |
//! | w·s, ∂g/∂xᵢ | I12F20 | ∂g/∂xᵢ feeds the gradient filter; saturates (flagged) |
//!
//! For K = 1 the value and the parameter derivatives are bit-identical to
//! [`crate::ident::neuron::Neuron::eval`]; ∂g/∂x is kept in I12F20 instead of I16F16 because it is a
//! coefficient of the sensitivity recursion, not a signal.

#![deny(clippy::float_arithmetic)]

use crate::ident::neuron::{ARG_FRAC_BITS, ONE_I2F30, TANH_FRAC_BITS, tanh_i2f30};
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::mul_i32_wide;

/// A K-input neuron evaluated at one point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TermOutput<const K: usize> {
    /// g = w·tanh(z).
    pub g: SignalI16F16,
    /// ∂g/∂w = tanh z.
    pub dw: SignalI16F16,
    /// ∂g/∂aᵢ = w·s·xᵢ.
    pub da: [SignalI16F16; K],
    /// ∂g/∂c = w·s.
    pub dc: SignalI16F16,
    /// ∂g/∂xᵢ = w·s·aᵢ, I12F20 raw.
    pub dg_dx_i12f20: [i32; K],
    /// A derivative saturated.
    pub saturated: bool,
}

/// Evaluates `w·tanh(Σ aᵢxᵢ + c)` and its derivatives. Never panics.
pub fn eval<const K: usize>(
    w: ParamI12F20,
    a: [ParamI12F20; K],
    c: ParamI12F20,
    x: [SignalI16F16; K],
) -> TermOutput<K> {
    let mut sat = false;
    // aᵢ·xᵢ < 2^62 each: a saturating sum (saturation means |z| ≫ 8, where tanh is ±1 exactly).
    let mut z_i28f36: i64 = i64::from(c.raw()) << 16;
    for (ai, xi) in a.iter().zip(x.iter()) {
        z_i28f36 = z_i28f36.saturating_add(mul_i32_wide(ai.raw(), xi.raw()));
    }
    let z = shr_round_i64(z_i28f36, 36 - ARG_FRAC_BITS)
        .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
    let t = tanh_i2f30(z);
    // s = 1 − t² ∈ [0, 2^30]; w·s fits I12F20 because s ≤ 1.
    let s = ONE_I2F30 - shr_round_i64(mul_i32_wide(t, t), TANH_FRAC_BITS) as i32;
    let ws_i12f20 = shr_round_i64(mul_i32_wide(w.raw(), s), TANH_FRAC_BITS) as i32;
    let mut da = [SignalI16F16::ZERO; K];
    let mut dg_dx_i12f20 = [0i32; K];
    for (((d, dx), ai), xi) in da
        .iter_mut()
        .zip(dg_dx_i12f20.iter_mut())
        .zip(a.iter())
        .zip(x.iter())
    {
        // I12F20 × I16F16 = I28F36 → I16F16; I12F20 × I12F20 = I24F40 → I12F20.
        *d = SignalI16F16::from_raw(sat_i32(
            shr_round_i64(mul_i32_wide(ws_i12f20, xi.raw()), 20),
            &mut sat,
        ));
        *dx = sat_i32(
            shr_round_i64(mul_i32_wide(ws_i12f20, ai.raw()), 20),
            &mut sat,
        );
    }
    TermOutput {
        // w·t: I14F50 → I16F16, |g| ≤ |w| < 2^11 (exact cast).
        g: SignalI16F16::from_raw(shr_round_i64(mul_i32_wide(w.raw(), t), 34) as i32),
        dw: SignalI16F16::from_raw(shr_round_i64(i64::from(t), 14) as i32),
        da,
        dc: SignalI16F16::from_raw(shr_round_i64(i64::from(ws_i12f20), 4) as i32),
        dg_dx_i12f20,
        saturated: sat,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::neuron::Neuron;

    fn p(x: f64) -> ParamI12F20 {
        ParamI12F20::from_f64(x).unwrap()
    }
    fn s(x: f64) -> SignalI16F16 {
        SignalI16F16::from_f64(x).unwrap()
    }

    #[test]
    fn one_input_matches_the_neuron_bit_for_bit() {
        for &(w, a, c) in &[(0.0, 1.0, 0.0), (3.5, 0.7, -0.4), (-120.0, 0.05, 0.3)] {
            let n = Neuron::new(p(w), p(a), p(c));
            for k in -40..=40 {
                let x = s(f64::from(k) * 0.37);
                let o = n.eval(x);
                let t = eval(p(w), [p(a)], p(c), [x]);
                assert_eq!(
                    (t.g, t.dw, t.da[0], t.dc),
                    (o.g, o.grad.dw, o.grad.da, o.grad.dc)
                );
            }
        }
    }

    #[test]
    fn two_inputs_match_float64() {
        let (w, a1, a2, c) = (2.5, 0.3, -0.8, 0.2);
        for k in -20..=20 {
            let (x1, x2) = (f64::from(k) * 0.5, f64::from(k) * -0.11 + 0.3);
            let o = eval(p(w), [p(a1), p(a2)], p(c), [s(x1), s(x2)]);
            let th = (a1 * x1 + a2 * x2 + c).tanh();
            let ws = w * (1.0 - th * th);
            assert!((o.g.to_f64() - w * th).abs() < 2.5 * 9.4e-5 + 1e-4);
            assert!((o.da[0].to_f64() - ws * x1).abs() < 1e-2);
            assert!((f64::from(o.dg_dx_i12f20[1]) / 1048576.0 - ws * a2).abs() < 2e-3);
            assert!(!o.saturated);
        }
    }

    #[test]
    fn extreme_inputs_saturate_without_panic() {
        let o = eval(
            ParamI12F20::MAX,
            [ParamI12F20::MAX; 2],
            ParamI12F20::MIN,
            [SignalI16F16::MAX, SignalI16F16::MIN],
        );
        assert!(o.g.raw().abs() <= (ParamI12F20::MAX.raw() >> 4) + 1);
    }
}
