//! `sledid study`: the paper's identification procedure (Sections 3–5) on any recording, in f64.
//!
//! # Procedure
//! 1. Signals as in the paper: y in sensor quanta (`y / y_unit`, with `y_unit` the quantum), u in
//!    volts (`u · u_scale`). Any other `y_unit` is allowed; tables and plots then name the unit
//!    `y_unit` × the y column's unit, or the name given ([`StudyInput::y_unit_name`]).
//!    findings.md's reference figures are shown only for the twin ([`results::ReferenceFigure`]).
//! 2. An identification segment A:B and a validation segment C:D (sample indices, end exclusive),
//!    the latter possibly from a second recording. Both are centred (below).
//! 3. ARX1, ARX2 (eq. 1) by least squares; OE1, OE2 (eq. 2) by Levenberg–Marquardt on the
//!    simulation error, started from the ARX fit, poles kept inside the unit circle
//!    ([`models`]).
//! 4. Per model: parameters, poles, zeros, simulation RMS on both segments, one-step prediction
//!    RMS, parameter count against data length (and Akaike's FPE), the residual–input
//!    cross-correlation on the validation segment with 99 % bounds `±2.58/√N` (Fig. 7), and for
//!    the first-order models the criterion surfaces V_N(pole, b1) (Fig. 8) ([`analysis`]).
//! 5. The same after down-sampling by 2: the firmware's half-band low-pass
//!    ([`crate::reference::decimate`], unquantised taps) run over the *whole* recording, then every
//!    second sample; decimated sample m stands for input sample `2m + 1 − 11` (the filter's
//!    group delay), which is how A:B maps to the decimated segment (≈ (B − A)/2 samples). The
//!    filter has unit DC gain, so the segment is centred with the same value as at Ts.
//! 6. At both rates, every nonlinear structure of Section 5 (eq. 5, 6, 7, Wiener, friction
//!    feedback) by Levenberg–Marquardt from its linear OE model and from seeded random starts,
//!    with over-fitting flags ([`nonlinear`]).
//! 7. At both rates, every model's identification-only criterion (blocked cross-validation
//!    inside the identification segment) and the recommended model ([`select`]).
//!
//! # Centring ([`Centring`])
//! The paper studies the end of a step, around a constant reference; the models have no offset,
//! so each segment is shifted by one value c (y − c, r − c; u is not shifted: the models are
//! linear in u and the drive at a constant reference averages ≈ 0 V):
//! - `final-reference` (default when r is mapped): c = r at the segment's last sample, the target
//!   the loop settles to;
//! - `mean-reference`: c = the mean of r over the segment (equal to the former on a dwell);
//! - `last-output` (default without r): c = y at the segment's last sample; in a ±1-quantum limit
//!   cycle this can be one quantum off the reference, which is why r is preferred when it exists;
//! - `none`.
//!
//! # RMS figures
//! Simulations start from the measured `y(0…n−1)` (n the model's order); every RMS of every model
//! is taken over samples [`RMS_START`]`…N−1` of its segment so the four models are scored on the
//! same samples. The OE one-step predictor is its simulation (noise model 1), so its
//! `rms_pred_*` equal its `rms_sim_*`.

pub mod analysis;
pub mod data;
pub mod models;
pub mod nonlinear;
pub mod plots;
pub mod protocol;
pub mod report;
pub mod results;
pub mod select;
pub mod table;

use std::fmt;
use std::path::{Path, PathBuf};

use crate::recording::{ReaderOptions, RecordingError, read_all};
use crate::twin::TwinError;
use sledid::ident::decimate::GROUP_DELAY_SAMPLES;

pub use data::Signals;
pub use results::{Centring, Dataset, ModelReport, RateReport, Segment, Study};

/// First sample of a segment counted in every RMS (the largest model order).
pub const RMS_START: usize = 2;
/// Shortest segment accepted at Ts (8 samples after ÷2, twice the parameters of OE2).
pub const MIN_SEGMENT: usize = 16;
/// A model with fewer identification samples per parameter than this is flagged.
pub const MIN_SAMPLES_PER_PARAMETER: f64 = 10.0;

