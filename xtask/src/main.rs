//! `cargo xtask <task>`: the project's checks as one command each.
//!
//! - `test`: formatting, clippy (host and both thumb targets), library builds for
//!   `thumbv7em-none-eabihf` and `thumbv6m-none-eabi`, and every host test (overflow checks on).
//! - `fmt`: format the workspace.

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
            "clippy", "--lib", "--target", t, "--", "-D", "warnings",
        ]);
        steps.push(vec!["build", "--lib", "--release", "--target", t]);
    }
    steps.push(vec!["test", "--workspace"]);
    steps.iter().all(|s| cargo(s))
}

fn main() -> ExitCode {
    let task = std::env::args().nth(1).unwrap_or_default();
    let ok = match task.as_str() {
        "test" => test(),
        "fmt" => cargo(&["fmt", "--all"]),
        _ => {
            eprintln!("usage: cargo xtask <test|fmt>");
            false
        }
    };
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
