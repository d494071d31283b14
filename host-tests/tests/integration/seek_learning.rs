//! The seeks' gain learner (`sledid::control::scheduled::learn`, issue 22 item 4): its per-seek
//! ratio against the float64 reference on simulated seeks, and in the closed loop the fast
//! corner sleds — whose calibrated gain is 5–12 % off and whose seeks last two or three samples —
//! learning their gain and landing their seeks.

use sledid::control::scheduled::learn::{RATIO_ONE, SeekGainLearner};
use sledid::control::{Redesign, SeekPlan};
use sledid_host::control::design::{design_from_prior, physical_model};
use sledid_host::control::family::{Corner, FamilyRanges};
use sledid_host::control::seek::run::{SeekController, SeekOptions, run_seeks, seek_design};
use sledid_host::reference::seek::sampled_f64;
use sledid_host::reference::seek_gain::seek_ratio;
use sledid_host::twin::TwinParams;

/// One simulated seek of a first-order sled whose gain is `rho` times the plan's (a, b): `n1`
/// samples at `u1` full scale, then braking at −u1/2 while the plan's model still advances; the
/// readings rounded (with a deterministic ±`noise` quantum dither). Returns (drives, readings).
fn simulated_seek(
    a: f64,
    b: f64,
    rho: f64,
    n1: usize,
    u1: f64,
    noise: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (c1, b0) = sampled_f64(a, b);
    let (mut x, mut v, mut vm) = (0.3, 0.0, 0.0);
    let mut drives = Vec::new();
    let mut readings = vec![0.0];
    for k in 0..4000 {
        let u = if k < n1 { u1 } else { -0.5 * u1 };
        let next_vm = a * vm + b * u;
        if k >= n1 && next_vm <= 0.0 {
            break;
        }
        vm = next_vm;
        x += c1 * v + rho * b0 * u;
        v = a * v + rho * b * u;
        let dither = noise * ((k as f64 * 2.399).sin());
        drives.push(u);
        readings.push((x + dither).round());
    }
    (drives, readings)
}

/// The library's r for the same seek (I16F16 → f64), or `None` when the seek taught nothing.
fn fixed_ratio(a: f64, b: f64, drives: &[f64], readings: &[f64]) -> Option<f64> {
    let plan = SeekPlan::design(a as f32, b as f32, 0.0, 1.0, 0.7, 0.0).expect("plan");
    let mut learner = SeekGainLearner::new();
    let raw = |q: f64| (q * 65_536.0) as i64;
    learner.start(raw(readings[0]), raw(1e6));
    for (u, y) in drives.iter().zip(readings.iter().skip(1)) {
        learner.step(&plan, (u * 65_536.0).round() as i32, raw(*y));
    }
    learner.finish();
    (learner.seeks() > 0).then(|| f64::from(learner.estimate()) / f64::from(RATIO_ONE))
}

/// The fixed-point per-seek ratio follows the float64 reference within 2·10⁻³ (relative;
/// measured 5.4·10⁻⁴) and the reference estimates the sled's true gain ratio within 3 %
/// (measured 9.4·10⁻³) on simulated seeks of fast, nominal-like
/// and slow sleds (a 0.83 / 0.97 / 0.45) whose gain is 0.7–1.4 × the plan's, readings quantised
/// with a ±0.3-quantum dither. Trips on: a wrong sampled model (c₁, b₀) in the learner, a sum
/// that loses bits, a window that runs past the sled's first stop.
#[test]
fn fixed_point_ratio_tracks_float64_on_simulated_seeks() {
    let mut worst_fixed: f64 = 0.0;
    let mut worst_truth: f64 = 0.0;
    let mut cases = 0;
    for (a, b, n1, u1) in [
        (0.834, 236.6, 1, 0.5),
        (0.834, 236.6, 2, 1.0),
        (0.97, 2.0, 40, 1.0),
        (0.97, 2.0, 8, 0.6),
        (0.45, 0.8, 300, 1.0),
    ] {
        for rho in [0.7, 0.9, 1.1, 1.4] {
            let (drives, readings) = simulated_seek(a, b, rho, n1, u1, 0.3);
            let f64_ratio = seek_ratio(a, b, &drives, &readings, 1e6).expect("a long seek");
            let fixed = fixed_ratio(a, b, &drives, &readings).expect("a long seek");
            worst_fixed = worst_fixed.max((fixed / f64_ratio - 1.0).abs());
            worst_truth = worst_truth.max((f64_ratio / rho - 1.0).abs());
            cases += 1;
        }
    }
    println!(
        "{cases} seeks: fixed vs f64 {worst_fixed:.2e}, f64 vs the true ratio {worst_truth:.2e}"
    );
    assert!(worst_fixed <= 2e-3, "fixed point vs f64: {worst_fixed}");
    assert!(worst_truth <= 0.03, "estimate vs truth: {worst_truth}");
}