/// Errors of the study; each names what to change.
#[derive(Debug)]
pub enum StudyError {
    /// A segment does not fit its recording or is too short; `name` is the CLI option.
    Segment {
        /// `--ident` or `--valid`.
        name: &'static str,
        /// The segment.
        segment: Segment,
        /// Samples in the recording.
        len: usize,
        /// What the segment must satisfy.
        requirement: String,
    },
    /// A numeric option is out of range; `name` is the CLI option.
    InvalidParameter {
        /// The option.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// A model could not be fitted (singular regressors).
    Fit {
        /// The model.
        model: String,
        /// `Ts` or `2·Ts`.
        rate: String,
    },
    /// Reading a recording.
    Recording(RecordingError),
    /// Generating the twin recording.
    Twin(TwinError),
    /// Writing an output file.
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// Drawing a plot.
    Plot {
        /// The file.
        path: PathBuf,
        /// What plotters said.
        message: String,
    },
    /// Writing the JSON.
    Json(serde_json::Error),
    /// Anything else the caller got wrong (a missing option, a bad mapping).
    Usage(String),
}

impl fmt::Display for StudyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Segment {
                name,
                segment,
                len,
                requirement,
            } => write!(
                f,
                "{name} {segment}: {requirement} (the recording has {len} samples)"
            ),
            Self::InvalidParameter {
                name,
                value,
                requirement,
            } => write!(f, "{name} = {value}: must be {requirement}"),
            Self::Fit { model, rate } => write!(f, "{model} at {rate}: singular regressors"),
            Self::Recording(e) => write!(f, "{e}"),
            Self::Twin(e) => write!(f, "{e}"),
            Self::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Self::Plot { path, message } => write!(f, "{}: {message}", path.display()),
            Self::Json(e) => write!(f, "study JSON: {e}"),
            Self::Usage(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for StudyError {}

/// Tunables of the analysis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StudyOptions {
    /// How segments are centred.
    pub centring: Centring,
    /// Points per axis of the criterion surfaces.
    pub surface_grid: usize,
    /// Largest |τ| of the cross-correlation, samples.
    pub xcorr_lags: usize,
    /// Ridge δ of the nonlinear fits, `δ‖θ − θ₀‖²` added to the simulation SSE (0: the paper's
    /// criterion); see [`nonlinear`].
    pub nonlinear_ridge: f64,
    /// Seeded random starts of each nonlinear fit besides the linear one ([`select`]).
    pub random_starts: usize,
    /// Seed of those starts.
    pub start_seed: u64,
}

impl Default for StudyOptions {
    fn default() -> Self {
        Self {
            centring: Centring::Auto,
            surface_grid: 61,
            xcorr_lags: 20,
            nonlinear_ridge: 0.0,
            random_starts: 4,
            start_seed: 1,
        }
    }
}

/// A study of files, as the CLI gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyInput {
    /// Recording with the identification segment.
    pub ident_file: PathBuf,
    /// Recording with the validation segment (default: the same).
    pub valid_file: Option<PathBuf>,
    /// Column mapping, e.g. `u=u_v,y=y_m,r=r_m,t=t_s`.
    pub columns: String,
    /// Sampling period when there is no time column, s.
    pub ts_s: Option<f64>,
    /// The y unit in the y column's unit (y is divided by it): the sensor quantum for figures in
    /// quanta, as in the paper.
    pub y_unit: f64,
    /// The y unit's name in tables and plots (`quanta`, `mV`); `None`: `y_unit` × the y column's
    /// unit ([`data::y_unit_label`]).
    pub y_unit_name: Option<String>,
    /// Factor from the u column to volts.
    pub u_scale: f64,
    /// Identification segment.
    pub ident: Segment,
    /// Validation segment.
    pub valid: Segment,
    /// Analysis tunables.
    pub options: StudyOptions,
}

/// Reads the recording(s) of `input` and runs the study.
pub fn run_files(input: &StudyInput) -> Result<Study, StudyError> {
    for (name, value) in [("--y-unit", input.y_unit), ("--u-scale", input.u_scale)] {
        if !(value.is_finite() && value != 0.0) {
            return Err(StudyError::InvalidParameter {
                name,
                value,
                requirement: "finite and non-zero",
            });
        }
    }
    let mapping = input
        .columns
        .parse()
        .map_err(|e| StudyError::Usage(format!("--columns: {e}")))?;
    let mut reader = ReaderOptions::new(mapping);
    reader.ts_s = input.ts_s;
    let read = |p: &Path| {
        read_all(p, &reader)
            .map(|rec| {
                let mut signals = Signals::from_recording(&rec, input.y_unit, input.u_scale);
                if let Some(name) = &input.y_unit_name {
                    signals.y_unit_name.clone_from(name);
                }
                signals
            })
            .map_err(StudyError::Recording)
    };
    let ident = read(&input.ident_file)?;
    let valid = match &input.valid_file {
        Some(p) => read(p)?,
        None => ident.clone(),
    };
    let mut study = run(&ident, input.ident, &valid, input.valid, &input.options)?;
    study.y_unit = input.y_unit;
    study.u_scale = input.u_scale;
    Ok(study)
}

/// Checks that `seg` fits `len` samples and holds at least `min`.
fn check_segment(
    name: &'static str,
    seg: Segment,
    len: usize,
    min: usize,
) -> Result<(), StudyError> {
    let requirement = if seg.end > len {
        "must end within the recording".to_owned()
    } else if seg.len() < min {
        format!("must hold at least {min} samples")
    } else {
        return Ok(());
    };
    Err(StudyError::Segment {
        name,
        segment: seg,
        len,
        requirement,
    })
}

