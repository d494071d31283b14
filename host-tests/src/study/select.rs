//! Multi-start nonlinear fits, the identification-only criterion and the recommended model.
//!
//! # Multi-start
//! Every nonlinear batch fit runs from the linear start θ₀ (the OE model with w = 0, the paper's)
//! and from [`StudyOptions::random_starts`] seeded random starts around it: the linear part as in
//! θ₀, each neuron's output weight `w ~ U(−½, ½)·scale` (scale `|b₁|·max|u|`, the size of the
//! linear input term; for the Wiener output map `max|y|`), its input weights θ₀'s times
//! `U(⅓, 3)` and its bias θ₀'s plus `U(−1, 1)`. The starts are drawn from ChaCha8 seeded with
//! [`StudyOptions::start_seed`], one stream per (rate, structure, fold), so a study is
//! deterministic. The fit kept is the one with the lowest identification criterion (the SSE,
//! plus the ridge term `δ‖θ − θ₀‖²` toward the linear start when `--ridge` is set); the
//! validation segment never chooses.
//!
//! # Criterion: blocked cross-validation inside the identification segment
//! Four folds hold out, in turn, the segment's last half, first half, last third and first third;
//! each model's whole procedure (ARX by least squares; OE by LM from that ARX; a nonlinear
//! structure by the multi-start LM from that OE, with its own random starts) is fitted on the
//! contiguous rest and simulated over the held-out block from its measured initial outputs,
//! scored over samples [`RMS_START`]… of the block, as the validation segment is scored.
//! [`Criterion::rms`] is the RMS over every held-out sample of the four folds ([`CRITERION`]).
//! Only the identification segment is used.
//!
//! Measured on the twin (STUDY.md, "The recommended model"): selecting by this criterion keeps
//! the recommended model within 5 % of the best linear model's validation RMS far more often
//! than selecting by the identification fit, FPE or AIC, which pick an over-fitted nonlinear
//! model in almost every case; two folds (halves only) did worse than four.
//!
//! # Recommendation
//! At each rate: among the linear models (ARX1, ARX2, OE1, OE2) and, separately, the nonlinear
//! ones, those within [`PARSIMONY_TOLERANCE`] of their group's lowest criterion are a tie that
//! the one with fewer parameters wins. The nonlinear winner is recommended when its criterion
//! is more than [`RECOMMEND_MARGIN`] below the lowest linear one; otherwise the linear winner.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::models::{LinearModel, fit_arx, fit_oe, project_stable, refit_num, sse_from};
use super::results::{Criterion, ModelReport, NonlinearReport, Recommendation};
use super::{Dataset, RMS_START, StudyOptions};
use crate::reference::linear::stable;
use crate::reference::nonlinear_batch::{NonlinearFit, fit_from, simulate_from_measured};
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};

/// A nonlinear model is recommended only when its criterion is below the best linear model's by
/// more than this fraction: on the twin, margins 0 / 0.1 / 0.2 kept 86 / 90 / 92.5 % of 80 cases
/// within 5 % of the best linear model (seeds 1–40, STUDY.md), while the matched plants'
/// structures win by 50–75 %.
pub const RECOMMEND_MARGIN: f64 = 0.2;

/// Models whose criteria are within this fraction of each other are a tie, which the one with
/// fewer parameters wins.
pub const PARSIMONY_TOLERANCE: f64 = 0.05;

/// The criterion's name in study.json.
pub const CRITERION: &str = "cv_rms_blocked_4fold";

/// Pole modulus an OE start beyond it is pulled in to (the batch fit accepts |p| ≤ 0.999).
pub const START_RADIUS: f64 = 0.998;

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

/// θ₀ of `s` from the linear θ = [f…, b…] (the paper's initialisation, [`NonlinearDesign`]).
pub fn theta0(s: NonlinearStructure, linear: &[f64], r: InputRanges) -> Vec<f64> {
    sledid::with_parameter_count!(s, |N| NonlinearDesign::<N>::from_linear(s, linear, r)
        .theta0
        .to_vec())
}

