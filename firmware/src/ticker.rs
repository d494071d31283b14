//! The interrupt's body ([`Ticker`]) behind the embedded-hal boundary the PIL stands in for
//! (a frame's position in, PWM + direction pin out), and the run's result line ([`Summary`]).

use core::borrow::Borrow;
use core::convert::Infallible;
use core::fmt;

use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::pwm::{ErrorType as PwmErrorType, SetDutyCycle};
use sledid::Status;
use sledid::control::Redesign;
use sledid::control::scheduled::{RedesignJob, RedesignResult};
use sledid::servo::hal::{ControlLoop, DriveError, PositionSensor, PwmDirection};
use sledid::servo::{
    Calibrated, CalibrationRecord, Posted, ServoFlags, SledServo, SledServoState, StopReason,
    Ticket,
};

use crate::health::HealthLine;
use crate::link::{DownFrame, Kind, UpFrame, flags_word};

/// Full scale of the PIL drive's PWM channel: a 20 kHz PWM on a 72 MHz timer clock, as on the
/// board image.
pub const PWM_MAX_DUTY: u16 = 3_600;

/// What starts the firmware's result line (followed by a space and the [`Summary`]).
pub const RESULT_PREFIX: &str = "sledid-fw result:";
/// What starts the firmware's timing line (key=value pairs, see the firmware's `main.rs`).
pub const TIMING_PREFIX: &str = "sledid-fw timing:";

/// The PIL's position input: the y of the frame being stepped (`None`: lost).
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameSensor {
    /// The reading of this sample, whole quanta.
    pub counts: Option<i64>,
}

/// A reading the frame did not carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoReading;

impl PositionSensor for FrameSensor {
    type Error = NoReading;
    fn read_counts(&mut self) -> Result<i64, NoReading> {
        self.counts.ok_or(NoReading)
    }
}

/// The PIL's PWM channel: keeps the duty it was set to (a board's timer compare register).
#[derive(Clone, Copy, Debug, Default)]
pub struct PilPwm {
    /// The duty set last.
    pub duty: u16,
}

impl PwmErrorType for PilPwm {
    type Error = Infallible;
}

impl SetDutyCycle for PilPwm {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }
    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.duty = duty;
        Ok(())
    }
}

/// The PIL's direction pin: keeps its level (a board's GPIO output register).
#[derive(Clone, Copy, Debug, Default)]
pub struct PilPin {
    /// The level set last.
    pub high: bool,
}

impl PinErrorType for PilPin {
    type Error = Infallible;
}

impl OutputPin for PilPin {
    fn set_low(&mut self) -> Result<(), Infallible> {
        self.high = false;
        Ok(())
    }
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.high = true;
        Ok(())
    }
}

/// The interrupt's body, one call per sample period: the frame's position through the servo's
/// step behind [`ControlLoop`] (position in, drive out over embedded-hal 1.0), the answer, and
/// the run's totals. The firmware's SysTick handler and the host's reference run step the same
/// code on the same words.
///
/// `C` holds the configuration: the host owns it (`SledServo`); the firmware borrows it from its
/// own static storage, so that the configuration and the ticker are each built in place.
pub struct Ticker<C> {
    config: C,
    state: SledServoState,
    control: ControlLoop<FrameSensor, PwmDirection<PilPwm, PilPin>>,
    totals: Summary,
}

