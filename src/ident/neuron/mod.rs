//! The single tanh neuron `g(x) = w·tanh(a·x + c)` and the one-hidden-layer sum of the paper's
//! nonlinear models, with the derivatives a recursive prediction-error method needs.
//!
//! # Equations
//! The paper adds a small neural net to a linear model (§5, Sjöberg's initialisation):
//!
//! ```text
//! ŷ(t) = −f₁ŷ(t−1) + b₁u(t−1) + g(θ, u(t−1))                                   (eq. 5, M = 2)
//! ŷ(t) = f₁ŷ(t−1) + f₂ŷ(t−2) + b₁u(t−1) + g(u(t−1)) + b₂u(t−2)                  (eq. 7, M = 1)
//! g(θ, x) = Σᵢ wᵢ·tanh(aᵢ·x + cᵢ),   i = 1 … M          (one hidden layer, no output bias)
//! ```
//!
//! The Wiener model (Figure 16) uses the same neuron on the linear model's output. With
//! `t = tanh(z)`, `z = a·x + c` and `s = 1 − t²`:
//!
//! ```text
//! ∂g/∂x = w·a·s    ∂g/∂w = t    ∂g/∂a = w·x·s    ∂g/∂c = w·s
//! ```
//!
//! tanh is a 257-entry table of `tanh(k/32)`, k = 0 … 256, with linear interpolation, odd symmetry
//! and exact saturation to ±1 for |z| ≥ 8 (the last entry is stored as exactly 1, which costs
//! 2.3·10⁻⁷ and makes the curve continuous and monotonic into saturation). The derivative uses
//! `s = 1 − t²` of the interpolated t: no second table.
//!
//! Initialisation (the paper's, after Sjöberg): output weights w = 0, so the nonlinear model starts
//! equal to the linear one, and input weights that keep every neuron unsaturated on the expected
//! input range, |z| ≤ 1.5 ([`NeuronDesign::initial`], [`HiddenLayerDesign::initial`]). The biases are
//! spread over [−0.5, 0.5]: identical neurons would receive identical gradients for ever.
//!
//! # Formats
//! | quantity | format | range | note |
//! |---|---|---|---|
//! | x, g, ∂g/∂x, ∂g/∂w, ∂g/∂a, ∂g/∂c | I16F16 ([`SignalI16F16`]) | ±32,768 | g in sensor quanta, added to the linear part |
//! | w, a, c | I12F20 ([`ParamI12F20`]) | ±2,048 | w in quanta, a per unit of x |
//! | z = a·x + c | I8F24 `i32` | ±128 (tanh is ±1 to 2⁻²² beyond ±8) | saturated to the `i32` range |
//! | t = tanh z, s = 1 − t² | I2F30 `i32` | t ∈ [−1, 1], s ∈ [0, 1] | ±1 exact |
//! | table entries | I2F30 `i32`, 257 × 4 B = 1 KiB flash | [0, 1] | step h = 1/32 |
//!
//! # Scaling and overflow
//! - `a·x` is exact in I28F36 (`i64`, |·| ≤ 2⁶²); `c` joins it shifted by 16 (|·| ≤ 2⁴⁷), so the sum
//!   stays below 2⁶³. z is rounded to I8F24 and saturated to the `i32` range (|z| ≥ 128): tanh is ±1
//!   there to far below 2⁻³⁰, so this saturation is exact and not flagged.
//! - Interpolation: `t₁ − t₀ < 2²⁵` (the slope of tanh is ≤ 1) times a 19-bit fraction, < 2⁴⁴.
//! - `g = w·t` and `w·s` are bounded by |w| < 2048: they never saturate. `∂g/∂x = (w·s)·a` and
//!   `∂g/∂a = (w·s)·x` can exceed ±32,768 (|w·a| or |w·x| that large): they saturate and raise
//!   [`Status::SATURATED`]; so does the sum of M neurons (only possible for M ≥ 16 or saturated
//!   terms).
//! - Every product of two `i32` goes through [`mul_i32_wide`] (four 16×16 `MULS` on Armv6-M instead
//!   of `__aeabi_lmul`); every narrowing rounds half up.
//!
//! # Accuracy
//! - tanh: max |error| 9.39·10⁻⁵ ≈ 2⁻¹³·⁴ over the whole I8F24 input range (the interpolation error
//!   h²/8·max|tanh″| = 9.40·10⁻⁵ at z ≈ 0.67); requirement 2⁻¹² = 2.44·10⁻⁴. Asserted, and printed, by
//!   `tanh_max_error_over_the_whole_input_range` in `host-tests/tests/integration/neuron_decimate.rs`.
//! - s = 1 − t²: error ≤ 2·9.4·10⁻⁵ = 1.9·10⁻⁴.
//! - g: ≤ |w|·9.4·10⁻⁵ + 2⁻¹⁷; ∂g/∂w: ≤ 9.4·10⁻⁵ + 2⁻¹⁷; ∂g/∂c: ≤ |w|·1.9·10⁻⁴ + 2⁻²¹ + 2⁻¹⁷;
//!   ∂g/∂x: ≤ |w·a|·1.9·10⁻⁴ + |a|·2⁻²¹ + 2⁻¹⁷; ∂g/∂a: ≤ |w·x|·1.9·10⁻⁴ + |x|·2⁻²¹ + 2⁻¹⁷ (w·s is
//!   rounded to I12F20 before the last product). Asserted against f64 (analytic and finite
//!   differences) in `neuron_derivatives_match_float64` and `hidden_layer_matches_float64`.
//!
//! # Cost
//! One neuron with its gradient: 7 widening multiplies and one table look-up; the value alone: 3.
//! Measured per call (the 2-neuron layer with every derivative): `bench_neuron_eval` in
//! BENCHMARKS.md.

