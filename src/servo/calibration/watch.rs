//! When to calibrate again (issue 22, item 5): a calibrated servo that does not settle a command
//! within the time its own model allows has a model the sled no longer follows (a mass or
//! friction change, wear). Then it calibrates again from where the sled is, at most once per
//! command, instead of waiting for the safety layer's stop.
//!
//! # Rule (per sample; positions I48F16 raw, quanta)
//! ```text
//! a new command r:   d = |r − y|, budget T = 2·d / v_max + T₀, since = 0, settled = false
//! every sample:      settled once |y − r| ≤ 1 quantum for 22 samples in a row (10 ms at Ts)
//! since = T, not settled, not yet re-calibrated for this command  →  calibrate again
//! ```
//! v_max = K·(1 − u_c) (quanta per sample, the calibrated model's top speed at full drive, at
//! least 1/16) and T₀ = 4/(1 − a) + 220 samples (four time constants and 100 ms), both fixed at
//! the calibration's adoption ([`CalibrationWatch::arm`]). Integer arithmetic on the sample path.

#![deny(clippy::float_arithmetic)]

use super::fit::CalibratedModel;

/// Samples in the band that count as settled (10 ms at Ts = 0.455 ms).
pub const SETTLED_SAMPLES: u16 = 22;

/// The watch's state (in the servo's state).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationWatch {
    /// Armed by a calibrated model.
    armed: bool,
    /// v_max, I16F16 raw quanta per sample (≥ 1/16).
    v_max_i16f16: i64,
    /// T₀, samples.
    base: u32,
    /// The command being watched, I48F16 raw.
    r: i64,
    /// Samples since it.
    since: u32,
    /// Its budget T, samples.
    budget: u32,
    in_band: u16,
    settled: bool,
    /// Re-calibrated for this command already.
    spent: bool,
}

impl CalibrationWatch {
    /// Armed from a calibrated model (f32 arithmetic, at the adoption, not per sample).
    #[allow(clippy::float_arithmetic, clippy::cast_possible_truncation)]
    pub fn arm(model: &CalibratedModel) -> Self {
        let v_max = (model.gain_k * (1.0 - model.coulomb_mean_fs())).max(1.0 / 16.0);
        let v = (v_max * 65536.0).min(1.0e12);
        let tau = 4.0 / (1.0 - model.a).max(1.0 / 4096.0);
        Self {
            armed: true,
            v_max_i16f16: v as i64,
            base: (tau.min(1.0e6) as u32).saturating_add(220),
            // No command yet: the first sample arms the first budget.
            r: i64::MIN,
            ..Self::default()
        }
    }

    /// One sample: the command `r` and the reading `y` (I48F16 raw). True when the servo should
    /// calibrate again now.
    pub fn step(&mut self, r: i64, y: i64) -> bool {
        if !self.armed {
            return false;
        }
        let e = r.saturating_sub(y).unsigned_abs();
        if r != self.r {
            self.r = r;
            self.since = 0;
            self.in_band = 0;
            self.settled = false;
            self.spent = false;
            // 2·d / v_max, both I16F16: the quotient is in samples.
            let travel = (e.min(1 << 47) as i64).saturating_mul(2) / self.v_max_i16f16.max(1);
            self.budget = u32::try_from(travel)
                .unwrap_or(u32::MAX)
                .saturating_add(self.base);
            return false;
        }
        self.since = self.since.saturating_add(1);
        if e <= 1 << 16 {
            self.in_band = self.in_band.saturating_add(1);
            self.settled |= self.in_band >= SETTLED_SAMPLES;
        } else {
            self.in_band = 0;
        }
        if self.since == self.budget && !self.settled && !self.spent {
            self.spent = true;
            return true;
        }
        false
    }

    /// The watch for a newly adopted calibration: armed from `model`; after a re-calibration
    /// (this watch was armed) the command in progress stays watched with the new model but is not
    /// re-calibrated again.
    pub fn adopt(&self, model: &CalibratedModel) -> Self {
        let mut w = Self::arm(model);
        if self.armed {
            w.r = self.r;
            w.spent = true;
            w.budget = u32::MAX;
        }
        w
    }
}
