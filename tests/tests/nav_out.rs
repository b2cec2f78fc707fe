//! The bridges to the aircraft behind the real daemon (issue 31): a flight
//! simulated over the North Pole (and then down the 180° meridian, so on the
//! antimeridian), replayed in real time into `nav-daemon`, whose solutions
//! `nav-mavlink` and `nav-nmea` send over UDP to independent decoders (PyPI
//! pymavlink and pynmeagps). Every message decodes with a valid CRC or
//! checksum, carries a solution equal to the daemon's (which equals `batch`
//! bit for bit) to the message's resolution, the heartbeat keeps 1 Hz, and
//! the daemon's stop is said within 1 s.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant, SystemTime};

use msgs::Solution;
use msgs::navlog::Record;
use polarnav::session;
use polarnav_config::{CliOverrides, ConfigFile, effective};
use polarnav_tests::harness::{Env, Proc, terminate, wait};
use polarnav_tests::{python, repo, simulate_file};
use serde_json::Value;

/// The daemon's solutions on `log` with `env`'s settings, as `batch` computes them.
fn batch_solutions(env: &Env, log: &Path) -> Vec<Solution> {
    let file = ConfigFile::load(&env.dir.join("nav.toml")).expect("config");
    let (records, report) = msgs::navlog::read_all(&std::fs::read(log).expect("log"));
    assert!(report.is_clean(), "{report}");
    let meta = records.iter().find_map(|r| match r {
        Record::Header(h) => Some(h.metadata.as_str()),
        _ => None,
    });
    let eff = effective(&file, meta, &CliOverrides::default()).expect("settings");
    session::navigate(&records, eff.session()).0.solutions
}

/// A decoder of `tests/python/receive.py`: its process, its port, its output.
struct Decoder {
    child: Child,
    port: u16,
    out: PathBuf,
}

fn decoder(py: &Path, kind: &str, out: PathBuf) -> Decoder {
    let mut child = std::process::Command::new(py)
        .arg(repo("aircraft/nav-out/tests/python/receive.py"))
        .arg(kind)
        .arg(&out)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("decoder");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("port");
    let port = line
        .trim()
        .strip_prefix("PORT ")
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("decoder said {line:?}"));
    Decoder { child, port, out }
}

impl Decoder {
    fn finish(mut self) -> (Vec<Value>, Value) {
        drop(self.child.stdin.take());
        let t0 = Instant::now();
        while self.child.try_wait().expect("wait").is_none() {
            assert!(t0.elapsed() < Duration::from_secs(30), "decoder hangs");
            std::thread::sleep(Duration::from_millis(20));
        }
        let text = std::fs::read_to_string(&self.out).expect("decoded");
        let mut v: Vec<Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("json"))
            .collect();
        let summary = v.pop().expect("summary")["summary"].clone();
        (v, summary)
    }
}

fn wall() -> f64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .expect("clock")
        .as_secs_f64()
}

fn f(m: &Value, k: &str) -> f64 {
    m[k].as_f64().unwrap_or_else(|| panic!("no {k} in {m}"))
}

fn dlon(a: f64, b: f64) -> f64 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}

