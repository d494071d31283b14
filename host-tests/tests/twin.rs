use sledid_host::twin::*;

fn show(p: &TwinParams, seed: u64) {
    let twin = Twin::run_baseline(p.clone(), seed).unwrap();
    for s in twin.seek_stats() {
        let lc = &s.limit_cycle;
        println!(
            "step {:6} first {:?} settle {:?} ovs {} | maxe {} off {:.2} sc {} per {:?} urms {:.2} upk {:.2} pulses {} w {:?}",
            s.step_counts,
            s.first_within_one_s.map(|t| (t * 1e3).round()),
            s.settling_time_s.map(|t| (t * 1e3).round()),
            s.overshoot_counts,
            lc.max_abs_error_counts,
            lc.off_target_fraction,
            lc.sign_changes,
            lc.period_s.map(|t| (t * 1e4).round() / 10.0),
            lc.u_rms_v,
            lc.u_peak_v,
            lc.pulses,
            lc.mean_pulse_s.map(|t| (t * 1e4).round() / 10.0)
        );
    }
}

#[test]
fn scan() {
    let mut p = TwinParams::default();
    let args: Vec<f64> = std::env::var("SCAN")
        .unwrap_or_default()
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    if args.len() >= 5 {
        p.controller.kp_v_per_count = args[0];
        p.controller.ki_v_per_count_s = args[1];
        p.controller.kd_v_s_per_count = args[2];
        p.controller.d_filter_hz = args[3];
        p.plant.noise_m = args[4];
    }
    if args.len() >= 10 {
        p.plant.mass_kg = args[5];
        p.plant.force_per_volt_n_per_v = args[6];
        p.plant.viscous_n_s_per_m = args[7];
        p.plant.coulomb_n = args[8];
        p.plant.static_n = args[9];
    }
    if args.len() >= 11 {
        p.controller.integrator_limit_v = args[10];
    }
    if args.len() >= 12 {
        p.reference.ref_rise_s = args[11];
    }
    println!("{:?}\n{:?}", p.controller, p.plant);
    for seed in 1..=2 {
        println!("seed {seed}");
        show(&p, seed);
    }
}

fn params_from_env() -> TwinParams {
    let mut p = TwinParams::default();
    if let Ok(s) = std::env::var("P") {
        for kv in s.split(',') {
            let (k, v) = kv.split_once('=').unwrap();
            let v: f64 = v.parse().unwrap();
            match k {
                "kp" => p.controller.kp_v_per_count = v,
                "ki" => p.controller.ki_v_per_count_s = v,
                "kd" => p.controller.kd_v_s_per_count = v,
                "fd" => p.controller.d_filter_hz = v,
                "il" => p.controller.integrator_limit_v = v,
                "m" => p.plant.mass_kg = v,
                "kf" => p.plant.force_per_volt_n_per_v = v,
                "b" => p.plant.viscous_n_s_per_m = v,
                "fc" => p.plant.coulomb_n = v,
                "fs" => p.plant.static_n = v,
                "n" => p.plant.noise_m = v,
                "rf" => p.reference.ref_rise_s = v,
                "dw" => p.reference.dwell_s = v,
                _ => panic!("{k}"),
            }
        }
    }
    p
}

#[test]
fn trace() {
    let p = params_from_env();
    let seed: u64 = std::env::var("SEED")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(1);
    let seek_i: usize = std::env::var("SEEK")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(0);
    let from: i64 = std::env::var("FROM")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(-40);
    let len: usize = std::env::var("LEN")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(200);
    let twin = Twin::run_baseline(p.clone(), seed).unwrap();
    show(&p, seed);
    let seek = &twin.seeks()[seek_i];
    let a = seek.arrival_index.unwrap() as i64;
    let q = p.plant.quantum_m;
    let s = twin.samples();
    for k in (a + from).max(0) as usize..((a + from) as usize + len).min(s.len()) {
        let x = &s[k];
        println!(
            "{:5} r-T {:8.3} e {:4} u {:7.4} x-T {:8.3}",
            k as i64 - a,
            x.r_m / q - seek.target_counts as f64,
            seek.target_counts - x.y_counts,
            x.u_v,
            x.x_m / q - seek.target_counts as f64
        );
    }
}

fn score(p: &TwinParams, seeds: u64) -> (usize, usize, f64, f64, i64, f64) {
    // (failures, seeks, mean period ms, mean settle ms, max overshoot, mean sign changes)
    let mut fails = 0;
    let mut n = 0;
    let mut per = 0.0;
    let mut nper = 0;
    let mut settle = 0.0;
    let mut nset = 0;
    let mut ovs = 0;
    let mut sc = 0.0;
    for seed in 1..=seeds {
        let twin = Twin::run_baseline(p.clone(), seed).unwrap();
        for s in twin.seek_stats() {
            n += 1;
            let lc = &s.limit_cycle;
            if lc.max_abs_error_counts > 1 {
                fails += 1;
            }
            if lc.sign_changes < 6 {
                fails += 1000;
            }
            if let Some(t) = lc.period_s {
                per += t;
                nper += 1;
            }
            if let Some(t) = s.settling_time_s {
                settle += t;
                nset += 1;
            }
            ovs = ovs.max(s.overshoot_counts);
            sc += lc.sign_changes as f64;
        }
    }
    (
        fails,
        n,
        per / nper.max(1) as f64 * 1e3,
        settle / nset.max(1) as f64 * 1e3,
        ovs,
        sc / n as f64,
    )
}

#[test]
fn grid() {
    let base = params_from_env();
    let seeds: u64 = std::env::var("SEEDS")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(5);
    let list = |name: &str, def: &[f64]| -> Vec<f64> {
        std::env::var(name)
            .ok()
            .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
            .unwrap_or(def.to_vec())
    };
    for kp in list("GKP", &[base.controller.kp_v_per_count]) {
        for ki in list("GKI", &[base.controller.ki_v_per_count_s]) {
            for kd in list("GKD", &[base.controller.kd_v_s_per_count]) {
                for n in list("GN", &[base.plant.noise_m]) {
                    let mut p = base.clone();
                    p.controller.kp_v_per_count = kp;
                    p.controller.ki_v_per_count_s = ki;
                    p.controller.kd_v_s_per_count = kd;
                    p.plant.noise_m = n;
                    let (f, tot, per, set, ovs, sc) = score(&p, seeds);
                    println!(
                        "kp {kp:<8} ki {ki:<6} kd {kd:<8} n {n:<8} fails {f:3}/{tot} per {per:6.1} settle {set:6.1} ovs {ovs:3} sc {sc:5.1}"
                    );
                }
            }
        }
    }
}
