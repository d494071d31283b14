//! The firmware's whole per-sample step (issue 6): the gain-scheduled position controller, the
//! on-line identifier it is designed from, and the paper's best model identified beside them at
//! half the rate — one function, called by the firmware's timer interrupt, by `sledid control`'s
//! closed loop on the twin, and by the bench image.
//!
//! # One sample k (positions in quanta, u in full scale)
//! ```text
//! u(k)      = controller(r(k), y(k), report(k−1))           sledid::control::scheduled (supervisor inside)
//! report(k) = identifier(y(k), u(k), r(k))                  ARX on velocity: sledid::ident::step::step, N = 2
//! (y_c, u)  → half-band ÷2 (y_c = y − r)                    sledid::ident::decimate, two channels
//! every 2nd sample: Wiener(y_c↓2, u↓2)                      sledid::ident::nonlinear, adapting in Settle/Hold only
//! ```
//! The paper's conclusion is that different models belong to different parts of a step response:
//! the velocity ARX model drives the seek/settle gains (it is what pole placement needs), while the
//! Wiener model — the paper's best, after down-sampling by 2 — learns the settle dynamics around the
//! reference, where it is valid, so its estimator is held during seeks (it still simulates).
//!
//! The slow-rate gain redesign is *not* part of the step: when [`LoopState::redesign_pending`] the
//! main loop calls [`LoopConfig::redesign`] (f32, outside the interrupt).

use crate::control::{
    ModelReport, Redesign, Region, ScheduledConfig, ScheduledDesign, ScheduledFlags, ScheduledState,
};
use crate::error::ConfigError;
use crate::ident::conditioning::Conditioning;
use crate::ident::decimate::{DecimatorConfig, DecimatorState};
use crate::ident::linear::{Estimate, LinearDesign, Structure};
use crate::ident::nonlinear::{NonlinearConfig, NonlinearDesign, NonlinearState};
use crate::ident::rls::{AntiWindup, RlsDesign};
use crate::ident::step::{IdentifierConfig, IdentifierDesign, IdentifierState, StepOutput, step};
use crate::num::boundary::{PositionI48F16, Sample};
use crate::num::fixed::SignalI16F16;
use crate::words::{WordReader, WordWriter, Words};

pub mod hal;

/// Parameters of the controller's identifier (ARX(1,1) on velocity).
pub const VELOCITY_N: usize = 2;
/// Parameters of the first-order Wiener model.
pub const WIENER_N: usize = 5;

/// User-facing settings of the whole loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopDesign {
    /// The gain-scheduled controller (its baseline PID is the fallback).
    pub controller: ScheduledDesign,
    /// The identifier the controller's gains are placed from.
    pub velocity: IdentifierDesign<VELOCITY_N, LinearDesign<VELOCITY_N>>,
    /// The Wiener model at 2·Ts on the centred position (`None`: not run).
    pub wiener: Option<NonlinearDesign<WIENER_N>>,
}

/// The controller's identifier as the loop expects it: ARX(1, 1) on the velocity Δy against u
/// (the first-order velocity model `sledid::control::placement` places gains from), started from the
/// velocity model `prior` = (a, b), λ = 0.995, P₀ = 10·I, dead zone ¼ quantum, trace(P) ≤ 100,
/// outlier gate 40 quanta per sample (16 in a row).
pub fn velocity_identifier(
    prior: (f64, f64),
) -> IdentifierDesign<VELOCITY_N, LinearDesign<VELOCITY_N>> {
    let mut model = LinearDesign::<VELOCITY_N>::new(Structure::Arx, 1, 1);
    model.theta0 = [-prior.0, prior.1];
    model.rls = RlsDesign {
        lambda: 0.995,
        p0: 10.0,
        dead_zone: 0.25,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        outlier_threshold: 40.0,
        outlier_limit: 16,
        ..RlsDesign::default()
    };
    IdentifierDesign::new(Conditioning::DifferencedOutput, model)
}

/// Validated configuration of the loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopConfig {
    controller: ScheduledConfig,
    velocity: IdentifierConfig<VELOCITY_N>,
    wiener: Option<NonlinearConfig<WIENER_N>>,
    decimator: DecimatorConfig,
}

