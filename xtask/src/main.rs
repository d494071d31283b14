//! `cargo xtask <task>`: the project's checks as one command each.
//!
//! - `test`: formatting, clippy (host and both thumb targets), library builds for
//!   `thumbv7em-none-eabihf` and `thumbv6m-none-eabi`, and every host test (overflow checks on).
//! - `fmt`: format the workspace.
//! - `fuzz [RUNS]`: every cargo-fuzz target for RUNS executions (default 10⁷) on its committed corpus.
//! - `cost`: build the bench image for Cortex-M4F and M0+ and count instructions / estimate cycles
//!   per call of every `bench_*` entry point with `../shared/tools/count_insns.py` (needs Python with
//!   `unicorn==2.1.4 capstone==5.0.9 pyelftools==0.33`), printing the table for BENCHMARKS.md.

use std::process::{Command, ExitCode};

const THUMB_TARGETS: [&str; 2] = ["thumbv7em-none-eabihf", "thumbv6m-none-eabi"];

fn cargo(args: &[&str]) -> bool {
    println!("\n==> cargo {}", args.join(" "));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    match Command::new(cargo).args(args).status() {
        Ok(s) => s.success(),
        Err(e) => {
            eprintln!("xtask: cannot run cargo: {e}");
            false
        }
    }
}

fn test() -> bool {
    let mut steps: Vec<Vec<&str>> = vec![
        vec!["fmt", "--all", "--check"],
        vec![
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ],
    ];
    for t in THUMB_TARGETS {
        steps.push(vec![
            "clippy", "--lib", "--bins", "--target", t, "--", "-D", "warnings",
        ]);
        // The firmware's count_insns.py entry points (not in the shipped image).
        steps.push(vec![
            "clippy",
            "--bins",
            "--target",
            t,
            "--features",
            "fw-bench",
            "--",
            "-D",
            "warnings",
        ]);
        steps.push(vec!["build", "--lib", "--release", "--target", t]);
    }
    steps.push(vec!["test", "--workspace"]);
    steps.iter().all(|s| cargo(s)) && fuzz(20_000)
}

/// The cargo-fuzz targets (fuzz/fuzz_targets).
const FUZZ_TARGETS: [&str; 2] = ["step", "recording"];

/// Runs every fuzz target for `runs` executions on nightly (installing cargo-fuzz if missing).
fn fuzz(runs: u64) -> bool {
    let have = Command::new("cargo")
        .args(["fuzz", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !have
        && !cargo(&[
            "install",
            "--locked",
            "--quiet",
            "cargo-fuzz",
            "--version",
            "0.13.2",
        ])
    {
        return false;
    }
    FUZZ_TARGETS.iter().all(|t| {
        // libFuzzer writes new inputs into its first corpus directory: a scratch one, so the
        // committed seeds (read-only second directory) stay as they are.
        let scratch = std::env::temp_dir().join(format!("sledid-fuzz-{t}-{}", std::process::id()));
        if let Err(e) = std::fs::create_dir_all(&scratch) {
            eprintln!("xtask: {}: {e}", scratch.display());
            return false;
        }
        let scratch = scratch.display().to_string();
        let corpus = format!("fuzz/corpus/{t}");
        let runs = format!("-runs={runs}");
        println!("\n==> cargo +nightly fuzz run {t} {scratch} {corpus} -- {runs}");
        Command::new("cargo")
            .args([
                "+nightly",
                "fuzz",
                "run",
                t,
                &scratch,
                &corpus,
                "--",
                &runs,
                "-max_len=4096",
            ])
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// Entry points of the bench image (src/bin/bench.rs).
const BENCH_FNS: [&str; 15] = [
    "bench_overhead",
    "bench_rls2_update",
    "bench_rls4_update",
    "bench_arx4_step",
    "bench_neuron_eval",
    "bench_decimate_push",
    "bench_pid_step",
    "bench_hammerstein_step",
    "bench_noe_step",
    "bench_noe221_step",
    "bench_wiener_step",
    "bench_friction_step",
    "bench_sched_step",
    "bench_sched_redesign",
    "bench_loop_step",
];

fn cost() -> bool {
    let tool =
        std::env::var("COUNT_INSNS").unwrap_or_else(|_| "../shared/tools/count_insns.py".into());
    let mut rows = Vec::new();
    for (target, arch) in [
        ("thumbv7em-none-eabihf", "m4f"),
        ("thumbv6m-none-eabi", "m0plus"),
    ] {
        if !cargo(&[
            "build",
            "--release",
            "--target",
            target,
            "--bin",
            "sledid-bench",
        ]) {
            return false;
        }
        let elf = format!("target/{target}/release/sledid-bench");
        for f in BENCH_FNS {
            let out = Command::new("python3")
                .args([
                    &tool,
                    &elf,
                    f,
                    "--arch",
                    arch,
                    "--init",
                    "bench_init",
                    "--warmup",
                    "64",
                    "--calls",
                    "256",
                    "--args",
                    "i",
                ])
                .output();
            let Ok(out) = out else {
                eprintln!("xtask: cannot run python3 {tool}");
                return false;
            };
            let text = String::from_utf8_lossy(&out.stdout);
            let field = |key: &str, col: usize| {
                text.lines()
                    .find(|l| l.trim_start().starts_with(key))
                    .and_then(|l| l.split_whitespace().nth(col).map(str::to_owned))
                    .unwrap_or_else(|| "?".into())
            };
            if !out.status.success() {
                eprintln!("{}", String::from_utf8_lossy(&out.stderr));
                return false;
            }
            rows.push(format!(
                "| {arch} | {f} | {} | {} | {} |",
                field("instructions", 2),
                field("est. cycles  ", 3),
                field("stack used", 5)
            ));
        }
    }
    println!("\n| core | function | instructions (mean) | est. cycles (mean) | stack bytes |");
    println!("|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
    true
}

fn main() -> ExitCode {
    let task = std::env::args().nth(1).unwrap_or_default();
    let ok = match task.as_str() {
        "test" => test(),
        "fmt" => cargo(&["fmt", "--all"]),
        "cost" => cost(),
        "fuzz" => fuzz(
            std::env::args()
                .nth(2)
                .and_then(|r| r.parse().ok())
                .unwrap_or(10_000_000),
        ),
        _ => {
            eprintln!("usage: cargo xtask <test|fmt|cost|fuzz [RUNS]>");
            false
        }
    };
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
