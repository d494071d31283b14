//! Replay of a recording through the library's per-sample `step` — the function the firmware's timer
//! interrupt calls — at the sampling rate (absolute deadlines, no drift) or as fast as possible, with
//! the float64 reference beside it. Writes `trace.csv` (every sample) and `summary.json`.
//!
//! Nothing is dropped silently: a malformed row stops the reader with an error naming its line; a
//! sample the boundary rejects (NaN, out of range) or a lost reading either stops the replay with an
//! error naming the sample ([`BadSample::Stop`], the default) or is held — written to the trace with
//! `input_rejected`, estimator frozen for that sample, conditioning re-primed ([`BadSample::Hold`],
//! what the firmware does). Faults can be injected ([`crate::faults`]).
//!
//! # Units
//! The fixed-point path's formats are absolute, the user's units arbitrary: a nonlinear model is
//! identified in normalised units ([`sledid::Normalisation`], [`Normalise`]): a first pass over
//! the file takes the conditioned signals' largest magnitudes in the user's units, the boundary
//! converts into units in which they are fixed targets, and the summary and the trace map θ, the
//! signals and the simulation RMS back ([`crate::reference::units`]). The float64 twin runs on the
//! same samples. The same recording in any unit replays the same samples, hence the same model
//! (`tests/integration/nonlinear_units.rs`).
//!
//! # Parts
//! [`replay`] picks the model and its float64 twin (`model.rs`), whose per-sample loop
//! (`run.rs`: faults, boundary, step, the twin, the summary) is paced against absolute deadlines
//! (`pacer.rs`) and writes the trace on a thread of its own (`trace.rs`).

mod model;
mod pacer;
mod reference;
mod run;
mod trace;

use crate::faults::Fault;
use crate::pacing::Stalls;
use crate::recording::{ReaderOptions, RecordingReader};
use model::{replay_linear, replay_nonlinear};
use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{Structure, parameter_count};
use sledid::ident::nonlinear::{InputRanges, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::StuckSensorDesign;
use sledid::{Normalisation, Scaling};
use std::path::Path;

/// How fast samples are fed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rate {
    /// As fast as possible.
    Max,
    /// At `factor` × real time (1 = the recording's Ts), against absolute deadlines.
    Paced(f64),
}

impl std::str::FromStr for Rate {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "max" => Ok(Self::Max),
            "realtime" => Ok(Self::Paced(1.0)),
            other => match other.parse::<f64>() {
                Ok(f) if f.is_finite() && f > 0.0 => Ok(Self::Paced(f)),
                _ => Err(format!(
                    "rate `{other}`: expected realtime, max or a positive factor"
                )),
            },
        }
    }
}

/// What to do with a sample that cannot enter the fixed-point path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BadSample {
    /// Stop with an error naming the sample.
    Stop,
    /// Hold the estimator for that sample and go on (flagged `input_rejected` in the trace).
    Hold,
}

/// The covariance's trace bound the CLI gives a nonlinear model by default: in normalised units θ
/// is of order 1, and a bound of 0.3 keeps a neuron's unidentifiable directions (w near 0, a bias
/// in saturation) from wandering — the wandering is what made the float64 twin itself ill-posed.
/// Measured over the 165 cases of `tests/integration/nonlinear_units.rs` (doc there).
pub const NONLINEAR_TRACE_LIMIT: f64 = 0.3;

/// Whether the boundary normalises the units ([`sledid::Normalisation`], module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Normalise {
    /// The user's units as given.
    Off,
    /// Ranges from a first pass over the file, the library's target octaves.
    On,
    /// `On` for the nonlinear models, `Off` for the linear ones (whose accuracy tests are
    /// measured in the user's units).
    Auto,
    /// Ranges from a first pass, brought to these targets.
    Targets {
        /// The normalised position range.
        y: f64,
        /// The normalised drive range.
        u: f64,
    },
    /// These units (a nonlinear model's linear start runs in its model's units).
    Fixed(Units),
}

/// The units a replay's fixed-point path runs in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Units {
    /// The boundary's conversion (the normalised units).
    pub scaling: Scaling,
    /// The normalised units relative to the user's.
    pub norm: Normalisation,
}