/// Everything one sample mutates.
#[derive(Clone, Debug)]
pub struct LoopState {
    controller: ScheduledState,
    velocity: IdentifierState<VELOCITY_N>,
    report: ModelReport,
    wiener: Option<NonlinearState<WIENER_N>>,
    decimate_y: DecimatorState,
    decimate_u: DecimatorState,
}

/// What one sample produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LoopOutput {
    /// The drive u(k), fraction of full scale.
    pub u: SignalI16F16,
    /// The controller's region.
    pub region: Region,
    /// The controller's flags (`FALLBACK` when the supervisor distrusts the model).
    pub control: ScheduledFlags,
    /// The velocity identifier's output (ŷ, ε, θ, status).
    pub velocity: StepOutput<VELOCITY_N>,
    /// The Wiener estimator's output, on every second sample.
    pub wiener: Option<Estimate>,
}

impl LoopDesign {
    /// Validates and quantises every part.
    ///
    /// # Errors
    /// The first part's [`ConfigError`].
    pub fn build(&self) -> Result<LoopConfig, ConfigError> {
        Ok(LoopConfig {
            controller: self.controller.build()?,
            velocity: self.velocity.build()?,
            wiener: match &self.wiener {
                Some(w) => Some(w.build()?),
                None => None,
            },
            decimator: DecimatorConfig::HALF_BAND_23,
        })
    }

    /// Builds every part and writes the configuration words ([`crate::words`]) into `out`: the
    /// velocity identifier's ([`IdentifierDesign::put_words`]), the Wiener model's if any (a
    /// `bool`, then [`NonlinearDesign::put_words`]), then the controller's ([`ScheduledConfig`];
    /// last, so that [`LoopConfig::from_words`] can decode the largest part straight into its
    /// result instead of into a copy on the stack). [`LoopConfig::from_words`] reads them back into the
    /// configuration [`Self::build`] gives. Returns the number of words written.
    ///
    /// # Errors
    /// The first part's [`ConfigError`], or [`ConfigError::Words`] when `out` is too short
    /// ([`LOOP_WORDS_MAX`] always suffices).
    pub fn to_words(&self, out: &mut [u32]) -> Result<usize, ConfigError> {
        let mut w = WordWriter::new(out);
        self.velocity.put_words(&mut w)?;
        self.wiener.is_some().put(&mut w)?;
        if let Some(wiener) = &self.wiener {
            wiener.put_words(&mut w)?;
        }
        self.controller.build()?.put(&mut w)?;
        Ok(w.len())
    }
}

/// A buffer size that holds the words of any [`LoopDesign`]: at most 181 (25 for the velocity
/// identifier with a stuck-sensor check and a pole radius, 22 for the Wiener model, 134 for the
/// controller with both input maps).
pub const LOOP_WORDS_MAX: usize = 192;

impl LoopConfig {
    /// The configuration from the words of [`LoopDesign::to_words`], computed on the host: every
    /// field checked as the parts' `build` functions check them (integer checks; only the two RLS
    /// designs are built from their `f64` settings, see [`crate::words`]). The decimator is the
    /// loop's fixed half-band filter.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first word that is missing, invalid or fails its check (or
    /// the first word left over), or an RLS design's error.
    pub fn from_words(words: &[u32]) -> Result<Self, ConfigError> {
        let mut slot = None;
        Self::from_words_into(words, &mut slot)?;
        slot.ok_or(ConfigError::Words { at: 0 })
    }

    /// [`Self::from_words`] into `slot` (`None` on an error), for a caller with static storage
    /// for the configuration: the controller's part, the largest, is decoded straight into it
    /// rather than into a copy on the stack.
    ///
    /// # Errors
    /// As [`Self::from_words`].
    pub fn from_words_into(words: &[u32], slot: &mut Option<Self>) -> Result<(), ConfigError> {
        *slot = None;
        let mut r = WordReader::new(words);
        let velocity = IdentifierConfig::take_words(&mut r)?;
        let wiener = match bool::take(&mut r) {
            true => Some(NonlinearConfig::take_words(&mut r)?),
            false => None,
        };
        // `insert` builds the value in the slot (`*slot = Some(…)` measured 64 B more stack).
        let _config = slot.insert(Self {
            controller: ScheduledConfig::take(&mut r),
            velocity,
            wiener,
            decimator: DecimatorConfig::HALF_BAND_23,
        });
        let done = r.finish();
        if done.is_err() {
            *slot = None;
        }
        done
    }

