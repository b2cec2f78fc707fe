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

#[test]
fn the_example_kvh1750_driver_publishes_every_good_message_with_the_sensors_time() {
    let env = Env::new("kvh");
    let driver = common::compile("examples/c/kvh1750.c", &env.dir);
    let link = env.dir.join("kvh-tty");
    let expected_path = env.dir.join("expected.json");
    let rate_hz = 200.0f64;
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
    // The feeder says "ready" once the terminal is linked.
    {
        use std::io::BufRead;
        let mut line = String::new();
        std::io::BufReader::new(feeder.stdout.as_mut().expect("stdout"))
            .read_line(&mut line)
            .expect("ready");
        assert_eq!(line.trim(), "ready");
    }
    let node = polarnav_ipc::node(&env.cfg, "test_imu").expect("node");
    let sub = polarnav_ipc::TopicSubscriber::<ImuSample>::new(&node, &env.cfg, Topic::Imu)
        .expect("subscriber");
    let mut drv = env
        .command_for(&driver, "kvh")
        .arg(&link)
        .arg(&env.cfg.prefix)
        .arg(rate_hz.to_string())
        .arg("increments")
        .spawn()
        .expect("driver");
    // Let the driver open the terminal and its publisher, then go.
    let mut got = Vec::new();
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_millis(500) {
        sub.drain(|s| got.push(s)).expect("drain");
        std::thread::sleep(Duration::from_millis(10));
    }
    writeln!(feeder.stdin.as_mut().expect("stdin"), "go").expect("go");
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        sub.drain(|s| got.push(s)).expect("drain");
        if let Some(st) = drv.try_wait().expect("driver") {
            assert!(st.success(), "driver: {st}: {}", env.read("kvh.err"));
            break;
        }
        assert!(Instant::now() < deadline, "the driver did not end");
        std::thread::sleep(Duration::from_millis(10));
    }
    sub.drain(|s| got.push(s)).expect("drain");
    assert!(feeder.wait().expect("feeder").success());
    let _ = wait(&mut drv, Duration::from_secs(1));

    let expected: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(&expected_path).expect("expected"))
            .expect("json");
    let printed = env.read("kvh.out");
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