/// Everything a replay needs besides the file.
#[derive(Clone, Debug)]
pub struct ReplaySpec {
    /// Reader settings (column mapping, Ts, scales).
    pub reader: ReaderOptions,
    /// Model structure (the linear part's, for a nonlinear model: OE prediction error).
    pub structure: Structure,
    /// (na, nb); na + nb ∈ {2, 3, 4}. Ignored for a nonlinear model (its structure fixes them).
    pub order: (usize, usize),
    /// One of the paper's nonlinear models instead of a linear one. It starts from the linear OE
    /// model of its order (the paper's initialisation), taken from `nonlinear_init` or else
    /// identified first by a replay of the same file through the linear OE (prediction-error)
    /// estimator, which also gives the neurons' input ranges.
    pub nonlinear: Option<NonlinearStructure>,
    /// The linear model [f…, b…] a nonlinear model starts from (None: identified first).
    pub nonlinear_init: Option<Vec<f64>>,
    /// Conditioning of the raw samples.
    pub conditioning: Conditioning,
    /// Position unit at the boundary (m per unit), i.e. the sensor quantum or a multiple of it.
    pub y_unit: f64,
    /// Full-scale drive (u unit).
    pub u_full_scale: f64,
    /// RLS settings.
    pub rls: RlsDesign,
    /// Pacing.
    pub rate: Rate,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// Faults injected into the stream.
    pub faults: Vec<Fault>,
    /// Policy for samples that cannot enter the fixed-point path.
    pub on_bad_sample: BadSample,
    /// Stuck-sensor detection.
    pub stuck_sensor: Option<StuckSensorDesign>,
    /// Units at the boundary.
    pub normalise: Normalise,
}

impl ReplaySpec {
    /// Defaults: ARX(2,2) on velocity against drive, λ = 0.995, trace ≤ 100, as fast as possible.
    pub fn new(reader: ReaderOptions) -> Self {
        Self {
            reader,
            structure: Structure::Arx,
            order: (2, 2),
            nonlinear: None,
            nonlinear_init: None,
            conditioning: Conditioning::DifferencedOutput,
            y_unit: 1.0,
            u_full_scale: 1.0,
            rls: RlsDesign {
                lambda: 0.995,
                p0: 10.0,
                anti_windup: AntiWindup::TraceLimit { max: 100.0 },
                ..RlsDesign::default()
            },
            rate: Rate::Max,
            progress: true,
            faults: Vec::new(),
            on_bad_sample: BadSample::Stop,
            stuck_sensor: None,
            normalise: Normalise::Auto,
        }
    }
}

/// Lateness statistics of a paced replay, µs.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Deadlines {
    /// Median lateness of the sample start against its deadline.
    pub p50_us: f64,
    /// 99th percentile.
    pub p99_us: f64,
    /// Maximum.
    pub max_us: f64,
    /// Samples whose processing ended after the next sample's deadline.
    pub overruns: usize,
    /// Of those, the ones in a backlog that began with a stall of the thread while it waited (a
    /// clock gap of at least [`crate::pacing::STALL_US`] inside the spin, where no code of ours
    /// runs): the machine's lateness, not the replay's.
    pub overruns_after_stall: usize,
    /// Stalls seen while waiting for deadlines.
    pub stalls: Stalls,
    /// Time from waking to the end of the sample's work (step, reference, trace line), µs: median.
    pub work_p50_us: f64,
    /// … 99th percentile.
    pub work_p99_us: f64,
    /// … maximum (a stall during the work shows here).
    pub work_max_us: f64,
}

/// What a replay produced (also written as `summary.json`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ReplaySummary {
    /// The recording.
    pub file: String,
    /// Samples replayed (every row of the file).
    pub samples: usize,
    /// Sampling period, s.
    pub ts_s: f64,
    /// `max` or the pacing factor.
    pub rate: String,
    /// Wall-clock time of the replay, s.
    pub wall_s: f64,
    /// Model description.
    pub model: String,
    /// Final θ of the fixed-point path.
    pub theta: Vec<f64>,
    /// Final θ of the float64 reference on the same conditioned samples.
    pub theta_f64: Vec<f64>,
    /// Relative distance of the final estimates.
    pub theta_rel_err: f64,
    /// Simulation RMS of the final fixed-point model on the conditioned data.
    pub sim_rms: f64,
    /// The same for the float64 model.
    pub sim_rms_f64: f64,
    /// Count of every status flag.
    pub flags: std::collections::BTreeMap<String, usize>,
    /// The boundary's unit change [k_y, k_u]: the estimator ran on y/k_y, u/k_u; θ, the RMS and
    /// the trace are mapped back to the user's units.
    pub normalisation: [f64; 2],
    /// Lateness statistics (paced replays only).
    pub deadline: Option<Deadlines>,
    /// Largest |u_c|, |y_c|, |Δy_c| of the conditioned data in the units the estimator ran in
    /// (normalised; what a nonlinear model's neurons are initialised for).
    #[serde(skip)]
    pub ranges: InputRanges,
    /// θ in the units the estimator ran in.
    #[serde(skip)]
    pub theta_normalised: Vec<f64>,
}

