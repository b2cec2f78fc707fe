//! Filter consistency by Monte Carlo: 30 seeds of a 900 s flight through the
//! North Pole (Table 1 sensor errors drawn per seed, initial errors drawn from
//! the init record's σ). The average NEES of position, velocity and attitude
//! (3 degrees of freedom each) over the 30 runs must lie in the 95 % χ² band
//! [χ²₀.₀₂₅(90)/30, χ²₀.₉₇₅(90)/30] = [2.188, 3.938].

use polarnav::navigator::NavigatorConfig;
use polarnav_tests::{Run, errors, nees, run, simulate_records};

const WINDOW: &str = r#"
name = "pole-window"
description = "900 s through the North Pole for Monte Carlo consistency"
[start]
lat_deg = 89.0
lon_deg = 40.0
h_m = 18000.0
heading_deg = 0.0
speed_mps = 250.0
[imu]
rate_hz = 200.0
gyro_bias_dph = 0.01
accel_bias_ug = 100.0
arw_dpsh = 0.001
vrw_ug_psqhz = 10.0
[truth]
rate_hz = 1.0
[srs]
rate_hz = 1.0
sigma_mps = 0.5
[cns]
rate_hz = 1.0
sigma_m = 20.0
[baro]
rate_hz = 10.0
sigma_m = 10.0
[init_error]
pos_h_m = 10.0
pos_v_m = 10.0
vel_h_mps = 0.1
vel_v_mps = 0.1
tilt_arcmin = 1.0
heading_arcmin = 3.0
[[segment]]
kind = "cruise"
duration_s = 900.0
"#;

const RUNS: u64 = 30;
const LO: f64 = 65.647 / 30.0;
const HI: f64 = 118.136 / 30.0;

