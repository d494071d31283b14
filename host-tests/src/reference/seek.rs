//! The time-optimal seek law (`sledid::control::seek`) in f64: the same model reading (c₁, b₀, the
//! velocity from the last increment), the same braking sequence tabulated at the same 33 speeds,
//! its inverse interpolated the same way — in f64, so that the fixed point's rounding (gains, I16F16
//! speeds, the integer interpolation) is what a comparison measures. [`SeekF64::exact_speed`] is
//! the curve without the table, by bisection on D itself, for the table's own error.

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
    d: Vec<f64>,
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
        let fits = (2.0 * b * braking * 60_000.0).sqrt();
        let top = if a < 1.0 {
            b * u_max / (1.0 - a)
        } else {
            16_384.0
        };
        let w_top = top.min(16_384.0).min(fits);
        // The library's step, I16F16-rounded as it stores it.
        let w_step = (w_top / 32.0 * 65_536.0).floor() / 65_536.0;
        let mut plan = Self {
            a,
            b,
            c1,
            b0,
            braking,
            p,
            w_step,
            d: Vec::new(),
        };
        plan.d = (0..33)
            .map(|j| plan.distance(f64::from(j) * w_step))
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

    /// D⁻¹ by the table: the largest entry at or below `d`, then linear interpolation; the top
    /// speed beyond.
    pub fn speed(&self, d: f64) -> f64 {
        let last = self.d.len() - 1;
        if d >= self.d[last] {
            return last as f64 * self.w_step;
        }
        let j = self.d.iter().rposition(|&dj| dj <= d).unwrap_or(0);
        let span = (self.d[j + 1] - self.d[j]).max(1e-12);
        (j as f64 + (d - self.d[j]) / span) * self.w_step
    }

    /// D⁻¹ exactly (bisection on D over [0, the top speed]).
    pub fn exact_speed(&self, d: f64) -> f64 {
        let top = 32.0 * self.w_step;
        if d >= self.distance(top) {
            return top;
        }
        let (mut lo, mut hi) = (0.0, top);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.distance(mid) <= d {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// v̂ = (a/c₁)·Δy + (b − a·b₀/c₁)·u_e(k−1).
    pub fn velocity(&self, dy: f64, v_last: f64) -> f64 {
        if self.c1 > 1e-6 {
            self.a / self.c1 * dy + (self.b - self.a * self.b0 / self.c1) * v_last
        } else {
            self.b * v_last
        }
    }

    /// The law's linear drive (full scale) for the error e, the last increment Δy and the last
    /// linear drive.
    pub fn drive(&self, e: f64, dy: f64, v_last: f64) -> f64 {
        let v_hat = self.velocity(dy, v_last);
        let left = e - self.c1 * v_hat;
        let v_star = left.signum() * self.speed(left.abs());
        ((1.0 - self.p) * v_star + (self.p - self.a) * v_hat) / self.b
    }
}
