//! Fixed-point estimators against their float64 references on closed-loop, quantised data.
//!
//! Bounds (see `src/rls.rs`, "Accuracy"):
//! - well-posed problems (ARX on any data; OE on adequately excited data): θ within 1e-3 relative of
//!   float64 at every sample after the first 200, simulation RMS within 1 %;
//! - gated estimators (dead zone) are compared with the reference locked to the fixed-point path's
//!   gate decisions, so a flip of ε across the threshold by one rounding does not count as arithmetic
//!   error (the flips are counted and printed);
//! - ill-posed problems (second-order OE on poorly excited data: a valley in the criterion, as in
//!   the paper's Fig. 8) amplify any perturbation: there the fixed-point deviation is asserted to be
//!   within 3× the problem's own sensitivity to the signal format (float64 vs float64 with ŷ and ψ on
//!   the I16F16 grid, [`signal_grid_sensitivity`]) and the simulation RMS within 1 %.

use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::compare::{Comparison, Decisions, compare_linear, signal_grid_sensitivity};
use sledid_host::plants::{ClosedLoopSpec, closed_loop};

fn first_order(dither: f64) -> ClosedLoopSpec {
    ClosedLoopSpec {
        a: vec![-0.95],
        b: vec![1.5],
        kp: 0.05,
        dither,
        step_every: 300,
        step_max: 40.0,
        samples: 20_000,
        seed: 7,
    }
}

fn second_order(dither: f64, seed: u64) -> ClosedLoopSpec {
    ClosedLoopSpec {
        a: vec![-1.9, 0.905],
        b: vec![0.5, 0.45],
        kp: 0.01,
        dither,
        step_every: 400,
        step_max: 60.0,
        samples: 20_000,
        seed,
    }
}

fn differenced(v: &[f64]) -> Vec<f64> {
    v.windows(2).map(|w| w[1] - w[0]).collect()
}

fn plain() -> RlsDesign {
    RlsDesign {
        lambda: 1.0,
        p0: 1e4,
        ..RlsDesign::default()
    }
}

fn windup_guarded() -> RlsDesign {
    RlsDesign {
        lambda: 0.995,
        p0: 100.0,
        dead_zone: 0.25,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    }
}

fn report(name: &str, c: &Comparison, rms_tolerance: f64) -> f64 {
    let rms_rel = (c.sim_rms_fx - c.sim_rms_f64).abs() / c.sim_rms_f64.max(1e-12);
    println!(
        "{name:<52} max rel θ err {:.2e} final {:.2e} | sim RMS fx {:.4} f64 {:.4} ({:.1e}) | updates {}/{} flips {} sat {}",
        c.max_rel_theta_err,
        c.final_rel_theta_err,
        c.sim_rms_fx,
        c.sim_rms_f64,
        rms_rel,
        c.updates_fx,
        c.updates_f64,
        c.decision_mismatches,
        c.saturated
    );
    assert_eq!(c.saturated, 0, "{name}: saturation");
    assert!(
        rms_rel < rms_tolerance,
        "{name}: simulation RMS differs by {rms_rel}"
    );
    rms_rel
}

fn well_posed<const N: usize>(
    name: &str,
    d: LinearDesign<N>,
    y: &[f64],
    u: &[f64],
    dec: Decisions,
) {
    let c = compare_linear(&d, y, u, 200, dec);
    report(name, &c, 0.01);
    assert!(
        c.max_rel_theta_err < 1e-3,
        "{name}: θ relative error {}",
        c.max_rel_theta_err
    );
}

#[test]
fn arx_meets_1e_3_on_every_setting() {
    let rec1 = closed_loop(&first_order(0.02));
    let rec2 = closed_loop(&second_order(0.02, 11));
    for (sname, rls, dec) in [
        ("λ=1", plain(), Decisions::Free),
        (
            "λ=0.995 trace≤100 dz=¼q (locked)",
            windup_guarded(),
            Decisions::Locked,
        ),
    ] {
        let mut d2 = LinearDesign::<2>::new(Structure::Arx, 1, 1);
        d2.rls = rls;
        well_posed(
            &format!("ARX n=2 {sname}"),
            d2,
            &differenced(&rec1.y),
            &differenced(&rec1.u),
            dec,
        );
        let mut d4 = LinearDesign::<4>::new(Structure::Arx, 2, 2);
        d4.rls = rls;
        well_posed(
            &format!("ARX n=4 {sname}"),
            d4,
            &differenced(&rec2.y),
            &differenced(&rec2.u),
            dec,
        );
    }
}

#[test]
fn first_order_output_error_meets_1e_3() {
    let rec = closed_loop(&first_order(0.02));
    let (y, u) = (differenced(&rec.y), differenced(&rec.u));
    for s in [
        Structure::OutputErrorPseudoLinear,
        Structure::OutputErrorPredictionError,
    ] {
        let mut d = LinearDesign::<2>::new(s, 1, 1);
        d.rls = plain();
        well_posed(&format!("{s:?} n=2 λ=1"), d, &y, &u, Decisions::Free);
        d.rls = windup_guarded();
        well_posed(
            &format!("{s:?} n=2 guarded (locked)"),
            d,
            &y,
            &u,
            Decisions::Locked,
        );
    }
}

#[test]
fn second_order_output_error_meets_1e_3_when_excited() {
    let rec = closed_loop(&second_order(0.1, 11));
    let (y, u) = (differenced(&rec.y), differenced(&rec.u));
    for s in [
        Structure::OutputErrorPseudoLinear,
        Structure::OutputErrorPredictionError,
    ] {
        let mut d = LinearDesign::<4>::new(s, 2, 2);
        d.rls = plain();
        well_posed(
            &format!("{s:?} n=4 λ=1 dither 0.1"),
            d,
            &y,
            &u,
            Decisions::Free,
        );
    }
}

#[test]
fn second_order_output_error_is_within_the_problems_own_sensitivity_when_poorly_excited() {
    for seed in [11, 12, 13] {
        let rec = closed_loop(&second_order(0.02, seed));
        let (y, u) = (differenced(&rec.y), differenced(&rec.u));
        let mut d = LinearDesign::<4>::new(Structure::OutputErrorPredictionError, 2, 2);
        d.rls = RlsDesign {
            p0: 100.0,
            ..plain()
        };
        let c = compare_linear(&d, &y, &u, 200, Decisions::Free);
        let sens = signal_grid_sensitivity(&d, &y, &u, 200);
        println!(
            "seed {seed}: problem sensitivity to the I16F16 signal grid: θ {:.2e}, sim RMS {:.2e}",
            sens.max_rel_theta, sens.sim_rms_rel
        );
        report(
            &format!("RPEM OE n=4 poorly excited seed {seed}"),
            &c,
            0.01f64.max(3.0 * sens.sim_rms_rel),
        );
        assert!(
            c.max_rel_theta_err < 1e-3 || c.max_rel_theta_err < 3.0 * sens.max_rel_theta,
            "seed {seed}: fixed-point deviation {} vs problem sensitivity {:?}",
            c.max_rel_theta_err,
            sens
        );
    }
}
