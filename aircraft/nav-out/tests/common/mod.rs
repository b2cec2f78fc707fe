//! What the bridges' tests share: the Python decoders (PyPI pymavlink and
//! pynmeagps in a virtual environment), a synthetic polar flight published
//! over iceoryx2 as the daemon would, and running the bridge binaries.

#![allow(dead_code)]

use std::f64::consts::{FRAC_PI_2, PI};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::time::{Duration, Instant, SystemTime};

use msgs::service::Topic;
use msgs::{Solution, Status, solution_flags};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use nav_out::geo;
use polarnav_ipc::{TopicPublisher, TransportConfig};

/// The Python packages of the independent decoders, pinned.
pub const PYTHON_PACKAGES: [&str; 2] = ["pymavlink==2.4.50", "pynmeagps==1.1.8"];

/// A Python interpreter with [`PYTHON_PACKAGES`]: a virtual environment in
/// the target directory, created once (PyPI is needed the first time)
/// under a file lock, so that test binaries running at once share it.
pub fn python() -> PathBuf {
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join("python-nav-out");
    let py = venv.join("bin/python3");
    let check = |py: &Path| {
        Command::new(py)
            .args([
                "-c",
                "import importlib.metadata as m, sys\nfor p in sys.argv[1:]:\n    n, v = p.split('==')\n    assert m.version(n) == v, p",
            ])
            .args(PYTHON_PACKAGES)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    std::fs::create_dir_all(env!("CARGO_TARGET_TMPDIR")).expect("target tmp dir");
    let lock = std::fs::File::create(venv.with_extension("lock")).expect("venv lock file");
    lock.lock().expect("venv lock");
    if !check(&py) {
        let ok = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status()
            .is_ok_and(|s| s.success())
            && Command::new(&py)
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                ])
                .args(PYTHON_PACKAGES)
                .status()
                .is_ok_and(|s| s.success());
        assert!(
            ok && check(&py),
            "could not provide Python with {PYTHON_PACKAGES:?} (python3 -m venv {} && pip install ...)",
            venv.display()
        );
    }
    drop(lock);
    py
}

/// The decoder process (`tests/python/receive.py`).
pub struct Receiver {
    child: Child,
    stdin: Option<ChildStdin>,
    pub port: u16,
    pub out: PathBuf,
}

impl Receiver {
    /// Starts the decoder of `kind` ("mavlink" or "nmea"); `serial` makes it
    /// serve a pseudo-terminal behind that link instead of UDP.
    pub fn start(kind: &str, out: PathBuf, serial: Option<&Path>) -> Self {
        let mut c = Command::new(python());
        c.arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/python/receive.py"))
            .arg(kind)
            .arg(&out);
        if let Some(link) = serial {
            c.arg("--serial").arg(link);
        }
        let mut child = c
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("python decoder");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("decoder's port");
        let port = line
            .trim()
            .strip_prefix("PORT ")
            .and_then(|p| p.parse().ok())
            .unwrap_or_else(|| panic!("decoder said {line:?}"));
        let stdin = child.stdin.take();
        Self {
            child,
            stdin,
            port,
            out,
        }
    }

    /// The decoder's process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Sends a command line to the decoder (CYCLE).
    pub fn say(&mut self, line: &str) {
        let s = self.stdin.as_mut().expect("decoder stdin");
        writeln!(s, "{line}").expect("write to decoder");
        s.flush().expect("flush");
    }

    /// Stops the decoder and reads what it decoded: the messages and the summary.
    pub fn finish(mut self) -> (Vec<serde_json::Value>, serde_json::Value) {
        drop(self.stdin.take());
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Some(st) = self.child.try_wait().expect("wait decoder") {
                assert!(st.success(), "decoder failed: {st}");
                break;
            }
            assert!(Instant::now() < deadline, "decoder did not finish");
            std::thread::sleep(Duration::from_millis(20));
        }
        let text = std::fs::read_to_string(&self.out).expect("decoder output");
        let mut msgs: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("json line"))
            .collect();
        let summary = msgs.pop().expect("summary")["summary"].clone();
        (msgs, summary)
    }
}

