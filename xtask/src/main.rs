//! `cargo xtask <task>`: the project's checks as one command each.
//!
//! - `setup`: installs what a fresh machine with only rustup lacks (the thumb targets, rustfmt and
//!   clippy, `qemu-system-arm`); `test` runs it first, so the README's test command
//!   is all a newcomer runs.
//! - `test`: formatting, clippy (host and both thumb targets), library builds for
//!   `thumbv7em-none-eabihf` and `thumbv6m-none-eabi`, every host test (overflow checks on; the
//!   firmware's PIL runs under QEMU among them), the board images (`boards/*`: formatting and
//!   clippy, which builds them) and the library's docs with warnings denied. The fuzz targets'
//!   bodies run among the host tests on their committed corpus and seeded mutations of it.
//!   Prints each command's wall time at the end.
//! - `fmt`: format the workspace.
//! - `fuzz [RUNS]`: every cargo-fuzz target for RUNS executions (default 10⁷) on its committed corpus
//!   (installs a nightly toolchain and cargo-fuzz when missing).
//! - `pil [ARGS]`: the firmware under QEMU in the loop with the sled twin on both cores, checked
//!   against the host (`cargo run --release -p sledid-host -- pil ARGS`, e.g. `--seeks 50`).
//! - `cost`: build the bench image for Cortex-M4F and M0+ and count instructions / estimate cycles
//!   per call of every `bench_*` entry point with `../shared/tools/count_insns.py` (needs Python with
//!   `unicorn==2.1.4 capstone==5.0.9 pyelftools==0.33`), printing the table for BENCHMARKS.md;
//!   then the firmware's interrupt over the PIL trace, its background's redesign and the
//!   shipped images' flash and RAM (`cost firmware` for only that part).