#![deny(clippy::float_arithmetic)]

pub mod term;

use crate::error::ConfigError;
use crate::ident::status::Status;
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::{mul_i32_wide, mul_u32_wide};

/// Fraction bits of the tanh argument z (I8F24).
pub const ARG_FRAC_BITS: u32 = 24;
/// Fraction bits of tanh and of 1 − tanh² (I2F30).
pub const TANH_FRAC_BITS: u32 = 30;
/// 1.0 in I2F30.
pub const ONE_I2F30: i32 = 1 << TANH_FRAC_BITS;
/// |z| from which tanh is exactly ±1 (8.0 in I8F24): the end of the table.
pub const SATURATION_I8F24: u32 = 8 << ARG_FRAC_BITS;
/// log₂ of the table step in I8F24 units: h = 2¹⁹ / 2²⁴ = 1/32.
const STEP_BITS: u32 = 19;
/// The fraction below one table step.
const STEP_MASK: u32 = (1 << STEP_BITS) - 1;
/// Number of table entries: z = k/32 for k = 0 … 256.
pub const TABLE_LEN: usize = 257;

/// `round(tanh(k/32) · 2^30)` for k = 0 … 255, and exactly 2^30 for k = 256 (z = 8).
/// Generated with `round(math.tanh(k / 32) * 2**30)`; checked entry by entry against f64 in the
/// host tests.
pub static TANH_TABLE_I2F30: [i32; TABLE_LEN] = [
    0, 33543514, 67021619, 100369417, 133523019, 166420030, 199000008, 231204897, 262979411,
    294271390, 325032097, 355216470, 384783327, 413695509, 441919982, 469427884, 496194519,
    522199322, 547425766, 571861244, 595496917, 618327534, 640351229, 661569304, 681985995,
    701608235, 720445410, 738509109, 755812887, 772372023, 788203292, 803324746, 817755498,
    831515533, 844625518, 857106631, 868980407, 880268593, 890993016, 901175474, 910837623,
    920000894, 928686409, 936914916, 944706725, 952081667, 959059047, 965657614, 971895537,
    977790386, 983359117, 988618065, 993582944, 998268841, 1002690226, 1006860957, 1010794288,
    1014502881, 1017998824, 1021293637, 1024398298, 1027323250, 1030078428, 1032673268, 1035116732,
    1037417324, 1039583108, 1041621725, 1043540415, 1045346031, 1047045057, 1048643629, 1050147544,
    1051562285, 1052893030, 1054144667, 1055321814, 1056428829, 1057469822, 1058448672, 1059369036,
    1060234362, 1061047900, 1061812714, 1062531689, 1063207545, 1063842843, 1064439994, 1065001270,
    1065528808, 1066024621, 1066490604, 1066928539, 1067340105, 1067726879, 1068090347, 1068431906,
    1068752870, 1069054476, 1069337886, 1069604193, 1069854425, 1070089550, 1070310477, 1070518060,
    1070713102, 1070896360, 1071068543, 1071230320, 1071382317, 1071525125, 1071659298, 1071785356,
    1071903791, 1072015063, 1072119603, 1072217818, 1072310092, 1072396782, 1072478226, 1072554741,
    1072626625, 1072694159, 1072757605, 1072817210, 1072873207, 1072925813, 1072975235, 1073021665,
    1073065284, 1073106261, 1073144757, 1073180922, 1073214897, 1073246815, 1073276799, 1073304968,
    1073331431, 1073356291, 1073379645, 1073401585, 1073422196, 1073441558, 1073459748, 1073476836,
    1073492889, 1073507970, 1073522137, 1073535446, 1073547948, 1073559694, 1073570728, 1073581093,
    1073590830, 1073599978, 1073608572, 1073616644, 1073624228, 1073631353, 1073638045, 1073644333,
    1073650239, 1073655788, 1073661000, 1073665897, 1073670497, 1073674818, 1073678878, 1073682692,
    1073686274, 1073689640, 1073692801, 1073695771, 1073698561, 1073701183, 1073703645, 1073705958,
    1073708131, 1073710172, 1073712090, 1073713891, 1073715584, 1073717174, 1073718667, 1073720070,
    1073721388, 1073722626, 1073723789, 1073724882, 1073725908, 1073726873, 1073727779, 1073728629,
    1073729429, 1073730180, 1073730885, 1073731548, 1073732171, 1073732756, 1073733305, 1073733821,
    1073734306, 1073734761, 1073735189, 1073735591, 1073735969, 1073736324, 1073736657, 1073736970,
    1073737264, 1073737540, 1073737800, 1073738044, 1073738273, 1073738488, 1073738690, 1073738880,
    1073739058, 1073739226, 1073739383, 1073739531, 1073739670, 1073739801, 1073739923, 1073740038,
    1073740146, 1073740248, 1073740344, 1073740433, 1073740518, 1073740597, 1073740671, 1073740741,
    1073740807, 1073740868, 1073740926, 1073740980, 1073741032, 1073741080, 1073741125, 1073741167,
    1073741207, 1073741244, 1073741279, 1073741312, 1073741343, 1073741373, 1073741400, 1073741426,
    1073741450, 1073741472, 1073741494, 1073741514, 1073741532, 1073741550, 1073741567, 1073741824,
];

