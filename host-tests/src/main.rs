//! `sledid`: the host CLI. `sledid demo` (the README's first command) generates a sled-twin recording,
//! replays it sample by sample through the library's per-sample `step` (the function the firmware's
//! timer interrupt calls), runs the float64 reference beside it, and writes a trace and a summary.

use clap::{Parser, Subcommand};
use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::nonlinear::NonlinearStructure;
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, step};
use sledid::{Scaling, Status};
use sledid_host::compare::relative_distance;
use sledid_host::reference::batch::{rms_error, simulate};
use sledid_host::reference::linear::LinearF64;
use sledid_host::twin::{Twin, TwinParams};
use std::fmt::Write as _;
use std::path::PathBuf;
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
    Soak {
        /// Samples.
        #[arg(long, default_value_t = 10_000_000)]
        samples: u64,
        /// Seeks per twin chunk.
        #[arg(long, default_value_t = 200)]
        seeks_per_chunk: u32,
    },
    /// Simulate the sled in closed loop with the paper's baseline controller and write a recording
    /// (t_s, r_m, u_v, y_m) plus a JSON sidecar with every parameter and the seed.
    Twin {
        /// Seed of the seek schedule and the sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Plant, reference and controller parameters (JSON; missing keys take the defaults: the
        /// paper's badly tuned loop, `host-tests/plants/paper_sled.json`; the earlier well-damped
        /// baseline is `host-tests/plants/well_damped.json`).
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Number of seeks (overrides the file).
        #[arg(long)]
        seeks: Option<u32>,
        /// Output CSV; the sidecar is written next to it with the extension `.json`.
        #[arg(long, default_value = "out/twin.csv")]
        out: PathBuf,
    },
    /// Replay recordings through the per-sample step (the firmware's function) and its float64
    /// reference: DIR/NAME/trace.csv and summary.json. Several files run in parallel.
    Replay(Box<ReplayArgs>),
    /// The paper's linear identification procedure (ARX1, ARX2, OE1, OE2 at Ts and after ÷2) on a
    /// recording, or on a twin recording with the paper's protocol (`--twin`): DIR/study.json and
    /// PNG figures like the paper's.
    Study(Box<StudyArgs>),
    /// The firmware under QEMU in the loop with the twin, checked against the host (`cargo xtask pil`).
    Pil(sledid_host::pil::PilArgs),
    /// The twin in closed loop with the library's controller (baseline PID, or the gain-scheduled
    /// controller fed by the identifier): DIR/summary.json (settling, overshoot, limit-cycle
    /// pulses, unsettled seeks, fallbacks) and DIR/step_responses.png.
    Control {
        /// Plant, reference and baseline parameters (JSON; missing keys take the defaults). The
        /// scheduled controller is tuned on this plant.
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Run on a plant the controller was not tuned on: the --plant plant (or the default)
        /// scaled, e.g. `mass=0.7`, `friction=1.5,quantum=2` (mass, friction = Coulomb and
        /// static, quantum).
        #[arg(long)]
        perturb: Option<String>,
        /// Which controller.
        #[arg(long, value_enum, default_value = "scheduled")]
        controller: ControllerArg,
        /// Random seeks.
        #[arg(long, default_value_t = 100)]
        seeks: u32,
        /// Seed of the seeks and the sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Can this machine pace a replay at Ts? Spin on the clock doing nothing else and count the
    /// gaps (the thread not running): each gap of at least Ts is an overrun of any paced replay,
    /// whatever its per-sample cost. Prints a JSON report.
    PacingProbe {
        /// How long to spin, s.
        #[arg(long, default_value_t = 60.0)]
        seconds: f64,
        /// The sampling period to judge against, s.
        #[arg(long, default_value_t = 0.000455)]
        ts: f64,
    },
    /// Generate a twin recording, replay it through the fixed-point identifier and its float64
    /// reference, write DIR/trace.csv and DIR/summary.json.
    Demo {
        /// Twin seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Twin parameters (JSON). Default: the built-in twin, the paper's kind of badly tuned loop
        /// (oscillates while settling, ends in the ±1-quantum limit cycle;
        /// `host-tests/plants/paper_sled.json` writes it out).
        #[arg(long)]
        plant: Option<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
}

/// `--controller`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum ControllerArg {
    /// The paper's badly tuned PID.
    Baseline,
    /// The gain-scheduled controller with the on-line identifier.
    Scheduled,
}

