//! The PID/lead position controller, the paper's loop (Section 3, Figure 2): configurable as the
//! twin's badly tuned baseline and as the EMPS rig's PD-with-inner-velocity-loop controller.
//! [`PidDesign`] (floats, engineering units) → [`PidConfig`] (validated, quantised, `Copy`) +
//! [`PidState`]; one [`PidConfig::step`] per sample. Cost: `bench_pid_step` in BENCHMARKS.md.
//!
//! # Equations
//! Per sample `k`, positions in sensor quanta, every term in fractions of the full-scale drive
//! `u_fs` (the design's gains in volts are divided by `u_fs` when the configuration is built):
//!
//! ```text
//! r_f(k) = r_f(k−1) + (1 − α)·(r(k) − r_f(k−1))     α = e^{−2π·f_r·Ts}   (prefilter; off: r_f = r)
//! e(k)   = r_f(k) − y(k)
//! w(k)   = e(k)        (derivative on the error)   or   −y(k)   (derivative on the measurement)
//! Δ(k)   = w(k) − w(k−n)                            n-sample moving sum of the differences, n ≤ 4
//! s(k)   = β·s(k−1) + (1 − β)·Δ(k)                  β = e^{−2π·f_d·Ts}   (off: β = 0, s = Δ)
//! P = Kp·e(k)      D = Kd/(n·Ts)·s(k)
//! I* = clamp(I(k−1) + Ki·Ts·e(k), ±I_max)
//! I(k) = I(k−1)    if |P + I* + D| > u_max and I* − I(k−1) has the sign of P + I* + D
//!        I*        otherwise                        (conditional integration: no windup)
//! u(k) = clamp(P + I(k) + D, ±u_max)
//! ```
//!
//! With n = 1 and a low-pass derivative this is the twin's baseline `PidController`
//! (`host-tests/src/twin/baseline.rs`): `D(k) = β·D(k−1) + (1 − β)·Kd·(e(k) − e(k−1))/Ts`, D = 0 on
//! the first sample. The EMPS controller `vir = kp·kv·(qg − qm) − kv·v̂` is Kp = kp·kv, Kd = kv,
//! Ki = 0, derivative on the measurement with v̂ = (qm(k) − qm(k−2))/(2·Ts): n = 2, no low-pass
//! ([`PidDesign::position_velocity_cascade`]).
//!
//! **First sample and bumpless enable.** On the first sample after [`PidState::new`] the
//! derivative history is filled with the current w (D = 0, no derivative kick) and the prefilter
//! starts at the measured position. While disabled ([`PidState::set_enabled`]) the output is
//! the manual value, the derivative history keeps running, the prefilter follows y, and the
//! integrator tracks `u_manual − P − D` (clamped to ±I_max): re-enabling continues from the manual
//! output without a step. Without an integrator (I_max = 0) the transfer cannot be bumpless and
//! [`PidFlags::TRACKING_LIMITED`] says so.
//!
//! # Formats
//! | quantity | format | range | step |
//! |---|---|---|---|
//! | r, y, r_f, w history | `i64` I48F16 ([`crate::num::boundary::PositionI48F16`]) | ±1.4·10¹⁴ quanta | 2⁻¹⁶ quanta |
//! | e, Δ, s | I16F16 ([`SignalI16F16`]) | ±32,768 quanta | 2⁻¹⁶ quanta |
//! | Kp, Ki·Ts, Kd/(n·Ts) | [`Gain`]: `i32` mantissa, \|m\| ∈ [2³⁰, 2³¹), own shift | (0, 2¹⁵) u_fs per quantum | 2⁻³¹ relative |
//! | α, 1 − α, β, 1 − β | U1F31 `u32` | [0, 1] | 4.7·10⁻¹⁰ |
//! | P, I, D, sums, I_max, u_max | `i64` I32F32 (u_max on the I16F16 grid) | ±2³¹ u_fs | 2⁻³² u_fs |
//! | u | I16F16 ([`SignalI16F16`]) | ±u_max (< 32,768 u_fs) | 2⁻¹⁶ u_fs |
//!
//! # Range analysis
//! Absolute positions stay in I48F16; only differences are narrowed. The error e and the moving
//! sum Δ are narrowed to I16F16 (±32,768 quanta): the sled's seeks are ≤ 2,000 tracks and ≤ 60
//! tracks per sample; on EMPS (quantum 5·10⁻⁸ m) |qg − qm| ≤ 17,045 counts and |Δ| ≤ 5,200 counts
//! for n = 2. Beyond that they saturate (flagged), which limits the controller's authority but
//! keeps its sign. Every term is an `i32` × `i32` product shifted right, so |P|, |D|, |Ki·Ts·e| <
//! 2⁶² and P + D < 2⁶³ is exact; I and u are clamped to limits below 2⁴⁷, and the sums with them
//! saturate (unflagged) only beyond ±2³¹ u_fs, where the output is clamped anyway.
//!
//! # Scaling and overflow
//! Every product of two `i32` goes through [`mul_i32_wide`](crate::num::wide::mul_i32_wide) (four `MULS` on Armv6-M); narrowings
//! round half up and saturate with [`PidFlags::ARITHMETIC_SATURATED`]; position differences are
//! `saturating_sub`, so any `i64` input, including `i64::MIN`, is accepted. The prefilter's rounding
//! stops it within 2⁻¹⁷/(1 − α) quanta of a constant reference (7.6·10⁻⁴ quanta at α = 0.99).
//!
//! # Accuracy
//! - Against the float64 law (`host-tests/src/reference/control.rs`), open loop on the same
//!   inputs: |u − u_f64| ≤ 2⁻¹⁷ u_fs (half an output LSB) + the gains' 2⁻³¹ relative rounding + the
//!   filters' 2⁻¹⁷ quanta per sample, asserted < 8·10⁻⁶ u_fs on the twin's baseline (with and
//!   without the prefilter) and on EMPS (`fixed_point_matches_float64_on_twin_and_emps` in
//!   `host-tests/tests/integration/control.rs`).
//! - In the twin's loop the baseline configuration follows the f64 law with its output rounded to
//!   the I16F16 grid sample for sample, and against the unrounded f64 baseline its seeks settle
//!   within one sample period and end in the ±1-quantum limit cycle
//!   (`fixed_point_baseline_reproduces_the_twin_closed_loop`).
//! - The EMPS configuration reproduces the recorded `vir` within the bound
//!   `emps_controller_reproduces_the_recorded_drive` asserts.