/// tanh(z) in I2F30 for z in I8F24: table with linear interpolation, odd, ±1 for |z| ≥ 8.
///
/// Max |error| 9.4·10⁻⁵ (see the module's *Accuracy*). Monotonic non-decreasing in z.
///
/// ```
/// use sledid::ident::neuron::{tanh_i2f30, ONE_I2F30};
/// assert_eq!(tanh_i2f30(0), 0);
/// assert_eq!(tanh_i2f30(9 << 24), ONE_I2F30);
/// assert_eq!(tanh_i2f30(i32::MIN), -ONE_I2F30);
/// let t = f64::from(tanh_i2f30(1 << 24)) / f64::from(ONE_I2F30);
/// assert!((t - 1f64.tanh()).abs() < 1.0 / 4096.0);
/// ```
#[inline]
pub fn tanh_i2f30(z_i8f24: i32) -> i32 {
    let mag = z_i8f24.unsigned_abs();
    let t = if mag >= SATURATION_I8F24 {
        ONE_I2F30
    } else {
        // mag < 2^27, so k ≤ 255 and k + 1 ≤ 256 are inside the table.
        let k = (mag >> STEP_BITS) as usize;
        let t0 = TANH_TABLE_I2F30.get(k).copied().unwrap_or(ONE_I2F30);
        let t1 = TANH_TABLE_I2F30.get(k + 1).copied().unwrap_or(ONE_I2F30);
        // 0 ≤ t1 − t0 < 2^25 (tanh increasing, slope ≤ 1); × a fraction < 2^19: < 2^44.
        let step = mul_u32_wide(t1.saturating_sub(t0).unsigned_abs(), mag & STEP_MASK);
        // The rounded step is ≤ t1 − t0, so t0 + it ≤ t1 ≤ 2^30: no overflow.
        t0 + shr_round_i64(step as i64, STEP_BITS) as i32
    };
    if z_i8f24 < 0 { -t } else { t }
}

/// A neuron's parameters in engineering units (floats); build a validated [`Neuron`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeuronDesign {
    /// Output weight w, in units of g (sensor quanta).
    pub w: f64,
    /// Input weight a, per unit of x.
    pub a: f64,
    /// Bias c.
    pub c: f64,
}

