//! Recursive least squares with exponential forgetting, in integers, on the UD factorisation of the
//! covariance (Bierman's update), with the anti-windup the sled's closed-loop data needs.
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
//! Sequential Estimation*, 1977, §V.3), in the "normalised gain" form used here:
//!
//! ```text
//! f = Uᵀψ,  α₀ = λ,  αⱼ = αⱼ₋₁ + dⱼ fⱼ²,  rⱼ = αⱼ₋₁/αⱼ,  gⱼ = dⱼ fⱼ / αⱼ
//! dⱼ ← dⱼ rⱼ / λ
//! for i < j:  Uᵢⱼ ← Uᵢⱼ − fⱼ κᵢ,   κᵢ ← κᵢ rⱼ + Uᵢⱼ(old) gⱼ ;   κⱼ = gⱼ
//! K = κ
//! ```
//!
//! # Why this form
//! - **Positive definite by construction.** Every dⱼ is a positive [`Dyadic`] (it cannot reach zero or
//!   change sign: it is only ever multiplied by positive factors) and U is unit triangular, so
//!   P = UDUᵀ is symmetric positive definite whatever the rounding. The textbook update loses positive
//!   definiteness after ~4,400 samples of the sled data at λ = 0.995 even in float64
//!   (`shared/findings.md`).
//! - **Range.** P spans ~2^50 on the sled data and winds up without bound under forgetting. Each dⱼ,
//!   αⱼ and 1/αⱼ carries its own exponent (32-bit mantissa), so range costs nothing.
//! - **No division.** The only reciprocals are of αⱼ, by a table-seeded Newton iteration
//!   ([`crate::num::wide::recip_q63`]): no 64-bit software division on the hot path.
//! - **Fixed point where the range is known.** f is normalised by a power of two (block floating
//!   point: ψ·2⁻ᵏ, which only rescales α₀ to λ·4⁻ᵏ and the gain by 2⁻ᵏ, both exact), the gains gⱼ share
//!   one exponent per update, and U is I8F24 — its entries are ratios of parameter scales, bounded
//!   when the regressors are normalised and centred.
//!
//! # Formats
//! | quantity | format | note |
//! |---|---|---|
//! | ψ, ε, ŷ | I16F16 ([`SignalI16F16`]) | quanta / fraction of full scale |
//! | θ | I12F20 ([`ParamI12F20`]) | saturating, flagged |
//! | U (strict upper part) | I8F24 `i32` | saturating, flagged |
//! | D (stored), λ, 1/λ | [`Dyadic`] (32-bit mantissa, own exponent) | exponent saturation flagged |
//! | vⱼ, αⱼ, 1/αⱼ, rⱼ, gⱼ, D (during the update) | mantissa in [2³¹, 2³²) and unclamped `i32` exponent | clamped once, when D is stored |
//! | f̂ = Uᵀψ normalised | I1F31 `i32`, max \|f̂\| ∈ [2³⁰, 2³¹] | scale 2ᵏ kept aside |
//! | rⱼ = αⱼ₋₁/αⱼ | I1F31 `i32`, rounded, ≤ 2³¹ − 1 | |
//! | κ (gain being built) | `i32` in units 2^e_κ, one e_κ per update: largest gⱼ below 2²⁵ (6 bits of headroom) | saturating, flagged |
//! | Gⱼ = gⱼ·2⁶ in κ units | `i32` < 2³¹ | so that Uᵢⱼ·Gⱼ/2³⁰ is in κ units |
//!
//! # Scaling and overflow
//! `f` is accumulated exactly in I24F40 (`i64`, saturating). Products of two `i32` are formed in
//! `i64` (no overflow possible); every narrowing saturates and raises [`Status::SATURATED`]. Shifts
//! round half up (truncation would bias U and θ over 10⁶ samples). The per-update shift amounts
//! (f̂, ΔU, Δθ) are computed once; in the usual range a product and its rounded shift are one
//! high-word multiply of an exactly pre-shifted operand, or 32-bit shifts of the two halves, and
//! both give exactly the general path's result (unit test). The mantissa/exponent chain cannot
//! overflow its `i32` exponents: stored exponents are within ±2¹⁴ and one update adds a few hundred.
//! The trace bound uses the column norms `1 + Σᵢ Uᵢⱼ²` summed while U is updated, through the same
//! function as [`RlsState::trace`], so the bound and the public trace agree exactly.
//!
//! # Anti-windup
//! Selected per configuration ([`AntiWindup`]) and independent of it: a dead zone on |ε| (in sensor
//! quanta: the ±1-quantum limit cycle does not drive the estimate), an excitation gate on ψᵀPψ, hold.
//! Skipped samples leave θ and P untouched (no forgetting without information, so no windup).
//!
//! # Accuracy
//! Against a float64 textbook RLS on the same data: `host-tests/tests/rls_vs_f64.rs` (simulated
//! closed-loop plants: ARX n = 4 within 3.6·10⁻⁴ relative, first-order OE within 4.2·10⁻⁴, both
//! held to 1·10⁻³) and `emps_vs_f64.rs` (the EMPS recording: ARX(1,1) within 6.2·10⁻⁴, held to
//! 1·10⁻³; ARX(2,2) 2.2–2.5·10⁻³, held to 4·10⁻³ — its maximum moves by ±50 % with the last bit of
//! any intermediate, and `emps_arx_rounding_spread` measures that spread over 24 position units:
//! median 1.3·10⁻³ of final error, as before this kernel's cost work; simulation RMS within 1.5 %).
//! The limit is U's absolute I8F24 step, not the scalar chain above. A κ headroom of 8 bits (one
//! `SMMULR` for Uᵢⱼ·Gⱼ) and unsigned-only Newton corrections were both cheaper (−43 / −14
//! instructions) but widened that spread (mean 1.5 and 1.7·10⁻³, max 3.3 and 4.1·10⁻³, against 1.3
//! and 2.8·10⁻³; with 24 samples suggestive rather than conclusive), so neither is used.

