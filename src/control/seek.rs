//! Time-optimal seeks planned from the identified model: each sample the drive whose predicted
//! stop point is the target, on a model-based observer of position and velocity — right in
//! discrete time when a seek lasts only a few samples (a fast sled crosses 100 tracks in one to
//! three samples of full drive), where a braking curve followed by a velocity loop lands late or
//! overshoots.
//!
//! # Model (quanta per sample, u in full scale)
//! The identifier's velocity model, read as a first-order velocity v (at the sampling instants)
//! with time constant τ = −Ts/ln a behind a zero-order hold, moves the sled within a sample by
//! only part of what the drive adds to v:
//! ```text
//! v(k+1) = a·v(k) + b·u_e(k)            u_e = u − u_c·sgn v    (the drive past friction)
//! x(k+1) = x(k) + c₁·v(k) + b₀·u_e(k)   c₁ = τ(1 − a),  b₀ = b·(1 − c₁)/(1 − a)
//! ```
//! (c₁ → 1 and b₀ → b/2 for a → 1; c₁ → 0, b₀ → b for a → 0.)
//!
//! # Observer ([`SeekObserver`], every sample, before the law)
//! The reading y is the position rounded to the nearest quantum, so it says only which cell the
//! sled is in. The observer propagates (x̂, v̂) with the model and the drive actually applied, and
//! corrects only when the reading leaves the predicted cell, by what it lies outside it:
//! ```text
//! x̂ ← x̂ + c₁·v̂ + b₀·u_e(k−1),   v̂ ← a·v̂ + b·u_e(k−1)                  (predict)
//! d = y − x̂;  if |d| > ½:  δ = d − sgn(d)·½,  x̂ ← x̂ + δ,  v̂ ← v̂ + l_v·δ    (correct)
//! ```
//! l_v = ½·a/c₁: a velocity error ε shows as c₁·ε of position a sample later, when the velocity
//! error is a·ε; half of it is taken (the part of d inside the cell is unknown). On a slow sled
//! (a fraction of a quantum per sample) the increments of y are 0 or 1 and say nothing about the
//! speed; the model does.
//!
//! # Stop point and law (per sample, Seek region; e = target − x̂)
//! S(u): where the sled stops if it is driven at u for this sample, then braked at
//! u_e = −(α·u_max + u_c) until it stops — in the last sample at what stops it exactly:
//! ```text
//! S(u) = x̂ + c₁·v̂ + b₀·u_e + sgn(w)·D(|w|),   w = a·v̂ + b·u_e   (the velocity after this sample)
//! D(w): braking distance from w (Δ = c₁·w − b₀·u_b per sample, w ← a·w − b·u_b,
//!       u_b = min(α·u_max + u_c, a·w/b), while w > 0)
//! ```
//! S is increasing in u; with u_e = (w − a·v̂)/b, S = target reads K(w) = e − (c₁ − a·b₀/b)·v̂ with
//! K(w) = D(w) + (b₀/b)·w, increasing and odd. [`BrakingCurve`] tabulates K at 33 speeds
//! `w_j = j·w_top/32` (w_top = b·u_max/(1 − a), the top speed, capped) when a model is placed,
//! outside the interrupt, so the interrupt solves S(u) = target by one binary search over the
//! table and one linear interpolation (integer arithmetic, one division):
//! ```text
//! e″ = e − (c₁ − a·b₀/b)·v̂
//! w* = sgn(e″)·K⁻¹(|e″|)                       the velocity after this sample that stops at the target
//! u  = clamp(h⁻¹(((1 − p)·w* + (p − a)·v̂)/b), ±u_max)     friction compensated, saturated
//! ```
//! With p = 0 the model lands exactly: full drive while even full drive stops short, then the
//! braking curve, the last samples' drives below full scale, at rest on the target. p > 0 reaches
//! w* only in part (v(k+1) = p·v̂ + (1 − p)·w* in the model), which keeps the loop stable for a
//! sled whose gain is up to (1 + a)/(a − p) times the model's — the prior's setting. α < 1 leaves
//! the loop a margin of braking for a sled weaker than its model.
//!
//! **Uncompensated drives.** Where the drive did not compensate friction (the settle law's
//! coasting, Hold, a pulsed settle's off-samples) the sled sees Coulomb friction the predict step
//! above leaves out: after it, [`SeekObserver::coulomb_decay`] takes b·u_c off |v̂|, never
//! reversing it (v̂ ← sgn(v̂)·max(|v̂| − b·u_c, 0)). Without it a sticky sled at rest kept a
//! model velocity that coasted x̂ across a cell's edge, and the correction's kick was damped
//! as motion.
//!
//! # Hand-over
//! The law brings the sled to rest on the target; the Seek region is left only once the sled is
//! at rest in the settle band — by the observer ([`SeekPlan::at_rest`]: |v̂| under the speed whose
//! coasting distance is a quantum) and by the reading (unchanged this sample) — so the settle law
//! starts at rest instead of catching a sled at speed (or after 16 samples in the band, for a sled
//! friction holds short).
//!
//! # Formats
//! x̂ I48F16 raw quanta (`i64`), v̂ and speeds I16F16 raw quanta per sample (`i32`), table distances
//! I16F16 raw quanta (`u32`, up to 65,535 quanta; a longer distance asks for v_top), the gains
//! [`Gain`].

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
    /// p once a model is identified, in [0, 1): 0 lands the model's sled exactly (module doc).
    pub velocity_pole: f64,
    /// α of a model measured by power-on calibration (`crate::servo::calibration`), in (0, 1].
    pub alpha_calibrated: f64,
    /// p of a calibrated model, in [0, 1).
    pub velocity_pole_calibrated: f64,
    /// p of a calibrated model whose gain the seeks have corrected
    /// ([`crate::control::scheduled::learn`]), in [0, 1) (α stays `alpha_calibrated`).
    pub velocity_pole_learnt: f64,
}

