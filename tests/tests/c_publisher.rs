//! libpolarnav_pub from C, and the Python publisher: programs compiled by
//! `cc` against the header and the shared library as `scripts/install.sh`
//! installs them (flags from its pkg-config file), and
//! `examples/python/publisher.py`, publish a
//! simulated flight into the daemon (the recording equals `batch` on the
//! same records bit for bit), provoke and name every code, are refused
//! and counted by the daemon as a second publisher, and never block on a
//! subscriber that does not read. Each test has its own iceoryx2 prefix
//! and root, and a deadline on every wait.

use std::path::Path;
use std::time::{Duration, Instant};

use msgs::navlog::Record;
use msgs::service::Topic;
use msgs::{AidKind, BaroSample, ImuSample, Solution};
use polarnav::session;
use polarnav_config::{CliOverrides, ConfigFile, effective};
use polarnav_tests::harness::{Env, short_log, status_until, terminate, wait};
use polarnav_tests::{python, repo};

#[path = "../c/common.rs"]
mod common;
use common::compile;

/// The bytes of a `#[repr(C)]` wire payload, as C sees it.
#[allow(unsafe_code)]
fn bytes_of<T: Copy>(x: &T) -> &[u8] {
    // SAFETY: the wire payloads are #[repr(C)] plain data with explicit
    // padding fields (no uninitialized bytes; msgs/include/polarnav_msgs.h
    // is their layout, checked against cbindgen in CI), and the slice
    // borrows `x` for its lifetime.
    unsafe { std::slice::from_raw_parts((x as *const T).cast::<u8>(), size_of::<T>()) }
}

/// The inputs of `records` as the C feed program reads them: u32 tag
/// (0 init, 1 imu, 2 + k aid k), u32 size, the payload's bytes.
fn feed_file(records: &[Record], path: &Path) -> usize {
    let mut out = Vec::new();
    let mut n = 0;
    let mut put = |tag: u32, bytes: &[u8]| {
        out.extend_from_slice(&tag.to_ne_bytes());
        out.extend_from_slice(&(bytes.len() as u32).to_ne_bytes());
        out.extend_from_slice(bytes);
        n += 1;
    };
    for r in records {
        match r {
            Record::Init(x) => put(0, bytes_of(x)),
            Record::Imu(x) => put(1, bytes_of(x)),
            Record::Aid(a) => {
                let tag = 2 + a.kind() as u32;
                msgs::match_aid_kind!(a.kind(), P => {
                    put(tag, bytes_of(<P as msgs::AidPayload>::of(a).expect("its payload")))
                })
            }
            _ => {}
        }
    }
    std::fs::write(path, out).expect("feed file");
    n
}

/// Runs `codes PREFIX MODE` (`tests/c/codes.c`) to its end, exit 0 within
/// 60 s, with `var` set in its environment when given; returns what it printed.
fn run_codes(env: &Env, codes: &Path, mode: &str, var: Option<(&str, &Path)>) -> String {
    let mut c = env.command_for(codes, mode);
    c.args([&env.cfg.prefix, mode]);
    if let Some((k, v)) = var {
        c.env(k, v);
    }
    let mut p = c.spawn().expect("codes");
    assert_eq!(
        wait(&mut p, Duration::from_secs(60)),
        Some(0),
        "codes {mode}: {}\n{}",
        env.read(&format!("{mode}.out")),
        env.read(&format!("{mode}.err"))
    );
    env.read(&format!("{mode}.out"))
}

/// The program that publishes the flight's inputs.
#[derive(Debug, Clone, Copy)]
enum Driver {
    /// `tests/c/feed.c` on libpolarnav_pub.
    C,
    /// `examples/python/publisher.py` on PyPI iceoryx2 and the ctypes mirror.
    Python,
}

#[test]
fn a_c_driver_publishes_a_flight_that_the_daemon_navigates_as_batch_does() {
    fly_through("cpub", Driver::C);
}

#[test]
fn a_python_driver_publishes_a_flight_that_the_daemon_navigates_as_batch_does() {
    fly_through("pypub", Driver::Python);
}

