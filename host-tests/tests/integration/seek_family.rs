//! Seeks on the plant family (`sledid control-family --passes seek`,
//! `sledid_host::control::seek::family`): two families of 200 plants (seeds 1 and 7), 100
//! log-uniform seeks of 20–2,000 tracks each; each seek's access time over the minimum-time bound
//! of its plant. Assertions are on the families' statistics.
//!
//! "Seek mode" is the time-optimal seek ([`sledid::control::SeekMode::TimeOptimal`], switched
//! on by `control::seek::seek_design`): each sample the drive whose predicted stop point is the
//! target, on a model-based observer. Two settings (`BENCHMARKS.md`, controller, seeks):
//!
//! **Each plant's servo designed from its own exact model, identification frozen**
//! (`--prior exact --frozen`: the law alone). Seeds 1 / 7 (2): access / bound median 1.00 / 1.00
//! (1.00), p95 1.25 / 1.25 (1.25), ≥ 200 tracks 1.00; unsettled seeks 0 / 0 (0; seeds 3 / 4:
//! 0 / 3, the latter one plant; 0 / 4 on two plants with the two-sample flicker), pulses 0,
//! safe stops 0 — since the coasting damping no longer
//! takes a still sled's flicker for motion (`control::scheduled::rest`, "A resting sled's
//! flicker"); before it 1 / 0 (0; seed 4: 1 and 3 pulses): seed 1's plant 197, a heavy, almost
//! frictionless sled resting a cell off, was kicked away from the target by such a flicker and
//! held there. Asserted: median ≤ 1.05, p95 ≤ 1.5, no unsettled seek and no pulse (the issue's
//! target; identification is frozen, so the identifier's rounding cannot move it), no safe
//! stop. (The earlier law, a braking curve followed by a velocity loop, left 46–93 of 100
//! seeks unsettled on 8 of 10 fast sleds on their exact models.)
//!
//! **Every servo designed from the nominal prior, identification on-line** (the product until
//! power-on calibration lands):
//!
//! | measure | target | seek mode, seed 1 / 7 (before this law) | reference-following, seed 1 / 7 |
//! |---|---|---|---|
//! | access / bound, median over all seeks | ≤ 1.5 | 1.25 / 1.20 (1.43 / 1.38) | 6.06 / 5.70 |
//! | access / bound, p95 | ≤ 2.5 | 3.50 / 3.50 (8.0 / 9.7) | 26.0 / 20.7 |
//! | access / bound, median over seeks ≥ 200 tracks | ≤ 1.3 | 1.13 / 1.12 (1.24 / 1.21) | 3.14 / 2.93 |
//! | plants with 0 unsettled and 0 pulses | ≥ 99 % | 90.0 % / 91.5 % (89.0 % / 81.5 %) | 86.0 % / 86.5 % |
//! | safe stops in seek mode | 0 | 3 / 2 | 0 / 0 |
//! | nominal sled: median access, reference-following / seek mode | ≥ 3 | 27.3 / 5.0 ms = 5.45 | |
//!
//! The medians and the nominal speed-up meet the targets and are asserted at them; the p95, the
//! clean plants and the safe stops do not — the sleds 3–6× the prior's gain in quanta, on which
//! the prior's model rings until the fallback count stops the loop (issue: power-on calibration)
//! — and are asserted at today's level plus the seeds' spread, so that a regression trips.
//!
//! What trips each: a harness that times the reference-following servo from the reference's
//! arrival instead of the command (its ratios fall towards the seek mode's), a bound that is too
//! long or too short (every ratio moves), pulses, unsettled seeks or stops left uncounted (clean
//! goes to 100 %), a law that ignores the drive sample's own distance or follows w* through a
//! velocity loop on the exact model (the exact-model family's unsettled seeks and p95).

use sledid_host::control::family::FamilyRanges;
use sledid_host::control::family_eval::FamilyOptions;
use sledid_host::control::seek::SeekOptions;
use sledid_host::control::seek::family::{SeekFamilyReport, evaluate, stats_table};

