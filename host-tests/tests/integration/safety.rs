//! The servo's safety layer (`sledid::servo::safety`) in the twin's closed loop, one test per
//! trigger: the servo (designed from the nominal prior) seeks normally for 1,500 samples, then a
//! fault; the drive must reach 0 and stay there, latched, within the documented number of
//! samples, and the sled must come to rest inside the soft end stops: on seed 5 for the servo
//! without calibration, and as statistics over seeds 1–8 for the servo calibrated at power-on
//! (the product). The figures are in RELIABILITY.md (safety layer).
//!
//! No false stop on ordinary seeks: `control_family.rs` asserts 0 safe stops over two families of
//! 200 plants (every servo variant, 8.7·10⁷ samples).

use sledid::servo::{ServoFlags, StopReason};
use sledid_host::control::{ScheduledLoop, design_from_prior, identifier_design, run::twin_safety};
use sledid_host::reference::control::position_from_quanta;
use sledid_host::twin::{PlantParams, Twin, TwinParams};

const FAULT_AT: usize = 1500;

/// What happens to the sensor, the drive or the plant from `FAULT_AT` on.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    /// The reading's sign is reversed.
    ReversedSensor,
    /// The drive's polarity is reversed.
    ReversedDrive,
    /// The reading stays at its last value.
    StuckSensor,
    /// No reading at all.
    LostSensor,
    /// The mass is multiplied.
    MassStep(f64),
    /// None (a seek past the end stops does the harm).
    None,
}

/// What the run showed.
#[derive(Debug)]
struct Outcome {
    /// The first safe stop: samples after the fault, reason.
    stop: Option<(usize, StopReason)>,
    /// Samples after the stop until the drive applied is 0 and stays 0.
    drive_zero_after: Option<usize>,
    /// Extremes of the true position over the whole run, quanta.
    x_min: f64,
    x_max: f64,
    /// The sled at rest at the end (true position unchanged over the last 200 samples).
    at_rest: bool,
}

fn run_seed(fault: Fault, targets: Option<Vec<i64>>, samples: usize, seed: u64) -> (Outcome, f64) {
    run_with(fault, targets, samples, seed, false)
}

fn run_with(
    fault: Fault,
    targets: Option<Vec<i64>>,
    samples: usize,
    seed: u64,
    calibrate: bool,
) -> (Outcome, f64) {
    let mut params = TwinParams::default();
    params.reference.targets_tracks = targets;
    params.reference.travel_tracks = 3000;
    let design = design_from_prior(&params, &PlantParams::default()).unwrap();
    let safety = twin_safety(&params, &design);
    // Commands may go past the end stops (the twin's own travel limit is wider).
    params.reference.travel_tracks = 10_000;
    let limit = safety.travel_max_quanta;
    let mut lp = ScheduledLoop::with_safety(
        &design,
        &identifier_design(&design),
        sledid::servo::ServoOptions::default(),
        safety,
    )
    .unwrap()
    .with_calibration(calibrate.then(sledid::servo::CalibrationDesign::default))
    .unwrap();
    let fs = design.baseline.u_full_scale_v;
    let mut twin = Twin::new(params, seed).unwrap();
    lp.calibrate(&mut twin);
    let mut k = 0usize;
    let mut stuck_y = 0.0;
    let mut stop = None;
    for _ in 0..samples {
        if k == FAULT_AT
            && let Fault::MassStep(factor) = fault
        {
            let m = twin.plant().mass_kg() * factor;
            twin.plant_mut().set_mass_kg(m);
        }
        let mut controller = |r: f64, y: f64| {
            let faulty = k >= FAULT_AT;
            if k == FAULT_AT {
                stuck_y = y;
            }
            let out = match fault {
                Fault::LostSensor if faulty => {
                    lp.config.step_lost(&mut lp.state, position_from_quanta(r))
                }
                _ => {
                    let y = match fault {
                        // Reversed about where it was at the fault: no jump, every motion after
                        // it read the wrong way.
                        Fault::ReversedSensor if faulty => 2.0 * stuck_y - y,
                        Fault::StuckSensor if faulty => stuck_y,
                        _ => y,
                    };
                    lp.config.step(
                        &mut lp.state,
                        position_from_quanta(r),
                        position_from_quanta(y),
                    )
                }
            };
            if let Some(design) = lp.config.run_background(&mut lp.state) {
                lp.redesigns.push(design.outcome);
            }
            if stop.is_none()
                && let Some(reason) = out.stop
            {
                assert!(out.servo.contains(ServoFlags::SAFE_STOP));
                stop = Some((k, reason));
            }
            let u = out.u.to_f64() * fs;
            k += 1;
            match fault {
                Fault::ReversedDrive if faulty => -u,
                _ => u,
            }
        };
        if twin.step(&mut controller).is_none() {
            break;
        }
    }
    let s = twin.samples();
    let q = twin.params().plant.quantum_m;
    let xs: Vec<f64> = s.iter().map(|x| x.x_m / q).collect();
    let tail = &xs[xs.len().saturating_sub(200)..];
    let outcome = Outcome {
        stop: stop.map(|(at, r)| (at.saturating_sub(FAULT_AT), r)),
        drive_zero_after: stop.map(|(at, _)| {
            // The first sample from the stop on with u = 0 (it stays 0: latched, asserted below).
            let from = s
                .iter()
                .skip(at)
                .position(|x| x.u_v == 0.0)
                .unwrap_or(usize::MAX);
            assert!(s.iter().skip(at + from).all(|x| x.u_v == 0.0), "latched");
            from
        }),
        x_min: xs.iter().copied().fold(f64::MAX, f64::min),
        x_max: xs.iter().copied().fold(f64::MIN, f64::max),
        at_rest: tail.iter().all(|&x| x == tail[0]),
    };
    println!("{fault:?}: {outcome:?} (end stops ±{limit})");
    (outcome, limit)
}

