//! Fault injection through the replay harness: for each fault, the expected status flag appears
//! within a stated number of samples, the estimator's θ and P stay frozen while it is held and move
//! again after, θ ends within a measured bound of the fault-free run's, no panic, and the trace
//! keeps every sample. `cargo test -p sledid-host --test integration faults:: -- --nocapture` prints the table
//! and the spread kept in RELIABILITY.md.

use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::step::{IdentifierDesign, StuckSensorDesign, reject, step};
use sledid::{Scaling, Status};
use sledid_host::compare::relative_distance;
use sledid_host::faults::{Fault, Injector, Reading};
use sledid_host::recording::{ReaderOptions, read_all};
use sledid_host::replay::{BadSample, ReplaySpec, ReplaySummary, replay};
use sledid_host::twin::{Twin, TwinParams};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

const QUANTUM_M: f64 = 1.6e-6;

/// The twin seed of RELIABILITY.md's table.
const SEED: u64 = 4;

/// Seeds over which the θ error of each fault is measured and bounded
/// ([`theta_error_is_bounded_across_seeds_and_fault_positions`]).
const SEEDS: [u64; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

// Bounds on the relative θ error after a fault, against the fault-free run of the same recording.
// Each is twice the largest error measured by `theta_error_is_bounded_across_seeds_and_fault_positions`
// (`cargo test -p sledid-host --test integration faults::theta_error -- --nocapture`), which asserts it on every
// case it measures: 29 cases (the 8 seeds at the nominal sample, seed 4 with the fault moved
// −10…+10 samples), 11 for the stuck sensor (seed 4, start 15…25). The errors spread 2–30× across
// cases, so twice the worst is a change of behaviour, not of luck. Measured (min … max):
//   spike +200 q:   2.1e-6 … 6.6e-5  → 1.4e-4; with the outlier gate off 0.18 … 0.33 on the same cases
//   NaN:            3.6e-6 … 7.1e-5  → 1.5e-4
//   30 lost:        2.1e-5 … 4.0e-4  → 8.0e-4
//   stuck 200:      2.6e-3 … 5.0e-3  → 1.0e-2; detected one sample later (`samples: 3`) 0.43 at
//                   start 20 (0.37 … 0.49 for starts 16…23; at 15, 24, 25 it costs nothing)
// The NaN and lost-reading bounds only catch gross errors (a state reset, a sample that enters the
// estimator with a wrong lag): feeding the held reading to the estimator as data ends within the
// same range (measured once as a stuck sensor over the same samples with the stuck check off, seed
// 4, 21 positions: 0 … 1.4e-4 and 7.2e-5 … 2.3e-4); the frozen-state checks catch that.

/// θ error bound after a +200-quantum spike (see above).
const SPIKE_THETA_BOUND: f64 = 1.4e-4;
/// θ error bound after one NaN reading.
const NAN_THETA_BOUND: f64 = 1.5e-4;
/// θ error bound after 30 lost readings.
const MISSING_THETA_BOUND: f64 = 8.0e-4;
/// θ error bound after a sensor stuck for 200 samples while seeking, detected within 2 samples.
const STUCK_THETA_BOUND: f64 = 1.0e-2;

/// The twin recording of `seed` (4 seeks, 2,896 samples for seed 4), written once: the well-damped
/// baseline (`host-tests/plants/well_damped.json`), on which RELIABILITY.md's table was measured.
/// Its ±1 limit cycle changes sign every ~6 samples, so the data after a fault keep exciting the
/// identifier. On the default (the paper's loop, one sign change every ~38 samples) the reversed
/// sensor from sample 1500 was measured: b₁+b₂ never changes sign before the recording ends.
fn recording_of(seed: u64) -> PathBuf {
    static FILES: Mutex<Vec<(u64, PathBuf)>> = Mutex::new(Vec::new());
    let mut files = FILES.lock().expect("recording cache");
    if let Some((_, file)) = files.iter().find(|(s, _)| *s == seed) {
        return file.clone();
    }
    let dir = std::env::temp_dir().join(format!("sledid-faults-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let mut params = TwinParams::well_damped();
    params.reference.seek_count = 4;
    let twin = Twin::run_baseline(params, seed).expect("twin");
    let file = dir.join(format!("twin-{seed}.csv"));
    twin.write_csv(&file).expect("csv");
    files.push((seed, file.clone()));
    file
}

fn spec(faults: Vec<Fault>) -> ReplaySpec {
    let mut s = ReplaySpec::new(ReaderOptions::new(
        "u=u_v,y=y_m,r=r_m,t=t_s".parse().expect("mapping"),
    ));
    s.y_unit = QUANTUM_M;
    s.u_full_scale = 5.0;
    s.rls.outlier_threshold = 20.0; // quanta per sample: a seek moves up to ~30
    s.rls.outlier_limit = 16;
    s.stuck_sensor = Some(StuckSensorDesign {
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
    run_with(SEED, name, &spec(faults))
}

/// Replays the recording of `seed` with `spec` into a directory of its own (tests run in
/// parallel and replay the same cases).
fn run_with(seed: u64, name: &str, spec: &ReplaySpec) -> Run {
    static RUNS: AtomicUsize = AtomicUsize::new(0);
    let file = recording_of(seed);
    let unique = RUNS.fetch_add(1, Ordering::Relaxed);
    let out = file
        .parent()
        .expect("dir")
        .join(format!("{name}-seed{seed}-{unique}"));
    let summary = replay(&file, spec, &out).expect("replay never fails with Hold");
    let trace = std::fs::read_to_string(out.join("trace.csv")).expect("trace");
    let _ = std::fs::remove_dir_all(&out);
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

/// The identifier's θ and UD factors of P after one sample.
type Estimate = (
    [sledid::ParamI12F20; 4],
    [[i32; 4]; 4],
    [sledid::num::dyadic::Dyadic; 4],
);

/// The replay's per-sample path (`sledid_host::replay`: injector, boundary, `step` or `reject`)
/// run here so the identifier's state is visible: flags and the estimate after every sample of the
/// recording of `seed`. Checked against the replay's own trace (flags and b₁ + b₂ identical).
fn estimates(seed: u64, faults: Vec<Fault>) -> (Vec<Status>, Vec<Estimate>) {
    let spec = spec(faults.clone());
    let mut model = LinearDesign::<4>::new(spec.structure, spec.order.0, spec.order.1);
    assert_eq!((spec.structure, spec.order), (Structure::Arx, (2, 2)));
    model.rls = spec.rls;
    let mut design = IdentifierDesign::new(spec.conditioning, model);
    design.stuck_sensor = spec.stuck_sensor;
    let cfg = design.build().expect("design");
    let scaling = Scaling::new(spec.y_unit, spec.u_full_scale).expect("scaling");
    let recording = read_all(recording_of(seed), &spec.reader).expect("recording");
    let mut injector = Injector::new(faults.clone());
    let mut st = cfg.new_state();
    let (mut flags, mut states) = (Vec::new(), Vec::new());
    for (k, s) in recording.samples.iter().enumerate() {
        let sample = match injector.apply(k, *s) {
            Reading::Present(x) => scaling.sample(x.y, x.u, x.r.unwrap_or(0.0)).ok(),
            Reading::Missing => None,
        };
        let o = match sample {
            Some(sample) => step(&cfg, &mut st, &sample),
            None => reject(&cfg, &mut st),
        };
        let rls = st.model().rls();
        flags.push(o.status);
        states.push((*rls.theta(), *rls.u_i8f24(), *rls.d()));
    }
    let replayed = run_with(seed, "estimates", &spec);
    assert_eq!(flags, replayed.flags, "the same path as the replay");
    let b_sum: Vec<f64> = states
        .iter()
        .map(|(theta, _, _)| theta[2].to_f64() + theta[3].to_f64())
        .collect();
    assert_eq!(b_sum, replayed.theta_b_sum, "the same θ as the replay");
    (flags, states)
}

/// θ and P (U and D) identical on samples `held` to the estimate after `held.start − 1`; the
/// first update from `resume_from` on comes within `within` samples and changes θ and P.
/// Catches an estimator that keeps updating θ, or keeps inflating P by 1/λ, while it reports a
/// hold, and a hold that is never released.
fn assert_frozen_then_moving(
    name: &str,
    (flags, states): &(Vec<Status>, Vec<Estimate>),
    held: std::ops::Range<usize>,
    resume_from: usize,
    within: usize,
) {
    let before = states[held.start - 1];
    for k in held.clone() {
        assert!(
            !flags[k].contains(Status::UPDATED),
            "{name}: updated at {k}"
        );
        assert_eq!(states[k].0, before.0, "{name}: θ moved at {k}");
        assert_eq!(
            (states[k].1, states[k].2),
            (before.1, before.2),
            "{name}: P moved at {k}"
        );
    }
    let resumed = first(flags, resume_from, Status::UPDATED)
        .unwrap_or_else(|| panic!("{name}: never updated again after {resume_from}"));
    println!("{name}: held over {held:?}, first update {resumed} samples after {resume_from}");
    assert!(
        resumed <= within,
        "{name}: resumed {resumed} samples after {resume_from}"
    );
    let k = resume_from + resumed;
    let held_estimate = states[k - 1];
    assert_ne!(
        states[k].0, held_estimate.0,
        "{name}: θ did not move at {k}"
    );
    assert_ne!(
        (states[k].1, states[k].2),
        (held_estimate.1, held_estimate.2),
        "{name}: P did not move at {k}"
    );
}

/// θ error after `fault` on the recording of `seed` with `spec`, against the fault-free run.
fn theta_error(seed: u64, name: &str, mut spec: ReplaySpec, fault: Fault) -> f64 {
    spec.faults = vec![];
    let clean = run_with(seed, "clean", &spec);
    spec.faults = vec![fault];
    let faulty = run_with(seed, name, &spec);
    relative_distance(&faulty.summary.theta, &clean.summary.theta)
}

/// Prints min / median / max of `errors` and asserts every one within `bound`.
fn assert_spread(name: &str, errors: &[f64], bound: f64) {
    let mut sorted = errors.to_vec();
    sorted.sort_by(f64::total_cmp);
    println!(
        "{name}: {} cases, θ error min {:.1e} median {:.1e} max {:.1e} (bound {bound:.1e})",
        sorted.len(),
        sorted[0],
        sorted[sorted.len() / 2],
        sorted[sorted.len() - 1]
    );
    for (i, e) in errors.iter().enumerate() {
        assert!(
            *e <= bound,
            "{name}: case {i}: θ error {e:.2e} > {bound:.1e}"
        );
    }
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
    assert!(err <= SPIKE_THETA_BOUND, "θ moved {err}");
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
    assert!(err <= NAN_THETA_BOUND, "θ moved {err}");
    // Rejected at 1000, re-priming at 1001 (Δy needs two readings): frozen; updated at 1002.
    let e = estimates(SEED, vec![Fault::NotFinite { at: 1_000 }]);
    assert_frozen_then_moving("NaN at 1000", &e, 1_000..1_002, 1_002, 0);
}

#[test]
fn lost_readings_are_held_and_kept_in_the_trace() {
    let r = run("missing", vec![Fault::Missing { from: 800, len: 30 }]);
    assert_eq!(count(&r.flags, Status::INPUT_REJECTED), 30);
    assert!(r.flags[830].contains(Status::WARMUP));
    let err = relative_distance(&r.summary.theta, &clean().summary.theta);
    row(
        "30 readings lost from 800",
        "input_rejected ×30",
        first(&r.flags, 800, Status::INPUT_REJECTED),
        30,
        err,
        "θ and P frozen, 30 trace rows kept",
    );
    assert!(err <= MISSING_THETA_BOUND, "θ moved {err}");
    // Lost 800…829, re-priming at 830: θ and P frozen; the next sample updates (measured).
    let e = estimates(SEED, vec![Fault::Missing { from: 800, len: 30 }]);
    assert_frozen_then_moving("30 lost from 800", &e, 800..831, 831, 0);
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
    assert!(err <= STUCK_THETA_BOUND, "θ moved {err}");
    // From detection to the end of the fault, θ and P do not move at all. When the sensor comes
    // back (220) its catch-up jump and the two samples that carry it as a lag in ARX(2,2)'s
    // regressor are gated as outliers (measured: 220, 221, 222), then adaptation resumes.
    let e = estimates(SEED, vec![Fault::Stuck { from: 20, len: 200 }]);
    assert_frozen_then_moving("stuck 20…219", &e, 20 + lat..220, 220, 3);
}

/// The θ bounds above, on every case they were measured on (see their comment), plus the stuck
/// sensor on the other seeds, printed: where the check detects within 2 samples (seeds 1, 4, 6, 8)
/// θ ends 1.8e-4 … 4.2e-3 off, within its bound; each update before a later detection costs
/// more (seed 2: latency 7, 4.7e-4; seed 5: latency 4, 3.8e-2); on seeds 3 and 7 the drive at
/// sample 20 is below the check's 0.1 of full scale and it never arms (by design; 1.9e-4, 7.6e-2).
#[test]
fn theta_error_is_bounded_across_seeds_and_fault_positions() {
    let spike = |at| Fault::Spike {
        at,
        mag: 200.0 * QUANTUM_M,
        every: 0,
    };
    let nan = |at| Fault::NotFinite { at };
    let missing = |from| Fault::Missing { from, len: 30 };
    let stuck = |from| Fault::Stuck { from, len: 200 };
    let cases = |name: &str, fault: &dyn Fn(usize) -> Fault, at: usize| -> Vec<f64> {
        let seeds = SEEDS
            .iter()
            .map(|&seed| theta_error(seed, name, spec(vec![]), fault(at)));
        let positions =
            (at - 10..=at + 10).map(|k| theta_error(SEED, name, spec(vec![]), fault(k)));
        seeds.chain(positions).collect()
    };
    assert_spread("spike", &cases("spike", &spike, 1_200), SPIKE_THETA_BOUND);
    assert_spread("NaN", &cases("nan", &nan, 1_000), NAN_THETA_BOUND);
    assert_spread(
        "30 lost",
        &cases("missing", &missing, 800),
        MISSING_THETA_BOUND,
    );
    let stuck_positions: Vec<f64> = (15..=25)
        .map(|from| theta_error(SEED, "stuck", spec(vec![]), stuck(from)))
        .collect();
    assert_spread("stuck, seed 4", &stuck_positions, STUCK_THETA_BOUND);
    for seed in SEEDS {
        let r = run_with(seed, "stuck", &spec(vec![stuck(20)]));
        let err = theta_error(seed, "stuck", spec(vec![]), stuck(20));
        let lat = first(&r.flags, 20, Status::SENSOR_STUCK);
        println!("stuck from 20, seed {seed}: detected after {lat:?} samples, θ error {err:.1e}");
        if lat.is_some_and(|l| l <= 2) {
            assert!(err <= STUCK_THETA_BOUND, "seed {seed}: θ error {err:.2e}");
        }
    }
}

/// The bounds trip on the bugs they guard: a spike the outlier gate lets through (gate off) ends
/// 0.18 … 0.26 off on the 8 seeds, a stuck sensor detected one sample later (`samples: 3`) 0.43 off.
#[test]
fn theta_bounds_trip_without_the_gate_or_with_late_stuck_detection() {
    for seed in SEEDS {
        let mut no_gate = spec(vec![]);
        no_gate.rls.outlier_threshold = 0.0;
        let fault = Fault::Spike {
            at: 1_200,
            mag: 200.0 * QUANTUM_M,
            every: 0,
        };
        let err = theta_error(seed, "spike-nogate", no_gate, fault);
        println!("spike without the outlier gate, seed {seed}: θ error {err:.2e}");
        assert!(err > 100.0 * SPIKE_THETA_BOUND, "seed {seed}: {err}");
    }
    let mut late = spec(vec![]);
    late.stuck_sensor = Some(StuckSensorDesign {
        samples: 3,
        min_drive: 0.1,
    });
    let err = theta_error(
        SEED,
        "stuck-late",
        late,
        Fault::Stuck { from: 20, len: 200 },
    );
    println!("stuck sensor detected one sample later: θ error {err:.2e}");
    assert!(err > 10.0 * STUCK_THETA_BOUND, "{err}");
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
