use sledid_host::twin::{Twin, TwinParams};
fn main() {
    let mut p = TwinParams::well_damped();
    p.reference.seek_count = 3;
    let twin = Twin::run_baseline(p, 1).unwrap();
    for (s, st) in twin.seeks().iter().zip(twin.seek_stats()) {
        println!(
            "{:?} {:?} settle {:?} lc {:?}",
            s.start_index, s.end_index, st.settling_time_s, st.limit_cycle
        );
        let samples = &twin.samples()[s.start_index..s.end_index.unwrap()];
        let stuck = samples.windows(2).filter(|w| w[0].x_m == w[1].x_m).count();
        println!("stuck pairs {stuck} of {}", samples.len());
    }
}
