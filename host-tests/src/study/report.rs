//! What the study reports (serialised to `study.json`) and the table it prints.

use serde::Serialize;
use std::collections::BTreeMap;

use super::analysis::{
    CriterionSurfaces, CrossCorrelation, Periodogram, criterion_surfaces, cross_correlation,
    periodogram,
};
use super::models::{
    LinearModel, ModelSpec, OeInit, Structure, fit_arx, fit_oe, rms_from, sse_from,
};
use super::nonlinear::{NonlinearReport, fit_all};
use super::plots::PlotInfo;
use super::protocol::TwinProtocol;
use super::select::{Criterion, Recommendation, cross_validate, recommend};
use super::{
    Centring, Dataset, MIN_SAMPLES_PER_PARAMETER, RMS_START, Segment, StudyError, StudyOptions,
};

/// Pole modulus above which an OE estimate is reported as on the stability constraint.
pub const BOUNDARY_MODULUS: f64 = 0.999;

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

impl ModelReport {
    /// Scores `model` on both segments.
    fn new(
        model: &LinearModel,
        fit: FitReport,
        ident: &Dataset,
        valid: &Dataset,
        lags: usize,
    ) -> Self {
        let sim_ident = model.simulate(&ident.u, &ident.y);
        let sim_valid = model.simulate(&valid.u, &valid.y);
        let pred_ident = model.predict(&ident.u, &ident.y);
        let pred_valid = model.predict(&valid.u, &valid.y);
        let d = model.spec.parameter_count();
        let n_eff = ident.y.len().saturating_sub(model.spec.order).max(1) as f64;
        let v = fit.sse_final / n_eff;
        let ratio = d as f64 / n_eff;
        let eps: Vec<f64> = valid
            .y
            .iter()
            .zip(&pred_valid)
            .map(|(a, b)| a - b)
            .collect();
        let from = RMS_START.min(eps.len());
        let samples_per_param = ident.y.len() as f64 / d as f64;
        let max_pole_modulus = model
            .poles()
            .iter()
            .map(|p| p[0].hypot(p[1]))
            .fold(0.0, f64::max);
        Self {
            name: model.spec.name(),
            structure: model.spec.structure,
            order: model.spec.order,
            parameters: model
                .parameter_names()
                .into_iter()
                .zip(model.theta())
                .collect(),
            theta: model.theta(),
            poles: model.poles(),
            zeros: model.zeros(),
            stable: model.is_stable(),
            max_pole_modulus,
            at_stability_boundary: model.spec.structure == Structure::Oe
                && max_pole_modulus > BOUNDARY_MODULUS,
            n_params: d,
            samples_ident: ident.y.len(),
            samples_per_param,
            overfit_risk: samples_per_param < MIN_SAMPLES_PER_PARAMETER,
            cv: Criterion::default(),
            fpe: if ratio < 1.0 {
                v * (1.0 + ratio) / (1.0 - ratio)
            } else {
                f64::INFINITY
            },
            rms_sim_ident: rms_from(&ident.y, &sim_ident, RMS_START),
            rms_sim_valid: rms_from(&valid.y, &sim_valid, RMS_START),
            rms_pred_ident: rms_from(&ident.y, &pred_ident, RMS_START),
            rms_pred_valid: rms_from(&valid.y, &pred_valid, RMS_START),
            fit,
            xcorr_valid: cross_correlation(&eps[from..], &valid.u[from..], lags),
            sim_valid,
        }
    }
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

/// Fits and scores the paper's four models on one rate's segments.
pub(super) fn rate_report(
    label: &str,
    decimation: usize,
    ident: &Dataset,
    valid: &Dataset,
    options: &StudyOptions,
) -> Result<RateReport, StudyError> {
    let fail = |spec: &ModelSpec| StudyError::Fit {
        model: spec.name(),
        rate: label.to_owned(),
    };
    let (y, u) = (&ident.y, &ident.u);
    let mut arx_fits: Vec<LinearModel> = Vec::new();
    let mut fitted: Vec<(LinearModel, FitReport)> = Vec::new();
    for spec in ModelSpec::PAPER {
        let arx = match arx_fits.iter().find(|m| m.spec.order == spec.order) {
            Some(m) => m.clone(),
            None => {
                let m = fit_arx(spec.order, y, u).ok_or_else(|| fail(&spec))?;
                arx_fits.push(m.clone());
                m
            }
        };
        fitted.push(match spec.structure {
            Structure::Arx => {
                let sse = sse_from(y, &arx.predict(u, y), spec.order);
                let fit = FitReport {
                    method: "least_squares",
                    init: None,
                    sse_init: sse,
                    sse_final: sse,
                    iterations: 0,
                    rejected_unstable_steps: 0,
                    converged: true,
                };
                (arx, fit)
            }
            Structure::Oe => {
                let oe = fit_oe(spec.order, y, u, &arx).ok_or_else(|| fail(&spec))?;
                let fit = FitReport {
                    method: "levenberg_marquardt",
                    init: Some(oe.init),
                    sse_init: oe.sse_init,
                    sse_final: oe.sse_final,
                    iterations: oe.iterations,
                    rejected_unstable_steps: oe.rejected_unstable,
                    converged: oe.converged,
                };
                (oe.model, fit)
            }
        });
    }
    let first = |s: Structure| fitted.iter().find(|(m, _)| m.spec == ModelSpec::new(s, 1));
    let (Some((arx1, _)), Some((oe1, _))) = (first(Structure::Arx), first(Structure::Oe)) else {
        return Err(StudyError::Usage("first-order models missing".to_owned()));
    };
    let criterion_surfaces = criterion_surfaces(y, u, arx1, oe1, options.surface_grid);
    let mut models: Vec<ModelReport> = fitted
        .iter()
        .map(|(m, f)| ModelReport::new(m, f.clone(), ident, valid, options.xcorr_lags))
        .collect();
    let (mut nonlinear, notes) = fit_all(ident, valid, &models, options, label, decimation);
    for (name, cv) in cross_validate(ident, options, decimation) {
        if let Some(m) = models.iter_mut().find(|m| m.name == name) {
            m.cv = cv.clone();
        }
        if let Some(m) = nonlinear.iter_mut().find(|m| m.name == name) {
            m.cv = cv.clone();
        }
    }
    let recommended = recommend(&models, &nonlinear);
    Ok(RateReport {
        label: label.to_owned(),
        ts_s: ident.ts_s,
        decimation,
        segment_ident: ident.segment,
        segment_valid: valid.segment,
        samples_ident: ident.y.len(),
        samples_valid: valid.y.len(),
        centre_ident_q: ident.centre_q,
        centre_valid_q: valid.centre_q,
        models,
        nonlinear,
        recommended,
        notes,
        criterion_surfaces,
        spectra: (periodogram(u, ident.ts_s), periodogram(y, ident.ts_s)),
        ident: ident.clone(),
        valid: valid.clone(),
    })
}

/// A model's figures from the paper and, for a twin study, from `shared/findings.md`.
///
/// The findings figures belong to a simulated sled (a float64 study of a friction-dominated one):
/// reference values for the twin, never for a user's recording, whose study leaves them `None`
/// ([`reference_figures`]).
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

/// The reference figures of the linear and nonlinear models: the paper's always, findings.md's
/// only `with_findings` (a twin study; see [`ReferenceFigure`]).
pub fn reference_figures(with_findings: bool) -> Vec<ReferenceFigure> {
    let f = |model, ts: Option<f64>, dec2: Option<f64>, paper| ReferenceFigure {
        model,
        findings_rms_sim_valid_ts: ts.filter(|_| with_findings),
        findings_rms_sim_valid_dec2: dec2.filter(|_| with_findings),
        paper,
    };
    vec![
        f(
            "ARX1",
            Some(6.38),
            Some(1.01),
            "good one-step prediction, very poor simulation at Ts (Fig. 6a); much better after ÷2 (Fig. 10a)",
        ),
        f("ARX2", None, None, "not shown"),
        f(
            "OE1",
            Some(5.02),
            Some(0.65),
            "simulates far better than ARX1 at Ts (Fig. 6b); ÷2 in Fig. 10b",
        ),
        f(
            "OE2",
            Some(0.28),
            Some(0.21),
            "slightly better than the first-order models, real poles (Fig. 11)",
        ),
        f(
            "NOE-Hammerstein1",
            Some(4.77),
            Some(0.85),
            "eq. 5: 9 % lower validation RMS than OE1 at Ts (Fig. 13)",
        ),
        f("NOE1-yu", None, None, "eq. 6: similar to eq. 5"),
        f(
            "NOE221",
            Some(0.48),
            Some(1.51),
            "eq. 7 (÷2 data): 13 % lower than OE2 (Fig. 14)",
        ),
        f(
            "Wiener1",
            Some(4.66),
            Some(1.09),
            "best model of the paper, after ÷2 (Fig. 17)",
        ),
        f(
            "Friction2",
            None,
            None,
            "the paper's proposed next step (Sec. 6)",
        ),
    ]
}

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
