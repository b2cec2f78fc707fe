//! Helpers for the workspace-level integration tests in `tests/tests/`:
//! simulate in memory, run the navigator, compare with the truth or with
//! another run at the truth epochs.

use std::path::{Path, PathBuf};

use msgs::navlog::{Record, read_all};
use msgs::{InitState, TruthRecord};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use polarnav::earth;
use polarnav::frames;
use polarnav::integrity::{Test, Verdict};
use polarnav::navigator::{NavigatorConfig, SwitchEvent};
use polarnav::session::{Event, Input, Session, SessionSettings, Sink, Stream};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

pub mod harness;

/// A command running the `nav-daemon` binary `bin` as deployed
/// (systemd/nav-daemon.service: CPUSchedulingPolicy=fifo): under
/// `chrt -f 50` when this machine permits it. Returns the command and
/// whether it is real-time (for the benches' reports).
pub fn daemon_command(bin: &Path) -> (std::process::Command, bool) {
    use std::process::Command;
    let rt = Command::new("chrt")
        .args(["-f", "50", "true"])
        .status()
        .is_ok_and(|s| s.success());
    if rt {
        let mut c = Command::new("chrt");
        c.args(["-f", "50"]).arg(bin);
        (c, true)
    } else {
        (Command::new(bin), false)
    }
}

/// The workspace's binaries, in the guide's order (the generated CLI
/// reference and the guide's command tests name these).
pub const BINARIES: [&str; 5] = [
    "nav-daemon",
    "sensor-replay",
    "gnss-ubx",
    "nav-mavlink",
    "nav-nmea",
];

/// A binary of the workspace, built by `cargo test --workspace` beside the
/// test executables (`target/<profile>/NAME`).
pub fn bin(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable");
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("target directory");
    let p = dir.join(name);
    assert!(
        p.exists(),
        "{} is not built: run the workspace tests (cargo test --workspace)",
        p.display()
    );
    p
}

/// The Python packages the tests run against, pinned: the iceoryx2 binding
/// (the Python consumer), the reference MCAP reader with its protobuf
/// decoder, a WebSocket client for the Foxglove live view, pyubx2 (a
/// UBX implementation independent of gnss-ubx's, which makes its frames),
/// and the independent MAVLink and NMEA decoders of the bridges' output
/// (`tests/nav_out.rs`; nav-out's own tests pin the same two), and the
/// official Kubernetes client, whose models are the Job schema a
/// campaign's manifest is checked against, and the readers a campaign's
/// merged Parquet table is read with: pandas on pyarrow, and polars
/// (`tests/campaign.rs`).
pub const PYTHON_PACKAGES: [&str; 12] = [
    "iceoryx2==0.10.0",
    "mcap==1.6.0",
    "mcap-protobuf-support==0.6.0",
    "zstandard==0.25.0",
    "websockets==17.4",
    "pyubx2==1.4.0",
    "pymavlink==2.4.50",
    "pynmeagps==1.1.8",
    "kubernetes==37.0.2",
    "pandas==3.1.1",
    "pyarrow==26.0.1",
    "polars==2.1.0",
];

