//! Recursive least squares with exponential forgetting, in integers, on the UD factorisation of the
//! covariance (Bierman's update) in one pass over the columns, with the anti-windup the sled's
//! closed-loop data needs.
//!
//! # Equations
//! For the regression `y(t) = ψ(t)ᵀθ + e(t)` (eq. 1 of the paper for ARX, its pseudo-linear and
//! prediction-error forms for OE, eq. 2), with forgetting factor λ ∈ (0, 1]:
//!
//! ```text
//! ε(t) = y(t) − ŷ(t)                       (prediction error, computed by the model structure)
//! K(t) = P ψ / (λ + ψᵀ P ψ)
//! θ(t) = θ(t−1) + K(t) ε(t)
//! P(t) = (P − K ψᵀ P) / λ
//! ```
//!
//! P is never formed. It is held as `P = U·D·Uᵀ` with U unit upper-triangular and D diagonal and
//! positive, and updated with Bierman's algorithm (G. J. Bierman, *Factorization Methods for Discrete
//! Sequential Estimation*, 1977, §V.3), on a block-normalised regressor and without ever forming
//! the innovation variances βⱼ, only their ratios and the running reciprocal γⱼ = 1/βⱼ
//! (`shared/kernel-design.md`):
//!
//! ```text
//! φ̂ = 2^σ ψ            one leading-zero count over all |ψᵢ|: max |φ̂| ∈ [½, 1); σ the block exponent
//! f = Uᵀφ̂,  γ₀ = 1/(λ·4^σ)
//! for each column j:
//!     gⱼ = dⱼ fⱼ,  μⱼ = −fⱼ γⱼ₋₁,  qⱼ = |gⱼ μⱼ|          (= dⱼ fⱼ² / βⱼ₋₁ ≥ 0)
//!     rⱼ = 1 / (1 + qⱼ)                                 (= βⱼ₋₁ / βⱼ: a reciprocal of a number ≥ 1)
//!     γⱼ = γⱼ₋₁ rⱼ,   dⱼ ← cap(dⱼ rⱼ / λ)
//!     for i < j:  Uᵢⱼ ← Uᵢⱼ + νᵢ μⱼ,   νᵢ ← νᵢ + Uᵢⱼ(old) gⱼ
//!     νⱼ = gⱼ
//! θ ← θ + 2^σ ν γ_N ε                                   (K = 2^σ ν γ_N)
//! ```
//!
//! # Why this form
//! - **Positive definite by construction.** Every dⱼ is a positive [`Dyadic`] (only ever multiplied
//!   by positive factors, floored at the smallest positive value) and U is unit triangular, so
//!   P = UDUᵀ is symmetric positive definite whatever the rounding; a saturated Uᵢⱼ leaves U unit
//!   triangular. The textbook update loses positive definiteness after ~4,400 samples of the sled
//!   data at λ = 0.995 even in float64 (`shared/findings.md`).
//! - **Unit-free.** ψ is normalised by one power of two per update, so no absolute format sees the
//!   magnitude of the regressors; dⱼ, gⱼ, μⱼ, qⱼ, rⱼ, γⱼ float (32-bit mantissa or high word, own
//!   exponent).
//!   U holds ratios of parameter scales: it stays in range when the regressors are of comparable
//!   magnitude, which the boundary's normalisation provides ([`crate::num::boundary`]).
//! - **No division.** Each column needs one reciprocal of a number ≥ 1
//!   ([`crate::num::wide::recip_q61`]: a 256-entry seed and two 32-bit Newton steps); 1 + qⱼ is an
//!   add to a constant, not a general floating add.
//! - **One pass over the columns.** ν's block exponent is known before the first column (from the
//!   exponents of D and the bit lengths of f), so the scalar chain (D, γ and each column's Mⱼ, Gⱼ
//!   below) runs one column at a time; it needs neither U nor ν, so the U/ν triangle follows it
//!   column by column with only those two numbers per column (column j's triangle right after
//!   column j's chain on Armv6-M, after the whole chain on Armv7-M), then θ.
//! - **One body for every N.** [`RlsConfig::update`] is a thin const-generic wrapper of one kernel
//!   on slices, so an image with several parameter counts carries the kernel once.
//!
//! # Formats
//! | quantity | format | note |
//! |---|---|---|
//! | ψ, ε, ŷ | I16F16 ([`SignalI16F16`]) | the interface |
//! | φ̂ | I3F29 `i32`, max \|φ̂\| ∈ [2²⁸, 2²⁹) raw | block exponent σ per update; λ·4^σ exact |
//! | U (strict upper part, column-major) | I8F24 `i32` ([`U_FRAC_BITS`]) | saturating, flagged |
//! | f = Uᵀφ̂ | exact I11F53 `i64` sum, rounded once to I11F21 `i32` (its high word) | \|f\| < 1 + 7·128 < 1024 |
//! | D | [`Dyadic`]: mantissa in [2³¹, 2³²), own exponent | capped per column (anti-windup) |
//! | γⱼ, 1 + qⱼ | mantissa in [2³¹, 2³²) and `i32` exponent | normalised by one leading-zero count |
//! | gⱼ, μⱼ, qⱼ | `u32` high words of 32×32 products, sign kept aside: gⱼ, μⱼ ∈ [2³⁰, 2³²), qⱼ ∈ [2²⁸, 2³²), own exponent | not normalised (only γ and D keep a mantissa) |
//! | rⱼ | ≈ 2⁶¹/(1 + qⱼ) ∈ (2²⁹, 2³⁰ + 3) ([`crate::num::wide::recip_q61`]) with its exponent | |
//! | Gⱼ, Mⱼ | `i32`: gⱼ in ν units, μⱼ pre-shifted for the U update (both truncated, ≥ 29 bits) | |
//! | ν (the gain being built) | νᵢ·2²⁴ in an exact 64-bit accumulator, ν in units 2^e_ν, one e_ν per update | headroom H bits above the largest gⱼ |
//! | θ | I16F48 `i64` ([`RlsState::theta_i16f48`]), read out as I12F20 ([`ParamI12F20`]) | saturating, flagged |
//!
//! # Scaling and overflow
//! - |φ̂| ≤ 2²⁹ and |Uᵢⱼ| ≤ 2³¹ raw: each product of f is at most 2⁶⁰ and f's sum of ≤ 8 terms
//!   (with φ̂ⱼ·2²⁴) stays below 2⁶³ — plain adds; its rounded high word is f̂ⱼ in I11F21.
//! - ν: e_ν = max_j(exponent bound of gⱼ) − (31 − H), the bound from D's exponents and f̂'s bit
//!   lengths (|f̂ⱼ| ≤ 2^b with b the bit length of f̂ⱼ ^ (f̂ⱼ >> 31)), and the headroom
//!   H = bitlen((N−1)·2^k) from |Uᵢⱼ| ≤ 2^k (k ≥ 0; one OR of Uᵢⱼ ^ (Uᵢⱼ >> 31) per entry while
//!   f is formed). Gⱼ = ⌊|gⱼ|/2^e_ν⌋ < 2^(31−H) and 2^H ≥ 1 + (N−1)·2^k, so the exact
//!   |νᵢ| ≤ Gmax·(1 + (N−1)·2^k) < 2³¹: ν keeps 31 − H bits when U is small and stays in range
//!   when it is large, with no saturation. νᵢ + Uᵢⱼ·gⱼ is one `SMLAL` into the accumulator; νᵢ
//!   is read from it by a constant shift (floor).
//! - Uᵢⱼ + νᵢ μⱼ: μⱼ is pre-shifted to Mⱼ with ν·Mⱼ/2³² in I8F24 (one rounded high-word multiply,
//!   `SMMULR` on Armv7E-M) when that shift is a right shift (the usual case); else (early
//!   updates from a large P₀) the 64-bit product is shifted and narrowed, saturating.
//! - θ: Δθ = ν·(γ_N |ε|) as a 64-bit product shifted by one per-update amount, added saturating
//!   (a wrapped sum is beyond the read-out's range and redone saturating there).
//! - Exponents: stored ones are within ±2¹⁴ and one update adds a few hundred, so `i32` cannot
//!   overflow; the clamp is applied when D is stored.
//!
//! # Anti-windup
//! Selected per configuration ([`AntiWindup`]): a cap on each dⱼ applied in the column loop (one
//! exponent compare; it bounds trace(P) ≤ d_max·Σⱼ(1 + Σ_{i<j} Uᵢⱼ²)), or a trace,
//! diagonal or constant-trace bound applied after the update (P scaled, U unchanged). Independent
//! of it: a dead zone on |ε| (in sensor quanta: the ±1-quantum limit cycle does not drive the
//! estimate), an excitation gate on ψᵀPψ, an outlier gate, hold. Skipped samples leave θ and P
//! untouched (no forgetting without information, so no windup).
//!
//! # Accuracy
//! Against a float64 UD update on the same quantised data: `host-tests/tests/integration/rls_vs_f64.rs`
//! (simulated closed-loop plants), `emps_vs_f64.rs` (the EMPS recording) and `unit_sweep.rs`
//! (position units 2⁻¹⁰…2¹⁰ × nominal and each recording's own quantum, EMPS ARX(1,1)/(2,2),
//! Silverbox, and the twin's closed-loop records without the stability projection, whose
//! decisions at their z = 1 pole are not the kernel's: θ within 1·10⁻³ of float64). Measured
//! figures and cost:
//! [BENCHMARKS.md](../../BENCHMARKS.md) (kernel section).

