//! The controller interface of the twin and the paper's baseline controller, a PID with a
//! filtered derivative (lead), a clamped integrator and output saturation, in f64.
//!
//! # Baseline law
//! With the error `e(k) = r(k) − y(k)` in counts (quanta), `β = e^{−2π·d_filter_hz·Ts}`:
//! ```text
//! I(k) = clamp(I(k−1) + Ki·Ts·e(k), ±integrator_limit_v)   (held while the output saturates in the direction of e)
//! D(k) = β·D(k−1) + (1 − β)·Kd·(e(k) − e(k−1))/Ts          (D = 0 on the first sample)
//! u(k) = clamp(Kp·e(k) + I(k) + D(k), ±u_max_v)
//! ```
//!
//! # Why it ends in a ±1-quantum limit cycle
//! Once the reference is constant the error is an integer, and the integrator is the badly tuned
//! part: whatever it holds in the zero-error cell is either below breakaway (the sled rests there)
//! or not (it coasts on into the opposite cell, where the integrator reverses). The limit cycle is
//! the integrator building up to breakaway at `e = ±1`, a pulse that carries the sled across the
//! target, and the same from the other side. As the paper concludes, the oscillation is
//! controller induced.
//!
//! With the defaults ([`PidParams::default`], the paper's loop) the integrator gains 3.6 mV per
//! sample at one track of error and is clamped at ±0.3 V: through a seek it winds up, the sled
//! overshoots by ~10 tracks and swings back and forth for ~90 samples (the paper's settling
//! oscillation), then hunts `…, +1, …, +1, 0, −1, …, −1, 0, +1, …` with a period of about 77
//! samples (35 ms), one pulse above breakaway per half period. The way out, the sled at rest in
//! the zero cell with `|I|` below breakaway, is reached in 70 of 1,200 random seeks (seeds 0–199,
//! default noise; `tests/integration/twin.rs`).
//!
//! With [`PidParams::well_damped`] (the earlier default) the P and D terms make a loop of about
//! 90 Hz that rings down within a few samples, and the integrator moves 91 mV per sample at one
//! track and is clamped at ±70 mV, just above the breakaway voltage (62.5 mV): at `e = ±1` it
//! swings to its clamp within one or two samples, and in the zero cell it holds a value above the
//! Coulomb voltage (37.5 mV), so the sled coasts on. The measurement hunts
//! `…, 0, −1, −1, −1, 0, +1, +1, +1, 0, …` with a period of about 12 samples, the drive a train of
//! ±(50…90) mV pulses; it rests in the zero cell in 0 of 1,800 random seeks without noise, 1 of
//! 1,800 with the default noise.

use super::params::PidParams;

/// A controller that can be put in the twin's loop.
///
/// Closures `FnMut(r_counts, y_counts) -> u_v` implement it too.
pub trait SledController {
    /// One sample: the reference `r_counts` and the quantized measurement `y_counts` (both in
    /// quanta) in, the drive command in volts out (the twin's amplifier saturates it).
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64;
}

impl<F: FnMut(f64, f64) -> f64> SledController for F {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        self(r_counts, y_counts)
    }
}

/// The paper's baseline controller; see the module documentation for the law.
#[derive(Clone, Debug, PartialEq)]
pub struct PidController {
    /// Proportional gain, V/count.
    kp_v_per_count: f64,
    /// Integrator increment per count of error and sample, V/count (`Ki·Ts`).
    ki_ts_v_per_count: f64,
    /// Derivative gain over the sampling interval, V/count (`Kd/Ts`).
    kd_over_ts_v_per_count: f64,
    /// Derivative filter pole β.
    d_filter_pole: f64,
    /// Integrator clamp, V.
    integrator_limit_v: f64,
    /// Output saturation, V.
    u_max_v: f64,
    /// Integral term, V.
    integral_v: f64,
    /// Filtered derivative term, V.
    derivative_v: f64,
    /// Error of the previous sample, counts (`None` before the first sample).
    previous_error_counts: Option<f64>,
}

impl PidController {
    /// A controller in its initial state for sampling interval `ts_s` and output limit `u_max_v`
    /// (parameters assumed validated).
    pub fn new(params: &PidParams, ts_s: f64, u_max_v: f64) -> Self {
        Self {
            kp_v_per_count: params.kp_v_per_count,
            ki_ts_v_per_count: params.ki_v_per_count_s * ts_s,
            kd_over_ts_v_per_count: params.kd_v_s_per_count / ts_s,
            d_filter_pole: (-2.0 * std::f64::consts::PI * params.d_filter_hz * ts_s).exp(),
            integrator_limit_v: params.integrator_limit_v,
            u_max_v,
            integral_v: 0.0,
            derivative_v: 0.0,
            previous_error_counts: None,
        }
    }

    /// Returns to the initial state (integrator and derivative cleared).
    pub fn reset(&mut self) {
        self.integral_v = 0.0;
        self.derivative_v = 0.0;
        self.previous_error_counts = None;
    }

    /// The integral term, V.
    pub fn integral_v(&self) -> f64 {
        self.integral_v
    }
}

impl SledController for PidController {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let error_counts = r_counts - y_counts;
        let proportional_v = self.kp_v_per_count * error_counts;
        self.derivative_v = match self.previous_error_counts {
            Some(previous) => {
                let raw_v = self.kd_over_ts_v_per_count * (error_counts - previous);
                self.d_filter_pole * self.derivative_v + (1.0 - self.d_filter_pole) * raw_v
            }
            None => 0.0,
        };
        self.previous_error_counts = Some(error_counts);
        let candidate_integral_v = (self.integral_v + self.ki_ts_v_per_count * error_counts)
            .clamp(-self.integrator_limit_v, self.integrator_limit_v);
        let unsaturated_v = proportional_v + candidate_integral_v + self.derivative_v;
        // Conditional integration: do not wind further into a saturated output.
        let winding_up = unsaturated_v.abs() > self.u_max_v
            && (candidate_integral_v - self.integral_v) * unsaturated_v > 0.0;
        if !winding_up {
            self.integral_v = candidate_integral_v;
        }
        (proportional_v + self.integral_v + self.derivative_v).clamp(-self.u_max_v, self.u_max_v)
    }
}
