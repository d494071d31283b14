//! Fault injection through the replay harness: for each fault, the expected status flag appears
//! within a stated number of samples, the estimator freezes or recovers as documented, no panic,
//! and the trace keeps every sample. `cargo test -p sledid-host --test faults -- --nocapture`
//! prints the table kept in RELIABILITY.md.

use sledid::Status;
use sledid_host::compare::relative_distance;
use sledid_host::faults::Fault;
use sledid_host::recording::ReaderOptions;
use sledid_host::replay::{BadSample, ReplaySpec, ReplaySummary, replay};
use sledid_host::twin::{Twin, TwinParams};
use std::path::PathBuf;
use std::sync::OnceLock;

const QUANTUM_M: f64 = 1.6e-6;

/// One twin recording (4 seeks, 2,896 samples) shared by every test: the well-damped baseline
/// (`host-tests/plants/well_damped.json`), on which RELIABILITY.md's table was measured. Its ±1
/// limit cycle changes sign every ~6 samples, so the data after a fault keep exciting the
/// identifier. On the default (the paper's loop, one sign change every ~38 samples) the reversed
/// sensor from sample 1500 was measured: b₁+b₂ never changes sign before the recording ends.
fn recording() -> &'static PathBuf {
    static FILE: OnceLock<PathBuf> = OnceLock::new();
    FILE.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("sledid-faults-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let mut params = TwinParams::well_damped();
        params.reference.seek_count = 4;
        let twin = Twin::run_baseline(params, 4).expect("twin");
        let file = dir.join("twin.csv");
        twin.write_csv(&file).expect("csv");
        file
    })
}

fn spec(faults: Vec<Fault>) -> ReplaySpec {
    let mut s = ReplaySpec::new(ReaderOptions::new(
        "u=u_v,y=y_m,r=r_m,t=t_s".parse().expect("mapping"),
    ));
    s.y_unit = QUANTUM_M;
    s.u_full_scale = 5.0;
    s.rls.outlier_threshold = 20.0; // quanta per sample: a seek moves up to ~30
    s.rls.outlier_limit = 16;
    s.stuck_sensor = Some(sledid::ident::step::StuckSensorDesign {
        samples: 2,
        min_drive: 0.1,
    });
    s.on_bad_sample = BadSample::Hold;
    s.progress = false;
    s.faults = faults;
    s
}

struct Run {
    summary: ReplaySummary,
    flags: Vec<Status>,
    theta_b_sum: Vec<f64>,
}

fn run(name: &str, faults: Vec<Fault>) -> Run {
    let out = recording().parent().expect("dir").join(name);
    let summary = replay(recording(), &spec(faults), &out).expect("replay never fails with Hold");
    let trace = std::fs::read_to_string(out.join("trace.csv")).expect("trace");
    let mut flags = Vec::new();
    let mut theta_b_sum = Vec::new();
    for line in trace.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        flags.push(Status::from_bits(
            cols.last().and_then(|x| x.parse().ok()).expect("flags"),
        ));
        // Columns: t_s,u,y,y_c,u_c,y_hat,eps,theta0..3,flags → b1 + b2 = theta2 + theta3.
        theta_b_sum
            .push(cols[9].parse::<f64>().expect("b1") + cols[10].parse::<f64>().expect("b2"));
    }
    assert_eq!(
        flags.len(),
        summary.samples,
        "{name}: one trace line per sample"
    );
    Run {
        summary,
        flags,
        theta_b_sum,
    }
}

fn clean() -> &'static Run {
    static CLEAN: OnceLock<Run> = OnceLock::new();
    CLEAN.get_or_init(|| run("clean", vec![]))
}

fn first(flags: &[Status], from: usize, flag: Status) -> Option<usize> {
    flags
        .iter()
        .enumerate()
        .skip(from)
        .find(|(_, f)| f.contains(flag))
        .map(|(k, _)| k - from)
}

fn count(flags: &[Status], flag: Status) -> usize {
    flags.iter().filter(|f| f.contains(flag)).count()
}

fn row(
    fault: &str,
    expected: &str,
    latency: Option<usize>,
    flagged: usize,
    theta_err: f64,
    note: &str,
) {
    println!(
        "| {fault} | {expected} | {} | {flagged} | {theta_err:.1e} | {note} |",
        latency.map_or("—".into(), |l| l.to_string())
    );
}

#[test]
fn clean_run_raises_no_fault_flag() {
    let c = clean();
    assert_eq!(c.summary.samples, 2_896);
    for flag in [
        Status::OUTLIER,
        Status::SENSOR_STUCK,
        Status::INPUT_REJECTED,
        Status::SATURATED,
    ] {
        assert_eq!(count(&c.flags, flag), 0, "{flag:?} in the clean run");
    }
    row("none", "—", None, 0, 0.0, "reference run");
}

