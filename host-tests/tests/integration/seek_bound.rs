//! The minimum-time bound of a seek on the twin's own plant (`twin::bound`, issue 14): it matches
//! the analytic bang-bang time of a frictionless sled, it grows like √distance for short seeks and
//! linearly for long ones, it never shrinks with the distance, and the reference shape options it
//! is measured with leave the twin's defaults untouched. That no closed-loop run beats it is
//! `tests/integration/seek.rs`.

use sledid_host::twin::{
    PlantParams, ReferenceParams, ReferenceProfile, SeekDistribution, Twin, TwinParams,
    min_time_seek,
};

fn samples(plant: &PlantParams, tracks: i64) -> usize {
    min_time_seek(plant, 0.0, tracks)
        .expect("reachable")
        .samples
}

/// Nominal sled: the bounds issue 14 quotes (≈ 0.9 / 2.7 / 10 ms for 20 / 200 / 2,000 tracks).
/// Measured: 2, 6 and 22 samples. Trips on a search that misses the switch (longer) or a bound
/// that reads the true position instead of the rounded reading (shorter for short seeks).
#[test]
fn nominal_bounds() {
    let p = PlantParams::default();
    let ms = |d| samples(&p, d) as f64 * p.ts_s * 1e3;
    println!(
        "bound 20 / 200 / 2000 tracks: {:.2} / {:.2} / {:.2} ms",
        ms(20),
        ms(200),
        ms(2000)
    );
    assert_eq!(samples(&p, 20), 2);
    assert_eq!(samples(&p, 200), 6);
    assert_eq!(samples(&p, 2000), 22);
    assert_eq!(samples(&p, -2000), 22, "friction is symmetric");
    assert_eq!(samples(&p, 1), 0, "already within ±1 track");
}

/// A sled without friction is a double integrator, a = k_f·u_max/m. Entering the band
/// [T − 1.5, T + 1.5) quanta for good is fastest by full drive, then full braking to rest just
/// below its far edge (total travel L = (D + 1.5)·q, rest-to-rest time 2√(L/a)); the band's near
/// edge is passed √(2·3q/a) before the stop: t_e = 2√(L/a) − √(6q/a), the continuous-time
/// optimum, which no sampled control beats: t_e ≤ J·Ts. The zero-order hold costs at most two
/// samples: the readings are taken at the samples (< 1) and a sampled sled comes to rest at a
/// sample instant, so its rest-to-rest time is the continuous one rounded up to whole samples
/// (< 1). Asserted for 2 to 10⁵ tracks: 0 ≤ J − t_e/Ts < 2; measured at most 1.48 samples (5
/// tracks), 1.24 from 20 tracks on. Trips on a switch search that loses a sample, or a plant step
/// that is not the exact solution.
#[test]
fn frictionless_sled_matches_the_analytic_bang_bang_time() {
    let p = PlantParams {
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        static_n: 0.0,
        noise_m: 0.0,
        ..PlantParams::default()
    };
    let a = p.force_per_volt_n_per_v * p.u_max_v / p.mass_kg;
    let q = p.quantum_m;
    let (mut worst, mut worst_long): (f64, f64) = (0.0, 0.0);
    for d in (2..40).chain([55, 200, 640, 2000, 7777, 20_000, 100_000]) {
        let t_e = 2.0 * ((d as f64 + 1.5) * q / a).sqrt() - (6.0 * q / a).sqrt();
        let j = samples(&p, d) as f64;
        let lag = j - t_e / p.ts_s;
        worst = worst.max(lag);
        if d >= 20 {
            worst_long = worst_long.max(lag);
        }
        assert!(
            (-1e-9..2.0).contains(&lag),
            "{d} tracks: J = {j}, t_e/Ts = {}",
            t_e / p.ts_s
        );
    }
    println!("frictionless: J − t_e/Ts at most {worst:.3} samples, {worst_long:.3} from 20 tracks");
    assert!(worst_long < 1.25, "{worst_long}");
}

