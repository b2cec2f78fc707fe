//! The nav-daemon command-line contract: exit codes, messages that name the
//! file and key, and a damaged log replayed up to every intact record.

use std::path::{Path, PathBuf};
use std::process::Command;

use msgs::navlog::{Header, NavlogWriter, Record};
use msgs::{ImuSample, InitState};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic};
use polarnav::frames;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_nav-daemon"))
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// A stationary, level vehicle at 45° N: init record and exact increments.
fn stationary_log(n: u64, with_init: bool) -> Vec<u8> {
    let geo = Geodetic::from_deg(45.0, 7.0, 300.0);
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let dt = 0.01;
    let w_b = c_e_g * earth::omega_ie_e();
    let f_b = Vector3::new(0.0, 0.0, earth::normal_gravity(geo.lat_rad, geo.h_m));
    let q = UnitQuaternion::from_matrix(&c_e_g.transpose()).into_inner();
    let mut w =
        NavlogWriter::new(Vec::new(), Header::new("test", "stationary", 0, "")).expect("header");
    if with_init {
        w.write(&Record::Init(InitState {
            r_e_m: earth::geodetic_to_ecef(&geo).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            sigma_pos_h_m: 1.0,
            ..Default::default()
        }))
        .expect("init");
    }
    for k in 1..=n {
        w.write(&Record::Imu(ImuSample {
            t_ns: k * 10_000_000,
            seq: k - 1,
            dt_s: dt,
            d_theta_rad: (w_b * dt).into(),
            d_v_mps: (f_b * dt).into(),
        }))
        .expect("imu");
    }
    w.finish().expect("finish")
}

fn run_batch(dir: &Path, log: &[u8], extra: &[&str]) -> (i32, String, Vec<String>) {
    let log_path = dir.join("in.navlog");
    let out = dir.join("out.csv");
    std::fs::write(&log_path, log).expect("write log");
    let o = bin()
        .args(["batch", "--log"])
        .arg(&log_path)
        .arg("--out")
        .arg(&out)
        .args(extra)
        .output()
        .expect("run nav-daemon");
    let rows = std::fs::read_to_string(&out)
        .unwrap_or_default()
        .lines()
        .map(str::to_owned)
        .collect();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stderr).into_owned(),
        rows,
    )
}