#[test]
fn spike_is_gated_and_leaves_theta_alone() {
    let r = run(
        "spike",
        vec![Fault::Spike {
            at: 1_200,
            mag: 200.0 * QUANTUM_M,
            every: 0,
        }],
    );
    let lat = first(&r.flags, 1_200, Status::OUTLIER);
    let err = relative_distance(&r.summary.theta, &clean().summary.theta);
    row(
        "spike +200 q at 1200",
        "outlier",
        lat,
        count(&r.flags, Status::OUTLIER),
        err,
        "Δy spikes up then down: both gated",
    );
    assert_eq!(lat, Some(0));
    assert!(count(&r.flags, Status::OUTLIER) <= 4);
    assert!(err < 1e-2, "θ moved {err}");
}

#[test]
fn nan_reading_is_rejected_then_recovered() {
    let r = run("nan", vec![Fault::NotFinite { at: 1_000 }]);
    assert!(r.flags[1_000].contains(Status::INPUT_REJECTED));
    assert!(
        r.flags[1_001].contains(Status::WARMUP),
        "conditioning re-primes: {:?}",
        r.flags[1_001]
    );
    assert!(r.flags[1_002].contains(Status::UPDATED));
    let err = relative_distance(&r.summary.theta, &clean().summary.theta);
    row(
        "NaN at 1000",
        "input_rejected, warmup",
        first(&r.flags, 1_000, Status::INPUT_REJECTED),
        1,
        err,
        "held one sample, re-primed",
    );
    assert!(err < 1e-2, "θ moved {err}");
}

#[test]
fn lost_readings_are_held_and_kept_in_the_trace() {
    let r = run("missing", vec![Fault::Missing { from: 800, len: 30 }]);
    assert_eq!(count(&r.flags, Status::INPUT_REJECTED), 30);
    assert!(r.flags[830].contains(Status::WARMUP));
    // θ is frozen while the readings are lost.
    assert!((800..830).all(|k| r.theta_b_sum[k] == r.theta_b_sum[799]));
    let err = relative_distance(&r.summary.theta, &clean().summary.theta);
    row(
        "30 readings lost from 800",
        "input_rejected ×30",
        first(&r.flags, 800, Status::INPUT_REJECTED),
        30,
        err,
        "θ frozen, 30 trace rows kept",
    );
    assert!(err < 5e-2, "θ moved {err}");
}

#[test]
fn stuck_sensor_holds_the_estimator() {
    // From sample 20, in the middle of the first seek (|u| ≈ 0.4 of full scale).
    let r = run("stuck", vec![Fault::Stuck { from: 20, len: 200 }]);
    let lat = first(&r.flags, 20, Status::SENSOR_STUCK).expect("stuck sensor detected");
    // Detected on the 2nd driven sample without movement. Late detection is what hurts: ARX
    // regresses on measured lags, so after one gated sample a frozen y is *predictable* (a₁ → −1,
    // b → 0 within 4 updates: measured with `samples: 4`, θ ended 43 % off). A false alarm (Δy = 0
    // for 2 samples at a reversal) only holds adaptation while it lasts.
    assert!(lat <= 2, "latency {lat}");
    // From detection to the end of the fault: held, no update.
    let held = (20 + lat..220).all(|k| {
        r.flags[k].contains(Status::SENSOR_STUCK)
            || r.flags[k].contains(Status::OUTLIER)
            || !r.flags[k].contains(Status::UPDATED)
    });
    assert!(held, "updates while stuck");
    let stuck_updates = (20..220)
        .filter(|&k| r.flags[k].contains(Status::UPDATED))
        .count();
    let err = relative_distance(&r.summary.theta, &clean().summary.theta);
    row(
        "stuck 200 samples from 20 (seeking)",
        "outlier (1st), sensor_stuck",
        Some(lat),
        count(&r.flags, Status::SENSOR_STUCK),
        err,
        &format!(
            "ARX's measured lags adapt to the frozen y within 2 samples: {stuck_updates} updates before the hold"
        ),
    );
    assert!(stuck_updates <= 1);
    assert!(err < 0.1, "θ moved {err}");
}

#[test]
fn reversed_sensor_is_followed_after_the_outlier_limit() {
    let r = run("flip", vec![Fault::Flip { from: 1_500 }]);
    let lat = first(&r.flags, 1_500, Status::OUTLIER);
    let sign_before = r.theta_b_sum[1_499].signum();
    let followed = r
        .theta_b_sum
        .iter()
        .enumerate()
        .skip(1_500)
        .find(|(_, b)| b.signum() == -sign_before)
        .map(|(k, _)| k - 1_500);
    row(
        "sensor sign reversed from 1500",
        "outlier ×≤16, then re-adaptation",
        lat,
        count(&r.flags, Status::OUTLIER),
        f64::NAN,
        &format!("b₁+b₂ changes sign after {followed:?} samples"),
    );
    assert!(lat.is_some_and(|l| l <= 2), "latency {lat:?}");
    assert!(
        followed.is_some(),
        "the estimator never followed the reversed sign"
    );
}
