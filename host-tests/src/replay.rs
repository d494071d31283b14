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
//! (`tests/nonlinear_units.rs`).

use crate::compare::relative_distance;
use crate::faults::{Fault, Injector, Reading};
use crate::pacing::{StallTracker, Stalls};
use crate::recording::{ReaderOptions, RecordingReader};
use crate::reference::batch::{rms_error, simulate};
use crate::reference::linear::LinearF64;
use crate::reference::nonlinear::{self as nl64, NonlinearF64};
use crate::reference::units::{ModelKind, factors, to_normalised, to_user};
use serde_json::json;
use sledid::ident::conditioning::Conditioning;
use sledid::ident::estimator::{Estimator, EstimatorDesign};
use sledid::ident::linear::{LinearDesign, Structure, parameter_count};
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, StuckSensorDesign, reject, step};
use sledid::{Normalisation, Scaling, Status};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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
/// Measured over the 165 cases of `tests/nonlinear_units.rs` (doc there).
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

/// The float64 twin run beside the fixed-point path, and the simulation its final θ is scored by.
trait Reference<const N: usize> {
    fn step(&mut self, y: f64, u: f64);
    fn theta(&self) -> Vec<f64>;
    /// The model at `theta` simulated from rest on `u`.
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64>;
}

struct LinearReference<const N: usize> {
    model: LinearF64<N>,
    na: usize,
}

impl<const N: usize> Reference<N> for LinearReference<N> {
    fn step(&mut self, y: f64, u: f64) {
        self.model.step(y, u);
    }
    fn theta(&self) -> Vec<f64> {
        self.model.theta().to_vec()
    }
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64> {
        simulate(theta, u, self.na, 1)
    }
}

struct NonlinearReference<const N: usize> {
    model: NonlinearF64<N>,
    structure: NonlinearStructure,
}

impl<const N: usize> Reference<N> for NonlinearReference<N> {
    fn step(&mut self, y: f64, u: f64) {
        let _ = self.model.step_forced(y, u, None);
    }
    fn theta(&self) -> Vec<f64> {
        self.model.theta().to_vec()
    }
    fn simulate(&self, theta: &[f64], u: &[f64]) -> Vec<f64> {
        nl64::simulate(self.structure, theta, u)
    }
}

fn replay_linear<const N: usize>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
) -> Result<ReplaySummary, String> {
    let units = units(file, spec, false)?;
    let norm = units.norm;
    let mut model = LinearDesign::<N>::new(spec.structure, spec.order.0, spec.order.1);
    model.rls = normalised_rls(spec.rls, norm);
    let reference = LinearReference {
        model: LinearF64::new(&model),
        na: spec.order.0,
    };
    let label = format!(
        "{:?}({},{}) conditioning {:?}",
        spec.structure, spec.order.0, spec.order.1, spec.conditioning
    );
    let kind = ModelKind::Linear { na: spec.order.0 };
    replay_model(file, spec, out, model, reference, label, (units, kind))
}

/// The RLS settings in signal units (dead zone, outlier gate) moved into the normalised units.
fn normalised_rls(mut rls: RlsDesign, norm: Normalisation) -> RlsDesign {
    rls.dead_zone /= norm.y_factor();
    rls.outlier_threshold /= norm.y_factor();
    rls
}

