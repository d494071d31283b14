//! The paper's nonlinear model structures as one simulation step each: from θ and the lagged
//! internal state and inputs, the next state, the output, and the partial derivatives the
//! sensitivity recursion of [`super`] needs.
//!
//! Every structure has an internal simulated state s(t) and an output ŷ(t) = H(s(t)):
//! ```text
//! s(t) = F(θ; s(t−1), s(t−2), u(t−1), u(t−2))        ŷ(t) = H(θ; s(t))   (H = identity but Wiener)
//! ```
//! | structure | θ | F | H |
//! |---|---|---|---|
//! | Hammerstein (eq. 5) | f₁ b₁ w₁ a₁ c₁ w₂ a₂ c₂ | −f₁s₁ + b₁u₁ + Σᵢ wᵢ tanh(aᵢu₁ + cᵢ) | s |
//! | NOE in ŷ and u (eq. 6) | f₁ b₁ w a_y a_u c | −f₁s₁ + b₁u₁ + w tanh(a_y s₁ + a_u u₁ + c) | s |
//! | NOE 221 (eq. 7) | f₁ f₂ b₁ b₂ w a c | −f₁s₁ − f₂s₂ + b₁u₁ + b₂u₂ + w tanh(a u₁ + c) | s |
//! | Wiener (Fig. 16) | f₁ b₁ w a c | −f₁s₁ + b₁u₁ | s + w tanh(a s + c) |
//! | friction feedback | f₁ f₂ b₁ b₂ w a c | −f₁s₁ − f₂s₂ + b₁u₁ + b₂u₂ + w tanh(a (s₁ − s₂) + c) | s |
//!
//! with s₁ = s(t−1), u₁ = u(t−1) and so on. Conventions: the paper writes eq. 7 with `+f₁ŷ(t−1)`;
//! here every denominator is `F(q) = 1 + f₁q⁻¹ + f₂q⁻²`, as in eq. 1–2, so θ always starts with
//! the denominator and one stability projection serves all. The paper's Wiener model has 6
//! parameters: a linear gain k in parallel with the neuron, ŷ = k·x + w tanh(a x + c); k and b₁
//! only act through their product (k·b₁), so k is fixed to 1 here (5 identifiable parameters,
//! the same model set). The friction-feedback model is the paper's suggested next step: a smooth
//! Coulomb/stiction force `w tanh(a v̂ + c)` of the simulated velocity v̂ = s(t−1) − s(t−2), added
//! where the drive acts (in output units: it absorbs b₁).
//!
//! The derivatives returned: the direct part ∂F/∂θ (s₁, s₂ held fixed), the feedback coefficients
//! ∂F/∂s₁, ∂F/∂s₂ (I12F20), and for the output map ∂H/∂s (I12F20) and ∂H/∂θ.

#![deny(clippy::float_arithmetic)]

use crate::error::ConfigError;
use crate::ident::neuron::term;
use crate::ident::rls::RlsConfig;
use crate::num::fixed::{PARAM_FRAC_BITS, ParamI12F20, SignalI16F16, sat_i32};
use crate::words::{WordReader, WordWriter, Words};

/// Which nonlinear model (see the module table for θ and the equations).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NonlinearStructure {
    /// First-order NOE Hammerstein, eq. 5: two neurons on u(t−1).
    Hammerstein,
    /// First-order NOE nonlinear in ŷ(t−1) and u(t−1), eq. 6: one two-input neuron.
    NoeOutputInput,
    /// Second-order NOE with one neuron on u(t−1), eq. 7 (the paper's "NOE 221").
    Noe221,
    /// First-order Wiener: OE linear part, then identity + one neuron (Fig. 16).
    Wiener,
    /// Second-order OE with a neuron of the simulated velocity fed back where the drive acts
    /// (the paper's conclusion).
    FrictionFeedback,
}

impl NonlinearStructure {
    /// Every structure, in the paper's order.
    pub const ALL: [Self; 5] = [
        Self::Hammerstein,
        Self::NoeOutputInput,
        Self::Noe221,
        Self::Wiener,
        Self::FrictionFeedback,
    ];