#[test]
fn batch_writes_the_design_header_and_one_row_per_imu_sample() {
    let dir = temp_dir("rows");
    let (code, err, rows) = run_batch(&dir, &stationary_log(500, true), &["--aids", "none"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows[0], polarnav::solution_csv::header());
    assert_eq!(rows.len(), 501);
    // Stationary and exact: still at 45° N after 5 s.
    let parsed = polarnav::solution_csv::parse(&rows.join("\n"), "out.csv").expect("rows");
    let last = parsed[499];
    assert_eq!(last.frame, 'g');
    assert!((last.lat_deg - 45.0).abs() < 1e-9);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn truncated_log_is_navigated_up_to_the_last_intact_record_and_the_damage_reported() {
    let dir = temp_dir("trunc");
    let full = stationary_log(300, true);
    // Cut inside the last record and flip a bit in the middle of the file.
    let mut damaged = full[..full.len() - 7].to_vec();
    let mid = damaged.len() / 2;
    damaged[mid] ^= 0x10;
    let (code, err, rows) = run_batch(&dir, &damaged, &[]);
    assert_eq!(code, 0, "{err}");
    // 300 samples: one lost to truncation, one or two to the flipped byte.
    let n = rows.len() - 1;
    assert!((297..=298).contains(&n), "{n} rows");
    assert!(err.contains("skipped"), "damage not reported: {err}");
    assert!(err.contains("truncated 1"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn log_without_init_starts_from_the_configured_init() {
    let dir = temp_dir("cfginit");
    let cfg = dir.join("nav.toml");
    std::fs::write(
        &cfg,
        "[init]\nlat_deg = 45.0\nlon_deg = 7.0\nh_m = 300.0\nheading_deg = 0.0\nsigma_pos_h_m = 5.0\nsigma_pos_v_m = 5.0\nsigma_vel_mps = 0.05\nsigma_tilt_arcmin = 1.0\nsigma_heading_arcmin = 10.0\n",
    )
    .expect("write");
    let cfg_arg = cfg.display().to_string();
    let (code, err, rows) = run_batch(
        &dir,
        &stationary_log(100, false),
        &["--config", &cfg_arg, "--aids", "none"],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows.len(), 101);
    assert!(err.contains("initializing from the configuration"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn log_without_init_is_refused_with_exit_2() {
    let dir = temp_dir("noinit");
    let (code, err, _) = run_batch(&dir, &stationary_log(10, false), &[]);
    assert_eq!(code, 2);
    assert!(
        err.contains("no init record") && err.contains("in.navlog"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// One flipped bit in the only init record: batch still exits 2, and the
/// message says the init record was there but damaged, naming the byte
/// offset of its frame (it used to report it as missing).
#[test]
fn a_damaged_init_record_is_named_with_its_offset_and_exits_2() {
    let dir = temp_dir("badinit");
    let clean = stationary_log(10, true);
    // The init record is the second frame: it starts after the header's
    // delimiter and ends at the next one.
    let zeros: Vec<usize> = clean
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == 0)
        .map(|(i, _)| i)
        .collect();
    let (start, end) = (zeros[0] + 1, zeros[1]);
    // A bit in the middle of its values: not a COBS code byte (those are
    // where the payload had zeros), so the frame decodes and only its
    // checksum fails.
    let mut damaged = clean.clone();
    let pos = (start + 16..end - 8)
        .find(|&i| {
            let mut d = clean.clone();
            d[i] ^= 0x08;
            let (_, report) = msgs::navlog::read_all(&d);
            report.checksum == 1
        })
        .expect("a byte whose flip is a checksum mismatch");
    damaged[pos] ^= 0x08;
    let (code, err, _) = run_batch(&dir, &damaged, &[]);
    assert_eq!(code, 2, "{err}");
    let expected = format!("its init record at byte {start} is damaged (checksum mismatch)");
    assert!(
        err.contains("in.navlog") && err.contains(&expected),
        "expected {expected:?} in: {err}"
    );
    // The same log intact navigates.
    let (code, err, _) = run_batch(&dir, &clean, &[]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A 100 Hz log under the built-in `[live] imu_rate_hz = 200`: batch says
/// once that the two disagree, with both rates and the setting to change;
/// with the setting at the stream's rate it says nothing.
#[test]
fn an_imu_stream_off_the_configured_rate_is_said_once() {
    let dir = temp_dir("imurate");
    let log = stationary_log(500, true);
    let (code, err, _) = run_batch(&dir, &log, &["--aids", "none"]);
    assert_eq!(code, 0, "{err}");
    let said = "the IMU stream runs at 100.0 Hz (median interval 10.000 ms of its first 64 \
                samples) but [live] imu_rate_hz = 200 Hz";
    assert_eq!(err.matches(said).count(), 1, "{err}");
    assert!(err.contains("set imu_rate_hz = 100"), "{err}");
    let cfg = dir.join("nav.toml");
    std::fs::write(&cfg, "[live]\nimu_rate_hz = 100\n").expect("config");
    let cfg_arg = cfg.display().to_string();
    let (code, err, _) = run_batch(&dir, &log, &["--config", &cfg_arg, "--aids", "none"]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("the IMU stream runs at"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_options_exit_2_with_a_clear_message() {
    let dir = temp_dir("opts");
    let log = stationary_log(10, true);
    let (code, err, _) = run_batch(&dir, &log, &["--aids", "gps"]);
    assert_eq!(code, 2);
    assert!(err.contains("gps"), "{err}");
    let (code, err, _) = run_batch(&dir, &log, &["--conversion", "magic"]);
    assert_eq!(code, 2);
    assert!(err.contains("--conversion"), "{err}");
    let (code, err, _) = run_batch(&dir, &log, &["--force-switch", "5,2"]);
    assert_eq!(code, 2);
    assert!(err.contains("force_switch_s"), "{err}");
    for every in ["0", "-1", "NaN", "inf", "1e300", "1e-400", "soon"] {
        let (code, err, _) = run_batch(&dir, &log, &["--every", every]);
        assert_eq!(code, 2, "--every {every}: {err}");
        assert!(err.contains("--every"), "--every {every}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn forced_switch_times_switch_the_frame_in_batch() {
    let dir = temp_dir("forced");
    let (code, err, rows) = run_batch(&dir, &stationary_log(400, true), &["--force-switch", "1,3"]);
    assert_eq!(code, 0, "{err}");
    let parsed = polarnav::solution_csv::parse(&rows.join("\n"), "out.csv").expect("rows");
    let frame = |i: usize| parsed[i - 1].frame;
    assert_eq!(frame(50), 'g'); // t = 0.5 s
    assert_eq!(frame(200), 'G'); // t = 2.0 s
    assert_eq!(frame(350), 'g'); // t = 3.5 s
    assert!(err.contains("2 frame switch"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn check_config_accepts_the_shipped_file_and_names_a_bad_key() {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/nav-daemon.toml");
    let o = bin()
        .arg("--check-config")
        .arg(&shipped)
        .output()
        .expect("run");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let dir = temp_dir("cfg");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[frame]\nswitch_enter_deg = \"seventy\"\n").expect("write");
    let o = bin().arg("--check-config").arg(&bad).output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        err.contains("bad.toml") && err.contains("switch_enter_deg"),
        "{err}"
    );
    // A malformed --config is also exit 2 for batch.
    let o = bin()
        .arg("--config")
        .arg(&bad)
        .args(["batch", "--log", "x", "--out", "y"])
        .output()
        .expect("run");
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

/// One prefix rule for the file, `--check-config` and the command line: each
/// refusal is exit 2 and names the file or flag and the key, before any
/// iceoryx2 resource is touched.
#[test]
fn a_bad_prefix_is_refused_alike_from_the_file_and_the_command_line() {
    let dir = temp_dir("prefix");
    let long = "p".repeat(250);
    for (prefix, why) in [
        (long.as_str(), "at most 64"),
        ("a\\u0000b", "'\\0'"),
        ("a b", "' '"),
        ("", "empty"),
    ] {
        let file = dir.join("nav.toml");
        std::fs::write(&file, format!("prefix = \"{prefix}\"\n")).expect("write");
        for args in [vec!["--check-config"], vec!["--config"]] {
            let o = bin()
                .args(&args)
                .arg(&file)
                .env("POLARNAV_IOX_ROOT", dir.join("iox"))
                .output()
                .expect("run");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?} {prefix:?}: {err}");
            assert!(
                err.contains("nav.toml") && err.contains("`prefix`") && err.contains(why),
                "{args:?} {prefix:?}: {err}"
            );
        }
    }
    let good = dir.join("good.toml");
    std::fs::write(&good, "prefix = \"polarnav\"\n").expect("write");
    for bad in ["a b", "x/", long.as_str()] {
        for args in [
            vec!["--config", good.to_str().expect("utf-8"), "--prefix", bad],
            vec![
                "--check-config",
                good.to_str().expect("utf-8"),
                "--prefix",
                bad,
            ],
        ] {
            let o = bin()
                .args(&args)
                .env("POLARNAV_IOX_ROOT", dir.join("iox"))
                .output()
                .expect("run");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert!(
                err.contains("command line --prefix") && err.contains("`prefix`"),
                "{args:?}: {err}"
            );
        }
    }
    assert!(
        !dir.join("iox").exists(),
        "an iceoryx2 root was created before the prefix was checked"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A refused star tracker sample is logged and counted, and batch goes on
/// (the per-stream log limits once had no entry for the fifth stream).
#[test]
fn batch_logs_and_counts_a_refused_star_sample_and_goes_on() {
    let geo = Geodetic::from_deg(45.0, 7.0, 300.0);
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let q_b_e = UnitQuaternion::from_matrix(&c_e_g.transpose());
    let bytes = stationary_log(500, true);
    let (records, _) = msgs::navlog::read_all(&bytes);
    let mut w =
        NavlogWriter::new(Vec::new(), Header::new("test", "stationary", 0, "")).expect("header");
    for r in records.iter().filter(|r| !matches!(r, Record::Header(_))) {
        w.write(r).expect("record");
        if let Record::Imu(s) = r
            && s.t_ns % 1_000_000_000 == 0
            && s.t_ns < 5_000_000_000
        {
            let c_e_i = nalgebra::Rotation3::from_axis_angle(
                &Vector3::z_axis(),
                earth::OMEGA_IE * s.t_ns as f64 * 1e-9,
            );
            let q = (UnitQuaternion::from_rotation_matrix(&c_e_i) * q_b_e).into_inner();
            let mut star = msgs::StarSample {
                t_ns: s.t_ns,
                seq: s.t_ns / 1_000_000_000,
                q_b_i: [q.w, q.i, q.j, q.k],
                boresight_b: [0.0, 0.0, 1.0],
                sigma_cross_arcsec: 5.0,
                sigma_boresight_arcsec: 40.0,
            };
            if s.t_ns == 2_000_000_000 {
                star.q_b_i[0] = f64::NAN;
            }
            w.write(&Record::aid(star)).expect("star");
        }
    }
    let log = w.finish().expect("finish");
    let dir = temp_dir("star");
    let (code, err, rows) = run_batch(&dir, &log, &["--aids", "star"]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(rows.len(), 501);
    assert!(
        err.contains("star sample rejected: non-finite value in star"),
        "{err}"
    );
    assert!(err.contains("aids: 3 fused, 1 rejected"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Settings under which nothing can navigate (or that no flight reaches)
/// are refused by `--check-config` and by the daemon alike: exit 2, and the
/// message names the file, the key and the physical reason. One row per
/// refused setting; NaN and ±Inf are refused for every numeric key.
#[test]
fn settings_that_can_never_navigate_are_refused_with_file_key_and_reason() {
    let dir = temp_dir("never");
    #[rustfmt::skip]
    let cases: &[(&str, &str, &str)] = &[
        // (file text, key, words of the reason)
        ("[filter]\nmax_accel_mps2 = 9.0\n", "filter.max_accel_mps2", "measures gravity"),
        ("[filter]\nmax_accel_mps2 = 1e300\n", "filter.max_accel_mps2", "refuse nothing"),
        ("[filter]\nmax_gyro_rate_dps = 0.004\n", "filter.max_gyro_rate_dps", "Earth's rate"),
        ("[filter]\nmax_gyro_rate_dps = 0.0\n", "filter.max_gyro_rate_dps", "Earth's rate"),
        ("[filter]\nmax_gyro_rate_dps = 1e18\n", "filter.max_gyro_rate_dps", "refuse nothing"),
        ("[filter]\nmax_gyro_rate_dps = nan\n", "filter.max_gyro_rate_dps", "finite"),
        ("[live]\ncheckpoint_period_s = 1e300\n", "live.checkpoint_period_s", "longer than any flight"),
        ("[live]\ncheckpoint_period_s = 1e-12\n", "live.checkpoint_period_s", "every sample"),
        ("[live]\ncheckpoint_period_s = inf\n", "live.checkpoint_period_s", "finite"),
        ("[live]\ncheckpoint_max_age_s = 3600\n", "live.checkpoint_max_age_s", "coasted"),
        ("[live]\ncheckpoint_max_age_s = 0\n", "live.checkpoint_max_age_s", "fastest IMU"),
        ("[live]\nimu_rate_hz = 5\n", "live.imu_rate_hz", "strapdown"),
        ("[live]\nimu_rate_hz = 1e6\n", "live.imu_rate_hz", "1 kHz"),
        ("[live]\nimu_lost_periods = 0\n", "live.imu_lost_periods", "between any"),
        ("[live]\nimu_lost_periods = 4000000000\n", "live.imu_lost_periods", "longest coast"),
        ("[live]\nimu_rate_hz = 10\n", "filter.imu_gap_s", "time jump"),
        ("[filter]\nimu_gap_s = 1e-6\n", "filter.imu_gap_s", "time jump"),
        ("[filter]\nimu_gap_s = 1e300\n", "filter.imu_gap_s", "cannot be bridged"),
        ("[filter]\nimu_max_coast_s = 1e7\n", "filter.imu_max_coast_s", "state is unknown"),
        ("[filter]\ncovariance_interval_s = 1e-12\n", "filter.covariance_interval_s", "resolution"),
        ("[filter]\ncovariance_interval_s = 10\n", "filter.covariance_interval_s", "once a second"),
        ("[filter]\ncoast_accel_mps2 = -1\n", "filter.coast_accel_mps2", "negative"),
        ("[filter]\ncoast_accel_mps2 = 1e18\n", "filter.coast_accel_mps2", "10 g"),
        ("[filter]\ncoast_rate_dps = 1e18\n", "filter.coast_rate_dps", "full circle"),
        ("[filter]\ngyro_bias_dph = 1e-300\n", "filter.gyro_bias_dph", "positive definite"),
        ("[filter]\naccel_bias_ug = 0\n", "filter.accel_bias_ug", "positive definite"),
        ("[filter]\narw_dpsh = -0.001\n", "filter.arw_dpsh", "noise-free"),
        ("[filter]\nvrw_ug_psqhz = 1e300\n", "filter.vrw_ug_psqhz", "overflow"),
        ("[filter]\ngyro_bias_tau_s = 0.5\n", "filter.gyro_bias_tau_s", "white noise"),
        ("[filter]\naccel_bias_tau_s = 1e300\n", "filter.accel_bias_tau_s", "constant over any flight"),
        ("[aids]\nsrs_gate = 1e-300\n", "aids.srs_gate", "good samples"),
        ("[aids]\nbaro_gate = 0.5\n", "aids.baro_gate", "good samples"),
        ("[aids]\ncns_gate = 1e300\n", "aids.cns_gate", "refuses nothing"),
        ("[aids]\nstar_gate = inf\n", "aids.star_gate", "finite"),
        ("[aids]\ncns_timeout_s = 1e300\n", "aids.cns_timeout_s", "longer than any flight"),
        ("[aids]\nbaro_timeout_s = 0.001\n", "aids.baro_timeout_s", "stale between"),
        ("[aids]\nmax_latency_s = 1e-9\n", "aids.max_latency_s", "late"),
        ("[aids]\nmax_latency_s = 30\n", "aids.max_latency_s", "1 s"),
        ("[live]\nimu_rate_hz = 1000\n[aids]\nmax_latency_s = 0.9\n", "aids.max_latency_s", "state history"),
        ("[aids]\nreset_after_s = 1\n", "aids.reset_after_s", "aid fault"),
        ("[frame]\nswitch_enter_deg = 89.9\nswitch_leave_deg = 89.5\n", "frame.switch_enter_deg", "pole"),
        ("[frame]\nswitch_enter_deg = 1.0\nswitch_leave_deg = 0.5\n", "frame.switch_leave_deg", "equator"),
        ("[frame]\nforce_switch_s = [300.0, 1e300]\n", "frame.force_switch_s", "longer than any flight"),
        ("[frame]\nforce_switch_s = [nan]\n", "frame.force_switch_s", "ascending"),
        (INIT_OK_BUT_H, "init.h_m", "underground"),
        (INIT_OK_BUT_SPEED, "init.vel_enu_mps", "1000 m/s"),
        (INIT_OK_BUT_PITCH, "init.pitch_deg", "another attitude"),
        (INIT_OK_BUT_SIGMA_TILT, "init.sigma_tilt_arcmin", "double"),
        (INIT_OK_BUT_SIGMA_ZERO, "init.sigma_pos_h_m", "exact state"),
        (INIT_OK_BUT_LON, "init.lon_deg", "turn"),
    ];
    let file = dir.join("never.toml");
    for (text, key, reason) in cases {
        std::fs::write(&file, text).expect("write");
        for args in [vec!["--check-config"], vec!["--config"]] {
            let o = bin()
                .args(&args)
                .arg(&file)
                .env("POLARNAV_IOX_ROOT", dir.join("iox"))
                .output()
                .expect("run");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?} {text:?}: {err}");
            assert!(
                err.contains("never.toml")
                    && err.contains(&format!("`{key}`"))
                    && err.contains(reason),
                "{args:?} {text:?}: expected file, `{key}` and {reason:?} in: {err}"
            );
        }
    }
    // The bounds are bounds, not the defaults: values at their edges pass.
    std::fs::write(
        &file,
        "[filter]\nmax_accel_mps2 = 9.84\nmax_gyro_rate_dps = 0.0042\nimu_gap_s = 0.005\n\
         coast_accel_mps2 = 100\n[aids]\nbaro_gate = 1.0\nmax_latency_s = 1.0\n\
         [live]\ncheckpoint_period_s = 1e7\ncheckpoint_max_age_s = 60\n",
    )
    .expect("write");
    let o = bin()
        .arg("--check-config")
        .arg(&file)
        .output()
        .expect("run");
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(
        !dir.join("iox").exists(),
        "an iceoryx2 root was created before the settings were checked"
    );
    std::fs::remove_dir_all(&dir).ok();
}

const INIT_OK_BUT_H: &str = "[init]\nlat_deg = 80\nlon_deg = 0\nh_m = -5000\nheading_deg = 0\nsigma_pos_h_m = 10\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 3\n";
const INIT_OK_BUT_SPEED: &str = "[init]\nlat_deg = 80\nlon_deg = 0\nh_m = 18000\nvel_enu_mps = [900.0, 900.0, 0.0]\nheading_deg = 0\nsigma_pos_h_m = 10\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 3\n";
const INIT_OK_BUT_PITCH: &str = "[init]\nlat_deg = 80\nlon_deg = 0\nh_m = 18000\nheading_deg = 0\npitch_deg = 120\nsigma_pos_h_m = 10\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 3\n";
const INIT_OK_BUT_SIGMA_TILT: &str = "[init]\nlat_deg = 80\nlon_deg = 0\nh_m = 18000\nheading_deg = 0\nsigma_pos_h_m = 10\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1e6\nsigma_heading_arcmin = 3\n";
const INIT_OK_BUT_SIGMA_ZERO: &str = "[init]\nlat_deg = 80\nlon_deg = 0\nh_m = 18000\nheading_deg = 0\nsigma_pos_h_m = 0\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 3\n";
const INIT_OK_BUT_LON: &str = "[init]\nlat_deg = 80\nlon_deg = 1e300\nh_m = 18000\nheading_deg = 0\nsigma_pos_h_m = 10\nsigma_pos_v_m = 10\nsigma_vel_mps = 0.1\nsigma_tilt_arcmin = 1\nsigma_heading_arcmin = 3\n";

#[test]
fn batch_out_into_a_missing_directory_is_bad_usage_naming_the_path() {
    let dir = temp_dir("missing-out");
    let log = dir.join("in.navlog");
    std::fs::write(&log, stationary_log(10, true)).expect("write log");
    for name in ["out.csv", "out.mcap"] {
        let out = dir.join("no-such-dir").join(name);
        let o = bin()
            .args(["batch", "--log"])
            .arg(&log)
            .arg("--out")
            .arg(&out)
            .output()
            .expect("run nav-daemon");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(&*out.to_string_lossy()), "{name}: {err}");
        assert!(err.contains("does not exist"), "{name}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A closed standard error (`nav-daemon batch ... 2>&1 | head -1`) loses
/// the progress and summary lines, not the run: batch exits 0 and writes
/// every row (it used to panic on the first progress line and leave a
/// truncated file).
#[test]
fn batch_with_standard_error_closed_finishes_and_writes_every_row() {
    use std::process::Stdio;
    let dir = temp_dir("closed-stderr");
    let log_path = dir.join("in.navlog");
    let out = dir.join("out.csv");
    std::fs::write(&log_path, stationary_log(2000, true)).expect("write log");
    let mut child = bin()
        .args(["batch", "--progress", "0.001", "--log"])
        .arg(&log_path)
        .arg("--out")
        .arg(&out)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("run nav-daemon");
    // The reader goes before the first line is written.
    drop(child.stderr.take());
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(0), "batch with stderr closed");
    let rows = std::fs::read_to_string(&out).expect("csv").lines().count();
    assert_eq!(rows, 2001, "header and one row per IMU sample");
    std::fs::remove_dir_all(&dir).ok();
}

/// `nav-daemon man | head`: a reader gone before the page is written is
/// not an error (exit 0, nothing on stderr); a full disk is (exit 1,
/// naming the man page).
#[test]
fn man_into_a_closed_pipe_exits_0_and_into_a_full_disk_exits_1() {
    // A pipe whose reader is closed before the child starts: its first
    // write fails with EPIPE, whatever the timing.
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let o = bin()
        .arg("man")
        .stdout(writer)
        .output()
        .expect("run nav-daemon man");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.is_empty(), "{err}");
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return; // no /dev/full here: the first half stands alone
    };
    let o = bin().arg("man").stdout(full).output().expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("man:"), "{err}");
}
