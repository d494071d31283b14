//! The per-sample step: the one function the firmware's timer interrupt, the host replay, the
//! closed-loop twin and the tests all call, so what is tested is what runs.
//!
//! `step(config, state, sample) → StepOutput`: condition the raw sample (centre on the reference or
//! difference, [`crate::ident::conditioning::Conditioning`]), run the model estimator (ARX or OE,
//! [`crate::ident::linear`]; or one of the paper's nonlinear models, [`crate::ident::nonlinear`] — anything that is
//! an [`Estimator`]), and report ŷ, ε, θ and the status flags. Never panics, never returns an error.
//!
//! # Degradation on bad input (documented and tested in `host-tests/tests/integration/faults.rs`)
//! - A sample the boundary cannot convert (NaN, ±∞, out of range, a missing reading) is passed as
//!   [`reject`]: θ and P are held, the output carries [`Status::INPUT_REJECTED`], and the
//!   conditioning re-primes (differences never span the gap: the next sample is a
//!   [`Status::WARMUP`]).
//! - Stuck sensor ([`StuckSensorDesign`]): when y has not changed for `samples` consecutive samples
//!   while |u| ≥ `min_drive`, adaptation is held ([`Status::SENSOR_STUCK`]) until y moves again.
//! - Spikes and reversed signs are the estimator's outlier gate ([`crate::ident::rls::RlsDesign`]).

use crate::error::ConfigError;
use crate::ident::conditioning::{Conditioning, ConditioningState};
use crate::ident::estimator::{Estimator, EstimatorDesign};
use crate::ident::linear::{LinearConfig, LinearDesign, LinearState};
use crate::ident::status::Status;
use crate::num::boundary::{PositionI48F16, Sample};
use crate::num::fixed::{ParamI12F20, SignalI16F16};
use crate::num::float_bits::from_fixed;
use crate::words::{WordReader, WordWriter, Words};

/// Stuck-sensor detection: y unchanged for `samples` consecutive samples while |u| ≥ `min_drive`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StuckSensorDesign {
    /// Consecutive unchanged samples (≥ 2).
    pub samples: u32,
    /// Minimum |u| (fraction of full scale) for "driven".
    pub min_drive: f64,
}

/// User-facing settings of the identifier: conditioning, a model estimator design `D` (a linear one
/// by default), stuck-sensor detection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifierDesign<const N: usize, D = LinearDesign<N>> {
    /// How raw samples are conditioned.
    pub conditioning: Conditioning,
    /// The model estimator.
    pub model: D,
    /// Stuck-sensor detection (`None`: off).
    pub stuck_sensor: Option<StuckSensorDesign>,
}

/// Quantised stuck-sensor check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct StuckSensor {
    samples: u32,
    min_drive_i16f16: u32,
}

impl<const N: usize, D: EstimatorDesign<N>> IdentifierDesign<N, D> {
    /// A design without stuck-sensor detection.
    pub fn new(conditioning: Conditioning, model: D) -> Self {
        Self {
            conditioning,
            model,
            stuck_sensor: None,
        }
    }

    /// Validates and quantises.
    ///
    /// # Errors
    /// The model's [`ConfigError`], or [`ConfigError::StuckSensor`].
    pub fn build(&self) -> Result<IdentifierConfig<N, D::Config>, ConfigError> {
        let stuck = match self.stuck_sensor {
            None => None,
            Some(d) => {
                let drive = SignalI16F16::from_f64(d.min_drive)
                    .map_err(|_| ConfigError::StuckSensor(d.min_drive))?;
                let s = StuckSensor {
                    samples: d.samples,
                    min_drive_i16f16: drive.raw().unsigned_abs(),
                };
                s.validate()
                    .map_err(|_| ConfigError::StuckSensor(d.min_drive))?;
                Some(s)
            }
        };
        Ok(IdentifierConfig {
            conditioning: self.conditioning,
            model: self.model.build()?,
            stuck,
        })
    }
}

