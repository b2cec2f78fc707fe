//! Resident memory of `sensor-replay play` (not a test): writes a synthetic
//! navlog of more than 1 GB (IMU at 200 Hz, baro at 10 Hz, SRS and CNS at
//! 1 Hz; `PLAY_GB=X` to change the size) and one a tenth of its length,
//! replays each as fast as it goes (`--speed 1e6`, nobody subscribed) on
//! an isolated iceoryx2 prefix, and prints each replay's peak resident set
//! (`/usr/bin/time -f %M` where present, else the largest VmHWM seen while
//! it runs) and time, against the bound `play` keeps whatever the log's
//! length (PLAY_RSS_BOUND_MB). `BASE_BIN=path/to/sensor-replay` replays the
//! same logs with another build too (e.g. one that held the log in memory).
//!
//! `cargo build --release --bins && cargo bench -p polarnav-tests --bench play_memory`

use std::io::{BufWriter, Write as _};
use std::path::Path;
use std::time::{Duration, Instant};

use msgs::navlog::{Header, NavlogWriter, Record};
use msgs::{BaroSample, CnsFix, ImuSample, InitState, SrsSample};
use polarnav_tests::bin;
use polarnav_tests::harness::Env;

/// The peak resident set `play` stays under (MB), whatever the log's length.
const PLAY_RSS_BOUND_MB: f64 = 32.0;

/// Writes `seconds` of a 200 Hz flight; its size in bytes.
fn write_log(path: &Path, seconds: u64) -> u64 {
    let f = BufWriter::with_capacity(1 << 20, std::fs::File::create(path).expect("create"));
    let mut w =
        NavlogWriter::new(f, Header::new("play_memory", "synthetic", 0, "")).expect("header");
    w.write(&Record::Init(InitState {
        t_ns: 0,
        r_e_m: [1.0e6, 0.0, 6.2e6],
        q_b_e: [1.0, 0.0, 0.0, 0.0],
        ..Default::default()
    }))
    .expect("init");
    let mut srs = SrsSample {
        count: 4,
        ..Default::default()
    };
    for k in 0..seconds * 200 {
        let t_ns = k * 5_000_000;
        w.write(&Record::Imu(ImuSample {
            t_ns,
            seq: k,
            dt_s: 0.005,
            d_theta_rad: [1e-6 * (k as f64 * 1e-3).sin(), -2e-6, 3e-9],
            d_v_mps: [1e-3, 2e-4, 0.049],
        }))
        .expect("imu");
        if k % 20 == 0 {
            w.write(&Record::aid(BaroSample {
                t_ns,
                seq: k / 20,
                pressure_pa: 7565.0 + (k as f64 * 1e-4).sin(),
                temperature_k: 216.65,
                sigma_m: 10.0,
            }))
            .expect("baro");
        }
        if k % 200 == 0 {
            srs.t_ns = t_ns;
            srs.seq = k / 200;
            w.write(&Record::aid(srs)).expect("srs");
            w.write(&Record::aid(CnsFix {
                t_ns,
                seq: k / 200,
                lat_rad: 1.5,
                lon_rad: 0.1,
                sigma_h_m: 20.0,
            }))
            .expect("cns");
        }
    }
    w.finish().expect("finish").flush().expect("flush");
    std::fs::metadata(path).expect("size").len()
}

fn vm_hwm_kb(pid: u32) -> Option<u64> {
    std::fs::read_to_string(format!("/proc/{pid}/status"))
        .ok()?
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// Replays `log` with `program`; (peak RSS MB, how it was measured, seconds, play's summary).
fn replay(env: &Env, program: &Path, log: &Path, tag: &str) -> (f64, &'static str, f64, String) {
    let time = Path::new("/usr/bin/time");
    let mut c = if time.exists() {
        let mut c = env.command_for(time, tag);
        c.args(["-f", "max_rss_kb %M"]).arg(program);
        c
    } else {
        env.command_for(program, tag)
    };
    c.arg("play")
        .arg(log)
        .args(["--speed", "1e6", "--prefix", &env.cfg.prefix]);
    let t0 = Instant::now();
    let mut child = c.spawn().expect("play");
    let mut polled = 0;
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        // With /usr/bin/time the child is `time`: play is its child.
        let pid = child.id();
        let play_pid = std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children"))
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse().ok())
            .unwrap_or(pid);
        polled = polled.max(vm_hwm_kb(play_pid).unwrap_or(0));
        std::thread::sleep(Duration::from_millis(10));
    };
    let secs = t0.elapsed().as_secs_f64();
    let out = std::fs::read_to_string(env.dir.join(format!("{tag}.out"))).unwrap_or_default();
    let err = std::fs::read_to_string(env.dir.join(format!("{tag}.err"))).unwrap_or_default();
    assert!(status.success(), "play failed: {err}");
    let timed = err
        .lines()
        .find_map(|l| l.strip_prefix("max_rss_kb ")?.trim().parse::<u64>().ok());
    let (kb, how) = match timed {
        Some(kb) => (kb, "/usr/bin/time"),
        None => (polled, "VmHWM polled every 10 ms"),
    };
    (kb as f64 / 1024.0, how, secs, out.trim().to_owned())
}

fn main() {
    let gb: f64 = std::env::var("PLAY_GB")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1.1);
    let env = Env::new("play-memory");
    // About 83 bytes of log per IMU sample with the aids.
    let seconds = (gb * 1e9 / (200.0 * 83.0)).ceil() as u64;
    let logs = [
        ("short", env.dir.join("short.navlog"), seconds / 10),
        ("long", env.dir.join("long.navlog"), seconds),
    ];
    let mut programs = vec![("this build", bin("sensor-replay"))];
    if let Ok(b) = std::env::var("BASE_BIN") {
        programs.push(("BASE_BIN", b.into()));
    }
    let mut worst: f64 = 0.0;
    for (name, path, s) in &logs {
        let t = Instant::now();
        let size = write_log(path, *s);
        println!(
            "play_memory: {name} log {:.2} GB ({:.1} h at 200 Hz) written in {:.1} s",
            size as f64 / 1e9,
            *s as f64 / 3600.0,
            t.elapsed().as_secs_f64()
        );
        for (who, program) in &programs {
            let (mb, how, secs, summary) = replay(&env, program, path, &format!("{name}-play"));
            println!(
                "play_memory: {who}: {name} log: peak RSS {mb:.1} MB ({how}), {secs:.1} s; {}",
                summary.lines().last().unwrap_or("")
            );
            if *who == "this build" {
                worst = worst.max(mb);
            }
        }
    }
    println!(
        "play_memory: this build's largest peak {worst:.1} MB, bound {PLAY_RSS_BOUND_MB} MB: {}",
        if worst < PLAY_RSS_BOUND_MB {
            "under"
        } else {
            "OVER"
        }
    );
    assert!(worst < PLAY_RSS_BOUND_MB, "play held {worst:.1} MB");
}
