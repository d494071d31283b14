//! Twin parameters: the sled plant, the seek reference and the baseline controller, in physical
//! units, loaded from JSON and validated.
//!
//! # JSON layout
//! Three objects, each with its own keys; every key carries its unit in its name, missing keys
//! take the defaults below, and an unknown key is an error:
//! ```json
//! { "plant":      { "mass_kg": 0.05, "force_per_volt_n_per_v": 2.0, "...": "..." },
//!   "reference":  { "ref_rise_s": 0.03, "seek_count": 6, "...": "..." },
//!   "controller": { "kp_v_per_count": 0.01, "...": "..." } }
//! ```
//!
//! # Why the defaults are plausible for a CD sled
//! The sled is modelled as a 50 g optics housing on two guide rods, driven by a voltage-fed
//! linear motor. A voltage-driven motor is, at the sled, a force source `F = (Bl/R)·u` with a
//! back-EMF damping `b = (Bl)²/R`; with `Bl = 10 N/A` and `R = 5 Ω`:
//!
//! | quantity | default | reasoning |
//! |---|---|---|
//! | `mass_kg` | 0.05 | optics housing, lens actuator and motor coil |
//! | `force_per_volt_n_per_v` | 2 | `Bl/R`: 10 N at the 5 V rail, 200 m/s² on 50 g |
//! | `viscous_n_s_per_m` | 20 | back-EMF `(Bl)²/R`: no-load speed 0.5 m/s at 5 V (`1/Bl` = 0.1 m/s per V), mechanical time constant `m/b` = 2.5 ms ≈ 5.5 samples |
//! | `coulomb_n` | 0.075 | guide-rod friction, μ ≈ 0.15 times the sled's weight (0.49 N): 37.5 mV keeps the sled sliding |
//! | `static_n` | 0.125 | μ ≈ 0.25: 62.5 mV breaks the sled loose |
//! | `u_max_v` | 5 | the drive amplifier's rail |
//! | `quantum_m` | 1.6e-6 | one track pitch: the position is counted in tracks |
//! | `ts_s` | 0.455e-3 | the paper's sampling interval |
//! | `noise_m` | 0.05e-6 | ≈ 3 % of a track: changes `y` only where the sled is within ~0.15 µm of a track boundary |
//!
//! Friction is 1–2 % of the drive's force range, but at the scale of one track it dominates:
//! moving the sled by one track needs about as much voltage for friction as for motion.
//!
//! The reference rises over 30 ms: a 2,000-track (3.2 mm) seek peaks at 0.21 m/s and 22 m/s²,
//! about 2.7 V, within the rail.
//!
//! # Why the controller defaults are the paper's badly tuned loop
//! The twin exists to produce the paper's data: closed-loop steps whose output follows the
//! reference, oscillates around it for ~100 samples while settling (the paper's identification
//! range, its Fig. 4–5) and ends in a controller-induced ±1-quantum limit cycle. The default PID
//! ([`PidParams::default`]) does that on the default sled:
//!
//! | key | default | reasoning |
//! |---|---|---|
//! | `kp_v_per_count` | 0.01 | 10 mV per track, far below the 62.5 mV breakaway: near the target the integrator does the moving |
//! | `kd_v_s_per_count` | 4e-5 | 50 N·s/m of electronic damping over the 20 of the back-EMF: the seek is well damped and the output follows the reference (median delay 3 samples) |
//! | `d_filter_hz` | 300 | the lead's pole: a quieter derivative on quantized feedback |
//! | `ki_v_per_count_s` | 8 | the badly tuned part: integral time `Kp/Ki` = 1.25 ms ≈ 2.7 samples. The integral winds to its clamp through a long seek and unwinds too slowly, so the sled overshoots by ~10 tracks and swings back and forth |
//! | `integrator_limit_v` | 0.3 | a loose anti-windup clamp, 4.8× the breakaway voltage |
//!
//! Measured (`tests/integration/paper_sled_control.rs`, 100 seeks, seed 1): |e| ≤ 1 for good a median of
//! 89 samples after the reference arrives, through a median of 4 alternating excursions beyond
//! ±1; ±1-quantum hunting with a period of ~77 samples (35 ms) in 98 of 100 dwells; over 1,200
//! seeks 70 end at rest in the zero cell (`tests/integration/twin.rs`). `host-tests/plants/README.md` has the full account and how the
//! gains were chosen; `host-tests/plants/paper_sled.json` writes these defaults out.
//!
//! [`PidParams::well_damped`] is the earlier default, a well-damped PD loop of about 90 Hz with
//! a fast integrator (91 mV per sample at one track of error) clamped at 70 mV: it rings down
//! within 0–7 samples of the reference's arrival and hunts ±1 quantum with a period of ~12
//! samples. It is kept (`host-tests/plants/well_damped.json`) for the tests and tables measured
//! on it: the fault, windup and soak figures of RELIABILITY.md, and the case where a controller
//! cannot settle 30 % faster than the baseline because the reference itself is slower.