/// a·(input range) of the initial design: tanh(1) = 0.76, s ≥ 0.42 on the range.
pub const INITIAL_INPUT_GAIN: f64 = 1.0;
/// Largest |c| of the initial biases: with [`INITIAL_INPUT_GAIN`], |z| ≤ 1.5 and s ≥ 0.18.
pub const INITIAL_BIAS_SPREAD: f64 = 0.5;

impl NeuronDesign {
    /// The paper's initialisation for inputs in ±`input_range`: w = 0 (g ≡ 0, the model starts
    /// equal to the linear one), a = 1/`input_range` (the neuron is unsaturated, |z| ≤ 1, on the
    /// range), c = 0.
    ///
    /// A range that is not finite and positive gives a = NaN, which [`NeuronDesign::build`]
    /// rejects; a range beyond ~2¹⁰ leaves a with fewer than 10 significant bits in I12F20.
    #[allow(clippy::float_arithmetic)] // design time, not the per-sample path
    pub fn initial(input_range: f64) -> Self {
        let a = if input_range.is_finite() && input_range > 0.0 {
            INITIAL_INPUT_GAIN / input_range
        } else {
            f64::NAN
        };
        Self { w: 0.0, a, c: 0.0 }
    }

    /// Validates and quantises (round to nearest).
    ///
    /// # Errors
    /// [`ConfigError::InitialModel`] with the first of w, a, c that is not finite or outside ±2048.
    ///
    /// ```
    /// use sledid::ident::neuron::NeuronDesign;
    /// let n = NeuronDesign::initial(1.0).build().unwrap();
    /// assert_eq!(n.w().raw(), 0);
    /// assert!(NeuronDesign { w: 1.0, a: f64::NAN, c: 0.0 }.build().is_err());
    /// assert!(NeuronDesign::initial(0.0).build().is_err());
    /// ```
    pub fn build(&self) -> Result<Neuron, ConfigError> {
        let q = |v: f64| ParamI12F20::from_f64(v).map_err(|_| ConfigError::InitialModel(v));
        Ok(Neuron::new(q(self.w)?, q(self.a)?, q(self.c)?))
    }
}

/// A tanh neuron `g(x) = w·tanh(a·x + c)` with quantised parameters (`Copy`).
///
/// The neuron is a static map: it has no state. Its parameters are what a nonlinear estimator
/// updates, so [`Neuron::new`] takes them from the raw formats without validation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Neuron {
    w: ParamI12F20,
    a: ParamI12F20,
    c: ParamI12F20,
}

/// The derivatives of g with respect to one neuron's parameters, in I16F16.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NeuronGradient {
    /// ∂g/∂w = tanh(z).
    pub dw: SignalI16F16,
    /// ∂g/∂a = w·x·(1 − tanh²z).
    pub da: SignalI16F16,
    /// ∂g/∂c = w·(1 − tanh²z).
    pub dc: SignalI16F16,
}

/// One neuron evaluated at x, with its derivatives.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NeuronOutput {
    /// g(x) = w·tanh(z).
    pub g: SignalI16F16,
    /// tanh(z) in I2F30 (the full-precision ∂g/∂w).
    pub tanh_i2f30: i32,
    /// 1 − tanh²(z) in I2F30.
    pub sech2_i2f30: i32,
    /// ∂g/∂x = w·a·(1 − tanh²z).
    pub dg_dx: SignalI16F16,
    /// The derivatives with respect to w, a, c.
    pub grad: NeuronGradient,
    /// [`Status::SATURATED`] when ∂g/∂x or ∂g/∂a saturated.
    pub status: Status,
}

impl Neuron {
    /// From quantised parameters.
    pub const fn new(w: ParamI12F20, a: ParamI12F20, c: ParamI12F20) -> Self {
        Self { w, a, c }
    }

    /// Output weight w.
    pub const fn w(&self) -> ParamI12F20 {
        self.w
    }

    /// Input weight a.
    pub const fn a(&self) -> ParamI12F20 {
        self.a
    }

    /// Bias c.
    pub const fn c(&self) -> ParamI12F20 {
        self.c
    }

    /// The argument z = a·x + c in I8F24, saturated to the `i32` range (where tanh is ±1).
    #[inline]
    pub fn argument_i8f24(&self, x: SignalI16F16) -> i32 {
        // a·x in I28F36, |·| ≤ 2^62; c·2^16 ≤ 2^47 in magnitude: the sum is below 2^63.
        let z_i28f36 = mul_i32_wide(self.a.raw(), x.raw()) + (i64::from(self.c.raw()) << 16);
        let z = shr_round_i64(z_i28f36, 36 - ARG_FRAC_BITS);
        z.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
    }

