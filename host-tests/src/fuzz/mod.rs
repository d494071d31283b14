//! The fuzz targets' bodies. `fuzz/fuzz_targets/*.rs` call them under libFuzzer (`cargo xtask
//! fuzz`, nightly); the test command replays the committed corpus and seeded mutations of it
//! through the same bodies on the stable toolchain (`tests/integration/fuzz_corpus.rs`).

pub mod recording;
pub mod step;
