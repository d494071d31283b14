//! Power-on calibration (`sledid::servo::calibration`): the experiment and its fit on the plant
//! family, the fit against its float64 reference, and the sleds it must refuse.
//!
//! Measured (`cargo test -p sledid-host --test integration calibration:: -- --nocapture`; the servo designed
//! from the nominal prior, each plant of the family calibrated once, noise seed = plant index):
//!
//! | family seed | gain b within 10 % / 25 % | b error median / max | samples median / max | travel median / max (quanta) | Coulomb ≥ 0.5 % FS within 25 % |
//! |---|---|---|---|---|---|
//! | 1 | 197 / 200 of 200 | 1.1 % / 11.5 % | 159 / 235 | 46 / 92 | 112 of 117 |
//! | 7 | 195 / 200 of 200 | 1.3 % / 16.5 % | 162 / 249 | 47 / 80 | 124 of 132 |
//!
//! The misses beyond 10 % are strongly damped sleds (a ≤ 0.35) whose pole and gain trade off
//! within a track's quantisation. BENCHMARKS.md (calibration) holds the per-plant figures.

use sledid::PositionI48F16;
use sledid::control::scheduled::RedesignJob;
use sledid::servo::calibration::fit;
use sledid::servo::{CalibrationDesign, Posted, Refusal, ServoFlags, StopReason};
use sledid_host::control::calibration::{CalibrationCheck, calibrate, family};
use sledid_host::control::design::physical_model;
use sledid_host::control::design::{design_from_prior, identifier_design};
use sledid_host::control::family::{Corner, FamilyRanges};
use sledid_host::control::family_eval::FamilyOptions;
use sledid_host::control::run::ScheduledLoop;
use sledid_host::control::seek::run::seek_design;
use sledid_host::reference::calibration::fit_f64;
use sledid_host::reference::control::position_from_quanta;
use sledid_host::twin::{PlantParams, SledController, Twin, TwinParams};