use super::integrator::integrate;
use super::{ControlFlags, ControlInput, ControlOutput, Controller, Region};
use crate::error::ConfigError;
use crate::ident::status::Status;
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::{SignalI16F16, sat_i32, shr_round_i64};
use crate::num::float_bits::from_fixed;
use crate::num::gain::{
    Gain, LIMIT_I32F32_MAX, ONE_U1F31, clamp_sym_i64, i32f32_from_f64, mul_i64_u1f31, pole_u1f31,
};
use crate::num::wide::mul_i32_u32_wide;
use crate::words::{WordReader, WordWriter, Words};

/// Longest moving sum of position differences in the derivative (history length).
pub const MAX_DERIVATIVE_SAMPLES: u8 = 4;

/// What the PID did in one sample.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidFlags(u8);

impl PidFlags {
    /// No flag.
    pub const NONE: Self = Self(0);
    /// P + I + D exceeded ±u_max and the output was clamped.
    pub const OUTPUT_SATURATED: Self = Self(1 << 0);
    /// The integrator reached ±I_max.
    pub const INTEGRATOR_LIMITED: Self = Self(1 << 1);
    /// Conditional integration held the integrator (it would have wound further into saturation).
    pub const INTEGRATION_HELD: Self = Self(1 << 2);
    /// A fixed-point narrowing saturated (error, moving sum or output beyond I16F16).
    pub const ARITHMETIC_SATURATED: Self = Self(1 << 3);
    /// Disabled: the output is the manual value and the integrator tracks it.
    pub const MANUAL: Self = Self(1 << 4);
    /// Disabled, and the integrator limit kept it from absorbing `u_manual − P − D`: re-enabling
    /// will step the output.
    pub const TRACKING_LIMITED: Self = Self(1 << 5);
    /// The first sample after `new`/`reset`: the derivative history was primed (D = 0).
    pub const FIRST_SAMPLE: Self = Self(1 << 6);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 7] = [
        (Self::OUTPUT_SATURATED, "output_saturated"),
        (Self::INTEGRATOR_LIMITED, "integrator_limited"),
        (Self::INTEGRATION_HELD, "integration_held"),
        (Self::ARITHMETIC_SATURATED, "arithmetic_saturated"),
        (Self::MANUAL, "manual"),
        (Self::TRACKING_LIMITED, "tracking_limited"),
        (Self::FIRST_SAMPLE, "first_sample"),
    ];

    /// The common [`ControlFlags`] equivalent (manual and tracking have none).
    pub const fn control(self) -> ControlFlags {
        let mut f = ControlFlags::NONE;
        if self.intersects(Self::OUTPUT_SATURATED) {
            f = f.union(ControlFlags::OUTPUT_SATURATED);
        }
        if self.intersects(Self::INTEGRATOR_LIMITED) {
            f = f.union(ControlFlags::INTEGRATOR_LIMITED);
        }
        if self.intersects(Self::INTEGRATION_HELD) {
            f = f.union(ControlFlags::INTEGRATION_HELD);
        }
        if self.intersects(Self::ARITHMETIC_SATURATED) {
            f = f.union(ControlFlags::ARITHMETIC_SATURATED);
        }
        if self.intersects(Self::FIRST_SAMPLE) {
            f = f.union(ControlFlags::FIRST_SAMPLE);
        }
        f
    }

    /// The identifier-side [`Status`] equivalent: arithmetic saturation → `SATURATED`, manual →
    /// `HELD`, first sample → `WARMUP` (output and integrator limits have no equivalent).
    pub const fn status(self) -> Status {
        let mut bits = 0;
        if self.intersects(Self::ARITHMETIC_SATURATED) {
            bits |= Status::SATURATED.bits();
        }
        if self.intersects(Self::MANUAL) {
            bits |= Status::HELD.bits();
        }
        if self.intersects(Self::FIRST_SAMPLE) {
            bits |= Status::WARMUP.bits();
        }
        Status::from_bits(bits)
    }
}