use std::process::{Command, ExitCode};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Every command a task ran and its wall time, printed at the end (where CI's minutes go).
static TIMES: Mutex<Vec<(String, Duration)>> = Mutex::new(Vec::new());

/// Runs `f`, recording its wall time under `label`.
fn timed(label: String, f: impl FnOnce() -> bool) -> bool {
    let start = Instant::now();
    let ok = f();
    if let Ok(mut t) = TIMES.lock() {
        t.push((label, start.elapsed()));
    }
    ok
}

/// The recorded commands, slowest first, with the total.
fn print_times() {
    let Ok(mut t) = TIMES.lock() else { return };
    if t.is_empty() {
        return;
    }
    let total: Duration = t.iter().map(|(_, d)| *d).sum();
    t.sort_by_key(|e| std::cmp::Reverse(e.1));
    println!(
        "\nxtask: wall time per command (total {:.0} s)",
        total.as_secs_f64()
    );
    for (label, d) in t.iter() {
        println!("{:>7.1} s  {label}", d.as_secs_f64());
    }
}

const THUMB_TARGETS: [&str; 2] = ["thumbv7em-none-eabihf", "thumbv6m-none-eabi"];

fn cargo(args: &[&str]) -> bool {
    cargo_env(args, &[])
}

/// The board images (`boards/*`): each its own workspace, built from its own directory so that
/// its `.cargo/config.toml` (target, probe-rs runner) applies.
const BOARDS: [&str; 1] = ["boards/stm32f411"];

/// `cargo args…` in `dir`.
fn cargo_in(dir: &str, args: &[&str]) -> bool {
    let label = format!("(cd {dir} && cargo {})", args.join(" "));
    println!("\n==> {label}");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    timed(label, || {
        match Command::new(cargo).current_dir(dir).args(args).status() {
            Ok(s) => s.success(),
            Err(e) => {
                eprintln!("xtask: cannot run cargo in {dir}: {e}");
                false
            }
        }
    })
}

/// `cargo args…` with extra environment variables.
fn cargo_env(args: &[&str], env: &[(&str, &str)]) -> bool {
    let label = format!("cargo {}", args.join(" "));
    println!("\n==> {label}");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    timed(label, || {
        match Command::new(cargo)
            .args(args)
            .envs(env.iter().copied())
            .status()
        {
            Ok(s) => s.success(),
            Err(e) => {
                eprintln!("xtask: cannot run cargo: {e}");
                false
            }
        }
    })
}

/// Runs `program args…`, printing it first; true on success.
fn run(program: &str, args: &[&str]) -> bool {
    let label = format!("{program} {}", args.join(" "));
    println!("\n==> {label}");
    timed(label, || {
        Command::new(program)
            .args(args)
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// stdout of `program args…`, or empty when it cannot run.
fn output(program: &str, args: &[&str]) -> String {
    Command::new(program)
        .args(args)
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default()
}

/// Is `program` on the PATH (it answers `--version`)?
fn have(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The Debian package that provides `qemu-system-arm`.
const QEMU_PACKAGE: &str = "qemu-system-arm";

/// Installs what `test` needs and a fresh machine lacks. Idempotent: each step checks first.
///
/// rustup installs `rust-toolchain.toml`'s targets and components only when it installs the
/// toolchain itself; a machine that already had the pinned toolchain lacks them, so they are added
/// here. `qemu-system-arm` comes from apt when this user can install packages (root, or sudo without
/// a password); otherwise setup stops and prints the command to run.
fn setup() -> bool {
    let targets = output("rustup", &["target", "list", "--installed"]);
    for t in THUMB_TARGETS {
        if !targets.lines().any(|l| l.trim() == t) && !run("rustup", &["target", "add", t]) {
            return false;
        }
    }
    let components = output("rustup", &["component", "list", "--installed"]);
    for c in ["rustfmt", "clippy"] {
        if !components.lines().any(|l| l.starts_with(c)) && !run("rustup", &["component", "add", c])
        {
            return false;
        }
    }
    if !have("qemu-system-arm") && !timed(format!("apt-get install {QEMU_PACKAGE}"), install_qemu) {
        return false;
    }
    true
}

/// apt-get install qemu-system-arm, as root or through password-less sudo.
fn install_qemu() -> bool {
    let root = output("id", &["-u"]).trim() == "0";
    let sudo = !root
        && Command::new("sudo")
            .args(["-n", "true"])
            .status()
            .is_ok_and(|s| s.success());
    let apt = have("apt-get");
    if apt && (root || sudo) {
        let prefix: &[&str] = if root { &[] } else { &["sudo", "-n"] };
        let cmd = |args: &[&str]| {
            let all: Vec<&str> = prefix.iter().chain(args).copied().collect();
            let (p, rest) = all.split_first().map_or(("", &[][..]), |(p, r)| (*p, r));
            Command::new(p)
                .args(rest)
                .env("DEBIAN_FRONTEND", "noninteractive")
                .status()
                .is_ok_and(|s| s.success())
        };
        println!("\n==> apt-get install {QEMU_PACKAGE}");
        if cmd(&["apt-get", "update", "-qq"])
            && cmd(&[
                "apt-get",
                "install",
                "-y",
                "-qq",
                "--no-install-recommends",
                QEMU_PACKAGE,
            ])
            && have("qemu-system-arm")
        {
            return true;
        }
    }
    eprintln!(
        "xtask: the firmware tests need qemu-system-arm and this user cannot install it.\n\
         Run:  sudo apt-get install -y --no-install-recommends {QEMU_PACKAGE}\n\
         (other systems: install QEMU's ARM system emulator, e.g. `brew install qemu`), then \
         `cargo xtask test` again."
    );
    false
}

fn test() -> bool {
    if !setup() {
        return false;
    }
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
            "clippy",
            "-p",
            "sledid",
            "-p",
            "sledid-firmware",
            "--lib",
            "--bins",
            "--target",
            t,
            "--",
            "-D",
            "warnings",
        ]);
        // The firmware's count_insns.py entry points (not in the shipped image).
        steps.push(vec![
            "clippy",
            "-p",
            "sledid-firmware",
            "--bins",
            "--target",
            t,
            "--features",
            "fw-bench",
            "--",
            "-D",
            "warnings",
        ]);
        steps.push(vec![
            "build",
            "-p",
            "sledid",
            "--lib",
            "--release",
            "--target",
            t,
        ]);
    }
    steps.push(vec!["test", "--workspace"]);
    steps.iter().all(|s| cargo(s))
        // The board images build (they cannot run here): formatting and clippy, which builds them.
        && BOARDS.iter().all(|b| {
            cargo_in(b, &["fmt", "--check"])
                && cargo_in(b, &["clippy", "--release", "--", "-D", "warnings"])
        })
        // The library's and the harness's docs: every intra-doc link resolves, nothing public
        // links a private item.
        && cargo_env(
            &[
                "doc",
                "--no-deps",
                "--lib",
                "-p",
                "sledid",
                "-p",
                "sledid-firmware",
                "-p",
                "sledid-host",
            ],
            &[("RUSTDOCFLAGS", "-D warnings")],
        )
}

/// The cargo-fuzz targets (fuzz/fuzz_targets).
const FUZZ_TARGETS: [&str; 2] = ["step", "recording"];

/// Runs every fuzz target for `runs` executions on nightly (installing nightly and cargo-fuzz if
/// missing). The test command does not: it replays the corpus and seeded mutations through the
/// same bodies on stable (`host-tests/tests/integration/fuzz_corpus.rs`).
fn fuzz(runs: u64) -> bool {
    // cargo-fuzz needs a nightly toolchain (sanitizer flags).
    let toolchains = output("rustup", &["toolchain", "list"]);
    if !toolchains.lines().any(|l| l.starts_with("nightly"))
        && !run(
            "rustup",
            &["toolchain", "install", "nightly", "--profile", "minimal"],
        )
    {
        return false;
    }
    let installed = Command::new("cargo")
        .args(["fuzz", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !installed
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
        let label = format!("cargo +nightly fuzz run {t} {scratch} {corpus} -- {runs}");
        println!("\n==> {label}");
        timed(label, || {
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
    })
}

/// Entry points of the bench image (src/bin/bench.rs).
const BENCH_FNS: [&str; 20] = [
    "bench_overhead",
    "bench_rls2_update",
    "bench_rls3_update",
    "bench_rls4_update",
    "bench_rls4_trace_update",
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
    "bench_seek_step",
    "bench_sched_redesign",
    "bench_loop_step",
    "bench_health_feed",
    "bench_health_step",
];

/// The `count_insns.py` script.
fn count_insns_tool() -> String {
    std::env::var("COUNT_INSNS").unwrap_or_else(|_| "../shared/tools/count_insns.py".into())
}

/// The lines of `count_insns.py`'s report that start with `key`, split in words.
fn report_field(text: &str, key: &str, col: usize) -> String {
    text.lines()
        .find(|l| l.trim_start().starts_with(key))
        .and_then(|l| l.split_whitespace().nth(col).map(str::to_owned))
        .unwrap_or_else(|| "?".into())
}

/// Runs `count_insns.py` on `symbol` of `elf` for `arch` with `args` (init, calls, …), every
/// call's argument the call index; its report, or `None` (the failure printed).
fn count_insns(tool: &str, elf: &str, symbol: &str, arch: &str, args: &[&str]) -> Option<String> {
    let out = Command::new("python3")
        .args([tool, elf, symbol, "--arch", arch])
        .args(args)
        .args(["--args", "i"])
        .output();
    let Ok(out) = out else {
        eprintln!("xtask: cannot run python3 {tool}");
        return None;
    };
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
        return None;
    }
    Some(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Records of the PIL trace (`fixtures/pil_trace.bin`: power-on calibration and 3 seeks of the
/// twin), every one measured: each record is three varints (`firmware/src/recording.rs`), each
/// ending in the one byte whose top bit is clear. `None` if the file cannot be read or is cut off.
fn trace_samples() -> Option<String> {
    let bytes = std::fs::read("fixtures/pil_trace.bin").ok()?;
    let ends = bytes.iter().filter(|&&b| b & 0x80 == 0).count();
    (ends % 3 == 0 && bytes.last().is_some_and(|b| b & 0x80 == 0)).then(|| (ends / 3).to_string())
}

/// The firmware's cost: the interrupt's body over the PIL trace (seeks, settling, holds and the
/// hand-overs, every call measured: mean and worst), the scaffolding to subtract, the
/// background's redesign; then flash and RAM of the shipped images.
fn cost_firmware() -> bool {
    let tool = count_insns_tool();
    let Some(samples) = trace_samples() else {
        eprintln!("fixtures/pil_trace.bin: missing or cut off");
        return false;
    };
    let dir = "target/fwbench";
    let mut rows = Vec::new();
    for (target, arch) in [
        ("thumbv7em-none-eabihf", "m4f"),
        ("thumbv6m-none-eabi", "m0plus"),
    ] {
        if !cargo_env(
            &[
                "build",
                "--profile",
                "firmware",
                "-p",
                "sledid-firmware",
                "--features",
                "fw-bench",
                "--target",
                target,
                "--bin",
                "sledid-fw",
            ],
            &[("CARGO_TARGET_DIR", dir)],
        ) {
            return false;
        }
        let elf = format!("{dir}/{target}/firmware/sledid-fw");
        for (f, calls) in [
            ("sledid_fw_bench_tick", samples.as_str()),
            ("sledid_fw_bench_overhead", samples.as_str()),
            ("sledid_fw_bench_redesign", "8"),
            ("sledid_fw_bench_calibrate", "2"),
        ] {
            println!("\n==> python3 {tool} {elf} {f} --arch {arch} --calls {calls}");
            let init = ["--init", "sledid_fw_bench_init", "--calls", calls];
            let Some(text) = count_insns(&tool, &elf, f, arch, &init) else {
                return false;
            };
            print!("{text}");
            rows.push(format!(
                "| {arch} | {f} | {} / {} | {} / {} | {} |",
                report_field(&text, "instructions", 2),
                report_field(&text, "instructions", 6),
                report_field(&text, "est. cycles  ", 3),
                report_field(&text, "est. cycles  ", 7),
                report_field(&text, "stack used", 5)
            ));
        }
    }
    println!(
        "\n| core | function | instructions mean / max | est. cycles mean / max | stack bytes |"
    );
    println!("|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
    // The shipped images (no bench exports): flash = vector table + text + rodata + data.
    if !cargo_env(
        &[
            "build",
            "--profile",
            "firmware",
            "-p",
            "sledid-firmware",
            "--bin",
            "sledid-fw",
            "--target",
            THUMB_TARGETS[0],
            "--target",
            THUMB_TARGETS[1],
        ],
        &[("CARGO_TARGET_DIR", "target/fw")],
    ) {
        return false;
    }
    println!("\n| image | vector + text + rodata + data (flash) | data + bss |");
    println!("|---|---|---|");
    for t in THUMB_TARGETS {
        let elf = format!("target/fw/{t}/firmware/sledid-fw");
        let text = output("llvm-size", &["-A", &elf]);
        let size = |name: &str| -> u64 {
            text.lines()
                .find(|l| l.split_whitespace().next() == Some(name))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse().ok())
                .unwrap_or(0)
        };
        let flash = size(".vector_table") + size(".text") + size(".rodata") + size(".data");
        let ram = size(".data") + size(".bss") + size(".uninit");
        println!("| {t} | {flash} B | {ram} B (+ the painted stack: `cargo xtask pil`) |");
    }
    true
}

fn cost() -> bool {
    let tool = count_insns_tool();
    let mut rows = Vec::new();
    for (target, arch) in [
        ("thumbv7em-none-eabihf", "m4f"),
        ("thumbv6m-none-eabi", "m0plus"),
    ] {
        // The bench links no defmt: the workspace's thumb rustflags (`-Tdefmt.x`, for the
        // firmware) would fail its link on a fresh clone, so RUSTFLAGS replaces them here, in a
        // target directory of its own (no rebuild of the other thumb builds).
        if !cargo_env(
            &[
                "build",
                "--release",
                "--target",
                target,
                "--bin",
                "sledid-bench",
            ],
            &[
                ("CARGO_TARGET_DIR", "target/bench"),
                ("RUSTFLAGS", "-C link-arg=-Tlink.x"),
            ],
        ) {
            return false;
        }
        let elf = format!("target/bench/{target}/release/sledid-bench");
        for f in BENCH_FNS {
            let init = ["--init", "bench_init", "--warmup", "64", "--calls", "256"];
            let Some(text) = count_insns(&tool, &elf, f, arch, &init) else {
                return false;
            };
            rows.push(format!(
                "| {arch} | {f} | {} | {} | {} |",
                report_field(&text, "instructions", 2),
                report_field(&text, "est. cycles  ", 3),
                report_field(&text, "stack used", 5)
            ));
        }
    }
    println!("\n| core | function | instructions (mean) | est. cycles (mean) | stack bytes |");
    println!("|---|---|---|---|---|");
    for r in rows {
        println!("{r}");
    }
    cost_firmware()
}

fn main() -> ExitCode {
    let task = std::env::args().nth(1).unwrap_or_default();
    let ok = match task.as_str() {
        "test" => test(),
        "setup" => setup(),
        "fmt" => cargo(&["fmt", "--all"]) && BOARDS.iter().all(|b| cargo_in(b, &["fmt"])),
        "cost" if std::env::args().nth(2).as_deref() == Some("firmware") => cost_firmware(),
        "cost" => cost(),
        "pil" => {
            let rest: Vec<String> = std::env::args().skip(2).collect();
            let mut args = vec!["run", "--release", "-p", "sledid-host", "--", "pil"];
            args.extend(rest.iter().map(String::as_str));
            cargo(&args)
        }
        "fuzz" => fuzz(
            std::env::args()
                .nth(2)
                .and_then(|r| r.parse().ok())
                .unwrap_or(10_000_000),
        ),
        _ => {
            eprintln!("usage: cargo xtask <setup|test|fmt|pil [ARGS]|cost [firmware]|fuzz [RUNS]>");
            false
        }
    };
    print_times();
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