//! # Cost
//! One update with n = 4 (λ = 0.99, trace limit; `cargo xtask cost`): ≈ 1,970 instructions, ≈ 2,650
//! cycles on Cortex-M4F and ≈ 6,890 cycles on M0+ (n = 2: ≈ 1,100 and ≈ 2,560). On the host
//! (x86-64) a full ARX(2,2) step on the EMPS recording takes ≈ 158 ns. Per update that is
//! about 78 widening multiplies (f, the α chain with n reciprocals, the U/κ triangle, θ, the trace)
//! plus the normalisations between them; `BENCHMARKS.md` has the breakdown and why the targets of
//! 300 / 2,000 cycles are out of reach for this factorisation in integers.

#![deny(clippy::float_arithmetic)]

use crate::error::ConfigError;
use crate::ident::status::Status;
use crate::num::dyadic::Dyadic;
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shift_round_i64, shr_round_i64};
use crate::num::wide::{mul_i32_wide, mul_u32_wide, shr_i64};
use crate::words::{WordReader, WordWriter, Words};

/// Fraction bits of the U factor (I8F24).
pub const U_FRAC_BITS: u32 = 24;
/// Headroom bits of the gain accumulator κ above the largest gⱼ.
const KAPPA_HEADROOM_BITS: i32 = 6;
/// Uᵢⱼ (I8F24) × Gⱼ (gⱼ in κ units · 2^KAPPA_HEADROOM_BITS) → κ units.
const UG_SHIFT: i32 = U_FRAC_BITS as i32 + KAPPA_HEADROOM_BITS;
/// Largest supported parameter count (the α accumulation and κ headroom are sized for it).
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
        let bound = match self.anti_windup {
            AntiWindup::None => Bound::None,
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
        Ok(RlsConfig {
            lambda,
            lambda_inv: lambda.recip(),
            p0,
            dead_zone_i16f16: dz.raw().unsigned_abs(),
            excitation_min,
            bound,
            outlier_i16f16: outlier.raw().unsigned_abs(),
            outlier_limit: self.outlier_limit,
        })
    }
}