crate::flag_set_impl!(PidFlags, u8);

/// The result of one PID step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidOutput {
    /// The drive, fraction of full scale, |u| ≤ u_max.
    pub u: SignalI16F16,
    /// What happened.
    pub flags: PidFlags,
}

/// The signal the derivative term differentiates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DerivativeOn {
    /// The error `r_f − y` (the twin's baseline: a reference step kicks D).
    #[default]
    Error,
    /// The negated measurement `−y` (the EMPS rig's velocity loop: `−kv·v̂`).
    Measurement,
}

/// User-facing controller settings in engineering units; build a validated [`PidConfig`].
///
/// Gains act on the error in sensor quanta and give volts; they are divided by `u_full_scale_v`
/// when built, so the output is a fraction of full scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidDesign {
    /// Sampling period Ts, s.
    pub ts_s: f64,
    /// Full-scale drive u_fs, V: the unit of the output (u = 1 is u_fs volts).
    pub u_full_scale_v: f64,
    /// Output saturation ±u_max, V (< 32,768·u_fs).
    pub u_limit_v: f64,
    /// Proportional gain Kp, V per quantum of error.
    pub kp_v_per_quantum: f64,
    /// Integral gain Ki, V per quantum-second of error.
    pub ki_v_per_quantum_s: f64,
    /// Derivative gain Kd, V per quantum/s of rate.
    pub kd_v_s_per_quantum: f64,
    /// Integrator clamp ±I_max, V (anti-windup; 0 disables the integrator).
    pub integrator_limit_v: f64,
    /// What the derivative differentiates.
    pub derivative_on: DerivativeOn,
    /// n: the rate is the moving average of the last n position differences,
    /// `(w(k) − w(k−n))/(n·Ts)`; 1 is the backward difference. 1..=4.
    pub derivative_samples: u8,
    /// Corner of the first-order low-pass on the rate, Hz; 0 disables it.
    pub derivative_lowpass_hz: f64,
    /// Corner of the first-order low-pass prefilter on the reference, Hz; 0 disables it.
    pub reference_lowpass_hz: f64,
}

impl PidDesign {
    /// A design with zero gains, no filters, n = 1, and the output limit at full scale.
    pub const fn new(ts_s: f64, u_full_scale_v: f64) -> Self {
        Self {
            ts_s,
            u_full_scale_v,
            u_limit_v: u_full_scale_v,
            kp_v_per_quantum: 0.0,
            ki_v_per_quantum_s: 0.0,
            kd_v_s_per_quantum: 0.0,
            integrator_limit_v: 0.0,
            derivative_on: DerivativeOn::Error,
            derivative_samples: 1,
            derivative_lowpass_hz: 0.0,
            reference_lowpass_hz: 0.0,
        }
    }