impl<C: Borrow<SledServo>> Ticker<C> {
    /// A fresh run of a built configuration (infallible, so that the firmware can construct it
    /// in place).
    #[inline(always)]
    pub fn new(config: C) -> Self {
        Self {
            state: config.borrow().new_state(),
            config,
            control: ControlLoop::new(
                FrameSensor::default(),
                PwmDirection {
                    pwm: PilPwm::default(),
                    direction: PilPin::default(),
                },
            ),
            totals: Summary::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &SledServo {
        self.config.borrow()
    }

    /// The servo's state.
    pub fn state(&self) -> &SledServoState {
        &self.state
    }

    /// One sample period on `frame` (of kind [`Kind::Sample`] or [`Kind::Lost`]): the answer.
    /// A redesign the step asks for waits in the state for [`Self::take_job`]. Never panics.
    #[inline(never)]
    pub fn step(&mut self, frame: &DownFrame) -> UpFrame {
        let lost = frame.command.kind() != Some(Kind::Sample);
        self.control.sensor.counts = (!lost).then_some(frame.y.raw() >> 16);
        let k = self.state.sample_index();
        let out = match self
            .control
            .tick(self.config.borrow(), &mut self.state, frame.r)
        {
            Ok(out) => out,
            Err(DriveError::First(e) | DriveError::Second(e)) => match e {},
        };
        let drive = &self.control.drive;
        let up = UpFrame {
            k,
            u_raw: out.u.raw(),
            flags: flags_word(&out),
            duty: drive.pwm.duty,
            forward: drive.direction.high,
        };
        let t = &mut self.totals;
        t.samples = t.samples.wrapping_add(1);
        t.lost = t.lost.wrapping_add(u32::from(lost));
        t.updates = t
            .updates
            .wrapping_add(u32::from(out.identifier.status.contains(Status::UPDATED)));
        for (count, flag) in t.handover.iter_mut().zip([
            ServoFlags::REDESIGN_POSTED,
            ServoFlags::REDESIGN_ADOPTED,
            ServoFlags::HANDOVER_MISSED,
        ]) {
            *count = count.wrapping_add(u32::from(out.servo.contains(flag)));
        }
        up
    }

    /// The background's side: the redesign job a step posted, once.
    pub fn take_job(&mut self) -> Option<Posted<RedesignJob>> {
        self.state.take_job()
    }

    /// The background's result for a job (counted by outcome when the hand-over accepts it:
    /// false when its due sample has passed).
    pub fn deliver(&mut self, ticket: Ticket, design: RedesignResult) -> bool {
        let accepted = self.state.deliver(ticket, design);
        if accepted {
            let i = match design.outcome {
                Redesign::Applied(_) => 0,
                Redesign::Rejected(_) => 1,
                Redesign::Skipped => 2,
            };
            if let Some(count) = self.totals.redesigns.get_mut(i) {
                *count = count.wrapping_add(1);
            }
        }
        accepted
    }

    /// The background's side of power-on calibration: the record the experiment posted, once
    /// (the background answers with [`SledServo::calibrate`]).
    pub fn take_calibration_job(&mut self) -> Option<Posted<CalibrationRecord>> {
        self.state.take_calibration_job()
    }

    /// [`Self::take_calibration_job`] copied straight into `record`: the ticket, or `None`.
    pub fn take_calibration_job_into(&mut self, record: &mut CalibrationRecord) -> Option<Ticket> {
        self.state.take_calibration_job_into(record)
    }

    /// The background's answer to calibration's record: false when its due sample has passed
    /// (the step has flagged the miss and posted the record again).
    pub fn deliver_calibration(
        &mut self,
        ticket: Ticket,
        answer: Calibrated<RedesignResult>,
    ) -> bool {
        self.state.deliver_calibration(ticket, answer)
    }

    /// What the run has produced so far.
    pub fn summary(&self) -> Summary {
        let mut s = self.totals;
        s.calibrations = self.state.calibrations();
        for (dst, t) in s
            .theta_raw
            .iter_mut()
            .zip(self.state.identifier().model().theta())
        {
            *dst = t.raw();
        }
        s.stop = self.state.safe_stop();
        s
    }
}

/// Parameters of the velocity identifier reported in the result line.
pub const THETA_N: usize = sledid::servo::VELOCITY_N;

/// The outcome of a run: what the firmware prints and the host's reference must equal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Samples stepped.
    pub samples: u32,
    /// Of which without a position ([`Kind::Lost`]).
    pub lost: u32,
    /// Samples on which the velocity identifier updated θ and P.
    pub updates: u32,
    /// Hand-overs: jobs posted, results adopted, hand-overs missed (servo flags).
    pub handover: [u32; 3],
    /// Results accepted by the hand-over: [applied, rejected, skipped].
    pub redesigns: [u32; 3],
    /// Handlers that ended after the next period had begun (the target's count; the host
    /// expects one per overrun it asked for, [`crate::Command::stall`]).
    pub overruns: u32,
    /// Calibrations adopted (power-on's and every re-calibration).
    pub calibrations: u32,
    /// Why the safety layer stopped the servo, if it did (the latched reason at the end; the
    /// sample it stopped at is the first answer flagged `SAFE_STOP`).
    pub stop: Option<StopReason>,
    /// Final velocity θ, raw I12F20.
    pub theta_raw: [i32; THETA_N],
    /// The friction health at the end ([`crate::health`]; filled in by the caller, which owns
    /// the estimator: [`Ticker::summary`] leaves it at its default).
    pub health: HealthLine,
}

/// `[a, b, c]`: a slice as defmt prints it.
fn write_list<T: fmt::Display>(f: &mut fmt::Formatter<'_>, items: &[T]) -> fmt::Result {
    f.write_str("[")?;
    for (k, t) in items.iter().enumerate() {
        if k > 0 {
            f.write_str(", ")?;
        }
        write!(f, "{t}")?;
    }
    f.write_str("]")
}

impl fmt::Display for Summary {
    /// `samples=… lost=… updates=… handover=[posted, adopted, missed] redesigns=[applied,
    /// rejected, skipped] overruns=… calibrations=… stop=none|code theta=[…] health=[ĉ, c_ref]
    /// health_updates=… health_flags=… health_dropped=…` (the stop's [`StopReason::code`]; θ,
    /// ĉ and c_ref raw I12F20; [`HealthLine`]), exactly the firmware's defmt line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "samples={} lost={} updates={} handover=",
            self.samples, self.lost, self.updates
        )?;
        write_list(f, &self.handover)?;
        f.write_str(" redesigns=")?;
        write_list(f, &self.redesigns)?;
        write!(
            f,
            " overruns={} calibrations={} stop=",
            self.overruns, self.calibrations
        )?;
        match self.stop {
            Some(reason) => write!(f, "{}", reason.code())?,
            None => f.write_str("none")?,
        }
        f.write_str(" theta=")?;
        write_list(f, &self.theta_raw)?;
        let h = &self.health;
        f.write_str(" health=")?;
        write_list(f, &h.coulomb_raw)?;
        write!(
            f,
            " health_updates={} health_flags={} health_dropped={}",
            h.updates, h.flags, h.dropped
        )
    }
}
