//! The gain-scheduled position controller: seek / settle / hold laws chosen per sample by
//! [`RegionSelector`], settle and seek gains placed on-line from the identified model
//! ([`super::placement`]), an inverse input map for the identified static nonlinearity
//! ([`InverseInputMap`]), and a supervisor that falls back to the baseline PID
//! ([`PidConfig`]) whenever the model is not trusted.
//!
//! # Law (per sample k; positions in quanta, u in full scale)
//! ```text
//! e = r − y,  d_y = y(k) − y(k−2),  d_r = r(k) − r(k−2),  v_r = r(k) − r(k−1),  Δv_r = v_r(k) − v_r(k−1)
//! Seek:    v = Kp_s·e + Kd_s/2·(d_r − d_y) + (1 − a)/b·v_r + Δv_r/b + I,   I ← I − I/2⁴ (fades)
//!          (time-optimal seeks, [`super::seek`]: on the seek observer's (x̂, v̂), e″ = r − x̂ − (c₁ − a·b₀/b)·v̂,
//!           v = ((1 − p)·sgn(e″)·K⁻¹(|e″|) + (p − a)·v̂)/b, u = v + u_c·sgn(v̂): the drive whose stop
//!           point is the target r; Settle only once at rest in the settle band)
//! Settle:  v = Kp_z·e − Kd_z/2·d_y + I,   I ← clamp(I + Ki_z·e, ±I_max)   (conditional integration)
//! Hold:    u = u_hold,  I frozen                                           (dead band: no limit cycle)
//! u = clamp(h⁻¹(v), ±u_max)                                                (compensation optional)
//! Redesign: θ = [a…, b…, c] → (a, b) placed; h = Coulomb map of u_c = c/Σb    (friction identified)
//! Settle with a Wiener output map ŷ = x + w·tanh(a·x + c):  e ← −m⁻¹(y − r)   (output compensation)
//! ```
//! **Settle of a time-optimal seek** (the rules below measured over 16 families of 200 plants,
//! BENCHMARKS.md, "Settle after a time-optimal seek"). Coasting damps the larger of two
//! motions: the seek observer's v̂ (model-propagated, sub-quantum) beyond v_arrive, and the
//! velocity observer's beyond l/2 — a heavy, nearly frictionless sled left gliding at a tenth
//! of a quantum per sample is under the latter's dead zone and coasts out of the band; a fast
//! sled the model has (wrongly) at rest shows only in the latter. Hold takes a sled only at
//! rest by the seek observer's v̂ too. On a sticky model ([`super::seek::SeekPlan::sticky`]) a
//! fine step's drive, while the reading stands still, is applied one sample in [`PULSE_PERIOD`]:
//! a ramp that breaks the sled away keeps driving it until the reading shows the move — on a
//! fast sled with stiction 2–3× its Coulomb level, three quanta and more — while a pulse stops
//! driving at once and friction stops the sled within a sample or two. Pulsing every still
//! settle sample, not only fine steps, helped the sticky sleds a little more and cost the
//! nominal sled's short dwells their pulses (measured in BENCHMARKS.md). In both modes a fine
//! step is pulsed, too, once one has thrown the sled a cell past the target on a model whose
//! breakaway throws ([`super::placement::breakaway_throws`]; [`rest`], "A sticking sled's
//! breakaway"): the sled's stiction, which no model here identifies, shown by the sled itself.
//!
//! The paper (§3, Fig. 4) shows the baseline's ±1-quantum limit cycle is controller-induced and
//! that the lens loop takes up the residual error: Hold stops driving the sled inside the band and
//! lets static friction hold it.
//!
//! **Transfers.** Entering Seek or Settle from another law re-initialises I so that v is
//! continuous (`I = v(k−1) − terms(k)`, clamped to ±I_max; [`ControlFlags::TRANSFER_LIMITED`]
//! when the clamp binds). Leaving Hold resumes with the frozen integrator. Entering the fallback
//! primes the baseline PID in manual at the last output (its own bumpless enable), returning
//! from it re-initialises I from `h(u(k−1))`.
//!
//! **Supervisor.** A bad estimator flag ([`Status::COVARIANCE_SATURATED`], `SATURATED`,
//! `SENSOR_STUCK`, `INPUT_REJECTED`, `OUTLIER`) distrusts the model for `untrusted_hold_samples`;
//! a running mean of |ε| (time constant 32 samples) above `eps_limit_quanta` distrusts it while it
//! lasts; [`ScheduledConfig::redesign`] refuses models outside the allowed region. In any of
//! these the baseline PID runs and [`ControlFlags::FALLBACK`] is set.
//!
//! # Formats
//! Positions I48F16 (`i64`), differences and e I16F16 (saturating, flagged), gains [`Gain`](crate::num::gain::Gain),
//! terms and I in I32F32 (`i64`, each term < 2⁶², sums saturating), u I16F16. The running mean of
//! |ε| is a `u32` in I16F16 (`m ← m − m/32 + |ε|/32`, never above max |ε|).
//!
//! # Accuracy
//! Against the float64 law (`host-tests/src/reference/scheduled.rs`) in the twin's closed loop, 30
//! seeks: identical regions and fallback decisions; |u − u_f64| < 2·10⁻⁵ full scale without
//! compensation (output LSB, gain rounding), < 4·10⁻³ with the Coulomb inverse map or a Wiener
//! output map (the table's interpolation at the map's steep centre)
//! (`fixed_point_matches_float64_in_closed_loop` in `host-tests/tests/integration/scheduled_control.rs`); an
//! identity output map is bit-identical to none (`output_map_acts_only_in_settle_and_identity_is_exact`).
//!
//! # Cost
//! `bench_sched_step` and `bench_sched_redesign` (the redesign, outside the interrupt) in
//! BENCHMARKS.md.

#![deny(clippy::float_arithmetic)]

pub mod learn;
pub mod observer;
pub mod regions;
pub mod rest;
pub mod supervisor;

use super::compensation::InverseInputMap;
use super::integrator::integrate;
use super::pid::{PidConfig, PidDesign, PidState};
use super::placement::{ModelGains, PlacementDesign, Rejection, SupervisorDesign, VelocityModel};
use super::seek::{SeekObserver, SeekPlan, TimeOptimalDesign};
use super::{ConfigError, ControlFlags, ControlInput, ControlOutput, Controller, PidFlags};
use crate::ident::status::Status;
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::{ParamI12F20, SignalI16F16, sat_i32, shr_round_i64};
use crate::num::float_bits::from_fixed;
use crate::num::gain::{LIMIT_I32F32_MAX, clamp_sym_i32, clamp_sym_i64, i32f32_from_f64};
use crate::words::{WordReader, WordWriter, Words};
use learn::{RATIO_ONE, SeekGainLearner};
use observer::VelocityObserver;
use regions::{Region, RegionDesign, RegionSelector};
use rest::{NearTarget, StillReading, Verdict};
use supervisor::{DISTRUST, ModelReport, Redesign};

/// How the Seek region drives the sled.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum SeekMode {
    /// Follow the reference r(k) (PD with the model-inverse feedforward): for users whose
    /// trajectory comes from elsewhere.
    #[default]
    FollowReference,
    /// r is the target ("go to track N"): full drive, then braking along the identified model's
    /// curve, handed to the settle law near the target ([`super::seek`]).
    TimeOptimal(TimeOptimalDesign),
}

impl SeekMode {
    /// Time-optimal seeks with the default α and velocity pole, and regions for a target that
    /// jumps: Settle within 3 quanta, back to Seek beyond 12.
    pub fn time_optimal() -> (Self, RegionDesign) {
        (
            Self::TimeOptimal(TimeOptimalDesign::default()),
            RegionDesign {
                settle_enter_quanta: 3.0,
                settle_leave_quanta: 12.0,
                ..RegionDesign::default()
            },
        )
    }
}