#![deny(clippy::float_arithmetic)]

use crate::error::ConfigError;
use crate::ident::status::Status;
use crate::num::dyadic::{Dyadic, EXP_MAX, EXP_MIN};
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shift_round_i64, shr_round_i64};
use crate::num::wide::{
    leading_zeros_compact, leading_zeros_near, leading_zeros_u32, mul_hi_round_i32, mul_hi_u32,
    mul_i32_wide, mul_i32_wide_compact, mul_u32_wide, mul_u32_wide_compact, recip_q61,
};

mod words;

/// Fraction bits of the U factor (I8F24: |Uᵢⱼ| < 128; the nonlinear models' regressors need more
/// than I4F28's 8, measured: `tests/integration/nonlinear.rs`, `tests/integration/nonlinear_units.rs`).
pub const U_FRAC_BITS: u32 = 24;
/// Fraction bits of the normalised regressor φ̂ (I3F29).
const PHI_FRAC_BITS: u32 = 29;
/// Fraction bits of f̂ = Uᵀφ̂ after its one rounding (I11F21): the high word of the I11F53 sum.
const F_FRAC_BITS: i32 = (U_FRAC_BITS + PHI_FRAC_BITS) as i32 - 32;
/// Fraction bits of θ (I16F48).
pub const THETA_FRAC_BITS: u32 = 48;
/// θ's I16F48 → I12F20 read-out shift.
const THETA_OUT_SHIFT: u32 = THETA_FRAC_BITS - crate::num::fixed::PARAM_FRAC_BITS;
/// Largest supported parameter count (f's exact sum and ν's headroom are sized for it).
pub const MAX_PARAMS: usize = 8;

/// How the covariance is kept from winding up; all limits are on P in parameter units²/signal units².
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AntiWindup {
    /// No covariance limit (the dead zone and excitation gate still apply).
    #[default]
    None,
    /// After each update, if trace(P) > `max`, scale P down so that trace(P) = `max`.
    TraceLimit {
        /// Largest allowed trace.
        max: f64,
    },
    /// After each update, if the largest diagonal element of P exceeds `max`, scale P down to it.
    DiagonalLimit {
        /// Largest allowed diagonal element.
        max: f64,
    },
    /// Constant-trace regularisation: after each update, scale P so that trace(P) = `trace`.
    ConstantTrace {
        /// The trace P is held at.
        trace: f64,
    },
    /// Each dⱼ of P = UDUᵀ held at or below `max` rounded down to a power of two, in the update's
    /// column loop (one exponent compare per column, no trace formed): trace(P) ≤
    /// max·Σⱼ(1 + Σ_{i<j} Uᵢⱼ²).
    FactorCap {
        /// Largest dⱼ (rounded down to a power of two).
        max: f64,
    },
}

impl AntiWindup {
    /// The cap a [`Self::FactorCap`] applies to each dⱼ: `max` rounded down to a power of two
    /// (what the float64 reference applies too); `None` for the other variants.
    pub fn factor_cap(&self) -> Option<Dyadic> {
        match *self {
            Self::FactorCap { max } => match Dyadic::from_f64(max) {
                Some(d) if !d.is_zero() => Some(Dyadic::ONE.shl(d.exp() + 31)),
                _ => None,
            },
            _ => None,
        }
    }
}

/// User-facing RLS settings, in engineering units (floats); build a validated [`RlsConfig`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RlsDesign {
    /// Forgetting factor λ ∈ (0, 1]; 1 means no forgetting.
    pub lambda: f64,
    /// Initial covariance P₀ = p0 · I.
    pub p0: f64,
    /// Dead zone on |ε| in signal units (sensor quanta for positions); 0 disables it.
    pub dead_zone: f64,
    /// Minimum ψᵀPψ for an update; 0 disables the gate.
    pub excitation_threshold: f64,
    /// Covariance limit.
    pub anti_windup: AntiWindup,
    /// Outlier gate: updates with |ε| above this (signal units) are skipped as sensor spikes; 0
    /// disables it.
    pub outlier_threshold: f64,
    /// After this many consecutive outliers the gate opens again (a persistent "outlier" is a plant
    /// change — a reversed sensor, a mass step — that the estimator must follow, not ignore).
    pub outlier_limit: u16,
}

impl Default for RlsDesign {
    fn default() -> Self {
        Self {
            lambda: 1.0,
            p0: 1.0e4,
            dead_zone: 0.0,
            excitation_threshold: 0.0,
            anti_windup: AntiWindup::None,
            outlier_threshold: 0.0,
            outlier_limit: 16,
        }
    }
}

/// The quantised covariance limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Bound {
    None,
    Trace(Dyadic),
    Diagonal(Dyadic),
    ConstantTrace(Dyadic),
}

/// Validated, quantised RLS configuration (`Copy`; swap it between samples without touching state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RlsConfig {
    lambda: Dyadic,
    lambda_inv: Dyadic,
    p0: Dyadic,
    /// Largest exponent a stored dⱼ keeps (mantissa below 2³²): the factor cap, else [`EXP_MAX`].
    d_cap_exp: i32,
    dead_zone_i16f16: u32,
    excitation_min: Dyadic,
    bound: Bound,
    outlier_i16f16: u32,
    outlier_limit: u16,
}

fn positive_dyadic(x: f64, err: ConfigError) -> Result<Dyadic, ConfigError> {
    match Dyadic::from_f64(x) {
        Some(d) if !d.is_zero() && !d.is_saturated() => Ok(d),
        _ => Err(err),
    }
}

impl RlsDesign {
    /// Validates and quantises.
    ///
    /// # Errors
    /// A [`ConfigError`] naming the first parameter out of range.
    ///
    /// ```
    /// use sledid::ident::rls::{AntiWindup, RlsDesign};
    /// let cfg = RlsDesign { lambda: 0.995, anti_windup: AntiWindup::TraceLimit { max: 100.0 },
    ///                       ..RlsDesign::default() }.build();
    /// assert!(cfg.is_ok());
    /// assert!(RlsDesign { lambda: 1.5, ..RlsDesign::default() }.build().is_err());
    /// ```
    pub fn build(&self) -> Result<RlsConfig, ConfigError> {
        if !(self.lambda > 0.0 && self.lambda <= 1.0) {
            return Err(ConfigError::Lambda(self.lambda));
        }
        let lambda = positive_dyadic(self.lambda, ConfigError::Lambda(self.lambda))?;
        let p0 = positive_dyadic(self.p0, ConfigError::InitialCovariance(self.p0))?;
        if self.dead_zone.is_nan() || self.dead_zone < 0.0 {
            return Err(ConfigError::DeadZone(self.dead_zone));
        }
        let dz = SignalI16F16::from_f64(self.dead_zone)
            .map_err(|_| ConfigError::DeadZone(self.dead_zone))?;
        if self.outlier_threshold.is_nan() || self.outlier_threshold < 0.0 {
            return Err(ConfigError::OutlierThreshold(self.outlier_threshold));
        }
        let outlier = SignalI16F16::from_f64(self.outlier_threshold)
            .map_err(|_| ConfigError::OutlierThreshold(self.outlier_threshold))?;
        if outlier.raw() != 0 && outlier.raw() <= dz.raw() {
            return Err(ConfigError::OutlierThreshold(self.outlier_threshold));
        }
        let excitation_min = match Dyadic::from_f64(self.excitation_threshold) {
            Some(d) if !d.is_saturated() => d,
            _ => return Err(ConfigError::ExcitationThreshold(self.excitation_threshold)),
        };
        let mut d_cap_exp = EXP_MAX;
        let bound = match self.anti_windup {
            AntiWindup::None => Bound::None,
            AntiWindup::FactorCap { max } => {
                let cap = positive_dyadic(max, ConfigError::CovarianceLimit(max))?;
                // max ∈ [2^(e+31), 2^(e+32)): dⱼ = m·2^e' < 2^(e+31) for every e' ≤ e − 1.
                d_cap_exp = cap.exp() - 1;
                Bound::None
            }
            AntiWindup::TraceLimit { max } => {
                Bound::Trace(positive_dyadic(max, ConfigError::CovarianceLimit(max))?)
            }
            AntiWindup::DiagonalLimit { max } => {
                Bound::Diagonal(positive_dyadic(max, ConfigError::CovarianceLimit(max))?)
            }
            AntiWindup::ConstantTrace { trace } => {
                Bound::ConstantTrace(positive_dyadic(trace, ConfigError::CovarianceLimit(trace))?)
            }
        };
        let config = RlsConfig {
            lambda,
            lambda_inv: lambda.recip(),
            p0,
            d_cap_exp,
            dead_zone_i16f16: dz.raw().unsigned_abs(),
            excitation_min,
            bound,
            outlier_i16f16: outlier.raw().unsigned_abs(),
            outlier_limit: self.outlier_limit,
        };
        // The decoded words' checks: a design this far is within them (one copy of the rules).
        config.validate()?;
        Ok(config)
    }
}