use serde::{Deserialize, Serialize};
use std::path::Path;

use super::TwinError;

/// Everything the twin needs besides the seed: plant, reference and baseline controller.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TwinParams {
    /// The sled, its drive and its position sensor.
    pub plant: PlantParams,
    /// The sequence of low-pass filtered seek steps.
    pub reference: ReferenceParams,
    /// The baseline PID controller.
    pub controller: PidParams,
}

/// The sled, its drive amplifier and its quantized position sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantParams {
    /// Moving mass seen at the sled (optics housing plus reflected motor inertia), kg.
    pub mass_kg: f64,
    /// Force on the sled per volt of drive, N/V.
    pub force_per_volt_n_per_v: f64,
    /// Viscous friction (mostly motor back-EMF), N per m/s.
    pub viscous_n_s_per_m: f64,
    /// Coulomb (sliding) friction, N; opposes the motion while the sled moves.
    pub coulomb_n: f64,
    /// Static (breakaway) friction, N; a resting sled stays stuck while |drive force| ≤ this.
    pub static_n: f64,
    /// Drive amplifier saturation: the applied voltage is clamped to ±`u_max_v`, V.
    pub u_max_v: f64,
    /// Position sensor step (one track), m; the measurement is rounded to the nearest multiple.
    pub quantum_m: f64,
    /// Sampling interval (zero-order hold on the drive voltage), s.
    pub ts_s: f64,
    /// Standard deviation of Gaussian sensor noise added before quantization, m (0: none).
    pub noise_m: f64,
}

impl Default for PlantParams {
    fn default() -> Self {
        Self {
            mass_kg: 0.05,
            force_per_volt_n_per_v: 2.0,
            viscous_n_s_per_m: 20.0,
            coulomb_n: 0.075,
            static_n: 0.125,
            u_max_v: 5.0,
            quantum_m: 1.6e-6,
            ts_s: 0.455e-3,
            noise_m: 0.05e-6,
        }
    }
}

/// The reference: a sequence of seeks, each a low-pass filtered step followed by a dwell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceParams {
    /// Length of the Hann-window FIR low-pass that turns each target step into the reference:
    /// the time the filtered step takes to rise to the target, s.
    pub ref_rise_s: f64,
    /// Number of random seeks (ignored when `targets_tracks` is given).
    pub seek_count: u32,
    /// Smallest random seek length, tracks.
    pub seek_min_tracks: u32,
    /// Largest random seek length, tracks.
    pub seek_max_tracks: u32,
    /// Random targets stay within ±`travel_tracks` of the start (track 0); a step that would
    /// leave this range is taken in the other direction.
    pub travel_tracks: u32,
    /// Explicit seek targets (absolute, tracks from the start, within ±`travel_tracks`); when
    /// present they replace the random seeks.
    pub targets_tracks: Option<Vec<i64>>,
    /// Time held at each target after the filtered reference has arrived, s.
    pub dwell_s: f64,
    /// How random seek lengths are drawn from `seek_min_tracks..=seek_max_tracks` (default
    /// uniform; written to JSON only when not the default).
    #[serde(skip_serializing_if = "SeekDistribution::is_uniform")]
    pub seek_distribution: SeekDistribution,
    /// The shape of each seek's reference (default the S-curve of `ref_rise_s`; written to JSON
    /// only when not the default).
    #[serde(skip_serializing_if = "ReferenceProfile::is_s_curve")]
    pub profile: ReferenceProfile,
}

