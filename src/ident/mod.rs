//! On-line identification: the paper's model structures as fixed-point recursive estimators, and
//! the per-sample step that runs them.
//!
//! | module | what |
//! |---|---|
//! | [`step`] | the per-sample step the firmware, the replay and the tests share; the servo's [`step::Identifier`] |
//! | [`estimator`] | the seam: [`Estimator`] and [`EstimatorDesign`] |
//! | [`linear`] | ARX and OE (eq. 1–2) |
//! | [`nonlinear`] | eq. 5–7, Wiener, friction feedback: recursive prediction error on the simulation error |
//! | [`rls`] | the UD-factored RLS update every estimator here uses, its anti-windup and outlier gate |
//! | [`neuron`] | the tanh neuron of the nonlinear structures |
//! | [`stability`] | the pole projection of the denominator |
//! | [`conditioning`], [`decimate`] | the raw sample made into the identified signals |
//! | [`status`] | what one sample reports |
//!
//! # Adding an estimator
//! [`step::step`], the servo and the host tools drive any [`Estimator`]; none of them changes.
//! 1. **The parameter count, in one table.** A new nonlinear structure is a variant of
//!    [`NonlinearStructure`]: its θ entries in [`NonlinearStructure::parameter_names`] (the
//!    table [`NonlinearStructure::parameter_count`], hence every N, derives from), its step in
//!    [`nonlinear::structure::evaluate`] with a row in that module's table, its θ₀ in
//!    [`nonlinear::NonlinearDesign::from_linear`], and its variant in the list of
//!    [`crate::with_parameter_count`] (the compiler points there). A linear order's count is
//!    [`linear::parameter_count`]. A new kind of estimator is a module here whose `build` refuses
//!    an N that is not its count, as [`crate::ConfigError::ParameterCount`] does.
//! 2. **The traits.** A `…Design` (f64, engineering units) implementing [`EstimatorDesign`]
//!    builds a quantised, `Copy` `…Config` implementing [`Estimator`] and a `…State<N>`. `step`
//!    never panics and reports through [`Status`]; `covariance_positive_definite` is the
//!    invariant the fuzz target checks after every sample; `seed` restarts from a calibrated θ.
//! 3. **Errors and words.** A setting that is refused names itself in a [`crate::ConfigError`]
//!    variant. Configuration words go through `put_words`/`take_words`, as
//!    [`linear::LinearDesign::put_words`] and [`nonlinear::NonlinearDesign::put_words`], `take`
//!    checking with the same `validate` as `build` ([`crate::words`]).
//! 4. **The float64 reference.** A textbook twin in `host-tests/src/reference/` (as
//!    `reference::nonlinear::NonlinearF64` for [`nonlinear::NonlinearConfig`]; a new structure is
//!    an arm of its `evaluate`), listed in that module's doc.
//! 5. **Accuracy.** A test in `host-tests/tests/` asserts the fixed-point error against the twin
//!    and prints it: θ and simulation RMS as `rls_vs_f64.rs` does for the linear models,
//!    simulation RMS within 2 % as `nonlinear.rs` does (its loop over
//!    [`NonlinearStructure::ALL`] takes a new structure). The bound goes into the module's
//!    `# Accuracy`. Also add it to `properties.rs` and `fuzz/fuzz_targets/step.rs`.
//! 6. **Replay, study, bench.** Replay: `host-tests/src/replay.rs` (a `Reference` impl, the
//!    dispatch in `replay`) and the model name in `host-tests/src/cmd/replay.rs` (a nonlinear
//!    structure's is [`NonlinearStructure::name`]). Study: `describe` in
//!    `host-tests/src/study/select.rs` (the batch fit, `reference::nonlinear_batch`, runs the
//!    reference's `evaluate`). Bench: a
//!    scenario and a `bench_<name>_step` entry point in `src/bin/bench.rs`, the symbol in
//!    `BENCH_FNS` of `xtask/src/main.rs`, the cost in `BENCHMARKS.md` (`cargo xtask cost`).
//!
//! [`Estimator`]: estimator::Estimator
//! [`EstimatorDesign`]: estimator::EstimatorDesign
//! [`NonlinearStructure`]: nonlinear::NonlinearStructure
//! [`NonlinearStructure::parameter_names`]: nonlinear::NonlinearStructure::parameter_names
//! [`NonlinearStructure::parameter_count`]: nonlinear::NonlinearStructure::parameter_count
//! [`NonlinearStructure::ALL`]: nonlinear::NonlinearStructure::ALL
//! [`NonlinearStructure::name`]: nonlinear::NonlinearStructure::name
//! [`Status`]: status::Status

pub mod conditioning;
pub mod decimate;
pub mod estimator;
pub mod linear;
pub mod neuron;
pub mod nonlinear;
pub(crate) mod regressor;
pub mod rls;
pub mod stability;
pub mod status;
pub mod step;
