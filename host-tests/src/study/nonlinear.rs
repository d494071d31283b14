//! The paper's nonlinear models (Section 5) in the study: every [`NonlinearStructure`] fitted by
//! Levenberg–Marquardt on the simulation error (`nonlinear_batch`), started from the matching
//! linear OE model of the same rate as the paper does (w = 0, so the start *is* the OE model) and
//! from seeded random starts around it, keeping the lowest identification SSE
//! ([`super::select`]), so the fit's SSE is never above the OE model's:
//!
//! | report name | structure | from | paper |
//! |---|---|---|---|
//! | `NOE-Hammerstein1` | eq. 5, two neurons on u(t−1), 8 parameters | OE1 | 9 % lower validation RMS than OE1 (Fig. 13) |
//! | `NOE1-yu` | eq. 6, one neuron on ŷ(t−1), u(t−1), 6 | OE1 | "similar" to eq. 5 |
//! | `NOE221` | eq. 7, one neuron on u(t−1), 7 | OE2 | 13 % lower than OE2 (Fig. 14) |
//! | `Wiener1` | OE1 then x + w tanh(a x + c), 5 (the paper's gain k ≡ 1) | OE1 | best after ÷2 (Fig. 17) |
//! | `Friction2` | OE2 + a neuron of the simulated velocity at the drive, 7 | OE2 | the paper's proposed next step |
//!
//! The neurons' initial input weights come from the identification segment's ranges
//! (max |u|, max |y|, max |Δy|; [`InputRanges`]). Over-fitting is *flagged*, not tuned away:
//! `overfit_risk` when there are fewer than [`MIN_SAMPLES_PER_PARAMETER`] identification samples
//! per parameter, `overfit_evidence` when the fit improves on its linear model on the
//! identification segment but is worse on validation, and Akaike's FPE beside the linear one.
//! [`StudyOptions::nonlinear_ridge`] adds `δ‖θ − θ₀‖²` to the criterion (0, the paper's
//! criterion, by default).

use serde::Serialize;
use std::collections::BTreeMap;

use super::analysis::{CrossCorrelation, cross_correlation};
use super::models::{monic_roots, rms_from};
use super::report::ModelReport;
use super::select::{Criterion, fit_structure, linear_start};
use super::{Dataset, MIN_SAMPLES_PER_PARAMETER, RMS_START, StudyOptions};
use crate::reference::linear::stable;
use crate::reference::nonlinear::{evaluate, static_map};
use crate::reference::nonlinear_batch::simulate_from_measured;
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};

/// Points of a static-map curve.
const MAP_POINTS: usize = 81;

/// The study's name of a structure, its linear counterpart and the paper's relative change.
pub fn describe(s: NonlinearStructure) -> (&'static str, &'static str, Option<f64>) {
    match s {
        NonlinearStructure::Hammerstein => ("NOE-Hammerstein1", "OE1", Some(-0.09)),
        NonlinearStructure::NoeOutputInput => ("NOE1-yu", "OE1", None),
        NonlinearStructure::Noe221 => ("NOE221", "OE2", Some(-0.13)),
        NonlinearStructure::Wiener => ("Wiener1", "OE1", None),
        NonlinearStructure::FrictionFeedback => ("Friction2", "OE2", None),
    }
}

