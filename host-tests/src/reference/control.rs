//! The position controller of [`sledid::control`] in `f64` ([`PidF64`]), the fixed-point controller
//! behind the twin's [`SledController`] interface ([`FixedPid`]), and the designs that make it the
//! twin's baseline ([`baseline_design`]) and the EMPS rig's controller ([`emps_design`]).
//!
//! [`PidF64`] implements the law of the `sledid::control` module documentation term by term, in
//! volts and quanta, without quantisation: it is what the fixed-point path is measured against.
//! Built from the same [`PidDesign`] (validated by [`PidDesign::build`], so both accept the same
//! designs).

use sledid::PositionI48F16;
use sledid::control::{ConfigError, DerivativeOn, PidConfig, PidDesign, PidFlags, PidState};
use sledid::num::fixed::SignalI16F16;

use crate::twin::{PidParams, SledController};

/// EMPS position-loop gain kp, 1/s (`shared/data/README.md`).
pub const EMPS_KP_PER_S: f64 = 160.18;
/// EMPS velocity-loop gain kv, V/(m/s).
pub const EMPS_KV_V_S_PER_M: f64 = 243.45;
/// EMPS encoder quantum, m.
pub const EMPS_QUANTUM_M: f64 = 5e-8;
/// EMPS sampling period of the controller, s.
pub const EMPS_TS_S: f64 = 1e-3;
/// Full scale used for the EMPS drive, V.
pub const EMPS_U_FULL_SCALE_V: f64 = 10.0;

/// The design that reproduces the twin's baseline `PidController`: derivative on the error over
/// one sample, low-passed at `d_filter_hz`; the output unit is the amplifier rail `u_max_v`.
pub fn baseline_design(params: &PidParams, ts_s: f64, u_max_v: f64) -> PidDesign {
    PidDesign {
        kp_v_per_quantum: params.kp_v_per_count,
        ki_v_per_quantum_s: params.ki_v_per_count_s,
        kd_v_s_per_quantum: params.kd_v_s_per_count,
        integrator_limit_v: params.integrator_limit_v,
        derivative_lowpass_hz: params.d_filter_hz,
        ..PidDesign::new(ts_s, u_max_v)
    }
}

/// The EMPS rig's controller `vir = kp·kv·(qg − qm) − kv·v̂`, v̂ = (qm(k) − qm(k−2))/(2·Ts), in
/// encoder counts, ±10 V.
pub fn emps_design() -> PidDesign {
    PidDesign::position_velocity_cascade(
        EMPS_TS_S,
        EMPS_U_FULL_SCALE_V,
        EMPS_KP_PER_S,
        EMPS_KV_V_S_PER_M * EMPS_QUANTUM_M,
    )
}

/// `e^{−2π·f·Ts}`, 0 for `f = 0` (filter off).
fn pole(corner_hz: f64, ts_s: f64) -> f64 {
    if corner_hz == 0.0 {
        0.0
    } else {
        (-2.0 * std::f64::consts::PI * corner_hz * ts_s).exp()
    }
}

/// The controller law in `f64`: volts, quanta, seconds.
#[derive(Clone, Debug, PartialEq)]
pub struct PidF64 {
    design: PidDesign,
    /// Derivative low-pass pole β.
    beta: f64,
    /// Prefilter pole α (0: off).
    alpha: f64,
    r_f: f64,
    history: [f64; 4],
    rate: f64,
    integral_v: f64,
    primed: bool,
    enabled: bool,
    manual_v: f64,
}

impl PidF64 {
    /// A controller in its initial state.
    ///
    /// # Errors
    /// The [`ConfigError`] of [`PidDesign::build`].
    pub fn new(design: &PidDesign) -> Result<Self, ConfigError> {
        design.build()?;
        Ok(Self {
            design: *design,
            beta: pole(design.derivative_lowpass_hz, design.ts_s),
            alpha: pole(design.reference_lowpass_hz, design.ts_s),
            r_f: 0.0,
            history: [0.0; 4],
            rate: 0.0,
            integral_v: 0.0,
            primed: false,
            enabled: true,
            manual_v: 0.0,
        })
    }

    /// Back to the initial state.
    pub fn reset(&mut self) {
        if let Ok(fresh) = Self::new(&self.design) {
            *self = fresh;
        }
    }

