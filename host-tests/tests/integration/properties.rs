//! Property tests of the fixed-point path (run with overflow checks on: any unplanned wrap panics).
//!
//! For any configuration in range and any input sequence: no panic; every dⱼ stays positive, so
//! P = UDUᵀ is symmetric positive definite with positive diagonal; the trace limit holds; `reset()`
//! equals `new()`; the shared per-sample `step` accepts any raw sample.

use proptest::prelude::*;
use sledid::ident::conditioning::Conditioning;
use sledid::ident::linear::{LinearDesign, Structure};
use sledid::ident::rls::{AntiWindup, RlsConfig, RlsDesign, RlsState};
use sledid::ident::step::{IdentifierDesign, step};
use sledid::num::boundary::{PositionI48F16, Sample};
use sledid::num::dyadic::Dyadic;
use sledid::num::fixed::{ParamI12F20, SignalI16F16};

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 256,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn anti_windup() -> impl Strategy<Value = AntiWindup> {
    prop_oneof![
        Just(AntiWindup::None),
        (1e-3f64..1e6).prop_map(|max| AntiWindup::TraceLimit { max }),
        (1e-3f64..1e6).prop_map(|max| AntiWindup::DiagonalLimit { max }),
        (1e-3f64..1e6).prop_map(|trace| AntiWindup::ConstantTrace { trace }),
        (1e-3f64..1e6).prop_map(|max| AntiWindup::FactorCap { max }),
    ]
}

fn design() -> impl Strategy<Value = RlsDesign> {
    (
        1e-3f64..=1.0,
        1e-6f64..1e8,
        0.0f64..4.0,
        prop_oneof![Just(0.0), 1e-9f64..1e3],
        anti_windup(),
        prop_oneof![Just(None), (0.1f64..100.0).prop_map(Some)],
        1u16..64,
    )
        .prop_map(
            |(lambda, p0, dead_zone, excitation_threshold, anti_windup, outlier, outlier_limit)| {
                RlsDesign {
                    lambda,
                    p0,
                    dead_zone,
                    excitation_threshold,
                    anti_windup,
                    // The gate must sit above the dead zone.
                    outlier_threshold: outlier.map_or(0.0, |o| dead_zone + o),
                    outlier_limit,
                }
            },
        )
}

/// Raw I16F16 values: mostly realistic magnitudes, sometimes extreme.
fn signal() -> impl Strategy<Value = i32> {
    prop_oneof![4 => -(64i32 << 16)..(64i32 << 16), 1 => any::<i32>(), 1 => Just(0)]
}

fn check_invariants<const N: usize>(
    st: &RlsState<N>,
    cfg_design: &RlsDesign,
) -> Result<(), TestCaseError> {
    for j in 0..N {
        prop_assert!(!st.d()[j].is_zero(), "d[{j}] reached zero");
    }
    let tr = st.trace();
    prop_assert!(!tr.is_zero());
    if let Some(cap) = cfg_design.anti_windup.factor_cap() {
        // Every update stores each dⱼ at or below the cap; P₀ may exceed it until the first one.
        let limit = cap.to_f64().max(cfg_design.p0);
        for j in 0..N {
            prop_assert!(
                st.d()[j].to_f64() <= limit,
                "d[{j}] = {} > {limit}",
                st.d()[j].to_f64()
            );
        }
    }
    if let AntiWindup::TraceLimit { max } = cfg_design.anti_windup {
        let limit = Dyadic::from_f64(max).unwrap().to_f64();
        // Only updates bound the trace; P₀ itself may exceed the limit until the first update.
        let p0_trace = cfg_design.p0 * N as f64;
        prop_assert!(
            tr.to_f64() <= limit.max(p0_trace) * (1.0 + 1e-6),
            "trace {} > {}",
            tr.to_f64(),
            limit
        );
    }
    Ok(())
}

