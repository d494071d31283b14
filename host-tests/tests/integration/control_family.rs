//! The servo judged on the plant family (`sledid control-family`, `sledid_host::control::family_eval`):
//! two families of 200 plants (seeds 1 and 7), 100 seeks each, every servo designed from the
//! nominal prior only. Assertions are on the families' statistics, not on hand-picked plants.
//!
//! The servo issue's targets and what these families measure (`BENCHMARKS.md`, control family):
//!
//! | target | seed 1 | seed 7 | asserted here |
//! |---|---|---|---|
//! | 0 pulses and 0 unsettled seeks on ≥ 99 % of plants | 99.0 % | 99.5 % | ≥ 98.5 % (the floor over seeds 1–7, below) |
//! | median settling ≤ 0.7× baseline on ≥ 90 % of plants | 99.0 % | 97.5 % | ≥ 95 % |
//! | identified no worse than frozen on every plant | 2 plants > 1.02× (1.065, 1.045) | 0 | ≤ 5 (target not met) |
//! | ≥ 20 % faster than frozen where the prior is > 30 % off | 81.5 % of 195 | 85.2 % of 196 | ≥ 75 % (target: all) |
//! | holding error ≤ 1 quantum | true ≤ 1.23, 0 plants ≥ 1.5 (read ≤ 2); 3 plants over 1 | 0.98, 0; 0 | ≤ 5 plants per family over 1, ≤ 1 at 1.5 or more, none ≥ 2 (target not met) |
//! | friction identified shortens settling on high-friction plants | 0.984× linear-only | 0.985× | < 1 |
//! | no false safe stop (issue 18), 4.3·10⁷ servo samples per family | 0 | 0 | 0, every variant (1 on seed 7's linear-only variant, plant 24, before the runaway test required |e| itself to grow); the family's slow end in its own test below (before the fallbacks' recovery: stops on seeds 9 and 10 of 1–16) |
//!
//! The holding error as a statistic over families: the largest true error over 200 plants moves
//! with the last bit of the identifier, so the plants held 1.5 quanta or more off (two cells) are
//! counted (`holding_error_spread_over_seeds`, seeds 1–6, 200 plants each): with the previous RLS
//! kernel 0 in every family (largest 1.482–1.493); with the one-pass kernel of issue 24 2, 1, 0,
//! 1, 0, 0 (largest 1.62, 1.95, 1.49, 1.64, 1.49, 1.48) — 4 of 1,200 plants, a measured cost of
//! the new kernel on this statistic, not only luck. Since the coasting damping no longer takes a
//! still sled's flicker for motion (`control::scheduled::rest`, "A resting sled's flicker";
//! measured 2026-11-28 with `sledid control-family --passes settling`, seeds 1–7): 0 on every
//! seed, the largest 1.49 on every seed (before it 2, 1, 0, 1, 0, 0, 0 on seeds 1, 2, 3, 4, 5,
//! 6, 7, largest 1.62, 1.87, 1.49, 2.11, 1.49, 1.49, 1.49: a resting sled kicked off by a
//! flicker, held a cell further). Asserted: at most 1 per family (one plant of spread) and none
//! at 2 quanta or more. Since the reference-following servo holds a sled one cell off only once
//! its fine steps are spent (`control::scheduled::rest`, "The reference-following servo's
//! holding error", "A kick's return" and "A resting sled's flicker"; measured 2026-11-28, seeds
//! 1, 7, 2, 3, 4, 5, 6): plants over 1 quantum 6, 2, 4, 9, 3, 4, 3 (before: 193–198 on every
//! seed), the largest 1.36, 1.18, 1.34, 1.40, 1.27, 1.34, 1.36. Asserted: at most 12 per family over 1 quantum (the largest
//! count over the seven families and a margin of spread; without the rule ≈ 195 trip it). Since
//! a sticking sled's fine steps are pulsed once one has thrown it past the target
//! (`control::scheduled::rest`, "A sticking sled's breakaway"; measured 2026-12-07 with
//! `sledid control-family --passes settling`, seeds 1, 7, 2, 3, 4, 5, 6): 4, 0, 3, 4, 2, 1, 2
//! plants over 1 quantum (before it, the same day: 6, 2, 4, 9, 3, 4, 3), the largest 1.33,
//! 0.98, 1.20, 1.23, 1.27, 1.29, 1.36. Asserted: at most 5 per family (above the largest of the
//! seven; seed 1's 6 without the pulses trips it). With no reference-following Hold on the
//! sample after any drive (`control::scheduled::rest`, the same day): 3, 0, 3, 4, 2, 1, 2, the
//! largest on seed 1 1.23. The target (≤ 1 quantum) is still not met:
//! heavy, nearly frictionless sleds whose fine steps glide a cell past the target both ways
//! are held one cell off once both are spent (`BENCHMARKS.md`, "The holding error ≤ 1
//! quantum").
//!
//! Clean plants over seeds 1–7: 99.0, 99.5, 99.0, 99.5, 100.0, 100.0, 99.5 % (seeds 1, 7, 2, 3, 5,
//! 6, 4; 2026-12-07, with the pulsed fine steps of a sticking sled — seed 3 was 99.0 before them);
//! 99.0, 99.5, 99.0, 99.0, 100.0, 100.0, 99.5 % (seeds 1, 7, 2, 3, 5,
//! 6, 4; 2026-11-28, with the fine steps before an off-target Hold, a kick's return and the
//! two-sample flicker — mean 99.43 %; before them 99.0, 99.0, 98.5, 98.5, 99.5, 99.5, 100.0 %, mean 99.14 %; with the
//! still sled's flicker rule — before that
//! 99.0, 99.5, 99.0, 98.5, 99.5, 99.0, 100.0 %), from 97.0, 94.5, 93.0, 94.5, 96.0, 96.5, 95.0 % before two changes: each plant's seek
//! window is at least three times its 2,000-track minimum-time seek (`dwell_for_plant`, the seek
//! pass's rule: the 0.3 s window was shorter than the slowest sleds' fastest seek, up to 0.36 s, and
//! counted the plant's physics as the servo's unsettled seeks) — 99.0 / 98.0 % on seeds 1 / 7 with
//! that alone —, and a crawling reference-following seek asks for its redesign before it reaches
//! the settle band (`SEEK_REDESIGN_UPDATES`, `tests/integration/scheduled_control.rs`). Asserted at the floor
//! of the seven families: a one-plant flip on seed 1 would otherwise decide the test.
//!
//! What trips each: a servo without identification (clean falls to the frozen servo's ≈ 80 %,
//! and the off-prior gain to 0), a placement off its poles (settling ratio), a hold rule that lets
//! a sled rest two cells off (true error ≥ 1.5), compensation that ignores the identified
//! friction (ratio ≥ 1), a safety layer that takes braking for a runaway (safe stops).

