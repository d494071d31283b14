//! The velocity observer: a one-state estimator of the sled's velocity on the identified model,
//! so that no control term differentiates the quantised position directly.
//!
//! # Equations
//! With the velocity model of [`crate::control::placement`], `v(k) = a·v(k−1) + b·u(k−1)` (v the
//! position difference over one sample, quanta; u the drive the model sees, full scale):
//! ```text
//! v̂(k) = (1 − l)·(a·v̂(k−1) + b·u(k−1)) + l·Δy(k),     Δy(k) = y(k) − y(k−1)
//! v̄(k) = v̄(k−1) + (v̂(k) − v̄(k−1))/8
//! ```
//! The estimation error obeys `ε(k) = (1 − l)·a·ε(k−1)`: with the model exact the observer's pole
//! is (1 − l)·a, which the placement keeps at or below p_o, and the closed loop's poles are the
//! law's and the observer's (separation). A one-quantum flicker of the reading moves v̂ by l
//! quanta per sample instead of one, and its alternation averages out of v̄ — which a coasting
//! sled keeps: v̄ is what "at rest" is judged by.
//!
//! # Formats
//! v̂, v̄, u, Δy I16F16 (`i32`); the gains (1 − l)·a, (1 − l)·b, l [`Gain`](crate::num::gain::Gain)s
//! into an I32F32 sum (each term < 2⁶², the sum saturating), rounded back to I16F16 (saturating,
//! flagged).

#![deny(clippy::float_arithmetic)]

use crate::control::placement::ModelGains;
use crate::num::fixed::{sat_i32, shr_round_i64};

/// The observer's state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct VelocityObserver {
    /// v̂, I16F16 raw quanta per sample.
    v_hat: i32,
    /// v̄, I16F16 raw quanta per sample.
    v_bar: i32,
}

impl VelocityObserver {
    /// At rest.
    pub const fn new() -> Self {
        Self { v_hat: 0, v_bar: 0 }
    }

    /// One sample: `u_prev_i16f16` the drive the model saw over the last sample, `dy_i16f16` the
    /// measured position difference. Returns v̂(k); `saturated` is set when a narrowing saturated.
    pub fn update(
        &mut self,
        gains: &ModelGains,
        u_prev_i16f16: i32,
        dy_i16f16: i32,
        saturated: &mut bool,
    ) -> i32 {
        let acc = gains
            .obs_a
            .apply(self.v_hat)
            .saturating_add(gains.obs_b.apply(u_prev_i16f16))
            .saturating_add(gains.obs_l.apply(dy_i16f16));
        self.v_hat = sat_i32(shr_round_i64(acc, 16), saturated);
        self.v_bar = self
            .v_bar
            .saturating_add(self.v_hat.saturating_sub(self.v_bar) >> 3);
        self.v_hat
    }

    /// Restarts v̂ at `v_hat` (I16F16 raw quanta per sample), v̄ kept: the hand-over from a
    /// time-optimal seek, whose own estimate is current where the observer lags a hard braking.
    pub fn restart(&mut self, v_hat: i32) {
        self.v_hat = v_hat;
    }

    /// v̂, I16F16 raw quanta per sample.
    pub const fn velocity(&self) -> i32 {
        self.v_hat
    }

    /// v̄ (v̂ low-passed), I16F16 raw quanta per sample.
    pub const fn mean_velocity(&self) -> i32 {
        self.v_bar
    }
}