/// θ's entry names, in θ's order (see `sledid::ident::nonlinear::structure`).
pub fn parameter_names(s: NonlinearStructure) -> &'static [&'static str] {
    match s {
        NonlinearStructure::Hammerstein => &["f1", "b1", "w1", "a1", "c1", "w2", "a2", "c2"],
        NonlinearStructure::NoeOutputInput => &["f1", "b1", "w", "a_y", "a_u", "c"],
        NonlinearStructure::Noe221 | NonlinearStructure::FrictionFeedback => {
            &["f1", "f2", "b1", "b2", "w", "a", "c"]
        }
        NonlinearStructure::Wiener => &["f1", "b1", "w", "a", "c"],
    }
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
    /// `samples_per_param <` [`MIN_SAMPLES_PER_PARAMETER`].
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

/// θ₀ of `s` from the linear θ = [f…, b…] (the paper's initialisation, [`NonlinearDesign`]).
pub fn theta0(s: NonlinearStructure, linear: &[f64], r: InputRanges) -> Vec<f64> {
    match s.parameter_count() {
        5 => NonlinearDesign::<5>::from_linear(s, linear, r)
            .theta0
            .to_vec(),
        6 => NonlinearDesign::<6>::from_linear(s, linear, r)
            .theta0
            .to_vec(),
        7 => NonlinearDesign::<7>::from_linear(s, linear, r)
            .theta0
            .to_vec(),
        _ => NonlinearDesign::<8>::from_linear(s, linear, r)
            .theta0
            .to_vec(),
    }
}

/// The internal state s(t) of the simulation from the measured start (s = ŷ but for Wiener).
fn states(s: NonlinearStructure, theta: &[f64], y: &[f64], u: &[f64]) -> Vec<f64> {
    let na = s.na();
    let mut x = y[..na.min(y.len())].to_vec();
    for t in na..y.len().min(u.len()) {
        let lag = |v: &[f64], k: usize| if t >= k { v[t - k] } else { 0.0 };
        let ev = evaluate(s, theta, [x[t - 1], lag(&x, 2)], [u[t - 1], lag(u, 2)]);
        x.push(ev.s);
    }
    x
}

fn min_max(v: &[f64]) -> [f64; 2] {
    v.iter()
        .fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], &x| {
            [a.min(x), b.max(x)]
        })
}

/// The static map of the fitted model over the argument's range on the identification segment.
fn map_of(s: NonlinearStructure, theta: &[f64], linear: &[f64], ident: &Dataset) -> StaticMap {
    let na = s.na();
    let x_state = states(s, theta, &ident.y, &ident.u);
    let unit = &ident.y_unit_name;
    let (arg, input, output): (Vec<f64>, String, String) = match s {
        NonlinearStructure::Wiener => (
            x_state,
            format!("linear output x ({unit})"),
            "ŷ = x + g(x)".to_owned(),
        ),
        NonlinearStructure::FrictionFeedback => (
            x_state.windows(2).map(|w| w[1] - w[0]).collect(),
            format!("simulated velocity s(t−1) − s(t−2) ({unit}/sample)"),
            format!("g(v) ({unit})"),
        ),
        _ => (
            ident.u.clone(),
            "u(t−1) (V)".to_owned(),
            format!("b1·u + g(·) ({unit})"),
        ),
    };
    let data_range = min_max(&arg);
    let pad = 0.1 * (data_range[1] - data_range[0]).max(1e-9);
    let x: Vec<f64> = (0..MAP_POINTS)
        .map(|i| {
            data_range[0] - pad
                + (data_range[1] - data_range[0] + 2.0 * pad) * i as f64 / (MAP_POINTS - 1) as f64
        })
        .collect();
    let (lin_label, lin): (&str, Vec<f64>) = match s {
        NonlinearStructure::Wiener => ("OE1: ŷ = x", x.clone()),
        NonlinearStructure::FrictionFeedback => ("OE2: none", vec![0.0; x.len()]),
        _ => ("b1·u", x.iter().map(|v| linear[na] * v).collect()),
    };
    let nonlinear = if s == NonlinearStructure::NoeOutputInput {
        // g(ŷ, u) + b1·u at three ŷ(t−1) slices over the identification range of y.
        let ry = min_max(&ident.y);
        [ry[0], 0.5 * (ry[0] + ry[1]), ry[1]]
            .iter()
            .map(|&yv| MapCurve {
                label: format!("ŷ(t−1) = {yv:.1}"),
                values: x
                    .iter()
                    .map(|&u| {
                        theta[1] * u + theta[2] * (theta[3] * yv + theta[4] * u + theta[5]).tanh()
                    })
                    .collect(),
            })
            .collect()
    } else {
        vec![MapCurve {
            label: "nonlinear".to_owned(),
            values: x
                .iter()
                .map(|&v| static_map(s, theta, v).unwrap_or(f64::NAN))
                .collect(),
        }]
    };
    StaticMap {
        input,
        output,
        x,
        linear: MapCurve {
            label: lin_label.to_owned(),
            values: lin,
        },
        nonlinear,
        data_range,
    }
}

/// Akaike's FPE `V(1 + d/N)/(1 − d/N)` with V = SSE/N.
pub fn fpe(sse: f64, n: usize, d: usize) -> f64 {
    let n = n.max(1) as f64;
    let r = d as f64 / n;
    if r < 1.0 {
        sse / n * (1.0 + r) / (1.0 - r)
    } else {
        f64::INFINITY
    }
}

