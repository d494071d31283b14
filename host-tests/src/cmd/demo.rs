//! `sledid demo` (the README's first command): generates a sled-twin recording, replays it sample
//! by sample through the library's per-sample `step` (the function the firmware's timer interrupt
//! calls), runs the float64 reference beside it, writes a trace and a summary, and runs the
//! paper's study on the same twin; then the product on the same sled: power-on calibration and
//! seek commands in the seek mode, access time against the minimum-time bound.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, step};
use sledid::{Scaling, Status};
use sledid_host::compare::relative_distance;
use sledid_host::control::seek::{
    SeekController, SeekOptions, bound_curve, run_seeks, seek_design,
};
use sledid_host::control::{design_from_prior, plot};
use sledid_host::reference::batch::{rms_error, simulate};
use sledid_host::reference::linear::LinearF64;
use sledid_host::twin::{PlantParams, Twin, TwinParams};
use std::fmt::Write as _;
use std::path::PathBuf;

/// `sledid demo`.
#[derive(clap::Args)]
pub struct Args {
    /// Twin seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Twin parameters (JSON). Default: the built-in twin, the paper's kind of badly tuned loop
    /// (oscillates while settling, ends in the ±1-quantum limit cycle;
    /// `host-tests/plants/paper_sled.json` writes it out).
    #[arg(long)]
    pub plant: Option<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
}

impl Default for Args {
    fn default() -> Self {
        Self {
            seed: 1,
            plant: None,
            out: PathBuf::from("out/demo"),
        }
    }
}

/// Runs the command.
///
/// # Errors
/// Parameter, replay, study or file errors.
pub fn run(a: &Args) -> Result<(), String> {
    demo(a.seed, a.plant.as_deref(), &a.out)
}

/// The identifier the demo runs: velocity against drive (the sled integrates), ARX(2,2), λ = 0.995,
/// trace limit.
fn demo_design() -> IdentifierDesign<4> {
    let mut model = LinearDesign::<4>::new(Structure::Arx, 2, 2);
    model.rls = RlsDesign {
        lambda: 0.995,
        p0: 10.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    };
    IdentifierDesign::new(Conditioning::DifferencedOutput, model)
}