use sledid_host::control::family_eval::{FamilyOptions, FamilyStats, evaluate, stats_table};

/// The statistics, the plants held 1.5 quanta or more off and those held more than 1 off.
fn family(seed: u64) -> (FamilyStats, usize, usize) {
    let options = FamilyOptions {
        plants: 200,
        seed,
        seeks: 100,
        ..FamilyOptions::default()
    };
    let report = evaluate(&options, None).expect("the family runs");
    println!("family seed {seed}:\n{}", stats_table(&report.stats));
    let two_off = report
        .plants
        .iter()
        .filter(|p| p.identified.hold_true_error_max_quanta >= 1.5)
        .count();
    let over_one = report
        .plants
        .iter()
        .filter(|p| p.identified.hold_true_error_max_quanta > 1.0)
        .count();
    println!("family seed {seed}: plants held ≥ 1.5 quanta off: {two_off}, over 1: {over_one}");
    (report.stats, two_off, over_one)
}

#[test]
fn the_servo_holds_up_on_the_plant_family() {
    for seed in [1, 7] {
        let (s, two_off, over_one) = family(seed);
        assert_eq!(s.plants, 200);
        assert!(s.clean >= 0.985, "seed {seed}: clean {}", s.clean);
        assert!(
            s.clean >= s.clean_frozen + 0.10,
            "seed {seed}: identification earns its keep: {} vs frozen {}",
            s.clean,
            s.clean_frozen
        );
        assert!(s.ratio_le_0_7 >= 0.95, "seed {seed}: {}", s.ratio_le_0_7);
        assert!(
            s.worse_than_frozen <= 5,
            "seed {seed}: {}",
            s.worse_than_frozen
        );
        // The populations the statistics below are over, from the seeded draws (measured 195 /
        // 196 plants with a prior > 30 % off, 41 / 49 with friction ≥ 1.5× the prior's, seeds
        // 1 / 7): exact, so a generator, a classification or an evaluation that drops or adds
        // plants trips here rather than moving a statistic unseen (it was `≥ 150` and `≥ 30`).
        let (off_prior, high_friction) = if seed == 1 { (195, 41) } else { (196, 49) };
        assert_eq!(s.off_prior, off_prior, "seed {seed}");
        assert_eq!(s.high_friction, high_friction, "seed {seed}");
        assert!(
            s.off_prior_gain_20 >= 0.75,
            "seed {seed}: {}",
            s.off_prior_gain_20
        );
        assert!(
            two_off <= 1,
            "seed {seed}: {two_off} plants held two cells off"
        );
        assert!(
            over_one <= 5,
            "seed {seed}: {over_one} plants held more than a quantum off"
        );
        assert!(
            s.hold_true_error_max_quanta < 2.0,
            "seed {seed}: {}",
            s.hold_true_error_max_quanta
        );
        // Every run of every variant to its schedule's end: 46,032,900 / 47,558,100 samples on
        // seeds 1 / 7 (measured; 200 plants × 100 seeks, each plant's window fixed by its own
        // minimum-time seek, `dwell_for_plant`; 43,440,000 with every window 0.3 s). A run cut
        // short (an error, a schedule that ends early) lowers it; it was asserted only > 10⁷
        // before.
        println!("seed {seed}: {} servo samples", s.servo_samples);
        let samples = if seed == 1 { 46_032_900 } else { 47_558_100 };
        assert_eq!(s.servo_samples, samples, "seed {seed}");
        assert_eq!(s.safe_stops_servo, 0, "seed {seed}: a false safe stop");
        assert_eq!(
            s.safe_stops, 0,
            "seed {seed}: a false safe stop of a variant"
        );
        assert!(
            s.high_friction_settling_ratio < 1.0,
            "seed {seed}: {}",
            s.high_friction_settling_ratio
        );
    }
}

