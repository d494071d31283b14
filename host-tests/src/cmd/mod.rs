//! The CLI's commands, one module each: its arguments and its `run`.

pub mod control;
pub mod control_family;
pub mod demo;
pub mod pacing;
pub mod replay;
pub mod seek;
pub mod soak;
pub mod study;
pub mod twin;