    /// A position loop around a velocity loop, `u = kv·(kp·(r − y) − v̂)`: Kp = kp·kv, Kd = kv,
    /// no integrator, the derivative on the measurement, v̂ over two samples (the EMPS rig).
    ///
    /// `kp_per_s` is the position-loop gain (1/s), `kv_v_s_per_quantum` the velocity gain in V per
    /// quantum/s (V/(m/s) times the quantum in metres).
    ///
    /// ```
    /// use sledid::control::PidDesign;
    /// // EMPS: kp = 160.18 1/s, kv = 243.45 V/(m/s), 5e-8 m encoder counts, Ts = 1 ms, ±10 V.
    /// let design = PidDesign::position_velocity_cascade(1e-3, 10.0, 160.18, 243.45 * 5e-8);
    /// assert!(design.build().is_ok());
    /// ```
    #[allow(clippy::float_arithmetic)] // design time, not the per-sample path
    pub fn position_velocity_cascade(
        ts_s: f64,
        u_full_scale_v: f64,
        kp_per_s: f64,
        kv_v_s_per_quantum: f64,
    ) -> Self {
        Self {
            kp_v_per_quantum: kp_per_s * kv_v_s_per_quantum,
            kd_v_s_per_quantum: kv_v_s_per_quantum,
            derivative_on: DerivativeOn::Measurement,
            derivative_samples: 2,
            ..Self::new(ts_s, u_full_scale_v)
        }
    }

    /// Validates and quantises.
    ///
    /// # Errors
    /// A [`ConfigError`] naming the first parameter out of range.
    ///
    /// ```
    /// use sledid::control::{ConfigError, PidDesign};
    /// let mut d = PidDesign::new(0.455e-3, 5.0);
    /// d.kp_v_per_quantum = 0.015;
    /// d.ki_v_per_quantum_s = 200.0;
    /// d.integrator_limit_v = 0.07;
    /// assert!(d.build().is_ok());
    /// d.derivative_lowpass_hz = 5000.0; // above Nyquist
    /// assert_eq!(d.build(), Err(ConfigError::DerivativeLowPass(5000.0)));
    /// ```
    #[allow(clippy::float_arithmetic)] // design time, not the per-sample path
    pub fn build(&self) -> Result<PidConfig, ConfigError> {
        use ConfigError as E;
        let ts = self.ts_s;
        if !(ts.is_finite() && ts > 0.0) {
            return Err(E::SamplePeriod(ts));
        }
        let fs = self.u_full_scale_v;
        if !(fs.is_finite() && fs > 0.0) {
            return Err(E::FullScale(fs));
        }
        let u_limit = match SignalI16F16::from_f64(self.u_limit_v / fs) {
            Ok(l) if l.raw() > 0 => l,
            _ => return Err(E::OutputLimit(self.u_limit_v)),
        };
        // I_max keeps its 32 fraction bits: rounding it to I16F16 would bias the output by half
        // an LSB whenever the integrator sits at its clamp (most of the twin's limit cycle).
        let integrator_limit_i32f32 = match i32f32_from_f64(self.integrator_limit_v / fs) {
            Some(l) if self.integrator_limit_v >= 0.0 => l,
            _ => return Err(E::IntegratorLimit(self.integrator_limit_v)),
        };
        let n = self.derivative_samples;
        if !(1..=MAX_DERIVATIVE_SAMPLES).contains(&n) {
            return Err(E::DerivativeSamples(n));
        }
        let kp = Gain::from_f64(self.kp_v_per_quantum / fs).ok_or(E::Kp(self.kp_v_per_quantum))?;
        let ki_ts = Gain::from_f64(self.ki_v_per_quantum_s * ts / fs)
            .ok_or(E::Ki(self.ki_v_per_quantum_s))?;
        let kd = Gain::from_f64(self.kd_v_s_per_quantum / (f64::from(n) * ts) / fs)
            .ok_or(E::Kd(self.kd_v_s_per_quantum))?;
        let beta = pole_u1f31(self.derivative_lowpass_hz, ts)
            .ok_or(E::DerivativeLowPass(self.derivative_lowpass_hz))?;
        let alpha = pole_u1f31(self.reference_lowpass_hz, ts)
            .ok_or(E::ReferenceLowPass(self.reference_lowpass_hz))?;
        let config = PidConfig {
            kp,
            ki_ts,
            kd,
            integrator_limit_i32f32,
            u_limit_i32f32: i64::from(u_limit.raw()) << 16,
            derivative_on: self.derivative_on,
            derivative_samples: n,
            beta_u1f31: beta,
            prefilter: alpha != 0,
            one_minus_alpha_u1f31: ONE_U1F31 - alpha,
        };
        config.validate()?;
        Ok(config)
    }
}

