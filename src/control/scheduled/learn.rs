//! Learning the seek model's gain from every time-optimal seek (issue 22, item 4): power-on
//! calibration sees a fast sled for one or two samples per push and leaves its gain b up to
//! ≈ 12 % off; a seek of such a sled is itself one to three samples of drive, as exact as that
//! gain (a 5 % error is 15 tracks of overshoot on a 300-track seek). Each seek is a fresh
//! experiment with a known input: the drive the law applied.
//!
//! # Estimator (per seek; positions in quanta, drives in full scale)
//! From the seek's start at rest (reading y₀, direction d = sgn(r − y₀)) the plan's own model runs
//! open loop — no correction from the readings — on the linear drive u_e the model saw (the
//! drive past the Coulomb level it compensated), as the seek observer predicts
//! ([`crate::control::seek`]):
//! ```text
//! x̃ ← x̃ + c₁·ṽ + b₀·u_e(k−1),   ṽ ← a·ṽ + b·u_e(k−1)          (x̃ = ṽ = 0 at the start)
//! p(k) = d·(y(k) − y₀)                                          (progress, quanta)
//! S_xy += d·x̃·p,   S_xx += x̃²                                   (while d·ṽ > 0 and p ≥ max p − 1)
//! ```
//! x̃ is linear in b (c₁ and b₀/b depend on a only), so a sled whose gain is ρ·b moves ρ·x̃: the
//! least-squares ratio r = S_xy/S_xx estimates b_true/b over the seek's motion towards the target,
//! up to the sled's first stop or turn (after which static friction and the settle law decide).
//! A seek is used when √S_xx ≥ 20 quanta (its quantisation error ≤ 2.5 %); r is clamped to
//! [½, 2] (a gate relative to the model, not in absolute quanta).
//!
//! # Across seeks
//! ρ (the learnt gain over θ's) moves half of the way to ρ_in_use·r each seek; when it is more
//! than 1/64 (1.6 %) away from the ratio of the gains in use a redesign is asked for, placed
//! in the background from θ with its gain terms (b and the Coulomb term b·u_c) scaled by ρ
//! ([`crate::control::Controller::redesign`]) at the learnt velocity pole
//! ([`crate::control::TimeOptimalDesign::velocity_pole_learnt`]), adopted through the hand-over
//! like every redesign.
//! ρ stays within [¼, 4] of θ.
//!
//! # Formats
//! x̃ I48F16 raw quanta (`i64`), ṽ I16F16 raw quanta per sample; the sums in quanta² with 8
//! fractional bits (x̃ and p each to 4, `i64`, saturating: ≤ 4,096 samples of ≤ 2¹⁹ quanta); r,
//! ρ I16F16 (`i32`, 1.0 = 65,536), r by one 64-bit division per seek.

#![deny(clippy::float_arithmetic)]

use crate::control::seek::SeekPlan;
use crate::num::fixed::{sat_i32, shr_round_i64};

/// 1.0 in I16F16.
pub const RATIO_ONE: i32 = 1 << 16;
/// √S_xx below this many quanta: the seek is too short to learn from.
pub const MIN_RESPONSE_QUANTA: i64 = 20;
/// Samples of a seek's window at most.
pub const MAX_WINDOW_SAMPLES: u16 = 4096;
/// ρ moves 1/2^this of the way to each seek's estimate.
const WEIGHT_LOG2: u32 = 1;
/// A redesign is asked for when ρ is more than 1/2^this of the ratio in use away from it.
const REDESIGN_LOG2: u32 = 6;
/// One quantum, I48F16 raw.
const QUANTUM: i64 = 1 << 16;
/// x̃ and p to 4 fractional bits for the sums.
const SUM_SHIFT: u32 = 12;

/// The learner's state: the seek under way and the learnt ratio.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeekGainLearner {
    /// A seek's window is open.
    active: bool,
    /// The seek's direction, ±1.
    direction: i8,
    /// Samples in the window.
    samples: u16,
    /// x̃, I48F16 raw quanta.
    x_model: i64,
    /// ṽ, I16F16 raw quanta per sample.
    v_model: i32,
    /// y₀, I48F16 raw quanta.
    y_start: i64,
    /// The furthest progress d·(y − y₀) so far, I48F16 raw quanta.
    progress_max: i64,
    /// S_xy, quanta² · 2⁸.
    sum_xy: i64,
    /// S_xx, quanta² · 2⁸.
    sum_xx: i64,
    /// The last seek's r (unclamped, 0 before any), I16F16.
    estimate: i32,
    /// ρ, I16F16.
    ratio: i32,
    /// The ratio of the gains in use, I16F16.
    ratio_in_use: i32,
    /// Seeks learnt from since the gains in use were placed from calibration.
    seeks: u16,
}

impl Default for SeekGainLearner {
    fn default() -> Self {
        Self::new()
    }
}

