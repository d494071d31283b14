//! The RLS configuration as configuration words ([`crate::words`]): the quantised settings the
//! host built, so a target decodes them without `f64` arithmetic (no [`super::RlsDesign::build`]
//! on target), and [`RlsConfig::validate`] — the invariants `build` establishes, checked again on
//! the decoded values.
//!
//! | field | words |
//! |---|---|
//! | λ, p₀ ([`Dyadic`]: mantissa, exponent) | 2 each |
//! | the largest stored exponent of D (`i32`) | 1 |
//! | the dead zone, I16F16 raw quanta (`u32`) | 1 |
//! | the excitation minimum ([`Dyadic`]) | 2 |
//! | the covariance bound: 0 none, 1 trace, 2 diagonal, 3 constant trace, then its [`Dyadic`] | 1 or 3 |
//! | the outlier gate, I16F16 raw quanta (`u32`), and its run limit (`u16`) | 2 |
//!
//! 1/λ is not carried: `take` computes it from λ as `build` does.

use super::{Bound, RlsConfig};
use crate::error::ConfigError;
use crate::num::dyadic::{Dyadic, EXP_MAX, EXP_MIN};
use crate::words::{WordReader, WordWriter, Words};

/// Positive and below saturation: what `build`'s `positive_dyadic` accepts.
fn positive(d: Dyadic) -> bool {
    !d.is_zero() && !d.is_saturated()
}

impl RlsConfig {
    /// The invariants [`super::RlsDesign::build`] establishes: 0 < λ ≤ 1 and 1/λ its
    /// reciprocal, p₀ positive, the dead zone and the outlier gate within the I16F16 range and
    /// the gate 0 (off) or above the dead zone, the excitation minimum not saturated, a bound's
    /// limit positive, D's exponent cap within the format's exponents (one below the smallest
    /// for a factor cap at the smallest value).
    ///
    /// # Errors
    /// The [`ConfigError`] naming the first setting out of range (its value `NaN`: the design's
    /// `f64` is not on target).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let nan = f64::NAN;
        if !positive(self.lambda) || Dyadic::ONE.lt(self.lambda) {
            return Err(ConfigError::Lambda(nan));
        }
        if self.lambda_inv != self.lambda.recip() {
            return Err(ConfigError::Lambda(nan));
        }
        if !positive(self.p0) {
            return Err(ConfigError::InitialCovariance(nan));
        }
        if self.dead_zone_i16f16 > i32::MAX as u32 {
            return Err(ConfigError::DeadZone(nan));
        }
        if self.outlier_i16f16 > i32::MAX as u32
            || (self.outlier_i16f16 != 0 && self.outlier_i16f16 <= self.dead_zone_i16f16)
        {
            return Err(ConfigError::OutlierThreshold(nan));
        }
        if self.excitation_min.is_saturated() {
            return Err(ConfigError::ExcitationThreshold(nan));
        }
        let limit_ok = match self.bound {
            Bound::None => true,
            Bound::Trace(d) | Bound::Diagonal(d) | Bound::ConstantTrace(d) => positive(d),
        };
        if !limit_ok || !(EXP_MIN - 1..=EXP_MAX).contains(&self.d_cap_exp) {
            return Err(ConfigError::CovarianceLimit(nan));
        }
        Ok(())
    }
}

#[cfg(test)]
impl RlsConfig {
    /// Sets the outlier gate's raw I16F16 value (a test's invalid configuration).
    pub(crate) fn outlier_for_test(&mut self, raw: u32) {
        self.outlier_i16f16 = raw;
    }
}

/// Mantissa, then exponent; `take` accepts only a normalised value (0 with exponent 0, or a
/// mantissa in `[2³¹, 2³²)` with an exponent in `[EXP_MIN, EXP_MAX]`).
impl Words for Dyadic {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.mant().put(w)?;
        self.exp().put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let mant = u32::take(r);
        let exp = i32::take(r);
        let zero = mant == 0 && exp == 0;
        let normal = mant >= 1 << 31 && (EXP_MIN..=EXP_MAX).contains(&exp);
        r.check(zero || normal);
        if normal {
            Self::from_parts(mant, exp)
        } else {
            Self::ZERO
        }
    }
}