fn replay_nonlinear<const N: usize>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
    structure: NonlinearStructure,
) -> Result<ReplaySummary, String> {
    let na = structure.na();
    let units = units(file, spec, true)?;
    let norm = units.norm;
    let (linear, ranges) = match &spec.nonlinear_init {
        Some(l) => (to_normalised(ModelKind::Linear { na }, l, norm), None),
        None => {
            let mut first = spec.clone();
            first.nonlinear = None;
            first.structure = Structure::OutputErrorPredictionError;
            first.order = (na, na);
            first.rate = Rate::Max;
            first.progress = false;
            first.normalise = Normalise::Fixed(units);
            let dir = out.join("linear-init");
            let s = replay(file, &first, &dir)?;
            (s.theta_normalised, Some(s.ranges))
        }
    };
    let ranges = ranges.unwrap_or(InputRanges {
        u: 1.0,
        y: 10.0,
        dy: 1.0,
    });
    let mut model = NonlinearDesign::<N>::from_linear(structure, &linear, ranges);
    model.rls = normalised_rls(spec.rls, norm);
    let reference = NonlinearReference {
        model: NonlinearF64::new(&model),
        structure,
    };
    let label = format!(
        "{} from OE{na} {:?}, conditioning {:?}",
        structure.name(),
        linear,
        spec.conditioning
    );
    let kind = ModelKind::Nonlinear(structure);
    replay_model(file, spec, out, model, reference, label, (units, kind))
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

fn replay_model<const N: usize, D: EstimatorDesign<N>, R: Reference<N>>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
    model: D,
    mut reference: R,
    label: String,
    (units, kind): (Units, ModelKind),
) -> Result<ReplaySummary, String> {
    let (scaling, norm) = (units.scaling, units.norm);
    let mut design = IdentifierDesign::new(spec.conditioning, model);
    design.stuck_sensor = spec.stuck_sensor.map(|mut d| {
        d.min_drive /= norm.u_factor();
        d
    });
    let mut injector = Injector::new(spec.faults.clone());
    let cfg = design.build().map_err(|e| format!("configuration: {e}"))?;
    let needs_r = spec.conditioning == Conditioning::CentredOnReference;
    if needs_r && spec.reader.mapping.reference.is_none() {
        return Err("conditioning centred-on-reference needs a reference column (r=…)".into());
    }
    let mut reader = RecordingReader::open(file, &spec.reader).map_err(|e| e.to_string())?;
    let ts_s = reader.meta().ts_s;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let trace_path = out.join("trace.csv");
    let trace_file =
        std::fs::File::create(&trace_path).map_err(|e| format!("{}: {e}", trace_path.display()))?;
    // The trace is written on its own thread: the paced loop formats into memory and never makes
    // a system call (a write stalling for a few hundred µs would be an overrun at Ts = 0.455 ms).
    let (trace_tx, trace_rx) = std::sync::mpsc::channel::<Vec<u8>>();
    let writer = std::thread::spawn(move || -> std::io::Result<()> {
        let mut w = BufWriter::new(trace_file);
        for chunk in trace_rx {
            w.write_all(&chunk)?;
        }
        w.flush()
    });
    let mut trace: Vec<u8> = Vec::with_capacity(1 << 16);
    let theta_cols: Vec<String> = (0..N).map(|i| format!("theta{i}")).collect();
    writeln!(
        trace,
        "t_s,u,y,y_c,u_c,y_hat,eps,{},flags",
        theta_cols.join(",")
    )
    .map_err(|e| e.to_string())?;

    let mut st = cfg.new_state();
    // The trace and the summary are in the user's units (module doc, *Units*).
    let (ky, ku) = (norm.y_factor(), norm.u_factor());
    let theta_k = factors(kind, N, norm);
    let (mut ys, mut us) = (Vec::new(), Vec::new());
    let mut counts = [0usize; Status::NAMES.len()];
    // The reader streams, so the length is unknown: a counter, on terminals only.
    let bar = (spec.progress && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} {pos} samples replayed",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        b
    });
    let period = match spec.rate {
        Rate::Max => None,
        Rate::Paced(f) => Some(Duration::from_secs_f64(ts_s / f)),
    };
    let mut lateness_us: Vec<f64> = Vec::new();
    let mut work_us: Vec<f64> = Vec::new();
    let mut overruns = 0usize;
    let mut overruns_after_stall = 0usize;
    let mut stalls = StallTracker::default();
    // A backlog (samples finishing after the next deadline) and whether a stall began it.
    let (mut in_backlog, mut backlog_from_stall) = (false, false);
    let mut woke = Instant::now();
    let start = Instant::now();
    let mut n = 0usize;
    for (k, item) in reader.by_ref().enumerate() {
        let s = item.map_err(|e| e.to_string())?;
        if let Some(p) = period {
            let deadline = start + p * k as u32;
            // Absolute deadlines, no drift. A sleeping thread can wake milliseconds late on a loaded
            // or virtualised host (measured: 155 overruns in 10⁵ samples at Ts = 0.455 ms when
            // sleeping to 150 µs before each deadline), so sleep only to 1 ms before it and spin the
            // rest: at sub-millisecond Ts the replay spins, holding one core — as the MCU would.
            let now = Instant::now();
            if deadline > now + Duration::from_millis(2) {
                std::thread::sleep(deadline - now - Duration::from_millis(1));
            }
            let stalled;
            (woke, stalled) = stalls.spin_until(deadline);
            backlog_from_stall = if in_backlog {
                backlog_from_stall || stalled
            } else {
                stalled
            };
            lateness_us.push((woke - deadline).as_secs_f64() * 1e6);
        }
        let reading = injector.apply(k, s);
        let converted = match reading {
            Reading::Present(x) => scaling
                .sample(x.y, x.u, x.r.unwrap_or(0.0))
                .map_err(|e| format!("{}: sample {} (t = {} s): {e}", file.display(), k, s.t_s)),
            Reading::Missing => Err(format!(
                "{}: sample {} (t = {} s): reading lost",
                file.display(),
                k,
                s.t_s
            )),
        };
        let (s, o) = match (converted, spec.on_bad_sample) {
            (Ok(sample), _) => (s, step(&cfg, &mut st, &sample)),
            (Err(e), BadSample::Stop) => return Err(e),
            (Err(_), BadSample::Hold) => (s, reject(&cfg, &mut st)),
        };
        if let Some(p) = period {
            let end = Instant::now();
            work_us.push((end - woke).as_secs_f64() * 1e6);
            in_backlog = end > start + p * (k as u32 + 1);
            if in_backlog {
                overruns += 1;
                overruns_after_stall += usize::from(backlog_from_stall);
            }
        }
        for (c, (flag, _)) in counts.iter_mut().zip(Status::NAMES.iter()) {
            *c += usize::from(o.status.contains(*flag));
        }
        if !o.status.intersects(Status::WARMUP | Status::INPUT_REJECTED) {
            reference.step(o.y.to_f64(), o.u.to_f64());
            ys.push(o.y.to_f64());
            us.push(o.u.to_f64());
        }
        let th: Vec<String> = o
            .theta
            .iter()
            .zip(&theta_k)
            .map(|(p, k)| (p.to_f64() * k).to_string())
            .collect();
        writeln!(
            trace,
            "{},{},{},{},{},{},{},{},{}",
            s.t_s,
            s.u,
            s.y,
            o.y.to_f64() * ky,
            o.u.to_f64() * ku,
            o.y_hat.to_f64() * ky,
            o.eps.to_f64() * ky,
            th.join(","),
            o.status.bits()
        )
        .map_err(|e| e.to_string())?;
        if trace.len() >= 1 << 16 {
            let full = std::mem::replace(&mut trace, Vec::with_capacity(1 << 16));
            trace_tx
                .send(full)
                .map_err(|_| "trace writer stopped".to_owned())?;
        }
        n += 1;
        if let Some(b) = &bar
            && n.is_multiple_of(4096)
        {
            b.set_position(n as u64);
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    trace_tx
        .send(trace)
        .map_err(|_| "trace writer stopped".to_owned())?;
    drop(trace_tx);
    writer
        .join()
        .map_err(|_| "trace writer panicked".to_owned())?
        .map_err(|e| format!("{}: {e}", trace_path.display()))?;
    let theta: Vec<f64> = cfg
        .model()
        .theta(st.model())
        .iter()
        .map(|p| p.to_f64())
        .collect();
    let theta_f64 = reference.theta();
    let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let dy: Vec<f64> = ys.windows(2).map(|w| w[1] - w[0]).collect();
    let ranges = InputRanges {
        u: max_abs(&us).max(1e-3),
        y: max_abs(&ys).max(1.0),
        dy: max_abs(&dy).max(1.0),
    };
    let deadline = period.map(|_| {
        let mut sorted = lateness_us.clone();
        sorted.sort_by(f64::total_cmp);
        let mut work = work_us.clone();
        work.sort_by(f64::total_cmp);
        Deadlines {
            p50_us: percentile(&sorted, 0.5),
            p99_us: percentile(&sorted, 0.99),
            max_us: sorted.last().copied().unwrap_or(0.0),
            overruns,
            overruns_after_stall,
            stalls: stalls.stalls(),
            work_p50_us: percentile(&work, 0.5),
            work_p99_us: percentile(&work, 0.99),
            work_max_us: work.last().copied().unwrap_or(0.0),
        }
    });
    let summary = ReplaySummary {
        file: file.display().to_string(),
        samples: n,
        ts_s,
        rate: match spec.rate {
            Rate::Max => "max".into(),
            Rate::Paced(f) => format!("{f}"),
        },
        wall_s,
        model: label,
        theta_rel_err: relative_distance(&theta, &theta_f64),
        sim_rms: rms_error(&reference.simulate(&theta, &us), &ys) * ky,
        sim_rms_f64: rms_error(&reference.simulate(&theta_f64, &us), &ys) * ky,
        ranges,
        theta: to_user(kind, &theta, norm),
        theta_f64: to_user(kind, &theta_f64, norm),
        theta_normalised: theta,
        normalisation: [ky, ku],
        flags: Status::NAMES
            .iter()
            .zip(counts.iter())
            .map(|((_, name), c)| ((*name).to_owned(), *c))
            .collect(),
        deadline,
    };
    let text = serde_json::to_string_pretty(&json!(summary)).map_err(|e| e.to_string())?;
    let summary_path: PathBuf = out.join("summary.json");
    std::fs::write(&summary_path, text).map_err(|e| format!("{}: {e}", summary_path.display()))?;
    Ok(summary)
}
