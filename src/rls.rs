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
//! - **Positive definite by construction.** Every dⱼ is stored as a positive mantissa (floored at one
//!   unit, never zero, never negative: it is only ever multiplied by positive factors) and U is unit
//!   triangular, so P = UDUᵀ is symmetric positive definite whatever the rounding. The textbook update
//!   loses positive definiteness after ~4,400 samples of the sled data at λ = 0.995 even in float64
//!   (`shared/findings.md`).
//! - **Range.** P spans ~2^50 on the sled data and winds up without bound under forgetting. D is held
//!   in block floating point: `u32` mantissas with one shared exponent, renormalised after every
//!   update (max mantissa in [2²⁹, 2³⁰)), so P's overall scale costs nothing; the spread *between*
//!   the dⱼ is resolved to 30 bits, below which a dⱼ is floored (an over-estimate of that
//!   direction's uncertainty: conservative).
//! - **No division.** The only reciprocals are of αⱼ, one per parameter, by a table-seeded Newton
//!   iteration ([`crate::wide::recip_q63`]): no division instruction, no 64-bit software division.
//! - **Fixed point elsewhere.** f is normalised by a power of two (ψ·2⁻ᵏ only rescales α₀ to λ·4⁻ᵏ and
//!   the gain by 2⁻ᵏ, both exact); the α chain is summed in one `u64` scale per update; the gains gⱼ
//!   share one exponent per update; U is I8F24 (ratios of parameter scales, bounded when the
//!   regressors are normalised and centred). Widening multiplies avoid `__aeabi_lmul` on Armv6-M
//!   ([`crate::wide`]).
//!
//! # Formats
//! | quantity | format | note |
//! |---|---|---|
//! | ψ, ε, ŷ | I16F16 ([`SignalI16F16`]) | quanta / fraction of full scale |
//! | θ | I12F20 ([`ParamI12F20`]) | saturating, flagged |
//! | U (strict upper part) | I8F24 `i32` | saturating, flagged |
//! | D | `u32` mantissas, one `i32` exponent: dⱼ = Dⱼ·2^E | max Dⱼ ∈ [2²⁹, 2³⁰), Dⱼ ≥ 1 |
//! | f̂ = Uᵀψ normalised | I1F31 `i32`, max \|f̂\| ∈ [2³⁰, 2³¹) | scale 2ᵏ kept aside |
//! | Σ dⱼf̃ⱼ², αⱼ | `u64` in one scale per update | ≥ 32 significant bits |
//! | rⱼ = αⱼ₋₁/αⱼ | U0F32 `u32` | |
//! | λ, 1/λ | U1F31, U2F30 `u32` | λ ∈ [0.5, 1] |
//! | κ (gain being built) | `i32` with one exponent per update, 6 bits of headroom | saturating, flagged |
//!
//! # Scaling and overflow
//! `f` is accumulated in I24F40 (`i64`, saturating). Products of two 32-bit numbers are formed exactly
//! in 64 bits; every narrowing uses [`sat_i32`] and raises [`Status::SATURATED`]. Shifts round half up
//! (truncation would bias U and θ over 10⁶ samples). The block exponent saturates at ±16,384 and raises
//! [`Status::COVARIANCE_SATURATED`] at the top.
//!
//! # Anti-windup
//! Selected per configuration ([`AntiWindup`]) and independent of it: a dead zone on |ε| (in sensor
//! quanta: the ±1-quantum limit cycle does not drive the estimate), an excitation gate on ψᵀPψ, hold.
//! Skipped samples leave θ and P untouched (no forgetting without information, so no windup).
//!
//! # Accuracy
//! Against a float64 textbook RLS on the same data (`host-tests/tests/rls_vs_f64.rs`): θ within 1e-3
//! relative at every sample on well-posed problems (ARX; OE with excitation), simulation RMS within
//! 1 %; on ill-posed ones (second-order OE on poorly excited data) within 3× the problem's own
//! sensitivity to the signal format.
//!
//! # Cost
//! See `BENCHMARKS.md` (instructions and estimated cycles per update on Cortex-M4F and M0+).

