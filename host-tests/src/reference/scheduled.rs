//! The gain-scheduled controller of `sledid::control::scheduled` in `f64` ([`ScheduledF64`]):
//! the same regions, supervisor, transfers and laws, written directly from the module
//! documentation, with its own pole placement (f64, not the library's f32 + `libm`), the exact
//! inverse of the input map (bisection on `h(u) = u + w·tanh(a·u + c)` with `f64::tanh`, not the
//! interpolated table) and the f64 baseline [`PidF64`] as the fallback. It is what the fixed-point
//! path is measured against (`host-tests/tests/scheduled_control.rs`).

use sledid::Status;
use sledid::control::scheduled::supervisor::DISTRUST;
use sledid::control::{ConfigError, Region, ScheduledDesign};

use super::control::PidF64;

/// Gains in full scale per quantum (per sample for Ki).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainsF64 {
    /// Seek Kp.
    pub kp_seek: f64,
    /// Seek Kd/2.
    pub kd2_seek: f64,
    /// (1 − a)/b.
    pub kv_ff: f64,
    /// 1/b.
    pub ka_ff: f64,
    /// Settle Kp.
    pub kp_settle: f64,
    /// Settle Kd/2.
    pub kd2_settle: f64,
    /// Settle Ki.
    pub ki_settle: f64,
}

/// The pole placement of `sledid::control::placement` in f64 for the velocity model (a, b).
pub fn place_f64(a: f64, b: f64, seek_pole: f64, settle_pole: f64, ff: bool) -> GainsF64 {
    let (ps, pz) = (seek_pole, settle_pole);
    let (s1, s2, s3) = (3.0 * pz, 3.0 * pz * pz, pz.powi(3));
    let bkd = a - s3;
    let bkp = 1.0 + 2.0 * s3 - s2;
    let bki = (2.0 + a - s1 - bkp - bkd).max(0.0);
    GainsF64 {
        kp_seek: (1.0 - ps).powi(2) / b,
        kd2_seek: (a - ps * ps) / 2.0 / b,
        kv_ff: if ff { (1.0 - a) / b } else { 0.0 },
        ka_ff: if ff { 1.0 / b } else { 0.0 },
        kp_settle: bkp / b,
        kd2_settle: bkd / 2.0 / b,
        ki_settle: bki / b,
    }
}

/// θ = [a₁ … a_na, b…] → (a, b) with the supervisor's checks; `None` when refused.
pub fn reduce_f64(theta: &[f64], na: usize, design: &ScheduledDesign) -> Option<(f64, f64)> {
    let s = &design.supervisor;
    let b_sum: f64 = theta.iter().skip(na).sum();
    let (a, b) = match na {
        1 => (-*theta.first()?, b_sum),
        _ => {
            let (a1, a2) = (*theta.first()?, *theta.get(1)?);
            let disc = a1 * a1 - 4.0 * a2;
            if disc < 0.0 {
                return None;
            }
            let (r1, r2) = ((-a1 + disc.sqrt()) / 2.0, (-a1 - disc.sqrt()) / 2.0);
            let a = if r1.abs() >= r2.abs() { r1 } else { r2 };
            (a, (1.0 - a) * b_sum / (1.0 + a1 + a2))
        }
    };
    let ok = (s.pole_min..=s.pole_max).contains(&a) && (s.gain_min..=s.gain_max).contains(&b);
    ok.then_some((a, b))
}

/// The controller law in f64: positions in quanta, u in full scale.
#[derive(Clone, Debug)]
pub struct ScheduledF64 {
    design: ScheduledDesign,
    gains: Option<GainsF64>,
    /// (w, a, c) of the compensated input map.
    map: Option<(f64, f64, f64)>,
    /// (w, a, c) of the compensated Wiener output map.
    output_map: Option<(f64, f64, f64)>,
    y1: f64,
    y2: f64,
    r1: f64,
    r2: f64,
    dr1_previous: f64,
    integral: f64,
    last_v: f64,
    last_u: f64,
    region: Region,
    primed: bool,
    in_fallback: bool,
    pid: PidF64,
    untrusted: u16,
    eps_mean: f64,
    trusted_updates: u32,
    redesign_pending: bool,
}

