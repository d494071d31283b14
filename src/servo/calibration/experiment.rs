//! The calibration experiment as a per-sample state machine (module docs of [`super`]): one
//! call per sample, a drive out, nothing waits. Positions I48F16 raw (`i64`, quanta), drives and
//! the record's readings I16F16 raw (`i32`: fractions of full scale, quanta relative to a push's
//! first reading).

use super::{CalibrationConfig, Refusal};

/// Pushes recorded: +U₀, −U₀, +U₁, −U₁.
pub const SEGMENTS: usize = 4;

/// Readings recorded per push (push and braking).
pub const SEGMENT_LEN: usize = 48;

const ONE: i32 = 1 << 16;
/// The breakaway search holds its cap this many times a level's samples before it refuses.
const MAX_LEVEL_HOLDS: u16 = 8;

/// One push from rest: the drive d·U for samples j < `push_len`, −d·U from there (braking), and
/// the readings x(j) − x(0), I16F16 raw quanta, valid for j < `len` (braking samples after the
/// sled may have stopped are left out).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Segment {
    /// d·U, I16F16 raw fraction of full scale (0: not recorded).
    pub drive_i16f16: i32,
    /// Samples under the push's drive.
    pub push_len: u16,
    /// Valid readings.
    pub len: u16,
    /// x(j) − x(0), I16F16 raw quanta.
    pub x_i16f16: [i32; SEGMENT_LEN],
}

impl Segment {
    const EMPTY: Self = Self {
        drive_i16f16: 0,
        push_len: 0,
        len: 0,
        x_i16f16: [0; SEGMENT_LEN],
    };

    /// The direction of the push: 1, −1, or 0 when not recorded.
    pub fn direction(&self) -> i32 {
        self.drive_i16f16.signum()
    }

    /// The valid readings.
    pub fn readings(&self) -> &[i32] {
        self.x_i16f16
            .get(..usize::from(self.len))
            .unwrap_or(&self.x_i16f16)
    }
}

/// What the experiment hands to the background's fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationRecord {
    /// The pushes, in the order +U₀, −U₀, +U₁, −U₁.
    pub segments: [Segment; SEGMENTS],
    /// The breakaway drive found in each direction (+, −), I16F16 raw fraction of full scale.
    pub breakaway_i16f16: [i32; 2],
    /// Samples the experiment took.
    pub samples: u16,
    /// The furthest the sled went from where it started, I16F16 raw quanta.
    pub travel_i16f16: i32,
}

impl CalibrationRecord {
    /// Every push recorded to its end (its braking included): what the fit needs.
    pub fn complete(&self) -> bool {
        self.segments
            .iter()
            .all(|s| s.drive_i16f16 != 0 && s.len > 0)
    }

    /// Nothing recorded.
    pub const EMPTY: Self = Self {
        segments: [Segment::EMPTY; SEGMENTS],
        breakaway_i16f16: [0; 2],
        samples: 0,
        travel_i16f16: 0,
    };
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
enum Phase {
    Rest,
    Breakaway,
    Push,
    Brake,
    /// The record is with the background; the drive stays 0.
    Fitting,
    Done,
    Refused(Refusal),
}

/// What one sample of the experiment did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// Nothing to report.
    None,
    /// The record is complete: post it to the background.
    Recorded,
    /// The sled is refused.
    Refused(Refusal),
}

/// The experiment's progress (in the servo's state).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationState {
    phase: Phase,
    /// 1, 2: breakaway +, −; 3 … 6: the pushes; 7: recorded. Run after a rest.
    stage: u8,
    k: u16,
    started: bool,
    home: i64,
    y1: i64,
    from: i64,
    /// The reading at the stage's start.
    origin: i64,
    level: i32,
    held: u16,
    n: u16,
    quiet: u16,
    waited: u16,
    record: CalibrationRecord,
}

impl Default for CalibrationState {
    fn default() -> Self {
        Self::new()
    }
}

/// a·b of two I16F16 raw values, saturated.
fn mul(a: i32, b: i32) -> i32 {
    let p = (i64::from(a) * i64::from(b)) >> 16;
    i32::try_from(p).unwrap_or(if p < 0 { i32::MIN } else { i32::MAX })
}

/// A position difference as I16F16 raw, saturated.
fn rel(y: i64, from: i64) -> i32 {
    let d = y.saturating_sub(from);
    i32::try_from(d).unwrap_or(if d < 0 { i32::MIN } else { i32::MAX })
}