/// Everything an update mutates: θ and the UD factors of P.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RlsState<const N: usize> {
    theta: [ParamI12F20; N],
    /// Strictly upper part of U in I8F24 (`u[i][j]`, i < j); the rest stays zero.
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

    /// The current estimate θ.
    pub fn theta(&self) -> &[ParamI12F20; N] {
        &self.theta
    }

    /// Overwrites θ (used by the stability projection of the model structures).
    pub fn set_theta(&mut self, theta: [ParamI12F20; N]) {
        self.theta = theta;
    }

    /// The U factor (strict upper part meaningful), I8F24.
    pub fn u_i8f24(&self) -> &[[i32; N]; N] {
        &self.u_i8f24
    }

    /// The D factor.
    pub fn d(&self) -> &[Dyadic; N] {
        &self.d
    }

    /// `1 + Σ_{i<j} U_ij²` for column j, in U16F48 (saturating).
    fn column_norm2(&self, j: usize) -> u64 {
        let mut acc: u64 = 1 << (2 * U_FRAC_BITS);
        for row in self.u_i8f24.iter().take(j) {
            let uij = row.get(j).copied().unwrap_or(0);
            acc = acc.saturating_add(mul_i32_wide(uij, uij).unsigned_abs());
        }
        acc
    }

    /// trace(P) = Σⱼ dⱼ (1 + Σ_{i<j} Uᵢⱼ²).
    pub fn trace(&self) -> Dyadic {
        let mut norms = [0u64; N];
        for (j, n) in norms.iter_mut().enumerate() {
            *n = self.column_norm2(j);
        }
        trace_of(&self.d, &norms)
    }

    /// The largest diagonal element of P: Pᵢᵢ = dᵢ + Σ_{j>i} Uᵢⱼ² dⱼ.
    pub fn max_diagonal(&self) -> Dyadic {
        let mut best = Dyadic::ZERO;
        for (i, row) in self.u_i8f24.iter().enumerate() {
            let mut pii = self.d.get(i).copied().unwrap_or(Dyadic::ZERO);
            for (j, (&uij, dj)) in row.iter().zip(self.d.iter()).enumerate().skip(i + 1) {
                let _ = j;
                let u2 = Dyadic::from_u64(i64::from(uij).pow(2).unsigned_abs(), -48);
                pii = pii.add_trunc(u2.mul_trunc(*dj));
            }
            if best.lt(pii) {
                best = pii;
            }
        }
        best
    }

    /// Multiplies P by `factor` (scales D; U is unchanged).
    fn scale(&mut self, factor: Dyadic) {
        for dj in &mut self.d {
            *dj = dj.mul_trunc(factor);
            if dj.is_zero() {
                *dj = Dyadic::MIN_POSITIVE;
            }
        }
    }
}

/// Σⱼ dⱼ·normⱼ with the column norms `1 + Σ_{i<j} Uᵢⱼ²` in U16F48: the one formula the update's
/// covariance bound and [`RlsState::trace`] share, so both see the same number.
fn trace_of<const N: usize>(d: &[Dyadic; N], col_norm: &[u64; N]) -> Dyadic {
    let term = |dj: &Dyadic, n: u64| {
        // n ≥ 2^48: its high word is non-zero, one 32-bit leading-zero count normalises it.
        let (hi, lo) = ((n >> 32) as u32, n as u32);
        let lz = crate::num::wide::leading_zeros_u32(hi); // < 16
        let norm = Pos {
            m: (hi << lz) | ((lo >> 1) >> (31 - lz)),
            e: 32 - lz as i32 - 2 * U_FRAC_BITS as i32,
        };
        // D is positive by construction (zero is floored to the smallest positive value).
        Pos::of(*dj).mul(norm)
    };
    let mut terms = d.iter().zip(col_norm.iter()).map(|(dj, &n)| term(dj, n));
    let Some(first) = terms.next() else {
        return Dyadic::ZERO;
    };
    let t = terms.fold(first, Pos::add);
    Dyadic::from_normalised(t.m, t.e)
}