/// Short seeks are acceleration-limited (time ∝ √D), long ones speed-limited (time ∝ D at the top
/// speed v_max = (k_f·u_max − F_c)/b). On a heavy, lightly damped sled (τ = m/b = 0.5 s) 4× the
/// distance takes 2× the samples (within one sample) from 200 to 3,200 tracks; on the nominal
/// sled (τ = 2.5 ms) going from 20,000 to 40,000 tracks adds 20,000 tracks at v_max (within one
/// sample). Trips on a bound that ignores the viscous friction or the rail.
#[test]
fn bound_grows_like_the_square_root_then_linearly() {
    let heavy = PlantParams {
        mass_kg: 1.0,
        viscous_n_s_per_m: 2.0,
        ..PlantParams::default()
    };
    for d in [200i64, 800] {
        let (j1, j4) = (samples(&heavy, d) as f64, samples(&heavy, 4 * d) as f64);
        println!("heavy sled: {d} tracks {j1} samples, {} tracks {j4}", 4 * d);
        assert!((j4 - 2.0 * j1).abs() <= 2.0, "{d}: {j1} → {j4}");
    }
    let p = PlantParams::default();
    let v_max = (p.force_per_volt_n_per_v * p.u_max_v - p.coulomb_n) / p.viscous_n_s_per_m;
    let per_sample = v_max * p.ts_s / p.quantum_m;
    let (j1, j2) = (samples(&p, 20_000) as f64, samples(&p, 40_000) as f64);
    let expected = 20_000.0 / per_sample;
    println!(
        "nominal: 20,000 → 40,000 tracks adds {} samples, {expected:.2} at v_max",
        j2 - j1
    );
    assert!((j2 - j1 - expected).abs() <= 1.0);
}

/// A longer seek never has a shorter bound, on the nominal sled and on a slow, sticky one, for
/// every distance from 1 to 3,000 tracks. Trips on a search that misses the optimum for some
/// distances (non-monotone jumps).
#[test]
fn bound_never_shrinks_with_the_distance() {
    let slow = PlantParams {
        mass_kg: 0.25,
        viscous_n_s_per_m: 300.0,
        force_per_volt_n_per_v: 1.0,
        coulomb_n: 0.15,
        static_n: 0.45,
        ..PlantParams::default()
    };
    for p in [PlantParams::default(), slow] {
        let mut last = 0;
        for d in 1..=3000 {
            let j = samples(&p, d);
            assert!(j >= last, "{d} tracks: {j} < {last}");
            last = j;
        }
    }
}

/// A rail that cannot break the sled loose has no bound; a start already within the band has 0.
#[test]
fn unreachable_and_trivial_seeks() {
    let stuck = PlantParams {
        static_n: 20.0,
        coulomb_n: 1.0,
        ..PlantParams::default()
    };
    assert!(min_time_seek(&stuck, 0.0, 100).is_none());
    let p = PlantParams::default();
    let b = min_time_seek(&p, 99.4 * p.quantum_m, 100).unwrap();
    assert_eq!(b.samples, 0);
}

/// The new reference options keep the defaults: a default reference serialises without them
/// (sidecars and plant files unchanged) and draws the same targets as before (uniform lengths);
/// the log-uniform draw stays in range and puts about half of its lengths below the geometric
/// mean; the step profile holds the target from the seek's first sample.
#[test]
fn reference_options_are_additive() {
    let json = TwinParams::default().to_json_string().unwrap();
    assert!(
        !json.contains("profile") && !json.contains("seek_distribution"),
        "{json}"
    );
    let parsed = TwinParams::from_json_str(
        r#"{"reference": {"profile": "step", "seek_distribution": "log_uniform"}}"#,
    )
    .unwrap();
    assert_eq!(parsed.reference.profile, ReferenceProfile::Step);
    assert_eq!(
        parsed.reference.seek_distribution,
        SeekDistribution::LogUniform
    );

    let with = |r: ReferenceParams| {
        let mut t = Twin::new(
            TwinParams {
                reference: r,
                ..TwinParams::default()
            },
            3,
        )
        .unwrap();
        let mut zero = |_: f64, _: f64| 0.0;
        t.run(&mut zero);
        t
    };
    let base = ReferenceParams {
        seek_count: 400,
        dwell_s: 0.001,
        ..ReferenceParams::default()
    };
    let log = with(ReferenceParams {
        seek_distribution: SeekDistribution::LogUniform,
        ..base.clone()
    });
    let mut previous = 0;
    let mut below = 0;
    for s in log.seeks() {
        let d = (s.target_counts - previous).abs();
        previous = s.target_counts;
        assert!((20..=2000).contains(&d), "{d}");
        below += usize::from(d < 200);
    }
    assert!(
        (160..=240).contains(&below),
        "{below} of 400 below 200 tracks"
    );

    let step = with(ReferenceParams {
        profile: ReferenceProfile::Step,
        seek_count: 3,
        ..base.clone()
    });
    for s in step.seeks() {
        assert_eq!(s.arrival_index, Some(s.start_index));
        let r = step.samples()[s.start_index].r_m / step.params().plant.quantum_m;
        assert_eq!(r, s.target_counts as f64);
    }
}