#[derive(clap::Args)]
struct ReplayArgs {
    /// Recording(s): CSV or whitespace-separated.
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Column mapping by name or 0-based index, e.g. `u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s`.
    #[arg(long)]
    columns: String,
    /// Sampling period (s) when there is no time column (or to check the one there is).
    #[arg(long)]
    ts: Option<f64>,
    /// Model structure: linear (arx, oe = pseudo-linear OE, oe-pem = prediction-error OE) or one of
    /// the paper's nonlinear models (hammerstein = eq. 5, noe = eq. 6, noe221 = eq. 7, wiener,
    /// friction = friction feedback), which start from the linear OE model of their order.
    #[arg(long, default_value = "arx", value_parser = ["arx", "oe", "oe-pem", "hammerstein", "noe", "noe221", "wiener", "friction"])]
    model: String,
    /// A nonlinear model's initial linear part `f1[,f2],b1[,b2]` (default: identified first by a
    /// linear OE replay of the same file).
    #[arg(long)]
    init: Option<String>,
    /// Orders `na,nb`.
    #[arg(long, default_value = "2,2")]
    order: String,
    /// Conditioning of y (and u): centred (y − r), differenced (Δy, Δu), velocity (Δy, u), none.
    #[arg(long, default_value = "velocity", value_parser = ["centred", "differenced", "velocity", "none"])]
    conditioning: String,
    /// Position unit at the boundary, in the y column's unit (e.g. the sensor quantum).
    #[arg(long, default_value_t = 1.0)]
    y_unit: f64,
    /// Full-scale drive, in the u column's unit.
    #[arg(long, default_value_t = 1.0)]
    u_full_scale: f64,
    /// Forgetting factor λ ∈ (0, 1].
    #[arg(long, default_value_t = 0.995)]
    lambda: f64,
    /// Initial covariance P₀ = p0·I.
    #[arg(long, default_value_t = 10.0)]
    p0: f64,
    /// Trace limit on P (0: none).
    #[arg(long, default_value_t = 100.0)]
    trace_limit: f64,
    /// Dead zone on |ε| in y units (0: none).
    #[arg(long, default_value_t = 0.0)]
    dead_zone: f64,
    /// Outlier gate on |ε| in y units (0: none).
    #[arg(long, default_value_t = 0.0)]
    outlier: f64,
    /// Consecutive outliers after which the gate reopens.
    #[arg(long, default_value_t = 16)]
    outlier_limit: u16,
    /// Stuck-sensor check: samples of unchanged y while driven (0: off).
    #[arg(long, default_value_t = 0)]
    stuck_samples: u32,
    /// Stuck-sensor check: minimum |u| (fraction of full scale) for "driven".
    #[arg(long, default_value_t = 0.1)]
    stuck_drive: f64,
    /// Inject a fault: spike:at=N,mag=M[,every=K] | stuck:from=N,len=L | missing:from=N,len=L |
    /// nan:at=N | flip:from=N (repeatable).
    #[arg(long)]
    inject: Vec<String>,
    /// What to do with a sample that cannot enter the fixed-point path: stop (error naming it) or
    /// hold (freeze the estimator for it, flag it, go on).
    #[arg(long, default_value = "stop", value_parser = ["stop", "hold"])]
    on_bad_sample: String,
    /// realtime, max, or a factor of real time.
    #[arg(long, default_value = "max")]
    rate: String,
    /// Output directory.
    #[arg(long, default_value = "out/replay")]
    out: PathBuf,
}

fn replay_cmd(a: &ReplayArgs) -> Result<(), String> {
    use rayon::prelude::*;
    use sledid_host::recording::ReaderOptions;
    use sledid_host::replay::{ReplaySpec, replay};
    let mapping = a.columns.parse().map_err(|e| format!("--columns: {e}"))?;
    let mut reader = ReaderOptions::new(mapping);
    reader.ts_s = a.ts;
    let mut spec = ReplaySpec::new(reader);
    spec.structure = match a.model.as_str() {
        "oe" => Structure::OutputErrorPseudoLinear,
        "oe-pem" => Structure::OutputErrorPredictionError,
        _ => Structure::Arx,
    };
    spec.nonlinear = NonlinearStructure::ALL
        .into_iter()
        .find(|s| s.name() == a.model);
    if let Some(init) = &a.init {
        let v: Vec<f64> = init
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| format!("--init `{init}`: expected numbers f1[,f2],b1[,b2]"))?;
        spec.nonlinear_init = Some(v);
    }
    let order: Vec<usize> = a
        .order
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("--order `{}`: expected na,nb", a.order))
        })
        .collect::<Result<_, _>>()?;
    let [na, nb] = order[..] else {
        return Err(format!("--order `{}`: expected na,nb", a.order));
    };
    spec.order = (na, nb);
    spec.conditioning = match a.conditioning.as_str() {
        "centred" => Conditioning::CentredOnReference,
        "differenced" => Conditioning::Differenced,
        "none" => Conditioning::None,
        _ => Conditioning::DifferencedOutput,
    };
    spec.y_unit = a.y_unit;
    spec.u_full_scale = a.u_full_scale;
    spec.rls = RlsDesign {
        lambda: a.lambda,
        p0: a.p0,
        dead_zone: a.dead_zone,
        anti_windup: if a.trace_limit > 0.0 {
            AntiWindup::TraceLimit { max: a.trace_limit }
        } else {
            AntiWindup::None
        },
        ..RlsDesign::default()
    };
    spec.rls.outlier_threshold = a.outlier;
    spec.rls.outlier_limit = a.outlier_limit;
    spec.stuck_sensor = (a.stuck_samples > 0).then_some(sledid::ident::step::StuckSensorDesign {
        samples: a.stuck_samples,
        min_drive: a.stuck_drive,
    });
    spec.faults = a
        .inject
        .iter()
        .map(|f| f.parse())
        .collect::<Result<_, _>>()?;
    spec.on_bad_sample = if a.on_bad_sample == "hold" {
        sledid_host::replay::BadSample::Hold
    } else {
        sledid_host::replay::BadSample::Stop
    };
    spec.rate = a.rate.parse()?;
    spec.progress = a.files.len() == 1;
    let results: Vec<Result<(), String>> = a
        .files
        .par_iter()
        .map(|f| {
            let stem = f.file_stem().map_or_else(|| "recording".into(), |s| s.to_string_lossy().into_owned());
            let dir = a.out.join(stem);
            let s = replay(f, &spec, &dir)?;
            let mut line = format!(
                "{}: {} samples in {:.3} s | θ {:?} | θ_f64 {:?} (rel. {:.1e}) | sim RMS {:.4} (f64 {:.4})",
                s.file, s.samples, s.wall_s, s.theta, s.theta_f64, s.theta_rel_err, s.sim_rms, s.sim_rms_f64
            );
            if let Some(d) = s.deadline {
                line += &format!(
                    " | lateness p50 {:.1} µs p99 {:.1} µs max {:.1} µs, overruns {} ({} after \
                     host stalls: {} stalls, longest {:.0} µs) | work p99 {:.1} µs max {:.1} µs",
                    d.p50_us,
                    d.p99_us,
                    d.max_us,
                    d.overruns,
                    d.overruns_after_stall,
                    d.stalls.count,
                    d.stalls.max_us,
                    d.work_p99_us,
                    d.work_max_us
                );
            }
            println!("{line}\n  → {}", dir.display());
            Ok(())
        })
        .collect();
    results.into_iter().collect()
}

