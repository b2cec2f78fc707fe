//! The example C driver (`examples/c/kvh1750.c`, a KVH 1750 on RS-422
//! through libpolarnav_pub): compiled by the plain `cc` line its comment
//! gives, fed by a unit simulated on a pseudo-terminal from the message's
//! layout alone (`tests/python/kvh_feed.py`: its own CRC-32/MPEG-2, garbage
//! with a false header, a damaged CRC, three messages lost on the line),
//! and read back from `<prefix>/imu` by a subscriber of this test.

use std::io::Write;
use std::process::Stdio;
use std::time::{Duration, Instant};

use msgs::ImuSample;
use msgs::service::Topic;
use polarnav_tests::harness::{Env, wait};
use polarnav_tests::repo;
use serde_json::Value;

#[path = "../c/common.rs"]
mod common;

/// 400 slots of a unit at `rate_hz` through the driver told `driver_hz`:
/// the samples received, the messages that should arrive, and what the
/// driver printed at its end.
fn fly_kvh(env: &Env, rate_hz: f64, driver_hz: f64) -> (Vec<ImuSample>, Vec<Value>, String) {
    let driver = common::compile("examples/c/kvh1750.c", &env.dir);
    let link = env.dir.join("kvh-tty");
    let expected_path = env.dir.join("expected.json");
    let mut feeder = std::process::Command::new("python3")
        .arg(repo("tests/python/kvh_feed.py"))
        .arg(&link)
        .arg(rate_hz.to_string())
        .arg("400")
        .arg(&expected_path)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("python3");
    // The feeder's lines ("ready" once the terminal is linked, "sent" once
    // every message is written), read on a thread so that each wait has a
    // deadline.
    let lines = {
        use std::io::BufRead;
        let out = feeder.stdout.take().expect("stdout");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for l in std::io::BufReader::new(out).lines().map_while(Result::ok) {
                let _ = tx.send(l);
            }
        });
        rx
    };
    let said = |what: &str| {
        let l = lines
            .recv_timeout(Duration::from_secs(30))
            .unwrap_or_else(|e| panic!("the feeder did not say {what}: {e}"));
        assert_eq!(l.trim(), what);
    };
    said("ready");
    let node = polarnav_ipc::node(&env.cfg, "test_imu").expect("node");
    let sub = polarnav_ipc::TopicSubscriber::<ImuSample>::new(&node, &env.cfg, Topic::Imu)
        .expect("subscriber");
    let mut drv = env
        .command_for(&driver, "kvh")
        .arg(&link)
        .arg(&env.cfg.prefix)
        .arg(driver_hz.to_string())
        .arg("increments")
        .spawn()
        .expect("driver");
    // The driver opens the terminal, then its publisher: once the
    // publisher is there, go.
    let mut got = Vec::new();
    let until = |what: &str,
                 deadline: Duration,
                 done: &mut dyn FnMut(&mut Vec<ImuSample>) -> bool,
                 got: &mut Vec<ImuSample>| {
        let t0 = Instant::now();
        loop {
            sub.drain(|s| got.push(s)).expect("drain");
            if done(got) {
                return;
            }
            assert!(t0.elapsed() < deadline, "{what} within {deadline:?}");
            std::thread::sleep(Duration::from_millis(10));
        }
    };
    until(
        "the driver's publisher",
        Duration::from_secs(20),
        &mut |_| sub.publishers() > 0,
        &mut got,
    );
    writeln!(feeder.stdin.as_mut().expect("stdin"), "go").expect("go");
    said("sent");
    let expected: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(&expected_path).expect("expected"))
            .expect("json");
    // Every message that should arrive has arrived: the terminal may close.
    until(
        "every good message",
        Duration::from_secs(20),
        &mut |g| g.len() >= expected.len(),
        &mut got,
    );
    writeln!(feeder.stdin.as_mut().expect("stdin"), "done").expect("done");
    assert!(feeder.wait().expect("feeder").success());
    // The driver sees the terminal close and ends.
    assert_eq!(
        wait(&mut drv, Duration::from_secs(20)),
        Some(0),
        "driver: {}",
        env.read("kvh.err")
    );
    sub.drain(|s| got.push(s)).expect("drain");
    (got, expected, env.read("kvh.out"))
}