#![deny(clippy::float_arithmetic)]

use crate::dyadic::Dyadic;
use crate::error::ConfigError;
use crate::fixed::{ParamI12F20, SignalI16F16, sat_i32, shift_round_i64, shr_round_i64};
use crate::status::Status;
use crate::wide::{mul_i32_u32_wide, mul_i32_wide, mul_u32_wide, recip_q63};

/// Fraction bits of the U factor (I8F24).
pub const U_FRAC_BITS: u32 = 24;
/// Headroom bits of the gain accumulator κ above the largest gⱼ.
const KAPPA_HEADROOM_BITS: i32 = 6;
/// Largest supported parameter count (the α accumulation and κ headroom are sized for it).
pub const MAX_PARAMS: usize = 8;
/// Bit length of the largest D mantissa after renormalisation (max Dⱼ ∈ [2²⁹, 2³⁰)).
const D_BITS: i32 = 30;
/// Limits of the block exponent of D.
const D_EXP_MAX: i32 = 16_384;
const D_EXP_MIN: i32 = -16_384;

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
    /// Forgetting factor λ ∈ [0.5, 1]; 1 means no forgetting.
    pub lambda: f64,
    /// Initial covariance P₀ = p0 · I.
    pub p0: f64,
    /// Dead zone on |ε| in signal units (sensor quanta for positions); 0 disables it.
    pub dead_zone: f64,
    /// Minimum ψᵀPψ for an update; 0 disables the gate.
    pub excitation_threshold: f64,
    /// Covariance limit.
    pub anti_windup: AntiWindup,
}

impl Default for RlsDesign {
    fn default() -> Self {
        Self {
            lambda: 1.0,
            p0: 1.0e4,
            dead_zone: 0.0,
            excitation_threshold: 0.0,
            anti_windup: AntiWindup::None,
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
    lambda_u1f31: u32,
    lambda_inv_u2f30: u32,
    p0_mant: u32,
    p0_exp: i32,
    dead_zone_i16f16: u32,
    excitation_min: Dyadic,
    bound: Bound,
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
    /// use sledid::rls::{AntiWindup, RlsDesign};
    /// let cfg = RlsDesign { lambda: 0.995, anti_windup: AntiWindup::TraceLimit { max: 100.0 },
    ///                       ..RlsDesign::default() }.build();
    /// assert!(cfg.is_ok());
    /// assert!(RlsDesign { lambda: 1.5, ..RlsDesign::default() }.build().is_err());
    /// ```
    #[allow(clippy::float_arithmetic)] // configuration time, not the per-sample path
    pub fn build(&self) -> Result<RlsConfig, ConfigError> {
        if !(0.5..=1.0).contains(&self.lambda) {
            return Err(ConfigError::Lambda(self.lambda));
        }
        let lambda_u1f31 = (self.lambda * 2_147_483_648.0 + 0.5) as u32;
        let lambda_inv_u2f30 = (1_073_741_824.0 / self.lambda + 0.5) as u32;
        let p0 = positive_dyadic(self.p0, ConfigError::InitialCovariance(self.p0))?;
        // Dyadic mantissa in [2^31, 2^32) → D mantissa in [2^29, 2^30).
        let p0_exp = p0.exp().saturating_add(2);
        if !(D_EXP_MIN..=D_EXP_MAX / 2).contains(&p0_exp) {
            return Err(ConfigError::InitialCovariance(self.p0));
        }
        if self.dead_zone.is_nan() || self.dead_zone < 0.0 {
            return Err(ConfigError::DeadZone(self.dead_zone));
        }
        let dz = SignalI16F16::from_f64(self.dead_zone)
            .map_err(|_| ConfigError::DeadZone(self.dead_zone))?;
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
            AntiWindup::ConstantTrace { trace } => Bound::ConstantTrace(positive_dyadic(
                trace,
                ConfigError::CovarianceLimit(trace),
            )?),
        };
        Ok(RlsConfig {
            lambda_u1f31,
            lambda_inv_u2f30,
            p0_mant: p0.mant() >> 2,
            p0_exp,
            dead_zone_i16f16: dz.raw().unsigned_abs(),
            excitation_min,
            bound,
        })
    }
}

/// Everything an update mutates: θ and the UD factors of P.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RlsState<const N: usize> {
    theta: [ParamI12F20; N],
    /// Strictly upper part of U in I8F24 (`u[i][j]`, i < j); the rest stays zero.
    u_i8f24: [[i32; N]; N],
    /// D mantissas: dⱼ = `d_mant[j]` · 2^`d_exp`, max in [2²⁹, 2³⁰), each ≥ 1.
    d_mant: [u32; N],
    d_exp: i32,
    enabled: bool,
}