/// The structures' ranges for the neuron initialisation, from the data being fitted.
pub fn ranges(y: &[f64], u: &[f64]) -> InputRanges {
    let max_abs = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0f64, |m, x| m.max(x.abs()));
    InputRanges {
        u: max_abs(&mut u.iter().copied()).max(1e-9),
        y: max_abs(&mut y.iter().copied()).max(1e-9),
        dy: max_abs(&mut y.windows(2).map(|w| w[1] - w[0])).max(1e-9),
    }
}

/// The linear start of `s` from its OE counterpart `(den, num)`: θ₀ and `oe` or, when the OE
/// poles lie beyond [`START_RADIUS`], the poles pulled in and B refitted (`projected_oe`).
pub fn linear_start(
    s: NonlinearStructure,
    den: &[f64],
    num: &[f64],
    y: &[f64],
    u: &[f64],
) -> Option<(Vec<f64>, Vec<f64>, &'static str)> {
    let (den, num, init) = if stable(den, START_RADIUS) {
        (den.to_vec(), num.to_vec(), "oe")
    } else {
        let pulled = project_stable(den, START_RADIUS);
        let b = refit_num(&pulled, y, u)?;
        (pulled, b, "projected_oe")
    };
    let lin: Vec<f64> = den.iter().chain(&num).copied().collect();
    let th0 = theta0(s, &lin, ranges(y, u));
    Some((lin, th0, init))
}

/// The random generator of one (rate, structure, fold): fold 0 is the full segment.
fn rng(
    options: &StudyOptions,
    decimation: usize,
    s: NonlinearStructure,
    fold: usize,
) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(options.start_seed);
    let index = NonlinearStructure::ALL
        .iter()
        .position(|x| *x == s)
        .unwrap_or(0);
    r.set_stream(((decimation as u64) << 16) | ((index as u64) << 8) | fold as u64);
    r
}

