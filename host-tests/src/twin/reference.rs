//! The seek reference: a sequence of target steps, each low-pass filtered (as in the paper,
//! "a low-pass filtered step") and followed by a dwell at the constant reference.
//!
//! # Filter
//! Each target step is passed through a Hann-window FIR low-pass of length `ref_rise_s`
//! (`L`); sampled, its output is the cycloidal S-curve
//! ```text
//! r(t) = r₀ + (target − r₀) · S((t − t₀)/L),   S(p) = p − sin(2πp)/(2π)  for 0 ≤ p < 1,  S = 1 after
//! ```
//! Velocity is a Hann bump (zero at both ends, peak `2·step/L`), acceleration is continuous.
//! A finite-length (FIR) filter is used rather than an IIR low-pass because its step response
//! reaches the target *exactly* after `L`: during the dwell the reference is constant and the
//! controller error `r − y` is an integer number of quanta. An exponential tail would keep
//! feeding the integrator a fraction of a quantum long after the seek and decide, by chance,
//! whether the sled freezes or hunts.
//!
//! With [`ReferenceProfile::Step`] there is no filter: `r = target` from the seek's first sample
//! on (a seek command, for a controller that plans its own trajectory), i.e. the S-curve of a
//! one-sample rise.
//!
//! # Seek timing
//! A seek starts at the sample where the target changes (`t₀`, the first sample with `p > 0`).
//! The reference has *arrived* at the first sample with `p ≥ 1`; the seek then dwells for
//! `dwell_s` and the next seek starts at the following sample.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::params::{ReferenceParams, ReferenceProfile, SeekDistribution};

/// One seek of the schedule, with the sample indices at which its phases began.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Seek {
    /// Target position, tracks (quanta) from the start position.
    pub target_counts: i64,
    /// Index of the first sample of this seek (the target step).
    pub start_index: usize,
    /// Index of the sample at which the filtered reference arrived at the target.
    pub arrival_index: Option<usize>,
    /// One past the index of the last sample of this seek (set when the seek has ended).
    pub end_index: Option<usize>,
}

/// Draws the seek targets: the given ones, or `seek_count` random steps from `rng`.
///
/// Each random step has a length drawn from `seek_min_tracks..=seek_max_tracks` by
/// `seek_distribution` (uniformly over the whole lengths by default, or log-uniformly) and a
/// random direction; a step that would leave ±`travel_tracks` is taken the other way.
pub fn draw_targets(params: &ReferenceParams, rng: &mut ChaCha8Rng) -> Vec<i64> {
    if let Some(targets) = &params.targets_tracks {
        return targets.clone();
    }
    let travel = i64::from(params.travel_tracks);
    let mut position: i64 = 0;
    let (min, max) = (params.seek_min_tracks, params.seek_max_tracks);
    (0..params.seek_count)
        .map(|_| {
            let length = i64::from(match params.seek_distribution {
                SeekDistribution::Uniform => rng.gen_range(min..=max),
                SeekDistribution::LogUniform => log_uniform_length(rng, min, max),
            });
            let step = if rng.gen_bool(0.5) { length } else { -length };
            position = if (position + step).abs() <= travel {
                position + step
            } else {
                position - step
            };
            position
        })
        .collect()
}

/// A whole length log-uniform in `min..=max` (`1 ≤ min ≤ max`):
/// `round(exp(ln min + w·(ln max − ln min)))`, `w` uniform in [0, 1), kept within the range.
fn log_uniform_length(rng: &mut ChaCha8Rng, min: u32, max: u32) -> u32 {
    let (lo, hi) = (f64::from(min).ln(), f64::from(max).ln());
    let w: f64 = rng.r#gen();
    ((lo + w * (hi - lo)).exp().round() as u32).clamp(min, max)
}

/// Generates the filtered reference sample by sample and keeps the seek bookkeeping.
#[derive(Clone, Debug)]
pub struct SeekReference {
    /// The targets to visit, in order.
    targets_counts: Vec<i64>,
    /// Samples of the S-curve (FIR length), at least 1.
    rise_samples: usize,
    /// Samples to hold after arrival, at least 1.
    dwell_samples: usize,
    /// Where the seek in progress started from, counts.
    origin_counts: i64,
    /// The seeks begun so far.
    seeks: Vec<Seek>,
}

impl SeekReference {
    /// A reference starting at rest at position 0 that visits `targets_counts` in order.
    pub fn new(params: &ReferenceParams, ts_s: f64, targets_counts: Vec<i64>) -> Self {
        Self {
            targets_counts,
            rise_samples: match params.profile {
                ReferenceProfile::SCurve => (params.ref_rise_s / ts_s).round().max(1.0) as usize,
                // A one-sample rise: the target from the seek's first sample on.
                ReferenceProfile::Step => 1,
            },
            dwell_samples: (params.dwell_s / ts_s).round().max(1.0) as usize,
            origin_counts: 0,
            seeks: Vec::new(),
        }
    }

    /// The seeks begun so far, with their phase indices.
    pub fn seeks(&self) -> &[Seek] {
        &self.seeks
    }

    /// The target of the seek in progress or, between seeks, of the next one, counts (`None`
    /// when all seeks have ended).
    pub fn current_target_counts(&self) -> Option<i64> {
        match self.seeks.last() {
            Some(seek) if seek.end_index.is_none() => Some(seek.target_counts),
            _ => self.targets_counts.get(self.seeks.len()).copied(),
        }
    }

    /// Whether every seek has ended.
    pub fn is_finished(&self) -> bool {
        self.current_target_counts().is_none()
    }

    /// The reference for sample `index` (the samples must be asked for in order), counts;
    /// `None` when every seek has ended.
    pub fn next_counts(&mut self, index: usize) -> Option<f64> {
        let target_counts = self.current_target_counts()?;
        if self
            .seeks
            .last()
            .is_none_or(|seek| seek.end_index.is_some())
        {
            if let Some(previous) = self.seeks.last() {
                self.origin_counts = previous.target_counts;
            }
            self.seeks.push(Seek {
                target_counts,
                start_index: index,
                arrival_index: None,
                end_index: None,
            });
        }
        let origin_counts = self.origin_counts;
        let rise_samples = self.rise_samples;
        let dwell_samples = self.dwell_samples;
        let seek = self.seeks.last_mut()?;
        let elapsed = index - seek.start_index + 1;
        let reference_counts = if elapsed >= rise_samples {
            if seek.arrival_index.is_none() {
                seek.arrival_index = Some(index);
            }
            target_counts as f64
        } else {
            let p = elapsed as f64 / rise_samples as f64;
            let s = p - (2.0 * std::f64::consts::PI * p).sin() / (2.0 * std::f64::consts::PI);
            origin_counts as f64 + (target_counts - origin_counts) as f64 * s
        };
        if let Some(arrival) = seek.arrival_index
            && index + 1 - arrival >= dwell_samples
        {
            seek.end_index = Some(index + 1);
        }
        Some(reference_counts)
    }
}
