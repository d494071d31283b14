//! Float64 reference of `sledid::servo::health` (same equations, RLS in Bierman form), and the runner that drives the fixed-point estimator through its queue over a
//! recorded (y, u) sequence.

use sledid::num::boundary::PositionI48F16;
use sledid::num::fixed::SignalI16F16;
use sledid::servo::CalibratedModel;
use sledid::servo::health::{
    HEALTH_N, HealthConfig, HealthDesign, HealthFeed, HealthQueue, HealthReference, HealthVerdict,
};

use super::rls::RlsF64;

/// The float64 estimator.
pub struct HealthF64 {
    design: HealthDesign,
    y_start: Option<f64>,
    u_pair: [f64; 2],
    second: bool,
    rls: RlsF64<HEALTH_N>,
    lags: [f64; 3],
    fill: u8,
    /// Updates since the reference.
    pub updates: u32,
    /// Of those, the updates with the drive opposing the motion (u(2m−1)·V(m) < 0).
    pub braking: u32,
    /// c_ref, fraction of full scale.
    pub reference_fs: f64,
    theta0_pole2: f64,
}

/// θ₀ and c_ref from a calibration, in float64 (the module doc's model, computed here
/// independently of `sledid::servo::health::reference_theta`).
pub fn reference_f64(model: &CalibratedModel) -> ([f64; HEALTH_N], f64) {
    let a = f64::from(model.a);
    let k = f64::from(model.gain_k);
    let c = f64::from(model.coulomb_mean_fs());
    let lambda = -a.ln();
    let c1 = (1.0 - a) / lambda;
    let d0 = 1.0 - c1;
    let (b1, b2) = (k * d0, k * (c1 * (1.0 - a) - a * d0));
    // (1 + q⁻¹)(1 + a q⁻¹) = 1 + (1 + a) q⁻¹ + a q⁻², times β₁q⁻¹ + β₂q⁻².
    let p = [1.0, 1.0 + a, a];
    let mut g = [0.0; 4];
    for (i, pi) in p.iter().enumerate() {
        g[i] += pi * b1;
        g[i + 1] += pi * b2;
    }
    let sum: f64 = g.iter().sum();
    ([a * a, g[0], g[1], g[2], g[3], -c * sum], c)
}

impl HealthF64 {
    /// At the reference's θ₀.
    pub fn new(design: &HealthDesign, theta0: [f64; HEALTH_N], reference_fs: f64) -> Self {
        Self {
            design: *design,
            y_start: None,
            u_pair: [0.0; 2],
            second: false,
            rls: RlsF64::new(&design.rls, theta0),
            lags: [0.0; 3],
            fill: 0,
            updates: 0,
            braking: 0,
            reference_fs,
            theta0_pole2: theta0[0],
        }
    }

    /// One sample at Ts: reading y (quanta), drive u (fraction of full scale).
    pub fn feed(&mut self, y: f64, u: f64) {
        let Some(start) = self.y_start else {
            self.y_start = Some(y);
            self.u_pair = [u, 0.0];
            self.second = true;
            return;
        };
        if self.second {
            self.u_pair[1] = u;
            self.second = false;
            return;
        }
        let [u2, u1] = self.u_pair;
        self.step(y - start, u1, u2);
        self.y_start = Some(y);
        self.u_pair = [u, 0.0];
        self.second = true;
    }

    fn step(&mut self, v: f64, u1: f64, u2: f64) {
        let [v1, u3, u4] = self.lags;
        if self.fill >= 1 {
            let gate = self.design.gate_speed_quanta;
            if v.abs() >= gate && v1.abs() >= gate && (v > 0.0) == (v1 > 0.0) {
                let phi = [
                    v1,
                    u1,
                    u2,
                    u3,
                    u4,
                    (self.design.neuron_slope_per_quantum * v1).tanh(),
                ];
                let eps = v - self.rls.predict(&phi);
                let s = self.rls.update(&phi, eps);
                if s.contains(sledid::Status::UPDATED) {
                    self.updates += 1;
                    if u1 * v < 0.0 {
                        self.braking += 1;
                    }
                }
            }
        }
        self.lags = [v, u1, u2];
        self.fill = 1;
    }

    /// θ = [a², γ₁, γ₂, γ₃, γ₄, w].
    pub fn theta(&self) -> [f64; HEALTH_N] {
        self.rls.theta
    }

    /// ĉ = −w/Σγ (NaN for Σγ ≤ 0).
    pub fn level_fs(&self) -> f64 {
        let [_, g1, g2, g3, g4, w] = self.rls.theta;
        let b = g1 + g2 + g3 + g4;
        if b > 0.0 { -w / b } else { f64::NAN }
    }

