//! The numeric law of `sledid::control::scheduled` in `f64` ([`ScheduledF64`]): the pole
//! placement and the velocity observer's gains ([`place_f64`], f64, not the library's f32 +
//! `libm`), the model reduction with its projection ([`reduce_f64`]), the observer, the seek,
//! settle, fine-step and coasting laws, the transfers and the conditional integrator, the exact
//! inverse of the input map (bisection on `h(u) = u + w·tanh(a·u + c)` with `f64::tanh`, not the
//! interpolated table) and the f64 baseline [`PidF64`] as the fallback — written from the module
//! documentation. The *decisions* (region, fine step, coasting, fallback) are the fixed-point
//! controller's, passed in per sample as a [`LawMode`]: they are logic on integer readings and
//! counters, tested on their own; what is measured here is the arithmetic
//! (`host-tests/tests/integration/scheduled_control.rs`).

use sledid::control::placement::PlacementDesign;
use sledid::control::{ConfigError, ControlFlags, ControlOutput, Region, ScheduledDesign};

use super::control::PidF64;
use super::seek::{SeekF64, SeekObserverF64};
use sledid::control::SeekMode;

/// Gains in full scale per quantum (per sample for Ki), and the observer's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GainsF64 {
    /// Seek Kp.
    pub kp_seek: f64,
    /// Seek Kd.
    pub kd_seek: f64,
    /// (1 − a)/b.
    pub kv_ff: f64,
    /// 1/b.
    pub ka_ff: f64,
    /// Settle Kp.
    pub kp_settle: f64,
    /// Settle Kd.
    pub kd_settle: f64,
    /// Settle Ki.
    pub ki_settle: f64,
    /// Observer (1 − l)·a.
    pub obs_a: f64,
    /// Observer (1 − l)·b.
    pub obs_b: f64,
    /// Observer l.
    pub obs_l: f64,
}

/// The pole placement of `sledid::control::placement` in f64 for the velocity model (a, b).
pub fn place_f64(a: f64, b: f64, p: &PlacementDesign) -> GainsF64 {
    let (ps, pz) = (p.seek_pole, p.settle_pole);
    let (s1, s2, s3) = (3.0 * pz, 3.0 * pz * pz, pz.powi(3));
    let bkd = a - s3;
    let bkp = 1.0 + 2.0 * s3 - s2;
    let bki = (2.0 + a - s1 - bkp - bkd).max(0.0);
    let l = if a > p.observer_pole {
        1.0 - p.observer_pole / a
    } else {
        0.0
    }
    .clamp(p.observer_gain_min, 1.0);
    let ff = p.feedforward;
    GainsF64 {
        kp_seek: (1.0 - ps).powi(2) / b,
        kd_seek: (a - ps * ps) / b,
        kv_ff: if ff { (1.0 - a) / b } else { 0.0 },
        ka_ff: if ff { 1.0 / b } else { 0.0 },
        kp_settle: bkp / b,
        kd_settle: bkd / b,
        ki_settle: bki / b,
        obs_a: (1.0 - l) * a,
        obs_b: (1.0 - l) * b,
        obs_l: l,
    }
}

/// θ = [a₁ … a_na, b…] → (a, b) with the supervisor's checks, the projection of a pole below
/// `pole_min` up to it (same DC gain) and of one in (`pole_max`, 1] down to it (same b); `None`
/// when refused.
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
    if !(a > -1.0 && a <= 1.0) {
        return None;
    }
    let (a, b) = if a < s.pole_min {
        (s.pole_min, b * (1.0 - s.pole_min) / (1.0 - a))
    } else if a > s.pole_max {
        (s.pole_max, b)
    } else {
        (a, b)
    };
    (s.gain_min..=s.gain_max).contains(&b).then_some((a, b))
}

/// The law a sample ran, as the fixed-point controller decided it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LawMode {
    /// The baseline PID (the model distrusted or refused, and no prior to fall back to).
    Fallback,
    /// Hold: the hold bias.
    Hold,
    /// Seek: PD with the model-inverse feedforward.
    Seek,
    /// Settle, a fine step: the settle law without compensation.
    Fine,
    /// Settle, a fine step whose reading moved toward the target: the integrator restarts at 0,
    /// then the fine step's law.
    FineRestart,
    /// Settle, coasting: damping only.
    Coast,
    /// Settle, coasting on a still sled's flicker: nothing drives.
    CoastFlicker,
    /// Settle: the PID law with compensation.
    Settle,
}

