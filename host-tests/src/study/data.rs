//! The study's data: signals in the paper's units, centred and cut into the segments the models are
//! fitted to (see the [module documentation](super) for the conventions). [`Segment`],
//! [`Centring`] and [`Dataset`] are plain data in [`super::results`].

use super::results::{Centring, Dataset, Segment};
use crate::recording::Recording;
use crate::reference::decimate::{DecimatorF64, design_taps};

/// The name of the study's y unit when none is given: `y / y_unit` is in units of `y_unit` × the
/// y column's unit, e.g. `0.001 × y-column unit`, `1.6e-6 × y-column unit`. It is the sensor's
/// quantum only if `y_unit` is that quantum, which the study cannot know, so it never says
/// "quanta" by itself.
pub fn y_unit_label(y_unit: f64) -> String {
    if y_unit == 1.0 {
        "y-column unit".to_owned()
    } else if (1e-3..1e4).contains(&y_unit.abs()) {
        format!("{y_unit} × y-column unit")
    } else {
        format!("{y_unit:e} × y-column unit")
    }
}

/// A recording in the study's units: y and r in [`Signals::y_unit_name`] (`y / y_unit`; quanta
/// when `y_unit` is the sensor quantum, as on the twin), u in volts. Fields named `_q` hold y-unit
/// values.
#[derive(Clone, Debug, PartialEq)]
pub struct Signals {
    /// Where it came from.
    pub source: String,
    /// Sampling period, s.
    pub ts_s: f64,
    /// The unit of y and r, as tables and plots name it (`quanta`, `mV`, [`y_unit_label`]).
    pub y_unit_name: String,
    /// Input, V.
    pub u_v: Vec<f64>,
    /// Output, y unit.
    pub y_q: Vec<f64>,
    /// Reference, y unit, if mapped.
    pub r_q: Option<Vec<f64>>,
}

impl Signals {
    /// From a recording read with unit scales: `y / y_unit`, `u · u_scale`, `r / y_unit`; the y
    /// unit named by [`y_unit_label`].
    pub fn from_recording(rec: &Recording, y_unit: f64, u_scale: f64) -> Self {
        let s = &rec.samples;
        let r_q = s
            .iter()
            .map(|x| x.r.map(|r| r / y_unit))
            .collect::<Option<Vec<f64>>>()
            .filter(|r| !r.is_empty());
        Self {
            source: rec.meta.path.display().to_string(),
            ts_s: rec.meta.ts_s,
            y_unit_name: y_unit_label(y_unit),
            u_v: s.iter().map(|x| x.u * u_scale).collect(),
            y_q: s.iter().map(|x| x.y / y_unit).collect(),
            r_q,
        }
    }

    /// Half-band low-pass and every second sample, at `2·Ts`.
    pub fn decimated_by_2(&self) -> Self {
        let run = |x: &[f64]| DecimatorF64::run(design_taps(), x);
        Self {
            source: format!("{} (÷2)", self.source),
            ts_s: 2.0 * self.ts_s,
            y_unit_name: self.y_unit_name.clone(),
            u_v: run(&self.u_v),
            y_q: run(&self.y_q),
            r_q: self.r_q.as_deref().map(run),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.y_q.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.y_q.is_empty()
    }

    /// The centring value of `seg` (see [`Centring`]) and the rule that was applied.
    pub fn centre(&self, seg: Segment, how: Centring) -> (f64, Centring) {
        let last = seg.end - 1;
        let how = match (how, &self.r_q) {
            (Centring::Auto, Some(_)) => Centring::FinalReference,
            (Centring::Auto | Centring::FinalReference | Centring::MeanReference, None) => {
                Centring::LastOutput
            }
            (h, _) => h,
        };
        let value = match (how, &self.r_q) {
            (Centring::FinalReference, Some(r)) => r[last],
            (Centring::MeanReference, Some(r)) => {
                r[seg.start..seg.end].iter().sum::<f64>() / seg.len() as f64
            }
            (Centring::None, _) => 0.0,
            _ => self.y_q[last],
        };
        (value, how)
    }

    /// The segment `seg`, shifted by `centre_q`.
    pub fn dataset(&self, seg: Segment, centre_q: f64) -> Dataset {
        let r = seg.start..seg.end;
        Dataset {
            ts_s: self.ts_s,
            y_unit_name: self.y_unit_name.clone(),
            segment: seg,
            centre_q,
            u: self.u_v[r.clone()].to_vec(),
            y: self.y_q[r.clone()].iter().map(|y| y - centre_q).collect(),
            r: self
                .r_q
                .as_ref()
                .map(|x| x[r].iter().map(|v| v - centre_q).collect()),
        }
    }
}