fn run(fault: Fault, targets: Option<Vec<i64>>, samples: usize) -> (Outcome, f64) {
    run_seed(fault, targets, samples, 5)
}

/// The servo calibrated at power-on (the product) on seeds 1–8: per seed the samples from the
/// fault to the stop, each stop checked by [`assert_stopped`] but the bound, which is asserted
/// on the largest.
fn calibrated_over_seeds(fault: Fault, reason: StopReason, within: usize) -> Vec<usize> {
    let after: Vec<usize> = (1..=8)
        .map(|seed| {
            let (o, limit) = run_with(fault, None, 8000, seed, true);
            assert_stopped(&o, limit, reason, usize::MAX);
            o.stop.map_or(usize::MAX, |s| s.0)
        })
        .collect();
    println!("{fault:?}, calibrated, seeds 1–8: stopped after {after:?} samples");
    assert!(after.iter().all(|&a| a <= within), "{after:?}");
    after
}

fn assert_stopped(o: &Outcome, limit: f64, reason: StopReason, within: usize) {
    let (after, r) = o.stop.expect("a safe stop");
    assert_eq!(r, reason);
    assert!(after <= within, "stopped {after} samples after the fault");
    assert_eq!(
        o.drive_zero_after,
        Some(0),
        "the drive is 0 on the stop's own sample"
    );
    assert!(o.x_max < limit && o.x_min > -limit, "{o:?}");
    assert!(o.at_rest, "{o:?}");
}

/// A reversed sensor: the servo's own feedback turns positive. Runaway (N = 16 samples of |e|
/// growing). Measured 16 samples after the reversal on seed 5 without calibration (16 on seeds
/// 1–8), 16–18 with it (seeds 1–8). Bounded at 18 and 20: a runaway rule that needs a longer
/// window, or counts from the wrong sample, trips it.
#[test]
fn a_reversed_sensor_stops_the_servo() {
    let (o, limit) = run(Fault::ReversedSensor, None, 6000);
    assert_stopped(&o, limit, StopReason::Runaway, 18);
    calibrated_over_seeds(Fault::ReversedSensor, StopReason::Runaway, 20);
}