/// `round(a·b / 2^32)` (half up): one `SMMULR` on Armv7E-M. The caller guarantees the result fits
/// (it does whenever |a·b| ≤ 2^62, i.e. always for `i32` operands).
#[inline(always)]
fn mul_hi_round(a: i32, b: i32) -> i32 {
    ((mul_i32_wide(a, b) + (1 << 31)) >> 32) as i32
}

/// The top 32 bits of a product `p` in `[2^62, 2^64)` after a one-bit normalisation, and that
/// bit (1 when `p ≥ 2^63`): one variable 64-bit shift, for 64-bit hosts. Same result as
/// [`normalise_product_halves`] (unit test).
#[inline(always)]
fn normalise_product_u64(p: u64) -> (u32, u32) {
    let top = (p >> 63) as u32;
    (((p << (top ^ 1)) >> 32) as u32, top)
}

/// [`normalise_product_u64`] with constant shifts on the two words (a variable 64-bit shift costs
/// ~8 instructions on Cortex-M). Bit 63 is data (set about one time in two): a select, not a
/// branch (as a branch it was mispredicted ~4 times per update, cachegrind's branch simulation).
#[inline(always)]
fn normalise_product_halves(p: u64) -> (u32, u32) {
    let (hi, lo) = ((p >> 32) as u32, p as u32);
    let top = hi >> 31;
    (
        core::hint::select_unpredictable(top != 0, hi, (hi << 1) | (lo >> 31)),
        top,
    )
}

/// A positive number `m · 2^e` with `m` in `[2^31, 2^32)`: the update's working form of a
/// [`Dyadic`], without its exponent clamp and zero case. Exponents of stored values are within
/// ±2¹⁴ and one update adds a few hundred at most, so `i32` cannot overflow; the clamp is applied
/// once, when D is stored ([`Dyadic::from_normalised`]). `ZERO` (m = 0) only marks a zero gain.
#[derive(Clone, Copy)]
struct Pos {
    m: u32,
    e: i32,
}

impl Pos {
    const ZERO: Self = Self { m: 0, e: 0 };

    /// From a positive dyadic (D, λ, 1/λ: never zero).
    #[inline(always)]
    fn of(d: Dyadic) -> Self {
        Self {
            m: d.mant(),
            e: d.exp(),
        }
    }

    /// `self · 2^k`.
    #[inline(always)]
    fn shl(self, k: i32) -> Self {
        Self {
            m: self.m,
            e: self.e + k,
        }
    }

