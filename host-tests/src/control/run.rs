//! One closed-loop run on the twin: the baseline PID or the servo's per-sample step (controller,
//! identifier, background redesign and hand-over) behind the twin's controller interface.

use sledid::control::{ControlFlags, Redesign, Region, ScheduledDesign};
use sledid::ident::step::IdentifierDesign;
use sledid::servo::{
    CalibratedModel, CalibrationDesign, CalibrationRecord, Refusal, SafetyDesign, ServoDesign,
    ServoFlags, ServoOptions, SledServo, SledServoState, StopReason, VELOCITY_N,
};

use super::design::{identifier_design, scheduled_design_for};
use super::summary::{ControlSummary, ControllerKind, fine_step_marks, summarize};
use crate::reference::control::{FixedPid, baseline_design, position_from_quanta};
use crate::twin::{PlantParams, SledController, Twin, TwinParams};

/// The servo (the library's per-sample step: controller, identifier, safety layer, redesign
/// hand-over) behind the twin's controller interface; the redesign runs after the sample that
/// requests it, as the firmware's main loop would before the next interrupt.
pub struct ScheduledLoop {
    /// The loop configuration (its controller gains swapped by redesigns).
    pub config: SledServo,
    /// The loop state.
    pub state: SledServoState,
    u_full_scale_v: f64,
    /// Per sample: the region and flags.
    pub trace: Vec<(Region, ControlFlags)>,
    /// Per sample: the servo reported a seek error ([`ServoFlags::SEEK_ERROR`]).
    pub seek_errors: Vec<bool>,
    /// Every redesign outcome.
    pub redesigns: Vec<Redesign>,
    /// The first safe stop: sample index and reason.
    pub first_stop: Option<(usize, StopReason)>,
    /// The sample the servo suspended identification at (the fallbacks' recovery without
    /// calibration, [`ServoFlags::IDENTIFICATION_SUSPENDED`]).
    pub suspended_at: Option<usize>,
}

impl ScheduledLoop {
    /// From a design and the identifier's design, the servo's default options.
    pub fn new(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
    ) -> Result<Self, String> {
        Self::with_options(design, identifier, ServoOptions::default())
    }

    /// As [`Self::new`], with the servo's options (hand-over latency, identification) and its
    /// default safety layer for this design ([`ServoDesign::new`]).
    pub fn with_options(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
        options: ServoOptions,
    ) -> Result<Self, String> {
        Self::with_safety(
            design,
            identifier,
            options,
            ServoDesign::new(*design).safety,
        )
    }

    /// As [`Self::with_options`], with the safety layer `safety`.
    pub fn with_safety(
        design: &ScheduledDesign,
        identifier: &IdentifierDesign<VELOCITY_N>,
        options: ServoOptions,
        safety: SafetyDesign,
    ) -> Result<Self, String> {
        let config = ServoDesign {
            controller: *design,
            velocity: *identifier,
            options,
            safety,
            calibration: None,
        }
        .build()
        .map_err(|e| e.to_string())?;
        Ok(Self {
            state: config.new_state(),
            config,
            u_full_scale_v: design.baseline.u_full_scale_v,
            trace: Vec::new(),
            seek_errors: Vec::new(),
            redesigns: Vec::new(),
            first_stop: None,
            suspended_at: None,
        })
    }

    /// This loop with power-on calibration `calibration` (`None`: without), from a fresh state.
    ///
    /// # Errors
    /// The calibration design's error.
    pub fn with_calibration(
        mut self,
        calibration: Option<CalibrationDesign>,
    ) -> Result<Self, String> {
        let built = calibration
            .map(|c| c.build())
            .transpose()
            .map_err(|e| e.to_string())?;
        self.config = self.config.with_calibration(built);
        self.state = self.config.new_state();
        Ok(self)
    }

    /// Runs power-on calibration on `twin` before its schedule ([`Twin::pre_roll`]); the trace
    /// restarts with the schedule, a refusal is the run's first stop (at sample 0).
    pub fn calibrate(&mut self, twin: &mut Twin) -> Option<CalibrationOutcome> {
        self.config.calibration()?;
        let samples = twin.pre_roll(self, |c| !c.state.calibration().is_running(), 10_000);
        self.trace.clear();
        self.seek_errors.clear();
        self.first_stop = self.first_stop.map(|(_, r)| (0, r));
        let cal = self.state.calibration();
        Some(CalibrationOutcome {
            samples,
            experiment_samples: usize::from(cal.samples()),
            travel_quanta: f64::from(cal.record().travel_i16f16) / 65536.0,
            model: self.state.calibrated().copied(),
            refusal: cal.refusal(),
            record: *cal.record(),
        })
    }

