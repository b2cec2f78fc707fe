//! Issue acceptance: error-free IMU at 200 Hz, pure inertial from the truth,
//! must integrate back to the truth (position < 0.1 m, attitude < 0.01′) —
//! through a g→G switch, straight over each pole, and at low latitude in g.

use msgs::TruthRecord;
use msgs::navlog::{Record, read_all};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use polarnav::earth;
use polarnav::frames;
use polarnav::mech::FrameKind;
use polarnav::navigator::{Navigator, NavigatorConfig};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

const ARCMIN: f64 = std::f64::consts::PI / 180.0 / 60.0;

struct Outcome {
    max_horizontal_m: f64,
    max_vertical_m: f64,
    max_attitude_arcmin: f64,
    switches: Vec<(f64, FrameKind)>,
    frames_seen: Vec<FrameKind>,
    min_abs_lat_deg: f64,
    max_abs_lat_deg: f64,
}

fn quat(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

fn fly(text: &str) -> Outcome {
    let s = Scenario::parse(text, "test scenario").expect("scenario");
    let mut buf = Vec::new();
    simulate(
        &s,
        text,
        SimOptions {
            perfect: true,
            ..Default::default()
        },
        &mut buf,
    )
    .expect("simulate");
    let (records, report) = read_all(&buf);
    assert!(report.is_clean());
    let Some(Record::Init(init)) = records.iter().find(|r| matches!(r, Record::Init(_))) else {
        panic!("no init")
    };
    let mut nav = Navigator::new(init, &NavigatorConfig::default());
    let mut o = Outcome {
        max_horizontal_m: 0.0,
        max_vertical_m: 0.0,
        max_attitude_arcmin: 0.0,
        switches: Vec::new(),
        frames_seen: vec![nav.state().kind()],
        min_abs_lat_deg: 90.0,
        max_abs_lat_deg: 0.0,
    };
    let compare = |nav: &Navigator, t: &TruthRecord, o: &mut Outcome| {
        assert_eq!(nav.t_ns(), t.t_ns);
        let ff = nav.state().frame_free();
        let r = Vector3::from(t.r_e_m);
        let g = earth::ecef_to_geodetic(&r);
        let d = frames::c_e_g(g.lat_rad, g.lon_rad) * (ff.r_e - r);
        o.max_horizontal_m = o.max_horizontal_m.max(d.xy().norm());
        o.max_vertical_m = o.max_vertical_m.max(d.z.abs());
        o.max_attitude_arcmin = o
            .max_attitude_arcmin
            .max(ff.q_b_e.angle_to(&quat(&t.q_b_e)) / ARCMIN);
        o.min_abs_lat_deg = o.min_abs_lat_deg.min(g.lat_rad.to_degrees().abs());
        o.max_abs_lat_deg = o.max_abs_lat_deg.max(g.lat_rad.to_degrees().abs());
    };
    for rec in &records {
        match rec {
            Record::Imu(s) => {
                let out = nav.on_imu(s).expect("valid sample");
                if let Some(sw) = out.switch {
                    o.switches.push((sw.t_ns as f64 * 1e-9, sw.to));
                    o.frames_seen.push(sw.to);
                }
            }
            Record::Truth(t) if t.t_ns > 0 => compare(&nav, t, &mut o),
            _ => {}
        }
    }
    o
}

fn assert_accurate(name: &str, o: &Outcome) {
    eprintln!(
        "{name}: max horizontal {:.3e} m, vertical {:.3e} m, attitude {:.3e}′; switches {:?}",
        o.max_horizontal_m, o.max_vertical_m, o.max_attitude_arcmin, o.switches
    );
    assert!(
        o.max_horizontal_m < 0.1,
        "{name}: horizontal {} m",
        o.max_horizontal_m
    );
    assert!(
        o.max_vertical_m < 0.1,
        "{name}: vertical {} m",
        o.max_vertical_m
    );
    assert!(
        o.max_attitude_arcmin < 0.01,
        "{name}: attitude {}′",
        o.max_attitude_arcmin
    );
}

#[test]
fn climbing_through_70n_switches_g_to_grid_and_stays_on_truth() {
    let o = fly(r#"
name = "climb-through-70N"
[start]
lat_deg = 67.6
lon_deg = -150.0
h_m = 12000.0
heading_deg = 5.0
speed_mps = 250.0
[[segment]]
kind = "cruise"
duration_s = 300.0
[[segment]]
kind = "climb"
duration_s = 400.0
altitude_change_m = 6000.0
[[segment]]
kind = "turn"
duration_s = 60.0
heading_change_deg = -20.0
[[segment]]
kind = "cruise"
duration_s = 700.0
[[segment]]
kind = "turn"
duration_s = 40.0
heading_change_deg = 15.0
[[segment]]
kind = "cruise"
duration_s = 300.0
"#);
    assert_eq!(
        o.frames_seen,
        vec![FrameKind::Geographic, FrameKind::Grid],
        "{:?}",
        o.switches
    );
    assert!(
        o.switches[0].0 > 100.0 && o.switches[0].0 < 1700.0,
        "switch mid-flight: {:?}",
        o.switches
    );
    assert!(o.max_abs_lat_deg > 70.5);
    assert_accurate("g→G at 70° N", &o);
}

const ACROSS_POLE: &str = r#"
name = "across-the-pole"
[start]
lat_deg = LAT
lon_deg = 40.0
h_m = 18000.0
heading_deg = HEADING
speed_mps = 250.0
[[segment]]
kind = "cruise"
duration_s = 1800.0
"#;

#[test]
fn straight_across_the_north_pole_stays_on_truth() {
    let o = fly(&ACROSS_POLE.replace("LAT", "88.0").replace("HEADING", "0.0"));
    // Passes within metres of the exact pole.
    assert!(
        o.max_abs_lat_deg > 89.9999,
        "closest approach {}",
        o.max_abs_lat_deg
    );
    assert_eq!(o.frames_seen, vec![FrameKind::Grid]);
    assert_accurate("North Pole", &o);
}

#[test]
fn straight_across_the_south_pole_stays_on_truth() {
    let o = fly(&ACROSS_POLE
        .replace("LAT", "-88.0")
        .replace("HEADING", "180.0"));
    assert!(
        o.max_abs_lat_deg > 89.9999,
        "closest approach {}",
        o.max_abs_lat_deg
    );
    assert_eq!(o.frames_seen, vec![FrameKind::Grid]);
    assert_accurate("South Pole", &o);
}

#[test]
fn lowlat_vehicle_in_g_stays_on_truth() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/scenarios/lowlat-vehicle.toml");
    let text = std::fs::read_to_string(path).expect("shipped scenario");
    // The scenario is 1200 s; the acceptance asks for 1800 s, so cruise 600 s more.
    let text = format!("{text}\n[[segment]]\nkind = \"cruise\"\nduration_s = 600.0\n");
    let o = fly(&text);
    assert_eq!(o.frames_seen, vec![FrameKind::Geographic]);
    assert!(o.max_abs_lat_deg < 33.0);
    assert_accurate("lowlat-vehicle", &o);
}
