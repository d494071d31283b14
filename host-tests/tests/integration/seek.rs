//! Seeks as commands (`sledid seek`, `sledid_host::control::seek`, issue 14): the access time
//! against the minimum-time bound of the true plant, per seek.
//!
//! - the bound's own bang-bang drive, played open loop in the twin's loop, reaches the band for
//!   good exactly at the bound (the bound and the access time see the same physics and readings);
//! - no closed-loop run beats the bound, on the nominal sled and on 30 plants of the family, under
//!   the baseline, the seek mode and the servo following the S-curve;
//! - a seek that never settles, or whose dwell is shorter than 10 ms, is unsettled and counts with
//!   its whole length;
//! - on the nominal sled, what the controllers measure (the seek mode against issue 14's targets);
//! - the command writes its files and refuses bad arguments, naming them.

use std::cell::Cell;
use std::path::PathBuf;
use std::process::Command;

use sledid_host::control::design_from_prior;
use sledid_host::control::family::FamilyRanges;
use sledid_host::control::seek::{
    SeekController, SeekOptions, SeekSummary, access_samples, rows_of, run_seeks, seek_design,
};
use sledid_host::twin::{
    PlantParams, ReferenceProfile, SeekDistribution, Twin, TwinParams, min_time_seek,
};

fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sledid-seek-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A twin of `plant` visiting log-uniform targets with step references.
fn step_twin(plant: &PlantParams, seeks: u32, dwell_s: f64, seed: u64) -> Twin {
    let mut params = TwinParams {
        plant: plant.clone(),
        ..TwinParams::default()
    };
    params.reference.seek_count = seeks;
    params.reference.seek_distribution = SeekDistribution::LogUniform;
    params.reference.profile = ReferenceProfile::Step;
    params.reference.dwell_s = dwell_s;
    Twin::new(params, seed).unwrap()
}

/// Runs `twin` with, at each command, the bound's drive from where the sled is, played open loop.
fn play_the_bound(twin: &mut Twin) {
    let plant = twin.params().plant.clone();
    let x = Cell::new(0.0);
    let (mut plan, mut i, mut last_r) = (Vec::new(), 0, f64::NAN);
    let mut controller = |r: f64, _y: f64| {
        if r != last_r {
            last_r = r;
            plan = min_time_seek(&plant, x.get(), r as i64)
                .map(|b| b.drive_v)
                .unwrap_or_default();
            i = 0;
        }
        i += 1;
        plan.get(i - 1).copied().unwrap_or(0.0)
    };
    loop {
        x.set(twin.plant().position_m());
        if twin.step(&mut controller).is_none() {
            break;
        }
    }
}

/// The bound's drive, played open loop on a noise-free sensor, has the bound as its access time,
/// to the sample, on every seek of the nominal sled and of a slow, sticky one (both directions).
/// Trips on an access time or a bound off by a sample, a bound on other physics than the twin's,
/// a drive that does not do what the bound says, or a bound whose band is on the true position
/// (|x − T| ≤ 1 quantum) instead of the reading (checked: a 41-track seek then has access 3.19 ms
/// against a bound of 3.64).
#[test]
fn the_bounds_drive_played_open_loop_has_the_bound_as_access_time() {
    let nominal = PlantParams {
        noise_m: 0.0,
        ..PlantParams::default()
    };
    let slow = PlantParams {
        mass_kg: 0.2,
        viscous_n_s_per_m: 200.0,
        force_per_volt_n_per_v: 1.2,
        coulomb_n: 0.15,
        static_n: 0.4,
        ..nominal.clone()
    };
    for plant in [nominal, slow] {
        let mut twin = step_twin(&plant, 40, 0.3, 3);
        play_the_bound(&mut twin);
        let rows = rows_of(&twin);
        assert_eq!(rows.len(), 40);
        assert!(rows.iter().any(|r| r.distance_tracks < 0));
        for r in &rows {
            assert!(r.settled, "{r:?}");
            assert_eq!(Some(r.access_ms), r.bound_ms, "{r:?}");
            assert_eq!(r.limit_cycle_pulses, 0);
        }
    }
}