fn twin_cmd(
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
    Ok(())
}

#[derive(clap::Args)]
struct StudyArgs {
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
    /// Output directory: study.json, fig*.png (and twin.csv with `--twin`).
    #[arg(long, default_value = "out/study")]
    out: PathBuf,
}

fn study_cmd(a: &StudyArgs) -> Result<(), String> {
    use sledid_host::study::{self, StudyInput, StudyOptions};
    let options = StudyOptions {
        centring: a.centre,
        nonlinear_ridge: a.ridge,
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

fn pacing_probe(seconds: f64, ts: f64) -> Result<(), String> {
    if !(seconds.is_finite() && seconds > 0.0 && ts.is_finite() && ts > 0.0) {
        return Err(format!(
            "pacing-probe: --seconds ({seconds}) and --ts ({ts}) must be positive"
        ));
    }
    let r = sledid_host::pacing::probe(seconds, ts);
    let mut j = serde_json::to_value(r).map_err(|e| e.to_string())?;
    if let Some(o) = j.as_object_mut() {
        o.insert(
            "gaps_over_ts_per_minute".into(),
            r.gaps_over_ts_per_minute().into(),
        );
    }
    println!(
        "{}",
        serde_json::to_string_pretty(&j).map_err(|e| e.to_string())?
    );
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command.unwrap_or(Command::Demo {
        seed: 1,
        plant: None,
        out: PathBuf::from("out/demo"),
    }) {
        Command::Demo { seed, plant, out } => demo(seed, plant.as_deref(), &out),
        Command::Pil(args) => sledid_host::pil::pil_cmd(&args),
        Command::Control {
            plant,
            perturb,
            controller,
            seeks,
            seed,
            out,
        } => perturb
            .as_deref()
            .map(sledid_host::control_eval::Perturbation::parse)
            .transpose()
            .and_then(|perturb| {
                sledid_host::control_eval::control_cmd(
                    plant.as_deref(),
                    perturb,
                    match controller {
                        ControllerArg::Baseline => {
                            sledid_host::control_eval::ControllerKind::Baseline
                        }
                        ControllerArg::Scheduled => {
                            sledid_host::control_eval::ControllerKind::Scheduled
                        }
                    },
                    seeks,
                    seed,
                    &out,
                )
            }),
        Command::Replay(args) => replay_cmd(&args),
        Command::Study(args) => study_cmd(&args),
        Command::Soak {
            samples,
            seeks_per_chunk,
        } => sledid_host::soak::soak(samples, seeks_per_chunk, true)
            .and_then(|r| serde_json::to_string_pretty(&r).map_err(|e| e.to_string()))
            .map(|j| println!("{j}")),
        Command::Twin {
            seed,
            plant,
            seeks,
            out,
        } => twin_cmd(seed, plant.as_deref(), seeks, &out),
        Command::PacingProbe { seconds, ts } => pacing_probe(seconds, ts),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sledid: {e}");
            ExitCode::FAILURE
        }
    }
}
