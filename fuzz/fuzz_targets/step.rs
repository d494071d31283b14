//! The per-sample `step` with an arbitrary (valid) configuration — any linear or nonlinear model —
//! and arbitrary raw samples: no panic, no overflow (overflow checks are on), P stays positive definite.
//! The body is `sledid_host::fuzz::step::target`, which the test command also replays.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| sledid_host::fuzz::step::target(data));