/// Validated, quantised controller configuration (`Copy`; swap it between samples without
/// touching the state — the state holds nothing that depends on it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidConfig {
    kp: Gain,
    ki_ts: Gain,
    /// Kd/(n·Ts).
    kd: Gain,
    integrator_limit_i32f32: i64,
    u_limit_i32f32: i64,
    derivative_on: DerivativeOn,
    derivative_samples: u8,
    /// Derivative low-pass pole β (0: off).
    beta_u1f31: u32,
    prefilter: bool,
    /// 1 − α of the reference prefilter.
    one_minus_alpha_u1f31: u32,
}

/// Everything a step mutates.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PidState {
    /// Prefiltered reference r_f, I48F16 raw.
    r_f: i64,
    /// w(k−1) … w(k−4), I48F16 raw.
    history: [i64; MAX_DERIVATIVE_SAMPLES as usize],
    /// Filtered moving sum s, I16F16 raw.
    rate: i32,
    /// Integral term I, I32F32.
    integral_i32f32: i64,
    primed: bool,
    enabled: bool,
    manual_u: SignalI16F16,
}

impl Default for PidState {
    fn default() -> Self {
        Self::new()
    }
}

impl PidState {
    /// A fresh state: integrator at zero, unprimed (the first step primes the derivative history
    /// and the prefilter), enabled, manual output zero.
    pub const fn new() -> Self {
        Self {
            r_f: 0,
            history: [0; MAX_DERIVATIVE_SAMPLES as usize],
            rate: 0,
            integral_i32f32: 0,
            primed: false,
            enabled: true,
            manual_u: SignalI16F16::ZERO,
        }
    }

    /// Back to [`PidState::new`] (enable and manual output included).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// Enables (true) or switches to manual (false): while disabled the output is the manual value
    /// and the integrator tracks it, so re-enabling is bumpless.
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// True unless in manual.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// The output while disabled, fraction of full scale (clamped to ±u_max when applied).
    pub fn set_manual_output(&mut self, u: SignalI16F16) {
        self.manual_u = u;
    }

    /// The integral term, fraction of full scale (rounded to I16F16).
    pub fn integral(&self) -> SignalI16F16 {
        // |I| ≤ I_max ≤ i32::MAX·2^16 (checked when built): never saturates.
        SignalI16F16::from_raw(sat_i32(shr_round_i64(self.integral_i32f32, 16), &mut false))
    }

    /// The prefiltered reference r_f of the last step (r itself without a prefilter).
    pub fn filtered_reference(&self) -> PositionI48F16 {
        PositionI48F16::from_raw(self.r_f)
    }
}

