//! The paper's nonlinear models in fixed point against their float64 twin, in any unit and on
//! recordings and excitations they were not tuned on (issue 17).
//!
//! The replay normalises the units at the boundary (`sledid::Normalisation`: the recording's own
//! ranges become fixed targets), so the unit a user picks for y or u cannot change what the
//! fixed-point path computes: [`the_same_recording_in_any_unit_gives_the_same_model`]. Whether the
//! fixed point then means what its float64 twin means is measured per recording, per structure:
//! [`fixed_point_tracks_float64_on_real_recordings`], [`fixed_point_tracks_float64_under_any_excitation`].
//!
//! A recursive prediction-error fit of a neuron is not always a well-posed computation: on some
//! records the float64 twin itself ends at a model whose simulation RMS moves by several per cent
//! when the data move slightly (a neuron's output weight passing through 0, where its input weight
//! and bias are not identifiable and the path picks one of the two mirror solutions (w, a, c) ~
//! (−w, −a, −c); a bias drifting into saturation). There no finite-precision implementation can
//! stay within 2 % of it, so each case is first checked for that: the float64 twin is run again
//! with the normalisation's targets moved by ±10⁻⁴ (y up and u down, then the reverse — the size
//! of the fixed point's own departure from the twin in θ, 10⁻⁴–10⁻³, is what matters; 10⁻⁶ missed
//! mirror-solution splits) and the case counts as *well-posed* when its RMS moves by less than
//! 0.5 % and its static map by less than 0.0125 of its span both times.
//!
//! The covariance bound in normalised units ([`NONLINEAR_TRACE_LIMIT`]) decides how many cases are
//! well-posed; measured over the 165 cases (`cargo test --release -p sledid-host --test
//! nonlinear_units -- --nocapture` prints every one): well-posed and, of them, outside 2 % / 0.05,
//! real (45) | generated (120):
//!
//! | trace bound | real | generated |
//! |---|---|---|
//! | 100 (the linear models' default) | 20, 1 outside (EMPS eq. 6 +2.8 %) | 66, 5 outside (eq. 6 +23 %, Hammerstein +25 %, −6 %, −4 %, a map 0.11 apart) |
//! | 10 | 23, 1 (EMPS eq. 6 +39 %) | 67, 3 |
//! | 1 | 30, 2 (EMPS) | 98, 1 |
//! | **0.3** | **37, 1 (EMPS Wiener +14.6 %)** | **95, 0** |
//! | 0.1 | 39, 3 (EMPS) | 101, 0 |
//!
//! EMPS stays outside for a reason that is not precision: on its velocity data the first-order
//! pole sits at 0.996–0.998, and the stability projection halves a step that would leave the unit
//! circle — a discontinuity: a proposal within rounding of the circle is halved by one twin and
//! not by the other (sample ~100), every parameter's step then differs by 2× and the paths part.
//! Shortening the step to the boundary instead (continuous) brought EMPS's five structures within
//! 0.5 % but moved the matched-plant tests (`tests/integration/nonlinear.rs`: eq. 5 on-line 0.4555 against a
//! batch optimum of 0.2805 with the step on the boundary, friction 0.3717 against 0.3067 half-way
//! to it), so the halving stays.
//!
//! The tests assert the 0.3 row: every well-posed generated case within 2 % and 0.05, of the real
//! ones at most one outside and by at most 1.1× (with the one-pass kernel of issue 24: 36 of 45
//! well-posed, 99 of 120; the one real case outside is Silverbox's second segment's Wiener map at
//! 0.0501, every EMPS case now within), and at least three in four cases well-posed (a change that
//! made the estimator itself chaotic would otherwise hide among the ill-posed).