impl CalibrationState {
    /// Not started: the first sample starts the experiment where the sled is.
    pub const fn new() -> Self {
        Self {
            phase: Phase::Rest,
            stage: 1,
            k: 0,
            started: false,
            home: 0,
            y1: 0,
            from: 0,
            origin: 0,
            level: 0,
            held: 0,
            n: 0,
            quiet: 0,
            waited: 0,
            record: CalibrationRecord::EMPTY,
        }
    }

    /// Calibration already finished (or was never configured): the servo runs.
    pub const fn finished() -> Self {
        let mut s = Self::new();
        s.phase = Phase::Done;
        s
    }

    /// The experiment (or its fit) is still running: the servo does not seek yet.
    pub fn is_running(&self) -> bool {
        !matches!(self.phase, Phase::Done | Phase::Refused(_))
    }

    /// Calibrated: the model has been adopted.
    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// Why the sled was refused, if it was.
    pub fn refusal(&self) -> Option<Refusal> {
        match self.phase {
            Phase::Refused(r) => Some(r),
            _ => None,
        }
    }

    /// The record (complete once posted).
    pub fn record(&self) -> &CalibrationRecord {
        &self.record
    }

    /// Samples since the experiment started.
    pub fn samples(&self) -> u16 {
        self.k
    }

    /// Where the experiment started, I48F16 raw quanta.
    pub fn home(&self) -> i64 {
        self.home
    }

    /// The fit was adopted.
    pub(crate) fn finish(&mut self) {
        self.phase = Phase::Done;
    }

    /// Refused (by the experiment or by the fit).
    pub(crate) fn refuse(&mut self, r: Refusal) {
        self.phase = Phase::Refused(r);
    }

    fn direction(&self) -> i32 {
        if self.stage % 2 == 1 { 1 } else { -1 }
    }

    /// Stage done: rest, then the next.
    fn next_stage(&mut self) {
        self.stage = self.stage.saturating_add(1);
        self.phase = Phase::Rest;
        self.quiet = 0;
        self.waited = 0;
    }

    /// The push drive of segment `s` (magnitude), I16F16 raw.
    fn push_level(&self, c: &CalibrationConfig, s: usize) -> i32 {
        let d = usize::from(self.direction() < 0);
        let bk = self.record.breakaway_i16f16.get(d).copied().unwrap_or(ONE);
        let u0 = mul(bk, c.push_ratio_i16f16).clamp(1, ONE);
        if s < 2 {
            return u0;
        }
        // The second push in this direction: as much harder as the first fell short of D.
        let first = self.record.segments.get(s - 2).unwrap_or(&Segment::EMPTY);
        let dist = first
            .x_i16f16
            .get(usize::from(first.push_len))
            .map_or(0, |x| x.saturating_mul(first.direction()))
            .max(ONE);
        let ratio =
            ((i64::from(c.push_i16f16) << 16) / i64::from(dist)).clamp(2 << 16, 16 << 16) as i32; // within [2, 16] · 2¹⁶
        mul(u0, ratio).clamp(1, ONE)
    }

    /// Starts the current stage at reading `y`; the drive of this sample.
    fn start_stage(&mut self, c: &CalibrationConfig, y: i64) -> (i32, Event) {
        self.from = y;
        self.origin = y;
        let d = self.direction();
        match self.stage {
            1 | 2 => {
                self.phase = Phase::Breakaway;
                self.level = c.start_i16f16;
                self.held = 0;
                (d * self.level, Event::None)
            }
            3..=6 => {
                let s = usize::from(self.stage - 3);
                let u = d * self.push_level(c, s);
                if let Some(seg) = self.record.segments.get_mut(s) {
                    *seg = Segment::EMPTY;
                    seg.drive_i16f16 = u;
                }
                self.phase = Phase::Push;
                self.n = 1;
                (u, Event::None)
            }
            _ => {
                self.phase = Phase::Fitting;
                self.record.samples = self.k;
                (0, Event::Recorded)
            }
        }
    }

    /// One sample of the experiment: the reading (`None`: lost) in, the drive (I16F16 raw) out.
    /// Outside the experiment (fitting, done, refused) the drive is 0. Never panics.
    pub fn step(&mut self, c: &CalibrationConfig, y: Option<i64>) -> (i32, Event) {
        if !matches!(
            self.phase,
            Phase::Rest | Phase::Breakaway | Phase::Push | Phase::Brake
        ) {
            return (0, Event::None);
        }
        let Some(y) = y else {
            // A lost reading spoils the stage in progress: it is run again after a rest.
            self.phase = Phase::Rest;
            self.quiet = 0;
            return (0, Event::None);
        };
        if !self.started {
            self.started = true;
            self.home = y;
            self.y1 = y;
        }
        self.k = self.k.saturating_add(1);
        let out = self.advance(c, y);
        self.y1 = y;
        let away = rel(y, self.home).saturating_abs();
        self.record.travel_i16f16 = self.record.travel_i16f16.max(away);
        let refusal = if let (_, Event::Refused(r)) = out {
            Some(r)
        } else if away > c.travel_i16f16 {
            Some(Refusal::Travel)
        } else if self.k > c.samples_max {
            Some(Refusal::Timeout)
        } else {
            None
        };
        match refusal {
            Some(r) => {
                self.refuse(r);
                (0, Event::Refused(r))
            }
            None => out,
        }
    }