/// A test that fails before [`Receiver::finish`] leaves no decoder behind.
impl Drop for Receiver {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Wall-clock seconds since the Unix epoch (Python's `time.time()`).
pub fn wall() -> f64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .expect("clock")
        .as_secs_f64()
}

/// A pose of the synthetic flight.
#[derive(Debug, Clone, Copy)]
pub struct Pose {
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub h_m: f64,
    pub heading_rad: f64,
    pub speed_mps: f64,
    pub flags: u32,
}

/// One published solution and the phase it belongs to.
#[derive(Debug, Clone, Copy)]
pub struct Published {
    pub sol: Solution,
    pub phase: &'static str,
    /// Wall-clock time of publication (s).
    pub wall: f64,
}

/// The solution the daemon would publish at `pose`: ECEF position and
/// velocity, ENU velocity along the heading, body→ECEF attitude level at
/// that heading (body x right, y forward, z up), small σ.
pub fn solution(t_ns: u64, seq: u64, p: &Pose) -> Solution {
    let (sl, cl) = p.lat_rad.sin_cos();
    let (so, co) = p.lon_rad.sin_cos();
    let east = Vector3::new(-so, co, 0.0);
    let north = Vector3::new(-sl * co, -sl * so, cl);
    let up = Vector3::new(cl * co, cl * so, sl);
    let (sh, ch) = p.heading_rad.sin_cos();
    let fwd = east * sh + north * ch;
    let right = east * ch - north * sh;
    let c_b_e = Matrix3::from_columns(&[right, fwd, up]);
    let q = UnitQuaternion::from_matrix(&c_b_e);
    let v_e = fwd * p.speed_mps;
    Solution {
        t_ns,
        seq,
        lat_rad: p.lat_rad,
        lon_rad: p.lon_rad,
        h_m: p.h_m,
        r_e_m: geo::geodetic_to_ecef(p.lat_rad, p.lon_rad, p.h_m),
        v_e_mps: v_e.into(),
        v_enu_mps: [p.speed_mps * sh, p.speed_mps * ch, 0.0],
        v_nav_mps: [p.speed_mps * sh, p.speed_mps * ch, 0.0],
        q_b_e: [q.w, q.i, q.j, q.k],
        heading_rad: p.heading_rad,
        sigma_pos_enu_m: [3.0, 4.0, 6.0],
        sigma_vel_mps: [0.05, 0.05, 0.08],
        sigma_att_rad: [2e-4, 2e-4, 5e-4],
        flags: p.flags,
        ..Default::default()
    }
}

/// A segment of the flight: a phase name, a duration, and the pose at a
/// fraction u ∈ [0, 1) of it.
pub type Segment = (&'static str, f64, Box<dyn Fn(f64) -> Pose>);

const A: u32 = solution_flags::ALIGNED;

fn pose(lat_deg: f64, lon_deg: f64, heading_deg: f64, flags: u32) -> Pose {
    // Off the decimal grid by up to 5e-8° (half of MAVLink's 1e-7°), so
    // the encodings' rounding is exercised; the exact poles and meridian
    // ±180° are published by the hold segments.
    let j = ((lat_deg + lon_deg) * 1e4).sin() * 4.9e-8;
    let lat_deg = if lat_deg.abs() < 89.999 {
        lat_deg + j
    } else {
        lat_deg
    };
    Pose {
        lat_rad: lat_deg.to_radians(),
        lon_rad: (lon_deg - j).to_radians(),
        h_m: 18_000.0,
        heading_rad: heading_deg.to_radians(),
        speed_mps: 220.0,
        flags,
    }
}

/// A polar flight: not aligned at first; over the North Pole along
/// meridians 30° E / 150° W, holding the exact pole (latitude π/2) for
/// 0.4 s; east across the antimeridian at 75° N, holding λ = +π and λ = −π;
/// coasting; over the South Pole (latitude −π/2 held); then level at 70° N.
/// Positions move faster than an aircraft would, to cross each singular
/// place within seconds; the bridges do not care.
pub fn polar_flight() -> Vec<Segment> {
    vec![
        ("not_aligned", 1.5, Box::new(|_| pose(80.0, 10.0, 0.0, 0))),
        (
            "north_pole",
            1.5,
            Box::new(|u| pose(89.97 + 0.03 * u, 30.0, 0.0, A)),
        ),
        (
            "north_pole",
            0.4,
            Box::new(|_| Pose {
                lat_rad: FRAC_PI_2,
                ..pose(90.0, 30.0, 0.0, A)
            }),
        ),
        (
            "north_pole",
            1.5,
            Box::new(|u| pose(90.0 - 0.03 * (u + 0.01), -150.0, 180.0, A)),
        ),
        (
            "antimeridian",
            1.0,
            Box::new(|u| pose(75.0, 179.98 + 0.02 * u, 90.0, A)),
        ),
        (
            "antimeridian",
            0.4,
            Box::new(|_| Pose {
                lon_rad: PI,
                ..pose(75.0, 180.0, 90.0, A)
            }),
        ),
        (
            "antimeridian",
            0.4,
            Box::new(|_| Pose {
                lon_rad: -PI,
                ..pose(75.0, -180.0, 90.0, A)
            }),
        ),
        (
            "antimeridian",
            1.0,
            Box::new(|u| pose(75.0, -179.9999 + 0.02 * u, 90.0, A)),
        ),
        (
            "coasting",
            1.0,
            Box::new(|_| pose(75.0, -179.9, 90.0, A | solution_flags::COASTING)),
        ),
        (
            "south_pole",
            1.2,
            Box::new(|u| pose(-89.97 - 0.03 * u, 60.0, 180.0, A)),
        ),
        (
            "south_pole",
            0.4,
            Box::new(|_| Pose {
                lat_rad: -FRAC_PI_2,
                ..pose(-90.0, 60.0, 180.0, A)
            }),
        ),
        (
            "south_pole",
            1.2,
            Box::new(|u| pose(-90.0 + 0.03 * (u + 0.01), -120.0, 0.0, A)),
        ),
    ]
}

/// The daemon's side: publishers of solution and status on `cfg`.
pub struct FakeDaemon {
    solution: Option<TopicPublisher<Solution>>,
    status: Option<TopicPublisher<Status>>,
    node: Option<iceoryx2::node::Node<iceoryx2::prelude::ipc::Service>>,
    seq: u64,
    status_seq: u64,
    t_ns: u64,
    last_status: Option<Instant>,
    pub published: Vec<Published>,
}

/// Solution period of the synthetic flight (50 Hz).
pub const PERIOD: Duration = Duration::from_millis(20);

impl FakeDaemon {
    pub fn start(cfg: &TransportConfig) -> Self {
        let node = polarnav_ipc::node(cfg, "nav-daemon").expect("node");
        let solution =
            TopicPublisher::new(&node, cfg, Topic::Solution).expect("solution publisher");
        let status = TopicPublisher::new(&node, cfg, Topic::Status).expect("status publisher");
        Self {
            solution: Some(solution),
            status: Some(status),
            node: Some(node),
            seq: 0,
            status_seq: 0,
            t_ns: 1_000_000_000,
            last_status: None,
            published: Vec::new(),
        }
    }

    /// Publishes a status at 1 Hz of the wall clock.
    pub fn tick_status(&mut self) {
        let now = Instant::now();
        if self
            .last_status
            .is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1))
        {
            self.last_status = Some(now);
            self.status_seq += 1;
            let st = Status {
                t_ns: self.t_ns,
                seq: self.status_seq,
                ..Default::default()
            };
            self.status
                .as_ref()
                .expect("status")
                .publish(&st)
                .expect("publish status");
        }
    }