/// Everything an update mutates: θ and the UD factors of P.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RlsState<const N: usize> {
    /// θ in I16F48.
    theta_i16f48: [i64; N],
    /// θ read out in I12F20 (rounded, saturating), kept with every change of `theta_i16f48`.
    theta: [ParamI12F20; N],
    /// Strictly upper part of U in I8F24, column-major: `u[j][i]` = Uᵢⱼ for i < j; the rest
    /// stays zero.
    u_i8f24: [[i32; N]; N],
    d: [Dyadic; N],
    enabled: bool,
    /// Consecutive samples rejected by the outlier gate.
    outliers_in_a_row: u16,
}

impl<const N: usize> RlsState<N> {
    const SIZE_OK: () = assert!(N >= 1 && N <= MAX_PARAMS, "1 ≤ N ≤ 8 parameters");

    /// A fresh state: θ = `theta0`, P = p₀·I, enabled.
    pub fn new(config: &RlsConfig, theta0: [ParamI12F20; N]) -> Self {
        let () = Self::SIZE_OK;
        Self {
            theta_i16f48: theta0.map(|t| i64::from(t.raw()) << THETA_OUT_SHIFT),
            theta: theta0,
            u_i8f24: [[0; N]; N],
            d: [config.p0; N],
            enabled: true,
            outliers_in_a_row: 0,
        }
    }

    /// Back to θ = `theta0`, P = p₀·I (the enable state is kept).
    pub fn reset(&mut self, config: &RlsConfig, theta0: [ParamI12F20; N]) {
        let enabled = self.enabled;
        *self = Self::new(config, theta0);
        self.enabled = enabled;
    }

    /// Enables (true) or holds (false) the estimator; on hold θ and P are frozen.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// True unless on hold.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// The current estimate θ, I12F20 (θ's I16F48 rounded, saturating).
    pub fn theta(&self) -> &[ParamI12F20; N] {
        &self.theta
    }

    /// The current estimate θ at full precision, raw I16F48.
    pub fn theta_i16f48(&self) -> &[i64; N] {
        &self.theta_i16f48
    }

    /// Overwrites θ (the friction term's projection of the linear models). Entries equal to the
    /// current read-out keep their I16F48 precision; the others are set exactly.
    pub fn set_theta(&mut self, theta: [ParamI12F20; N]) {
        for ((hi, out), new) in self
            .theta_i16f48
            .iter_mut()
            .zip(self.theta.iter_mut())
            .zip(theta.iter())
        {
            if out != new {
                *hi = i64::from(new.raw()) << THETA_OUT_SHIFT;
                *out = *new;
            }
        }
    }

    /// Overwrites θ at full precision, raw I16F48 (the stability projection's trial steps), its
    /// read-out rounded to I12F20; true when a read-out saturated.
    pub fn set_theta_i16f48(&mut self, theta: [i64; N]) -> bool {
        let mut sat = false;
        for ((hi, out), new) in self
            .theta_i16f48
            .iter_mut()
            .zip(self.theta.iter_mut())
            .zip(theta.iter())
        {
            *hi = *new;
            *out = ParamI12F20::from_raw(theta_out(*new, &mut sat));
        }
        sat
    }

    /// The U factor in I8F24, column-major: `u[j][i]` = Uᵢⱼ for i < j (the rest is zero; the
    /// diagonal is 1, implicit).
    pub fn u_i8f24(&self) -> &[[i32; N]; N] {
        &self.u_i8f24
    }

    /// The D factor.
    pub fn d(&self) -> &[Dyadic; N] {
        &self.d
    }

    /// P = U·D·Uᵀ with U unit upper triangular is positive definite: every dⱼ > 0 (D is unsigned).
    pub fn is_positive_definite(&self) -> bool {
        self.d.iter().all(|d| !d.is_zero())
    }

    /// trace(P) = Σⱼ dⱼ (1 + Σ_{i<j} Uᵢⱼ²).
    pub fn trace(&self) -> Dyadic {
        trace_of(self.u_i8f24.as_flattened(), &self.d, N)
    }

    /// The largest diagonal element of P: Pᵢᵢ = dᵢ + Σ_{j>i} Uᵢⱼ² dⱼ.
    pub fn max_diagonal(&self) -> Dyadic {
        max_diagonal_of(self.u_i8f24.as_flattened(), &self.d, N)
    }
}

/// Σⱼ dⱼ·(1 + Σ_{i<j} Uᵢⱼ²): the one formula the trace bounds and [`RlsState::trace`] share.
fn trace_of(u: &[i32], d: &[Dyadic], n: usize) -> Dyadic {
    let mut acc = Pos::TINY;
    for (j, (col, dj)) in columns(u, n.max(1)).zip(d.iter()).enumerate() {
        acc = acc.add(trace_term(col.get(..j).unwrap_or_default(), *dj));
    }
    acc.to_dyadic()
}

/// dⱼ·(1 + Σ_{i<j} Uᵢⱼ²) for one column (its entries above the diagonal), the squares truncated
/// to U48F16 (one high-word multiply each; the sum is below 2³⁴, no overflow).
#[inline(always)]
fn trace_term(col: &[i32], dj: Dyadic) -> Pos {
    if col.is_empty() {
        // The first column: dⱼ·1 (exact, no product).
        return Pos::of(dj);
    }
    let mut norm: u64 = 1 << 16;
    for &uij in col {
        // U² < 2^14: U²·2^16 < 2^30.
        norm += (mul_i32_wide(uij, uij) >> 32) as u64;
    }
    // 2^16 ≤ norm < 2^34: its top 32 bits (truncated) from the two words by 32-bit shifts.
    let (hi, lo) = ((norm >> 32) as u32, norm as u32);
    let norm = if hi == 0 {
        Pos::of_u32(lo, -16)
    } else {
        // 1 ≤ hi < 4: a right shift of the pair by 1 or 2.
        let k = 32 - leading_zeros_u32(hi);
        Pos {
            m: (lo >> k) | (hi << (32 - k)),
            e: k as i32 - 16,
        }
    };
    Pos::of(dj).mul(norm)
}

/// max over i of dᵢ + Σ_{j>i} Uᵢⱼ² dⱼ, the squares truncated to U48F16 as in [`trace_term`].
fn max_diagonal_of(u: &[i32], d: &[Dyadic], n: usize) -> Dyadic {
    let mut best = Pos::TINY;
    for (i, di) in d.iter().enumerate().take(n) {
        let mut pii = Pos::of(*di);
        for (j, dj) in d.iter().enumerate().take(n).skip(i + 1) {
            let uij = u.get(j * n + i).copied().unwrap_or(0);
            // U² < 2^14: U²·2^16 < 2^30.
            let u_abs = uij.unsigned_abs();
            let u2 = (mul_u32_wide_compact(u_abs, u_abs) >> 32) as u32;
            if u2 != 0 {
                pii = pii.add(Pos::of_u32_compact(u2, -16).mul_compact(Pos::of(*dj)));
            }
        }
        if (pii.e, pii.m) > (best.e, best.m) {
            best = pii;
        }
    }
    best.to_dyadic()
}

/// Multiplies P by `factor` (scales D; U is unchanged), keeping every dⱼ positive.
fn scale_d(d: &mut [Dyadic], factor: Dyadic) {
    for dj in d {
        *dj = dj.mul_trunc(factor);
        if dj.is_zero() {
            *dj = Dyadic::MIN_POSITIVE;
        }
    }
}

/// `round(a·b / 2^32)` (half up): one `SMMULR` on Armv7E-M; four 16×16 products on Armv6-M.
/// |a·b| ≤ 2^62 for `i32` operands, so the result always fits.
#[inline(always)]
fn mul_hi_round(a: i32, b: i32) -> i32 {
    mul_hi_round_i32(a, b)
}

/// The top 32 bits of a product `p` in `[2^62, 2^64)` after a one-bit normalisation, and that
/// bit (1 when `p ≥ 2^63`); constant shifts on the two words.
#[inline(always)]
fn normalise_product(p: u64) -> (u32, u32) {
    let (hi, lo) = ((p >> 32) as u32, p as u32);
    let top = hi >> 31;
    (
        core::hint::select_unpredictable(top != 0, hi, (hi << 1) | (lo >> 31)),
        top,
    )
}

/// A positive number `m · 2^e` with `m` in `[2^31, 2^32)`: the update's working float, without a
/// zero case or an exponent clamp (see the module doc's scaling section).
#[derive(Clone, Copy)]
struct Pos {
    m: u32,
    e: i32,
}

impl Pos {
    /// A start for sums: below the smallest [`Dyadic`] (2^EXP_MIN) by far, so adding it to any
    /// stored value changes nothing, and it is stored as the smallest positive value.
    const TINY: Self = Self {
        m: 1 << 31,
        e: 4 * EXP_MIN,
    };

    /// From a positive dyadic (D, λ, 1/λ: never zero).
    #[inline(always)]
    fn of(d: Dyadic) -> Self {
        Self {
            m: d.mant(),
            e: d.exp(),
        }
    }

