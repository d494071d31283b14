//! How the study's report is made: the four linear models of one rate fitted and scored into a
//! [`RateReport`], and the reference figures (the types are in [`super::results`]).

use super::analysis::{criterion_surfaces, cross_correlation, periodogram};
use super::models::{LinearModel, ModelSpec, fit_arx, fit_oe, rms_from, sse_from};
use super::nonlinear::fit_all;
use super::results::{Criterion, FitReport, ModelReport, RateReport, ReferenceFigure, Structure};
use super::select::{cross_validate, recommend};
use super::{Dataset, MIN_SAMPLES_PER_PARAMETER, RMS_START, StudyError, StudyOptions};

/// Pole modulus above which an OE estimate is reported as on the stability constraint.
pub const BOUNDARY_MODULUS: f64 = 0.999;

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
