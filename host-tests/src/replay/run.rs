//! One replay's per-sample loop, whatever the model: each sample read, faulted and converted at
//! the boundary, stepped (or held), paced ([`Pacer`]), traced ([`TraceWriter`]) and fed to the
//! float64 twin ([`Reference`]); then the summary, written as `summary.json`.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde_json::json;
use sledid::ident::conditioning::Conditioning;
use sledid::ident::estimator::{Estimator, EstimatorDesign};
use sledid::ident::nonlinear::InputRanges;
use sledid::ident::step::{IdentifierConfig, IdentifierDesign, IdentifierState, StepOutput};
use sledid::ident::step::{reject, step};
use sledid::{Normalisation, Scaling, Status};

use super::pacer::Pacer;
use super::reference::Reference;
use super::trace::TraceWriter;
use super::{BadSample, Deadlines, Rate, ReplaySpec, ReplaySummary, Units};
use crate::compare::relative_distance;
use crate::faults::{Injector, Reading};
use crate::recording::{RecordingReader, Sample};
use crate::reference::batch::rms_error;
use crate::reference::units::{ModelKind, factors, to_user};

/// Replays `file` through `model` with its float64 twin `reference` into `out`: `label` names
/// the model in the summary; `units` are the boundary's, `kind` maps θ back to the user's.
///
/// # Errors
/// As [`super::replay`].
pub(super) fn replay_model<const N: usize, D: EstimatorDesign<N>, R: Reference<N>>(
    file: &Path,
    spec: &ReplaySpec,
    out: &Path,
    model: D,
    reference: R,
    label: String,
    (units, kind): (Units, ModelKind),
) -> Result<ReplaySummary, String> {
    let norm = units.norm;
    let cfg = identifier(spec, model, norm)?;
    let mut reader = open_reader(file, spec)?;
    let ts_s = reader.meta().ts_s;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    // The trace and the summary are in the user's units (`super`'s doc, *Units*).
    let factors_back = (norm.y_factor(), norm.u_factor());
    let mut trace = TraceWriter::create(out, factors_back, factors(kind, N, norm))?;
    let mut boundary = Boundary::new(file, spec, units.scaling);
    let mut st = cfg.new_state();
    let mut tally = Tally::new(reference);
    let bar = progress_bar(spec.progress);
    let start = Instant::now();
    let mut pacer = period(spec.rate, ts_s).map(|p| Pacer::new(p, start));
    let mut n = 0usize;
    for (k, item) in reader.by_ref().enumerate() {
        let s = item.map_err(|e| e.to_string())?;
        if let Some(p) = pacer.as_mut() {
            p.wait_for(k);
        }
        let o = boundary.step(&cfg, &mut st, k, &s)?;
        if let Some(p) = pacer.as_mut() {
            p.done(k);
        }
        tally.record(&o);
        trace.line(&s, &o)?;
        n += 1;
        if let Some(b) = &bar
            && n.is_multiple_of(4096)
        {
            b.set_position(n as u64);
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    trace.finish()?;
    let theta = cfg
        .model()
        .theta(st.model())
        .iter()
        .map(|p| p.to_f64())
        .collect();
    let facts = RunFacts {
        file,
        samples: n,
        ts_s,
        rate: spec.rate,
        wall_s,
        label,
        deadline: pacer.map(|p| p.deadlines()),
    };
    let summary = tally.summary::<N>(facts, theta, kind, norm);
    write_summary(out, &summary)?;
    Ok(summary)
}

/// The identifier of `model` under `spec`'s conditioning, its stuck-sensor check's drive moved
/// into the normalised units.
fn identifier<const N: usize, D: EstimatorDesign<N>>(
    spec: &ReplaySpec,
    model: D,
    norm: Normalisation,
) -> Result<IdentifierConfig<N, D::Config>, String> {
    let mut design = IdentifierDesign::new(spec.conditioning, model);
    design.stuck_sensor = spec.stuck_sensor.map(|mut d| {
        d.min_drive /= norm.u_factor();
        d
    });
    design.build().map_err(|e| format!("configuration: {e}"))
}

/// The recording's reader; refuses a conditioning on the reference without a reference column.
fn open_reader(file: &Path, spec: &ReplaySpec) -> Result<RecordingReader, String> {
    let needs_r = spec.conditioning == Conditioning::CentredOnReference;
    if needs_r && spec.reader.mapping.reference.is_none() {
        return Err("conditioning centred-on-reference needs a reference column (r=…)".into());
    }
    RecordingReader::open(file, &spec.reader).map_err(|e| e.to_string())
}

/// The sample period at `rate` (`None`: as fast as possible).
fn period(rate: Rate, ts_s: f64) -> Option<Duration> {
    match rate {
        Rate::Max => None,
        Rate::Paced(f) => Some(Duration::from_secs_f64(ts_s / f)),
    }
}

/// A counter of the samples replayed, on terminals only (the reader streams: the length is
/// unknown).
fn progress_bar(progress: bool) -> Option<indicatif::ProgressBar> {
    (progress && std::io::stderr().is_terminal()).then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {elapsed_precise} {pos} samples replayed",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        b
    })
}

/// The way from a recorded sample to the step: the injected faults, the boundary's conversion,
/// and what a sample that cannot enter the fixed-point path does.
struct Boundary<'a> {
    /// The recording, for errors.
    file: &'a Path,
    /// The injected faults.
    injector: Injector,
    /// The boundary's conversion.
    scaling: Scaling,
    /// Stop, or hold the estimator.
    on_bad_sample: BadSample,
}