    /// The product, truncated to 32 bits: one widening multiply and a one-bit normalisation.
    #[inline(always)]
    fn mul(self, rhs: Self) -> Self {
        let p = mul_u32_wide(self.m, rhs.m); // in [2^62, 2^64)
        let (m, top) = if cfg!(target_pointer_width = "64") {
            normalise_product_u64(p)
        } else {
            normalise_product_halves(p)
        };
        Self {
            m,
            e: self.e + rhs.e + 31 + top as i32,
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
        let d = hi.e.abs_diff(lo.e);
        let lo_m = lo.m.checked_shr(d).unwrap_or(0);
        let (sum, carry) = hi.m.overflowing_add(lo_m);
        if carry {
            Self {
                m: (sum >> 1) | (1 << 31),
                e: hi.e + 1,
            }
        } else {
            Self { m: sum, e: hi.e }
        }
    }

    /// `1 / self` ([`crate::num::wide::recip_q63`], within two units of the last kept bit).
    #[inline(always)]
    fn recip(self) -> Self {
        // recip_q63 is in [2^31 − 1, 2^32): keep the mantissa normalised.
        let x = (crate::num::wide::recip_q63(self.m) as u32).max(1 << 31);
        Self {
            m: x,
            e: -63 - self.e,
        }
    }

    /// The value (≤ 1 up to rounding) as I1F31, rounded, saturating at `i32::MAX`.
    #[inline(always)]
    fn to_i1f31(self) -> i32 {
        // raw = m · 2^(e + 31) = m >> (−31 − e).
        let sh = -31 - self.e;
        // Selects, not branches (fewer instructions on Cortex-M4F and M0+, `cargo xtask cost`).
        let x = self.shr_round(sh);
        let x = core::hint::select_unpredictable(x > i32::MAX as u32, i32::MAX as u32, x);
        core::hint::select_unpredictable(sh <= 0, i32::MAX, x as i32)
    }

    /// `m >> sh` rounded half up, for `sh ≥ 1` (0 when `sh < 1` or `sh > 32`).
    #[inline(always)]
    fn shr_round(self, sh: i32) -> u32 {
        // sh − 1 outside 0..=31 (sh < 1 or sh > 32) wraps to a shift of 32 or more: 0.
        let x = self.m.checked_shr(sh.wrapping_sub(1) as u32).unwrap_or(0);
        (x >> 1) + (x & 1)
    }
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
        let status = self.update_gated(st, psi, eps);
        if gate_reopened {
            status | Status::OUTLIER
        } else {
            status
        }
    }

