//! The time-optimal seek law (`sledid::control::seek`) in f64: the same sampled model (c₁, b₀),
//! the same stop-point curve K(w) = D(w) + (b₀/b)·w tabulated at the same 33 speeds, its inverse
//! interpolated the same way, the same observer and friction compensation — in f64, so that the
//! fixed point's rounding (gains, I16F16 speeds and positions, the integer interpolation) is what
//! a comparison measures. [`SeekF64::exact_speed`] is the curve without the table, by bisection on
//! K itself, for the table's own error.

/// One model's seek plan in f64.
#[derive(Clone, Debug, PartialEq)]
pub struct SeekF64 {
    a: f64,
    b: f64,
    c1: f64,
    b0: f64,
    braking: f64,
    p: f64,
    w_step: f64,
    /// u_c, full scale.
    u_c: f64,
    /// Arrival speed, quanta per sample.
    v_arrive: f64,
    /// K at the table's speeds.
    k: Vec<f64>,
}

/// The seek's observer (x̂, v̂) in f64, quanta and quanta per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SeekObserverF64 {
    /// x̂.
    pub x: f64,
    /// v̂.
    pub v: f64,
}

impl SeekObserverF64 {
    /// Coulomb friction over an uncompensated drive: |v̂| less b·u_c, never reversed.
    pub fn coulomb_decay(&mut self, plan: Option<&SeekF64>) {
        if let Some(p) = plan {
            self.v = self.v.signum() * (self.v.abs() - p.coulomb_step()).max(0.0);
        }
    }

    /// One sample: predict with `plan`'s model (none: no motion) and the applied linear drive,
    /// correct by what the reading `y` lies outside the predicted cell.
    pub fn update(&mut self, plan: Option<&SeekF64>, drive: f64, y: f64) {
        if let Some(p) = plan {
            self.x += p.c1 * self.v + p.b0 * drive;
            self.v = p.a * self.v + p.b * drive;
        } else {
            self.v = 0.0;
        }
        let d = y - self.x;
        if d.abs() > 0.5 {
            let delta = d - 0.5 * d.signum();
            self.x += delta;
            if let Some(p) = plan {
                self.v += p.correct() * delta;
            }
        }
    }
}

/// (c₁, b₀) of the sampled first-order velocity: c₁ = τ(1 − a), b₀ = b·(1 − c₁)/(1 − a).
pub fn sampled_f64(a: f64, b: f64) -> (f64, f64) {
    if a <= 1e-6 {
        (0.0, b)
    } else if a >= 1.0 - 1e-4 {
        (1.0, 0.5 * b)
    } else {
        let c1 = -(1.0 - a) / a.ln();
        (c1, b * (1.0 - c1) / (1.0 - a))
    }
}

impl SeekF64 {
    /// The plan of the model (a, b, u_c) braking at α·u_max with velocity pole p; `None` where
    /// the library refuses one (a ∉ [0, 1], b ≤ 0, nothing to brake with).
    pub fn new(a: f64, b: f64, u_c: f64, u_max: f64, alpha: f64, p: f64) -> Option<Self> {
        if !(0.0..=1.0).contains(&a) || b <= 0.0 || u_max <= 0.0 {
            return None;
        }
        let braking = alpha * u_max + u_c.max(0.0);
        if braking <= 0.0 {
            return None;
        }
        let (c1, b0) = sampled_f64(a, b);
        let fits = (2.0 * b * braking * 48_000.0).sqrt();
        let top = if a < 1.0 {
            b * u_max / (1.0 - a)
        } else {
            16_384.0
        };
        let w_top = top.min(16_384.0).min(fits);
        // The library's step, I16F16-rounded as it stores it.
        let w_step = (w_top / 32.0 * 65_536.0).floor() / 65_536.0;
        let coast_per_speed = if a < 1.0 - 1e-4 { c1 / (1.0 - a) } else { 1.0 };
        let mut plan = Self {
            a,
            b,
            c1,
            b0,
            braking,
            p,
            w_step,
            u_c: u_c.clamp(0.0, 0.5),
            v_arrive: (1.0 / coast_per_speed.max(1.0 / 1024.0)).min(1.0),
            k: Vec::new(),
        };
        plan.k = (0..33)
            .map(|j| plan.stop_distance(f64::from(j) * w_step))
            .collect();
        Some(plan)
    }

    /// D(w): the braking distance from velocity w (module doc of `sledid::control::seek`).
    pub fn distance(&self, mut w: f64) -> f64 {
        let mut d = 0.0;
        while w > 1e-6 {
            let u = self.braking.min(self.a * w / self.b);
            d += self.c1 * w - self.b0 * u;
            w = self.a * w - self.b * u;
        }
        d
    }

    /// K(w) = D(w) + (b₀/b)·w: the stop point's part that depends on the velocity w after this
    /// sample.
    pub fn stop_distance(&self, w: f64) -> f64 {
        self.distance(w) + self.b0 / self.b * w
    }

    /// K⁻¹ by the table: the largest entry at or below `d`, then linear interpolation; the top
    /// speed beyond.
    pub fn speed(&self, d: f64) -> f64 {
        let last = self.k.len() - 1;
        if d >= self.k[last] {
            return last as f64 * self.w_step;
        }
        let j = self.k.iter().rposition(|&kj| kj <= d).unwrap_or(0);
        let span = (self.k[j + 1] - self.k[j]).max(1e-12);
        (j as f64 + (d - self.k[j]) / span) * self.w_step
    }

    /// K⁻¹ exactly (bisection on K over [0, the top speed]).
    pub fn exact_speed(&self, d: f64) -> f64 {
        let top = 32.0 * self.w_step;
        if d >= self.stop_distance(top) {
            return top;
        }
        let (mut lo, mut hi) = (0.0, top);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.stop_distance(mid) <= d {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// l_v = ½·a/c₁ (0 for c₁ → 0).
    pub fn correct(&self) -> f64 {
        if self.c1 > 1e-6 {
            0.5 * self.a / self.c1
        } else {
            0.0
        }
    }

    /// The law's linear drive (full scale) for the observer's error e = target − x̂ and velocity
    /// v̂.
    pub fn drive(&self, e: f64, v_hat: f64) -> f64 {
        let left = e - (self.c1 - self.a * self.b0 / self.b) * v_hat;
        let w_star = left.signum() * self.speed(left.abs());
        ((1.0 - self.p) * w_star + (self.p - self.a) * v_hat) / self.b
    }

    /// The arrival speed, quanta per sample.
    pub fn v_arrive(&self) -> f64 {
        self.v_arrive
    }

    /// b·u_c: what Coulomb friction takes off a sample's velocity, quanta per sample.
    pub fn coulomb_step(&self) -> f64 {
        self.b * self.u_c
    }

    /// |v̂| ≤ the arrival speed.
    pub fn at_rest(&self, v_hat: f64) -> bool {
        v_hat.abs() <= self.v_arrive
    }

    /// (u, the linear drive after the rail): u = clamp(v + u_c·sgn(v̂, or v at rest), ±u_max).
    pub fn compensate(&self, v: f64, v_hat: f64, u_max: f64) -> (f64, f64) {
        let direction = if self.at_rest(v_hat) { v } else { v_hat };
        let friction = if direction > 0.0 {
            self.u_c
        } else if direction < 0.0 {
            -self.u_c
        } else {
            0.0
        };
        let u = (v + friction).clamp(-u_max, u_max);
        (u, u - friction)
    }
}
