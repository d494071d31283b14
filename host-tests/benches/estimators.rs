//! Host throughput of the per-sample estimators: the fixed-point path and its float64 references
//! side by side, on the same closed-loop data (`cargo bench -p sledid-host --bench estimators`).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::compare::to_signal;
use sledid_host::plants::{ClosedLoopSpec, closed_loop};
use sledid_host::reference::linear::LinearF64;
use sledid_host::reference::rls::CovarianceForm;
use std::hint::black_box;

const SAMPLES: usize = 10_000;

fn data() -> (Vec<f64>, Vec<f64>) {
    let rec = closed_loop(&ClosedLoopSpec {
        a: vec![-1.9, 0.905],
        b: vec![0.5, 0.45],
        kp: 0.01,
        dither: 0.1,
        step_every: 400,
        step_max: 60.0,
        samples: SAMPLES + 1,
        seed: 1,
    });
    let d = |v: &[f64]| v.windows(2).map(|w| w[1] - w[0]).collect::<Vec<f64>>();
    (d(&rec.y), d(&rec.u))
}

fn design<const N: usize>() -> LinearDesign<N> {
    let mut d = LinearDesign::<N>::new(Structure::Arx, N / 2, N - N / 2);
    d.rls = RlsDesign {
        lambda: 0.995,
        p0: 100.0,
        anti_windup: AntiWindup::TraceLimit { max: 1e4 },
        ..RlsDesign::default()
    };
    d
}

fn bench_n<const N: usize>(c: &mut Criterion, y: &[f64], u: &[f64]) {
    let yq: Vec<_> = y.iter().map(|&v| to_signal(v)).collect();
    let uq: Vec<_> = u.iter().map(|&v| to_signal(v)).collect();
    let d = design::<N>();
    let cfg = d.build().expect("design");
    let mut g = c.benchmark_group(format!("arx_n{N}_step"));
    g.throughput(Throughput::Elements(SAMPLES as u64));
    g.bench_function("fixed_point", |b| {
        b.iter(|| {
            let mut st = cfg.new_state();
            for (y, u) in yq.iter().zip(uq.iter()) {
                black_box(cfg.step(&mut st, *y, *u));
            }
            black_box(st)
        })
    });
    for (name, form) in [
        ("f64_ud", CovarianceForm::Bierman),
        ("f64_textbook", CovarianceForm::Textbook),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut r = LinearF64::new(&d);
                r.rls.form = form;
                for (y, u) in yq.iter().zip(uq.iter()) {
                    black_box(r.step(y.to_f64(), u.to_f64()));
                }
                black_box(r.rls.theta)
            })
        });
    }
    g.finish();
}

fn estimators(c: &mut Criterion) {
    let (y, u) = data();
    bench_n::<2>(c, &y, &u);
    bench_n::<4>(c, &y, &u);
}

criterion_group!(benches, estimators);
criterion_main!(benches);