    /// θ's entries, in θ's order (the module table's θ column): the one table the parameter
    /// count, and so every estimator's N, is derived from.
    pub const fn parameter_names(self) -> &'static [&'static str] {
        match self {
            Self::Hammerstein => &["f1", "b1", "w1", "a1", "c1", "w2", "a2", "c2"],
            Self::NoeOutputInput => &["f1", "b1", "w", "a_y", "a_u", "c"],
            Self::Noe221 | Self::FrictionFeedback => &["f1", "f2", "b1", "b2", "w", "a", "c"],
            Self::Wiener => &["f1", "b1", "w", "a", "c"],
        }
    }

    /// Number of parameters θ: the N of the structure's [`super::NonlinearDesign`]. A structure
    /// chosen at run time reaches its N through [`crate::with_parameter_count`].
    pub const fn parameter_count(self) -> usize {
        self.parameter_names().len()
    }

    /// Order of the linear denominator (θ[..na]).
    pub const fn na(self) -> usize {
        match self {
            Self::Noe221 | Self::FrictionFeedback => 2,
            _ => 1,
        }
    }

    /// Short name (CLI, reports).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Hammerstein => "hammerstein",
            Self::NoeOutputInput => "noe",
            Self::Noe221 => "noe221",
            Self::Wiener => "wiener",
            Self::FrictionFeedback => "friction",
        }
    }
}

/// Evaluates `$body` with the const `$n` set to `$structure`'s
/// [`NonlinearStructure::parameter_count`]: the one dispatch from a structure chosen at run time
/// to the const generic N of its estimator (replay, study, bench, property and fuzz tests). One
/// arm per structure, so a new structure that is not listed here fails to compile.
///
/// ```
/// use sledid::ident::nonlinear::{NonlinearDesign, NonlinearStructure};
///
/// for s in NonlinearStructure::ALL {
///     let design = sledid::with_parameter_count!(s, |N| NonlinearDesign::<N> {
///         structure: s,
///         theta0: [0.0; N],
///         rls: Default::default(),
///         stability_margin: 0.0,
///     }
///     .build()
///     .is_ok());
///     assert!(design);
/// }
/// ```
#[macro_export]
macro_rules! with_parameter_count {
    ($structure:expr, |$n:ident| $body:expr) => {
        $crate::with_parameter_count!(
            @arms $structure, $n, $body;
            Hammerstein NoeOutputInput Noe221 Wiener FrictionFeedback
        )
    };
    (@arms $structure:expr, $n:ident, $body:expr; $($variant:ident)*) => {
        match $structure {
            $($crate::ident::nonlinear::NonlinearStructure::$variant => {
                const $n: usize =
                    $crate::ident::nonlinear::NonlinearStructure::$variant.parameter_count();
                $body
            })*
        }
    };
}

/// The lagged signals one step reads: s(t−1), s(t−2), u(t−1), u(t−2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Lags {
    /// s(t−1), s(t−2).
    pub s: [SignalI16F16; 2],
    /// u(t−1), u(t−2).
    pub u: [SignalI16F16; 2],
}

/// One simulation step with its derivatives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Evaluation<const N: usize> {
    /// s(t).
    pub s: SignalI16F16,
    /// ŷ(t) = H(s(t)).
    pub y_hat: SignalI16F16,
    /// ∂F/∂θ with the lagged states held.
    pub ds_dtheta: [SignalI16F16; N],
    /// ∂F/∂s(t−1), ∂F/∂s(t−2), I12F20 raw.
    pub ds_dlag_i12f20: [i32; 2],
    /// ∂H/∂s, I12F20 raw (1.0 but for Wiener).
    pub dy_ds_i12f20: i32,
    /// ∂H/∂θ (zero but for the Wiener neuron).
    pub dy_dtheta: [SignalI16F16; N],
    /// A signal or derivative saturated.
    pub saturated: bool,
}

/// θ entry `i` (zero if out of range: the designs make N match the structure).
fn at<const N: usize>(theta: &[ParamI12F20; N], i: usize) -> ParamI12F20 {
    theta.get(i).copied().unwrap_or(ParamI12F20::ZERO)
}

fn put<const N: usize>(v: &mut [SignalI16F16; N], i: usize, x: SignalI16F16) {
    if let Some(slot) = v.get_mut(i) {
        *slot = x;
    }
}

/// a + b, saturating (flagged).
fn add(a: SignalI16F16, b: SignalI16F16, sat: &mut bool) -> SignalI16F16 {
    SignalI16F16::from_raw(sat_i32(i64::from(a.raw()) + i64::from(b.raw()), sat))
}

/// −f as the I12F20 raw coefficient of a lagged state.
fn neg(f: ParamI12F20) -> i32 {
    f.raw().saturating_neg()
}