    /// Enables (true) or switches to manual (false).
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }

    /// The output while disabled, V.
    pub fn set_manual_output_v(&mut self, u_v: f64) {
        self.manual_v = u_v;
    }

    /// The integral term, V.
    pub fn integral_v(&self) -> f64 {
        self.integral_v
    }

    /// One sample: `r` and `y` in quanta, the drive in volts.
    pub fn step_quanta(&mut self, r: f64, y: f64) -> f64 {
        let d = &self.design;
        let first = !self.primed;
        self.primed = true;
        let prefilter = self.alpha != 0.0;
        self.r_f = if !prefilter {
            r
        } else if first || !self.enabled {
            y
        } else {
            self.r_f + (1.0 - self.alpha) * (r - self.r_f)
        };
        let e = self.r_f - y;
        let w = match d.derivative_on {
            DerivativeOn::Error => e,
            DerivativeOn::Measurement => -y,
        };
        if first {
            self.history = [w; 4];
            self.rate = 0.0;
        }
        let n = usize::from(d.derivative_samples);
        let delta = w - self.history[n - 1];
        self.history.rotate_right(1);
        self.history[0] = w;
        self.rate = self.beta * self.rate + (1.0 - self.beta) * delta;
        let kd_v = d.kd_v_s_per_quantum / (n as f64 * d.ts_s);
        let pd = d.kp_v_per_quantum * e + kd_v * self.rate;
        let (u_max, i_max) = (d.u_limit_v, d.integrator_limit_v);
        let total = if self.enabled {
            let previous = self.integral_v;
            let candidate = (previous + d.ki_v_per_quantum_s * d.ts_s * e).clamp(-i_max, i_max);
            let unsaturated = pd + candidate;
            let winding = (unsaturated > u_max && candidate > previous)
                || (unsaturated < -u_max && candidate < previous);
            if !winding {
                self.integral_v = candidate;
            }
            pd + self.integral_v
        } else {
            self.integral_v = (self.manual_v - pd).clamp(-i_max, i_max);
            self.manual_v
        };
        total.clamp(-u_max, u_max)
    }
}

impl SledController for PidF64 {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        self.step_quanta(r_counts, y_counts)
    }
}

/// Quanta as `f64` → I48F16, rounded; saturating at the `i64` range, NaN → 0.
pub fn position_from_quanta(x: f64) -> PositionI48F16 {
    PositionI48F16::from_raw((x * 65_536.0).round() as i64)
}

/// The fixed-point controller ([`PidConfig::step`]) as a [`SledController`]: counts in (converted
/// to I48F16), volts out (`u · u_full_scale_v`).
#[derive(Clone, Debug, PartialEq)]
pub struct FixedPid {
    config: PidConfig,
    state: PidState,
    u_full_scale_v: f64,
    last_flags: PidFlags,
}

impl FixedPid {
    /// The controller of `design`, in its initial state.
    ///
    /// # Errors
    /// The [`ConfigError`] of [`PidDesign::build`].
    pub fn new(design: &PidDesign) -> Result<Self, ConfigError> {
        let config = design.build()?;
        Ok(Self {
            config,
            state: config.new_state(),
            u_full_scale_v: design.u_full_scale_v,
            last_flags: PidFlags::NONE,
        })
    }

    /// One sample with positions already in the fixed-point domain; the drive in volts.
    pub fn step_positions(&mut self, r: PositionI48F16, y: PositionI48F16) -> f64 {
        let out = self.config.step(&mut self.state, r, y);
        self.last_flags = out.flags;
        out.u.to_f64() * self.u_full_scale_v
    }

    /// The flags of the last step.
    pub fn last_flags(&self) -> PidFlags {
        self.last_flags
    }

    /// The configuration.
    pub fn config(&self) -> &PidConfig {
        &self.config
    }

    /// The state (mutable: enable, manual output, reset).
    pub fn state_mut(&mut self) -> &mut PidState {
        &mut self.state
    }

    /// The manual output in volts, converted to the fixed-point full-scale fraction (saturating).
    pub fn set_manual_output_v(&mut self, u_v: f64) {
        let u = SignalI16F16::from_f64(u_v / self.u_full_scale_v).unwrap_or(if u_v > 0.0 {
            SignalI16F16::MAX
        } else {
            SignalI16F16::MIN
        });
        self.state.set_manual_output(u);
    }
}

impl SledController for FixedPid {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        self.step_positions(
            position_from_quanta(r_counts),
            position_from_quanta(y_counts),
        )
    }
}
