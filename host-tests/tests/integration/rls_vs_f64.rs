//! Fixed-point estimators against their float64 references on closed-loop, quantised data.
//!
//! Bounds (see `src/rls.rs`, "Accuracy"):
//! - well-posed problems (ARX on any data; second-order OE on adequately excited data): θ within
//!   1e-3 relative of float64 at every sample after the first 200, simulation RMS within 1 %;
//! - first-order OE on the closed-loop records of seeds 1–24: the criterion below (1e-3 or 3× the
//!   problem's own sensitivity) on all but a few of the 96 cases — many of these fits are
//!   ill-conditioned, and a single seed passed by its seed
//!   (`first_order_output_error_is_within_the_problems_own_sensitivity_over_seeds`);
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

/// First-order OE (pseudo-linear and prediction-error, λ = 1 and windup-guarded with a dead zone,
/// the guarded ones with the reference locked to the fixed point's gate decisions) on the
/// closed-loop records of seeds 1–24: per case θ within 1·10⁻³ of float64 or within 3× the
/// problem's own sensitivity to the signal format ([`signal_grid_sensitivity`]), and the
/// simulation RMS within 1 % (or 3× its sensitivity), on all but [`OE_CASES_BEYOND_MAX`] of the
/// 96 cases; no case saturated.
///
/// Until 2026-12-08 this was seed 7 alone against 1·10⁻³, and it passed by its seed: over seeds
/// 1–24, 25 of the 96 cases were over 1·10⁻³ (27 since the stability projection's trial steps
/// keep θ's full precision, `sledid::ident::stability`, "Accuracy" — which took seed 7's guarded
/// prediction-error case itself from 4.5·10⁻⁴ to 3.5·10⁻³). In 23 of those 25 the float64 reference is as far from itself
/// with its signals on the I16F16 grid (e.g. seed 11, prediction error, λ = 1: 5.1 against 5.1;
/// seed 3: 2.3 against 2.3): the first-order OE fits of these records are ill-conditioned — the
/// filter's and the projection's decisions flip on the last bits of the signals — and the fixed
/// point's distance is that, not its arithmetic. Measured (`cargo test -p sledid-host --test
/// integration rls_vs_f64::first_order -- --nocapture` prints every case beyond 1·10⁻³): 1 of 96
/// beyond the criterion (seed 24, prediction error, λ = 1: 1.6·10⁻³ against 3 × 3.0·10⁻⁴, 5,474
/// decisions apart); 2 before the projection kept θ's precision (seed 18's guarded prediction
/// error too: 0.13 against 3 × 1.6·10⁻²). Trips on a kernel with a systematic error, which moves
/// most cases at once — γ₀ = 1/(λ·4^σ) off by a factor 2 in the column chain: 62 of 96 beyond
/// (measured; the U update's truncated high word, which `unit_sweep`'s N = 4 records catch, leaves
/// N = 2 at 2 of 96) — not on a 10⁻⁵ change of its rounding.
#[test]
fn first_order_output_error_is_within_the_problems_own_sensitivity_over_seeds() {
    let mut beyond = Vec::new();
    for seed in 1..=24u64 {
        let mut spec = first_order(0.02);
        spec.seed = seed;
        let rec = closed_loop(&spec);
        let (y, u) = (differenced(&rec.y), differenced(&rec.u));
        for s in [
            Structure::OutputErrorPseudoLinear,
            Structure::OutputErrorPredictionError,
        ] {
            for (guard, rls, dec) in [
                ("λ=1", plain(), Decisions::Free),
                ("guarded (locked)", windup_guarded(), Decisions::Locked),
            ] {
                let mut d = LinearDesign::<2>::new(s, 1, 1);
                d.rls = rls;
                let c = compare_linear(&d, &y, &u, 200, dec);
                let sens = signal_grid_sensitivity(&d, &y, &u, 200);
                let rms_rel = (c.sim_rms_fx - c.sim_rms_f64).abs() / c.sim_rms_f64.max(1e-12);
                assert_eq!(c.saturated, 0, "seed {seed} {s:?} {guard}: saturation");
                let theta_ok =
                    c.max_rel_theta_err < 1e-3 || c.max_rel_theta_err < 3.0 * sens.max_rel_theta;
                let rms_ok = rms_rel < 0.01f64.max(3.0 * sens.sim_rms_rel);
                if c.max_rel_theta_err >= 1e-3 || !rms_ok {
                    println!(
                        "seed {seed} {s:?} {guard}: θ {:.2e} (the problem's own {:.2e}), sim RMS \
                         {rms_rel:.1e} (own {:.1e}), {} decisions apart{}",
                        c.max_rel_theta_err,
                        sens.max_rel_theta,
                        sens.sim_rms_rel,
                        c.decision_mismatches,
                        if theta_ok && rms_ok { "" } else { ": BEYOND" }
                    );
                }
                if !(theta_ok && rms_ok) {
                    beyond.push((seed, s, guard));
                }
            }
        }
    }
    println!("{} of 96 cases beyond the criterion", beyond.len());
    assert!(
        beyond.len() <= OE_CASES_BEYOND_MAX,
        "{} of 96 first-order OE cases beyond 1e-3 and 3× the problem's own sensitivity: {beyond:?}",
        beyond.len()
    );
}

/// Cases of the 96 in `first_order_output_error_is_within_the_problems_own_sensitivity_over_seeds`
/// allowed beyond its criterion: measured 1 (2 with the projection's previous rounding), one more
/// than the larger so that a change of the rounding's last bit does not flip the test.
const OE_CASES_BEYOND_MAX: usize = 3;

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