/// One step of `structure` at θ. Never panics.
pub fn evaluate<const N: usize>(
    structure: NonlinearStructure,
    theta: &[ParamI12F20; N],
    lags: &Lags,
) -> Evaluation<N> {
    let [s1, s2] = lags.s;
    let [u1, u2] = lags.u;
    let mut sat = false;
    let na = structure.na();
    // The linear part's regressor [−s₁ (−s₂) u₁ (u₂)] in the first 2·na slots: it is also ∂F/∂θ there.
    let mut phi = [SignalI16F16::ZERO; N];
    put(
        &mut phi,
        0,
        SignalI16F16::from_raw(s1.raw().saturating_neg()),
    );
    if na == 2 {
        put(
            &mut phi,
            1,
            SignalI16F16::from_raw(s2.raw().saturating_neg()),
        );
    }
    put(&mut phi, na, u1);
    if na == 2 {
        put(&mut phi, na + 1, u2);
    }
    let linear = RlsConfig::predict(theta, &phi, &mut sat);
    let mut ds_dlag = [
        neg(at(theta, 0)),
        if na == 2 { neg(at(theta, 1)) } else { 0 },
    ];
    let mut dy_ds = 1i32 << PARAM_FRAC_BITS;
    let mut dy_dtheta = [SignalI16F16::ZERO; N];
    let mut g = SignalI16F16::ZERO;
    let mut y_hat = None;
    let first = 2 * na;
    match structure {
        NonlinearStructure::Hammerstein => {
            for k in 0..2 {
                let i = first + 3 * k;
                let o = term::eval(at(theta, i), [at(theta, i + 1)], at(theta, i + 2), [u1]);
                g = add(g, o.g, &mut sat);
                put(&mut phi, i, o.dw);
                put(&mut phi, i + 1, o.da[0]);
                put(&mut phi, i + 2, o.dc);
                sat |= o.saturated;
            }
        }
        NonlinearStructure::NoeOutputInput => {
            let o = term::eval(
                at(theta, 2),
                [at(theta, 3), at(theta, 4)],
                at(theta, 5),
                [s1, u1],
            );
            g = o.g;
            put(&mut phi, 2, o.dw);
            put(&mut phi, 3, o.da[0]);
            put(&mut phi, 4, o.da[1]);
            put(&mut phi, 5, o.dc);
            ds_dlag[0] = ds_dlag[0].saturating_add(o.dg_dx_i12f20[0]);
            sat |= o.saturated;
        }
        NonlinearStructure::Noe221 => {
            let o = term::eval(at(theta, 4), [at(theta, 5)], at(theta, 6), [u1]);
            g = o.g;
            put(&mut phi, 4, o.dw);
            put(&mut phi, 5, o.da[0]);
            put(&mut phi, 6, o.dc);
            sat |= o.saturated;
        }
        NonlinearStructure::FrictionFeedback => {
            let v = s1.saturating_sub(s2);
            let o = term::eval(at(theta, 4), [at(theta, 5)], at(theta, 6), [v]);
            g = o.g;
            put(&mut phi, 4, o.dw);
            put(&mut phi, 5, o.da[0]);
            put(&mut phi, 6, o.dc);
            let [d1, d2] = ds_dlag;
            ds_dlag = [
                d1.saturating_add(o.dg_dx_i12f20[0]),
                d2.saturating_sub(o.dg_dx_i12f20[0]),
            ];
            sat |= o.saturated;
        }
        NonlinearStructure::Wiener => {
            let o = term::eval(at(theta, 2), [at(theta, 3)], at(theta, 4), [linear]);
            y_hat = Some(add(linear, o.g, &mut sat));
            put(&mut dy_dtheta, 2, o.dw);
            put(&mut dy_dtheta, 3, o.da[0]);
            put(&mut dy_dtheta, 4, o.dc);
            dy_ds = dy_ds.saturating_add(o.dg_dx_i12f20[0]);
            sat |= o.saturated;
        }
    }
    let s = add(linear, g, &mut sat);
    Evaluation {
        s,
        y_hat: y_hat.unwrap_or(s),
        ds_dtheta: phi,
        ds_dlag_i12f20: ds_dlag,
        dy_ds_i12f20: dy_ds,
        dy_dtheta,
        saturated: sat,
    }
}

/// Words: the index in [`NonlinearStructure::ALL`].
impl Words for NonlinearStructure {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        let index = Self::ALL.iter().position(|s| s == self).unwrap_or(0);
        index.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let index = usize::take(r);
        Self::ALL.get(index).copied().unwrap_or_else(|| {
            r.fail();
            Self::Wiener
        })
    }
}
