//! Bench image for on-target cost: each `bench_*` function runs one call of a kernel on state kept in
//! a static, for `shared/tools/count_insns.py` (instructions and estimated cycles per call on
//! Cortex-M4F and M0+). `bench_overhead` has the same scaffolding and an empty body: subtract it.
//!
//! Built for the host, `main` runs every scenario a few thousand times and prints the final θ
//! (a smoke test that the scenarios are meaningful, not a measurement).
#![cfg_attr(target_os = "none", no_std, no_main)]

use sledid::control::{
    Controller, InverseInputMap, ModelReport, PidConfig, PidDesign, PidState, ScheduledConfig,
    ScheduledDesign, ScheduledState,
};
use sledid::ident::decimate::{DecimatorConfig, DecimatorState};
use sledid::ident::linear::{LinearConfig, LinearDesign, LinearState, Structure};
use sledid::ident::neuron::{HiddenLayer, HiddenLayerDesign, NeuronDesign};
use sledid::ident::nonlinear::{
    InputRanges, NonlinearConfig, NonlinearDesign, NonlinearState, NonlinearStructure,
};
use sledid::ident::rls::{AntiWindup, RlsConfig, RlsDesign, RlsState};
use sledid::ident::status::Status;
use sledid::num::boundary::PositionI48F16;
use sledid::num::fixed::{ParamI12F20, SignalI16F16};
use sledid::servo::CalibratedModel;
use sledid::servo::health::{
    HealthConfig, HealthDesign, HealthFeed, HealthQueue, HealthReference, HealthSample, HealthState,
};

/// Length of the input tables (calls cycle through them).
const TABLE: usize = 64;

/// A deterministic pseudo-random table of I16F16 values in ±`amp_i16f16`.
const fn table(seed: u32, amp_i16f16: i32) -> [i32; TABLE] {
    let mut t = [0i32; TABLE];
    let mut x = seed;
    let mut i = 0;
    while i < TABLE {
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let r = ((x >> 8) as i32 & 0xFFFF) - 0x8000; // ±2^15
        t[i] = (r as i64 * amp_i16f16 as i64 / 0x8000) as i32;
        i += 1;
    }
    t
}

/// Regressor entries (a few quanta, as on the centred sled data) and inputs (±0.5 of full scale).
static PSI_TABLE: [i32; TABLE] = table(1, 3 << 16);
static U_TABLE: [i32; TABLE] = table(2, 1 << 15);
static Y_TABLE: [i32; TABLE] = table(3, 2 << 16);

fn at(t: &[i32; TABLE], i: u32) -> SignalI16F16 {
    SignalI16F16::from_raw(t.get(i as usize % TABLE).copied().unwrap_or(0))
}

/// The RLS design the cost figures are for: λ = 0.99 (the reference point's setting), each dⱼ
/// capped at 2¹³ (the kernel's own anti-windup, `AntiWindup::FactorCap`).
fn rls_design() -> RlsDesign {
    RlsDesign {
        lambda: 0.99,
        p0: 100.0,
        anti_windup: AntiWindup::FactorCap { max: 1.0e4 },
        ..RlsDesign::default()
    }
}

/// [`rls_design`] with the trace limit 10⁴ instead (the servo's kind of bound; the design the
/// previous kernel's figures were measured with).
fn rls_design_trace() -> RlsDesign {
    RlsDesign {
        anti_windup: AntiWindup::TraceLimit { max: 1.0e4 },
        ..rls_design()
    }
}

/// One bare RLS kernel update with N parameters.
pub struct RlsBench<const N: usize> {
    config: RlsConfig,
    state: RlsState<N>,
}

impl<const N: usize> RlsBench<N> {
    /// Builds the scenario; `None` if the design were invalid (it is not).
    pub fn new() -> Option<Self> {
        Self::with(rls_design())
    }

