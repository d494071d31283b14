//! The sled's health: a single-neuron friction model identified in the background beside the
//! servo, from a lock-free queue the sample interrupt fills, against the Coulomb level the
//! power-on calibration measured.
//!
//! # Model (the paper's §6 friction feedback, on the velocity, at the §4 rate 2·Ts)
//! The sled's velocity model of the calibration ([`super::calibration`]: first order, pole a per
//! Ts, Coulomb level c, under the ZOH drive) makes the first difference Δy(k) = y(k) − y(k−1)
//! exactly ARX: `Δy(k+1) = a·Δy(k) + β₁·(u(k) − c·s) + β₂·(u(k−1) − c·s)`, s the sign of the
//! motion. Down-sampled by 2 to the travel over a pair, V(m) = y(2m) − y(2m−2) = (1 + q⁻¹)Δy(2m),
//! the same model multiplied through by (1 + a·q⁻¹) is a polynomial in q⁻² in its denominator
//! and so still exact at 2·Ts, with both inputs of each pair kept (the paper's §4 low-pass before
//! picking every second sample is left out on purpose: it made the first-order model approximate,
//! and the friction estimate with it: measured over 10 family plants, ĉ 0.0096 fs RMS off the
//! calibration's level with the half-band filter of [`crate::ident::decimate`], against levels of
//! 0.002–0.016). The background
//! identifies, by recursive least squares ([`crate::ident::rls`]),
//! ```text
//! V(m) = a²·V(m−1) + Σⱼ γⱼ·u(2m−j) + w·tanh(α·V(m−1)),   j = 1 … 4,   θ = [a² γ₁ γ₂ γ₃ γ₄ w]
//! ```
//! with the friction neuron of the paper's conclusion, `w·tanh(α·v̂ + c)`, fed the measured
//! travel (equation error, so the regression is linear in θ), its slope α fixed by the design
//! and c = 0 (a symmetric Coulomb force). At speeds well above 1/α the neuron is ±w, and the
//! Coulomb level in the units of the drive is
//! ```text
//! ĉ = −w / Σⱼ γⱼ           fraction of full scale, the calibration's `coulomb_fs`
//! ```
//! θ adapts only while V(m) and V(m−1) are both at least the design's speed gate and of one
//! sign: at rest stiction, not the Coulomb level, holds the sled, the quantised travel says
//! little at low speed, and the model assumes one direction over its window.
//!
//! # Verdict
//! [`HealthConfig::verdict`]: the friction has risen ([`HealthFlags::DRIFT`]) when, after at
//! least `min_updates` updates since the reference was set, `ĉ − c_ref > drift_fs + drift_rel·c_ref`,
//! c_ref the calibration's mean Coulomb level (wear and contamination raise friction). One-sided
//! on purpose: on healthy identifiable sleds ĉ is biased low (typically by 0.000–0.005 of full
//! scale, once by 0.18; equation error on quantised closed-loop data) and never measured high by
//! more than 0.0003 (`host-tests/tests/integration/health.rs`, 48 plants), so a fall cannot be told from the
//! bias. A sled whose calibrated pole is below `min_pole` per Ts reaches its terminal speed
//! within a sample: its seeks cruise at full drive and friction cannot be told from the gain
//! (measured: ĉ off by up to 0.05 of full scale), so its verdict is
//! [`HealthFlags::NOT_IDENTIFIABLE`], never `DRIFT`.
//!
//! # Hand-over
//! [`HealthConfig::feed`] (the interrupt) pushes one [`HealthSample`] (V and the pair's two
//! inputs) every second sample into a
//! `heapless::spsc::Queue` and never waits: a full queue drops the sample, counts it and returns
//! [`FeedFlags::DROPPED`]. [`HealthConfig::drain`] (the background) pops and runs the estimator.
//! A dropped sample breaks the lag chain: the next sample only refills the lags.
//!
//! # Formats
//! | quantity | format | unit |
//! |---|---|---|
//! | V | I16F16 ([`SignalI16F16`]) | quanta per 2·Ts; saturates (flagged) beyond ±32,768 |
//! | u | I16F16 | fraction of full scale |
//! | tanh(α·V) | I16F16 in [−1, 1] | from [`tanh_i2f30`] (error ≤ 9.4·10⁻⁵) |
//! | α | I8F24 `i32` | per (quantum per 2·Ts), (0, 128) |
//! | θ | I12F20 ([`ParamI12F20`]) | a²: 1; γ: quanta per 2·Ts per full scale; w: quanta per 2·Ts |
//! | ĉ, c_ref, thresholds | I12F20 | fraction of full scale |
//!
//! # Scaling and overflow
//! α·V: I8F24 × I16F16 → I24F40 in `i64` (|·| < 2⁶²), rounded to I8F24 and saturated (tanh is ±1
//! there). ĉ = −w·2²⁰/Σγ in `i64`: |w| < 2³¹, so |w·2²⁰| < 2⁵¹; saturated to I12F20. The
//! verdict's threshold sum saturates. Everything else is the RLS kernel's.
//!
//! # Accuracy
//! Against the float64 reference (`host-tests/src/reference/health.rs`) on twin and recorded data:
//! ĉ within 10⁻⁵ of full scale on the twin (measured 1.0·10⁻⁶) and 10⁻⁴ on the EMPS recording
//! (measured 2.1·10⁻⁵), θ within 10⁻⁴ / 2·10⁻³, with the same update decisions; asserted in
//! `host-tests/tests/integration/health.rs` (`fixed_point_tracks_float64_on_twin`, `…_on_emps`). Cost per call
//! on target: `bench_health_feed`, `bench_health_step` in BENCHMARKS.md.