fn run_kernel<const N: usize>(d: RlsDesign, seq: &[(Vec<i32>, i32)]) -> Result<(), TestCaseError> {
    let cfg: RlsConfig = d.build().map_err(|e| TestCaseError::fail(format!("{e}")))?;
    let mut st = RlsState::<N>::new(&cfg, [ParamI12F20::ZERO; N]);
    for (psi_raw, eps_raw) in seq {
        let mut psi = [SignalI16F16::ZERO; N];
        for (p, r) in psi.iter_mut().zip(psi_raw.iter()) {
            *p = SignalI16F16::from_raw(*r);
        }
        let _ = cfg.update(&mut st, &psi, SignalI16F16::from_raw(*eps_raw));
        check_invariants(&st, &d)?;
    }
    let mut reset = st.clone();
    reset.reset(&cfg, [ParamI12F20::ZERO; N]);
    prop_assert_eq!(reset, RlsState::<N>::new(&cfg, [ParamI12F20::ZERO; N]));
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn kernel_n2_never_panics_and_keeps_p_positive_definite(
        d in design(),
        seq in prop::collection::vec((prop::collection::vec(signal(), 2), signal()), 1..200),
    ) {
        run_kernel::<2>(d, &seq)?;
    }

    #[test]
    fn kernel_n4_never_panics_and_keeps_p_positive_definite(
        d in design(),
        seq in prop::collection::vec((prop::collection::vec(signal(), 4), signal()), 1..200),
    ) {
        run_kernel::<4>(d, &seq)?;
    }

    #[test]
    fn step_accepts_any_raw_sample(
        d in design(),
        structure in prop_oneof![
            Just(Structure::Arx),
            Just(Structure::OutputErrorPseudoLinear),
            Just(Structure::OutputErrorPredictionError)
        ],
        conditioning in prop_oneof![
            Just(Conditioning::None),
            Just(Conditioning::CentredOnReference),
            Just(Conditioning::Differenced),
            Just(Conditioning::DifferencedOutput)
        ],
        samples in prop::collection::vec((any::<i64>(), signal(), any::<i64>()), 1..300),
    ) {
        let mut model = LinearDesign::<4>::new(structure, 2, 2);
        model.rls = d;
        let cfg = IdentifierDesign::new(conditioning, model).build().unwrap();
        let mut st = cfg.new_state();
        for (y, u, r) in samples {
            let s = Sample { y: PositionI48F16::from_raw(y), u: SignalI16F16::from_raw(u), r: PositionI48F16::from_raw(r) };
            let out = step(&cfg, &mut st, &s);
            // The estimate is always a valid parameter vector; P stays positive definite.
            prop_assert_eq!(out.theta, *st.model().theta());
            for j in 0..4 {
                prop_assert!(!st.model().rls().d()[j].is_zero());
            }
        }
    }

    #[test]
    fn nonlinear_step_accepts_any_raw_sample(
        d in design(),
        which in 0..sledid::ident::nonlinear::NonlinearStructure::ALL.len(),
        // Any θ₀ (the stable-denominator check aside): saturated neurons, huge weights.
        theta in prop::collection::vec(-2000.0f64..2000.0, 8),
        f1 in -0.99f64..0.99,
        conditioning in prop_oneof![
            Just(Conditioning::None),
            Just(Conditioning::CentredOnReference),
            Just(Conditioning::DifferencedOutput)
        ],
        samples in prop::collection::vec((any::<i64>(), signal(), any::<i64>()), 1..200),
    ) {
        use sledid::ident::nonlinear::NonlinearStructure;
        let structure = NonlinearStructure::ALL[which];
        sledid::with_parameter_count!(structure, |N| run_nonlinear::<N>(
            structure, d, &theta, f1, conditioning, &samples
        )?);
    }

    #[test]
    fn dyadic_arithmetic_tracks_f64(a in 1e-30f64..1e30, b in 1e-30f64..1e30) {
        let (da, db) = (Dyadic::from_f64(a).unwrap(), Dyadic::from_f64(b).unwrap());
        let rel = |x: f64, y: f64| ((x - y) / y).abs();
        // Conversion keeps 32 bits; each operation on the represented values loses < 2^-30.
        prop_assert!(rel(da.to_f64(), a) < 2f64.powi(-31));
        let (ra, rb) = (da.to_f64(), db.to_f64());
        prop_assert!(rel(da.mul_trunc(db).to_f64(), ra * rb) < 2f64.powi(-30));
        prop_assert!(rel(da.add_trunc(db).to_f64(), ra + rb) < 2f64.powi(-30));
        prop_assert!(rel(da.recip().to_f64(), 1.0 / ra) < 2f64.powi(-30));
    }
}

/// A nonlinear estimator through the shared step on any samples: no panic, P positive definite,
/// the linear denominator inside the unit circle after every sample.
fn run_nonlinear<const N: usize>(
    structure: sledid::ident::nonlinear::NonlinearStructure,
    d: RlsDesign,
    theta: &[f64],
    f1: f64,
    conditioning: Conditioning,
    samples: &[(i64, i32, i64)],
) -> Result<(), TestCaseError> {
    use sledid::ident::nonlinear::NonlinearDesign;
    let mut theta0 = [0.0; N];
    theta0.copy_from_slice(&theta[..N]);
    // A stable denominator: f₁ only (f₂ = 0 for second-order structures).
    theta0[0] = f1;
    if structure.na() == 2 {
        theta0[1] = 0.0;
    }
    let model = NonlinearDesign {
        structure,
        theta0,
        rls: d,
        stability_margin: 0.0,
    };
    let cfg = IdentifierDesign::new(conditioning, model).build().unwrap();
    let mut st = cfg.new_state();
    let one = 1i64 << 20;
    for &(y, u, r) in samples {
        let s = Sample {
            y: PositionI48F16::from_raw(y),
            u: SignalI16F16::from_raw(u),
            r: PositionI48F16::from_raw(r),
        };
        let out = step(&cfg, &mut st, &s);
        prop_assert_eq!(out.theta, *st.model().theta());
        prop_assert!(st.model().rls().d().iter().all(|d| !d.is_zero()));
        let f = out.theta;
        let stable = if structure.na() == 1 {
            i64::from(f[0].raw()).abs() <= one
        } else {
            let (f1, f2) = (i64::from(f[0].raw()), i64::from(f[1].raw()));
            f2.abs() <= one && (f1.abs() << 20) <= (one << 20) + f2 * one
        };
        prop_assert!(stable, "denominator left the unit circle: {:?}", &f[..2]);
    }
    Ok(())
}
