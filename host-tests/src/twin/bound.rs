//! The minimum-time bound of a seek on the twin's own plant: how soon any controller with the
//! same drive rail could have the sled's reading at the target for good.
//!
//! # Problem
//! The sled rests at `x₀`; the target is track `T`. Each sample `j = 0, 1, …` (`j = 0` the
//! sample of the command) holds a drive `|u(j)| ≤ u_max` over `[j·Ts, (j+1)·Ts)` and the plant
//! moves by its exact stick/slip solution ([`SledPlant::advance`]: mass, force constant,
//! viscous, Coulomb and static friction, the rail). The reading is the noise-free sensor's,
//! `y(j) = round(x(j·Ts)/q)`. The bound is
//! ```text
//! J* = min over u(·) of  min { j : |y(i) − T| ≤ 1 for every i ≥ j }
//! ```
//! — the access time's criterion (`control::seek`) without its dwell, on the same readings, so
//! no controller's access time is shorter (up to sensor noise, which can round a reading 1.5
//! quanta off into the band a sample early).
//!
//! # Search: bang-bang with one switch sample
//! Moving towards the target (the mirror image for the other direction: friction is symmetric),
//! ```text
//! u(j) = +u_max            j < k
//! u(k) = v                 the switch sample, v ∈ [−u_max, u_max]  (v ∈ [0, u_max] when k = 0)
//! u(j) = −u_max            while the sled would still move forward at the sample's end
//! u(j) = u_s               the sample in which −u_max would stop it: the brake that stops it
//!                          without reversing (below)
//! u(j) = 0                 at rest: |0| ≤ F_s, the sled sticks
//! ```
//! In the stopping sample the drive is `u_s = −F_s/k_f` (the strongest brake a resting sled
//! withstands) if that stops the sled within the sample — it then sticks — and otherwise the
//! `u_s ∈ [−u_max, −F_s/k_f]` that brings the velocity to zero at the sample's end: from the
//! plant's solution for a moving sled, `v(Ts) = v₀ + a₀·Ts·φ₁(b·Ts/m) = 0` with
//! `a₀ = (k_f·u_s − F_c − b·v₀)/m`, so `k_f·u_s = F_c + b·v₀ − m·v₀/(Ts·φ₁)`, checked by stepping
//! the plant (bisection if the check fails). A sled slower than
//! [`REST_SPEED_QUANTA_PER_SAMPLE`] counts as at rest (the rounding of that zero; it matters only
//! without friction).
//!
//! With `s = k + f`, `v = −u_max + 2·f·u_max` (`v = f·u_max` for `k = 0`), the trajectory is
//! continuous and ordered in `s`: a larger `s` is ahead at every sample (the comparison
//! principle of the same braking dynamics), so the rest position `R(s)` grows with `s` and the
//! first sample in the band comes no later. The minimum is therefore at the largest `s` whose
//! final reading is still `≤ T + 1`: the integer part is found by doubling and bisection, the
//! switch fraction by bisection to [`SWITCH_TOLERANCE`]; every trajectory evaluated on the way
//! that ends in the band is a feasible control, and the bound is the smallest `J` among them.
//! Over the continuous-time optimum it loses at most the sampling of the readings and the
//! zero-order hold of the switch (`tests/integration/seek_bound.rs` checks a frictionless sled against the
//! analytic bang-bang time).

use super::params::PlantParams;
use super::plant::SledPlant;

/// A sled moving less than this many quanta per sample counts as at rest (after the stopping
/// sample's bisection, whose residual velocity is at the rounding level).
pub const REST_SPEED_QUANTA_PER_SAMPLE: f64 = 1e-9;
/// The search stops when the switch parameter `s` is known to this precision (a fraction of
/// one sample of full drive).
pub const SWITCH_TOLERANCE: f64 = 1e-9;
/// No trajectory is simulated beyond this many samples (a seek the rail cannot complete).
pub const MAX_SAMPLES: usize = 200_000;

/// The minimum-time bound of one seek and the bang-bang control that achieves it.
#[derive(Clone, Debug, PartialEq)]
pub struct SeekBound {
    /// `J*`: samples from the command to the first sample after which the reading stays within
    /// ±1 quantum of the target.
    pub samples: usize,
    /// `J*·Ts`, s.
    pub time_s: f64,
    /// Samples at `+u_max` before the switch sample (in the direction of the target).
    pub accelerate_samples: usize,
    /// The switch sample's drive, V (in the direction of the target).
    pub switch_v: f64,
    /// Where the sled comes to rest, relative to the target, quanta (in the direction of the
    /// target: positive is beyond it).
    pub rest_error_quanta: f64,
    /// The drive of every sample from the command until the sled rests, V (0 after): played
    /// open loop on the plant from `start_m`, it reaches the band for good at sample `samples`.
    pub drive_v: Vec<f64>,
}