/// User-facing settings; [`ScheduledDesign::build`] validates and quantises.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduledDesign {
    /// The baseline PID: the fallback, and Ts, full scale and output limit of the whole controller.
    pub baseline: PidDesign,
    /// Region thresholds.
    pub regions: RegionDesign,
    /// Closed-loop poles of every identified model's gains.
    pub placement: PlacementDesign,
    /// Closed-loop poles of the prior's gains, which run until the first model is identified:
    /// slower than `placement`'s, so that a prior whose gain is several times off the sled's
    /// still gives a stable loop (a seek double pole p tolerates a gain error k while
    /// |a − k·(a − p²)| < 1: k < 2.6 at p = 0.4, k < 9.7 at p = 0.8, for a = 0.83).
    pub prior_placement: PlacementDesign,
    /// Allowed model region and estimator health limits.
    pub supervisor: SupervisorDesign,
    /// Settle integrator clamp ±I_max, V.
    pub integrator_limit_v: f64,
    /// Output while holding, V (0: let static friction hold the sled).
    pub hold_bias_v: f64,
    /// Denominator order na of the identifier's θ = [a…, b…] (1 or 2).
    pub model_na: usize,
    /// The identifier's θ ends with a Coulomb term c = Σb·u_c
    /// ([`crate::ident::linear::LinearDesign::coulomb`]): left out of the gain.
    pub model_coulomb: bool,
    /// Each accepted redesign replaces the input compensation with the Coulomb inverse map of the
    /// identified level u_c = c/Σb ([`coulomb_compensation`]); needs `model_coulomb`. Off: the
    /// compensation stays `compensation` (linear-only scheduling).
    pub identify_friction: bool,
    /// A velocity model (a, b) to start from; `None`: baseline until the first accepted redesign.
    pub prior_model: Option<(f64, f64)>,
    /// Inverse of the static input map the loop starts with (the prior's friction), if any.
    pub compensation: Option<InverseInputMap>,
    /// How seeks are driven: along the reference, or time-optimally to the target the reference
    /// jumps to.
    pub seek: SeekMode,
    /// Inverse of a Wiener output map `m(x) = x + w·tanh(a·x + c)` (quanta, centred on the
    /// reference, as the paper's Wiener model of [`crate::ident::nonlinear`] identifies it): every
    /// law — its P and I terms and the velocity observer — acts on the linear position
    /// x̂ = r + m⁻¹(y − r), not on the reading, so the gains placed on the linear model meet a
    /// linear plant. Region selection, rest and the hold band stay on the reading (quanta of the
    /// sensor).
    pub output_map: Option<InverseInputMap>,
}

impl ScheduledDesign {
    /// The default schedule around `baseline`: ARX(1, 1) with a Coulomb term on velocity
    /// (θ = [a₁, b₁, c], the friction identified and compensated), no prior, no compensation to
    /// start with.
    pub fn new(baseline: PidDesign) -> Self {
        Self {
            baseline,
            regions: RegionDesign::default(),
            placement: PlacementDesign::default(),
            prior_placement: PlacementDesign {
                seek_pole: 0.8,
                settle_pole: 0.85,
                ..PlacementDesign::default()
            },
            supervisor: SupervisorDesign::default(),
            integrator_limit_v: 1.0,
            hold_bias_v: 0.0,
            model_na: 1,
            model_coulomb: true,
            identify_friction: true,
            prior_model: None,
            compensation: None,
            seek: SeekMode::FollowReference,
            output_map: None,
        }
    }

    /// This design with time-optimal seeks ([`SeekMode::time_optimal`]: the default α, velocity
    /// pole and regions).
    pub fn with_time_optimal_seeks(mut self) -> Self {
        let (seek, regions) = SeekMode::time_optimal();
        self.seek = seek;
        self.regions = regions;
        self
    }

    /// The prior is the sled's own model (measured, or a calibration's): its seek plan brakes
    /// and follows at [`TimeOptimalDesign::TRUSTED`] instead of the prior's cautious settings.
    /// No change without time-optimal seeks.
    pub fn with_trusted_prior(mut self) -> Self {
        if let SeekMode::TimeOptimal(t) = &mut self.seek {
            (t.alpha_prior, t.velocity_pole_prior) = TimeOptimalDesign::TRUSTED;
        }
        self
    }

    /// Validates and quantises; places the prior model's gains if there is one.
    ///
    /// # Errors
    /// The first [`ConfigError`]: the baseline's, a region threshold, a pole, a supervisor limit,
    /// [`ConfigError::IntegratorLimit`], [`ConfigError::OutputLimit`] (hold bias),
    /// [`ConfigError::ModelOrder`], or [`ConfigError::InitialModel`] for a prior the supervisor
    /// refuses.
    #[allow(clippy::float_arithmetic)] // design time
    pub fn build(&self) -> Result<ScheduledConfig, ConfigError> {
        let baseline = self.baseline.build()?;
        let selector = self.regions.build()?;
        self.placement.validate()?;
        self.prior_placement.validate()?;
        self.supervisor.validate()?;
        let fs = self.baseline.u_full_scale_v;
        let i_max = i32f32_from_f64(self.integrator_limit_v / fs)
            .ok_or(ConfigError::IntegratorLimit(self.integrator_limit_v))?;
        let hold = SignalI16F16::from_f64(self.hold_bias_v / fs)
            .ok()
            .filter(|h| h.raw().unsigned_abs() <= baseline.u_limit().raw().unsigned_abs())
            .ok_or(ConfigError::OutputLimit(self.hold_bias_v))?;
        if !(1..=2).contains(&self.model_na) {
            return Err(ConfigError::ModelOrder {
                na: self.model_na,
                nb: 1,
                n: self.model_na + 1,
            });
        }
        if self.identify_friction && !self.model_coulomb {
            return Err(ConfigError::CoulombTerm);
        }
        let eps_limit = SignalI16F16::from_f64(self.supervisor.eps_limit_quanta)
            .map_err(|_| ConfigError::SupervisorLimit(self.supervisor.eps_limit_quanta))?;
        let seek = match self.seek {
            SeekMode::FollowReference => None,
            SeekMode::TimeOptimal(d) => {
                d.validate()?;
                Some(d)
            }
        };
        let mut config = ScheduledConfig {
            seek,
            baseline,
            selector,
            placement: self.placement,
            supervisor: self.supervisor,
            prior_gains: None,
            integrator_limit_i32f32: i_max,
            u_limit_i32f32: i64::from(baseline.u_limit().raw()) << 16,
            hold_bias: hold.raw(),
            eps_limit: eps_limit.raw().unsigned_abs(),
            na: self.model_na,
            model_coulomb: self.model_coulomb,
            identify_friction: self.identify_friction,
            compensation: self.compensation,
            output_map: self.output_map,
        };
        if let Some((a, b)) = self.prior_model {
            let model = VelocityModel {
                a: a as f32,
                b: b as f32,
                coulomb_fs: 0.0,
            };
            // The supervisor's checks apply to the prior too.
            super::placement::reduce(
                &[
                    ParamI12F20::from_f64(-a).map_err(|_| ConfigError::InitialModel(a))?,
                    ParamI12F20::from_f64(b).map_err(|_| ConfigError::InitialModel(b))?,
                ],
                1,
                &self.supervisor,
            )
            .map_err(|_| ConfigError::InitialModel(a))?;
            let mut gains = super::placement::place(model, &self.prior_placement)
                .map_err(|_| ConfigError::InitialModel(b))?;
            gains.breakaway_throws = super::placement::breakaway_throws(
                model,
                compensation_level(self.compensation.as_ref()),
            );
            if let Some(d) = seek
                && !config.seek_plan_into(
                    &mut gains.seek,
                    model,
                    compensation_level(self.compensation.as_ref()),
                    d.alpha_prior,
                    d.velocity_pole_prior,
                )
            {
                return Err(ConfigError::SeekDesign(d.alpha_prior));
            }
            config.prior_gains = Some(gains);
        }
        config.validate()?;
        Ok(config)
    }
}

/// Validated configuration (`Copy`, immutable while the loop runs: the gains a redesign places
/// live in [`ScheduledState`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScheduledConfig {
    baseline: PidConfig,
    selector: RegionSelector,
    placement: PlacementDesign,
    supervisor: SupervisorDesign,
    /// The prior's gains (`None`: no prior, the baseline runs until a model is accepted).
    prior_gains: Option<ModelGains>,
    integrator_limit_i32f32: i64,
    u_limit_i32f32: i64,
    hold_bias: i32,
    eps_limit: u32,
    na: usize,
    model_coulomb: bool,
    identify_friction: bool,
    /// The input compensation the loop starts with.
    compensation: Option<InverseInputMap>,
    output_map: Option<InverseInputMap>,
    /// Time-optimal seeks (`None`: seeks follow the reference).
    seek: Option<TimeOptimalDesign>,
}

