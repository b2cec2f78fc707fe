//! nav-nmea end to end: the polar flight's solutions over iceoryx2, the
//! bridge's sentences parsed by an independent implementation (PyPI
//! pynmeagps, checksums validated) and compared with the solutions to each
//! field's resolution, over both poles and across the antimeridian; a
//! serial device that goes away and comes back.

mod common;

use std::time::Duration;

use common::*;
use nav_out::geo;
use polarnav_ipc::TransportConfig;
use serde_json::Value;

const KNOT_MPS: f64 = 1852.0 / 3600.0;

fn f(m: &Value, k: &str) -> f64 {
    m[k].as_f64()
        .unwrap_or_else(|| panic!("no number {k} in {m}"))
}

fn course_deg(s: &msgs::Solution) -> f64 {
    s.v_enu_mps[0]
        .atan2(s.v_enu_mps[1])
        .to_degrees()
        .rem_euclid(360.0)
}

#[test]
#[allow(clippy::float_cmp)] // the exact poles and antimeridian are published exactly
fn sentences_equal_the_solution_over_both_poles_and_the_antimeridian() {
    let cfg = TransportConfig::isolated("navnmea");
    // Its iceoryx2 root and shared-memory files go also when the test fails.
    let _cleanup = polarnav_ipc::IsolatedCleanup(cfg.clone());
    let dir = scratch("nmea");
    let rx = Receiver::start("nmea", dir.join("decoded.jsonl"), None);
    let config = dir.join("nav-nmea.toml");
    std::fs::write(
        &config,
        format!(
            r#"
[nmea]
rate_hz = 10.0
talker = "GN"
minute_decimals = 5
[output]
transport = "udp"
udp_target = "127.0.0.1:{}"
"#,
            rx.port
        ),
    )
    .expect("settings");
    let mut daemon = FakeDaemon::start(&cfg);
    let bridge = spawn_bridge(env!("CARGO_BIN_EXE_nav-nmea"), &config, &cfg);
    daemon.stall(Duration::from_millis(1500));
    daemon.fly(&polar_flight());
    // The stop begins when the publisher goes, inside `stop`: a bridge may
    // say no fix before `stop` returns, so the clock starts before it.
    let stop_at = wall();
    daemon.stop();
    std::thread::sleep(Duration::from_millis(1500));
    let (status, stderr) = terminate(bridge);
    let (msgs, summary) = rx.finish();
    assert!(status.success(), "nav-nmea exited with {status}: {stderr}");
    assert_eq!(summary["bad"], 0, "sentences that did not parse: {summary}");

    // One epoch per datagram: GGA, RMC, VTG, HDT in that order.
    let mut epochs: Vec<Vec<&Value>> = Vec::new();
    for m in &msgs {
        assert_eq!(m["talker"], "GN", "{m}");
        match epochs.last_mut() {
            Some(e) if e[0]["datagram"] == m["datagram"] => e.push(m),
            _ => epochs.push(vec![m]),
        }
    }
    let res_deg = 1e-5 / 60.0;
    let (mut checked, mut north, mut south, mut anti) = (0, 0, 0, 0);
    let mut last_match = 0usize;
    for e in &epochs {
        let kinds: Vec<&str> = e.iter().map(|m| m["msg"].as_str().expect("msg")).collect();
        assert_eq!(kinds, ["GGA", "RMC", "VTG", "HDT"], "{e:?}");
        let (gga, rmc, vtg, hdt) = (e[0], e[1], e[2], e[3]);
        if gga["lat"] == "" {
            assert_eq!(gga["quality"], 0, "no position, no fix: {gga}");
            continue;
        }
        let (lat, lon) = (f(gga, "lat"), f(gga, "lon"));
        // The solution this epoch carries: the first at or after the last
        // matched one whose position rounds to the sentence's.
        let fits = |p: &Published| {
            (lat - p.sol.lat_rad.to_degrees()).abs() <= res_deg / 2.0 + 1e-9
                && dlon_deg(lon, p.sol.lon_rad.to_degrees()).abs() <= res_deg / 2.0 + 1e-9
        };
        let k = (last_match..daemon.published.len())
            .find(|&k| fits(&daemon.published[k]))
            .unwrap_or_else(|| panic!("GGA of no published solution: {}", gga["raw"]));
        last_match = k;
        let p = &daemon.published[k];
        let s = &p.sol;
        assert!(f(rmc, "lat") == lat && f(rmc, "lon") == lon, "{rmc}");
        // Fix by phase (epochs after the stop say no fix; checked below).
        if f(gga, "t") < stop_at {
            let (q, mode) = match p.phase {
                "not_aligned" => (0, "N"),
                "coasting" => (6, "E"),
                _ => (1, "A"),
            };
            assert_eq!(gga["quality"], q, "{} phase: {}", p.phase, gga["raw"]);
            assert_eq!(rmc["posMode"], mode, "{}", rmc["raw"]);
            assert_eq!(vtg["posMode"], mode, "{}", vtg["raw"]);
            assert_eq!(
                rmc["status"],
                if q == 0 { "V" } else { "A" },
                "{}",
                rmc["raw"]
            );
        }
        // Heights: above MSL and the geoid separation (EGM96), 0.01 m.
        let n = geo::geoid_undulation_m(s.lat_rad, s.lon_rad);
        assert!(
            (f(gga, "sep") - n).abs() <= 0.005 + 1e-9,
            "sep {n}: {}",
            gga["raw"]
        );
        assert!(
            (f(gga, "alt") - (s.h_m - n)).abs() <= 0.005 + 1e-9,
            "alt {}: {}",
            s.h_m - n,
            gga["raw"]
        );
        // Speed (0.001 kn, 0.001 km/h) and course (0.01°).
        let v = s.v_enu_mps[0].hypot(s.v_enu_mps[1]);
        assert!(
            (f(rmc, "spd") - v / KNOT_MPS).abs() <= 0.0005 + 1e-9,
            "{}",
            rmc["raw"]
        );
        assert!(
            (f(vtg, "sogn") - v / KNOT_MPS).abs() <= 0.0005 + 1e-9,
            "{}",
            vtg["raw"]
        );
        assert!(
            (f(vtg, "sogk") - v * 3.6).abs() <= 0.0005 + 1e-9,
            "{}",
            vtg["raw"]
        );
        for c in [f(rmc, "cog"), f(vtg, "cogt")] {
            assert!(
                dlon_deg(c, course_deg(s)).abs() <= 0.005 + 1e-9,
                "course {c}: {e:?}"
            );
        }
        // Heading: none at the exact poles; 0.01° elsewhere away from them.
        if s.lat_rad.abs() == std::f64::consts::FRAC_PI_2 {
            assert_eq!(hdt["headingT"], "", "{}", hdt["raw"]);
        } else if s.lat_rad.abs() < 89f64.to_radians() && gga["quality"] != 0 {
            let h = s.heading_rad.to_degrees().rem_euclid(360.0);
            assert!(
                dlon_deg(f(hdt, "headingT"), h).abs() <= 0.005 + 1e-9,
                "{}",
                hdt["raw"]
            );
        }
        if lat == 90.0 {
            north += 1;
        }
        if lat == -90.0 {
            south += 1;
        }
        if lon == -180.0 {
            anti += 1;
        }
        checked += 1;
    }
    println!(
        "NMEA: {} sentences in {} epochs, {checked} epochs checked against their solutions ({north} at \
         the North Pole, {south} at the South Pole, {anti} at λ = ±180°)",
        summary["messages"],
        epochs.len()
    );
    assert!(
        north >= 2 && south >= 2 && anti >= 2,
        "{north} {south} {anti}"
    );
    assert!(checked >= 100, "{checked}");
    // After the stop: quality 0 within 1 s, and from then on.
    let after: Vec<(f64, i64)> = epochs
        .iter()
        .map(|e| (f(e[0], "t"), e[0]["quality"].as_i64().expect("quality")))
        .filter(|(t, _)| *t > stop_at)
        .collect();
    let said = after
        .iter()
        .find(|(_, q)| *q == 0)
        .map(|(t, _)| t - stop_at)
        .expect("no fix after the stop");
    println!("daemon stopped: GGA quality 0 after {said:.3} s");
    assert!(said <= 1.0, "{said}");
    assert!(after.iter().all(|(t, q)| *t <= stop_at + 1.0 || *q == 0));
}

