//! What the study reports (serialised to `study.json`) and the table it prints.

use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::analysis::{
    CriterionSurfaces, CrossCorrelation, Periodogram, criterion_surfaces, cross_correlation,
    periodogram,
};
use super::models::{
    LinearModel, ModelSpec, OeInit, Structure, fit_arx, fit_oe, rms_from, sse_from,
};
use super::plots::PlotInfo;
use super::protocol::TwinProtocol;
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
    /// Akaike's final prediction error `V·(1 + d/N)/(1 − d/N)` of the fit's criterion.
    pub fpe: f64,
    /// Simulation RMS on the identification segment, quanta.
    pub rms_sim_ident: f64,
    /// Simulation RMS on the validation segment, quanta.
    pub rms_sim_valid: f64,
    /// One-step prediction RMS on the identification segment, quanta.
    pub rms_pred_ident: f64,
    /// One-step prediction RMS on the validation segment, quanta.
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
    /// Value subtracted from the identification y (and r), quanta.
    pub centre_ident_q: f64,
    /// Value subtracted from the validation y (and r), quanta.
    pub centre_valid_q: f64,
    /// ARX1, ARX2, OE1, OE2.
    pub models: Vec<ModelReport>,
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
    /// The model called `name`.
    pub fn model(&self, name: &str) -> Option<&ModelReport> {
        self.models.iter().find(|m| m.name == name)
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
    let models = fitted
        .iter()
        .map(|(m, f)| ModelReport::new(m, f.clone(), ident, valid, options.xcorr_lags))
        .collect();
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
        criterion_surfaces,
        spectra: (periodogram(u, ident.ts_s), periodogram(y, ident.ts_s)),
        ident: ident.clone(),
        valid: valid.clone(),
    })
}

/// A model's figures from the paper and from `shared/findings.md`, for comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferenceFigure {
    /// Model name.
    pub model: &'static str,
    /// findings.md: validation simulation RMS at Ts, quanta (friction-dominated simulated sled).
    pub findings_rms_sim_valid_ts: Option<f64>,
    /// findings.md: the same after ÷2.
    pub findings_rms_sim_valid_dec2: Option<f64>,
    /// What the paper says (it gives figures, not RMS numbers, for the linear models).
    pub paper: &'static str,
}

/// The reference figures of the four models.
pub fn reference_figures() -> Vec<ReferenceFigure> {
    let f = |model, ts, dec2, paper| ReferenceFigure {
        model,
        findings_rms_sim_valid_ts: ts,
        findings_rms_sim_valid_dec2: dec2,
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
    /// The y column's unit per quantum.
    pub y_unit: f64,
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
    /// Reference figures (paper, findings.md).
    pub reference: Vec<ReferenceFigure>,
    /// Caveats found while running.
    pub notes: Vec<String>,
    /// The plots written, with what their axes and marks mean.
    pub plots: Vec<PlotInfo>,
}

impl Study {
    /// What was studied, in two lines.
    pub fn header(&self) -> String {
        let (ts, dec) = (&self.at_ts, &self.decimated_by_2);
        format!(
            "identification: {} {} ({} samples, ÷2: {})\n\
             validation:     {} {} ({} samples, ÷2: {}); Ts = {:.4} ms; centring: {:?}",
            self.ident_source,
            self.ident_segment,
            ts.samples_ident,
            dec.samples_ident,
            self.valid_source,
            self.valid_segment,
            ts.samples_valid,
            dec.samples_valid,
            self.ts_s * 1e3,
            self.centring
        )
    }

    /// The compact comparison table (Markdown), with footnotes.
    pub fn table(&self) -> String {
        let num = |x: Option<f64>| x.map_or_else(|| "–".to_owned(), |v| format!("{v:.2}"));
        let rms = |m: &ModelReport, v: f64| {
            let mark = if !m.stable {
                " †"
            } else if m.at_stability_boundary {
                " ‡"
            } else {
                ""
            };
            if v.abs() < 1e4 {
                format!("{v:.2}{mark}")
            } else {
                format!("{v:.1e}{mark}")
            }
        };
        let mut t = String::from(
            "| model | sim RMS valid, Ts | sim RMS valid, ÷2 | findings Ts | findings ÷2 \
             | pred RMS valid, Ts | pred RMS valid, ÷2 | sim RMS ident, Ts | poles at Ts | 2n / N (Ts, ÷2) | paper |\n\
             |---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for r in &self.reference {
            let (Some(a), Some(b)) = (
                self.at_ts.model(r.model),
                self.decimated_by_2.model(r.model),
            ) else {
                continue;
            };
            let poles: Vec<String> = a
                .poles
                .iter()
                .filter(|p| p[1] >= 0.0)
                .map(|p| {
                    if p[1] == 0.0 {
                        format!("{:.3}", p[0])
                    } else {
                        format!("{:.3}±{:.3}i", p[0], p[1].abs())
                    }
                })
                .collect();
            let _ = writeln!(
                t,
                "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {} | {} | {}/{}, {}/{} | {} |",
                r.model,
                rms(a, a.rms_sim_valid),
                rms(b, b.rms_sim_valid),
                num(r.findings_rms_sim_valid_ts),
                num(r.findings_rms_sim_valid_dec2),
                a.rms_pred_valid,
                b.rms_pred_valid,
                rms(a, a.rms_sim_ident),
                poles.join(", "),
                a.n_params,
                a.samples_ident,
                b.n_params,
                b.samples_ident,
                r.paper
            );
        }
        t.push_str(
            "\nRMS in quanta over samples 2..N of each segment. † unstable model: its simulation \
             diverges. ‡ OE estimate on the stability constraint (a pole at |p| > 0.999). \
             findings: shared/findings.md (float64 study of a simulated friction-dominated sled).\n",
        );
        t
    }
}
