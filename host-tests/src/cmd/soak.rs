//! `sledid soak`: N samples of twin closed-loop data through the per-sample step; fails if P or
//! θ leave their bounds. Prints a JSON report.

/// `sledid soak`.
#[derive(clap::Args)]
pub struct Args {
    /// Samples.
    #[arg(long, default_value_t = 10_000_000)]
    pub samples: u64,
    /// Seeks per twin chunk.
    #[arg(long, default_value_t = 200)]
    pub seeks_per_chunk: u32,
}

/// Runs the command.
///
/// # Errors
/// A bound left, or a twin error.
pub fn run(a: &Args) -> Result<(), String> {
    sledid_host::soak::soak(a.samples, a.seeks_per_chunk, true)
        .and_then(|r| serde_json::to_string_pretty(&r).map_err(|e| e.to_string()))
        .map(|j| println!("{j}"))
}
