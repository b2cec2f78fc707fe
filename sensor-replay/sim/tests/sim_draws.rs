//! The simulator's random IMU bias draws have the statistics the scenario
//! specifies (issue 21: the nine accelerometer draws of seeds 1–3 of the
//! quick start have an RMS of 142 µg against 100 µg; is that chance?).
//! The draws are taken as `simulate` takes them (the first draws of the
//! seed's generator, checked against a simulated log's truth bias record)
//! over thousands of seeds, and tested against N(0, σ²): the variance with
//! χ² bounds, the mean, and the whole distribution with a
//! Kolmogorov–Smirnov bound, each at a false-alarm rate of about 1e-4.

use msgs::navlog::Record;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::sensors::ImuErrorModel;
use polarnav_sim::simulate::{SimOptions, simulate, truth_bias_record};
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

const SEEDS: u64 = 3000;
/// 1e-6 g in m/s² (the scenario's µg, with the simulator's g).
const UG: f64 = 1e-6 * polarnav::earth::G0;
const DPH: f64 = std::f64::consts::PI / 180.0 / 3600.0;

fn quick_start() -> (Scenario, String) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/scenarios/polar-crossing.toml");
    let text = std::fs::read_to_string(path)
        .expect("scenario")
        .replace("duration_s = 19600.0", "duration_s = 1.0");
    (
        Scenario::parse(&text, "polar-crossing").expect("scenario"),
        text,
    )
}

/// The accelerometer and gyro bias `simulate` draws for `seed`.
fn drawn(s: &Scenario, seed: u64) -> ([f64; 3], [f64; 3]) {
    let m = ImuErrorModel::new(&s.imu, &mut ChaCha20Rng::seed_from_u64(seed));
    let r = truth_bias_record(0, &m, false);
    (r.accel_bias_mps2, r.gyro_bias_rps)
}

/// Standard normal CDF (Abramowitz–Stegun 7.1.26 erf, |error| < 1.5e-7).
fn phi(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// Variance ratio, mean in σ of the mean, and the KS distance of `x/σ`
/// from N(0, 1).
fn stats(x: &[f64], sigma: f64) -> (f64, f64, f64) {
    let n = x.len() as f64;
    let var_ratio = x.iter().map(|v| (v / sigma).powi(2)).sum::<f64>() / n;
    let mean_z = x.iter().sum::<f64>() / n / (sigma / n.sqrt());
    let mut z: Vec<f64> = x.iter().map(|v| v / sigma).collect();
    z.sort_by(f64::total_cmp);
    let ks = z
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let f = phi(*v);
            (f - k as f64 / n).abs().max(((k + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max);
    (var_ratio, mean_z, ks)
}

#[test]
fn the_draws_are_what_simulate_draws() {
    let (s, text) = quick_start();
    for seed in 1..=3 {
        let mut log = Vec::new();
        simulate(
            &s,
            &text,
            SimOptions {
                seed,
                ..Default::default()
            },
            &mut log,
        )
        .expect("simulate");
        let (records, _) = msgs::navlog::read_all(&log);
        let in_log = records
            .iter()
            .find_map(|r| match r {
                Record::TruthBias(b) => Some((b.accel_bias_mps2, b.gyro_bias_rps)),
                _ => None,
            })
            .expect("truth bias record");
        assert_eq!(in_log, drawn(&s, seed), "seed {seed}");
    }
}

#[test]
fn bias_draws_over_many_seeds_are_normal_with_the_specified_sigma() {
    let (s, _) = quick_start();
    let (sa, sg) = (s.imu.accel_bias_ug * UG, s.imu.gyro_bias_dph * DPH);
    assert!(sa > 0.0 && sg > 0.0, "the quick start draws biases");
    let (mut accel, mut gyro) = (Vec::new(), Vec::new());
    for seed in 1..=SEEDS {
        let (a, g) = drawn(&s, seed);
        accel.extend(a);
        gyro.extend(g);
    }
    let first9 = &accel[..9];
    let rms9 = (first9.iter().map(|v| v * v).sum::<f64>() / 9.0).sqrt() / UG;
    let n = accel.len() as f64;
    // χ²_n / n ≈ N(1, 2/n); 3.9σ two-sided ≈ 1e-4.
    let var_bound = 3.9 * (2.0 / n).sqrt();
    // Kolmogorov–Smirnov: P(D > 2.0/√n) ≈ 6.7e-4 (asymptotic).
    let ks_bound = 2.0 / n.sqrt();
    for (name, x, sigma) in [("accelerometer", &accel, sa), ("gyro", &gyro, sg)] {
        let (v, m, ks) = stats(x, sigma);
        eprintln!(
            "{name}: {} draws over {SEEDS} seeds: RMS/σ {:.4} (bound ±{:.4} on its square), mean {m:.2} σ of the mean, KS {ks:.4} (bound {ks_bound:.4})",
            x.len(),
            v.sqrt(),
            var_bound
        );
        assert!((v - 1.0).abs() < var_bound, "{name}: variance ratio {v}");
        assert!(m.abs() < 3.9, "{name}: mean {m} σ of the mean");
        assert!(ks < ks_bound, "{name}: KS distance {ks}");
    }
    // Seeds 1-3: an RMS of 142 µg of nine N(0, (100 µg)²) draws has
    // P(χ²_9 ≥ 9 · 1.42²) ≈ 0.03, chance rather than a defect.
    eprintln!("seeds 1-3: RMS of the nine accelerometer draws {rms9:.1} µg");
}
