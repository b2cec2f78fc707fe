//! Import/export acceptance: a simulated flight exported to KF-GINS and
//! imported back navigates identically; the real PSINS RLG record imports
//! completely and its mean rates are those the dataset README states.

use std::path::{Path, PathBuf};

use msgs::ImuSample;
use msgs::navlog::{Record, read_all};
use nalgebra::Vector3;
use polarnav::navigator::{Navigator, NavigatorConfig};
use polarnav_eval::logfile;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};
use sensor_replay::interop::{self, AidSynthesis};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Navigates a log pure-inertially; returns (t_ns, ECEF position, attitude) at every IMU sample.
fn navigate(records: &[Record]) -> Vec<(u64, Vector3<f64>, nalgebra::UnitQuaternion<f64>)> {
    let init = msgs::navlog::first_init(records).expect("init");
    let mut nav = Navigator::new(&init, &NavigatorConfig::default());
    let mut out = Vec::new();
    for r in records {
        if let Record::Imu(s) = r {
            nav.on_imu(s).expect("valid");
            let ff = nav.state().frame_free();
            out.push((s.t_ns, ff.r_e, ff.q_b_e));
        }
    }
    out
}

#[test]
fn kfgins_export_then_import_navigates_identically() {
    let dir = temp_dir("kfgins");
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenarios/lowlat-vehicle.toml");
    let text = std::fs::read_to_string(path).expect("scenario");
    // The first 300 s (Table 2 errors, with noise) keep the test quick.
    let text = text.replace("duration_s = 120.0", "duration_s = 60.0");
    let mut s = Scenario::parse(&text, "lowlat").expect("scenario");
    s.segments.truncate(4);
    // Importers start from the first truth record; start the simulated run there too
    // (sensor errors stay: Table 2 biases and noise).
    s.init_error = Default::default();
    let log = dir.join("sim.navlog");
    simulate(
        &s,
        &text,
        SimOptions {
            seed: 7,
            ..Default::default()
        },
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");
    let sim = logfile::load(&log).expect("load");
    interop::export_kfgins(&dir.join("kf"), &sim.imu, &sim.truth).expect("export");
    let imported = dir.join("imported.navlog");
    let sum = interop::import_kfgins(
        &dir.join("kf/imu.txt"),
        &dir.join("kf/truth.nav"),
        &AidSynthesis::default(),
        std::fs::File::create(&imported).expect("create"),
    )
    .expect("import");
    assert!(sum.skipped.lines.is_empty(), "{:?}", sum.skipped);
    assert_eq!(sum.imu, sim.imu.len() as u64);

    let a_bytes = std::fs::read(&log).expect("read");
    let b_bytes = std::fs::read(&imported).expect("read");
    let (a, _) = read_all(&a_bytes);
    let (b, _) = read_all(&b_bytes);
    // The increments survive the text round trip bit for bit.
    let imu = |r: &[Record]| -> Vec<ImuSample> {
        r.iter()
            .filter_map(|x| {
                if let Record::Imu(s) = x {
                    Some(*s)
                } else {
                    None
                }
            })
            .collect()
    };
    let (ia, ib) = (imu(&a), imu(&b));
    for (x, y) in ia.iter().zip(&ib) {
        assert_eq!(x.t_ns, y.t_ns);
        // Bit-for-bit: the text form is the shortest round-trip representation.
        assert_eq!(
            x.d_theta_rad.map(f64::to_bits),
            y.d_theta_rad.map(f64::to_bits)
        );
        assert_eq!(x.d_v_mps.map(f64::to_bits), y.d_v_mps.map(f64::to_bits));
        assert!((x.dt_s - y.dt_s).abs() < 1e-12);
    }
    let na = navigate(&a);
    let nb = navigate(&b);
    assert_eq!(na.len(), nb.len());
    let mut worst_pos: f64 = 0.0;
    let mut worst_att: f64 = 0.0;
    for ((ta, ra, qa), (tb, rb, qb)) in na.iter().zip(&nb) {
        assert_eq!(ta, tb);
        worst_pos = worst_pos.max((ra - rb).norm());
        worst_att = worst_att.max(qa.angle_to(qb));
    }
    eprintln!(
        "KF-GINS round trip: max position difference {worst_pos:.3e} m, attitude {worst_att:.3e} rad"
    );
    // Only the text rounding of the initial truth (~1e-9 m, ~1e-15 rad) separates the two runs.
    assert!(worst_pos < 1e-5, "{worst_pos} m");
    assert!(worst_att < 1e-9, "{worst_att} rad");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn kfgins_import_skips_and_names_bad_lines_and_keeps_the_rest() {
    let dir = temp_dir("kfgins-bad");
    let imu = dir.join("imu.txt");
    let truth = dir.join("truth.nav");
    std::fs::write(
        &imu,
        "0.000 0 0 0 0 0 0\n0.005 1e-6 0 0 0 0 0.049\n0.010 nan 0 0 0 0 0.049\n0.015 1e-6 0 0 0\n0.020 1e-6 0 0 0 0 0.049\n",
    )
    .expect("write");
    std::fs::write(
        &truth,
        "0 0.0 45.0 10.0 100.0 0 0 0 0 0 0\n0 0.010 45.0 10.0 100.0 0 0 0 0 0 x\n",
    )
    .expect("write");
    let out = dir.join("out.navlog");
    let sum = interop::import_kfgins(
        &imu,
        &truth,
        &AidSynthesis::default(),
        std::fs::File::create(&out).expect("create"),
    )
    .expect("import");
    let lines: Vec<usize> = sum.skipped.lines.iter().map(|(_, l, _)| *l).collect();
    assert_eq!(sum.skipped.lines.len(), 3, "{:?}", sum.skipped.lines);
    assert!(lines.contains(&3) && lines.contains(&4), "{lines:?}");
    assert_eq!(sum.imu, 2);
    // A file that is not of the format at all is an error, not an empty log.
    std::fs::write(&imu, "hello\nworld\n").expect("write");
    assert!(
        interop::import_kfgins(&imu, &truth, &AidSynthesis::default(), std::io::sink()).is_err()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The PSINS laser-gyro record of the project's shared data (`../shared`
/// beside this checkout); a test without it says so.
fn lasergyro() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/datasets/psins-lasergyro/lasergyro.imu");
    let shared = "the tests read the project's shared data from ../shared, beside this checkout \
                  (README, Quick start): clone or link it there";
    assert!(p.exists(), "{} is missing: {shared}", p.display());
    p
}

#[test]
fn psins_rlg_record_imports_completely_with_the_documented_mean_rates() {
    let file = lasergyro();
    let mut buf = Vec::new();
    let aids = AidSynthesis {
        cns_sigma_m: Some(20.0),
        baro_sigma_m: Some(10.0),
        srs_sigma_mps: Some(0.5),
        seed: 3,
        preset: None,
    };
    let sum = interop::import_psins(&file, &aids, &mut buf).expect("import");
    assert_eq!(sum.imu, 184_718);
    assert!(sum.skipped.lines.is_empty());
    assert!(sum.cns > 1800 && sum.baro > 1800 && sum.srs > 1800);
    let (records, report) = read_all(&buf);
    assert!(report.is_clean());
    let (mut w, mut f, mut t) = (Vector3::zeros(), Vector3::zeros(), 0.0);
    for r in &records {
        if let Record::Imu(s) = r {
            w += Vector3::from(s.d_theta_rad);
            f += Vector3::from(s.d_v_mps);
            t += s.dt_s;
        }
    }
    let dph = (w / t).map(|x| x.to_degrees() * 3600.0);
    let acc = f / t;
    eprintln!("PSINS mean rate {dph:?} deg/h, mean specific force {acc:?} m/s²");
    // README: ≈ (−12.27, +0.44, +8.36) deg/h and (−0.061, +0.159, 9.794) m/s².
    for (got, want) in dph.iter().zip([-12.27, 0.44, 8.36]) {
        assert!((got - want).abs() < 0.01, "{got} vs {want}");
    }
    for (got, want) in acc.iter().zip([-0.061, 0.159, 9.794]) {
        assert!((got - want).abs() < 0.001, "{got} vs {want}");
    }
}

/// `--preset` on an import: the header names the grade and `batch`'s
/// effective settings take its noise model from it.
#[test]
fn an_import_with_a_preset_carries_it_to_batch() {
    let file = lasergyro();
    let mut buf = Vec::new();
    let aids = AidSynthesis {
        cns_sigma_m: None,
        baro_sigma_m: None,
        srs_sigma_mps: None,
        seed: 3,
        preset: Some(polarnav_config::SensorGrade::Tactical),
    };
    interop::import_psins(&file, &aids, &mut buf).expect("import");
    let (records, _) = read_all(&buf);
    let meta = records
        .iter()
        .find_map(|r| match r {
            Record::Header(h) => Some(h.metadata.clone()),
            _ => None,
        })
        .expect("header");
    assert!(meta.contains("# imported from PSINS"), "{meta}");
    let e = polarnav_config::effective(
        &polarnav_config::ConfigFile::defaults(),
        Some(&meta),
        &polarnav_config::CliOverrides::default(),
    )
    .expect("effective");
    assert_eq!(
        e.config.filter,
        polarnav_config::SensorGrade::Tactical.apply(&Default::default())
    );
    assert_eq!(
        e.source("filter.arw_dpsh"),
        Some(&polarnav_config::Source::Header)
    );
}
