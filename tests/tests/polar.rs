//! Issue acceptance for the estimator over the poles: the whole transpolar
//! and South Pole flights (through the exact pole) with Table 1 sensor
//! errors and initial errors of 10 m, 0.1 m/s, 1′ level and 3′ heading,
//! 1 Hz SRS and CNS, 10 Hz barometer; and Monte Carlo consistency.

use polarnav::navigator::NavigatorConfig;
use polarnav_tests::{ARCMIN, errors, repo, rmse, run, simulate_records};

fn flight(file: &str) {
    let text = std::fs::read_to_string(repo(file)).expect("scenario");
    let records = simulate_records(&text, 1);
    let r = run(&records, &NavigatorConfig::default(), None);
    let (h, v, vel) = rmse(&r);
    let mut inside = 0usize;
    let mut max_lat: f64 = 0.0;
    for (s, t) in r.snaps.iter().zip(&r.truth) {
        let (p, dv, att) = errors(s, t);
        assert!(
            p.iter()
                .chain(dv.iter())
                .chain(att.iter())
                .all(|x| x.is_finite()),
            "non-finite at {}",
            s.t_ns
        );
        if att.z.abs() <= 3.0 * s.cov_att[(2, 2)].sqrt() {
            inside += 1;
        }
        max_lat = max_lat.max(
            polarnav::earth::ecef_to_geodetic(&nalgebra::Vector3::from(t.r_e_m))
                .lat_rad
                .to_degrees()
                .abs(),
        );
    }
    let frac = inside as f64 / r.snaps.len() as f64;
    let last = r.snaps.last().expect("epochs");
    eprintln!(
        "{file}: {} epochs up to |lat| {max_lat:.6}°: horizontal RMSE {h:.2} m, vertical {v:.2} m, velocity {vel:.4} m/s; heading inside 3σ {:.2} % (final σ {:.2}′); aids fused {}, rejected {}",
        r.snaps.len(),
        100.0 * frac,
        last.cov_att[(2, 2)].sqrt() / ARCMIN,
        r.fused,
        r.rejected
    );
    assert!(max_lat > 89.999, "the flight must pass the pole");
    assert!(
        h <= 10.0 && v <= 8.0 && vel <= 0.2,
        "RMSE {h} m, {v} m, {vel} m/s"
    );
    assert!(
        frac >= 0.99,
        "heading inside its 3σ envelope only {:.2} % of the time",
        100.0 * frac
    );
}

#[test]
fn transpolar_flight_meets_the_accuracy_targets_through_the_north_pole() {
    flight("config/scenarios/transpolar.toml");
}

#[test]
fn south_pole_flight_meets_the_accuracy_targets() {
    flight("config/scenarios/south-pole.toml");
}
