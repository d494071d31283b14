//! Windup: 10⁶ samples of the sled twin holding a constant reference in its ±1-quantum limit cycle
//! (closed loop, no excitation but the limit cycle), through the shared per-sample `step`.
//!
//! With λ < 1 and the anti-windup on (dead zone of one quantum + trace limit), P stays bounded, θ
//! drifts less than 1 % from its value at the start of the dwell and no saturation occurs. The same
//! data without anti-windup winds P up and drags θ around — so the test can fail.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, step};
use sledid::{Scaling, Status};
use sledid_host::twin::{Twin, TwinParams};

const DWELL_SAMPLES: usize = 1_000_000;

struct Outcome {
    max_drift: f64,
    max_trace: f64,
    final_trace: f64,
    updates: usize,
    saturated: usize,
    cov_saturated: usize,
    dead_zone: usize,
    bounded: usize,
}

/// One seek to 800 tracks, then a dwell of [`DWELL_SAMPLES`] on `params`' loop; θ's drift is
/// measured against its value `learn` samples into the dwell.
///
/// `TwinParams::well_damped()` (`host-tests/plants/well_damped.json`): its limit cycle hunts ±1 every
/// ~12 samples, ~80,000 cycles in the dwell; RELIABILITY.md's table was measured on it. The default
/// (the paper's loop) overshoots ~10 quanta and hunts every ~77 samples; with this seed the hunt
/// ends at rest inside the target's quantum after ~10⁵ samples — the estimate at the start of the
/// dwell is still the seek's, and the few updates the hunt drives (52, measured) move it by ~100 %
/// before the dead zone holds it.
fn run(mut params: TwinParams, rls: RlsDesign, learn: usize) -> Outcome {
    params.reference.seek_count = 1;
    params.reference.targets_tracks = Some(vec![800]);
    params.reference.dwell_s = ((DWELL_SAMPLES + learn) as f64 + 2_000.0) * params.plant.ts_s;
    let mut twin = Twin::new(params.clone(), 3).expect("twin");
    let mut pid = twin.baseline_controller();
    let scaling = Scaling::new(params.plant.quantum_m, params.plant.u_max_v).expect("scaling");
    let mut model = LinearDesign::<2>::new(Structure::Arx, 1, 1);
    model.rls = rls;
    let cfg = IdentifierDesign::new(Conditioning::CentredOnReference, model)
        .build()
        .expect("design");
    let mut st = cfg.new_state();
    // The seek and its settling (~0.15 s) identify θ; the dwell starts after 0.3 s.
    let dwell_start = (0.3 / params.plant.ts_s) as usize;
    let mut theta_ref: Option<Vec<f64>> = None;
    let mut out = Outcome {
        max_drift: 0.0,
        max_trace: 0.0,
        final_trace: 0.0,
        updates: 0,
        saturated: 0,
        cov_saturated: 0,
        dead_zone: 0,
        bounded: 0,
    };
    let mut n = 0;
    while let Some(s) = twin.step(&mut pid) {
        let sample = scaling.sample(s.y_m, s.u_v, s.r_m).expect("in range");
        let o = step(&cfg, &mut st, &sample);
        n += 1;
        if n < dwell_start + learn {
            continue;
        }
        let theta: Vec<f64> = o.theta.iter().map(|p| p.to_f64()).collect();
        let reference = theta_ref.get_or_insert_with(|| theta.clone());
        let num: f64 = theta
            .iter()
            .zip(reference.iter())
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        let den: f64 = reference.iter().map(|b| b * b).sum::<f64>().sqrt();
        out.max_drift = out.max_drift.max(num / den);
        let tr = st.model().rls().trace().to_f64();
        out.max_trace = out.max_trace.max(tr);
        out.final_trace = tr;
        out.updates += usize::from(o.status.contains(Status::UPDATED));
        out.saturated += usize::from(o.status.contains(Status::SATURATED));
        out.cov_saturated += usize::from(o.status.contains(Status::COVARIANCE_SATURATED));
        out.dead_zone += usize::from(o.status.contains(Status::DEAD_ZONE));
        out.bounded += usize::from(o.status.contains(Status::COVARIANCE_BOUNDED));
        if n >= dwell_start + learn + DWELL_SAMPLES {
            break;
        }
    }
    assert!(
        n >= dwell_start + learn + DWELL_SAMPLES,
        "twin ended early after {n} samples"
    );
    out
}