/// How the random seek lengths are drawn between `seek_min_tracks` and `seek_max_tracks`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SeekDistribution {
    /// Every whole length equally likely.
    #[default]
    Uniform,
    /// Log-uniform: `length = round(exp(ln min + w·(ln max − ln min)))`, `w` uniform in [0, 1)
    /// (as many seeks of 20–200 tracks as of 200–2,000): a drive's seek-time-versus-distance
    /// curve is read on a log scale.
    LogUniform,
}

impl SeekDistribution {
    /// Whether this is the default, [`Self::Uniform`].
    pub fn is_uniform(&self) -> bool {
        *self == Self::Uniform
    }
}

/// The shape of the reference from the previous target to the next.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceProfile {
    /// The paper's low-pass filtered step: the cycloidal S-curve rising over `ref_rise_s`.
    #[default]
    SCurve,
    /// The step itself, `r = target` from the seek's first sample on (`ref_rise_s` ignored): a
    /// seek command ("go to track N") for a controller that plans its own trajectory. The seek
    /// has arrived at its first sample, and dwells `dwell_s` from there.
    Step,
}

impl ReferenceProfile {
    /// Whether this is the default, [`Self::SCurve`].
    pub fn is_s_curve(&self) -> bool {
        *self == Self::SCurve
    }
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            ref_rise_s: 0.03,
            seek_count: 6,
            seek_min_tracks: 20,
            seek_max_tracks: 2000,
            travel_tracks: 10_000,
            targets_tracks: None,
            dwell_s: 0.3,
            seek_distribution: SeekDistribution::Uniform,
            profile: ReferenceProfile::SCurve,
        }
    }
}

/// The baseline PID controller acting on the error `r − y` in counts (quanta).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PidParams {
    /// Proportional gain, V per count of error.
    pub kp_v_per_count: f64,
    /// Integral gain, V per count-second of error.
    pub ki_v_per_count_s: f64,
    /// Derivative gain, V per count/s of error rate.
    pub kd_v_s_per_count: f64,
    /// Corner frequency of the first-order low-pass on the derivative term (the lead's pole), Hz.
    pub d_filter_hz: f64,
    /// The integral term is clamped to ±this (anti-windup), V.
    pub integrator_limit_v: f64,
}

impl Default for PidParams {
    fn default() -> Self {
        Self {
            kp_v_per_count: 0.01,
            ki_v_per_count_s: 8.0,
            kd_v_s_per_count: 4.0e-5,
            d_filter_hz: 300.0,
            integrator_limit_v: 0.3,
        }
    }
}

impl PidParams {
    /// The earlier, well-damped baseline (`host-tests/plants/well_damped.json`): a PD loop of about
    /// 90 Hz with an integrator of 91 mV per sample at one track of error clamped at 70 mV, just
    /// above breakaway. It rings down within 0–7 samples and hunts ±1 quantum with a period of
    /// about 12 samples; see the module documentation.
    pub fn well_damped() -> Self {
        Self {
            kp_v_per_count: 0.015,
            ki_v_per_count_s: 200.0,
            kd_v_s_per_count: 1.0e-5,
            d_filter_hz: 1000.0,
            integrator_limit_v: 0.07,
        }
    }
}

impl TwinParams {
    /// The default sled and reference under the well-damped baseline ([`PidParams::well_damped`]).
    pub fn well_damped() -> Self {
        Self {
            controller: PidParams::well_damped(),
            ..Self::default()
        }
    }

    /// Reads parameters from a JSON file (missing keys take their defaults) and validates them.
    pub fn from_json_file(path: impl AsRef<Path>) -> Result<Self, TwinError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| TwinError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_json_str(&text)
    }

    /// Parses parameters from JSON text (missing keys take their defaults) and validates them.
    pub fn from_json_str(text: &str) -> Result<Self, TwinError> {
        let params: Self = serde_json::from_str(text).map_err(TwinError::Json)?;
        params.validate()?;
        Ok(params)
    }

    /// The parameters as pretty-printed JSON.
    pub fn to_json_string(&self) -> Result<String, TwinError> {
        serde_json::to_string_pretty(self).map_err(TwinError::Json)
    }

    /// Checks every parameter; the error names the first offending one.
    pub fn validate(&self) -> Result<(), TwinError> {
        self.plant.validate()?;
        self.reference.validate()?;
        self.controller.validate(self.plant.ts_s)
    }
}