/// A reversed drive: the same, from the other end of the loop. Measured 19 samples on seed 5
/// (19–21 on seeds 1–8) without calibration, 19–22 with it. Bounded at 21 and 24.
#[test]
fn a_reversed_drive_stops_the_servo() {
    let (o, limit) = run(Fault::ReversedDrive, None, 6000);
    assert_stopped(&o, limit, StopReason::Runaway, 21);
    calibrated_over_seeds(Fault::ReversedDrive, StopReason::Runaway, 24);
}

/// A sensor stuck while the servo drives: no reading change for S = 32 samples under a drive of
/// at least u_stall (stall), before the sled, which the servo cannot see any more, reaches an end
/// stop. Without calibration u_stall is the configuration's 24× the prior's Coulomb level (0.18
/// of full scale on the nominal prior): measured 34 samples on seed 5, 32–48 on seeds 1–8 but
/// **706 on seed 7**, where the hold's integrator drives the unseen sled at 0.16 of full scale,
/// under u_stall, 17,000 tracks past the end stop before the next command trips the rule — the
/// servo without calibration cannot tell that drive from a sticky sled's. With calibration
/// u_stall is 3× the breakaway measured on the sled (`SafetyState::set_stall_drive`): 32 samples
/// on seeds 1–6 and 8, 61 on seed 7, every sled inside the travel. Bounded at 36 (seed 5) and 64.
#[test]
fn a_stuck_sensor_stops_the_servo() {
    let (o, limit) = run(Fault::StuckSensor, None, 6000);
    assert_stopped(&o, limit, StopReason::Stall, 36);
    calibrated_over_seeds(Fault::StuckSensor, StopReason::Stall, 64);
}

/// No reading at all: bridged for K = 16 samples, then stopped (16 on every seed, with and
/// without calibration).
#[test]
fn a_lost_sensor_stops_the_servo() {
    let (o, limit) = run(Fault::LostSensor, None, 6000);
    assert_stopped(&o, limit, StopReason::SensorLost, 16);
    calibrated_over_seeds(Fault::LostSensor, StopReason::SensorLost, 16);
}

/// A seek commanded past the soft end stop (3,000 tracks of travel, end stops at ±4,500): the
/// servo cuts the drive where the sled would coast past the stop, and it comes to rest inside.
#[test]
fn a_seek_past_the_end_stop_stops_inside_it() {
    let (o, limit) = run(Fault::None, Some(vec![1000, -2000, 9000, 0]), 6000);
    let (_, reason) = o.stop.expect("a safe stop");
    assert_eq!(reason, StopReason::Travel);
    assert!(o.x_max < limit && o.x_min > -limit, "{o:?}");
    assert!(o.at_rest);
}

/// A mass step mid-seek: a hundred times the mass, the sled cannot be braked as the servo expects
/// and runs on past the target with the drive against it (runaway, measured 18 samples after the
/// step on seed 5; 17–19 on seeds 1–6 and 8 without calibration, **1,411 on seed 7**, where the
/// step lands in a dwell); a tenth of the mass the servo re-identifies and keeps (no stop). Both
/// end at rest inside the travel. With calibration (seeds 1–8): runaway at 16–18 samples on seven
/// seeds; on seed 7 the servo calibrates again, and calibration refuses the sled
/// (`calibration_stuck`, 415 samples after the step; since the breakaway search holds its cap 16
/// samples, 2026-11-27, the heavy sled moves there and runs out of the experiment's samples:
/// `calibration_timeout`): every seed stops, at rest inside the travel. (Measured in between: ×3 and ×10 are braked and held without a stop; ×30 swings
/// slowly inside the travel without a stop; ×300 is stopped at 18 samples but coasts past the end
/// stop, beyond any margin.)
#[test]
fn a_mass_step_the_loop_cannot_brake_stops() {
    let (o, limit) = run(Fault::MassStep(100.0), None, 8000);
    assert_stopped(&o, limit, StopReason::Runaway, 20);
    let (mut runaways, mut inside) = (0, 0);
    for seed in 1..=8 {
        let (o, limit) = run_with(Fault::MassStep(100.0), None, 8000, seed, true);
        let (after, reason) = o.stop.expect("a safe stop");
        match reason {
            StopReason::Runaway => {
                runaways += 1;
                assert!(after <= 20, "seed {seed}: {after}");
            }
            StopReason::Calibration(
                sledid::servo::Refusal::Stuck | sledid::servo::Refusal::Timeout,
            ) => {}
            other => panic!("seed {seed}: {other:?}"),
        }
        assert!(o.at_rest, "seed {seed}: {o:?}");
        inside += usize::from(o.x_max < limit && o.x_min > -limit);
    }
    assert!(runaways >= 7, "{runaways}");
    // The drive is cut, not reversed: a sled of 100× the mass caught at seek speed coasts on
    // (seeds 3 and 4 come to rest 2,400–2,900 tracks past the ±4,500 end stop, measured) — the
    // degradation the ×300 case above shows on every seed. Measured inside: 6 of 8.
    assert!(inside >= 6, "{inside} of 8 inside the travel");
    let (o, limit) = run(Fault::MassStep(0.1), None, 8000);
    assert_eq!(o.stop, None, "a lighter sled is adapted to, not stopped");
    assert!(o.x_max < limit && o.x_min > -limit && o.at_rest, "{o:?}");
}

