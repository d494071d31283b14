//! The boundary between engineering units and the fixed-point path: positions in metres become
//! [`PositionI48F16`] sensor quanta, the drive in volts becomes a fraction of full scale in
//! [`SignalI16F16`]. NaN, ±∞ and out-of-range values are rejected here with a [`BoundaryError`].

use crate::error::{BoundaryError, ConfigError};
use crate::num::fixed::SignalI16F16;

/// An absolute position in sensor quanta, I48F16 in an `i64`: `value = raw / 2^16`, range ±1.4·10¹⁴
/// quanta (±2.2·10⁸ m at 1.6 µm per track), step 2⁻¹⁶ quanta. Encoder counts convert exactly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PositionI48F16(i64);

impl PositionI48F16 {
    /// From the raw integer (quanta × 2¹⁶).
    pub const fn from_raw(raw: i64) -> Self {
        Self(raw)
    }

    /// The raw integer (quanta × 2¹⁶).
    pub const fn raw(self) -> i64 {
        self.0
    }

    /// From whole sensor counts (exact, saturating).
    pub const fn from_counts(counts: i64) -> Self {
        Self(counts.saturating_mul(1 << 16))
    }

    /// `self − rhs` narrowed to a signal (I16F16), saturating; the flag is set when it saturated.
    pub const fn offset_from(self, rhs: Self, saturated: &mut bool) -> SignalI16F16 {
        SignalI16F16::from_raw(crate::num::fixed::sat_i32(
            self.0.saturating_sub(rhs.0),
            saturated,
        ))
    }

    /// To quanta as `f64`.
    pub fn to_f64(self) -> f64 {
        self.0 as f64 / 65_536.0
    }
}

/// One raw sample in the fixed-point domain: the input of the per-sample step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Measured position y, quanta.
    pub y: PositionI48F16,
    /// Drive u, fraction of full scale.
    pub u: SignalI16F16,
    /// Reference r, quanta.
    pub r: PositionI48F16,
}

/// The conversion from engineering units: sensor quantum (m) and full-scale drive (V).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    quantum_m: f64,
    u_full_scale_v: f64,
}

impl Scaling {
    /// A scaling with the sensor quantum in metres and the full-scale drive in volts.
    ///
    /// # Errors
    /// [`ConfigError::Quantum`] / [`ConfigError::FullScale`] for non-finite or non-positive values.
    pub fn new(quantum_m: f64, u_full_scale_v: f64) -> Result<Self, ConfigError> {
        if !(quantum_m.is_finite() && quantum_m > 0.0) {
            return Err(ConfigError::Quantum(quantum_m));
        }
        if !(u_full_scale_v.is_finite() && u_full_scale_v > 0.0) {
            return Err(ConfigError::FullScale(u_full_scale_v));
        }
        Ok(Self {
            quantum_m,
            u_full_scale_v,
        })
    }

    /// The sensor quantum, m.
    pub fn quantum_m(&self) -> f64 {
        self.quantum_m
    }

    /// The full-scale drive, V.
    pub fn u_full_scale_v(&self) -> f64 {
        self.u_full_scale_v
    }

    /// Converts a position in metres to quanta.
    ///
    /// # Errors
    /// [`BoundaryError`] for NaN/±∞ or a value beyond ±2⁴⁷ quanta.
    pub fn position(&self, pos_m: f64) -> Result<PositionI48F16, BoundaryError> {
        const QUANTITY: &str = "position (I48F16 quanta)";
        if !pos_m.is_finite() {
            return Err(BoundaryError::NotFinite { quantity: QUANTITY });
        }
        let raw = pos_m / self.quantum_m * 65_536.0;
        let lim = (1u64 << 62) as f64;
        if !(-lim..lim).contains(&raw) {
            return Err(BoundaryError::OutOfRange {
                quantity: QUANTITY,
                value: pos_m,
                min: -lim / 65_536.0 * self.quantum_m,
                max: lim / 65_536.0 * self.quantum_m,
            });
        }
        let r = if raw >= 0.0 { raw + 0.5 } else { raw - 0.5 };
        Ok(PositionI48F16(r as i64))
    }

    /// Converts a drive in volts to a fraction of full scale.
    ///
    /// # Errors
    /// [`BoundaryError`] for NaN/±∞ or |u| ≥ 32768 × full scale.
    pub fn drive(&self, u_v: f64) -> Result<SignalI16F16, BoundaryError> {
        SignalI16F16::from_f64(u_v / self.u_full_scale_v).map_err(|e| match e {
            BoundaryError::OutOfRange { quantity, .. } => BoundaryError::OutOfRange {
                quantity,
                value: u_v,
                min: -32_768.0 * self.u_full_scale_v,
                max: 32_768.0 * self.u_full_scale_v,
            },
            other => other,
        })
    }

    /// Converts one sample (y and r in metres, u in volts).
    ///
    /// # Errors
    /// The first [`BoundaryError`] among y, u, r.
    pub fn sample(&self, y_m: f64, u_v: f64, r_m: f64) -> Result<Sample, BoundaryError> {
        Ok(Sample {
            y: self.position(y_m)?,
            u: self.drive(u_v)?,
            r: self.position(r_m)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn converts_and_rejects() {
        let s = Scaling::new(5e-8, 10.0).unwrap();
        let smp = s.sample(0.2, -2.5, 0.2000001).unwrap();
        assert_eq!(smp.y.raw(), 4_000_000 << 16);
        assert_eq!(smp.u.to_f64(), -0.25);
        let mut sat = false;
        assert_eq!(smp.y.offset_from(smp.r, &mut sat).to_f64(), -2.0);
        assert!(!sat);
        assert!(s.sample(f64::NAN, 0.0, 0.0).is_err());
        assert!(s.sample(0.0, f64::INFINITY, 0.0).is_err());
        assert!(s.sample(0.0, 1e9, 0.0).is_err());
        assert!(s.position(1e30).is_err());
        assert_eq!(Scaling::new(0.0, 1.0), Err(ConfigError::Quantum(0.0)));
        assert_eq!(Scaling::new(1.0, -1.0), Err(ConfigError::FullScale(-1.0)));
        // Far apart positions saturate the signal, and say so.
        let _ =
            PositionI48F16::from_counts(1 << 20).offset_from(PositionI48F16::default(), &mut sat);
        assert!(sat);
    }
}
