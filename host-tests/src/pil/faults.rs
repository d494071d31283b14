//! The faults a PIL run injects ([`Faults`]): the tests' plan, or `sledid pil --inject` specs in
//! the `KIND:key=value,…` syntax of `sledid seek --inject` ([`crate::faults::spec`]).
//!
//! # Sample and job indices
//! K counts the PIL's samples: the frame's index from 0 at the run's first frame (the up frame's
//! `k`). The firmware's servo calibrates at power-on first, so the seek schedule starts at
//! sample [`super::LoopRun::calibration_samples`] (a plant step due before it comes at that
//! sample). J counts the redesign jobs in the order the servo posts them, from 0 (calibration's
//! fit is not one of them).
//!
//! | kind | keys | what happens |
//! |---|---|---|
//! | `lost` | `at`, `n` (default 1) | samples K … K + n − 1 are sent without a position |
//! | `stall` | `at` | the handler overruns at the first sample ≥ K with no redesign in flight |
//! | `handover-miss` | `job` | job J's result comes back late (delay L): its hand-over misses |
//! | `handover-slow` | `job` | job J's result comes back slow but in time (delay L − 1) |
//! | `flip` | `from` | the reading mirrored about its value at K, from K on (a reversed sensor) |
//! | `drive-flip` | `from` | the drive reaches the sled reversed from K on |
//! | `mass`, `friction` | `at`, `factor` | the twin's plant stepped before sample K (as `seek`'s) |
//!
//! The twin runs on the host, and so do the sensor, drive and plant faults: the frames the target
//! and the host's reference step are the same, and the lockstep holds.

use crate::control::inject::ServoFault;
use crate::faults::spec::Spec;

/// The faults a run injects (module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Faults {
    /// Samples sent without a position (ascending).
    pub lost: Vec<u32>,
    /// Samples whose handler overruns (ascending); each moves to the first sample at or after it
    /// with no redesign in flight (so that the late background the overrun causes misses no
    /// hand-over).
    pub stalls: Vec<u32>,
    /// Jobs whose background is slow but in time (delay L − 1).
    pub slow_jobs: Vec<u32>,
    /// Jobs whose background is late (delay L): their hand-overs miss.
    pub missed_jobs: Vec<u32>,
    /// From this sample on, the sensor reads reversed: y mirrored about its reading at that
    /// sample (a connector plugged in the wrong way; the safety layer must stop the servo).
    pub reversed_sensor_from: Option<u32>,
    /// From this sample on, the drive reaches the sled reversed (the safety layer must stop the
    /// servo).
    pub reversed_drive_from: Option<u32>,
    /// Steps of the twin's plant: [`ServoFault::Mass`] and [`ServoFault::Friction`] only.
    pub plant_steps: Vec<ServoFault>,
}

/// One `sledid pil --inject` spec (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PilFault {
    /// Samples `at` … `at + n − 1` without a position.
    Lost {
        /// First lost sample.
        at: u32,
        /// How many (≥ 1).
        n: u32,
    },
    /// An overrun at the first sample ≥ `at` with no redesign in flight.
    Stall {
        /// The sample.
        at: u32,
    },
    /// Job `job`'s hand-over misses.
    HandoverMiss {
        /// The job.
        job: u32,
    },
    /// Job `job`'s result comes back slow, in time.
    HandoverSlow {
        /// The job.
        job: u32,
    },
    /// The reading mirrored from `from` on.
    ReversedSensor {
        /// First reversed sample.
        from: u32,
    },
    /// The drive reversed from `from` on.
    ReversedDrive {
        /// First reversed sample.
        from: u32,
    },
    /// A mass or friction step of the twin's plant.
    PlantStep(ServoFault),
}

/// The kinds `sledid pil --inject` takes.
const KINDS: &str = "lost, stall, handover-miss, handover-slow, flip, drive-flip, mass, friction";

