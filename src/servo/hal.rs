//! I/O at the boundary through embedded-hal 1.0: the drive as PWM duty cycles
//! ([`embedded_hal::pwm::SetDutyCycle`]), the position as a small sensor trait of ours, and
//! [`ControlLoop`], which connects them to the servo's step — so the same code runs on a
//! board, in QEMU and on the host (with fake PWM channels and sensors).
//!
//! # Drive mapping
//! The controller's signed u (fraction of full scale) becomes a magnitude and a direction:
//! `duty = round(min(|u|, 1) · max_duty)` (`u32` product of a ≤ 2¹⁶ value and a `u16`: < 2³²),
//! either on one of two H-bridge channels ([`HBridge`]: the other one at 0 %) or on one channel
//! plus a direction pin ([`PwmDirection`]).

use super::{ServoConfig, ServoOutput, ServoState};
use crate::control::Controller;
use crate::ident::step::Identifier;
use crate::num::boundary::PositionI48F16;
use crate::num::fixed::SignalI16F16;
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;

/// A position sensor that counts quanta (an encoder, a track counter).
pub trait PositionSensor {
    /// Why a reading failed.
    type Error;
    /// The position now, in quanta.
    ///
    /// # Errors
    /// The sensor's error when no valid reading is available.
    fn read_counts(&mut self) -> Result<i64, Self::Error>;
}

/// A signed drive.
pub trait Drive {
    /// Why writing failed.
    type Error;
    /// Applies u (fraction of full scale; |u| > 1 is clamped to full scale).
    ///
    /// # Errors
    /// The output's error.
    fn apply(&mut self, u: SignalI16F16) -> Result<(), Self::Error>;
}

/// `round(min(|u|, 1) · max_duty)`.
pub fn duty_for(u: SignalI16F16, max_duty: u16) -> u16 {
    let magnitude = u.raw().unsigned_abs().min(1 << 16); // ≤ 2^16
    let scaled = magnitude * u32::from(max_duty) + (1 << 15); // < 2^32
    (scaled >> 16) as u16 // ≤ max_duty
}

/// An error of one of two outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveError<A, B> {
    /// The first output (forward channel, or the PWM channel).
    First(A),
    /// The second output (reverse channel, or the direction pin).
    Second(B),
}

/// Two PWM channels of an H-bridge: forward for u > 0, reverse for u < 0, the other at 0 %.
#[derive(Debug)]
pub struct HBridge<F, R> {
    /// Forward channel.
    pub forward: F,
    /// Reverse channel.
    pub reverse: R,
}

impl<F: SetDutyCycle, R: SetDutyCycle> Drive for HBridge<F, R> {
    type Error = DriveError<F::Error, R::Error>;

    fn apply(&mut self, u: SignalI16F16) -> Result<(), Self::Error> {
        let (fwd, rev) = if u.raw() >= 0 {
            (duty_for(u, self.forward.max_duty_cycle()), 0)
        } else {
            (0, duty_for(u, self.reverse.max_duty_cycle()))
        };
        // The channel being switched off first: never both on.
        if u.raw() >= 0 {
            self.reverse
                .set_duty_cycle(rev)
                .map_err(DriveError::Second)?;
            self.forward.set_duty_cycle(fwd).map_err(DriveError::First)
        } else {
            self.forward
                .set_duty_cycle(fwd)
                .map_err(DriveError::First)?;
            self.reverse.set_duty_cycle(rev).map_err(DriveError::Second)
        }
    }
}

/// One PWM channel for |u| and a direction pin (high: u ≥ 0).
#[derive(Debug)]
pub struct PwmDirection<P, D> {
    /// The magnitude.
    pub pwm: P,
    /// The direction.
    pub direction: D,
}

impl<P: SetDutyCycle, D: OutputPin> Drive for PwmDirection<P, D> {
    type Error = DriveError<P::Error, D::Error>;

    fn apply(&mut self, u: SignalI16F16) -> Result<(), Self::Error> {
        let duty = duty_for(u, self.pwm.max_duty_cycle());
        // Magnitude to 0 before a reversal, so the old direction never gets the new duty.
        self.pwm.set_duty_cycle(0).map_err(DriveError::First)?;
        if u.raw() >= 0 {
            self.direction.set_high().map_err(DriveError::Second)?;
        } else {
            self.direction.set_low().map_err(DriveError::Second)?;
        }
        self.pwm.set_duty_cycle(duty).map_err(DriveError::First)
    }
}

/// Sensor → [`ServoConfig::step`] → drive. A failed reading goes through
/// [`ServoConfig::step_lost`] (the last good position held, the model distrusted): the loop never
/// stalls.
#[derive(Debug)]
pub struct ControlLoop<S, D> {
    /// The sensor.
    pub sensor: S,
    /// The drive.
    pub drive: D,
}

impl<S: PositionSensor, D: Drive> ControlLoop<S, D> {
    /// A loop on `sensor` and `drive`.
    pub fn new(sensor: S, drive: D) -> Self {
        Self { sensor, drive }
    }

    /// One sample: read, step, drive. The output's `identifier` status carries
    /// [`crate::ident::status::Status::INPUT_REJECTED`] when the reading failed.
    ///
    /// # Errors
    /// The drive's error (the servo state has advanced; the caller decides what to do with a
    /// drive that cannot be written).
    pub fn tick<C: Controller, I: Identifier>(
        &mut self,
        config: &ServoConfig<C, I>,
        state: &mut ServoState<C, I>,
        reference: PositionI48F16,
    ) -> Result<ServoOutput<I::Output>, D::Error> {
        let output = match self.sensor.read_counts() {
            Ok(counts) => config.step(state, reference, PositionI48F16::from_counts(counts)),
            Err(_) => config.step_lost(state, reference),
        };
        self.drive.apply(output.u)?;
        Ok(output)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duty_rounds_and_clamps() {
        let s = |x: f64| SignalI16F16::from_f64(x).unwrap();
        assert_eq!(duty_for(s(0.5), 1000), 500);
        assert_eq!(duty_for(s(-0.25), 1000), 250);
        assert_eq!(duty_for(s(3.0), 1000), 1000);
        assert_eq!(duty_for(SignalI16F16::MIN, u16::MAX), u16::MAX);
        assert_eq!(duty_for(SignalI16F16::ZERO, u16::MAX), 0);
    }
}