/// A Python interpreter with [`PYTHON_PACKAGES`]: a virtual environment in
/// the target directory, created once (PyPI is needed the first time) under
/// a file lock, so that test binaries running at the same time share it.
pub fn python() -> PathBuf {
    use std::process::{Command, Stdio};
    let venv = bin("nav-daemon")
        .parent()
        .expect("target dir")
        .join("python-tools");
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
    let lock_path = venv.with_extension("lock");
    let lock = std::fs::File::create(&lock_path).expect("python venv lock file");
    lock.lock().expect("python venv lock");
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
                    // Bytecode is compiled on first import, for the modules
                    // a test imports: compiling all of pandas, pyarrow,
                    // polars and kubernetes up front took 24 of 53 s.
                    "--no-compile",
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

/// Runs `tests/python/check_mcap.py` (the reference reader, PyPI `mcap`)
/// on `mcap`, against the solution CSV `csv` when given, requiring the
/// `require` topics; returns its summary (per-topic counts, solutions
/// checked). Fails the test with the reader's message.
pub fn check_mcap(mcap: &Path, csv: Option<&Path>, require: &[&str]) -> serde_json::Value {
    let mut c = std::process::Command::new(python());
    c.arg(repo("tests/python/check_mcap.py")).arg(mcap);
    if let Some(csv) = csv {
        c.arg(csv);
    }
    let out = c.arg("--require").args(require).output().expect("python");
    assert!(
        out.status.success(),
        "the reference reader refused {}: {}",
        mcap.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("check_mcap's summary")
}

/// Simulates the scenario `text` into the navlog file `path`.
pub fn simulate_file(text: &str, name: &str, path: &Path) {
    let s = Scenario::parse(text, name).expect("scenario");
    simulate(
        &s,
        text,
        SimOptions::default(),
        std::fs::File::create(path).expect("create"),
    )
    .expect("simulate");
}

/// Path of a file in the repository.
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A file of the project's shared data sets (`../shared/datasets`
/// beside this checkout); a test without it says so.
pub fn shared_dataset(rel: &str) -> PathBuf {
    let p = repo(&format!("../shared/datasets/{rel}"));
    assert!(
        p.exists(),
        "{} is missing: the tests read the project's shared data from ../shared, beside this \
         checkout (README, Quick start): clone or link it there",
        p.display()
    );
    p
}

/// The PSINS laser-gyro record of the project's shared data.
pub fn lasergyro() -> PathBuf {
    shared_dataset("psins-lasergyro/lasergyro.imu")
}

/// Simulates scenario text into navlog records.
pub fn simulate_records(text: &str, seed: u64) -> Vec<Record> {
    let s = Scenario::parse(text, "test scenario").expect("scenario");
    let mut buf = Vec::new();
    simulate(
        &s,
        text,
        SimOptions {
            seed,
            ..Default::default()
        },
        &mut buf,
    )
    .expect("simulate");
    let (records, report) = read_all(&buf);
    assert!(report.is_clean());
    records
}

/// The navigator state at one truth epoch.
#[derive(Debug, Clone, Copy)]
pub struct Snapshot {
    pub t_ns: u64,
    pub r_e: Vector3<f64>,
    pub v_e: Vector3<f64>,
    pub q_b_e: UnitQuaternion<f64>,
    pub cov_pos: Matrix3<f64>,
    pub cov_vel: Matrix3<f64>,
    pub cov_att: Matrix3<f64>,
    pub frame: u8,
    /// The solution flags, as the session publishes them (an aid's
    /// exclusion included).
    pub flags: u32,
    /// Levels fused from the accelerometers so far (paper 003 §4.5).
    pub levels_fused: u64,
}

/// One run: snapshots at every truth epoch, switches, aid accounting.
#[derive(Debug, Clone, Default)]
pub struct Run {
    pub snaps: Vec<Snapshot>,
    pub truth: Vec<TruthRecord>,
    pub switches: Vec<SwitchEvent>,
    pub fused: u64,
    pub rejected: u64,
    /// Every integrity test (an aid that is not autonomous): its time,
    /// test and decision.
    pub integrity: Vec<(u64, Test, Verdict)>,
    /// Each time an integrity test was lost (false) or regained (true).
    pub availability: Vec<(u64, bool)>,
    /// The final status.
    pub status: msgs::Status,
    /// The flight-state recognition's and the level compensation's counts
    /// at the end.
    pub level: polarnav::navigator::LevelCounters,
}

impl Run {
    /// The times of the exclusions and readmissions (ns).
    pub fn decisions(&self, verdict: Verdict) -> Vec<u64> {
        self.integrity
            .iter()
            .filter(|(_, _, v)| *v == verdict)
            .map(|(t, _, _)| *t)
            .collect()
    }
}

pub fn quat(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// Collects the frame switches and the refused IMU samples from the
/// session's events.
#[derive(Debug, Default)]
struct RunSink {
    switches: Vec<SwitchEvent>,
    rejected_imu: u64,
    integrity: Vec<(u64, Test, Verdict)>,
    availability: Vec<(u64, bool)>,
}

impl Sink for RunSink {
    fn solution(&mut self, _s: &msgs::Solution) {}
    fn event(&mut self, e: &Event) {
        match e {
            Event::Switch(sw) => self.switches.push(*sw),
            Event::Integrity {
                t_ns,
                test,
                verdict,
                ..
            } => self.integrity.push((*t_ns, *test, *verdict)),
            Event::IntegrityAvailability {
                t_ns, available, ..
            } => self.availability.push((*t_ns, *available)),
            Event::Rejected {
                stream: Stream::Imu,
                ..
            } => self.rejected_imu += 1,
            _ => {}
        }
    }
}

/// Runs the session over records, as `batch` and the daemon do; `init`
/// replaces the log's init records when given. Snapshots are taken at every
/// truth epoch that an IMU sample reached (after the aids stamped at it).
/// Panics if any IMU sample is refused (the logs of these tests are clean).
pub fn run(records: &[Record], cfg: &NavigatorConfig, init: Option<InitState>) -> Run {
    run_session(
        records,
        SessionSettings {
            navigator: cfg.clone(),
            ..Default::default()
        },
        init,
    )
}

/// [`run`] with a stationary alignment over the first `align_s` of IMU
/// data after the log's init record (`batch --align`).
pub fn run_aligned(records: &[Record], cfg: &NavigatorConfig, align_s: f64) -> Run {
    run_session(
        records,
        SessionSettings {
            navigator: cfg.clone(),
            align_s: Some(align_s),
            ..Default::default()
        },
        None,
    )
}

fn run_session(records: &[Record], settings: SessionSettings, init: Option<InitState>) -> Run {
    let mut session = Session::new(settings);
    let mut sink = RunSink::default();
    if let Some(i) = &init {
        session.push(Input::Init(i), &mut sink);
    }
    let mut out = Run::default();
    for rec in records {
        match rec {
            Record::Init(_) if init.is_some() => {}
            Record::Truth(t) => {
                // The aids stamped up to now are fused (as before a solution).
                session.flush(&mut sink);
                if let Some(nav) = session.navigator().filter(|n| n.t_ns() == t.t_ns)
                    && session.span_ns().0 < t.t_ns
                {
                    let ff = nav.state().frame_free();
                    let (cov_pos, cov_vel, cov_att) = nav.covariances_enu();
                    out.snaps.push(Snapshot {
                        t_ns: t.t_ns,
                        r_e: ff.r_e,
                        v_e: ff.v_e,
                        q_b_e: ff.q_b_e,
                        cov_pos,
                        cov_vel,
                        cov_att,
                        frame: nav.solution().frame,
                        flags: nav.solution().flags | session.integrity_flags(),
                        levels_fused: nav.level_counters().fused,
                    });
                    out.truth.push(*t);
                }
            }
            other => {
                if let Some(input) = Input::from_record(other) {
                    session.push(input, &mut sink);
                }
            }
        }
    }
    session.finish(&mut sink);
    if let Some(n) = session.navigator() {
        out.level = n.level_counters();
    }
    assert_eq!(
        sink.rejected_imu, 0,
        "an IMU sample of a clean log was refused"
    );
    let st = session.status();
    out.status = st;
    out.integrity = sink.integrity;
    out.availability = sink.availability;
    out.switches = sink.switches;
    out.fused = st.each_aid().map(|(_, c, _)| c.accepted).sum();
    out.rejected = st
        .each_aid()
        .map(|(_, c, _)| {
            c.rejected_invalid + c.rejected_time + c.rejected_gate + c.rejected_integrity
        })
        .sum();
    out
}

/// NEES of position, velocity and attitude (3 degrees of freedom each) of
/// every snapshot of a run against its truth.
pub fn nees(r: &Run) -> Vec<[f64; 3]> {
    r.snaps
        .iter()
        .zip(&r.truth)
        .map(|(s, t)| {
            let (p, v, a) = errors(s, t);
            let q = |e: Vector3<f64>, c: &Matrix3<f64>| {
                e.dot(&(c.try_inverse().expect("P invertible") * e))
            };
            [q(p, &s.cov_pos), q(v, &s.cov_vel), q(a, &s.cov_att)]
        })
        .collect()
}

/// Errors of a snapshot against its truth, in local ENU: position (m), velocity (m/s), attitude φ (rad).
pub fn errors(s: &Snapshot, t: &TruthRecord) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let r = Vector3::from(t.r_e_m);
    let g = earth::ecef_to_geodetic(&r);
    let c = frames::c_e_g(g.lat_rad, g.lon_rad);
    let att = c * -(s.q_b_e * quat(&t.q_b_e).inverse()).scaled_axis();
    (c * (s.r_e - r), c * (s.v_e - Vector3::from(t.v_e_mps)), att)
}

pub const ARCMIN: f64 = std::f64::consts::PI / 180.0 / 60.0;

/// Maximum deviation of run `a` from reference run `b` within `after_s` after each switch of `a`:
/// (heading ′, velocity m/s, position m) per switch.
pub fn deviation_after_switches(a: &Run, b: &Run, after_s: f64) -> Vec<(f64, f64, f64)> {
    a.switches
        .iter()
        .map(|sw| {
            let (t0, t1) = (sw.t_ns, sw.t_ns + (after_s * 1e9) as u64);
            let mut d = (0.0f64, 0.0f64, 0.0f64);
            for (x, y) in a
                .snaps
                .iter()
                .zip(&b.snaps)
                .filter(|(x, _)| x.t_ns >= t0 && x.t_ns <= t1)
            {
                assert_eq!(x.t_ns, y.t_ns);
                let g = earth::ecef_to_geodetic(&y.r_e);
                let c = frames::c_e_g(g.lat_rad, g.lon_rad);
                let att = c * (x.q_b_e * y.q_b_e.inverse()).scaled_axis();
                d.0 = d.0.max(att.z.abs() / ARCMIN);
                d.1 = d.1.max((x.v_e - y.v_e).norm());
                d.2 = d.2.max((x.r_e - y.r_e).norm());
            }
            d
        })
        .collect()
}

/// RMSE of horizontal position, vertical position and velocity against the truth.
pub fn rmse(r: &Run) -> (f64, f64, f64) {
    let n = r.snaps.len() as f64;
    let (mut h, mut v, mut vel) = (0.0, 0.0, 0.0);
    for (s, t) in r.snaps.iter().zip(&r.truth) {
        let (p, dv, _) = errors(s, t);
        h += p.xy().norm_squared();
        v += p.z * p.z;
        vel += dv.norm_squared();
    }
    ((h / n).sqrt(), (v / n).sqrt(), (vel / n).sqrt())
}
