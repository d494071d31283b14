//! The sled twin: a deterministic simulator of the paper's CD sled in closed loop, in f64.
//!
//! A [`Twin`] combines the plant ([`plant`]: mass, viscous/Coulomb/static friction, amplifier
//! saturation), the quantized noisy position sensor, the seek reference
//! ([`reference`](mod@reference): low-pass filtered steps with dwells) and any
//! [`SledController`] (the paper's baseline PID is [`PidController`]). Everything random (the
//! seek targets, the sensor noise) comes from a `u64` seed through ChaCha8, so a seed and a
//! [`TwinParams`] reproduce a recording bit for bit. [`bound`] computes, on the same plant, the
//! minimum-time bound of a seek (bang-bang under the same rail), which any controller's access
//! time is judged against.
//!
//! # One sample `k` (`t = k·Ts`)
//! ```text
//! r(k) = filtered reference                      (reference::SeekReference)
//! y(k) = q · round((x(t) + n(k)) / q)            n ~ N(0, noise_m²), round to nearest
//! u(k) = sat(controller(r(k)/q, y(k)/q))         held constant over [t, t + Ts)
//! x(t + Ts) from the exact stick/slip solution   (plant::SledPlant)
//! ```
//! The controller's output acts at once (no computation delay): `y(k)` first affects `u(k)`,
//! which first affects `y(k+1)`, matching the `u(t−1)` regressors of the paper's models.
//! The sensor rounds to the nearest track, so an error of 0 counts means the sled is within
//! half a track of the reference.
//!
//! # Recording
//! [`Twin::write_csv`] writes `t_s,r_m,u_v,y_m` and a JSON sidecar ([`TwinSidecar`]) with every
//! parameter, the seed and the seek schedule; the true position is kept in memory
//! ([`TwinSample::x_m`]) for tests.

pub mod analysis;
pub mod baseline;
pub mod bound;
pub mod params;
pub mod plant;
pub mod reference;

pub use analysis::{LimitCycleStats, SeekStats};
pub use baseline::{PidController, SledController};
pub use bound::{SeekBound, min_time_seek};
pub use params::{
    PidParams, PlantParams, ReferenceParams, ReferenceProfile, SeekDistribution, TwinParams,
};
pub use plant::SledPlant;
pub use reference::{Seek, SeekReference};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};

/// The CSV columns of a recording, in order.
pub const CSV_COLUMNS: [&str; 4] = ["t_s", "r_m", "u_v", "y_m"];

/// ChaCha stream of the seek targets (the noise uses [`NOISE_STREAM`]): changing the noise
/// level does not change the seeks.
const SEEK_STREAM: u64 = 0;
/// ChaCha stream of the sensor noise.
const NOISE_STREAM: u64 = 1;

/// Errors of the twin: bad parameters, files, JSON, CSV.
#[derive(Debug)]
pub enum TwinError {
    /// A parameter is out of its range; `name` is its JSON path (e.g. `plant.static_n`).
    InvalidParameter {
        /// JSON path of the parameter.
        name: &'static str,
        /// The rejected value (a count for list parameters).
        value: f64,
        /// What the value must satisfy.
        requirement: &'static str,
    },
    /// Reading or writing a file failed.
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// JSON could not be parsed (including unknown keys) or written.
    Json(serde_json::Error),
    /// The CSV recording could not be written.
    Csv(csv::Error),
}

impl fmt::Display for TwinError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidParameter {
                name,
                value,
                requirement,
            } => write!(
                f,
                "invalid parameter {name} = {value}: must be {requirement}"
            ),
            Self::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Self::Json(source) => write!(f, "twin parameters JSON: {source}"),
            Self::Csv(source) => write!(f, "twin recording CSV: {source}"),
        }
    }
}

impl std::error::Error for TwinError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::InvalidParameter { .. } => None,
            Self::Io { source, .. } => Some(source),
            Self::Json(source) => Some(source),
            Self::Csv(source) => Some(source),
        }
    }
}

/// One recorded sample of the closed loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwinSample {
    /// Sample time `k·Ts`, s.
    pub t_s: f64,
    /// Filtered reference, m.
    pub r_m: f64,
    /// Applied (saturated) drive voltage held over `[t_s, t_s + Ts)`, V.
    pub u_v: f64,
    /// Quantized measurement, m (`y_counts · quantum_m`).
    pub y_m: f64,
    /// Quantized measurement, counts (tracks).
    pub y_counts: i64,
    /// True sled position at `t_s`, m (not in the CSV).
    pub x_m: f64,
    /// Target of the seek in progress, counts.
    pub target_counts: i64,
}