impl std::str::FromStr for PilFault {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let spec = Spec::parse(text)?;
        let keys: &[&str] = match spec.kind {
            "lost" => &["at", "n"],
            "stall" => &["at"],
            "handover-miss" | "handover-slow" => &["job"],
            "flip" | "drive-flip" => &["from"],
            "mass" | "friction" => return plant_step(text),
            other => {
                return Err(spec.error(format_args!("unknown fault `{other}` ({KINDS})")));
            }
        };
        spec.only_keys(keys)?;
        Ok(match spec.kind {
            "lost" => lost(&spec)?,
            "stall" => Self::Stall {
                at: spec.value("at")?,
            },
            "handover-miss" => Self::HandoverMiss {
                job: spec.value("job")?,
            },
            "handover-slow" => Self::HandoverSlow {
                job: spec.value("job")?,
            },
            "flip" => Self::ReversedSensor {
                from: spec.value("from")?,
            },
            _ => Self::ReversedDrive {
                from: spec.value("from")?,
            },
        })
    }
}

/// `lost:at=K[,n=N]`: N ≥ 1, the last sample within `u32`.
fn lost(spec: &Spec<'_>) -> Result<PilFault, String> {
    let at: u32 = spec.value("at")?;
    let n: u32 = spec.value_or("n", 1)?;
    if n == 0 || at.checked_add(n - 1).is_none() {
        return Err(spec.error(format_args!("n must be ≥ 1 and at + n − 1 ≤ {}", u32::MAX)));
    }
    Ok(PilFault::Lost { at, n })
}

/// `mass:…` and `friction:…`, parsed as `sledid seek --inject` parses them.
fn plant_step(text: &str) -> Result<PilFault, String> {
    let step: ServoFault = text.parse()?;
    Ok(PilFault::PlantStep(step))
}

/// The earlier of `a` and `b`.
fn earliest(a: Option<u32>, b: u32) -> Option<u32> {
    Some(a.map_or(b, |a| a.min(b)))
}

impl Faults {
    /// The tests' plan on the default twin (power-on calibration takes frames 0–3,193, its
    /// experiment 0–118; the first seek starts at 3,194 and arrives by 3,202; the seek mode posts
    /// a redesign on each arrival): the hand-overs of jobs 0 and 1 miss (due while settling after
    /// the first and second seeks), jobs 2 and 5 come back slow but in time; three overruns, the
    /// first while the first seek moves; four lost positions — one during calibration's
    /// experiment, one while the first seek moves, two in a row while holding.
    pub fn plan() -> Self {
        Self {
            lost: vec![60, 3_196, 4_000, 4_001],
            stalls: vec![3_197, 5_000, 9_000],
            slow_jobs: vec![2, 5],
            missed_jobs: vec![0, 1],
            ..Self::default()
        }
    }

    /// The plan of the PIL's other sleds ([`super::plants`], sled `i` ≥ 1), at samples valid on
    /// any of them (power-on calibration takes about 3,200–3,400 frames: its experiment and the
    /// fit's latency): the hand-over of job i mod 3 misses, job 3 comes back slow but in time,
    /// one overrun at 4,000 + 100·i (made once nothing is in flight), one lost position at
    /// 3,500 + 37·i; every third sled's sensor reverses from sample 6,000 (it must stop).
    pub fn generic(i: usize) -> Self {
        let n = u32::try_from(i % 1_000).unwrap_or(0);
        Self {
            lost: vec![3_500 + 37 * n],
            stalls: vec![4_000 + 100 * n],
            slow_jobs: vec![3],
            missed_jobs: vec![n % 3],
            reversed_sensor_from: i.is_multiple_of(3).then_some(6_000),
            ..Self::default()
        }
    }

    /// The faults of `sledid pil --inject` specs (nothing else: they replace the plan). Two
    /// reversals of the same kind keep the earlier.
    ///
    /// # Errors
    /// The first bad spec, named; a job both slow and missed.
    pub fn from_specs<S: AsRef<str>>(specs: &[S]) -> Result<Self, String> {
        let mut faults = Self::default();
        for spec in specs {
            faults.add(spec.as_ref().parse()?);
        }
        faults.lost.sort_unstable();
        faults.lost.dedup();
        faults.stalls.sort_unstable();
        if let Some(job) = faults
            .slow_jobs
            .iter()
            .find(|j| faults.missed_jobs.contains(j))
        {
            return Err(format!(
                "--inject: job {job} is both handover-slow and handover-miss"
            ));
        }
        Ok(faults)
    }

