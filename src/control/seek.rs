//! Time-optimal seeks planned from the identified model: the proximate time-optimal
//! servomechanism (PTOS) of storage servos, its braking curve computed from the velocity model the
//! identifier has learnt instead of tuned off-line.
//!
//! # Model (quanta per sample, u in full scale)
//! The identifier's velocity model, read as a first-order velocity v (at the sampling instants)
//! with time constant τ = −Ts/ln a behind a zero-order hold, moves the sled within a sample by
//! only part of what the drive adds to v:
//! ```text
//! v(k+1)  = a·v(k) + b·u_e(k)            u_e = u − u_c·sgn v    (the drive past friction)
//! Δy(k+1) = c₁·v(k) + b₀·u_e(k)          c₁ = τ(1 − a),  b₀ = b·(1 − c₁)/(1 − a)
//! v̂(k)    = (a/c₁)·Δy(k) + (b − a·b₀/c₁)·u_e(k−1)               (v from the last increment)
//! ```
//! (c₁ → 1 and b₀ → b/2 for a → 1; c₁ → 0, v̂ → b·u_e(k−1) for a → 0.)
//!
//! # Braking curve
//! D(w): the distance covered braking from velocity w until it stops, at u_e = −(α·u_max + u_c)
//! or, in the last sample, at what stops it exactly (Δ = c₁·w − b₀·u_b per sample, w ← a·w −
//! b·u_b, u_b = min(α·u_max + u_c, a·w/b), while w > 0).
//! D is increasing; [`BrakingCurve`] tabulates it at 33 speeds `w_j = j·w_top/32` (w_top = b·u_max
//! /(1 − a), the top speed, capped) when a model is placed, outside the interrupt.
//!
//! # Law (per sample, Seek region; e = target − y)
//! ```text
//! e'  = e − c₁·v̂                                    what is left after this sample's coasting
//! v*  = sgn(e')·D⁻¹(|e'|)                            the fastest velocity that still stops at the target
//! v   = ((1 − p)·v* + (p − a)·v̂) / b                 the model's inverse: v(k+1) = p·v̂ + (1 − p)·v*
//! u   = clamp(h⁻¹(v), ±u_max)                        friction compensated, saturated: full drive far away
//! ```
//! Far from the target v* exceeds what the drive can give and u saturates (full drive); nearer,
//! v* follows the braking curve down to the target, braking at the fraction α of the deceleration
//! the model predicts at full drive, which leaves the loop the rest to correct model error. D⁻¹ is
//! a binary search over the table and one linear interpolation: integer arithmetic, one division.
//! α: `alpha_prior` while the controller runs its prior, `alpha` once a model is identified (the
//! identified model is trusted closer to the drive's limit). The law inverts the velocity, not the
//! position increment: the increment's zero at −b₁/b₀ (near −1 for a slow velocity pole) would
//! make an increment-inverting law ring.
//!
//! # Formats
//! Speeds I16F16 raw quanta per sample (`i32`), table distances I16F16 raw quanta (`u32`, up to
//! 65,535 quanta; a longer distance asks for v_top), the law's gains [`Gain`].

use super::ConfigError;
use crate::num::gain::Gain;
use crate::words::{WordReader, WordWriter, Words};

/// Intervals of the braking-curve table (2⁵).
pub const CURVE_INTERVALS_LOG2: u32 = 5;
/// Entries of the braking-curve table.
pub const CURVE_ENTRIES: usize = (1 << CURVE_INTERVALS_LOG2) + 1;
/// Top speed the table is built up to, quanta per sample (a model with a ≈ 1 has none; the
/// table's distances may cap it lower).
pub const V_TOP_MAX: f32 = 16_384.0;
/// Braking steps simulated per table entry before the curve is refused (a model that cannot stop).
const MAX_BRAKING_STEPS: u32 = 1 << 16;