/// Requirement on a parameter value, used by the `check_*` helpers.
fn check(
    name: &'static str,
    value: f64,
    ok: bool,
    requirement: &'static str,
) -> Result<(), TwinError> {
    if value.is_finite() && ok {
        Ok(())
    } else {
        Err(TwinError::InvalidParameter {
            name,
            value,
            requirement,
        })
    }
}

/// `value` must be finite and > 0.
fn check_positive(name: &'static str, value: f64) -> Result<(), TwinError> {
    check(name, value, value > 0.0, "finite and > 0")
}

/// `value` must be finite and ≥ 0.
fn check_non_negative(name: &'static str, value: f64) -> Result<(), TwinError> {
    check(name, value, value >= 0.0, "finite and >= 0")
}

impl PlantParams {
    /// Checks the plant parameters; the error names the first offending one.
    pub fn validate(&self) -> Result<(), TwinError> {
        check_positive("plant.mass_kg", self.mass_kg)?;
        check_positive("plant.force_per_volt_n_per_v", self.force_per_volt_n_per_v)?;
        check_non_negative("plant.viscous_n_s_per_m", self.viscous_n_s_per_m)?;
        check_non_negative("plant.coulomb_n", self.coulomb_n)?;
        check(
            "plant.static_n",
            self.static_n,
            self.static_n >= self.coulomb_n,
            "finite and >= plant.coulomb_n",
        )?;
        check_positive("plant.u_max_v", self.u_max_v)?;
        check_positive("plant.quantum_m", self.quantum_m)?;
        check_positive("plant.ts_s", self.ts_s)?;
        check_non_negative("plant.noise_m", self.noise_m)
    }
}

impl ReferenceParams {
    /// Checks the reference parameters; the error names the first offending one.
    pub fn validate(&self) -> Result<(), TwinError> {
        check_positive("reference.ref_rise_s", self.ref_rise_s)?;
        check_positive("reference.dwell_s", self.dwell_s)?;
        match &self.targets_tracks {
            Some(targets) => {
                check(
                    "reference.targets_tracks",
                    targets.len() as f64,
                    !targets.is_empty(),
                    "at least one target",
                )?;
                let travel = i64::from(self.travel_tracks);
                match targets
                    .iter()
                    .find(|target| target.unsigned_abs() > travel.unsigned_abs())
                {
                    Some(&outside) => check(
                        "reference.targets_tracks",
                        outside as f64,
                        false,
                        "targets within ±reference.travel_tracks",
                    ),
                    None => Ok(()),
                }
            }
            None => {
                check(
                    "reference.seek_count",
                    f64::from(self.seek_count),
                    self.seek_count >= 1,
                    ">= 1",
                )?;
                check(
                    "reference.seek_min_tracks",
                    f64::from(self.seek_min_tracks),
                    self.seek_min_tracks >= 1,
                    ">= 1",
                )?;
                check(
                    "reference.seek_max_tracks",
                    f64::from(self.seek_max_tracks),
                    self.seek_max_tracks >= self.seek_min_tracks,
                    ">= reference.seek_min_tracks",
                )?;
                check(
                    "reference.travel_tracks",
                    f64::from(self.travel_tracks),
                    self.travel_tracks >= self.seek_max_tracks,
                    ">= reference.seek_max_tracks",
                )
            }
        }
    }
}

impl PidParams {
    /// Checks the controller parameters (the derivative filter must lie below the Nyquist
    /// frequency of `ts_s`); the error names the first offending one.
    pub fn validate(&self, ts_s: f64) -> Result<(), TwinError> {
        check_non_negative("controller.kp_v_per_count", self.kp_v_per_count)?;
        check_non_negative("controller.ki_v_per_count_s", self.ki_v_per_count_s)?;
        check_non_negative("controller.kd_v_s_per_count", self.kd_v_s_per_count)?;
        check(
            "controller.d_filter_hz",
            self.d_filter_hz,
            self.d_filter_hz > 0.0 && self.d_filter_hz * ts_s < 0.5,
            "finite, > 0 and below the Nyquist frequency 1/(2·plant.ts_s)",
        )?;
        check_non_negative("controller.integrator_limit_v", self.integrator_limit_v)
    }
}