/// Validated identifier configuration around a model estimator `M`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentifierConfig<const N: usize, M = LinearConfig<N>> {
    conditioning: Conditioning,
    model: M,
    stuck: Option<StuckSensor>,
}

/// Everything the identifier mutates; `S` is the model estimator's state.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IdentifierState<const N: usize, S = LinearState<N>> {
    conditioning: ConditioningState,
    model: S,
    /// Adaptation enabled by the user (the stuck-sensor hold comes on top).
    enabled: bool,
    last_y: PositionI48F16,
    /// `last_y` holds a real sample (the first sample only primes the stuck check).
    has_last_y: bool,
    unchanged: u32,
}

/// What one step produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepOutput<const N: usize> {
    /// Conditioned output y_c(t) (y − r, Δy or y).
    pub y: SignalI16F16,
    /// Conditioned input u_c(t).
    pub u: SignalI16F16,
    /// ŷ(t), in the conditioned coordinates.
    pub y_hat: SignalI16F16,
    /// ε(t) = y_c(t) − ŷ(t).
    pub eps: SignalI16F16,
    /// θ after this sample.
    pub theta: [ParamI12F20; N],
    /// What happened.
    pub status: Status,
}

impl<const N: usize, M: Estimator<N>> IdentifierConfig<N, M> {
    /// A fresh state.
    pub fn new_state(&self) -> IdentifierState<N, M::State> {
        IdentifierState {
            conditioning: ConditioningState::default(),
            model: self.model.new_state(),
            enabled: true,
            last_y: PositionI48F16::default(),
            has_last_y: false,
            unchanged: 0,
        }
    }

    /// The model configuration.
    pub fn model(&self) -> &M {
        &self.model
    }

    /// The conditioning.
    pub fn conditioning(&self) -> Conditioning {
        self.conditioning
    }
}

impl<const N: usize, S> IdentifierState<N, S> {
    /// The model estimator's state.
    pub fn model(&self) -> &S {
        &self.model
    }

    /// Holds (false) or enables (true) adaptation (applied from the next sample on).
    pub fn set_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
    }
}

/// What an identifier reported in one sample: what the servo's supervisor judges the model by.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelReport {
    /// The estimator's flags.
    pub status: Status,
    /// Its prediction error ε, in the conditioned output's unit (quanta per sample on velocity).
    pub eps: SignalI16F16,
}

/// An on-line identifier the servo can run beside its controller: one call per sample, a
/// [`ModelReport`] for the supervisor, θ for the controller's redesigns. A new identifier is a
/// new type implementing this (the servo does not change).
pub trait Identifier {
    /// Everything one sample mutates.
    type State;
    /// What one sample produced.
    type Output: Copy;
    /// A fresh state.
    fn new_state(&self) -> Self::State;
    /// One sample. Never panics.
    fn identify(&self, state: &mut Self::State, sample: &Sample) -> Self::Output;
    /// A sample that could not be read: θ and P held. Never panics.
    fn reject(&self, state: &mut Self::State) -> Self::Output;
    /// Holds (false) or resumes (true) adaptation from the next sample on; the model keeps
    /// predicting while held.
    fn set_adapting(&self, state: &mut Self::State, adapting: bool);
    /// The report of one output.
    fn report(output: &Self::Output) -> ModelReport;
    /// The current estimate θ.
    fn theta<'a>(&self, state: &'a Self::State) -> &'a [ParamI12F20];
    /// Restarts the estimate from `theta` (its first entries; the rest keep theirs), P = p₀·I.
    fn seed(&self, state: &mut Self::State, theta: &[ParamI12F20]);
}

impl<const N: usize, M: Estimator<N>> Identifier for IdentifierConfig<N, M> {
    type State = IdentifierState<N, M::State>;
    type Output = StepOutput<N>;

    fn new_state(&self) -> Self::State {
        IdentifierConfig::new_state(self)
    }

    fn identify(&self, state: &mut Self::State, sample: &Sample) -> StepOutput<N> {
        step(self, state, sample)
    }

    fn reject(&self, state: &mut Self::State) -> StepOutput<N> {
        reject(self, state)
    }