/// User-facing settings of the time-optimal seek.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimeOptimalDesign {
    /// α while the prior drives (before the first identified model), in (0, 1].
    pub alpha_prior: f64,
    /// α once a model is identified, in (0, 1].
    pub alpha: f64,
    /// p while the prior drives, in [0, 1): slower than `velocity_pole`, so that a sled whose
    /// gain b is several times the prior's still follows the curve (the velocity loop's pole is
    /// a − k·(a − p) for a gain error k: stable for k < (1 + a)/(a − p)).
    pub velocity_pole_prior: f64,
    /// p: pole of the velocity loop that follows the curve once a model is identified, in [0, 1).
    pub velocity_pole: f64,
}

impl Default for TimeOptimalDesign {
    fn default() -> Self {
        // Measured on the nominal sled (100 seeks of 20–2,000 tracks): α 0.6 / 0.7 and p = 0.5
        // gave the shortest median; p ≤ 0.3 rings on the sampled velocity's lag. Under the prior
        // p = 0.7: over the plant family (seeds 1, 7 and 2, 200 plants each) the p95 of access /
        // bound fell from 19.3 / 54.9 / 13.5 at p = 0.5 to 10.5 / 13.7 / 8.0 (BENCHMARKS.md,
        // controller, seeks).
        Self {
            alpha_prior: 0.6,
            alpha: 0.7,
            velocity_pole_prior: 0.7,
            velocity_pole: 0.5,
        }
    }
}

impl TimeOptimalDesign {
    /// α ∈ (0, 1], p ∈ [0, 1).
    ///
    /// # Errors
    /// [`ConfigError::SeekDesign`] naming the value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for alpha in [self.alpha_prior, self.alpha] {
            if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
                return Err(ConfigError::SeekDesign(alpha));
            }
        }
        for p in [self.velocity_pole_prior, self.velocity_pole] {
            if !(p.is_finite() && (0.0..1.0).contains(&p)) {
                return Err(ConfigError::SeekDesign(p));
            }
        }
        Ok(())
    }
}

/// Words: α_prior, α, p_prior, p (`f64` bits; validity: [`TimeOptimalDesign::validate`]).
impl Words for TimeOptimalDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.alpha_prior,
            self.alpha,
            self.velocity_pole_prior,
            self.velocity_pole,
        ]
        .put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [alpha_prior, alpha, velocity_pole_prior, velocity_pole] = <[f64; 4]>::take(r);
        Self {
            alpha_prior,
            alpha,
            velocity_pole_prior,
            velocity_pole,
        }
    }
}

/// G(v) at 33 speeds (`Copy`): the braking curve of one model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BrakingCurve {
    /// v_top/32, I16F16 raw quanta per sample (0: no curve).
    v_step: i32,
    /// G(j·v_step), I16F16 raw quanta, increasing.
    g: [u32; CURVE_ENTRIES],
}

impl Default for BrakingCurve {
    fn default() -> Self {
        Self::NONE
    }
}

impl BrakingCurve {
    /// No curve (reference-following seeks): every distance asks for speed 0.
    pub const NONE: Self = Self {
        v_step: 0,
        g: [0; CURVE_ENTRIES],
    };

