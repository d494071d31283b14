//! `sledid control`: the twin in closed loop with the library's controller, designed from a prior
//! plant only, never from the plant it runs on — by default the product's servo (power-on
//! calibration, then random seek commands in its seek mode: `sledid seek`'s run and outputs); or
//! the same servo following the paper's S-curve references, or the paper's baseline PID.

use sledid::servo::{Identification, ServoOptions};
use sledid_host::control::inject::ServoFault;
use sledid_host::control::run::run_servo_with_faults;
use sledid_host::control::{Perturbation, design_from_prior, plot};
use sledid_host::twin::TwinParams;
use std::path::PathBuf;

use super::seek::IdentificationArg;

/// `--controller`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ControllerArg {
    /// The product's servo: power-on calibration, then each command a step in its seek mode
    /// (time-optimal seek, settle, hold) — `sledid seek`'s run: summary.json as `sledid seek`
    /// writes it (beside the reference-following servo on the same seeks), seek_vs_distance.png,
    /// seek_steps.png.
    Seek,
    /// The paper's badly tuned PID following the S-curve references.
    Baseline,
    /// The servo (gain-scheduled controller and on-line identifier) following the paper's 30 ms
    /// S-curve references, without calibration.
    Scheduled,
}

/// `sledid control`.
#[derive(clap::Args)]
pub struct Args {
    /// The plant the twin simulates (JSON: plant, reference and baseline parameters; missing keys
    /// take the defaults). Default: the built-in nominal sled.
    #[arg(long)]
    pub plant: Option<PathBuf>,
    /// The plant the servo is designed from (JSON, its `plant` section is used). Default: the
    /// built-in nominal sled — never the `--plant` file.
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// Run on the `--plant` plant scaled, e.g. `mass=0.7`, `friction=1.5,quantum=2` (mass,
    /// friction = Coulomb and static, quantum).
    #[arg(long)]
    pub perturb: Option<String>,
    /// Which controller.
    #[arg(long, value_enum, default_value = "seek")]
    pub controller: ControllerArg,
    /// The servo's identification: on-line, or frozen at the prior.
    #[arg(long, value_enum, default_value = "online")]
    pub identification: IdentificationArg,
    /// Random seeks.
    #[arg(long, default_value_t = 100)]
    pub seeks: u32,
    /// Seed of the seeks and the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A fault injected into the servo's loop, repeatable (as `sledid seek --inject`: the replay's
    /// sensor faults, `drive-flip:from=K`, `mass:at=K,factor=F`, `friction:at=K,factor=F`; K from
    /// the first sample). `safe_stop` in the summary says what stopped the servo, where.
    #[arg(long)]
    pub inject: Vec<String>,
    /// Output directory: summary.json, and step_responses.png (`baseline`, `scheduled`) or
    /// seek_vs_distance.png and seek_steps.png (`seek`).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs the command: writes `DIR/summary.json` and the figures (`Args::out`), prints the summary.
///
/// # Errors
/// Parameter, run, file or plot errors.
pub fn run(a: &Args) -> Result<(), String> {
    let read =
        |p: &PathBuf| TwinParams::from_json_file(p).map_err(|e| format!("{}: {e}", p.display()));
    let plant = a.plant.as_ref().map(read).transpose()?.unwrap_or_default();
    let prior = a.prior.as_ref().map(read).transpose()?.unwrap_or_default();
    let perturb = a
        .perturb
        .as_deref()
        .map(Perturbation::parse)
        .transpose()?
        .unwrap_or_default();
    let params = perturb.apply(&plant);
    params.validate().map_err(|e| e.to_string())?;
    let design = match a.controller {
        ControllerArg::Seek => return super::seek::run_on(&params, &prior, false, &seek_args(a)),
        ControllerArg::Baseline => None,
        ControllerArg::Scheduled => Some(design_from_prior(&params, &prior.plant)?),
    };
    let options = ServoOptions {
        identification: match a.identification {
            IdentificationArg::Online => Identification::OnLine,
            IdentificationArg::Frozen => Identification::FrozenAtPrior,
        },
        ..ServoOptions::default()
    };
    let faults: Vec<ServoFault> = a
        .inject
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let run = run_servo_with_faults(
        &params,
        a.seed,
        a.seeks,
        design.as_ref(),
        options,
        None,
        &faults,
    )?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let json = serde_json::to_string_pretty(&run.summary).map_err(|e| e.to_string())?;
    let path = a.out.join("summary.json");
    std::fs::write(&path, json.clone() + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    plot::plot_steps(&run, &a.out.join("step_responses.png"), 4)?;
    println!("{json}\n→ {}", a.out.display());
    Ok(())
}

/// `sledid seek`'s arguments for `a` (`--controller seek`): its seeks, seed, identification,
/// faults and output directory, `sledid seek`'s distances and dwell, calibration on; the plant
/// and prior are passed to [`super::seek::run_on`] already read and perturbed.
fn seek_args(a: &Args) -> super::seek::Args {
    super::seek::Args {
        plant: None,
        prior: None,
        seeks: a.seeks,
        distances: super::seek::DISTANCES.to_owned(),
        seed: a.seed,
        controller: super::seek::SeekControllerArg::Seek,
        dwell_ms: super::seek::DWELL_MS,
        identification: a.identification,
        no_calibrate: false,
        inject: a.inject.clone(),
        out: a.out.clone(),
    }
}