use rayon::prelude::*;
use sledid::ident::conditioning::Conditioning;
use sledid::ident::nonlinear::{InputRanges, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::excitation::{Excitation, Plant, write_recording};
use sledid_host::recording::ReaderOptions;
use sledid_host::reference::nonlinear::static_map;
use sledid_host::reference::units::{ModelKind, to_normalised};
use sledid_host::replay::{NONLINEAR_TRACE_LIMIT, Normalise, ReplaySpec, ReplaySummary, replay};
use sledid_host::twin::{Twin, params::TwinParams};
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir()
        .join("sledid-nonlinear-units")
        .join(name);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// A recording and how it is read.
#[derive(Clone, Debug)]
struct Case {
    name: String,
    file: PathBuf,
    columns: &'static str,
    ts_s: f64,
    conditioning: Conditioning,
    lambda: f64,
    y_unit: f64,
    u_full_scale: f64,
}

impl Case {
    fn spec(&self, structure: NonlinearStructure) -> ReplaySpec {
        let mut reader = ReaderOptions::new(self.columns.parse().expect("columns"));
        reader.ts_s = Some(self.ts_s);
        let mut s = ReplaySpec::new(reader);
        s.conditioning = self.conditioning;
        s.y_unit = self.y_unit;
        s.u_full_scale = self.u_full_scale;
        s.progress = false;
        s.nonlinear = Some(structure);
        s.rls = RlsDesign {
            lambda: self.lambda,
            p0: 10.0,
            anti_windup: AntiWindup::TraceLimit {
                max: NONLINEAR_TRACE_LIMIT,
            },
            ..RlsDesign::default()
        };
        s
    }

    fn run(&self, s: &ReplaySpec, tag: &str) -> ReplaySummary {
        let structure = s.nonlinear.expect("nonlinear");
        let out = scratch(&format!("{}-{}-{tag}", self.name, structure.name()));
        replay(&self.file, s, &out).unwrap_or_else(|e| panic!("{}: {e}", self.name))
    }
}

/// Rows `from..to` (0-based, data rows) of a CSV with a header, copied to the scratch directory.
fn segment(rel: &str, from: usize, to: usize, name: &str) -> PathBuf {
    let text = std::fs::read_to_string(data(rel)).expect("recording");
    let mut lines = text.lines();
    let header = lines.next().expect("header");
    let body: Vec<&str> = lines.skip(from).take(to - from).collect();
    let path = scratch("segments").join(format!("{name}.csv"));
    std::fs::write(&path, format!("{header}\n{}\n", body.join("\n"))).expect("write");
    path
}

fn twin_recording(seed: u64) -> PathBuf {
    let path = scratch("twins").join(format!("twin{seed}.csv"));
    let twin = Twin::run_baseline(TwinParams::default(), seed).expect("twin");
    twin.write_csv(&path).expect("write");
    path
}

fn silverbox(from: usize, to: usize, name: &str) -> Case {
    Case {
        name: name.into(),
        file: segment("silverbox/SNLS80mV.csv", from, to, name),
        columns: "u=V1,y=V2",
        ts_s: 1.0 / 610.35,
        conditioning: Conditioning::None,
        lambda: 0.9995,
        y_unit: 1e-3,
        u_full_scale: 1.0,
    }
}

fn daisy() -> Case {
    Case {
        name: "daisy".into(),
        file: data("daisy/cd_player_arm.csv"),
        columns: "u=u1_force,y=y1_tracking",
        ts_s: 1.0,
        conditioning: Conditioning::None,
        lambda: 0.995,
        y_unit: 1.0,
        u_full_scale: 1.0,
    }
}

fn emps() -> Case {
    Case {
        name: "emps".into(),
        file: data("emps/DATA_EMPS.csv"),
        columns: "u=vir_ctrl_V,y=qm_meas_pos_m,t=t_s",
        ts_s: 1e-3,
        conditioning: Conditioning::DifferencedOutput,
        lambda: 1.0,
        y_unit: 5e-8,
        u_full_scale: 1.0,
    }
}

fn twin(seed: u64) -> Case {
    Case {
        name: format!("twin{seed}"),
        file: twin_recording(seed),
        columns: "u=u_v,y=y_m,r=r_m,t=t_s",
        ts_s: 0.455e-3,
        conditioning: Conditioning::CentredOnReference,
        lambda: 1.0,
        y_unit: 1.6e-6,
        u_full_scale: 5.0,
    }
}

/// The largest difference of the fixed-point model's static map from the float64 model's, over
/// the data's input range, relative to the float64 map's span: eq. 5 and 7 u ↦ b₁u + g(u), the
/// Wiener output map, the friction force against the velocity; eq. 6's neuron over its (ŷ, u)
/// plane with b₁u added. `fx` and `f64n` are θ in the normalised units `r` is in.
fn shape_error(s: NonlinearStructure, r: InputRanges, fx: &[f64], f64n: &[f64]) -> f64 {
    let n = 81;
    let grid = |range: f64| (0..n).map(move |i| range * (2.0 * i as f64 / (n - 1) as f64 - 1.0));
    let (a, b): (Vec<f64>, Vec<f64>) = match s {
        NonlinearStructure::NoeOutputInput => {
            let map =
                |t: &[f64], y: f64, u: f64| t[1] * u + t[2] * (t[3] * y + t[4] * u + t[5]).tanh();
            grid(r.y)
                .flat_map(|y| grid(r.u).map(move |u| (y, u)))
                .map(|(y, u)| (map(fx, y, u), map(f64n, y, u)))
                .unzip()
        }
        _ => {
            let range = match s {
                NonlinearStructure::Wiener => r.y,
                NonlinearStructure::FrictionFeedback => r.dy,
                _ => r.u,
            };
            grid(range)
                .map(|x| {
                    (
                        static_map(s, fx, x).expect("map"),
                        static_map(s, f64n, x).expect("map"),
                    )
                })
                .unzip()
        }
    };
    let span =
        b.iter().cloned().fold(f64::MIN, f64::max) - b.iter().cloned().fold(f64::MAX, f64::min);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    worst / span.max(1e-12)
}

fn normalisation_of(sum: &ReplaySummary) -> sledid::Normalisation {
    let [ky, ku] = sum.normalisation;
    sledid::Normalisation::from_factors(ky, ku).expect("factors")
}

/// One case, one structure: (fixed/f64 − 1, shape error, and the f64's own moves of both under
/// ±10⁻⁴ changes of the data).
fn compare(case: &Case, s: NonlinearStructure) -> [f64; 4] {
    let spec = case.spec(s);
    let sum = case.run(&spec, "nominal");
    let kind = ModelKind::Nonlinear(s);
    let norm = normalisation_of(&sum);
    // Every θ in the nominal run's normalised units.
    let f64n = to_normalised(kind, &sum.theta_f64, norm);
    // The float64 twin's own moves, the larger of two perturbations of opposite sign.
    let (mut own, mut own_shape) = (0.0f64, 0.0f64);
    for (i, d) in [1e-4, -1e-4].into_iter().enumerate() {
        let mut moved = spec.clone();
        moved.normalise = Normalise::Targets {
            y: sledid::num::boundary::Y_TARGET * (1.0 + d),
            u: sledid::num::boundary::U_TARGET * (1.0 - d),
        };
        let other = case.run(&moved, &format!("moved{i}"));
        let m = other.sim_rms_f64 / sum.sim_rms_f64 - 1.0;
        if m.abs() > own.abs() {
            own = m;
        }
        let moved_f64n = to_normalised(kind, &other.theta_f64, norm);
        own_shape = own_shape.max(shape_error(s, sum.ranges, &moved_f64n, &f64n));
    }
    [
        sum.sim_rms / sum.sim_rms_f64 - 1.0,
        shape_error(s, sum.ranges, &sum.theta_normalised, &f64n),
        own,
        own_shape,
    ]
}

/// Runs every structure on every case, prints the table and returns the well-posed cases outside
/// 2 % or 0.05 (as "case structure") and the count of well-posed cases.
fn check(cases: &[Case]) -> (Vec<String>, usize, f64) {
    let jobs: Vec<(&Case, NonlinearStructure)> = cases
        .iter()
        .flat_map(|c| NonlinearStructure::ALL.into_iter().map(move |s| (c, s)))
        .collect();
    let results: Vec<_> = jobs
        .par_iter()
        .map(|(c, s)| ((*c, *s), compare(c, *s)))
        .collect();
    let mut failures = Vec::new();
    let mut well_posed = 0;
    // The largest excess over the bounds of a well-posed case: max(|rel|/0.02, shape/0.05).
    let mut worst = 0.0f64;
    for ((c, s), [rel, shape, own, own_shape]) in &results {
        let posed = own.abs() < 5e-3 && *own_shape < 0.0125;
        well_posed += usize::from(posed);
        println!(
            "{:<22} {:<12} fixed/f64 − 1 {:+.4} shape {:.4} | f64 own move {:+.1e} shape {:.1e}{}",
            c.name,
            s.name(),
            rel,
            shape,
            own,
            own_shape,
            if posed { "" } else { " (ill-posed)" },
        );
        if posed {
            worst = worst.max((rel.abs() / 0.02).max(*shape / 0.05));
        }
        if posed && (rel.abs() >= 0.02 || *shape >= 0.05) {
            failures.push(format!(
                "{} {}: {rel:+.4}, shape {shape:.4}",
                c.name,
                s.name()
            ));
        }
    }
    println!(
        "{well_posed} of {} well-posed; outside 2 % / 0.05: {failures:?}",
        results.len()
    );
    (failures, well_posed, worst)
}

/// The same recording replayed in units spanning 2^±10 of the nominal, including factors that are
/// not powers of two, and with the full-scale drive over 2^±4: the fixed-point path computes the
/// same θ (normalised, bit for bit) and reports the same simulation RMS in the user's units. A
/// normalisation computed from the user's units (rounding differs per unit), a mapping back with
/// a wrong factor, or a setting left in the user's units (dead zone, gate) trips it.
#[test]
fn the_same_recording_in_any_unit_gives_the_same_model() {
    let cases = [
        silverbox(0, 20_000, "silverbox-head"),
        daisy(),
        emps(),
        twin(1),
    ];
    let scales = [
        (2f64.powi(-10), 1.0),
        (2f64.powi(10), 16.0),
        (0.0316, 1.0 / 16.0),
        (3.7, 3.0),
    ];
    let jobs: Vec<(&Case, NonlinearStructure)> = cases
        .iter()
        .flat_map(|c| NonlinearStructure::ALL.into_iter().map(move |s| (c, s)))
        .collect();
    jobs.par_iter().for_each(|(case, s)| {
        let base = case.run(&case.spec(*s), "unit-base");
        for (i, (ky, ku)) in scales.iter().enumerate() {
            let mut c = Case::clone(case);
            c.y_unit *= ky;
            c.u_full_scale *= ku;
            let other = c.run(&c.spec(*s), &format!("unit{i}"));
            assert_eq!(
                other.theta_normalised,
                base.theta_normalised,
                "{} {} ×{ky}",
                case.name,
                s.name()
            );
            for (a, b) in [
                (other.sim_rms, base.sim_rms),
                (other.sim_rms_f64, base.sim_rms_f64),
            ] {
                assert!(
                    (a * ky / b - 1.0).abs() < 1e-9,
                    "{} {}: {a} × {ky} vs {b}",
                    case.name,
                    s.name()
                );
            }
        }
    });
}

/// Real recordings: Silverbox in three segments (the noise "arrow" and two halves of the
/// multisines), the DaISy CD arm, EMPS, and four twin recordings.
#[test]
fn fixed_point_tracks_float64_on_real_recordings() {
    let mut cases = vec![
        silverbox(0, 40_650, "silverbox-arrow"),
        silverbox(40_650, 85_000, "silverbox-ms1"),
        silverbox(85_000, 131_072, "silverbox-ms2"),
        daisy(),
        emps(),
    ];
    cases.extend((1..=4).map(twin));
    let (outside, posed, worst) = check(&cases);
    assert!(posed * 4 >= cases.len() * 5 * 3, "{posed} well-posed");
    // A statistic over the 45 cases, not a list of exempt ones: at most one well-posed case outside
    // 2 % / 0.05, and none beyond 1.1× those bounds. Measured: the previous kernel one (EMPS Wiener
    // +14.6 %, the projection's discontinuity, module doc); the one-pass kernel (issue 24) one,
    // Silverbox's second segment's Wiener static map 0.0501 from its twin's (1.002× the bound),
    // every EMPS case within. A kernel whose rounding moved a second case out, or this one far,
    // trips it.
    assert!(outside.len() <= 1, "outside: {outside:?}");
    assert!(
        worst < 1.1,
        "worst case at {worst:.3}× the bounds: {outside:?}"
    );
}

/// Generated recordings: a Duffing oscillator and the sled plant in open loop, under Schroeder and
/// random-phase multisines, random steps and low-pass noise, at 0.1, 1 and 10 × the nominal
/// amplitude.
#[test]
fn fixed_point_tracks_float64_under_any_excitation() {
    let mut cases = Vec::new();
    for plant in [Plant::Duffing, Plant::Sled] {
        for e in Excitation::ALL {
            for amp in [0.1, 1.0, 10.0] {
                let name = format!("{plant:?}-{e:?}-{amp}");
                let file = scratch("excitation").join(format!("{name}.csv"));
                write_recording(&file, plant, e, amp, 8192, 7).expect("write");
                cases.push(Case {
                    name,
                    file,
                    columns: "u=u,y=y,t=t_s",
                    ts_s: plant.ts_s(),
                    conditioning: match plant {
                        Plant::Duffing => Conditioning::None,
                        Plant::Sled => Conditioning::DifferencedOutput,
                    },
                    lambda: 0.9995,
                    y_unit: match plant {
                        Plant::Duffing => 1e-3,
                        Plant::Sled => 1.6e-6,
                    },
                    u_full_scale: 1.0,
                });
            }
        }
    }
    let (outside, posed, _) = check(&cases);
    assert!(posed * 4 >= cases.len() * 5 * 3, "{posed} well-posed");
    assert!(outside.is_empty(), "outside: {outside:?}");
}
