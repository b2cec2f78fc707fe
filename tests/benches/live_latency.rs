//! Benchmark (not a test) of the live service over iceoryx2: IMU-publish →
//! solution-receive latency at 1 kHz, cycle overruns over a soak, pacing of
//! the publisher against absolute deadlines, and the daemon's RSS.
//!
//! In the same run, first, the transport's floor: the same measurement
//! against a bare echo process (this binary with `--echo`) that waits on a
//! WaitSet for the same IMU service and publishes a `Solution` on the same
//! kind of service for each sample, with the same scheduling. The daemon's
//! latency is printed as a ratio to it.
//!
//! `cargo build --release --bins && cargo bench -p polarnav-tests --bench live_latency [-- SECONDS]`
//! (default 60 s; the soak is 600).

use msgs::AidKind;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use msgs::service::Topic;
use msgs::{BaroSample, CnsFix, ImuSample, InitState, Solution, Status};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic, isa};
use polarnav::frames;
use polarnav_ipc::{TopicPublisher, TopicSubscriber, TransportConfig};

fn percentile(v: &mut [u64], q: f64) -> f64 {
    v.sort_unstable();
    v.get(((v.len().max(1) - 1) as f64 * q).round() as usize)
        .map_or(f64::NAN, |x| *x as f64 * 1e-3)
}

/// The echo process of the floor measurement: per IMU sample, one solution
/// with its time stamp, woken like the daemon (listener + interval tick).
fn echo() {
    use iceoryx2::prelude::*;
    let cfg = TransportConfig::new(&std::env::var("POLARNAV_ECHO_PREFIX").expect("prefix"));
    let node = polarnav_ipc::node(&cfg, "bench-echo").expect("node");
    let sub = TopicSubscriber::<ImuSample>::new(&node, &cfg, Topic::Imu).expect("imu");
    let publ = TopicPublisher::<Solution>::new(&node, &cfg, Topic::Solution).expect("solution");
    let ws = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .expect("waitset");
    let _guard = ws.attach_notification(sub.listener()).expect("attach");
    let _tick = ws.attach_interval(Duration::from_millis(1)).expect("tick");
    let mut done = false;
    while !done {
        if ws
            .wait_and_process_once(|_| CallbackProgression::Continue)
            .is_err()
        {
            break;
        }
        sub.clear_events();
        sub.drain(|x| {
            done |= x.seq == u64::MAX;
            publ.publish(&Solution {
                t_ns: x.t_ns,
                seq: x.seq,
                ..Default::default()
            })
            .expect("publish");
        })
        .expect("drain");
    }
}

/// IMU-publish → echo-receive latencies (ns) over `seconds` at 1 kHz.
fn floor(seconds: f64) -> Vec<u64> {
    let cfg = TransportConfig::isolated("floor");
    let exe = std::env::current_exe().expect("exe");
    let (mut cmd, _) = polarnav_tests::daemon_command(&exe);
    let mut child = cmd
        .arg("--echo")
        .env("POLARNAV_ECHO_PREFIX", &cfg.prefix)
        .env(
            "POLARNAV_IOX_PREFIX",
            cfg.iox_prefix.as_deref().expect("isolated"),
        )
        .env(
            "POLARNAV_IOX_ROOT",
            cfg.iox_root.as_ref().expect("isolated"),
        )
        .stdin(Stdio::null())
        .spawn()
        .expect("echo");
    let node = polarnav_ipc::node(&cfg, "bench-floor").expect("node");
    let imu = TopicPublisher::<ImuSample>::new(&node, &cfg, Topic::Imu).expect("imu");
    let sol = TopicSubscriber::<Solution>::new(&node, &cfg, Topic::Solution).expect("solution");
    let t0 = Instant::now();
    while imu.publish(&ImuSample::default()).expect("probe") == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "echo did not subscribe"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(100));
    sol.drain(|_| {}).expect("drain");
    let n = (seconds * 1000.0) as u64;
    let mut sent_at: Vec<Option<Instant>> = vec![None; n as usize + 2];
    let mut latency_ns = Vec::with_capacity(n as usize);
    let start = Instant::now() + Duration::from_millis(50);
    let drain = |latency_ns: &mut Vec<u64>, sent_at: &[Option<Instant>]| {
        sol.drain(|s| {
            if let Some(Some(t)) = sent_at.get(s.seq as usize) {
                latency_ns.push(t.elapsed().as_nanos() as u64);
            }
        })
        .expect("drain");
    };
    for k in 1..=n {
        let deadline = start + Duration::from_micros(k * 1000);
        while Instant::now() < deadline {
            drain(&mut latency_ns, &sent_at);
            std::hint::spin_loop();
        }
        sent_at[k as usize] = Some(Instant::now());
        imu.publish(&ImuSample {
            t_ns: k * 1_000_000,
            seq: k,
            dt_s: 0.001,
            ..Default::default()
        })
        .expect("imu");
    }
    let settle = Instant::now();
    while settle.elapsed() < Duration::from_millis(200) {
        drain(&mut latency_ns, &sent_at);
    }
    imu.publish(&ImuSample {
        seq: u64::MAX,
        ..Default::default()
    })
    .expect("stop");
    let t0 = Instant::now();
    while child.try_wait().expect("wait").is_none() && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let _ = child.kill();
    let _ = child.wait();
    drop((imu, sol, node));
    polarnav_ipc::remove_isolated(&cfg);
    latency_ns
}