/// The spread of the holding-error figure over families (a measurement, run on demand:
/// `cargo test --release -p sledid-host --test integration control_family:: -- --ignored --nocapture`): for
/// each seed, the largest true holding error and the plants held 1.5 quanta or more off (two
/// cells), and the other statistics the test above asserts.
#[test]
#[ignore = "a measurement (families of 200 plants over several seeds), run on demand"]
fn holding_error_spread_over_seeds() {
    let seeds: Vec<u64> = std::env::var("SLEDID_FAMILY_SEEDS")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| (1..=8).collect());
    for seed in seeds {
        let (s, off, _) = family(seed);
        println!(
            "SPREAD seed {seed}: hold true max {:.3}, plants ≥ 1.5 off {off}, clean {:.3} (frozen {:.3}), ratio≤0.7 {:.3}, worse {} , gain20 {:.3}, hf ratio {:.3}, stops {}/{}",
            s.hold_true_error_max_quanta,
            s.clean,
            s.clean_frozen,
            s.ratio_le_0_7,
            s.worse_than_frozen,
            s.off_prior_gain_20,
            s.high_friction_settling_ratio,
            s.safe_stops_servo,
            s.safe_stops
        );
    }
}

/// The family's slow end (viscous 12–25×, force 0.5–0.7×, quantum 1.4–2×: top speeds of one to
/// a few quanta per sample), 60 plants per seed, the settling pass's four variants. On these
/// sleds the quantised velocity cannot tell the pole (the estimate runs to −1) and gain from
/// friction; each identified model is applied and distrusted on the next saturated sample, and the
/// fallbacks it caused latched the safety layer's stop on a healthy sled (measured 2026-12-07 with
/// the recovery removed, seeds 1–5: the servo stopped on 1, 1, 3, 5, 2 plants — every one of them
/// slower than frozen, 1.4–2.0× — and 2, 2, 6, 10, 7 runs of any variant). The servo without
/// calibration now recovers from the entry that would stop it by keeping its prior's design
/// (`sledid::servo::safety`, "Before the fallbacks' stop"): measured over seeds 1–8, 0 stops, 0
/// plants slower than frozen, identification suspended on 1–6 plants per seed. Asserted on seeds
/// 3 and 4 (3 and 5 stops without the recovery): no stop of any variant, no plant slower than
/// frozen, and at least one suspension (the path runs). Trips on a recovery removed or refused
/// (checked: 6 stops on seed 3), or on a family that no longer reaches the recovery. A suspension
/// that keeps the identified design instead of the prior's does not trip it (checked): the
/// supervisor's running mean of |ε| stays above its limit once nothing adapts, so the law runs
/// on the prior's gains anyway — the reset makes that so whatever the mean.
#[test]
fn the_slowest_sleds_are_not_stopped_for_their_fallbacks() {
    use sledid_host::control::family::FamilyRanges;
    for seed in [3, 4] {
        let options = FamilyOptions {
            plants: 60,
            seed,
            seeks: 100,
            ranges: FamilyRanges {
                viscous: (12.0, 25.0),
                force: (0.5, 0.7),
                quantum: (1.4, 2.0),
                ..FamilyRanges::default()
            },
            ..FamilyOptions::default()
        };
        let report = evaluate(&options, None).expect("the family runs");
        let s = &report.stats;
        println!("slow end, seed {seed}:\n{}", stats_table(s));
        assert_eq!(s.safe_stops, 0, "seed {seed}: a false safe stop");
        let slower: Vec<u64> = report
            .plants
            .iter()
            .filter(|p| p.identified.settling_median_ms > 1.02 * p.frozen.settling_median_ms)
            .map(|p| p.index)
            .collect();
        assert!(
            slower.is_empty(),
            "seed {seed}: slower than frozen {slower:?}"
        );
        assert!(s.suspended[0] >= 1, "seed {seed}: no suspension");
    }
}