    /// The scenario with the trace limit ([`rls_design_trace`]).
    pub fn with_trace_limit() -> Option<Self> {
        Self::with(rls_design_trace())
    }

    fn with(design: RlsDesign) -> Option<Self> {
        let config = design.build().ok()?;
        let state = RlsState::new(&config, [ParamI12F20::ZERO; N]);
        Some(Self { config, state })
    }

    /// Call `i`: one update with table-driven ψ and ε.
    pub fn call(&mut self, i: u32) -> u16 {
        let mut psi = [SignalI16F16::ZERO; N];
        for (k, p) in psi.iter_mut().enumerate() {
            *p = at(&PSI_TABLE, i.wrapping_add(k as u32 * 7));
        }
        self.config
            .update(&mut self.state, &psi, at(&Y_TABLE, i))
            .bits()
    }
}

/// One full ARX(na, nb) step (regressor, prediction, update) with N parameters.
pub struct ArxBench<const N: usize> {
    config: LinearConfig<N>,
    state: LinearState<N>,
}

impl<const N: usize> ArxBench<N> {
    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let mut d = LinearDesign::<N>::new(Structure::Arx, N / 2, N - N / 2);
        d.rls = rls_design();
        let config = d.build().ok()?;
        let state = config.new_state();
        Some(Self { config, state })
    }

    /// Call `i`.
    pub fn call(&mut self, i: u32) -> u16 {
        self.config
            .step(&mut self.state, at(&Y_TABLE, i), at(&U_TABLE, i))
            .status
            .bits()
    }
}

/// The 2-neuron hidden layer of eq. 5 evaluated at one input, with g, ∂g/∂x and the gradient with
/// respect to all six parameters (what a prediction-error update needs per sample).
pub struct NeuronBench {
    layer: HiddenLayer<2>,
}

impl NeuronBench {
    /// Builds the scenario: fitted-looking weights (w ≠ 0, so every derivative is non-trivial).
    pub fn new() -> Option<Self> {
        let layer = HiddenLayerDesign {
            neurons: [
                NeuronDesign {
                    w: 1.5,
                    a: 1.2,
                    c: -0.4,
                },
                NeuronDesign {
                    w: -0.8,
                    a: 2.5,
                    c: 0.5,
                },
            ],
        }
        .build()
        .ok()?;
        Some(Self { layer })
    }

    /// Call `i`: one evaluation at a table input (±0.5 of full scale); every output folded in.
    pub fn call(&mut self, i: u32) -> u32 {
        let o = self.layer.eval(at(&U_TABLE, i));
        let mut acc = o.g.raw() ^ o.dg_dx.raw() ^ i32::from(o.status.bits());
        for g in &o.grad {
            acc = acc.wrapping_add(g.dw.raw() ^ g.da.raw() ^ g.dc.raw());
        }
        acc as u32
    }
}

/// One input sample through the half-band decimator (an output every second call).
pub struct DecimateBench {
    config: DecimatorConfig,
    state: DecimatorState,
}

impl DecimateBench {
    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let config = DecimatorConfig::HALF_BAND_23;
        Some(Self {
            config,
            state: config.new_state(),
        })
    }

    /// Call `i`: push one table sample (a few quanta).
    pub fn call(&mut self, i: u32) -> u32 {
        self.config
            .push(&mut self.state, at(&Y_TABLE, i))
            .map_or(0, |o| o.y.raw() as u32)
    }
}

/// The health estimator (`sledid::servo::health`, default design, against a calibration of the
/// family's plant 0): the interrupt's `feed` on a sled moving ≈ 10 quanta per sample (a push
/// every second call; the queue is emptied, not measured, when full) and the background's `step`
/// on one moving sample (an RLS update, n = 6).
pub struct HealthBench {
    config: HealthConfig,
    feed: HealthFeed,
    queue: HealthQueue<64>,
    state: HealthState,
    y_i48f16: i64,
}

