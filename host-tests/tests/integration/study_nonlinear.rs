//! The paper's nonlinear models in `sledid study` (Section 5): on the sled twin with the paper's
//! protocol, and on the Silverbox recording (a real cubic-spring system).
//!
//! `cargo test -p sledid-host --test integration study_nonlinear:: -- --nocapture` prints the tables. What the
//! assertions say is what was measured (see STUDY.md); the thresholds leave a margin around the
//! measured values and were set after measuring, as regression guards: they can fail.

use sledid_host::study::protocol::{PAPER_WINDOW, run_twin_with};
use sledid_host::study::results::NonlinearReport;
use sledid_host::study::{Centring, Segment, Study, StudyInput, StudyOptions, run_files};
use sledid_host::twin::TwinParams;
use std::path::PathBuf;

/// Seeds of the twin runs, as in `tests/integration/study.rs`.
const TWIN_SEEDS: [u64; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sledid-study-nl-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The twin study of `seed` on the default twin (the paper's loop) or, with `well_damped`, under
/// the well-damped baseline (`host-tests/plants/well_damped.json`).
fn twin_study(seed: u64, ridge: f64, well_damped: bool) -> Study {
    let dir = scratch_dir(&format!("twin-{seed}-{ridge}-{well_damped}"));
    let options = StudyOptions {
        nonlinear_ridge: ridge,
        ..StudyOptions::default()
    };
    let params = if well_damped {
        TwinParams::well_damped()
    } else {
        TwinParams::default()
    };
    run_twin_with(params, seed, PAPER_WINDOW, &dir, options).unwrap()
}

/// Every nonlinear model of `study` at both rates, with the rate's label.
fn all(study: &Study) -> Vec<(&str, &NonlinearReport)> {
    [&study.at_ts, &study.decimated_by_2]
        .into_iter()
        .flat_map(|r| r.nonlinear.iter().map(move |m| (r.label.as_str(), m)))
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Relative validation changes against the linear start, per rate (Ts, ÷2), pooled over the
/// seeds and the five structures.
fn changes(studies: &[Study]) -> [Vec<f64>; 2] {
    let pick = |dec: bool| {
        studies
            .iter()
            .flat_map(|s| {
                let r = if dec { &s.decimated_by_2 } else { &s.at_ts };
                r.nonlinear.iter().map(|m| m.change_vs_linear_valid)
            })
            .collect()
    };
    [pick(false), pick(true)]
}

/// LM from the OE model fits the identification window at least as well as the OE model, on both
/// twins; the parameter-count flags; the validation census of both (printed).
fn check_fits(studies: &[Study]) {
    for (seed, study) in TWIN_SEEDS.iter().zip(studies) {
        println!("twin seed {seed}, ridge 0\n{}", study.table());
        for (rate, m) in all(study) {
            assert_eq!(m.n_params, m.theta.len());
            assert_eq!(m.parameters.len(), m.n_params);
            // LM from the linear model never ends above its start ...
            assert!(m.fit.sse_final <= m.fit.sse_init, "{} {rate}", m.name);
            assert!(m.stable, "{} {rate}: poles {:?}", m.name, m.poles);
            // ... so, started from the OE model itself, it fits the identification data at
            // least as well as the linear model.
            if m.fit.init == "oe" {
                assert!(
                    m.rms_sim_ident <= m.linear_rms_sim_ident * (1.0 + 1e-9),
                    "seed {seed} {} {rate}: {} > {}",
                    m.name,
                    m.rms_sim_ident,
                    m.linear_rms_sim_ident
                );
            }
        }
        // The parameter-count rule: at ÷2 (50 samples) every model but the 5-parameter Wiener
        // has fewer than 10 samples per parameter and is flagged; none is at Ts (100 samples).
        for m in &study.decimated_by_2.nonlinear {
            assert_eq!(m.overfit_risk, m.n_params > 5, "{}", m.name);
        }
        assert!(study.at_ts.nonlinear.iter().all(|m| !m.overfit_risk));
    }
}

/// (better, worse, median change, over-fitting evidence) per rate [Ts, ÷2], printed.
fn census(name: &str, studies: &[Study]) -> [(usize, usize, f64, usize); 2] {
    let [ts, dec] = changes(studies);
    let worse = |v: &[f64]| v.iter().filter(|c| **c > 0.01).count();
    let better = |v: &[f64]| v.iter().filter(|c| **c < -0.01).count();
    let evidence: Vec<usize> = [false, true]
        .map(|dec| {
            studies
                .iter()
                .flat_map(|s| {
                    if dec { &s.decimated_by_2 } else { &s.at_ts }
                        .nonlinear
                        .iter()
                })
                .filter(|m| m.overfit_evidence)
                .count()
        })
        .to_vec();
    println!(
        "{name}: validation change vs linear start, {} cases per rate: Ts: {} better (< −1 %), {} worse \
         (> +1 %), median {:+.1} %; ÷2: {} better, {} worse, median {:+.1} %; over-fitting \
         evidence (ident better, valid worse) Ts {}, ÷2 {}",
        ts.len(),
        better(&ts),
        worse(&ts),
        100.0 * median(ts.clone()),
        better(&dec),
        worse(&dec),
        100.0 * median(dec.clone()),
        evidence[0],
        evidence[1]
    );
    [
        (better(&ts), worse(&ts), median(ts.clone()), evidence[0]),
        (better(&dec), worse(&dec), median(dec.clone()), evidence[1]),
    ]
}

/// The well-damped baseline (`host-tests/plants/well_damped.json`), whose windows are mostly the
/// ±1-quantum limit cycle: the nonlinear models fit better but validate worse.
#[test]
fn well_damped_twin_nonlinear_models_fit_better_but_validate_worse_than_linear() {
    let studies: Vec<Study> = TWIN_SEEDS
        .iter()
        .map(|&s| twin_study(s, 0.0, true))
        .collect();
    check_fits(&studies);
    let [ts, dec] = changes(&studies);
    let [(_, _, _, evidence_ts), (_, _, _, evidence_dec)] = census("well damped", &studies);
    let evidence = [evidence_ts, evidence_dec];
    let worse = |v: &[f64]| v.iter().filter(|c| **c > 0.01).count();
    let better = |v: &[f64]| v.iter().filter(|c| **c < -0.01).count();
    // Measured (40 cases per rate, multi-start fits): Ts 16 better / 22 worse, median +18.0 %;
    // ÷2 9 better / 30 worse, median +139.7 %; over-fitting evidence in 23 (Ts) and 30 (÷2). Unlike the
    // paper (9 %, 13 % better), the nonlinear models do NOT beat their linear starts: the windows are mostly the ±1-quantum limit cycle
    // (0–7 samples of decaying oscillation in 100), so there is little nonlinearity to learn and
    // the extra parameters fit one seek's quantisation pattern.
    assert!(median(ts.clone()) > 0.0 && median(dec.clone()) > 0.0);
    assert!(worse(&dec) >= 2 * better(&dec), "÷2: {dec:?}");
    assert!(worse(&ts) >= better(&ts), "Ts: {ts:?}");
    // And over-fitting is visible: most cases improve on identification but not on validation.
    assert!(2 * evidence[0] >= ts.len() && 2 * evidence[1] >= dec.len() + dec.len() / 4);
}

/// The default twin (the paper's loop), whose windows hold the decaying oscillation: the fits are
/// checked as on the well-damped twin; on validation the nonlinear models still lose more often
/// than they win (STUDY.md).
#[test]
fn default_twin_nonlinear_models_fit_better_but_mostly_validate_worse() {
    let studies: Vec<Study> = TWIN_SEEDS
        .iter()
        .map(|&s| twin_study(s, 0.0, false))
        .collect();
    check_fits(&studies);
    let [ts, dec] = census("paper's loop", &studies);
    // Measured (40 cases per rate, multi-start fits): Ts 9 better / 29 worse, median +47.8 %;
    // ÷2 15 better / 23 worse, median +10.4 %; over-fitting evidence in 30 and 24 cases. 5–8 parameters on 50–100
    // samples of one seek over-fit even where the window holds the paper's decaying oscillation.
    for (better, worse, median, _) in [ts, dec] {
        assert!(
            median > 0.0 && worse > better,
            "{better} better, {worse} worse"
        );
    }
}

#[test]
fn twin_ridge_keeps_nonlinear_models_near_their_linear_start() {
    let plain: Vec<Study> = TWIN_SEEDS
        .iter()
        .map(|&s| twin_study(s, 0.0, false))
        .collect();
    let ridged: Vec<Study> = TWIN_SEEDS
        .iter()
        .map(|&s| twin_study(s, 1.0, false))
        .collect();
    let abs_median = |v: &[f64]| median(v.iter().map(|c| c.abs()).collect());
    let [p_ts, p_dec] = changes(&plain);
    let [r_ts, r_dec] = changes(&ridged);
    let worst = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    println!(
        "median |change| ridge 0 → 1: Ts {:.1} % → {:.1} %, ÷2 {:.1} % → {:.1} %; worst ÷2 \
         {:+.0} % → {:+.0} %",
        100.0 * abs_median(&p_ts),
        100.0 * abs_median(&r_ts),
        100.0 * abs_median(&p_dec),
        100.0 * abs_median(&r_dec),
        100.0 * worst(&p_dec),
        100.0 * worst(&r_dec)
    );
    for s in &ridged {
        for (_, m) in all(s) {
            assert_eq!(m.fit.ridge, 1.0);
        }
    }
    // The guard works as a guard: it pulls the models toward the linear one (both ways: it also
    // removes the few gains), most clearly on the 50 samples after ÷2.
    assert!(abs_median(&r_dec) < 0.5 * abs_median(&p_dec));
    assert!(abs_median(&r_ts) < abs_median(&p_ts));
    assert!(worst(&r_dec) < worst(&p_dec));
}

#[test]
fn twin_study_is_deterministic() {
    let a = twin_study(4, 0.0, false);
    let b = twin_study(4, 0.0, false);
    let key = |s: &Study| -> Vec<(String, f64, f64)> {
        all(s)
            .iter()
            .map(|(r, m)| (format!("{} {r}", m.name), m.rms_sim_valid, m.rms_sim_ident))
            .collect()
    };
    assert_eq!(key(&a), key(&b));
    assert_eq!(a.at_ts.nonlinear.len(), 5);
    assert_eq!(
        a.at_ts
            .nonlinear
            .iter()
            .map(|m| m.name.as_str())
            .collect::<Vec<_>>(),
        [
            "NOE-Hammerstein1",
            "NOE1-yu",
            "NOE221",
            "Wiener1",
            "Friction2"
        ]
    );
}

/// The Silverbox study: identification on 4,000 samples of the multisine part, validation on a
/// held-back 4,000 of another multisine realisation. y in mV (`y_unit` 1e-3 V), u in V.
fn silverbox(valid: Segment) -> Study {
    let input = StudyInput {
        ident_file: PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../shared/data/silverbox/SNLS80mV.csv"
        )),
        valid_file: None,
        columns: "u=V1,y=V2".to_owned(),
        ts_s: Some(1.0 / 610.35),
        y_unit: 1e-3,
        y_unit_name: Some("mV".to_owned()),
        u_scale: 1.0,
        ident: Segment {
            start: 50_000,
            end: 54_000,
        },
        valid,
        options: StudyOptions {
            centring: Centring::None,
            ..StudyOptions::default()
        },
    };
    run_files(&input).unwrap()
}

#[test]
fn silverbox_second_order_nonlinear_models_beat_oe2() {
    let study = silverbox(Segment {
        start: 100_000,
        end: 104_000,
    });
    println!("{}\n{}", study.header(), study.table());
    for rate in [&study.at_ts, &study.decimated_by_2] {
        let oe1 = rate.model("OE1").unwrap().rms_sim_valid;
        let oe2 = rate.model("OE2").unwrap().rms_sim_valid;
        let nl = |n: &str| rate.nonlinear_model(n).unwrap();
        let l = &rate.label;
        // A resonant (second-order) system: OE2 is far better than OE1.
        assert!(oe2 < 0.3 * oe1, "{l}: OE2 {oe2} OE1 {oe1}");
        // Measured: NOE221 −20 % (Ts) / −12 % (÷2), Friction2 −25 % / −29 % against OE2.
        assert!(nl("NOE221").change_vs_linear_valid < -0.07, "{l}");
        assert!(nl("Friction2").change_vs_linear_valid < -0.15, "{l}");
        // First-order structures cannot model the resonance: within a few % of OE1 (measured
        // −1 %), and far worse than OE2 — the first-order Wiener model is not the best here.
        for n in ["NOE-Hammerstein1", "NOE1-yu", "Wiener1"] {
            let m = nl(n);
            assert!(m.change_vs_linear_valid.abs() < 0.05, "{l} {n}");
            assert!(m.rms_sim_valid > 3.0 * oe2, "{l} {n}");
        }
        // The recommendation, from the identification segment alone, is the best model on
        // validation here (measured: Friction2 at both rates, criterion 8.60 / 7.81 against
        // OE2's 11.13 / 11.52).
        assert_eq!(rate.recommended.as_ref().unwrap().model, "Friction2", "{l}");
        for (_, m) in all(&study) {
            assert!(m.samples_per_param >= 200.0 && !m.overfit_risk);
            assert!(!m.overfit_evidence, "{} {}", m.name, l);
        }
    }
}