/// Dead zone of one quantum + trace ≤ 100.
fn guarded_design() -> RlsDesign {
    RlsDesign {
        lambda: 0.995,
        p0: 100.0,
        dead_zone: 1.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    }
}

/// Forgetting without anti-windup.
fn naked_design() -> RlsDesign {
    RlsDesign {
        lambda: 0.995,
        p0: 100.0,
        ..RlsDesign::default()
    }
}

fn print(name: &str, o: &Outcome) {
    println!(
        "{name:<22} max θ drift {:.3e}  max trace(P) {:.3e}  final {:.3e}  updates {}  bounded {}  dead-zone skips {}  saturated {}  cov-saturated {}",
        o.max_drift,
        o.max_trace,
        o.final_trace,
        o.updates,
        o.bounded,
        o.dead_zone,
        o.saturated,
        o.cov_saturated
    );
}

#[test]
fn on_the_paper_loop_the_dead_zone_holds_theta_once_the_hunt_is_learnt() {
    // The paper's loop: the slow hunt after the overshoot still teaches the model (measured: 52
    // updates in the dwell's first 10⁵ samples, θ moves ~100 % from the seek's estimate). From there
    // on, over 10⁶ samples: only the hunt's last pulses get past the dead zone (4 updates, moving
    // θ by 22 % — b is barely identifiable below breakaway, each pulse is real information), then
    // the sled rests in the target's quantum and nothing moves θ; P stays bounded. Without
    // anti-windup the same data update θ on every sample and wind P up to the format's limit.
    let learn = 100_000;
    let guarded = run(TwinParams::default(), guarded_design(), learn);
    let naked = run(TwinParams::default(), naked_design(), learn);
    print("paper loop, guarded", &guarded);
    print("paper loop, none", &naked);
    assert!(guarded.max_drift < 0.3, "θ drifted {}", guarded.max_drift);
    assert!(guarded.max_trace <= 100.0 * (1.0 + 1e-6));
    assert!(guarded.updates <= 10, "{} updates", guarded.updates);
    assert!(naked.updates > 900_000 && naked.max_drift > 3.0 * guarded.max_drift);
    assert_eq!(guarded.saturated + guarded.cov_saturated, 0);
    assert!(
        naked.max_trace > 1e6 * guarded.max_trace.max(1e-9),
        "without anti-windup trace(P) reached only {}",
        naked.max_trace
    );
}

#[test]
fn anti_windup_keeps_p_bounded_and_theta_still_over_a_million_limit_cycle_samples() {
    let guarded = run(TwinParams::well_damped(), guarded_design(), 0);
    // Trace limit alone (the limit cycle does drive updates): the bound must act on every sample.
    let trace_only = run(
        TwinParams::well_damped(),
        RlsDesign {
            lambda: 0.995,
            p0: 100.0,
            anti_windup: AntiWindup::TraceLimit { max: 1.0 },
            ..RlsDesign::default()
        },
        0,
    );
    let naked = run(TwinParams::well_damped(), naked_design(), 0);
    for (name, o) in [
        ("dead zone + trace≤100", &guarded),
        ("trace≤1 only", &trace_only),
        ("none", &naked),
    ] {
        print(name, o);
    }
    assert!(trace_only.updates > 900_000);
    assert!(
        trace_only.max_trace <= 1.0 * (1.0 + 1e-6),
        "trace {}",
        trace_only.max_trace
    );
    assert!(trace_only.bounded > 0);
    assert_eq!(trace_only.saturated, 0);
    assert!(
        guarded.max_trace <= 100.0 * (1.0 + 1e-6),
        "trace {}",
        guarded.max_trace
    );
    assert!(guarded.max_drift < 0.01, "θ drifted {}", guarded.max_drift);
    assert_eq!(guarded.saturated, 0);
    assert_eq!(guarded.cov_saturated, 0);
    // The same data without anti-windup: θ is dragged around by the limit cycle and P winds up.
    assert!(
        naked.max_drift > 0.1,
        "without anti-windup θ drifted only {}",
        naked.max_drift
    );
    assert!(
        naked.max_trace > 10.0 * guarded.max_trace.max(1e-9)
            || naked.max_drift > 10.0 * guarded.max_drift
    );
}