/// The bound for a sled of `plant` resting at `start_m` commanded to track `target_counts`
/// (position `target_counts·q`); `None` if the rail cannot break the sled loose
/// (`k_f·u_max ≤ F_s`) or no trajectory ends in the band within [`MAX_SAMPLES`].
/// A sled whose reading is already in the band has the bound 0.
pub fn min_time_seek(plant: &PlantParams, start_m: f64, target_counts: i64) -> Option<SeekBound> {
    let q = plant.quantum_m;
    let in_band =
        |x_m: f64, sign: f64| ((sign * x_m / q).round() as i64 - target_counts).abs() <= 1;
    if in_band(start_m, 1.0) {
        return Some(SeekBound {
            samples: 0,
            time_s: 0.0,
            accelerate_samples: 0,
            switch_v: 0.0,
            rest_error_quanta: start_m / q - target_counts as f64,
            drive_v: Vec::new(),
        });
    }
    if plant.force_per_volt_n_per_v * plant.u_max_v <= plant.static_n {
        return None;
    }
    // Mirror so that the target lies ahead.
    let sign = if target_counts as f64 * q >= start_m {
        1.0
    } else {
        -1.0
    };
    let search = Search::new(plant, sign * start_m, sign * target_counts as f64);
    search.run().map(|best| SeekBound {
        samples: best.samples,
        time_s: best.samples as f64 * plant.ts_s,
        accelerate_samples: best.accelerate_samples,
        switch_v: best.switch_v,
        rest_error_quanta: best.rest_m / q - sign * target_counts as f64,
        drive_v: best.drive_v.iter().map(|u| sign * u).collect(),
    })
}

/// One evaluated trajectory.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    /// First sample after which the reading stays in the band (`None`: it ends outside).
    samples: Option<usize>,
    /// Whether the sled rests beyond the band's far edge (read `> T + 1`).
    beyond: bool,
    accelerate_samples: usize,
    /// The switch fraction `f`.
    f: f64,
    switch_v: f64,
    rest_m: f64,
}

/// The best feasible trajectory found.
#[derive(Clone, Debug)]
struct Best {
    samples: usize,
    accelerate_samples: usize,
    f: f64,
    switch_v: f64,
    rest_m: f64,
    /// Its drive (towards +x), recorded once the search has ended.
    drive_v: Vec<f64>,
}

/// The search's fixed data and the cached acceleration phase (moving towards +x).
struct Search {
    ts_s: f64,
    u_max_v: f64,
    q: f64,
    /// The target in quanta (after mirroring; an integer or its negation).
    target_quanta: f64,
    /// The strongest brake a resting sled withstands, V (≤ 0).
    hold_brake_v: f64,
    /// A sled slower than this counts as at rest, m/s.
    rest_speed: f64,
    /// The plant's constants, for the stopping brake's closed form.
    mass_kg: f64,
    force_per_volt_n_per_v: f64,
    viscous_n_s_per_m: f64,
    coulomb_n: f64,
    /// The plant after `k` samples of `+u_max`, `k = 0…` (grown on demand).
    accelerated: Vec<SledPlant>,
    /// `last_out[k]`: the last sample among `0..=k` of the acceleration phase whose reading is
    /// outside the band.
    last_out: Vec<Option<usize>>,
}

impl Search {
    fn new(params: &PlantParams, start_m: f64, target_quanta: f64) -> Self {
        let mut plant = SledPlant::new(params);
        plant.reset(start_m);
        // The strongest brake that still leaves a resting sled stuck (|k_f·u| ≤ F_s), rounded
        // towards zero so that the product does not exceed F_s.
        let hold = (params.static_n / params.force_per_volt_n_per_v).min(params.u_max_v);
        let mut s = Self {
            ts_s: params.ts_s,
            u_max_v: params.u_max_v,
            q: params.quantum_m,
            target_quanta,
            hold_brake_v: -hold * (1.0 - 1e-12),
            rest_speed: REST_SPEED_QUANTA_PER_SAMPLE * params.quantum_m / params.ts_s,
            mass_kg: params.mass_kg,
            force_per_volt_n_per_v: params.force_per_volt_n_per_v,
            viscous_n_s_per_m: params.viscous_n_s_per_m,
            coulomb_n: params.coulomb_n,
            accelerated: vec![plant],
            last_out: vec![None],
        };
        s.last_out = vec![s.out_of_band(start_m).then_some(0)];
        s
    }