/// θ₀ and `k` random starts around it (see the module documentation).
fn starts(
    s: NonlinearStructure,
    th0: &[f64],
    y: &[f64],
    u: &[f64],
    k: usize,
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<f64>> {
    let na = s.na();
    let r = ranges(y, u);
    let scale = match s {
        NonlinearStructure::Wiener => r.y,
        _ => th0[na].abs().max(1e-9) * r.u,
    };
    let names = s.parameter_names();
    let mut all = vec![th0.to_vec()];
    for _ in 0..k {
        let mut th = th0.to_vec();
        for (i, name) in names.iter().enumerate().skip(2 * na) {
            th[i] = match name.as_bytes()[0] {
                b'w' => rng.gen_range(-0.5..0.5) * scale,
                b'a' => th0[i] * rng.gen_range(1.0 / 3.0..3.0),
                _ => th0[i] + rng.gen_range(-1.0..1.0),
            };
        }
        all.push(th);
    }
    all
}

/// A multi-start fit: the fit with the lowest identification criterion and the index of its
/// start (0: the linear start).
pub struct MultiStart {
    /// The fit kept.
    pub fit: NonlinearFit,
    /// Its start: 0 the linear one, 1… the random ones.
    pub start: usize,
    /// The final identification SSE from every start (∞ where the fit failed).
    pub sse_per_start: Vec<f64>,
    /// The identification SSE at the linear start θ₀ (∞ where it could not be fitted).
    pub sse_linear: f64,
}

/// Fits `s` from θ₀ and the random starts on (y, u); `None` when no start could be fitted.
pub fn fit_multistart(
    s: NonlinearStructure,
    th0: &[f64],
    y: &[f64],
    u: &[f64],
    options: &StudyOptions,
    rng: &mut ChaCha8Rng,
) -> Option<MultiStart> {
    // The fit's own criterion: the SSE plus the ridge term (toward θ₀).
    let v = |f: &NonlinearFit| {
        let pen: f64 = f.theta.iter().zip(th0).map(|(a, b)| (a - b).powi(2)).sum();
        f.sse_final + options.nonlinear_ridge * pen
    };
    let mut best: Option<(usize, NonlinearFit)> = None;
    let mut sse_per_start = Vec::new();
    let mut sse_linear = f64::INFINITY;
    for (i, th) in starts(s, th0, y, u, options.random_starts, rng)
        .iter()
        .enumerate()
    {
        let f =
            fit_from(s, th, th0, options.nonlinear_ridge, y, u).filter(|f| f.sse_final.is_finite());
        sse_per_start.push(f.as_ref().map_or(f64::INFINITY, |f| f.sse_final));
        if i == 0 {
            sse_linear = f.as_ref().map_or(f64::INFINITY, |f| f.sse_init);
        }
        if let Some(f) = f
            && best.as_ref().is_none_or(|(_, b)| v(&f) < v(b))
        {
            best = Some((i, f));
        }
    }
    best.map(|(start, fit)| MultiStart {
        fit,
        start,
        sse_per_start,
        sse_linear,
    })
}

/// The multi-start fit of `s` from the rate's `seed` stream for `fold` (0: the whole segment).
pub fn fit_structure(
    s: NonlinearStructure,
    th0: &[f64],
    y: &[f64],
    u: &[f64],
    options: &StudyOptions,
    decimation: usize,
    fold: usize,
) -> Option<MultiStart> {
    let mut r = rng(options, decimation, s, fold);
    fit_multistart(s, th0, y, u, options, &mut r)
}

/// Held-out SSE and sample count, per fold.
#[derive(Clone, Default)]
struct Score {
    sse: Vec<f64>,
    n: Vec<usize>,
}

impl Score {
    fn add(&mut self, y: &[f64], yhat: Option<&[f64]>) {
        let sse = yhat.map_or(f64::INFINITY, |yhat| sse_from(y, yhat, RMS_START));
        self.sse
            .push(if sse.is_finite() { sse } else { f64::INFINITY });
        self.n.push(y.len().saturating_sub(RMS_START));
    }

    /// A fold that scores no model.
    fn skip(&mut self) {
        self.sse.push(f64::NAN);
        self.n.push(0);
    }

    fn rms(&self) -> Criterion {
        let rms = |sse: f64, n: usize| {
            if n == 0 {
                f64::NAN
            } else {
                (sse / n as f64).sqrt()
            }
        };
        let used = || self.sse.iter().zip(&self.n).filter(|(_, n)| **n > 0);
        let total = rms(used().map(|x| x.0).sum(), used().map(|x| x.1).sum());
        Criterion {
            rms: if total.is_nan() { f64::INFINITY } else { total },
            folds: self
                .sse
                .iter()
                .zip(&self.n)
                .map(|(s, n)| rms(*s, *n))
                .collect(),
        }
    }
}

/// One fold's held-out readings and every model's simulation of them (`None`: not fitted).
struct FoldSims {
    y: Vec<f64>,
    linear: Vec<Option<Vec<f64>>>,
    nonlinear: Vec<Option<Vec<f64>>>,
}

/// The criterion of every linear and nonlinear model of one rate (names as in the report),
/// from the identification segment alone (see the module documentation).
pub fn cross_validate(
    ident: &Dataset,
    options: &StudyOptions,
    decimation: usize,
) -> Vec<(String, Criterion)> {
    let n = ident.y.len();
    let blocks = [
        (0..n - n / 2, n - n / 2..n),
        (n / 2..n, 0..n / 2),
        (0..n - n / 3, n - n / 3..n),
        (n / 3..n, 0..n / 3),
    ];
    let linear_names = ["ARX1", "ARX2", "OE1", "OE2"];
    // The folds, and each fold's nonlinear fits, run in parallel (each fit is deterministic: the
    // same criteria on any number of threads); the scores are added in fold order.
    let folds: Vec<Option<FoldSims>> = blocks
        .into_par_iter()
        .enumerate()
        .map(|(fold, (train, test))| {
            let (y, u) = (&ident.y[train.clone()], &ident.u[train]);
            let (yv, uv) = (&ident.y[test.clone()], &ident.u[test]);
            let mut arx: [Option<LinearModel>; 2] = [None, None];
            let mut oe: [Option<LinearModel>; 2] = [None, None];
            for order in 1..=2 {
                arx[order - 1] = fit_arx(order, y, u);
                oe[order - 1] = arx[order - 1]
                    .as_ref()
                    .and_then(|a| fit_oe(order, y, u, a))
                    .map(|f| f.model);
            }
            if arx.iter().chain(&oe).any(Option::is_none) {
                // A part without excitation (e.g. a window that is flat at its end): the linear
                // models cannot be fitted on it, so it scores no model.
                return None;
            }
            let linear = arx
                .iter()
                .chain(&oe)
                .map(|m| m.as_ref().map(|m| m.simulate(uv, yv)))
                .collect();
            let nonlinear = NonlinearStructure::ALL
                .par_iter()
                .map(|&s| {
                    let fitted = oe[s.na() - 1]
                        .as_ref()
                        .and_then(|m| linear_start(s, &m.den, &m.num, y, u))
                        .and_then(|(_, th0, _)| {
                            fit_structure(s, &th0, y, u, options, decimation, fold + 1)
                        });
                    fitted.map(|f| simulate_from_measured(s, &f.fit.theta, yv, uv))
                })
                .collect();
            Some(FoldSims {
                y: yv.to_vec(),
                linear,
                nonlinear,
            })
        })
        .collect();
    let mut lin: [Score; 4] = Default::default();
    let mut nl: [Score; 5] = Default::default();
    for fold in &folds {
        let Some(f) = fold else {
            lin.iter_mut().chain(nl.iter_mut()).for_each(Score::skip);
            continue;
        };
        for (score, sim) in lin.iter_mut().zip(&f.linear) {
            score.add(&f.y, sim.as_deref());
        }
        for (score, sim) in nl.iter_mut().zip(&f.nonlinear) {
            score.add(&f.y, sim.as_deref());
        }
    }
    linear_names
        .iter()
        .map(|n| (*n).to_owned())
        .zip(lin.iter().map(Score::rms))
        .chain(
            NonlinearStructure::ALL
                .iter()
                .map(|s| describe(*s).0.to_owned())
                .zip(nl.iter().map(Score::rms)),
        )
        .collect()
}

/// The recommendation from the models' criteria (see the module documentation); `None` when no
/// linear model has a finite criterion.
pub fn recommend(linear: &[ModelReport], nonlinear: &[NonlinearReport]) -> Option<Recommendation> {
    let lin: Vec<(&str, usize, f64)> = linear
        .iter()
        .map(|m| (m.name.as_str(), m.n_params, m.cv.rms))
        .collect();
    let nl: Vec<(&str, usize, f64)> = nonlinear
        .iter()
        .map(|m| (m.name.as_str(), m.n_params, m.cv.rms))
        .collect();
    let (lin_name, _, lin_v) = parsimonious(&lin)?;
    let best_nl = parsimonious(&nl);
    let (model, value) = match best_nl {
        Some((n, _, v)) if v < (1.0 - RECOMMEND_MARGIN) * lowest(&lin) => (n, v),
        _ => (lin_name, lin_v),
    };
    Some(Recommendation {
        model: model.to_owned(),
        criterion: CRITERION,
        value,
        best_linear: lin_name.to_owned(),
        best_linear_value: lin_v,
        best_nonlinear: best_nl.map(|b| b.0.to_owned()),
        best_nonlinear_value: best_nl.map(|b| b.2),
        margin: RECOMMEND_MARGIN,
    })
}

/// The lowest finite criterion of `models` (name, parameters, criterion); ∞ if none.
fn lowest(models: &[(&str, usize, f64)]) -> f64 {
    models
        .iter()
        .map(|m| m.2)
        .filter(|c| c.is_finite())
        .fold(f64::INFINITY, f64::min)
}

/// Of the models within [`PARSIMONY_TOLERANCE`] of the lowest criterion, the one with the fewest
/// parameters (then the lowest criterion); `None` if no criterion is finite.
fn parsimonious<'a>(models: &[(&'a str, usize, f64)]) -> Option<(&'a str, usize, f64)> {
    let low = lowest(models);
    models
        .iter()
        .filter(|m| m.2.is_finite() && m.2 <= (1.0 + PARSIMONY_TOLERANCE) * low)
        .min_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)))
        .copied()
}
