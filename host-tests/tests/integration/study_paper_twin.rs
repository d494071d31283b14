//! The paper's study on the default twin (the paper's kind of badly tuned baseline, which
//! oscillates while settling; `host-tests/plants/paper_sled.json` writes it out): its windows
//! hold the decaying oscillation the paper identifies from, and the paper's linear findings hold
//! there on every seed — ARX1 simulates very poorly at Ts (Fig. 6a) and much better after ÷2
//! (Fig. 10a); OE1 simulates far better than ARX1 at Ts (Fig. 6b); OE2 better than OE1 (Fig. 11).
//! The nonlinear models are reported, not asserted: on these 100-sample windows they win on some
//! seeds and lose on others (printed with `--nocapture`).

use sledid_host::study::protocol::{PAPER_WINDOW, run_twin};
use sledid_host::study::{RateReport, StudyOptions};

const SEEDS: u64 = 8;

fn rms(rate: &RateReport, name: &str) -> f64 {
    rate.models
        .iter()
        .map(|m| (m.name.as_str(), m.rms_sim_valid))
        .chain(
            rate.nonlinear
                .iter()
                .map(|m| (m.name.as_str(), m.rms_sim_valid)),
        )
        .find(|(n, _)| *n == name)
        .map(|(_, r)| r)
        .unwrap_or_else(|| panic!("no model {name}"))
}

#[test]
fn paper_findings_hold_on_the_default_twin() {
    let mut settle = Vec::new();
    let mut counts = [0usize; 4];
    for seed in 1..=SEEDS {
        let dir =
            std::env::temp_dir().join(format!("sledid-study-paper-{}-{seed}", std::process::id()));
        let s = run_twin(seed, PAPER_WINDOW, &dir, StudyOptions::default()).unwrap();
        let n = s.twin.as_ref().unwrap().ident.settling_samples_in_window;
        settle.push(n);
        let (ts, half) = (&s.at_ts, &s.decimated_by_2);
        println!(
            "seed {seed}: {n:3} settling samples | Ts: ARX1 {:.3e} OE1 {:.3} OE2 {:.3} Wiener1 {:.3} NOE221 {:.3} | ÷2: ARX1 {:.3e} OE1 {:.3} OE2 {:.3} Wiener1 {:.3} NOE221 {:.3}",
            rms(ts, "ARX1"),
            rms(ts, "OE1"),
            rms(ts, "OE2"),
            rms(ts, "Wiener1"),
            rms(ts, "NOE221"),
            rms(half, "ARX1"),
            rms(half, "OE1"),
            rms(half, "OE2"),
            rms(half, "Wiener1"),
            rms(half, "NOE221"),
        );
        counts[0] += usize::from(rms(ts, "ARX1") > 2.0 * rms(ts, "OE1"));
        counts[1] += usize::from(rms(half, "ARX1") < rms(ts, "ARX1"));
        counts[2] += usize::from(rms(ts, "OE2") < rms(ts, "OE1"));
        counts[3] += usize::from(rms(ts, "Wiener1") < rms(ts, "OE1"));
        let _ = std::fs::remove_dir_all(&dir);
    }
    settle.sort_unstable();
    println!(
        "settling samples in the 100-sample window: {settle:?}; ARX1 ≫ OE1 at Ts {}/{SEEDS}, ARX1 better after ÷2 {}/{SEEDS}, OE2 < OE1 {}/{SEEDS}, Wiener1 < OE1 at Ts {}/{SEEDS}",
        counts[0], counts[1], counts[2], counts[3]
    );
    // Measured (seeds 1–8): 37–100 samples, median 84; every finding 8/8; Wiener1 < OE1 on 2/8.
    assert!(settle[settle.len() / 2] >= 60, "{settle:?}");
    assert_eq!(
        counts[0], SEEDS as usize,
        "ARX1 simulates far worse than OE1 at Ts"
    );
    assert_eq!(counts[1], SEEDS as usize, "ARX1 simulates better after ÷2");
    assert_eq!(counts[2], SEEDS as usize, "OE2 beats OE1 at Ts");
}