    /// g(x) = w·tanh(a·x + c) alone (never saturates: |g| ≤ |w|).
    #[inline]
    pub fn value(&self, x: SignalI16F16) -> SignalI16F16 {
        let t = tanh_i2f30(self.argument_i8f24(x));
        g_from_tanh(self.w, t)
    }

    /// g(x) and its derivatives with respect to x, w, a and c: [`term::eval`] with one input,
    /// and ∂g/∂x as an I16F16 signal.
    pub fn eval(&self, x: SignalI16F16) -> NeuronOutput {
        let o = term::eval(self.w, [self.a], self.c, [x]);
        let mut sat = o.da_saturated;
        // I12F20 × I12F20 = I24F40 → I16F16.
        let dg_dx = sat_i32(
            shr_round_i64(mul_i32_wide(o.ws_i12f20, self.a.raw()), 24),
            &mut sat,
        );
        let [da] = o.da;
        NeuronOutput {
            g: o.g,
            tanh_i2f30: o.tanh_i2f30,
            sech2_i2f30: o.sech2_i2f30,
            dg_dx: SignalI16F16::from_raw(dg_dx),
            grad: NeuronGradient {
                dw: o.dw,
                da,
                dc: o.dc,
            },
            status: if sat { Status::SATURATED } else { Status::NONE },
        }
    }
}

/// w·t: I12F20 × I2F30 = I14F50 → I16F16; |g| ≤ |w| < 2^11, so the cast is exact.
#[inline]
fn g_from_tanh(w: ParamI12F20, t_i2f30: i32) -> SignalI16F16 {
    SignalI16F16::from_raw(shr_round_i64(mul_i32_wide(w.raw(), t_i2f30), 34) as i32)
}

/// Designs of the M neurons of one hidden layer; build a [`HiddenLayer`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HiddenLayerDesign<const M: usize> {
    /// The neurons.
    pub neurons: [NeuronDesign; M],
}

impl<const M: usize> HiddenLayerDesign<M> {
    /// The paper's initialisation for inputs in ±`input_range`: every w = 0, every
    /// a = 1/`input_range`, biases spread evenly over ±[`INITIAL_BIAS_SPREAD`] (0 for M = 1), so
    /// |z| ≤ 1.5 on the range and no two neurons are alike.
    ///
    /// ```
    /// use sledid::ident::neuron::HiddenLayerDesign;
    /// let d = HiddenLayerDesign::<2>::initial(1.0);
    /// assert_eq!((d.neurons[0].c, d.neurons[1].c), (-0.5, 0.5));
    /// let net = d.build().unwrap();
    /// assert_eq!(net.value(sledid::SignalI16F16::from_int(1)).0.raw(), 0);
    /// ```
    #[allow(clippy::float_arithmetic)] // design time, not the per-sample path
    pub fn initial(input_range: f64) -> Self {
        let mut neurons = [NeuronDesign::initial(input_range); M];
        if M > 1 {
            let span = (M - 1) as f64;
            for (i, n) in neurons.iter_mut().enumerate() {
                n.c = INITIAL_BIAS_SPREAD * (2.0 * i as f64 - span) / span;
            }
        }
        Self { neurons }
    }

    /// Validates and quantises every neuron.
    ///
    /// # Errors
    /// The first neuron's [`ConfigError`].
    pub fn build(&self) -> Result<HiddenLayer<M>, ConfigError> {
        let mut neurons = [Neuron::default(); M];
        for (n, d) in neurons.iter_mut().zip(self.neurons.iter()) {
            *n = d.build()?;
        }
        Ok(HiddenLayer { neurons })
    }
}

/// One hidden layer of M tanh neurons, `g(x) = Σᵢ wᵢ·tanh(aᵢ·x + cᵢ)` (`Copy`, no state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HiddenLayer<const M: usize> {
    neurons: [Neuron; M],
}

/// The layer evaluated at x, with every derivative.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LayerOutput<const M: usize> {
    /// g(x) = Σ wᵢ tanh(zᵢ).
    pub g: SignalI16F16,
    /// ∂g/∂x = Σ wᵢaᵢ(1 − tanh²zᵢ).
    pub dg_dx: SignalI16F16,
    /// Per neuron: ∂g/∂wᵢ, ∂g/∂aᵢ, ∂g/∂cᵢ.
    pub grad: [NeuronGradient; M],
    /// [`Status::SATURATED`] when a derivative or a sum saturated.
    pub status: Status,
}

