//! The fixed-point position controller (`sledid::control`): the twin's baseline reproduced in closed
//! loop, the EMPS rig's controller reproduced on its recording, the fixed-point output against the
//! float64 law, and properties (no panic, |u| ≤ u_max, reset = new) for any input.

use proptest::prelude::*;
use sledid::PositionI48F16;
use sledid::Scaling;
use sledid::control::{DerivativeOn, PidDesign, PidFlags, PidState};
use sledid_host::recording::{ReaderOptions, read_all};
use sledid_host::reference::control::{
    EMPS_QUANTUM_M, EMPS_U_FULL_SCALE_V, FixedPid, PidF64, baseline_design, emps_design,
    position_from_quanta,
};
use sledid_host::twin::{SeekStats, SledController, Twin, TwinParams};

const EMPS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/emps/DATA_EMPS.csv"
);

/// Seeds of the closed-loop comparison (6 random seeks each, as in `tests/integration/twin.rs`).
const SEEDS: [u64; 4] = [1, 2, 3, 4];

/// The twin with `controller` in the loop, run to the end.
fn run_twin<C: SledController>(params: &TwinParams, seed: u64, controller: &mut C) -> Twin {
    let mut twin = Twin::new(params.clone(), seed).unwrap();
    twin.run(controller);
    twin
}

fn fixed_baseline(params: &TwinParams) -> FixedPid {
    FixedPid::new(&baseline_design(
        &params.controller,
        params.plant.ts_s,
        params.plant.u_max_v,
    ))
    .unwrap()
}

fn f64_baseline(params: &TwinParams) -> PidF64 {
    PidF64::new(&baseline_design(
        &params.controller,
        params.plant.ts_s,
        params.plant.u_max_v,
    ))
    .unwrap()
}

/// Per-seek comparison of two runs' statistics (printed when `verbose`): (seeks, settling within
/// one sample, both hunting or both at rest).
fn compare_stats(
    verbose: bool,
    name: &str,
    ts_s: f64,
    a: &[SeekStats],
    b: &[SeekStats],
) -> (usize, usize, usize) {
    assert_eq!(a.len(), b.len(), "{name}: seek count");
    let (mut within, mut cycling) = (0, 0);
    for (sa, sb) in a.iter().zip(b) {
        assert_eq!(sa.target_counts, sb.target_counts);
        let settle = |s: &SeekStats| s.settling_time_s.unwrap_or(f64::INFINITY);
        let d_settle = (settle(sa) - settle(sb)).abs();
        if d_settle <= ts_s * 1.001 || (settle(sa).is_infinite() && settle(sb).is_infinite()) {
            within += 1;
        }
        // Both hunting, or both at rest in the zero cell.
        if (sa.limit_cycle.sign_changes > 0) == (sb.limit_cycle.sign_changes > 0) {
            cycling += 1;
        }
        if !verbose {
            continue;
        }
        println!(
            "{name:>9} step {:>6}: settle {:>8.3} / {:>8.3} ms, overshoot {:>2} / {:>2}, sign changes {:>3} / {:>3}, \
             period {:>5.2} / {:>5.2} ms, max|e| {} / {}, u_rms {:.4} / {:.4} V",
            sa.step_counts,
            settle(sa) * 1e3,
            settle(sb) * 1e3,
            sa.overshoot_counts,
            sb.overshoot_counts,
            sa.limit_cycle.sign_changes,
            sb.limit_cycle.sign_changes,
            sa.limit_cycle.period_s.unwrap_or(f64::NAN) * 1e3,
            sb.limit_cycle.period_s.unwrap_or(f64::NAN) * 1e3,
            sa.limit_cycle.max_abs_error_counts,
            sb.limit_cycle.max_abs_error_counts,
            sa.limit_cycle.u_rms_v,
            sb.limit_cycle.u_rms_v,
        );
    }
    (a.len(), within, cycling)
}

/// A controller whose output is rounded to the I16F16 grid of `u_fs`: the f64 law with the
/// fixed-point path's output quantisation and nothing else.
struct OutputOnGrid<C>(C, f64);