    /// The identifier's θ now.
    pub fn theta(&self) -> [f64; VELOCITY_N] {
        self.state.identifier().model().theta().map(|p| p.to_f64())
    }
}

impl SledController for ScheduledLoop {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        super::inject::ReadingController::step_reading(self, r_counts, Some(y_counts))
    }
}

impl super::inject::ReadingController for ScheduledLoop {
    fn step_reading(&mut self, r_counts: f64, y_counts: Option<f64>) -> f64 {
        let r = position_from_quanta(r_counts);
        let out = match y_counts {
            Some(y) => self
                .config
                .step(&mut self.state, r, position_from_quanta(y)),
            None => self.config.step_lost(&mut self.state, r),
        };
        // The background's turn between two samples (the hand-over adopts it at k + L).
        if let Some(design) = self.config.run_background(&mut self.state) {
            self.redesigns.push(design.outcome);
        }
        if let (None, Some(reason)) = (self.first_stop, out.stop) {
            self.first_stop = Some((self.trace.len(), reason));
        }
        if self.suspended_at.is_none() && out.servo.contains(ServoFlags::IDENTIFICATION_SUSPENDED) {
            self.suspended_at = Some(self.trace.len());
        }
        self.trace.push((out.region, out.control));
        self.seek_errors
            .push(out.servo.contains(ServoFlags::SEEK_ERROR));
        out.u.to_f64() * self.u_full_scale_v
    }
}

/// What power-on calibration did before a run's schedule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationOutcome {
    /// Samples from power-on to the first seek (the experiment, the fit's hand-over).
    pub samples: usize,
    /// Samples of the experiment itself.
    pub experiment_samples: usize,
    /// The furthest the experiment moved the sled from where it started, quanta.
    pub travel_quanta: f64,
    /// The model adopted.
    pub model: Option<CalibratedModel>,
    /// Why the sled was refused.
    pub refusal: Option<Refusal>,
    /// The experiment's record (what the fit saw).
    pub record: CalibrationRecord,
}

/// [`CalibrationOutcome`] for reports (`summary.json`, the summary line).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CalibrationBrief {
    /// Samples from power-on to the first seek.
    pub samples: usize,
    /// Samples of the experiment.
    pub experiment_samples: usize,
    /// ms from power-on to the first seek.
    pub time_ms: f64,
    /// The furthest the experiment went from its start, quanta.
    pub travel_quanta: f64,
    /// The velocity pole a.
    pub a: Option<f64>,
    /// The gain b, quanta per sample² per full scale.
    pub b: Option<f64>,
    /// The Coulomb level (+, −), fraction of full scale.
    pub coulomb_fs: Option<[f64; 2]>,
    /// The breakaway drive (+, −), fraction of full scale.
    pub breakaway_fs: Option<[f64; 2]>,
    /// RMS residual of the fit, quanta.
    pub rms_quanta: Option<f64>,
    /// Why the sled was refused.
    pub refusal: Option<&'static str>,
}

impl CalibrationOutcome {
    /// The brief, with the sampling period `ts_s`.
    pub fn brief(&self, ts_s: f64) -> CalibrationBrief {
        let m = self.model.as_ref();
        CalibrationBrief {
            samples: self.samples,
            experiment_samples: self.experiment_samples,
            time_ms: self.samples as f64 * ts_s * 1e3,
            travel_quanta: self.travel_quanta,
            a: m.map(|m| f64::from(m.a)),
            b: m.map(|m| f64::from(m.b())),
            coulomb_fs: m.map(|m| m.coulomb_fs.map(f64::from)),
            breakaway_fs: m.map(|m| m.breakaway_fs.map(f64::from)),
            rms_quanta: m.map(|m| f64::from(m.rms)),
            refusal: self.refusal.map(Refusal::name),
        }
    }