fn main() {
    if std::env::args().any(|a| a == "--echo") {
        echo();
        return;
    }
    let seconds: f64 = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(60.0);
    let exe = std::env::current_exe().expect("exe");
    let daemon_bin = exe
        .parent()
        .and_then(std::path::Path::parent)
        .expect("target")
        .join("nav-daemon");
    assert!(
        daemon_bin.exists(),
        "{} missing: run cargo build --release --bins first",
        daemon_bin.display()
    );
    // The transport's floor first, then the daemon, in the same run.
    let floor_s = seconds.min(20.0);
    let mut floor_ns = floor(floor_s);
    let floor_p50 = percentile(&mut floor_ns, 0.5);
    let floor_p99 = percentile(&mut floor_ns, 0.99);
    let cfg = TransportConfig::isolated("bench");
    let dir = std::env::temp_dir().join(format!("polarnav-bench-live-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let cfg_path = dir.join("nav.toml");
    std::fs::write(
        &cfg_path,
        format!(
            "prefix = \"{}\"\n[live]\nimu_rate_hz = 1000.0\n",
            cfg.prefix
        ),
    )
    .expect("config");
    let (mut cmd, rt) = polarnav_tests::daemon_command(&daemon_bin);
    eprintln!(
        "daemon scheduling: {}",
        if rt {
            "SCHED_FIFO 50"
        } else {
            "SCHED_OTHER (chrt not permitted)"
        }
    );
    let mut daemon = cmd
        .arg("--config")
        .arg(&cfg_path)
        .env(
            "POLARNAV_IOX_PREFIX",
            cfg.iox_prefix.as_deref().expect("isolated"),
        )
        .env(
            "POLARNAV_IOX_ROOT",
            cfg.iox_root.as_ref().expect("isolated"),
        )
        .env("RUST_LOG", "warn")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(dir.join("daemon.err")).expect("log"))
        .spawn()
        .expect("daemon");

    let node = polarnav_ipc::node(&cfg, "bench").expect("node");
    let imu = TopicPublisher::<ImuSample>::new(&node, &cfg, Topic::Imu).expect("imu");
    let cns = TopicPublisher::<CnsFix>::new(&node, &cfg, Topic::Aid(AidKind::Cns)).expect("cns");
    let baro =
        TopicPublisher::<BaroSample>::new(&node, &cfg, Topic::Aid(AidKind::Baro)).expect("baro");
    let init_pub = TopicPublisher::<InitState>::new(&node, &cfg, Topic::Init).expect("init");
    let sol = TopicSubscriber::<Solution>::new(&node, &cfg, Topic::Solution).expect("solution");
    let status = TopicSubscriber::<Status>::new(&node, &cfg, Topic::Status).expect("status");
    // Wait (bounded) for the daemon's subscribers.
    let t0 = Instant::now();
    while imu.publish(&ImuSample::default()).expect("probe") == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "daemon did not subscribe"
        );
        std::thread::sleep(Duration::from_millis(20));
    }

    // A stationary vehicle at 75° N with exact 1 kHz increments; CNS 1 Hz, baro 10 Hz.
    let geo = Geodetic::from_deg(75.0, 10.0, 200.0);
    let r = earth::geodetic_to_ecef(&geo);
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let q = UnitQuaternion::from_matrix(&c_e_g.transpose());
    let init = InitState {
        r_e_m: r.into(),
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_pos_h_m: 10.0,
        sigma_pos_v_m: 10.0,
        sigma_vel_h_mps: 0.1,
        sigma_vel_v_mps: 0.1,
        sigma_tilt_rad: 3e-4,
        sigma_heading_rad: 1e-3,
        ..Default::default()
    };
    // Until the daemon's init subscriber is connected (bounded).
    let t0 = Instant::now();
    while init_pub.publish(&init).expect("init") == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "daemon did not subscribe to init"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let dt = 0.001;
    let w = c_e_g * earth::omega_ie_e() * dt;
    let f = Vector3::new(0.0, 0.0, earth::normal_gravity(geo.lat_rad, geo.h_m)) * dt;
    let p = isa::pressure(isa::geopotential_from_geometric(geo.h_m));

    let n = (seconds * 1000.0) as u64;
    let mut sent_at: Vec<Option<Instant>> = vec![None; n as usize + 2];
    let mut latency_ns: Vec<u64> = Vec::with_capacity(n as usize);
    let mut lateness_ns: Vec<u64> = Vec::with_capacity(n as usize);
    let mut rss_kb = Vec::new();
    // The daemon's samples leave with its publisher: keep the newest status while it runs.
    let mut last_status: Option<Status> = None;
    let start = Instant::now() + Duration::from_millis(50);
    let drain = |latency_ns: &mut Vec<u64>, sent_at: &[Option<Instant>]| {
        sol.drain(|s| {
            let k = (s.t_ns / 1_000_000) as usize;
            if let Some(Some(t)) = sent_at.get(k) {
                latency_ns.push(t.elapsed().as_nanos() as u64);
            }
        })
        .expect("drain");
    };
    for k in 1..=n {
        let deadline = start + Duration::from_micros(k * 1000);
        while Instant::now() < deadline {
            drain(&mut latency_ns, &sent_at);
            std::hint::spin_loop();
        }
        let t_ns = k * 1_000_000;
        if k % 100 == 0 {
            baro.publish(&BaroSample {
                t_ns,
                seq: k / 100,
                pressure_pa: p,
                temperature_k: 250.0,
                sigma_m: 10.0,
            })
            .expect("baro");
        }
        if k % 1000 == 0 {
            cns.publish(&CnsFix {
                t_ns,
                seq: k / 1000,
                lat_rad: geo.lat_rad,
                lon_rad: geo.lon_rad,
                sigma_h_m: 20.0,
            })
            .expect("cns");
            status.drain(|s| last_status = Some(s)).expect("status");
            if let Some(v) = std::fs::read_to_string(format!("/proc/{}/status", daemon.id()))
                .ok()
                .and_then(|s| {
                    s.lines()
                        .find(|l| l.starts_with("VmRSS:"))
                        .and_then(|l| l.split_whitespace().nth(1))
                        .and_then(|v| v.parse::<u64>().ok())
                })
            {
                rss_kb.push(v);
            }
        }
        lateness_ns.push(deadline.elapsed().as_nanos() as u64);
        sent_at[k as usize] = Some(Instant::now());
        imu.publish(&ImuSample {
            t_ns,
            seq: k,
            dt_s: dt,
            d_theta_rad: w.into(),
            d_v_mps: f.into(),
        })
        .expect("imu");
    }
    let settle = Instant::now();
    while settle.elapsed() < Duration::from_millis(1200) {
        drain(&mut latency_ns, &sent_at);
        status.drain(|s| last_status = Some(s)).expect("status");
    }
    let _ = Command::new("kill")
        .arg("-TERM")
        .arg(daemon.id().to_string())
        .status();
    let exit = daemon.wait().expect("daemon exit");
    let st = last_status.expect("a status from the running daemon");

    let received = latency_ns.len();
    if received == 0 {
        eprintln!(
            "no solution received; daemon log:\n{}",
            std::fs::read_to_string(dir.join("daemon.err")).unwrap_or_default()
        );
    }
    println!(
        "live service over iceoryx2, {seconds:.0} s at 1 kHz IMU (CNS 1 Hz, baro 10 Hz), daemon exit {:?}:",
        exit.code()
    );
    println!(
        "  IMU-publish -> solution-receive latency: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs ({received} of {n} solutions)",
        percentile(&mut latency_ns, 0.5),
        percentile(&mut latency_ns, 0.99),
        percentile(&mut latency_ns, 1.0)
    );
    let (p50, p99) = (
        percentile(&mut latency_ns, 0.5),
        percentile(&mut latency_ns, 0.99),
    );
    println!(
        "  transport floor (bare echo process, same services and WaitSet wake-up, {floor_s:.0} s): p50 {floor_p50:.1} µs, p99 {floor_p99:.1} µs ({} round trips)",
        floor_ns.len()
    );
    println!(
        "  daemon / floor: p50 {:.2}x, p99 {:.2}x (target p99 <= 1.5x)",
        p50 / floor_p50,
        p99 / floor_p99
    );
    println!(
        "  daemon cycles {}, overruns {} of which {} with the cycle's own CPU time over the period, the rest preemptions (cycle time mean {:.1} µs, max {:.1} µs in the last status period)",
        st.cycles,
        st.overruns,
        st.overruns_cpu,
        st.cycle_time_mean_ns as f64 * 1e-3,
        st.cycle_time_max_ns as f64 * 1e-3
    );
    println!(
        "  publisher pacing lateness: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        percentile(&mut lateness_ns, 0.5),
        percentile(&mut lateness_ns, 0.99),
        percentile(&mut lateness_ns, 1.0)
    );
    println!(
        "  daemon RSS: first {} kB, last {} kB, max {} kB",
        rss_kb.first().copied().unwrap_or(0),
        rss_kb.last().copied().unwrap_or(0),
        rss_kb.iter().copied().max().unwrap_or(0)
    );
    drop((imu, cns, baro, init_pub, sol, status, node));
    polarnav_ipc::remove_isolated(&cfg);
    let _ = std::fs::remove_dir_all(&dir);
}