    /// |x|·2^e for a non-zero `x` (one leading-zero count).
    #[inline(always)]
    fn of_u32(x: u32, e: i32) -> Self {
        let lz = leading_zeros_u32(x);
        Self {
            m: x << lz,
            e: e - lz as i32,
        }
    }

    /// [`Self::of_u32`] off the per-sample path ([`crate::num::wide::leading_zeros_compact`]).
    #[inline(always)]
    fn of_u32_compact(x: u32, e: i32) -> Self {
        let lz = leading_zeros_compact(x);
        Self {
            m: x << lz,
            e: e - lz as i32,
        }
    }

    /// [`Self::mul`] off the per-sample path ([`crate::num::wide::mul_u32_wide_compact`]).
    #[inline(always)]
    fn mul_compact(self, rhs: Self) -> Self {
        let (m, top) = normalise_product(mul_u32_wide_compact(self.m, rhs.m));
        Self {
            m,
            e: self.e + rhs.e + 31 + top as i32,
        }
    }

    /// The product, truncated to 32 bits: one widening multiply and a one-bit normalisation.
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        let (m, top) = normalise_product(mul_u32_wide(self.m, rhs.m));
        Self {
            m,
            e: self.e + rhs.e + 31 + top as i32,
        }
    }

    /// `1 + self` (truncated to 32 bits): an add to a constant, no general alignment.
    #[inline(always)]
    fn one_plus(self) -> Self {
        if self.e <= -32 {
            // self < 1: 1 + self = (2^31 + self·2^31)·2^−31, self·2^31 < 2^31.
            let add = self.m.checked_shr((-31 - self.e) as u32).unwrap_or(0);
            Self {
                m: (1 << 31) + add,
                e: -31,
            }
        } else {
            // 1 = 2^(−e) in units of 2^e (below the kept bits when e ≥ 1).
            let one = if self.e >= 1 {
                0
            } else {
                1u32 << (-self.e) as u32
            };
            let (s, carry) = self.m.overflowing_add(one);
            Self::carried(s, carry, self.e)
        }
    }

    /// A 32-bit sum at exponent `e` with its carry out, renormalised (the carry becomes the top
    /// bit, the lowest bit is dropped).
    #[inline(always)]
    fn carried(sum: u32, carry: bool, e: i32) -> Self {
        if carry {
            Self {
                m: (sum >> 1) | (1 << 31),
                e: e + 1,
            }
        } else {
            Self { m: sum, e }
        }
    }

    /// The sum, aligned and added in 32 bits (error below 2 units of the last kept bit).
    #[inline(always)]
    fn add(self, rhs: Self) -> Self {
        let (hi, lo) = if self.e >= rhs.e {
            (self, rhs)
        } else {
            (rhs, self)
        };
        let lo_m = lo.m.checked_shr(hi.e.abs_diff(lo.e)).unwrap_or(0);
        let (sum, carry) = hi.m.overflowing_add(lo_m);
        Self::carried(sum, carry, hi.e)
    }

    /// As a dyadic (exponent limits applied).
    #[inline(always)]
    fn to_dyadic(self) -> Dyadic {
        if self.e > EXP_MAX {
            Dyadic::MAX
        } else if self.e < EXP_MIN {
            Dyadic::MIN_POSITIVE
        } else {
            Dyadic::from_normalised(self.m, self.e)
        }
    }
}

/// True when compiling for Armv6-M (as in [`crate::num::wide`]): a constant, the other branch is
/// removed at compile time.
const ARMV6M: bool = cfg!(all(target_arch = "arm", not(target_has_atomic = "32")));

/// The n columns of a column-major n×n matrix. On Armv6-M without `chunks_exact`, which divides
/// the length by n (a library call there; one `UDIV` on Armv7-M, where it is the shorter loop).
#[cfg(all(target_arch = "arm", not(target_has_atomic = "32")))]
fn columns(u: &[i32], n: usize) -> impl Iterator<Item = &[i32]> {
    let mut rest = u;
    core::iter::from_fn(move || {
        let (col, tail) = rest.split_at_checked(n)?;
        rest = tail;
        Some(col)
    })
}

/// The n columns of a column-major n×n matrix.
#[cfg(not(all(target_arch = "arm", not(target_has_atomic = "32"))))]
fn columns(u: &[i32], n: usize) -> impl Iterator<Item = &[i32]> {
    u.chunks_exact(n)
}

/// [`columns`], mutable.
#[cfg(all(target_arch = "arm", not(target_has_atomic = "32")))]
fn columns_mut(u: &mut [i32], n: usize) -> impl Iterator<Item = &mut [i32]> {
    let mut rest = u;
    core::iter::from_fn(move || {
        let (col, tail) = core::mem::take(&mut rest).split_at_mut_checked(n)?;
        rest = tail;
        Some(col)
    })
}

/// [`columns`], mutable.
#[cfg(not(all(target_arch = "arm", not(target_has_atomic = "32"))))]
fn columns_mut(u: &mut [i32], n: usize) -> impl Iterator<Item = &mut [i32]> {
    u.chunks_exact_mut(n)
}

/// ν's headroom H = bitlen((n−1)·2^k) ≥ ⌈log₂(1 + (n−1)·2^k)⌉, where |Uᵢⱼ| < 2^k (k ≥ 0) is
/// read off the OR of every |Uᵢⱼ| (`u_or`, raw I8F24): |νᵢ| ≤ |g|max·(1 + (n−1)·2^k) (module doc).
/// bitlen((n−1)·2^k) = bitlen(n−1) + k for n ≥ 2 (n − 1 ≤ 7: two compares) and 1 for n = 1;
/// k = 0 unless some |Uᵢⱼ| ≥ 1 (no leading-zero count in the usual case).
#[inline(always)]
fn nu_headroom(n: usize, u_or: u32) -> i32 {
    let k = if u_or >> U_FRAC_BITS == 0 {
        0
    } else {
        32 - leading_zeros_u32(u_or) as i32 - U_FRAC_BITS as i32
    };
    let m = n.saturating_sub(1);
    if m == 0 {
        1
    } else if m >= 4 {
        3 + k
    } else if m >= 2 {
        2 + k
    } else {
        1 + k
    }
}

/// The parts of a state the kernel works on, as slices (one kernel body for every N).
struct Parts<'a> {
    theta_i16f48: &'a mut [i64],
    theta: &'a mut [ParamI12F20],
    /// Column-major, n×n.
    u_i8f24: &'a mut [i32],
    d: &'a mut [Dyadic],
}

impl RlsConfig {
    /// The forgetting factor.
    pub fn lambda(&self) -> Dyadic {
        self.lambda
    }

    /// The dead zone on |ε|, raw I16F16.
    pub fn dead_zone_i16f16(&self) -> u32 {
        self.dead_zone_i16f16
    }

    /// ŷ = ψᵀθ, rounded to I16F16 (saturating; the flag is set when it saturated).
    pub fn predict<const N: usize>(
        theta: &[ParamI12F20; N],
        psi: &[SignalI16F16; N],
        saturated: &mut bool,
    ) -> SignalI16F16 {
        // Each product < 2^62; N ≤ 8 terms: saturating sum.
        let mut acc_i28f36: i64 = 0;
        for (t, p) in theta.iter().zip(psi.iter()) {
            acc_i28f36 = acc_i28f36.saturating_add(mul_i32_wide(t.raw(), p.raw()));
        }
        let y = shr_round_i64(acc_i28f36, crate::num::fixed::PARAM_FRAC_BITS);
        SignalI16F16::from_raw(sat_i32(y, saturated))
    }

    /// One RLS update with regressor ψ and prediction error ε (computed by the caller with the same
    /// θ). Never panics; returns what it did.
    pub fn update<const N: usize>(
        &self,
        st: &mut RlsState<N>,
        psi: &[SignalI16F16; N],
        eps: SignalI16F16,
    ) -> Status {
        if !st.enabled {
            return Status::HELD;
        }
        let e_abs = eps.raw().unsigned_abs();
        if e_abs <= self.dead_zone_i16f16 && self.dead_zone_i16f16 > 0 {
            st.outliers_in_a_row = 0;
            return Status::DEAD_ZONE;
        }
        let mut gate_reopened = false;
        if self.outlier_i16f16 > 0 && e_abs > self.outlier_i16f16 {
            if st.outliers_in_a_row < self.outlier_limit {
                st.outliers_in_a_row = st.outliers_in_a_row.saturating_add(1);
                return Status::OUTLIER;
            }
            gate_reopened = true;
        } else {
            st.outliers_in_a_row = 0;
        }
        let parts = Parts {
            theta_i16f48: &mut st.theta_i16f48,
            theta: &mut st.theta,
            u_i8f24: st.u_i8f24.as_flattened_mut(),
            d: &mut st.d,
        };
        let status = self.update_gated(parts, psi, eps);
        if gate_reopened {
            status | Status::OUTLIER
        } else {
            status
        }
    }
}

/// θ's I12F20 read-out of a raw I16F48 value (the stability projection's trial steps):
/// round(θ / 2^28), saturating (flagged).
pub(crate) fn theta_read_out(x: i64, sat: &mut bool) -> ParamI12F20 {
    ParamI12F20::from_raw(theta_out(x, sat))
}