#[test]
fn thirty_seed_average_nees_is_inside_the_95_percent_chi2_band() {
    let per_seed: Vec<Vec<[f64; 3]>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2u64)
            .map(|k| {
                scope.spawn(move || {
                    (0..RUNS)
                        .filter(|s| s % 2 == k)
                        .map(|seed| {
                            nees(&run(
                                &simulate_records(WINDOW, 100 + seed),
                                &NavigatorConfig::default(),
                                None,
                            ))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("thread"))
            .collect()
    });
    assert_eq!(per_seed.len() as u64, RUNS);
    let epochs = per_seed[0].len();
    let names = ["position", "velocity", "attitude"];
    for (i, name) in names.iter().enumerate() {
        let anees: Vec<f64> = (0..epochs)
            .map(|k| per_seed.iter().map(|r| r[k][i]).sum::<f64>() / RUNS as f64)
            .collect();
        let mean = anees.iter().sum::<f64>() / epochs as f64;
        let inside = anees.iter().filter(|a| (LO..=HI).contains(*a)).count() as f64 / epochs as f64;
        eprintln!(
            "{name}: average NEES {mean:.3} (band [{LO:.3}, {HI:.3}], ideal 3); epochs with ANEES inside the band {:.1} %",
            100.0 * inside
        );
        assert!(
            (LO..=HI).contains(&mean),
            "{name} average NEES {mean} outside [{LO}, {HI}]"
        );
    }
}

/// The same pole window flown with a tactical-grade IMU whose biases are
/// Gauss–Markov processes (the tactical preset's σ and τ, no constant
/// part), 300 s at 100 Hz, the filter given the tactical preset (issue 12).
fn gm_window() -> String {
    let v: std::collections::BTreeMap<_, _> = polarnav::settings::SensorGrade::Tactical
        .values()
        .into_iter()
        .collect();
    WINDOW
        .replace(
            "[imu]\nrate_hz = 200.0\ngyro_bias_dph = 0.01\naccel_bias_ug = 100.0\narw_dpsh = 0.001\nvrw_ug_psqhz = 10.0\n",
            &format!(
                "[imu]\nrate_hz = 100.0\narw_dpsh = {}\nvrw_ug_psqhz = {}\ngm_gyro_sigma_dph = {}\ngm_gyro_tau_s = {}\ngm_accel_sigma_ug = {}\ngm_accel_tau_s = {}\n",
                v["arw_dpsh"],
                v["vrw_ug_psqhz"],
                v["gyro_bias_instability_dph"],
                v["gyro_bias_tau_s"],
                v["accel_bias_instability_ug"],
                v["accel_bias_tau_s"]
            ),
        )
        .replace("duration_s = 900.0", "duration_s = 300.0")
}

/// 30 seeds with Gauss–Markov truth biases and the matching preset: the
/// average NEES of position, velocity and attitude inside the 95 % band,
/// and the RMS tilt error at most 1.2× the filter's own RMS tilt σ (the
/// covariance analysis of the same model: P of the filter given the
/// truth's noise model, which is what a covariance analysis propagates).
#[test]
fn gauss_markov_biases_with_the_matching_preset_are_consistent() {
    let text = gm_window();
    assert!(text.contains("gm_gyro_sigma_dph"), "scenario not rewritten");
    let cfg = NavigatorConfig {
        filter: polarnav::settings::SensorGrade::Tactical.apply(&Default::default()),
        ..Default::default()
    };
    let runs: Vec<Run> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2u64)
            .map(|k| {
                let (text, cfg) = (&text, &cfg);
                scope.spawn(move || {
                    (0..RUNS)
                        .filter(|s| s % 2 == k)
                        .map(|seed| run(&simulate_records(text, 500 + seed), cfg, None))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("thread"))
            .collect()
    });
    let per_seed: Vec<Vec<[f64; 3]>> = runs.iter().map(nees).collect();
    let epochs = per_seed[0].len();
    for (i, name) in ["position", "velocity", "attitude"].iter().enumerate() {
        let mean = (0..epochs)
            .map(|k| per_seed.iter().map(|r| r[k][i]).sum::<f64>() / RUNS as f64)
            .sum::<f64>()
            / epochs as f64;
        eprintln!(
            "GM biases, tactical preset: {name} average NEES {mean:.3} (band [{LO:.3}, {HI:.3}])"
        );
        assert!(
            (LO..=HI).contains(&mean),
            "{name} average NEES {mean} outside [{LO}, {HI}]"
        );
    }
    let (mut e2, mut s2) = (0.0, 0.0);
    for r in &runs {
        for (s, t) in r.snaps.iter().zip(&r.truth) {
            let (_, _, a) = errors(s, t);
            e2 += a.x * a.x + a.y * a.y;
            s2 += s.cov_att[(0, 0)] + s.cov_att[(1, 1)];
        }
    }
    let ratio = (e2 / s2).sqrt();
    eprintln!("GM biases, tactical preset: RMS tilt error / RMS tilt σ = {ratio:.3} (bound 1.2)");
    assert!(ratio <= 1.2, "tilt error {ratio}× the covariance limit");
}

/// Issue 13: the pole window with the star tracker on (1 Hz, 5″ across,
/// 40″ about the boresight), 300 s, 30 seeds: the average NEES of
/// attitude (and of position and velocity) inside the 95 % band. The star
/// tracker is the most precise aid (attitude σ falls from arcminutes to
/// arcseconds within a minute), so a wrong R or H shows here first.
#[test]
fn thirty_seed_average_nees_with_the_star_tracker_is_inside_the_95_percent_chi2_band() {
    let text = format!(
        "{}\n[star]\nrate_hz = 1.0\nsigma_arcsec = 5.0\nboresight_sigma_arcsec = 40.0\n",
        WINDOW.replace("duration_s = 900.0", "duration_s = 300.0")
    );
    let per_seed: Vec<Vec<[f64; 3]>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..2u64)
            .map(|k| {
                let text = &text;
                scope.spawn(move || {
                    (0..RUNS)
                        .filter(|s| s % 2 == k)
                        .map(|seed| {
                            let records = simulate_records(text, 700 + seed);
                            assert!(
                                records
                                    .iter()
                                    .any(|r| matches!(r, msgs::navlog::Record::Aid(a) if a.kind() == msgs::AidKind::Star))
                            );
                            nees(&run(&records, &NavigatorConfig::default(), None))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("thread"))
            .collect()
    });
    let epochs = per_seed[0].len();
    for (i, name) in ["position", "velocity", "attitude"].iter().enumerate() {
        let anees: Vec<f64> = (0..epochs)
            .map(|k| per_seed.iter().map(|r| r[k][i]).sum::<f64>() / RUNS as f64)
            .collect();
        let mean = anees.iter().sum::<f64>() / epochs as f64;
        let inside = anees.iter().filter(|a| (LO..=HI).contains(*a)).count() as f64 / epochs as f64;
        eprintln!(
            "star tracker on: {name} average NEES {mean:.3} (band [{LO:.3}, {HI:.3}], ideal 3); epochs with ANEES inside the band {:.1} %",
            100.0 * inside
        );
        assert!(
            (LO..=HI).contains(&mean),
            "star tracker on: {name} average NEES {mean} outside [{LO}, {HI}]"
        );
    }
}
