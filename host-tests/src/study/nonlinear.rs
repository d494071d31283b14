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
//!
//! [`InputRanges`]: sledid::ident::nonlinear::InputRanges

use super::analysis::cross_correlation;
use super::models::{monic_roots, rms_from};
use super::results::{
    Criterion, MapCurve, ModelReport, NonlinearFitReport, NonlinearReport, StaticMap,
};
use super::select::{describe, fit_structure, linear_start};
use super::{Dataset, MIN_SAMPLES_PER_PARAMETER, RMS_START, StudyOptions};
use crate::reference::linear::stable;
use crate::reference::nonlinear::{evaluate, static_map};
use crate::reference::nonlinear_batch::simulate_from_measured;
use rayon::prelude::*;
use sledid::ident::nonlinear::NonlinearStructure;

/// Points of a static-map curve.
const MAP_POINTS: usize = 81;

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
    // The structures are fitted in parallel (each fit is deterministic: the same reports, in
    // the order of `NonlinearStructure::ALL`, on any number of threads).
    let fitted: Vec<Fitted> = NonlinearStructure::ALL
        .par_iter()
        .map(|&s| fit_one(s, ident, valid, linear, options, label, decimation))
        .collect();
    let mut reports = Vec::new();
    let mut notes = Vec::new();
    for f in fitted {
        match f {
            Fitted::Report(r) => reports.push(*r),
            Fitted::Note(n) => notes.push(n),
            Fitted::Skipped => {}
        }
    }
    (reports, notes)
}

/// One structure's outcome in [`fit_all`].
enum Fitted {
    Report(Box<NonlinearReport>),
    Note(String),
    Skipped,
}

/// Fits and scores structure `s` ([`fit_all`]).
fn fit_one(
    s: NonlinearStructure,
    ident: &Dataset,
    valid: &Dataset,
    linear: &[ModelReport],
    options: &StudyOptions,
    label: &str,
    decimation: usize,
) -> Fitted {
    let (y, u) = (&ident.y, &ident.u);
    let (name, counterpart, paper) = describe(s);
    let Some(lin) = linear.iter().find(|m| m.name == counterpart) else {
        return Fitted::Skipped;
    };
    let na = s.na();
    let (den, num) = (&lin.theta[..na], &lin.theta[na..]);
    let Some((lin_theta, th0, init)) = linear_start(s, den, num, y, u) else {
        return Fitted::Skipped;
    };
    let Some(ms) = fit_structure(s, &th0, y, u, options, decimation, 0) else {
        return Fitted::Note(format!(
            "{name} at {label}: could not be fitted (start or data)"
        ));
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
    Fitted::Report(Box::new(NonlinearReport {
        name: name.to_owned(),
        structure: s.name(),
        linear_counterpart: counterpart.to_owned(),
        order: na,
        parameters: s
            .parameter_names()
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
        overfit_evidence: rms_sim_ident < lin.rms_sim_ident && rms_sim_valid > lin.rms_sim_valid,
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
    }))
}