impl Default for TimeOptimalDesign {
    fn default() -> Self {
        // Measured over the plant family (`control-family --passes seek`, seeds 1 and 7, 200
        // plants × 100 seeks, nominal prior, on-line identification; BENCHMARKS.md, controller,
        // seeks): identified models p = 0.3 (0 and 0.2 ring on the ARX(1,1) model's bias: p95
        // 5.2–12.5; 0.4–0.5 slower), α 0.6; under the prior p = 0.7 and α = 0.3 (the prior's gain
        // may be several times off). A model known to be the sled's own: [`Self::TRUSTED`].
        //
        // A calibrated model (within a few % of the sled's, up to 17 % on strongly damped sleds:
        // `tests/integration/calibration.rs`), held: α 0.7, p 0.15 (`control-family --passes seek
        // --calibrate`, seeds 1 / 7: access / bound median 1.09 / 1.08, p95 2.00 / 1.75, clean
        // 98.0 / 97.0 %; p = 0 gives 1.00 / 1.00, 1.50 / 1.33 and 96.0 / 96.5 % with 4 pulses;
        // (0.6, 0.3) gives 1.25 / 1.23, 2.50 / 2.50 and 97.0 / 98.5 %).
        //
        // Once the seeks have corrected its gain (`scheduled::learn`): p = 0, the exact model's
        // setting (seeds 1 / 7 / 2: median 1.09 / 1.08 / 1.07 → 1.04 / 1.04 / 1.04, p95 2.00 /
        // 1.75 / 1.75 → 1.60 / 1.57 / 1.60, clean 100 / 100 / 99.5 → 99.5 / 100 / 99.5 %; the
        // fast, free corner sled over run seeds 1–5: median 2.00 → 1.00, p95 3.00 → 2.00;
        // p = 0.05: 100 / 100 / 98.5 % clean, corner median 1.67; BENCHMARKS.md).
        Self {
            alpha_prior: 0.3,
            alpha: 0.6,
            velocity_pole_prior: 0.7,
            velocity_pole: 0.3,
            alpha_calibrated: 0.7,
            velocity_pole_calibrated: 0.15,
            velocity_pole_learnt: 0.0,
        }
    }
}

impl TimeOptimalDesign {
    /// (α, p) for a model known to be the sled's own (measured, or its exact twin): p = 0 lands
    /// it exactly; α = 0.7 keeps 30 % of the braking for the rest. Over the family on each
    /// plant's exact model (`control-family --prior exact --frozen`, seeds 1, 7, 2) it gives
    /// access / bound median 1.00, p95 1.25, no unsettled seek; (0.6, 0.3) gives 1.25–1.27 / 2.50
    /// and 7–16 unsettled seeks.
    pub const TRUSTED: (f64, f64) = (0.7, 0.0);
}

impl TimeOptimalDesign {
    /// α ∈ (0, 1], p ∈ [0, 1).
    ///
    /// # Errors
    /// [`ConfigError::SeekDesign`] naming the value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for alpha in [self.alpha_prior, self.alpha, self.alpha_calibrated] {
            if !(alpha.is_finite() && alpha > 0.0 && alpha <= 1.0) {
                return Err(ConfigError::SeekDesign(alpha));
            }
        }
        for p in [
            self.velocity_pole_prior,
            self.velocity_pole,
            self.velocity_pole_calibrated,
            self.velocity_pole_learnt,
        ] {
            if !(p.is_finite() && (0.0..1.0).contains(&p)) {
                return Err(ConfigError::SeekDesign(p));
            }
        }
        Ok(())
    }
}

