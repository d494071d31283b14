//! Host harness for `sledid`: recordings, replay, float64 references, the sled twin, the paper's study.
#![forbid(unsafe_code)]

pub mod closed_loop;
pub mod compare;
pub mod control;
pub mod excitation;
pub mod faults;
pub mod figure;
pub mod fuzz;
pub mod pacing;
pub mod pil;
pub mod plants;
pub mod recording;
pub mod reference;
pub mod replay;
pub mod soak;
pub mod study;
pub mod twin;
