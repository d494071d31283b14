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

fn pairs<'a>(spec: &str, rest: &'a str) -> Result<Vec<(&'a str, &'a str)>, String> {
    rest.split(',')
        .filter(|p| !p.is_empty())
        .map(|p| {
            p.split_once('=')
                .ok_or_else(|| format!("--inject `{spec}`: `{p}` is not key=value"))
        })
        .collect()
}

fn value<T: std::str::FromStr>(p: &[(&str, &str)], name: &str, spec: &str) -> Result<T, String> {
    let (_, v) = p
        .iter()
        .find(|(k, _)| *k == name)
        .ok_or_else(|| format!("--inject `{spec}`: missing `{name}=`"))?;
    v.parse()
        .map_err(|_| format!("--inject `{spec}`: `{name}={v}` is not a valid value"))
}

impl std::str::FromStr for ServoFault {
    type Err = String;
    fn from_str(spec: &str) -> Result<Self, String> {
        let (kind, rest) = spec.split_once(':').unwrap_or((spec, ""));
        let p = pairs(spec, rest)?;
        let known: &[&str] = match kind {
            "drive-flip" => &["from"],
            "mass" | "friction" => &["at", "factor"],
            _ => {
                return spec
                    .parse::<Fault>()
                    .map(Self::Sensor)
                    .map_err(|e| format!("{e}; in closed loop also drive-flip, mass, friction"));
            }
        };
        if let Some((k, _)) = p.iter().find(|(k, _)| !known.contains(k)) {
            return Err(format!(
                "--inject `{spec}`: unknown key `{k}` for `{kind}` (keys: {})",
                known.join(", ")
            ));
        }
        match kind {
            "drive-flip" => Ok(Self::DriveFlip {
                from: value(&p, "from", spec)?,
            }),
            _ => {
                let at = value(&p, "at", spec)?;
                let factor: f64 = value(&p, "factor", spec)?;
                let ok =
                    factor.is_finite() && (factor > 0.0 || (kind == "friction" && factor == 0.0));
                if !ok {
                    return Err(format!(
                        "--inject `{spec}`: factor must be finite and > 0 (≥ 0 for friction)"
                    ));
                }
                Ok(if kind == "mass" {
                    Self::Mass { at, factor }
                } else {
                    Self::Friction { at, factor }
                })
            }
        }
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
        let k = twin.samples().len() - start;
        for f in faults {
            match *f {
                ServoFault::Mass { at, factor } if at == k => {
                    twin.plant_mut().scale_mass(factor);
                }
                ServoFault::Friction { at, factor } if at == k => {
                    twin.plant_mut().scale_friction(factor);
                }
                _ => {}
            }
        }
        if twin.step(&mut faulty).is_none() {
            break;
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