/// The family of `seed`: 200 plants, 100 seeks each, every other option the default.
fn options(seed: u64) -> FamilyOptions {
    FamilyOptions {
        plants: 200,
        seed,
        seeks: 100,
        ..FamilyOptions::default()
    }
}

fn family(seed: u64) -> SeekFamilyReport {
    family_of(options(seed))
}

fn family_of(options: FamilyOptions) -> SeekFamilyReport {
    let seed = options.seed;
    let report = evaluate(&options, &SeekOptions::default(), None).expect("the family runs");
    println!("family seed {seed}:\n{}", stats_table(&report));
    report
}

#[test]
fn seeks_on_the_plant_family() {
    for seed in [1, 7] {
        let r = family(seed);
        assert_eq!(r.plants.len(), 200);
        for p in &r.plants {
            assert!(
                p.seek.ratios.len() >= 95 && p.reference.ratios.len() >= 95,
                "plant {}",
                p.index
            );
        }
        let (s, f) = (&r.seek, &r.reference);
        // Today's reference-following servo: held back by the 30 ms reference.
        assert!(f.ratio.median >= 4.0, "seed {seed}: {f:?}");
        assert!(f.ratio_long_median >= 2.5, "seed {seed}: {f:?}");
        assert!(f.clean >= 0.80, "seed {seed}: {f:?}");
        // The seek mode: the targets where met, today's level where not.
        assert!(s.ratio.median <= 1.5, "seed {seed}: {s:?}");
        assert!(s.ratio_long_median <= 1.3, "seed {seed}: {s:?}");
        // Measured 3.50 / 3.50 (seed 2: 3.00; 3.50–4.20 over the law's α, p settings tried).
        assert!(s.ratio.p95 <= 4.5, "seed {seed}: {s:?}");
        // Measured 90.0 / 91.5 % (seed 2: 93.0 %) with the one-pass RLS kernel, 91.5 / 93.5 %
        // (94.0 %) with the previous one; 89.5–94.5 % over the law's settings tried: 0.88 leaves
        // that spread (a plant is 0.5 %).
        assert!(s.clean >= 0.88, "seed {seed}: {s:?}");
        assert!(s.safe_stops <= 4, "seed {seed}: {s:?}");
        assert_eq!(f.safe_stops, 0, "seed {seed}: {f:?}");
        assert!(s.ratio.median * 3.0 <= f.ratio.median, "seed {seed}");
        assert!(r.nominal.speedup >= 3.0, "seed {seed}: {:?}", r.nominal);
        assert!((25.0..=31.0).contains(&r.nominal.reference.access_ms.median));
    }
}

/// The seek law alone: every plant's servo designed from its own exact model, identification
/// frozen (module doc).
#[test]
fn seeks_land_on_every_plant_with_its_exact_model() {
    for seed in [1, 7] {
        let r = family_of(FamilyOptions {
            exact_prior: true,
            frozen: true,
            ..options(seed)
        });
        let s = &r.seek;
        assert!(s.ratio.median <= 1.05, "seed {seed}: {s:?}");
        assert!(s.ratio.p95 <= 1.5, "seed {seed}: {s:?}");
        assert!(s.ratio_long_median <= 1.05, "seed {seed}: {s:?}");
        assert_eq!(s.unsettled, 0, "seed {seed}: {s:?}");
        assert_eq!(s.limit_cycle_pulses, 0, "seed {seed}: {s:?}");
        assert_eq!(s.safe_stops, 0, "seed {seed}: {s:?}");
    }
}