/// A 60 s flight's inputs published by `driver` into the daemon at 15×,
/// with a second (C) publisher on the IMU meanwhile: every sample sent,
/// none lost or refused, the second publisher's 200 refused and counted,
/// and the recording equal to `batch` on the same records bit for bit.
fn fly_through(tag: &str, driver: Driver) {
    let env = Env::new(tag);
    let codes = compile("tests/c/codes.c", &env.dir);
    let log = short_log(&env.dir, 60.0);
    let bytes = std::fs::read(&log).expect("log");
    let (records, report) = msgs::navlog::read_all(&bytes);
    assert!(report.is_clean(), "{report}");
    let fed = feed_file(&records, &env.dir.join("flight.feed"));
    let aids: Vec<AidKind> = AidKind::ALL
        .into_iter()
        .filter(|k| {
            records
                .iter()
                .any(|r| matches!(r, Record::Aid(a) if a.kind() == *k))
        })
        .collect();
    assert!(aids.len() >= 3, "{aids:?}");

    let mut daemon = env.start_daemon("daemon", None);
    let rec_path = env.dir.join("recorded.navlog");
    let mut recorder = env.start_recorder(&rec_path);
    let flight = env.dir.join("flight.feed");
    let mut c = match driver {
        Driver::C => env
            .command_for(&compile("tests/c/feed.c", &env.dir), "feed")
            .arg(&env.cfg.prefix)
            .arg(&flight)
            .arg("15")
            .spawn()
            .expect("feed"),
        Driver::Python => env
            .command_for(&python(), "feed")
            .current_dir(repo("examples/python"))
            .arg("publisher.py")
            .args(["--prefix", &env.cfg.prefix, "--speed", "15", "--feed"])
            .arg(&flight)
            .spawn()
            .expect("publisher.py"),
    };
    // A second C publisher on the IMU while the flight flies (once the
    // daemon has taken the driver's first IMU samples).
    status_until(&env, Duration::from_secs(30), |s| s.streams[0].accepted > 0);
    run_codes(&env, &codes, "second", None);
    assert_eq!(
        wait(&mut c, Duration::from_secs(120)),
        Some(0),
        "feed: {}",
        env.read("feed.err")
    );
    let printed = env.read("feed.out");
    eprintln!("{printed}");
    assert!(
        printed.lines().all(|l| l.contains(" lost=0 refused=0")),
        "{printed}"
    );
    let status = status_until(&env, Duration::from_secs(10), |s| {
        s.streams[0].refused_publisher >= 200
    });
    assert_eq!(status.streams[0].refused_publisher, 200, "{status:?}");
    assert_eq!(terminate(&mut daemon, Duration::from_secs(20)), Some(0));
    assert_eq!(terminate(&mut recorder, Duration::from_secs(20)), Some(0));

    let recording = std::fs::read(&rec_path).expect("recording");
    let (rec, report) = msgs::navlog::read_all(&recording);
    assert!(report.is_clean(), "{report}");
    let live: Vec<Solution> = rec
        .iter()
        .filter_map(|r| match r {
            Record::Solution(s) => Some(**s),
            _ => None,
        })
        .collect();
    // batch: the same session, the daemon's file and the log's header.
    let file = ConfigFile::load(&env.dir.join("nav.toml")).expect("config");
    let eff = effective(
        &file,
        msgs::navlog::header_metadata(&records),
        &CliOverrides::default(),
    )
    .expect("settings");
    let (collect, _) = session::navigate(&records, eff.session());
    let batch = collect.solutions;
    let by_t: std::collections::HashMap<u64, &Solution> =
        batch.iter().map(|s| (s.t_ns, s)).collect();
    // The second publisher's flag is the live run's alone: cleared before
    // the comparison (batch had no second publisher).
    let second_flag = msgs::solution_flags::SECOND_PUBLISHER;
    let flagged = live.iter().filter(|s| s.flags & second_flag != 0).count();
    let differing = live
        .iter()
        .filter(|s| {
            let mut s = **s;
            s.flags &= !second_flag;
            by_t.get(&s.t_ns).is_none_or(|b| **b != s)
        })
        .count();
    eprintln!(
        "{driver:?} driver: {fed} records of imu, init and {aids:?}; {} of {} solutions recorded, {differing} differ from batch, {flagged} flagged SECOND_PUBLISHER",
        live.len(),
        batch.len()
    );
    assert_eq!(
        differing, 0,
        "the {driver:?}-fed live run differs from batch"
    );
    assert!(flagged > 0, "no solution flagged SECOND_PUBLISHER");
    assert!(
        live.len() * 100 >= batch.len() * 99,
        "the recorder lost more than 1 %: {} of {}",
        live.len(),
        batch.len()
    );
}