/// Words: α_prior, α, p_prior, p, α and p calibrated, p learnt (`f64` bits; validity:
/// [`TimeOptimalDesign::validate`]).
impl Words for TimeOptimalDesign {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        [
            self.alpha_prior,
            self.alpha,
            self.velocity_pole_prior,
            self.velocity_pole,
            self.alpha_calibrated,
            self.velocity_pole_calibrated,
            self.velocity_pole_learnt,
        ]
        .put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [
            alpha_prior,
            alpha,
            velocity_pole_prior,
            velocity_pole,
            alpha_calibrated,
            velocity_pole_calibrated,
            velocity_pole_learnt,
        ] = <[f64; 7]>::take(r);
        Self {
            alpha_prior,
            alpha,
            velocity_pole_prior,
            velocity_pole,
            alpha_calibrated,
            velocity_pole_calibrated,
            velocity_pole_learnt,
        }
    }
}

/// K(w) = D(w) + (b₀/b)·w at 33 speeds (`Copy`): the stop-point curve of one model (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BrakingCurve {
    /// v_top/32, I16F16 raw quanta per sample (0: no curve).
    v_step: i32,
    /// K(j·v_step), I16F16 raw quanta, increasing.
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

    /// K of the model (a, b, u_c) braking at `alpha`·`u_max` (full scale): `None` when the model
    /// cannot brake (α·u_max + u_c ≤ 0, a not in [0, 1], b ≤ 0, non-finite values) or K leaves
    /// the table's format. f32 arithmetic (the redesign's, outside the interrupt).
    pub fn design(a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32) -> Option<Self> {
        let mut curve = Self::NONE;
        curve.design_into(a, b, u_c, u_max, alpha).then_some(curve)
    }

    /// [`Self::design`] written into `self` (no curve built beside it and copied: the
    /// redesign's frame holds one); false, and `self` [`Self::NONE`], where that is `None`.
    pub fn design_into(&mut self, a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32) -> bool {
        if self.tabulate(a, b, u_c, u_max, alpha).is_none() || self.validate().is_err() {
            *self = Self::NONE;
            return false;
        }
        true
    }

    /// The table of [`Self::design`] into `self`; `None` (`self` partly written) where the model
    /// cannot brake or K leaves the table's format.
    #[allow(clippy::float_arithmetic)]
    fn tabulate(&mut self, a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32) -> Option<()> {
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
        // braking distance w²/(2·b·braking) under 48,000 quanta, the drive sample's (b₀/b)·w ≤
        // V_TOP_MAX/2 beside it; viscous friction only shortens D).
        let fits = libm::sqrtf(2.0 * b * braking * 48_000.0);
        let lead = b0 / b;
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
        self.v_step = v_step;
        let g = &mut self.g;
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
            // The drive sample's own part of the stop point: K = D + (b₀/b)·w.
            let raw =
                (distance + lead * (j as i64 * i64::from(v_step)) as f32 / 65_536.0) * 65_536.0;
            if raw.is_nan() || raw >= u32::MAX as f32 {
                return None;
            }
            *gj = raw as u32;
        }
        // K may be flat at the bottom (a slow speed stops within one sample without moving a
        // quantum's fraction): keep it strictly increasing by one LSB per entry.
        for j in 1..CURVE_ENTRIES {
            let prev = g.get(j - 1).copied().unwrap_or(0);
            if let Some(gj) = g.get_mut(j) {
                *gj = (*gj).max(prev.saturating_add(1));
            }
        }
        Some(())
    }

    /// K increasing (strictly past the first entry, which is 0) and a positive step, or the
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

    /// w* = K⁻¹(d) for a distance `d` (I16F16 raw quanta), I16F16 raw quanta per sample: binary
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

    /// (v_step, K table), for the float64 reference and the tests.
    pub fn table(&self) -> (i32, &[u32; CURVE_ENTRIES]) {
        (self.v_step, &self.g)
    }
}

/// Words: v_step, then the 33 entries of K (validity: [`BrakingCurve::validate`]).
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

