//! `sledid-firmware`: what the firmware images and the host that checks them share, so that they
//! cannot drift — the parts the images are built for ([`part`]), the configuration words
//! ([`words`]), the processor-in-the-loop (PIL) link's frames ([`link`]), the interrupt's body and
//! the result line ([`ticker`]), the friction health beside the servo ([`health`]), the bench image's recorded run ([`recording`]) and, on target, the
//! interrupt's clocks (`timing`). The QEMU image (`src/main.rs`, binary `sledid-fw`), the board
//! image (`boards/stm32f411`) and the host (`host-tests/src/pil`, `host-tests/tests/integration/firmware_qemu.rs`)
//! depend on this crate; it is the firmware's, not part of the identification library (`sledid`).
//!
//! # The loop, per sample period (processor in the loop)
//! ```text
//! host → target   DownFrame { command, r(k), y(k) }       r, y raw I48F16 (quanta × 2¹⁶)
//! target          Ticker::step: the servo's step behind sledid::servo::hal::ControlLoop
//!                 (position in: FrameSensor; drive out: PwmDirection over embedded-hal 1.0)
//! target → host   UpFrame { k, u(k), flags(k), duty, direction }
//! host            the twin's sled advances one period under u(k)
//! ```
//! The host runs the same [`Ticker`] on the same configuration words beside the target and
//! compares every [`UpFrame`] (`host-tests/src/pil`).
//!
//! # Redesign hand-over (L = [`sledid::servo::SledServo::handover_latency`], from the words)
//! A redesign requested by sample k is posted as a job; the firmware's main loop (the
//! background) computes it and hands the result to the interrupt, which adopts it at sample
//! k + L ([`sledid::servo::handover`]). A result not delivered by then is dropped: the old gains
//! stay and the step flags `HANDOVER_MISSED`. The host's reference delivers every job at once
//! (or, for a job the host told the target to hold back by [`Command::delay`] ≥ L periods, not
//! at all), so the two agree exactly whenever the target's background meets L.
//!
//! # Up frame
//! [`UpFrame::to_bytes`] (16 bytes, little-endian): k (`u32`), u (`i32`, raw I16F16 full
//! scale), the flags word ([`flags_word`]: controller flags in bits 0–15, servo flags in 16–23,
//! region index in 24–31), the PWM duty (`u16`), the direction pin (`u8`, 1 = high, u ≥ 0) and
//! a zero byte. The host compares every one; the interrupt keeps no checksum of them (it would
//! cost ≈ 300 cycles a sample for a check the host already makes).

#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod health;
pub mod link;
pub mod part;
pub mod recording;
pub mod ticker;
#[cfg(target_os = "none")]
pub mod timing;
pub mod words;

pub use health::{
    HEALTH_Q, HealthConsumer, HealthLine, HealthProducer, HealthTap, HealthWatch, health_config,
};
pub use link::{
    Command, DOWN_FRAME_BYTES, DownFrame, Kind, LINK_DOWN, LINK_UP, UP_FRAME_BYTES, UpFrame,
    flags_word,
};
pub use part::{PART_M0PLUS, PART_M4F, Part, SAMPLE_PERIOD_NS};
pub use ticker::{
    FrameSensor, NoReading, PWM_MAX_DUTY, PilPin, PilPwm, RESULT_PREFIX, Summary, THETA_N,
    TIMING_PREFIX, Ticker,
};
pub use words::{HEALTH_WORDS, LOOP_WORDS, config, config_into};
