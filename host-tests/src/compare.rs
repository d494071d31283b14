//! Runs a fixed-point estimator and its float64 reference side by side on the same quantised data
//! and measures how far apart they are: the accuracy evidence for every numeric kernel.

use crate::reference::batch::{rms_error, simulate};
use crate::reference::linear::LinearF64;
use sledid::SignalI16F16;
use sledid::ident::linear::LinearDesign;

/// How far the fixed-point estimate is from the float64 one.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// max over samples ≥ `skip` of ‖θ_fx − θ_f64‖₂ / ‖θ_f64‖₂.
    pub max_rel_theta_err: f64,
    /// The same at the last sample.
    pub final_rel_theta_err: f64,
    /// Final fixed-point θ.
    pub theta_fx: Vec<f64>,
    /// Final float64 θ.
    pub theta_f64: Vec<f64>,
    /// Simulation RMS of the final fixed-point model on the data.
    pub sim_rms_fx: f64,
    /// Simulation RMS of the final float64 model on the data.
    pub sim_rms_f64: f64,
    /// Samples on which the fixed-point estimator updated.
    pub updates_fx: usize,
    /// Samples on which the float64 estimator updated.
    pub updates_f64: usize,
    /// Samples where the two took different decisions (update vs skip, projection).
    pub decision_mismatches: usize,
    /// Samples flagged saturated by the fixed-point path.
    pub saturated: usize,
}

/// Quantises a signal to the I16F16 grid (what the fixed-point path sees), saturating.
pub fn to_signal(x: f64) -> SignalI16F16 {
    SignalI16F16::from_f64(x.clamp(-32768.0, 32767.99)).unwrap_or(SignalI16F16::ZERO)
}

/// How the float64 reference takes its gate decisions (dead zone, excitation, hold).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decisions {
    /// On its own: decision flips near a gate threshold count against the fixed-point path.
    Free,
    /// Follows the fixed-point path's update/skip decision: the comparison measures arithmetic only
    /// (flips are still counted in `decision_mismatches`).
    Locked,
}

/// Runs both estimators over conditioned `(y, u)` and compares them.
pub fn compare_linear<const N: usize>(
    design: &LinearDesign<N>,
    y: &[f64],
    u: &[f64],
    skip: usize,
    decisions: Decisions,
) -> Comparison {
    let cfg = design.build().expect("valid design");
    let mut st = cfg.new_state();
    let mut reference = LinearF64::new(design);
    let mut max_rel = 0.0f64;
    let mut final_rel = 0.0;
    let (mut upd_fx, mut upd_f64, mut mismatch, mut sat) = (0, 0, 0, 0);
    let yq: Vec<SignalI16F16> = y.iter().map(|&v| to_signal(v)).collect();
    let uq: Vec<SignalI16F16> = u.iter().map(|&v| to_signal(v)).collect();
    for t in 0..y.len() {
        let e = cfg.step(&mut st, yq[t], uq[t]);
        let fx_up = e.status.contains(sledid::Status::UPDATED);
        let force = (decisions == Decisions::Locked).then_some(fx_up);
        let r = reference.step_forced(yq[t].to_f64(), uq[t].to_f64(), force);
        let f_up = r.status.contains(sledid::Status::UPDATED);
        upd_fx += usize::from(fx_up);
        upd_f64 += usize::from(f_up);
        mismatch += usize::from(
            fx_up != f_up
                || reference.rls.last_overridden
                || e.status.contains(sledid::Status::PROJECTED)
                    != r.status.contains(sledid::Status::PROJECTED),
        );
        sat += usize::from(e.status.contains(sledid::Status::SATURATED));
        let th_fx: Vec<f64> = st.theta().iter().map(|p| p.to_f64()).collect();
        final_rel = relative_distance(&th_fx, reference.theta());
        if t >= skip {
            max_rel = max_rel.max(final_rel);
        }
    }
    let theta_fx: Vec<f64> = st.theta().iter().map(|p| p.to_f64()).collect();
    let theta_f64 = reference.theta().to_vec();
    let yd: Vec<f64> = yq.iter().map(|v| v.to_f64()).collect();
    let ud: Vec<f64> = uq.iter().map(|v| v.to_f64()).collect();
    let sim_fx = simulate(&theta_fx, &ud, design.na, design.nk);
    let sim_f = simulate(&theta_f64, &ud, design.na, design.nk);
    Comparison {
        max_rel_theta_err: max_rel,
        final_rel_theta_err: final_rel,
        sim_rms_fx: rms_error(&sim_fx, &yd),
        sim_rms_f64: rms_error(&sim_f, &yd),
        theta_fx,
        theta_f64,
        updates_fx: upd_fx,
        updates_f64: upd_f64,
        decision_mismatches: mismatch,
        saturated: sat,
    }
}

/// How much a problem's estimate moves when only the signal format changes.
#[derive(Clone, Copy, Debug)]
pub struct Sensitivity {
    /// max over samples ≥ `skip` of the relative θ distance.
    pub max_rel_theta: f64,
    /// Relative difference of the final models' simulation RMS.
    pub sim_rms_rel: f64,
}

/// The problem's own sensitivity to the signal format: the float64 reference against the same
/// reference with its internal signals (ŷ, ψ) rounded to the I16F16 grid. An ill-posed problem (a
/// valley in the criterion) shows large values here: no 32-bit signal format can do better.
pub fn signal_grid_sensitivity<const N: usize>(
    design: &LinearDesign<N>,
    y: &[f64],
    u: &[f64],
    skip: usize,
) -> Sensitivity {
    let mut exact = LinearF64::new(design);
    let mut gridded = LinearF64::new(design);
    gridded.signal_grid = true;
    let mut max_rel = 0.0f64;
    for t in 0..y.len() {
        let (yq, uq) = (to_signal(y[t]).to_f64(), to_signal(u[t]).to_f64());
        exact.step(yq, uq);
        gridded.step(yq, uq);
        if t >= skip {
            max_rel = max_rel.max(relative_distance(gridded.theta(), exact.theta()));
        }
    }
    let yd: Vec<f64> = y.iter().map(|&v| to_signal(v).to_f64()).collect();
    let ud: Vec<f64> = u.iter().map(|&v| to_signal(v).to_f64()).collect();
    let rms = |th: &[f64]| rms_error(&simulate(th, &ud, design.na, design.nk), &yd);
    let (a, b) = (rms(gridded.theta()), rms(exact.theta()));
    Sensitivity {
        max_rel_theta: max_rel,
        sim_rms_rel: (a - b).abs() / b.max(1e-12),
    }
}

/// ‖a − b‖₂ / ‖b‖₂ (denominator floored at 1e-9).
pub fn relative_distance(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, z)| (x - z).powi(2))
        .sum::<f64>()
        .sqrt();
    num / b.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-9)
}
