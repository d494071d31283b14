//! The calibration's fit (module docs of [`super`]): the first-order velocity model with Coulomb
//! friction, sampled exactly under the ZOH drive, fitted to the pushes' readings. `f32`, in the
//! background; `host-tests/src/reference/calibration.rs` is its float64 reference.

#![allow(clippy::float_arithmetic)] // the background's fit

use super::experiment::{CalibrationRecord, SEGMENTS};
use super::{CalibrationConfig, Refusal};
use crate::num::fixed::ParamI12F20;

/// Unknowns: K, K·u_c(+), K·u_c(−), and y₀ of each push.
const P: usize = 3 + SEGMENTS;

/// λ = −ln a searched over [λ_MIN, λ_MAX] (a from 0.998 to 5·10⁻⁵).
const LAMBDA_MIN: f32 = 0.002;
const LAMBDA_MAX: f32 = 10.0;
/// Points of the log grid, then golden-section steps between the best point's neighbours.
const GRID: usize = 25;
const GOLDEN_STEPS: usize = 20;

/// What calibration found.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibratedModel {
    /// The velocity pole a = e^{−λ} per sample.
    pub a: f32,
    /// K: the terminal speed per unit of drive, quanta per sample per full scale.
    pub gain_k: f32,
    /// The Coulomb level in each direction (+, −), fraction of full scale.
    pub coulomb_fs: [f32; 2],
    /// The breakaway drive found in each direction (+, −), fraction of full scale.
    pub breakaway_fs: [f32; 2],
    /// RMS residual of the fit, quanta.
    pub rms: f32,
}

impl CalibratedModel {
    /// b = (1 − a)·K: the ARX(1,1) velocity model's gain, quanta per sample² per full scale.
    pub fn b(&self) -> f32 {
        (1.0 - self.a) * self.gain_k
    }

    /// The mean Coulomb level of both directions (≥ 0), fraction of full scale.
    pub fn coulomb_mean_fs(&self) -> f32 {
        let [pos, neg] = self.coulomb_fs;
        (0.5 * (pos + neg)).max(0.0)
    }

    /// θ of the servo's velocity identifier: [−a, b, b·u_c] (`crate::servo::velocity_identifier`);
    /// `None` when a value leaves the I12F20 range.
    pub fn theta(&self) -> Option<[ParamI12F20; 3]> {
        let b = self.b();
        let p = |x: f32| ParamI12F20::from_f64(f64::from(x)).ok();
        Some([p(-self.a)?, p(b)?, p(b * self.coulomb_mean_fs())?])
    }
}

/// The exact ZOH response over one sample: (position gain of v, position gain of the input,
/// velocity gain of the input) = ((1 − a)/λ, 1 − (1 − a)/λ, 1 − a).
fn zoh(lambda: f32) -> (f32, f32, f32, f32) {
    let a = libm::expf(-lambda);
    let c1 = if lambda < 1e-3 {
        1.0 - lambda * (0.5 - lambda / 6.0)
    } else {
        (1.0 - a) / lambda
    };
    (a, c1, 1.0 - c1, 1.0 - a)
}

/// One reading's row of the regression x(j) = y₀ + K·x_u(j) − C(d)·x_d(j): φ has three non-zero
/// entries — K's (x_u), the push direction's Coulomb term (−x_d) and the push's offset (1) —
/// at the indices `nonzero`, in increasing order.
struct Row {
    /// The indices of φ's non-zero entries: 0, 1 or 2 (the direction), 3 + the push.
    nonzero: [usize; 3],
    /// Those entries: x_u, −x_d, 1.
    phi: [f32; 3],
    /// The reading, quanta.
    x: f32,
}