#![deny(clippy::float_arithmetic)]

use heapless::spsc::{Consumer, Producer};

use crate::error::ConfigError;
use crate::ident::neuron::{ARG_FRAC_BITS, TANH_FRAC_BITS, tanh_i2f30};
use crate::ident::rls::{RlsConfig, RlsDesign, RlsState};
use crate::ident::status::Status;
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::{PARAM_FRAC_BITS, ParamI12F20, SignalI16F16, sat_i32, shr_round_i64};
use crate::num::wide::mul_i32_wide;
use crate::words::{WordReader, WordWriter, Words};

/// Parameters θ = [a², γ₁, γ₂, γ₃, γ₄, w].
pub const HEALTH_N: usize = 6;

/// The queue between the interrupt and the background: capacity `Q − 1` samples (heapless 0.8).
pub type HealthQueue<const Q: usize> = heapless::spsc::Queue<HealthSample, Q>;

/// One sample at 2·Ts, interrupt → background.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthSample {
    /// V(m) = y(2m) − y(2m−2), quanta per 2·Ts.
    pub v: SignalI16F16,
    /// u(2m−1), u(2m−2): the pair's drives, fraction of full scale.
    pub u: [SignalI16F16; 2],
    /// A sample was dropped, or the feed restarted ([`HealthFeed::restart`]), just before this
    /// one (the lag chain is broken).
    pub after_drop: bool,
}

/// User-facing settings of the health estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthDesign {
    /// The RLS settings (λ per update at 2·Ts, p₀, anti-windup).
    pub rls: RlsDesign,
    /// α: the neuron's fixed slope, per (quantum per 2·Ts), in (0, 128).
    pub neuron_slope_per_quantum: f64,
    /// θ adapts only while |V(m)|, |V(m−1)| ≥ this, quanta per 2·Ts (≥ 0), and of one sign.
    pub gate_speed_quanta: f64,
    /// The verdict's absolute threshold, fraction of full scale (≥ 0).
    pub drift_fs: f64,
    /// The verdict's relative threshold, times c_ref (≥ 0).
    pub drift_rel: f64,
    /// Updates since the reference before a verdict can flag.
    pub min_updates: u32,
    /// The calibrated velocity pole a (per Ts) below which friction is not identifiable on
    /// seeks, in [0, 1).
    pub min_pole: f64,
}

impl Default for HealthDesign {
    /// The settings measured in `host-tests/tests/integration/health.rs` (module doc there).
    fn default() -> Self {
        Self {
            rls: RlsDesign {
                lambda: 0.9995,
                p0: 0.01,
                ..RlsDesign::default()
            },
            neuron_slope_per_quantum: 1.0,
            gate_speed_quanta: 2.0,
            drift_fs: 0.002,
            drift_rel: 0.25,
            min_updates: 200,
            min_pole: 0.3,
        }
    }
}