impl HealthBench {
    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let config = HealthDesign::default().build().ok()?;
        let model = CalibratedModel {
            a: 0.917,
            gain_k: 415.5,
            coulomb_fs: [0.0033, 0.0033],
            breakaway_fs: [0.015, 0.015],
            rms: 0.29,
        };
        let mut state = config.new_state();
        config.set_reference(&mut state, &HealthReference::from_calibration(&model)?);
        Some(Self {
            config,
            feed: HealthFeed::new(),
            queue: HealthQueue::new(),
            state,
            y_i48f16: 0,
        })
    }

    /// Call `i` of the interrupt's part.
    pub fn call_feed(&mut self, i: u32) -> u32 {
        if self.queue.is_full() {
            self.queue = HealthQueue::new();
        }
        self.y_i48f16 = self
            .y_i48f16
            .wrapping_add((10 << 16) + i64::from(at(&Y_TABLE, i).raw()));
        let (mut producer, _) = self.queue.split();
        let flags = self.config.feed(
            &mut self.feed,
            &mut producer,
            PositionI48F16::from_raw(self.y_i48f16),
            at(&U_TABLE, i),
        );
        u32::from(flags == Default::default())
    }

    /// Call `i` of the background's part: one sample moving at ≈ 20 quanta per 2·Ts.
    pub fn call_step(&mut self, i: u32) -> u32 {
        let v = SignalI16F16::from_raw((20 << 16) + at(&Y_TABLE, i).raw());
        let sample = HealthSample {
            v,
            u: [at(&U_TABLE, i), at(&U_TABLE, i.wrapping_add(1))],
            after_drop: false,
        };
        u32::from(self.config.step(&mut self.state, sample).bits())
    }
}

/// One position-controller step: the twin's baseline PID (P, integrator at ±70 mV with conditional
/// integration, derivative low-passed at 1 kHz) plus a 300 Hz reference prefilter — every option on.
pub struct PidBench {
    config: PidConfig,
    state: PidState,
}

impl PidBench {
    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let config = PidDesign {
            kp_v_per_quantum: 0.015,
            ki_v_per_quantum_s: 200.0,
            kd_v_s_per_quantum: 1.0e-5,
            integrator_limit_v: 0.07,
            derivative_lowpass_hz: 1000.0,
            reference_lowpass_hz: 300.0,
            ..PidDesign::new(0.455e-3, 5.0)
        }
        .build()
        .ok()?;
        Some(Self {
            config,
            state: PidState::new(),
        })
    }

    /// Call `i`: a reference a few hundred quanta from zero, the measurement a table value (a few
    /// quanta) around it.
    pub fn call(&mut self, i: u32) -> u32 {
        let r = PositionI48F16::from_counts(300);
        let y = PositionI48F16::from_raw(r.raw() + i64::from(at(&Y_TABLE, i).raw()));
        let o = self.config.step(&mut self.state, r, y);
        (o.u.raw() as u32) ^ u32::from(o.flags.bits())
    }
}

/// One full step of one of the paper's nonlinear models (simulation, sensitivities, RLS update with
/// N parameters, projection), from a fitted-looking θ (w ≠ 0: every derivative is non-trivial).
pub struct NonlinearBench<const N: usize> {
    config: NonlinearConfig<N>,
    state: NonlinearState<N>,
}

impl<const N: usize> NonlinearBench<N> {
    /// Builds the scenario for `structure` (`None` unless N is its parameter count:
    /// [`sledid::with_parameter_count`] picks N).
    pub fn new(structure: NonlinearStructure) -> Option<Self> {
        let linear: &[f64] = if structure.na() == 2 {
            &[-1.5, 0.6, 0.5, 0.2]
        } else {
            &[-0.9, 0.5]
        };
        let ranges = InputRanges {
            u: 0.5,
            y: 3.0,
            dy: 1.0,
        };
        let mut d = NonlinearDesign::<N>::from_linear(structure, linear, ranges);
        // Neuron output weights off zero.
        let first_w = 2 * structure.na();
        if let Some(w) = d.theta0.get_mut(first_w) {
            *w = 0.7;
        }
        d.rls = rls_design();
        let config = d.build().ok()?;
        let state = config.new_state();
        Some(Self { config, state })
    }