    /// One line: time, travel, the model or the refusal.
    pub fn line(&self, ts_s: f64) -> String {
        let b = self.brief(ts_s);
        match (&self.model, b.refusal) {
            (Some(m), _) => format!(
                "calibration: {} samples ({:.1} ms) to the first seek, {:.0} quanta of travel; a {:.3}, b {:.2} quanta/sample² per full scale, Coulomb {:.4} / {:.4}, breakaway {:.4} / {:.4} of full scale (+ / −), fit RMS {:.2} quanta",
                b.samples,
                b.time_ms,
                b.travel_quanta,
                m.a,
                m.b(),
                m.coulomb_fs[0],
                m.coulomb_fs[1],
                m.breakaway_fs[0],
                m.breakaway_fs[1],
                m.rms
            ),
            (None, Some(r)) => format!(
                "calibration REFUSED ({r}) after {} samples, {:.0} quanta of travel: the servo does not seek",
                b.experiment_samples, b.travel_quanta
            ),
            (None, None) => "calibration: did not finish".to_owned(),
        }
    }
}

/// A finished closed-loop run.
pub struct ControlRun {
    /// The twin with its recording.
    pub twin: Twin,
    /// Per sample region and flags (scheduled only).
    pub trace: Vec<(Region, ControlFlags)>,
    /// Per sample: the servo reported a seek error (scheduled only).
    pub seek_errors: Vec<bool>,
    /// The summary.
    pub summary: ControlSummary,
    /// Every redesign outcome, in order (scheduled only).
    pub redesigns: Vec<Redesign>,
    /// The servo's first safe stop (sample, reason), if any.
    pub first_stop: Option<(usize, StopReason)>,
    /// Power-on calibration, when the servo calibrated.
    pub calibration: Option<CalibrationOutcome>,
    /// Calibrations adopted over the run (power-on's and every re-calibration).
    pub calibrations: u32,
    /// Re-calibrations that ran out of samples after every push had ended, the previous model
    /// kept.
    pub calibrations_inconclusive: u16,
}

impl ControlRun {
    /// Per seek of the twin's schedule (in order, ended or not), the fine steps the scheduled
    /// controller started in it: samples flagged `FINE_STEP` whose previous sample was not (0
    /// for the baseline, which has no trace).
    pub fn fine_steps_per_seek(&self) -> Vec<usize> {
        let marks = fine_step_marks(&self.trace);
        let on = |k: usize| marks.get(k).copied().unwrap_or(false);
        self.twin
            .seeks()
            .iter()
            .map(|seek| {
                let end = seek.end_index.unwrap_or(self.trace.len());
                (seek.start_index.max(1)..end)
                    .filter(|&k| on(k) && !on(k - 1))
                    .count()
            })
            .collect()
    }

    /// Per seek of the twin's schedule (in order, ended or not): the servo reported a seek
    /// error during it ([`ServoFlags::SEEK_ERROR`]; never for the baseline).
    pub fn seek_error_per_seek(&self) -> Vec<bool> {
        self.twin
            .seeks()
            .iter()
            .map(|seek| {
                let end = seek.end_index.unwrap_or(self.seek_errors.len());
                self.seek_errors
                    .get(seek.start_index..end)
                    .is_some_and(|s| s.iter().any(|&e| e))
            })
            .collect()
    }
}

/// The servo's safety layer on the twin `params`: [`ServoDesign::new`]'s for `design`, with soft
/// end stops half the twin's travel beyond the farthest target it commands (quanta of the plant)
/// — farther where the prior's sled, cut off at its top speed b·u_max/(1 − a), would coast past
/// them (T_coast · top speed + the margin beyond the travel): a sled of the family with a ≈ 0.98
/// coasts 10,000 quanta from top speed, and the layer would otherwise stop it for arriving at top
/// speed on a healthy seek.
pub fn twin_safety(params: &TwinParams, design: &ScheduledDesign) -> SafetyDesign {
    let safety = ServoDesign::new(*design).safety;
    let half = 0.5 * f64::from(params.reference.travel_tracks);
    let top_coast = design.prior_model.map_or(0.0, |(a, b)| {
        let u_max = design.baseline.u_limit_v / design.baseline.u_full_scale_v;
        safety.coast_samples * b * u_max / (1.0 - a.clamp(0.0, 0.99))
    });
    let travel = (3.0 * half).max(half + top_coast + safety.travel_margin_quanta);
    SafetyDesign {
        travel_min_quanta: -travel,
        travel_max_quanta: travel,
        ..safety
    }
}