/// Validated, quantised [`HealthDesign`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthConfig {
    rls: RlsConfig,
    alpha_i8f24: i32,
    gate_i16f16: i32,
    drift_fs: ParamI12F20,
    drift_rel: ParamI12F20,
    min_updates: u32,
    /// min_pole², I12F20 (compared with θ₀'s a²).
    min_pole2: ParamI12F20,
}

/// A non-negative finite setting below `max`, quantised by `q`.
fn setting<T>(x: f64, q: impl Fn(f64) -> Option<T>) -> Result<T, ConfigError> {
    let ok = x.is_finite() && x >= 0.0;
    ok.then(|| q(x)).flatten().ok_or(ConfigError::Health(x))
}

impl HealthDesign {
    /// Validates and quantises.
    ///
    /// # Errors
    /// The RLS design's errors; [`ConfigError::Health`] with the offending value for a slope
    /// outside (0, 128), or a gate or threshold that is negative, not finite or out of format.
    ///
    /// ```
    /// use sledid::servo::health::HealthDesign;
    /// assert!(HealthDesign::default().build().is_ok());
    /// let bad = HealthDesign { neuron_slope_per_quantum: 0.0, ..HealthDesign::default() };
    /// assert!(bad.build().is_err());
    /// ```
    pub fn build(&self) -> Result<HealthConfig, ConfigError> {
        let rls = self.rls.build()?;
        let slope = self.neuron_slope_per_quantum;
        if !(slope > 0.0 && slope < 128.0) {
            return Err(ConfigError::Health(slope));
        }
        let alpha_i8f24 = setting(slope, |x| {
            let s = ParamI12F20::from_f64(x).ok()?;
            s.raw().checked_mul(1 << (ARG_FRAC_BITS - PARAM_FRAC_BITS))
        })
        .ok()
        .filter(|&a| a > 0) // a slope below I12F20's resolution
        .ok_or(ConfigError::Health(slope))?;
        let gate_i16f16 = setting(self.gate_speed_quanta, |x| {
            SignalI16F16::from_f64(x).ok().map(SignalI16F16::raw)
        })?;
        let param = |x| setting(x, |x| ParamI12F20::from_f64(x).ok());
        let pole = self.min_pole;
        if !(0.0..1.0).contains(&pole) {
            return Err(ConfigError::Health(pole));
        }
        #[allow(clippy::float_arithmetic)] // design time
        let min_pole2 = param(pole * pole)?;
        let config = HealthConfig {
            rls,
            alpha_i8f24,
            gate_i16f16,
            drift_fs: param(self.drift_fs)?,
            drift_rel: param(self.drift_rel)?,
            min_updates: self.min_updates,
            min_pole2,
        };
        // The decoded words' checks (one copy of the rules).
        config.validate()?;
        Ok(config)
    }
}

/// Words of a [`HealthConfig`] frame at most: 3 of framing and 21 of payload.
pub const HEALTH_WORDS_MAX: usize = 24;

impl HealthConfig {
    /// The invariants [`HealthDesign::build`] establishes on the quantised values: the RLS
    /// settings' ([`RlsConfig::validate`]), a positive slope α, a non-negative gate and drift
    /// thresholds, min_pole² in [0, 1).
    ///
    /// # Errors
    /// The RLS settings' error, or [`ConfigError::Health`] (its value `NaN`: the design's `f64`
    /// is not on target).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.rls.validate()?;
        let ok = self.alpha_i8f24 > 0
            && self.gate_i16f16 >= 0
            && self.drift_fs.raw() >= 0
            && self.drift_rel.raw() >= 0
            && (0..1 << PARAM_FRAC_BITS).contains(&self.min_pole2.raw());
        if ok {
            Ok(())
        } else {
            Err(ConfigError::Health(f64::NAN))
        }
    }

    /// The configuration as a sealed frame of configuration words ([`crate::words`]) in `out`
    /// (at least [`HEALTH_WORDS_MAX`] words); returns its length.
    ///
    /// # Errors
    /// [`ConfigError::Words`] when `out` is too short.
    pub fn to_words(&self, out: &mut [u32]) -> Result<usize, ConfigError> {
        crate::words::put_frame(self, out)
    }

    /// Decodes a frame of [`Self::to_words`] and checks it ([`Self::validate`]): what a target
    /// runs instead of [`HealthDesign::build`] (no `f64`).
    ///
    /// # Errors
    /// The frame's errors ([`crate::words::open`]), [`ConfigError::Words`] at the first bad
    /// word (an index into the frame), or [`Self::validate`]'s.
    pub fn from_words(words: &[u32]) -> Result<Self, ConfigError> {
        let config: Self = crate::words::take_frame(words)?;
        config.validate()?;
        Ok(config)
    }
}