/// The servo's controller with its fallback entered on command (the test sets `forced` before a
/// sample): everything else is the scheduled controller's.
struct ForcedFallback {
    inner: sledid::control::ScheduledConfig,
    forced: std::cell::Cell<bool>,
}

impl sledid::control::Controller for ForcedFallback {
    type State = sledid::control::ScheduledState;
    type Job = <sledid::control::ScheduledConfig as sledid::control::Controller>::Job;
    type Design = <sledid::control::ScheduledConfig as sledid::control::Controller>::Design;

    fn new_state(&self) -> Self::State {
        self.inner.new_state()
    }
    fn step(
        &self,
        state: &mut Self::State,
        input: &sledid::control::ControlInput,
    ) -> sledid::control::ControlOutput {
        let mut out = self.inner.step(state, input);
        if self.forced.get() {
            out.flags.insert(sledid::control::ControlFlags::FALLBACK);
        }
        out
    }
    fn redesign_job(
        &self,
        state: &mut Self::State,
        theta: &[sledid::ParamI12F20],
    ) -> Option<Self::Job> {
        self.inner.redesign_job(state, theta)
    }
    fn redesign(&self, job: &Self::Job) -> Self::Design {
        self.inner.redesign(job)
    }
    fn adopt(&self, state: &mut Self::State, design: &Self::Design) {
        self.inner.adopt(state, design);
    }
    fn place_job(&self, theta: &[sledid::ParamI12F20]) -> Self::Job {
        self.inner.place_job(theta)
    }
    fn placed(design: &Self::Design) -> bool {
        sledid::control::ScheduledConfig::placed(design)
    }
}

/// What a run of forced fallbacks showed: per forced entry (1-based), the servo's flags on that
/// sample and on the next, and the stop; the identifier's θ at the end.
struct Entries {
    flags: Vec<(ServoFlags, ServoFlags, Option<StopReason>)>,
    theta_end: Vec<f64>,
    theta_prior: Vec<f64>,
    calibrations: u32,
}

