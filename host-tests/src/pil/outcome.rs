//! What a run's servo did about its faults: every seek settled, or a safe stop — its reason,
//! sample and position — that the target and the host's reference agree on: the reason is the
//! result line's (the host's summary; [`super::PilRun::check`] demands the target's line equal
//! it), the sample the first answer flagged `SAFE_STOP` (bit-identical to the host's). Which of
//! the two the faults call for is [`Faults::stop_rule`](super::Faults::stop_rule).

use std::fmt;

use sledid::servo::{ServoFlags, StopReason};
use sledid_firmware::{Kind, UpFrame};

use super::{LoopRun, StopRule, design};

/// A run's safe stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SafeStop {
    /// Why: the reason latched at the end of the run (the result line's `stop=` code).
    pub reason: StopReason,
    /// The first sample whose answer is flagged `SAFE_STOP`.
    pub k: u32,
}

impl fmt::Display for SafeStop {
    /// `reason at sample k`, e.g. `runaway at sample 1466`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} at sample {}", self.reason.name(), self.k)
    }
}

/// True for an answer flagged `SAFE_STOP`.
fn flagged_stop(up: &UpFrame) -> bool {
    up.servo_flags().contains(ServoFlags::SAFE_STOP)
}

/// A move of the sled: 2 quanta, more than the reading's flicker about a position at rest.
pub const MOVED_QUANTA: u32 = 2;

impl LoopRun {
    /// The twin's sample index of frame `k` (`None` during power-on calibration, which the twin
    /// runs before its schedule: frames count calibration's samples first).
    pub fn twin_index(&self, k: u32) -> Option<usize> {
        (k as usize).checked_sub(self.calibration_samples)
    }

    /// The frame of the twin's sample `i`.
    pub fn frame_index(&self, i: usize) -> usize {
        i + self.calibration_samples
    }

    /// The seek (index in the schedule) sample `k` falls in (0 during calibration).
    fn seek_of(&self, k: u32) -> usize {
        let Some(i) = self.twin_index(k) else {
            return 0;
        };
        self.twin
            .seeks()
            .iter()
            .rposition(|s| s.start_index <= i)
            .unwrap_or(0)
    }

    /// The safe stop: the summary's reason at the first answer flagged `SAFE_STOP` (`None` when
    /// either is missing; [`Self::check_outcome`] refuses a run where they disagree).
    pub fn stop(&self) -> Option<SafeStop> {
        let k = self.records.iter().position(|r| flagged_stop(&r.up))?;
        Some(SafeStop {
            reason: self.summary.stop?,
            k: u32::try_from(k).ok()?,
        })
    }

    /// The first sample at or after `k` at which the sled has moved: its reading at least
    /// [`MOVED_QUANTA`] from the reading at `k` (the first reading at or after `k`), if the run
    /// has one. A reversed sensor or drive shows only once the sled moves: one injected while it
    /// holds at rest shows on the next seek, one whose servo's drive stays below breakaway not
    /// at all.
    pub fn first_move(&self, k: u32) -> Option<u32> {
        let mut readings = self
            .records
            .get(k as usize..)?
            .iter()
            .filter(|r| r.frame.command.kind() == Some(Kind::Sample))
            .map(|r| (r.up.k, r.frame.y.raw()));
        let (_, at_k) = readings.next()?;
        let moved = i64::from(MOVED_QUANTA) << 16;
        readings
            .find(|&(_, y)| (y - at_k).abs() >= moved)
            .map(|(k, _)| k)
    }

    /// What the servo did, in one phrase: `20/20 seeks settled, no safe stop`, or `SAFE STOP
    /// (runaway) at sample 1516 in seek 3 of 4, reading … quanta, sled at … quanta; 2/4 seeks
    /// settled` (seeks counted from 1; the reading is the frame's y, the sled's position the
    /// twin's sensor before the faults).
    pub fn outcome_line(&self) -> String {
        let (seeks, settled) = self.settled();
        let settled = format!("{settled}/{seeks} seeks settled");
        let Some(stop) = self.stop() else {
            return format!("{settled}, no safe stop");
        };
        let k = stop.k as usize;
        let reading = match self
            .records
            .get(k)
            .map(|r| (r.frame.command.kind(), r.frame.y))
        {
            Some((Some(Kind::Sample), y)) => format!("reading {} quanta", y.raw() >> 16),
            _ => "no reading".to_owned(),
        };
        let sample = self
            .twin_index(stop.k)
            .and_then(|i| self.twin.samples().get(i));
        let sled = sample.map_or(String::new(), |s| {
            format!(", sled at {} quanta", s.y_counts)
        });
        format!(
            "SAFE STOP ({}) at sample {k} in seek {} of {}, {reading}{sled}; {settled}",
            stop.reason.name(),
            self.seek_of(stop.k) + 1,
            self.twin.seeks().len()
        )
    }

    /// Checks that the servo did what the run's faults call for ([`StopRule`]): with none that
    /// may stop it, no stop and every seek settled; with one that may, that or a stop; with one
    /// that must, a stop. The summary's reason and the answers' flags must agree; a stop must
    /// come at or after the first fault that may cause it and hold to the end with the drive
    /// cut.
    ///
    /// # Errors
    /// What the servo did instead.
    pub fn check_outcome(&self) -> Result<(), String> {
        let flagged = self.records.iter().position(|r| flagged_stop(&r.up));
        if flagged.is_some() != self.summary.stop.is_some() {
            return Err(format!(
                "the summary's stop ({:?}) and the first answer flagged SAFE_STOP ({flagged:?}) \
                 disagree",
                self.summary.stop
            ));
        }
        let bridged = design()?.safety.lost_samples;
        let samples = u32::try_from(self.records.len()).unwrap_or(u32::MAX);
        let rule = self
            .plan
            .stop_rule(samples, bridged, |k| self.first_move(k));
        match (rule, self.stop()) {
            (StopRule::Never, Some(stop)) => Err(format!(
                "the servo stopped ({stop}), though no fault injected may stop it"
            )),
            (StopRule::Required { from }, None) => Err(format!(
                "no safe stop, though the faults from sample {from} must stop the servo; {}",
                self.outcome_line()
            )),
            (StopRule::Allowed { from } | StopRule::Required { from }, Some(stop)) => {
                self.check_stop(stop, from)
            }
            (StopRule::Never | StopRule::Allowed { .. }, None) => {
                let (seeks, settled) = self.settled();
                if settled == seeks && seeks > 0 {
                    Ok(())
                } else {
                    Err(format!("{settled} of {seeks} seeks settled, no safe stop"))
                }
            }
        }
    }

    /// `stop` came at or after sample `from` and held to the end with the drive cut.
    fn check_stop(&self, stop: SafeStop, from: u32) -> Result<(), String> {
        if stop.k < from {
            return Err(format!(
                "the servo stopped ({stop}) before the first fault that may stop it (sample {from})"
            ));
        }
        let held = |up: &UpFrame| flagged_stop(up) && up.u_raw == 0;
        match self
            .records
            .get(stop.k as usize..)
            .unwrap_or_default()
            .iter()
            .find(|r| !held(&r.up))
        {
            Some(r) => Err(format!(
                "the stop ({stop}) did not hold: sample {} answered {:?}",
                r.up.k, r.up
            )),
            None => Ok(()),
        }
    }
}