#[test]
fn a_serial_device_that_goes_away_is_reported_and_reconnected() {
    let cfg = TransportConfig::isolated("navnmeaser");
    // Its iceoryx2 root and shared-memory files go also when the test fails.
    let _cleanup = polarnav_ipc::IsolatedCleanup(cfg.clone());
    let dir = scratch("nmea-serial");
    let link = dir.join("ttyNMEA");
    let mut rx = Receiver::start("nmea", dir.join("decoded.jsonl"), Some(&link));
    let config = dir.join("nav-nmea.toml");
    std::fs::write(
        &config,
        format!(
            r#"
[nmea]
rate_hz = 10.0
[output]
transport = "serial"
serial_device = "{}"
serial_baud = 115200
"#,
            link.display()
        ),
    )
    .expect("settings");
    let mut daemon = FakeDaemon::start(&cfg);
    let bridge = spawn_bridge(env!("CARGO_BIN_EXE_nav-nmea"), &config, &cfg);
    let steady: Vec<Segment> = vec![(
        "steady",
        2.0,
        Box::new(|u| Pose {
            lat_rad: 80f64.to_radians(),
            lon_rad: (10.0 + u).to_radians(),
            h_m: 18_000.0,
            heading_rad: 1.0,
            speed_mps: 200.0,
            flags: msgs::solution_flags::ALIGNED,
        }),
    )];
    daemon.fly(&steady);
    let gone_at = wall();
    rx.say("CYCLE");
    daemon.fly(&steady);
    daemon.fly(&steady);
    let (status, stderr) = terminate(bridge);
    let (msgs, summary) = rx.finish();
    assert!(status.success(), "{status}: {stderr}");
    assert_eq!(summary["bad"], 0, "{summary}");
    assert_eq!(summary["cycles"], 1, "{summary}");
    let before = msgs.iter().filter(|m| f(m, "t") < gone_at).count();
    let back: Vec<f64> = msgs
        .iter()
        .map(|m| f(m, "t"))
        .filter(|t| *t > gone_at + 1.5)
        .collect();
    println!(
        "serial: {before} sentences before the device went away, {} after it came back (first {:.2} s after it went)",
        back.len(),
        back.first().map_or(f64::NAN, |t| t - gone_at)
    );
    assert!(before >= 40, "{before}");
    assert!(back.len() >= 40, "{}", back.len());
    assert!(
        back[0] - gone_at < 1.5 + 1.5,
        "reconnected {} s after",
        back[0] - gone_at
    );
    assert!(stderr.contains("lost"), "the loss is reported: {stderr}");
    assert!(
        stderr.contains("is back"),
        "the return is reported: {stderr}"
    );
}