/// θ's I12F20 read-out: round(θ_I16F48 / 2^28), saturating (flagged), from the two words.
#[inline(always)]
fn theta_out(x: i64, sat: &mut bool) -> i32 {
    let hi = (x >> 32) as i32;
    if hi >> 27 != hi >> 31 {
        // |θ| ≥ 2^11: beyond I12F20.
        *sat = true;
        return if hi < 0 { i32::MIN } else { i32::MAX };
    }
    theta_round(x)
}

/// round(θ_I16F48 / 2^28) for |θ| < 2^59 (saturating at the one value that rounds up to 2^31).
#[inline(always)]
fn theta_round(x: i64) -> i32 {
    let (hi, lo) = ((x >> 32) as i32, x as u32);
    let t = (hi << 4) | (lo >> 28) as i32;
    t.saturating_add(((lo >> 27) & 1) as i32)
}

/// `a + b`, saturating, flagged.
#[inline(always)]
fn add_sat_i32(a: i32, b: i32, sat: &mut bool) -> i32 {
    match a.checked_add(b) {
        Some(x) => x,
        None => {
            *sat = true;
            if b > 0 { i32::MAX } else { i32::MIN }
        }
    }
}

/// `m·2^e` normalised by one leading-zero count (`m` non-zero; the chain's products are nearly
/// normalised: [`leading_zeros_near`]).
#[inline(always)]
fn normalise(m: u32, e: i32) -> (u32, i32) {
    let k = leading_zeros_near(m);
    (m << k, e - k as i32)
}

/// 1 + q for q = m·2^e ≥ 2^(e+28) with e > −32 (q ≥ 2^−3: the chain's uncommon case), as a
/// normalised `(w, w_e)` with 1 + q = w·2^w_e (the common case is an add in line; both share the
/// one reciprocal).
#[cold]
#[inline(never)]
fn one_plus_large(m: u32, e: i32) -> (u32, i32) {
    let (m, e) = normalise(m, e);
    let w = Pos { m, e }.one_plus();
    (w.m, w.e)
}

/// The column chain, one column at a time: gⱼ = dⱼ fⱼ, μⱼ = −fⱼ γⱼ₋₁, qⱼ = gⱼ|μⱼ|,
/// rⱼ = 1/(1 + qⱼ), γⱼ = γⱼ₋₁ rⱼ, dⱼ ← cap(dⱼ rⱼ / λ), and the column's Mⱼ (μⱼ pre-shifted for
/// the U update) and Gⱼ (gⱼ in ν units). Products are the high words of 32×32 multiplies,
/// normalised only where a mantissa is kept (γ, D): gⱼ, μⱼ ∈ [2^30, 2^32), qⱼ ∈ [2^28, 2^32).
///
/// Shifts: with f̂ⱼ = f_m·2^(−F−lz), gⱼ = g·2^(e_d + 32 − F − lz), μⱼ = mu·2^(e_γ + 32 − F − lz);
/// Gⱼ = g >> (e_ν − e_g) = g >> (`g_base` + lz − e_d); Mⱼ = mu >> t with t = −(e_ν + e_μ + 24 +
/// 32) = t_γ + lz, t_γ = k_t − e_γ, k_t = −e_ν − 88 + F (ΔUᵢⱼ = νᵢ μⱼ in I8F24 = hi32(ν_raw·Mⱼ));
/// 1 + q = 2^31 + q >> s_q in units 2^−31 with s_q = −31 − e_q = s_g + t − 7 (the sum of the two
/// shifts less 7). γ is carried as (γ_m, t_γ): Mⱼ's shift is then t_γ + lz and the exponents of
/// gⱼ and 1 + qⱼ follow from it and Gⱼ's shift alone (one value fewer live per column).
struct Chain {
    g_base: i32,
    k_t: i32,
    l_m: u32,
    l_e: i32,
    cap_exp: i32,
    gamma_m: u32,
    t_gamma: i32,
    /// A dⱼ met its cap.
    capped: bool,
}

impl Chain {
    /// γ₀ = 1/(λ·4^σ).
    #[inline(always)]
    fn new(cfg: &RlsConfig, e_nu: i32, sigma: i32) -> Self {
        let (l_m, l_e) = (cfg.lambda_inv.mant(), cfg.lambda_inv.exp());
        let k_t = -e_nu - 88 + F_FRAC_BITS;
        Self {
            g_base: e_nu - 32 + F_FRAC_BITS,
            k_t,
            l_m,
            l_e,
            cap_exp: cfg.d_cap_exp,
            gamma_m: l_m,
            t_gamma: k_t - (l_e - 2 * sigma),
            capped: false,
        }
    }

    /// γ_N after the last column.
    #[inline(always)]
    fn gamma(&self) -> (u32, i32) {
        (self.gamma_m, self.k_t - self.t_gamma)
    }

    /// Column j: `gj` holds f̂ⱼ and gets Gⱼ, `mj` gets Mⱼ, `wj` the [`wide_code`] of a ΔU that
    /// needs the 64-bit path (left as it is otherwise: [`NARROW`]); updates dⱼ and γ. f̂ⱼ = 0:
    /// rⱼ = 1, gⱼ = μⱼ = 0 (U's column, γ and ν unchanged, νⱼ = 0), dⱼ only forgets.
    /// (Each result is stored as soon as it is known: fewer values live, measured.)
    #[inline(always)]
    fn column(&mut self, dj: &mut Dyadic, gj: &mut i32, mj: &mut i32, wj: &mut i8) {
        let (mut d_m, mut d_e) = (dj.mant(), dj.exp());
        let fj = *gj;
        if fj != 0 {
            let sgn = fj >> 31; // 0 or −1
            let f_abs = (fj ^ sgn).wrapping_sub(sgn) as u32;
            let lz = leading_zeros_u32(f_abs);
            let f_m = f_abs << lz;
            // Gⱼ: gⱼ in ν units, truncated, below 2^(31−H) (shift ≥ H ≥ 1).
            let g = mul_hi_u32(d_m, f_m);
            let s_g = self.g_base + lz as i32 - d_e;
            let gn = g.checked_shr(s_g as u32).unwrap_or(0) as i32;
            *gj = (gn ^ sgn).wrapping_sub(sgn);
            // Mⱼ, with μⱼ's sign (−fⱼ's).
            let mu = mul_hi_u32(f_m, self.gamma_m);
            let t = self.t_gamma + lz as i32;
            let m_mu = if t >= 1 {
                mu.checked_shr(t as u32).unwrap_or(0) as i32
            } else {
                // A large ΔU (early updates from a large P₀): the 64-bit product of νᵢ and
                // mu/2, shifted by −t − 31 and narrowed, saturating.
                *wj = wide_code(-t - 31);
                (mu >> 1) as i32
            };
            *mj = (m_mu ^ !sgn).wrapping_sub(!sgn);
            // rⱼ = 1/(1 + qⱼ), then γ.
            let q = mul_hi_u32(g, mu);
            let s_q = s_g + t - 7;
            // 1 + q = w·2^w_e, carried as (w, 30 + w_e).
            let (w, adj) = if s_q >= 1 {
                // q < 1: 1 + q = 2^31 + q >> s_q in units 2^−31.
                ((1 << 31) + q.checked_shr(s_q as u32).unwrap_or(0), -1)
            } else {
                let (w, w_e) = one_plus_large(q, -31 - s_q);
                (w, 30 + w_e)
            };
            // r = (2^61/w)·2^(−61−w_e) = x2·2^(−62−w_e); γ's exponent gains r_e + 32 =
            // −30 − w_e, less its normalisation.
            let x2 = recip_q61(w) << 1;
            let (m, z) = normalise(mul_hi_u32(self.gamma_m, x2), 0);
            self.gamma_m = m;
            self.t_gamma += adj - z;
            (d_m, d_e) = (mul_hi_u32(d_m, x2), d_e - adj);
        } else {
            *mj = 0;
        }
        let (m, e) = normalise(mul_hi_u32(d_m, self.l_m), d_e + self.l_e + 32);
        *dj = store_d(m, e, self.cap_exp, &mut self.capped);
    }
}

/// D's stored form: above `cap_exp` the cap itself (flagged), below [`EXP_MIN`] the smallest
/// positive value; `m` normalised.
#[inline(always)]
fn store_d(m: u32, e: i32, cap_exp: i32, capped: &mut bool) -> Dyadic {
    if e.wrapping_sub(EXP_MIN) as u32 <= cap_exp.wrapping_sub(EXP_MIN) as u32 {
        // m ≥ 2^31 and EXP_MIN ≤ e ≤ cap_exp ≤ EXP_MAX.
        Dyadic::from_parts(m, e)
    } else if e > cap_exp {
        *capped = true;
        Dyadic::from_parts(u32::MAX, cap_exp)
    } else {
        Dyadic::MIN_POSITIVE
    }
}

/// νᵢ (floor) from its accumulator words.
#[inline(always)]
fn nu_of(lo: u32, hi: i32) -> i32 {
    (hi << (32 - U_FRAC_BITS)) | (lo >> U_FRAC_BITS) as i32
}