impl<const M: usize> HiddenLayer<M> {
    /// From quantised neurons.
    pub const fn new(neurons: [Neuron; M]) -> Self {
        Self { neurons }
    }

    /// The neurons.
    pub const fn neurons(&self) -> &[Neuron; M] {
        &self.neurons
    }

    /// g(x) alone; [`Status::SATURATED`] if the sum saturated.
    pub fn value(&self, x: SignalI16F16) -> (SignalI16F16, Status) {
        let mut g: i32 = 0;
        let mut sat = false;
        for n in &self.neurons {
            g = sat_add(g, n.value(x).raw(), &mut sat);
        }
        let status = if sat { Status::SATURATED } else { Status::NONE };
        (SignalI16F16::from_raw(g), status)
    }

    /// g(x), ∂g/∂x and the gradient with respect to every parameter.
    pub fn eval(&self, x: SignalI16F16) -> LayerOutput<M> {
        let mut out = LayerOutput {
            g: SignalI16F16::ZERO,
            dg_dx: SignalI16F16::ZERO,
            grad: [NeuronGradient::default(); M],
            status: Status::NONE,
        };
        let (mut g, mut dx, mut sat) = (0i32, 0i32, false);
        for (n, grad) in self.neurons.iter().zip(out.grad.iter_mut()) {
            let o = n.eval(x);
            g = sat_add(g, o.g.raw(), &mut sat);
            dx = sat_add(dx, o.dg_dx.raw(), &mut sat);
            *grad = o.grad;
            out.status |= o.status;
        }
        out.g = SignalI16F16::from_raw(g);
        out.dg_dx = SignalI16F16::from_raw(dx);
        out.status.set_if(Status::SATURATED, sat);
        out
    }
}

/// Saturating `i32` sum; the flag is set when it saturated.
#[inline]
fn sat_add(a: i32, b: i32, saturated: &mut bool) -> i32 {
    sat_i32(i64::from(a) + i64::from(b), saturated)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tanh_edges() {
        assert_eq!(tanh_i2f30(0), 0);
        assert_eq!(tanh_i2f30(i32::MAX), ONE_I2F30);
        assert_eq!(tanh_i2f30(i32::MIN), -ONE_I2F30);
        assert_eq!(tanh_i2f30(8 << 24), ONE_I2F30);
        assert!(ONE_I2F30 - tanh_i2f30((8 << 24) - 1) <= 1);
        assert_eq!(tanh_i2f30(-(1 << 19)), -TANH_TABLE_I2F30[1]);
        let mut prev = -ONE_I2F30;
        let mut z = -(9i32 << 24);
        while z < 9 << 24 {
            let t = tanh_i2f30(z);
            assert!(t >= prev, "not monotonic at {z}");
            assert_eq!(tanh_i2f30(-z), -t);
            prev = t;
            z += 4099;
        }
    }

    #[test]
    fn neuron_edges() {
        let p = ParamI12F20::from_raw;
        // w = 0: g ≡ 0 and only ∂g/∂w is non-zero.
        let n = Neuron::new(p(0), p(1 << 20), p(0));
        let o = n.eval(SignalI16F16::from_int(1));
        assert_eq!(o.g, SignalI16F16::ZERO);
        let z = SignalI16F16::ZERO;
        assert_eq!((o.grad.da, o.grad.dc, o.dg_dx), (z, z, z));
        assert!(o.grad.dw.raw() > 0);
        // Extreme parameters and inputs: saturation is flagged, nothing wraps.
        let n = Neuron::new(ParamI12F20::MAX, ParamI12F20::MIN, ParamI12F20::MAX);
        for x in [SignalI16F16::MIN, SignalI16F16::ZERO, SignalI16F16::MAX] {
            let o = n.eval(x);
            assert!(o.g.raw().unsigned_abs() <= (1 << 27));
            assert_eq!(o.g, n.value(x));
        }
        let n = Neuron::new(ParamI12F20::MAX, ParamI12F20::MAX, ParamI12F20::ZERO);
        let o = n.eval(SignalI16F16::ZERO);
        assert_eq!(o.dg_dx, SignalI16F16::MAX);
        assert_eq!(o.status, Status::SATURATED);
        let layer = HiddenLayer::new([n; 2]);
        assert_eq!(layer.eval(SignalI16F16::ZERO).status, Status::SATURATED);
    }
}
