//! The study's result types, plain data: what [`super::run`] returns, `study.json` holds and the
//! tables and plots show. Every other study module may import it; it imports none of them.

use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;
use std::str::FromStr;

use sledid::ident::decimate::GROUP_DELAY_SAMPLES;

/// The whole study, as written to `study.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Study {
    /// `sledid study`.
    pub tool: String,
    /// Recording of the identification segment.
    pub ident_source: String,
    /// Recording of the validation segment.
    pub valid_source: String,
    /// Sampling period of the recording, s.
    pub ts_s: f64,
    /// The y column's value of one y unit (y is divided by it).
    pub y_unit: f64,
    /// What y and every RMS figure are in: `quanta` on the twin (`y_unit` is its sensor quantum),
    /// the name the user gave (`--y-unit-name`), else `y_unit` × the y column's unit
    /// ([`super::data::y_unit_label`]).
    pub y_unit_name: String,
    /// Factor from the u column to volts.
    pub u_scale: f64,
    /// The centring rule applied.
    pub centring: Centring,
    /// Identification segment A:B at Ts.
    pub ident_segment: Segment,
    /// Validation segment C:D at Ts.
    pub valid_segment: Segment,
    /// First sample of each segment counted in the RMS figures.
    pub rms_start_sample: usize,
    /// How the segments were chosen on a twin recording.
    pub twin: Option<TwinProtocol>,
    /// The four models at Ts.
    pub at_ts: RateReport,
    /// The four models after ÷2.
    pub decimated_by_2: RateReport,
    /// Reference figures: the paper's; findings.md's only for the twin.
    pub reference: Vec<ReferenceFigure>,
    /// Caveats found while running.
    pub notes: Vec<String>,
    /// The plots written, with what their axes and marks mean.
    pub plots: Vec<PlotInfo>,
}

/// A model's figures from the paper and, for a twin study, from `shared/findings.md`.
///
/// The findings figures belong to a simulated sled (a float64 study of a friction-dominated one):
/// reference values for the twin, never for a user's recording, whose study leaves them `None`
/// ([`reference_figures`](super::report::reference_figures)).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceFigure {
    /// Model name.
    pub model: &'static str,
    /// findings.md: validation simulation RMS at Ts, quanta (friction-dominated simulated sled);
    /// `None` unless the study is of the twin.
    pub findings_rms_sim_valid_ts: Option<f64>,
    /// findings.md: the same after ÷2.
    pub findings_rms_sim_valid_dec2: Option<f64>,
    /// What the paper says (it gives figures, not RMS numbers, for the linear models).
    pub paper: &'static str,
}

/// Everything at one sampling rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RateReport {
    /// `Ts` or `2·Ts`.
    pub label: String,
    /// Sampling period, s.
    pub ts_s: f64,
    /// 1 or 2.
    pub decimation: usize,
    /// Identification segment in this rate's sample indices.
    pub segment_ident: Segment,
    /// Validation segment in this rate's sample indices.
    pub segment_valid: Segment,
    /// Identification samples.
    pub samples_ident: usize,
    /// Validation samples.
    pub samples_valid: usize,
    /// Value subtracted from the identification y (and r), y unit.
    pub centre_ident_q: f64,
    /// Value subtracted from the validation y (and r), y unit.
    pub centre_valid_q: f64,
    /// ARX1, ARX2, OE1, OE2.
    pub models: Vec<ModelReport>,
    /// Every nonlinear structure, each started from its linear OE counterpart above.
    pub nonlinear: Vec<NonlinearReport>,
    /// The recommended model, chosen by the identification-only criterion ([`super::select`]);
    /// `None` when no linear model could be scored.
    pub recommended: Option<Recommendation>,
    /// Caveats of this rate's fits.
    #[serde(skip)]
    pub notes: Vec<String>,
    /// V_N over (pole, b1) of ARX1 and OE1 on the identification segment (Fig. 8).
    pub criterion_surfaces: CriterionSurfaces,
    /// The identification segment (for the plots).
    #[serde(skip)]
    pub ident: Dataset,
    /// The validation segment (for the plots).
    #[serde(skip)]
    pub valid: Dataset,
    /// Periodograms of the identification u and y (for the plots).
    #[serde(skip)]
    pub spectra: (Periodogram, Periodogram),
}