/// The accumulator plus `u·g`, as words.
#[inline(always)]
fn nu_acc(lo: u32, hi: i32, u: i32, g: i32) -> (u32, i32) {
    let acc = ((i64::from(hi) << 32) | i64::from(lo)) + mul_i32_wide(u, g);
    (acc as u32, (acc >> 32) as i32)
}

/// `wide[j]` for a column whose ΔU is the rounded high word of νᵢ·Mⱼ (the common case).
const NARROW: i8 = 0;

/// `wide[j]` for a column whose ΔU is νᵢ·Mⱼ·2^s (|s| ≤ 63): s + 64, never [`NARROW`].
#[inline(always)]
fn wide_code(s: i32) -> i8 {
    (s.clamp(-32, 63) + 64) as i8
}

/// Uᵢⱼ + νᵢ·Mⱼ·2^s for a wide column (`code` its [`wide_code`]): early updates from a large
/// P₀, out of line (the common column's ΔU is the rounded high word, in line).
#[cold]
#[inline(never)]
fn wide_entry(u: i32, nu: i32, m_mu: i32, code: i8, sat: &mut bool) -> i32 {
    add_shifted(u, mul_i32_wide_compact(nu, m_mu), i32::from(code) - 64, sat)
}

/// u + round(p·2^s) (half up) for |p| ≤ 2^62 and −32 ≤ s ≤ 63, saturating (flagged); a
/// round(p·2^s) beyond `i32` saturates to p's sign. From the two 32-bit words only (a 64-bit
/// variable shift is long, and a library call on Armv6-M); with s = −32 it is
/// `add_sat_i32(u, mul_hi_round(..))`, the narrow columns' ΔU (tested).
#[inline(always)]
fn add_shifted(u: i32, p: i64, s: i32, sat: &mut bool) -> i32 {
    let (hi, lo) = ((p >> 32) as i32, p as u32);
    let v = if s < 0 {
        // (p + 2^(k−1)) >> k for k = −s in 1..=32; the sum stays below 2^63.
        let k = s.unsigned_abs();
        let (lo, carry) = lo.overflowing_add(1u32.wrapping_shl(k - 1));
        let hi = hi.wrapping_add(i32::from(carry));
        if k >= 32 {
            Some(hi)
        } else {
            let v = ((lo >> k) | ((hi as u32) << (32 - k))) as i32;
            (hi >> k == v >> 31).then_some(v)
        }
    } else {
        // p·2^s fits an i32 iff p does and the shift keeps its sign bits.
        let x = lo as i32;
        if hi != x >> 31 {
            None
        } else if s < 32 {
            let y = x << s;
            (y >> s == x).then_some(y)
        } else {
            (x == 0).then_some(0)
        }
    };
    match v {
        Some(v) => add_sat_i32(u, v, sat),
        None => {
            *sat = true;
            if p > 0 { i32::MAX } else { i32::MIN }
        }
    }
}

/// Column j of the U/ν triangle: its entries above the diagonal (`col`, the first j of the
/// column) get Uᵢⱼ + νᵢ μⱼ and νᵢ gets Uᵢⱼ(old)·gⱼ, then νⱼ = gⱼ. Mⱼ and Gⱼ are read from
/// `nu_lo[j]` and `nu_hi[j]` ([`Chain::column`] put them there), `wj` is the column's kind. ν·2^24
/// in exact 64-bit accumulators as two arrays of words; the headroom H keeps νᵢ below 2^31 in
/// ν units.
#[inline(always)]
fn triangle_column(
    j: usize,
    col: &mut [i32],
    nu_lo: &mut [i32; MAX_PARAMS],
    nu_hi: &mut [i32; MAX_PARAMS],
    wj: i8,
    sat: &mut bool,
) {
    let m_mu = nu_lo.get(j).copied().unwrap_or(0);
    let gn = nu_hi.get(j).copied().unwrap_or(0);
    for (uij, (lo, hi)) in col.iter_mut().zip(nu_lo.iter_mut().zip(nu_hi.iter_mut())) {
        let u_old = *uij;
        let nu = nu_of(*lo as u32, *hi);
        *uij = if wj == NARROW {
            add_sat_i32(u_old, mul_hi_round(nu, m_mu), sat)
        } else {
            wide_entry(u_old, nu, m_mu, wj, sat)
        };
        let (l, h) = nu_acc(*lo as u32, *hi, u_old, gn);
        (*lo, *hi) = (l as i32, h);
    }
    if let (Some(lo), Some(hi)) = (nu_lo.get_mut(j), nu_hi.get_mut(j)) {
        *lo = ((gn as u32) << U_FRAC_BITS) as i32;
        *hi = gn >> (32 - U_FRAC_BITS);
    }
}