#[test]
fn bridges_follow_a_replayed_flight_over_the_pole_and_say_when_the_daemon_stops() {
    let py = python();
    let env = Env::new("navout");
    // 20 s from 1.1 km short of the North Pole along the 0° meridian: over
    // the pole after 4.5 s, then south on the 180° meridian.
    let text = std::fs::read_to_string(repo("config/scenarios/transpolar.toml"))
        .expect("scenario")
        .replace("lat_deg = 85.0", "lat_deg = 89.99")
        .replace("duration_s = 4480.0", "duration_s = 20.0");
    let log = env.dir.join("pole.navlog");
    simulate_file(&text, "pole", &log);
    let solutions = batch_solutions(&env, &log);
    let by_t: HashMap<u64, &Solution> = solutions.iter().map(|s| (s.t_ns / 1000, s)).collect();

    let mav = decoder(&py, "mavlink", env.dir.join("mavlink.jsonl"));
    let nmea = decoder(&py, "nmea", env.dir.join("nmea.jsonl"));
    let write = |name: &str, body: String| {
        let p = env.dir.join(name);
        std::fs::write(&p, body).expect("settings");
        p
    };
    let mav_cfg = write(
        "nav-mavlink.toml",
        format!(
            "[mavlink]\ngps_input_hz = 10.0\n[output]\ntransport = \"udp\"\nudp_target = \"127.0.0.1:{}\"\n",
            mav.port
        ),
    );
    let nmea_cfg = write(
        "nav-nmea.toml",
        format!(
            "[nmea]\nrate_hz = 10.0\n[output]\ntransport = \"udp\"\nudp_target = \"127.0.0.1:{}\"\n",
            nmea.port
        ),
    );
    let mut daemon = env.start_daemon("daemon", None);
    let bridge = |bin: &str, cfg: &Path| {
        let mut c = env.command(bin, bin);
        c.arg("--config")
            .arg(cfg)
            .args(["--prefix", &env.cfg.prefix]);
        let p = Proc(c.spawn().expect("bridge"));
        env.wait_for(bin, "sending", Duration::from_secs(20));
        p
    };
    let mut mav_bridge = bridge("nav-mavlink", &mav_cfg);
    let mut nmea_bridge = bridge("nav-nmea", &nmea_cfg);
    let mut play = env.start_play("play", &log, "1");
    assert_eq!(wait(&mut play, Duration::from_secs(120)), Some(0), "play");
    let stop_at = wall();
    assert_eq!(terminate(&mut daemon, Duration::from_secs(20)), Some(0));
    std::thread::sleep(Duration::from_millis(1500));
    assert_eq!(terminate(&mut mav_bridge, Duration::from_secs(10)), Some(0));
    assert_eq!(
        terminate(&mut nmea_bridge, Duration::from_secs(10)),
        Some(0)
    );
    let (msgs, summary) = mav.finish();
    let (sentences, nsummary) = nmea.finish();

    // MAVLink: every datagram one frame with a valid CRC.
    assert_eq!(summary["bad"], 0, "{summary}");
    assert_eq!(summary["messages"], summary["datagrams"], "{summary}");
    let mut checked = 0;
    let (mut max_lat, mut pole_km) = (-90f64, f64::INFINITY);
    let mut lons = std::collections::BTreeSet::new();
    for m in msgs.iter().filter(|m| m["msg"] == "GPS_INPUT") {
        let t_us = m["time_usec"].as_u64().expect("time_usec");
        let Some(s) = by_t.get(&t_us) else {
            assert!(
                m["fix_type"].as_u64() <= Some(1),
                "GPS_INPUT of no solution: {m}"
            );
            continue;
        };
        let lat_e7 = (s.lat_rad.to_degrees() * 1e7).round() as i64;
        assert_eq!(m["lat"].as_i64(), Some(lat_e7), "{m}");
        let lon = f(m, "lon") * 1e-7;
        assert!(
            dlon(lon, s.lon_rad.to_degrees()).abs() <= 0.5e-7 + 1e-12,
            "{m}"
        );
        let msl = s.h_m - nav_out::geo::geoid_undulation_m(s.lat_rad, s.lon_rad);
        assert!((f(m, "alt") - msl).abs() < 2e-3, "alt {msl}: {m}");
        if f(m, "t") < stop_at {
            assert_eq!(m["fix_type"], 3, "{m}");
        }
        max_lat = max_lat.max(f(m, "lat") * 1e-7);
        pole_km = pole_km.min((90.0 - s.lat_rad.to_degrees()) * 111.694);
        lons.insert(m["lon"].as_i64().expect("lon").signum());
        checked += 1;
    }
    let hb: Vec<f64> = msgs
        .iter()
        .filter(|m| m["msg"] == "HEARTBEAT")
        .map(|m| f(m, "t"))
        .collect();
    let rate = (hb.len() - 1) as f64 / (hb[hb.len() - 1] - hb[0]);
    let said = msgs
        .iter()
        .filter(|m| m["msg"] == "GPS_INPUT" && f(m, "t") > stop_at && m["fix_type"] == 0)
        .map(|m| f(m, "t") - stop_at)
        .next()
        .expect("NO_GPS after the stop");
    eprintln!(
        "nav-mavlink behind the daemon: {} messages, {checked} GPS_INPUT equal to the daemon's solutions \
         (closest to the pole {pole_km:.3} km, largest latitude sent {max_lat}°, longitude signs {lons:?}); \
         heartbeat {rate:.4} Hz over {} beats; daemon stop said (NO_GPS) after {said:.3} s",
        summary["messages"],
        hb.len()
    );
    assert!(checked >= 150, "{checked}");
    assert!(pole_km < 1.0, "the flight passed the pole at {pole_km} km");
    assert!((0.95..=1.05).contains(&rate), "{rate}");
    assert!(said <= 1.0, "{said}");

    // NMEA: every sentence with a valid checksum, GGA on a daemon solution.
    assert_eq!(nsummary["bad"], 0, "{nsummary}");
    let res = 1e-5 / 60.0;
    let mut ggas = 0;
    let mut k = 0usize;
    for m in sentences
        .iter()
        .filter(|m| m["msg"] == "GGA" && m["lat"] != "")
    {
        let (lat, lon) = (f(m, "lat"), f(m, "lon"));
        let fits = |s: &Solution| {
            (lat - s.lat_rad.to_degrees()).abs() <= res / 2.0 + 1e-9
                && dlon(lon, s.lon_rad.to_degrees()).abs() <= res / 2.0 + 1e-9
        };
        k = (k..solutions.len())
            .find(|&i| fits(&solutions[i]))
            .unwrap_or_else(|| panic!("GGA of no solution: {}", m["raw"]));
        let s = &solutions[k];
        let n = nav_out::geo::geoid_undulation_m(s.lat_rad, s.lon_rad);
        assert!((f(m, "sep") - n).abs() <= 0.005 + 1e-9, "{}", m["raw"]);
        assert!(
            (f(m, "alt") - (s.h_m - n)).abs() <= 0.005 + 1e-9,
            "{}",
            m["raw"]
        );
        ggas += 1;
    }
    let quality_0 = sentences
        .iter()
        .filter(|m| m["msg"] == "GGA" && f(m, "t") > stop_at && m["quality"] == 0)
        .map(|m| f(m, "t") - stop_at)
        .next()
        .expect("quality 0 after the stop");
    eprintln!(
        "nav-nmea behind the daemon: {} sentences, {ggas} GGA on the daemon's solutions; stop said after {quality_0:.3} s",
        nsummary["messages"]
    );
    assert!(ggas >= 150, "{ggas}");
    assert!(quality_0 <= 1.0, "{quality_0}");
}