/// Everything a step mutates.
#[derive(Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ScheduledState {
    y1: i64,
    r1: i64,
    dr1_previous: i32,
    integral_i32f32: i64,
    /// The linear command v of the last sample (before h⁻¹), I32F32.
    last_v_i32f32: i64,
    last_u: i32,
    region: Region,
    primed: bool,
    in_fallback: bool,
    pid: PidState,
    untrusted: u16,
    eps_mean: u32,
    trusted_updates: u32,
    redesign_pending: bool,
    /// Hold's low-passed error, I16F16 raw quanta ([`regions`]).
    hold_error: i32,
    /// The velocity observer.
    observer: VelocityObserver,
    /// The time-optimal seek's observer of position and velocity (runs every sample when seeks
    /// are time-optimal).
    seek_observer: SeekObserver,
    /// The last sample's drive left Coulomb friction uncompensated (coasting, Hold, a pulse's
    /// off-sample): the seek observer decays v̂ by it.
    friction_free_drive: bool,
    /// The pulsed settle drive's phase, 0 … [`PULSE_PERIOD`] − 1 (0: on).
    pulse_phase: u8,
    /// Samples a time-optimal seek has spent in the settle band without arriving.
    arrival_wait: u16,
    /// Rest, cell and band bookkeeping near the target.
    near: NearTarget,
    /// The gains in use: the prior's, then each adopted redesign's.
    gains: ModelGains,
    /// The input compensation in use: the design's, then (friction identified) each adopted
    /// redesign's.
    compensation: Option<InverseInputMap>,
    /// The model was refused (or none accepted yet): the baseline runs.
    fallback: bool,
    /// The gains in use were placed from power-on calibration's θ (and what the seeks taught
    /// since): the seeks' gain is learnt ([`learn`]).
    calibrated_plan: bool,
    /// The seeks' gain learner.
    learner: SeekGainLearner,
    /// The learner asks for a redesign at its ratio.
    gain_redesign_pending: bool,
    /// Coasting: a sled without drive and its kept reading ([`rest`], "A resting sled's
    /// flicker").
    still: StillReading,
}

impl ScheduledState {
    /// A fresh state: Seek, unprimed, nothing distrusted, the gains `gains` (`None`: none yet, the
    /// baseline runs until a redesign is accepted) and the input compensation `compensation`.
    pub const fn new(gains: Option<ModelGains>, compensation: Option<InverseInputMap>) -> Self {
        let (gains, fallback) = match gains {
            Some(g) => (g, false),
            None => (ModelGains::ZERO, true),
        };
        Self {
            y1: 0,
            r1: 0,
            dr1_previous: 0,
            integral_i32f32: 0,
            last_v_i32f32: 0,
            last_u: 0,
            region: Region::Seek,
            primed: false,
            in_fallback: false,
            pid: PidState::new(),
            untrusted: 0,
            eps_mean: 0,
            trusted_updates: 0,
            redesign_pending: false,
            hold_error: 0,
            observer: VelocityObserver::new(),
            seek_observer: SeekObserver::new(),
            friction_free_drive: false,
            pulse_phase: 0,
            arrival_wait: 0,
            near: NearTarget::new(),
            gains,
            compensation,
            fallback,
            calibrated_plan: false,
            learner: SeekGainLearner::new(),
            gain_redesign_pending: false,
            still: StillReading::new(),
        }
    }

    /// The seeks' gain learner ([`learn`]).
    pub fn learner(&self) -> &SeekGainLearner {
        &self.learner
    }

    /// The time-optimal seek's observer.
    pub fn seek_observer(&self) -> &SeekObserver {
        &self.seek_observer
    }

    /// The region of the last step.
    pub fn region(&self) -> Region {
        self.region
    }

    /// A redesign is due (set on Seek → Settle, cleared when the servo takes the job).
    pub fn redesign_pending(&self) -> bool {
        self.redesign_pending
    }

    /// Asks for a redesign now (as the Seek → Settle transfer does): the servo takes the job
    /// after the next step.
    pub fn request_redesign(&mut self) {
        self.redesign_pending = true;
    }

    /// The settle integrator, fraction of full scale.
    pub fn integral(&self) -> SignalI16F16 {
        SignalI16F16::from_raw(sat_i32(shr_round_i64(self.integral_i32f32, 16), &mut false))
    }

    /// The running mean of |ε|, quanta per sample.
    pub fn eps_mean(&self) -> SignalI16F16 {
        SignalI16F16::from_raw(sat_i32(i64::from(self.eps_mean), &mut false))
    }

    /// The gains in use.
    pub fn gains(&self) -> &ModelGains {
        &self.gains
    }

    /// The input compensation in use.
    pub fn compensation(&self) -> Option<&InverseInputMap> {
        self.compensation.as_ref()
    }

    /// True while the model is refused (or none was accepted yet): the baseline drives.
    pub fn fallback(&self) -> bool {
        self.fallback
    }
}

/// A time-optimal seek in the settle band hands over to Settle after this many samples even if
/// it has not arrived (a sled friction holds short of the target cell).
pub const ARRIVAL_WAIT_SAMPLES: u16 = 16;

/// A fine step's drive on a sticky model is applied one sample in this many (module doc,
/// "Settle of a time-optimal seek"); a power of two.
pub const PULSE_PERIOD: u8 = 4;

/// Trusted identifier updates since the last redesign after which a settling controller asks for
/// another.
pub const SETTLE_REDESIGN_UPDATES: u32 = 32;

/// Trusted identifier updates since the last redesign after which a reference-following seek
/// whose reference has arrived, but whose sled has not reached the settle band, asks for another.
/// On a slow sled (heavily damped, gain in quanta a tenth of the prior's) the prior's gains
/// crawl to the target over hundreds of samples and Settle, where redesigns were asked for, never
/// came before the next seek (`tests/integration/control.rs`, `a_crawling_seek_is_redesigned`). Not while the
/// reference moves: a model fitted to a saturated seek and placed mid-seek held heavy,
/// low-friction sleds two and three cells off (seeds 2, 5, 6 of the family: largest true holding
/// error 1.87 / 1.49 / 1.49 → 3.39 / 2.31 / 2.01 quanta).
pub const SEEK_REDESIGN_UPDATES: u32 = 128;

/// Largest θ a redesign job carries (na + nb (+ c) of the velocity model: ≤ 4).
pub const MAX_MODEL_PARAMS: usize = 4;

/// A redesign job: what the supervisor decided when it was requested, and the identifier's θ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RedesignJob {
    /// The estimator is distrusted: refuse (the baseline runs).
    Untrusted,
    /// No trusted update since the last design: keep the gains.
    Skip,
    /// Place gains from θ = [a₁ … a_na, b… (, c)] (the first `len` entries).
    Place {
        /// θ, zero-padded.
        theta: [ParamI12F20; MAX_MODEL_PARAMS],
        /// Entries of θ in use.
        len: u8,
        /// Where θ came from (the seek plan's α and p).
        source: ModelSource,
        /// ρ, I16F16: θ's gain terms (b… and c) are placed scaled by it ([`learn`]).
        gain_ratio: i32,
    },
}

impl RedesignJob {
    /// The θ's source and gain ratio ρ (I16F16) a placement carries; (identified, 1) otherwise.
    pub fn origin(&self) -> (ModelSource, i32) {
        match self {
            Self::Place {
                source, gain_ratio, ..
            } => (*source, *gain_ratio),
            _ => (ModelSource::Identified, RATIO_ONE),
        }
    }
}

/// Where a placed θ came from: the seek plan's α and p are chosen by it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelSource {
    /// Identified on-line (or the prior's).
    Identified,
    /// Measured by power-on calibration.
    Calibrated,
    /// Calibration's, its gain corrected by the seeks ([`learn`]).
    Learnt,
}

