//! The fuzz targets on the stable toolchain: every committed corpus input (`fuzz/corpus/TARGET`,
//! what libFuzzer kept for new coverage, and any crash reproducer in `fuzz/artifacts/TARGET`)
//! and seeded mutations of them run through the same bodies `cargo xtask fuzz` runs under
//! libFuzzer (`sledid_host::fuzz`), with the test profile's overflow checks and debug assertions.
//! A regression that panics on an input the fuzzer once reached fails here without nightly.
//! A failing mutant is written to the temporary directory and named in the failure, to be added
//! to the corpus once fixed.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// Mutants per target. Measured: 4,000 step mutants take ≈ 3 s of one core in the test profile.
const MUTANTS: u64 = 50_000;
/// libFuzzer's `-max_len` in `cargo xtask fuzz`.
const MAX_LEN: usize = 4096;

fn dir(kind: &str, target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz")
        .join(kind)
        .join(target)
}

/// Every file of `fuzz/corpus/target` and `fuzz/artifacts/target`, by name.
fn inputs(target: &str) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for kind in ["corpus", "artifacts"] {
        let Ok(entries) = std::fs::read_dir(dir(kind, target)) else {
            continue;
        };
        for e in entries.flatten() {
            let path = e.path();
            if path.is_file() {
                let bytes = std::fs::read(&path).expect("corpus file readable");
                out.push((path.display().to_string(), bytes));
            }
        }
    }
    out.sort();
    out
}

/// xorshift64*: the mutations are the same on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One to four of libFuzzer's basic mutations of `base` (bit flip, random byte, insert, erase,
/// splice with `other`), at most [`MAX_LEN`] bytes.
fn mutate(rng: &mut Rng, base: &[u8], other: &[u8]) -> Vec<u8> {
    let mut m = base.to_vec();
    for _ in 0..1 + rng.below(4) {
        match rng.below(5) {
            0 if !m.is_empty() => {
                let i = rng.below(m.len());
                m[i] ^= 1 << rng.below(8);
            }
            1 if !m.is_empty() => {
                let i = rng.below(m.len());
                m[i] = rng.next() as u8;
            }
            2 => {
                let at = rng.below(m.len() + 1);
                let n = 1 + rng.below(16);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                m.splice(at..at, bytes);
            }
            3 if !m.is_empty() => {
                let at = rng.below(m.len());
                let n = 1 + rng.below(m.len() - at);
                m.drain(at..at + n);
            }
            _ => {
                let cut = rng.below(m.len() + 1);
                let from = rng.below(other.len() + 1);
                m.truncate(cut);
                m.extend_from_slice(&other[from..]);
            }
        }
    }
    m.truncate(MAX_LEN);
    m
}

/// Runs `body` on the corpus and [`MUTANTS`] mutants; returns the corpus size. Panics naming the
/// first input that panics (a mutant is written out first).
fn replay(target: &str, body: fn(&[u8])) -> usize {
    let corpus = inputs(target);
    for (name, bytes) in &corpus {
        if catch_unwind(AssertUnwindSafe(|| body(bytes))).is_err() {
            panic!("{target}: the corpus input {name} panics");
        }
    }
    let mut rng = Rng(0x5eed_f022 ^ target.len() as u64);
    for k in 0..MUTANTS {
        let base = &corpus[rng.below(corpus.len())].1;
        let other = &corpus[rng.below(corpus.len())].1;
        let m = mutate(&mut rng, base, other);
        if catch_unwind(AssertUnwindSafe(|| body(&m))).is_err() {
            let out = std::env::temp_dir().join(format!("sledid-fuzz-{target}-mutant-{k}"));
            let _ = std::fs::write(&out, &m);
            panic!(
                "{target}: mutant {k} panics; its bytes are in {}",
                out.display()
            );
        }
    }
    corpus.len()
}

/// The step under every committed input and its mutants: no panic, no overflow, θ reported is
/// θ held, P positive definite. Trips on any arithmetic overflow or broken invariant the fuzzer
/// once reached, and if the corpus went missing (at least the 538 files committed today).
#[test]
fn the_step_survives_its_corpus_and_mutations() {
    let n = replay("step", sledid_host::fuzz::step::target);
    assert!(
        n >= 538,
        "the step corpus has {n} inputs, 538 were committed"
    );
}

/// The recording reader under every committed file and its mutants: a sample or a typed error
/// whose message formats, never a panic. Trips on a reader that indexes past a line, slices a
/// multi-byte character or overflows on a number, and if the corpus went missing.
#[test]
fn the_recording_reader_survives_its_corpus_and_mutations() {
    let n = replay("recording", sledid_host::fuzz::recording::target);
    assert!(
        n >= 445,
        "the recording corpus has {n} inputs, 445 were committed"
    );
}