    /// The curve of the model (a, b, u_c) braking at `alpha`·`u_max` (full scale): `None` when
    /// the model cannot brake (α·u_max + u_c ≤ 0, a not in [0, 1], b ≤ 0, non-finite values) or
    /// D leaves the table's format. f32 arithmetic (the redesign's, outside the interrupt).
    #[allow(clippy::float_arithmetic)]
    pub fn design(a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32) -> Option<Self> {
        let finite = [a, b, u_c, u_max, alpha].iter().all(|x| x.is_finite());
        if !finite || !(0.0..=1.0).contains(&a) || b <= 0.0 || u_max <= 0.0 {
            return None;
        }
        let braking = alpha * u_max + u_c.max(0.0);
        if braking <= 0.0 {
            return None;
        }
        let (c1, b0) = sampled(a, b);
        // The top speed, within V_TOP_MAX and within what the table's distances can hold (a
        // braking distance w²/(2·b·braking) under 60,000 quanta; viscous friction only shortens it).
        let fits = libm::sqrtf(2.0 * b * braking * 60_000.0);
        let w_top = if a < 1.0 {
            b * u_max / (1.0 - a)
        } else {
            V_TOP_MAX
        }
        .min(V_TOP_MAX)
        .min(fits);
        let v_step = (w_top / (CURVE_ENTRIES - 1) as f32 * 65_536.0) as i32;
        if v_step <= 0 {
            return None;
        }
        let mut g = [0u32; CURVE_ENTRIES];
        for (j, gj) in g.iter_mut().enumerate() {
            // The table's own speeds, as the interrupt reads them.
            let mut w = (j as i64 * i64::from(v_step)) as f32 / 65_536.0;
            let mut distance = 0.0f32;
            let mut steps = 0;
            while w > 1e-6 {
                // Full braking, or exactly what stops the sled this sample.
                let u = braking.min(a * w / b);
                distance += c1 * w - b0 * u;
                w = a * w - b * u;
                steps += 1;
                if steps > MAX_BRAKING_STEPS {
                    return None;
                }
            }
            let raw = distance * 65_536.0;
            if raw.is_nan() || raw >= u32::MAX as f32 {
                return None;
            }
            *gj = raw as u32;
        }
        // D may be flat at the bottom (a slow speed stops within one sample without moving a
        // quantum's fraction): keep it strictly increasing by one LSB per entry.
        for j in 1..CURVE_ENTRIES {
            let prev = g.get(j - 1).copied().unwrap_or(0);
            if let Some(gj) = g.get_mut(j) {
                *gj = (*gj).max(prev.saturating_add(1));
            }
        }
        let curve = Self { v_step, g };
        curve.validate().ok().map(|()| curve)
    }

    /// G increasing (strictly past the first entry, which is 0) and a positive step, or the
    /// empty curve.
    ///
    /// # Errors
    /// [`ConfigError::SeekDesign`] otherwise.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if *self == Self::NONE {
            return Ok(());
        }
        let increasing = self.g.windows(2).all(|p| p.first() < p.get(1));
        if self.v_step > 0 && self.g.first() == Some(&0) && increasing {
            Ok(())
        } else {
            Err(ConfigError::SeekDesign(f64::from(self.v_step)))
        }
    }

    /// The curve exists.
    pub fn is_some(&self) -> bool {
        self.v_step > 0
    }

    /// v* = G⁻¹(d) for a distance `d` (I16F16 raw quanta), I16F16 raw quanta per sample: binary
    /// search and linear interpolation; v_top beyond the table. Never panics.
    #[inline]
    pub fn speed(&self, d: u32) -> i32 {
        let last = CURVE_ENTRIES - 1;
        let top = self.g.get(last).copied().unwrap_or(0);
        if d >= top {
            return self.v_step.saturating_mul(last as i32);
        }
        // The largest j with g[j] ≤ d (g[0] = 0 ≤ d < g[last]).
        let (mut lo, mut hi) = (0usize, last);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if self.g.get(mid).is_some_and(|&g| g <= d) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (g0, g1) = (
            self.g.get(lo).copied().unwrap_or(0),
            self.g.get(hi).copied().unwrap_or(u32::MAX),
        );
        let span = u64::from(g1.saturating_sub(g0)).max(1);
        let frac = u64::from(d - g0) * u64::from(self.v_step.unsigned_abs()) / span;
        // < v_step ≤ 2³¹: fits.
        (lo as i32)
            .saturating_mul(self.v_step)
            .saturating_add(frac as i32)
    }

    /// (v_step, G table), for the float64 reference and the tests.
    pub fn table(&self) -> (i32, &[u32; CURVE_ENTRIES]) {
        (self.v_step, &self.g)
    }
}

/// Words: v_step, then the 33 entries of G (validity: [`BrakingCurve::validate`]).
impl Words for BrakingCurve {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.v_step.put(w)?;
        self.g.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            v_step: i32::take(r),
            g: <[u32; CURVE_ENTRIES]>::take(r),
        }
    }
}

/// The seek law's gains and curve for one model (`Copy`, part of the placed gains).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeekPlan {
    /// a/c₁ on Δy (the velocity estimate).
    pub k_dy: Gain,
    /// b − a·b₀/c₁ on the last linear drive (the velocity estimate), quanta per sample per full
    /// scale.
    pub k_drive: Gain,
    /// c₁: the distance this sample coasts, per unit of v̂.
    pub k_coast: Gain,
    /// (1 − p)/b on v*.
    pub k_target: Gain,
    /// (p − a)/b on v̂.
    pub k_velocity: Gain,
    /// G of the model.
    pub curve: BrakingCurve,
}