/// What a redesign produced.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RedesignResult {
    /// The outcome.
    pub outcome: Redesign,
    /// The gains, when placed.
    pub gains: Option<ModelGains>,
    /// The input compensation of the identified friction, when placed with `identify_friction`
    /// (`None` there: no friction worth compensating).
    pub compensation: Option<InverseInputMap>,
    /// The job's θ's source.
    pub source: ModelSource,
    /// The job's ρ, I16F16.
    pub gain_ratio: i32,
}

/// Identified Coulomb levels below this (fraction of full scale) are not compensated: the map's
/// slope at zero, 1/(1 − 0.9), would only amplify the estimate's noise.
pub const MIN_COULOMB_FS: f32 = 1e-3;
/// Identified Coulomb levels are capped here (fraction of full scale).
pub const MAX_COULOMB_FS: f32 = 0.5;

/// The input compensation of a Coulomb level `u_c` (fraction of full scale):
/// `h(u) = u − u_c·tanh(0.9·u/u_c)` inverted over v ∈ ±2·u_c ([`InverseInputMap::coulomb_raw`]);
/// past it h(u) − u is taken as constant (|u| ≥ 2.9·u_c: tanh within 1.1 %). `None` below
/// [`MIN_COULOMB_FS`] (or NaN), capped at [`MAX_COULOMB_FS`]. The table's interpolation error
/// scales with u_c (`tests/compensation_table.rs` bounds it). Integer arithmetic past the one
/// conversion.
#[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
pub fn coulomb_compensation(u_c: f32) -> Option<InverseInputMap> {
    if u_c.is_nan() || u_c < MIN_COULOMB_FS {
        return None;
    }
    let raw = (u_c.min(MAX_COULOMB_FS) * 65_536.0) as i32; // ≤ 32,768
    InverseInputMap::coulomb_raw(raw, raw.saturating_mul(2)).ok()
}