    /// Call `i`.
    pub fn call(&mut self, i: u32) -> u32 {
        self.config
            .step(&mut self.state, at(&Y_TABLE, i), at(&U_TABLE, i))
            .status
            .bits()
            .into()
    }
}

/// One gain-scheduled controller step (the per-sample path): the twin's baseline as fallback, the
/// nominal sled's velocity model as gains, the Coulomb inverse input map; the reference constant and
/// the measurement a table value (±2 quanta) around it, so Settle and Hold alternate with the
/// region logic, the supervisor and the map all running.
pub struct ScheduledBench {
    config: ScheduledConfig,
    state: ScheduledState,
}

impl ScheduledBench {
    /// The controller design of the scenario.
    pub fn design() -> Option<ScheduledDesign> {
        let baseline = PidDesign {
            kp_v_per_quantum: 0.015,
            ki_v_per_quantum_s: 200.0,
            kd_v_s_per_quantum: 1.0e-5,
            integrator_limit_v: 0.07,
            derivative_lowpass_hz: 1000.0,
            ..PidDesign::new(0.455e-3, 5.0)
        };
        let mut design = ScheduledDesign::new(baseline);
        design.prior_model = Some((0.8336, 23.66));
        design.compensation = Some(InverseInputMap::coulomb(0.0075, 0.9, 0.05).ok()?);
        Some(design)
    }

    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let config = Self::design()?.build().ok()?;
        Some(Self {
            state: Controller::new_state(&config),
            config,
        })
    }

    /// Call `i`: one step with an updated, small-ε identifier report.
    pub fn call(&mut self, i: u32) -> u32 {
        let r = PositionI48F16::from_counts(300);
        let y = PositionI48F16::from_raw(r.raw() + i64::from(at(&Y_TABLE, i).raw()));
        let report = ModelReport {
            status: Status::UPDATED,
            eps: at(&PSI_TABLE, i),
        };
        let o = self.config.step_law(&mut self.state, r, y, &report);
        (o.u.raw() as u32) ^ u32::from(o.flags.bits())
    }

    /// The time-optimal seek scenario: the same design with [`ScheduledDesign::with_time_optimal_seeks`].
    pub fn new_seek() -> Option<Self> {
        let config = Self::design()?.with_time_optimal_seeks().build().ok()?;
        Some(Self {
            state: Controller::new_state(&config),
            config,
        })
    }

    /// Call `i` of the seek scenario: one Seek-region step of the time-optimal law (velocity
    /// estimate, braking-curve search, model inverse, friction compensation, saturation), the
    /// error 20–650 quanta from the target (on the nominal model's braking curve, so the table
    /// search and its interpolation run) with the reading wobbling by the ±2-quantum table.
    pub fn call_seek(&mut self, i: u32) -> u32 {
        let r = PositionI48F16::from_counts(3000);
        let e_counts = 20 + i64::from(i % 64) * 10;
        let y =
            PositionI48F16::from_raw(r.raw() - (e_counts << 16) + i64::from(at(&Y_TABLE, i).raw()));
        let report = ModelReport {
            status: Status::UPDATED,
            eps: at(&PSI_TABLE, i),
        };
        let o = self.config.step_law(&mut self.state, r, y, &report);
        (o.u.raw() as u32) ^ u32::from(o.flags.bits()) ^ u32::from(o.region.index())
    }

    /// Call `i`: the same step, then the slow-rate redesign (f32 + libm, and the identified
    /// friction's inverse map) from a θ = [a₁, b₁, c] that varies with `i` (subtract the step's
    /// cost).
    pub fn call_with_redesign(&mut self, i: u32) -> u32 {
        let acc = self.call(i);
        let a = ParamI12F20::from_raw(-(858_000 + (i % 64) as i32 * 100));
        let b = ParamI12F20::from_raw(24_800_000 + (i % 64) as i32 * 1000);
        let mut theta = [ParamI12F20::ZERO; sledid::control::scheduled::MAX_MODEL_PARAMS];
        theta[0] = a;
        theta[1] = b;
        // c = b·u_c with u_c ≈ 0.0075 full scale: the redesign builds the friction map too.
        theta[2] = ParamI12F20::from_raw(195_000 + (i % 64) as i32 * 100);
        let job = sledid::control::scheduled::RedesignJob::Place {
            theta,
            len: 3,
            source: sledid::control::scheduled::ModelSource::Identified,
            gain_ratio: sledid::control::scheduled::learn::RATIO_ONE,
        };
        let design = Controller::redesign(&self.config, &job);
        Controller::adopt(&self.config, &mut self.state, &design);
        acc ^ u32::from(matches!(
            design.outcome,
            sledid::control::Redesign::Applied(_)
        ))
    }
}