impl<C: SledController> SledController for OutputOnGrid<C> {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let u = self.0.step(r_counts, y_counts);
        (u / self.1 * 65_536.0).round() / 65_536.0 * self.1
    }
}

/// The fixed-point baseline in the twin's loop against the f64 one: (seeks, settling within one
/// sample, same limit-cycle state, sign changes f64 / fixed). With `whole_first_seek` the
/// fixed-point loop's y must equal the gridded f64 loop's through the first seek, otherwise equal
/// the f64 or the gridded f64 loop's for the first `min_identical` samples.
fn fixed_point_loop(
    params: &TwinParams,
    whole_first_seek: bool,
    min_identical: usize,
) -> (usize, usize, usize, usize, usize) {
    let params = params.clone();
    let ts_s = params.plant.ts_s;
    let (mut seeks, mut within, mut cycling, mut within_grid) = (0, 0, 0, 0);
    let (mut changes_f64, mut changes_fixed) = (0usize, 0usize);
    for seed in SEEDS {
        let reference = Twin::run_baseline(params.clone(), seed).unwrap();
        let fixed = run_twin(&params, seed, &mut fixed_baseline(&params));
        let grid = run_twin(
            &params,
            seed,
            &mut OutputOnGrid(f64_baseline(&params), params.plant.u_max_v),
        );
        let (a, b) = (reference.seek_stats(), fixed.seek_stats());
        changes_f64 += a.iter().map(|s| s.limit_cycle.sign_changes).sum::<usize>();
        changes_fixed += b.iter().map(|s| s.limit_cycle.sign_changes).sum::<usize>();
        let (n, w, c) = compare_stats(true, &format!("seed {seed}"), ts_s, &a, &b);
        seeks += n;
        within += w;
        cycling += c;
        within_grid += compare_stats(false, "f64 grid", ts_s, &a, &grid.seek_stats()).1;
        for s in &b {
            // ±1-quantum limit cycle, or at rest in the zero cell.
            assert!(
                s.limit_cycle.max_abs_error_counts <= 1,
                "±1-quantum limit cycle"
            );
        }
        // Where the two loops part: the fixed-point loop against the f64 baseline, and against
        // the f64 law with its output on the I16F16 grid.
        let first_difference = |x: &Twin| {
            reference
                .samples()
                .iter()
                .zip(x.samples())
                .position(|(p, q)| p.y_counts != q.y_counts)
        };
        let vs_grid = fixed
            .samples()
            .iter()
            .zip(grid.samples())
            .position(|(p, q)| p.y_counts != q.y_counts);
        let first_seek_end = fixed.seeks()[0].end_index.unwrap();
        println!(
            "seed {seed}: y first differs from the f64 baseline at sample {:?} (f64 law with u on \
             the grid: {:?}); from the gridded f64 law at {vs_grid:?} of {} (first seek ends at {first_seek_end})",
            first_difference(&fixed),
            first_difference(&grid),
            fixed.samples().len()
        );
        if whole_first_seek {
            assert!(
                vs_grid.is_none_or(|i| i >= first_seek_end),
                "seed {seed}: the fixed-point loop leaves the gridded f64 loop at {vs_grid:?}"
            );
        }
        let len = fixed.samples().len();
        let identical = first_difference(&fixed)
            .unwrap_or(len)
            .max(vs_grid.unwrap_or(len));
        assert!(
            identical >= min_identical,
            "seed {seed}: the fixed-point loop leaves both f64 loops at {identical}"
        );
    }
    println!(
        "baseline f64 vs fixed point: {within}/{seeks} seeks settle within one sample period \
         (f64 law with u on the I16F16 grid: {within_grid}/{seeks}), {cycling}/{seeks} in the same \
         limit-cycle state, sign changes {changes_f64} / {changes_fixed}"
    );
    (seeks, within, cycling, changes_f64, changes_fixed)
}

