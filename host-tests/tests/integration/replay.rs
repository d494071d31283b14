//! `replay` end to end on every bundled dataset: every row replayed through the per-sample step,
//! trace and summary written, and the fixed-point estimate within tolerance of float64.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::recording::ReaderOptions;
use sledid_host::replay::{Rate, ReplaySpec, replay};
use std::path::PathBuf;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data")).join(rel)
}

fn out_dir(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("sledid-replay-test-{}-{name}", std::process::id()))
}

fn spec(
    columns: &str,
    ts: Option<f64>,
    conditioning: Conditioning,
    y_unit: f64,
    u_full_scale: f64,
) -> ReplaySpec {
    let mut reader = ReaderOptions::new(columns.parse().expect("mapping"));
    reader.ts_s = ts;
    let mut s = ReplaySpec::new(reader);
    s.conditioning = conditioning;
    s.y_unit = y_unit;
    s.u_full_scale = u_full_scale;
    s.progress = false;
    s
}

fn check(name: &str, file: PathBuf, s: &ReplaySpec, rows: usize, tol: f64) {
    let out = out_dir(name);
    let sum = replay(&file, s, &out).expect("replay");
    println!(
        "{name}: {} samples, θ rel. err {:.2e}, sim RMS {:.4} vs f64 {:.4}, {:.3} s",
        sum.samples, sum.theta_rel_err, sum.sim_rms, sum.sim_rms_f64, sum.wall_s
    );
    assert_eq!(sum.samples, rows, "{name}: every row replayed");
    let trace = std::fs::read_to_string(out.join("trace.csv")).expect("trace");
    assert_eq!(
        trace.lines().count(),
        rows + 1,
        "{name}: one trace line per sample"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary"))
            .expect("json");
    for key in [
        "samples",
        "ts_s",
        "rate",
        "wall_s",
        "theta",
        "theta_f64",
        "sim_rms",
        "flags",
    ] {
        assert!(summary.get(key).is_some(), "{name}: summary lacks {key}");
    }
    assert!(sum.flags["updated"] > rows / 2, "{name}: {:?}", sum.flags);
    assert!(
        sum.theta_rel_err < tol,
        "{name}: θ rel. err {}",
        sum.theta_rel_err
    );
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn emps_velocity_model() {
    let s = spec(
        "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s",
        None,
        Conditioning::DifferencedOutput,
        1e-5,
        10.0,
    );
    check("emps", data("emps/DATA_EMPS.csv"), &s, 24_841, 1e-3);
}

#[test]
fn silverbox_arx() {
    let mut s = spec(
        "u=V1,y=V2",
        Some(1.0 / 610.35),
        Conditioning::None,
        1e-3,
        0.1,
    );
    s.rls = RlsDesign {
        lambda: 1.0,
        p0: 10.0,
        anti_windup: AntiWindup::None,
        ..RlsDesign::default()
    };
    check(
        "silverbox",
        data("silverbox/SNLS80mV.csv"),
        &s,
        131_072,
        1e-3,
    );
}

#[test]
fn daisy_cd_arm_arx() {
    let mut s = spec(
        "u=u2_force,y=y2_tracking",
        Some(1.0),
        Conditioning::None,
        0.01,
        1.0,
    );
    s.rls = RlsDesign {
        lambda: 1.0,
        p0: 10.0,
        anti_windup: AntiWindup::None,
        ..RlsDesign::default()
    };
    check("daisy", data("daisy/cd_player_arm.csv"), &s, 2_048, 1e-3);
}

#[test]
fn paced_replay_reports_deadlines() {
    // The first 400 rows of EMPS, replayed at 20× real time (50 µs per sample).
    let text = std::fs::read_to_string(data("emps/DATA_EMPS.csv")).expect("emps");
    let excerpt: String = text.lines().take(401).map(|l| format!("{l}\n")).collect();
    let dir = out_dir("paced");
    std::fs::create_dir_all(&dir).expect("dir");
    let file = dir.join("excerpt.csv");
    std::fs::write(&file, excerpt).expect("write");
    let mut s = spec(
        "u=vir_ctrl_V,y=qm_meas_pos_m,t=t_s",
        None,
        Conditioning::DifferencedOutput,
        1e-5,
        10.0,
    );
    s.rate = Rate::Paced(20.0);
    let sum = replay(&file, &s, &dir.join("out")).expect("replay");
    let d = sum.deadline.expect("deadline statistics");
    println!(
        "paced ×20: lateness p50 {:.1} µs p99 {:.1} µs max {:.1} µs, overruns {}",
        d.p50_us, d.p99_us, d.max_us, d.overruns
    );
    assert_eq!(sum.samples, 400);
    // (p50 ≤ p99 ≤ max holds by construction of sorted data: `percentile_matches_a_brute_force_rank`
    // checks the quantiles themselves.) Stepping takes time: a zero means the clock was not read.
    assert!(d.work_p50_us > 0.0, "work p50 {}", d.work_p50_us);
    // Stall attribution: a subset of the overruns; a stall is at least STALL_US long.
    assert!(d.overruns_after_stall <= d.overruns);
    assert!(d.stalls.count == 0 || d.stalls.max_us >= sledid_host::pacing::STALL_US);
    assert!(d.stalls.lost_us >= d.stalls.count as f64 * sledid_host::pacing::STALL_US);
    // Every overrun after a stall needs a stall to begin its backlog.
    assert!(d.overruns_after_stall == 0 || d.stalls.count > 0);
    // 400 samples at 50 µs cannot take less than 20 ms.
    assert!(sum.wall_s >= 400.0 * 50e-6 * 0.99, "wall {}", sum.wall_s);
    let _ = std::fs::remove_dir_all(dir);
}

/// The deadline statistics' quantile against its definition, computed without indexing: v is the
/// p-quantile iff #{x < v} ≤ round((n − 1)·p) < #{x ≤ v}. On shuffled data with repeated values,
/// for n = 1…60 and p on a grid including 0, 0.5, 0.99 and 1. Catches a wrong rank (n·p, floor
/// instead of round, an off-by-one) and an out-of-range index at p = 1.
#[test]
fn percentile_matches_a_brute_force_rank() {
    use sledid_host::replay::percentile;
    assert_eq!(percentile(&[], 0.5), 0.0);
    let mut state = 12_345u64;
    for n in 1..=60usize {
        let mut data: Vec<f64> = (0..n)
            .map(|_| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                ((state >> 33) % 17) as f64 * 0.25
            })
            .collect();
        data.sort_by(f64::total_cmp);
        for p in (0..=100)
            .map(|i| f64::from(i) / 100.0)
            .chain([0.5, 0.99, 0.999])
        {
            let v = percentile(&data, p);
            let rank = ((n - 1) as f64 * p).round() as usize;
            let below = data.iter().filter(|&&x| x < v).count();
            let at_or_below = data.iter().filter(|&&x| x <= v).count();
            assert!(
                below <= rank && rank < at_or_below,
                "n {n} p {p}: {v} has {below} below, {at_or_below} at or below, rank {rank}"
            );
        }
    }
    // By hand: 1..=100 → p50 is rank round(49.5) = 50 (value 51), p99 rank 98 (value 99).
    let hundred: Vec<f64> = (1..=100).map(f64::from).collect();
    assert_eq!(percentile(&hundred, 0.5), 51.0);
    assert_eq!(percentile(&hundred, 0.99), 99.0);
    assert_eq!(percentile(&hundred, 1.0), 100.0);
}

#[test]
fn a_sample_outside_the_format_stops_the_replay_naming_it() {
    // A position unit of 1e-12 m puts EMPS far outside the I48F16 range on the first moving sample.
    let s = spec(
        "u=vir_ctrl_V,y=qm_meas_pos_m,t=t_s",
        None,
        Conditioning::DifferencedOutput,
        1e-30,
        10.0,
    );
    let err = replay(&data("emps/DATA_EMPS.csv"), &s, &out_dir("bad")).expect_err("must fail");
    assert!(err.contains("sample 0"), "{err}");
    assert!(err.contains("position"), "{err}");
    let _ = std::fs::remove_dir_all(out_dir("bad"));
}

/// The paper's second-order nonlinear models replayed on Silverbox (a real cubic spring) through the
/// same per-sample step: each starts from the linear OE2 the replay identifies first, beats it in
/// simulation on the whole record, and its fixed-point simulation RMS is within 2 % of the float64
/// twin's (θ itself is not compared: a neuron has flat directions — (w, a) ~ (−w, −a), and a
/// barely-used neuron's a, c are ill-determined).
#[test]
fn silverbox_nonlinear_models_beat_their_linear_start() {
    use sledid::ident::linear::Structure;
    use sledid::ident::nonlinear::NonlinearStructure;
    let mut s = spec(
        "u=V1,y=V2",
        Some(1.0 / 610.35),
        Conditioning::None,
        1e-3,
        1.0,
    );
    s.rls = RlsDesign {
        lambda: 0.9995,
        p0: 10.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    };
    s.structure = Structure::OutputErrorPredictionError;
    s.order = (2, 2);
    let file = data("silverbox/SNLS80mV.csv");
    let linear = replay(&file, &s, &out_dir("sb-oe2")).expect("replay");
    for structure in [
        NonlinearStructure::Noe221,
        NonlinearStructure::FrictionFeedback,
    ] {
        s.nonlinear = Some(structure);
        let nl = replay(&file, &s, &out_dir(structure.name())).expect("replay");
        println!(
            "silverbox {}: sim RMS {:.3} (f64 {:.3}) vs OE2 {:.3} mV",
            structure.name(),
            nl.sim_rms,
            nl.sim_rms_f64,
            linear.sim_rms
        );
        assert_eq!(nl.samples, 131_072);
        assert!(nl.sim_rms < 0.9 * linear.sim_rms, "{}", structure.name());
        assert!(
            (nl.sim_rms / nl.sim_rms_f64 - 1.0).abs() < 0.02,
            "{}",
            structure.name()
        );
    }
    // Issue 17's measurement: in a 0.1 mV unit the fixed point ended 71 % worse than its twin
    // (166.8 against 97.6) when the boundary took the user's unit as is; normalised, the same
    // recording in any unit gives the same model (98.34 against 98.14 measured: ten times the
    // 1 mV figures, 9.834 against 9.814).
    s.nonlinear = Some(NonlinearStructure::Noe221);
    s.y_unit = 1e-4;
    let nl = replay(&file, &s, &out_dir("noe221-0.1mV")).expect("replay");
    println!(
        "silverbox NOE221 at 0.1 mV: {:.2} (f64 {:.2})",
        nl.sim_rms, nl.sim_rms_f64
    );
    assert!((nl.sim_rms / nl.sim_rms_f64 - 1.0).abs() < 0.02);
}
