//! Fault injection for replays: what a servo loop's sensor and data do to it in the field.
//!
//! `KIND:key=value,…` on the command line (`sledid replay … --inject spike:at=900,mag=40`), applied
//! to each sample in engineering units before the boundary. Sample indices count from 0; magnitudes
//! are in the y column's unit.
//!
//! | kind | keys | what happens to the sample stream |
//! |---|---|---|
//! | `spike` | `at`, `mag`, `every` (0 = once) | y += mag at `at` (and every `every` samples after) |
//! | `stuck` | `from`, `len` | y frozen at its value at `from` for `len` samples |
//! | `missing` | `from`, `len` | the readings are lost (dropped samples / a gap) |
//! | `nan` | `at` | y = NaN at `at` |
//! | `flip` | `from` | y's sign reversed from `from` on (a reversed sensor) |

pub mod spec;

use crate::recording::Sample;
use spec::Spec;

/// One fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// Sensor spike(s).
    Spike {
        /// First sample.
        at: usize,
        /// Added to y.
        mag: f64,
        /// Period (0: once).
        every: usize,
    },
    /// Stuck sensor.
    Stuck {
        /// First stuck sample.
        from: usize,
        /// Length.
        len: usize,
    },
    /// Lost readings.
    Missing {
        /// First lost sample.
        from: usize,
        /// Length.
        len: usize,
    },
    /// A non-finite reading.
    NotFinite {
        /// The sample.
        at: usize,
    },
    /// Reversed sensor sign.
    Flip {
        /// First reversed sample.
        from: usize,
    },
}

/// What reaches the boundary for one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reading {
    /// A (possibly corrupted) sample.
    Present(Sample),
    /// No reading.
    Missing,
}

impl std::str::FromStr for Fault {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        let spec = Spec::parse(text)?;
        let known: &[&str] = match spec.kind {
            "spike" => &["at", "mag", "every"],
            "stuck" | "missing" => &["from", "len"],
            "nan" => &["at"],
            "flip" => &["from"],
            other => {
                return Err(spec.error(format_args!(
                    "unknown fault `{other}` (spike, stuck, missing, nan, flip)"
                )));
            }
        };
        spec.only_keys(known)?;
        let fault = match spec.kind {
            "spike" => Fault::Spike {
                at: spec.value("at")?,
                mag: spec.value("mag")?,
                every: spec.value_or("every", 0)?,
            },
            "stuck" => Fault::Stuck {
                from: spec.value("from")?,
                len: spec.value("len")?,
            },
            "missing" => Fault::Missing {
                from: spec.value("from")?,
                len: spec.value("len")?,
            },
            "nan" => Fault::NotFinite {
                at: spec.value("at")?,
            },
            _ => Fault::Flip {
                from: spec.value("from")?,
            },
        };
        if let Fault::Spike { mag, .. } = fault
            && !mag.is_finite()
        {
            return Err(spec.error("mag must be finite"));
        }
        Ok(fault)
    }
}

/// Applies faults to a stream, sample by sample (keeps what a stuck sensor holds).
#[derive(Clone, Debug, Default)]
pub struct Injector {
    faults: Vec<Fault>,
    held_y: Option<f64>,
}

impl Injector {
    /// An injector for these faults.
    pub fn new(faults: Vec<Fault>) -> Self {
        Self {
            faults,
            held_y: None,
        }
    }

    /// True when no fault is configured.
    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    /// The reading at sample `k` given the true sample.
    pub fn apply(&mut self, k: usize, mut s: Sample) -> Reading {
        let mut missing = false;
        for f in &self.faults {
            match *f {
                Fault::Spike { at, mag, every } => {
                    let hit = k == at || (every > 0 && k > at && (k - at).is_multiple_of(every));
                    if hit {
                        s.y += mag;
                    }
                }
                Fault::Stuck { from, len } => {
                    if k == from {
                        self.held_y = Some(s.y);
                    }
                    if (from..from + len).contains(&k) {
                        s.y = self.held_y.unwrap_or(s.y);
                    }
                }
                Fault::Missing { from, len } => missing |= (from..from + len).contains(&k),
                Fault::NotFinite { at } => {
                    if k == at {
                        s.y = f64::NAN;
                    }
                }
                Fault::Flip { from } => {
                    if k >= from {
                        s.y = -s.y;
                        s.r = s.r.map(|r| -r);
                    }
                }
            }
        }
        if missing {
            Reading::Missing
        } else {
            Reading::Present(s)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        assert_eq!(
            "spike:at=3,mag=2.5".parse(),
            Ok(Fault::Spike {
                at: 3,
                mag: 2.5,
                every: 0
            })
        );
        assert_eq!(
            "stuck:from=1,len=4".parse(),
            Ok(Fault::Stuck { from: 1, len: 4 })
        );
        assert_eq!("flip:from=9".parse(), Ok(Fault::Flip { from: 9 }));
        assert!(
            "spike:at=3"
                .parse::<Fault>()
                .unwrap_err()
                .contains("missing `mag=`")
        );
        assert!(
            "spike:at=3,mag=1,bogus=2"
                .parse::<Fault>()
                .unwrap_err()
                .contains("unknown key `bogus`")
        );
        assert!(
            "smoke:at=1"
                .parse::<Fault>()
                .unwrap_err()
                .contains("unknown fault")
        );
        assert!(
            "nan:at=x"
                .parse::<Fault>()
                .unwrap_err()
                .contains("not a valid value")
        );
    }

    #[test]
    fn applies_in_order() {
        let s = |y: f64| Sample {
            t_s: 0.0,
            u: 1.0,
            y,
            r: Some(y),
        };
        let mut inj = Injector::new(vec![
            Fault::Stuck { from: 1, len: 2 },
            Fault::Missing { from: 4, len: 1 },
            Fault::NotFinite { at: 5 },
        ]);
        let ys: Vec<Reading> = (0..6).map(|k| inj.apply(k, s(k as f64))).collect();
        assert_eq!(ys[1], Reading::Present(s(1.0)));
        assert_eq!(ys[2], Reading::Present(Sample { y: 1.0, ..s(2.0) }));
        assert_eq!(ys[3], Reading::Present(s(3.0)));
        assert_eq!(ys[4], Reading::Missing);
        assert!(matches!(ys[5], Reading::Present(x) if x.y.is_nan()));
    }
}