/// Runs the study on in-memory signals (see the module documentation).
pub fn run(
    ident: &Signals,
    ident_seg: Segment,
    valid: &Signals,
    valid_seg: Segment,
    options: &StudyOptions,
) -> Result<Study, StudyError> {
    check_segment("--ident", ident_seg, ident.len(), MIN_SEGMENT)?;
    check_segment("--valid", valid_seg, valid.len(), MIN_SEGMENT)?;
    if !(ident.ts_s.is_finite() && ident.ts_s > 0.0) {
        return Err(StudyError::InvalidParameter {
            name: "--ts",
            value: ident.ts_s,
            requirement: "positive",
        });
    }
    if !(options.nonlinear_ridge.is_finite() && options.nonlinear_ridge >= 0.0) {
        return Err(StudyError::InvalidParameter {
            name: "--ridge",
            value: options.nonlinear_ridge,
            requirement: "finite and ≥ 0",
        });
    }
    let (ci, how) = ident.centre(ident_seg, options.centring);
    let (cv, _) = valid.centre(valid_seg, options.centring);
    let at_ts = report::rate_report(
        "Ts",
        1,
        &ident.dataset(ident_seg, ci),
        &valid.dataset(valid_seg, cv),
        options,
    )?;
    let mut notes = Vec::new();
    let (ident2, valid2) = (ident.decimated_by_2(), valid.decimated_by_2());
    // The last decimated samples of a segment that ends near the end of its recording would need
    // input beyond it (the filter looks 11 samples ahead of the sample it stands for): cut them.
    let mut decimated = |name: &'static str, seg: Segment, len: usize, full_len: usize| {
        let d = seg.decimated();
        let cut = Segment {
            start: d.start,
            end: d.end.min(len),
        };
        if cut.end < d.end {
            notes.push(format!(
                "the {} segment ends within {} samples of its recording's end: its last {} \
                 decimated samples do not exist and are left out",
                if name == "--ident" {
                    "identification"
                } else {
                    "validation"
                },
                GROUP_DELAY_SAMPLES - 1,
                d.end - cut.end
            ));
        }
        if cut.len() < MIN_SEGMENT / 2 {
            return Err(StudyError::Segment {
                name,
                segment: seg,
                len: full_len,
                requirement: format!(
                    "leaves {} samples after ÷2, fewer than {}: it ends too close to the \
                     recording's end for the half-band filter",
                    cut.len(),
                    MIN_SEGMENT / 2
                ),
            });
        }
        Ok(cut)
    };
    let is2 = decimated("--ident", ident_seg, ident2.len(), ident.len())?;
    let vs2 = decimated("--valid", valid_seg, valid2.len(), valid.len())?;
    let dec = report::rate_report(
        "2·Ts",
        2,
        &ident2.dataset(is2, ci),
        &valid2.dataset(vs2, cv),
        options,
    )?;
    for (name, seg) in [("identification", ident_seg), ("validation", valid_seg)] {
        if seg.start < 2 * GROUP_DELAY_SAMPLES {
            notes.push(format!(
                "the {name} segment starts at sample {}: the ÷2 filter has less than its 23 samples \
                 of history there, so the first decimated samples carry its start-up transient",
                seg.start
            ));
        }
    }
    for rate in [&at_ts, &dec] {
        notes.extend(rate.notes.iter().cloned());
        for m in rate.nonlinear.iter().filter(|m| m.overfit_evidence) {
            notes.push(format!(
                "{} at {}: lower identification RMS than {} ({:.3} vs {:.3}) but higher validation \
                 RMS ({:.3} vs {:.3}): over-fitting ({:.1} samples per parameter)",
                m.name,
                rate.label,
                m.linear_counterpart,
                m.rms_sim_ident,
                m.linear_rms_sim_ident,
                m.rms_sim_valid,
                m.linear_rms_sim_valid,
                m.samples_per_param
            ));
        }
    }
    Ok(Study {
        tool: "sledid study".to_owned(),
        ident_source: ident.source.clone(),
        valid_source: valid.source.clone(),
        ts_s: ident.ts_s,
        y_unit: 1.0,
        y_unit_name: ident.y_unit_name.clone(),
        u_scale: 1.0,
        centring: how,
        ident_segment: ident_seg,
        valid_segment: valid_seg,
        rms_start_sample: RMS_START,
        twin: None,
        at_ts,
        decimated_by_2: dec,
        reference: report::reference_figures(false),
        notes,
        plots: Vec::new(),
    })
}

/// Writes `dir/study.json` and the plots; fills [`Study::plots`]. Returns the files written.
pub fn write_outputs(study: &mut Study, dir: &Path) -> Result<Vec<PathBuf>, StudyError> {
    std::fs::create_dir_all(dir).map_err(|source| StudyError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    study.plots = plots::write_all(study, dir)?;
    let json_path = dir.join("study.json");
    let text = serde_json::to_string_pretty(study).map_err(StudyError::Json)?;
    std::fs::write(&json_path, text + "\n").map_err(|source| StudyError::Io {
        path: json_path.clone(),
        source,
    })?;
    let mut files = vec![json_path];
    files.extend(study.plots.iter().map(|p| dir.join(&p.file)));
    Ok(files)
}