/// No controller reaches the band for good sooner than the bound. The bound is defined on the
/// noise-free readings `round(x/q)` (`twin::bound`), so the check is too: every seek's access
/// time recomputed on the true positions of its run is ≥ its bound, under the baseline, the seek
/// mode and the servo following the S-curve, on the nominal sled and plants 0–29 of family
/// seed 1. Measured: 3,720 seeks, smallest noise-free access / bound 1.000 (the seek mode reaches
/// the bound itself on short seeks). On the sensor's noisy readings (up to 0.1 quantum) a sled
/// passing 1.5 quanta off can read 1 a sample early: the noisy ratio has measured down to 0.80
/// (family plant 22, a 30-track seek of 5 samples reaching the band at its 4th on a reading
/// rounded in; 1.000 on today's run), so it is bounded by one sample of the bound, not by 1.
/// Trips on a bound one
/// sample too long (the seek mode's seeks that reach it beat it), e.g. a switch search that
/// loses a sample, or on an access time measured from a later sample than the command.
#[test]
fn no_closed_loop_run_beats_the_bound() {
    let ranges = FamilyRanges::default();
    let plants = std::iter::once(TwinParams::default())
        .chain((0..30).map(|i| ranges.draw(1, i).twin(&TwinParams::default())));
    let options = SeekOptions {
        seeks: 40,
        ..SeekOptions::default()
    };
    let (mut smallest, mut smallest_noisy) = (f64::INFINITY, f64::INFINITY);
    let mut seeks = 0;
    for params in plants {
        let design = design_from_prior(&params, &PlantParams::default()).unwrap();
        let q = params.plant.quantum_m;
        let min_dwell = sledid_host::control::seek::access::min_dwell_samples(params.plant.ts_s);
        for c in [
            SeekController::Baseline,
            SeekController::Seek(seek_design(design)),
            SeekController::Reference(design),
        ] {
            let run = run_seeks(&params, &c, &options).unwrap();
            let samples = run.run.twin.samples();
            let ts_ms = params.plant.ts_s * 1e3;
            for (row, seek) in run.rows.iter().zip(run.run.twin.seeks()) {
                let (Some(bound_ms), Some(end)) = (row.bound_ms, seek.end_index) else {
                    continue;
                };
                let bound = (bound_ms / ts_ms).round() as usize;
                let true_readings: Vec<i64> = samples[seek.start_index..end]
                    .iter()
                    .map(|s| (s.x_m / q).round() as i64)
                    .collect();
                let access = access_samples(&true_readings, seek.target_counts, min_dwell)
                    .unwrap_or(true_readings.len());
                seeks += 1;
                smallest = smallest.min(access as f64 / bound as f64);
                assert!(
                    access >= bound,
                    "{}: {row:?}, noise-free access {access}",
                    c.label()
                );
                let noisy = row.ratio.unwrap();
                smallest_noisy = smallest_noisy.min(noisy);
                assert!(
                    row.access_ms >= bound_ms - ts_ms - 1e-9,
                    "{}: {row:?}",
                    c.label()
                );
            }
        }
    }
    println!(
        "{seeks} seeks, smallest access / bound {smallest:.3} (noise-free), {smallest_noisy:.3} (noisy)"
    );
    assert!(seeks >= 31 * 3 * 39);
}

