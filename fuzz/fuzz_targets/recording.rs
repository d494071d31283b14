//! The recording reader on arbitrary file contents: every outcome is a sample or a typed error (and
//! its message), never a panic. The body is `sledid_host::fuzz::recording::target`, which the test
//! command also replays.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| sledid_host::fuzz::recording::target(data));