impl SeekGainLearner {
    /// Nothing learnt: ρ = 1.
    pub const fn new() -> Self {
        Self {
            active: false,
            direction: 1,
            samples: 0,
            x_model: 0,
            v_model: 0,
            y_start: 0,
            progress_max: 0,
            sum_xy: 0,
            sum_xx: 0,
            estimate: 0,
            ratio: RATIO_ONE,
            ratio_in_use: RATIO_ONE,
            seeks: 0,
        }
    }

    /// ρ, I16F16: the learnt gain over θ's.
    pub const fn ratio(&self) -> i32 {
        self.ratio
    }

    /// The last learnt seek's r = S_xy/S_xx (before the clamp to [½, 2]; 0 before any),
    /// I16F16.
    pub const fn estimate(&self) -> i32 {
        self.estimate
    }

    /// The ratio of the gains in use, I16F16.
    pub const fn ratio_in_use(&self) -> i32 {
        self.ratio_in_use
    }

    /// Seeks learnt from.
    pub const fn seeks(&self) -> u16 {
        self.seeks
    }

    /// Gains placed with ratio `ratio` (I16F16) were adopted.
    pub fn adopt(&mut self, ratio: i32) {
        self.ratio_in_use = ratio;
    }

    /// A seek starts at rest at the reading `y` (I48F16 raw quanta) towards `target`.
    pub fn start(&mut self, y: i64, target: i64) {
        *self = Self {
            active: true,
            direction: if target >= y { 1 } else { -1 },
            y_start: y,
            estimate: self.estimate,
            ratio: self.ratio,
            ratio_in_use: self.ratio_in_use,
            seeks: self.seeks,
            ..Self::new()
        };
    }

    /// One sample of the seek: the plan in use, the linear drive its model saw over the last
    /// sample (I16F16 raw full scale) and the reading (I48F16 raw quanta). Returns true when the
    /// window closed this sample and ρ moved far enough from the gains in use that a redesign
    /// is due.
    pub fn step(&mut self, plan: &SeekPlan, drive: i32, y: i64) -> bool {
        if !self.active {
            return false;
        }
        let mut sat = false;
        let dx = plan.advance(self.v_model, drive);
        let v = shr_round_i64(
            plan.k_a
                .apply(self.v_model)
                .saturating_add(plan.k_b.apply(drive)),
            16,
        );
        self.v_model = sat_i32(v, &mut sat);
        self.x_model = self.x_model.saturating_add(dx);
        self.samples = self.samples.saturating_add(1);
        let d = i64::from(self.direction);
        let progress = y.saturating_sub(self.y_start).saturating_mul(d);
        let turned = progress < self.progress_max.saturating_sub(QUANTUM);
        let stopped = i64::from(self.v_model).saturating_mul(d) <= 0;
        if turned || stopped || sat || self.samples > MAX_WINDOW_SAMPLES {
            return self.finish();
        }
        self.progress_max = self.progress_max.max(progress);
        let x = self.x_model.saturating_mul(d) >> SUM_SHIFT;
        let p = progress >> SUM_SHIFT;
        self.sum_xy = self.sum_xy.saturating_add(x.saturating_mul(p));
        self.sum_xx = self.sum_xx.saturating_add(x.saturating_mul(x));
        false
    }

    /// The seek's window closes (the law left Seek, or [`Self::step`] ended it): ρ learns from it
    /// if the response was long enough. Returns true when a redesign is due.
    pub fn finish(&mut self) -> bool {
        if !self.active {
            return false;
        }
        self.active = false;
        let min = (MIN_RESPONSE_QUANTA * MIN_RESPONSE_QUANTA) << (2 * (16 - SUM_SHIFT));
        if self.sum_xx < min {
            return false;
        }
        // Both sums below 2⁴⁰ before the quotient's 16-bit shift (S_xy ≈ r·S_xx, r ≤ 2 here).
        let shift = (64 - self.sum_xx.leading_zeros()).saturating_sub(40);
        let xx = self.sum_xx >> shift;
        // max/min, not clamp: clamp's bounds check (4·xx ≥ 0 is not provable) pulls `core::fmt`
        // into the firmware image (≈ 0.9 KB of flash on each core).
        let xy = (self.sum_xy >> shift).max(0).min(4 * xx);
        let unclamped = (xy << 16) / xx.max(1); // ≤ 4·2¹⁶
        self.estimate = sat_i32(unclamped, &mut false);
        let r = unclamped.clamp(i64::from(RATIO_ONE / 2), i64::from(2 * RATIO_ONE));
        let estimate = (i64::from(self.ratio_in_use) * r) >> 16;
        let ratio = i64::from(self.ratio);
        let moved = ratio + ((estimate - ratio) >> WEIGHT_LOG2);
        self.ratio = moved.clamp(i64::from(RATIO_ONE / 4), i64::from(4 * RATIO_ONE)) as i32;
        self.seeks = self.seeks.saturating_add(1);
        let off = self.ratio.abs_diff(self.ratio_in_use);
        off > self.ratio_in_use.unsigned_abs() >> REDESIGN_LOG2
    }
}