    /// The verdict: risen beyond the band (after `min_updates`, on an identifiable sled).
    pub fn drifted(&self) -> bool {
        let d = &self.design;
        self.theta0_pole2 >= d.min_pole * d.min_pole
            && self.updates >= d.min_updates
            && self.level_fs() - self.reference_fs
                > d.drift_fs + d.drift_rel * self.reference_fs.abs()
    }
}

/// One point of a fixed-point run: the sample index at Ts and the verdict there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthPoint {
    /// Sample index (at Ts) after which the background ran.
    pub k: usize,
    /// The verdict.
    pub verdict: HealthVerdict,
}

/// Runs the fixed-point estimator over `samples` = (y quanta, u fraction of full scale) from
/// `start` on, through a queue of capacity `Q − 1` drained every `drain_every` samples at Ts;
/// returns the verdict after every drain and the samples dropped.
pub fn run_fixed<const Q: usize>(
    config: &HealthConfig,
    reference: &HealthReference,
    samples: &[(i64, f64)],
    drain_every: usize,
) -> (Vec<HealthPoint>, u32) {
    let mut queue: HealthQueue<Q> = HealthQueue::new();
    let (mut producer, mut consumer) = queue.split();
    let mut feed = HealthFeed::new();
    let mut st = config.new_state();
    config.set_reference(&mut st, reference);
    let mut points = Vec::new();
    for (k, &(y, u)) in samples.iter().enumerate() {
        let u = SignalI16F16::from_f64(u).unwrap_or(SignalI16F16::ZERO);
        config.feed(&mut feed, &mut producer, PositionI48F16::from_counts(y), u);
        if (k + 1) % drain_every.max(1) == 0 {
            config.drain(&mut st, &mut consumer);
            points.push(HealthPoint {
                k,
                verdict: config.verdict(&st),
            });
        }
    }
    config.drain(&mut st, &mut consumer);
    points.push(HealthPoint {
        k: samples.len(),
        verdict: config.verdict(&st),
    });
    (points, feed.dropped())
}

/// The health verdict of a seek run, for `sledid seek`'s summary.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct HealthBrief {
    /// ĉ at the end of the run, fraction of full scale.
    pub coulomb_fs: f64,
    /// c_ref: power-on calibration's mean Coulomb level, fraction of full scale.
    pub reference_fs: f64,
    /// Estimator updates over the run.
    pub updates: u32,
    /// The drift flag at the end of the run.
    pub drift: bool,
    /// Whether the calibrated sled is identifiable (pole ≥ `min_pole`).
    pub identifiable: bool,
    /// Whether the estimator had its `min_updates` (`NOT_READY` clear): a verdict at all.
    pub ready: bool,
    /// Samples dropped on a full queue.
    pub dropped: u32,
}

impl HealthBrief {
    /// `friction ĉ X vs calibrated Y of full scale (N updates): ok | RISEN | not identifiable |
    /// not ready`.
    pub fn line(&self) -> String {
        let verdict = if !self.identifiable {
            "not identifiable"
        } else if self.drift {
            "RISEN"
        } else if !self.ready {
            "not ready (too few updates)"
        } else {
            "ok"
        };
        format!(
            "friction ĉ {:.4} vs calibrated {:.4} of full scale ({} updates): {verdict}",
            self.coulomb_fs, self.reference_fs, self.updates
        )
    }
}

/// The default health estimator over a run's samples from the first seek on (y in quanta, u in
/// fraction of full scale), against `model` (power-on calibration), through a 64-slot queue
/// drained every 8 samples; `None` when the model leaves the formats.
pub fn health_brief(model: &CalibratedModel, samples: &[(i64, f64)]) -> Option<HealthBrief> {
    let config = HealthDesign::default().build().ok()?;
    let reference = HealthReference::from_calibration(model)?;
    let (points, dropped) = run_fixed::<64>(&config, &reference, samples, 8);
    let v = points.last()?.verdict;
    use sledid::servo::health::HealthFlags;
    Some(HealthBrief {
        coulomb_fs: v.coulomb_fs.to_f64(),
        reference_fs: v.reference_fs.to_f64(),
        updates: v.updates,
        drift: v.flags.contains(HealthFlags::DRIFT),
        identifiable: !v.flags.contains(HealthFlags::NOT_IDENTIFIABLE),
        ready: !v.flags.contains(HealthFlags::NOT_READY),
        dropped,
    })
}
