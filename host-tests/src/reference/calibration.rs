//! Float64 reference of power-on calibration's fit (`sledid::servo::calibration::fit`): the same
//! first-order sled with Coulomb friction, sampled exactly under the ZOH drive, least squares in
//! (K, K·u_c(+), K·u_c(−), y₀ per push) at each pole λ, λ by a log grid and a golden-section
//! refinement — in `f64`, with the least squares solved by Cholesky ([`least_squares`]) instead of the library's
//! pivoted elimination, and the golden section run to convergence (60 steps).

use sledid::servo::calibration::{CalibrationRecord, SEGMENTS};

use super::batch::least_squares;

const P: usize = 3 + SEGMENTS;

/// The reference's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationF64 {
    /// a = e^{−λ}.
    pub a: f64,
    /// K, quanta per sample per full scale.
    pub gain_k: f64,
    /// u_c(+), u_c(−), fraction of full scale.
    pub coulomb_fs: [f64; 2],
    /// RMS residual, quanta.
    pub rms: f64,
}

impl CalibrationF64 {
    /// b = (1 − a)·K.
    pub fn b(&self) -> f64 {
        (1.0 - self.a) * self.gain_k
    }
}

fn rows(record: &CalibrationRecord, lambda: f64, mut row: impl FnMut(&[f64; P], f64)) {
    let a = (-lambda).exp();
    let c1 = -(-lambda).exp_m1() / lambda;
    let (d0, g) = (1.0 - c1, 1.0 - a);
    for (s, seg) in record.segments.iter().enumerate() {
        let d = seg.direction();
        if d == 0 {
            continue;
        }
        let df = f64::from(d);
        let drive = f64::from(seg.drive_i16f16) / 65536.0;
        let (mut vu, mut xu, mut vd, mut xd) = (0.0, 0.0, 0.0, 0.0);
        for (j, &x) in seg.readings().iter().enumerate() {
            let mut phi = [0.0; P];
            phi[0] = xu;
            phi[if d > 0 { 1 } else { 2 }] = -xd;
            phi[3 + s] = 1.0;
            row(&phi, f64::from(x) / 65536.0);
            let u = if j < usize::from(seg.push_len) {
                drive
            } else {
                -drive
            };
            xu += vu * c1 + u * d0;
            vu = a * vu + g * u;
            xd += vd * c1 + df * d0;
            vd = a * vd + g * df;
        }
    }
}

/// Least squares at pole λ by [`least_squares`] (Cholesky on the normal equations), the
/// pseudo-observations as rows: y₀ = 0 of weight 1 per push, 10⁻³·θᵢ = 0 on K and K·u_c(±) (the
/// library's ridge of 10⁻⁶ on the normal equations). The unknowns, the residual sum of squares
/// (the y₀ rows included) and the readings' count.
fn solve(record: &CalibrationRecord, lambda: f64) -> Option<([f64; P], f64, usize)> {
    let (mut phi, mut x) = (Vec::new(), Vec::new());
    rows(record, lambda, |row, target| {
        phi.push(row.to_vec());
        x.push(target);
    });
    let n = x.len();
    for i in 0..P {
        let mut row = vec![0.0; P];
        row[i] = if i >= 3 { 1.0 } else { 1e-3 };
        phi.push(row);
        x.push(0.0);
    }
    let theta: [f64; P] = least_squares(&phi, &x)?.try_into().ok()?;
    let mut ssr = 0.0;
    rows(record, lambda, |phi, x| {
        let e = x - phi.iter().zip(&theta).map(|(p, t)| p * t).sum::<f64>();
        ssr += e * e;
    });
    ssr += theta[3..].iter().map(|y| y * y).sum::<f64>();
    Some((theta, ssr, n))
}

fn cost(record: &CalibrationRecord, ln_lambda: f64) -> f64 {
    solve(record, ln_lambda.exp()).map_or(f64::INFINITY, |s| s.1)
}

/// The fit of `record` in float64 (`None`: no pushes or a singular system).
pub fn fit_f64(record: &CalibrationRecord) -> Option<CalibrationF64> {
    let (lo, hi) = (0.002f64.ln(), 10.0f64.ln());
    let grid = |i: usize| lo + (hi - lo) * i as f64 / 24.0;
    let best = (0..25)
        .map(|i| (i, cost(record, grid(i))))
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    if !best.1.is_finite() {
        return None;
    }
    let (mut l, mut h) = (grid(best.0.saturating_sub(1)), grid((best.0 + 1).min(24)));
    let r = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..60 {
        let (m1, m2) = (h - r * (h - l), l + r * (h - l));
        if cost(record, m1) <= cost(record, m2) {
            h = m2;
        } else {
            l = m1;
        }
    }
    let ln_lambda = 0.5 * (l + h);
    let ln_lambda = if cost(record, grid(best.0)) < cost(record, ln_lambda) {
        grid(best.0)
    } else {
        ln_lambda
    };
    let lambda = ln_lambda.exp();
    let (theta, ssr, n) = solve(record, lambda)?;
    Some(CalibrationF64 {
        a: (-lambda).exp(),
        gain_k: theta[0],
        coulomb_fs: [theta[1] / theta[0], theta[2] / theta[0]],
        rms: (ssr / n as f64).sqrt(),
    })
}