/// The RLS settings' words, then α (I8F24 raw), the gate (I16F16 raw), the drift thresholds,
/// the update count and min_pole² (I12F20 raw).
impl Words for HealthConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.rls.put(w)?;
        self.alpha_i8f24.put(w)?;
        self.gate_i16f16.put(w)?;
        self.drift_fs.put(w)?;
        self.drift_rel.put(w)?;
        self.min_updates.put(w)?;
        self.min_pole2.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            rls: RlsConfig::take(r),
            alpha_i8f24: i32::take(r),
            gate_i16f16: i32::take(r),
            drift_fs: ParamI12F20::take(r),
            drift_rel: ParamI12F20::take(r),
            min_updates: u32::take(r),
            min_pole2: ParamI12F20::take(r),
        }
    }
}

/// The interrupt side's state: the pair in progress, the drop counter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HealthFeed {
    /// y(2m−2): the reading that starts the pair (`None` before the first).
    y_start: Option<PositionI48F16>,
    /// u(2m−2), u(2m−1) as they arrive.
    u_first: SignalI16F16,
    u_second: SignalI16F16,
    /// The next call reads the second sample of the pair.
    second: bool,
    dropped: u32,
    after_drop: bool,
}

impl Default for HealthFeed {
    fn default() -> Self {
        Self::new()
    }
}

impl HealthFeed {
    /// Empty history, nothing dropped.
    pub const fn new() -> Self {
        Self {
            y_start: None,
            u_first: SignalI16F16::ZERO,
            u_second: SignalI16F16::ZERO,
            second: false,
            dropped: 0,
            after_drop: false,
        }
    }

    /// Samples dropped on a full queue since [`Self::new`] (saturating).
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Forgets the pair in progress and keeps the count: the next reading starts a new pair,
    /// and the next sample pushed breaks the lag chain as after a drop. For a sample that is not
    /// fed (no reading, or a drive that is not the servo's: calibration's experiment, a safe
    /// stop), so that no pair spans it.
    pub fn restart(&mut self) {
        self.y_start = None;
        self.second = false;
        self.after_drop = true;
    }
}

/// What [`HealthConfig::feed`] did.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FeedFlags(u8);

impl FeedFlags {
    /// Nothing pushed (the first of a pair, or the first reading).
    pub const NONE: Self = Self(0);
    /// A sample was pushed.
    pub const PUSHED: Self = Self(1);
    /// The queue was full: the sample was dropped and counted.
    pub const DROPPED: Self = Self(2);
    /// The travel V saturated.
    pub const SATURATED: Self = Self(4);

    /// All flags with their names, in bit order.
    pub const NAMES: [(Self, &'static str); 3] = [
        (Self::PUSHED, "pushed"),
        (Self::DROPPED, "dropped"),
        (Self::SATURATED, "saturated"),
    ];
}

crate::flag_set_impl!(FeedFlags, u8);

/// The background side's state: θ and P, the lags, the counters, the reference.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HealthState {
    rls: RlsState<HEALTH_N>,
    /// V(m−1), u(2m−3), u(2m−4).
    lags: [SignalI16F16; 3],
    /// The lags hold the previous sample (not after the start or a drop).
    lags_valid: bool,
    updates: u32,
    samples: u32,
    reference_fs: ParamI12F20,
    /// a² of the reference.
    reference_pole2: ParamI12F20,
}

/// The reference a verdict compares with, and the θ the estimator starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthReference {
    /// c_ref, fraction of full scale.
    pub coulomb_fs: ParamI12F20,
    /// θ₀ = [a², γ₁, γ₂, γ₃, γ₄, w].
    pub theta0: [ParamI12F20; HEALTH_N],
}