impl RlsConfig {
    /// The update proper, after the hold, dead-zone and outlier gates: one body for every N (the
    /// state's arrays as slices of length n), not inlined, so an image carries it once.
    #[inline(never)]
    fn update_gated(&self, p: Parts<'_>, psi: &[SignalI16F16], eps: SignalI16F16) -> Status {
        let Parts {
            theta_i16f48,
            theta,
            u_i8f24,
            d,
        } = p;
        let n = d.len();
        if n == 0 || n > MAX_PARAMS || u_i8f24.len() != n * n {
            return Status::LOW_EXCITATION;
        }

        // φ̂ = 2^σ ψ in I3F29, max |φ̂| in [2^28, 2^29]: one leading-zero count over the OR of |ψᵢ|.
        let or_abs = psi.iter().fold(0u32, |a, x| a | x.raw().unsigned_abs());
        if or_abs == 0 {
            return Status::LOW_EXCITATION;
        }
        let b = 32 - leading_zeros_u32(or_abs) as i32; // bit length of max |ψ_raw|, 1..=32
        let sigma = 16 - b;
        let mut phi = [0i32; MAX_PARAMS];
        let sh_phi = PHI_FRAC_BITS as i32 - b;
        if sh_phi >= 0 {
            // |ψ_raw| < 2^b: the shifted value is below 2^29.
            for (ph, x) in phi.iter_mut().zip(psi.iter()) {
                *ph = x.raw() << sh_phi;
            }
        } else {
            // |ψ| ≥ 2^13 (rare): a rounded right shift by 1..=3.
            let s = sh_phi.unsigned_abs();
            for (ph, x) in phi.iter_mut().zip(psi.iter()) {
                *ph = ((i64::from(x.raw()) + (1 << (s - 1))) >> s) as i32;
            }
        }

        // f = Uᵀφ̂: exact I11F53 sum (module doc), rounded once to I11F21 (its high word). With
        // it, ν's block exponent: |gⱼ| = dⱼ|f̂ⱼ| < 2^Bⱼ, Bⱼ = e(dⱼ) + 32 + bⱼ − F where |f̂ⱼ| ≤ 2^bⱼ,
        // bⱼ the bit length of |f̂ⱼ| or |f̂ⱼ| − 1 (f̂ ^ (f̂ >> 31): one instruction).
        let mut fh = [0i32; MAX_PARAMS];
        let mut b_max = i32::MIN;
        let mut u_or = 0u32;
        for (j, ((col, fj), dj)) in columns(u_i8f24, n)
            .zip(fh.iter_mut())
            .zip(d.iter())
            .enumerate()
        {
            let col = col.get(..j).unwrap_or_default();
            let phi_j = phi.get(j).copied().unwrap_or(0);
            let mut acc = i64::from(phi_j) << U_FRAC_BITS;
            for (uij, ph) in col.iter().zip(phi.iter()) {
                acc += mul_i32_wide(*uij, *ph);
                u_or |= (uij ^ (uij >> 31)) as u32;
            }
            *fj = ((acc + (1 << 31)) >> 32) as i32;
            if *fj != 0 {
                if ARMV6M {
                    // Only the largest exponent here; the bit lengths below, by one search.
                    b_max = b_max.max(dj.exp());
                } else {
                    let bl = 32 - leading_zeros_u32((*fj ^ (*fj >> 31)) as u32) as i32;
                    b_max = b_max.max(dj.exp() + bl + (32 - F_FRAC_BITS));
                }
            }
        }
        if b_max == i32::MIN {
            return Status::LOW_EXCITATION;
        }
        if ARMV6M {
            // maxⱼ(e(dⱼ) + bⱼ) over the columns with f̂ⱼ ≠ 0 from one bit length (Armv6-M has no
            // CLZ; the search is long): with E = maxⱼ e(dⱼ) there, bitlen(ORⱼ xⱼ >> (E − e(dⱼ)))
            // = maxⱼ max(bⱼ − (E − e(dⱼ)), 0), and the column at E keeps the maximum ≥ 0: the
            // same b_max as the per-column lengths.
            let mut x_or = 0u32;
            for (fj, dj) in fh.iter().zip(d.iter()) {
                if *fj != 0 {
                    let x = (*fj ^ (*fj >> 31)) as u32;
                    x_or |= x.checked_shr((b_max - dj.exp()) as u32).unwrap_or(0);
                }
            }
            b_max += 32 - leading_zeros_u32(x_or) as i32 + (32 - F_FRAC_BITS);
        }
        let headroom = nu_headroom(n, u_or);
        let e_nu = b_max - 31 + headroom;

        // Excitation gate: ψᵀPψ = 4^−σ Σ dⱼ f̂ⱼ² below the threshold skips the update.
        if !self.excitation_min.is_zero() {
            let mut s = Pos::TINY;
            for (fj, dj) in fh.iter().zip(d.iter()) {
                if *fj != 0 {
                    let f = Pos::of_u32_compact(fj.unsigned_abs(), -F_FRAC_BITS);
                    s = s.add(Pos::of(*dj).mul_compact(f).mul_compact(f));
                }
            }
            let excitation = Pos {
                m: s.m,
                e: s.e - 2 * sigma,
            }
            .to_dyadic();
            if excitation.lt(self.excitation_min) {
                return Status::LOW_EXCITATION;
            }
        }

        // The column chain (D, γ, each column's Mⱼ and Gⱼ: [`Chain`]) and the U/ν triangle
        // column by column ([`triangle_column`]). The chain needs neither U nor ν, so column j's
        // chain can run just before column j's triangle (one loop: Armv6-M, where the chain's
        // values live in memory anyway) or every chain column before the triangle (two loops:
        // Armv7-M, where one loop spills the chain's constants around the triangle); both
        // measured. The same operations in the same order per column, the same results. Mⱼ is
        // stored over φ̂ⱼ and Gⱼ over f̂ⱼ, and the ν accumulators' two arrays of words are those
        // two arrays (low, high), no arrays of their own to zero: column j reads its Mⱼ and Gⱼ
        // before it writes νⱼ over them, and reads only the νᵢ (i < j) earlier columns wrote.
        let mut chain = Chain::new(self, e_nu, sigma);
        let mut sat = false;
        if ARMV6M {
            for (j, (dj, col)) in d.iter_mut().zip(columns_mut(u_i8f24, n)).enumerate() {
                let mut wj = NARROW;
                if let (Some(mj), Some(gj)) = (phi.get_mut(j), fh.get_mut(j)) {
                    chain.column(dj, gj, mj, &mut wj);
                }
                let col = col.get_mut(..j).unwrap_or_default();
                triangle_column(j, col, &mut phi, &mut fh, wj, &mut sat);
            }
        } else {
            let mut wide = [NARROW; MAX_PARAMS];
            for (((dj, gj), mj), wj) in d
                .iter_mut()
                .zip(fh.iter_mut())
                .zip(phi.iter_mut())
                .zip(wide.iter_mut())
            {
                chain.column(dj, gj, mj, wj);
            }
            // Through a closure: LLVM then unrolls the triangle's entries with the accumulators
            // at fixed stack offsets (measured: a direct call is dearer on the M4F).
            let mut column = |j: usize, col: &mut [i32], wj: i8| {
                triangle_column(j, col, &mut phi, &mut fh, wj, &mut sat);
            };
            for (j, (col, &wj)) in columns_mut(u_i8f24, n).zip(wide.iter()).enumerate() {
                column(j, col.get_mut(..j).unwrap_or_default(), wj);
            }
        }
        let capped = chain.capped;
        let (g_m, g_e) = chain.gamma();
        let (nu_lo, nu_hi) = (&phi, &fh);

        // θ ← θ + 2^σ ν γ_N ε with c = γ_N |ε|: Kᵢ = round(νᵢ·(m_c/2)/2^32) (one high-word
        // multiply; m_c/2 < 2^31), Δθ in I16F48 = Kᵢ·2^a, a = e_ν + e_c + σ + 48 + 33 (one shift
        // amount per update: usually a left shift of a 32-bit Kᵢ, exact).
        let e_abs = eps.raw().unsigned_abs();
        if e_abs != 0 {
            let lz = leading_zeros_u32(e_abs);
            let c_m = mul_hi_u32(g_m, e_abs << lz); // [2^30, 2^32)
            let m_c = (c_m >> 1) as i32;
            let m_c = if eps.raw() < 0 { -m_c } else { m_c };
            let a = e_nu + g_e + 16 - lz as i32 + sigma + THETA_FRAC_BITS as i32 + 33;
            let gains = nu_lo
                .iter()
                .zip(nu_hi.iter())
                .map(|(lo, hi)| nu_of(*lo as u32, *hi));
            let thetas = theta_i16f48.iter_mut().zip(theta.iter_mut());
            if (0..=31).contains(&a) {
                for ((th, out), nu) in thetas.zip(gains) {
                    // |Kᵢ| < 2^31: |Δθ| < 2^62; the two words by 32-bit shifts. A wrapped sum
                    // is beyond the read-out's range (|θ| ≥ 2^59): checked there.
                    let k = mul_hi_round(nu, m_c);
                    let dth = (i64::from((k >> 1) >> (31 - a)) << 32) | i64::from((k as u32) << a);
                    let new = th.wrapping_add(dth);
                    let hi = (new >> 32) as i32;
                    *out = if hi >> 27 == hi >> 31 {
                        *th = new;
                        ParamI12F20::from_raw(theta_round(new))
                    } else {
                        *th = th.saturating_add(dth);
                        ParamI12F20::from_raw(theta_out(*th, &mut sat))
                    };
                }
            } else {
                for ((th, out), nu) in thetas.zip(gains) {
                    // (Rare: the product off line on Armv6-M.)
                    let k = ((mul_i32_wide_compact(nu, m_c) + (1 << 31)) >> 32) as i32;
                    let dth = shift_round_i64(i64::from(k), a);
                    *th = th.saturating_add(dth);
                    *out = ParamI12F20::from_raw(theta_out(*th, &mut sat));
                }
            }
        }

        let mut status = Status::UPDATED;
        status.set_if(Status::SATURATED, sat);
        if capped {
            if self.d_cap_exp < EXP_MAX {
                status |= Status::COVARIANCE_BOUNDED;
            } else {
                status |= Status::COVARIANCE_SATURATED;
            }
        }
        let tr = if matches!(self.bound, Bound::Trace(_) | Bound::ConstantTrace(_)) {
            trace_of(u_i8f24, d, n)
        } else {
            Dyadic::ZERO
        };
        status | self.bound_covariance(u_i8f24, d, tr)
    }

