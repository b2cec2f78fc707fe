//! nav-mavlink end to end: a synthetic polar flight published over
//! iceoryx2 as the daemon publishes it, the bridge's UDP stream decoded by
//! an independent implementation (PyPI pymavlink, MAVLink 2 common
//! dialect), every message checked against the solution it carries.

mod common;

use std::collections::HashMap;
use std::path::Path;
use std::time::{Duration, Instant};

use common::*;
use nav_out::geo;
use polarnav_ipc::TransportConfig;
use serde_json::Value;

fn f(m: &Value, k: &str) -> f64 {
    m[k].as_f64().unwrap_or_else(|| panic!("no {k} in {m}"))
}

/// Half a unit in the last place of `x` as an f32: the resolution of a
/// MAVLink float field.
fn f32_half_ulp(x: f64) -> f64 {
    let v = x as f32;
    f64::from(f32::from_bits(v.abs().to_bits() + 1) - v.abs()) / 2.0
}

#[test]
#[allow(clippy::float_cmp)] // the exact poles and antimeridian are published exactly
fn gps_input_equals_the_solution_over_both_poles_and_the_antimeridian() {
    let cfg = TransportConfig::isolated("navmav");
    // Its iceoryx2 root and shared-memory files go also when the test fails.
    let _cleanup = polarnav_ipc::IsolatedCleanup(cfg.clone());
    let dir = scratch("mavlink");
    let rx = Receiver::start("mavlink", dir.join("decoded.jsonl"), None);
    let config = dir.join("nav-mavlink.toml");
    std::fs::write(
        &config,
        format!(
            r#"
[mavlink]
system_id = 42
component_id = 191
gps_input_hz = 10.0
[mavlink.odometry]
enabled = true
rate_hz = 20.0
reanchor_km = 100.0
[output]
transport = "udp"
udp_target = "127.0.0.1:{}"
"#,
            rx.port
        ),
    )
    .expect("settings");
    let mut daemon = FakeDaemon::start(&cfg);
    let bridge = spawn_bridge(env!("CARGO_BIN_EXE_nav-mavlink"), &config, &cfg);
    // Let the bridge start (its first messages say no source).
    daemon.stall(Duration::from_millis(1500));
    daemon.fly(&polar_flight());
    let stall_at = wall();
    daemon.stall(Duration::from_secs(2));
    let resume_at = wall();
    daemon.fly(&[(
        "resume",
        2.0,
        Box::new(|_| {
            let mut p = solution_pose(70.0, 0.0);
            p.flags = msgs::solution_flags::ALIGNED;
            p
        }),
    )]);
    // The stop begins when the publisher goes, inside `stop` (which then
    // also drops the status port and the node): a bridge may say NO_GPS
    // before `stop` returns, so the clock starts before it.
    let stop_at = wall();
    daemon.stop();
    std::thread::sleep(Duration::from_secs(2));
    let (status, stderr) = terminate(bridge);
    let (msgs, summary) = rx.finish();
    assert!(
        status.success(),
        "nav-mavlink exited with {status}: {stderr}"
    );

    // Every datagram is one frame that decodes with a valid CRC.
    assert_eq!(summary["bad"], 0, "undecodable data: {summary}");
    assert_eq!(
        summary["messages"], summary["datagrams"],
        "one frame per datagram: {summary}"
    );
    let count = |t: &str| msgs.iter().filter(|m| m["msg"] == t).count();
    println!(
        "decoded {} messages in {} datagrams: HEARTBEAT {}, GPS_INPUT {}, ODOMETRY {}, SYSTEM_TIME {}",
        summary["messages"],
        summary["datagrams"],
        count("HEARTBEAT"),
        count("GPS_INPUT"),
        count("ODOMETRY"),
        count("SYSTEM_TIME")
    );
    for m in &msgs {
        assert_eq!(m["sysid"], 42, "{m}");
        assert_eq!(m["compid"], 191, "{m}");
    }

    // GPS_INPUT equals the solution it carries (time_usec) to the
    // message's resolution: 1e-7° in latitude and longitude, the f32 of
    // h − N (EGM96) in altitude.
    let by_t: HashMap<u64, &Published> = daemon
        .published
        .iter()
        .map(|p| (p.sol.t_ns / 1000, p))
        .collect();
    let (mut checked, mut north, mut south, mut anti) = (0, 0, 0, 0);
    let mut worst_lat = 0f64;
    let mut worst_alt = 0f64;
    for m in msgs.iter().filter(|m| m["msg"] == "GPS_INPUT") {
        let t_us = m["time_usec"].as_u64().expect("time_usec");
        if t_us == 0 {
            assert!(
                m["fix_type"].as_u64() <= Some(1),
                "no solution yet: no fix: {m}"
            );
            continue;
        }
        let p = by_t
            .get(&t_us)
            .unwrap_or_else(|| panic!("GPS_INPUT of no published solution: {m}"));
        let s = &p.sol;
        let lat = f(m, "lat") * 1e-7;
        let lon = f(m, "lon") * 1e-7;
        let dlat = (lat - s.lat_rad.to_degrees()).abs();
        let dlon = dlon_deg(lon, s.lon_rad.to_degrees()).abs();
        assert!(
            dlat <= 0.5e-7 + 1e-12,
            "lat {lat} vs {}: {m}",
            s.lat_rad.to_degrees()
        );
        assert!(
            dlon <= 0.5e-7 + 1e-12,
            "lon {lon} vs {}: {m}",
            s.lon_rad.to_degrees()
        );
        assert!((-1_800_000_000..1_800_000_000).contains(&m["lon"].as_i64().expect("lon")));
        worst_lat = worst_lat.max(dlat.max(dlon));
        let msl = s.h_m - geo::geoid_undulation_m(s.lat_rad, s.lon_rad);
        let dalt = (f(m, "alt") - msl).abs();
        assert!(
            dalt <= f32_half_ulp(msl) + 1e-9,
            "alt {} vs {msl}: {m}",
            f(m, "alt")
        );
        worst_alt = worst_alt.max(dalt);
        for (k, v) in [
            ("vn", s.v_enu_mps[1]),
            ("ve", s.v_enu_mps[0]),
            ("vd", -s.v_enu_mps[2]),
        ] {
            assert!((f(m, k) - v).abs() <= f32_half_ulp(v) + 1e-9, "{k}: {m}");
        }
        // Accuracies, unless flagged unknown (a stale solution: no fix).
        if m["ignore_flags"].as_u64().expect("flags") & 64 == 0 {
            let h_acc = (s.sigma_pos_enu_m[0].powi(2) + s.sigma_pos_enu_m[1].powi(2)).sqrt();
            assert!((f(m, "horiz_accuracy") - h_acc).abs() < 1e-5, "{m}");
            assert!(
                (f(m, "vert_accuracy") - s.sigma_pos_enu_m[2]).abs() < 1e-5,
                "{m}"
            );
        } else {
            assert!(m["fix_type"].as_u64() <= Some(1), "{m}");
        }
        // Fix type by phase, unless the message went out after the stall began.
        let fix = m["fix_type"].as_u64().expect("fix_type");
        let expected = match p.phase {
            "not_aligned" => 1,
            "coasting" => 2,
            _ => 3,
        };
        let arrived = f(m, "t");
        if arrived < stall_at || (arrived > resume_at && arrived < stop_at) {
            assert_eq!(fix, expected, "{} phase: {m}", p.phase);
        }
        // Yaw: withheld at the exact poles, the heading in cdeg elsewhere
        // away from them (north = 36000).
        let yaw = m["yaw"].as_u64().expect("yaw");
        if s.lat_rad.abs() == std::f64::consts::FRAC_PI_2 {
            assert_eq!(yaw, 0, "yaw at the pole: {m}");
        } else if s.lat_rad.abs() < 89f64.to_radians() && fix >= 2 {
            let cd = (s.heading_rad.to_degrees().rem_euclid(360.0) * 100.0).round() as u64;
            assert_eq!(yaw, if cd == 0 { 36_000 } else { cd }, "{m}");
        }
        match m["lat"].as_i64() {
            Some(900_000_000) => north += 1,
            Some(-900_000_000) => south += 1,
            _ => {}
        }
        if m["lon"].as_i64() == Some(-1_800_000_000) {
            anti += 1;
        }
        checked += 1;
    }
    println!(
        "GPS_INPUT: {checked} checked against their solutions ({north} at the North Pole, {south} at \
         the South Pole, {anti} at λ = ±180°); largest |Δlat|,|Δlon| {worst_lat:.2e}°, |Δalt| {worst_alt:.2e} m"
    );
    assert!(
        north >= 2 && south >= 2 && anti >= 2,
        "{north} {south} {anti}"
    );
    assert!(checked >= 150, "{checked} GPS_INPUT checked");

    // The daemon stalls (status on, no solution): no fix within 1 s; it
    // stops: fix type 0 (NO_GPS) within 1 s, and nothing better after.
    let gps: Vec<(f64, u64)> = msgs
        .iter()
        .filter(|m| m["msg"] == "GPS_INPUT")
        .map(|m| (f(m, "t"), m["fix_type"].as_u64().expect("fix")))
        .collect();
    let said = |from: f64, ok: &dyn Fn(u64) -> bool| {
        gps.iter()
            .find(|(t, fx)| *t > from && ok(*fx))
            .map(|(t, _)| t - from)
    };
    let stall_said = said(stall_at, &|fx| fx <= 1).expect("no fix after the stall");
    let stop_said = said(stop_at, &|fx| fx == 0).expect("NO_GPS after the stop");
    println!(
        "daemon stalled: no fix said after {stall_said:.3} s; stopped: NO_GPS said after {stop_said:.3} s"
    );
    assert!(stall_said <= 1.0, "{stall_said}");
    assert!(stop_said <= 1.0, "{stop_said}");
    for (t, fx) in &gps {
        if *t > stall_at + 1.0 && *t < resume_at {
            assert!(*fx <= 1, "fix {fx} during the stall at {t}");
        }
        if *t > stop_at + 1.0 {
            assert_eq!(*fx, 0, "fix {fx} after the stop at {t}");
        }
    }

    // HEARTBEAT at 1 Hz ± 5 % over the whole run (first to last).
    let hb: Vec<&Value> = msgs.iter().filter(|m| m["msg"] == "HEARTBEAT").collect();
    let span = f(hb[hb.len() - 1], "t") - f(hb[0], "t");
    let rate = (hb.len() - 1) as f64 / span;
    println!("HEARTBEAT: {} over {span:.3} s: {rate:.4} Hz", hb.len());
    assert!((0.95..=1.05).contains(&rate), "heartbeat {rate} Hz");
    assert!(hb.len() >= 15, "{}", hb.len());
    for m in &hb {
        assert_eq!(m["type"], 18, "MAV_TYPE_ONBOARD_CONTROLLER: {m}");
        assert_eq!(m["autopilot"], 8, "MAV_AUTOPILOT_INVALID: {m}");
        assert_eq!(m["mavlink_version"], 3, "{m}");
    }

    // SYSTEM_TIME: the wall clock.
    for m in msgs.iter().filter(|m| m["msg"] == "SYSTEM_TIME") {
        let d = f(m, "time_unix_usec") * 1e-6 - f(m, "t");
        assert!(d.abs() < 0.5, "SYSTEM_TIME off by {d} s: {m}");
    }

    // ODOMETRY: in the anchored frame, distances between two messages of
    // one anchor (same reset_counter) are the distances between their
    // solutions' ECEF positions (a rotation keeps them), across the pole too;
    // the anchor moves (reset_counter + 1) when the flight jumps by more
    // than 100 km.
    let odo: Vec<&Value> = msgs.iter().filter(|m| m["msg"] == "ODOMETRY").collect();
    assert!(odo.len() >= 100, "{} ODOMETRY", odo.len());
    let mut counters = std::collections::BTreeSet::new();
    let mut worst_dist = 0f64;
    // Each message against the next and against the first of its anchor.
    let mut first = odo[0];
    let pairs: Vec<(&Value, &Value)> = odo
        .windows(2)
        .flat_map(|w| {
            if w[0]["reset_counter"] != w[1]["reset_counter"] {
                first = w[1];
            }
            [(w[0], w[1]), (first, w[1])]
        })
        .collect();
    for (a, b) in pairs {
        for m in [a, b] {
            assert_eq!(m["frame_id"], 1, "MAV_FRAME_LOCAL_NED: {m}");
            assert_eq!(m["child_frame_id"], 12, "MAV_FRAME_BODY_FRD: {m}");
            let q: Vec<f64> = m["q"]
                .as_array()
                .expect("q")
                .iter()
                .map(|x| x.as_f64().expect("q"))
                .collect();
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((n - 1.0).abs() < 1e-6, "|q| {n}: {m}");
        }
        counters.insert(a["reset_counter"].as_u64().expect("reset_counter"));
        if a["reset_counter"] != b["reset_counter"] {
            continue;
        }
        let sa = &by_t[&a["time_usec"].as_u64().expect("t")].sol;
        let sb = &by_t[&b["time_usec"].as_u64().expect("t")].sol;
        let d_sol = (0..3)
            .map(|i| (sa.r_e_m[i] - sb.r_e_m[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        let d_odo = ["x", "y", "z"]
            .iter()
            .map(|k| (f(a, k) - f(b, k)).powi(2))
            .sum::<f64>()
            .sqrt();
        let err = (d_sol - d_odo).abs();
        assert!(
            err < 0.05 + 2e-7 * d_sol,
            "ODOMETRY distance {d_odo} vs {d_sol}: {a} {b}"
        );
        worst_dist = worst_dist.max(err);
    }
    println!(
        "ODOMETRY: {} messages, anchors {:?}, largest distance error {worst_dist:.1e} m",
        odo.len(),
        counters
    );
    assert!(
        counters.len() >= 3,
        "the anchor moved at each jump: {counters:?}"
    );
}

/// A test that fails between starting its bridge and stopping it leaves
/// neither the bridge nor the decoder running, nor the bridge's iceoryx2
/// root: the bridge and the decoder are killed as the panic drops them,
/// and `IsolatedCleanup`, bound first, removes the files after them.
#[test]
fn a_failing_test_leaves_no_bridge_decoder_or_iceoryx2_root_behind() {
    let cfg = TransportConfig::isolated("navmavfail");
    let root = cfg.iox_root.clone().expect("isolated root");
    let dir = scratch("mavlink-fail");
    let alive = |pid: u32| Path::new(&format!("/proc/{pid}")).exists();
    let pids = std::sync::Mutex::new(Vec::new());
    let failed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let _cleanup = polarnav_ipc::IsolatedCleanup(cfg.clone());
        let rx = Receiver::start("mavlink", dir.join("decoded.jsonl"), None);
        let config = dir.join("nav-mavlink.toml");
        std::fs::write(
            &config,
            format!(
                "[output]\ntransport = \"udp\"\nudp_target = \"127.0.0.1:{}\"\n",
                rx.port
            ),
        )
        .expect("settings");
        let bridge = spawn_bridge(env!("CARGO_BIN_EXE_nav-mavlink"), &config, &cfg);
        let bridge_pid = bridge.id().expect("running");
        pids.lock().expect("pids").extend([bridge_pid, rx.id()]);
        // Running, with its iceoryx2 root made.
        let deadline = Instant::now() + Duration::from_secs(20);
        while !root.exists() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(
            root.exists() && alive(bridge_pid),
            "the bridge did not start"
        );
        panic!("the test fails here, its bridge running");
    }));
    assert!(failed.is_err());
    let pids = pids.into_inner().expect("pids");
    assert_eq!(pids.len(), 2);
    for pid in pids {
        assert!(!alive(pid), "process {pid} left running");
    }
    assert!(!root.exists(), "{} left behind", root.display());
}

fn solution_pose(lat_deg: f64, lon_deg: f64) -> Pose {
    Pose {
        lat_rad: lat_deg.to_radians(),
        lon_rad: lon_deg.to_radians(),
        h_m: 18_000.0,
        heading_rad: 1.0,
        speed_mps: 220.0,
        flags: 0,
    }
}