impl ScheduledConfig {
    /// The invariants the law relies on, checked by [`ScheduledDesign::build`] and by the
    /// decoding of configuration words alike: every part's own (`validate`), `0 ≤ I_max ≤
    /// i32::MAX·2¹⁶`, u_max the baseline's, |hold bias| ≤ u_max, ε limit < 2³¹, na ∈ {1, 2}.
    ///
    /// # Errors
    /// The [`ConfigError`] naming the parameter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.baseline.validate()?;
        self.selector.validate()?;
        self.placement.validate()?;
        self.supervisor.validate()?;
        if let Some(g) = &self.prior_gains {
            g.validate()?;
        }
        for map in [&self.compensation, &self.output_map].into_iter().flatten() {
            map.validate()?;
        }
        if self.identify_friction && !self.model_coulomb {
            return Err(ConfigError::CoulombTerm);
        }
        if let Some(d) = &self.seek {
            d.validate()?;
        }
        let i_max = self.integrator_limit_i32f32;
        if !(0..=LIMIT_I32F32_MAX).contains(&i_max) {
            return Err(ConfigError::IntegratorLimit(from_fixed(i_max, 32)));
        }
        let u_max = self.baseline.u_limit().raw();
        if self.u_limit_i32f32 != i64::from(u_max) << 16 {
            return Err(ConfigError::OutputLimit(from_fixed(i64::from(u_max), 16)));
        }
        if self.hold_bias.unsigned_abs() > u_max.unsigned_abs() {
            return Err(ConfigError::OutputLimit(from_fixed(
                i64::from(self.hold_bias),
                16,
            )));
        }
        if self.eps_limit > i32::MAX as u32 {
            return Err(ConfigError::SupervisorLimit(from_fixed(
                i64::from(self.eps_limit),
                16,
            )));
        }
        if !(1..=2).contains(&self.na) {
            return Err(ConfigError::ModelOrder {
                na: self.na,
                nb: 1,
                n: self.na + 1,
            });
        }
        Ok(())
    }

    /// The prior's gains (`None`: no prior).
    pub fn prior_gains(&self) -> Option<&ModelGains> {
        self.prior_gains.as_ref()
    }

    /// The baseline PID (the fallback).
    pub fn baseline(&self) -> &PidConfig {
        &self.baseline
    }

    /// The time-optimal seek plan of `model` (u_c: the Coulomb level compensated, fraction of full
    /// scale) braking at `alpha` with velocity pole `pole`, written into `plan` (in place: the
    /// redesign's frame holds one plan); false (and `plan` [`SeekPlan::NONE`]) when the model
    /// cannot brake or a gain does not fit (or seeks follow the reference).
    #[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
    fn seek_plan_into(
        &self,
        plan: &mut SeekPlan,
        model: VelocityModel,
        u_c: f32,
        alpha: f64,
        pole: f64,
    ) -> bool {
        if self.seek.is_none() {
            *plan = SeekPlan::NONE;
            return false;
        }
        let u_max = self.baseline.u_limit().to_f64() as f32;
        plan.design_into(model.a, model.b, u_c, u_max, alpha as f32, pole as f32)
    }

    /// Time-optimal seeks, if configured.
    pub fn seek(&self) -> Option<&TimeOptimalDesign> {
        self.seek.as_ref()
    }

    /// θ ends with a Coulomb term.
    pub fn model_coulomb(&self) -> bool {
        self.model_coulomb
    }

    /// The denominator order of θ.
    pub fn model_na(&self) -> usize {
        self.na
    }

    /// The compensation map the loop starts with, if any.
    pub fn compensation(&self) -> Option<&InverseInputMap> {
        self.compensation.as_ref()
    }

    /// θ split into the linear part [a…, b…] and the Coulomb term c (0 without one).
    pub fn split_theta<'a>(&self, theta: &'a [ParamI12F20]) -> (&'a [ParamI12F20], i32) {
        match (self.model_coulomb, theta.split_last()) {
            (true, Some((c, linear))) => (linear, c.raw()),
            _ => (theta, 0),
        }
    }

    /// θ with its gain terms (b… and the Coulomb term c = Σb·u_c: every entry past the na poles)
    /// scaled by `gain_ratio` (I16F16, [`learn`]), saturating at the format's range; ρ = 1
    /// returns θ exactly.
    fn scale_gain_terms(
        &self,
        theta: &[ParamI12F20; MAX_MODEL_PARAMS],
        gain_ratio: i32,
    ) -> [ParamI12F20; MAX_MODEL_PARAMS] {
        let mut scaled = *theta;
        for t in scaled.iter_mut().skip(self.na) {
            let x = shr_round_i64(i64::from(t.raw()).saturating_mul(i64::from(gain_ratio)), 16);
            *t = ParamI12F20::from_raw(sat_i32(x, &mut false));
        }
        scaled
    }

    /// [`Controller::redesign`]'s placement of θ (its first `len` entries, the gain terms
    /// scaled by `gain_ratio`, I16F16) from `source`: the gains, with `identify_friction` the
    /// compensation of the identified Coulomb level (the seek plan's u_c), written into
    /// `result`; the checked model, or why it was refused (`result`'s gains and compensation
    /// are then left for the caller to clear).
    #[allow(clippy::float_arithmetic)] // the redesign's, outside the interrupt
    fn place_into(
        &self,
        theta: &[ParamI12F20; MAX_MODEL_PARAMS],
        len: u8,
        source: ModelSource,
        gain_ratio: i32,
        result: &mut RedesignResult,
    ) -> Result<VelocityModel, Rejection> {
        let scaled = self.scale_gain_terms(theta, gain_ratio);
        let (linear, c) = self.split_theta(scaled.get(..usize::from(len)).unwrap_or(&[]));
        let mut m = super::placement::reduce(linear, self.na, &self.supervisor)?;
        let b_sum: f32 = linear.iter().skip(self.na).map(|p| p.to_f32()).sum();
        // b_sum > 0: reduce refuses a non-positive gain (Σb has the sign of b).
        m.coulomb_fs = ParamI12F20::from_raw(c).to_f32() / b_sum;
        // Built once: the result's compensation and the seek plan's u_c.
        if self.identify_friction {
            result.compensation = coulomb_compensation(m.coulomb_fs);
        }
        let g = result
            .gains
            .insert(super::placement::place(m, &self.placement)?);
        let u_c = if self.identify_friction {
            compensation_level(result.compensation.as_ref())
        } else {
            compensation_level(self.compensation.as_ref())
        };
        g.breakaway_throws = super::placement::breakaway_throws(m, u_c);
        if let Some(d) = self.seek {
            let (alpha, pole) = match source {
                ModelSource::Identified => (d.alpha, d.velocity_pole),
                ModelSource::Calibrated => (d.alpha_calibrated, d.velocity_pole_calibrated),
                ModelSource::Learnt => (d.alpha_calibrated, d.velocity_pole_learnt),
            };
            if !self.seek_plan_into(&mut g.seek, m, u_c, alpha, pole) {
                return Err(Rejection::GainFormat);
            }
        }
        Ok(m)
    }

    /// Supervisor bookkeeping of one identifier report; true when it distrusts the model now.
    fn supervise(&self, state: &mut ScheduledState, report: &ModelReport) -> bool {
        let bad = report.status.intersects(DISTRUST);
        state.untrusted = if bad {
            self.supervisor.untrusted_hold_samples
        } else {
            state.untrusted.saturating_sub(1)
        };
        if report
            .status
            .intersects(Status::UPDATED.union(Status::DEAD_ZONE))
        {
            let abs = report.eps.raw().unsigned_abs();
            // m − m/32 + |ε|/32 ≤ max(m, |ε|): no overflow.
            state.eps_mean = state.eps_mean - (state.eps_mean >> 5) + (abs >> 5);
        }
        if report.status.contains(Status::UPDATED) && !bad {
            state.trusted_updates = state.trusted_updates.saturating_add(1);
        }
        state.untrusted > 0 || state.eps_mean > self.eps_limit
    }

    /// One sample: reference and measurement (quanta) and the identifier's report in, the drive
    /// out. The only data path; never panics; |u| ≤ u_max for every input.
    pub fn step_law(
        &self,
        state: &mut ScheduledState,
        r: PositionI48F16,
        y: PositionI48F16,
        report: &ModelReport,
    ) -> ControlOutput {
        let mut tally = Tally {
            flags: ControlFlags::NONE,
            sat: false,
        };
        let mut s = self.measure(state, r, y, report, &mut tally);
        state.friction_free_drive = false;
        let sel = self.select(state, &mut s, &mut tally.flags);
        request_redesign_when_due(state, &s, &sel, &mut tally.flags);
        self.learn_seek_gain(state, &s, &sel, &mut tally.flags);
        tally.flags.set_if(ControlFlags::FALLBACK, s.falling_back);
        if s.falling_back && self.prior_gains.is_none() {
            return self.step_baseline(state, &s, sel.region, tally);
        }
        let returning = state.in_fallback;
        state.in_fallback = false;
        let band = self.selector.hold_band_raw();
        let near = sel.verdict.e_filtered.unsigned_abs() <= (band + (band >> 1)).unsigned_abs();
        let terms = match sel.region {
            Region::Hold => return self.step_hold(state, tally),
            Region::Seek if s.time_optimal => return self.step_time_optimal_seek(state, &s, tally),
            Region::Seek => self.seek_terms(state, &s),
            Region::Settle if near && state.near.fine_step(&sel.verdict) => {
                self.fine_step_terms(state, &s, &sel.verdict, &mut tally.flags)
            }
            Region::Settle if near => return self.step_coasting(state, &s, tally),
            Region::Settle => self.settle_terms(state, &s, true, false),
        };
        self.update_integral(state, &s, &sel, terms, returning, &mut tally.flags);
        self.drive_pid(state, terms, sel.region, tally)
    }

    /// The common front: the errors on the reading and on the linear position, priming, the
    /// supervisor's verdict, both observers and the reference's differences.
    fn measure(
        &self,
        state: &mut ScheduledState,
        r: PositionI48F16,
        y: PositionI48F16,
        report: &ModelReport,
        tally: &mut Tally,
    ) -> Sample {
        let e = sat_i32(r.raw().saturating_sub(y.raw()), &mut tally.sat);
        // The linear position the laws act on: with a Wiener output map ŷ = m(x) (centred on the
        // reference), x̂ = r + m⁻¹(y − r), so that gains placed on the linear model meet a linear
        // plant; without one, y itself. Decisions (regions, rest, band) stay on the reading.
        let e_lin = self.linear_error(e);
        let y_lin = r.raw().saturating_sub(i64::from(e_lin));
        if !state.primed {
            state.primed = true;
            (state.y1, state.r1) = (y_lin, r.raw());
            state.dr1_previous = 0;
            state.seek_observer.restart(y_lin);
            tally.flags.insert(ControlFlags::FIRST_SAMPLE);
        }
        let dy1 = sat_i32(y_lin.saturating_sub(state.y1), &mut tally.sat);
        let distrusted = self.supervise(state, report);
        tally
            .flags
            .set_if(ControlFlags::MODEL_UNTRUSTED, distrusted);
        // Falling back: to the prior's gains where there is a prior (placed for a model several
        // times off, they hold a sled the identified model has misled), else to the baseline PID.
        let falling_back = state.fallback || distrusted;
        let g = self.gains_in_use(&state.gains, falling_back);
        // The model's input over the last sample: the linear drive, after friction compensation.
        let v_prev = sat_i32(shr_round_i64(state.last_v_i32f32, 16), &mut tally.sat);
        let v_hat = state.observer.update(g, v_prev, dy1, &mut tally.sat);
        let time_optimal = self.seek.is_some();
        // The seek's error and velocity on its observer (time-optimal seeks only).
        let (e_seek, v_seek) = if time_optimal {
            state
                .seek_observer
                .update(&g.seek, v_prev, y_lin, &mut tally.sat);
            if state.friction_free_drive {
                state.seek_observer.coulomb_decay(&g.seek);
            }
            let x_hat = state.seek_observer.position();
            (
                sat_i32(r.raw().saturating_sub(x_hat), &mut tally.sat),
                state.seek_observer.velocity(),
            )
        } else {
            (0, 0)
        };
        let dr1 = sat_i32(r.raw().saturating_sub(state.r1), &mut tally.sat);
        let ar = dr1.saturating_sub(state.dr1_previous);
        (state.y1, state.r1) = (y_lin, r.raw());
        state.dr1_previous = dr1;
        Sample {
            r,
            y,
            e,
            e_lin,
            dy1,
            dr1,
            ar,
            v_hat,
            e_seek,
            v_seek,
            time_optimal,
            y_lin,
            v_prev,
            distrusted,
            falling_back,
        }
    }

    /// The gains in use: the prior's while falling back with a prior, else `gains` (the state's).
    /// Borrowed, not copied: the gains carry the seek plan's table (a copy per sample cost
    /// ≈ 400 cycles on the M0+).
    fn gains_in_use<'a>(&'a self, gains: &'a ModelGains, falling_back: bool) -> &'a ModelGains {
        match (falling_back, &self.prior_gains) {
            (true, Some(prior)) => prior,
            _ => gains,
        }
    }

    /// The region of this sample: the near-target verdict, the selector with the time-optimal
    /// arrival rule, and the transfer bookkeeping (the rest tracking re-entered on a change, v̂
    /// restarted on leaving a time-optimal seek).
    fn select(
        &self,
        state: &mut ScheduledState,
        s: &mut Sample,
        flags: &mut ControlFlags,
    ) -> Selection {
        let g = self.gains_in_use(&state.gains, s.falling_back);
        let verdict = state.near.update(
            s.y.raw(),
            s.e,
            state.observer.mean_velocity(),
            self.selector.hold_band_raw(),
            g.rest_samples,
            g.rest_speed_i16f16,
            s.time_optimal,
            state.last_u != 0,
        );
        let previous = state.region;
        // Time-optimal seeks: Hold takes a sled at rest by the model too (a frictionless sled
        // the last push set gliding is at rest by its readings for a while).
        let holdable = verdict.holdable && (!s.time_optimal || g.seek.at_rest(s.v_seek));
        let mut region =
            self.selector
                .select(previous, s.e, s.dr1, holdable, &mut state.hold_error);
        if s.time_optimal
            && previous == Region::Seek
            && region == Region::Settle
            && self.seek_goes_on(state, s)
        {
            region = Region::Seek;
        }
        if region != Region::Seek || previous != Region::Seek {
            state.arrival_wait = 0;
        }
        state.region = region;
        let changed = region != previous;
        if changed {
            state.near.enter(s.e, region == Region::Seek);
        }
        if changed && previous == Region::Seek && s.time_optimal {
            // Out of a time-optimal seek: the velocity observer lags the braking; its estimate
            // restarts at the seek observer's.
            s.v_hat = s.v_seek;
            state.observer.restart(s.v_hat);
        }
        flags.set_if(ControlFlags::REGION_CHANGED, changed);
        Selection {
            previous,
            region,
            changed,
            verdict,
        }
    }

    /// The seeks' gain learner ([`learn`]), for gains placed from calibration: a seek from rest
    /// opens its window, each Seek sample feeds it, leaving Seek closes it; a learnt ratio far
    /// enough from the gains in use asks for a redesign.
    fn learn_seek_gain(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        sel: &Selection,
        flags: &mut ControlFlags,
    ) {
        if !(s.time_optimal && state.calibrated_plan) || s.falling_back {
            state.learner.finish();
            return;
        }
        let due = if sel.region != Region::Seek {
            state.learner.finish()
        } else if sel.previous != Region::Seek || flags.contains(ControlFlags::FIRST_SAMPLE) {
            if s.dy1 == 0 && state.gains.seek.at_rest(s.v_seek) {
                state.learner.start(s.y_lin, s.r.raw());
            } else {
                state.learner.finish();
            }
            false
        } else {
            state.learner.step(&state.gains.seek, s.v_prev, s.y_lin)
        };
        if due {
            state.gain_redesign_pending = true;
            flags.insert(ControlFlags::REDESIGN_REQUESTED);
        }
    }

    /// The time-optimal arrival rule, asked when the selector would leave Seek for Settle: true
    /// while the seek goes on (counts the samples waited in the band).
    fn seek_goes_on(&self, state: &mut ScheduledState, s: &Sample) -> bool {
        // A time-optimal seek hands over at rest in the settle band, not at speed through it —
        // at rest by the model and by the reading (the observer of a model that is off can
        // think a sled still coasting stopped); a sled friction holds short is handed over
        // after ARRIVAL_WAIT_SAMPLES in the band.
        state.arrival_wait = state.arrival_wait.saturating_add(1);
        let g = self.gains_in_use(&state.gains, s.falling_back);
        let arrived = s.e.unsigned_abs() <= self.selector.settle_band_raw()
            && g.seek.at_rest(s.v_seek)
            && s.dy1 == 0;
        !arrived && state.arrival_wait < ARRIVAL_WAIT_SAMPLES
    }

    /// The fallback without a prior: the baseline PID drives.
    fn step_baseline(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        region: Region,
        mut tally: Tally,
    ) -> ControlOutput {
        let entering = !state.in_fallback;
        state.in_fallback = true;
        if entering {
            // The baseline's own bumpless enable: one manual step at the last output.
            state.pid.reset();
            state.pid.set_enabled(false);
            state
                .pid
                .set_manual_output(SignalI16F16::from_raw(state.last_u));
        }
        let out = self.baseline.step(&mut state.pid, s.r, s.y);
        state.pid.set_enabled(true);
        tally.flags.set_if(
            ControlFlags::OUTPUT_SATURATED,
            out.flags.contains(PidFlags::OUTPUT_SATURATED),
        );
        tally.sat |= out.flags.contains(PidFlags::ARITHMETIC_SATURATED);
        state.last_u = out.u.raw();
        state.last_v_i32f32 = i64::from(forward(state, out.u.raw())) << 16;
        tally.finish(out.u.raw(), region)
    }

    /// Hold: u = u_hold.
    fn step_hold(&self, state: &mut ScheduledState, tally: Tally) -> ControlOutput {
        // Nothing drives (not even the compensation map's value at 0): static friction
        // holds the sled; no integrator.
        state.integral_i32f32 = 0;
        state.friction_free_drive = true;
        state.last_u = self.hold_bias;
        state.last_v_i32f32 = i64::from(forward(state, self.hold_bias)) << 16;
        tally.finish(self.hold_bias, Region::Hold)
    }

    /// Time-optimal Seek: the drive whose stop point is the target (r), friction compensated
    /// against the motion.
    fn step_time_optimal_seek(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        mut tally: Tally,
    ) -> ControlOutput {
        state.integral_i32f32 = 0;
        let g = self.gains_in_use(&state.gains, s.falling_back);
        let v = sat_i32(
            shr_round_i64(g.seek.drive(s.e_seek, s.v_seek), 16),
            &mut tally.sat,
        );
        let u_max = self.u_max();
        let (u, applied) = g.seek.compensate(v, s.v_seek, u_max);
        tally.flags.set_if(
            ControlFlags::OUTPUT_SATURATED,
            u.unsigned_abs() == u_max.unsigned_abs() && u != v,
        );
        state.last_u = u;
        state.last_v_i32f32 = i64::from(applied) << 16;
        tally.finish(u, Region::Seek)
    }

    /// Settle coasting into the band: damping only, nothing pushes; a still sled's flicker is
    /// not motion ([`rest`], "A resting sled's flicker").
    fn step_coasting(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        mut tally: Tally,
    ) -> ControlOutput {
        tally.flags.insert(ControlFlags::COASTING);
        state.integral_i32f32 = 0;
        state.friction_free_drive = true;
        let flicker = state
            .still
            .flicker(s.y.raw(), state.last_u == 0, !s.time_optimal);
        tally.flags.set_if(ControlFlags::FLICKER, flicker);
        let g = self.gains_in_use(&state.gains, s.falling_back);
        let moving = if flicker {
            0
        } else if s.time_optimal {
            // The larger of the two observers' motions past their dead zones: the seek
            // observer's sees a glide below a quantum per sample, the reading's a fast sled the
            // model has (wrongly) at rest.
            let gliding = past(s.v_seek, g.seek.v_arrive);
            let moving = dead_zone(s.v_hat, g.obs_l);
            if gliding.unsigned_abs() > moving.unsigned_abs() {
                gliding
            } else {
                moving
            }
        } else {
            dead_zone(s.v_hat, g.obs_l)
        };
        let v = 0i64.saturating_sub(g.kd_settle.apply(moving));
        let u = clamp_sym_i32(sat_i32(shr_round_i64(v, 16), &mut tally.sat), self.u_max());
        state.last_u = u;
        // Uncompensated: the linear drive the sled sees is h(u).
        state.last_v_i32f32 = i64::from(forward(state, u)) << 16;
        tally.finish(u, Region::Settle)
    }

    /// Seek following the reference: PD with the model-inverse feedforward.
    fn seek_terms(&self, state: &ScheduledState, s: &Sample) -> Terms {
        let g = self.gains_in_use(&state.gains, s.falling_back);
        // Each term < 2^62 in magnitude; four of them are summed saturating.
        Terms {
            sum_i32f32: g
                .kp_seek
                .apply(s.e_lin)
                .saturating_add(g.kd_seek.apply(s.dr1.saturating_sub(s.v_hat)))
                .saturating_add(g.kv_ff.apply(s.dr1))
                .saturating_add(g.ka_ff.apply(s.ar)),
            integrating: false,
            compensate: true,
            pulsed: false,
        }
    }

    /// Fine positioning: at rest near the band's edge, the settle law (no compensation: its
    /// step at zero would chatter) moves the sled toward the target cell; its first move
    /// ends the step.
    fn fine_step_terms(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        verdict: &Verdict,
        flags: &mut ControlFlags,
    ) -> Terms {
        flags.insert(ControlFlags::FINE_STEP);
        if verdict.fine_arrived {
            // The sled broke away toward the target: the integrator that built up the
            // breakaway drive — on a sticking sled well above its Coulomb level — would
            // carry it a cell past; the settle law brakes it from here.
            state.integral_i32f32 = 0;
            flags.insert(ControlFlags::INTEGRATOR_RESTARTED);
        }
        self.settle_terms(state, s, false, true)
    }

    /// The settle law's PD terms (`compensate`: through the input compensation; `fine`: a fine
    /// step's, pulsed on a sticky sled).
    fn settle_terms(
        &self,
        state: &ScheduledState,
        s: &Sample,
        compensate: bool,
        fine: bool,
    ) -> Terms {
        let g = self.gains_in_use(&state.gains, s.falling_back);
        Terms {
            sum_i32f32: g
                .kp_settle
                .apply(s.e_lin)
                .saturating_sub(g.kd_settle.apply(s.v_hat)),
            integrating: true,
            compensate,
            pulsed: fine
                && s.dy1 == 0
                && ((s.time_optimal && g.seek.sticky())
                    || (g.breakaway_throws && state.near.overshot())),
        }
    }

    /// The PID-type laws' drive, the integrator updated: v = terms + I, u = clamp(h⁻¹(v), ±u_max).
    fn drive_pid(
        &self,
        state: &mut ScheduledState,
        terms: Terms,
        region: Region,
        mut tally: Tally,
    ) -> ControlOutput {
        let v = terms.sum_i32f32.saturating_add(state.integral_i32f32);
        let v_i16f16 = sat_i32(shr_round_i64(v, 16), &mut tally.sat);
        let u_raw = match &state.compensation {
            Some(map) if terms.compensate => map.apply(v_i16f16),
            _ => v_i16f16,
        };
        let mut u = clamp_sym_i32(u_raw, self.u_max());
        tally
            .flags
            .set_if(ControlFlags::OUTPUT_SATURATED, u != u_raw);
        let off = if terms.pulsed {
            state.pulse_phase = (state.pulse_phase + 1) & (PULSE_PERIOD - 1);
            state.pulse_phase != 0
        } else {
            state.pulse_phase = 0;
            false
        };
        if off {
            // An off-sample of the pulsed drive: nothing drives, friction acts (the seek
            // observer's Coulomb decay); the integrator ran on.
            u = 0;
            tally.flags.insert(ControlFlags::PULSE_OFF);
            state.friction_free_drive = true;
            state.last_v_i32f32 = 0;
            state.last_u = 0;
            return tally.finish(u, region);
        }
        // The linear drive the sled sees: v, or h(u) where the map was not applied. (Where the
        // rail clips u the sled sees h(u), not v: the velocity observer is fed v there, and
        // feeding it h(u) moved the reference-following family's holding error from 1.49 to
        // 1.67 quanta, `tests/integration/control_family.rs`; the time-optimal seek feeds its own observer
        // what the rail let through.)
        state.last_v_i32f32 = if terms.compensate {
            v
        } else {
            i64::from(forward(state, u)) << 16
        };
        state.last_u = u;
        tally.finish(u, region)
    }

    /// The integrator of a PID-type law: re-initialised on a transfer (bumpless), conditional
    /// integration while settling, fading in Seek.
    fn update_integral(
        &self,
        state: &mut ScheduledState,
        s: &Sample,
        sel: &Selection,
        terms: Terms,
        returning: bool,
        flags: &mut ControlFlags,
    ) {
        let i_max = self.integrator_limit_i32f32;
        if sel.seek_to_settle() {
            // The seek's terms (feedforward) do not carry over: the settle law starts from the
            // state (e, v̂) with no stored drive.
            state.integral_i32f32 = 0;
        } else if returning || (sel.changed && sel.previous != Region::Hold) {
            let wanted = state.last_v_i32f32.saturating_sub(terms.sum_i32f32);
            state.integral_i32f32 = clamp_sym_i64(wanted, i_max);
            flags.set_if(
                ControlFlags::TRANSFER_LIMITED,
                state.integral_i32f32 != wanted,
            );
        } else if terms.integrating {
            let g = self.gains_in_use(&state.gains, s.falling_back);
            let step = integrate(
                &mut state.integral_i32f32,
                g.ki_settle.apply(s.e_lin),
                terms.sum_i32f32,
                i_max,
                self.u_limit_i32f32,
            );
            flags.set_if(ControlFlags::INTEGRATOR_LIMITED, step.limited);
            flags.set_if(ControlFlags::INTEGRATION_HELD, step.held);
        } else {
            // Seek: the integrator fades with a time constant of 16 samples.
            state.integral_i32f32 -= state.integral_i32f32 >> 4;
        }
    }

    /// u_max, I16F16 raw.
    fn u_max(&self) -> i32 {
        (self.u_limit_i32f32 >> 16) as i32 // built from an I16F16 value
    }

    /// The laws' error: −m⁻¹(y − r) with an output map, else e = r − y (I16F16 raw quanta).
    fn linear_error(&self, e: i32) -> i32 {
        self.output_map
            .as_ref()
            .map_or(e, |m| m.apply(e.saturating_neg()).saturating_neg())
    }
}

