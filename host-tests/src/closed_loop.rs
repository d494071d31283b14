//! The full loop under faults: the sled twin, the library's fixed-point controller and the
//! identifier's per-sample step, all seeing the same (possibly faulty) measurement — faults injected
//! *inside* the loop, so the controller has to live with them too.
//!
//! Sensor faults ([`crate::faults::Fault`]) corrupt the measurement before the controller and the
//! identifier; a lost or non-finite reading makes the controller hold its last good measurement
//! (sample-and-hold: it never stalls) and the identifier [`sledid::ident::step::reject`] the sample. Plant
//! faults change the twin mid-run: mass or friction steps, an amplifier that saturates early (the
//! identifier is fed the controller's command, as firmware would be).

use crate::faults::{Fault, Injector, Reading};
use crate::recording::Sample as RecSample;
use crate::reference::control::{FixedPid, baseline_design};
use crate::twin::{SledController, Twin, TwinParams};
use sledid::ident::step::{IdentifierConfig, IdentifierState, reject, step};
use sledid::{Scaling, Status};

/// A fault in the loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoopFault {
    /// A sensor fault (spike, stuck, missing, NaN, reversed sign).
    Sensor(Fault),
    /// The moving mass is multiplied by `factor` from sample `at`.
    MassStep {
        /// First sample.
        at: usize,
        /// Factor.
        factor: f64,
    },
    /// Coulomb and static friction are multiplied by `factor` from sample `at`.
    FrictionStep {
        /// First sample.
        at: usize,
        /// Factor.
        factor: f64,
    },
    /// The amplifier saturates at `u_max_v` from sample `at`.
    AmplifierLimit {
        /// First sample.
        at: usize,
        /// New saturation, V.
        u_max_v: f64,
    },
}

/// The controller seen through a faulty sensor.
struct FaultySensor {
    pid: FixedPid,
    injector: Injector,
    k: usize,
    last_good_counts: f64,
    /// (measurement in counts or None when lost, command in V) of the sample just stepped.
    last: (Option<f64>, f64),
}

impl SledController for FaultySensor {
    fn step(&mut self, r_counts: f64, y_counts: f64) -> f64 {
        let truth = RecSample {
            t_s: 0.0,
            u: 0.0,
            y: y_counts,
            r: Some(r_counts),
        };
        let measured = match self.injector.apply(self.k, truth) {
            Reading::Present(s) if s.y.is_finite() => Some(s.y),
            _ => None,
        };
        self.k += 1;
        if let Some(y) = measured {
            self.last_good_counts = y;
        }
        let u = self.pid.step(r_counts, self.last_good_counts);
        self.last = (measured, u);
        u
    }
}

/// What a faulty closed-loop run produced, per sample.
#[derive(Clone, Debug, Default)]
pub struct LoopRun {
    /// Identifier status per sample.
    pub status: Vec<Status>,
    /// Controller command, V.
    pub command_v: Vec<f64>,
    /// True position minus reference, quanta.
    pub error_quanta: Vec<f64>,
    /// b₁ + b₂ of the identifier after each sample.
    pub b_sum: Vec<f64>,
    /// Final θ.
    pub theta: Vec<f64>,
    /// The controller's output limit, V.
    pub u_limit_v: f64,
}

/// Runs the twin with the fixed-point baseline controller and the identifier, with `faults`.
///
/// # Errors
/// Twin or controller configuration errors.
pub fn run_loop(
    params: &TwinParams,
    seed: u64,
    identifier: &IdentifierConfig<4>,
    faults: &[LoopFault],
) -> Result<LoopRun, String> {
    let mut twin = Twin::new(params.clone(), seed).map_err(|e| e.to_string())?;
    let design = baseline_design(&params.controller, params.plant.ts_s, params.plant.u_max_v);
    let pid = FixedPid::new(&design).map_err(|e| e.to_string())?;
    let sensor_faults: Vec<Fault> = faults
        .iter()
        .filter_map(|f| {
            if let LoopFault::Sensor(s) = f {
                Some(*s)
            } else {
                None
            }
        })
        .collect();
    let mut ctl = FaultySensor {
        pid,
        injector: Injector::new(sensor_faults),
        k: 0,
        last_good_counts: 0.0,
        last: (None, 0.0),
    };
    let scaling =
        Scaling::new(params.plant.quantum_m, params.plant.u_max_v).map_err(|e| e.to_string())?;
    let mut st: IdentifierState<4> = identifier.new_state();
    let mut run = LoopRun {
        u_limit_v: params.plant.u_max_v,
        ..LoopRun::default()
    };
    let mut k = 0usize;
    loop {
        for f in faults {
            match *f {
                LoopFault::MassStep { at, factor } if at == k => {
                    twin.plant_mut().scale_mass(factor)
                }
                LoopFault::FrictionStep { at, factor } if at == k => {
                    twin.plant_mut().scale_friction(factor)
                }
                LoopFault::AmplifierLimit { at, u_max_v } if at == k => {
                    twin.plant_mut().set_u_max_v(u_max_v)
                }
                _ => {}
            }
        }
        let Some(s) = twin.step(&mut ctl) else { break };
        let (measured, command_v) = ctl.last;
        let out = match measured {
            Some(y_counts) => {
                match scaling.sample(y_counts * params.plant.quantum_m, command_v, s.r_m) {
                    Ok(sample) => step(identifier, &mut st, &sample),
                    Err(_) => reject(identifier, &mut st),
                }
            }
            None => reject(identifier, &mut st),
        };
        run.status.push(out.status);
        run.command_v.push(command_v);
        run.error_quanta
            .push((s.x_m - s.r_m) / params.plant.quantum_m);
        run.b_sum
            .push(out.theta[2].to_f64() + out.theta[3].to_f64());
        k += 1;
    }
    run.theta = st.model().theta().iter().map(|p| p.to_f64()).collect();
    Ok(run)
}
