//! Full per-sample steps per second on real recordings: `sledid::ident::step::step` — conditioning, the
//! model estimator, flags: the function the firmware's interrupt and `replay` call — on the EMPS
//! and Silverbox recordings already converted at the boundary (reading and parsing the CSV is
//! replay's I/O, measured by `replay --rate max` itself). ARX(2,2) and the first-order Wiener model.
//!
//! `cargo bench -p sledid-host --bench full_step`

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sledid::Scaling;
use sledid::ident::conditioning::Conditioning;
use sledid::ident::estimator::EstimatorDesign;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, step};
use sledid::num::boundary::Sample;
use sledid_host::recording::{ReaderOptions, read_all};
use std::hint::black_box;
use std::path::PathBuf;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data")).join(rel)
}

/// The recording's samples through the boundary conversion (rows it rejects are skipped here: the
/// bench measures the step, not the policy).
fn samples(file: &str, columns: &str, ts: Option<f64>, y_unit: f64, u_fs: f64) -> Vec<Sample> {
    let mut opts = ReaderOptions::new(columns.parse().expect("mapping"));
    opts.ts_s = ts;
    let rec = read_all(data(file), &opts).expect("recording");
    let scaling = Scaling::new(y_unit, u_fs).expect("scaling");
    rec.samples
        .iter()
        .filter_map(|s| scaling.sample(s.y, s.u, s.r.unwrap_or(0.0)).ok())
        .collect()
}

fn rls() -> RlsDesign {
    RlsDesign {
        lambda: 0.9995,
        p0: 10.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        ..RlsDesign::default()
    }
}

fn bench_model<const N: usize, D: EstimatorDesign<N> + Copy>(
    c: &mut Criterion,
    group: &str,
    conditioning: Conditioning,
    model: D,
    data: &[Sample],
) {
    let cfg = IdentifierDesign::new(conditioning, model)
        .build()
        .expect("design");
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(data.len() as u64));
    g.bench_function("step", |b| {
        b.iter(|| {
            let mut st = cfg.new_state();
            let mut acc = 0u32;
            for s in data {
                acc ^= u32::from(step(&cfg, &mut st, black_box(s)).status.bits());
            }
            acc
        })
    });
    g.finish();
}

fn full_step(c: &mut Criterion) {
    let emps = samples(
        "emps/DATA_EMPS.csv",
        "u=vir_ctrl_V,y=qm_meas_pos_m,r=qg_ref_pos_m,t=t_s",
        None,
        1e-5,
        10.0,
    );
    let silverbox = samples(
        "silverbox/SNLS80mV.csv",
        "u=V1,y=V2",
        Some(1.0 / 610.35),
        1e-3,
        1.0,
    );
    let mut arx = LinearDesign::<4>::new(Structure::Arx, 2, 2);
    arx.rls = rls();
    let ranges = InputRanges {
        u: 1.0,
        y: 50.0,
        dy: 5.0,
    };
    let mut wiener =
        NonlinearDesign::<5>::from_linear(NonlinearStructure::Wiener, &[-0.9, 0.5], ranges);
    wiener.rls = rls();
    for (name, d, cond) in [
        ("emps", &emps, Conditioning::DifferencedOutput),
        ("silverbox", &silverbox, Conditioning::None),
    ] {
        bench_model(c, &format!("{name}_arx_n4_full_step"), cond, arx, d);
        bench_model(c, &format!("{name}_wiener_full_step"), cond, wiener, d);
    }
}

criterion_group!(benches, full_step);
criterion_main!(benches);
