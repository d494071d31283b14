//! `sledid study`: the paper's identification procedure on a recording, or on a twin recording
//! with the paper's protocol: study.json and the paper's figures.

use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Recording with the identification segment (not with `--twin`).
    #[arg(required_unless_present = "twin", conflicts_with = "twin")]
    file: Option<PathBuf>,
    /// Generate a twin recording (default parameters, `--seed`) into DIR and use the paper's
    /// protocol: identification on the settling of seek 0, validation on seek 1.
    #[arg(long)]
    twin: bool,
    /// Twin seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Samples per window with `--twin`.
    #[arg(long, default_value_t = 100)]
    twin_window: usize,
    /// Twin parameters with `--twin` (JSON, e.g. `host-tests/plants/well_damped.json`); default:
    /// the built-in twin, the paper's kind of badly tuned loop.
    #[arg(long, requires = "twin")]
    plant: Option<PathBuf>,
    /// Column mapping by name or 0-based index, e.g. `u=u_v,y=y_m,r=r_m,t=t_s`.
    #[arg(long, required_unless_present = "twin", conflicts_with = "twin")]
    columns: Option<String>,
    /// Identification segment A:B (sample indices, B exclusive).
    #[arg(long, required_unless_present = "twin", conflicts_with = "twin")]
    ident: Option<sledid_host::study::Segment>,
    /// Validation segment C:D (sample indices, D exclusive).
    #[arg(long, required_unless_present = "twin", conflicts_with = "twin")]
    valid: Option<sledid_host::study::Segment>,
    /// Recording with the validation segment (default: FILE).
    #[arg(long, conflicts_with = "twin")]
    valid_file: Option<PathBuf>,
    /// Sampling period (s) when there is no time column (or to check the one there is).
    #[arg(long)]
    ts: Option<f64>,
    /// Unit of y in the y column's unit (y and r are divided by it): the sensor quantum, e.g.
    /// 1.6e-6, for figures in quanta as in the paper; or any scale, e.g. 0.001 for V → mV.
    #[arg(long, default_value_t = 1.0)]
    y_unit: f64,
    /// Name of that unit in the table and plots, e.g. `quanta` or `mV`; default: "Y × y-column
    /// unit" (Y the --y-unit).
    #[arg(long, conflicts_with = "twin")]
    y_unit_name: Option<String>,
    /// Factor from the u column to volts.
    #[arg(long, default_value_t = 1.0)]
    u_scale: f64,
    /// Centring of each segment: auto (final-reference if r is mapped, else last-output),
    /// final-reference, mean-reference, last-output, none.
    #[arg(long, default_value = "auto")]
    centre: sledid_host::study::Centring,
    /// Ridge δ of the nonlinear fits: δ‖θ − θ₀‖² added to the simulation SSE (0: the paper's
    /// criterion); pulls the neurons toward the linear start on short records.
    #[arg(long, default_value_t = 0.0)]
    ridge: f64,
    /// Seeded random starts of each nonlinear fit besides the linear start (the fit with the
    /// lowest identification SSE, plus the ridge term, is kept).
    #[arg(long, default_value_t = 4)]
    starts: usize,
    /// Seed of the random starts.
    #[arg(long, default_value_t = 1)]
    start_seed: u64,
    /// Output directory: study.json, fig*.png (and twin.csv with `--twin`).
    #[arg(long, default_value = "out/study")]
    out: PathBuf,
}

/// Runs the command.
///
/// # Errors
/// Argument, file or fit errors.
pub fn run(a: &Args) -> Result<(), String> {
    use sledid_host::study::{self, StudyInput, StudyOptions};
    let options = StudyOptions {
        centring: a.centre,
        nonlinear_ridge: a.ridge,
        random_starts: a.starts,
        start_seed: a.start_seed,
        ..StudyOptions::default()
    };
    let study = match (&a.file, &a.columns, a.ident, a.valid) {
        _ if a.twin => {
            let params = match &a.plant {
                Some(p) => {
                    sledid_host::twin::TwinParams::from_json_file(p).map_err(|e| e.to_string())?
                }
                None => sledid_host::twin::TwinParams::default(),
            };
            study::protocol::run_twin_with(params, a.seed, a.twin_window, &a.out, options)
        }
        (Some(file), Some(columns), Some(ident), Some(valid)) => study::run_files(&StudyInput {
            ident_file: file.clone(),
            valid_file: a.valid_file.clone(),
            columns: columns.clone(),
            ts_s: a.ts,
            y_unit: a.y_unit,
            y_unit_name: a.y_unit_name.clone(),
            u_scale: a.u_scale,
            ident,
            valid,
            options,
        }),
        _ => return Err("study: FILE, --columns, --ident and --valid (or --twin)".to_owned()),
    };
    let mut study = study.map_err(|e| e.to_string())?;
    let files = study::write_outputs(&mut study, &a.out).map_err(|e| e.to_string())?;
    println!("{}\n", study.header());
    print!("{}", study.table());
    for note in &study.notes {
        println!("note: {note}");
    }
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