    /// Flies `segments` in real time at 50 Hz.
    pub fn fly(&mut self, segments: &[Segment]) {
        for (phase, dur, f) in segments {
            let n = (dur / PERIOD.as_secs_f64()).round() as usize;
            let t0 = Instant::now();
            for k in 0..n {
                let at = t0 + PERIOD * k as u32;
                if let Some(d) = at.checked_duration_since(Instant::now()) {
                    std::thread::sleep(d);
                }
                let u = k as f64 / n as f64;
                self.seq += 1;
                self.t_ns += PERIOD.as_nanos() as u64;
                let sol = solution(self.t_ns, self.seq, &f(u));
                self.solution
                    .as_ref()
                    .expect("solution")
                    .publish(&sol)
                    .expect("publish");
                self.published.push(Published {
                    sol,
                    phase,
                    wall: wall(),
                });
                self.tick_status();
            }
        }
    }

    /// Publishes no solution for `d`, status going on; sensor time runs on.
    pub fn stall(&mut self, d: Duration) {
        let t0 = Instant::now();
        while t0.elapsed() < d {
            self.tick_status();
            std::thread::sleep(PERIOD);
        }
        self.t_ns += d.as_nanos() as u64;
    }

    /// A clean stop: every port and the node go away.
    pub fn stop(&mut self) {
        self.solution = None;
        self.status = None;
        self.node = None;
    }
}

/// A bridge process, killed when dropped unless [`terminate`] stopped it:
/// a test that fails before it stops its bridge leaves no process behind
/// (its iceoryx2 root and shared memory go with `IsolatedCleanup`, bound
/// before the bridge and so dropped after it).
pub struct Bridge(Option<Child>);

impl Drop for Bridge {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Bridge {
    /// The process id (while it runs).
    pub fn id(&self) -> Option<u32> {
        self.0.as_ref().map(Child::id)
    }
}

/// A bridge binary running with its settings file and iceoryx2 isolation.
pub fn spawn_bridge(bin: &str, config: &Path, cfg: &TransportConfig) -> Bridge {
    let child = Command::new(bin)
        .arg("--config")
        .arg(config)
        .arg("--prefix")
        .arg(&cfg.prefix)
        .env(
            "POLARNAV_IOX_PREFIX",
            cfg.iox_prefix.as_deref().expect("isolated"),
        )
        .env(
            "POLARNAV_IOX_ROOT",
            cfg.iox_root.as_deref().expect("isolated"),
        )
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("bridge");
    Bridge(Some(child))
}

/// SIGTERM, then the exit status and standard error (with a deadline).
pub fn terminate(mut bridge: Bridge) -> (std::process::ExitStatus, String) {
    let mut child = bridge.0.take().expect("a running bridge");
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let deadline = Instant::now() + Duration::from_secs(10);
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the bridge did not stop within 10 s of SIGTERM");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        use std::io::Read;
        let _ = e.read_to_string(&mut err);
    }
    (status, err)
}

/// A scratch directory for one test.
pub fn scratch(tag: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("nav-out-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// Longitude difference wrapped onto [-180°, 180°).
pub fn dlon_deg(a: f64, b: f64) -> f64 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}