/// The quantised settings (module doc); `take` checks the encoding, [`RlsConfig::validate`] the
/// values.
impl Words for RlsConfig {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        self.lambda.put(w)?;
        self.p0.put(w)?;
        self.d_cap_exp.put(w)?;
        self.dead_zone_i16f16.put(w)?;
        self.excitation_min.put(w)?;
        match self.bound {
            Bound::None => w.word(0)?,
            Bound::Trace(d) => {
                w.word(1)?;
                d.put(w)?;
            }
            Bound::Diagonal(d) => {
                w.word(2)?;
                d.put(w)?;
            }
            Bound::ConstantTrace(d) => {
                w.word(3)?;
                d.put(w)?;
            }
        }
        self.outlier_i16f16.put(w)?;
        self.outlier_limit.put(w)
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        let lambda = Dyadic::take(r);
        let p0 = Dyadic::take(r);
        let d_cap_exp = i32::take(r);
        let dead_zone_i16f16 = u32::take(r);
        let excitation_min = Dyadic::take(r);
        let bound = match r.word() {
            0 => Bound::None,
            1 => Bound::Trace(Dyadic::take(r)),
            2 => Bound::Diagonal(Dyadic::take(r)),
            3 => Bound::ConstantTrace(Dyadic::take(r)),
            _ => {
                r.fail();
                Bound::None
            }
        };
        Self {
            lambda,
            lambda_inv: lambda.recip(),
            p0,
            d_cap_exp,
            dead_zone_i16f16,
            excitation_min,
            bound,
            outlier_i16f16: u32::take(r),
            outlier_limit: u16::take(r),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{AntiWindup, RlsDesign};
    use super::*;

    /// Every anti-windup mode, an excitation minimum and an outlier gate round-trip exactly
    /// (1/λ recomputed equal); a λ above 1, a zero p₀ and an unnormalised mantissa re-encoded
    /// are refused. Trips on a field left out or swapped, or a `validate` that misses a check.
    #[test]
    fn rls_settings_round_trip_through_their_words() {
        let modes = [
            AntiWindup::None,
            AntiWindup::TraceLimit { max: 100.0 },
            AntiWindup::DiagonalLimit { max: 7.5 },
            AntiWindup::ConstantTrace { trace: 3.0 },
            AntiWindup::FactorCap { max: 1e6 },
        ];
        for anti_windup in modes {
            let c = RlsDesign {
                lambda: 0.995,
                p0: 10.0,
                dead_zone: 0.25,
                excitation_threshold: 1e-6,
                anti_windup,
                outlier_threshold: 40.0,
                outlier_limit: 16,
            }
            .build()
            .unwrap();
            let mut buf = [0u32; 16];
            let mut w = WordWriter::new(&mut buf);
            c.put(&mut w).unwrap();
            let n = w.len();
            let mut r = WordReader::new(&buf[..n]);
            let back = RlsConfig::take(&mut r);
            assert_eq!(r.finish(), Ok(()));
            assert_eq!(back, c, "{anti_windup:?}");
            assert_eq!(back.validate(), Ok(()));
            // λ = 2 (mantissa 2³¹, exponent −30): refused.
            let mut bad = buf;
            bad[0] = 1 << 31;
            bad[1] = (-30i32) as u32;
            let mut r = WordReader::new(&bad[..n]);
            let l = RlsConfig::take(&mut r);
            assert_eq!(r.finish(), Ok(()));
            assert!(matches!(l.validate(), Err(ConfigError::Lambda(_))));
            // p₀ = 0: refused by validate; an unnormalised mantissa: by take.
            let mut bad = buf;
            bad[2] = 0;
            bad[3] = 0;
            let mut r = WordReader::new(&bad[..n]);
            let p = RlsConfig::take(&mut r);
            assert_eq!(r.finish(), Ok(()));
            assert!(matches!(
                p.validate(),
                Err(ConfigError::InitialCovariance(_))
            ));
            bad[2] = 1;
            let mut r = WordReader::new(&bad[..n]);
            let _ = RlsConfig::take(&mut r);
            assert!(r.finish().is_err());
        }
    }
}
