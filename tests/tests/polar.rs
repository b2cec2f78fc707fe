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

/// The quick start's flight shows what polarnav is for: it enters the grid
/// frame northbound at the 70° switch latitude, crosses the pole, and
/// returns to geographic southbound at 69.5° — one switch each way — and
/// meets the same accuracy targets as the flights above.
#[test]
fn the_quick_start_flight_switches_both_ways_and_crosses_the_pole() {
    use polarnav::mech::FrameKind;
    use polarnav::session::{Event, SessionSettings, navigate};
    let file = "config/scenarios/polar-crossing.toml";
    flight(file);
    let text = std::fs::read_to_string(repo(file)).expect("scenario");
    let records = simulate_records(&text, 1);
    let (out, status) = navigate(&records, SessionSettings::default());
    let switches: Vec<_> = out
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Switch(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(switches.len(), 2, "{switches:?}");
    let (north, south) = (switches[0], switches[1]);
    assert_eq!(
        (north.from, north.to),
        (FrameKind::Geographic, FrameKind::Grid)
    );
    assert_eq!(
        (south.from, south.to),
        (FrameKind::Grid, FrameKind::Geographic)
    );
    // At the thresholds, to the 250 m/s × 10 ms a sample moves (~2e-5°).
    assert!(
        (north.lat_rad.to_degrees() - 70.0).abs() < 1e-4,
        "{north:?}"
    );
    assert!(
        (south.lat_rad.to_degrees() - 69.5).abs() < 1e-4,
        "{south:?}"
    );
    // The pole is crossed in between, in the grid frame.
    let pole_t_ns = records
        .iter()
        .filter_map(|r| match r {
            msgs::navlog::Record::Truth(t) => Some(t),
            _ => None,
        })
        .max_by(|a, b| a.r_e_m[2].total_cmp(&b.r_e_m[2]))
        .expect("truth")
        .t_ns;
    assert!(north.t_ns < pole_t_ns && pole_t_ns < south.t_ns);
    assert_eq!(status.switch_count, 2);
    // The flight ends back south of the switch latitude.
    let last = out.solutions.last().expect("solutions");
    assert!(
        last.lat_rad.to_degrees() < 69.0 && last.frame == 0,
        "{}",
        last.lat_rad.to_degrees()
    );
}