impl HealthReference {
    /// From the power-on calibration's model (per Ts): the module doc's model with its a, K
    /// and mean Coulomb level (`None` when a value leaves I12F20 or a ∉ (0, 1)).
    pub fn from_calibration(model: &super::CalibratedModel) -> Option<Self> {
        let [a2, g1, g2, g3, g4, w, c] =
            reference_theta(model.a, model.gain_k, model.coulomb_mean_fs())?;
        let p = |x: f32| ParamI12F20::from_f64(f64::from(x)).ok();
        Some(Self {
            coulomb_fs: p(c)?,
            theta0: [p(a2)?, p(g1)?, p(g2)?, p(g3)?, p(g4)?, p(w)?],
        })
    }
}

/// θ₀ and c_ref from the calibration's a, K, c (the module doc's model): β₁ = K·d₀,
/// β₂ = K·(c₁·(1 − a) − a·d₀) with c₁ = (1 − a)/λ, d₀ = 1 − c₁, λ = −ln a (the calibration's
/// exact ZOH, [`super::calibration`]); γ the coefficients of (1 + q⁻¹)(1 + a·q⁻¹)(β₁q⁻¹ + β₂q⁻²);
/// w = −c·Σγ. Returns [a², γ₁, γ₂, γ₃, γ₄, w, c].
#[allow(clippy::float_arithmetic)] // background, once per calibration
pub fn reference_theta(a: f32, gain_k: f32, c: f32) -> Option<[f32; 7]> {
    if !(a > 0.0 && a < 1.0 && gain_k.is_finite() && c.is_finite()) {
        return None;
    }
    let lambda = -libm::logf(a);
    let c1 = if lambda < 1e-3 {
        1.0 - lambda * (0.5 - lambda / 6.0)
    } else {
        (1.0 - a) / lambda
    };
    let d0 = 1.0 - c1;
    let b1 = gain_k * d0;
    let b2 = gain_k * (c1 * (1.0 - a) - a * d0);
    let g = [b1, b2 + (1.0 + a) * b1, (1.0 + a) * b2 + a * b1, a * b2];
    let sum: f32 = g.iter().sum();
    Some([a * a, g[0], g[1], g[2], g[3], -c * sum, c])
}

/// What the background's estimator and its verdict report.
#[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthFlags(u8);

impl HealthFlags {
    /// Nothing to report: healthy.
    pub const NONE: Self = Self(0);
    /// The identified Coulomb level has risen above the band over the reference.
    pub const DRIFT: Self = Self(1);
    /// Fewer than `min_updates` updates since the reference: no verdict yet.
    pub const NOT_READY: Self = Self(2);
    /// Σγ ≤ 0: the level is undefined (reported as 0).
    pub const NO_GAIN: Self = Self(4);
    /// The reference's pole is below `min_pole`: friction is not identifiable on seeks.
    pub const NOT_IDENTIFIABLE: Self = Self(8);

    /// All flags with their names, in bit order (`bits()`: `DRIFT` 1, `NOT_READY` 2,
    /// `NO_GAIN` 4, `NOT_IDENTIFIABLE` 8).
    pub const NAMES: [(Self, &'static str); 4] = [
        (Self::DRIFT, "drift"),
        (Self::NOT_READY, "not_ready"),
        (Self::NO_GAIN, "no_gain"),
        (Self::NOT_IDENTIFIABLE, "not_identifiable"),
    ];
}

crate::flag_set_impl!(HealthFlags, u8);

/// The verdict: the identified level and the flags.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HealthVerdict {
    /// ĉ = −w/Σγ, fraction of full scale.
    pub coulomb_fs: ParamI12F20,
    /// c_ref, fraction of full scale.
    pub reference_fs: ParamI12F20,
    /// Updates since the reference.
    pub updates: u32,
    /// [`HealthFlags`].
    pub flags: HealthFlags,
}

impl HealthConfig {
    /// A state at θ₀ = 0 and c_ref = 0 ([`Self::set_reference`] before the first verdict).
    pub fn new_state(&self) -> HealthState {
        HealthState {
            rls: RlsState::new(&self.rls, [ParamI12F20::ZERO; HEALTH_N]),
            lags: [SignalI16F16::ZERO; 3],
            lags_valid: false,
            updates: 0,
            samples: 0,
            reference_fs: ParamI12F20::ZERO,
            reference_pole2: ParamI12F20::ZERO,
        }
    }