    fn set_adapting(&self, state: &mut Self::State, adapting: bool) {
        state.set_enabled(adapting);
    }

    fn report(output: &StepOutput<N>) -> ModelReport {
        ModelReport {
            status: output.status,
            eps: output.eps,
        }
    }

    fn theta<'a>(&self, state: &'a Self::State) -> &'a [ParamI12F20] {
        self.model.theta(&state.model)
    }

    fn seed(&self, state: &mut Self::State, theta: &[ParamI12F20]) {
        let mut full = *self.model.theta(&state.model);
        for (f, t) in full.iter_mut().zip(theta) {
            *f = *t;
        }
        self.model.seed(&mut state.model, &full);
    }
}

/// One sample through the identifier. Never panics.
pub fn step<const N: usize, M: Estimator<N>>(
    config: &IdentifierConfig<N, M>,
    state: &mut IdentifierState<N, M::State>,
    sample: &Sample,
) -> StepOutput<N> {
    let mut sat = false;
    let stuck = config.stuck.is_some_and(|c| {
        let driven = sample.u.raw().unsigned_abs() >= c.min_drive_i16f16;
        if !state.has_last_y || sample.y != state.last_y {
            state.unchanged = 0;
        } else if driven {
            state.unchanged = state.unchanged.saturating_add(1);
        }
        state.unchanged >= c.samples
    });
    state.last_y = sample.y;
    state.has_last_y = true;
    config
        .model
        .set_enabled(&mut state.model, state.enabled && !stuck);
    let Some((y, u)) = config
        .conditioning
        .apply(&mut state.conditioning, sample, &mut sat)
    else {
        return StepOutput {
            y: SignalI16F16::ZERO,
            u: SignalI16F16::ZERO,
            y_hat: SignalI16F16::ZERO,
            eps: SignalI16F16::ZERO,
            theta: *config.model.theta(&state.model),
            status: Status::WARMUP,
        };
    };
    let est = Estimator::step(&config.model, &mut state.model, y, u);
    let mut status = est.status;
    status.set_if(Status::SATURATED, sat);
    status.set_if(Status::SENSOR_STUCK, stuck);
    StepOutput {
        y,
        u,
        y_hat: est.y_hat,
        eps: est.eps,
        theta: *config.model.theta(&state.model),
        status,
    }
}

/// A sample that could not be read or converted (NaN, ±∞, out of range, missing): θ and P are held,
/// the conditioning re-primes so no difference spans the gap. Never panics.
pub fn reject<const N: usize, M: Estimator<N>>(
    config: &IdentifierConfig<N, M>,
    state: &mut IdentifierState<N, M::State>,
) -> StepOutput<N> {
    state.conditioning = ConditioningState::default();
    StepOutput {
        y: SignalI16F16::ZERO,
        u: SignalI16F16::ZERO,
        y_hat: SignalI16F16::ZERO,
        eps: SignalI16F16::ZERO,
        theta: *config.model.theta(&state.model),
        status: Status::INPUT_REJECTED,
    }
}

impl StuckSensor {
    /// At least 2 samples and a drive in (0, 2³¹) raw, checked by [`IdentifierDesign::build`] and
    /// by the decoding of configuration words alike.
    fn validate(&self) -> Result<(), ConfigError> {
        let d = self.min_drive_i16f16;
        if self.samples >= 2 && d > 0 && d <= i32::MAX as u32 {
            Ok(())
        } else {
            Err(ConfigError::StuckSensor(from_fixed(i64::from(d), 16)))
        }
    }
}

/// Words: samples, least |u| (raw I16F16).
impl Words for StuckSensor {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.samples.put(w)?;
        self.min_drive_i16f16.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        Self {
            samples: u32::take(r),
            min_drive_i16f16: u32::take(r),
        }
    }
}