    /// These faults as `--inject` specs ([`Self::from_specs`] gives them back): consecutive lost
    /// positions as one `lost:at=K,n=N`.
    pub fn to_specs(&self) -> Vec<String> {
        let mut specs: Vec<String> = lost_runs(&self.lost)
            .into_iter()
            .map(|(at, n)| match n {
                1 => format!("lost:at={at}"),
                n => format!("lost:at={at},n={n}"),
            })
            .collect();
        specs.extend(self.stalls.iter().map(|k| format!("stall:at={k}")));
        specs.extend(
            self.missed_jobs
                .iter()
                .map(|j| format!("handover-miss:job={j}")),
        );
        specs.extend(
            self.slow_jobs
                .iter()
                .map(|j| format!("handover-slow:job={j}")),
        );
        specs.extend(self.reversed_sensor_from.map(|k| format!("flip:from={k}")));
        specs.extend(
            self.reversed_drive_from
                .map(|k| format!("drive-flip:from={k}")),
        );
        specs.extend(self.plant_steps.iter().filter_map(|f| match *f {
            ServoFault::Mass { at, factor } => Some(format!("mass:at={at},factor={factor}")),
            ServoFault::Friction { at, factor } => {
                Some(format!("friction:at={at},factor={factor}"))
            }
            _ => None,
        }));
        specs
    }

    fn add(&mut self, fault: PilFault) {
        match fault {
            PilFault::Lost { at, n } => self.lost.extend((0..n).map(|i| at + i)),
            PilFault::Stall { at } => self.stalls.push(at),
            PilFault::HandoverMiss { job } => self.missed_jobs.push(job),
            PilFault::HandoverSlow { job } => self.slow_jobs.push(job),
            PilFault::ReversedSensor { from } => {
                self.reversed_sensor_from = earliest(self.reversed_sensor_from, from);
            }
            PilFault::ReversedDrive { from } => {
                self.reversed_drive_from = earliest(self.reversed_drive_from, from);
            }
            PilFault::PlantStep(step) => self.plant_steps.push(step),
        }
    }

    /// The drive's sign at sample `k`: −1 once the drive is reversed.
    pub fn drive_sign(&self, k: u32) -> f64 {
        if self.reversed_drive_from.is_some_and(|from| k >= from) {
            -1.0
        } else {
            1.0
        }
    }

    /// What the safety layer must do about these faults in a run of `samples` samples whose servo
    /// bridges `bridged` consecutive lost positions (K of the safety layer); `first_move(k)` is
    /// the first sample at or after k at which the servo drives the sled, if the run has one.
    ///
    /// More than K lost positions in a row must stop the servo; so must a reversed sensor or
    /// drive that a move follows (the sled runs away once it is driven; one reversed while the
    /// sled holds after the last move may go unnoticed, and may stop it); a mass or friction
    /// step may (an unstable loop runs away); nothing else may. Faults past the end do not count.
    pub fn stop_rule(
        &self,
        samples: u32,
        bridged: u16,
        first_move: impl Fn(u32) -> Option<u32>,
    ) -> StopRule {
        let reversals = [self.reversed_sensor_from, self.reversed_drive_from]
            .into_iter()
            .flatten()
            .filter(|&k| k < samples);
        let (exposed, unexposed): (Vec<u32>, Vec<u32>) =
            reversals.partition(|&k| first_move(k).is_some());
        let required = exposed
            .into_iter()
            .chain(lost_runs_longer_than(&self.lost, bridged))
            .filter(|&k| k < samples)
            .min();
        let plant_steps = self.plant_steps.iter().filter_map(|f| match *f {
            ServoFault::Mass { at, .. } | ServoFault::Friction { at, .. } => u32::try_from(at).ok(),
            _ => None,
        });
        let allowed = unexposed
            .into_iter()
            .chain(plant_steps.filter(|&k| k < samples))
            .min();
        match (required, allowed) {
            (Some(r), a) => StopRule::Required {
                from: a.map_or(r, |a| a.min(r)),
            },
            (None, Some(a)) => StopRule::Allowed { from: a },
            (None, None) => StopRule::Never,
        }
    }
}