impl RateReport {
    /// The linear model called `name`.
    pub fn model(&self, name: &str) -> Option<&ModelReport> {
        self.models.iter().find(|m| m.name == name)
    }

    /// The nonlinear model called `name`.
    pub fn nonlinear_model(&self, name: &str) -> Option<&NonlinearReport> {
        self.nonlinear.iter().find(|m| m.name == name)
    }
}

/// How a model's parameters were found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitReport {
    /// `least_squares` (ARX) or `levenberg_marquardt` (OE).
    pub method: &'static str,
    /// OE: where LM started.
    pub init: Option<OeInit>,
    /// The criterion's SSE (prediction for ARX, simulation for OE) at the start of the search
    /// (= `sse_final` for ARX).
    pub sse_init: f64,
    /// The criterion's SSE at the estimate, over samples n…N−1 of the identification segment.
    pub sse_final: f64,
    /// Accepted LM steps (0 for ARX).
    pub iterations: usize,
    /// LM trial steps rejected because a pole left the unit circle.
    pub rejected_unstable_steps: usize,
    /// Whether LM stopped on its tolerance.
    pub converged: bool,
}

/// One model at one rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModelReport {
    /// `ARX1`, `ARX2`, `OE1`, `OE2`.
    pub name: String,
    /// ARX or OE.
    pub structure: Structure,
    /// n.
    pub order: usize,
    /// `a1…`/`f1…` and `b1…` by name.
    pub parameters: BTreeMap<String, f64>,
    /// θ = [a | f, b] in order.
    pub theta: Vec<f64>,
    /// Poles `[re, im]`.
    pub poles: Vec<[f64; 2]>,
    /// Finite zeros `[re, im]`.
    pub zeros: Vec<[f64; 2]>,
    /// All poles strictly inside the unit circle.
    pub stable: bool,
    /// Largest pole modulus.
    pub max_pole_modulus: f64,
    /// OE: the estimate sits on the stability constraint (largest pole modulus > 0.999): the
    /// unconstrained minimum has a pole on or outside the unit circle.
    pub at_stability_boundary: bool,
    /// 2n.
    pub n_params: usize,
    /// Identification samples.
    pub samples_ident: usize,
    /// `samples_ident / n_params`.
    pub samples_per_param: f64,
    /// `samples_per_param < 10`: the estimate may be fitting the noise.
    pub overfit_risk: bool,
    /// The identification-only criterion ([`super::select`]): simulation RMS on held-out halves
    /// of the identification segment, y unit.
    pub cv: Criterion,
    /// Akaike's final prediction error `V·(1 + d/N)/(1 − d/N)` of the fit's criterion.
    pub fpe: f64,
    /// Simulation RMS on the identification segment, y unit ([`Study::y_unit_name`]).
    pub rms_sim_ident: f64,
    /// Simulation RMS on the validation segment, y unit.
    pub rms_sim_valid: f64,
    /// One-step prediction RMS on the identification segment, y unit.
    pub rms_pred_ident: f64,
    /// One-step prediction RMS on the validation segment, y unit.
    pub rms_pred_valid: f64,
    /// The search.
    pub fit: FitReport,
    /// Residual (one-step prediction error) vs input on the validation segment.
    pub xcorr_valid: CrossCorrelation,
    /// Simulated output on the validation segment (for the plots).
    #[serde(skip)]
    pub sim_valid: Vec<f64>,
}

