//! Generated recordings for the nonlinear models' robustness to excitation and amplitude: two plants
//! — a Duffing oscillator (an electrical mass–spring–damper with a cubic spring, the kind of system
//! the Silverbox benchmark is) and the sled twin's plant in open loop — driven by four kinds of
//! input, each at any amplitude, written as `t_s,u,y` CSV for `sledid replay`.
//!
//! | excitation | signal |
//! |---|---|
//! | [`Excitation::Schroeder`] | odd multisine, flat amplitude over the band, Schroeder phases (low crest factor) |
//! | [`Excitation::RandomPhase`] | odd multisine, flat amplitude, phases uniform in [0, 2π) |
//! | [`Excitation::Steps`] | random levels in [−1, 1], each held a random 20–200 samples |
//! | [`Excitation::Noise`] | Gaussian noise through a first-order low-pass (pole 0.9) |
//!
//! Every signal is scaled to a peak of `amplitude` × the plant's nominal input, then measured with
//! the plant's sensor noise. Deterministic given the seed.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::io::Write;
use std::path::Path;

use crate::twin::params::PlantParams;
use crate::twin::plant::SledPlant;

/// The kind of input signal (module table).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excitation {
    /// Odd multisine, Schroeder phases.
    Schroeder,
    /// Odd multisine, random phases.
    RandomPhase,
    /// Random steps.
    Steps,
    /// Low-pass filtered Gaussian noise.
    Noise,
}

impl Excitation {
    /// All four.
    pub const ALL: [Self; 4] = [Self::Schroeder, Self::RandomPhase, Self::Steps, Self::Noise];

    /// `n` samples with peak |u| = 1 (the multisines' band: odd harmonics up to `band` × Nyquist).
    pub fn signal(self, n: usize, band: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let period = n.max(2) as f64;
        let lines: Vec<usize> = (1..)
            .step_by(2)
            .take_while(|&k| (k as f64) < band * period / 2.0)
            .collect();
        let count = lines.len().max(1) as f64;
        let x: Vec<f64> = match self {
            Self::Schroeder | Self::RandomPhase => {
                let phases: Vec<f64> = (0..lines.len())
                    .map(|i| {
                        if self == Self::Schroeder {
                            -PI * (i as f64) * (i as f64 + 1.0) / count
                        } else {
                            rng.r#gen::<f64>() * 2.0 * PI
                        }
                    })
                    .collect();
                (0..n)
                    .map(|t| {
                        lines
                            .iter()
                            .zip(&phases)
                            .map(|(&k, p)| (2.0 * PI * k as f64 * t as f64 / period + p).cos())
                            .sum()
                    })
                    .collect()
            }
            Self::Steps => {
                let mut v = Vec::with_capacity(n);
                while v.len() < n {
                    let level = rng.r#gen::<f64>() * 2.0 - 1.0;
                    let hold = rng.gen_range(20..=200);
                    v.extend(std::iter::repeat_n(level, hold));
                }
                v.truncate(n);
                v
            }
            Self::Noise => {
                let mut state = 0.0;
                (0..n)
                    .map(|_| {
                        state = 0.9 * state + gaussian(&mut rng);
                        state
                    })
                    .collect()
            }
        };
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        x.into_iter().map(|v| v / peak).collect()
    }
}

/// A standard normal draw (Box–Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.r#gen::<f64>().max(1e-300);
    let u2: f64 = rng.r#gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
}

/// The plant a recording is generated on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plant {
    /// `ÿ + 2ζω ẏ + ω² (y + y³/y_c²) = ω² u` (volts), ω = 2π·60 Hz, ζ = 0.05, y_c = 0.25 V, at
    /// fs = 610.35 Hz (Silverbox's), sensor noise 0.1 mV RMS; nominal input 0.15 V peak.
    Duffing,
    /// The sled twin's plant (Coulomb and static friction, viscous damping, saturation) in open
    /// loop at Ts = 0.455 ms, position quantised to the track (1.6 µm); nominal input 1 V peak.
    Sled,
}

impl Plant {
    /// Sampling period, s.
    pub fn ts_s(self) -> f64 {
        match self {
            Self::Duffing => 1.0 / 610.35,
            Self::Sled => 0.455e-3,
        }
    }

    /// The input of amplitude 1, in the u column's unit.
    pub fn nominal_input(self) -> f64 {
        match self {
            Self::Duffing => 0.15,
            Self::Sled => 1.0,
        }
    }

    /// The measured output for the input `u` (one sample per entry).
    pub fn respond(self, u: &[f64], seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
        match self {
            Self::Duffing => {
                let (w, zeta, yc) = (2.0 * PI * 60.0, 0.05, 0.25);
                let f = |y: f64, v: f64, u: f64| {
                    (
                        v,
                        w * w * (u - y - y * y * y / (yc * yc)) - 2.0 * zeta * w * v,
                    )
                };
                let sub = 8;
                let h = self.ts_s() / sub as f64;
                let (mut y, mut v) = (0.0f64, 0.0f64);
                u.iter()
                    .map(|&uk| {
                        let out = y + 1e-4 * gaussian(&mut rng);
                        for _ in 0..sub {
                            let (k1y, k1v) = f(y, v, uk);
                            let (k2y, k2v) = f(y + 0.5 * h * k1y, v + 0.5 * h * k1v, uk);
                            let (k3y, k3v) = f(y + 0.5 * h * k2y, v + 0.5 * h * k2v, uk);
                            let (k4y, k4v) = f(y + h * k3y, v + h * k3v, uk);
                            y += h / 6.0 * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);
                            v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
                        }
                        out
                    })
                    .collect()
            }
            Self::Sled => {
                let params = PlantParams::default();
                let mut plant = SledPlant::new(&params);
                let q = 1.6e-6;
                u.iter()
                    .map(|&uk| {
                        let out = (plant.position_m() / q).round() * q;
                        plant.advance(uk, self.ts_s());
                        out
                    })
                    .collect()
            }
        }
    }
}

/// Writes `n` samples of `plant` under `excitation` at `amplitude` × nominal to `path` as
/// `t_s,u,y`.
///
/// # Errors
/// I/O errors.
pub fn write_recording(
    path: &Path,
    plant: Plant,
    excitation: Excitation,
    amplitude: f64,
    n: usize,
    seed: u64,
) -> std::io::Result<()> {
    let band = match plant {
        Plant::Duffing => 0.5,
        Plant::Sled => 0.05,
    };
    let u: Vec<f64> = excitation
        .signal(n, band, seed)
        .into_iter()
        .map(|x| x * amplitude * plant.nominal_input())
        .collect();
    let y = plant.respond(&u, seed);
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(w, "t_s,u,y")?;
    for (k, (u, y)) in u.iter().zip(&y).enumerate() {
        writeln!(w, "{},{u},{y}", k as f64 * plant.ts_s())?;
    }
    w.flush()
}
