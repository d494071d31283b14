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

/// What [`levenberg_marquardt`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct LmOutcome {
    /// θ at the minimum found.
    pub theta: Vec<f64>,
    /// The criterion there.
    pub cost: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Trial steps rejected because they left the feasible set.
    pub rejected_infeasible: usize,
    /// Whether the search stopped on its tolerance (or found no descent step), not on the limit.
    pub converged: bool,
}

/// Levenberg–Marquardt from `theta0`: at each iterate the Gauss–Newton normal equations
/// `(H, g) = (Σψψᵀ, Σψε)` from `normal_equations`, the step `(H + μ·diag(max(Hᵢᵢ, floor))) d = g`,
/// accepted when `feasible` and `cost` decreases (μ ÷ 10), else μ × 10; stops when an accepted step
/// gains less than `tolerance` (relative), when μ > 10¹² (no descent step left: a constrained
/// minimum) or after `max_iterations` accepted steps.
pub fn levenberg_marquardt(
    theta0: Vec<f64>,
    max_iterations: usize,
    tolerance: f64,
    diag_floor: f64,
    mut normal_equations: impl FnMut(&[f64]) -> (Vec<Vec<f64>>, Vec<f64>),
    cost: impl Fn(&[f64]) -> f64,
    feasible: impl Fn(&[f64]) -> bool,
) -> LmOutcome {
    let mut theta = theta0;
    let mut v = cost(&theta);
    let (mut mu, mut iterations, mut rejected, mut converged) = (1e-3, 0, 0, false);
    'outer: while iterations < max_iterations {
        let (h, g) = normal_equations(&theta);
        loop {
            let mut hm = h.clone();
            for (i, row) in hm.iter_mut().enumerate() {
                row[i] += mu * h[i][i].max(diag_floor);
            }
            if let Some(d) = solve(hm, g.clone()) {
                let c: Vec<f64> = theta.iter().zip(&d).map(|(a, b)| a + b).collect();
                if !feasible(&c) {
                    rejected += 1;
                } else {
                    let vc = cost(&c);
                    if vc.is_finite() && vc < v {
                        let gain = (v - vc) / v.max(f64::MIN_POSITIVE);
                        theta = c;
                        v = vc;
                        iterations += 1;
                        mu = (mu / 10.0).max(1e-12);
                        if gain < tolerance {
                            converged = true;
                            break 'outer;
                        }
                        continue 'outer;
                    }
                }
            }
            mu *= 10.0;
            if mu > 1e12 {
                converged = true;
                break 'outer;
            }
        }
    }
    LmOutcome {
        theta,
        cost: v,
        iterations,
        rejected_infeasible: rejected,
        converged,
    }
}

/// The Gauss–Newton normal equations `(Σψψᵀ, Σψε)` over `t ≥ start`, ε = y − ŷ.
pub fn normal_equations(
    y: &[f64],
    yhat: &[f64],
    psi: &[Vec<f64>],
    start: usize,
    n: usize,
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let mut h = vec![vec![0.0; n]; n];
    let mut g = vec![0.0; n];
    for t in start..yhat.len().min(y.len()) {
        let e = y[t] - yhat[t];
        for i in 0..n {
            g[i] += psi[t][i] * e;
            for j in 0..n {
                h[i][j] += psi[t][i] * psi[t][j];
            }
        }
    }
    (h, g)
}
