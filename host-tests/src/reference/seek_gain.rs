//! The seeks' gain learner (`sledid::control::scheduled::learn`) in f64: the plan's model run open
//! loop from the seek's start on the drives applied, the least-squares ratio of the readings'
//! progress to the model's over the window up to the sled's first stop or turn — the same rules,
//! without the fixed point's rounding (x̃ to I16F16, the sums to 4 fractional bits per factor).

use super::seek::sampled_f64;

/// r = S_xy/S_xx of one seek, or `None` below the learner's 20-quantum response.
///
/// `drives[j]` is the linear drive the model saw over sample j of the seek (from its start at
/// rest), `readings[0]` the reading at the start and `readings[j + 1]` the one after drive j,
/// quanta; `target` the seek's target (its direction); (a, b) the plan's model.
pub fn seek_ratio(a: f64, b: f64, drives: &[f64], readings: &[f64], target: f64) -> Option<f64> {
    let (c1, b0) = sampled_f64(a, b);
    let y0 = *readings.first()?;
    let d = if target >= y0 { 1.0 } else { -1.0 };
    let (mut x, mut v) = (0.0, 0.0);
    let (mut sxy, mut sxx, mut progress_max) = (0.0, 0.0, 0.0f64);
    for (u, y) in drives.iter().zip(readings.iter().skip(1)) {
        x += c1 * v + b0 * u;
        v = a * v + b * u;
        let progress = d * (y - y0);
        if progress < progress_max - 1.0 || d * v <= 0.0 {
            break;
        }
        progress_max = progress_max.max(progress);
        sxy += d * x * progress;
        sxx += x * x;
    }
    (sxx >= 400.0).then(|| sxy / sxx)
}