/// A controller that never drives leaves every seek unsettled, counted with its whole length
/// (and with a bound); a seek that reaches the band with less than 10 ms of its dwell left is
/// unsettled too. Trips on an access time that ignores the dwell or drops unsettled seeks.
#[test]
fn unsettled_seeks_count_with_their_whole_length() {
    let plant = PlantParams {
        noise_m: 0.0,
        ..PlantParams::default()
    };
    let ts_ms = plant.ts_s * 1e3;
    let mut idle = step_twin(&plant, 5, 0.05, 1);
    let mut zero = |_: f64, _: f64| 0.0;
    idle.run(&mut zero);
    let rows = rows_of(&idle);
    let s = SeekSummary::of("idle", &rows, 0.05);
    assert_eq!(s.unsettled, 5);
    for (r, seek) in rows.iter().zip(idle.seeks()) {
        let length = seek.end_index.unwrap() - seek.start_index;
        assert!(!r.settled && r.bound_ms.is_some());
        assert_eq!(r.access_ms, length as f64 * ts_ms);
    }
    // The bound's drive settles every seek of a 25 ms dwell (≥ 10 ms after the longest bound,
    // 22 samples); with a 9.6 ms dwell (21 samples, one short of 10 ms) none is settled although
    // each ends in the band.
    let mut short = step_twin(&plant, 5, 21.0 * plant.ts_s, 1);
    play_the_bound(&mut short);
    let rows = rows_of(&short);
    assert!(rows.iter().all(|r| !r.settled), "{rows:?}");
    let mut enough = step_twin(&plant, 5, 0.025, 1);
    play_the_bound(&mut enough);
    assert!(rows_of(&enough).iter().all(|r| r.settled));
}

/// What the controllers measure on the nominal sled (100 log-uniform seeks of 20–2,000 tracks,
/// seed 1, designed from the nominal prior), `BENCHMARKS.md` (controller, seeks):
///
/// | controller | access median (ms) | access / bound median | p95 | ≥ 200 tracks | pulses | unsettled |
/// |---|---|---|---|---|---|---|
/// | servo following the 30 ms S-curve | 27.30 | 9.67 | 26.5 | 5.59 | 0 | 0 |
/// | seek mode (time-optimal seeks) | 5.00 | 1.67 | 3.50 | 1.44 | 0 | 0 |
/// | baseline PID fed the step | 51.87 | 17.21 | 45.0 | 11.78 | 856 | 0 |
///
/// Asserted: the reference-following servo cannot arrive before its reference (median access
/// 25–31 ms, every seek ≥ 3× its bound from 200 tracks on); the seek mode is ≥ 3× faster
/// (issue 14's target; measured 5.45×), within 2× of the bound in the median and 1.5× from 200
/// tracks on, every seek settled, every pulse a fine step; the baseline's limit cycle is counted
/// (pulses). Trips on a harness that measures from the reference's arrival instead of the
/// command (the reference-following median falls near 0) or loses the pulses, on a seek mode
/// switched off (the scheduled law fed the step: 12.7 ms, ratio 3.63) or braking late (pulses,
/// overshoot past the band: unsettled).
#[test]
fn today_on_the_nominal_sled() {
    let params = TwinParams::default();
    let design = design_from_prior(&params, &params.plant).unwrap();
    let o = SeekOptions::default();
    let run = |c: SeekController| run_seeks(&params, &c, &o).unwrap();
    let reference = run(SeekController::Reference(design));
    let seek = run(SeekController::Seek(seek_design(design)));
    let baseline = run(SeekController::Baseline);
    for r in [&reference, &seek, &baseline] {
        let s = &r.summary;
        println!(
            "{}: access median {:.2} ms, ratio median / p95 {:.2} / {:.2}, ≥ 200: {:.2}, pulses {}, unsettled {}",
            s.controller,
            s.access_ms.median,
            s.ratio.median,
            s.ratio.p95,
            s.ratio_long_median,
            s.limit_cycle_pulses,
            s.unsettled
        );
        assert_eq!(s.seeks, 100);
        assert_eq!(s.without_bound, 0);
    }
    let (r, s) = (&reference.summary, &seek.summary);
    assert!((25.0..=31.0).contains(&r.access_ms.median), "{r:?}");
    assert_eq!((r.unsettled, r.limit_cycle_pulses), (0, 0));
    assert!(
        reference
            .rows
            .iter()
            .filter(|x| x.distance_tracks.abs() >= 200)
            .all(|x| x.ratio.is_some_and(|q| q >= 3.0))
    );
    assert!(r.access_ms.median / s.access_ms.median >= 3.0, "{s:?}");
    assert!(s.ratio.median <= 2.0, "{s:?}");
    // 1.5, not 1.4: the stop-point law runs an identified model at α = 0.6, p = 0.3 (its
    // ARX(1,1) bias rings at p = 0) where the earlier law ran α = 0.7, p = 0.5 — measured 1.44–1.45
    // here (1.33 before) for a p95 of 2.67–3.50 (3.50) here and 3.50 / 3.57 (8.0 / 9.7) over the
    // families (`tests/integration/seek_family.rs`); on its exact model the same sled is at 1.05.
    assert!(s.ratio_long_median <= 1.5, "{s:?}");
    assert_eq!(s.unsettled, 0, "{s:?}");
    // Every pulse of the seek mode is a fine step (a sled at rest one cell off stepping toward
    // the target, at most `FINE_STEPS_MAX` per seek), never hunting.
    let fine_max = usize::from(sledid::control::scheduled::rest::FINE_STEPS_MAX);
    for (row, fine_started) in seek.rows.iter().zip(seek.run.fine_steps_per_seek()) {
        assert!(
            row.limit_cycle_pulses <= fine_started.min(fine_max),
            "{row:?}: {fine_started} fine steps"
        );
    }
    assert!(baseline.summary.limit_cycle_pulses >= 500);
}

