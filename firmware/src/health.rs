//! The friction health beside the servo ([`sledid::servo::health`], issue 23 item 2): what the
//! interrupt feeds after each step ([`HealthTap`]), what the background drains and compares with
//! calibration ([`HealthWatch`]), and the result line's fields ([`HealthLine`]). The image and the
//! host's PIL reference run this same code, so the estimate under PIL is bit-identical.
//!
//! # When it feeds
//! Only samples on which the servo drives the sled from a reading: a sample of calibration's
//! experiment (or of the fit's wait, [`ServoFlags::CALIBRATING`]), a safe stop or a lost reading
//! feeds nothing and restarts the pair ([`HealthFeed::restart`]: no travel spans it, the lag chain
//! breaks). So nothing is queued while the background fits calibration's record (24 ms on the
//! M4F, 0.7 s on the M0+): the queue only has to cover the background's other work, a redesign
//! (≤ 9.4 periods of the background's share on the M0+, `BENCHMARKS.md`), and it is drained
//! after every job and while a job is held back.
//!
//! # When the reference is set
//! When the background's fit is accepted by the hand-over ([`HealthWatch::adopt`], power-on and
//! every re-calibration): it drains the queue first. Feeding stops from calibration's first
//! sample until its adoption, and the fit is delivered in between, so the queue then holds
//! exactly the samples before the calibration, whatever the background's timing: the reference
//! falls at the same place in the sample sequence on the target as on the host, which delivers
//! the fit at once and drains every sample. (The background sets it right after the delivery,
//! before anything else; the first sample after the adoption is pushed two periods later.)
//!
//! # Queue
//! [`HEALTH_Q`] = 16 slots of 16 bytes (15 samples, 30 periods at one sample per 2·Ts): three
//! times the longest redesign on the M0+. A full queue drops the sample and counts it
//! (`dropped`, on the result line; the host's reference never drops, so a drop fails the PIL
//! comparison).

use heapless::spsc::{Consumer, Producer};
use sledid::SignalI16F16;
use sledid::control::scheduled::RedesignResult;
use sledid::error::ConfigError;
use sledid::servo::health::{
    FeedFlags, HealthConfig, HealthFeed, HealthQueue, HealthReference, HealthSample, HealthState,
    HealthVerdict,
};
use sledid::servo::{Calibrated, ServoFlags};

use crate::link::{DownFrame, Kind, UpFrame};

/// The queue's slots (heapless 0.8: capacity `HEALTH_Q − 1`).
pub const HEALTH_Q: usize = 16;

/// The queue between the interrupt and the background.
pub type Queue = HealthQueue<HEALTH_Q>;

/// The interrupt's end of [`Queue`].
pub type HealthProducer<'q> = Producer<'q, HealthSample, HEALTH_Q>;

/// The background's end of [`Queue`].
pub type HealthConsumer<'q> = Consumer<'q, HealthSample, HEALTH_Q>;

/// The estimator's configuration: [`HealthDesign::default`](sledid::servo::health::HealthDesign::default) built and quantised on the host,
/// decoded from [`HEALTH_WORDS`](crate::HEALTH_WORDS) and checked here (no `f64` on target).
///
/// # Errors
/// The words' (none for the committed ones: `firmware_qemu`'s `loop_words_are_up_to_date`).
pub fn health_config() -> Result<HealthConfig, ConfigError> {
    HealthConfig::from_words(&crate::HEALTH_WORDS)
}

/// The interrupt's side: the pair in progress and the drop count.
#[derive(Clone, Debug)]
pub struct HealthTap {
    config: HealthConfig,
    feed: HealthFeed,
}

impl HealthTap {
    /// Nothing fed yet.
    pub const fn new(config: HealthConfig) -> Self {
        Self {
            config,
            feed: HealthFeed::new(),
        }
    }

    /// After the step on `frame` answered `up`: feeds the reading and the drive answered
    /// (pushes every second sample, drops on a full queue), or restarts the pair on a sample
    /// the servo did not drive from a reading (module doc). Never waits.
    #[inline(always)]
    pub fn feed<const Q: usize>(
        &mut self,
        producer: &mut Producer<'_, HealthSample, Q>,
        frame: &DownFrame,
        up: &UpFrame,
    ) -> FeedFlags {
        let not_driving = ServoFlags::CALIBRATING.union(ServoFlags::SAFE_STOP);
        if frame.command.kind() != Some(Kind::Sample) || up.servo_flags().intersects(not_driving) {
            self.feed.restart();
            return FeedFlags::NONE;
        }
        self.config.feed(
            &mut self.feed,
            producer,
            frame.y,
            SignalI16F16::from_raw(up.u_raw),
        )
    }

    /// Samples dropped on a full queue.
    pub fn dropped(&self) -> u32 {
        self.feed.dropped()
    }
}

/// The background's side: the estimator and its reference.
#[derive(Clone, Debug)]
pub struct HealthWatch {
    config: HealthConfig,
    state: HealthState,
}

impl HealthWatch {
    /// At θ = 0 with no reference (the verdict says `NOT_READY` until calibration's).
    pub fn new(config: HealthConfig) -> Self {
        Self {
            state: config.new_state(),
            config,
        }
    }

    /// Runs the estimator on every queued sample; how many.
    pub fn drain(&mut self, consumer: &mut HealthConsumer<'_>) -> u32 {
        self.config.drain(&mut self.state, consumer)
    }

    /// Calibration's answer, accepted by the hand-over: drains what was queued before the
    /// calibration, then compares with its model from here on (nothing for a refusal or a model
    /// outside the formats).
    pub fn adopt(
        &mut self,
        consumer: &mut HealthConsumer<'_>,
        answer: &Calibrated<RedesignResult>,
    ) {
        let Calibrated::Model { model, .. } = answer else {
            return;
        };
        let Some(reference) = HealthReference::from_calibration(model) else {
            return;
        };
        self.drain(consumer);
        self.config.set_reference(&mut self.state, &reference);
    }

    /// The verdict on what has been drained.
    pub fn verdict(&self) -> HealthVerdict {
        self.config.verdict(&self.state)
    }

    /// The estimator's state.
    pub fn state(&self) -> &HealthState {
        &self.state
    }
}

/// The result line's health fields: `health=[ĉ, c_ref] health_updates=… health_flags=…
/// health_dropped=…`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HealthLine {
    /// [ĉ, c_ref], raw I12F20, fraction of full scale.
    pub coulomb_raw: [i32; 2],
    /// Estimator updates since the reference.
    pub updates: u32,
    /// The verdict's `HealthFlags` bits.
    pub flags: u8,
    /// Samples dropped on a full queue.
    pub dropped: u32,
}

impl HealthLine {
    /// From the verdict and the drop count.
    pub fn new(verdict: &HealthVerdict, dropped: u32) -> Self {
        Self {
            coulomb_raw: [verdict.coulomb_fs.raw(), verdict.reference_fs.raw()],
            updates: verdict.updates,
            flags: verdict.flags.bits(),
            dropped,
        }
    }
}