/// The product setting: every servo designed from the nominal prior, calibrated at power-on
/// (`sledid::servo::calibration`), seeking on the calibrated model at the calibrated α 0.7,
/// p 0.15 until its seeks have corrected its gain (`control::scheduled::learn`), then at p 0
/// (`control-family --passes seek --calibrate`). Measured 2026-11-27 with the learner, seeds
/// 1 / 7 (2): access / bound median 1.04 / 1.04 (1.04), p95 1.60 / 1.57 (1.60), ≥ 200 tracks
/// 1.05 / 1.04 (1.05), clean 99.5 / 100.0 % (99.5 %), unsettled 1 / 0 (1), pulses 0 / 0 (0),
/// safe stops 0 / 0 (0); seeds 3–6: clean 100 %, p95 ≤ 1.67. With the two-sample flicker
/// (`control::scheduled::rest`, 2026-11-28): median 1.05 / 1.04 (1.04), p95 1.60 / 1.50 (1.60),
/// clean 100.0 / 99.5 % (99.5 %), unsettled 0 / 1 (3), pulses 0 / 0 (0); seeds 3 / 4: clean
/// 100 / 99.5 %. Before the learner (the
/// calibrated model held at p 0.15): median 1.09 / 1.08 (1.07), p95 2.00 / 1.75 (1.75), ≥ 200
/// tracks 1.07 / 1.06 (1.06), clean 100.0 / 100.0 % (99.5 %), unsettled 0 / 0 (2) — against the on-line servo without calibration's 1.25 / 1.20 median, 3.50 /
/// 3.50 p95, 90.0 / 91.5 % clean and 3 / 2 stops (`seeks_on_the_plant_family`). Over seeds 1–7
/// the plants with an unsettled seek or a pulse are 0 / 1 / 2 / 0 / 1 / 3 / 0 (of 200; at most
/// 3 unsettled seeks and 1 pulse per family): clean ≥ 99 % holds with two plants to spare on
/// seeds 1 and 7 and is asserted at the target, unsettled at 3 and pulses at 1 (the
/// seeds' largest). Before the fine step's integrator restart and time limit
/// (`control::scheduled::rest`) the same seeds measured 98.0 / 97.0 % clean, 4 / 9 unsettled,
/// 0 / 2 pulses: reverting either trips `clean`. The median, p95 and stops meet the issue's
/// targets and are asserted at them, the median also at 1.15 (the identified settings α 0.6,
/// p 0.3 on the same calibrated model measured 1.25 / 1.23). Trips on a calibration that is
/// not adopted (p95 and stops of the uncalibrated servo), calibration samples counted as access
/// time (every first seek's ratio), a hold that lets the biased on-line estimate back in (p95
/// 3.2–5.3, measured) or the identified settings on a calibrated model (median).
#[test]
fn calibrated_seeks_on_the_plant_family() {
    for seed in [1, 7] {
        let r = family_of(FamilyOptions {
            calibrate: true,
            ..options(seed)
        });
        let s = &r.seek;
        let all: Vec<f64> = r
            .plants
            .iter()
            .flat_map(|p| p.seek.ratios.iter().map(|q| q.1))
            .collect();
        let at_most = all.iter().filter(|q| **q <= 2.5).count() as f64 / all.len() as f64;
        println!(
            "seed {seed}: {:.2} % of seeks within 2.5× the bound",
            100.0 * at_most
        );
        assert!(s.ratio.median <= 1.15, "seed {seed}: {s:?}");
        assert!(s.ratio_long_median <= 1.3, "seed {seed}: {s:?}");
        assert!(s.ratio.p95 <= 2.5, "seed {seed}: {s:?}");
        assert_eq!(s.safe_stops, 0, "seed {seed}: {s:?}");
        assert!(s.clean >= 0.99, "seed {seed}: {s:?}");
        assert!(s.unsettled <= 3, "seed {seed}: {s:?}");
        assert!(s.limit_cycle_pulses <= 1, "seed {seed}: {s:?}");
        // Seek errors (`ServoFlags::SEEK_ERROR`): every unsettled seek reported; settled seeks
        // reported all the same — settled after the seek error's budget (late, not lost), or off
        // track after settling (the reading left ±1 quantum and came back before the window's
        // last 10 ms; `servo::calibration::watch`), or hunting after settling (four drive
        // pulses past the calibrated breakaway level, each the other way), or ringing (four
        // crossings of the target, each more than a quantum past it) — measured 80 / 71 of
        // 10,000 with the ring rule (seed 2: 75; 79 / 71 / 75 before it: one settled seek of seed
        // 1 crossed four times; seeds 3–5 34 / 65 / 44, one more on seed 5); 79 / 71 of
        // 10,000 since the hunting level is capped at 3 × the fitted Coulomb level (seed 2: 75;
        // 62 / 65 / 66 before the cap, which then left 3 / 4 of the wider family's failing plants
        // unflagged, 1 / 3 with it; at 2 × Coulomb 86 / 88 and 0 / 3); 58 / 64 / 58 before the
        // hunting rule (the rule flags 2 of the wider
        // family's 9 failing plants that nothing flagged, seeds 1 / 7; at three pulses 84 / 76;
        // seeds 2–6 before it: 58 / 25 / 39 / 39 / 26) since the seeks' learner lands at p 0
        // (39 / 35 / 30 at p 0.15 before it, 44 / 35 / 29 with the learner at p 0.15 — whose
        // fast corner sled then kept a p95 of 2.5 —, 3 / 12 / 15 before the off-track rule),
        // asserted at the seeds' largest (57 / 54, seed 2: 80, with the two-sample flicker).
        // Trips on a watch that reports seeks while they move or
        // hold (thousands), or that hunts at three pulses (84 / 76; counted either way, a fine
        // step's chatter too: 98 / 87).
        assert_eq!(s.unsettled_reported, s.unsettled, "seed {seed}: {s:?}");
        assert!(s.settled_reported <= 80, "seed {seed}: {s:?}");
    }
}