/// Fits and scores every nonlinear structure on one rate's segments; `linear` holds that rate's
/// linear reports (OE1 and OE2 are used). A structure whose start cannot be built or whose data
/// are too short is left out (and named in the returned notes).
pub fn fit_all(
    ident: &Dataset,
    valid: &Dataset,
    linear: &[ModelReport],
    options: &StudyOptions,
    label: &str,
    decimation: usize,
) -> (Vec<NonlinearReport>, Vec<String>) {
    let (y, u) = (&ident.y, &ident.u);
    let mut reports = Vec::new();
    let mut notes = Vec::new();
    for s in NonlinearStructure::ALL {
        let (name, counterpart, paper) = describe(s);
        let Some(lin) = linear.iter().find(|m| m.name == counterpart) else {
            continue;
        };
        let na = s.na();
        let (den, num) = (&lin.theta[..na], &lin.theta[na..]);
        let Some((lin_theta, th0, init)) = linear_start(s, den, num, y, u) else {
            continue;
        };
        let Some(ms) = fit_structure(s, &th0, y, u, options, decimation, 0) else {
            notes.push(format!(
                "{name} at {label}: could not be fitted (start or data)"
            ));
            continue;
        };
        let f = &ms.fit;
        let sim_ident = simulate_from_measured(s, &f.theta, y, u);
        let sim_valid = simulate_from_measured(s, &f.theta, &valid.y, &valid.u);
        let rms_sim_ident = rms_from(y, &sim_ident, RMS_START);
        let rms_sim_valid = rms_from(&valid.y, &sim_valid, RMS_START);
        let d = s.parameter_count();
        let samples_per_param = y.len() as f64 / d as f64;
        let eps: Vec<f64> = valid.y.iter().zip(&sim_valid).map(|(a, b)| a - b).collect();
        let from = RMS_START.min(eps.len());
        let n_eff = y.len().saturating_sub(na);
        let den_fit = &f.theta[..na];
        let b = &f.theta[na..2 * na];
        let zeros = match b.split_first() {
            Some((&b1, rest)) if b1 != 0.0 => {
                monic_roots(&rest.iter().map(|v| v / b1).collect::<Vec<_>>())
            }
            _ => Vec::new(),
        };
        reports.push(NonlinearReport {
            name: name.to_owned(),
            structure: s.name(),
            linear_counterpart: counterpart.to_owned(),
            order: na,
            parameters: parameter_names(s)
                .iter()
                .map(|n| (*n).to_owned())
                .zip(f.theta.iter().copied())
                .collect(),
            theta: f.theta.clone(),
            theta0: th0,
            poles: monic_roots(den_fit),
            zeros,
            stable: stable(den_fit, 1.0 - 1e-12),
            n_params: d,
            samples_ident: y.len(),
            samples_per_param,
            overfit_risk: samples_per_param < MIN_SAMPLES_PER_PARAMETER,
            overfit_evidence: rms_sim_ident < lin.rms_sim_ident
                && rms_sim_valid > lin.rms_sim_valid,
            fpe: fpe(f.sse_final, n_eff, d),
            linear_fpe: lin.fpe,
            rms_sim_ident,
            rms_sim_valid,
            linear_rms_sim_ident: lin.rms_sim_ident,
            linear_rms_sim_valid: lin.rms_sim_valid,
            change_vs_linear_valid: rms_sim_valid / lin.rms_sim_valid - 1.0,
            paper_change_vs_linear: paper,
            fit: NonlinearFitReport {
                method: "levenberg_marquardt",
                init,
                ridge: options.nonlinear_ridge,
                sse_init: ms.sse_linear,
                sse_final: f.sse_final,
                iterations: f.iterations,
                converged: f.converged,
                start: if ms.start == 0 {
                    "linear".to_owned()
                } else {
                    format!("random {}", ms.start)
                },
                sse_per_start: ms.sse_per_start.clone(),
            },
            cv: Criterion::default(),
            xcorr_valid: cross_correlation(&eps[from..], &valid.u[from..], options.xcorr_lags),
            static_map: map_of(s, &f.theta, &lin_theta, ident),
            sim_valid,
        });
    }
    (reports, notes)
}