/// Calls `row` for every valid reading of every push, for the pole λ: x_u the response to the
/// drive, x_d to the direction, under the exact ZOH update.
fn rows(record: &CalibrationRecord, lambda: f32, mut row: impl FnMut(&Row)) {
    let (a, c1, d0, g) = zoh(lambda);
    for (s, seg) in record.segments.iter().enumerate() {
        let d = seg.direction();
        if d == 0 {
            continue;
        }
        let df = d as f32;
        let drive = seg.drive_i16f16 as f32 / 65536.0;
        let coulomb = if d > 0 { 1 } else { 2 };
        let (mut vu, mut xu, mut vd, mut xd) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for (j, &x) in seg.readings().iter().enumerate() {
            row(&Row {
                nonzero: [0, coulomb, 3 + s],
                phi: [xu, -xd, 1.0],
                x: x as f32 / 65536.0,
            });
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

/// Least squares at pole λ: the unknowns and the residual sum of squares (the pseudo-observations
/// y₀ = 0 included), `None` for a singular system.
fn solve(record: &CalibrationRecord, lambda: f32) -> Option<([f32; P], f32, usize)> {
    // The normal equations from φ's three non-zero entries per row: the zero products the
    // dense sums would add change nothing (x + 0 = x), so the sums are the dense ones, in the
    // same order, at a sixth of the work.
    let mut m = [[0.0f32; P + 1]; P];
    let mut count = 0usize;
    rows(record, lambda, |r| {
        count += 1;
        for (&i, &pi) in r.nonzero.iter().zip(&r.phi) {
            let Some(mi) = m.get_mut(i) else { continue };
            for (&j, &pj) in r.nonzero.iter().zip(&r.phi) {
                if let Some(mij) = mi.get_mut(j) {
                    *mij += pi * pj;
                }
            }
            if let Some(rhs) = mi.last_mut() {
                *rhs += pi * r.x;
            }
        }
    });
    // y₀ = 0 with the weight of one reading (the offset within the cell), and a tiny ridge on
    // every unknown so that a direction without pushes stays solvable.
    for (i, mi) in m.iter_mut().enumerate() {
        if let Some(mii) = mi.get_mut(i) {
            *mii += if i >= 3 { 1.0 } else { 1e-6 };
        }
    }
    let theta = gauss(m)?;
    let mut ssr = 0.0f32;
    rows(record, lambda, |r| {
        let fit: f32 = r
            .nonzero
            .iter()
            .zip(&r.phi)
            .map(|(&i, p)| p * theta.get(i).copied().unwrap_or(0.0))
            .sum();
        let e = r.x - fit;
        ssr += e * e;
    });
    ssr += theta.iter().skip(3).map(|y| y * y).sum::<f32>();
    Some((theta, ssr, count))
}

/// Gaussian elimination with partial pivoting on the augmented matrix.
fn gauss(mut m: [[f32; P + 1]; P]) -> Option<[f32; P]> {
    for col in 0..P {
        let mut pivot = (col, 0.0f32);
        for (i, row) in m.iter().enumerate().skip(col) {
            let v = libm::fabsf(*row.get(col)?);
            if v > pivot.1 {
                pivot = (i, v);
            }
        }
        if pivot.1.partial_cmp(&1e-12) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        // The pivot row to `col` (rows below `col` only): `split_at_mut_checked` and `get_mut`
        // instead of `swap`, whose bounds check is a panic path (`pivot.0 < P` always holds).
        if pivot.0 > col {
            let (upper, lower) = m.split_at_mut_checked(pivot.0)?;
            core::mem::swap(upper.get_mut(col)?, lower.first_mut()?);
        }
        let (top, rest) = m.split_at_mut(col + 1);
        let prow = top.last()?;
        let p = *prow.get(col)?;
        for row in rest.iter_mut() {
            let f = *row.get(col)? / p;
            for (r, q) in row.iter_mut().zip(prow.iter()).skip(col) {
                *r -= f * q;
            }
        }
    }
    let mut theta = [0.0f32; P];
    for row in (0..P).rev() {
        let mrow = m.get(row)?;
        let mut s = *mrow.get(P)?;
        for (k, t) in theta.iter().enumerate().skip(row + 1) {
            s -= mrow.get(k)? * t;
        }
        *theta.get_mut(row)? = s / mrow.get(row)?;
    }
    theta.iter().all(|t| t.is_finite()).then_some(theta)
}

/// The largest step between two consecutive readings of the record's pushes, quanta.
fn largest_step(record: &CalibrationRecord) -> f32 {
    let mut step = 0i64;
    for seg in &record.segments {
        let x = seg.x_i16f16.get(..usize::from(seg.len)).unwrap_or(&[]);
        for w in x.windows(2) {
            if let [a, b] = *w {
                step = step.max((i64::from(b) - i64::from(a)).abs());
            }
        }
    }
    step as f32 / 65536.0
}

/// The residual at ln λ (∞ when singular).
fn cost(record: &CalibrationRecord, ln_lambda: f32) -> f32 {
    solve(record, libm::expf(ln_lambda)).map_or(f32::INFINITY, |(_, ssr, _)| ssr)
}

/// The velocity model that explains the record best, or why the sled is refused. Pure; run in the
/// background (≈ 45 least-squares solves of 7 unknowns over ≤ 192 readings).
///
/// # Errors
/// [`Refusal::Fit`] for a record without pushes, a singular or non-finite fit, a gain K ≤ 0 or an
/// RMS residual above the limit; [`Refusal::Gain`] for b outside [gain_min, gain_max].
pub fn fit(c: &CalibrationConfig, record: &CalibrationRecord) -> Result<CalibratedModel, Refusal> {
    let (lo, hi) = (libm::logf(LAMBDA_MIN), libm::logf(LAMBDA_MAX));
    let step = (hi - lo) / (GRID - 1) as f32;
    let grid = |i: usize| lo + step * i as f32;
    let mut best = (0usize, f32::INFINITY);
    for i in 0..GRID {
        let e = cost(record, grid(i));
        if e < best.1 {
            best = (i, e);
        }
    }
    if !best.1.is_finite() {
        return Err(Refusal::Fit);
    }
    // Golden section between the best point's neighbours.
    let (mut l, mut h) = (
        grid(best.0.saturating_sub(1)),
        grid((best.0 + 1).min(GRID - 1)),
    );
    let r = 0.618_034f32;
    let (mut m1, mut m2) = (h - r * (h - l), l + r * (h - l));
    let (mut e1, mut e2) = (cost(record, m1), cost(record, m2));
    for _ in 0..GOLDEN_STEPS {
        if e1 <= e2 {
            h = m2;
            (m2, e2) = (m1, e1);
            m1 = h - r * (h - l);
            e1 = cost(record, m1);
        } else {
            l = m1;
            (m1, e1) = (m2, e2);
            m2 = l + r * (h - l);
            e2 = cost(record, m2);
        }
    }
    let ln_lambda = if e1 <= e2 { m1 } else { m2 };
    let ln_lambda = if best.1 < e1.min(e2) {
        grid(best.0)
    } else {
        ln_lambda
    };
    let lambda = libm::expf(ln_lambda);
    let (theta, ssr, count) = solve(record, lambda).ok_or(Refusal::Fit)?;
    let [k, c_pos, c_neg, ..] = theta;
    if !k.is_finite() || k <= 0.0 || count == 0 {
        return Err(Refusal::Fit);
    }
    let rms = libm::sqrtf(ssr / count as f32);
    let fs = |raw: i32| raw as f32 / 65536.0;
    let [bk_pos, bk_neg] = record.breakaway_i16f16;
    let model = CalibratedModel {
        a: libm::expf(-lambda),
        gain_k: k,
        coulomb_fs: [c_pos / k, c_neg / k],
        breakaway_fs: [fs(bk_pos), fs(bk_neg)],
        rms,
    };
    if !rms.is_finite() || rms > c.rms_max.max(c.rms_per_step * largest_step(record)) {
        return Err(Refusal::Fit);
    }
    let b = model.b();
    if !b.is_finite() || b < c.gain_min || b > c.gain_max {
        return Err(Refusal::Gain);
    }
    Ok(model)
}
