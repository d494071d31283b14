//! Scratch: the scheduled controller on family plants.
use rayon::prelude::*;
use sledid_host::control_eval::{run_with, scheduled_design_for};
use sledid_host::family::FamilyRanges;
use sledid_host::twin::{PlantParams, TwinParams};

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let seeks: u32 = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let ranges = FamilyRanges::default();
    let rows: Vec<String> = (0..n)
        .into_par_iter()
        .map(|i| {
            let f = ranges.draw(std::env::var("FAMILY_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1), i);
            let params = f.twin(&TwinParams::default());
            // Strict prior: the nominal sled in every respect, its quantum included.
            let mut units = params.clone();
            units.plant.quantum_m = PlantParams::default().quantum_m;
            let design = scheduled_design_for(&units, &PlantParams::default()).unwrap();
            let base = run_with(&params, 1, seeks, None).unwrap().summary;
            let run = run_with(&params, 1, seeks, Some(&design)).unwrap();
            let sched = run.summary.clone();
            let frozen = sledid_host::control_eval::run_with_options(&params, 1, seeks, Some(&design), sledid::servo::ServoOptions { identification: sledid::servo::Identification::FrozenAtPrior, ..Default::default() }).unwrap().summary;
            let prior_err = f.prior_error(sledid_host::control_eval::physical_model);
            let truth = sledid_host::control_eval::physical_model(&params.plant);
            let last = run.redesigns.iter().rev().find_map(|r| match r { sledid::control::Redesign::Applied(m) => Some((m.a, m.b)), _ => None });
            format!(
                "{i:3} {:48} base {:6.1} ms uns {:3} pul {:4} | sched {:6.1} ms ({:.2}) uns {:3} pul {:4} hold {:3} fb {:3} | a {:.3}/{:.3} b {:.2}/{:.2} | frozen {:6.1} ms ({:.2}) uns {:3} pul {:4} prior-err {:.2}",
                f.label(),
                base.settling_ms.median,
                base.unsettled,
                base.limit_cycle_pulses,
                sched.settling_ms.median,
                sched.settling_ms.median / base.settling_ms.median,
                sched.unsettled,
                sched.limit_cycle_pulses,
                sched.hold_pulses,
                sched.fallbacks,
                last.map_or(f32::NAN, |m| m.0), truth.0, last.map_or(f32::NAN, |m| m.1), truth.1,
                frozen.settling_ms.median, sched.settling_ms.median / frozen.settling_ms.median, frozen.unsettled, frozen.limit_cycle_pulses, prior_err
            )
        })
        .collect();
    let verbose = std::env::var_os("VERBOSE").is_some();
    let mut ratios = Vec::new();
    let (mut bad_pulses, mut bad_uns) = (0, 0);
    for r in &rows {
        if verbose {
            println!("{r}");
        }
        let ratio: f64 = r
            .split('(')
            .nth(1)
            .unwrap()
            .split(')')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        ratios.push(ratio);
        let sched = r.split("| sched").nth(1).unwrap();
        let uns: usize = sched
            .split("uns")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let pul: usize = sched
            .split("pul")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap();
        if pul > 0 {
            bad_pulses += 1;
            if !verbose {
                println!("PULSES {r}");
            }
        }
        if uns > 0 {
            bad_uns += 1;
            if !verbose {
                println!("UNSETTLED {r}");
            }
        }
        if ratio > 0.7 && !verbose {
            println!("RATIO {r}");
        }
    }
    let ok = ratios.iter().filter(|&&x| x <= 0.7).count();
    let mut worse = 0;
    let mut off = 0;
    let mut gain20 = 0;
    for r in &rows {
        let id_vs = r.split("frozen").nth(1).unwrap();
        let ratio: f64 = id_vs
            .split('(')
            .nth(1)
            .unwrap()
            .split(')')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        let perr: f64 = id_vs
            .split("prior-err")
            .nth(1)
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        if ratio > 1.0 {
            worse += 1;
            println!("ID-WORSE {r}");
        }
        if perr > 0.3 {
            off += 1;
            if ratio <= 0.8 {
                gain20 += 1;
            } else {
                println!("ID-NOGAIN {r}");
            }
        }
    }
    println!(
        "id worse than frozen on {worse} plants; {gain20} of {off} off-prior plants gain >= 20%"
    );
    println!(
        "plants {} ratio<=0.7: {} ({:.1}%), with pulses {}, with unsettled {}",
        rows.len(),
        ok,
        100.0 * ok as f64 / rows.len() as f64,
        bad_pulses,
        bad_uns
    );
}
