//! Tests of the sled twin: determinism, the stick/slip plant, quantization, saturation, the
//! baseline closed loop (settling and the ±1-quantum limit cycle; the default is the paper's badly
//! tuned loop, `host-tests/plants/paper_sled.json`, and the earlier well-damped one is
//! `host-tests/plants/well_damped.json`), parameters and recordings.

use proptest::prelude::*;
use sledid_host::twin::{
    PidController, PlantParams, SledController, SledPlant, Twin, TwinError, TwinParams, TwinSample,
    TwinSidecar,
};
use std::path::PathBuf;

/// Seeds the closed-loop tests use (6 random seeks each).
const CLOSED_LOOP_SEEDS: [u64; 4] = [1, 2, 3, 4];

/// A fresh scratch directory for one test.
fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sledid-twin-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Baseline run with the default parameters.
fn baseline(seed: u64) -> Twin {
    Twin::run_baseline(TwinParams::default(), seed).unwrap()
}

#[test]
fn same_seed_gives_identical_recordings_and_files() {
    let first = baseline(7);
    let second = baseline(7);
    assert!(first.samples().len() > 1000);
    assert_eq!(first.samples(), second.samples());
    assert_eq!(first.seeks(), second.seeks());

    let dir = scratch_dir("determinism");
    first.write_csv(dir.join("a.csv")).unwrap();
    second.write_csv(dir.join("b.csv")).unwrap();
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert_eq!(read("a.csv"), read("b.csv"));
    assert_eq!(read("a.json"), read("b.json"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn different_seeds_give_different_recordings() {
    let first = baseline(7);
    let second = baseline(8);
    assert_ne!(
        first.seeks()[0].target_counts,
        second.seeks()[0].target_counts
    );
    assert_ne!(first.samples(), second.samples());
}

#[test]
fn noise_depends_on_the_seed_but_not_the_seeks() {
    let mut params = TwinParams::default();
    params.reference.targets_tracks = Some(vec![300]);
    params.plant.noise_m = 0.4e-6;
    let first = Twin::run_baseline(params.clone(), 1).unwrap();
    let second = Twin::run_baseline(params, 2).unwrap();
    assert_eq!(
        first.seeks()[0].target_counts,
        second.seeks()[0].target_counts
    );
    assert_ne!(first.samples(), second.samples());
}

/// Force on the default sled per volt, and the voltages that match its friction forces.
fn default_plant_voltages() -> (PlantParams, f64, f64) {
    let plant = PlantParams::default();
    let breakaway_v = plant.static_n / plant.force_per_volt_n_per_v;
    let sliding_v = plant.coulomb_n / plant.force_per_volt_n_per_v;
    (plant, breakaway_v, sliding_v)
}

#[test]
fn sled_at_rest_stays_stuck_below_static_friction() {
    let (params, breakaway_v, _) = default_plant_voltages();
    for u_v in [0.99 * breakaway_v, -0.99 * breakaway_v, breakaway_v, 0.0] {
        let mut plant = SledPlant::new(&params);
        for _ in 0..2000 {
            plant.advance(u_v, params.ts_s);
        }
        assert_eq!(plant.position_m(), 0.0, "u = {u_v} V moved the sled");
        assert!(plant.is_at_rest());
    }
}

#[test]
fn sled_at_rest_breaks_loose_above_static_friction() {
    let (params, breakaway_v, _) = default_plant_voltages();
    for direction in [1.0, -1.0] {
        let mut plant = SledPlant::new(&params);
        plant.advance(direction * 1.01 * breakaway_v, params.ts_s);
        assert!(plant.position_m() * direction > 0.0);
        assert!(plant.velocity_m_per_s() * direction > 0.0);
    }
}

#[test]
fn moving_sled_keeps_sliding_between_coulomb_and_static_friction() {
    let (params, breakaway_v, sliding_v) = default_plant_voltages();
    let between_v = 0.5 * (breakaway_v + sliding_v);
    let mut plant = SledPlant::new(&params);
    plant.advance(2.0 * breakaway_v, params.ts_s);
    for _ in 0..200 {
        plant.advance(between_v, params.ts_s);
    }
    // Not enough to break loose, more than enough to keep sliding: the steady speed is
    // (F − F_c)/b.
    let expected =
        (between_v * params.force_per_volt_n_per_v - params.coulomb_n) / params.viscous_n_s_per_m;
    assert!((plant.velocity_m_per_s() - expected).abs() < 1e-9 * expected.abs().max(1.0));
}

#[test]
fn sled_stops_exactly_and_does_not_chatter() {
    let (params, breakaway_v, _) = default_plant_voltages();
    let mut plant = SledPlant::new(&params);
    for _ in 0..20 {
        plant.advance(5.0, params.ts_s);
    }
    assert!(plant.velocity_m_per_s() > 0.0);
    // Coast against friction with a small reverse drive that cannot break the sled loose.
    let mut previous_velocity = plant.velocity_m_per_s();
    let mut stopped_at = None;
    for k in 0..500 {
        plant.advance(-0.9 * breakaway_v, params.ts_s);
        let v = plant.velocity_m_per_s();
        assert!(v >= 0.0, "velocity crossed zero at sample {k}: {v}");
        assert!(v <= previous_velocity);
        previous_velocity = v;
        match stopped_at {
            None if v == 0.0 => stopped_at = Some(plant.position_m()),
            Some(position) => assert_eq!(plant.position_m(), position),
            None => {}
        }
    }
    assert!(stopped_at.is_some());
}

#[test]
fn free_motion_matches_the_closed_form_solution() {
    let (params, _, _) = default_plant_voltages();
    let mut plant = SledPlant::new(&params);
    let u_v = 1.0;
    let steps = 50;
    for _ in 0..steps {
        plant.advance(u_v, params.ts_s);
    }
    let t = steps as f64 * params.ts_s;
    let tau = params.mass_kg / params.viscous_n_s_per_m;
    let v_inf = (u_v * params.force_per_volt_n_per_v - params.coulomb_n) / params.viscous_n_s_per_m;
    let x = v_inf * (t - tau * (1.0 - (-t / tau).exp()));
    let v = v_inf * (1.0 - (-t / tau).exp());
    assert!(
        (plant.position_m() - x).abs() < 1e-12,
        "{} vs {x}",
        plant.position_m()
    );
    assert!((plant.velocity_m_per_s() - v).abs() < 1e-12);
}

#[test]
fn frictionless_undamped_sled_is_a_double_integrator() {
    let params = PlantParams {
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        static_n: 0.0,
        ..PlantParams::default()
    };
    let mut plant = SledPlant::new(&params);
    plant.advance(1.0, 0.01);
    let a = params.force_per_volt_n_per_v / params.mass_kg;
    assert!((plant.position_m() - 0.5 * a * 1e-4).abs() < 1e-15);
    assert!((plant.velocity_m_per_s() - a * 0.01).abs() < 1e-15);
}

proptest! {
    // Integration tests have no lib.rs beside them for proptest's regression files.
    #![proptest_config(ProptestConfig { failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn resting_sled_moves_only_when_the_drive_exceeds_static_friction(
        u_v in -0.2f64..0.2,
    ) {
        let (params, breakaway_v, _) = default_plant_voltages();
        let mut plant = SledPlant::new(&params);
        plant.advance(u_v, params.ts_s);
        prop_assert_eq!(plant.position_m() != 0.0, u_v.abs() > breakaway_v);
    }

    #[test]
    fn plant_state_stays_finite_for_any_drive(
        drive in proptest::collection::vec(prop_oneof![-100.0f64..100.0, Just(f64::NAN)], 1..300),
    ) {
        let (params, _, _) = default_plant_voltages();
        let mut plant = SledPlant::new(&params);
        for u_v in drive {
            let applied = plant.advance(u_v, params.ts_s);
            prop_assert!(applied.abs() <= params.u_max_v);
            prop_assert!(plant.position_m().is_finite() && plant.velocity_m_per_s().is_finite());
        }
    }
}

#[test]
fn every_measurement_is_a_whole_number_of_quanta() {
    let mut params = TwinParams::default();
    params.plant.noise_m = 0.3e-6;
    let twin = Twin::run_baseline(params.clone(), 3).unwrap();
    let quantum_m = params.plant.quantum_m;
    for sample in twin.samples() {
        let counts = sample.y_m / quantum_m;
        assert!(
            (counts - counts.round()).abs() < 1e-9,
            "y = {} m",
            sample.y_m
        );
        assert_eq!(counts.round() as i64, sample.y_counts);
    }
}

#[test]
fn noiseless_sensor_rounds_to_the_nearest_quantum() {
    let mut params = TwinParams::default();
    params.plant.noise_m = 0.0;
    let twin = Twin::run_baseline(params.clone(), 3).unwrap();
    let half_quantum_m = 0.5 * params.plant.quantum_m;
    let mut worst_m: f64 = 0.0;
    for sample in twin.samples() {
        worst_m = worst_m.max((sample.y_m - sample.x_m).abs());
    }
    assert!(worst_m <= half_quantum_m * (1.0 + 1e-9), "{worst_m}");
    assert!(worst_m > 0.4 * half_quantum_m, "{worst_m}");
}

#[test]
fn drive_never_exceeds_the_amplifier_rail() {
    let params = TwinParams::default();
    let u_max_v = params.plant.u_max_v;
    let twin = baseline(5);
    assert!(twin.samples().iter().all(|s| s.u_v.abs() <= u_max_v));

    // A bang-bang controller asking for 100 V (and NaN once) gets the rail.
    let mut twin = Twin::new(params, 5).unwrap();
    let mut calls = 0;
    let mut bang_bang = |r_counts: f64, y_counts: f64| {
        calls += 1;
        if calls == 10 {
            f64::NAN
        } else {
            100.0 * (r_counts - y_counts).signum()
        }
    };
    twin.run(&mut bang_bang);
    let samples = twin.samples();
    assert!(samples.iter().all(|s| s.u_v.abs() <= u_max_v));
    assert!(samples.iter().any(|s| s.u_v == u_max_v));
    assert!(samples.iter().any(|s| s.u_v == -u_max_v));
    assert_eq!(samples[9].u_v, 0.0);
}

/// Errors `target − y` in the last half of each seek's dwell.
fn late_dwell_errors(twin: &Twin) -> Vec<Vec<i64>> {
    twin.seeks()
        .iter()
        .map(|seek| {
            let arrival = seek.arrival_index.unwrap();
            let end = seek.end_index.unwrap();
            let start = end - (end - arrival) / 2;
            twin.samples()[start..end]
                .iter()
                .map(|s| seek.target_counts - s.y_counts)
                .collect()
        })
        .collect()
}

/// Sign changes of a sequence, zeros skipped.
fn sign_changes(errors: &[i64]) -> usize {
    let signs: Vec<i64> = errors
        .iter()
        .map(|e| e.signum())
        .filter(|&s| s != 0)
        .collect();
    signs.windows(2).filter(|w| w[0] != w[1]).count()
}

#[test]
fn closed_loop_reaches_every_target_and_ends_in_a_one_quantum_limit_cycle() {
    let params = TwinParams::default();
    let mut at_rest = 0;
    for seed in CLOSED_LOOP_SEEDS {
        let twin = baseline(seed);
        assert!(twin.is_finished());
        assert_eq!(twin.seeks().len(), params.reference.seek_count as usize);
        for (seek, errors) in twin.seeks().iter().zip(late_dwell_errors(&twin)) {
            let context = format!("seed {seed}, target {}", seek.target_counts);
            let seek_samples = &twin.samples()[seek.start_index..seek.end_index.unwrap()];
            assert!(
                seek_samples
                    .iter()
                    .any(|s| (s.target_counts - s.y_counts).abs() <= 1),
                "{context}: never within one quantum"
            );
            assert!(
                errors.iter().all(|e| e.abs() <= 1),
                "{context}: late error outside ±1: {:?}",
                errors.iter().filter(|e| e.abs() > 1).collect::<Vec<_>>()
            );
            // The loop's other equilibrium: at rest in the zero cell with the integral below
            // breakaway (measured: 1 of these 24 seeks, 70 of 1,200 in `limit_cycle_over_many_seeds`).
            if errors.iter().all(|&e| e == 0) {
                at_rest += 1;
                continue;
            }
            // 150 ms of dwell: the cycle of ~35 ms changes sign 8–9 times (measured on all 23
            // hunting seeks; with the well-damped baseline's ~5.5 ms cycle it was > 30).
            let changes = sign_changes(&errors);
            assert!(changes >= 7, "{context}: only {changes} sign changes");
            let plus = errors.iter().filter(|&&e| e == 1).count();
            let minus = errors.iter().filter(|&&e| e == -1).count();
            assert!(
                plus > errors.len() / 5 && minus > errors.len() / 5,
                "{context}: one-sided"
            );
        }
    }
    assert!(at_rest <= 2, "{at_rest} seeks at rest");
}

#[test]
fn closed_loop_rings_down_before_the_limit_cycle() {
    // Long seeks overshoot by ~10 quanta and swing back and forth: decaying oscillations, as in
    // the paper (measured 9–12 quanta on the 12 seeks of ≥ 500 tracks; the well-damped baseline
    // overshot by 1–15).
    let mut overshoots = Vec::new();
    for seed in CLOSED_LOOP_SEEDS {
        for stats in baseline(seed).seek_stats() {
            if stats.step_counts.abs() >= 500 {
                overshoots.push(stats.overshoot_counts);
            }
        }
    }
    assert!(overshoots.len() >= 5);
    assert!(
        overshoots.iter().all(|&o| (5..=15).contains(&o)),
        "{overshoots:?}"
    );
    assert!(
        overshoots.iter().filter(|&&o| o >= 3).count() >= 3,
        "{overshoots:?}"
    );
}

#[test]
fn limit_cycle_moves_the_true_position_over_and_back() {
    let twin = baseline(1);
    let seek = &twin.seeks()[0];
    let end = seek.end_index.unwrap();
    let target_m = seek.target_counts as f64 * twin.params().plant.quantum_m;
    let late = &twin.samples()[end - 200..end];
    let above = late.iter().filter(|s| s.x_m > target_m).count();
    let below = late.iter().filter(|s| s.x_m < target_m).count();
    assert!(above > 40 && below > 40, "above {above}, below {below}");
    let swing_m = late
        .iter()
        .map(|s| (s.x_m - target_m).abs())
        .fold(0.0, f64::max);
    assert!(swing_m < 1.5 * twin.params().plant.quantum_m);
}

#[test]
fn step_api_with_the_baseline_equals_run_baseline() {
    let reference = baseline(11);
    let mut twin = Twin::new(TwinParams::default(), 11).unwrap();
    let mut controller = twin.baseline_controller();
    let mut stepped: Vec<TwinSample> = Vec::new();
    while let Some(sample) = twin.step(&mut controller) {
        stepped.push(sample);
    }
    assert_eq!(stepped.as_slice(), reference.samples());
    assert!(twin.step(&mut controller).is_none());
    assert_eq!(twin.samples().len(), stepped.len());
}

#[test]
fn a_trait_object_controller_can_close_the_loop() {
    let params = TwinParams::default();
    let mut twin = Twin::new(params.clone(), 2).unwrap();
    let mut boxed: Box<dyn SledController> = Box::new(PidController::new(
        &params.controller,
        params.plant.ts_s,
        params.plant.u_max_v,
    ));
    twin.set_controller_label("boxed_pid");
    twin.run(boxed.as_mut());
    assert_eq!(twin.samples(), baseline(2).samples());
    assert_eq!(twin.sidecar().controller, "boxed_pid");
}

#[test]
fn csv_and_sidecar_hold_the_recording() {
    let twin = baseline(4);
    let dir = scratch_dir("csv");
    let path = dir.join("run.csv");
    twin.write_csv(&path).unwrap();

    let mut reader = csv::Reader::from_path(&path).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(header, ["t_s", "r_m", "u_v", "y_m"]);
    let rows: Vec<(f64, f64, f64, f64)> = reader.deserialize().map(Result::unwrap).collect();
    assert_eq!(rows.len(), twin.samples().len());
    for (row, sample) in rows.iter().zip(twin.samples()) {
        assert_eq!(*row, (sample.t_s, sample.r_m, sample.u_v, sample.y_m));
    }

    let sidecar: TwinSidecar =
        serde_json::from_str(&std::fs::read_to_string(dir.join("run.json")).unwrap()).unwrap();
    assert_eq!(sidecar.seed, 4);
    assert_eq!(sidecar.samples, rows.len());
    assert_eq!(&sidecar.params, twin.params());
    assert_eq!(sidecar.seeks, twin.seeks());
    assert_eq!(sidecar.quantization, "round_to_nearest");
    assert_eq!(sidecar.controller, "baseline_pid");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn writing_into_a_missing_directory_is_an_error() {
    let twin = baseline(4);
    let error = twin
        .write_csv("/nonexistent-sledid-dir/run.csv")
        .unwrap_err();
    assert!(matches!(error, TwinError::Csv(_)), "{error:?}");
}

#[test]
fn params_round_trip_through_json_and_files() {
    let mut params = TwinParams::default();
    params.plant.mass_kg = 0.08;
    params.reference.targets_tracks = Some(vec![10, -20, 300]);
    params.controller.kd_v_s_per_count = 2e-5;
    let json = params.to_json_string().unwrap();
    assert_eq!(TwinParams::from_json_str(&json).unwrap(), params);

    let dir = scratch_dir("params");
    let path = dir.join("params.json");
    std::fs::write(&path, &json).unwrap();
    assert_eq!(TwinParams::from_json_file(&path).unwrap(), params);
    std::fs::remove_dir_all(dir).unwrap();

    assert!(matches!(
        TwinParams::from_json_file("/nonexistent-sledid.json"),
        Err(TwinError::Io { .. })
    ));
}

#[test]
fn missing_keys_take_their_defaults() {
    let params = TwinParams::from_json_str(r#"{"plant": {"mass_kg": 0.07}}"#).unwrap();
    let mut expected = TwinParams::default();
    expected.plant.mass_kg = 0.07;
    assert_eq!(params, expected);
    assert_eq!(
        TwinParams::from_json_str("{}").unwrap(),
        TwinParams::default()
    );
}

#[test]
fn unknown_keys_are_rejected() {
    for json in [
        r#"{"plant": {"mass": 0.05}}"#,
        r#"{"reference": {"seek_count": 3, "dwell": 0.1}}"#,
        r#"{"controller": {"kp": 1.0}}"#,
        r#"{"plants": {}}"#,
    ] {
        let error = TwinParams::from_json_str(json).unwrap_err();
        assert!(matches!(error, TwinError::Json(_)), "{json}: {error:?}");
        assert!(
            error.to_string().contains("unknown field"),
            "{json}: {error}"
        );
    }
}

/// The name reported for `params` failing validation.
fn invalid_name(params: &TwinParams) -> &'static str {
    match params.validate() {
        Err(TwinError::InvalidParameter { name, .. }) => name,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

#[test]
fn validation_names_the_offending_parameter() {
    type Edit = fn(&mut TwinParams);
    let cases: [(Edit, &str); 15] = [
        (|p| p.plant.mass_kg = 0.0, "plant.mass_kg"),
        (|p| p.plant.mass_kg = f64::NAN, "plant.mass_kg"),
        (
            |p| p.plant.force_per_volt_n_per_v = -1.0,
            "plant.force_per_volt_n_per_v",
        ),
        (
            |p| p.plant.viscous_n_s_per_m = f64::INFINITY,
            "plant.viscous_n_s_per_m",
        ),
        (|p| p.plant.coulomb_n = -0.1, "plant.coulomb_n"),
        (|p| p.plant.static_n = 0.05, "plant.static_n"),
        (|p| p.plant.quantum_m = 0.0, "plant.quantum_m"),
        (|p| p.plant.ts_s = -1e-3, "plant.ts_s"),
        (|p| p.plant.noise_m = -1e-9, "plant.noise_m"),
        (|p| p.reference.ref_rise_s = 0.0, "reference.ref_rise_s"),
        (
            |p| p.reference.seek_max_tracks = 10,
            "reference.seek_max_tracks",
        ),
        (
            |p| p.reference.targets_tracks = Some(vec![]),
            "reference.targets_tracks",
        ),
        (
            |p| p.reference.targets_tracks = Some(vec![5, i64::MIN]),
            "reference.targets_tracks",
        ),
        (
            |p| p.controller.d_filter_hz = 2000.0,
            "controller.d_filter_hz",
        ),
        (
            |p| p.controller.ki_v_per_count_s = -1.0,
            "controller.ki_v_per_count_s",
        ),
    ];
    for (edit, name) in cases {
        let mut params = TwinParams::default();
        edit(&mut params);
        assert_eq!(invalid_name(&params), name);
        let message = params.validate().unwrap_err().to_string();
        assert!(message.contains(name), "{message}");
        assert!(Twin::new(params, 1).is_err());
    }
    let error = TwinParams::from_json_str(r#"{"plant": {"static_n": 0.01}}"#).unwrap_err();
    assert!(error.to_string().contains("plant.static_n"), "{error}");
}

#[test]
fn given_targets_are_visited_in_order() {
    let mut params = TwinParams::default();
    params.reference.targets_tracks = Some(vec![5, -3, 40]);
    params.reference.dwell_s = 0.1;
    let twin = Twin::run_baseline(params.clone(), 9).unwrap();
    let targets: Vec<i64> = twin.seeks().iter().map(|s| s.target_counts).collect();
    assert_eq!(targets, [5, -3, 40]);
    let quantum_m = params.plant.quantum_m;
    for seek in twin.seeks() {
        let arrival = seek.arrival_index.unwrap();
        let end = seek.end_index.unwrap();
        assert_eq!(end - arrival, (0.1 / params.plant.ts_s).round() as usize);
        // Constant and exact from arrival on.
        for sample in &twin.samples()[arrival..end] {
            assert_eq!(sample.r_m, seek.target_counts as f64 * quantum_m);
        }
    }
}

#[test]
fn random_seeks_respect_their_range() {
    let params = TwinParams::default();
    let reference = &params.reference;
    for seed in 0..20 {
        // A zero controller: only the reference schedule matters here.
        let mut twin = Twin::new(params.clone(), seed).unwrap();
        twin.run(&mut |_: f64, _: f64| 0.0);
        let mut position = 0;
        let mut drawn = Vec::new();
        for seek in twin.seeks() {
            let step = (seek.target_counts - position).abs();
            assert!(
                (i64::from(reference.seek_min_tracks)..=i64::from(reference.seek_max_tracks))
                    .contains(&step)
            );
            assert!(seek.target_counts.abs() <= i64::from(reference.travel_tracks));
            position = seek.target_counts;
            drawn.push(step);
        }
        assert_eq!(drawn.len(), reference.seek_count as usize);
    }
}

#[test]
fn print_closed_loop_statistics() {
    println!(
        "{:>4} {:>6} {:>9} {:>10} {:>9} | {:>5} {:>7} {:>9} {:>7} {:>7} {:>6} {:>8}",
        "seed",
        "step",
        "first_ms",
        "settle_ms",
        "overshoot",
        "max_e",
        "changes",
        "period_ms",
        "u_rms",
        "u_peak",
        "pulses",
        "pulse_ms"
    );
    for seed in CLOSED_LOOP_SEEDS {
        for stats in baseline(seed).seek_stats() {
            let cycle = &stats.limit_cycle;
            let ms = |t: Option<f64>| t.map_or(f64::NAN, |t| t * 1e3);
            println!(
                "{seed:>4} {:>6} {:>9.1} {:>10.1} {:>9} | {:>5} {:>7} {:>9.2} {:>7.4} {:>7.4} {:>6} {:>8.2}",
                stats.step_counts,
                ms(stats.first_within_one_s),
                ms(stats.settling_time_s),
                stats.overshoot_counts,
                cycle.max_abs_error_counts,
                cycle.sign_changes,
                ms(cycle.period_s),
                cycle.u_rms_v,
                cycle.u_peak_v,
                cycle.pulses,
                ms(cycle.mean_pulse_s),
            );
            assert!(stats.settling_time_s.is_some());
            // 1, or 0 for the one seek at rest (see above).
            assert!(cycle.max_abs_error_counts <= 1);
        }
    }
}

/// Seeks at rest in the zero cell and wider cycles over many random seeks (1,200 seeks; fast with
/// the optimised test profile).
fn limit_cycle_census(params: &TwinParams, at_rest_below_changes: usize) -> (usize, usize, usize) {
    let mut frozen = 0;
    let mut wide = 0;
    let mut seeks = 0;
    for seed in 0..200 {
        for stats in Twin::run_baseline(params.clone(), seed)
            .unwrap()
            .seek_stats()
        {
            seeks += 1;
            if stats.limit_cycle.max_abs_error_counts > 1 {
                wide += 1;
            }
            if stats.limit_cycle.sign_changes < at_rest_below_changes {
                frozen += 1;
            }
        }
    }
    (seeks, frozen, wide)
}

/// The paper's loop ends in ±1 on every seek but rests in the zero cell more often than the
/// well-damped one: its integrator crawls (3.6 mV per sample at one track), so a swing that ends
/// with the integral below breakaway stays there. Measured: 70 of 1,200 at rest, none wider; the
/// bound leaves room for ~40 % more. The well-damped baseline keeps its earlier bound (≤ 1 %,
/// measured 1 of 1,200), counting < 10 sign changes in its 150 ms as frozen (its cycle changes
/// sign ~55 times there; the paper's ~35 ms cycle only 8–9 times, so there < 2 counts).
#[test]
fn limit_cycle_over_many_seeds() {
    let (seeks, frozen, wide) = limit_cycle_census(&TwinParams::default(), 2);
    println!(
        "paper's loop: {seeks} seeks: {frozen} at rest, {wide} with |e| > 1 late in the dwell"
    );
    assert_eq!(wide, 0);
    assert!(frozen <= seeks / 12, "{frozen} of {seeks} at rest");
    let (seeks, frozen, wide) = limit_cycle_census(&TwinParams::well_damped(), 10);
    println!("well damped: {seeks} seeks: {frozen} frozen, {wide} with |e| > 1 late in the dwell");
    assert!(frozen + wide <= seeks / 100);
}

/// The committed plant files are the defaults and the well-damped variant, key for key.
#[test]
fn plant_files_are_the_documented_parameter_sets() {
    let file = |name: &str| {
        TwinParams::from_json_file(format!("{}/plants/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    assert_eq!(file("paper_sled.json"), TwinParams::default());
    assert_eq!(file("well_damped.json"), TwinParams::well_damped());
    assert_ne!(TwinParams::default(), TwinParams::well_damped());
}