    /// Restarts the estimator at the reference's θ₀ (P = p₀·I) and compares with its level from now
    /// on (after power-on calibration and every re-calibration).
    pub fn set_reference(&self, st: &mut HealthState, reference: &HealthReference) {
        st.rls.reset(&self.rls, reference.theta0);
        st.reference_fs = reference.coulomb_fs;
        st.reference_pole2 = reference.theta0[0];
        st.updates = 0;
    }

    /// The interrupt's part, every sample: reading y and drive u. Pushes every second sample;
    /// on a full queue drops it and counts it. Never waits, never panics.
    pub fn feed<const Q: usize>(
        &self,
        feed: &mut HealthFeed,
        producer: &mut Producer<'_, HealthSample, Q>,
        y: PositionI48F16,
        u: SignalI16F16,
    ) -> FeedFlags {
        if feed.y_start.is_some() && feed.second {
            feed.u_second = u;
            feed.second = false;
            return FeedFlags::NONE;
        }
        // The pair's travel and drives (none on the first reading); y starts the next pair.
        let mut sat = false;
        let sample = feed.y_start.map(|start| HealthSample {
            v: y.offset_from(start, &mut sat),
            u: [feed.u_second, feed.u_first],
            after_drop: feed.after_drop,
        });
        feed.y_start = Some(y);
        feed.u_first = u;
        feed.second = true;
        let Some(sample) = sample else {
            return FeedFlags::NONE;
        };
        let mut flags = FeedFlags::NONE;
        flags.set_if(FeedFlags::SATURATED, sat);
        if producer.enqueue(sample).is_ok() {
            feed.after_drop = false;
            flags |= FeedFlags::PUSHED;
        } else {
            feed.dropped = feed.dropped.saturating_add(1);
            feed.after_drop = true;
            flags |= FeedFlags::DROPPED;
        }
        flags
    }

    /// The background's part: pops and runs [`Self::step`] on every queued sample; returns how
    /// many it ran.
    pub fn drain<const Q: usize>(
        &self,
        st: &mut HealthState,
        consumer: &mut Consumer<'_, HealthSample, Q>,
    ) -> u32 {
        let mut n = 0u32;
        while let Some(sample) = consumer.dequeue() {
            self.step(st, sample);
            n = n.saturating_add(1);
        }
        n
    }

    /// tanh(α·v), I16F16.
    fn neuron(&self, v: SignalI16F16) -> SignalI16F16 {
        let mut sat = false;
        // α I8F24 × v I16F16 = I24F40, |·| < 2⁶²; to I8F24 (tanh is ±1 beyond the saturation).
        let z = sat_i32(
            shr_round_i64(mul_i32_wide(self.alpha_i8f24, v.raw()), 16),
            &mut sat,
        );
        let t_i2f30 = tanh_i2f30(z);
        SignalI16F16::from_raw(t_i2f30 >> (TANH_FRAC_BITS - 16))
    }

    /// One sample at 2·Ts (module doc's equation). Never panics.
    pub fn step(&self, st: &mut HealthState, sample: HealthSample) -> Status {
        st.samples = st.samples.saturating_add(1);
        if sample.after_drop {
            st.lags_valid = false;
        }
        let mut status = Status::WARMUP;
        let [v1, u3, u4] = st.lags;
        let [u1, u2] = sample.u;
        if st.lags_valid {
            let phi = [v1, u1, u2, u3, u4, self.neuron(v1)];
            let moving = |v: SignalI16F16| v.raw().saturating_abs() >= self.gate_i16f16;
            let one_sign = (sample.v.raw() > 0) == (v1.raw() > 0);
            status = Status::HELD;
            if moving(sample.v) && moving(v1) && one_sign {
                let mut sat = false;
                let pred = RlsConfig::predict(st.rls.theta(), &phi, &mut sat);
                let eps = SignalI16F16::from_raw(sat_i32(
                    i64::from(sample.v.raw()) - i64::from(pred.raw()),
                    &mut sat,
                ));
                status = self.rls.update(&mut st.rls, &phi, eps);
                status.set_if(Status::SATURATED, sat);
                if status.contains(Status::UPDATED) {
                    st.updates = st.updates.saturating_add(1);
                }
            }
        }
        st.lags = [sample.v, u1, u2];
        st.lags_valid = true;
        status
    }