fn demo(seed: u64, plant: Option<&std::path::Path>, out: &PathBuf) -> Result<(), String> {
    let params = match plant {
        Some(p) => TwinParams::from_json_file(p).map_err(|e| e.to_string())?,
        None => TwinParams::default(),
    };
    let twin = Twin::run_baseline(params.clone(), seed).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let csv_path = out.join("twin.csv");
    twin.write_csv(&csv_path).map_err(|e| e.to_string())?;

    let scaling =
        Scaling::new(params.plant.quantum_m, params.plant.u_max_v).map_err(|e| e.to_string())?;
    let design = demo_design();
    let cfg = design.build().map_err(|e| e.to_string())?;
    let mut st = cfg.new_state();
    let mut reference = LinearF64::new(&design.model);
    let mut trace = String::from("t_s,y_c,u_c,y_hat,eps,a1,a2,b1,b2,flags\n");
    let (mut ys, mut us) = (Vec::new(), Vec::new());
    let mut counts = [0usize; Status::NAMES.len()];
    let mut max_rel = 0.0f64;
    let started = std::time::Instant::now();
    for (t, s) in twin.samples().iter().enumerate() {
        let sample = scaling
            .sample(s.y_m, s.u_v, s.r_m)
            .map_err(|e| format!("sample {t}: {e}"))?;
        let o = step(&cfg, &mut st, &sample);
        for (c, (flag, _)) in counts.iter_mut().zip(Status::NAMES.iter()) {
            *c += usize::from(o.status.contains(*flag));
        }
        if o.status.contains(Status::WARMUP) {
            continue;
        }
        reference.step(o.y.to_f64(), o.u.to_f64());
        ys.push(o.y.to_f64());
        us.push(o.u.to_f64());
        let th: Vec<f64> = o.theta.iter().map(|p| p.to_f64()).collect();
        if t > 200 {
            max_rel = max_rel.max(relative_distance(&th, reference.theta()));
        }
        let _ = writeln!(
            trace,
            "{:.6},{},{},{},{},{},{},{},{},{}",
            s.t_s,
            o.y.to_f64(),
            o.u.to_f64(),
            o.y_hat.to_f64(),
            o.eps.to_f64(),
            th[0],
            th[1],
            th[2],
            th[3],
            o.status.bits()
        );
    }
    let wall_s = started.elapsed().as_secs_f64();
    std::fs::write(out.join("trace.csv"), trace).map_err(|e| e.to_string())?;
    let theta: Vec<f64> = st.model().theta().iter().map(|p| p.to_f64()).collect();
    let theta_f64 = reference.theta().to_vec();
    let rms_fx = rms_error(&simulate(&theta, &us, 2, 1), &ys);
    let rms_f64 = rms_error(&simulate(&theta_f64, &us, 2, 1), &ys);
    let flags: serde_json::Map<String, serde_json::Value> = Status::NAMES
        .iter()
        .zip(counts.iter())
        .map(|((_, name), c)| ((*name).to_owned(), (*c).into()))
        .collect();
    let summary = serde_json::json!({
        "recording": csv_path.display().to_string(),
        "samples": twin.samples().len(),
        "ts_s": params.plant.ts_s,
        "rate": "max",
        "wall_s": wall_s,
        "model": "ARX(2,2) on Δy (quanta/sample) against u (fraction of full scale)",
        "theta": theta,
        "theta_f64": theta_f64,
        "max_rel_theta_err_vs_f64": max_rel,
        "sim_rms": rms_fx,
        "sim_rms_f64": rms_f64,
        "flags": flags,
    });
    let text = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
    std::fs::write(out.join("summary.json"), text).map_err(|e| e.to_string())?;

    println!(
        "sled twin, seed {seed}: {} samples at Ts = {} ms",
        twin.samples().len(),
        params.plant.ts_s * 1e3
    );
    println!(
        "identifier: {}, replayed in {:.3} s",
        summary["model"].as_str().unwrap_or(""),
        wall_s
    );
    println!();
    println!("| parameter | fixed point | float64 |");
    println!("|---|---|---|");
    for (name, (a, b)) in ["a1", "a2", "b1", "b2"]
        .iter()
        .zip(theta.iter().zip(theta_f64.iter()))
    {
        println!("| {name} | {a:.6} | {b:.6} |");
    }
    println!("| simulation RMS (quanta/sample) | {rms_fx:.4} | {rms_f64:.4} |");
    println!();
    println!("max relative θ distance to float64 over the record: {max_rel:.2e}");
    println!(
        "wrote {}, {}/trace.csv, {}/summary.json",
        csv_path.display(),
        out.display(),
        out.display()
    );

    // The paper's study on the same twin: ~100 settling samples of one seek to identify, of the next
    // to validate, every linear and nonlinear model at Ts and after ÷2, the paper's figures beside.
    let study_dir = out.join("study");
    let mut study = sledid_host::study::protocol::run_twin_with(
        params.clone(),
        seed,
        sledid_host::study::protocol::PAPER_WINDOW,
        &study_dir,
        sledid_host::study::StudyOptions::default(),
    )
    .map_err(|e| e.to_string())?;
    let files =
        sledid_host::study::write_outputs(&mut study, &study_dir).map_err(|e| e.to_string())?;
    println!();
    println!("{}", study.header());
    println!("{}", study.table());
    for note in &study.notes {
        println!("note: {note}");
    }
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    println!("plots: {}", names.join(", "));
    product_seeks(&params, seed, &out.join("seek"))
}

/// The product on the same sled: the servo designed from the nominal prior calibrates at power-on
/// (`sledid::servo::calibration`), then runs [`PRODUCT_SEEKS`] seek commands in its seek mode;
/// access time against the sled's minimum-time bound, one figure (`seek/seek_vs_distance.png`)
/// and `seek/summary.json`.
fn product_seeks(params: &TwinParams, seed: u64, out: &std::path::Path) -> Result<(), String> {
    let schedule = SeekOptions {
        seeks: PRODUCT_SEEKS,
        seed,
        calibrate: true,
        ..SeekOptions::default()
    };
    let design = design_from_prior(params, &PlantParams::default())?;
    let run = run_seeks(
        params,
        &SeekController::Seek(seek_design(design)),
        &schedule,
    )?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let json = serde_json::to_string_pretty(&serde_json::json!({
        "summary": run.summary,
        "seeks": run.rows,
    }))
    .map_err(|e| e.to_string())?;
    std::fs::write(out.join("summary.json"), json + "\n").map_err(|e| e.to_string())?;
    let curve = bound_curve(&params.plant, schedule.min_tracks, schedule.max_tracks);
    let figure = out.join("seek_vs_distance.png");
    plot::plot_seek_distance(
        &[(run.controller.label(), run.rows.as_slice())],
        &curve,
        &format!(
            "calibrated at power-on, then {PRODUCT_SEEKS} seeks of {}–{} tracks, seed {seed}",
            schedule.min_tracks, schedule.max_tracks
        ),
        &figure,
    )?;
    println!();
    println!("the servo (seek mode, designed from the nominal prior):");
    if let Some(c) = &run.run.calibration {
        println!("{}", c.line(params.plant.ts_s));
    }
    println!("{}", run.summary.line());
    println!("plot: {}", figure.display());
    Ok(())
}

/// Seek commands of the demo's product run.
pub const PRODUCT_SEEKS: u32 = 40;