/// One sample's signals from the common front ([`ScheduledConfig::step_law`]), read by the
/// region's law; I16F16 raw quanta unless named otherwise.
#[derive(Clone, Copy)]
struct Sample {
    /// The reference, as given.
    r: PositionI48F16,
    /// The reading, as given.
    y: PositionI48F16,
    /// e = r − y on the reading (the decisions).
    e: i32,
    /// The laws' error, on the linear position.
    e_lin: i32,
    /// The linear position's change over the last sample.
    dy1: i32,
    /// v_r = r(k) − r(k−1).
    dr1: i32,
    /// Δv_r = v_r(k) − v_r(k−1).
    ar: i32,
    /// The velocity observer's v̂ (the seek observer's on leaving a time-optimal seek).
    v_hat: i32,
    /// The seek observer's error r − x̂ (time-optimal seeks only, else 0).
    e_seek: i32,
    /// The seek observer's velocity (time-optimal seeks only, else 0).
    v_seek: i32,
    /// Seeks are time-optimal.
    time_optimal: bool,
    /// The linear position, I48F16 raw quanta.
    y_lin: i64,
    /// The linear drive the model saw over the last sample, I16F16 raw full scale.
    v_prev: i32,
    /// The supervisor distrusts the model this sample.
    distrusted: bool,
    /// The model is refused or distrusted: the prior's gains, or the baseline PID, drive.
    falling_back: bool,
}

