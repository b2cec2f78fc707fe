//! MCAP from `batch` read by the reference reader (PyPI `mcap`): one
//! `/solution` per row of the same run's CSV with every value equal, a
//! schema on every channel, `foxglove.LocationFix` channels that decode, and
//! the frame switch and aid updates present.

use std::io::BufReader;
use std::process::Command;

use nav_daemon::batch::{self, BatchOptions, Output};
use polarnav_config::ConfigFile;
use polarnav_foxglove::{AidSource, McapFile};
use polarnav_tests::{check_mcap, python, repo, simulate_file};

#[test]
fn batch_mcap_has_one_solution_per_csv_row_with_equal_values_and_every_schema() {
    let dir = std::env::temp_dir().join(format!("polarnav-mcap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    // paper-sim switches g -> G at 212 s; 260 s of it at 200 Hz, with a
    // star tracker, a GNSS receiver and a dual-antenna baseline (the
    // simulator's and the navigator's default antennas; a magnetometer,
    // its bound on the horizontal field at its lowest, 2000 nT, as 87.5° N
    // is near the magnetic pole) so that every stream has its channel.
    let text = std::fs::read_to_string(repo("config/scenarios/paper-sim.toml"))
        .expect("scenario")
        .replace("duration_s = 600.0", "duration_s = 260.0")
        .replace(
            "[init_error]",
            "[star]\nrate_hz = 1.0\nsigma_arcsec = 5.0\n\n[gnss]\nrate_hz = 5.0\n\n\
             [baseline]\nrate_hz = 5.0\n\n[mag]\nrate_hz = 1.0\nepoch_utc = \"2026-06-01T00:00:00Z\"\n\n\
             [navigator.aids.mag]\nepoch_utc = \"2026-06-01T00:00:00Z\"\nmin_horizontal_nt = 2000.0\n\n\
             [init_error]",
        );
    let log = dir.join("paper.navlog");
    simulate_file(&text, "paper-sim (260 s)", &log);
    let open = || BufReader::new(std::fs::File::open(&log).expect("open"));
    let csv = dir.join("paper.csv");
    let a = batch::run(
        open(),
        "paper.navlog",
        std::io::BufWriter::new(std::fs::File::create(&csv).expect("create")),
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
    .expect("batch csv");
    let mcap = dir.join("paper.mcap");
    let b = batch::run_to::<_, std::io::Sink>(
        open(),
        "paper.navlog",
        Output::Mcap(Box::new(
            McapFile::create(&mcap, AidSource::Updates).expect("mcap"),
        )),
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
    .expect("batch mcap");
    assert_eq!(a.rows, b.rows);
    assert_eq!(b.switches.len(), 1);

    // Every channel of the mapping is in the file.
    let summary = check_mcap(&mcap, Some(&csv), &polarnav_foxglove::topics());
    let counts = &summary["counts"];
    assert_eq!(summary["solutions_checked"].as_u64(), Some(a.rows));
    // The display channels: one solution per 50 ms of sensor time and the
    // first one in a new frame, counted here from the CSV's stamps.
    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut last: Option<(u64, String)> = None;
    let mut shown = 0u64;
    for line in text.lines().skip(1) {
        let mut cols = line.split(',');
        let t_ns = (cols.next().expect("t_s").parse::<f64>().expect("t_s") * 1e9).round() as u64;
        let frame = cols.next().expect("frame").to_owned();
        let show = last.as_ref().is_none_or(|(t0, f0)| {
            *f0 != frame || t_ns < *t0 || t_ns - t0 >= polarnav_foxglove::DISPLAY_PERIOD_NS
        });
        if show {
            shown += 1;
            last = Some((t_ns, frame));
        } else if let Some(l) = last.as_mut() {
            l.1 = frame;
        }
    }
    assert!(
        shown * 9 < a.rows && shown * 11 > a.rows,
        "{shown} of {}",
        a.rows
    );
    for t in ["/solution/fix", "/solution/pose", "/solution/nav_frame"] {
        assert_eq!(counts[t].as_u64(), Some(shown), "{t}");
    }
    assert_eq!(counts["/events/switch"].as_u64(), Some(1));
    // Every aid sample that reached the gate has its update: fused + gate-rejected.
    let st = &b.status;
    for (k, c, _) in st.each_aid() {
        let topic = k.decl().update_topic;
        assert_eq!(
            counts[topic].as_u64(),
            Some(c.accepted + c.rejected_gate),
            "{topic}: {c:?}"
        );
    }
    // Status once per second of sensor time, and a last one at the end.
    let status = counts["/status"].as_u64().expect("status");
    assert!((260..=262).contains(&status), "{status} status messages");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The init record says which method aligned (issue 30): `batch --align`
/// on the MEMS aircraft (standing for its first 60 s) writes, beside the
/// init it was given (method 0, "given"), the init its alignment made,
/// stamped at the alignment's end: levelling and the magnetometer's
/// heading, read back by the reference reader; the status says the same.
/// With a navigation-grade IMU on the ground the same alignment, offered
/// the same magnetometer, gyrocompasses and says so.
#[test]
fn batch_mcap_init_records_say_how_the_alignment_found_the_heading() {
    let dir = std::env::temp_dir().join(format!("polarnav-mcap-init-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let mems =
        std::fs::read_to_string(repo("config/scenarios/mems-aircraft.toml")).expect("scenario");
    // The same flight with a navigation-grade IMU (the navigation preset's
    // noise, no bias wander), whose gyros sense the Earth's rate.
    let navigation = mems
        .replace("preset = \"mems\"", "preset = \"navigation\"")
        .replace("gm_gyro_sigma_dph = 50.0", "gm_gyro_sigma_dph = 0.0")
        .replace("arw_dpsh = 0.3", "arw_dpsh = 0.002")
        .replace("vrw_ug_psqhz = 300.0", "vrw_ug_psqhz = 5.0")
        .replace("gm_accel_sigma_ug = 2000.0", "gm_accel_sigma_ug = 0.0");
    assert_ne!(mems, navigation);
    let cases = [
        (
            "mems",
            mems,
            msgs::InitMethod::AidHeading(msgs::AidKind::Mag),
        ),
        ("navigation", navigation, msgs::InitMethod::Gyrocompass),
    ];
    for (name, text, method) in &cases {
        let log = dir.join(format!("{name}.navlog"));
        simulate_file(text, name, &log);
        let mcap = dir.join(format!("{name}.mcap"));
        // The same aids in both: the magnetometer's heading is there to
        // be taken, and only the MEMS gyro takes it.
        let aids = polarnav::settings::AidSet::NONE
            .with(msgs::AidKind::Mag, true)
            .with(msgs::AidKind::Baro, true);
        let report = batch::run_to::<_, std::io::Sink>(
            BufReader::new(std::fs::File::open(&log).expect("open")),
            "init.navlog",
            Output::Mcap(Box::new(
                McapFile::create(&mcap, AidSource::Updates).expect("mcap"),
            )),
            &ConfigFile::defaults(),
            &BatchOptions {
                cli: polarnav_config::CliOverrides {
                    align_s: Some(50.0),
                    fuse: Some(aids),
                    ..Default::default()
                },
                ..Default::default()
            },
        )
        .expect("batch mcap");
        let a = report.alignment.expect("aligned");
        let summary = check_mcap(&mcap, None, &["/init"]);
        let inits = summary["inits"].as_array().expect("inits");
        println!("{name}: /init messages {inits:?}");
        assert_eq!(inits.len(), 2, "{name}: {inits:?}");
        assert_eq!(inits[0]["method"].as_u64(), Some(0), "{name}");
        assert_eq!(inits[0]["method_name"].as_str(), Some("given"), "{name}");
        let (m, k) = method.to_wire();
        assert_eq!(inits[1]["method"].as_u64(), Some(u64::from(m)), "{name}");
        assert_eq!(
            inits[1]["heading_aid"].as_u64(),
            Some(u64::from(k)),
            "{name}"
        );
        assert_eq!(
            inits[1]["method_name"].as_str(),
            Some(method.to_string().as_str()),
            "{name}"
        );
        let t1 = inits[1]["t_ns"].as_u64().expect("t_ns");
        assert!(
            (t1 as f64 * 1e-9 - inits[0]["t_ns"].as_u64().expect("t_ns") as f64 * 1e-9 - a.time_s)
                .abs()
                < 0.02,
            "{name}: aligned init at {t1} ns after {} s",
            a.time_s
        );
        assert_eq!(report.status.init_method(), Some(*method), "{name}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A file that is not MCAP is refused by the reader: the checker can fail.
#[test]
fn the_reference_reader_check_refuses_a_damaged_file() {
    let dir = std::env::temp_dir().join(format!("polarnav-mcap-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let bad = dir.join("bad.mcap");
    std::fs::write(&bad, b"\x89MCAP0\r\n not really").expect("write");
    let out = Command::new(python())
        .arg(repo("tests/python/check_mcap.py"))
        .arg(&bad)
        .output()
        .expect("python");
    assert!(!out.status.success());
    let _ = std::fs::remove_dir_all(&dir);
}
