//! The firmware's whole per-sample step (`sledid::servo`): the scheduled controller and its
//! velocity identifier — shadow mode and the configuration words.

use sledid_host::control::{identifier_design, scheduled_design};
use sledid_host::twin::TwinParams;

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
        velocity: identifier_design(&design),
        options: sledid::servo::ServoOptions::default(),
        safety: sledid::servo::SafetyDesign::default(),
        calibration: None,
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
/// maps, time-optimal seeks, a stuck-sensor check, a pole radius on the velocity model, power-on
/// calibration. The largest word count (279 with the frame: `SERVO_WORDS_MAX`; 278 before the prior gains carried `breakaway_throws`, 279 while the RLS settings were carried as their `f64` design), decoded into the
/// configuration `build` gives, and refused by a buffer one word short.
#[test]
fn configuration_words_of_a_full_design_round_trip() {
    use sledid::ConfigError;
    use sledid::ident::step::StuckSensorDesign;
    use sledid::servo::{SERVO_WORDS_MAX, ServoDesign, SledServo};

    let mut controller = scheduled_design(&TwinParams::default()).expect("scheduled design");
    assert!(
        controller.compensation.is_some(),
        "the twin's design compensates friction"
    );
    controller.output_map = controller.compensation;
    let controller = controller.with_time_optimal_seeks();
    let mut velocity = identifier_design(&controller);
    velocity.stuck_sensor = Some(StuckSensorDesign {
        samples: 50,
        min_drive: 0.05,
    });
    velocity.model.stability_margin = Some(0.0);
    let design = ServoDesign {
        controller,
        velocity,
        options: sledid::servo::ServoOptions::default(),
        safety: sledid::servo::SafetyDesign::default(),
        calibration: Some(sledid::servo::CalibrationDesign::default()),
    };
    let built = design.build().expect("the design builds");
    let mut buf = [0u32; SERVO_WORDS_MAX];
    let n = design.to_words(&mut buf).expect("words");
    assert_eq!(n, 279);
    assert_eq!(n, SERVO_WORDS_MAX);
    assert_eq!(SledServo::from_words(&buf[..n]), Ok(built));
    assert_eq!(
        design.to_words(&mut buf[..n - 1]),
        Err(ConfigError::Words { at: n - 1 })
    );
}

/// The servo's state is copied whole on the sample that adopts calibration's answer, the
/// interrupt's worst case on the M0+ (`BENCHMARKS.md`, "Cycles of the interrupt": 10,552 of
/// its 10,920 cycles, 2026-12-07). A field added to the state shows there first, and not only
/// by its size: a one-byte `bool` added to the near-target bookkeeping sent that copy through
/// the byte-wise `memcpy` and took the worst tick to 14,758 cycles with the mean unchanged, and
/// nothing else in the test command noticed (the PIL runs now check the longest handler against
/// the budget: `firmware_qemu::interrupt_budget`). This size is the tripwire: when it changes, run
/// `cargo xtask cost firmware`, check the worst tick against both budgets and record it (with
/// this figure) in BENCHMARKS.md. 2,616 B measured with the worst tick above (the `bool`
/// version: 2,624 B). Trips on any change of the state's size on the host (not on a field that
/// fits existing padding: the size is a tripwire, the emulator's count is the measurement).
#[test]
fn the_servo_state_keeps_the_layout_its_worst_tick_was_measured_with() {
    let size = core::mem::size_of::<sledid::servo::SledServoState>();
    println!("SledServoState: {size} B on the host");
    assert_eq!(size, 2616, "re-measure the firmware's worst tick (doc)");
}
