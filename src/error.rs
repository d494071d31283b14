//! Typed errors: configuration (a `…Design` that cannot be built) and boundary conversions.
//!
//! The per-sample path never returns an error; it reports what it did in [`crate::ident::status::Status`].

use core::fmt;

/// A value from engineering units that cannot enter the fixed-point path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BoundaryError {
    /// NaN or ±∞.
    NotFinite {
        /// What was being converted.
        quantity: &'static str,
    },
    /// Outside the representable range of the format.
    OutOfRange {
        /// What was being converted.
        quantity: &'static str,
        /// The offending value.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
}

impl fmt::Display for BoundaryError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotFinite { quantity } => write!(f, "{quantity}: value is NaN or infinite"),
            Self::OutOfRange {
                quantity,
                value,
                min,
                max,
            } => write!(f, "{quantity}: {value} is outside [{min}, {max})"),
        }
    }
}

impl core::error::Error for BoundaryError {}

#[cfg(feature = "defmt")]
impl defmt::Format for BoundaryError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Self::NotFinite { quantity } => defmt::write!(f, "{=str}: not finite", quantity),
            Self::OutOfRange { quantity, .. } => defmt::write!(f, "{=str}: out of range", quantity),
        }
    }
}

/// A configuration parameter that is out of its valid range; the variant names the parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// Forgetting factor λ outside (0, 1] or not finite.
    Lambda(f64),
    /// Initial covariance p₀ not positive, not finite, or outside the dyadic range.
    InitialCovariance(f64),
    /// Dead zone negative, not finite or outside the signal format.
    DeadZone(f64),
    /// Excitation threshold negative or not finite.
    ExcitationThreshold(f64),
    /// Outlier threshold negative, not finite, outside the signal format, or inside the dead zone.
    OutlierThreshold(f64),
    /// Stuck-sensor check: sample count or minimum drive out of range.
    StuckSensor(f64),
    /// Covariance limit (trace, diagonal or constant trace) not positive or not finite.
    CovarianceLimit(f64),
    /// A Coulomb term on a structure other than ARX (its regressor needs the measured output).
    CoulombTerm,
    /// Time-optimal seek: α not in (0, 1], a velocity pole not in [0, 1), or a braking curve
    /// that is not increasing.
    SeekDesign(f64),
    /// Safety layer: end stops not finite or not ordered, a negative margin or coasting time, a
    /// zero count, more than 7 fallbacks.
    Safety(f64),
    /// Power-on calibration: a drive, ratio, distance, count or limit out of its range
    /// (`crate::servo::calibration::CalibrationDesign::build` names each range).
    Calibration(f64),
    /// Model orders: (na, nb) do not sum to the parameter count, or an order is unsupported.
    ModelOrder {
        /// Output (denominator) order.
        na: usize,
        /// Input (numerator) order.
        nb: usize,
        /// Parameter count of the estimator.
        n: usize,
    },
    /// The estimator's parameter count N does not match the nonlinear structure's.
    ParameterCount {
        /// What the structure needs.
        expected: usize,
        /// The estimator's N.
        n: usize,
    },
    /// Input delay nk outside the supported range.
    Delay(usize),
    /// Stability margin outside [0, 0.5).
    StabilityMargin(f64),
    /// An initial parameter outside the parameter format, or an unstable initial model.
    InitialModel(f64),
    /// Sensor quantum not positive or not finite.
    Quantum(f64),
    /// Sampling period not positive or not finite.
    SamplePeriod(f64),
    /// Full-scale drive not positive or not finite.
    FullScale(f64),
    /// A signal range for the normalisation (its own unit) not positive or not finite.
    SignalRange(f64),
    /// Controller output limit (V) not finite, not > 0, or not below 32,768 full scales.
    OutputLimit(f64),
    /// Proportional gain (V per quantum) not finite or |Kp/u_fs| ≥ 2¹⁵ per quantum.
    Kp(f64),
    /// Integral gain (V per quantum·s) not finite or |Ki·Ts/u_fs| ≥ 2¹⁵ per quantum.
    Ki(f64),
    /// Derivative gain (V·s per quantum) not finite or |Kd/(n·Ts·u_fs)| ≥ 2¹⁵ per quantum.
    Kd(f64),
    /// Integrator limit (V) not finite, negative, or not below 32,768 full scales.
    IntegratorLimit(f64),
    /// Derivative difference length outside 1..=4 samples.
    DerivativeSamples(u8),
    /// Derivative low-pass (Hz) not 0 (off) or in (0, 1/(2·Ts)).
    DerivativeLowPass(f64),
    /// Reference low-pass (Hz) not 0 (off) or in (0, 1/(2·Ts)).
    ReferenceLowPass(f64),
    /// Closed-loop pole (or pole radius) of the scheduled controller outside [0, 1).
    ClosedLoopPole(f64),
    /// Region threshold of the scheduled controller (quanta) negative, not finite, out of the
    /// I16F16 range, or out of order (hold ≤ settle band, enter ≤ leave).
    RegionThreshold(f64),
    /// Supervisor limit (model pole region, gain range, prediction-error limit) not finite or out of
    /// order.
    SupervisorLimit(f64),
    /// Input-map compensation: range not finite / not positive, or the map is not increasing.
    CompensationMap(f64),
    /// Configuration words ([`crate::words`]): word `at` is missing, is not a valid value of its
    /// field, or the value fails the check its `…Design::build` makes; also a buffer too short
    /// to write them into, or words left over after the configuration.
    Words {
        /// Index of the offending word.
        at: usize,
    },
    /// Configuration words of another format (their first word; the words' module names the one
    /// this build reads).
    WordsVersion(u32),
    /// Configuration words whose CRC-32 does not match: corrupted in storage or transfer.
    WordsChecksum,
    /// Servo: the identifier's speed gate (quanta per sample) negative, not finite or out of range.
    IdentifySpeed(f64),
    /// Servo: the redesign hand-over latency L (samples from a request to its adoption) must be ≥ 1.
    HandoverLatency(u16),
    /// Health estimator: the neuron's slope outside (0, 128), or a speed gate or drift threshold
    /// that is negative, not finite or out of format (`crate::servo::health::HealthDesign`).
    Health(f64),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Lambda(v) => write!(f, "lambda = {v}: the forgetting factor must be in (0, 1]"),
            Self::InitialCovariance(v) => {
                write!(f, "p0 = {v}: the initial covariance must be finite and > 0")
            }
            Self::DeadZone(v) => {
                write!(f, "dead_zone = {v}: must be finite, ≥ 0 and < 32768 quanta")
            }
            Self::ExcitationThreshold(v) => {
                write!(f, "excitation_threshold = {v}: must be finite and ≥ 0")
            }
            Self::OutlierThreshold(v) => write!(
                f,
                "outlier_threshold = {v}: must be 0 (off) or finite, above the dead zone and < 32768"
            ),
            Self::StuckSensor(v) => write!(
                f,
                "stuck-sensor check = {v}: the minimum drive must be finite, in (0, 32768), with ≥ 2 samples"
            ),
            Self::CovarianceLimit(v) => {
                write!(f, "covariance limit = {v}: must be finite and > 0")
            }
            Self::ModelOrder { na, nb, n } => write!(
                f,
                "model order na = {na}, nb = {nb}: na + nb (+ 1 with a Coulomb term) must equal the parameter count {n} (na ≥ 1, nb ≥ 1)"
            ),
            Self::Safety(v) => write!(
                f,
                "safety = {v}: end stops finite and ordered with room between the margins, margins and coasting ≥ 0, counts ≥ 1, at most 7 fallbacks"
            ),
            Self::Calibration(v) => write!(
                f,
                "calibration = {v}: drives in (0, 1], ratios above 1, distances and counts ≥ 1, a push within the record, the gain range ordered"
            ),
            Self::SeekDesign(v) => write!(
                f,
                "time-optimal seek = {v}: α must be in (0, 1], the velocity pole in [0, 1), the braking curve increasing"
            ),
            Self::CoulombTerm => write!(
                f,
                "coulomb = true: a Coulomb term needs the ARX structure (its regressor is the measured output's sign)"
            ),
            Self::ParameterCount { expected, n } => write!(
                f,
                "parameter count {n}: this nonlinear structure has {expected} parameters"
            ),
            Self::Delay(v) => write!(f, "nk = {v}: the input delay must be in 0..=8"),
            Self::StabilityMargin(v) => {
                write!(f, "stability_margin = {v}: must be in [0, 0.5)")
            }
            Self::InitialModel(v) => write!(
                f,
                "initial model: parameter {v} is outside ±2048 or the initial model is unstable"
            ),
            Self::Quantum(v) => write!(f, "quantum = {v}: must be finite and > 0"),
            Self::SamplePeriod(v) => {
                write!(f, "ts = {v}: the sampling period must be finite and > 0")
            }
            Self::FullScale(v) => write!(
                f,
                "u_max = {v}: the full-scale drive must be finite and > 0"
            ),
            Self::SignalRange(v) => write!(
                f,
                "signal range = {v}: the normalisation needs a finite range > 0"
            ),
            Self::OutputLimit(v) => write!(
                f,
                "u_limit_v = {v}: must be finite, > 0 and below 32768 full scales"
            ),
            Self::Kp(v) => write!(
                f,
                "kp_v_per_quantum = {v}: must be finite with |kp/u_fs| < 32768"
            ),
            Self::Ki(v) => write!(
                f,
                "ki_v_per_quantum_s = {v}: must be finite with |ki·ts/u_fs| < 32768"
            ),
            Self::Kd(v) => write!(
                f,
                "kd_v_s_per_quantum = {v}: must be finite with |kd/(n·ts·u_fs)| < 32768"
            ),
            Self::IntegratorLimit(v) => write!(
                f,
                "integrator_limit_v = {v}: must be finite, ≥ 0 and below 32768 full scales"
            ),
            Self::DerivativeSamples(v) => write!(f, "derivative_samples = {v}: must be in 1..=4"),
            Self::DerivativeLowPass(v) => write!(
                f,
                "derivative_lowpass_hz = {v}: must be 0 (off) or in (0, 1/(2·ts_s))"
            ),
            Self::ReferenceLowPass(v) => write!(
                f,
                "reference_lowpass_hz = {v}: must be 0 (off) or in (0, 1/(2·ts_s))"
            ),
            Self::ClosedLoopPole(v) => {
                write!(f, "closed-loop pole = {v}: must be finite and in [0, 1)")
            }
            Self::RegionThreshold(v) => write!(
                f,
                "region threshold = {v}: must be finite, ≥ 0, < 32768 quanta and ordered (hold < settle, enter ≤ leave)"
            ),
            Self::SupervisorLimit(v) => write!(
                f,
                "supervisor limit = {v}: must be finite, > 0 and ordered (min < max)"
            ),
            Self::CompensationMap(v) => write!(
                f,
                "compensation map = {v}: the range must be finite and > 0 and the map increasing"
            ),
            Self::Words { at } => write!(
                f,
                "configuration words: word {at} is missing, invalid or fails its check"
            ),
            Self::WordsVersion(v) => write!(
                f,
                "configuration words of format {v:#010x}: not the format this build reads"
            ),
            Self::WordsChecksum => write!(f, "configuration words: the CRC-32 does not match"),
            Self::IdentifySpeed(v) => write!(
                f,
                "identification speed gate = {v} quanta per sample: must be finite, ≥ 0 and below 32,768"
            ),
            Self::Health(v) => write!(
                f,
                "health = {v}: the neuron slope must be in (0, 128) per quantum, the speed gate and drift thresholds finite, ≥ 0 and in format"
            ),
            Self::HandoverLatency(l) => write!(
                f,
                "redesign hand-over latency = {l} samples: must be at least 1"
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

#[cfg(feature = "defmt")]
impl defmt::Format for ConfigError {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "invalid configuration parameter");
    }
}
