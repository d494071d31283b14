//! `sledid`: the host CLI. `sledid demo` (the README's first command) generates a sled-twin recording,
//! replays it sample by sample through the library's per-sample `step` (the function the firmware's
//! timer interrupt calls), runs the float64 reference beside it, and writes a trace and a summary.
//! Each command lives in its own module of [`cmd`].

mod cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "sledid",
    version,
    about = "On-line identification of a CD sled: host tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Soak: N samples of twin closed-loop data (random seeks ending in limit cycles) through the
    /// per-sample step; fails if P or θ leave their bounds. Prints a JSON report.
    Soak(cmd::soak::Args),
    /// Simulate the sled in closed loop with the paper's baseline controller and write a recording
    /// (t_s, r_m, u_v, y_m) plus a JSON sidecar with every parameter and the seed.
    Twin(cmd::twin::Args),
    /// Replay recordings through the per-sample step (the firmware's function) and its float64
    /// reference: DIR/NAME/trace.csv and summary.json. Several files run in parallel.
    Replay(Box<cmd::replay::Args>),
    /// The paper's linear identification procedure (ARX1, ARX2, OE1, OE2 at Ts and after ÷2) on a
    /// recording, or on a twin recording with the paper's protocol (`--twin`): DIR/study.json and
    /// PNG figures like the paper's.
    Study(Box<cmd::study::Args>),
    /// The firmware under QEMU in the loop with the twin, checked against the host (`cargo xtask pil`).
    Pil(sledid_host::pil::PilArgs),
    /// The twin in closed loop with the library's controller (baseline PID, or the servo designed
    /// from `--prior`, identifying on-line or frozen): DIR/summary.json (settling, overshoot,
    /// limit-cycle pulses, unsettled seeks, fallbacks, holding error) and DIR/step_responses.png.
    Control(cmd::control::Args),
    /// The servo on N plants of the seeded family (baseline, identified, frozen at the prior,
    /// without friction identification), in parallel: DIR/family.{json,md,png}.
    ControlFamily(cmd::control_family::Args),
    /// Seek commands on the twin: each seek's access time (until |y − target| ≤ 1 track for
    /// ≥ 10 ms) against the plant's minimum-time bound, for the controller under test and today's
    /// reference-following servo: DIR/summary.json, seek_vs_distance.png, seek_steps.png.
    Seek(cmd::seek::Args),
    /// Can this machine pace a replay at Ts? Spin on the clock doing nothing else and count the
    /// gaps (the thread not running): each gap of at least Ts is an overrun of any paced replay,
    /// whatever its per-sample cost. Prints a JSON report.
    PacingProbe(cmd::pacing::Args),
    /// Generate a twin recording, replay it through the fixed-point identifier and its float64
    /// reference, write DIR/trace.csv and DIR/summary.json.
    Demo(cmd::demo::Args),
}

/// A reader that closed the pipe (`sledid … | head`) ends the run quietly: writing to a closed
/// stdout makes `println!` panic with "Broken pipe"; that one panic exits with success instead of
/// a backtrace and status 101. Any other panic goes to the default hook.
fn exit_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    exit_quietly_on_a_closed_pipe();
    let cli = Cli::parse();
    let result = match cli
        .command
        .unwrap_or_else(|| Command::Demo(cmd::demo::Args::default()))
    {
        Command::Demo(a) => cmd::demo::run(&a),
        Command::Control(a) => cmd::control::run(&a),
        Command::ControlFamily(a) => cmd::control_family::run(&a),
        Command::Seek(a) => cmd::seek::run(&a),
        Command::Replay(a) => cmd::replay::run(&a),
        Command::Study(a) => cmd::study::run(&a),
        Command::Pil(a) => sledid_host::pil::pil_cmd(&a),
        Command::Soak(a) => cmd::soak::run(&a),
        Command::Twin(a) => cmd::twin::run(&a),
        Command::PacingProbe(a) => cmd::pacing::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sledid: {e}");
            ExitCode::FAILURE
        }
    }
}