/// The fixed-point baseline reproduces the f64 loop: the same limit-cycle state on every seek, sign
/// changes within 10 %. How closely the trajectories agree depends on the loop. The well-damped
/// baseline rings down in a few samples: y is identical to the f64 law with its output on the
/// I16F16 grid through the first seek, and the settling time within one sample on ≥ 5/6 of the
/// seeks. The paper's loop (the default) swings ~10 quanta back and forth for ~90 samples, where
/// one output LSB (of the fixed-point law, or of the grid against pure f64) eventually changes a
/// swing: y is identical to the f64 or the gridded f64 loop's for the first 70–877 samples (seeds
/// 1–4; ≥ 60 asserted: the whole acceleration of the first seek), and the last excursion beyond
/// ±1 can end a whole swing (~12 ms) earlier or later: 12 of 24 settling times within one sample
/// (≥ 1/3 asserted).
#[test]
fn fixed_point_baseline_reproduces_the_twin_closed_loop() {
    for (params, whole_first_seek, min_identical, min_within) in [
        (TwinParams::default(), false, 60, 1.0 / 3.0),
        (TwinParams::well_damped(), true, 0, 5.0 / 6.0),
    ] {
        let (seeks, within, cycling, changes_f64, changes_fixed) =
            fixed_point_loop(&params, whole_first_seek, min_identical);
        assert!(
            within as f64 >= min_within * seeks as f64,
            "settling within one sample on {within}/{seeks}"
        );
        assert_eq!(
            cycling, seeks,
            "same limit-cycle state on {cycling}/{seeks}"
        );
        let ratio = changes_fixed as f64 / changes_f64 as f64;
        assert!(
            (0.9..1.1).contains(&ratio),
            "sign changes {changes_fixed} vs {changes_f64}"
        );
    }
}

#[test]
fn float64_law_is_the_twin_baseline() {
    // The f64 reference of the library's law, configured as the baseline, against the twin's own
    // `PidController`, open loop on a baseline recording: the same law up to rounding.
    let params = TwinParams::default();
    let twin = Twin::run_baseline(params.clone(), 5).unwrap();
    let mut baseline = twin.baseline_controller();
    let mut law = f64_baseline(&params);
    let mut max_diff = 0.0f64;
    for s in twin.samples() {
        let r = s.r_m / params.plant.quantum_m;
        let y = s.y_counts as f64;
        let a = baseline.step(r, y);
        let b = law.step_quanta(r, y);
        max_diff = max_diff.max((a - b).abs());
    }
    println!(
        "f64 law vs twin PidController: max |Δu| = {max_diff:.3e} V over {} samples",
        twin.samples().len()
    );
    assert!(max_diff < 1e-12);
}

/// Open-loop replay of (r, y) in quanta through the fixed-point controller and the f64 law:
/// (max |Δu|, RMS Δu) in volts.
fn fixed_vs_f64(design: &PidDesign, ry: &[(PositionI48F16, PositionI48F16)]) -> (f64, f64) {
    let mut fixed = FixedPid::new(design).unwrap();
    let mut law = PidF64::new(design).unwrap();
    let (mut max, mut sum2) = (0.0f64, 0.0);
    for &(r, y) in ry {
        let a = fixed.step_positions(r, y);
        let b = law.step_quanta(r.to_f64(), y.to_f64());
        max = max.max((a - b).abs());
        sum2 += (a - b) * (a - b);
    }
    (max, (sum2 / ry.len() as f64).sqrt())
}

fn emps_samples() -> Vec<sledid_host::recording::Sample> {
    let mapping = "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s"
        .parse()
        .unwrap();
    let rec = read_all(EMPS, &ReaderOptions::new(mapping)).unwrap();
    assert_eq!(rec.samples.len(), 24_841);
    rec.samples
}

/// EMPS (r, y) in encoder counts, through the boundary conversion.
fn emps_positions(
    samples: &[sledid_host::recording::Sample],
) -> Vec<(PositionI48F16, PositionI48F16)> {
    let scaling = Scaling::new(EMPS_QUANTUM_M, EMPS_U_FULL_SCALE_V).unwrap();
    samples
        .iter()
        .map(|s| {
            (
                scaling.position(s.r.unwrap()).unwrap(),
                scaling.position(s.y).unwrap(),
            )
        })
        .collect()
}