/// How the nonlinear search went.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NonlinearFitReport {
    /// `levenberg_marquardt`.
    pub method: &'static str,
    /// `oe` (the linear model as it is) or `projected_oe` (its poles pulled to 0.998 and B
    /// refitted, because the batch fit requires |p| ≤ 0.999).
    pub init: &'static str,
    /// The ridge δ used.
    pub ridge: f64,
    /// Simulation SSE at the start (the linear model), samples na…N−1.
    pub sse_init: f64,
    /// Simulation SSE at the estimate.
    pub sse_final: f64,
    /// Accepted LM steps.
    pub iterations: usize,
    /// Whether LM stopped on its tolerance (not the iteration limit).
    pub converged: bool,
    /// The start the fit kept (lowest identification SSE, plus the ridge term if any): `linear`
    /// (θ₀) or `random k` ([`super::select`]).
    pub start: String,
    /// The final identification SSE from each start, θ₀ first (∞: the fit failed).
    pub sse_per_start: Vec<f64>,
}

/// One curve of a static map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapCurve {
    /// What it is.
    pub label: String,
    /// Its values at [`StaticMap::x`].
    pub values: Vec<f64>,
}

/// The estimated static nonlinearity beside the linear model's (Fig. 13b, 15, 17b).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StaticMap {
    /// The map's argument, e.g. `u(t−1) (V)`.
    pub input: String,
    /// What the values are, e.g. `b1·u + g(u)`.
    pub output: String,
    /// Argument grid (the identification segment's range of the argument, ±10 %).
    pub x: Vec<f64>,
    /// The linear counterpart's map at x.
    pub linear: MapCurve,
    /// The nonlinear model's map(s) at x (eq. 6: one per ŷ(t−1) slice).
    pub nonlinear: Vec<MapCurve>,
    /// The argument's range over the identification segment.
    pub data_range: [f64; 2],
}

/// One nonlinear model at one rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NonlinearReport {
    /// `NOE-Hammerstein1`, `NOE1-yu`, `NOE221`, `Wiener1`, `Friction2`.
    pub name: String,
    /// `sledid` structure name (`hammerstein`, `noe`, `noe221`, `wiener`, `friction`).
    pub structure: &'static str,
    /// The linear model it starts from and is compared with (`OE1`, `OE2`).
    pub linear_counterpart: String,
    /// Linear order na.
    pub order: usize,
    /// θ by name.
    pub parameters: BTreeMap<String, f64>,
    /// θ in the structure's order.
    pub theta: Vec<f64>,
    /// The start θ₀ (the linear model with w = 0).
    pub theta0: Vec<f64>,
    /// Poles of the linear part `[re, im]`.
    pub poles: Vec<[f64; 2]>,
    /// Finite zeros of the linear part's B.
    pub zeros: Vec<[f64; 2]>,
    /// Linear-part poles strictly inside the unit circle.
    pub stable: bool,
    /// Parameters.
    pub n_params: usize,
    /// Identification samples.
    pub samples_ident: usize,
    /// `samples_ident / n_params`.
    pub samples_per_param: f64,
    /// `samples_per_param <` [`MIN_SAMPLES_PER_PARAMETER`](super::MIN_SAMPLES_PER_PARAMETER).
    pub overfit_risk: bool,
    /// Lower identification RMS than the linear counterpart but higher validation RMS.
    pub overfit_evidence: bool,
    /// Akaike's FPE of the simulation criterion.
    pub fpe: f64,
    /// The linear counterpart's FPE.
    pub linear_fpe: f64,
    /// Simulation RMS on the identification segment.
    pub rms_sim_ident: f64,
    /// Simulation RMS on the validation segment.
    pub rms_sim_valid: f64,
    /// The linear counterpart's, on identification data.
    pub linear_rms_sim_ident: f64,
    /// The linear counterpart's, on validation data.
    pub linear_rms_sim_valid: f64,
    /// `rms_sim_valid / linear_rms_sim_valid − 1` (the paper: −0.09 eq. 5, −0.13 eq. 7).
    pub change_vs_linear_valid: f64,
    /// The paper's figure for this change, where it gives one.
    pub paper_change_vs_linear: Option<f64>,
    /// The search.
    pub fit: NonlinearFitReport,
    /// The identification-only criterion ([`super::select`]): simulation RMS on held-out halves
    /// of the identification segment, y unit.
    pub cv: Criterion,
    /// Simulation residual (the NOE predictor is its simulation) vs input on validation data.
    pub xcorr_valid: CrossCorrelation,
    /// The estimated static nonlinearity.
    pub static_map: StaticMap,
    /// Simulated output on the validation segment (plots).
    #[serde(skip)]
    pub sim_valid: Vec<f64>,
}