fn quantile(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn checks(seed: u64) -> Vec<CalibrationCheck> {
    let c = family(&FamilyOptions {
        plants: 200,
        seed,
        ..FamilyOptions::default()
    })
    .expect("the family calibrates");
    let err: Vec<f64> = c.iter().map(CalibrationCheck::gain_error).collect();
    let within = |t: f64| err.iter().filter(|e| **e <= t).count();
    let samples: Vec<f64> = c.iter().map(|c| c.samples as f64).collect();
    let travel: Vec<f64> = c.iter().map(|c| c.travel_quanta).collect();
    let coulomb: Vec<f64> = c
        .iter()
        .filter(|c| c.true_coulomb_fs >= 0.005)
        .map(CalibrationCheck::coulomb_error)
        .collect();
    println!(
        "seed {seed}: b within 10 % {} / 25 % {} of {}, error median {:.3} max {:.3}; samples median {} max {}; travel median {:.0} max {:.0}; Coulomb ≥ 0.5 % FS within 25 %: {} of {}",
        within(0.10),
        within(0.25),
        c.len(),
        quantile(err.clone(), 0.5),
        quantile(err.clone(), 1.0),
        quantile(samples.clone(), 0.5),
        quantile(samples, 1.0),
        quantile(travel.clone(), 0.5),
        quantile(travel, 1.0),
        coulomb.iter().filter(|e| **e <= 0.25).count(),
        coulomb.len()
    );
    for c in c.iter().filter(|c| c.gain_error() > 0.1) {
        println!(
            "  plant {} {:?}: true {:?} found {:?}",
            c.index, c.refusal, c.true_model, c.found
        );
    }
    c
}

/// The targets on each family: b within ±10 % of the truth on ≥ 95 % of the plants and
/// within ±25 % on all, no healthy sled refused, ≤ 330 samples and ≤ 200 quanta of travel, the
/// Coulomb level within ±25 % on ≥ 90 % of the plants whose Coulomb level is ≥ 0.5 % of full
/// scale (none of the family reaches the 5 %: its largest is 3 %). Trips on a fit that
/// ignores the ZOH's intra-sample motion or the Coulomb term (b off by the friction's share), a
/// push that stops before the sled shows its pole, a breakaway search that mistakes creep for a
/// reversed sled (the refusals), or a rest that does not brake a coasting sled (travel).
#[test]
fn calibration_measures_every_plant_of_the_family() {
    for seed in [1, 7] {
        let c = checks(seed);
        assert_eq!(c.len(), 200);
        let refused: Vec<_> = c.iter().filter(|c| c.refusal.is_some()).collect();
        assert!(refused.is_empty(), "seed {seed}: refused {refused:?}");
        let within = |t: f64| c.iter().filter(|c| c.gain_error() <= t).count();
        assert!(within(0.10) >= 190, "seed {seed}: {}", within(0.10));
        assert_eq!(within(0.25), 200, "seed {seed}");
        assert!(c.iter().all(|c| c.samples <= 330), "seed {seed}");
        assert!(c.iter().all(|c| c.travel_quanta <= 200.0), "seed {seed}");
        let coulomb: Vec<_> = c.iter().filter(|c| c.true_coulomb_fs >= 0.005).collect();
        let good = coulomb.iter().filter(|c| c.coulomb_error() <= 0.25).count();
        assert!(
            good * 10 >= coulomb.len() * 9,
            "seed {seed}: {good} of {}",
            coulomb.len()
        );
    }
}

/// The `f32` fit against its float64 reference on every record of family seed 1: the pole, the
/// gain b and the Coulomb level. Trips on a fit whose golden section stops at the grid, whose
/// elimination loses precision (an f32 residual by the normal equations' cancellation measured
/// 5 % on b) or whose model differs from the reference's.
#[test]
fn the_fit_matches_float64() {
    let c = family(&FamilyOptions {
        plants: 200,
        seed: 1,
        ..FamilyOptions::default()
    })
    .expect("the family calibrates");
    let (mut worst_a, mut worst_b, mut worst_c) = (0.0f64, 0.0f64, 0.0f64);
    for check in &c {
        let out = &check.outcome;
        let m = out.model.expect("calibrated");
        let r = fit_f64(&out.record).expect("the reference fits");
        worst_a = worst_a.max((f64::from(m.a) - r.a).abs());
        worst_b = worst_b.max((f64::from(m.b()) / r.b() - 1.0).abs());
        let cr = 0.5 * (r.coulomb_fs[0] + r.coulomb_fs[1]);
        worst_c = worst_c.max((f64::from(m.coulomb_mean_fs()) - cr.max(0.0)).abs());
    }
    println!("f32 − f64: a {worst_a:.2e}, b (relative) {worst_b:.2e}, u_c {worst_c:.2e} FS");
    // Measured 5.1·10⁻⁴, 5.5·10⁻⁴, 1.5·10⁻⁵: bounded at twice that.
    assert!(worst_a <= 1e-3, "a {worst_a}");
    assert!(worst_b <= 1.1e-3, "b {worst_b}");
    assert!(worst_c <= 3e-5, "u_c {worst_c}");
}

/// The family's four corners ([`Corner`]: fastest and slowest in quanta, with the most friction
/// and noise or none), noise seeds 0–3: every one calibrates, its gain b within 25 % of the truth.
/// Measured 2026-11-27: b error ≤ 21 % (fast and sticky: its fit leaves 2.2–3.3 quanta of
/// residual at 35 quanta per sample — refused by a flat 1.5-quanta limit before the limit
/// followed the record's speed; the other corners ≤ 6.3 %). Trips on a residual limit that does not
/// scale with the sled's speed, and on an experiment that cannot move or stop a corner sled.
#[test]
fn calibration_measures_the_family_corners() {
    let ranges = FamilyRanges::default();
    let prior = PlantParams::default();
    for corner in Corner::ALL {
        let params = ranges.corner(corner).twin(&TwinParams::default());
        let truth = physical_model(&params.plant).1;
        for seed in 0..4 {
            let out = calibrate(&params, &prior, CalibrationDesign::default(), seed)
                .expect("a calibration");
            let model = out
                .model
                .unwrap_or_else(|| panic!("{} seed {seed}: {:?}", corner.name(), out.refusal));
            let error = (f64::from(model.b()) / truth - 1.0).abs();
            println!(
                "{} seed {seed}: b {:.3} (true {truth:.3}, {:.1} %), residual {:.2} quanta",
                corner.name(),
                model.b(),
                100.0 * error,
                model.rms
            );
            assert!(
                error <= 0.25,
                "{} seed {seed}: b off by {error}",
                corner.name()
            );
        }
    }
}

/// A record that is not a sled's motion is refused for its residual however fast it is: the
/// fast, sticky corner's record with every other reading set back to where its push started
/// (a reading that jumps back and forth by the whole push) leaves a residual far above both
/// limits. Trips on a residual limit that scales so far with the record's steps that nothing is
/// refused.
#[test]
fn calibration_refuses_a_record_that_is_not_motion() {
    let params = FamilyRanges::default()
        .corner(Corner::FastSticky)
        .twin(&TwinParams::default());
    let out = calibrate(
        &params,
        &PlantParams::default(),
        CalibrationDesign::default(),
        0,
    )
    .expect("a calibration");
    let config = CalibrationDesign::default()
        .build()
        .expect("the default builds");
    assert!(fit(&config, &out.record).is_ok(), "the record itself fits");
    let mut zigzag = out.record;
    for seg in &mut zigzag.segments {
        for x in seg.x_i16f16.iter_mut().skip(1).step_by(2) {
            *x = 0;
        }
    }
    assert_eq!(fit(&config, &zigzag).map(|m| m.rms), Err(Refusal::Fit));
}

/// The servo with calibration on `plant`, its drive (`reverse_drive`) or its reading
/// (`reverse_sensor`) reversed, run for `samples` samples fed its own reading as the reference:
/// per sample the drive (V) and the latched stop.
fn run_faulty(
    plant: PlantParams,
    samples: usize,
    reverse_drive: bool,
    reverse_sensor: bool,
) -> (ScheduledLoop, Vec<(f64, Option<StopReason>)>) {
    let params = TwinParams {
        plant,
        ..TwinParams::default()
    };
    let d = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let mut servo = ScheduledLoop::new(&d, &identifier_design(&d))
        .unwrap()
        .with_calibration(Some(CalibrationDesign::default()))
        .unwrap();
    let mut twin = Twin::new(params, 3).unwrap();
    let mut log = Vec::new();
    let mut wrapped = |_r: f64, y: f64| {
        let y = if reverse_sensor { -y } else { y };
        let u = servo.step(y, y);
        log.push((u, servo.state.safe_stop()));
        if reverse_drive { -u } else { u }
    };
    twin.pre_roll(&mut wrapped, |_| false, samples);
    (servo, log)
}

/// A sled that does not respond like one ends calibration stopped, with the drive cut, and never
/// starts seeking: a stuck sled (static friction beyond the rail), a reversed drive, a reversed
/// sensor, a sled whose gain is 1/400 of the prior's or 50× it (outside the family's range × 4).
/// Each stop says why, within the experiment's budget (measured: samples 30, 20, 20, 30 and 243;
/// asserted ≤ 400, the 330-sample budget and the fit's 64-sample hand-over); a reset runs
/// calibration again, which refuses again. Trips on a refusal that is not
/// latched (the drive comes back), a check that is missing (the sled is calibrated and seeks) or
/// a reset that skips calibration.
#[test]
fn calibration_refuses_what_is_not_a_sled() {
    let nominal = PlantParams::default();
    let cases: [(&str, PlantParams, bool, bool, &[StopReason]); 5] = [
        (
            "stuck",
            PlantParams {
                static_n: 100.0,
                ..nominal.clone()
            },
            false,
            false,
            &[StopReason::Calibration(Refusal::Stuck), StopReason::Stall],
        ),
        (
            "reversed drive",
            nominal.clone(),
            true,
            false,
            &[
                StopReason::Calibration(Refusal::Reversed),
                StopReason::Runaway,
            ],
        ),
        (
            "reversed sensor",
            nominal.clone(),
            false,
            true,
            &[
                StopReason::Calibration(Refusal::Reversed),
                StopReason::Runaway,
            ],
        ),
        (
            "gain / 400",
            PlantParams {
                mass_kg: nominal.mass_kg * 400.0,
                viscous_n_s_per_m: nominal.viscous_n_s_per_m * 0.01,
                ..nominal.clone()
            },
            false,
            false,
            // Too slow to move 2 quanta within the breakaway search's levels: stuck — or, since
            // the search holds its cap 16 samples (the slow, sticky corner needs them), moved
            // there and out of the experiment's 330 samples in its pushes (measured: timeout).
            &[
                StopReason::Calibration(Refusal::Gain),
                StopReason::Calibration(Refusal::Stuck),
                StopReason::Calibration(Refusal::Timeout),
            ],
        ),
        (
            "gain × 50",
            PlantParams {
                quantum_m: nominal.quantum_m / 50.0,
                ..nominal.clone()
            },
            false,
            false,
            // Its 40-quanta pushes coast past the experiment's travel first (measured: at 243).
            &[
                StopReason::Calibration(Refusal::Gain),
                StopReason::Calibration(Refusal::Travel),
            ],
        ),
    ];
    for (name, plant, rev_drive, rev_sensor, expected) in cases {
        let (mut servo, log) = run_faulty(plant.clone(), 2000, rev_drive, rev_sensor);
        let stop = servo.state.safe_stop();
        println!(
            "{name}: stop {stop:?} at sample {:?}",
            log.iter().position(|l| l.1.is_some())
        );
        assert!(
            stop.is_some_and(|s| expected.contains(&s)),
            "{name}: {stop:?}"
        );
        assert!(!servo.state.calibration().is_done(), "{name}");
        let at = log.iter().position(|l| l.1.is_some()).expect("stopped");
        assert!(at <= 400, "{name}: stopped at {at}");
        assert!(
            log[at..].iter().all(|l| l.0 == 0.0),
            "{name}: drive after the stop"
        );
        // A reset runs calibration again from where the sled is, into the same refusal.
        servo.config.reset_safe_stop(&mut servo.state);
        assert!(servo.state.safe_stop().is_none());
        assert!(servo.state.calibration().is_running(), "{name}");
        let out = servo.config.step(
            &mut servo.state,
            PositionI48F16::default(),
            PositionI48F16::default(),
        );
        assert!(out.servo.contains(ServoFlags::CALIBRATING), "{name}");
    }
}

/// The calibrated seek mode on the nominal sled whose mass (`mass`) or friction (`friction`)
/// changes by the given factor at sample `at`: the stop, the calibrations adopted, the seeks
/// after the change, how many of them are unsettled, and the seeks' learnt gain ratio at the end
/// (`sledid::control::scheduled::learn`).
fn plant_change(
    seed: u64,
    mass: f64,
    friction: f64,
    at: usize,
) -> (Option<StopReason>, u32, usize, usize, f64) {
    use sledid::servo::{Identification, ServoOptions};
    use sledid_host::control::run::twin_safety;
    use sledid_host::control::seek::SeekOptions;
    use sledid_host::control::seek::run::rows_of;
    use sledid_host::twin::ReferenceProfile;
    let schedule = SeekOptions {
        seeks: 60,
        seed,
        ..SeekOptions::default()
    };
    let params = schedule
        .twin_params(&TwinParams::default(), ReferenceProfile::Step)
        .unwrap();
    let d = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let options = ServoOptions {
        identification: Identification::FrozenAtPrior,
        ..ServoOptions::default()
    };
    let mut servo = ScheduledLoop::with_safety(
        &d,
        &identifier_design(&d),
        options,
        twin_safety(&params, &d),
    )
    .unwrap()
    .with_calibration(Some(CalibrationDesign::default()))
    .unwrap();
    let mut twin = Twin::new(params, seed).unwrap();
    servo.calibrate(&mut twin);
    while twin.step(&mut servo).is_some() {
        if twin.samples().len() == at {
            twin.plant_mut().scale_mass(mass);
            twin.plant_mut().scale_friction(friction);
        }
    }
    let first_after = twin
        .seeks()
        .iter()
        .position(|s| s.start_index >= at)
        .unwrap_or(usize::MAX);
    let rows = rows_of(&twin);
    let after: Vec<_> = rows.iter().filter(|r| r.index >= first_after).collect();
    (
        servo.state.safe_stop(),
        servo.state.calibrations(),
        after.len(),
        after.iter().filter(|r| !r.settled).count(),
        f64::from(servo.state.controller().learner().ratio()) / 65_536.0,
    )
}

/// A plant change under the calibrated seek mode, 60 seeks of 20–2,000 tracks, the change at
/// sample 15,000 (seek 23), 37 seeks after it, seeds 1–4. Measured:
///
/// | change | calibrations | unsettled seeks after it, seeds 1–4 | without the watch (before it existed) |
/// |---|---|---|---|
/// | mass × 0.4 | 2 on every seed (since the seeks' gain learner: 1, the learnt gain ratio 1.42 / 1.45 / 1.21 / … ) | 0 / 0 / 0 / 0 | 9 / 2 / 2 / 3 |
/// | mass × 0.25, mass × 0.4 with friction × 0.3 | 2 on every seed | 0 on every seed | – |
/// | mass × 3, friction × 3 | 1 (the slower sled still lands) | 0 on every seed | 0 |
/// | mass × 8 | 1 | 0 / 0 / 1 / 1 | – |
///
/// No stop in any case. Asserted: no stop; a faster sled calibrated again on every seed — or,
/// since the seeks learn their gain (`sledid::control::scheduled::learn`, 2026-11-27), its
/// change taken up by the learner instead (ratio ≥ 1.1: beyond calibration's error and the
/// learner's 1.6 % redesign step) — with ≤ 1 unsettled seek over the four seeds; the slower ones
/// ≤ 2 over the four seeds. Trips on a watch that never fires while the learner does not
/// either (the faster sled's 16 unsettled seeks), one that fires on a healthy settle
/// (extra calibrations on the slower sleds are allowed, stops are not), or a re-calibration that
/// is not adopted or leaves the command unfollowed (its seeks unsettled).
#[test]
fn a_plant_change_is_calibrated_again_in_the_next_dwell() {
    for (mass, friction, faster) in [
        (0.4, 1.0, true),
        (0.25, 1.0, true),
        (0.4, 0.3, true),
        (3.0, 1.0, false),
        (1.0, 3.0, false),
        (8.0, 1.0, false),
    ] {
        let mut unsettled = 0;
        for seed in 1..=4 {
            let (stop, calibrations, after, lost, learnt) =
                plant_change(seed, mass, friction, 15_000);
            println!(
                "seed {seed} mass ×{mass} friction ×{friction}: stop {stop:?}, {calibrations} calibrations, {lost} of {after} seeks unsettled, learnt gain ratio {learnt:.2}"
            );
            assert_eq!(
                stop, None,
                "seed {seed}, mass ×{mass}, friction ×{friction}"
            );
            assert!(after >= 30);
            if faster {
                assert!(
                    calibrations == 2 || learnt >= 1.1,
                    "seed {seed}, mass ×{mass}: {calibrations} calibrations, learnt {learnt}"
                );
            }
            unsettled += lost;
        }
        assert!(
            unsettled <= if faster { 1 } else { 2 },
            "mass ×{mass}, friction ×{friction}: {unsettled}"
        );
    }
}

/// A command during calibration waits: the experiment's drive is the same whatever the
/// reference (it is not followed until the calibrated design is adopted, then the servo seeks to
/// it), so nothing runs on the uncalibrated prior — no ringing on a sled 4× the prior's gain.
/// Trips on a servo that steps its controller during calibration (the drives differ).
#[test]
fn a_command_during_calibration_waits_for_it() {
    // A sled 4× the prior's gain in quanta (force ×2, mass ×0.5).
    let nominal = PlantParams::default();
    let plant = PlantParams {
        force_per_volt_n_per_v: 2.0 * nominal.force_per_volt_n_per_v,
        mass_kg: 0.5 * nominal.mass_kg,
        ..nominal
    };
    let params = TwinParams {
        plant,
        ..TwinParams::default()
    };
    let d = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let drives = |target: Option<f64>| {
        let mut servo = ScheduledLoop::new(&d, &identifier_design(&d))
            .unwrap()
            .with_calibration(Some(CalibrationDesign::default()))
            .unwrap();
        let mut twin = Twin::new(params.clone(), 5).unwrap();
        let mut log = Vec::new();
        let mut finished = false;
        let mut c = |_r: f64, y: f64| {
            let u = servo.step(target.unwrap_or(y), y);
            finished |= !servo.state.calibration().is_running();
            if !finished {
                log.push(u);
            }
            u
        };
        twin.pre_roll(&mut c, |_| false, 1000);
        (
            log,
            finished,
            twin.plant().position_m() / params.plant.quantum_m,
        )
    };
    let (quiet, finished_quiet, _) = drives(None);
    let (commanded, finished_commanded, end) = drives(Some(500.0));
    assert!(
        finished_quiet && finished_commanded,
        "calibration within 1,000 samples"
    );
    let first = quiet.iter().zip(&commanded).position(|(a, b)| a != b);
    assert_eq!(
        quiet,
        commanded,
        "lengths {} / {}, first difference at {first:?}",
        quiet.len(),
        commanded.len()
    );
    // Then the command is followed: after calibration the sled went to it.
    assert!((end - 500.0).abs() <= 1.5, "{end}");
}

/// Calibration's fit and the redesigns share the servo's one hand-over and result slot: while
/// the fit is posted no redesign job is offered and a design delivered for the fit's ticket is
/// refused; once calibrated, a fit's answer delivered for a redesign's ticket is refused. Trips on
/// a slot that takes either answer for the other's ticket (the fit's answer would be adopted as
/// gains, or a design as a calibration), or on a run without a fit or a redesign to check.
#[test]
fn the_fit_and_the_redesigns_share_one_hand_over_without_mixing_answers() {
    let params = TwinParams::default();
    let d = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let fs = d.baseline.u_full_scale_v;
    let mut servo = ScheduledLoop::new(&d, &identifier_design(&d))
        .unwrap()
        .with_calibration(Some(CalibrationDesign::default()))
        .unwrap();
    let mut twin = Twin::new(params, 5).unwrap();
    let (mut fits, mut redesigns) = (0, 0);
    let mut c = |r: f64, y: f64| {
        let (config, state) = (&servo.config, &mut servo.state);
        let out = config.step(state, position_from_quanta(r), position_from_quanta(y));
        if let Some(posted) = state.take_calibration_job() {
            assert!(!state.redesign_in_flight() && state.take_job().is_none());
            let skip = Posted {
                ticket: posted.ticket,
                job: RedesignJob::Skip,
            };
            assert!(!state.deliver(posted.ticket, config.redesign(&skip)));
            assert!(state.deliver_calibration(posted.ticket, config.calibrate(&posted.job)));
            fits += 1;
        }
        if let Some(posted) = state.take_job() {
            assert!(state.redesign_in_flight());
            let refused = config.calibrated(Err(Refusal::Fit));
            assert!(!state.deliver_calibration(posted.ticket, refused));
            assert!(state.deliver(posted.ticket, config.redesign(&posted)));
            redesigns += 1;
        }
        out.u.to_f64() * fs
    };
    for _ in 0..8_000 {
        if twin.step(&mut c).is_none() {
            break;
        }
    }
    assert!(
        fits >= 1 && redesigns >= 1,
        "{fits} fits, {redesigns} redesigns"
    );
    assert_eq!(servo.state.calibrations(), 1, "the fit adopted");
}

/// `sledid seek --inject`'s faults through the product's run (`run_seeks_with_faults`, nominal
/// sled, 30 seeks, seed 1, the fault at sample 5,000 of the schedule, in a dwell): a reversed
/// sensor stops the servo for a runaway 16 samples later; a reversed drive (runaway) and a stuck
/// sensor (stall) 288 and 303 samples later — at the next command, the dwell's drive being too
/// small to show them; a lighter sled (mass × 0.4) is calibrated again and settles every seek.
/// Bounded at 50 / 400 / 400 samples. The summary carries the stop's reason and sample and the
/// re-calibrations. Trips on faults that are parsed but not applied (no stop, no
/// re-calibration), on a stop sample counted from power-on instead of the schedule, or on a
/// summary that loses the stop.
#[test]
fn injected_faults_show_in_the_summary() {
    use sledid_host::control::inject::ServoFault;
    use sledid_host::control::seek::run::run_seeks_with_faults;
    use sledid_host::control::seek::{SeekController, SeekOptions};
    let params = TwinParams::default();
    let design = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let schedule = SeekOptions {
        seeks: 30,
        calibrate: true,
        ..SeekOptions::default()
    };
    let run = |spec: &str| {
        let fault: ServoFault = spec.parse().unwrap();
        let r = run_seeks_with_faults(&params, &SeekController::Seek(design), &schedule, &[fault])
            .unwrap();
        println!("{spec}: {}", r.summary.line());
        r.summary
    };
    for (spec, reason, within) in [
        ("flip:from=5000", "runaway", 50),
        ("drive-flip:from=5000", "runaway", 400),
        ("stuck:from=5000,len=1000000", "stall", 400),
    ] {
        let s = run(spec);
        let stop = s.safe_stop.expect("stopped");
        assert_eq!(stop.reason, reason, "{spec}");
        assert!(
            (5000..=5000 + within).contains(&stop.sample),
            "{spec}: {stop:?}"
        );
    }
    // A mass × 0.4 (the gain in quanta × 2.2) is absorbed by the seeks' gain learner since
    // 2026-11-27 (no re-calibration, no seek lost); × 0.25 still calls for one.
    let s = run("mass:at=5000,factor=0.25");
    assert!(s.safe_stop.is_none());
    assert!(s.calibrations >= 2, "{s:?}");
    assert_eq!(s.unsettled, 0);
}

/// The fast, sticky corner in seek mode, seeds 1–10 of 100 seeks each: its seeks land a few
/// quanta off and stick there, the watch calibrates again, and a re-calibration from a sled that
/// flickers at rest can run out of its 330 samples. That latched the safety layer's stop
/// (`calibration_timeout`) on a healthy sled — measured 2026-12-07 before the change: seeds 2
/// and 10 stopped at seeks 5 and 8, 95 and 92 seeks unsettled, 1 of them reported (each record
/// complete: four pushes braked, the closing rest unfinished). A re-calibration that runs out of
/// samples after every push has ended now keeps the previous model (`sledid::servo::calibration::watch`, "A
/// re-calibration without a model"): measured, no stop on any of the ten seeds, unsettled 7, 10,
/// 2, 14, 8, 9, 9, 7, 5, 6, every one reported as a seek error, 2 re-calibrations kept the
/// previous model. Since the settle rules of 2026-12-07 (`control::scheduled`, "Settle of a
/// time-optimal seek") no re-calibration of seeds 1–10 runs out of samples (unsettled 9, 7, 0,
/// 6, 13, 10, 5, 7, 10, 5, all reported), so the path that keeps the model is not reached here
/// (the next test reaches it);
/// the timeouts come from calibration's rest brake, which on this sled hops it ±2 quanta a
/// sample until the experiment's samples run out (BENCHMARKS.md, "Settle after a time-optimal
/// seek": variants of the settle rules stopped on seeds 2, 6 or 7). Asserted: no stop, no
/// unsettled seek unreported. Trips on the stop restored for such a timeout, or on a resumed
/// law that loses its seeks unreported.
#[test]
fn a_recalibration_that_runs_out_of_samples_keeps_the_previous_model() {
    use sledid_host::control::seek::run::run_seeks;
    use sledid_host::control::seek::{SeekController, SeekOptions};
    let params = FamilyRanges::default()
        .corner(Corner::FastSticky)
        .twin(&TwinParams::default());
    let design = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    for seed in 1..=10 {
        let schedule = SeekOptions {
            seeks: 100,
            seed,
            calibrate: true,
            ..SeekOptions::default()
        };
        let r = run_seeks(&params, &SeekController::Seek(design), &schedule).unwrap();
        let s = &r.summary;
        println!("seed {seed}: {}", s.line());
        assert!(s.safe_stop.is_none(), "seed {seed}: {:?}", s.safe_stop);
        assert_eq!(s.failing_unreported, 0, "seed {seed}");
        assert_eq!(s.unsettled, s.unsettled_reported, "seed {seed}");
    }
}

/// The path that keeps the previous model, reached (`sledid::servo::calibration::watch`, "A
/// re-calibration without a model"): the nominal sled, 30 calibrated seeks (seed 1), the sled
/// made 4× lighter at sample 5,000 of the schedule (the watch calibrates again) and from sample
/// 5,600 a sensor that reads a quantum off on every second
/// sample (`spike:at=5600,mag=1,every=2`). Measured 2026-12-08 (`sledid seek --seeks 30 --inject
/// mass:at=5000,factor=0.25 --inject spike:at=5600,mag=1,every=2`): that re-calibration's pushes
/// have ended when the flicker starts, its closing rest never comes, and it runs out of samples
/// with a complete record — the previous model is kept ("1 re-calibration(s) without a model")
/// and the servo seeks on; a later re-calibration, whose pushes the flicker keeps from ending,
/// stops it (`calibration_timeout` at sample 7,165, seek 10). With the flicker from any of 5,100
/// … 5,500 instead the servo stops at 5,873 (the first re-calibration's pushes disturbed); from
/// 5,650 … 5,860 that re-calibration is over and succeeds, and nothing stops. Asserted: one
/// re-calibration kept the previous model, and the stop (the sensor is faulty: the safety
/// layer's last resort) comes after it (sample > 6,000). Trips on a servo that stops on every
/// calibration timeout (measured: no model kept, the stop at 5,873) or never stops on this
/// sensor.
#[test]
fn a_recalibration_with_its_pushes_done_keeps_the_model_under_a_flickering_sensor() {
    use sledid_host::control::inject::ServoFault;
    use sledid_host::control::seek::run::run_seeks_with_faults;
    use sledid_host::control::seek::{SeekController, SeekOptions};
    let params = TwinParams::default();
    let design = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
    let schedule = SeekOptions {
        seeks: 30,
        calibrate: true,
        ..SeekOptions::default()
    };
    let faults: Vec<ServoFault> = ["mass:at=5000,factor=0.25", "spike:at=5600,mag=1,every=2"]
        .iter()
        .map(|f| f.parse().unwrap())
        .collect();
    let r =
        run_seeks_with_faults(&params, &SeekController::Seek(design), &schedule, &faults).unwrap();
    let s = &r.summary;
    println!("{}", s.line());
    assert_eq!(s.calibrations_inconclusive, 1, "{s:?}");
    let stop = s
        .safe_stop
        .expect("the faulty sensor stops the servo in the end");
    assert_eq!(stop.reason, "calibration_timeout");
    assert!(stop.sample > 6_000, "{stop:?}");
}
