//! The per-sample `step` with an arbitrary (valid) configuration — any linear or nonlinear model —
//! and arbitrary raw samples: no panic, no overflow (overflow checks are on), P stays positive
//! definite.

use sledid::ident::conditioning::Conditioning;
use sledid::ident::estimator::{Estimator, EstimatorDesign};
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::nonlinear::{NonlinearDesign, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid::ident::step::{IdentifierDesign, StuckSensorDesign, reject, step};
use sledid::num::boundary::{PositionI48F16, Sample};
use sledid::num::fixed::SignalI16F16;

/// Reads little-endian values from the fuzzer's bytes (zeros when exhausted).
struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        let n = K.min(self.0.len());
        out[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn unit(&mut self) -> f64 {
        f64::from(u16::from_le_bytes(self.take())) / 65_535.0
    }
}

fn run<const N: usize>(b: &mut Bytes, na: usize, nb: usize) {
    let structure = match b.u8() % 3 {
        0 => Structure::Arx,
        1 => Structure::OutputErrorPseudoLinear,
        _ => Structure::OutputErrorPredictionError,
    };
    let conditioning = match b.u8() % 4 {
        0 => Conditioning::None,
        1 => Conditioning::CentredOnReference,
        2 => Conditioning::Differenced,
        _ => Conditioning::DifferencedOutput,
    };
    let rls = rls_design(b);
    let mut model = LinearDesign::<N>::new(structure, na, nb);
    model.rls = rls;
    drive(b, conditioning, model);
}

/// One of the paper's nonlinear models from arbitrary (possibly saturating) initial parameters.
fn run_nonlinear<const N: usize>(b: &mut Bytes, structure: NonlinearStructure) {
    let conditioning = match b.u8() % 3 {
        0 => Conditioning::None,
        1 => Conditioning::CentredOnReference,
        _ => Conditioning::DifferencedOutput,
    };
    let mut theta0 = [0.0; N];
    for t in theta0.iter_mut() {
        *t = (b.unit() - 0.5) * 4000.0;
    }
    theta0[0] = b.unit() * 1.98 - 0.99;
    if structure.na() == 2 {
        theta0[1] = 0.0;
    }
    let model = NonlinearDesign {
        structure,
        theta0,
        rls: rls_design(b),
        stability_margin: 0.0,
    };
    drive(b, conditioning, model);
}

fn rls_design(b: &mut Bytes) -> RlsDesign {
    let dead_zone = b.unit() * 4.0;
    RlsDesign {
        lambda: 0.5 + 0.5 * b.unit(),
        p0: 10f64.powf(-6.0 + 14.0 * b.unit()),
        dead_zone,
        excitation_threshold: if b.u8().is_multiple_of(2) {
            0.0
        } else {
            10f64.powf(-9.0 + 12.0 * b.unit())
        },
        anti_windup: match b.u8() % 5 {
            0 => AntiWindup::None,
            1 => AntiWindup::TraceLimit {
                max: 10f64.powf(-3.0 + 9.0 * b.unit()),
            },
            2 => AntiWindup::DiagonalLimit {
                max: 10f64.powf(-3.0 + 9.0 * b.unit()),
            },
            3 => AntiWindup::ConstantTrace {
                trace: 10f64.powf(-3.0 + 9.0 * b.unit()),
            },
            _ => AntiWindup::FactorCap {
                max: 10f64.powf(-3.0 + 9.0 * b.unit()),
            },
        },
        outlier_threshold: if b.u8().is_multiple_of(2) {
            0.0
        } else {
            dead_zone + 0.1 + 100.0 * b.unit()
        },
        outlier_limit: u16::from(b.u8()),
    }
}

/// The shared step on the rest of the bytes.
fn drive<const N: usize, D: EstimatorDesign<N>>(
    b: &mut Bytes,
    conditioning: Conditioning,
    model: D,
) {
    let mut design = IdentifierDesign::new(conditioning, model);
    if b.u8() % 2 == 1 {
        design.stuck_sensor = Some(StuckSensorDesign {
            samples: 2 + u32::from(b.u8()),
            min_drive: 0.01 + b.unit(),
        });
    }
    let Ok(cfg) = design.build() else { return };
    let mut st = cfg.new_state();
    while !b.0.is_empty() {
        if b.u8() == 0xFF {
            let _ = reject(&cfg, &mut st);
            continue;
        }
        let s = Sample {
            y: PositionI48F16::from_raw(i64::from_le_bytes(b.take())),
            u: SignalI16F16::from_raw(i32::from_le_bytes(b.take())),
            r: PositionI48F16::from_raw(i64::from_le_bytes(b.take())),
        };
        let out = step(&cfg, &mut st, &s);
        assert_eq!(out.theta, *cfg.model().theta(st.model()));
        assert!(
            cfg.model().covariance_positive_definite(st.model()),
            "P lost positive definiteness"
        );
    }
}

/// The step target: the first byte picks the model (three linear orders, then the nonlinear
/// structures), the next ones its design, the rest are samples (a `0xFF` byte rejects one).
/// Panics on a broken invariant: θ reported differs from θ held, or P not positive definite.
pub fn target(data: &[u8]) {
    let mut b = Bytes(data);
    // Three linear orders, then the nonlinear structures.
    match b.u8() % (3 + NonlinearStructure::ALL.len() as u8) {
        0 => run::<2>(&mut b, 1, 1),
        1 => run::<3>(&mut b, 2, 1),
        2 => run::<4>(&mut b, 2, 2),
        k => {
            let s = NonlinearStructure::ALL[usize::from(k - 3)];
            sledid::with_parameter_count!(s, |N| run_nonlinear::<N>(&mut b, s))
        }
    }
}