/// `x · 2^s` for an unsigned 64-bit value and a signed shift; right shifts round half up, left
/// shifts saturate, shifts beyond the width give 0 (right) or saturate (left).
#[inline(always)]
fn shift_u64(x: u64, s: i32) -> u64 {
    if s >= 0 {
        let s = s.unsigned_abs();
        if x == 0 {
            0
        } else if s >= 64 || x > (u64::MAX >> s) {
            u64::MAX
        } else {
            x << s
        }
    } else {
        let s = s.unsigned_abs();
        if s > 64 {
            0
        } else if s == 64 {
            x >> 63
        } else {
            (x >> s) + ((x >> (s - 1)) & 1)
        }
    }
}

/// Bit length of a `u64` (0 for 0).
#[inline(always)]
fn bit_len(x: u64) -> i32 {
    crate::wide::bit_len_u64(x)
}

impl<const N: usize> RlsState<N> {
    const SIZE_OK: () = assert!(N >= 1 && N <= MAX_PARAMS, "1 ≤ N ≤ 8 parameters");

    /// A fresh state: θ = `theta0`, P = p₀·I, enabled.
    pub fn new(config: &RlsConfig, theta0: [ParamI12F20; N]) -> Self {
        let () = Self::SIZE_OK;
        Self {
            theta: theta0,
            u_i8f24: [[0; N]; N],
            d_mant: [config.p0_mant; N],
            d_exp: config.p0_exp,
            enabled: true,
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

    /// dⱼ as a dyadic number.
    pub fn d(&self, j: usize) -> Dyadic {
        Dyadic::from_u32(self.d_mant.get(j).copied().unwrap_or(0), self.d_exp)
    }

    /// `(1 + Σ_{i<j} Uᵢⱼ²)` for column j in U16F16 (saturating).
    fn column_norm2_u16f16(&self, j: usize) -> u64 {
        let mut acc: u64 = 1 << 16;
        for row in self.u_i8f24.iter().take(j) {
            let uij = row.get(j).copied().unwrap_or(0);
            acc = acc.saturating_add(mul_i32_wide(uij, uij).unsigned_abs() >> 32);
        }
        acc
    }

    /// trace(P) = Σⱼ dⱼ (1 + Σ_{i<j} Uᵢⱼ²).
    pub fn trace(&self) -> Dyadic {
        let mut t: u64 = 0;
        for (j, &dj) in self.d_mant.iter().enumerate() {
            t = t.saturating_add(u64::from(dj).saturating_mul(self.column_norm2_u16f16(j)));
        }
        Dyadic::from_u64(t, self.d_exp.saturating_sub(16))
    }

    /// The largest diagonal element of P: Pᵢᵢ = dᵢ + Σ_{j>i} Uᵢⱼ² dⱼ.
    pub fn max_diagonal(&self) -> Dyadic {
        let mut best: u64 = 0;
        for (i, row) in self.u_i8f24.iter().enumerate() {
            let mut pii = u64::from(self.d_mant.get(i).copied().unwrap_or(0)) << 16;
            for (&uij, &dj) in row.iter().zip(self.d_mant.iter()).skip(i + 1) {
                let u2 = mul_i32_wide(uij, uij).unsigned_abs() >> 32; // U16F16
                pii = pii.saturating_add(u2.saturating_mul(u64::from(dj)));
            }
            best = best.max(pii);
        }
        Dyadic::from_u64(best, self.d_exp.saturating_sub(16))
    }

    /// Stores new D mantissas (any magnitude below 2⁶³) at exponent `exp`, renormalised so the largest
    /// has bit length [`D_BITS`], each floored at 1. Returns true if the exponent saturated high.
    fn store_d(&mut self, d: &[u64; N], exp: i32) -> bool {
        let max = d.iter().copied().max().unwrap_or(0);
        let shift = if max == 0 { 0 } else { bit_len(max) - D_BITS };
        for (dst, &x) in self.d_mant.iter_mut().zip(d.iter()) {
            *dst = shift_u64(x, -shift).clamp(1, u64::from(u32::MAX)) as u32;
        }
        let e = exp.saturating_add(shift);
        self.d_exp = e.clamp(D_EXP_MIN, D_EXP_MAX);
        e >= D_EXP_MAX
    }

    /// Multiplies P by `factor` (scales D; U is unchanged).
    fn scale(&mut self, factor: Dyadic) -> bool {
        let mut d = [0u64; N];
        for (dst, &x) in d.iter_mut().zip(self.d_mant.iter()) {
            *dst = shift_u64(mul_u32_wide(x, factor.mant()), -32);
        }
        let exp = self.d_exp.saturating_add(factor.exp()).saturating_add(32);
        self.store_d(&d, exp)
    }
}

impl RlsConfig {
    /// The forgetting factor, U1F31.
    pub fn lambda_u1f31(&self) -> u32 {
        self.lambda_u1f31
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
        // Each product ≤ 2^62; N ≤ 8 terms: saturating sum.
        let mut acc_i28f36: i64 = 0;
        for (t, p) in theta.iter().zip(psi.iter()) {
            acc_i28f36 = acc_i28f36.saturating_add(mul_i32_wide(t.raw(), p.raw()));
        }
        let y = shr_round_i64(acc_i28f36, crate::fixed::PARAM_FRAC_BITS);
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
        if eps.raw().unsigned_abs() <= self.dead_zone_i16f16 && self.dead_zone_i16f16 > 0 {
            return Status::DEAD_ZONE;
        }
        let mut sat = false;

        // f = Uᵀψ in I24F40 (saturating: only reachable with saturated U and ψ).
        let mut f_i24f40 = [0i64; N];
        let mut f_max: u64 = 0;
        for (j, fj) in f_i24f40.iter_mut().enumerate() {
            let psi_j = psi.get(j).map_or(0, |p| i64::from(p.raw()));
            let mut acc = psi_j << U_FRAC_BITS;
            for (row, p) in st.u_i8f24.iter().zip(psi.iter()).take(j) {
                let uij = row.get(j).copied().unwrap_or(0);
                acc = acc.saturating_add(mul_i32_wide(uij, p.raw()));
            }
            *fj = acc;
            f_max = f_max.max(acc.unsigned_abs());
        }
        if f_max == 0 {
            return Status::LOW_EXCITATION;
        }
        // Normalise: f̂ = f·2^(31−b) in I1F31, max |f̂| in [2^30, 2^31]; f = 2^k f̃ with k = b − 40.
        let b = bit_len(f_max);
        let k = b - 40;
        let mut fh_i1f31 = [0i32; N];
        let mut ignore = false;
        for (fh, f) in fh_i1f31.iter_mut().zip(f_i24f40.iter()) {
            *fh = sat_i32(shift_round_i64(*f, 31 - b), &mut ignore);
        }

        // Pass 1a: wⱼ = Dⱼ|f̂ⱼ|/2^31 and the running sums S_j = Σ_{i≤j} wᵢ|f̂ᵢ|/4, so that
        // Σ_{i≤j} dᵢf̃ᵢ² = S_j · 2^(E−29). Bounds: D < 2^30, |f̂| ≤ 2^31 → w ≤ 2^30, terms ≤ 2^59.
        let mut w = [0u32; N];
        let mut s_cum = [0u64; N];
        let mut s_acc: u64 = 0;
        for ((wj, sj), (&dj, &fh)) in w
            .iter_mut()
            .zip(s_cum.iter_mut())
            .zip(st.d_mant.iter().zip(fh_i1f31.iter()))
        {
            let fa = fh.unsigned_abs();
            *wj = shift_u64(mul_u32_wide(dj, fa), -31) as u32;
            s_acc = s_acc.saturating_add(shift_u64(mul_u32_wide(*wj, fa), -2));
            *sj = s_acc;
        }
        let e = st.d_exp;
        // Excitation gate: ψᵀPψ = 4ᵏ Σ dⱼf̃ⱼ² = S_n · 2^(E − 29 + 2k).
        if !self.excitation_min.is_zero()
            && Dyadic::from_u64(s_acc, e - 29 + 2 * k).lt(self.excitation_min)
        {
            return Status::LOW_EXCITATION;
        }

        // α₀ = λ·4⁻ᵏ in units of 2^(E−29): λ_U1F31 · 2^(−2k − E − 2). One u64 scale 2^σ for the chain.
        let s_l = -2 * k - e - 2;
        let top = (32 + s_l).max(bit_len(s_acc));
        let sigma = (top - 62).max(0);
        let alpha0 = shift_u64(u64::from(self.lambda_u1f31), s_l - sigma);

        // Pass 1b: αⱼ, rⱼ = αⱼ₋₁/αⱼ, gⱼ = dⱼf̃ⱼ/αⱼ (as G'ⱼ·2^γⱼ), new D.
        let mut r_u0f32 = [u32::MAX; N];
        let mut g_mag = [0u64; N];
        let mut g_exp = [0i32; N];
        let mut d_new = [0u64; N];
        // α as a normalised 32-bit mantissa m ∈ [2^31, 2^32) and shift: α ≈ m·2^sh.
        let normalise = |a: u64| {
            let sh = bit_len(a) - 32;
            (shift_u64(a, -sh).min(u64::from(u32::MAX)) as u32, sh)
        };
        let (mut m_prev, mut sh_prev) = normalise(alpha0);
        for j in 0..N {
            let s_j = s_cum.get(j).copied().unwrap_or(0);
            let alpha = alpha0.saturating_add(shift_u64(s_j, -sigma));
            let dj = st.d_mant.get(j).copied().unwrap_or(1);
            let wj = w.get(j).copied().unwrap_or(0);
            let (r, gm, ge) = if alpha == 0 {
                (u32::MAX, 0, 0)
            } else {
                let (m, sh) = normalise(alpha);
                let q = recip_q63(m).min(u64::from(u32::MAX)) as u32; // ≈ 2^63 / m
                // rⱼ = αⱼ₋₁/αⱼ = m_prev·q·2^(sh_prev − sh − 63), in U0F32 (α non-decreasing: ≤ 1).
                let r = if m_prev == 0 {
                    0
                } else {
                    shift_u64(mul_u32_wide(m_prev, q), sh_prev - sh - 31).min(u64::from(u32::MAX))
                        as u32
                };
                m_prev = m;
                sh_prev = sh;
                // gⱼ = wⱼ·2^E / (α·2^(σ+E−29)) = wⱼ·q·2^(−34 − sh − σ).
                (r, mul_u32_wide(wj, q), -34 - sh - sigma)
            };
            if let Some(x) = r_u0f32.get_mut(j) {
                *x = r;
            }
            if let Some(x) = g_mag.get_mut(j) {
                *x = gm;
            }
            if let Some(x) = g_exp.get_mut(j) {
                *x = ge;
            }
            // dⱼ ← dⱼ rⱼ / λ, rounded (truncation would bias a small dⱼ down by one unit per update).
            let dr = shift_u64(mul_u32_wide(dj, r), -32) as u32;
            if let Some(x) = d_new.get_mut(j) {
                *x = shift_u64(mul_u32_wide(dr, self.lambda_inv_u2f30), -30);
            }
        }

        // Pass 2: the gains in one block exponent e_κ, |Gⱼ| < 2^(31 − headroom); U and κ in fixed point.
        let beta = g_mag
            .iter()
            .zip(g_exp.iter())
            .filter(|(m, _)| **m != 0)
            .map(|(m, x)| x.saturating_add(bit_len(*m)))
            .max()
            .unwrap_or(0);
        let e_kappa = beta - 31 + KAPPA_HEADROOM_BITS;
        let mut kappa = [0i32; N];
        for j in 0..N {
            let gm = g_mag.get(j).copied().unwrap_or(0);
            let ge = g_exp.get(j).copied().unwrap_or(0);
            let g_abs = shift_u64(gm, ge - e_kappa).min(i32::MAX as u64) as i32;
            let fh_j = fh_i1f31.get(j).copied().unwrap_or(0);
            let g_j = if fh_j < 0 { -g_abs } else { g_abs };
            let r_j = r_u0f32.get(j).copied().unwrap_or(u32::MAX);

            for (row, kap) in st.u_i8f24.iter_mut().zip(kappa.iter_mut()).take(j) {
                if let Some(uij) = row.get_mut(j) {
                    let u_old = *uij;
                    // Uᵢⱼ ← Uᵢⱼ − f̃ⱼ κᵢ: I1F31 × (κ·2^e_κ) → I8F24.
                    let du = shift_round_i64(mul_i32_wide(fh_j, *kap), e_kappa - 7);
                    *uij = sat_i32(i64::from(u_old).saturating_sub(du), &mut sat);
                    // κᵢ ← κᵢ rⱼ + Uᵢⱼ(old) gⱼ.
                    let kr = shr_round_i64(mul_i32_u32_wide(*kap, r_j), 32);
                    let ug = shr_round_i64(mul_i32_wide(u_old, g_j), U_FRAC_BITS);
                    *kap = sat_i32(kr + ug, &mut sat);
                }
            }
            if let Some(kj) = kappa.get_mut(j) {
                *kj = g_j;
            }
        }

        // θ ← θ + K ε with K = 2⁻ᵏ κ·2^e_κ: raw F20 = κ·ε_raw·2^(e_κ − k + 4).
        let s_theta = e_kappa - k + 4;
        for (th, kap) in st.theta.iter_mut().zip(kappa.iter()) {
            let dth = shift_round_i64(mul_i32_wide(*kap, eps.raw()), s_theta);
            let new = sat_i32(i64::from(th.raw()).saturating_add(dth), &mut sat);
            *th = ParamI12F20::from_raw(new);
        }
        let mut exp_saturated = st.store_d(&d_new, e);

        let mut status = Status::UPDATED;
        let (bound_status, bound_saturated) = self.bound_covariance(st);
        status |= bound_status;
        exp_saturated |= bound_saturated;
        status.set_if(Status::SATURATED, sat);
        status.set_if(Status::COVARIANCE_SATURATED, exp_saturated);
        status
    }

    /// Applies the configured covariance limit after an update.
    fn bound_covariance<const N: usize>(&self, st: &mut RlsState<N>) -> (Status, bool) {
        match self.bound {
            Bound::None => (Status::NONE, false),
            Bound::Trace(max) => {
                let tr = st.trace();
                if max.lt(tr) {
                    (Status::COVARIANCE_BOUNDED, st.scale(max.mul(tr.recip())))
                } else {
                    (Status::NONE, false)
                }
            }
            Bound::Diagonal(max) => {
                let pmax = st.max_diagonal();
                if max.lt(pmax) {
                    (Status::COVARIANCE_BOUNDED, st.scale(max.mul(pmax.recip())))
                } else {
                    (Status::NONE, false)
                }
            }
            Bound::ConstantTrace(c) => {
                let tr = st.trace();
                (Status::TRACE_NORMALISED, st.scale(c.mul(tr.recip())))
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
    }
}