    /// The update proper, after the hold, dead-zone and outlier gates.
    fn update_gated<const N: usize>(
        &self,
        st: &mut RlsState<N>,
        psi: &[SignalI16F16; N],
        eps: SignalI16F16,
    ) -> Status {
        let mut sat = false;

        // f = Uᵀψ, exactly, in I24F40.
        let mut f_i24f40 = [0i64; N];
        let mut f_or: u64 = 0;
        for (j, fj) in f_i24f40.iter_mut().enumerate() {
            let psi_j = psi.get(j).map_or(0, |p| i64::from(p.raw()));
            let mut acc = psi_j << U_FRAC_BITS;
            for (row, p) in st.u_i8f24.iter().zip(psi.iter()).take(j) {
                let uij = row.get(j).copied().unwrap_or(0);
                acc = acc.saturating_add(mul_i32_wide(uij, p.raw()));
            }
            *fj = acc;
            // The OR has the bit length of the largest |fⱼ|.
            f_or |= acc.unsigned_abs();
        }
        if f_or == 0 {
            return Status::LOW_EXCITATION;
        }
        // Normalise: f̂ = f·2^(31−b) in I1F31 with max |f̂| in [2^30, 2^31); f = 2^k f̃, k = b − 40.
        let b = crate::num::wide::bit_len_u64(f_or);
        let k = b - 40;
        let mut fh_i1f31 = [0i32; N];
        let sh = b - 32; // f̂ = round(f / 2^(sh + 1))
        if (0..=31).contains(&sh) {
            // The usual case (|f| ≥ 2^32, ψ above 2^-8 of a unit): x = f >> sh has |x| < 2^32, built
            // from 32-bit shifts of the halves (a variable 64-bit shift is a library call on
            // Armv6-M); rounding it to f̂ takes constant shifts only.
            for (fh, f) in fh_i1f31.iter_mut().zip(f_i24f40.iter()) {
                let (hi, lo) = ((*f >> 32) as i32, *f as u32);
                let x = if sh == 0 {
                    *f
                } else {
                    let lo_x = (lo >> sh) | ((hi as u32) << (32 - sh));
                    (i64::from(hi >> sh) << 32) | i64::from(lo_x)
                };
                *fh = ((x >> 1) + (x & 1)).min(i64::from(i32::MAX)) as i32;
            }
        } else {
            let mut dummy = false;
            for (fh, f) in fh_i1f31.iter_mut().zip(f_i24f40.iter()) {
                *fh = sat_i32(shift_round_i64(*f, 31 - b), &mut dummy);
            }
        }

        // Pass 1: the scalar chain αⱼ, rⱼ, gⱼ and the new D, on unclamped mantissa/exponent pairs.
        let lambda_inv = Pos::of(self.lambda_inv);
        let alpha0 = Pos::of(self.lambda).shl(-2 * k);
        let mut alpha = alpha0;
        let mut g = [Pos::ZERO; N];
        let mut r_i1f31 = [0i32; N];
        let mut d_new = st.d;
        for ((dn, fh), (gj, rj)) in d_new
            .iter_mut()
            .zip(fh_i1f31.iter())
            .zip(g.iter_mut().zip(r_i1f31.iter_mut()))
        {
            let d = Pos::of(*dn);
            let fa = fh.unsigned_abs();
            if fa == 0 {
                // fⱼ = 0: αⱼ = αⱼ₋₁, rⱼ = 1, gⱼ = 0.
                *rj = i32::MAX;
                let dl = d.mul(lambda_inv);
                *dn = Dyadic::from_normalised(dl.m, dl.e);
                continue;
            }
            let lz = crate::num::wide::leading_zeros_u32(fa);
            let f = Pos {
                m: fa << lz,
                e: -31 - lz as i32,
            };
            let v = d.mul(f); // dⱼ |f̃ⱼ|
            let alpha_next = alpha.add(v.mul(f));
            let rho = alpha_next.recip();
            let r = alpha.mul(rho);
            *rj = r.to_i1f31();
            *gj = v.mul(rho);
            let dl = d.mul(r).mul(lambda_inv);
            *dn = Dyadic::from_normalised(dl.m, dl.e);
            alpha = alpha_next;
        }
        // Excitation gate: ψᵀPψ = 4ᵏ (α_N − α₀) < threshold.
        if !self.excitation_min.is_zero() {
            let a0 = Dyadic::from_normalised(alpha0.m, alpha0.e);
            let limit = a0.add_trunc(self.excitation_min.shl(-2 * k));
            if Dyadic::from_normalised(alpha.m, alpha.e).lt(limit) {
                return Status::LOW_EXCITATION;
            }
        }

        // Pass 2: gains in one block exponent e_κ (largest gain below 2^(31−KAPPA_HEADROOM_BITS)),
        // then U and κ in fixed point.
        let e_g = g
            .iter()
            .filter(|x| x.m != 0)
            .map(|x| x.e)
            .max()
            .unwrap_or(0);
        let e_kappa = e_g.saturating_add(1 + KAPPA_HEADROOM_BITS);
        // Uᵢⱼ −= f̃ⱼ κᵢ: I1F31 × (κ·2^e_κ) → I8F24 is a right shift by 7 − e_κ of the product.
        let s_du = 7 - e_kappa;
        let du_shift_ok = (1..=62).contains(&s_du);
        let du_half = if du_shift_ok { 1i64 << (s_du - 1) } else { 0 };
        let du_smmulr_ok = (1..=32).contains(&s_du);
        let du_pre_shift = (32 - s_du).clamp(0, 31).unsigned_abs();
        let norms = matches!(self.bound, Bound::Trace(_) | Bound::ConstantTrace(_));
        let mut col_norm = [0u64; N];
        let mut kappa = [0i32; N];
        for (j, ((gj, &fh_j), (&r_j, cn))) in g
            .iter()
            .zip(fh_i1f31.iter())
            .zip(r_i1f31.iter().zip(col_norm.iter_mut()))
            .enumerate()
        {
            // gⱼ in κ units (κⱼ's start) and ·2^KAPPA_HEADROOM_BITS (Gⱼ: Uᵢⱼ·Gⱼ/2^UG_SHIFT is
            // in κ units).
            let sh = e_kappa - KAPPA_HEADROOM_BITS - gj.e;
            // Both below 2^31 (sh ≥ 1 for the largest gain; rounding may reach 2^31: clamped).
            let g_big = gj.shr_round(sh).min(i32::MAX as u32) as i32;
            let g_kappa = gj.shr_round(sh + KAPPA_HEADROOM_BITS) as i32;
            let (g_big, g_kappa) = if fh_j < 0 {
                (-g_big, -g_kappa)
            } else {
                (g_big, g_kappa)
            };
            let mut norm: u64 = 1 << (2 * U_FRAC_BITS);
            for (row, kap) in st.u_i8f24.iter_mut().zip(kappa.iter_mut()).take(j) {
                if let Some(uij) = row.get_mut(j) {
                    let u_old = *uij;
                    // κᵢ·2^(32−s_du) exact in 32 bits (the usual case): one high-word multiply,
                    // bit-identical to the rounded 64-bit shift of the full product.
                    let kap_pre = kap.wrapping_shl(du_pre_shift);
                    let du = if du_smmulr_ok && kap_pre >> du_pre_shift == *kap {
                        i64::from(mul_hi_round(fh_j, kap_pre))
                    } else if du_shift_ok {
                        // |p| ≤ 2^62: adding half a unit cannot overflow.
                        shr_i64(mul_i32_wide(fh_j, *kap) + du_half, s_du.unsigned_abs())
                    } else {
                        shift_round_i64(mul_i32_wide(fh_j, *kap), -s_du)
                    };
                    // Usually |du| < 2^31: a 32-bit subtraction with an overflow check; else
                    // the difference in 64 bits (|du| ≤ 2^62, no overflow) narrowed.
                    let u_new = if i64::from(du as i32) == du {
                        match u_old.checked_sub(du as i32) {
                            Some(x) => x,
                            None => {
                                sat = true;
                                if u_old < 0 { i32::MIN } else { i32::MAX }
                            }
                        }
                    } else {
                        sat_i32(i64::from(u_old) - du, &mut sat)
                    };
                    *uij = u_new;
                    // κᵢ ← κᵢ rⱼ + Uᵢⱼ(old) gⱼ: both terms below 2^31 in magnitude.
                    let kr = ((mul_i32_wide(*kap, r_j) + (1 << 30)) >> 31) as i32;
                    let ug =
                        ((mul_i32_wide(u_old, g_big) + (1 << (UG_SHIFT - 1))) >> UG_SHIFT) as i32;
                    *kap = match kr.checked_add(ug) {
                        Some(x) => x,
                        None => {
                            sat = true;
                            if kr > 0 { i32::MAX } else { i32::MIN }
                        }
                    };
                    if norms {
                        norm = norm.saturating_add(mul_i32_wide(u_new, u_new).unsigned_abs());
                    }
                }
            }
            *cn = norm;
            if let Some(kj) = kappa.get_mut(j) {
                *kj = g_kappa;
            }
        }

        // θ ← θ + K ε with K = 2⁻ᵏ κ·2^e_κ: raw F20 = κ·ε_raw·2^(e_κ − k + 4).
        let s_theta = e_kappa.saturating_sub(k).saturating_add(4);
        // Usually 0 ≤ s_θ + 32 ≤ 31 and ε·2^(s_θ+32) fits in 32 bits: then the rounded product is
        // one high-word multiply (SMMULR) of κ by that exact pre-shift, bit-identical to the
        // general path (the shift loses nothing; both round half up).
        let a_theta = s_theta.saturating_add(32);
        let eps_pre = if (0..=31).contains(&a_theta) {
            let shifted = eps.raw().wrapping_shl(a_theta.unsigned_abs());
            (shifted >> a_theta == eps.raw()).then_some(shifted)
        } else {
            None
        };
        for (th, kap) in st.theta.iter_mut().zip(kappa.iter()) {
            let dth = match eps_pre {
                // |κ·ε'| ≤ 2^62: the high word is below 2^30, no narrowing needed.
                Some(e) => mul_hi_round(*kap, e),
                None => sat_i32(
                    shift_round_i64(mul_i32_wide(*kap, eps.raw()), s_theta),
                    &mut sat,
                ),
            };
            let new = match th.raw().checked_add(dth) {
                Some(x) => x,
                None => {
                    sat = true;
                    if dth > 0 { i32::MAX } else { i32::MIN }
                }
            };
            *th = ParamI12F20::from_raw(new);
        }
        st.d = d_new;

        let mut status = Status::UPDATED;
        status.set_if(Status::SATURATED, sat);
        status |= self.bound_covariance(st, &col_norm);
        status.set_if(
            Status::COVARIANCE_SATURATED,
            st.d.iter().any(|d| d.is_saturated()),
        );
        status
    }

