//! `sledid replay`: recordings through the per-sample step (the firmware's function) and its
//! float64 reference; several files in parallel.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::Structure;
use sledid::ident::nonlinear::NonlinearStructure;
use sledid::ident::rls::{AntiWindup, RlsDesign};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
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
    /// Trace limit on P (0: none) [default: 100 for the linear models in your units; 0.3 for the
    /// nonlinear ones, in normalised units where θ is of order 1 (tests/integration/nonlinear_units.rs)].
    #[arg(long)]
    trace_limit: Option<f64>,
    /// Dead zone on |ε| in y units (0: none).
    #[arg(long, default_value_t = 0.0)]
    dead_zone: f64,
    /// Outlier gate on |ε| in y units (0: none).
    #[arg(long, default_value_t = 0.0)]
    outlier: f64,
    /// Consecutive outliers after which the gate reopens.
    #[arg(long, default_value_t = 16)]
    outlier_limit: u16,
    /// Units at the boundary: `auto` normalises for the nonlinear models (ranges from a first pass
    /// over the file become fixed targets; θ, trace and RMS reported in your units), `on` for
    /// every model, `off`, or the targets `Y,U` (the normalised ranges of y and u).
    #[arg(long, default_value = "auto")]
    normalise: String,
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

/// Runs the command.
///
/// # Errors
/// Argument, file or replay errors.
pub fn run(a: &Args) -> Result<(), String> {
    use rayon::prelude::*;
    use sledid_host::recording::ReaderOptions;
    use sledid_host::replay::{Normalise, ReplaySpec, replay};
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
    spec.normalise = match a.normalise.as_str() {
        "auto" => Normalise::Auto,
        "on" => Normalise::On,
        "off" => Normalise::Off,
        t => {
            let v: Vec<f64> = t
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("--normalise `{t}`: expected auto, on, off or Y,U"))?;
            let [y, u] = v[..] else {
                return Err(format!("--normalise `{t}`: expected auto, on, off or Y,U"));
            };
            Normalise::Targets { y, u }
        }
    };
    spec.y_unit = a.y_unit;
    spec.u_full_scale = a.u_full_scale;
    let trace_limit = a.trace_limit.unwrap_or(if spec.nonlinear.is_some() {
        sledid_host::replay::NONLINEAR_TRACE_LIMIT
    } else {
        100.0
    });
    spec.rls = RlsDesign {
        lambda: a.lambda,
        p0: a.p0,
        dead_zone: a.dead_zone,
        anti_windup: if trace_limit > 0.0 {
            AntiWindup::TraceLimit { max: trace_limit }
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
