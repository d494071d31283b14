//! Soak: very long runs of the full per-sample path — the library's fixed-point controller closing
//! the loop around the sled twin, and the identifier's step on the same samples — on poorly excited
//! data (random seeks, each ending in a ±1-quantum limit cycle), checking that P, θ and the command
//! stay bounded and counting every status flag. Streaming: twin chunks (fresh seeds, the controller
//! in the loop) are generated on one thread while the identifier consumes them on another; a chunk
//! seam is passed as a rejected sample so no difference spans it. The twin runs the well-damped
//! baseline ([`TwinParams::well_damped`]), whose faster limit cycle excites the identifier more.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, reject, step};
use sledid::{Sample, Scaling, Status};
use std::sync::mpsc::sync_channel;
use std::time::Instant;

use crate::reference::control::{FixedPid, baseline_design};
use crate::twin::{Twin, TwinParams};

/// What a soak measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SoakReport {
    /// Samples through `step`.
    pub samples: u64,
    /// Wall-clock time, s.
    pub wall_s: f64,
    /// Largest trace(P) seen (checked every 1,024 samples).
    pub max_trace: f64,
    /// Largest |θᵢ| seen.
    pub max_abs_theta: f64,
    /// Largest |drive| the fixed-point controller applied (its command after the amplifier), V.
    pub max_abs_command_v: f64,
    /// Final θ.
    pub theta: Vec<f64>,
    /// Count of every status flag.
    pub flags: std::collections::BTreeMap<String, u64>,
}

/// The identifier the soak runs: ARX(2,2) on velocity against drive, λ = 0.995, trace ≤ 100,
/// outlier gate, as the replay defaults.
fn design() -> IdentifierDesign<4> {
    let mut model = LinearDesign::<4>::new(Structure::Arx, 2, 2);
    model.rls = RlsDesign {
        lambda: 0.995,
        p0: 10.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        outlier_threshold: 40.0,
        outlier_limit: 16,
        ..RlsDesign::default()
    };
    IdentifierDesign::new(Conditioning::DifferencedOutput, model)
}

/// Runs `samples` samples; `seeks_per_chunk` seeks per twin chunk.
///
/// # Errors
/// Configuration or conversion errors (naming the sample), or a violated bound.
pub fn soak(samples: u64, seeks_per_chunk: u32, progress: bool) -> Result<SoakReport, String> {
    // The well-damped baseline: its ±1 cycle changes sign every ~6 samples (the paper's loop, the
    // default, every ~38), the denser excitation for the anti-windup; RELIABILITY.md's figures.
    let mut params = TwinParams::well_damped();
    params.reference.seek_count = seeks_per_chunk;
    let scaling =
        Scaling::new(params.plant.quantum_m, params.plant.u_max_v).map_err(|e| e.to_string())?;
    let cfg = design().build().map_err(|e| e.to_string())?;
    let (tx, rx) = sync_channel::<Vec<Sample>>(2);
    let producer_params = params.clone();
    let producer = std::thread::spawn(move || -> Result<(), String> {
        let design = baseline_design(
            &producer_params.controller,
            producer_params.plant.ts_s,
            producer_params.plant.u_max_v,
        );
        for seed in 0u64.. {
            // The library's fixed-point controller closes the loop (the full per-sample path).
            let mut twin = Twin::new(producer_params.clone(), seed).map_err(|e| e.to_string())?;
            let mut pid = FixedPid::new(&design).map_err(|e| e.to_string())?;
            twin.run(&mut pid);
            let chunk: Result<Vec<Sample>, String> = twin
                .samples()
                .iter()
                .map(|s| {
                    scaling
                        .sample(s.y_m, s.u_v, s.r_m)
                        .map_err(|e| format!("seed {seed}: {e}"))
                })
                .collect();
            if tx.send(chunk?).is_err() {
                return Ok(()); // the consumer is done
            }
        }
        Ok(())
    });
    let mut st = cfg.new_state();
    let mut counts = [0u64; Status::NAMES.len()];
    let (mut n, mut max_trace, mut max_abs_theta, mut max_u) = (0u64, 0f64, 0f64, 0f64);
    let start = Instant::now();
    'outer: for chunk in rx.iter() {
        let _ = reject(&cfg, &mut st); // the seam between two twin runs
        for s in &chunk {
            let o = step(&cfg, &mut st, s);
            max_u = max_u.max(s.u.to_f64().abs() * params.plant.u_max_v);
            for (c, (flag, _)) in counts.iter_mut().zip(Status::NAMES.iter()) {
                *c += u64::from(o.status.contains(*flag));
            }
            n += 1;
            if n.is_multiple_of(1024) {
                max_trace = max_trace.max(st.model().rls().trace().to_f64());
                for p in &o.theta {
                    max_abs_theta = max_abs_theta.max(p.to_f64().abs());
                }
                if progress && n.is_multiple_of(1 << 26) {
                    eprintln!(
                        "{n} samples, {:.0} s, max trace {max_trace:.3e}, max |θ| {max_abs_theta:.3}",
                        start.elapsed().as_secs_f64()
                    );
                }
            }
            if n >= samples {
                break 'outer;
            }
        }
    }
    drop(rx);
    producer
        .join()
        .map_err(|_| "twin producer panicked".to_owned())??;
    let report = SoakReport {
        samples: n,
        wall_s: start.elapsed().as_secs_f64(),
        max_trace,
        max_abs_theta,
        max_abs_command_v: max_u,
        theta: st.model().theta().iter().map(|p| p.to_f64()).collect(),
        flags: Status::NAMES
            .iter()
            .zip(counts.iter())
            .map(|((_, name), c)| ((*name).to_owned(), *c))
            .collect(),
    };
    if report.max_trace > 100.0 * (1.0 + 1e-6) {
        return Err(format!("trace(P) reached {} > 100", report.max_trace));
    }
    if report.max_abs_theta >= 2047.0 {
        return Err(format!(
            "θ reached the edge of its format: {}",
            report.max_abs_theta
        ));
    }
    if report
        .flags
        .get("covariance_saturated")
        .copied()
        .unwrap_or(0)
        > 0
    {
        return Err("covariance exponent saturated".into());
    }
    Ok(report)
}