/// The firmware's whole per-sample step (`sledid::servo`): scheduled controller + supervisor,
/// ARX(1,1) velocity identifier with its Coulomb term. Same scenario as [`ScheduledBench`].
pub struct LoopBench {
    config: sledid::servo::SledServo,
    state: sledid::servo::SledServoState,
}

impl LoopBench {
    /// Builds the scenario.
    pub fn new() -> Option<Self> {
        let controller = ScheduledBench::design()?;
        let mut velocity_model = LinearDesign::<3>::new(Structure::Arx, 1, 1);
        velocity_model.coulomb = true;
        velocity_model.theta0 = [-0.8336, 23.66, 0.18];
        velocity_model.rls = rls_design();
        let velocity = sledid::ident::step::IdentifierDesign::new(
            sledid::ident::conditioning::Conditioning::DifferencedOutput,
            velocity_model,
        );
        let config = sledid::servo::ServoDesign {
            controller,
            velocity,
            options: sledid::servo::ServoOptions::default(),
            safety: sledid::servo::SafetyDesign::default(),
            calibration: None,
        }
        .build()
        .ok()?;
        Some(Self {
            state: config.new_state(),
            config,
        })
    }

    /// Call `i`: the reference constant, the measurement a table value (±2 quanta) around it.
    pub fn call(&mut self, i: u32) -> u32 {
        let r = PositionI48F16::from_counts(300);
        let y = PositionI48F16::from_raw(r.raw() + i64::from(at(&Y_TABLE, i).raw()));
        let o = self.config.step(&mut self.state, r, y);
        (o.u.raw() as u32) ^ u32::from(o.identifier.status.bits())
    }
}

#[cfg(target_os = "none")]
mod target {
    use super::{
        ArxBench, DecimateBench, HealthBench, LoopBench, NeuronBench, NonlinearBench, PidBench,
        RlsBench, ScheduledBench,
    };
    use core::cell::RefCell;
    use cortex_m_rt::entry;
    use critical_section::Mutex;
    use sledid::ident::nonlinear::NonlinearStructure::{
        FrictionFeedback, Hammerstein, Noe221, NoeOutputInput, Wiener,
    };