impl SeekPlan {
    /// No plan (reference-following seeks).
    pub const NONE: Self = Self {
        k_dy: Gain::ZERO,
        k_drive: Gain::ZERO,
        k_coast: Gain::ZERO,
        k_target: Gain::ZERO,
        k_velocity: Gain::ZERO,
        curve: BrakingCurve::NONE,
    };

    /// The plan for the model (a, b, u_c) at `alpha`·`u_max` with velocity pole `p`; `None` as
    /// [`BrakingCurve::design`], or a gain out of [`Gain`]'s format.
    #[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
    pub fn design(a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32, p: f32) -> Option<Self> {
        let curve = BrakingCurve::design(a, b, u_c, u_max, alpha)?;
        let (c1, b0) = sampled(a, b);
        let (k_dy, k_drive) = if c1 > 1e-6 {
            (a / c1, b - a * b0 / c1)
        } else {
            (0.0, b)
        };
        let g = |x: f32| Gain::from_f64(f64::from(x));
        Some(Self {
            k_dy: g(k_dy)?,
            k_drive: g(k_drive)?,
            k_coast: g(c1)?,
            k_target: g((1.0 - p) / b)?,
            k_velocity: g((p - a) / b)?,
            curve,
        })
    }

    /// The gains valid, the curve valid.
    ///
    /// # Errors
    /// [`ConfigError::SeekDesign`] otherwise.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let gains = [
            self.k_dy,
            self.k_drive,
            self.k_coast,
            self.k_target,
            self.k_velocity,
        ];
        if !gains.iter().all(|k| k.is_valid()) {
            return Err(ConfigError::SeekDesign(f64::NAN));
        }
        self.curve.validate()
    }

    /// The law's linear drive (I32F32 full scale, before compensation) for the error `e` (I16F16
    /// raw quanta, any sign), the last position increment `dy` (I16F16 raw quanta per sample) and
    /// the last linear drive `v_last` (I16F16 raw full scale, past friction). Never panics.
    #[inline]
    pub fn drive(&self, e: i32, dy: i32, v_last: i32) -> i64 {
        let v_hat = self.velocity(dy, v_last);
        let coast = crate::num::fixed::sat_i32(shr_round(self.k_coast.apply(v_hat)), &mut false);
        let left = e.saturating_sub(coast);
        let magnitude = self.curve.speed(left.unsigned_abs());
        let v_star = if left < 0 { -magnitude } else { magnitude };
        self.k_target
            .apply(v_star)
            .saturating_add(self.k_velocity.apply(v_hat))
    }

    /// v̂ = (a/c₁)·Δy + (b − a·b₀/c₁)·u_e(k−1) (I16F16 raw quanta per sample, saturating) from the
    /// last increment `dy` and the last linear drive `v_last`.
    #[inline]
    pub fn velocity(&self, dy: i32, v_last: i32) -> i32 {
        crate::num::fixed::sat_i32(
            shr_round(
                self.k_dy
                    .apply(dy)
                    .saturating_add(self.k_drive.apply(v_last)),
            ),
            &mut false,
        )
    }
}

/// I32F32 → I16F16, rounded.
fn shr_round(x: i64) -> i64 {
    crate::num::fixed::shr_round_i64(x, 16)
}

/// (c₁, b₀) of the sampled first-order velocity (module doc): c₁ = τ(1 − a), b₀ = b·(1 − c₁)/(1 − a),
/// τ = −1/ln a samples; (0, b) for a ≤ 0, (1, b/2) for a ≥ 1.
#[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
pub fn sampled(a: f32, b: f32) -> (f32, f32) {
    if a <= 1e-6 {
        (0.0, b)
    } else if a >= 1.0 - 1e-4 {
        (1.0, 0.5 * b)
    } else {
        let c1 = -(1.0 - a) / libm::logf(a);
        (c1, b * (1.0 - c1) / (1.0 - a))
    }
}