    /// ĉ against c_ref (module doc's *Verdict*). Background; one division.
    pub fn verdict(&self, st: &HealthState) -> HealthVerdict {
        let [_, g1, g2, g3, g4, w] = *st.rls.theta();
        let b = [g1, g2, g3, g4]
            .iter()
            .map(|g| i64::from(g.raw()))
            .sum::<i64>();
        let mut flags = HealthFlags::NONE;
        let mut sat = false;
        let level = if b > 0 {
            // |w·2²⁰| < 2⁵¹; the quotient saturates to I12F20.
            sat_i32((-(i64::from(w.raw())) << PARAM_FRAC_BITS) / b, &mut sat)
        } else {
            flags |= HealthFlags::NO_GAIN;
            0
        };
        let reference = st.reference_fs.raw();
        let rel = shr_round_i64(
            mul_i32_wide(self.drift_rel.raw(), reference.saturating_abs()),
            PARAM_FRAC_BITS,
        );
        let band = rel.saturating_add(i64::from(self.drift_fs.raw()));
        let rise = i64::from(level) - i64::from(reference);
        if st.reference_pole2.raw() < self.min_pole2.raw() {
            flags |= HealthFlags::NOT_IDENTIFIABLE;
        } else if st.updates < self.min_updates {
            flags |= HealthFlags::NOT_READY;
        } else if rise > band && !flags.contains(HealthFlags::NO_GAIN) {
            flags |= HealthFlags::DRIFT;
        }
        HealthVerdict {
            coulomb_fs: ParamI12F20::from_raw(level),
            reference_fs: st.reference_fs,
            updates: st.updates,
            flags,
        }
    }
}

impl HealthState {
    /// θ = [a², γ₁, γ₂, γ₃, γ₄, w].
    pub fn theta(&self) -> &[ParamI12F20; HEALTH_N] {
        self.rls.theta()
    }

    /// Updates since the reference.
    pub fn updates(&self) -> u32 {
        self.updates
    }

    /// Samples popped since [`HealthConfig::new_state`] (saturating).
    pub fn samples(&self) -> u32 {
        self.samples
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default design round-trips through its words; a single-bit flip anywhere, a short
    /// frame and a re-sealed invalid value (α = 0, a dead zone above the outlier gate) are
    /// refused. Trips on a `take` that misses a field, a `validate` that misses a check `build`
    /// makes, or words that do not carry the quantised RLS settings exactly.
    #[test]
    fn the_health_configuration_round_trips_through_its_words() {
        let config = HealthDesign::default().build().unwrap();
        let mut buf = [0u32; HEALTH_WORDS_MAX];
        let n = config.to_words(&mut buf).unwrap();
        let words = &buf[..n];
        assert_eq!(HealthConfig::from_words(words), Ok(config));
        for at in 0..n {
            for bit in 0..32 {
                let mut bad = words.to_vec();
                bad[at] ^= 1 << bit;
                assert!(
                    HealthConfig::from_words(&bad).is_err(),
                    "word {at} bit {bit}"
                );
            }
        }
        assert!(HealthConfig::from_words(&words[..n - 1]).is_err());
        let resealed = |c: HealthConfig| {
            let mut out = [0u32; HEALTH_WORDS_MAX];
            let n = crate::words::put_frame(&c, &mut out).unwrap();
            HealthConfig::from_words(&out[..n])
        };
        let tiny = HealthDesign {
            neuron_slope_per_quantum: 1e-7,
            ..HealthDesign::default()
        };
        assert_eq!(
            tiny.build(),
            Err(ConfigError::Health(1e-7)),
            "α quantised to 0"
        );
        let mut bad = config;
        bad.alpha_i8f24 = 0;
        assert!(matches!(resealed(bad), Err(ConfigError::Health(_))));
        let mut bad = config;
        bad.rls = RlsDesign {
            dead_zone: 2.0,
            outlier_threshold: 3.0,
            ..HealthDesign::default().rls
        }
        .build()
        .unwrap();
        assert_eq!(resealed(bad).map(|c| c.rls), Ok(bad.rls));
        bad.rls.outlier_for_test(1 << 17);
        assert!(matches!(
            resealed(bad),
            Err(ConfigError::OutlierThreshold(_))
        ));
    }
}