/// The region of one sample and how it was reached.
#[derive(Clone, Copy)]
struct Selection {
    previous: Region,
    region: Region,
    changed: bool,
    verdict: Verdict,
}

impl Selection {
    /// Seek → Settle this sample.
    fn seek_to_settle(&self) -> bool {
        self.changed && self.previous == Region::Seek && self.region == Region::Settle
    }
}

/// A PID-type law's terms before the integrator.
#[derive(Clone, Copy)]
struct Terms {
    /// The terms' sum, I32F32.
    sum_i32f32: i64,
    /// The settle integrator runs (else the integrator fades, as in Seek).
    integrating: bool,
    /// The input compensation applies.
    compensate: bool,
    /// A fine step on a sticky model (time-optimal seeks), or on a throwing model whose fine
    /// step has overshot (both modes), the reading still: the drive is applied one sample in
    /// [`PULSE_PERIOD`].
    pulsed: bool,
}

/// The flags of one sample and whether any fixed-point narrowing saturated on the way.
#[derive(Clone, Copy)]
struct Tally {
    flags: ControlFlags,
    sat: bool,
}

impl Tally {
    /// The drive `u` (I16F16 raw) in `region`, the sample's arithmetic saturation flagged.
    fn finish(mut self, u: i32, region: Region) -> ControlOutput {
        self.flags
            .set_if(ControlFlags::ARITHMETIC_SATURATED, self.sat);
        ControlOutput {
            u: SignalI16F16::from_raw(u),
            region,
            flags: self.flags,
        }
    }
}

