//! Seeks on the plant family (`sledid control-family --passes seek`,
//! `sledid_host::control::seek::family`): two families of 200 plants (seeds 1 and 7), 100
//! log-uniform seeks of 20–2,000 tracks each, every servo designed from the nominal prior only;
//! each seek's access time over the minimum-time bound of its plant. Assertions are on the
//! families' statistics.
//!
//! Issue 14's targets and what the controllers measure (`BENCHMARKS.md`, controller, seeks).
//! "Seek mode" is the time-optimal seek ([`sledid::control::SeekMode::TimeOptimal`], switched
//! on by `control::seek::seek_design`).
//!
//! | measure | target | seek mode, seed 1 / 7 | reference-following, seed 1 / 7 |
//! |---|---|---|---|
//! | access / bound, median over all seeks | ≤ 1.5 | 1.43 / 1.38 | 6.10 / 5.70 |
//! | access / bound, p95 | ≤ 2.5 | 8.0 / 9.7 | 26.0 / 20.7 |
//! | access / bound, median over seeks ≥ 200 tracks | ≤ 1.3 | 1.24 / 1.21 | 3.16 / 2.91 |
//! | plants with 0 unsettled and 0 pulses | ≥ 99 % | 89.0 % / 81.5 % | 84.0 % / 86.5 % |
//! | nominal sled: median access, reference-following / seek mode | ≥ 3 | 27.3 / 5.0 ms = 5.45 | |
//!
//! The medians and the nominal speed-up meet the targets and are asserted at them; the p95 and
//! the clean plants do not (issue 14's note: fast sleds several times the prior's gain ring
//! after a time-optimal arrival; a few sleds held one cell off after their fine steps still
//! flicker to two cells on sensor noise) and are asserted at today's level so that a regression
//! trips.
//!
//! What trips each: a harness that times the reference-following servo from the reference's
//! arrival instead of the command (its ratios fall towards the seek mode's), a bound that is too
//! long or too short (every ratio moves), pulses or unsettled seeks left uncounted (clean goes to
//! 100 %).

use sledid_host::control::family_eval::FamilyOptions;
use sledid_host::control::seek::SeekOptions;
use sledid_host::control::seek::family::{SeekFamilyReport, evaluate, stats_table};

fn family(seed: u64) -> SeekFamilyReport {
    let options = FamilyOptions {
        plants: 200,
        seed,
        seeks: 100,
        ..FamilyOptions::default()
    };
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
        // The seek mode: issue 14's targets where met, today's level where not.
        assert!(s.ratio.median <= 1.5, "seed {seed}: {s:?}");
        assert!(s.ratio_long_median <= 1.3, "seed {seed}: {s:?}");
        assert!(s.ratio.p95 <= 12.0, "seed {seed}: {s:?}");
        assert!(s.clean >= 0.78, "seed {seed}: {s:?}");
        assert!(s.ratio.median * 3.0 <= f.ratio.median, "seed {seed}");
        assert!(r.nominal.speedup >= 3.0, "seed {seed}: {:?}", r.nominal);
        assert!((25.0..=31.0).contains(&r.nominal.reference.access_ms.median));
    }
}