impl ScheduledF64 {
    /// A controller in its initial state (the prior's gains, if any).
    ///
    /// # Errors
    /// The design's [`ConfigError`].
    pub fn new(design: &ScheduledDesign) -> Result<Self, ConfigError> {
        design.build()?;
        let p = &design.placement;
        let gains = design
            .prior_model
            .map(|(a, b)| place_f64(a, b, p.seek_pole, p.settle_pole, p.feedforward));
        let wac = |m: sledid::control::InverseInputMap| {
            let n = m.neuron();
            (n.w().to_f64(), n.a().to_f64(), n.c().to_f64())
        };
        Ok(Self {
            design: *design,
            gains,
            map: design.compensation.map(wac),
            output_map: design.output_map.map(wac),
            y1: 0.0,
            y2: 0.0,
            r1: 0.0,
            r2: 0.0,
            dr1_previous: 0.0,
            integral: 0.0,
            last_v: 0.0,
            last_u: 0.0,
            region: Region::Seek,
            primed: false,
            in_fallback: false,
            pid: PidF64::new(&design.baseline)?,
            untrusted: 0,
            eps_mean: 0.0,
            trusted_updates: 0,
            redesign_pending: false,
        })
    }

    /// h(u).
    pub fn forward(&self, u: f64) -> f64 {
        forward_of(self.map, u)
    }

    /// h⁻¹(v) by bisection (h increasing; h(u) − u ∈ [−|w|, |w|]).
    pub fn inverse(&self, v: f64) -> f64 {
        inverse_of(self.map, v)
    }

    /// The Settle law's error: −m⁻¹(y − r) with an output map, else e.
    fn settle_error(&self, e: f64) -> f64 {
        -inverse_of(self.output_map, -e)
    }

    /// A redesign is due.
    pub fn redesign_pending(&self) -> bool {
        self.redesign_pending
    }

    /// The gains in use (`None`: fallback latched).
    pub fn gains(&self) -> Option<GainsF64> {
        self.gains
    }

    /// The slow-rate redesign from θ (f64); true when gains were placed.
    pub fn redesign(&mut self, theta: &[f64]) -> bool {
        self.redesign_pending = false;
        if self.untrusted > 0 || self.eps_mean > self.design.supervisor.eps_limit_quanta {
            self.gains = None;
            return false;
        }
        if self.trusted_updates == 0 {
            return false;
        }
        self.trusted_updates = 0;
        let p = self.design.placement;
        self.gains = reduce_f64(theta, self.design.model_na, &self.design)
            .map(|(a, b)| place_f64(a, b, p.seek_pole, p.settle_pole, p.feedforward));
        self.gains.is_some()
    }

    fn select(&self, e: f64, dy2: f64, dr1: f64) -> Region {
        let g = &self.design.regions;
        if dr1.abs() > g.moving_quanta || e.abs() > g.settle_leave_quanta {
            return Region::Seek;
        }
        match self.region {
            Region::Seek if e.abs() <= g.settle_enter_quanta => Region::Settle,
            Region::Settle
                if e.abs() <= g.hold_enter_quanta && dy2.abs() <= g.hold_speed_quanta =>
            {
                Region::Hold
            }
            Region::Hold if e.abs() > g.hold_leave_quanta => Region::Settle,
            same => same,
        }
    }