    static RLS2: Mutex<RefCell<Option<RlsBench<2>>>> = Mutex::new(RefCell::new(None));
    static RLS3: Mutex<RefCell<Option<RlsBench<3>>>> = Mutex::new(RefCell::new(None));
    static RLS4: Mutex<RefCell<Option<RlsBench<4>>>> = Mutex::new(RefCell::new(None));
    static RLS4T: Mutex<RefCell<Option<RlsBench<4>>>> = Mutex::new(RefCell::new(None));
    static ARX4: Mutex<RefCell<Option<ArxBench<4>>>> = Mutex::new(RefCell::new(None));
    static NEURON: Mutex<RefCell<Option<NeuronBench>>> = Mutex::new(RefCell::new(None));
    static DECIMATE: Mutex<RefCell<Option<DecimateBench>>> = Mutex::new(RefCell::new(None));
    static PID: Mutex<RefCell<Option<PidBench>>> = Mutex::new(RefCell::new(None));
    static HAMMERSTEIN: Mutex<RefCell<Option<NonlinearBench<{ Hammerstein.parameter_count() }>>>> =
        Mutex::new(RefCell::new(None));
    static NOE: Mutex<RefCell<Option<NonlinearBench<{ NoeOutputInput.parameter_count() }>>>> =
        Mutex::new(RefCell::new(None));
    static NOE221: Mutex<RefCell<Option<NonlinearBench<{ Noe221.parameter_count() }>>>> =
        Mutex::new(RefCell::new(None));
    static WIENER: Mutex<RefCell<Option<NonlinearBench<{ Wiener.parameter_count() }>>>> =
        Mutex::new(RefCell::new(None));
    static FRICTION: Mutex<
        RefCell<Option<NonlinearBench<{ FrictionFeedback.parameter_count() }>>>,
    > = Mutex::new(RefCell::new(None));
    static SCHED: Mutex<RefCell<Option<ScheduledBench>>> = Mutex::new(RefCell::new(None));
    static REDESIGN: Mutex<RefCell<Option<ScheduledBench>>> = Mutex::new(RefCell::new(None));
    static SEEK: Mutex<RefCell<Option<ScheduledBench>>> = Mutex::new(RefCell::new(None));
    static LOOP: Mutex<RefCell<Option<LoopBench>>> = Mutex::new(RefCell::new(None));
    static HEALTH: Mutex<RefCell<Option<HealthBench>>> = Mutex::new(RefCell::new(None));