/// Samples at the start of EMPS whose recorded vir depends on positions before the recording (the
/// two-sample velocity estimate): excluded from the RMS the data README quotes.
const EMPS_PRIMING: usize = 2;

/// RMS of `u − vir` over the whole recording and after the priming samples, volts.
fn vir_rms(u: &[f64], samples: &[sledid_host::recording::Sample]) -> (f64, f64) {
    let err: Vec<f64> = u.iter().zip(samples).map(|(u, s)| u - s.u).collect();
    let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    (rms(&err), rms(&err[EMPS_PRIMING..]))
}

fn replay_fixed(design: &PidDesign, ry: &[(PositionI48F16, PositionI48F16)]) -> Vec<f64> {
    let mut c = FixedPid::new(design).unwrap();
    ry.iter().map(|&(r, y)| c.step_positions(r, y)).collect()
}

#[test]
fn emps_controller_reproduces_the_recorded_drive() {
    let samples = emps_samples();
    let ry = emps_positions(&samples);
    // The README's controller with v̂ the two-sample moving average of the position difference.
    let design = emps_design();
    let u = replay_fixed(&design, &ry);
    let (full, settled) = vir_rms(&u, &samples);
    println!(
        "EMPS, v̂ = moving average of 2 differences: vir RMS error {settled:.5} V (from sample \
         {EMPS_PRIMING}), {full:.5} V over all {} samples",
        samples.len()
    );
    // Alternatives: the plain difference, longer moving averages, a first-order low-pass of the
    // difference (best corner on a grid).
    let mut best_other = f64::INFINITY;
    for n in [1u8, 3, 4] {
        let d = PidDesign {
            derivative_samples: n,
            ..design
        };
        let (_, rms) = vir_rms(&replay_fixed(&d, &ry), &samples);
        println!("  moving average of {n}: {rms:.5} V");
        best_other = best_other.min(rms);
    }
    let mut best_lp = (f64::INFINITY, 0.0);
    for corner_hz in (100..=300).step_by(5) {
        let d = PidDesign {
            derivative_samples: 1,
            derivative_lowpass_hz: f64::from(corner_hz),
            ..design
        };
        let (_, rms) = vir_rms(&replay_fixed(&d, &ry), &samples);
        if rms < best_lp.0 {
            best_lp = (rms, f64::from(corner_hz));
        }
    }
    let beta = (-2.0 * std::f64::consts::PI * best_lp.1 * 1e-3).exp();
    println!(
        "  first-order low-pass of the difference, best corner {} Hz (β = {beta:.3}): {:.5} V",
        best_lp.1, best_lp.0
    );
    best_other = best_other.min(best_lp.0);
    assert!(settled < 0.005, "vir RMS error {settled} V");
    assert!(full < 0.012, "vir RMS error over the whole record {full} V");
    assert!(
        settled < best_other,
        "the two-sample average must match best: {settled} vs {best_other}"
    );
}

/// Bound on |u − u_f64| in full scales: half an output LSB (2⁻¹⁷ = 7.63·10⁻⁶) plus the gains'
/// rounding (2⁻³¹ relative) and the filters' (2⁻¹⁷ quanta per sample).
const FIXED_VS_F64_BOUND: f64 = 8e-6;