/// The seek law's gains and curve for one model (`Copy`, part of the placed gains): the
/// observer's model (a, b, c₁, b₀, l_v) and the law's (c₁ − a·b₀/b, (1 − p)/b, (p − a)/b, K).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeekPlan {
    /// a: the velocity's decay per sample.
    pub k_a: Gain,
    /// b: velocity per sample of drive, quanta per sample per full scale.
    pub k_b: Gain,
    /// c₁: the distance a sample coasts per unit of v.
    pub k_c1: Gain,
    /// b₀: the distance a sample of drive moves the sled, quanta per full scale.
    pub k_b0: Gain,
    /// l_v = ½·a/c₁: the observer's velocity correction per quantum outside the predicted cell.
    pub k_correct: Gain,
    /// c₁ − a·b₀/b on v̂: the stop point's coasting part.
    pub k_coast: Gain,
    /// (1 − p)/b on w*.
    pub k_target: Gain,
    /// (p − a)/b on v̂.
    pub k_velocity: Gain,
    /// Arrival speed, I16F16 raw quanta per sample: a sled coasting from it moves a quantum
    /// (|v̂|·c₁/(1 − a) ≤ 1; 1 quantum per sample for a ≥ 1 − 10⁻⁴).
    pub v_arrive: i32,
    /// u_c, I16F16 raw full scale: the Coulomb level the law adds against the motion.
    pub u_coulomb: i32,
    /// K of the model.
    pub curve: BrakingCurve,
}

impl SeekPlan {
    /// No plan (reference-following seeks).
    pub const NONE: Self = Self {
        k_a: Gain::ZERO,
        k_b: Gain::ZERO,
        k_c1: Gain::ZERO,
        k_b0: Gain::ZERO,
        k_correct: Gain::ZERO,
        k_coast: Gain::ZERO,
        k_target: Gain::ZERO,
        k_velocity: Gain::ZERO,
        v_arrive: 0,
        u_coulomb: 0,
        curve: BrakingCurve::NONE,
    };

    /// The plan for the model (a, b, u_c) at `alpha`·`u_max` with velocity pole `p`; `None` as
    /// [`BrakingCurve::design`], or a gain out of [`Gain`]'s format.
    pub fn design(a: f32, b: f32, u_c: f32, u_max: f32, alpha: f32, p: f32) -> Option<Self> {
        let mut plan = Self::NONE;
        plan.design_into(a, b, u_c, u_max, alpha, p).then_some(plan)
    }

    /// [`Self::design`] written into `self` (its curve too: no plan built beside it and
    /// copied — the redesign's frame holds one); false, and `self` [`Self::NONE`], where that is
    /// `None`.
    pub fn design_into(
        &mut self,
        a: f32,
        b: f32,
        u_c: f32,
        u_max: f32,
        alpha: f32,
        p: f32,
    ) -> bool {
        if !self.curve.design_into(a, b, u_c, u_max, alpha) || self.place(a, b, u_c, p).is_none() {
            *self = Self::NONE;
            return false;
        }
        true
    }

    /// The gains, v_arrive and u_c of [`Self::design`] into `self` (the curve left as it is);
    /// `None` (`self` partly written) for a gain out of [`Gain`]'s format.
    #[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
    fn place(&mut self, a: f32, b: f32, u_c: f32, p: f32) -> Option<()> {
        let (c1, b0) = sampled(a, b);
        let correct = if c1 > 1e-6 { 0.5 * a / c1 } else { 0.0 };
        let coast_per_speed = if a < 1.0 - 1e-4 { c1 / (1.0 - a) } else { 1.0 };
        let v_arrive = (65_536.0 / coast_per_speed.max(1.0 / 1024.0)).min(65_536.0);
        let g = |x: f32| Gain::from_f64(f64::from(x));
        self.k_a = g(a)?;
        self.k_b = g(b)?;
        self.k_c1 = g(c1)?;
        self.k_b0 = g(b0)?;
        self.k_correct = g(correct)?;
        self.k_coast = g(c1 - a * b0 / b)?;
        self.k_target = g((1.0 - p) / b)?;
        self.k_velocity = g((p - a) / b)?;
        self.v_arrive = v_arrive as i32;
        self.u_coulomb = (u_c.clamp(0.0, 0.5) * 65_536.0) as i32;
        Some(())
    }

