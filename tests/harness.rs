//! The harness of the multi-process tests: each test's own iceoryx2
//! service prefix and root, its processes' output in files, a deadline on
//! every wait, and children that die with the test.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use polarnav_ipc::{TransportConfig, remove_isolated};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

use crate::bin;

#[derive(Debug)]
pub struct Env {
    pub dir: PathBuf,
    pub cfg: TransportConfig,
    _machine: Machine,
}

/// Tests share the machine; one that loads it on purpose (CPU burners) runs
/// alone, so that the others' timing assertions measure the daemon.
static MACHINE: std::sync::RwLock<()> = std::sync::RwLock::new(());

#[allow(dead_code)]
#[derive(Debug)]
pub enum Machine {
    Shared(std::sync::RwLockReadGuard<'static, ()>),
    Alone(std::sync::RwLockWriteGuard<'static, ()>),
}

impl Env {
    pub fn new(tag: &str) -> Self {
        let m = Machine::Shared(MACHINE.read().unwrap_or_else(|e| e.into_inner()));
        Self::with_machine(tag, m)
    }

    /// An environment that has the machine to itself while it lives.
    pub fn alone(tag: &str) -> Self {
        let m = Machine::Alone(MACHINE.write().unwrap_or_else(|e| e.into_inner()));
        Self::with_machine(tag, m)
    }

    pub fn with_machine(tag: &str, machine: Machine) -> Self {
        let cfg = TransportConfig::isolated(tag);
        let dir = std::env::temp_dir().join(format!("polarnav-live-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(
            dir.join("nav.toml"),
            format!("prefix = \"{}\"\n", cfg.prefix),
        )
        .expect("config");
        Self {
            dir,
            cfg,
            _machine: machine,
        }
    }

    pub fn command(&self, binary: &str, log: &str) -> Command {
        self.command_for(&bin(binary), log)
    }

    /// `program` with this environment's iceoryx2 isolation, its output in `<log>.out` / `<log>.err`.
    pub fn command_for(&self, program: &Path, log: &str) -> Command {
        let mut c = Command::new(program);
        c.env(
            "POLARNAV_IOX_PREFIX",
            self.cfg.iox_prefix.as_deref().expect("isolated"),
        )
        .env(
            "POLARNAV_IOX_ROOT",
            self.cfg.iox_root.as_ref().expect("isolated"),
        )
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(self.dir.join(format!("{log}.out"))).expect("log"))
        .stderr(std::fs::File::create(self.dir.join(format!("{log}.err"))).expect("log"));
        c
    }

    /// A file of this environment's directory, empty if it is missing.
    pub fn read(&self, name: &str) -> String {
        std::fs::read_to_string(self.dir.join(name)).unwrap_or_default()
    }

    /// Waits until `log`'s stderr contains `text`.
    pub fn wait_for(&self, log: &str, text: &str, deadline: Duration) {
        let path = self.dir.join(format!("{log}.err"));
        let t0 = Instant::now();
        while t0.elapsed() < deadline {
            if std::fs::read_to_string(&path).is_ok_and(|s| s.contains(text)) {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        panic!(
            "{log} did not print {text:?} within {deadline:?}: {}",
            std::fs::read_to_string(&path).unwrap_or_default()
        );
    }
}

impl Drop for Env {
    fn drop(&mut self) {
        remove_isolated(&self.cfg);
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

impl Env {
    /// Starts nav-daemon with this environment's configuration and waits until its services are open.
    pub fn start_daemon(&self, log: &str, extra_env: Option<(&str, &Path)>) -> Proc {
        let mut c = self.command("nav-daemon", log);
        c.arg("--config").arg(self.dir.join("nav.toml"));
        if let Some((k, v)) = extra_env {
            c.env(k, v);
        }
        let child = Proc(c.spawn().expect("nav-daemon"));
        self.wait_for(log, "services open", Duration::from_secs(20));
        child
    }

    /// Starts the flight recorder writing `path` and waits until it has subscribed.
    pub fn start_recorder(&self, path: &Path) -> Proc {
        let child = self
            .command("sensor-replay", "record")
            .args(["record", "--prefix", &self.cfg.prefix, "--out"])
            .arg(path)
            .spawn()
            .map(Proc)
            .expect("recorder");
        self.wait_for("record", "subscribed", Duration::from_secs(20));
        child
    }

    /// Starts a replay of `log_file` at `speed`.
    pub fn start_play(&self, log: &str, log_file: &Path, speed: &str) -> Proc {
        self.command("sensor-replay", log)
            .arg("play")
            .arg(log_file)
            .args(["--speed", speed, "--prefix", &self.cfg.prefix])
            .spawn()
            .map(Proc)
            .expect("play")
    }

    /// The daemon, a recorder into `recorded.navlog` and a replay of
    /// `log_file` at `speed`, started in that order; returns once the replay
    /// has ended with status 0 (within 120 s), with the daemon and the
    /// recorder still running, and the recording's path.
    pub fn replay_recorded(&self, log_file: &Path, speed: &str) -> (Proc, Proc, PathBuf) {
        let daemon = self.start_daemon("daemon", None);
        let rec_path = self.dir.join("recorded.navlog");
        let recorder = self.start_recorder(&rec_path);
        let mut play = self.start_play("play", log_file, speed);
        assert_eq!(
            wait(&mut play, Duration::from_secs(120)),
            Some(0),
            "{}: play of {} failed",
            self.cfg.prefix,
            log_file.display()
        );
        (daemon, recorder, rec_path)
    }
}

/// A child process that is killed when dropped, so a failing test leaves
/// nothing running.
#[derive(Debug)]
pub struct Proc(pub Child);

impl std::ops::Deref for Proc {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.0
    }
}

impl std::ops::DerefMut for Proc {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// Sends SIGTERM and waits for the exit status within `deadline` (SIGKILL after it).
pub fn terminate(child: &mut Child, deadline: Duration) -> Option<i32> {
    let _ = Command::new("kill")
        .arg("-TERM")
        .arg(child.id().to_string())
        .status();
    wait(child, deadline)
}

pub fn wait(child: &mut Child, deadline: Duration) -> Option<i32> {
    let t0 = Instant::now();
    while t0.elapsed() < deadline {
        if let Some(s) = child.try_wait().expect("wait") {
            return s.code();
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    panic!("process {} did not exit within {deadline:?}", child.id());
}

/// The first `seconds` of `transpolar.toml`, simulated into `dir`.
pub fn short_log(dir: &Path, seconds: f64) -> PathBuf {
    short_log_of(dir, seconds, "config/scenarios/transpolar.toml")
}

/// The first `seconds` of `scenario`, simulated into `dir`: a transpolar
/// scenario's `duration_s = 4480.0` set to `seconds`, or a scenario of
/// `[[segment]]`s (the last tables of its file) cut after the segment that
/// reaches `seconds`, so at least `seconds` long. Panics when neither
/// applies, rather than simulate the whole flight unseen.
pub fn short_log_of(dir: &Path, seconds: f64, scenario: &str) -> PathBuf {
    let text = shortened(
        &std::fs::read_to_string(crate::repo(scenario)).expect("scenario"),
        seconds,
    )
    .unwrap_or_else(|| panic!("{scenario}: cannot be cut to its first {seconds} s"));
    let s = Scenario::parse(&text, "short").expect("scenario");
    let log = dir.join("flight.navlog");
    simulate(
        &s,
        &text,
        SimOptions::default(),
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");
    log
}

/// A scenario's text flown for its first `seconds` (see [`short_log_of`]).
fn shortened(text: &str, seconds: f64) -> Option<String> {
    assert!(
        seconds.is_finite() && seconds > 0.0,
        "a flight of {seconds} s"
    );
    const TRANSPOLAR: &str = "duration_s = 4480.0";
    if text.contains(TRANSPOLAR) {
        return Some(text.replace(TRANSPOLAR, &format!("duration_s = {seconds}")));
    }
    const SEGMENT: &str = "\n[[segment]]\n";
    let first = text.find(SEGMENT)?;
    let mut flown = 0.0;
    let mut at = first;
    while flown < seconds {
        let next = text[at + 1..].find(SEGMENT).map(|i| at + 1 + i);
        let block = &text[at..next.unwrap_or(text.len())];
        flown += block
            .lines()
            .find_map(|l| l.trim().strip_prefix("duration_s = "))?
            .parse::<f64>()
            .ok()?;
        match next {
            Some(n) => at = n,
            None => return (flown >= seconds).then(|| text.to_owned()),
        }
    }
    // Only segments may be cut away, never another table after them.
    let rest = &text[at..];
    rest.lines()
        .map(str::trim_start)
        .all(|l| !l.starts_with('[') || l == "[[segment]]")
        .then(|| text[..at + 1].to_owned())
}

/// The port a `sensor-replay view` listens on, from its start line.
pub fn view_port(env: &Env, log: &str) -> u16 {
    env.wait_for(log, "view: serving", Duration::from_secs(20));
    let err = std::fs::read_to_string(env.dir.join(format!("{log}.err"))).expect("view log");
    let line = err
        .lines()
        .find(|l| l.contains("view: serving"))
        .expect("start line");
    line.rsplit(':')
        .next()
        .and_then(|p| p.split_whitespace().next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {line:?}"))
}

/// The newest status seen within `deadline` that satisfies `pred`.
pub fn status_until(
    env: &Env,
    deadline: Duration,
    pred: impl Fn(&msgs::Status) -> bool,
) -> msgs::Status {
    let node = polarnav_ipc::node(&env.cfg, "test_monitor").expect("node");
    let sub = polarnav_ipc::TopicSubscriber::<msgs::Status>::new(
        &node,
        &env.cfg,
        msgs::service::Topic::Status,
    )
    .expect("status");
    let t0 = Instant::now();
    let mut last = None;
    while t0.elapsed() < deadline {
        sub.drain(|s| last = Some(s)).expect("drain");
        if let Some(s) = last.filter(&pred) {
            return s;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    panic!("no status satisfying the condition within {deadline:?}; last: {last:?}");
}

#[cfg(test)]
mod tests {
    use super::shortened;

    #[test]
    fn a_scenario_is_cut_after_the_segment_that_reaches_the_time() {
        let text = "name = \"x\"\n[start]\nh_m = 1.0\n\n[[segment]]\nkind = \"cruise\"\nduration_s = 60.0\n\n[[segment]]\nkind = \"turn\"\nduration_s = 30.0\n\n[[segment]]\nkind = \"cruise\"\nduration_s = 90.0\n";
        let cut = |s: f64| shortened(text, s).map(|t| t.matches("[[segment]]").count());
        assert_eq!(cut(60.0), Some(1));
        assert_eq!(cut(61.0), Some(2));
        assert_eq!(cut(90.0), Some(2));
        assert_eq!(cut(180.0), Some(3));
        assert_eq!(cut(181.0), None, "longer than the flight");
        // A table after the segments is never cut away.
        assert_eq!(shortened(&format!("{text}[faults]\n"), 60.0), None);
        assert_eq!(shortened(&format!("{text}  [faults]\n"), 60.0), None);
        assert!(shortened("name = \"x\"\n", 60.0).is_none());
        let transpolar = shortened("a\nduration_s = 4480.0\n", 60.0).expect("cut");
        assert!(transpolar.contains("duration_s = 60\n"), "{transpolar}");
    }
}
