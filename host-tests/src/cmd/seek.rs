//! `sledid seek`: seek commands on the twin — each seek's access time against the minimum-time
//! bound of the true plant, for the controller under test and for today's reference-following
//! servo on the same seeks; writes `summary.json`, the seek-time-versus-distance plot and a few
//! step responses.

use serde::Serialize;
use sledid_host::control::inject::ServoFault;
use sledid_host::control::seek::run::run_seeks_with_faults;
use sledid_host::control::seek::{
    SeekController, SeekOptions, SeekRow, SeekRun, SeekSummary, bound_curve, seek_design,
};
use sledid_host::control::{design_from_prior, plot};
use sledid_host::twin::{PlantParams, TwinParams};
use std::path::PathBuf;

/// `--distances`' default, tracks.
pub const DISTANCES: &str = "20:2000";
/// `--dwell-ms`' default.
pub const DWELL_MS: f64 = 300.0;

/// `--controller`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum SeekControllerArg {
    /// The servo's seek mode fed the seek command (a step; without a seek mode in the design, the
    /// scheduled law fed the step).
    Seek,
    /// The paper's baseline PID fed the step.
    Baseline,
    /// The servo following the paper's 30 ms S-curve (today's `sledid control`).
    Reference,
}

/// `--identification`.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum IdentificationArg {
    /// The identifier adapts on-line (the product).
    Online,
    /// The identifier never adapts: the servo keeps its prior's design.
    Frozen,
}

/// `sledid seek`.
#[derive(clap::Args)]
pub struct Args {
    /// The plant the twin simulates (JSON; missing keys take the defaults). Default: the built-in
    /// nominal sled.
    #[arg(long)]
    pub plant: Option<PathBuf>,
    /// The plant the servo is designed from (JSON, its `plant` section), or `exact`: the `--plant`
    /// itself, trusted as an identified model (the seek law on the exact model). Default: the
    /// built-in nominal sled — never the `--plant` file.
    #[arg(long)]
    pub prior: Option<PathBuf>,
    /// Seeks.
    #[arg(long, default_value_t = 100)]
    pub seeks: u32,
    /// Seek distances MIN:MAX, tracks (log-uniform, random sign, within the travel).
    #[arg(long, default_value = DISTANCES)]
    pub distances: String,
    /// Seed of the seeks and the sensor noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The controller under test; today's reference-following servo always runs beside it.
    #[arg(long, value_enum, default_value = "seek")]
    pub controller: SeekControllerArg,
    /// Shortest dwell after each command (after the S-curve's arrival when following it), ms;
    /// lengthened on a slow sled to 3× the bound of the longest seek + 10 ms.
    #[arg(long, default_value_t = DWELL_MS)]
    pub dwell_ms: f64,
    /// `frozen`: the servo's identifier never adapts (with `--prior` the plant's own file, the
    /// seek law alone on the exact model).
    #[arg(long, value_enum, default_value = "online")]
    pub identification: IdentificationArg,
    /// The seek mode does not calibrate at power-on (`sledid::servo::calibration`; it calibrates
    /// by default, except with `--prior exact`): it starts seeking on the prior and identifies
    /// on-line.
    #[arg(long)]
    pub no_calibrate: bool,
    /// A fault injected into the servo's loop, repeatable: the replay's sensor faults (`spike`,
    /// `stuck`, `missing`, `nan`, `flip`), `drive-flip:from=K`, `mass:at=K,factor=F`,
    /// `friction:at=K,factor=F` (K counts from the first seek, after calibration; e.g.
    /// `--inject mass:at=10000,factor=0.4`). The summary line says what the servo did: the stop
    /// (reason, sample, seek, reading) or the re-calibrations.
    #[arg(long)]
    pub inject: Vec<String>,
    /// Output directory: summary.json, seek_vs_distance.png, seek_steps.png.
    #[arg(long)]
    pub out: PathBuf,
}

/// One controller's part of `summary.json`.
#[derive(Serialize)]
struct Part<'a> {
    summary: &'a SeekSummary,
    seeks: &'a [SeekRow],
}

/// `summary.json`.
#[derive(Serialize)]
struct Report<'a> {
    plant: &'a PlantParams,
    prior: &'a PlantParams,
    /// The `--inject` faults, as given.
    faults: &'a [String],
    schedule: &'a SeekOptions,
    /// The plant's bound from rest: (distance in tracks, ms).
    bound_curve: &'a [(f64, f64)],
    under_test: Part<'a>,
    /// Today's reference-following servo on the same seeks (absent when it is under test).
    reference_following: Option<Part<'a>>,
}