    /// The gains valid, 0 ≤ v_arrive ≤ 1 quantum per sample, the curve valid.
    ///
    /// # Errors
    /// [`ConfigError::SeekDesign`] otherwise.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.gains().iter().all(|k| k.is_valid()) {
            return Err(ConfigError::SeekDesign(f64::NAN));
        }
        if !(0..=1 << 16).contains(&self.v_arrive) {
            return Err(ConfigError::SeekDesign(f64::from(self.v_arrive)));
        }
        if !(0..=1 << 15).contains(&self.u_coulomb) {
            return Err(ConfigError::SeekDesign(f64::from(self.u_coulomb)));
        }
        self.curve.validate()
    }

    /// The law's linear drive (I32F32 full scale, before compensation) for the observer's error
    /// `e` = target − x̂ (I16F16 raw quanta, any sign) and velocity `v_hat` (I16F16 raw quanta per
    /// sample). Never panics.
    #[inline]
    pub fn drive(&self, e: i32, v_hat: i32) -> i64 {
        let coast = crate::num::fixed::sat_i32(shr_round(self.k_coast.apply(v_hat)), &mut false);
        let left = e.saturating_sub(coast);
        let magnitude = self.curve.speed(left.unsigned_abs());
        let w_star = if left < 0 { -magnitude } else { magnitude };
        self.k_target
            .apply(w_star)
            .saturating_add(self.k_velocity.apply(v_hat))
    }

    /// The eight gains in their word order (the order [`Words::take`] reads them back in).
    fn gains(&self) -> [Gain; 8] {
        [
            self.k_a,
            self.k_b,
            self.k_c1,
            self.k_b0,
            self.k_correct,
            self.k_coast,
            self.k_target,
            self.k_velocity,
        ]
    }

    /// The model's move over one sample, c₁·v + b₀·u (I16F16 raw quanta, rounded), from the
    /// velocity `v` (I16F16 raw quanta per sample) and the linear drive `drive` (I16F16 raw
    /// full scale): the seek observer's prediction and the gain learner's open-loop model
    /// (`crate::control::scheduled::learn`).
    #[inline]
    pub fn advance(&self, v: i32, drive: i32) -> i64 {
        shr_round(self.k_c1.apply(v).saturating_add(self.k_b0.apply(drive)))
    }

    /// The model is sticky: friction takes more than twice the arrival speed off a sample's
    /// velocity (b·u_c > 2·v_arrive) — it stops a sled within a sample, and breaking it away
    /// from rest takes a drive that, held on, throws it a few quanta ([`super::scheduled`],
    /// "Settle of a time-optimal seek"). The nominal sled's model is near b·u_c = v_arrive:
    /// the margin of 2 keeps an identified model of it out (measured, BENCHMARKS.md).
    #[inline]
    pub fn sticky(&self) -> bool {
        self.coulomb_step() > 2 * i64::from(self.v_arrive)
    }

    /// b·u_c, I16F16 raw quanta per sample: what Coulomb friction takes off a sample's velocity.
    #[inline]
    pub fn coulomb_step(&self) -> i64 {
        shr_round(self.k_b.apply(self.u_coulomb))
    }

    /// The observer has the sled at rest: |v̂| ≤ v_arrive.
    #[inline]
    pub fn at_rest(&self, v_hat: i32) -> bool {
        v_hat.unsigned_abs() <= self.v_arrive.unsigned_abs()
    }

    /// The drive u (I16F16 raw full scale, within ±`u_max`) that gives the sled the linear drive
    /// `v` (I16F16 raw) past Coulomb friction, which opposes the motion v̂ — or, at rest, the
    /// drive: u = v + u_c·sgn(v̂ or v). Returns (u, the linear drive the model sees after the
    /// rail's clamp).
    #[inline]
    pub fn compensate(&self, v: i32, v_hat: i32, u_max: i32) -> (i32, i32) {
        let direction = if self.at_rest(v_hat) { v } else { v_hat };
        let friction = match direction {
            d if d > 0 => self.u_coulomb,
            d if d < 0 => -self.u_coulomb,
            _ => 0,
        };
        let u = crate::num::gain::clamp_sym_i32(v.saturating_add(friction), u_max);
        (u, u.saturating_sub(friction))
    }
}

/// The seek's observer of position and velocity (module doc): model prediction, corrected only
/// when the reading leaves the predicted cell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SeekObserver {
    /// x̂, I48F16 raw quanta.
    x_hat: i64,
    /// v̂, I16F16 raw quanta per sample.
    v_hat: i32,
}

/// Half a quantum, I16F16 raw: the predicted cell's half-width.
const HALF_CELL: i32 = 1 << 15;

impl SeekObserver {
    /// At rest at 0.
    pub const fn new() -> Self {
        Self { x_hat: 0, v_hat: 0 }
    }

    /// At rest at the reading `y` (I48F16 raw quanta).
    pub fn restart(&mut self, y: i64) {
        self.x_hat = y;
        self.v_hat = 0;
    }