#[test]
fn fixed_point_matches_float64_on_twin_and_emps() {
    // Twin: the baseline's recorded (r, y), replayed open loop through several configurations.
    let params = TwinParams::default();
    let twin = Twin::run_baseline(params.clone(), 3).unwrap();
    let ry: Vec<_> = twin
        .samples()
        .iter()
        .map(|s| {
            (
                position_from_quanta(s.r_m / params.plant.quantum_m),
                PositionI48F16::from_counts(s.y_counts),
            )
        })
        .collect();
    let base = baseline_design(&params.controller, params.plant.ts_s, params.plant.u_max_v);
    let u_fs = params.plant.u_max_v;
    let variants = [
        ("baseline", base),
        (
            "prefilter 300 Hz",
            PidDesign {
                reference_lowpass_hz: 300.0,
                ..base
            },
        ),
        (
            "n=3, on y, 200 Hz",
            PidDesign {
                derivative_samples: 3,
                derivative_on: DerivativeOn::Measurement,
                derivative_lowpass_hz: 200.0,
                ..base
            },
        ),
    ];
    for (name, design) in variants {
        let (max, rms) = fixed_vs_f64(&design, &ry);
        println!(
            "twin {name:>18}: max |u − u_f64| = {max:.3e} V = {:.2e} u_fs, RMS {rms:.3e} V",
            max / u_fs
        );
        assert!(max / u_fs < FIXED_VS_F64_BOUND, "{name}: {max} V");
    }
    // EMPS: the rig's controller on the recording.
    let samples = emps_samples();
    let ry = emps_positions(&samples);
    let (max, rms) = fixed_vs_f64(&emps_design(), &ry);
    println!(
        "EMPS: max |u − u_f64| = {max:.3e} V = {:.2e} u_fs, RMS {rms:.3e} V",
        max / EMPS_U_FULL_SCALE_V
    );
    assert!(
        max / EMPS_U_FULL_SCALE_V < FIXED_VS_F64_BOUND,
        "EMPS: {max} V"
    );
}

#[test]
fn enable_is_bumpless() {
    // Open loop, constant error of a quarter quantum: in manual the integrator absorbs
    // u_manual − P, so the first enabled output is u_manual plus one integration step, Ki·Ts·e.
    let params = TwinParams::default();
    let design = baseline_design(&params.controller, params.plant.ts_s, params.plant.u_max_v);
    let (r, y) = (
        position_from_quanta(100.25),
        PositionI48F16::from_counts(100),
    );
    let mut c = FixedPid::new(&design).unwrap();
    c.state_mut().set_enabled(false);
    c.set_manual_output_v(0.05);
    for _ in 0..20 {
        assert!((c.step_positions(r, y) - 0.05).abs() < 1e-4);
        assert!(c.last_flags().contains(PidFlags::MANUAL));
        assert!(!c.last_flags().contains(PidFlags::TRACKING_LIMITED));
    }
    c.state_mut().set_enabled(true);
    let first = c.step_positions(r, y);
    let expected = 0.05 + design.ki_v_per_quantum_s * design.ts_s * 0.25;
    let mut fresh = FixedPid::new(&design).unwrap();
    let without_tracking = fresh.step_positions(r, y);
    println!(
        "manual 0.0500 V → first enabled {first:.5} V (expected {expected:.5} V; a fresh controller \
         gives {without_tracking:.5} V)"
    );
    assert!((first - expected).abs() < 2e-4, "{first} vs {expected}");
    // The f64 law agrees through the transfer.
    let mut law = PidF64::new(&design).unwrap();
    law.set_enabled(false);
    law.set_manual_output_v(0.05);
    for _ in 0..20 {
        law.step_quanta(100.25, 100.0);
    }
    law.set_enabled(true);
    assert!((law.step_quanta(100.25, 100.0) - first).abs() < 1e-4);

    // Closed loop: manual (0 V) for the first 100 samples of a seek, then enabled with a 50 Hz
    // prefilter starting from the measured position: the seek completes and settles.
    let mut params = TwinParams::default();
    params.reference.targets_tracks = Some(vec![200]);
    let mut twin = Twin::new(params.clone(), 1).unwrap();
    let mut c = FixedPid::new(&PidDesign {
        reference_lowpass_hz: 50.0,
        ..design
    })
    .unwrap();
    c.state_mut().set_enabled(false);
    for _ in 0..100 {
        twin.step(&mut c).unwrap();
    }
    c.state_mut().set_enabled(true);
    twin.run(&mut c);
    let stats = twin.seek_stats();
    println!(
        "enabled after 100 samples: settled after {:?} s",
        stats[0].settling_time_s
    );
    assert!(stats[0].settling_time_s.is_some());
}

