//! Signal conditioning: the raw sample becomes the signals the model is identified on.
//!
//! The estimator never sees absolute positions (part of the range analysis in [`crate::num::fixed`]):
//! - [`Conditioning::CentredOnReference`]: the tracking error `y_c = y − r` (the paper works around
//!   the settle point; with r constant this is the same linear model);
//! - [`Conditioning::Differenced`]: increments `Δy(t) = y(t) − y(t−1)`, `Δu(t) = u(t) − u(t−1)` (same
//!   parameters for any linear model without offset; removes any operating point);
//! - [`Conditioning::DifferencedOutput`]: `Δy` against `u` — velocity against drive, the model of an
//!   integrating plant (a sled, a positioning axis) without its integrator. Prefer it over
//!   `Differenced` there: differencing a slowly varying drive makes `Δu` a few LSBs of I16F16, and
//!   the estimate then loses its precision (measured on EMPS, see `host-tests/tests/integration/emps_vs_f64.rs`);
//! - [`Conditioning::None`]: y as is, for signals already centred by the user (e.g. Silverbox volts).
//!
//! Differences are formed in the wide [`PositionI48F16`] format and narrowed to I16F16 afterwards,
//! saturating and flagged, so absolute positions of millions of quanta are fine.

use crate::error::ConfigError;
use crate::num::boundary::{PositionI48F16, Sample};
use crate::num::fixed::SignalI16F16;
use crate::words::{WordReader, WordWriter, Words};

/// How raw samples are turned into the signals the model is identified on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Conditioning {
    /// Use y and u as they are.
    None,
    /// y − r (r: the reference), u as is.
    #[default]
    CentredOnReference,
    /// Δy and Δu (first differences).
    Differenced,
    /// Δy and u (velocity against drive, for integrating plants).
    DifferencedOutput,
}

/// The state of the conditioning stage (the previous raw sample, for differencing).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ConditioningState {
    prev_y: PositionI48F16,
    prev_u: SignalI16F16,
    primed: bool,
}

impl Conditioning {
    /// Conditions one raw sample into `(y_c, u_c)`; `None` on the first sample of a differenced stream
    /// (no increment yet). Saturating; `saturated` is set when a value did not fit I16F16.
    pub fn apply(
        self,
        st: &mut ConditioningState,
        sample: &Sample,
        saturated: &mut bool,
    ) -> Option<(SignalI16F16, SignalI16F16)> {
        match self {
            Self::None => Some((
                sample.y.offset_from(PositionI48F16::default(), saturated),
                sample.u,
            )),
            Self::CentredOnReference => Some((sample.y.offset_from(sample.r, saturated), sample.u)),
            Self::Differenced | Self::DifferencedOutput => {
                let out = st.primed.then(|| {
                    let u = if self == Self::Differenced {
                        sample.u.saturating_sub(st.prev_u)
                    } else {
                        sample.u
                    };
                    (sample.y.offset_from(st.prev_y, saturated), u)
                });
                st.prev_y = sample.y;
                st.prev_u = sample.u;
                st.primed = true;
                out
            }
        }
    }
}

/// Words: the variant's index (`None` 0 … `DifferencedOutput` 3).
impl Words for Conditioning {
    fn put(&self, w: &mut WordWriter<'_>) -> Result<(), ConfigError> {
        w.word(match self {
            Self::None => 0,
            Self::CentredOnReference => 1,
            Self::Differenced => 2,
            Self::DifferencedOutput => 3,
        })
    }
    fn take(r: &mut WordReader<'_>) -> Self {
        match r.word() {
            0 => Self::None,
            1 => Self::CentredOnReference,
            2 => Self::Differenced,
            3 => Self::DifferencedOutput,
            _ => {
                r.fail();
                Self::None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn smp(y: i64, u: i32, r: i64) -> Sample {
        Sample {
            y: PositionI48F16::from_counts(y),
            u: SignalI16F16::from_int(u),
            r: PositionI48F16::from_counts(r),
        }
    }

    #[test]
    fn differencing_primes_then_differences_wide_positions() {
        let mut st = ConditioningState::default();
        let mut sat = false;
        let c = Conditioning::Differenced;
        assert_eq!(c.apply(&mut st, &smp(4_000_000, 1, 0), &mut sat), None);
        let out = c.apply(&mut st, &smp(4_000_007, 0, 0), &mut sat);
        assert_eq!(
            out,
            Some((SignalI16F16::from_int(7), SignalI16F16::from_int(-1)))
        );
        assert!(!sat);
    }

    #[test]
    fn centring_subtracts_the_reference_and_flags_saturation() {
        let mut st = ConditioningState::default();
        let mut sat = false;
        let out = Conditioning::CentredOnReference.apply(
            &mut st,
            &smp(4_000_000, 3, 4_000_010),
            &mut sat,
        );
        assert_eq!(
            out,
            Some((SignalI16F16::from_int(-10), SignalI16F16::from_int(3)))
        );
        assert!(!sat);
        let _ = Conditioning::None.apply(&mut st, &smp(4_000_000, 0, 0), &mut sat);
        assert!(sat);
    }
}