/// The seeks of `run` closest (in log distance) to 20, 200 and 2,000 tracks: short, medium, long.
fn picks(run: &SeekRun) -> Vec<usize> {
    let mut out = Vec::new();
    for want in [20.0_f64, 200.0, 2000.0] {
        let best = run.rows.iter().min_by(|a, b| {
            let e =
                |r: &SeekRow| ((r.distance_tracks.unsigned_abs() as f64).ln() - want.ln()).abs();
            e(a).total_cmp(&e(b))
        });
        if let Some(r) = best
            && !out.contains(&r.index)
        {
            out.push(r.index);
        }
    }
    out
}

/// Runs the command.
///
/// # Errors
/// Argument, parameter, run, file or plot errors, naming the argument or file.
pub fn run(a: &Args) -> Result<(), String> {
    let read =
        |p: &PathBuf| TwinParams::from_json_file(p).map_err(|e| format!("{}: {e}", p.display()));
    let params = a.plant.as_ref().map(read).transpose()?.unwrap_or_default();
    let exact_prior = super::is_exact_prior(a.prior.as_ref());
    let prior = match &a.prior {
        Some(_) if exact_prior => params.clone(),
        p => p.as_ref().map(read).transpose()?.unwrap_or_default(),
    };
    run_on(&params, &prior, exact_prior, a)
}

/// [`run`] on `params` (the twin) with the servo designed from `prior`'s plant (`exact_prior`:
/// `prior` is the plant itself, trusted as an identified model); `a`'s `plant` and `prior` are
/// not read (`sledid control` passes a perturbed plant).
///
/// # Errors
/// As [`run`].
pub fn run_on(
    params: &TwinParams,
    prior: &TwinParams,
    exact_prior: bool,
    a: &Args,
) -> Result<(), String> {
    let (min_tracks, max_tracks) = SeekOptions::parse_distances(&a.distances)?;
    if a.seeks == 0 {
        return Err("--seeks 0: need at least one seek".to_owned());
    }
    if !(a.dwell_ms.is_finite() && a.dwell_ms > 0.0) {
        return Err(format!("--dwell-ms {}: must be finite and > 0", a.dwell_ms));
    }
    let schedule = SeekOptions {
        seeks: a.seeks,
        min_tracks,
        max_tracks,
        seed: a.seed,
        dwell_s: a.dwell_ms * 1e-3,
        frozen: a.identification == IdentificationArg::Frozen,
        calibrate: !a.no_calibrate && !exact_prior,
    };
    let design = design_from_prior(params, &prior.plant)?;
    let under_test = match a.controller {
        SeekControllerArg::Seek if exact_prior => {
            SeekController::Seek(seek_design(design).with_trusted_prior())
        }
        SeekControllerArg::Seek => SeekController::Seek(seek_design(design)),
        SeekControllerArg::Baseline => SeekController::Baseline,
        SeekControllerArg::Reference => SeekController::Reference(design),
    };
    let faults: Vec<ServoFault> = a
        .inject
        .iter()
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let tested = run_seeks_with_faults(params, &under_test, &schedule, &faults)?;
    let reference = match under_test {
        SeekController::Reference(_) => None,
        _ => Some(run_seeks_with_faults(
            params,
            &SeekController::Reference(design),
            &schedule,
            &faults,
        )?),
    };
    let curve = bound_curve(&params.plant, min_tracks, max_tracks);
    let report = Report {
        plant: &params.plant,
        prior: &prior.plant,
        faults: &a.inject,
        schedule: &schedule,
        bound_curve: &curve,
        under_test: Part {
            summary: &tested.summary,
            seeks: &tested.rows,
        },
        reference_following: reference.as_ref().map(|r| Part {
            summary: &r.summary,
            seeks: &r.rows,
        }),
    };
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    let json = serde_json::to_string_pretty(&report).map_err(|e| e.to_string())?;
    let path = a.out.join("summary.json");
    std::fs::write(&path, json + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    let mut series = vec![(tested.controller.label(), tested.rows.as_slice())];
    let mut runs = vec![&tested];
    if let Some(r) = &reference {
        series.push((r.controller.label(), r.rows.as_slice()));
        runs.push(r);
    }
    plot::plot_seek_distance(
        &series,
        &curve,
        &format!(
            "{} seeks of {min_tracks}–{max_tracks} tracks (log-uniform), seed {}",
            a.seeks, a.seed
        ),
        &a.out.join("seek_vs_distance.png"),
    )?;
    plot::plot_seek_steps(&runs, &picks(&tested), &a.out.join("seek_steps.png"))?;
    if let Some(c) = &tested.run.calibration {
        println!("{}", c.line(params.plant.ts_s));
    }
    println!("{}", tested.summary.line());
    if let Some(r) = &reference {
        println!("{}", r.summary.line());
    }
    println!("→ {}", a.out.display());
    Ok(())
}