    /// One sample: r, y (quanta), the identifier's flags and ε (quanta per sample); returns
    /// (u in full scale, region, fallback).
    pub fn step(&mut self, r: f64, y: f64, status: Status, eps: f64) -> (f64, Region, bool) {
        let d = self.design;
        let fs = d.baseline.u_full_scale_v;
        if !self.primed {
            self.primed = true;
            (self.y1, self.y2, self.r1, self.r2, self.dr1_previous) = (y, y, r, r, 0.0);
        }
        let (e, dy2, dr2, dr1) = (r - y, y - self.y2, r - self.r2, r - self.r1);
        let ar = dr1 - self.dr1_previous;
        (self.y2, self.y1, self.r2, self.r1, self.dr1_previous) = (self.y1, y, self.r1, r, dr1);
        let bad = status.intersects(DISTRUST);
        self.untrusted = if bad {
            d.supervisor.untrusted_hold_samples
        } else {
            self.untrusted.saturating_sub(1)
        };
        if status.intersects(Status::UPDATED.union(Status::DEAD_ZONE)) {
            self.eps_mean += (eps.abs() - self.eps_mean) / 32.0;
        }
        if status.contains(Status::UPDATED) && !bad {
            self.trusted_updates += 1;
        }
        let distrusted = self.untrusted > 0 || self.eps_mean > d.supervisor.eps_limit_quanta;
        let previous = self.region;
        let region = self.select(e, dy2, dr1);
        self.region = region;
        if previous == Region::Seek && region == Region::Settle {
            self.redesign_pending = true;
        }
        let gains = match self.gains {
            Some(g) if !distrusted => g,
            _ => {
                if !self.in_fallback {
                    self.pid.reset();
                    self.pid.set_enabled(false);
                    self.pid.set_manual_output_v(self.last_u * fs);
                }
                self.in_fallback = true;
                let u = self.pid.step_quanta(r, y) / fs;
                self.pid.set_enabled(true);
                self.last_u = u;
                self.last_v = self.forward(u);
                return (u, region, true);
            }
        };
        let returning = self.in_fallback;
        self.in_fallback = false;
        let i_max = d.integrator_limit_v / fs;
        let u_max = d.baseline.u_limit_v / fs;
        let (terms, integrating) = match region {
            Region::Hold => {
                let u = d.hold_bias_v / fs;
                self.last_u = u;
                self.last_v = self.forward(u);
                return (u, region, false);
            }
            Region::Seek => (
                gains.kp_seek * e
                    + gains.kd2_seek * (dr2 - dy2)
                    + gains.kv_ff * dr1
                    + gains.ka_ff * ar,
                false,
            ),
            Region::Settle => (
                gains.kp_settle * self.settle_error(e) - gains.kd2_settle * dy2,
                true,
            ),
        };
        if returning || (region != previous && previous != Region::Hold) {
            self.integral = (self.last_v - terms).clamp(-i_max, i_max);
        } else if integrating {
            let candidate =
                (self.integral + gains.ki_settle * self.settle_error(e)).clamp(-i_max, i_max);
            let v = terms + candidate;
            let winding = (v > u_max && candidate > self.integral)
                || (v < -u_max && candidate < self.integral);
            if !winding {
                self.integral = candidate;
            }
        } else {
            self.integral -= self.integral / 16.0;
        }
        let v = terms + self.integral;
        let u = self.inverse(v).clamp(-u_max, u_max);
        self.last_v = v;
        self.last_u = u;
        (u, region, false)
    }
}

/// x + w·tanh(a·x + c) (the identity without a map).
fn forward_of(map: Option<(f64, f64, f64)>, x: f64) -> f64 {
    map.map_or(x, |(w, a, c)| x + w * (a * x + c).tanh())
}

/// The inverse of [`forward_of`] by bisection (increasing; forward(x) − x ∈ [−|w|, |w|]).
fn inverse_of(map: Option<(f64, f64, f64)>, v: f64) -> f64 {
    let Some((w, _, _)) = map else { return v };
    let (mut lo, mut hi) = (v - w.abs() - 1e-9, v + w.abs() + 1e-9);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if forward_of(map, mid) <= v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