/// The JSON sidecar written next to a CSV recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinSidecar {
    /// The CSV columns, in order.
    pub columns: Vec<String>,
    /// Number of samples (CSV rows after the header).
    pub samples: usize,
    /// The seed of the seek targets and the sensor noise.
    pub seed: u64,
    /// How the sensor quantizes: always `"round_to_nearest"`.
    pub quantization: String,
    /// Which controller closed the loop (see [`Twin::set_controller_label`]).
    pub controller: String,
    /// Every parameter.
    pub params: TwinParams,
    /// The seek schedule with its sample indices.
    pub seeks: Vec<Seek>,
}

/// Deterministic Gaussian noise (Box–Muller over ChaCha8 uniforms).
#[derive(Clone, Debug)]
struct GaussianNoise {
    /// The uniform source.
    rng: ChaCha8Rng,
    /// The second Box–Muller value, not yet used.
    spare: Option<f64>,
}

impl GaussianNoise {
    /// A standard normal value.
    fn next_standard(&mut self) -> f64 {
        if let Some(spare) = self.spare.take() {
            return spare;
        }
        let u1 = 1.0 - self.rng.r#gen::<f64>(); // (0, 1]: ln is finite
        let u2: f64 = self.rng.r#gen();
        let radius = (-2.0 * u1.ln()).sqrt();
        let angle = 2.0 * std::f64::consts::PI * u2;
        self.spare = Some(radius * angle.sin());
        radius * angle.cos()
    }
}

/// The closed-loop sled simulator; see the module documentation.
#[derive(Clone, Debug)]
pub struct Twin {
    /// The validated parameters.
    params: TwinParams,
    /// The seed.
    seed: u64,
    /// Label of the controller in the loop, for the sidecar.
    controller_label: String,
    /// The sled.
    plant: SledPlant,
    /// The seek reference.
    reference: SeekReference,
    /// Sensor noise source.
    noise: GaussianNoise,
    /// Everything recorded so far.
    samples: Vec<TwinSample>,
}

impl Twin {
    /// A twin at rest at position 0, with its seek targets drawn from `seed`.
    pub fn new(params: TwinParams, seed: u64) -> Result<Self, TwinError> {
        params.validate()?;
        let mut seek_rng = ChaCha8Rng::seed_from_u64(seed);
        seek_rng.set_stream(SEEK_STREAM);
        let targets = reference::draw_targets(&params.reference, &mut seek_rng);
        let mut noise_rng = ChaCha8Rng::seed_from_u64(seed);
        noise_rng.set_stream(NOISE_STREAM);
        Ok(Self {
            plant: SledPlant::new(&params.plant),
            reference: SeekReference::new(&params.reference, params.plant.ts_s, targets),
            noise: GaussianNoise {
                rng: noise_rng,
                spare: None,
            },
            controller_label: String::from("unspecified"),
            samples: Vec::new(),
            params,
            seed,
        })
    }

    /// Runs the whole seek schedule with the baseline [`PidController`] of `params`.
    pub fn run_baseline(params: TwinParams, seed: u64) -> Result<Self, TwinError> {
        let mut twin = Self::new(params, seed)?;
        let mut controller = twin.baseline_controller();
        twin.set_controller_label("baseline_pid");
        twin.run(&mut controller);
        Ok(twin)
    }

    /// The baseline controller configured from this twin's parameters, in its initial state.
    pub fn baseline_controller(&self) -> PidController {
        PidController::new(
            &self.params.controller,
            self.params.plant.ts_s,
            self.params.plant.u_max_v,
        )
    }

    /// Names the controller in the loop in the sidecar (default `"unspecified"`).
    pub fn set_controller_label(&mut self, label: &str) {
        self.controller_label = label.to_owned();
    }

    /// Simulates one sample with `controller` in the loop and records it; `None` (and nothing
    /// recorded) once every seek has ended.
    pub fn step<C: SledController + ?Sized>(&mut self, controller: &mut C) -> Option<TwinSample> {
        let index = self.samples.len();
        let target_counts = self.reference.current_target_counts()?;
        let r_counts = self.reference.next_counts(index)?;
        let quantum_m = self.params.plant.quantum_m;
        let x_m = self.plant.position_m();
        let noise_m = if self.params.plant.noise_m > 0.0 {
            self.params.plant.noise_m * self.noise.next_standard()
        } else {
            0.0
        };
        let y_counts = ((x_m + noise_m) / quantum_m).round() as i64;
        let command_v = controller.step(r_counts, y_counts as f64);
        let u_v = self.plant.advance(command_v, self.params.plant.ts_s);
        let sample = TwinSample {
            t_s: index as f64 * self.params.plant.ts_s,
            r_m: r_counts * quantum_m,
            u_v,
            y_m: y_counts as f64 * quantum_m,
            y_counts,
            x_m,
            target_counts,
        };
        self.samples.push(sample);
        Some(sample)
    }

