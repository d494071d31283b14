//! The fixed-point estimators against float64 on a real closed-loop recording: the EMPS positioning
//! axis (u = controller output, y = encoder position, Ts = 1 ms, 24,841 samples).
//!
//! The axis integrates, so the model is velocity against drive: Δy(t) (counts per sample) regressed on
//! Δy(t−1…) and u(t−1…) (fraction of 10 V) — `Conditioning::DifferencedOutput`, exactly as the
//! per-sample step conditions it. (Differencing u as well makes Δu ~10⁻⁴ of full scale, a few LSBs of
//! I16F16; there the fixed-point estimate loses its precision. That scaling is outside the range
//! analysis of `src/fixed.rs` and documented in `src/conditioning.rs`.)

use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::compare::{Decisions, compare_linear, signal_grid_sensitivity};
use sledid_host::recording::{ReaderOptions, read_all};

const EMPS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../shared/data/emps/DATA_EMPS.csv"
);
/// Position unit at the boundary: 10 µm (200 encoder counts of 5e-8 m), so that |Δy| is 1–30 units
/// per sample, of the order of u. The kernel's U factor is absolute I8F24, so its accuracy depends
/// on this balance; measured max relative θ error of ARX(1,1), λ = 1, against float64 UD:
/// unit 5e-8 m (|Δy| ~ 10³) 2.6e-2; 1e-6 m 1.8e-3; 1e-5 m 6.1e-4. A scale-invariant U (one exponent
/// per column) is the open fix.
const QUANTUM_M: f64 = 1e-5;
/// Full scale used to normalise the drive.
const U_FULL_SCALE_V: f64 = 10.0;

fn emps_velocity_and_drive() -> (Vec<f64>, Vec<f64>) {
    let mapping = "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s"
        .parse()
        .expect("mapping");
    let rec = read_all(EMPS, &ReaderOptions::new(mapping)).expect("EMPS recording");
    assert_eq!(rec.samples.len(), 24_841);
    let y: Vec<f64> = rec.samples.iter().map(|s| s.y / QUANTUM_M).collect();
    let u: Vec<f64> = rec.samples.iter().map(|s| s.u / U_FULL_SCALE_V).collect();
    // Δy(t) = y(t) − y(t−1) and u(t), t ≥ 1 (the regressor's nk = 1 pairs Δy(t) with u(t−1)).
    let dy: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    (dy, u[1..].to_vec())
}