/// The model the study recommends at one rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recommendation {
    /// The model's name (`OE2`, `NOE221`, ...).
    pub model: String,
    /// [`CRITERION`](super::select::CRITERION).
    pub criterion: &'static str,
    /// Its criterion value (RMS, y unit).
    pub value: f64,
    /// The linear model with the lowest criterion.
    pub best_linear: String,
    /// Its criterion value.
    pub best_linear_value: f64,
    /// The nonlinear model with the lowest criterion, if any was fitted.
    pub best_nonlinear: Option<String>,
    /// Its criterion value.
    pub best_nonlinear_value: Option<f64>,
    /// [`RECOMMEND_MARGIN`](super::select::RECOMMEND_MARGIN).
    pub margin: f64,
}

/// A model's criterion: the held-out simulation RMS over all folds and per fold, y unit. A fold
/// whose training part the linear models cannot be fitted on (no excitation) scores no model:
/// NaN in `folds` (null in study.json), left out of `rms`; ∞ when no fold scores.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Criterion {
    /// Over every held-out sample.
    pub rms: f64,
    /// Per fold, in the folds' order.
    pub folds: Vec<f64>,
}

/// Normalised cross-correlation `R_εu(τ)` of residuals and input, with 99 % bounds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossCorrelation {
    /// Lags τ (samples); `R_εu(τ)` pairs `ε(t)` with `u(t − τ)`.
    pub lags: Vec<i64>,
    /// `Σₜ ε̃(t) ũ(t−τ) / √(Σ ε̃² Σ ũ²)` with the means removed (ε̃, ũ).
    pub values: Vec<f64>,
    /// `2.58/√N`.
    pub bound: f64,
    /// Number of samples N.
    pub samples: usize,
    /// Lags whose |value| exceeds the bound.
    pub outside: usize,
}

/// Periodogram `|X(f)|²/N` in dB of the mean-removed signal, for f = fs/N … fs/2 (DC, zero
/// after the mean is removed, is left out).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Periodogram {
    /// Frequencies, Hz.
    pub freq_hz: Vec<f64>,
    /// `10·log10(|X|²/N)`.
    pub power_db: Vec<f64>,
}

/// A point of a criterion surface: (pole = −a1 or −f1, b1, V_N).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SurfacePoint {
    /// Pole, `−a1` (ARX) or `−f1` (OE).
    pub pole: f64,
    /// b1.
    pub b1: f64,
    /// The criterion there.
    pub v_n: f64,
}

/// `V_N` (eq. 3) of the first-order ARX and OE criteria over a grid of (pole, b1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CriterionSurfaces {
    /// Grid of poles (`−a1` / `−f1`), ascending.
    pub pole_axis: Vec<f64>,
    /// Grid of b1, ascending.
    pub b1_axis: Vec<f64>,
    /// ARX criterion (mean squared one-step prediction error), `[b1 index][pole index]`.
    pub arx_v_n: Vec<Vec<f64>>,
    /// OE criterion (mean squared simulation error), `[b1 index][pole index]`.
    pub oe_v_n: Vec<Vec<f64>>,
    /// The ARX1 least-squares estimate and its criterion.
    pub arx_minimum: SurfacePoint,
    /// The OE1 estimate and its criterion.
    pub oe_minimum: SurfacePoint,
}

/// ARX or OE.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Structure {
    /// Eq. (1): least squares on the one-step prediction error.
    Arx,
    /// Eq. (2): prediction-error minimisation of the simulation error.
    Oe,
}

