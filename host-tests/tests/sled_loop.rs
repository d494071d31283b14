//! The firmware's whole per-sample step (`sledid::servo`) in the twin's closed loop: the
//! scheduled controller, its velocity identifier, and the first-order Wiener model identified beside
//! them at 2·Ts on the decimated, centred position.

use sledid::Status;
use sledid::control::Region;
use sledid::ident::nonlinear::{InputRanges, NonlinearDesign, NonlinearStructure};
use sledid::ident::rls::{AntiWindup, RlsDesign};
use sledid_host::control_eval::{ScheduledLoop, identifier_design, scheduled_design};
use sledid_host::twin::{Twin, TwinParams};

fn wiener() -> NonlinearDesign<5> {
    // A settle-phase prior: a first-order pole at 0.9, unit-ish gain; the neuron starts at w = 0.
    let mut d = NonlinearDesign::<5>::from_linear(
        NonlinearStructure::Wiener,
        &[-0.9, 5.0],
        InputRanges {
            u: 0.2,
            y: 20.0,
            dy: 2.0,
        },
    );
    d.rls = RlsDesign {
        lambda: 0.999,
        p0: 10.0,
        anti_windup: AntiWindup::TraceLimit { max: 100.0 },
        dead_zone: 0.25,
        ..RlsDesign::default()
    };
    d
}

/// Runs 20 seeks with and without the Wiener model; returns both loops.
fn run(
    seed: u64,
) -> (
    ScheduledLoop,
    ScheduledLoop,
    Vec<(f64, Option<sledid::ident::estimator::Estimate>)>,
) {
    let params = TwinParams::default();
    let design = scheduled_design(&params).unwrap();
    let id = identifier_design(design.prior_model.unwrap());
    let mut plain = ScheduledLoop::new(&design, &id).unwrap();
    let mut full = ScheduledLoop::with_wiener(&design, &id, Some(wiener())).unwrap();
    let mut p = params.clone();
    p.reference.seek_count = 20;
    let mut twin_a = Twin::new(p.clone(), seed).unwrap();
    let mut twin_b = Twin::new(p, seed).unwrap();
    twin_a.run(&mut plain);
    // The same closed loop, recording every loop output.
    let mut outs = Vec::new();
    let mut k = 0usize;
    let mut controller = |r: f64, y: f64| {
        let u = sledid_host::twin::SledController::step(&mut full, r, y);
        outs.push((u, full.last_wiener));
        k += 1;
        u
    };
    twin_b.run(&mut controller);
    let _ = k;
    (plain, full, outs)
}

#[test]
fn wiener_beside_the_controller_observes_without_disturbing() {
    let (plain, full, outs) = run(3);
    // The Wiener model is an observer: the drive is bit-identical with and without it.
    assert_eq!(plain.trace.len(), full.trace.len());
    assert_eq!(plain.trace, full.trace);
    // It runs on every second sample, held during seeks, adapting while settling and holding.
    let ran: Vec<_> = outs
        .iter()
        .enumerate()
        .filter_map(|(k, (_, w))| w.map(|w| (k, w)))
        .collect();
    let n = outs.len();
    assert!(
        (ran.len() as i64 - (n / 2) as i64).abs() <= 1,
        "{} of {n}",
        ran.len()
    );
    let mut held_in_seek = 0;
    let mut seek = 0;
    for (k, w) in &ran {
        if full.trace[*k].0 == Region::Seek {
            seek += 1;
            held_in_seek += usize::from(w.status.contains(Status::HELD));
        }
    }
    assert_eq!(held_in_seek, seek);
    let updated = ran
        .iter()
        .filter(|(_, w)| w.status.contains(Status::UPDATED))
        .count();
    println!(
        "Wiener: {} decimated samples, {seek} in seeks (held), {updated} updates",
        ran.len()
    );
    assert!(updated > 0);
    // The Wiener estimate stays a valid, stable model.
    let th = full.state.wiener().unwrap().theta();
    assert!(th[0].to_f64().abs() <= 1.0, "{th:?}");
    println!("Wiener θ = {:?}", th.map(|p| p.to_f64()));
}

/// Shadow mode: with the drive the plant received given explicitly, the loop computes its own u
/// but its identifier learns from the applied one — equal to the normal step when they coincide.
#[test]
fn shadow_mode_identifies_from_the_applied_drive() {
    use sledid::PositionI48F16;
    use sledid::servo::ServoDesign;
    let params = TwinParams::default();
    let design = scheduled_design(&params).unwrap();
    let loop_design = ServoDesign {
        controller: design,
        velocity: identifier_design(design.prior_model.unwrap()),
        wiener: Some(wiener()),
        options: sledid::servo::ServoOptions::default(),
    };
    let cfg = loop_design.build().unwrap();
    let (mut normal, mut shadow_same, mut shadow_other) =
        (cfg.new_state(), cfg.new_state(), cfg.new_state());
    let mut differ = 0;
    for k in 0..2000i64 {
        let r = PositionI48F16::from_counts(if k < 1000 { 0 } else { 40 });
        // Moving 3 quanta per sample: above the identifier's speed gate.
        let y = PositionI48F16::from_counts((3 * k) % 3000);
        let a = cfg.step(&mut normal, r, y);
        let b = cfg.step_shadow(&mut shadow_same, r, y, a.u);
        assert_eq!(a, b, "sample {k}");
        let c = cfg.step_shadow(&mut shadow_other, r, y, sledid::SignalI16F16::ZERO);
        differ += usize::from(c.identifier.theta != a.identifier.theta);
    }
    assert!(differ > 0);
}

/// The configuration words (`sledid::words`) of a design with every optional part: both input
/// maps, a stuck-sensor check, a pole radius on the velocity model, the Wiener model. The largest
/// word count (198 with the frame, within `SERVO_WORDS_MAX`), decoded into the configuration `build` gives, and
/// refused by a buffer one word short.
#[test]
fn configuration_words_of_a_full_design_round_trip() {
    use sledid::ConfigError;
    use sledid::ident::step::StuckSensorDesign;
    use sledid::servo::{SERVO_WORDS_MAX, ServoDesign, SledServo};
    use sledid_host::control_eval::physical_model;
    use sledid_host::twin::PlantParams;

    let mut controller = scheduled_design(&TwinParams::default()).expect("scheduled design");
    assert!(
        controller.compensation.is_some(),
        "the twin's design compensates friction"
    );
    controller.output_map = controller.compensation;
    let mut velocity = identifier_design(physical_model(&PlantParams::default()));
    velocity.stuck_sensor = Some(StuckSensorDesign {
        samples: 50,
        min_drive: 0.05,
    });
    velocity.model.stability_margin = Some(0.0);
    let design = ServoDesign {
        controller,
        velocity,
        wiener: Some(wiener()),
        options: sledid::servo::ServoOptions::default(),
    };
    let built = design.build().expect("the design builds");
    let mut buf = [0u32; SERVO_WORDS_MAX];
    let n = design.to_words(&mut buf).expect("words");
    assert_eq!(n, 198);
    assert_eq!(SledServo::from_words(&buf[..n]), Ok(built));
    assert_eq!(
        design.to_words(&mut buf[..n - 1]),
        Err(ConfigError::Words { at: n - 1 })
    );
}
