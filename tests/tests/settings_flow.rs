//! Settings flow one way: configuration file, then the navlog header's
//! `[navigator]` table, then the command line, through one function
//! (`polarnav_config::effective`) for the live daemon and `batch` alike.

use std::io::BufReader;
use std::path::Path;

use nav_daemon::batch::{self, BatchOptions, BatchReport};
use polarnav::solution_csv::{self, Row};
use polarnav_config::{CliOverrides, ConfigFile, Source, effective};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};
use polarnav_tests::repo;

fn short_log(dir: &Path, scenario: &str, seconds: f64) -> std::path::PathBuf {
    let text = std::fs::read_to_string(repo(scenario)).expect("scenario");
    let s = Scenario::parse(&text, scenario).expect("scenario");
    let dur = s.duration_s();
    // Shorten the last segment's flight (the tests need a minute, not an hour).
    let text = text.replacen(
        &format!("duration_s = {dur:.1}"),
        &format!("duration_s = {seconds:.1}"),
        1,
    );
    let s = Scenario::parse(&text, scenario).expect("scenario");
    let log = dir.join("flight.navlog");
    simulate(
        &s,
        &text,
        SimOptions::default(),
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");
    log
}

fn batch_with(log: &Path, config_text: &str, cli: CliOverrides) -> (Vec<Row>, BatchReport) {
    let file = ConfigFile::parse(config_text, "test.toml").expect("config");
    let mut csv = Vec::new();
    let report = batch::run(
        BufReader::new(std::fs::File::open(log).expect("log")),
        "flight.navlog",
        &mut csv,
        &file,
        &BatchOptions {
            cli,
            ..Default::default()
        },
    )
    .expect("batch");
    let rows = solution_csv::parse(&String::from_utf8(csv).expect("utf8"), "csv").expect("rows");
    (rows, report)
}

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("pn_settings_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("dir");
    d
}

#[test]
fn batch_config_filter_table_changes_the_solution() {
    let dir = tmp("filter");
    let log = short_log(&dir, "config/scenarios/transpolar.toml", 60.0);
    let (base, rb) = batch_with(&log, "", CliOverrides::default());
    assert_eq!(
        rb.effective.source("filter.arw_dpsh"),
        Some(&Source::Default)
    );
    // Ten times the angle random walk: the filter weighs the aids differently.
    let (noisy, rn) = batch_with(&log, "[filter]\narw_dpsh = 0.01\n", CliOverrides::default());
    assert_eq!(rn.effective.source("filter.arw_dpsh"), Some(&Source::File));
    assert_eq!(base.len(), noisy.len());
    let moved = base
        .iter()
        .zip(&noisy)
        .map(|(a, b)| (a.lat_deg - b.lat_deg).abs() + (a.h_m - b.h_m).abs())
        .fold(0.0f64, f64::max);
    assert!(
        moved > 0.0,
        "[filter] arw_dpsh had no effect on the solution"
    );
    // A rate limit below the Earth's rate would refuse every IMU sample: the
    // configuration is refused before anything runs (issue 20, item 7).
    let e = ConfigFile::parse("[filter]\nmax_gyro_rate_dps = 0.000001\n", "test.toml")
        .expect_err("a limit below the Earth's rate")
        .to_string();
    assert!(
        e.contains("test.toml")
            && e.contains("filter.max_gyro_rate_dps")
            && e.contains("Earth's rate"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn header_overrides_file_and_command_line_overrides_header() {
    let dir = tmp("order");
    let log = short_log(&dir, "config/scenarios/paper-sim.toml", 60.0);
    // The file says 80°, the header (paper-sim's [navigator]) 88°.
    let (_, r) = batch_with(
        &log,
        "[frame]\nswitch_enter_deg = 80.0\nswitch_leave_deg = 79.0\n",
        CliOverrides::default(),
    );
    let f = &r.effective.config.frame;
    assert!((f.switch_enter_deg - 88.0).abs() < 1e-12);
    assert_eq!(
        r.effective.source("frame.switch_enter_deg"),
        Some(&Source::Header)
    );
    // The command line wins over both.
    let (_, r) = batch_with(
        &log,
        "",
        CliOverrides {
            force_switch_s: Some(vec![]),
            ..Default::default()
        },
    );
    assert!(r.effective.config.frame.never_switch);
    assert_eq!(
        r.effective.source("frame.never_switch"),
        Some(&Source::CommandLine)
    );
    let text = r.effective.describe();
    assert!(
        text.contains("frame.switch_enter_deg = 88.0  # navlog header"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn effective_settings_survive_the_header_round_trip_exactly() {
    // What the flight recorder writes: every setting, so that batch on the
    // recording uses exactly the daemon's settings whatever its own file says.
    let file = ConfigFile::parse(
        "[filter]\narw_dpsh = 0.0013\nvrw_ug_psqhz = 7.1\n[aids]\nmax_latency_s = 0.25\nfuse = \"srs,baro\"\n[frame]\nconversion = \"none\"\n",
        "daemon.toml",
    )
    .expect("config");
    let daemon = effective(&file, None, &CliOverrides::default()).expect("effective");
    let header = daemon.header_toml();
    let other = ConfigFile::parse("[filter]\narw_dpsh = 0.5\n", "other.toml").expect("config");
    let replay = effective(&other, Some(&header), &CliOverrides::default()).expect("effective");
    assert_eq!(replay.config.frame, daemon.config.frame);
    assert_eq!(replay.config.filter, daemon.config.filter);
    assert_eq!(replay.config.aids, daemon.config.aids);
    assert_eq!(replay.session(), daemon.session());
}

#[test]
fn a_bad_header_value_is_an_error_that_names_the_header_and_key() {
    let meta = "[navigator.filter]\ncovariance_interval_s = -1.0\n";
    let e = effective(
        &ConfigFile::defaults(),
        Some(meta),
        &CliOverrides::default(),
    )
    .expect_err("refused")
    .to_string();
    assert!(
        e.contains("navlog header") && e.contains("filter.covariance_interval_s"),
        "{e}"
    );
    let meta = "[navigator]\nalign_s = 1e300\n";
    let e = effective(
        &ConfigFile::defaults(),
        Some(meta),
        &CliOverrides::default(),
    )
    .expect_err("refused")
    .to_string();
    assert!(e.contains("align_s"), "{e}");
}