/// How the OE search was started.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OeInit {
    /// The ARX parameters as they are (the ARX model was stable).
    Arx,
    /// The ARX poles projected to [`PROJECTION_RADIUS`](super::models::PROJECTION_RADIUS), B
    /// refitted by least squares.
    ProjectedArx,
}

/// The window taken from one seek.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SeekWindow {
    /// Seek index in the schedule.
    pub seek: usize,
    /// Its target, counts.
    pub target_counts: i64,
    /// Its step length, counts.
    pub step_counts: i64,
    /// The samples taken.
    pub segment: Segment,
    /// Samples of the window before `|e| ≤ 1` holds for the rest of the seek: the decaying
    /// oscillation; the rest of the window is the ±1-quantum limit cycle.
    pub settling_samples_in_window: usize,
    /// Overshoot beyond the target, counts.
    pub overshoot_counts: i64,
}

/// How a twin study was set up.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TwinProtocol {
    /// Twin seed (default parameters).
    pub seed: u64,
    /// The recording written.
    pub recording: String,
    /// Samples per window.
    pub window: usize,
    /// Identification: seek 0.
    pub ident: SeekWindow,
    /// Validation: seek 1.
    pub valid: SeekWindow,
}

/// One written figure and how to read it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PlotInfo {
    /// File name in the output directory.
    pub file: String,
    /// The paper's figure(s) it corresponds to.
    pub paper_figure: String,
    /// What is drawn, axes and marks.
    pub description: String,
}

/// Sample indices `start..end` (end exclusive); parsed from `A:B`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Segment {
    /// First sample.
    pub start: usize,
    /// One past the last sample.
    pub end: usize,
}

impl Segment {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.end.saturating_sub(self.start)
    }

    /// Whether it holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The decimated samples m whose centre input sample `2m + 1 − 11` lies in `start..end`.
    pub fn decimated(&self) -> Segment {
        let g = GROUP_DELAY_SAMPLES - 1;
        Segment {
            start: (self.start + g).div_ceil(2),
            end: (self.end + g).div_ceil(2),
        }
    }
}

impl fmt::Display for Segment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.start, self.end)
    }
}

impl FromStr for Segment {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("segment `{s}`: expected A:B with sample indices A < B");
        let (a, b) = s.split_once(':').ok_or_else(bad)?;
        let start = a.trim().parse().map_err(|_| bad())?;
        let end = b.trim().parse().map_err(|_| bad())?;
        if start >= end {
            return Err(bad());
        }
        Ok(Segment { start, end })
    }
}

/// How a segment is centred; see the [module documentation](super).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Centring {
    /// `FinalReference` when r is mapped, `LastOutput` otherwise.
    Auto,
    /// r at the segment's last sample.
    FinalReference,
    /// Mean of r over the segment.
    MeanReference,
    /// y at the segment's last sample.
    LastOutput,
    /// No shift.
    None,
}

impl FromStr for Centring {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "auto" => Self::Auto,
            "final-reference" => Self::FinalReference,
            "mean-reference" => Self::MeanReference,
            "last-output" => Self::LastOutput,
            "none" => Self::None,
            _ => {
                return Err(format!(
                    "centring `{s}`: expected auto, final-reference, mean-reference, last-output or none"
                ));
            }
        })
    }
}

/// One centred segment at one rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Sampling period, s.
    pub ts_s: f64,
    /// The unit of y and r ([`Signals::y_unit_name`](super::Signals::y_unit_name)).
    pub y_unit_name: String,
    /// Where it sits in its (possibly decimated) recording.
    pub segment: Segment,
    /// The value subtracted from y and r, y unit.
    pub centre_q: f64,
    /// Input, V.
    pub u: Vec<f64>,
    /// Centred output, y unit.
    pub y: Vec<f64>,
    /// Centred reference, y unit.
    pub r: Option<Vec<f64>>,
}
