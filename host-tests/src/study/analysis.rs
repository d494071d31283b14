//! Model validation and data views of the study: residual–input cross-correlation (paper Fig. 7,
//! 18), the criterion surface of the first-order models (Fig. 8) and the periodogram (Fig. 5 b).

use super::models::{LinearModel, simulate, sse_from};
use super::results::{CriterionSurfaces, CrossCorrelation, Periodogram, SurfacePoint};

/// The 99 % two-sided normal quantile: bounds `±2.58/√N` on a cross-correlation of white noise.
pub const Z_99: f64 = 2.58;

/// Cross-correlation of `eps` and `u` for τ = −`max_lag`…`max_lag`.
pub fn cross_correlation(eps: &[f64], u: &[f64], max_lag: usize) -> CrossCorrelation {
    let n = eps.len().min(u.len());
    let mean = |x: &[f64]| x[..n].iter().sum::<f64>() / n.max(1) as f64;
    let (me, mu) = (mean(eps), mean(u));
    let e: Vec<f64> = eps[..n].iter().map(|v| v - me).collect();
    let x: Vec<f64> = u[..n].iter().map(|v| v - mu).collect();
    let norm = (e.iter().map(|v| v * v).sum::<f64>() * x.iter().map(|v| v * v).sum::<f64>()).sqrt();
    let max_lag = max_lag.min(n.saturating_sub(1)) as i64;
    let lags: Vec<i64> = (-max_lag..=max_lag).collect();
    let values: Vec<f64> = lags
        .iter()
        .map(|&tau| {
            let s: f64 = (0..n as i64)
                .filter(|t| (0..n as i64).contains(&(t - tau)))
                .map(|t| e[t as usize] * x[(t - tau) as usize])
                .sum();
            if norm > 0.0 { s / norm } else { 0.0 }
        })
        .collect();
    let bound = Z_99 / (n.max(1) as f64).sqrt();
    let outside = values.iter().filter(|v| v.abs() > bound).count();
    CrossCorrelation {
        lags,
        values,
        bound,
        samples: n,
        outside,
    }
}

/// The periodogram of `x` sampled at `ts_s` (direct DFT: the segments are ~100 samples).
pub fn periodogram(x: &[f64], ts_s: f64) -> Periodogram {
    let n = x.len().max(1);
    let m = x.iter().sum::<f64>() / n as f64;
    let (mut freq_hz, mut power_db) = (Vec::new(), Vec::new());
    for k in 1..=n / 2 {
        let (mut re, mut im) = (0.0, 0.0);
        for (t, v) in x.iter().enumerate() {
            let ph = -2.0 * std::f64::consts::PI * (k * t) as f64 / n as f64;
            re += (v - m) * ph.cos();
            im += (v - m) * ph.sin();
        }
        freq_hz.push(k as f64 / (n as f64 * ts_s));
        power_db.push(10.0 * ((re * re + im * im) / n as f64 + 1e-20).log10());
    }
    Periodogram { freq_hz, power_db }
}

/// ARX1 criterion at (a1, b1): `V_N = 1/(N−1) Σ (y(t) + a1 y(t−1) − b1 u(t−1))²`.
fn arx1_v_n(y: &[f64], u: &[f64], a1: f64, b1: f64) -> f64 {
    let s: f64 = (1..y.len())
        .map(|t| (y[t] + a1 * y[t - 1] - b1 * u[t - 1]).powi(2))
        .sum();
    s / (y.len().saturating_sub(1).max(1)) as f64
}

/// OE1 criterion at (f1, b1): mean squared simulation error from `ŷ(0) = y(0)`.
fn oe1_v_n(y: &[f64], u: &[f64], f1: f64, b1: f64) -> f64 {
    sse_from(y, &simulate(&[f1], &[b1], u, y), 1) / (y.len().saturating_sub(1).max(1)) as f64
}

/// The two criterion surfaces on a `grid × grid` mesh that covers both estimates with a margin.
pub fn criterion_surfaces(
    y: &[f64],
    u: &[f64],
    arx1: &LinearModel,
    oe1: &LinearModel,
    grid: usize,
) -> CriterionSurfaces {
    let (pa, po) = (-arx1.den[0], -oe1.den[0]);
    let (ba, bo) = (arx1.num[0], oe1.num[0]);
    let wp = (pa - po).abs().max(0.05);
    let wb = (ba - bo).abs().max(0.5 * ba.abs().max(bo.abs())).max(1e-6);
    let axis = |lo: f64, hi: f64| -> Vec<f64> {
        let g = grid.max(2);
        (0..g)
            .map(|i| lo + (hi - lo) * i as f64 / (g - 1) as f64)
            .collect()
    };
    let pole_axis = axis(pa.min(po) - wp, pa.max(po) + wp);
    let b1_axis = axis(ba.min(bo) - wb, ba.max(bo) + wb);
    let surface = |f: &dyn Fn(f64, f64) -> f64| -> Vec<Vec<f64>> {
        b1_axis
            .iter()
            .map(|&b| pole_axis.iter().map(|&p| f(-p, b)).collect())
            .collect()
    };
    CriterionSurfaces {
        arx_v_n: surface(&|a, b| arx1_v_n(y, u, a, b)),
        oe_v_n: surface(&|f, b| oe1_v_n(y, u, f, b)),
        arx_minimum: SurfacePoint {
            pole: pa,
            b1: ba,
            v_n: arx1_v_n(y, u, -pa, ba),
        },
        oe_minimum: SurfacePoint {
            pole: po,
            b1: bo,
            v_n: oe1_v_n(y, u, -po, bo),
        },
        pole_axis,
        b1_axis,
    }
}