/// The conditioned signals' largest magnitudes in the recording's own units (y in the y column's,
/// u in the u column's): a pass over `file` with the same reader, conditioning in float64. Rows
/// the boundary would reject (not finite) are skipped; the replay itself reports them.
///
/// # Errors
/// The reader's error naming the line.
pub fn signal_ranges(file: &Path, spec: &ReplaySpec) -> Result<(f64, f64), String> {
    let reader = RecordingReader::open(file, &spec.reader).map_err(|e| e.to_string())?;
    let (mut y_max, mut u_max) = (0.0f64, 0.0f64);
    let mut prev: Option<(f64, f64)> = None;
    for item in reader {
        let s = item.map_err(|e| e.to_string())?;
        let (y, u, r) = (s.y, s.u, s.r.unwrap_or(0.0));
        if !(y.is_finite() && u.is_finite() && r.is_finite()) {
            prev = None;
            continue;
        }
        let (yc, uc) = match spec.conditioning {
            Conditioning::None => (Some(y), u),
            Conditioning::CentredOnReference => (Some(y - r), u),
            Conditioning::DifferencedOutput => (prev.map(|(py, _)| y - py), u),
            Conditioning::Differenced => {
                (prev.map(|(py, _)| y - py), prev.map_or(0.0, |p| u - p.1))
            }
        };
        prev = Some((y, u));
        y_max = y_max.max(yc.map_or(0.0, f64::abs));
        u_max = u_max.max(uc.abs());
    }
    Ok((y_max, u_max))
}

/// The units `spec` asks for on `file`, for a nonlinear model or not. Normalised units are
/// computed from the recording's own ranges (range / target in the column's unit), not from the
/// user's: the same file in any `y_unit` or `u_full_scale` gives the same boundary, bit for bit.
///
/// # Errors
/// The reader's error, or the configuration's (a signal that is zero throughout cannot be
/// normalised).
pub fn units(file: &Path, spec: &ReplaySpec, nonlinear: bool) -> Result<Units, String> {
    let user =
        Scaling::new(spec.y_unit, spec.u_full_scale).map_err(|e| format!("configuration: {e}"))?;
    let targets = match spec.normalise {
        Normalise::Off => None,
        Normalise::Auto if !nonlinear => None,
        Normalise::Fixed(u) => return Ok(u),
        Normalise::On | Normalise::Auto => Some((
            sledid::num::boundary::Y_TARGET,
            sledid::num::boundary::U_TARGET,
        )),
        Normalise::Targets { y, u } => Some((y, u)),
    };
    let Some((ty, tu)) = targets else {
        return Ok(Units {
            scaling: user,
            norm: Normalisation::NONE,
        });
    };
    let (y, u) = signal_ranges(file, spec)?;
    let bad = |e: sledid::ConfigError| format!("{}: normalisation: {e}", file.display());
    let norm = Normalisation::for_ranges_to(y / spec.y_unit, u / spec.u_full_scale, ty, tu)
        .map_err(bad)?;
    let scaling = Scaling::for_ranges_to(y, u, ty, tu).map_err(bad)?;
    Ok(Units { scaling, norm })
}

/// Replays `file` into `out` (created if needed).
///
/// # Errors
/// A message naming the file and line for reader errors, the sample for boundary errors, the
/// parameter for configuration errors, and the path for I/O errors.
pub fn replay(file: &Path, spec: &ReplaySpec, out: &Path) -> Result<ReplaySummary, String> {
    if let Some(structure) = spec.nonlinear {
        return sledid::with_parameter_count!(structure, |N| replay_nonlinear::<N>(
            file, spec, out, structure
        ));
    }
    match spec.order {
        (1, 1) => replay_linear::<{ parameter_count(1, 1, false) }>(file, spec, out),
        (1, 2) | (2, 1) => replay_linear::<{ parameter_count(1, 2, false) }>(file, spec, out),
        (2, 2) => replay_linear::<{ parameter_count(2, 2, false) }>(file, spec, out),
        (na, nb) => Err(format!(
            "order na = {na}, nb = {nb}: supported are 1,1 / 1,2 / 2,1 / 2,2"
        )),
    }
}

/// The `p`-quantile (0 ≤ p ≤ 1) of ascending `sorted` by nearest rank: the element of 0-based rank
/// `round((n − 1)·p)`; 0 for no data. The deadline statistics' p50 and p99.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}