/// `sledid seek` writes summary.json (both controllers, per-seek rows, the bound curve) and its
/// two figures; `control-family --passes seek` writes seek.{json,md,png}; bad arguments fail with
/// the argument named.
#[test]
fn the_commands_write_their_files_and_name_bad_arguments() {
    let exe = env!("CARGO_BIN_EXE_sledid");
    let dir = scratch_dir("cli");
    let out = Command::new(exe)
        .args([
            "seek",
            "--seeks",
            "6",
            "--distances",
            "30:300",
            "--seed",
            "2",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let tested = &json["under_test"];
    assert_eq!(tested["summary"]["controller"], "seek");
    assert_eq!(tested["seeks"].as_array().unwrap().len(), 6);
    for row in tested["seeks"].as_array().unwrap() {
        let d = row["distance_tracks"].as_i64().unwrap().abs();
        assert!((30..=300).contains(&d));
        assert!(row["access_ms"].as_f64().unwrap() >= row["bound_ms"].as_f64().unwrap());
    }
    assert_eq!(
        json["reference_following"]["summary"]["controller"],
        "reference_following"
    );
    assert!(json["bound_curve"].as_array().unwrap().len() > 10);
    for f in ["seek_vs_distance.png", "seek_steps.png"] {
        assert!(
            std::fs::metadata(dir.join(f)).unwrap().len() > 10_000,
            "{f}"
        );
    }
    let fam = scratch_dir("family");
    let out = Command::new(exe)
        .args([
            "control-family",
            "--plants",
            "3",
            "--seeks",
            "5",
            "--passes",
            "seek",
            "--out",
        ])
        .arg(&fam)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in ["seek.json", "seek.md", "seek.png"] {
        assert!(fam.join(f).exists(), "{f}");
    }
    assert!(!fam.join("family.json").exists());
    for (args, named) in [
        (vec!["--distances", "300"], "--distances"),
        (vec!["--distances", "300:30"], "--distances"),
        (vec!["--seeks", "0"], "--seeks"),
        (vec!["--dwell-ms", "0"], "--dwell-ms"),
        (
            vec!["--plant", "/nonexistent/plant.json"],
            "/nonexistent/plant.json",
        ),
    ] {
        let out = Command::new(exe)
            .arg("seek")
            .args(&args)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(named),
            "{args:?}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&fam);
}