impl PidConfig {
    /// The invariants the step relies on, checked by [`PidDesign::build`] and by the decoding of
    /// configuration words alike: valid gains, `0 ≤ I_max ≤ i32::MAX·2¹⁶`, `0 < u_max ≤
    /// i32::MAX·2¹⁶` on the I16F16 grid, `1 ≤ n ≤ 4`, β and 1 − α in U1F31 [0, 1], and the
    /// prefilter on exactly when α ≠ 0.
    ///
    /// # Errors
    /// The [`ConfigError`] naming the parameter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        use ConfigError as E;
        let volts = |raw: i64| from_fixed(raw, 32); // a fraction of full scale
        for (g, e) in [
            (self.kp, E::Kp(f64::NAN)),
            (self.ki_ts, E::Ki(f64::NAN)),
            (self.kd, E::Kd(f64::NAN)),
        ] {
            if !g.is_valid() {
                return Err(e);
            }
        }
        if !(0..=LIMIT_I32F32_MAX).contains(&self.integrator_limit_i32f32) {
            return Err(E::IntegratorLimit(volts(self.integrator_limit_i32f32)));
        }
        let u = self.u_limit_i32f32;
        if !(u > 0 && u <= LIMIT_I32F32_MAX && u & 0xffff == 0) {
            return Err(E::OutputLimit(volts(u)));
        }
        if !(1..=MAX_DERIVATIVE_SAMPLES).contains(&self.derivative_samples) {
            return Err(E::DerivativeSamples(self.derivative_samples));
        }
        if self.beta_u1f31 > ONE_U1F31 {
            return Err(E::DerivativeLowPass(f64::NAN));
        }
        if self.one_minus_alpha_u1f31 > ONE_U1F31
            || self.prefilter != (self.one_minus_alpha_u1f31 != ONE_U1F31)
        {
            return Err(E::ReferenceLowPass(f64::NAN));
        }
        Ok(())
    }

    /// A fresh state (the same as [`PidState::new`]).
    pub const fn new_state(&self) -> PidState {
        PidState::new()
    }

    /// The output limit u_max, fraction of full scale.
    pub fn u_limit(&self) -> SignalI16F16 {
        SignalI16F16::from_raw((self.u_limit_i32f32 >> 16) as i32) // built from an I16F16 value
    }

    /// The integrator limit I_max, fraction of full scale (rounded to I16F16).
    pub fn integrator_limit(&self) -> SignalI16F16 {
        // I_max ≤ i32::MAX·2^16 (checked when built): never saturates.
        SignalI16F16::from_raw(sat_i32(
            shr_round_i64(self.integrator_limit_i32f32, 16),
            &mut false,
        ))
    }

    /// The quantised gains Kp, Ki·Ts and Kd/(n·Ts), fraction of full scale per quantum.
    pub fn gains(&self) -> [Gain; 3] {
        [self.kp, self.ki_ts, self.kd]
    }

    /// One sample: reference `r` and measurement `y` in quanta in, the drive out. Never panics;
    /// every input, `i64::MIN`/`MAX` positions included, gives |u| ≤ u_max.
    pub fn step(&self, state: &mut PidState, r: PositionI48F16, y: PositionI48F16) -> PidOutput {
        let mut flags = PidFlags::NONE;
        let mut sat = false;
        let first = !state.primed;
        state.primed = true;
        // Prefilter: it starts from (and, in manual, follows) the measurement.
        state.r_f = if !self.prefilter {
            r.raw()
        } else if first || !state.enabled {
            y.raw()
        } else {
            let step = mul_i64_u1f31(
                r.raw().saturating_sub(state.r_f),
                self.one_minus_alpha_u1f31,
            );
            state.r_f.saturating_add(step)
        };
        let e_full = state.r_f.saturating_sub(y.raw());
        let e = sat_i32(e_full, &mut sat);
        let w = match self.derivative_on {
            DerivativeOn::Error => e_full,
            DerivativeOn::Measurement => y.raw().saturating_neg(),
        };
        if first {
            state.history = [w; MAX_DERIVATIVE_SAMPLES as usize];
            state.rate = 0;
            flags.insert(PidFlags::FIRST_SAMPLE);
        }
        let [h1, h2, h3, h4] = state.history;
        let oldest = match self.derivative_samples {
            1 => h1,
            2 => h2,
            3 => h3,
            _ => h4,
        };
        state.history = [w, h1, h2, h3];
        let delta = sat_i32(w.saturating_sub(oldest), &mut sat);
        if self.beta_u1f31 == 0 {
            state.rate = delta;
        } else {
            // β·s + (1 − β)·Δ: each product < 2^62, a convex combination of two i32.
            let acc = mul_i32_u32_wide(state.rate, self.beta_u1f31)
                + mul_i32_u32_wide(delta, ONE_U1F31 - self.beta_u1f31);
            state.rate = sat_i32(shr_round_i64(acc, 31), &mut sat);
        }
        // |P|, |D| < 2^62: P + D is exact.
        let pd = self.kp.apply(e) + self.kd.apply(state.rate);
        let u_max = self.u_limit_i32f32;
        let i_max = self.integrator_limit_i32f32;
        let total = if state.enabled {
            let step = integrate(
                &mut state.integral_i32f32,
                self.ki_ts.apply(e),
                pd,
                i_max,
                u_max,
            );
            flags.set_if(PidFlags::INTEGRATOR_LIMITED, step.limited);
            flags.set_if(PidFlags::INTEGRATION_HELD, step.held);
            pd.saturating_add(state.integral_i32f32)
        } else {
            flags.insert(PidFlags::MANUAL);
            let manual = i64::from(state.manual_u.raw()) << 16; // I16F16 → I32F32, < 2^47
            let wanted = manual.saturating_sub(pd);
            state.integral_i32f32 = clamp_sym_i64(wanted, i_max);
            flags.set_if(PidFlags::TRACKING_LIMITED, state.integral_i32f32 != wanted);
            manual
        };
        let clamped = clamp_sym_i64(total, u_max);
        flags.set_if(PidFlags::OUTPUT_SATURATED, clamped != total);
        // |clamped| ≤ u_max < 2^47: the narrowing cannot saturate.
        let u = SignalI16F16::from_raw(sat_i32(shr_round_i64(clamped, 16), &mut sat));
        flags.set_if(PidFlags::ARITHMETIC_SATURATED, sat);
        PidOutput { u, flags }
    }
}

/// The baseline as a servo law: no regions (always `Seek`), no redesign.
impl Controller for PidConfig {
    type State = PidState;
    type Job = ();
    type Design = ();

    fn new_state(&self) -> PidState {
        PidState::new()
    }