    /// Runs `controller` on the plant before the seek schedule (power-on calibration), fed its own
    /// reading as the reference, until `done(controller)` or `max` samples: nothing is recorded
    /// and the schedule does not advance; the sensor noise stream does. Returns the samples run.
    pub fn pre_roll<C: SledController>(
        &mut self,
        controller: &mut C,
        mut done: impl FnMut(&C) -> bool,
        max: usize,
    ) -> usize {
        let quantum_m = self.params.plant.quantum_m;
        for k in 0..max {
            if done(controller) {
                return k;
            }
            let noise_m = if self.params.plant.noise_m > 0.0 {
                self.params.plant.noise_m * self.noise.next_standard()
            } else {
                0.0
            };
            let y = ((self.plant.position_m() + noise_m) / quantum_m).round();
            let command_v = controller.step(y, y);
            self.plant.advance(command_v, self.params.plant.ts_s);
        }
        max
    }

    /// Runs until every seek has ended; returns the number of samples simulated.
    pub fn run<C: SledController + ?Sized>(&mut self, controller: &mut C) -> usize {
        let before = self.samples.len();
        while self.step(controller).is_some() {}
        self.samples.len() - before
    }

    /// Whether every seek has ended.
    pub fn is_finished(&self) -> bool {
        self.reference.is_finished()
    }

    /// The recorded samples.
    pub fn samples(&self) -> &[TwinSample] {
        &self.samples
    }

    /// The seeks begun so far, with their sample indices.
    pub fn seeks(&self) -> &[Seek] {
        self.reference.seeks()
    }

    /// The parameters.
    pub fn params(&self) -> &TwinParams {
        &self.params
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The plant, mutable: plant changes (mass, friction) and actuator faults mid-run.
    pub fn plant_mut(&mut self) -> &mut SledPlant {
        &mut self.plant
    }

    /// The plant (true position and velocity now).
    pub fn plant(&self) -> &SledPlant {
        &self.plant
    }

    /// The sidecar describing the recording so far.
    pub fn sidecar(&self) -> TwinSidecar {
        TwinSidecar {
            columns: CSV_COLUMNS.iter().map(|&c| c.to_owned()).collect(),
            samples: self.samples.len(),
            seed: self.seed,
            quantization: String::from("round_to_nearest"),
            controller: self.controller_label.clone(),
            params: self.params.clone(),
            seeks: self.seeks().to_vec(),
        }
    }

    /// Writes the recording as CSV (`t_s,r_m,u_v,y_m`) to `path` and the sidecar to
    /// `path.with_extension("json")`.
    pub fn write_csv(&self, path: impl AsRef<Path>) -> Result<(), TwinError> {
        let path = path.as_ref();
        let io_error = |source| TwinError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut writer = csv::Writer::from_path(path).map_err(TwinError::Csv)?;
        writer.write_record(CSV_COLUMNS).map_err(TwinError::Csv)?;
        for sample in &self.samples {
            writer
                .serialize((sample.t_s, sample.r_m, sample.u_v, sample.y_m))
                .map_err(TwinError::Csv)?;
        }
        writer.flush().map_err(io_error)?;
        let sidecar_path = path.with_extension("json");
        let json = serde_json::to_string_pretty(&self.sidecar()).map_err(TwinError::Json)?;
        std::fs::write(&sidecar_path, json + "\n").map_err(|source| TwinError::Io {
            path: sidecar_path,
            source,
        })
    }

    /// Settling and limit-cycle statistics of every ended seek (see [`analysis`]).
    pub fn seek_stats(&self) -> Vec<SeekStats> {
        analysis::seek_stats(self)
    }

    /// The same, with the samples the controller marked as fine steps (`fine_step[k]`) counted
    /// apart from the limit-cycle pulses ([`analysis`], "Pulses and fine steps").
    pub fn seek_stats_marked(&self, fine_step: &[bool]) -> Vec<SeekStats> {
        analysis::seek_stats_marked(self, fine_step)
    }
}