    fn advance(&mut self, c: &CalibrationConfig, y: i64) -> (i32, Event) {
        let d = self.direction();
        match self.phase {
            Phase::Rest => {
                let step = rel(y, self.y1);
                self.quiet = if step == 0 { self.quiet + 1 } else { 0 };
                self.waited = self.waited.saturating_add(1);
                if self.quiet >= c.rest || self.waited >= c.rest_max {
                    return self.start_stage(c, y);
                }
                if step == 0 || self.waited <= c.rest {
                    return (0, Event::None);
                }
                // Still moving after `rest` samples (a heavy sled with little friction coasts
                // for long): braked at the largest breakaway drive found so far.
                let [p, n] = self.record.breakaway_i16f16;
                let brake = p.max(n).max(c.start_i16f16);
                (-step.signum() * brake, Event::None)
            }
            Phase::Breakaway => {
                // Motion counts from the furthest reading against the drive (a sled still
                // creeping from the last stage is not a reversed one) ...
                if rel(y, self.from).saturating_mul(d) < 0 {
                    self.from = y;
                }
                let moved = rel(y, self.from).saturating_mul(d);
                if moved >= c.moved_i16f16 {
                    if let Some(b) = self.record.breakaway_i16f16.get_mut(usize::from(d < 0)) {
                        *b = self.level;
                    }
                    self.next_stage();
                    return (0, Event::None);
                }
                // ... and a reversed one runs against it: 4× the motion threshold.
                if rel(y, self.origin).saturating_mul(d) <= -c.moved_i16f16.saturating_mul(4) {
                    return (0, Event::Refused(Refusal::Reversed));
                }
                // The largest level is the cap itself, held MAX_LEVEL_HOLDS times as long: a
                // slow sled just past its breakaway there (the slow, sticky corner: ≈ 0.4 full
                // scale, 1.4 quanta per sample per full scale) needs a few samples to move the
                // threshold; refused as stuck only after that.
                self.held += 1;
                let at_max = self.level >= c.breakaway_max_i16f16;
                let hold = if at_max {
                    c.hold.saturating_mul(MAX_LEVEL_HOLDS)
                } else {
                    c.hold
                };
                if self.held >= hold {
                    if at_max {
                        return (0, Event::Refused(Refusal::Stuck));
                    }
                    self.held = 0;
                    self.level = mul(self.level, c.ratio_i16f16)
                        .max(self.level + 1)
                        .min(c.breakaway_max_i16f16);
                }
                (d * self.level, Event::None)
            }
            Phase::Push | Phase::Brake => self.record_push(c, y, d),
            _ => (0, Event::None),
        }
    }

    /// A push or braking sample: the reading recorded, the drive decided.
    fn record_push(&mut self, c: &CalibrationConfig, y: i64, d: i32) -> (i32, Event) {
        let j = self.n;
        let x = rel(y, self.from);
        let advancing = rel(y, self.y1).saturating_mul(d) > 0;
        let s = usize::from(self.stage.saturating_sub(3));
        let Some(seg) = self.record.segments.get_mut(s) else {
            return (0, Event::Refused(Refusal::Timeout));
        };
        if let Some(slot) = seg.x_i16f16.get_mut(usize::from(j)) {
            *slot = x;
        }
        self.n = j + 1;
        let u = seg.drive_i16f16;
        if self.phase == Phase::Push {
            let dist = x.saturating_mul(d);
            if dist <= -c.moved_i16f16.saturating_mul(4) {
                return (0, Event::Refused(Refusal::Reversed));
            }
            if dist >= c.push_i16f16 || j >= c.push_samples {
                seg.push_len = j;
                self.phase = Phase::Brake;
                return (-u, Event::None);
            }
            return (u, Event::None);
        }
        // Braking: the readings count while the sled surely moved through them (the sled may
        // have stopped anywhere after the last reading that advanced).
        let full = usize::from(j) + 1 >= SEGMENT_LEN;
        if !advancing || full {
            seg.len = if advancing {
                j + 1
            } else {
                j.saturating_sub(1).max(seg.push_len + 1)
            };
            self.next_stage();
            return (0, Event::None);
        }
        (-u, Event::None)
    }
}