impl LawMode {
    /// The mode of one fixed-point output of a controller with (`has_prior`) or without a prior:
    /// its fallback is the region's law on the prior's gains, or the baseline PID.
    pub fn of(out: &ControlOutput, has_prior: bool) -> Self {
        let f = out.flags;
        if f.contains(ControlFlags::FALLBACK) && !has_prior {
            Self::Fallback
        } else {
            match out.region {
                Region::Hold => Self::Hold,
                Region::Seek => Self::Seek,
                Region::Settle if f.contains(ControlFlags::INTEGRATOR_RESTARTED) => {
                    Self::FineRestart
                }
                Region::Settle if f.contains(ControlFlags::FINE_STEP) => Self::Fine,
                Region::Settle if f.contains(ControlFlags::FLICKER) => Self::CoastFlicker,
                Region::Settle if f.contains(ControlFlags::COASTING) => Self::Coast,
                Region::Settle => Self::Settle,
            }
        }
    }
}

/// The numeric law in f64: positions in quanta, u in full scale.
#[derive(Clone, Debug)]
pub struct ScheduledF64 {
    design: ScheduledDesign,
    gains: Option<GainsF64>,
    /// The prior's gains: the fallback's, where there is a prior.
    prior: Option<GainsF64>,
    /// The time-optimal seek's plan in use, and the prior's (the fallback's).
    seek: Option<SeekF64>,
    prior_seek: Option<SeekF64>,
    /// (w, a, c) of the compensated input map.
    map: Option<(f64, f64, f64)>,
    /// (w, a, c) of the compensated Wiener output map.
    output_map: Option<(f64, f64, f64)>,
    y1: f64,
    r1: f64,
    dr1_previous: f64,
    v_hat: f64,
    /// The time-optimal seek's observer.
    seek_observer: SeekObserverF64,
    /// The last drive left Coulomb friction uncompensated (coasting, Hold, a pulse's off-sample).
    friction_free_drive: bool,
    /// This sample is an off-sample of the pulsed settle drive (the fixed point's decision).
    pulse_off: bool,
    integral: f64,
    last_v: f64,
    last_u: f64,
    mode: LawMode,
    primed: bool,
    pid: PidF64,
}