    fn step(&self, state: &mut PidState, input: &ControlInput) -> ControlOutput {
        let out = PidConfig::step(self, state, input.r, input.y);
        ControlOutput {
            u: out.u,
            region: Region::Seek,
            flags: out.flags.control(),
        }
    }

    fn redesign_job(&self, _: &mut PidState, _: &[crate::num::fixed::ParamI12F20]) -> Option<()> {
        None
    }

    fn redesign(&self, _: &()) {}

    fn adopt(&self, _: &mut PidState, _: &()) {}

    fn place_job(&self, _: &[crate::num::fixed::ParamI12F20]) {}

    fn placed(_: &()) -> bool {
        true
    }
}

/// Words: 0 `Error`, 1 `Measurement`.
impl Words for DerivativeOn {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(match self {
            Self::Error => 0,
            Self::Measurement => 1,
        })
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let v = r.word();
        r.check(v <= 1);
        if v == 1 {
            Self::Measurement
        } else {
            Self::Error
        }
    }
}

/// Words: kp, ki·Ts, kd, I_max, u_max, derivative_on, n, β, 1 − α (`prefilter` is `α ≠ 0`).
/// Checked as [`PidDesign::build`] makes them: 0 ≤ I_max ≤ 2³¹·2¹⁶, u_max an I16F16 value in
/// (0, 2³¹) shifted to I32F32, 1 ≤ n ≤ [`MAX_DERIVATIVE_SAMPLES`], β and 1 − α in U1F31 ≤ 1.
impl Words for PidConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.kp.put(w)?;
        self.ki_ts.put(w)?;
        self.kd.put(w)?;
        self.integrator_limit_i32f32.put(w)?;
        self.u_limit_i32f32.put(w)?;
        self.derivative_on.put(w)?;
        self.derivative_samples.put(w)?;
        self.beta_u1f31.put(w)?;
        self.one_minus_alpha_u1f31.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let kp = Gain::take(r);
        let ki_ts = Gain::take(r);
        let kd = Gain::take(r);
        let integrator_limit_i32f32 = i64::take(r);
        let u_limit_i32f32 = i64::take(r);
        let derivative_on = DerivativeOn::take(r);
        let derivative_samples = u8::take(r);
        let beta_u1f31 = u32::take(r);
        let one_minus_alpha_u1f31 = u32::take(r);
        Self {
            kp,
            ki_ts,
            kd,
            integrator_limit_i32f32,
            u_limit_i32f32,
            derivative_on,
            derivative_samples,
            beta_u1f31,
            prefilter: one_minus_alpha_u1f31 != ONE_U1F31,
            one_minus_alpha_u1f31,
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    fn baseline() -> PidDesign {
        PidDesign {
            kp_v_per_quantum: 0.015,
            ki_v_per_quantum_s: 200.0,
            kd_v_s_per_quantum: 1.0e-5,
            derivative_lowpass_hz: 1000.0,
            integrator_limit_v: 0.07,
            ..PidDesign::new(0.455e-3, 5.0)
        }
    }

    fn q(counts: i64) -> PositionI48F16 {
        PositionI48F16::from_counts(counts)
    }

    #[test]
    fn zero_error_gives_zero_output() {
        let c = baseline().build().unwrap();
        let mut s = c.new_state();
        for k in 0..10 {
            let o = c.step(&mut s, q(1234), q(1234));
            assert_eq!(o.u, SignalI16F16::ZERO);
            assert_eq!(o.flags.contains(PidFlags::FIRST_SAMPLE), k == 0);
        }
    }

    #[test]
    fn proportional_only_is_exact() {
        let mut d = PidDesign::new(1e-3, 5.0);
        d.kp_v_per_quantum = 0.5; // 0.1 full scale per quantum
        let c = d.build().unwrap();
        let mut s = c.new_state();
        let o = c.step(&mut s, q(3), q(0));
        assert_eq!(o.u.raw(), 19_661); // round(0.3·2^16)
        let o = c.step(&mut s, q(100), q(0));
        assert_eq!(o.u, c.u_limit());
        assert!(o.flags.contains(PidFlags::OUTPUT_SATURATED));
        let o = c.step(&mut s, q(-100), q(0));
        assert_eq!(o.u.raw(), -c.u_limit().raw());
    }

    #[test]
    fn integrator_clamps_and_does_not_wind_into_saturation() {
        let c = baseline().build().unwrap();
        let mut s = c.new_state();
        for _ in 0..50 {
            let o = c.step(&mut s, q(1), q(0));
            assert!(o.u.raw() > 0);
        }
        assert_eq!(s.integral(), c.integrator_limit());
        // A huge error saturates the output: the integrator (already at its limit) stays.
        let o = c.step(&mut s, q(10_000), q(0));
        assert!(o.flags.contains(PidFlags::OUTPUT_SATURATED));
        // Conditional integration: from zero, a saturating error does not grow the integrator.
        let mut s = c.new_state();
        let o = c.step(&mut s, q(10_000), q(0));
        assert!(o.flags.contains(PidFlags::INTEGRATION_HELD));
        assert_eq!(s.integral(), SignalI16F16::ZERO);
    }

    #[test]
    fn manual_mode_tracks_and_enables_without_a_bump() {
        let c = baseline().build().unwrap();
        let mut s = c.new_state();
        s.set_enabled(false);
        let manual = SignalI16F16::from_f64(0.01).unwrap(); // 50 mV, inside I_max = 70 mV
        s.set_manual_output(manual);
        for _ in 0..5 {
            let o = c.step(&mut s, q(2), q(2));
            assert_eq!(o.u, manual);
            assert!(o.flags.contains(PidFlags::MANUAL));
            assert!(!o.flags.contains(PidFlags::TRACKING_LIMITED));
        }
        s.set_enabled(true);
        let o = c.step(&mut s, q(2), q(2));
        assert_eq!(o.u, manual);
        // Beyond I_max the transfer is flagged.
        s.set_enabled(false);
        s.set_manual_output(SignalI16F16::from_f64(0.5).unwrap());
        let o = c.step(&mut s, q(2), q(2));
        assert!(o.flags.contains(PidFlags::TRACKING_LIMITED));
    }

    #[test]
    fn reset_equals_new_and_extreme_positions_do_not_panic() {
        let mut d = baseline();
        d.reference_lowpass_hz = 300.0;
        d.derivative_samples = 3;
        let c = d.build().unwrap();
        let mut s = c.new_state();
        let extremes = [i64::MIN, i64::MAX, 0, -1, 1 << 40];
        for &a in &extremes {
            for &b in &extremes {
                let o = c.step(
                    &mut s,
                    PositionI48F16::from_raw(a),
                    PositionI48F16::from_raw(b),
                );
                assert!(o.u.raw().unsigned_abs() <= c.u_limit().raw().unsigned_abs());
            }
        }
        s.set_enabled(false);
        s.reset();
        assert_eq!(s, PidState::new());
    }

    #[test]
    fn build_names_the_bad_parameter() {
        use ConfigError as E;
        let ok = baseline();
        assert_eq!(
            PidDesign { ts_s: 0.0, ..ok }.build(),
            Err(E::SamplePeriod(0.0))
        );
        assert_eq!(
            PidDesign {
                u_full_scale_v: f64::NAN,
                ..ok
            }
            .build()
            .err()
            .map(|e| matches!(e, E::FullScale(_))),
            Some(true)
        );
        assert_eq!(
            PidDesign {
                u_limit_v: 0.0,
                ..ok
            }
            .build(),
            Err(E::OutputLimit(0.0))
        );
        assert_eq!(
            PidDesign {
                kp_v_per_quantum: 1e6,
                ..ok
            }
            .build(),
            Err(E::Kp(1e6))
        );
        assert_eq!(
            PidDesign {
                ki_v_per_quantum_s: f64::INFINITY,
                ..ok
            }
            .build(),
            Err(E::Ki(f64::INFINITY))
        );
        assert_eq!(
            PidDesign {
                kd_v_s_per_quantum: 1e9,
                ..ok
            }
            .build(),
            Err(E::Kd(1e9))
        );
        assert_eq!(
            PidDesign {
                integrator_limit_v: -1.0,
                ..ok
            }
            .build(),
            Err(E::IntegratorLimit(-1.0))
        );
        assert_eq!(
            PidDesign {
                derivative_samples: 5,
                ..ok
            }
            .build(),
            Err(E::DerivativeSamples(5))
        );
        assert_eq!(
            PidDesign {
                reference_lowpass_hz: -3.0,
                ..ok
            }
            .build(),
            Err(E::ReferenceLowPass(-3.0))
        );
    }

    #[test]
    fn flags_map_to_status() {
        let f = PidFlags::MANUAL | PidFlags::ARITHMETIC_SATURATED;
        assert_eq!(f.status(), Status::HELD | Status::SATURATED);
        assert_eq!(PidFlags::OUTPUT_SATURATED.status(), Status::NONE);
        assert!(f.contains(PidFlags::MANUAL) && !f.contains(PidFlags::FIRST_SAMPLE));
    }
}
