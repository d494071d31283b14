//! Scratch: one family plant with the scheduled controller, redesign outcomes.
use sledid_host::control_eval::{run_with, scheduled_design_for};
use sledid_host::family::FamilyRanges;
use sledid_host::twin::{PlantParams, TwinParams};

fn main() {
    let i: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let seeks: u32 = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let f = FamilyRanges::default().draw(
        std::env::var("FAMILY_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1),
        i,
    );
    let params = f.twin(&TwinParams::default());
    let mut units = params.clone();
    units.plant.quantum_m = PlantParams::default().quantum_m;
    let design = scheduled_design_for(&units, &PlantParams::default()).unwrap();
    println!(
        "{} true model {:?} prior {:?}",
        f.label(),
        sledid_host::control_eval::physical_model(&params.plant),
        design.prior_model
    );
    let run = run_with(&params, 1, seeks, Some(&design)).unwrap();
    println!("{:?}", run.redesigns);
    let mut last = None;
    for (k, (region, flags)) in run.trace.iter().enumerate() {
        let fb = flags.contains(sledid::control::ControlFlags::FALLBACK);
        let mu = flags.contains(sledid::control::ControlFlags::MODEL_UNTRUSTED);
        if last != Some((*region, fb, mu)) {
            let s = run.twin.samples()[k];
            println!(
                "{k:6} {:?} fb {fb} untrusted {mu} e {}",
                region,
                s.target_counts - s.y_counts
            );
            last = Some((*region, fb, mu));
        }
        if k > 4000 {
            break;
        }
    }
    let breakaway = params.plant.static_n / params.plant.force_per_volt_n_per_v;
    for seek in run.twin.seeks() {
        let (Some(arrival), Some(end)) = (seek.arrival_index, seek.end_index) else {
            continue;
        };
        let start = end - (end - arrival) / 2;
        for k in start..end {
            let s = run.twin.samples()[k];
            if s.u_v.abs() > breakaway {
                println!(
                    "pulse at {k} (window {start}..{end}): u {:.4} e {} {:?}",
                    s.u_v,
                    s.target_counts - s.y_counts,
                    run.trace[k]
                );
            }
        }
    }
    let samples = run.twin.samples();
    for (seek, st) in run.twin.seeks().iter().zip(run.twin.seek_stats()) {
        if st.limit_cycle.pulses > 0 {
            let end = seek.end_index.unwrap();
            let n = (st.limit_cycle.window_s / params.plant.ts_s).round() as usize;
            for k in end - n..end {
                if samples[k].u_v.abs() > breakaway {
                    println!(
                        "  counted pulse k {k} u {:.4} e {} {:?} x-target {:.3}",
                        samples[k].u_v,
                        samples[k].target_counts - samples[k].y_counts,
                        run.trace[k],
                        samples[k].x_m / params.plant.quantum_m - samples[k].target_counts as f64
                    );
                }
            }
            println!(
                "seek {}..{:?} step {} pulses {} first-within {:?} settle {:?}",
                seek.start_index,
                seek.end_index,
                st.step_counts,
                st.limit_cycle.pulses,
                st.first_within_one_s,
                st.settling_time_s
            );
        }
        if st.settling_time_s.is_none() {
            println!(
                "unsettled seek {}..{:?} step {}",
                seek.start_index, seek.end_index, st.step_counts
            );
        }
    }
    let from: usize = std::env::args()
        .nth(3)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let to: usize = std::env::args()
        .nth(4)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    for k in from..to.min(run.twin.samples().len()) {
        let s = run.twin.samples()[k];
        let (region, flags) = run.trace[k];
        println!(
            "{k:6} e {:4} u {:8.4} {:?} x-target {:8.3} {:?}",
            s.target_counts - s.y_counts,
            s.u_v,
            region,
            s.x_m / params.plant.quantum_m - s.target_counts as f64,
            flags
        );
    }
}
#[allow(dead_code)]
fn unused() {}