/// The runs of consecutive samples in ascending `lost`: (first, length).
fn lost_runs(lost: &[u32]) -> Vec<(u32, u32)> {
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for &k in lost {
        match runs.last_mut() {
            Some((first, n)) if first.checked_add(*n) == Some(k) => *n += 1,
            _ => runs.push((k, 1)),
        }
    }
    runs
}

/// The first samples of the runs of consecutive samples in ascending `lost` longer than `bridged`.
fn lost_runs_longer_than(lost: &[u32], bridged: u16) -> Vec<u32> {
    lost_runs(lost)
        .into_iter()
        .filter(|&(_, n)| n > u32::from(bridged))
        .map(|(first, _)| first)
        .collect()
}

/// What the safety layer must do about a run's faults ([`Faults::stop_rule`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopRule {
    /// No stop: every seek settles.
    Never,
    /// Either every seek settles or the servo stops, not before sample `from`.
    Allowed {
        /// The first fault that may stop it.
        from: u32,
    },
    /// The servo stops, not before sample `from`.
    Required {
        /// The first fault that may stop it.
        from: u32,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(spec: &str) -> Result<PilFault, String> {
        spec.parse()
    }

    /// Each kind parses to its fault. Trips on a kind mapped to the wrong fault or a key read
    /// from the wrong name.
    #[test]
    fn each_kind_parses() {
        assert_eq!(parse("lost:at=7"), Ok(PilFault::Lost { at: 7, n: 1 }));
        assert_eq!(parse("lost:at=7,n=20"), Ok(PilFault::Lost { at: 7, n: 20 }));
        assert_eq!(parse("stall:at=900"), Ok(PilFault::Stall { at: 900 }));
        assert_eq!(
            parse("handover-miss:job=1"),
            Ok(PilFault::HandoverMiss { job: 1 })
        );
        assert_eq!(
            parse("handover-slow:job=2"),
            Ok(PilFault::HandoverSlow { job: 2 })
        );
        assert_eq!(
            parse("flip:from=1500"),
            Ok(PilFault::ReversedSensor { from: 1500 })
        );
        assert_eq!(
            parse("drive-flip:from=3"),
            Ok(PilFault::ReversedDrive { from: 3 })
        );
        assert_eq!(
            parse("mass:at=10,factor=3"),
            Ok(PilFault::PlantStep(ServoFault::Mass {
                at: 10,
                factor: 3.0
            }))
        );
        assert_eq!(
            parse("friction:at=10,factor=0"),
            Ok(PilFault::PlantStep(ServoFault::Friction {
                at: 10,
                factor: 0.0
            }))
        );
    }

    /// Every bad spec is refused with a message naming it. Trips on a parser that accepts an
    /// unknown kind or key, a missing or malformed value, an empty burst or a bad factor.
    #[test]
    fn bad_specs_are_refused_naming_them() {
        for (spec, why) in [
            ("bump:at=3", "unknown fault `bump`"),
            ("lost", "missing `at=`"),
            ("lost:at=-1", "`at=-1` is not a valid value"),
            ("lost:at=5,n=0", "n must be ≥ 1"),
            ("lost:at=4294967295,n=2", "n must be ≥ 1"),
            ("lost:at=5,len=3", "unknown key `len` for `lost`"),
            ("stall:from=3", "unknown key `from` for `stall`"),
            ("stall:at", "`at` is not key=value"),
            ("handover-miss:job=x", "`job=x` is not a valid value"),
            ("handover-slow:at=3", "unknown key `at`"),
            ("flip:at=3", "unknown key `at` for `flip`"),
            ("drive-flip:from=", "`from=` is not a valid value"),
            ("mass:at=1,factor=-1", "factor must be finite and > 0"),
            ("friction:at=1,factor=nan", "factor must be finite"),
            ("mass:at=1", "missing `factor=`"),
        ] {
            let e = parse(spec).expect_err(spec);
            assert!(e.contains(&format!("`{spec}`")), "{spec}: {e}");
            assert!(e.contains(why), "{spec}: {e}");
        }
    }

    /// Specs add up (sorted lost positions and stalls, the earlier reversal), replace the plan,
    /// and a job both slow and missed is refused. Trips on specs merged into the plan or a
    /// stall list left unsorted (the lockstep consumes stalls in order).
    #[test]
    fn specs_build_the_faults() {
        let f = Faults::from_specs(&[
            "stall:at=90",
            "lost:at=10,n=3",
            "stall:at=20",
            "lost:at=11",
            "flip:from=50",
            "flip:from=40",
            "drive-flip:from=70",
            "mass:at=5,factor=2",
        ])
        .expect("parses");
        assert_eq!(f.lost, vec![10, 11, 12]);
        assert_eq!(f.stalls, vec![20, 90]);
        assert_eq!(f.reversed_sensor_from, Some(40));
        assert_eq!(f.reversed_drive_from, Some(70));
        assert_eq!((f.drive_sign(69), f.drive_sign(70)), (1.0, -1.0));
        assert_eq!(f.plant_steps.len(), 1);
        assert!(f.missed_jobs.is_empty() && f.slow_jobs.is_empty());
        assert_eq!(Faults::from_specs::<&str>(&[]), Ok(Faults::default()));
        let e = Faults::from_specs(&["handover-miss:job=2", "handover-slow:job=2"]);
        assert!(e.is_err_and(|e| e.contains("job 2")));
        let e = Faults::from_specs(&["stall:at=1", "lost:at=x"]).expect_err("bad");
        assert!(e.contains("`lost:at=x`"), "{e}");
    }

    /// The plan and injected faults survive the round trip through specs. Trips on a spec
    /// written in a form the parser reads differently.
    #[test]
    fn specs_round_trip() {
        let injected = Faults::from_specs(&[
            "lost:at=10,n=3",
            "lost:at=20",
            "flip:from=5",
            "drive-flip:from=6",
            "friction:at=7,factor=0.5",
            "mass:at=8,factor=3",
        ])
        .expect("parses");
        for faults in [Faults::plan(), injected] {
            assert_eq!(Faults::from_specs(&faults.to_specs()), Ok(faults.clone()));
        }
        assert_eq!(
            Faults::plan().to_specs()[..3],
            ["lost:at=60", "lost:at=3196", "lost:at=4000,n=2"]
        );
    }

    /// The stop rule: the plan never stops the servo, reversals a move follows and lost runs
    /// longer than K must, plant steps and reversals no move follows may, faults past the end do
    /// not count. Trips on a rule that counts a bridged lost run, a reversal after the run, or
    /// demands a stop for a reversal the sled is never driven after.
    #[test]
    fn stop_rule_follows_the_faults() {
        let moving = |k: u32| Some(k);
        let rule = |specs: &[&str]| {
            Faults::from_specs(specs)
                .expect("parses")
                .stop_rule(1_000, 16, moving)
        };
        assert_eq!(
            Faults::plan().stop_rule(20_000, 16, moving),
            StopRule::Never
        );
        let resting = Faults::from_specs(&["flip:from=500"]).expect("parses");
        assert_eq!(
            resting.stop_rule(1_000, 16, |_| None),
            StopRule::Allowed { from: 500 }
        );
        assert_eq!(rule(&["lost:at=10,n=16"]), StopRule::Never);
        assert_eq!(rule(&["lost:at=10,n=17"]), StopRule::Required { from: 10 });
        assert_eq!(rule(&["flip:from=500"]), StopRule::Required { from: 500 });
        assert_eq!(rule(&["flip:from=1000"]), StopRule::Never);
        assert_eq!(
            rule(&["drive-flip:from=600", "mass:at=300,factor=3"]),
            StopRule::Required { from: 300 }
        );
        assert_eq!(
            rule(&["friction:at=300,factor=2"]),
            StopRule::Allowed { from: 300 }
        );
    }
}