/// A redesign on entering Settle, and again while settling once the identifier has learnt from
/// enough motion since the last one (a loop the prior's gains leave ringing keeps moving, and
/// keeps informing the identifier, until the gains are redesigned) — or, in a reference-following
/// seek, once the reference has arrived and the sled still has not reached the settle band
/// ([`SEEK_REDESIGN_UPDATES`]). Never in Hold, nor in a time-optimal seek (its plan is the model's).
fn request_redesign_when_due(
    state: &mut ScheduledState,
    s: &Sample,
    sel: &Selection,
    flags: &mut ControlFlags,
) {
    let due = match sel.region {
        Region::Settle => Some(SETTLE_REDESIGN_UPDATES),
        Region::Seek if !s.time_optimal && s.dr1 == 0 => Some(SEEK_REDESIGN_UPDATES),
        _ => None,
    };
    let informed =
        due.is_some_and(|d| state.trusted_updates >= d) && !s.distrusted && !state.redesign_pending;
    if sel.seek_to_settle() || informed {
        state.redesign_pending = true;
        flags.insert(ControlFlags::REDESIGN_REQUESTED);
    }
}

/// The job placing gains from `theta` (zero-padded) of `source`, its gain terms scaled by
/// `gain_ratio` (I16F16).
fn place(theta: &[ParamI12F20], source: ModelSource, gain_ratio: i32) -> RedesignJob {
    let mut copy = [ParamI12F20::ZERO; MAX_MODEL_PARAMS];
    for (c, t) in copy.iter_mut().zip(theta) {
        *c = *t;
    }
    RedesignJob::Place {
        theta: copy,
        len: theta.len().min(MAX_MODEL_PARAMS) as u8, // ≤ 4
        source,
        gain_ratio,
    }
}

/// h(u) of the compensation map in use (the identity without one), I16F16 raw.
fn forward(state: &ScheduledState, u: i32) -> i32 {
    state.compensation.as_ref().map_or(u, |m| m.forward(u))
}

/// The scheduled law as a servo controller: the redesign places gains from the identified θ.
impl Controller for ScheduledConfig {
    type State = ScheduledState;
    type Job = RedesignJob;
    type Design = RedesignResult;

    fn new_state(&self) -> ScheduledState {
        ScheduledState::new(self.prior_gains, self.compensation)
    }

    fn step(&self, state: &mut ScheduledState, input: &ControlInput) -> ControlOutput {
        self.step_law(state, input.r, input.y, &input.report)
    }

    /// Requested on Seek → Settle. The supervisor's verdict is taken now, from the state of this
    /// sample; the trusted-update count restarts when a placement is asked for.
    fn redesign_job(
        &self,
        state: &mut ScheduledState,
        theta: &[ParamI12F20],
    ) -> Option<RedesignJob> {
        if state.gain_redesign_pending {
            // The seeks' gain learnt: θ (calibration's) placed again at ρ.
            state.gain_redesign_pending = false;
            state.redesign_pending = false;
            return Some(place(theta, ModelSource::Learnt, state.learner.ratio()));
        }
        if !state.redesign_pending {
            return None;
        }
        state.redesign_pending = false;
        if state.untrusted > 0 || state.eps_mean > self.eps_limit {
            return Some(RedesignJob::Untrusted);
        }
        if state.trusted_updates == 0 {
            return Some(RedesignJob::Skip);
        }
        state.trusted_updates = 0;
        Some(place(theta, ModelSource::Identified, state.learner.ratio()))
    }

    fn place_job(&self, theta: &[ParamI12F20]) -> RedesignJob {
        place(theta, ModelSource::Calibrated, RATIO_ONE)
    }

    fn placed(design: &RedesignResult) -> bool {
        matches!(design.outcome, Redesign::Applied(_)) && design.gains.is_some()
    }

    fn restart(&self, state: &mut ScheduledState) {
        state.primed = false;
    }

    /// θ → checked velocity model → placed gains (f32, outside the interrupt); with
    /// `identify_friction`, the Coulomb level u_c = c/Σb → its input compensation. The result
    /// is built in place (one design in the frame, not a placed copy moved into it).
    fn redesign(&self, job: &RedesignJob) -> RedesignResult {
        let (source, gain_ratio) = job.origin();
        let mut result = RedesignResult {
            outcome: Redesign::Skipped,
            gains: None,
            compensation: None,
            source,
            gain_ratio,
        };
        let placed = match job {
            RedesignJob::Untrusted => Err(Rejection::Untrusted),
            RedesignJob::Skip => return result,
            RedesignJob::Place { theta, len, .. } => {
                self.place_into(theta, *len, source, gain_ratio, &mut result)
            }
        };
        match placed {
            Ok(model) => result.outcome = Redesign::Applied(model),
            Err(r) => {
                result.outcome = Redesign::Rejected(r);
                result.gains = None;
                result.compensation = None;
            }
        }
        result
    }

    /// Placed gains replace the gains in use and end the fallback; a refusal latches the fallback
    /// until a model is accepted; a skip keeps everything.
    fn adopt(&self, state: &mut ScheduledState, design: &RedesignResult) {
        // Matched by reference: the gains are copied once, into the state.
        match (&design.outcome, &design.gains) {
            (Redesign::Applied(_), Some(g)) => {
                state.gains = *g;
                state.fallback = false;
                state.calibrated_plan = design.source != ModelSource::Identified;
                state.learner.adopt(design.gain_ratio);
                if self.identify_friction {
                    state.compensation = design.compensation;
                }
            }
            (Redesign::Rejected(_), _) => state.fallback = true,
            _ => {}
        }
    }
}

/// Words: the baseline PID, the region selector, placement, supervisor, the prior's gains, I_max,
/// hold bias, ε limit, na, the Coulomb term and friction identification, the input map and the
/// output map (`u_max` is the baseline's; validity:
/// [`ScheduledConfig::validate`]).
impl Words for ScheduledConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.baseline.put(w)?;
        self.selector.put(w)?;
        self.placement.put(w)?;
        self.supervisor.put(w)?;
        self.prior_gains.put(w)?;
        self.integrator_limit_i32f32.put(w)?;
        self.hold_bias.put(w)?;
        self.eps_limit.put(w)?;
        self.na.put(w)?;
        self.model_coulomb.put(w)?;
        self.identify_friction.put(w)?;
        self.compensation.put(w)?;
        self.output_map.put(w)?;
        self.seek.put(w)
    }
    #[inline(never)] // written straight into the caller's result, not into a copy on its stack
    fn take(r: &mut WordReader<'_>) -> Self {
        let baseline = PidConfig::take(r);
        let selector = RegionSelector::take(r);
        let placement = PlacementDesign::take(r);
        let supervisor = SupervisorDesign::take(r);
        let prior_gains = <Option<ModelGains> as Words>::take(r);
        let integrator_limit_i32f32 = i64::take(r);
        let u_max = baseline.u_limit().raw();
        let hold_bias = i32::take(r);
        let eps_limit = u32::take(r);
        let na = usize::take(r);
        let model_coulomb = bool::take(r);
        let identify_friction = bool::take(r);
        Self {
            baseline,
            selector,
            placement,
            supervisor,
            prior_gains,
            integrator_limit_i32f32,
            u_limit_i32f32: i64::from(u_max) << 16,
            hold_bias,
            eps_limit,
            na,
            model_coulomb,
            identify_friction,
            compensation: <Option<InverseInputMap> as Words>::take(r),
            output_map: <Option<InverseInputMap> as Words>::take(r),
            seek: <Option<TimeOptimalDesign> as Words>::take(r),
        }
    }
}

/// The Coulomb level a compensation map takes off the drive at speed: −w of its neuron (0 without
/// a map), fraction of full scale.
fn compensation_level(map: Option<&InverseInputMap>) -> f32 {
    // w ≤ 0 for a friction map: −w from the raw value, no float arithmetic.
    map.map_or(0.0, |m| {
        ParamI12F20::from_raw(m.neuron().w().raw().saturating_neg()).to_f32()
    })
    .max(0.0)
}

/// `v` less a dead zone of l/2 quanta per sample (half what one flicker of the reading moves v̂
/// by), I16F16 raw.
/// Never panics: the width is taken as |l|/2 (a validated l is in [0, 1]).
fn dead_zone(v: i32, l: crate::num::gain::Gain) -> i32 {
    let width = (sat_i32(shr_round_i64(l.apply(1 << 16), 16), &mut false) >> 1).saturating_abs();
    past(v, width)
}

/// `v` less a dead zone of ±`width` (≥ 0), I16F16 raw.
fn past(v: i32, width: i32) -> i32 {
    v.saturating_sub(v.max(-width).min(width))
}
