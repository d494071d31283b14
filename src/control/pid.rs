//! The PID/lead position controller: [`PidDesign`] (floats, engineering units) → [`PidConfig`]
//! (validated, quantised, `Copy`) + [`PidState`]; one [`PidConfig::step`] per sample.
//!
//! The law, the formats and the range analysis are in the [module documentation](super).
//!
//! # Cost
//! `bench_pid_step` (`src/bin/bench.rs`: prefilter, n = 1 low-pass derivative and integrator all
//! on; `count_insns.py`, 256 calls after 64, including ~26/29 instructions of bench scaffolding):
//! Cortex-M4F 437 instructions ≈ 546 cycles; Cortex-M0+ 945 instructions ≈ 1,350 cycles.

#![deny(clippy::float_arithmetic)]

use super::{
    ConfigError, ControlFlags, ControlOutput, Gain, LIMIT_I32F32_MAX, ONE_U1F31, clamp_sym_i64,
    mul_i64_u1f31,
};
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::{SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::mul_i32_u32_wide;
use crate::words::{WordReader, WordWriter, Words};

/// Longest moving sum of position differences in the derivative (history length).
pub const MAX_DERIVATIVE_SAMPLES: u8 = 4;

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
        let integrator_limit_i32f32 = match super::i32f32_from_f64(self.integrator_limit_v / fs) {
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
        let beta = super::pole_u1f31(self.derivative_lowpass_hz, ts)
            .ok_or(E::DerivativeLowPass(self.derivative_lowpass_hz))?;
        let alpha = super::pole_u1f31(self.reference_lowpass_hz, ts)
            .ok_or(E::ReferenceLowPass(self.reference_lowpass_hz))?;
        Ok(PidConfig {
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
        })
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
    pub fn step(
        &self,
        state: &mut PidState,
        r: PositionI48F16,
        y: PositionI48F16,
    ) -> ControlOutput {
        let mut flags = ControlFlags::NONE;
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
            flags.insert(ControlFlags::FIRST_SAMPLE);
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
            let previous = state.integral_i32f32;
            let wanted = previous.saturating_add(self.ki_ts.apply(e));
            let candidate = clamp_sym_i64(wanted, i_max);
            flags.set_if(ControlFlags::INTEGRATOR_LIMITED, candidate != wanted);
            let unsaturated = pd.saturating_add(candidate);
            let winding = (unsaturated > u_max && candidate > previous)
                || (unsaturated < -u_max && candidate < previous);
            if winding {
                flags.insert(ControlFlags::INTEGRATION_HELD);
            } else {
                state.integral_i32f32 = candidate;
            }
            pd.saturating_add(state.integral_i32f32)
        } else {
            flags.insert(ControlFlags::MANUAL);
            let manual = i64::from(state.manual_u.raw()) << 16; // I16F16 → I32F32, < 2^47
            let wanted = manual.saturating_sub(pd);
            state.integral_i32f32 = clamp_sym_i64(wanted, i_max);
            flags.set_if(
                ControlFlags::TRACKING_LIMITED,
                state.integral_i32f32 != wanted,
            );
            manual
        };
        let clamped = clamp_sym_i64(total, u_max);
        flags.set_if(ControlFlags::OUTPUT_SATURATED, clamped != total);
        // |clamped| ≤ u_max < 2^47: the narrowing cannot saturate.
        let u = SignalI16F16::from_raw(sat_i32(shr_round_i64(clamped, 16), &mut sat));
        flags.set_if(ControlFlags::ARITHMETIC_SATURATED, sat);
        ControlOutput { u, flags }
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
        r.check((0..=LIMIT_I32F32_MAX).contains(&integrator_limit_i32f32));
        let u_limit_i32f32 = i64::take(r);
        r.check(
            u_limit_i32f32 > 0
                && u_limit_i32f32 <= LIMIT_I32F32_MAX
                && u_limit_i32f32 & 0xffff == 0,
        );
        let derivative_on = DerivativeOn::take(r);
        let derivative_samples = u8::take(r);
        r.check((1..=MAX_DERIVATIVE_SAMPLES).contains(&derivative_samples));
        let beta_u1f31 = u32::take(r);
        r.check(beta_u1f31 <= ONE_U1F31);
        let one_minus_alpha_u1f31 = u32::take(r);
        r.check(one_minus_alpha_u1f31 <= ONE_U1F31);
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
            assert_eq!(o.flags.contains(ControlFlags::FIRST_SAMPLE), k == 0);
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
        assert!(o.flags.contains(ControlFlags::OUTPUT_SATURATED));
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
        assert!(o.flags.contains(ControlFlags::OUTPUT_SATURATED));
        // Conditional integration: from zero, a saturating error does not grow the integrator.
        let mut s = c.new_state();
        let o = c.step(&mut s, q(10_000), q(0));
        assert!(o.flags.contains(ControlFlags::INTEGRATION_HELD));
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
            assert!(o.flags.contains(ControlFlags::MANUAL));
            assert!(!o.flags.contains(ControlFlags::TRACKING_LIMITED));
        }
        s.set_enabled(true);
        let o = c.step(&mut s, q(2), q(2));
        assert_eq!(o.u, manual);
        // Beyond I_max the transfer is flagged.
        s.set_enabled(false);
        s.set_manual_output(SignalI16F16::from_f64(0.5).unwrap());
        let o = c.step(&mut s, q(2), q(2));
        assert!(o.flags.contains(ControlFlags::TRACKING_LIMITED));
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
}