    /// Applies a trace, diagonal or constant-trace bound after an update (scales D); `tr` is
    /// trace(P) of the new factors when the bound is on the trace.
    fn bound_covariance(&self, u: &[i32], d: &mut [Dyadic], tr: Dyadic) -> Status {
        let n = d.len();
        match self.bound {
            Bound::None => Status::NONE,
            Bound::Trace(max) => {
                if max.lt(tr) {
                    scale_d(d, max.mul_trunc(tr.recip()));
                    Status::COVARIANCE_BOUNDED
                } else {
                    Status::NONE
                }
            }
            Bound::Diagonal(max) => {
                let pmax = max_diagonal_of(u, d, n);
                if max.lt(pmax) {
                    scale_d(d, max.mul_trunc(pmax.recip()));
                    Status::COVARIANCE_BOUNDED
                } else {
                    Status::NONE
                }
            }
            Bound::ConstantTrace(c) => {
                scale_d(d, c.mul_trunc(tr.recip()));
                Status::TRACE_NORMALISED
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::float_arithmetic)]
    use super::*;

    fn sig(x: f64) -> SignalI16F16 {
        SignalI16F16::from_f64(x).unwrap()
    }

    #[test]
    fn product_normalisation_is_the_one_bit_shift() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (a, b) = ((x as u32) | 1 << 31, ((x >> 32) as u32) | 1 << 31);
            let p = mul_u32_wide(a, b);
            let top = (p >> 63) as u32;
            assert_eq!(normalise_product(p), (((p << (top ^ 1)) >> 32) as u32, top));
        }
    }

    fn pos_f64(p: Pos) -> f64 {
        f64::from(p.m) * 2f64.powi(p.e)
    }

    /// 1 + q and its reciprocal against f64 over q from 2⁻⁷⁰ to 2⁷⁰ (the column chain's two
    /// non-multiplies): 1 + q within 2⁻³⁰ relative, the reciprocal within 2⁻²⁸ — measured
    /// 2.1·10⁻⁹ = 2^−28.8 (2026-11-27): `recip_q61` is 2⁶¹/w within two units of a result
    /// ≥ 2²⁹ (`wide::reciprocal_q61_is_within_two_units`), where the previous `Pos` reciprocal
    /// held 2⁻²⁹. Trips on a reciprocal off by more than its Newton steps allow.
    #[test]
    fn one_plus_and_reciprocal_against_f64() {
        let mut x: u32 = 0x1234_5678;
        for e in -100..40 {
            for _ in 0..50 {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let q = Pos { m: x | 1 << 31, e };
                let w = q.one_plus();
                assert!(w.m >= 1 << 31);
                let want = 1.0 + pos_f64(q);
                assert!(((pos_f64(w) - want) / want).abs() < 2f64.powi(-30), "{e}");
                let r = f64::from(recip_q61(w.m)) * 2f64.powi(-61 - w.e);
                assert!((r * want - 1.0).abs() < 2f64.powi(-28), "{e}");
            }
        }
    }

    /// The factor cap holds every dⱼ at or below max rounded down to a power of two, flagged.
    #[test]
    fn factor_cap_bounds_every_d_under_forgetting_without_excitation() {
        let cfg = RlsDesign {
            lambda: 0.9,
            p0: 1.0,
            anti_windup: AntiWindup::FactorCap { max: 50.0 },
            ..RlsDesign::default()
        }
        .build()
        .unwrap();
        let mut st = RlsState::<3>::new(&cfg, [ParamI12F20::ZERO; 3]);
        let mut bounded = 0;
        for t in 0..2000 {
            let e = if t % 2 == 0 { sig(0.01) } else { sig(-0.01) };
            let s = cfg.update(&mut st, &[sig(1.0), sig(1.0), sig(0.5)], e);
            bounded += usize::from(s.contains(Status::COVARIANCE_BOUNDED));
            for d in st.d() {
                assert!(d.to_f64() <= 32.0, "{}", d.to_f64());
            }
        }
        assert!(bounded > 1000, "{bounded}");
        assert!(st.is_positive_definite());
        assert_eq!(
            AntiWindup::FactorCap { max: 50.0 }.factor_cap(),
            Dyadic::from_f64(32.0)
        );
    }

    /// Runs a noiseless 2-parameter regression and checks the estimate converges.
    #[test]
    fn converges_on_a_noiseless_regression() {
        let cfg = RlsDesign::default().build().unwrap();
        let mut st = RlsState::<2>::new(&cfg, [ParamI12F20::ZERO; 2]);
        let (a, b) = (0.8, -0.3);
        let mut x = 0.37_f64;
        for _ in 0..400 {
            x = (x * 3.9 * (1.0 - x)).clamp(0.01, 0.99);
            let psi = [sig(x * 4.0 - 2.0), sig((1.0 - x) * 3.0)];
            let y = a * psi[0].to_f64() + b * psi[1].to_f64();
            let mut s = false;
            let yh = RlsConfig::predict(st.theta(), &psi, &mut s);
            let e = sig(y).saturating_sub(yh);
            let _ = cfg.update(&mut st, &psi, e);
        }
        let th = st.theta();
        assert!((th[0].to_f64() - a).abs() < 1e-4, "{:?}", th);
        assert!((th[1].to_f64() - b).abs() < 1e-4, "{:?}", th);
    }

    #[test]
    fn gates_and_hold_leave_state_untouched() {
        let cfg = RlsDesign {
            dead_zone: 1.0,
            excitation_threshold: 1e-3,
            ..RlsDesign::default()
        }
        .build()
        .unwrap();
        let mut st = RlsState::<2>::new(&cfg, [ParamI12F20::ZERO; 2]);
        let before = st.clone();
        assert_eq!(
            cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(0.5)),
            Status::DEAD_ZONE
        );
        assert_eq!(
            cfg.update(&mut st, &[SignalI16F16::ZERO; 2], sig(3.0)),
            Status::LOW_EXCITATION
        );
        st.set_enabled(false);
        assert_eq!(
            cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(3.0)),
            Status::HELD
        );
        st.set_enabled(true);
        assert_eq!(st, before);
        assert!(
            cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(3.0))
                .contains(Status::UPDATED)
        );
        assert_ne!(st, before);
    }

    #[test]
    fn trace_limit_holds_under_forgetting_without_excitation() {
        let cfg = RlsDesign {
            lambda: 0.9,
            p0: 1.0,
            anti_windup: AntiWindup::TraceLimit { max: 50.0 },
            ..RlsDesign::default()
        }
        .build()
        .unwrap();
        let mut st = RlsState::<2>::new(&cfg, [ParamI12F20::ZERO; 2]);
        let mut bounded = 0;
        for t in 0..2000 {
            // Same regressor direction every time: the orthogonal direction winds up.
            let e = if t % 2 == 0 { sig(0.01) } else { sig(-0.01) };
            let s = cfg.update(&mut st, &[sig(1.0), sig(1.0)], e);
            if s.contains(Status::COVARIANCE_BOUNDED) {
                bounded += 1;
            }
            assert!(st.trace().to_f64() <= 50.0 * (1.0 + 1e-6));
        }
        assert!(bounded > 1000);
    }

    #[test]
    fn high_word_product_of_an_exact_pre_shift_equals_the_rounded_64_bit_shift() {
        let mut x: u32 = 12345;
        for _ in 0..20_000 {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let a = x as i32;
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let s = 1 + x % 32;
            let b = (x as i32) >> (32 - s).min(31); // small enough that b·2^(32−s) is exact
            let pre = b.wrapping_shl(32 - s);
            if pre >> (32 - s) != b {
                continue;
            }
            let expected = (mul_i32_wide(a, b) + (1i64 << (s - 1))) >> s;
            assert_eq!(i64::from(mul_hi_round(a, pre)), expected, "{a} {b} {s}");
        }
    }

    #[test]
    fn wide_delta_u_equals_the_64_bit_shift_and_the_narrow_one() {
        let mut x: u64 = 0x2545_F491_4F6C_DD1D;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for _ in 0..200_000 {
            let u = next() as i32;
            let bits = (next() % 63) as u32;
            let p = (next() as i64) >> (63 - bits.max(1)) >> 1; // |p| < 2^62
            let s = (next() % 96) as i32 - 32;
            let (mut a, mut b) = (false, false);
            let v = shift_round_i64(p, s);
            let want = if i32::try_from(v).is_ok() {
                sat_i32(i64::from(u) + v, &mut a)
            } else {
                a = true;
                if p > 0 { i32::MAX } else { i32::MIN }
            };
            assert_eq!(add_shifted(u, p, s, &mut b), want, "{u} {p} {s}");
            assert_eq!(a, b);
            if s == -32 {
                let (m, n) = (next() as i32, next() as i32);
                let mut c = false;
                let narrow = add_sat_i32(u, mul_hi_round(m, n), &mut c);
                assert_eq!(add_shifted(u, mul_i32_wide(m, n), -32, &mut b), narrow);
            }
        }
    }

    #[test]
    fn design_validation_names_the_parameter() {
        let d = RlsDesign::default();
        assert_eq!(
            RlsDesign { lambda: 0.0, ..d }.build(),
            Err(ConfigError::Lambda(0.0))
        );
        assert!(matches!(
            RlsDesign {
                lambda: f64::NAN,
                ..d
            }
            .build(),
            Err(ConfigError::Lambda(_))
        ));
        assert_eq!(
            RlsDesign { p0: -1.0, ..d }.build(),
            Err(ConfigError::InitialCovariance(-1.0))
        );
        assert_eq!(
            RlsDesign {
                dead_zone: -1.0,
                ..d
            }
            .build(),
            Err(ConfigError::DeadZone(-1.0))
        );
        assert_eq!(
            RlsDesign {
                excitation_threshold: f64::INFINITY,
                ..d
            }
            .build(),
            Err(ConfigError::ExcitationThreshold(f64::INFINITY))
        );
        assert_eq!(
            RlsDesign {
                anti_windup: AntiWindup::TraceLimit { max: 0.0 },
                ..d
            }
            .build(),
            Err(ConfigError::CovarianceLimit(0.0))
        );
        assert!(RlsDesign { lambda: 1.0, ..d }.build().is_ok());
        assert_eq!(
            RlsDesign {
                outlier_threshold: -1.0,
                ..d
            }
            .build(),
            Err(ConfigError::OutlierThreshold(-1.0))
        );
        assert!(matches!(
            RlsDesign {
                outlier_threshold: f64::NAN,
                ..d
            }
            .build(),
            Err(ConfigError::OutlierThreshold(_))
        ));
        // The gate must sit above the dead zone.
        assert_eq!(
            RlsDesign {
                dead_zone: 2.0,
                outlier_threshold: 1.0,
                ..d
            }
            .build(),
            Err(ConfigError::OutlierThreshold(1.0))
        );
        assert!(
            RlsDesign {
                dead_zone: 1.0,
                outlier_threshold: 5.0,
                ..d
            }
            .build()
            .is_ok()
        );
    }

    #[test]
    fn outlier_gate_skips_then_reopens_after_the_limit() {
        let cfg = RlsDesign {
            outlier_threshold: 2.0,
            outlier_limit: 3,
            ..RlsDesign::default()
        }
        .build()
        .unwrap();
        let mut st = RlsState::<2>::new(&cfg, [ParamI12F20::ZERO; 2]);
        let before = st.clone();
        for _ in 0..3 {
            assert_eq!(
                cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(10.0)),
                Status::OUTLIER
            );
        }
        assert_eq!(st.theta(), before.theta());
        // The fourth in a row is taken as a plant change: updated, and still flagged.
        let s = cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(10.0));
        assert!(
            s.contains(Status::UPDATED) && s.contains(Status::OUTLIER),
            "{s:?}"
        );
        // A normal sample resets the count.
        assert!(
            cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(0.5))
                .contains(Status::UPDATED)
        );
        assert_eq!(
            cfg.update(&mut st, &[sig(1.0), sig(1.0)], sig(10.0)),
            Status::OUTLIER
        );
    }
}