impl<const N: usize> IdentifierDesign<N, LinearDesign<N>> {
    /// Builds the design and appends its configuration words ([`crate::words`]): conditioning,
    /// the stuck-sensor check if any, then the model's ([`LinearDesign::put_words`]).
    ///
    /// # Errors
    /// [`Self::build`]'s errors, or [`ConfigError::Words`] when `w`'s buffer is full.
    pub fn put_words(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        let c = self.build()?;
        c.conditioning.put(w)?;
        c.stuck.put(w)?;
        self.model.put_words(w)
    }
}

impl<const N: usize> IdentifierConfig<N, LinearConfig<N>> {
    /// Reads the words of [`IdentifierDesign::put_words`], checked.
    ///
    /// # Errors
    /// [`ConfigError::Words`] at the first bad word, or the RLS design's error.
    pub fn take_words(r: &mut WordReader<'_>) -> Result<Self, ConfigError> {
        let config = Self {
            conditioning: Conditioning::take(r),
            stuck: <Option<StuckSensor> as Words>::take(r),
            model: LinearConfig::take_words(r)?,
        };
        config.validate()?;
        Ok(config)
    }

    /// The stuck-sensor check's and the model's invariants (as their `build`s check them).
    ///
    /// # Errors
    /// The part's [`ConfigError`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        if let Some(s) = &self.stuck {
            s.validate()?;
        }
        self.model.validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::linear::Structure;

    fn design() -> IdentifierDesign<2> {
        IdentifierDesign::new(
            Conditioning::DifferencedOutput,
            LinearDesign::<2>::new(Structure::Arx, 1, 1),
        )
    }

    fn sample(y: i64, u: f64) -> Sample {
        Sample {
            y: PositionI48F16::from_counts(y),
            u: SignalI16F16::from_f64(u).unwrap(),
            r: PositionI48F16::default(),
        }
    }

    #[test]
    fn stuck_sensor_design_is_validated() {
        let mut d = design();
        d.stuck_sensor = Some(StuckSensorDesign {
            samples: 1,
            min_drive: 0.1,
        });
        assert_eq!(d.build(), Err(ConfigError::StuckSensor(0.1)));
        d.stuck_sensor = Some(StuckSensorDesign {
            samples: 4,
            min_drive: 0.0,
        });
        assert_eq!(d.build(), Err(ConfigError::StuckSensor(0.0)));
        d.stuck_sensor = Some(StuckSensorDesign {
            samples: 4,
            min_drive: f64::NAN,
        });
        assert!(matches!(d.build(), Err(ConfigError::StuckSensor(_))));
        d.stuck_sensor = Some(StuckSensorDesign {
            samples: 4,
            min_drive: 0.1,
        });
        assert!(d.build().is_ok());
    }

    #[test]
    fn stuck_sensor_holds_until_y_moves_and_reject_reprimes() {
        let mut d = design();
        d.stuck_sensor = Some(StuckSensorDesign {
            samples: 2,
            min_drive: 0.1,
        });
        let cfg = d.build().unwrap();
        let mut st = cfg.new_state();
        assert!(
            step(&cfg, &mut st, &sample(0, 0.5))
                .status
                .contains(Status::WARMUP)
        );
        assert!(
            !step(&cfg, &mut st, &sample(0, 0.5))
                .status
                .contains(Status::SENSOR_STUCK)
        );
        let held = step(&cfg, &mut st, &sample(0, 0.5));
        assert!(held.status.contains(Status::SENSOR_STUCK) && held.status.contains(Status::HELD));
        // Undriven, an unchanged y is no evidence: the count does not grow but the hold stays.
        let moved = step(&cfg, &mut st, &sample(3, 0.5));
        assert!(!moved.status.contains(Status::SENSOR_STUCK));
        assert!(!moved.status.contains(Status::HELD));
        let r = reject(&cfg, &mut st);
        assert_eq!(r.status, Status::INPUT_REJECTED);
        assert!(
            step(&cfg, &mut st, &sample(5, 0.5))
                .status
                .contains(Status::WARMUP)
        );
        // The user's hold survives the stuck check.
        st.set_enabled(false);
        assert!(
            step(&cfg, &mut st, &sample(9, 0.5))
                .status
                .contains(Status::HELD)
        );
    }
}