    /// Applies the configured covariance limit after an update; `col_norm` holds the column norms
    /// of the new U ([`RlsState::column_norm2`]'s sums) when the bound is on the trace.
    fn bound_covariance<const N: usize>(
        &self,
        st: &mut RlsState<N>,
        col_norm: &[u64; N],
    ) -> Status {
        match self.bound {
            Bound::None => Status::NONE,
            Bound::Trace(max) => {
                let tr = trace_of(&st.d, col_norm);
                if max.lt(tr) {
                    st.scale(max.mul_trunc(tr.recip()));
                    Status::COVARIANCE_BOUNDED
                } else {
                    Status::NONE
                }
            }
            Bound::Diagonal(max) => {
                let pmax = st.max_diagonal();
                if max.lt(pmax) {
                    st.scale(max.mul_trunc(pmax.recip()));
                    Status::COVARIANCE_BOUNDED
                } else {
                    Status::NONE
                }
            }
            Bound::ConstantTrace(c) => {
                let tr = trace_of(&st.d, col_norm);
                st.scale(c.mul_trunc(tr.recip()));
                Status::TRACE_NORMALISED
            }
        }
    }
}

/// Words: the variant's index (None 0, TraceLimit 1, DiagonalLimit 2, ConstantTrace 3), then its limit.
impl Words for AntiWindup {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        match *self {
            Self::None => w.word(0),
            Self::TraceLimit { max } => {
                w.word(1)?;
                max.put(w)
            }
            Self::DiagonalLimit { max } => {
                w.word(2)?;
                max.put(w)
            }
            Self::ConstantTrace { trace } => {
                w.word(3)?;
                trace.put(w)
            }
        }
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        match r.word() {
            0 => Self::None,
            1 => Self::TraceLimit { max: f64::take(r) },
            2 => Self::DiagonalLimit { max: f64::take(r) },
            3 => Self::ConstantTrace {
                trace: f64::take(r),
            },
            _ => {
                r.fail();
                Self::None
            }
        }
    }
}

/// The design itself (validated when it is built: see the module doc).
impl Words for RlsDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.lambda.put(w)?;
        self.p0.put(w)?;
        self.dead_zone.put(w)?;
        self.excitation_threshold.put(w)?;
        self.anti_windup.put(w)?;
        self.outlier_threshold.put(w)?;
        self.outlier_limit.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            lambda: f64::take(r),
            p0: f64::take(r),
            dead_zone: f64::take(r),
            excitation_threshold: f64::take(r),
            anti_windup: AntiWindup::take(r),
            outlier_threshold: f64::take(r),
            outlier_limit: u16::take(r),
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
    fn product_normalisations_agree() {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (a, b) = ((x as u32) | 1 << 31, ((x >> 32) as u32) | 1 << 31);
            let p = crate::num::wide::mul_u32_wide(a, b);
            assert_eq!(
                normalise_product_u64(p),
                normalise_product_halves(p),
                "{p:#x}"
            );
        }
        for p in [1u64 << 62, (1 << 63) - 1, 1 << 63, u64::MAX] {
            assert_eq!(
                normalise_product_u64(p),
                normalise_product_halves(p),
                "{p:#x}"
            );
        }
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
