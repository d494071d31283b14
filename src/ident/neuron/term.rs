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
    /// t = tanh z, I2F30 raw.
    pub tanh_i2f30: i32,
    /// s = 1 − t², I2F30 raw.
    pub sech2_i2f30: i32,
    /// w·s, I12F20 raw.
    pub ws_i12f20: i32,
    /// A ∂g/∂aᵢ saturated.
    pub da_saturated: bool,
    /// A derivative saturated (∂g/∂aᵢ or ∂g/∂xᵢ).
    pub saturated: bool,
}

/// Evaluates `w·tanh(Σ aᵢxᵢ + c)` and its derivatives. Never panics.
pub fn eval<const K: usize>(
    w: ParamI12F20,
    a: [ParamI12F20; K],
    c: ParamI12F20,
    x: [SignalI16F16; K],
) -> TermOutput<K> {
    let (mut da_sat, mut dx_sat) = (false, false);
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
            &mut da_sat,
        ));
        *dx = sat_i32(
            shr_round_i64(mul_i32_wide(ws_i12f20, ai.raw()), 20),
            &mut dx_sat,
        );
    }
    TermOutput {
        // w·t: I14F50 → I16F16, |g| ≤ |w| < 2^11 (exact cast).
        g: SignalI16F16::from_raw(shr_round_i64(mul_i32_wide(w.raw(), t), 34) as i32),
        dw: SignalI16F16::from_raw(shr_round_i64(i64::from(t), 14) as i32),
        da,
        dc: SignalI16F16::from_raw(shr_round_i64(i64::from(ws_i12f20), 4) as i32),
        dg_dx_i12f20,
        tanh_i2f30: t,
        sech2_i2f30: s,
        ws_i12f20,
        da_saturated: da_sat,
        saturated: da_sat || dx_sat,
    }
}

#[cfg(test)]
mod tests {
    use super::super::Neuron;
    use super::*;

    fn p(x: f64) -> ParamI12F20 {
        ParamI12F20::from_f64(x).unwrap()
    }
    fn s(x: f64) -> SignalI16F16 {
        SignalI16F16::from_f64(x).unwrap()
    }

    /// K = 1 against float64: value and every derivative, and the neuron's own ∂g/∂x (I16F16)
    /// against the I12F20 one. Trips on a wrong shift or rounding in either.
    #[test]
    fn one_input_matches_float64() {
        for &(w, a, c) in &[(0.0, 1.0, 0.0), (3.5, 0.7, -0.4), (-120.0, 0.05, 0.3)] {
            let n = Neuron::new(p(w), p(a), p(c));
            for k in -40..=40 {
                let xf = f64::from(k) * 0.37;
                let x = s(xf);
                let t = eval(p(w), [p(a)], p(c), [x]);
                let (wq, aq, cq, xq) = (p(w).to_f64(), p(a).to_f64(), p(c).to_f64(), x.to_f64());
                let th = (aq * xq + cq).tanh();
                let ws = wq * (1.0 - th * th);
                let lsb = 1.0 / 65_536.0;
                // tanh's table error (≈ 9.4·10⁻⁵) scaled by |w|, plus rounding.
                assert!(
                    (t.g.to_f64() - wq * th).abs() < wq.abs() * 1e-4 + lsb,
                    "{w} {k}"
                );
                assert!((t.dw.to_f64() - th).abs() < 1e-4 + lsb);
                assert!((t.dc.to_f64() - ws).abs() < wq.abs() * 2e-4 + lsb);
                assert!((t.da[0].to_f64() - ws * xq).abs() < wq.abs() * xq.abs() * 2e-4 + lsb);
                let dx_term = f64::from(t.dg_dx_i12f20[0]) / 1_048_576.0;
                let dx_neuron = n.eval(x).dg_dx.to_f64();
                assert!((dx_term - ws * aq).abs() < wq.abs() * aq * 2e-4 + 1e-6);
                assert!((dx_neuron - dx_term).abs() <= lsb, "{dx_neuron} {dx_term}");
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