#[test]
fn emps_arx_and_output_error_agree_with_float64() {
    let (y, u) = emps_velocity_and_drive();
    let designs: Vec<(&str, Structure, RlsDesign, Decisions)> = vec![
        // P₀ = 10: with |Δy| ~ 10³ counts a larger P₀ throws the first gains past θ's ±2048 range.
        (
            "ARX λ=1",
            Structure::Arx,
            RlsDesign {
                p0: 10.0,
                ..RlsDesign::default()
            },
            Decisions::Free,
        ),
        (
            "ARX λ=0.995 trace≤1e3",
            Structure::Arx,
            RlsDesign {
                lambda: 0.995,
                p0: 10.0,
                anti_windup: AntiWindup::TraceLimit { max: 10.0 },
                ..RlsDesign::default()
            },
            Decisions::Free,
        ),
        (
            "RPEM OE λ=1",
            Structure::OutputErrorPredictionError,
            RlsDesign {
                p0: 10.0,
                ..RlsDesign::default()
            },
            Decisions::Free,
        ),
    ];
    for (name, structure, rls, dec) in designs {
        for (na, nb) in [(1usize, 1usize), (2, 2)] {
            let (c, sens, label) = if na == 1 {
                let mut d = LinearDesign::<2>::new(structure, na, nb);
                d.rls = rls;
                let sens = signal_grid_sensitivity(&d, &y, &u, 200);
                (
                    compare_linear(&d, &y, &u, 200, dec),
                    sens,
                    format!("{name} n=2"),
                )
            } else {
                let mut d = LinearDesign::<4>::new(structure, na, nb);
                d.rls = rls;
                let sens = signal_grid_sensitivity(&d, &y, &u, 200);
                (
                    compare_linear(&d, &y, &u, 200, dec),
                    sens,
                    format!("{name} n=4"),
                )
            };
            let rms_rel = (c.sim_rms_fx - c.sim_rms_f64).abs() / c.sim_rms_f64;
            println!(
                "{label:<26} max rel θ err {:.2e} final {:.2e} | sim RMS fx {:.3} f64 {:.3} counts/sample ({:.1e}) | flips {} sat {} | θ {:?}",
                c.max_rel_theta_err,
                c.final_rel_theta_err,
                c.sim_rms_fx,
                c.sim_rms_f64,
                rms_rel,
                c.decision_mismatches,
                c.saturated,
                c.theta_f64
            );
            assert_eq!(c.saturated, 0, "{label}");
            // n = 4 is held to 4e-3: see QUANTUM_M. Its maximum over the record is a rounding-luck
            // figure: rounding one intermediate of the old kernel (κⱼ's start) instead of truncating
            // it moved it from 1.87e-3 to 2.94e-3 (λ = 0.995) and 1.57e-3 to 1.08e-3 (λ = 1); the
            // 2026-11 kernel measures 2.54e-3 / 2.17e-3; over 24 position units within ±1.7 % the
            // spread of the final error is alike for both kernels (`emps_arx_rounding_spread`).
            // It was held to 2e-3 until then. Simulation
            // RMS of a model with its pole at 0.996 (DC gain ~250) amplifies 1e-4 in a₁ to ~1 %:
            // held to 1.5 %.
            // Output error on EMPS: measured 2.9e-3 (n = 2) against a signal-grid sensitivity of
            // 5e-6, i.e. the kernel's absolute-I8F24 U again (see QUANTUM_M). Held to 5e-3 so a
            // regression shows; reaching 1e-3 needs the scale-invariant U (open).
            let arx_bound: f64 = if na == 1 { 1e-3 } else { 4e-3 };
            let bound = if structure == Structure::Arx {
                arx_bound
            } else {
                5e-3
            };
            println!(
                "{label:<26} signal-grid sensitivity θ {:.2e}, sim RMS {:.2e}",
                sens.max_rel_theta, sens.sim_rms_rel
            );
            // Second-order OE on this record sits in a valley of its criterion (θ moves 6.5e-2 while
            // the simulation RMS agrees to 6e-4): there only the simulation RMS is asserted.
            if !(structure != Structure::Arx && na == 2) {
                assert!(
                    c.max_rel_theta_err < bound,
                    "{label}: {}",
                    c.max_rel_theta_err
                );
            }
            // Output error: measured 1.6 % (n = 2), same cause as above; held to 2.5 %.
            let rms_bound = if structure == Structure::Arx {
                0.015
            } else {
                0.025
            };
            assert!(rms_rel < rms_bound, "{label}: sim RMS {rms_rel}");
        }
    }
}

/// How much of the EMPS ARX(2,2) figure is rounding luck: the `replay` pipeline (Differenced
/// output, ARX(2,2), λ 0.995, the replay defaults) at 24 position units within ±1.7 % of 10 µm,
/// printing the spread of the final θ relative error and of the simulation-RMS ratio. A measurement,
/// not an assertion (`cargo test -p sledid-host --test integration emps_vs_f64:: -- --ignored --nocapture`).
/// Measured 2026-11: kernel before the cost work median 1.10e-3, mean 1.45e-3, max 3.84e-3; after
/// it median 1.27e-3, mean 1.29e-3, max 2.79e-3.
#[test]
#[ignore = "a measurement (24 replays of the whole record), run on demand"]
fn emps_arx_rounding_spread() {
    use sledid::ident::conditioning::Conditioning;
    use sledid_host::replay::{ReplaySpec, replay};
    let mut errs = Vec::new();
    let mut rms = Vec::new();
    for i in 0..24 {
        let mut s = ReplaySpec::new(ReaderOptions::new(
            "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s"
                .parse()
                .expect("mapping"),
        ));
        s.conditioning = Conditioning::DifferencedOutput;
        s.y_unit = QUANTUM_M * (1.0 + 0.0007 * f64::from(i));
        s.u_full_scale = U_FULL_SCALE_V;
        s.progress = false;
        let out = std::env::temp_dir().join(format!("sledid-spread-{}-{i}", std::process::id()));
        let sum = replay(std::path::Path::new(EMPS), &s, &out).expect("replay");
        errs.push(sum.theta_rel_err);
        rms.push((sum.sim_rms / sum.sim_rms_f64 - 1.0).abs());
        let _ = std::fs::remove_dir_all(out);
    }
    errs.sort_by(f64::total_cmp);
    rms.sort_by(f64::total_cmp);
    let n = errs.len();
    println!(
        "final θ rel. err over {n} units: median {:.2e} mean {:.2e} max {:.2e}; sim RMS rel. median {:.2e} max {:.2e}",
        errs[n / 2],
        errs.iter().sum::<f64>() / n as f64,
        errs[n - 1],
        rms[n / 2],
        rms[n - 1]
    );
}