/// A seek whose response stays under 20 quanta teaches nothing (its quantisation would be more
/// than 2.5 % of it). Trips on: a missing or misscaled gate.
#[test]
fn a_short_seek_teaches_nothing() {
    let (drives, readings) = simulated_seek(0.97, 2.0, 1.0, 2, 0.5, 0.0);
    assert!(readings.last().copied().unwrap_or(0.0) < 20.0);
    assert_eq!(fixed_ratio(0.97, 2.0, &drives, &readings), None);
    assert_eq!(seek_ratio(0.97, 2.0, &drives, &readings, 1e6), None);
}

/// The last placed model's gain of each run of `corner` (calibrated seek mode, nominal prior, 40
/// seeks, run seeds 1–3) over the true gain, and calibration's, and the runs' access / bound.
fn corner_runs(corner: Corner) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let params = FamilyRanges::default()
        .corner(corner)
        .twin(&TwinParams::default());
    let b_true = physical_model(&params.plant).1;
    let design = seek_design(design_from_prior(&params, &TwinParams::default().plant).unwrap());
    let (mut learnt, mut calibrated, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 1..=3 {
        let options = SeekOptions {
            calibrate: true,
            seeks: 40,
            seed,
            ..SeekOptions::default()
        };
        let run = run_seeks(&params, &SeekController::Seek(design), &options).unwrap();
        let cal = run.run.calibration.as_ref().and_then(|c| c.model).unwrap();
        calibrated.push(f64::from(cal.b()) / b_true);
        let last = run.run.redesigns.iter().rev().find_map(|r| match r {
            Redesign::Applied(m) => Some(f64::from(m.b)),
            _ => None,
        });
        learnt.push(last.unwrap_or(f64::from(cal.b())) / b_true);
        ratios.extend(run.rows.iter().map(|r| match (r.settled, r.ratio) {
            (true, Some(x)) => x,
            _ => f64::INFINITY,
        }));
    }
    ratios.sort_by(f64::total_cmp);
    (learnt, calibrated, ratios)
}

/// The fast, free corner sled (gain in quanta 10× the prior's; its seeks last two samples):
/// calibration leaves its gain ≈ 5 % high, which a two-sample seek turns into ≈ 15 tracks of
/// overshoot. After 40 seeks the placed gain is within 3 % of the truth on every run seed, and
/// the seeks meet issue 22's access targets: access / bound median ≤ 1.5, p95 ≤ 2.5 over the
/// three runs' 120 seeks (measured 2026-11-27: learnt gain 1.003 / 1.006 / 1.005× the truth
/// against calibration's 1.050×; median 1.00, p95 2.33 — without learning 2.00 and 3.00 over
/// run seeds 1–5, `sledid seek --plant` on the corner). Trips on: a learner that does not learn, learns the wrong way, or whose redesign is
/// not adopted.
#[test]
fn the_fast_free_corner_learns_its_gain_and_lands() {
    let (learnt, calibrated, ratios) = corner_runs(Corner::FastFree);
    let n = ratios.len();
    let (median, p95) = (ratios[n / 2], ratios[n * 95 / 100]);
    println!(
        "fast free: learnt {learnt:.3?}, calibrated {calibrated:.3?}, median {median:.2}, p95 {p95:.2}"
    );
    assert!(learnt.iter().all(|r| (r - 1.0).abs() <= 0.03), "{learnt:?}");
    assert!(median <= 1.5 && p95 <= 2.5, "median {median}, p95 {p95}");
}

/// The fast, sticky corner sled (stiction 3× its Coulomb level): calibration leaves its gain
/// 2–21 % high; after 40 seeks the placed gain is closer to the truth than calibration's on
/// every run seed and within 6 % of it (measured 2026-11-27, run seeds 1–3: learnt 0.997 /
/// 0.947 / 0.997× the truth against calibration's 1.118 / 1.210 / 1.018×). Its seeks still
/// fail (the sled sticks short of the target and the settle law's integrator does not break it
/// away in time; issue 22's notes) — not asserted here. Trips on: a learner whose window runs
/// into the sticking (the gain learnt low) or that does not learn.
#[test]
fn the_fast_sticky_corner_learns_its_gain() {
    let (learnt, calibrated, ratios) = corner_runs(Corner::FastSticky);
    let n = ratios.len();
    println!(
        "fast sticky: learnt {learnt:.3?}, calibrated {calibrated:.3?}, median {:.2}, p95 {:.2}",
        ratios[n / 2],
        ratios[n * 95 / 100]
    );
    for (l, c) in learnt.iter().zip(&calibrated) {
        assert!(
            (l - 1.0).abs() < (c - 1.0).abs(),
            "{learnt:?} vs {calibrated:?}"
        );
        assert!((l - 1.0).abs() <= 0.06, "{learnt:?}");
    }
}
