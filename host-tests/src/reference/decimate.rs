//! The half-band decimator of [`sledid::ident::decimate`] in `f64`: the unquantised design, direct-form
//! filtering and the frequency response.

use sledid::ident::decimate::{DecimatorConfig, GROUP_DELAY_SAMPLES, HALF_TAPS, TAPS};
use std::collections::VecDeque;
use std::f64::consts::PI;

/// The unquantised design, h(11 ± 1), h(11 ± 3), …, h(11 ± 11): `scipy.signal.remez(12, [0, 0.28],
/// [1], fs=1)` scaled to a sum of 1, halved (scipy 1.17).
pub const HALF_BAND_23_F64: [f64; HALF_TAPS] = [
    0.310_408_013_767_037_64,
    -0.084_357_288_787_123_65,
    0.033_125_833_519_913_43,
    -0.011_966_839_032_835_73,
    0.003_342_013_153_345_185,
    -0.000_551_732_620_336_901_2,
];

/// Passband edge, fraction of the input rate.
pub const PASSBAND_EDGE: f64 = 0.14;
/// Stopband edge, fraction of the input rate.
pub const STOPBAND_EDGE: f64 = 0.36;

/// The 23 taps from the off-centre half (centre 1/2, even offsets 0).
pub fn taps_from_half(half: &[f64; HALF_TAPS]) -> [f64; TAPS] {
    let mut h = [0.0; TAPS];
    h[GROUP_DELAY_SAMPLES] = 0.5;
    for (j, &v) in half.iter().enumerate() {
        h[GROUP_DELAY_SAMPLES - 1 - 2 * j] = v;
        h[GROUP_DELAY_SAMPLES + 1 + 2 * j] = v;
    }
    h
}

/// The 23 taps of the unquantised design.
pub fn design_taps() -> [f64; TAPS] {
    taps_from_half(&HALF_BAND_23_F64)
}

/// The 23 taps of a fixed-point configuration, exactly (I1F31 → f64).
pub fn config_taps(cfg: &DecimatorConfig) -> [f64; TAPS] {
    let half = cfg
        .half_band_i1f31()
        .map(|v| f64::from(v) / f64::from(1u32 << 31));
    taps_from_half(&half)
}

/// |H(e^{i2πf})| at f (fraction of the input rate).
pub fn magnitude(taps: &[f64; TAPS], f: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (n, &h) in taps.iter().enumerate() {
        let ph = -2.0 * PI * f * n as f64;
        re += h * ph.cos();
        im += h * ph.sin();
    }
    re.hypot(im)
}

/// Filter and keep every second output, in `f64`: `y(m) = Σ h(n) x(2m + 1 − n)`, the same phase as
/// the fixed-point decimator.
#[derive(Clone, Debug)]
pub struct DecimatorF64 {
    taps: [f64; TAPS],
    /// Newest first.
    line: VecDeque<f64>,
    odd: bool,
}

impl DecimatorF64 {
    /// With the given taps, zero history.
    pub fn new(taps: [f64; TAPS]) -> Self {
        Self {
            taps,
            line: VecDeque::from(vec![0.0; TAPS]),
            odd: false,
        }
    }

    /// One input; an output after every second one.
    pub fn push(&mut self, x: f64) -> Option<f64> {
        self.line.pop_back();
        self.line.push_front(x);
        self.odd = !self.odd;
        if self.odd {
            return None;
        }
        Some(
            self.taps
                .iter()
                .zip(self.line.iter())
                .map(|(h, x)| h * x)
                .sum(),
        )
    }

    /// Runs a whole signal.
    pub fn run(taps: [f64; TAPS], x: &[f64]) -> Vec<f64> {
        let mut d = Self::new(taps);
        x.iter().filter_map(|&v| d.push(v)).collect()
    }
}