/// The wider family (`FamilyRanges::wide`: every range doubled at both ends on a log scale;
/// `control-family --passes seek --wide`), the calibrated seek mode: the issue asks where it
/// breaks and that every failure there end flagged — a safe stop (calibration's refusals
/// included) or a seek error. Measured 2026-11-28, seeds 1 / 7 (BENCHMARKS.md, "The wider
/// family" and "Seek errors"): clean 79.5 / 80.5 %, 13 / 15 plants stopped, every unsettled seek
/// of a plant not stopped reported (seeds 2–4 too) — before the ring rule
/// (`servo::calibration::watch`, "Ringing") seed 7's plant 186 left 2 of its 26 unreported,
/// ringing ±250 tracks after a re-calibration; and plants failing with nothing flagged 1 / 2
/// (seeds 2–4: 2 / 5 / 3; 1 / 3 before the ring rule), every one by drive pulses while the
/// reading stays within ±1 quantum: heavy (mass 6–12×), noisy (0.15–0.2 quantum) sleds whose
/// readings flicker at the cell's centre and whose coasting damping kicks past the true
/// breakaway but under the hunting level. With the two-sample flicker
/// (`control::scheduled::rest`, "A resting sled's flicker"; 2026-11-28) those kicks are gone on
/// seeds 1 / 7: 0 / 0 plants failing unflagged (seeds 2–4: 2 / 0 / 0; main before it 1 / 0, 1 /
/// 2 / 1), pulses 32 / 10 (102 / 11). That target is still not met on seed 2; asserted: no
/// unreported unsettled seek, and at most 1 such plant per family (one plant of spread; 3
/// before the two-sample flicker, 5 / 4 before the hunting rule, 40 / 36 before the seek
/// error). Trips on a watch without the ring rule (seed 7) or without the
/// hunting rule (seed 1), or on ranges that are not the wider ones (the family's own has no
/// stop; the wider one 13 / 15: asserted ≥ 5).
#[test]
fn the_wider_family_fails_flagged() {
    for seed in [1, 7] {
        let r = family_of(FamilyOptions {
            calibrate: true,
            ranges: FamilyRanges::wide(),
            ..options(seed)
        });
        let s = &r.seek;
        for p in &r.plants {
            let b = &p.seek;
            assert!(
                b.safe_stop.is_some() || b.unsettled_reported == b.unsettled,
                "seed {seed}, plant {}: {} unsettled, {} reported, no stop",
                p.index,
                b.unsettled,
                b.unsettled_reported
            );
        }
        assert!(s.unflagged_failures <= 1, "seed {seed}: {s:?}");
        assert!(s.safe_stops >= 5, "seed {seed}: {s:?}");
    }
}