    /// One sample: predict with the plan's model and `drive` (the linear drive applied over the
    /// last sample, I16F16 raw full scale), then correct on the reading `y` (I48F16 raw quanta)
    /// if it left the predicted cell. `saturated` is set when a narrowing saturated.
    pub fn update(&mut self, plan: &SeekPlan, drive: i32, y: i64, saturated: &mut bool) {
        let dx = plan.advance(self.v_hat, drive);
        // Rounded toward zero: with the drive cut, v̂ decays to exactly 0 (rounded to nearest,
        // a·v̂ sticks at a few LSB and x̂ creeps by them every sample of a dwell).
        let v_acc = plan
            .k_a
            .apply(self.v_hat)
            .saturating_add(plan.k_b.apply(drive));
        let v = if v_acc < 0 {
            -(v_acc.saturating_neg() >> 16)
        } else {
            v_acc >> 16
        };
        self.v_hat = crate::num::fixed::sat_i32(v, saturated);
        self.x_hat = self.x_hat.saturating_add(dx);
        let d = crate::num::fixed::sat_i32(y.saturating_sub(self.x_hat), saturated);
        if d.unsigned_abs() > HALF_CELL.unsigned_abs() {
            let delta = if d > 0 { d - HALF_CELL } else { d + HALF_CELL };
            self.x_hat = self.x_hat.saturating_add(i64::from(delta));
            let dv = shr_round(plan.k_correct.apply(delta));
            self.v_hat =
                crate::num::fixed::sat_i32(i64::from(self.v_hat).saturating_add(dv), saturated);
        }
    }

    /// Coulomb friction over the last sample of a drive that did not compensate it (module doc,
    /// "Uncompensated drives"): it takes up to b·u_c off |v̂| and never reverses it.
    pub fn coulomb_decay(&mut self, plan: &SeekPlan) {
        let step = plan.coulomb_step().clamp(0, i64::from(i32::MAX));
        let speed = i64::from(self.v_hat.unsigned_abs())
            .saturating_sub(step)
            .max(0);
        // |v̂| − step ≤ |v̂| ≤ 2³¹: fits i32 after the sign.
        let speed = i32::try_from(speed).unwrap_or(i32::MAX);
        self.v_hat = if self.v_hat < 0 { -speed } else { speed };
    }

    /// x̂, I48F16 raw quanta.
    pub const fn position(&self) -> i64 {
        self.x_hat
    }