impl<'a> Boundary<'a> {
    fn new(file: &'a Path, spec: &ReplaySpec, scaling: Scaling) -> Self {
        Self {
            file,
            injector: Injector::new(spec.faults.clone()),
            scaling,
            on_bad_sample: spec.on_bad_sample,
        }
    }

    /// Sample `k` (`s` as recorded) through the faults and the boundary into the step, or held.
    ///
    /// # Errors
    /// With [`BadSample::Stop`], a sample the boundary rejects or a lost reading, named.
    fn step<const N: usize, M: Estimator<N>>(
        &mut self,
        cfg: &IdentifierConfig<N, M>,
        st: &mut IdentifierState<N, M::State>,
        k: usize,
        s: &Sample,
    ) -> Result<StepOutput<N>, String> {
        let converted = match self.injector.apply(k, *s) {
            Reading::Present(x) => self
                .scaling
                .sample(x.y, x.u, x.r.unwrap_or(0.0))
                .map_err(|e| format!("{}: sample {k} (t = {} s): {e}", self.file.display(), s.t_s)),
            Reading::Missing => Err(format!(
                "{}: sample {k} (t = {} s): reading lost",
                self.file.display(),
                s.t_s
            )),
        };
        match (converted, self.on_bad_sample) {
            (Ok(sample), _) => Ok(step(cfg, st, &sample)),
            (Err(e), BadSample::Stop) => Err(e),
            (Err(_), BadSample::Hold) => Ok(reject(cfg, st)),
        }
    }
}

/// What the summary is computed from besides the model: the float64 twin fed the same
/// conditioned samples, those samples, and the count of every status flag.
struct Tally<R> {
    /// The float64 twin.
    reference: R,
    /// The conditioned y of every sample the estimator used.
    ys: Vec<f64>,
    /// The conditioned u of the same samples.
    us: Vec<f64>,
    /// Samples carrying each flag of [`Status::NAMES`].
    counts: [usize; Status::NAMES.len()],
}

/// The run's facts the summary reports.
struct RunFacts<'a> {
    file: &'a Path,
    samples: usize,
    ts_s: f64,
    rate: Rate,
    wall_s: f64,
    label: String,
    deadline: Option<Deadlines>,
}

impl<R> Tally<R> {
    fn new(reference: R) -> Self {
        Self {
            reference,
            ys: Vec::new(),
            us: Vec::new(),
            counts: [0; Status::NAMES.len()],
        }
    }

    /// One step's output: its flags counted; past warm-up and unless rejected, its conditioned
    /// sample kept and fed to the twin.
    fn record<const N: usize>(&mut self, o: &StepOutput<N>)
    where
        R: Reference<N>,
    {
        for (c, (flag, _)) in self.counts.iter_mut().zip(Status::NAMES.iter()) {
            *c += usize::from(o.status.contains(*flag));
        }
        if !o.status.intersects(Status::WARMUP | Status::INPUT_REJECTED) {
            self.reference.step(o.y.to_f64(), o.u.to_f64());
            self.ys.push(o.y.to_f64());
            self.us.push(o.u.to_f64());
        }
    }

    /// Largest |u|, |y|, |Δy| of the conditioned samples kept (floored: 10⁻³, 1, 1).
    fn ranges(&self) -> InputRanges {
        let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let dy: Vec<f64> = self.ys.windows(2).map(|w| w[1] - w[0]).collect();
        InputRanges {
            u: max_abs(&self.us).max(1e-3),
            y: max_abs(&self.ys).max(1.0),
            dy: max_abs(&dy).max(1.0),
        }
    }

    /// The summary of a run whose fixed-point path ended at `theta` (normalised units).
    fn summary<const N: usize>(
        self,
        facts: RunFacts<'_>,
        theta: Vec<f64>,
        kind: ModelKind,
        norm: Normalisation,
    ) -> ReplaySummary
    where
        R: Reference<N>,
    {
        let ky = norm.y_factor();
        let theta_f64 = self.reference.theta();
        let sim_rms = |th: &[f64]| rms_error(&self.reference.simulate(th, &self.us), &self.ys) * ky;
        ReplaySummary {
            file: facts.file.display().to_string(),
            samples: facts.samples,
            ts_s: facts.ts_s,
            rate: match facts.rate {
                Rate::Max => "max".into(),
                Rate::Paced(f) => format!("{f}"),
            },
            wall_s: facts.wall_s,
            model: facts.label,
            theta_rel_err: relative_distance(&theta, &theta_f64),
            sim_rms: sim_rms(&theta),
            sim_rms_f64: sim_rms(&theta_f64),
            ranges: self.ranges(),
            theta: to_user(kind, &theta, norm),
            theta_f64: to_user(kind, &theta_f64, norm),
            theta_normalised: theta,
            normalisation: [ky, norm.u_factor()],
            flags: Status::NAMES
                .iter()
                .zip(self.counts.iter())
                .map(|((_, name), c)| ((*name).to_owned(), *c))
                .collect(),
            deadline: facts.deadline,
        }
    }
}

/// `out/summary.json`.
fn write_summary(out: &Path, summary: &ReplaySummary) -> Result<(), String> {
    let text = serde_json::to_string_pretty(&json!(summary)).map_err(|e| e.to_string())?;
    let summary_path: PathBuf = out.join("summary.json");
    std::fs::write(&summary_path, text).map_err(|e| format!("{}: {e}", summary_path.display()))
}