/// The nominal sled seeking on seed 3 for 3,000 samples (after power-on calibration when
/// `calibrate`), then 10 entries into the fallback: 10 samples forced, 10 free, ten times.
fn forced_entries(calibrate: bool) -> Entries {
    use sledid::servo::{ServoConfig, ServoOptions};
    let mut params = TwinParams::default();
    params.reference.seek_count = 20;
    let design = design_from_prior(&params, &PlantParams::default()).unwrap();
    let built = ScheduledLoop::with_safety(
        &design,
        &identifier_design(&design),
        ServoOptions::default(),
        twin_safety(&params, &design),
    )
    .unwrap()
    .with_calibration(calibrate.then(sledid::servo::CalibrationDesign::default))
    .unwrap()
    .config;
    let controller = ForcedFallback {
        inner: *built.controller(),
        forced: std::cell::Cell::new(false),
    };
    let servo = ServoConfig::new(
        controller,
        *built.identifier(),
        ServoOptions::default().build().unwrap(),
        *built.safety(),
    )
    .with_calibration(built.calibration().copied());
    let mut state = servo.new_state();
    let fs = design.baseline.u_full_scale_v;
    let mut twin = Twin::new(params, 3).unwrap();
    let mut k = 0usize;
    // After the first 3,000 samples: (running samples since, the servo's flags, its stop) per
    // sample. The phase counts only samples where the controller runs (not calibrating).
    let mut outs: Vec<(usize, ServoFlags, Option<StopReason>)> = Vec::new();
    let mut phase: Option<usize> = None;
    while phase.is_none_or(|p| p < 200) {
        let mut controller = |r: f64, y: f64| {
            let running = !state.calibration().is_running();
            if running && phase.is_none() && k >= 3_000 {
                phase = Some(0);
            }
            let p = phase.filter(|_| running);
            servo
                .controller()
                .forced
                .set(p.is_some_and(|p| p % 20 < 10));
            let out = servo.step(&mut state, position_from_quanta(r), position_from_quanta(y));
            servo.run_background(&mut state);
            if let Some(at) = phase {
                outs.push((at, out.servo, out.stop));
                if running {
                    phase = Some(at + 1);
                }
            }
            k += 1;
            out.u.to_f64() * fs
        };
        assert!(twin.step(&mut controller).is_some(), "the schedule ran out");
    }
    // Entry i: the first sample of running phase 20·i, and the sample after it.
    let flags = (0..10)
        .map(|i| {
            let at = outs.iter().position(|o| o.0 == 20 * i).unwrap();
            (outs[at].1, outs[at + 1].1, outs[at].2)
        })
        .collect();
    let theta = |t: &[sledid::ParamI12F20]| t.iter().map(|p| p.to_f64()).collect::<Vec<_>>();
    Entries {
        flags,
        theta_end: theta(state.identifier().model().theta()),
        theta_prior: theta(servo.identifier().new_state().model().theta()),
        calibrations: state.calibrations(),
    }
}

/// Issue 22, item 5: the entry that would stop the servo for its fallbacks (the fifth within
/// 8,192 samples) is recovered from once per window — without calibration by suspending
/// identification on the prior's design, with it by calibrating again — and the next five
/// entries within the window stop it (the last resort). Trips on a recovery removed (a stop on
/// the fifth entry), granted twice (no stop on the tenth), a suspension that keeps what was
/// learnt or keeps adapting (θ ≠ the prior's at the end), a recovery that does not calibrate
/// again, or entries the recovery forgot counted again.
#[test]
fn repeated_fallbacks_are_recovered_from_before_the_stop() {
    for calibrate in [false, true] {
        let e = forced_entries(calibrate);
        let what = if calibrate {
            "calibrated"
        } else {
            "without calibration"
        };
        for (i, (flags, _, stop)) in e.flags.iter().enumerate().take(9) {
            assert_eq!(*stop, None, "{what}: entry {} stopped", i + 1);
            assert!(
                !flags.contains(ServoFlags::SAFE_STOP),
                "{what}: entry {}",
                i + 1
            );
        }
        assert_eq!(
            e.flags[9].2,
            Some(StopReason::Fallbacks),
            "{what}: the tenth entry, five after the recovery"
        );
        let suspended = |i: usize| e.flags[i].0.contains(ServoFlags::IDENTIFICATION_SUSPENDED);
        if calibrate {
            assert!(!suspended(4) && !suspended(8), "{what}: suspended");
            assert!(
                e.flags[4].1.contains(ServoFlags::CALIBRATING),
                "{what}: no calibration after the fifth entry"
            );
            assert!(!e.flags[3].1.contains(ServoFlags::CALIBRATING));
            assert_eq!(e.calibrations, 2, "{what}: power-on's and the recovery's");
        } else {
            assert!(!suspended(3), "{what}: suspended before the fifth entry");
            assert!(
                suspended(4) && suspended(8),
                "{what}: not suspended from the fifth on"
            );
            assert_eq!(e.theta_end, e.theta_prior, "{what}: θ is not the prior's");
            assert_eq!(e.calibrations, 0);
        }
    }
}
