//! The tanh neuron and the one-hidden-layer sum in `f64` (the exact functions that
//! [`sledid::ident::neuron`] approximates), with analytic derivatives.

use sledid::ident::neuron::{HiddenLayer, HiddenLayerDesign, Neuron, NeuronDesign};

/// `g(x) = w·tanh(a·x + c)` in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeuronF64 {
    /// Output weight.
    pub w: f64,
    /// Input weight.
    pub a: f64,
    /// Bias.
    pub c: f64,
}

/// g and its derivatives at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeuronEvalF64 {
    /// g(x).
    pub g: f64,
    /// ∂g/∂x.
    pub dg_dx: f64,
    /// ∂g/∂w.
    pub dw: f64,
    /// ∂g/∂a.
    pub da: f64,
    /// ∂g/∂c.
    pub dc: f64,
}

impl NeuronF64 {
    /// The unquantised design.
    pub fn from_design(d: &NeuronDesign) -> Self {
        Self {
            w: d.w,
            a: d.a,
            c: d.c,
        }
    }

    /// The quantised parameters of a fixed-point neuron (isolates the arithmetic from the
    /// parameter rounding).
    pub fn from_fixed(n: &Neuron) -> Self {
        Self {
            w: n.w().to_f64(),
            a: n.a().to_f64(),
            c: n.c().to_f64(),
        }
    }

    /// g(x).
    pub fn g(&self, x: f64) -> f64 {
        self.w * (self.a * x + self.c).tanh()
    }

    /// g and the analytic derivatives.
    pub fn eval(&self, x: f64) -> NeuronEvalF64 {
        let t = (self.a * x + self.c).tanh();
        let s = 1.0 - t * t;
        NeuronEvalF64 {
            g: self.w * t,
            dg_dx: self.w * self.a * s,
            dw: t,
            da: self.w * x * s,
            dc: self.w * s,
        }
    }
}

/// `g(x) = Σᵢ wᵢ·tanh(aᵢ·x + cᵢ)` in `f64`.
#[derive(Clone, Debug, PartialEq)]
pub struct HiddenLayerF64 {
    /// The neurons.
    pub neurons: Vec<NeuronF64>,
}

impl HiddenLayerF64 {
    /// The unquantised design.
    pub fn from_design<const M: usize>(d: &HiddenLayerDesign<M>) -> Self {
        Self {
            neurons: d.neurons.iter().map(NeuronF64::from_design).collect(),
        }
    }

    /// The quantised parameters of a fixed-point layer.
    pub fn from_fixed<const M: usize>(l: &HiddenLayer<M>) -> Self {
        Self {
            neurons: l.neurons().iter().map(NeuronF64::from_fixed).collect(),
        }
    }

    /// g(x).
    pub fn g(&self, x: f64) -> f64 {
        self.neurons.iter().map(|n| n.g(x)).sum()
    }

    /// ∂g/∂x.
    pub fn dg_dx(&self, x: f64) -> f64 {
        self.neurons.iter().map(|n| n.eval(x).dg_dx).sum()
    }

    /// Per neuron: g and its derivatives.
    pub fn eval(&self, x: f64) -> Vec<NeuronEvalF64> {
        self.neurons.iter().map(|n| n.eval(x)).collect()
    }
}
