//! `sledid twin`: the sled in closed loop with the paper's baseline controller, written as a
//! recording (t_s, r_m, u_v, y_m) plus a JSON sidecar with every parameter and the seed.

use sledid_host::twin::{Twin, TwinParams};
use std::path::PathBuf;

/// `sledid twin`.
#[derive(clap::Args)]
pub struct Args {
    /// Seed of the seek schedule and the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Plant, reference and controller parameters (JSON; missing keys take the defaults: the
    /// paper's badly tuned loop, `host-tests/plants/paper_sled.json`; the earlier well-damped
    /// baseline is `host-tests/plants/well_damped.json`).
    #[arg(long)]
    pub plant: Option<PathBuf>,
    /// Number of seeks (overrides the file).
    #[arg(long)]
    pub seeks: Option<u32>,
    /// Output CSV; the sidecar is written next to it with the extension `.json`.
    #[arg(long, default_value = "out/twin.csv")]
    pub out: PathBuf,
}

/// Runs the command.
///
/// # Errors
/// Parameter or file errors.
pub fn run(a: &Args) -> Result<(), String> {
    run_with(a.seed, a.plant.as_deref(), a.seeks, &a.out)
}

fn run_with(
    seed: u64,
    plant: Option<&std::path::Path>,
    seeks: Option<u32>,
    out: &std::path::Path,
) -> Result<(), String> {
    let mut params = match plant {
        Some(p) => TwinParams::from_json_file(p).map_err(|e| e.to_string())?,
        None => TwinParams::default(),
    };
    if let Some(n) = seeks {
        params.reference.seek_count = n;
    }
    params.validate().map_err(|e| e.to_string())?;
    let twin = Twin::run_baseline(params, seed).map_err(|e| e.to_string())?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    twin.write_csv(out).map_err(|e| e.to_string())?;
    println!(
        "{} samples, {} seeks → {} (+ {})",
        twin.samples().len(),
        twin.seeks().len(),
        out.display(),
        out.with_extension("json").display()
    );
    for (k, st) in twin.seek_stats().iter().enumerate() {
        println!("  seek {k}: {st:?}");
    }
    Ok(())
}