    /// A fresh state.
    pub fn new_state(&self) -> LoopState {
        LoopState {
            controller: self.controller.new_state(),
            velocity: self.velocity.new_state(),
            report: ModelReport::default(),
            wiener: self.wiener.as_ref().map(NonlinearConfig::new_state),
            decimate_y: self.decimator.new_state(),
            decimate_u: self.decimator.new_state(),
        }
    }

    /// The controller configuration (gains in use, fallback).
    pub fn controller(&self) -> &ScheduledConfig {
        &self.controller
    }

    /// The slow-rate redesign of the controller's gains from the identifier's latest θ (call from
    /// the main loop when [`LoopState::redesign_pending`], not from the interrupt).
    pub fn redesign(&mut self, state: &mut LoopState) -> Redesign {
        self.controller
            .redesign(&mut state.controller, state.velocity.model().theta())
    }

    /// One sample: reference r(k) and measurement y(k) in, drive u(k) out. Never panics.
    pub fn step(&self, state: &mut LoopState, r: PositionI48F16, y: PositionI48F16) -> LoopOutput {
        self.step_with_drive(state, r, y, None)
    }

    /// Shadow mode, for commissioning beside a controller already in charge: the loop computes its
    /// drive u(k) (returned, not applied), but the identifiers learn from `u_applied`, the drive the
    /// plant really received — the only input that explains y. Never panics.
    pub fn step_shadow(
        &self,
        state: &mut LoopState,
        r: PositionI48F16,
        y: PositionI48F16,
        u_applied: SignalI16F16,
    ) -> LoopOutput {
        self.step_with_drive(state, r, y, Some(u_applied))
    }

    fn step_with_drive(
        &self,
        state: &mut LoopState,
        r: PositionI48F16,
        y: PositionI48F16,
        u_applied: Option<SignalI16F16>,
    ) -> LoopOutput {
        let out = self
            .controller
            .step(&mut state.controller, r, y, &state.report);
        let u_plant = u_applied.unwrap_or(out.u);
        let velocity = step(
            &self.velocity,
            &mut state.velocity,
            &Sample { y, u: u_plant, r },
        );
        state.report = ModelReport {
            status: velocity.status,
            eps: velocity.eps,
        };
        let mut wiener = None;
        if let (Some(cfg), Some(st)) = (&self.wiener, state.wiener.as_mut()) {
            let mut sat = false;
            let y_c = y.offset_from(r, &mut sat);
            let dy = self.decimator.push(&mut state.decimate_y, y_c);
            let du = self.decimator.push(&mut state.decimate_u, u_plant);
            if let (Some(dy), Some(du)) = (dy, du) {
                st.set_enabled(out.region != Region::Seek);
                let mut e = cfg.step(st, dy.y, du.y);
                e.status |= dy.status | du.status;
                e.status
                    .set_if(crate::ident::status::Status::SATURATED, sat);
                wiener = Some(e);
            }
        }
        LoopOutput {
            u: out.u,
            region: out.region,
            control: out.flags,
            velocity,
            wiener,
        }
    }
}

impl LoopState {
    /// The controller asks for a gain redesign (a settle phase began after trusted updates).
    pub fn redesign_pending(&self) -> bool {
        self.controller.redesign_pending()
    }

    /// The controller's state.
    pub fn controller(&self) -> &ScheduledState {
        &self.controller
    }

    /// The velocity identifier's state.
    pub fn velocity(&self) -> &IdentifierState<VELOCITY_N> {
        &self.velocity
    }

    /// The Wiener estimator's state, if it runs.
    pub fn wiener(&self) -> Option<&NonlinearState<WIENER_N>> {
        self.wiener.as_ref()
    }
}