    /// Whether the reading at `x_m` is outside the band.
    fn out_of_band(&self, x_m: f64) -> bool {
        ((x_m / self.q).round() - self.target_quanta).abs() > 1.0
    }

    /// Whether the reading at `x_m` is beyond the band's far edge.
    fn beyond(&self, x_m: f64) -> bool {
        (x_m / self.q).round() - self.target_quanta > 1.0
    }

    /// The plant after `k` full-drive samples, and the last out-of-band sample among `0..=k`.
    fn prefix(&mut self, k: usize) -> Option<(SledPlant, Option<usize>)> {
        while self.accelerated.len() <= k {
            if self.accelerated.len() > MAX_SAMPLES {
                return None;
            }
            let mut p = self.accelerated.last()?.clone();
            p.advance(self.u_max_v, self.ts_s);
            let j = self.accelerated.len();
            let last = if self.out_of_band(p.position_m()) {
                Some(j)
            } else {
                self.last_out.last().copied().flatten()
            };
            self.accelerated.push(p);
            self.last_out.push(last);
        }
        Some((self.accelerated.get(k)?.clone(), *self.last_out.get(k)?))
    }

    /// The drive of `s = k + f` in the switch sample.
    fn switch_v(&self, k: usize, f: f64) -> f64 {
        if k == 0 {
            f * self.u_max_v
        } else {
            (2.0 * f - 1.0) * self.u_max_v
        }
    }

    /// Simulates the trajectory of `s = k + f` to rest, appending its drive to `drive` if given.
    fn evaluate(&mut self, k: usize, f: f64, mut drive: Option<&mut Vec<f64>>) -> Option<Outcome> {
        let (mut p, mut last_out) = self.prefix(k)?;
        let switch_v = self.switch_v(k, f);
        let applied = if switch_v < 0.0 {
            // A braking switch sample never brakes harder than the stopping brake: at f = 0 it
            // is the first braking sample of s = k, so the trajectory is continuous in s.
            self.brake_step(&mut p, switch_v)
        } else {
            p.advance(switch_v, self.ts_s);
            switch_v
        };
        if let Some(d) = drive.as_deref_mut() {
            d.extend(std::iter::repeat_n(self.u_max_v, k));
            d.push(applied);
        }
        let rest_speed = self.rest_speed;
        let mut j = k + 1;
        loop {
            if self.out_of_band(p.position_m()) {
                last_out = Some(j);
            }
            let v = p.velocity_m_per_s();
            if v.abs() <= rest_speed {
                break;
            }
            if j >= MAX_SAMPLES {
                return None;
            }
            if v < 0.0 {
                // Not reached (no brake here reverses the sled); not a rest-to-rest seek.
                return Some(Outcome {
                    samples: None,
                    beyond: self.beyond(p.position_m()),
                    accelerate_samples: k,
                    f,
                    switch_v,
                    rest_m: p.position_m(),
                });
            }
            let u = self.brake_step(&mut p, -self.u_max_v);
            if let Some(d) = drive.as_deref_mut() {
                d.push(u);
            }
            j += 1;
        }
        let rest_m = p.position_m();
        Some(Outcome {
            samples: (!self.out_of_band(rest_m)).then(|| last_out.map_or(0, |i| i + 1)),
            beyond: self.beyond(rest_m),
            accelerate_samples: k,
            f,
            switch_v,
            rest_m,
        })
    }

    /// One braking sample of a sled moving forward, at most as strong as `strongest_v` (< 0):
    /// `strongest_v` unless that would stop the sled within the sample; then the hold brake if
    /// that stops it (it sticks), else the bisected brake that ends the sample with the sled
    /// (just) not reversed. Returns the drive applied.
    fn brake_step(&self, p: &mut SledPlant, strongest_v: f64) -> f64 {
        let after = |u: f64| {
            let mut c = p.clone();
            c.advance(u, self.ts_s);
            c
        };
        let c = after(strongest_v);
        if c.velocity_m_per_s() > 0.0 || strongest_v >= self.hold_brake_v {
            *p = c; // still moving forward, or stopped by a brake the resting sled withstands
            return strongest_v;
        }
        let c = after(self.hold_brake_v);
        if c.velocity_m_per_s() <= 0.0 {
            *p = c;
            return self.hold_brake_v;
        }
        // The drive that brings the velocity to zero at the sample's end, in closed form (the
        // plant's solution for a moving sled: v(Ts) = v₀ + a₀·Ts·φ₁(b·Ts/m) = 0 with
        // a₀ = (k_f·u − F_c − b·v₀)/m), checked on the plant itself.
        let v0 = p.velocity_m_per_s();
        let z = self.viscous_n_s_per_m * self.ts_s / self.mass_kg;
        let phi1 = if z < 1e-4 {
            1.0 - z / 2.0 + z * z / 6.0
        } else {
            -(-z).exp_m1() / z
        };
        let force_n =
            self.coulomb_n + self.viscous_n_s_per_m * v0 - self.mass_kg * v0 / (self.ts_s * phi1);
        let exact_v = (force_n / self.force_per_volt_n_per_v).clamp(strongest_v, self.hold_brake_v);
        let c = after(exact_v);
        if c.velocity_m_per_s().abs() <= self.rest_speed {
            *p = c;
            return exact_v;
        }
        // Otherwise bisection: lo stops (and reverses) the sled within the sample, hi does not.
        let (mut lo, mut hi) = (strongest_v, self.hold_brake_v);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if after(mid).velocity_m_per_s() > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        p.advance(hi, self.ts_s);
        hi
    }

