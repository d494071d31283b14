//! Faults a user injects into a closed-loop run (`sledid seek --inject`): the sensor faults of
//! the replay ([`crate::faults::Fault`]: `spike`, `stuck`, `missing`, `nan`, `flip`) plus a reversed
//! drive and plant steps, in the same `KIND:key=value,…` syntax. Sample indices count from the
//! first sample of the seek schedule (after power-on calibration); magnitudes are in quanta.
//!
//! | kind | keys | what happens |
//! |---|---|---|
//! | `spike`, `stuck`, `missing`, `nan`, `flip` | as `sledid replay --inject` | the reading the servo sees |
//! | `drive-flip` | `from` | the drive's polarity reversed from `from` on |
//! | `mass` | `at`, `factor` | the moving mass × `factor` from `at` on |
//! | `friction` | `at`, `factor` | Coulomb and static friction × `factor` from `at` on |

use crate::faults::spec::Spec;
use crate::faults::{Fault, Injector, Reading};
use crate::recording::Sample;
use crate::twin::{SledController, Twin};

/// One injected fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ServoFault {
    /// What the sensor reads.
    Sensor(Fault),
    /// The drive's polarity reversed from `from` on.
    DriveFlip {
        /// First reversed sample.
        from: usize,
    },
    /// The mass multiplied at `at`.
    Mass {
        /// The sample.
        at: usize,
        /// The factor (> 0).
        factor: f64,
    },
    /// Coulomb and static friction multiplied at `at`.
    Friction {
        /// The sample.
        at: usize,
        /// The factor (≥ 0).
        factor: f64,
    },
}

impl std::str::FromStr for ServoFault {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let spec = Spec::parse(text)?;
        let known: &[&str] = match spec.kind {
            "drive-flip" => &["from"],
            "mass" | "friction" => &["at", "factor"],
            _ => {
                return text
                    .parse::<Fault>()
                    .map(Self::Sensor)
                    .map_err(|e| format!("{e}; in closed loop also drive-flip, mass, friction"));
            }
        };
        spec.only_keys(known)?;
        if spec.kind == "drive-flip" {
            return Ok(Self::DriveFlip {
                from: spec.value("from")?,
            });
        }
        let at = spec.value("at")?;
        let factor: f64 = spec.value("factor")?;
        let friction = spec.kind == "friction";
        if !(factor.is_finite() && (factor > 0.0 || (friction && factor == 0.0))) {
            return Err(spec.error("factor must be finite and > 0 (≥ 0 for friction)"));
        }
        Ok(if friction {
            Self::Friction { at, factor }
        } else {
            Self::Mass { at, factor }
        })
    }
}

/// A controller behind the injected sensor and drive faults, fed `Option<reading>` (`None`:
/// lost) through `step_reading`.
pub trait ReadingController {
    /// One sample with the reading (`None`: lost or not finite); the drive, V.
    fn step_reading(&mut self, r_counts: f64, y_counts: Option<f64>) -> f64;
}

/// `inner` seen through the sensor and drive faults of `faults`.
pub struct Faulty<'a, C> {
    inner: &'a mut C,
    injector: Injector,
    drive_flip_from: Option<usize>,
    k: usize,
}

impl<'a, C: ReadingController> Faulty<'a, C> {
    /// Wraps `inner`; sample 0 is the next one stepped.
    pub fn new(inner: &'a mut C, faults: &[ServoFault]) -> Self {
        let sensor = faults
            .iter()
            .filter_map(|f| match f {
                ServoFault::Sensor(s) => Some(*s),
                _ => None,
            })
            .collect();
        let drive_flip_from = faults
            .iter()
            .filter_map(|f| match f {
                ServoFault::DriveFlip { from } => Some(*from),
                _ => None,
            })
            .min();
        Self {
            inner,
            injector: Injector::new(sensor),
            drive_flip_from,
            k: 0,
        }
    }
}

impl<C: ReadingController> SledController for Faulty<'_, C> {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let truth = Sample {
            t_s: 0.0,
            u: 0.0,
            y: y_counts,
            r: Some(r_counts),
        };
        let (r, y) = match self.injector.apply(self.k, truth) {
            Reading::Present(s) if s.y.is_finite() => (s.r.unwrap_or(r_counts), Some(s.y)),
            _ => (r_counts, None),
        };
        let u = self.inner.step_reading(r, y);
        let flipped = self.drive_flip_from.is_some_and(|f| self.k >= f);
        self.k += 1;
        if flipped { -u } else { u }
    }
}

/// Runs `controller` on `twin` until its schedule ends, the plant faults of `faults` applied
/// before the sample they name (sample 0: the twin's next sample).
pub fn run_with_faults<C: ReadingController>(
    twin: &mut Twin,
    controller: &mut C,
    faults: &[ServoFault],
) {
    let start = twin.samples().len();
    let mut faulty = Faulty::new(controller, faults);
    loop {
        apply_plant_faults(twin, faults, twin.samples().len() - start);
        if twin.step(&mut faulty).is_none() {
            break;
        }
    }
}

/// Applies the plant faults of `faults` (mass and friction steps) that name sample `k`, before
/// the twin steps it.
pub fn apply_plant_faults(twin: &mut Twin, faults: &[ServoFault], k: usize) {
    for f in faults {
        match *f {
            ServoFault::Mass { at, factor } if at == k => twin.plant_mut().scale_mass(factor),
            ServoFault::Friction { at, factor } if at == k => {
                twin.plant_mut().scale_friction(factor);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kind parses; a bad key, a bad factor and an unknown kind name what is wrong.
    #[test]
    fn parses_and_names_bad_specs() {
        assert_eq!(
            "mass:at=100,factor=0.5".parse::<ServoFault>(),
            Ok(ServoFault::Mass {
                at: 100,
                factor: 0.5
            })
        );
        assert_eq!(
            "drive-flip:from=7".parse::<ServoFault>(),
            Ok(ServoFault::DriveFlip { from: 7 })
        );
        assert!(matches!(
            "flip:from=3".parse::<ServoFault>(),
            Ok(ServoFault::Sensor(Fault::Flip { from: 3 }))
        ));
        let e = "mass:at=1,factor=-1".parse::<ServoFault>().unwrap_err();
        assert!(e.contains("factor"), "{e}");
        let e = "friction:at=1,fact=2".parse::<ServoFault>().unwrap_err();
        assert!(e.contains("unknown key `fact`"), "{e}");
        let e = "bump:at=1".parse::<ServoFault>().unwrap_err();
        assert!(e.contains("drive-flip, mass, friction"), "{e}");
    }
}