fn arb_position() -> impl Strategy<Value = PositionI48F16> {
    prop_oneof![
        Just(PositionI48F16::from_raw(i64::MIN)),
        Just(PositionI48F16::from_raw(i64::MAX)),
        (-5_000i64..5_000).prop_map(PositionI48F16::from_counts),
        any::<i64>().prop_map(PositionI48F16::from_raw),
    ]
}

fn arb_design() -> impl Strategy<Value = PidDesign> {
    (
        (
            0.0f64..10.0,
            0.0f64..1e4,
            0.0f64..1e-2,
            0.0f64..2.0,
            0.01f64..10.0,
        ),
        (
            1u8..=4,
            prop_oneof![Just(0.0), 1.0f64..1000.0],
            prop_oneof![Just(0.0), 1.0f64..1000.0],
            any::<bool>(),
        ),
    )
        .prop_map(
            |((kp, ki, kd, i_max, u_max), (n, fd, fr, on_y))| PidDesign {
                kp_v_per_quantum: kp,
                ki_v_per_quantum_s: ki,
                kd_v_s_per_quantum: kd,
                integrator_limit_v: i_max,
                u_limit_v: u_max,
                derivative_samples: n,
                derivative_lowpass_hz: fd,
                reference_lowpass_hz: fr,
                derivative_on: if on_y {
                    DerivativeOn::Measurement
                } else {
                    DerivativeOn::Error
                },
                ..PidDesign::new(0.455e-3, 5.0)
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_input_sequence_is_bounded_and_never_panics(
        design in arb_design(),
        inputs in prop::collection::vec((arb_position(), arb_position(), any::<bool>(), any::<i32>()), 1..200),
    ) {
        let config = design.build().unwrap();
        let limit = config.u_limit().raw().unsigned_abs();
        let mut state = PidState::new();
        for (r, y, enabled, manual) in inputs {
            state.set_enabled(enabled);
            state.set_manual_output(sledid::SignalI16F16::from_raw(manual));
            let out = config.step(&mut state, r, y);
            prop_assert!(out.u.raw().unsigned_abs() <= limit, "|u| = {} > {limit}", out.u.raw());
            prop_assert!(state.integral().raw().unsigned_abs() <= config.integrator_limit().raw().unsigned_abs());
        }
    }

    #[test]
    fn reset_equals_new(
        design in arb_design(),
        inputs in prop::collection::vec((arb_position(), arb_position()), 0..50),
    ) {
        let config = design.build().unwrap();
        let mut state = config.new_state();
        prop_assert_eq!(&state, &PidState::new());
        state.set_enabled(false);
        for (r, y) in inputs {
            config.step(&mut state, r, y);
        }
        state.reset();
        prop_assert_eq!(&state, &PidState::new());
        // And it behaves as new: the same outputs from the same inputs.
        let mut fresh = PidState::new();
        let (r, y) = (PositionI48F16::from_counts(7), PositionI48F16::from_counts(3));
        prop_assert_eq!(config.step(&mut state, r, y), config.step(&mut fresh, r, y));
    }

    #[test]
    fn any_design_builds_or_names_a_parameter(
        kp in prop_oneof![any::<f64>(), -1e6f64..1e6],
        ki in prop_oneof![any::<f64>(), -1e6f64..1e6],
        ts in prop_oneof![any::<f64>(), 1e-6f64..1.0],
        fd in prop_oneof![any::<f64>(), 0.0f64..2000.0],
        n in any::<u8>(),
    ) {
        let design = PidDesign {
            kp_v_per_quantum: kp,
            ki_v_per_quantum_s: ki,
            derivative_samples: n,
            derivative_lowpass_hz: fd,
            ..PidDesign::new(ts, 5.0)
        };
        if let Err(e) = design.build() {
            prop_assert!(!e.to_string().is_empty());
        }
    }
}