    /// The search of the module documentation.
    fn run(mut self) -> Option<Best> {
        let target_m = self.target_quanta * self.q;
        let mut best: Option<Best> = None;
        let mut consider = |o: &Outcome| {
            // Among equal times, the trajectory that rests nearest the target.
            let nearer = |b: &Best| (o.rest_m - target_m).abs() < (b.rest_m - target_m).abs();
            if let Some(samples) = o.samples
                && best
                    .as_ref()
                    .is_none_or(|b| samples < b.samples || (samples == b.samples && nearer(b)))
            {
                best = Some(Best {
                    samples,
                    accelerate_samples: o.accelerate_samples,
                    f: o.f,
                    switch_v: o.switch_v,
                    rest_m: o.rest_m,
                    drive_v: Vec::new(),
                });
            }
        };
        // The smallest whole k whose full-drive-then-brake trajectory (f = 1) ends beyond the
        // band: doubling, then bisection over k (f = 1 at k is s = k + 1).
        let mut hi = 1usize;
        loop {
            let o = self.evaluate(hi - 1, 1.0, None)?;
            consider(&o);
            if o.beyond {
                break;
            }
            hi = hi.checked_mul(2)?;
            if hi > MAX_SAMPLES {
                return None;
            }
        }
        let mut lo = hi / 2; // s = lo ends short of beyond (or lo = 0)
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            let o = self.evaluate(mid - 1, 1.0, None)?;
            consider(&o);
            if o.beyond {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        // s ∈ [lo, hi]: k = lo, bisect f for the largest one not beyond.
        let k = lo;
        let (mut f_lo, mut f_hi) = (0.0_f64, 1.0_f64);
        let o = self.evaluate(k, f_lo, None)?;
        consider(&o);
        while f_hi - f_lo > SWITCH_TOLERANCE {
            let mid = 0.5 * (f_lo + f_hi);
            let o = self.evaluate(k, mid, None)?;
            consider(&o);
            if o.beyond {
                f_hi = mid;
            } else {
                f_lo = mid;
            }
        }
        let mut best = best?;
        let mut drive = Vec::new();
        self.evaluate(best.accelerate_samples, best.f, Some(&mut drive))?;
        best.drive_v = drive;
        Some(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The search finds the best of its family: no trajectory of a fine grid over the switch
    /// sample and the switch drive reaches the band for good sooner. Trips on a bisection that
    /// keeps the wrong end or stops at the wrong k.
    #[test]
    fn no_trajectory_of_the_family_is_faster_than_the_search() {
        let nominal = PlantParams::default();
        let slow = PlantParams {
            mass_kg: 0.2,
            viscous_n_s_per_m: 200.0,
            force_per_volt_n_per_v: 1.2,
            coulomb_n: 0.15,
            static_n: 0.4,
            ..nominal.clone()
        };
        for plant in [&nominal, &slow] {
            for (start_m, target) in [
                (0.0, 20),
                (0.3e-6, 57),
                (0.0, 200),
                (-0.7e-6, -777),
                (0.0, 2000),
            ] {
                let bound = min_time_seek(plant, start_m, target).expect("reachable");
                let sign = if target > 0 { 1.0 } else { -1.0 };
                let mut search = Search::new(plant, sign * start_m, sign * target as f64);
                let mut grid_best = usize::MAX;
                for k in 0..=bound.accelerate_samples + 3 {
                    for i in 0..=400 {
                        let o = search
                            .evaluate(k, f64::from(i) / 400.0, None)
                            .expect("simulated");
                        if let Some(j) = o.samples {
                            grid_best = grid_best.min(j);
                        }
                    }
                }
                assert!(
                    bound.samples <= grid_best,
                    "{target} tracks: search {} vs grid {grid_best}",
                    bound.samples
                );
                assert!(bound.rest_error_quanta.abs() < 1.5, "{bound:?}");
            }
        }
    }
}