impl ScheduledF64 {
    /// A controller in its initial state (the prior's gains, if any).
    ///
    /// # Errors
    /// The design's [`ConfigError`].
    pub fn new(design: &ScheduledDesign) -> Result<Self, ConfigError> {
        design.build()?;
        let gains = design
            .prior_model
            .map(|(a, b)| place_f64(a, b, &design.prior_placement));
        let level = |m: Option<sledid::control::InverseInputMap>| {
            m.map_or(0.0, |m| -m.neuron().w().to_f64()).max(0.0)
        };
        let prior_seek = match (design.seek, design.prior_model) {
            (SeekMode::TimeOptimal(t), Some((a, b))) => SeekF64::new(
                a,
                b,
                level(design.compensation),
                design.baseline.u_limit_v / design.baseline.u_full_scale_v,
                t.alpha_prior,
                t.velocity_pole_prior,
            ),
            _ => None,
        };
        let wac = |m: sledid::control::InverseInputMap| {
            let n = m.neuron();
            (n.w().to_f64(), n.a().to_f64(), n.c().to_f64())
        };
        Ok(Self {
            design: *design,
            gains,
            prior: gains,
            seek: prior_seek.clone(),
            prior_seek,
            map: design.compensation.map(wac),
            output_map: design.output_map.map(wac),
            y1: 0.0,
            r1: 0.0,
            dr1_previous: 0.0,
            v_hat: 0.0,
            seek_observer: SeekObserverF64::default(),
            friction_free_drive: false,
            pulse_off: false,
            integral: 0.0,
            last_v: 0.0,
            last_u: 0.0,
            mode: LawMode::Seek,
            primed: false,
            pid: PidF64::new(&design.baseline)?,
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

    /// The gains in use (`None`: none yet, or refused).
    pub fn gains(&self) -> Option<GainsF64> {
        self.gains
    }

    /// An accepted redesign: gains placed (f64) from θ = [a…, b… (, c)]; with
    /// `identify_friction`, the input map of the Coulomb level u_c = c/Σb (none below
    /// `MIN_COULOMB_FS`, capped at `MAX_COULOMB_FS`). A refusal (`None` from [`reduce_f64`]) keeps
    /// everything (the fixed-point controller then runs its fallback, which the mode says).
    pub fn adopt(&mut self, theta: &[f64]) {
        let d = &self.design;
        let (linear, c) = match (d.model_coulomb, theta.split_last()) {
            (true, Some((c, linear))) => (linear, *c),
            _ => (theta, 0.0),
        };
        if let Some((a, b)) = reduce_f64(linear, d.model_na, d) {
            self.gains = Some(place_f64(a, b, &d.placement));
            if d.identify_friction {
                let b_sum: f64 = linear.iter().skip(d.model_na).sum();
                let u_c = c / b_sum;
                self.map =
                    (u_c >= f64::from(sledid::control::scheduled::MIN_COULOMB_FS)).then(|| {
                        let u_c = u_c.min(f64::from(sledid::control::scheduled::MAX_COULOMB_FS));
                        (-u_c, 0.9 / u_c, 0.0)
                    });
            }
            if let SeekMode::TimeOptimal(t) = d.seek {
                let u_c = self.map.map_or(0.0, |(w, _, _)| -w).max(0.0);
                let u_max = d.baseline.u_limit_v / d.baseline.u_full_scale_v;
                self.seek = SeekF64::new(a, b, u_c, u_max, t.alpha, t.velocity_pole);
            }
        }
    }

    /// The time-optimal seek's observer.
    pub fn seek_observer(&self) -> SeekObserverF64 {
        self.seek_observer
    }

    /// The velocity estimate v̂, quanta per sample.
    pub fn velocity(&self) -> f64 {
        self.v_hat
    }

    /// One sample as the fixed-point controller decided it (`out`: its region, its law, whether
    /// it fell back) at r, y (quanta); returns u (full scale).
    pub fn step_as(&mut self, out: &ControlOutput, r: f64, y: f64) -> f64 {
        let mode = LawMode::of(out, self.prior.is_some());
        let fallback = out.flags.contains(ControlFlags::FALLBACK);
        self.pulse_off = out.flags.contains(ControlFlags::PULSE_OFF);
        self.step(mode, fallback, r, y)
    }

    /// One sample of the law `mode` at r, y (quanta), on the prior's gains when `fallback` (and
    /// there is a prior); returns u (full scale).
    pub fn step(&mut self, mode: LawMode, fallback: bool, r: f64, y: f64) -> f64 {
        let d = self.design;
        let fs = d.baseline.u_full_scale_v;
        // The linear position x̂ = r + m⁻¹(y − r) (y without an output map).
        let y_raw = y;
        let e = self.settle_error(r - y);
        let y = r - e;
        if !self.primed {
            self.primed = true;
            (self.y1, self.r1, self.dr1_previous) = (y, r, 0.0);
            self.seek_observer = SeekObserverF64 { x: y, v: 0.0 };
        }
        let (dy1, dr1) = (y - self.y1, r - self.r1);
        let ar = dr1 - self.dr1_previous;
        (self.y1, self.r1, self.dr1_previous) = (y, r, dr1);
        let plan = if fallback && self.prior.is_some() {
            self.prior_seek.clone()
        } else {
            self.seek.clone()
        };
        let gains = if fallback && self.prior.is_some() {
            self.prior
        } else {
            self.gains
        };
        let g = gains.unwrap_or(GainsF64 {
            kp_seek: 0.0,
            kd_seek: 0.0,
            kv_ff: 0.0,
            ka_ff: 0.0,
            kp_settle: 0.0,
            kd_settle: 0.0,
            ki_settle: 0.0,
            obs_a: 0.0,
            obs_b: 0.0,
            obs_l: 0.0,
        });
        self.v_hat = g.obs_a * self.v_hat + g.obs_b * self.last_v + g.obs_l * dy1;
        let time_optimal = matches!(d.seek, SeekMode::TimeOptimal(_));
        if time_optimal {
            self.seek_observer.update(plan.as_ref(), self.last_v, y);
            if self.friction_free_drive {
                self.seek_observer.coulomb_decay(plan.as_ref());
            }
        }
        self.friction_free_drive = false;
        let previous = std::mem::replace(&mut self.mode, mode);
        let entering_settle = matches!(
            mode,
            LawMode::Fine
                | LawMode::FineRestart
                | LawMode::Coast
                | LawMode::CoastFlicker
                | LawMode::Settle
        );
        if previous == LawMode::Seek && entering_settle && time_optimal {
            self.v_hat = self.seek_observer.v;
        }
        let region = |m: LawMode| match m {
            LawMode::Hold => Some(Region::Hold),
            LawMode::Seek => Some(Region::Seek),
            LawMode::Fine
            | LawMode::FineRestart
            | LawMode::Coast
            | LawMode::CoastFlicker
            | LawMode::Settle => Some(Region::Settle),
            LawMode::Fallback => None,
        };
        if mode == LawMode::Fallback {
            if previous != LawMode::Fallback {
                self.pid.reset();
                self.pid.set_enabled(false);
                self.pid.set_manual_output_v(self.last_u * fs);
            }
            let u = self.pid.step_quanta(r, y_raw) / fs;
            self.pid.set_enabled(true);
            self.last_u = u;
            self.last_v = self.forward(u);
            return u;
        }
        let i_max = d.integrator_limit_v / fs;
        let u_max = d.baseline.u_limit_v / fs;
        let (terms, integrating, compensate) = match mode {
            LawMode::Hold => {
                self.integral = 0.0;
                self.friction_free_drive = true;
                let u = d.hold_bias_v / fs;
                self.last_u = u;
                self.last_v = self.forward(u);
                return u;
            }
            LawMode::Seek if time_optimal => {
                self.integral = 0.0;
                let (u, applied) = plan.as_ref().map_or((0.0, 0.0), |p| {
                    let obs = self.seek_observer;
                    p.compensate(p.drive(r - obs.x, obs.v), obs.v, u_max)
                });
                self.last_u = u;
                self.last_v = applied;
                return u;
            }
            LawMode::Seek => (
                g.kp_seek * e + g.kd_seek * (dr1 - self.v_hat) + g.kv_ff * dr1 + g.ka_ff * ar,
                false,
                true,
            ),
            LawMode::Fine => (g.kp_settle * e - g.kd_settle * self.v_hat, true, false),
            LawMode::FineRestart => {
                self.integral = 0.0;
                (g.kp_settle * e - g.kd_settle * self.v_hat, true, false)
            }
            LawMode::Coast | LawMode::CoastFlicker => {
                self.integral = 0.0;
                self.friction_free_drive = true;
                // Damping past a dead zone of l/2 quanta per sample (half what one flicker of
                // the reading moves v̂ by) — after a time-optimal seek, of the seek observer's v̂
                // past v_arrive; a still sled's flicker is not motion.
                let reading = past(self.v_hat, g.obs_l / 2.0);
                let moving = match (mode, time_optimal, plan.as_ref()) {
                    (LawMode::CoastFlicker, _, _) => 0.0,
                    (_, true, Some(p)) => {
                        let gliding = past(self.seek_observer.v, p.v_arrive());
                        if gliding.abs() > reading.abs() {
                            gliding
                        } else {
                            reading
                        }
                    }
                    _ => reading,
                };
                let v = -g.kd_settle * moving;
                let u = v.clamp(-u_max, u_max);
                self.last_v = self.forward(u);
                self.last_u = u;
                return u;
            }
            LawMode::Settle | LawMode::Fallback => {
                (g.kp_settle * e - g.kd_settle * self.v_hat, true, true)
            }
        };
        let changed = region(previous) != region(mode);
        let returning = previous == LawMode::Fallback;
        if changed && previous == LawMode::Seek && region(mode) == Some(Region::Settle) {
            self.integral = 0.0;
        } else if returning || (changed && previous != LawMode::Hold) {
            self.integral = (self.last_v - terms).clamp(-i_max, i_max);
        } else if integrating {
            let candidate = (self.integral + g.ki_settle * e).clamp(-i_max, i_max);
            let v = terms + candidate;
            let winding = (v > u_max && candidate > self.integral)
                || (v < -u_max && candidate < self.integral);
            if !winding {
                self.integral = candidate;
            }
        } else {
            self.integral -= self.integral / 16.0;
        }
        if self.pulse_off {
            // An off-sample of the pulsed settle drive: the integrator ran, nothing drives.
            self.friction_free_drive = true;
            self.last_v = 0.0;
            self.last_u = 0.0;
            return 0.0;
        }
        let v = terms + self.integral;
        let u = if compensate { self.inverse(v) } else { v }.clamp(-u_max, u_max);
        self.last_v = if compensate { v } else { self.forward(u) };
        self.last_u = u;
        u
    }
}

/// The largest |h⁻¹(v) − table(v)| of a fixed-point input map against the exact inverse of its
/// own neuron (bisection in f64), full scale, over v ∈ ±(2·range of the table's grid) on 8,001
/// points: what the table's linear interpolation (and its constant tail) costs.
pub fn map_table_error(map: &sledid::control::InverseInputMap) -> f64 {
    let n = map.neuron();
    let wac = Some((n.w().to_f64(), n.a().to_f64(), n.c().to_f64()));
    let (v0, step, _) = map.grid();
    let span = 2.0 * f64::from(v0).abs() / 65_536.0 + f64::from(step) / 65_536.0;
    (-4000..=4000)
        .map(|i| {
            let v = f64::from(i) * span / 4000.0;
            let raw = (v * 65_536.0).round() as i32;
            let v = f64::from(raw) / 65_536.0;
            (f64::from(map.apply(raw)) / 65_536.0 - inverse_of(wac, v)).abs()
        })
        .fold(0.0, f64::max)
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

/// `v` less a dead zone of ±`w` (≥ 0).
fn past(v: f64, w: f64) -> f64 {
    v - v.clamp(-w, w)
}