    /// Initialises every scenario (`--init bench_init`).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_init() {
        critical_section::with(|cs| {
            RLS2.borrow(cs).replace(RlsBench::new());
            RLS3.borrow(cs).replace(RlsBench::new());
            RLS4.borrow(cs).replace(RlsBench::new());
            RLS4T.borrow(cs).replace(RlsBench::with_trace_limit());
            ARX4.borrow(cs).replace(ArxBench::new());
            NEURON.borrow(cs).replace(NeuronBench::new());
            DECIMATE.borrow(cs).replace(DecimateBench::new());
            PID.borrow(cs).replace(PidBench::new());
            HAMMERSTEIN
                .borrow(cs)
                .replace(NonlinearBench::new(Hammerstein));
            NOE.borrow(cs).replace(NonlinearBench::new(NoeOutputInput));
            NOE221.borrow(cs).replace(NonlinearBench::new(Noe221));
            WIENER.borrow(cs).replace(NonlinearBench::new(Wiener));
            FRICTION
                .borrow(cs)
                .replace(NonlinearBench::new(FrictionFeedback));
            SCHED.borrow(cs).replace(ScheduledBench::new());
            REDESIGN.borrow(cs).replace(ScheduledBench::new());
            SEEK.borrow(cs).replace(ScheduledBench::new_seek());
            LOOP.borrow(cs).replace(LoopBench::new());
            HEALTH.borrow(cs).replace(HealthBench::new());
        });
    }

    /// The scaffolding alone (critical section, RefCell borrow), to subtract.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_overhead(i: u32) -> u32 {
        critical_section::with(|cs| {
            RLS2.borrow(cs).borrow_mut().as_mut().map_or(0, |b| {
                u32::from(core::hint::black_box(b as *mut _ as usize != 0)) + i
            })
        })
    }

    /// One RLS update, n = 2.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_rls2_update(i: u32) -> u32 {
        critical_section::with(|cs| {
            RLS2.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i).into())
        })
    }

    /// One RLS update, n = 3 (the servo's identifier).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_rls3_update(i: u32) -> u32 {
        critical_section::with(|cs| {
            RLS3.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i).into())
        })
    }

    /// One RLS update, n = 4.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_rls4_update(i: u32) -> u32 {
        critical_section::with(|cs| {
            RLS4.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i).into())
        })
    }

    /// One RLS update, n = 4, with the trace limit instead of the factor cap.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_rls4_trace_update(i: u32) -> u32 {
        critical_section::with(|cs| {
            RLS4T
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i).into())
        })
    }

    /// One ARX(2,2) step: regressor, prediction, RLS update, projection.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_arx4_step(i: u32) -> u32 {
        critical_section::with(|cs| {
            ARX4.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i).into())
        })
    }

    /// The 2-neuron layer of eq. 5: g, ∂g/∂x and the six parameter derivatives.
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_neuron_eval(i: u32) -> u32 {
        critical_section::with(|cs| {
            NEURON
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i))
        })
    }

    /// One input sample through the half-band decimator (mean over both phases).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_decimate_push(i: u32) -> u32 {
        critical_section::with(|cs| {
            DECIMATE
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i))
        })
    }

    /// The health estimator's interrupt part, one sample (mean over both phases of a pair).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_health_feed(i: u32) -> u32 {
        critical_section::with(|cs| {
            HEALTH
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call_feed(i))
        })
    }

    /// The health estimator's background part, one sample at 2·Ts (an update).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_health_step(i: u32) -> u32 {
        critical_section::with(|cs| {
            HEALTH
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call_step(i))
        })
    }

    /// One position-controller step (prefilter, P, I, low-passed D, saturation).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_pid_step(i: u32) -> u32 {
        critical_section::with(|cs| {
            PID.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i))
        })
    }

    /// A `bench_*` entry point running one call of the scenario in `$cell`.
    macro_rules! nonlinear_entry {
        ($(#[$doc:meta])* $name:ident, $cell:ident) => {
            $(#[$doc])*
            #[unsafe(no_mangle)]
            pub extern "C" fn $name(i: u32) -> u32 {
                critical_section::with(|cs| $cell.borrow(cs).borrow_mut().as_mut().map_or(0, |b| b.call(i)))
            }
        };
    }
    nonlinear_entry!(
        /// One eq. 5 Hammerstein step.
        bench_hammerstein_step,
        HAMMERSTEIN
    );
    nonlinear_entry!(
        /// One eq. 6 NOE step.
        bench_noe_step,
        NOE
    );
    nonlinear_entry!(
        /// One eq. 7 NOE 221 step.
        bench_noe221_step,
        NOE221
    );
    nonlinear_entry!(
        /// One first-order Wiener step.
        bench_wiener_step,
        WIENER
    );
    nonlinear_entry!(
        /// One friction-feedback step.
        bench_friction_step,
        FRICTION
    );
    nonlinear_entry!(
        /// The firmware's whole step: controller and velocity identifier.
        bench_loop_step,
        LOOP
    );

    /// One gain-scheduled controller step (regions, supervisor, law, inverse map, saturation).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_sched_step(i: u32) -> u32 {
        critical_section::with(|cs| {
            SCHED
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call(i))
        })
    }

    /// One time-optimal seek step (the Seek region's law, `sledid::control::seek`).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_seek_step(i: u32) -> u32 {
        critical_section::with(|cs| {
            SEEK.borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call_seek(i))
        })
    }

    /// One scheduled step plus the slow-rate redesign (f32 + libm pole placement).
    #[unsafe(no_mangle)]
    pub extern "C" fn bench_sched_redesign(i: u32) -> u32 {
        critical_section::with(|cs| {
            REDESIGN
                .borrow(cs)
                .borrow_mut()
                .as_mut()
                .map_or(0, |b| b.call_with_redesign(i))
        })
    }

    /// Keeps every bench entry point in the image (they are only reached by the emulator).
    #[used]
    static ENTRY_POINTS: [extern "C" fn(u32) -> u32; 20] = [
        bench_overhead,
        bench_rls2_update,
        bench_rls3_update,
        bench_rls4_update,
        bench_rls4_trace_update,
        bench_arx4_step,
        bench_neuron_eval,
        bench_decimate_push,
        bench_pid_step,
        bench_hammerstein_step,
        bench_noe_step,
        bench_noe221_step,
        bench_wiener_step,
        bench_friction_step,
        bench_sched_step,
        bench_seek_step,
        bench_sched_redesign,
        bench_loop_step,
        bench_health_feed,
        bench_health_step,
    ];

    #[entry]
    fn main() -> ! {
        bench_init();
        let mut i = 0u32;
        loop {
            core::hint::black_box(bench_rls2_update(i) + bench_rls4_update(i) + bench_arx4_step(i));
            core::hint::black_box(bench_overhead(i));
            i = i.wrapping_add(1);
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        // A permanently undefined instruction: the emulator (and a debugger) stops here.
        cortex_m::asm::udf()
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    let (Some(mut r2), Some(mut r4), Some(mut a4)) = (
        RlsBench::<2>::new(),
        RlsBench::<4>::new(),
        ArxBench::<4>::new(),
    ) else {
        eprintln!("bench scenarios failed to build");
        std::process::exit(1);
    };
    for i in 0..5000 {
        r2.call(i);
        r4.call(i);
        a4.call(i);
    }
    println!("rls2 θ = {:?}", r2.state.theta());
    println!("rls4 θ = {:?}", r4.state.theta());
    println!("arx4 θ = {:?}", a4.state.theta());
    if let (Some(mut nb), Some(mut db)) = (NeuronBench::new(), DecimateBench::new()) {
        let (mut n_acc, mut d_acc) = (0u32, 0u32);
        for i in 0..5000 {
            n_acc = n_acc.wrapping_add(nb.call(i));
            d_acc = d_acc.wrapping_add(db.call(i));
        }
        println!("neuron checksum = {n_acc:#x}, decimate checksum = {d_acc:#x}");
    }
    for s in NonlinearStructure::ALL {
        let acc = sledid::with_parameter_count!(s, |N| NonlinearBench::<N>::new(s)
            .map(|mut b| (0..5000).fold(0u32, |a, i| a ^ b.call(i))));
        println!("{} flags = {acc:?}", s.name());
    }
    if let Some(mut lb) = LoopBench::new() {
        let acc = (0..5000).fold(0u32, |a, i| a.wrapping_add(lb.call(i)));
        println!("loop checksum = {acc:#x}");
    }
    if let Some(mut pb) = PidBench::new() {
        let p_acc = (0..5000).fold(0u32, |acc, i| acc.wrapping_add(pb.call(i)));
        println!("pid checksum = {p_acc:#x}");
    }
    if let (Some(mut sb), Some(mut rb)) = (ScheduledBench::new(), ScheduledBench::new()) {
        let s_acc = (0..5000).fold(0u32, |acc, i| acc.wrapping_add(sb.call(i)));
        let r_acc = (0..500).fold(0u32, |acc, i| acc.wrapping_add(rb.call_with_redesign(i)));
        println!("scheduled checksum = {s_acc:#x}, with redesign = {r_acc:#x}");
    }
    if let Some(mut hb) = HealthBench::new() {
        let f_acc = (0..5000).fold(0u32, |acc, i| acc.wrapping_add(hb.call_feed(i)));
        let s_acc = (0..5000).fold(0u32, |acc, i| acc ^ hb.call_step(i));
        println!(
            "health feed checksum = {f_acc:#x}, step flags = {s_acc:#x}, θ = {:?}",
            hb.state.theta()
        );
    }
    println!(
        "Cost: build for thumbv7em-none-eabihf / thumbv6m-none-eabi and run count_insns.py (BENCHMARKS.md)."
    );
}
