//! A model identified in normalised units ([`sledid::Normalisation`]: y_n = y/k_y, u_n = u/k_u)
//! mapped to and from the user's units:
//!
//! | parameter | acts as | user = normalised × |
//! |---|---|---|
//! | f (denominator), c (bias) | ratio | 1 |
//! | b (numerator) | y per u | k_y / k_u |
//! | w (output weight) | y | k_y |
//! | a on u | per u | 1 / k_u |
//! | a on ŷ, on the Wiener state x, on the velocity Δŷ | per y | 1 / k_y |

use sledid::Normalisation;
use sledid::ident::nonlinear::NonlinearStructure;

/// The model whose parameters are mapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    /// A linear model [f₁ … f_na, b₁ … b_nb].
    Linear {
        /// Denominator order.
        na: usize,
    },
    /// One of the paper's nonlinear models (layout in `sledid::ident::nonlinear::structure`).
    Nonlinear(NonlinearStructure),
}

/// The factor (user value / normalised value) of every parameter of a model with `n` parameters.
pub fn factors(kind: ModelKind, n: usize, norm: Normalisation) -> Vec<f64> {
    let (y, u) = (norm.y_factor(), norm.u_factor());
    let b = y / u;
    match kind {
        ModelKind::Linear { na } => (0..n).map(|i| if i < na { 1.0 } else { b }).collect(),
        ModelKind::Nonlinear(s) => match s {
            NonlinearStructure::Hammerstein => vec![1.0, b, y, 1.0 / u, 1.0, y, 1.0 / u, 1.0],
            NonlinearStructure::NoeOutputInput => vec![1.0, b, y, 1.0 / y, 1.0 / u, 1.0],
            NonlinearStructure::Noe221 => vec![1.0, 1.0, b, b, y, 1.0 / u, 1.0],
            NonlinearStructure::Wiener => vec![1.0, b, y, 1.0 / y, 1.0],
            NonlinearStructure::FrictionFeedback => vec![1.0, 1.0, b, b, y, 1.0 / y, 1.0],
        },
    }
}

/// θ in normalised units → the user's units.
pub fn to_user(kind: ModelKind, theta: &[f64], norm: Normalisation) -> Vec<f64> {
    let k = factors(kind, theta.len(), norm);
    theta.iter().zip(k).map(|(t, k)| t * k).collect()
}

/// θ in the user's units → normalised units.
pub fn to_normalised(kind: ModelKind, theta: &[f64], norm: Normalisation) -> Vec<f64> {
    let k = factors(kind, theta.len(), norm);
    theta.iter().zip(k).map(|(t, k)| t / k).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::nonlinear::simulate;

    /// Every structure's simulation commutes with the unit change: simulating the normalised
    /// model on normalised u gives the user-unit simulation / k_y (a wrong factor for any
    /// parameter breaks this: every parameter of these θ is non-zero and acts).
    #[test]
    fn simulation_commutes_with_the_unit_change() {
        // k_y = 8, k_u = 1/4: powers of two, so the round trip below is exact.
        let norm = Normalisation::for_ranges(256.0, 0.25).unwrap();
        let u: Vec<f64> = (0..200).map(|k| 0.7 * (k as f64 * 0.13).sin()).collect();
        let thetas: [(NonlinearStructure, Vec<f64>); 5] = [
            (
                NonlinearStructure::Hammerstein,
                vec![-0.9, 0.5, 0.3, 1.2, -0.4, -0.2, 2.0, 0.3],
            ),
            (
                NonlinearStructure::NoeOutputInput,
                vec![-0.9, 0.5, 0.3, 0.4, 1.5, 0.1],
            ),
            (
                NonlinearStructure::Noe221,
                vec![-1.5, 0.6, 0.2, 0.1, 0.3, 1.4, 0.2],
            ),
            (NonlinearStructure::Wiener, vec![-0.8, 0.5, 0.4, 0.6, 0.1]),
            (
                NonlinearStructure::FrictionFeedback,
                vec![-1.5, 0.6, 0.2, 0.1, 0.3, 1.4, 0.2],
            ),
        ];
        for (s, theta) in thetas {
            let kind = ModelKind::Nonlinear(s);
            let y_user = simulate(s, &theta, &u);
            let u_n: Vec<f64> = u.iter().map(|x| x * 2f64.powi(2)).collect();
            let theta_n = to_normalised(kind, &theta, norm);
            let y_n = simulate(s, &theta_n, &u_n);
            for (a, b) in y_user.iter().zip(&y_n) {
                assert!((a * 2f64.powi(-3) - b).abs() < 1e-12, "{s:?}: {a} vs {b}");
            }
            assert_eq!(to_user(kind, &theta_n, norm), theta);
        }
        let lin = to_user(ModelKind::Linear { na: 2 }, &[0.5, 0.25, 1.0, 2.0], norm);
        assert_eq!(lin, vec![0.5, 0.25, 32.0, 64.0]);
    }
}
