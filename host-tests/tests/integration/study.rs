//! Tests of `sledid study`: the OE search on plants with known parameters, the stability
//! constraint, the paper's protocol on the sled twin, decimation, the JSON and the plots.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sledid_host::study::models::{LinearModel, ModelSpec, fit_arx, fit_oe, simulate, sse_from};
use sledid_host::study::protocol::{PAPER_WINDOW, run_twin};
use sledid_host::study::results::Structure;
use sledid_host::study::{
    Segment, Signals, Study, StudyOptions, analysis::cross_correlation, run, write_outputs,
};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Seeds of the twin runs (default parameters: the paper's loop, 6 seeks each).
const TWIN_SEEDS: [u64; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

/// A fresh scratch directory for one test.
fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sledid-study-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// ±1 random binary input and white Gaussian-ish noise (sum of 12 uniforms − 6).
fn excitation(n: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = (0..n)
        .map(|_| if rng.gen_bool(0.5) { 1.0 } else { -1.0 })
        .collect();
    let e = (0..n)
        .map(|_| (0..12).map(|_| rng.r#gen::<f64>()).sum::<f64>() - 6.0)
        .collect();
    (u, e)
}

/// `y = B/F u + σ e` from rest.
fn oe_plant(f: &[f64], b: &[f64], u: &[f64], e: &[f64], sigma: f64) -> Vec<f64> {
    let clean = simulate(f, b, u, &vec![0.0; f.len()]);
    clean.iter().zip(e).map(|(y, e)| y + sigma * e).collect()
}

#[test]
fn oe_recovers_known_first_and_second_order_plants() {
    let (u, e) = excitation(400, 11);
    // First order: pole 0.9, gain b1 = 0.5, output noise σ = 0.2 (SNR ≈ 4 in amplitude).
    let y = oe_plant(&[-0.9], &[0.5], &u, &e, 0.2);
    let arx = fit_arx(1, &y, &u).unwrap();
    let oe = fit_oe(1, &y, &u, &arx).unwrap();
    println!(
        "first order, true f1 = -0.9, b1 = 0.5: ARX {:?} {:?}, OE {:?} {:?} ({} LM steps)",
        arx.den, arx.num, oe.model.den, oe.model.num, oe.iterations
    );
    assert!(
        (oe.model.den[0] + 0.9).abs() < 0.01,
        "f1 = {}",
        oe.model.den[0]
    );
    assert!(
        (oe.model.num[0] - 0.5).abs() < 0.03,
        "b1 = {}",
        oe.model.num[0]
    );
    // The ARX estimate is biased by the coloured equation error (1/A noise model is wrong).
    assert!((arx.den[0] + 0.9).abs() > (oe.model.den[0] + 0.9).abs());

    // Second order: poles 0.9 and 0.6, B = 0.3 q⁻¹ + 0.2 q⁻², σ = 0.2.
    let (f2, b2) = ([-1.5, 0.54], [0.3, 0.2]);
    let y = oe_plant(&f2, &b2, &u, &e, 0.2);
    let arx = fit_arx(2, &y, &u).unwrap();
    let oe = fit_oe(2, &y, &u, &arx).unwrap();
    println!(
        "second order, true F = {f2:?}, B = {b2:?}: OE {:?} {:?}, poles {:?}",
        oe.model.den,
        oe.model.num,
        oe.model.poles()
    );
    for (got, want) in oe.model.theta().iter().zip(f2.iter().chain(&b2)) {
        assert!((got - want).abs() < 0.05, "θ {:?}", oe.model.theta());
    }
}

#[test]
fn lm_lowers_the_simulation_sse_below_the_arx_start_and_stays_stable() {
    let (u, e) = excitation(300, 5);
    let y = oe_plant(&[-0.95], &[0.2], &u, &e, 0.3);
    let arx = fit_arx(1, &y, &u).unwrap();
    let oe = fit_oe(1, &y, &u, &arx).unwrap();
    let sse = |m: &LinearModel| sse_from(&y, &m.simulate(&u, &y), 1);
    println!(
        "ARX start SSE {:.3} → OE SSE {:.3} in {} steps",
        oe.sse_init, oe.sse_final, oe.iterations
    );
    assert_eq!(oe.sse_init, sse(&arx));
    assert!((oe.sse_final - sse(&oe.model)).abs() < 1e-9 * oe.sse_final);
    assert!(oe.sse_final < 0.9 * oe.sse_init);
    assert!(oe.iterations > 0 && oe.converged);

    // An integrating plant (pole at 1, the sled's position) with an unstable ARX start: the
    // result must stay inside the unit circle, from a projected start.
    let mut y_int = vec![0.0; u.len()];
    for t in 1..u.len() {
        y_int[t] = 1.02 * y_int[t - 1] + 0.1 * u[t - 1] + 0.05 * e[t];
    }
    let arx = fit_arx(1, &y_int, &u).unwrap();
    assert!(!arx.is_stable(), "ARX pole {:?}", arx.poles());
    let oe = fit_oe(1, &y_int, &u, &arx).unwrap();
    println!(
        "unstable ARX start {:?} → OE poles {:?}, {} rejected steps, SSE {:.1} → {:.1}",
        arx.poles(),
        oe.model.poles(),
        oe.rejected_unstable,
        oe.sse_init,
        oe.sse_final
    );
    assert!(oe.model.is_stable());
    assert!(oe.sse_final <= oe.sse_init);
}

/// The twin study of `seed` with the paper's protocol.
fn twin_study(seed: u64) -> Study {
    let dir = scratch_dir(&format!("twin-{seed}"));
    run_twin(seed, PAPER_WINDOW, &dir, StudyOptions::default()).unwrap()
}

#[test]
fn twin_paper_protocol_arx1_simulates_worse_than_oe1() {
    let mut holds = Vec::new();
    for seed in TWIN_SEEDS {
        let study = twin_study(seed);
        println!("twin seed {seed}\n{}\n{}", study.header(), study.table());
        for rate in [&study.at_ts, &study.decimated_by_2] {
            for m in &rate.models {
                // LM never ends above its start, and OE models stay stable.
                assert!(
                    m.fit.sse_final <= m.fit.sse_init,
                    "{} {}",
                    m.name,
                    rate.label
                );
                if m.structure == Structure::Oe {
                    assert!(m.stable, "{} {} poles {:?}", m.name, rate.label, m.poles);
                }
            }
        }
        let arx1 = study.at_ts.model("ARX1").unwrap();
        let oe1 = study.at_ts.model("OE1").unwrap();
        // As in the paper: ARX1 predicts one step ahead far better than it simulates.
        assert!(arx1.rms_pred_valid < arx1.rms_sim_valid, "seed {seed}");
        holds.push((seed, arx1.rms_sim_valid > oe1.rms_sim_valid));
    }
    let count = holds.iter().filter(|(_, h)| *h).count();
    println!("ARX1 sim RMS > OE1 sim RMS (validation, Ts) per seed: {holds:?}");
    // The paper's and findings' ordering. Measured on the default twin (the paper's loop, whose
    // windows hold the decaying oscillation): holds on all 8 seeds, ARX1's simulation diverging on
    // 7 (`tests/integration/study_paper_twin.rs` asserts it with a factor of 2). On the well-damped baseline
    // (`plants/well_damped.json`, the default before) it held on 7 of 8 — it failed where ARX1
    // happened to be stable and both models simulated no better than the output's own RMS — and
    // this test asserted ≥ 6 of 8.
    assert_eq!(count, TWIN_SEEDS.len(), "{holds:?}");
}

#[test]
fn decimation_halves_the_sample_count() {
    let n = 1000;
    let s = Signals {
        source: "ramp".to_owned(),
        ts_s: 1e-3,
        y_unit_name: "quanta".to_owned(),
        u_v: (0..n).map(|k| (k as f64 * 0.1).sin()).collect(),
        y_q: (0..n).map(|k| k as f64).collect(),
        r_q: Some(vec![5.0; n]),
    };
    let d = s.decimated_by_2();
    assert_eq!(d.len(), n / 2);
    assert_eq!(d.ts_s, 2e-3);
    assert_eq!(d.r_q.as_ref().map(Vec::len), Some(n / 2));
    let seg = Segment {
        start: 100,
        end: 200,
    };
    assert_eq!(seg.decimated().len(), 50);
    // Decimated sample m stands for input 2m − 10 (group delay 11): on a ramp, y(m) = 2m − 10.
    let m = seg.decimated().start;
    assert!((d.y_q[m] - (2 * m - 10) as f64).abs() < 1e-9);
    assert_eq!(2 * m - 10, 100);

    let study = run(
        &s,
        seg,
        &s,
        Segment {
            start: 400,
            end: 500,
        },
        &StudyOptions::default(),
    )
    .unwrap();
    assert_eq!(study.at_ts.samples_ident, 100);
    assert_eq!(study.decimated_by_2.samples_ident, 50);
    assert_eq!(study.decimated_by_2.samples_valid, 50);
    assert_eq!(study.decimated_by_2.ts_s, 2.0 * study.at_ts.ts_s);
}

#[test]
fn cross_correlation_of_independent_noises_stays_inside_the_99_percent_bounds() {
    let (u, _) = excitation(2000, 1);
    let (_, e) = excitation(2000, 2);
    let x = cross_correlation(&e, &u, 20);
    assert_eq!(x.lags.len(), 41);
    assert!((x.bound - 2.58 / 2000f64.sqrt()).abs() < 1e-12);
    println!(
        "independent noises: {} of 41 lags outside ±{:.4}",
        x.outside, x.bound
    );
    assert!(x.outside <= 3);
    // A residual that is the input delayed by 3 correlates fully at τ = 3.
    let eps: Vec<f64> = (0..u.len())
        .map(|t| if t >= 3 { u[t - 3] } else { 0.0 })
        .collect();
    let x = cross_correlation(&eps, &u, 20);
    let at3 = x.values[x.lags.iter().position(|&l| l == 3).unwrap()];
    assert!(at3 > 0.99, "{at3}");
}

/// The default twin study written once to disk: (directory, files written).
fn written_study() -> &'static (PathBuf, Vec<PathBuf>) {
    static WRITTEN: OnceLock<(PathBuf, Vec<PathBuf>)> = OnceLock::new();
    WRITTEN.get_or_init(|| {
        let dir = scratch_dir("written");
        let mut study = run_twin(1, PAPER_WINDOW, &dir, StudyOptions::default()).unwrap();
        let files = write_outputs(&mut study, &dir).unwrap();
        (dir, files)
    })
}

#[test]
fn study_json_has_every_key() {
    let (dir, _) = written_study();
    let text = std::fs::read_to_string(dir.join("study.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "ident_source",
        "valid_source",
        "ts_s",
        "y_unit",
        "centring",
        "ident_segment",
        "valid_segment",
        "twin",
        "at_ts",
        "decimated_by_2",
        "reference",
        "plots",
    ] {
        assert!(json.get(key).is_some(), "missing {key}");
    }
    for rate in ["at_ts", "decimated_by_2"] {
        let r = &json[rate];
        for key in ["ts_s", "samples_ident", "samples_valid", "centre_ident_q"] {
            assert!(r.get(key).is_some(), "{rate}: missing {key}");
        }
        // The recommendation: a model of this rate, its criterion, and the best linear model.
        let rec = &r["recommended"];
        for key in [
            "model",
            "criterion",
            "value",
            "best_linear",
            "best_linear_value",
            "margin",
        ] {
            assert!(rec.get(key).is_some(), "{rate}: recommended.{key}");
        }
        let named = rec["model"].as_str().unwrap();
        assert!(
            ["models", "nonlinear"].iter().any(|k| r[k]
                .as_array()
                .unwrap()
                .iter()
                .any(|m| m["name"] == named && m["cv"]["rms"] == rec["value"])),
            "{rate}: {rec}"
        );
        for key in [
            "pole_axis",
            "b1_axis",
            "arx_v_n",
            "oe_v_n",
            "arx_minimum",
            "oe_minimum",
        ] {
            assert!(
                r["criterion_surfaces"].get(key).is_some(),
                "{rate}: surface {key}"
            );
        }
        let models = r["models"].as_array().unwrap();
        let names: Vec<&str> = models.iter().map(|m| m["name"].as_str().unwrap()).collect();
        assert_eq!(names, ["ARX1", "ARX2", "OE1", "OE2"]);
        for m in models {
            for key in [
                "parameters",
                "poles",
                "zeros",
                "rms_sim_ident",
                "rms_sim_valid",
                "rms_pred_ident",
                "rms_pred_valid",
                "n_params",
                "samples_ident",
                "samples_per_param",
                "fpe",
                "cv",
                "fit",
            ] {
                assert!(m.get(key).is_some(), "{rate} {}: missing {key}", m["name"]);
            }
            for key in ["lags", "values", "bound", "outside"] {
                assert!(m["xcorr_valid"].get(key).is_some(), "xcorr {key}");
            }
            let order = m["order"].as_u64().unwrap() as usize;
            assert_eq!(m["parameters"].as_object().unwrap().len(), 2 * order);
            assert_eq!(m["poles"].as_array().unwrap().len(), order);
            assert_eq!(m["zeros"].as_array().unwrap().len(), order - 1);
        }
    }
    for rate in ["at_ts", "decimated_by_2"] {
        let models = json[rate]["nonlinear"].as_array().unwrap();
        let names: Vec<&str> = models.iter().map(|m| m["name"].as_str().unwrap()).collect();
        assert_eq!(
            names,
            [
                "NOE-Hammerstein1",
                "NOE1-yu",
                "NOE221",
                "Wiener1",
                "Friction2"
            ]
        );
        for m in models {
            for key in [
                "linear_counterpart",
                "parameters",
                "theta",
                "theta0",
                "poles",
                "zeros",
                "n_params",
                "samples_ident",
                "samples_per_param",
                "overfit_risk",
                "overfit_evidence",
                "fpe",
                "rms_sim_ident",
                "rms_sim_valid",
                "linear_rms_sim_valid",
                "change_vs_linear_valid",
                "paper_change_vs_linear",
                "fit",
                "xcorr_valid",
                "static_map",
            ] {
                assert!(m.get(key).is_some(), "{rate} {}: missing {key}", m["name"]);
            }
            let d = m["n_params"].as_u64().unwrap() as usize;
            assert_eq!(m["theta"].as_array().unwrap().len(), d);
            assert_eq!(m["parameters"].as_object().unwrap().len(), d);
            for key in ["iterations", "converged", "sse_init", "sse_final", "ridge"] {
                assert!(m["fit"].get(key).is_some(), "fit {key}");
            }
        }
    }
    assert_eq!(json["plots"].as_array().unwrap().len(), 8);
}

#[test]
fn plots_are_written() {
    let (dir, files) = written_study();
    let pngs: Vec<&PathBuf> = files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "png"))
        .collect();
    assert_eq!(pngs.len(), 8);
    for name in [
        "fig5_ident_data.png",
        "fig6_simulation.png",
        "fig7_xcorr.png",
        "fig8_criterion.png",
        "fig11b_poles_zeros.png",
        "fig13_nonlinear_simulation.png",
        "fig13b_15_17b_static_maps.png",
        "fig18_nonlinear_xcorr.png",
    ] {
        let path: &Path = &dir.join(name);
        let bytes = std::fs::read(path).unwrap();
        println!("{}: {} bytes", path.display(), bytes.len());
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{name} is not a PNG"
        );
        // A drawn figure, not a blank canvas (a white 1840×800 PNG compresses to ~10 kB).
        assert!(bytes.len() > 50_000, "{name}: {} bytes", bytes.len());
    }
}

#[test]
fn a_second_file_can_hold_the_validation_segment() {
    use sledid_host::study::protocol::{TWIN_COLUMNS, twin_input};
    use sledid_host::study::{StudyInput, run_files};
    let (a, pa) = twin_input(1, 100, &scratch_dir("file-a"), StudyOptions::default()).unwrap();
    let (b, pb) = twin_input(2, 100, &scratch_dir("file-b"), StudyOptions::default()).unwrap();
    let input = StudyInput {
        valid_file: Some(b.ident_file.clone()),
        valid: pb.ident.segment,
        columns: TWIN_COLUMNS.to_owned(),
        ..a
    };
    let study = run_files(&input).unwrap();
    assert_eq!(study.ident_segment, pa.ident.segment);
    assert_eq!(study.valid_segment, pb.ident.segment);
    assert!(study.valid_source.ends_with("twin.csv") && study.valid_source != study.ident_source);
    assert!((study.at_ts.centre_valid_q - pb.ident.target_counts as f64).abs() < 1e-6);
    assert_eq!(
        ModelSpec::PAPER.map(|s| s.name()),
        ["ARX1", "ARX2", "OE1", "OE2"]
    );
}

/// The header cells of the table's first line.
fn table_columns(table: &str) -> Vec<String> {
    let header = table.lines().next().unwrap();
    header
        .trim_matches('|')
        .split(" | ")
        .map(|c| c.trim().to_owned())
        .collect()
}

/// A study of a recording (the twin's CSV read as a user's file): RMS figures are labelled with
/// the unit the study used — the name given, else `y_unit` × the y column's unit, never "quanta"
/// by default — and findings.md's reference columns, figures of a simulated sled, are absent from
/// the table and the JSON. Catches a table that hard-codes "quanta" (Silverbox with
/// `--y-unit 0.001` was labelled in quanta) and one that presents the twin's reference figures as
/// the recording's own (issue 12).
#[test]
fn a_file_study_labels_its_unit_and_shows_no_twin_reference() {
    use sledid_host::study::protocol::twin_input;
    use sledid_host::study::run_files;
    let (input, _) =
        twin_input(1, 100, &scratch_dir("file-unit"), StudyOptions::default()).unwrap();
    assert_eq!(input.y_unit, 1.6e-6, "the twin's quantum, m");
    // Even the sensor quantum is not called "quanta" unless the user says so.
    let unnamed = run_files(&sledid_host::study::StudyInput {
        y_unit_name: None,
        ..input.clone()
    })
    .unwrap();
    let named = run_files(&sledid_host::study::StudyInput {
        y_unit: 1e-3 * input.y_unit,
        y_unit_name: Some("mV".to_owned()),
        ..input
    })
    .unwrap();
    for (study, unit) in [(&unnamed, "1.6e-6 × y-column unit"), (&named, "mV")] {
        let table = study.table();
        println!("{table}");
        assert_eq!(study.y_unit_name, unit);
        assert!(!table.contains("quanta"), "{table}");
        assert!(
            table.contains(&format!("| model (RMS in {unit}) |")),
            "{table}"
        );
        assert!(
            table.contains(&format!("RMS in {unit} over samples")),
            "{table}"
        );
        assert!(!table.contains("findings"), "{table}");
        assert_eq!(table_columns(&table).len(), 10, "{table}");
        assert!(study.reference.iter().all(|r| {
            r.findings_rms_sim_valid_ts.is_none() && r.findings_rms_sim_valid_dec2.is_none()
        }));
        let wiener = study.at_ts.nonlinear_model("Wiener1").unwrap();
        assert_eq!(wiener.static_map.input, format!("linear output x ({unit})"));
    }
    // The same data in a 1000× smaller unit: every RMS 1000× larger (the label follows y_unit).
    let oe1 = |s: &Study| s.at_ts.model("OE1").unwrap().rms_sim_valid;
    assert!((oe1(&named) / oe1(&unnamed) - 1e3).abs() < 1e-6 * 1e3);
    use sledid_host::study::data::y_unit_label;
    assert_eq!(y_unit_label(0.001), "0.001 × y-column unit");
    assert_eq!(y_unit_label(1.0), "y-column unit");
}

/// The twin's study: y_unit is the sensor quantum, so figures are in quanta, and findings.md's
/// figures appear as the twin's reference columns (catches losing them for the twin).
#[test]
fn a_twin_study_is_in_quanta_with_its_reference_columns() {
    let study = twin_study(1);
    let table = study.table();
    assert_eq!(study.y_unit_name, "quanta");
    assert!(table.contains("| model (RMS in quanta) |"), "{table}");
    let columns = table_columns(&table);
    assert_eq!(columns.len(), 12, "{table}");
    assert_eq!(columns[3], "twin's reference (findings.md) Ts");
    assert_eq!(columns[8], "CV RMS ident (Ts, ÷2)");
    // The recommended model: one ★ per rate in the table, and its line under it.
    let rec = study.at_ts.recommended.as_ref().unwrap();
    assert!(
        table.contains(&format!("★ recommended at Ts: {} (", rec.model)),
        "{table}"
    );
    assert_eq!(table.matches(" ★ |").count(), 2, "{table}");
    assert!(
        table.contains("| 6.38 | 1.01 |"),
        "ARX1's findings figures: {table}"
    );
    assert!(table.contains("reference values for the twin, not figures of this run"));
}