/// Runs `seeks` random seeks of `params` with `kind` in the loop, the scheduled controller
/// tuned on the default sled ([`super::design::scheduled_design`]).
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    kind: ControllerKind,
) -> Result<ControlRun, String> {
    run_tuned(params, &PlantParams::default(), seed, seeks, kind)
}

/// Runs `seeks` random seeks of `params` with `kind` in the loop, the scheduled controller tuned
/// on the plant `nominal` ([`scheduled_design_for`]).
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_tuned(
    params: &TwinParams,
    nominal: &PlantParams,
    seed: u64,
    seeks: u32,
    kind: ControllerKind,
) -> Result<ControlRun, String> {
    match kind {
        ControllerKind::Baseline => run_with(params, seed, seeks, None),
        ControllerKind::Scheduled => {
            let design = scheduled_design_for(params, nominal)?;
            run_with(params, seed, seeks, Some(&design))
        }
    }
}

/// Runs `seeks` random seeks of `params` with the baseline (`design` = `None`) or the scheduled
/// controller of `design` in the loop.
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_with(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    design: Option<&ScheduledDesign>,
) -> Result<ControlRun, String> {
    run_with_options(params, seed, seeks, design, ServoOptions::default())
}

/// [`run_with`] with the servo's options.
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_with_options(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    design: Option<&ScheduledDesign>,
    options: ServoOptions,
) -> Result<ControlRun, String> {
    run_servo_with_faults(params, seed, seeks, design, options, None, &[])
}

/// [`run_with_options`] with power-on calibration before the schedule (`calibration`) and
/// `faults` injected into the servo's loop (both ignored for the baseline).
///
/// # Errors
/// Twin, controller or calibration configuration errors.
pub fn run_servo_with_faults(
    params: &TwinParams,
    seed: u64,
    seeks: u32,
    design: Option<&ScheduledDesign>,
    options: ServoOptions,
    calibration: Option<CalibrationDesign>,
    faults: &[super::inject::ServoFault],
) -> Result<ControlRun, String> {
    let mut params = params.clone();
    params.reference.seek_count = seeks;
    params.reference.targets_tracks = None;
    let mut twin = Twin::new(params.clone(), seed).map_err(|e| e.to_string())?;
    let p = &params.plant;
    let mut calibrated = None;
    let mut calibrations = 0;
    let mut calibrations_inconclusive = 0;
    let mut suspended_at = None;
    let (trace, seek_errors, redesigns, first_stop, kind) = match design {
        None => {
            let design = baseline_design(&params.controller, p.ts_s, p.u_max_v);
            let mut c = FixedPid::new(&design).map_err(|e| e.to_string())?;
            twin.set_controller_label("baseline_fixed_pid");
            twin.run(&mut c);
            (
                Vec::new(),
                Vec::new(),
                Vec::new(),
                None,
                ControllerKind::Baseline,
            )
        }
        Some(design) => {
            let mut c = ScheduledLoop::with_safety(
                design,
                &identifier_design(design),
                options,
                twin_safety(&params, design),
            )?
            .with_calibration(calibration)?;
            calibrated = c.calibrate(&mut twin);
            twin.set_controller_label("scheduled");
            super::inject::run_with_faults(&mut twin, &mut c, faults);
            calibrations = c.state.calibrations();
            calibrations_inconclusive = c.state.inconclusive_calibrations();
            suspended_at = c.suspended_at;
            (
                c.trace,
                c.seek_errors,
                c.redesigns,
                c.first_stop,
                ControllerKind::Scheduled,
            )
        }
    };
    let mut summary = summarize(&twin, &trace, &redesigns, kind, seed);
    summary.safe_stop = first_stop.map(|(k, reason)| {
        let y = twin.samples().get(k).map_or(0, |s| s.y_counts);
        format!("{} at sample {k}, reading {y} quanta", reason.name())
    });
    summary.identification_suspended_at = suspended_at;
    Ok(ControlRun {
        twin,
        trace,
        seek_errors,
        summary,
        redesigns,
        first_stop,
        calibration: calibrated,
        calibrations,
        calibrations_inconclusive,
    })
}