/// The calibrated seek mode on `plants` plants of `ranges` (run seed 1, 100 seeks each): plants
/// with an unsettled seek or a pulse, unsettled seeks, pulses, safe stops.
fn sub_family(ranges: FamilyRanges, seed: u64, plants: u64) -> [usize; 4] {
    use sledid_host::control::design::design_from_prior;
    use sledid_host::control::seek::SeekController;
    use sledid_host::control::seek::run::{run_seeks, seek_design};
    use sledid_host::twin::{PlantParams, TwinParams};
    let mut n = [0usize; 4];
    for index in 0..plants {
        let params = ranges.draw(seed, index).twin(&TwinParams::default());
        let design = seek_design(design_from_prior(&params, &PlantParams::default()).unwrap());
        let schedule = SeekOptions {
            seeks: 100,
            seed: 1,
            calibrate: true,
            ..SeekOptions::default()
        };
        let s = run_seeks(&params, &SeekController::Seek(design), &schedule)
            .unwrap()
            .summary;
        n[0] += usize::from(s.unsettled + s.limit_cycle_pulses > 0);
        n[1] += s.unsettled;
        n[2] += s.limit_cycle_pulses;
        n[3] += usize::from(s.safe_stop.is_some());
    }
    n
}

/// Settle after a time-optimal seek (`control::scheduled`, "Settle of a time-optimal seek") on
/// the two corners of the family it was built for, 100 plants each of sub-family seeds 1 and 2,
/// calibrated, 100 seeks each. Light and sticky (mass 0.5–0.9×, viscous 0.5–1.5×, Coulomb
/// 1.2–2×, stiction 2–3×, quantum 0.5–0.9×): a fine step's breakaway ramp carried the sled three
/// quanta and more, and a Hold one cell off cut fine steps short. Heavy and lightly damped (mass
/// 3–6×, viscous 0.5–1.3×, Coulomb 0–0.7×): a glide under the coasting dead zone left the band.
/// Measured 2026-12-07, main before the rules / with them (plants with an unsettled seek or a
/// pulse, unsettled seeks): light 16 + 19 / 10 + 8 plants, 49 + 37 / 19 + 22 unsettled (seeds
/// 3 / 4: 19 + 15 / 11 + 12 plants, 49 + 38 / 25 + 27); heavy 68 + 64 / 8 + 4 unsettled (8 + 8 /
/// 6 + 7 plants). With a fine step pulsed also once one has thrown the sled past the target on
/// a throwing model (`control::scheduled::rest`, "A sticking sled's breakaway"; 2026-12-07):
/// light 7 + 8 plants, 14 + 19 unsettled (seeds 3 / 4: 10 + 11, 25 + 25), heavy unchanged.
/// Asserted (unchanged): light ≤ 26 plants and ≤ 55 unsettled of 200, heavy ≤ 30 unsettled,
/// no safe stop. Trips on (measured, each rule removed alone): no pulsed fine steps (light 36
/// plants, 80 unsettled), a Hold one cell off during a fine step (39, 77), coasting damped on the
/// velocity observer alone (light 62 unsettled; heavy 97).
#[test]
fn settle_after_a_time_optimal_seek_on_the_sticky_and_the_gliding_corners() {
    let light = FamilyRanges {
        mass: (0.5, 0.9),
        viscous: (0.5, 1.5),
        coulomb: (1.2, 2.0),
        stiction_ratio: (2.0, 3.0),
        quantum: (0.5, 0.9),
        ..FamilyRanges::default()
    };
    let heavy = FamilyRanges {
        mass: (3.0, 6.0),
        viscous: (0.5, 1.3),
        coulomb: (0.0, 0.7),
        ..FamilyRanges::default()
    };
    let (l1, l2) = (sub_family(light, 1, 100), sub_family(light, 2, 100));
    let (h1, h2) = (sub_family(heavy, 1, 100), sub_family(heavy, 2, 100));
    println!(
        "light: {l1:?} {l2:?}; heavy: {h1:?} {h2:?} (plants failing, unsettled, pulses, stops)"
    );
    assert!(l1[0] + l2[0] <= 26, "light: {l1:?} {l2:?}");
    assert!(l1[1] + l2[1] <= 55, "light: {l1:?} {l2:?}");
    assert!(h1[1] + h2[1] <= 30, "heavy: {h1:?} {h2:?}");
    assert_eq!(l1[3] + l2[3] + h1[3] + h2[3], 0, "safe stops");
}