/// Words: the five gains, then the curve.
impl Words for SeekPlan {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.k_dy,
            self.k_drive,
            self.k_coast,
            self.k_target,
            self.k_velocity,
        ]
        .put(w)?;
        self.curve.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [k_dy, k_drive, k_coast, k_target, k_velocity] = <[Gain; 5]>::take(r);
        Self {
            k_dy,
            k_drive,
            k_coast,
            k_target,
            k_velocity,
            curve: BrakingCurve::take(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nominal sled: a = 0.8336, b = 23.66, u_c = 0.0075, u_max = 1.
    fn nominal(alpha: f32) -> BrakingCurve {
        BrakingCurve::design(0.8336, 23.66, 0.0075, 1.0, alpha).unwrap()
    }

    #[test]
    fn the_curve_is_the_models_braking_distance() {
        let c = nominal(1.0);
        let (v_step, g) = c.table();
        // Hand-simulated D at j = 8.
        let (c1, b0) = sampled(0.8336, 23.66);
        let braking = 1.0075f64;
        let mut w = 8.0 * v_step as f64 / 65_536.0;
        let mut d = 0.0;
        while w > 1e-6 {
            let u = braking.min(0.8336 * w / 23.66);
            d += f64::from(c1) * w - f64::from(b0) * u;
            w = 0.8336 * w - 23.66 * u;
        }
        assert!(
            (f64::from(g[8]) / 65_536.0 - d).abs() < 1e-2,
            "{} vs {d}",
            g[8]
        );
        // D⁻¹(D(w_j)) = w_j, and in between it interpolates.
        for (j, &gj) in g.iter().enumerate() {
            assert_eq!(c.speed(gj), j as i32 * v_step, "entry {j}");
        }
        let mid = (g[3] + g[4]) / 2;
        let s = c.speed(mid);
        assert!(s > 3 * v_step && s < 4 * v_step);
        // Beyond the table: the top speed.
        assert_eq!(c.speed(u32::MAX), 32 * v_step);
        assert_eq!(c.speed(0), 0);
    }

    #[test]
    fn less_braking_asks_for_less_speed() {
        let (hard, soft) = (nominal(1.0), nominal(0.5));
        let d = 200 << 16;
        assert!(soft.speed(d) < hard.speed(d));
    }

    #[test]
    fn models_that_cannot_brake_have_no_curve() {
        assert!(BrakingCurve::design(0.8, -1.0, 0.0, 1.0, 0.8).is_none());
        assert!(BrakingCurve::design(1.2, 20.0, 0.0, 1.0, 0.8).is_none());
        assert!(BrakingCurve::design(0.8, 20.0, 0.0, 1.0, 0.0).is_none());
        assert!(BrakingCurve::design(f32::NAN, 20.0, 0.0, 1.0, 0.8).is_none());
        // A near-integrator is capped at V_TOP_MAX and still brakes.
        assert!(BrakingCurve::design(1.0, 20.0, 0.0, 1.0, 0.8).is_some());
    }

    #[test]
    fn the_drive_saturates_far_away_and_brakes_near() {
        let plan = SeekPlan::design(0.8336, 23.66, 0.0075, 1.0, 0.85, 0.2).unwrap();
        let far = plan.drive(2000 << 16, 0, 0);
        assert!(far > 1 << 32, "full drive asked for: {far}");
        // Moving fast toward a target 10 quanta away: brake.
        let near = plan.drive(10 << 16, 60 << 16, 1 << 16);
        assert!(near < 0, "{near}");
        // Symmetric.
        assert_eq!(plan.drive(-(2000 << 16), 0, 0), -far);
    }

    #[test]
    fn the_sampled_velocity_moves_the_sled_part_of_its_gain() {
        // The nominal sled: τ = 5.47 samples, c₁ = 0.915, b₀ = 12.1 of 23.66.
        let (c1, b0) = sampled(0.8336, 23.66);
        assert!((c1 - 0.915).abs() < 1e-3, "{c1}");
        assert!((b0 - 12.1).abs() < 0.1, "{b0}");
        assert_eq!(sampled(0.0, 10.0), (0.0, 10.0));
        assert_eq!(sampled(1.0, 10.0), (1.0, 5.0));
    }
}
