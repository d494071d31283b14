//! Batch least squares and model simulation in `f64`.

/// The ARX regressor `[−y(t−1) … −y(t−na), u(t−nk) … u(t−nk−nb+1)]` at sample t (zeros before 0).
pub fn arx_regressor(y: &[f64], u: &[f64], t: usize, na: usize, nb: usize, nk: usize) -> Vec<f64> {
    let lag = |s: &[f64], m: usize| if m <= t { s[t - m] } else { 0.0 };
    (1..=na)
        .map(|i| -lag(y, i))
        .chain((0..nb).map(|i| lag(u, nk + i)))
        .collect()
}

/// Solves the normal equations `(ΦᵀΦ) θ = Φᵀy` by Cholesky; `None` if not positive definite.
pub fn least_squares(phi: &[Vec<f64>], y: &[f64]) -> Option<Vec<f64>> {
    let n = phi.first()?.len();
    let mut a = vec![vec![0.0; n]; n];
    let mut b = vec![0.0; n];
    for (row, &yt) in phi.iter().zip(y) {
        for i in 0..n {
            b[i] += row[i] * yt;
            for j in 0..n {
                a[i][j] += row[i] * row[j];
            }
        }
    }
    // Cholesky a = L Lᵀ.
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - s;
                if d <= 0.0 {
                    return None;
                }
                l[i][i] = d.sqrt();
            } else {
                l[i][j] = (a[i][j] - s) / l[j][j];
            }
        }
    }
    let mut z = vec![0.0; n];
    for i in 0..n {
        z[i] = (b[i] - (0..i).map(|k| l[i][k] * z[k]).sum::<f64>()) / l[i][i];
    }
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        x[i] = (z[i] - ((i + 1)..n).map(|k| l[k][i] * x[k]).sum::<f64>()) / l[i][i];
    }
    Some(x)
}

/// ARX(na, nb, nk) by batch least squares over samples `start..y.len()`.
pub fn fit_arx(y: &[f64], u: &[f64], na: usize, nb: usize, nk: usize) -> Option<Vec<f64>> {
    let start = na.max(nk + nb);
    let phi: Vec<Vec<f64>> = (start..y.len())
        .map(|t| arx_regressor(y, u, t, na, nb, nk))
        .collect();
    least_squares(&phi, &y[start..])
}

/// Simulates `ŷ(t) = −Σ aᵢ ŷ(t−i) + Σ bᵢ u(t−nk−i+1)` from zero initial conditions.
pub fn simulate(theta: &[f64], u: &[f64], na: usize, nk: usize) -> Vec<f64> {
    let nb = theta.len() - na;
    let mut y = vec![0.0; u.len()];
    for t in 0..u.len() {
        let mut acc = 0.0;
        for i in 1..=na {
            if i <= t {
                acc -= theta[i - 1] * y[t - i];
            }
        }
        for i in 0..nb {
            if nk + i <= t {
                acc += theta[na + i] * u[t - nk - i];
            }
        }
        y[t] = acc;
    }
    y
}

/// Root-mean-square of `a − b`.
pub fn rms_error(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()).max(1);
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// Solves the small dense system `a x = b` by Gaussian elimination with partial pivoting.
pub fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < f64::MIN_POSITIVE {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..n {
            let m = a[r][c] / a[c][c];
            let (pivot_rows, rest) = a.split_at_mut(r);
            for (x, p) in rest[0][c..].iter_mut().zip(&pivot_rows[c][c..]) {
                *x -= m * p;
            }
            b[r] -= m * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}