#[test]
fn the_example_kvh1750_driver_publishes_every_good_message_with_the_sensors_time() {
    let env = Env::new("kvh");
    let rate_hz = 200.0f64;
    let (got, expected, printed) = fly_kvh(&env, rate_hz, rate_hz);
    eprintln!("{printed}{} samples received", got.len());
    let count = |k: &str| -> u64 {
        printed
            .split_whitespace()
            .find_map(|w| w.strip_prefix(k))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {k} in {printed}"))
    };
    // Two CRC failures (the false header, the damaged message), the slots
    // after them and the three lost ones as gaps of 1 and 3 periods.
    assert_eq!(count("bad_crc="), 2, "{printed}");
    assert_eq!(count("gaps="), 2, "{printed}");
    assert_eq!(count("gap_periods="), 4, "{printed}");
    assert_eq!(count("published="), expected.len() as u64, "{printed}");
    assert_eq!(count("lost="), 0, "{printed}");
    assert_eq!(got.len(), expected.len(), "samples received");

    let period_ns = (1e9 / rate_hz).round() as u64;
    let resyncs = count("resyncs=");
    let mut off_schedule = 0;
    for (i, (s, e)) in got.iter().zip(&expected).enumerate() {
        let f = |k: &str, j: usize| e[k][j].as_f64().expect("float");
        for j in 0..3 {
            assert_eq!(
                s.d_theta_rad[j].to_bits(),
                f("gyro", j).to_bits(),
                "sample {i}"
            );
            assert_eq!(
                s.d_v_mps[j].to_bits(),
                f("accel", j).to_bits(),
                "sample {i}"
            );
        }
        assert_eq!(s.seq, i as u64);
        assert!((s.dt_s - 1.0 / rate_hz).abs() < 1e-15, "{}", s.dt_s);
        if i > 0 {
            let prev = &got[i - 1];
            assert!(s.t_ns > prev.t_ns, "stamps must increase at {i}");
            // The sensor's clock: the slots between the messages.
            let slots =
                e["slot"].as_u64().expect("slot") - expected[i - 1]["slot"].as_u64().expect("slot");
            if s.t_ns - prev.t_ns != slots * period_ns {
                off_schedule += 1;
            }
        }
    }
    // Every stamp on the sensor's schedule, but where the driver moved its
    // origin to the arrivals (a loaded machine's pacing: counted).
    assert!(
        off_schedule <= resyncs,
        "{off_schedule} stamps off the sensor's schedule, {resyncs} resyncs"
    );
}

/// The example's CMake file builds it against the installed library (found
/// through its pkg-config file), and the program it builds runs.
#[test]
fn the_example_builds_with_its_cmake_file() {
    let env = Env::new("kvhcmake");
    let stage = common::install_stage(&env.dir);
    let cmake = |args: &[&std::ffi::OsStr]| {
        let o = std::process::Command::new("cmake")
            .args(args)
            .env("PKG_CONFIG_PATH", stage.join("usr/lib/pkgconfig"))
            .env("PKG_CONFIG_SYSROOT_DIR", &stage)
            .output()
            .expect("cmake (install it: apt-get install cmake)");
        assert!(
            o.status.success(),
            "cmake {args:?}: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let build = env.dir.join("build");
    let rpath = format!("-DCMAKE_BUILD_RPATH={}", stage.join("usr/lib").display());
    cmake(&[
        "-S".as_ref(),
        repo("examples/c").as_os_str(),
        "-B".as_ref(),
        build.as_os_str(),
        rpath.as_ref(),
    ]);
    cmake(&["--build".as_ref(), build.as_os_str()]);
    // Its usage line, exit 2, from the binary CMake built and linked.
    let o = std::process::Command::new(build.join("kvh1750"))
        .output()
        .expect("kvh1750");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("usage: kvh1750 DEVICE PREFIX RATE_HZ"));
}

/// A unit whose clock runs 5 % slow against the one the driver was told
/// (200 Hz sent, 210 Hz said): the stamps drift from the arrivals, and the
/// driver moves their origin back to the arrivals past 5 ms, counted,
/// every stamp still after the one before.
#[test]
fn a_drifting_unit_clock_is_re_anchored_counted_and_stays_increasing() {
    let env = Env::new("kvhdrift");
    let (got, expected, printed) = fly_kvh(&env, 200.0, 210.0);
    eprintln!("{printed}");
    let resyncs: u64 = printed
        .split_whitespace()
        .find_map(|w| w.strip_prefix("resyncs="))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no resyncs in {printed}"));
    // 0.24 ms of drift a message: past 5 ms every ~21 messages.
    assert!(resyncs >= 5, "{printed}");
    assert_eq!(got.len(), expected.len());
    assert!(
        got.windows(2).all(|w| w[1].t_ns > w[0].t_ns),
        "stamps must increase"
    );
}