#[test]
fn every_code_is_provoked_named_and_a_full_subscriber_never_blocks() {
    let env = Env::new("ccodes");
    let codes = compile("tests/c/codes.c", &env.dir);
    // A squatter: `<prefix>/cns` created with another payload type.
    let node = polarnav_ipc::node(&env.cfg, "squatter").expect("node");
    let _squat =
        polarnav_ipc::pubsub_service::<BaroSample>(&node, &env.cfg, Topic::Aid(AidKind::Cns))
            .expect("squatted service");
    let out = run_codes(&env, &codes, "errors", None);
    eprintln!("{out}");
    for name in [
        "PN_E_NULL",
        "PN_E_BAD_PREFIX",
        "PN_E_UNKNOWN_STREAM",
        "PN_E_INCOMPATIBLE_SERVICE",
        "PN_OK",
        "PN_W_SECOND_PUBLISHER",
        "PN_E_NOT_FINITE",
        "PN_E_STAMP_NOT_INCREASING",
        "PN_E_WRONG_STREAM",
    ] {
        assert!(
            out.contains(&format!("{name} ok")),
            "{name} not provoked:\n{out}"
        );
    }
    assert!(out.contains("imu.d_theta_rad is not finite"), "{out}");

    // No shared memory where POLARNAV_IOX_ROOT points (a file).
    let not_a_dir = env.dir.join("not-a-directory");
    std::fs::write(&not_a_dir, "").expect("file");
    let out = run_codes(
        &env,
        &codes,
        "transport",
        Some(("POLARNAV_IOX_ROOT", &not_a_dir)),
    );
    assert!(out.contains("PN_E_TRANSPORT ok"), "{out}");

    // A subscriber that never reads (a stopped daemon's): 20 000 samples
    // go out without blocking, all but a buffer's worth counted lost.
    let sub = polarnav_ipc::TopicSubscriber::<ImuSample>::new(&node, &env.cfg, Topic::Imu)
        .expect("subscriber");
    let t0 = Instant::now();
    let out = run_codes(&env, &codes, "stalled", None);
    eprintln!("{out} (process {:.2} s)", t0.elapsed().as_secs_f64());
    let field = |k: &str| -> u64 {
        out.split_whitespace()
            .find_map(|w| w.strip_prefix(k))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {k} in {out}"))
    };
    let buffer = polarnav_ipc::qos(Topic::Imu).buffer as u64;
    assert_eq!(field("sent="), 20_000);
    assert_eq!(field("lost="), 20_000 - buffer, "{out}");
    // Bounded: no wait on the full buffer (the 20 000 sends take
    // milliseconds; a send that waited 1 ms each would take 20 s).
    let seconds: f64 = out
        .split_whitespace()
        .find_map(|w| w.strip_prefix("seconds="))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no seconds in {out}"));
    assert!(seconds < 5.0, "{out}");
    // What the buffer held went with the publisher's process (iceoryx2
    // 0.10 keeps a sample of a publisher that is gone for no subscriber it
    // had not connected to): the subscriber, which read nothing, holds
    // at most a buffer's worth.
    let mut received = 0u64;
    sub.drain(|_: ImuSample| received += 1).expect("drain");
    assert!(received <= buffer, "{received}");
}