    /// v̂, I16F16 raw quanta per sample.
    pub const fn velocity(&self) -> i32 {
        self.v_hat
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

/// Words: the eight gains, v_arrive, u_c, then the curve.
impl Words for SeekPlan {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.gains().put(w)?;
        [self.v_arrive, self.u_coulomb].put(w)?;
        self.curve.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let [
            k_a,
            k_b,
            k_c1,
            k_b0,
            k_correct,
            k_coast,
            k_target,
            k_velocity,
        ] = <[Gain; 8]>::take(r);
        Self {
            k_a,
            k_b,
            k_c1,
            k_b0,
            k_correct,
            k_coast,
            k_target,
            k_velocity,
            v_arrive: i32::take(r),
            u_coulomb: i32::take(r),
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

    /// K(w) = D(w) + (b₀/b)·w of the model, hand-simulated; trips on a curve that leaves out the
    /// drive sample's own distance (the earlier braking curve D) or a wrong braking sequence.
    #[test]
    fn the_curve_is_the_models_stop_distance() {
        let c = nominal(1.0);
        let (v_step, g) = c.table();
        let (c1, b0) = sampled(0.8336, 23.66);
        let braking = 1.0075f64;
        let w0 = 8.0 * v_step as f64 / 65_536.0;
        let (mut w, mut d) = (w0, 0.0);
        while w > 1e-6 {
            let u = braking.min(0.8336 * w / 23.66);
            d += f64::from(c1) * w - f64::from(b0) * u;
            w = 0.8336 * w - 23.66 * u;
        }
        let k = d + f64::from(b0) / 23.66 * w0;
        assert!(
            (f64::from(g[8]) / 65_536.0 - k).abs() < 1e-2,
            "{} vs {k}",
            g[8]
        );
        // K⁻¹(K(w_j)) = w_j, and in between it interpolates.
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

    /// A plan designed in place over another model's is the plan designed afresh (every field
    /// and table entry rewritten); a model that cannot brake leaves no plan. Trips on an entry
    /// or gain left over from the plan it overwrote.
    #[test]
    fn a_plan_designed_in_place_is_the_plan_designed_afresh() {
        let mut plan = SeekPlan::design(0.97, 5.0, 0.05, 1.0, 0.3, 0.7).unwrap();
        assert!(plan.design_into(0.8336, 23.66, 0.0075, 1.0, 0.7, 0.15));
        assert_eq!(
            Some(plan),
            SeekPlan::design(0.8336, 23.66, 0.0075, 1.0, 0.7, 0.15)
        );
        assert!(!plan.design_into(0.8, -1.0, 0.0, 1.0, 0.8, 0.0));
        assert_eq!(plan, SeekPlan::NONE);
    }

    #[test]
    fn the_drive_saturates_far_away_and_brakes_near() {
        let plan = SeekPlan::design(0.8336, 23.66, 0.0075, 1.0, 0.85, 0.0).unwrap();
        let far = plan.drive(2000 << 16, 0);
        assert!(far > 1 << 32, "full drive asked for: {far}");
        // Moving fast toward a target 10 quanta away: brake.
        let near = plan.drive(10 << 16, 60 << 16);
        assert!(near < 0, "{near}");
        // Symmetric.
        assert_eq!(plan.drive(-(2000 << 16), 0), -far);
    }

    /// The law run on its own model (the observer fed the model's exact position) lands a seek
    /// at rest on the target: a 100-quantum seek on a sled 10× the nominal's gain (two or three
    /// samples of drive) and a 300-quantum one on the nominal sled, within a quarter quantum and
    /// within 2 samples of the model's own minimum time. Trips on a law that ignores the drive
    /// sample's own distance (it overshoots by b₀·u per seek) or that lags with p > 0.
    #[test]
    #[allow(clippy::float_arithmetic)]
    fn the_law_lands_its_own_model_at_rest() {
        for (a, b, target) in [(0.8336f32, 236.6f32, 100.0f64), (0.8336, 23.66, 300.0)] {
            let plan = SeekPlan::design(a, b, 0.0, 1.0, 1.0, 0.0).unwrap();
            let (c1, b0) = sampled(a, b);
            let (mut x, mut v) = (0.0f64, 0.0f64);
            let mut obs = SeekObserver::new();
            let mut drive = 0i32;
            let mut arrived_at = None;
            for k in 0..200 {
                let y = libm::round(x * 65_536.0) as i64;
                obs.update(&plan, drive, y, &mut false);
                let e = ((target * 65_536.0) as i64 - obs.position()) as i32;
                let raw = (plan.drive(e, obs.velocity()) >> 16).clamp(-65_536, 65_536) as i32;
                let (u, applied) = plan.compensate(raw, obs.velocity(), 65_536);
                assert_eq!(u, applied, "no friction in this model");
                drive = applied;
                let uf = f64::from(drive) / 65_536.0;
                x += f64::from(c1) * v + f64::from(b0) * uf;
                v = f64::from(a) * v + f64::from(b) * uf;
                if arrived_at.is_none() && (x - target).abs() < 0.25 && v.abs() < 0.05 {
                    arrived_at = Some(k + 1);
                }
            }
            let k = arrived_at.expect("landed");
            assert!((x - target).abs() < 0.25, "rests at {x}");
            // The model's minimum time: bang-bang from rest, searched.
            let min_time = (1..200)
                .find(|&n| {
                    (1..=n).any(|s| {
                        let (mut x, mut v) = (0.0f64, 0.0f64);
                        for i in 0..n {
                            let u = if i < s { 1.0 } else { -1.0 };
                            x += f64::from(c1) * v + f64::from(b0) * u;
                            v = f64::from(a) * v + f64::from(b) * u;
                        }
                        x >= target && v <= 0.0
                    })
                })
                .unwrap();
            assert!(k <= min_time + 2, "{k} samples against {min_time}");
        }
    }

    /// The observer predicts with the model and corrects only outside the predicted cell:
    /// readings inside it leave (x̂, v̂) on the prediction; one 3 quanta off pulls x̂ to the
    /// cell's edge and v̂ by l_v·2.5. Trips on an observer that follows every reading (the
    /// quantisation's noise in v̂) or ignores them.
    #[test]
    fn the_observer_corrects_only_outside_the_cell() {
        let plan = SeekPlan::design(0.8, 10.0, 0.0, 1.0, 0.7, 0.0).unwrap();
        let mut obs = SeekObserver::new();
        let q = 1i64 << 16;
        // Predicted: x̂ = c₁·0 + b₀·0.05, v̂ = 0.5 — a reading of 0 is within half a cell of it.
        obs.update(&plan, 3277, 0, &mut false);
        let (c1, b0) = sampled(0.8, 10.0);
        let predicted = f64::from(b0) * 0.05;
        assert!(predicted < 0.5);
        assert!((obs.position() as f64 / 65_536.0 - predicted).abs() < 1e-3);
        assert!((f64::from(obs.velocity()) / 65_536.0 - 0.5).abs() < 1e-3);
        // Next: predicted x̂ ≈ predicted + c₁·0.5; a reading 3 quanta beyond it.
        let before = obs.position() + (f64::from(c1) * 0.5 * 65_536.0) as i64;
        let reading = (before + 3 * q) / q * q;
        obs.update(&plan, 0, reading, &mut false);
        assert_eq!(obs.position(), reading - q / 2, "x̂ at the cell's near edge");
        let l = 0.5 * 0.8 / f64::from(c1);
        let delta = (reading - q / 2 - before) as f64 / 65_536.0;
        let expected = 0.4 + l * delta;
        assert!(
            (f64::from(obs.velocity()) / 65_536.0 - expected).abs() < 2e-3,
            "{} vs {expected}",
            f64::from(obs.velocity()) / 65_536.0
        );
    }

    /// Friction is compensated against the motion (v̂), at rest against the drive; the linear
    /// drive returned is what the sled gets past friction after the rail.
    #[test]
    fn friction_is_compensated_against_the_motion() {
        let plan = SeekPlan::design(0.8336, 23.66, 0.02, 1.0, 0.7, 0.0).unwrap();
        let uc = plan.u_coulomb;
        assert!((uc - 1311).abs() <= 1, "{uc}");
        // Braking (drive −0.3) while moving forward: friction helps, u = −0.3 + u_c.
        let (u, applied) = plan.compensate(-19_661, 20 << 16, 65_536);
        assert_eq!((u, applied), (-19_661 + uc, -19_661));
        // At rest: against the drive.
        let (u, _) = plan.compensate(-19_661, 0, 65_536);
        assert_eq!(u, -19_661 - uc);
        // The rail: the sled gets u_max past friction.
        let (u, applied) = plan.compensate(80_000, 20 << 16, 65_536);
        assert_eq!((u, applied), (65_536, 65_536 - uc));
    }

    /// Coulomb decay takes b·u_c off |v̂| each call, in either direction, and stops at 0
    /// (never reverses); trips on a decay that reverses v̂, ignores the sign or friction's size.
    #[test]
    fn coulomb_decay_slows_the_model_sled_to_rest_and_not_past() {
        // b = 10 quanta per sample per full scale, u_c = 0.02: 0.2 quantum per sample per call.
        let plan = SeekPlan::design(0.9, 10.0, 0.02, 1.0, 0.7, 0.0).unwrap();
        let step = plan.coulomb_step() as f64 / 65_536.0;
        assert!((step - 0.2).abs() < 1e-3, "{step}");
        for sign in [1i32, -1] {
            let mut obs = SeekObserver::new();
            obs.v_hat = sign * (1 << 15); // 0.5 quantum per sample
            obs.coulomb_decay(&plan);
            let v = f64::from(obs.velocity()) / 65_536.0;
            assert!((v - f64::from(sign) * 0.3).abs() < 1e-3, "{v}");
            obs.coulomb_decay(&plan);
            obs.coulomb_decay(&plan);
            assert_eq!(obs.velocity(), 0, "at rest, not reversed");
            obs.coulomb_decay(&plan);
            assert_eq!(obs.velocity(), 0);
        }
    }

    /// A plan is sticky where friction takes more than 2·v_arrive off a sample's velocity: a
    /// fast, sticky model (b·u_c ≈ 0.68 against v_arrive ≈ 0.24) is; a heavy, nearly
    /// frictionless one (0.009 against 0.017) is not, nor the fast one without friction, nor
    /// the nominal sled's (0.177 against 0.182). Trips on the comparison inverted, on u_c left
    /// out, or on a margin of 1 that a model near the nominal sled's crosses.
    #[test]
    fn a_fast_sticky_model_is_sticky_and_a_gliding_one_is_not() {
        let sticky = SeekPlan::design(0.78, 76.0, 0.009, 1.0, 0.7, 0.0).unwrap();
        assert!(sticky.sticky(), "{sticky:?}");
        let heavy = SeekPlan::design(0.983, 1.8, 0.005, 1.0, 0.7, 0.0).unwrap();
        assert!(!heavy.sticky(), "{heavy:?}");
        let frictionless = SeekPlan::design(0.78, 76.0, 0.0, 1.0, 0.7, 0.0).unwrap();
        assert!(!frictionless.sticky());
        // The nominal model with 1.5× its friction: b·u_c ≈ 1.46·v_arrive, still not sticky.
        let nominal = SeekPlan::design(0.8336, 23.66, 0.0075 * 1.5, 1.0, 0.7, 0.0).unwrap();
        assert!(!nominal.sticky(), "{nominal:?}");
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
