//! Running a campaign's runs on this machine: a result directory opened
//! for a campaign, and a pool of worker processes, each run one child
//! process (`sensor-replay campaign run-one`) so that a run that panics,
//! hangs past its timeout or is killed takes nothing else with it and its
//! peak memory is its own.
//!
//! The same pool runs a Slurm array task's or a Kubernetes index's chunk
//! ([`super::cluster`]): every executor goes through [`execute`], so a run
//! is the same child process with the same arguments everywhere.

use std::collections::VecDeque;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::plan::{Frozen, Plan, PlanError};
use super::row::Outcome;
use super::store::{self, RunResult, RunState};

/// Why a campaign cannot be run or read (exit 2: the user's input).
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    #[error(transparent)]
    Plan(#[from] PlanError),
    #[error(
        "{dir}: holds campaign {found} ({found_file}), not {expected} ({file}): a result directory belongs to one campaign file; use another --out"
    )]
    OtherCampaign {
        dir: String,
        found: String,
        found_file: String,
        expected: String,
        file: String,
    },
    #[error(
        "{dir}: no campaign here ({what}); run `sensor-replay campaign run FILE --out {dir}` first"
    )]
    NoCampaign { dir: String, what: String },
    #[error("{0}")]
    Io(String),
}

/// The frozen campaign of a result directory.
pub fn frozen_path(dir: &Path) -> PathBuf {
    dir.join("campaign.json")
}

/// Opens `dir` for the campaign `file`: a new directory gets the campaign
/// frozen into it; one that holds a campaign must hold this one (the same
/// SHA-256 of the campaign's and its scenarios' texts).
pub fn open_for(file: &Path, dir: &Path) -> Result<(Frozen, Plan), CampaignError> {
    let f = Frozen::read(file)?;
    let plan = Plan::new(&f)?;
    let path = frozen_path(dir);
    if path.exists() {
        let (old, _) = open(dir)?;
        if old.sha256() != f.sha256() {
            return Err(CampaignError::OtherCampaign {
                dir: dir.display().to_string(),
                found: old.sha256(),
                found_file: old.file,
                expected: f.sha256(),
                file: file.display().to_string(),
            });
        }
        return Ok((old, plan));
    }
    std::fs::create_dir_all(dir)
        .map_err(|e| CampaignError::Io(format!("{}: {e}", dir.display())))?;
    let bytes = serde_json::to_vec_pretty(&f).expect("a campaign serializes");
    let tmp = dir.join(format!(".campaign.json.{}.tmp", std::process::id()));
    std::fs::write(&tmp, &bytes)
        .and_then(|()| std::fs::rename(&tmp, &path))
        .map_err(|e| CampaignError::Io(format!("{}: {e}", path.display())))?;
    Ok((f, plan))
}

/// Opens a result directory's own frozen campaign.
pub fn open(dir: &Path) -> Result<(Frozen, Plan), CampaignError> {
    let path = frozen_path(dir);
    let bytes = std::fs::read(&path).map_err(|e| CampaignError::NoCampaign {
        dir: dir.display().to_string(),
        what: format!("{}: {e}", path.display()),
    })?;
    let f: Frozen = serde_json::from_slice(&bytes).map_err(|e| CampaignError::NoCampaign {
        dir: dir.display().to_string(),
        what: format!("{}: {e}", path.display()),
    })?;
    let plan = Plan::new(&f)?;
    Ok((f, plan))
}

/// The state of every run of a campaign.
pub fn states(dir: &Path, plan: &Plan) -> Vec<RunState> {
    (0..plan.runs())
        .map(|i| store::state(dir, i, &plan.sha256))
        .collect()
}

/// The runs among `indices` that still need running: missing or failed.
pub fn to_run(dir: &Path, plan: &Plan, indices: impl Iterator<Item = u64>) -> Vec<u64> {
    indices
        .filter(|&i| !matches!(store::state(dir, i, &plan.sha256), RunState::Done))
        .collect()
}

/// `a..b` (or `a..=b`, or one index) within a campaign of `n` runs.
pub fn parse_range(s: &str, n: u64) -> Result<std::ops::Range<u64>, String> {
    let bad = || format!("--only {s:?}: expected INDEX, A..B or A..=B");
    let r = if let Some((a, b)) = s.split_once("..=") {
        let a: u64 = a.trim().parse().map_err(|_| bad())?;
        let b: u64 = b.trim().parse().map_err(|_| bad())?;
        a..b.checked_add(1).ok_or_else(bad)?
    } else if let Some((a, b)) = s.split_once("..") {
        let a: u64 = a.trim().parse().map_err(|_| bad())?;
        let b: u64 = if b.trim().is_empty() {
            n
        } else {
            b.trim().parse().map_err(|_| bad())?
        };
        a..b
    } else {
        let a: u64 = s.trim().parse().map_err(|_| bad())?;
        a..a.checked_add(1).ok_or_else(bad)?
    };
    if r.start >= r.end || r.end > n {
        return Err(format!(
            "--only {s:?}: outside the campaign's runs 0..{n} (or empty)"
        ));
    }
    Ok(r)
}

/// What a pool of runs did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Tally {
    pub done: u64,
    pub failed: u64,
    /// Stopped from outside (SIGTERM, SIGINT, SIGKILL: a cancelled job, an
    /// operator): no result is written, the run stays missing.
    pub stopped: u64,
    pub flight_h: f64,
    pub cpu_s: f64,
}

/// Runs `indices` of the campaign in `dir` with `jobs` worker processes at
/// a time; `executor` is what their cost rows say ran them. Progress goes
/// to stderr: a bar redrawn in place on a terminal, a line every
/// `progress_every` otherwise.
pub fn execute(
    dir: &Path,
    plan: &Plan,
    indices: Vec<u64>,
    jobs: usize,
    executor: &str,
    progress_every: Duration,
) -> Result<Tally, CampaignError> {
    let exe = own_program()?;
    store::remove_stale_temporaries(dir);
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs)
        .map_err(|e| CampaignError::Io(format!("{}: {e}", logs.display())))?;
    let total = indices.len() as u64;
    let queue = Arc::new(Mutex::new(VecDeque::from(indices)));
    let tally = Arc::new(Mutex::new(Tally::default()));
    let started = Instant::now();
    let tty = std::io::stderr().is_terminal();
    let timeout = Duration::from_secs_f64(plan.run.timeout_s);
    let jobs = jobs.max(1);
    std::thread::scope(|s| {
        for _ in 0..jobs {
            let queue = Arc::clone(&queue);
            let tally = Arc::clone(&tally);
            let exe = exe.clone();
            let logs = logs.clone();
            s.spawn(move || {
                loop {
                    let Some(index) = queue.lock().expect("queue").pop_front() else {
                        break;
                    };
                    let r = run_child(&exe, dir, plan, index, executor, timeout, &logs);
                    let mut t = tally.lock().expect("tally");
                    match r {
                        Ended::Result(r) => {
                            match r.metrics.outcome {
                                Outcome::Ok => t.done += 1,
                                Outcome::Failed => t.failed += 1,
                            }
                            t.flight_h += r.cost.flight_h;
                            t.cpu_s += r.cost.cpu_s;
                        }
                        Ended::Stopped => t.stopped += 1,
                    }
                }
            });
        }
        // Progress, from this thread, until the queue is empty and every
        // worker has reported.
        let mut last = Instant::now() - progress_every;
        loop {
            let t = *tally.lock().expect("tally");
            let finished = t.done + t.failed + t.stopped;
            let line = progress_line(&plan.name, t, total, started.elapsed());
            if tty {
                eprint!("\r\x1b[2K{line}");
            } else if last.elapsed() >= progress_every || finished == total {
                eprintln!("{line}");
                last = Instant::now();
            }
            if finished == total {
                if tty {
                    eprintln!();
                }
                break;
            }
            std::thread::sleep(Duration::from_millis(if tty { 200 } else { 500 }));
        }
    });
    let t = *tally.lock().expect("tally");
    Ok(t)
}

/// The program the runs are started from: this very executable, through
/// `/proc/self/exe`, which stays this build even when the file is replaced
/// while a campaign runs (a `cargo build` or an upgrade: its path then
/// names the new file, or reads "... (deleted)"), so every run of one
/// invocation is flown by one build. Elsewhere, the path it was started from.
fn own_program() -> Result<PathBuf, CampaignError> {
    let proc_exe = Path::new("/proc/self/exe");
    if proc_exe.exists() {
        return Ok(proc_exe.to_path_buf());
    }
    std::env::current_exe().map_err(|e| CampaignError::Io(format!("this program's path: {e}")))
}

/// The progress bar: runs, failures, flight hours, the rate and the ETA.
pub fn progress_line(name: &str, t: Tally, total: u64, elapsed: Duration) -> String {
    let finished = t.done + t.failed + t.stopped;
    let frac = if total == 0 {
        1.0
    } else {
        finished as f64 / total as f64
    };
    let width = 24;
    let filled = ((frac * width as f64).round() as usize).min(width);
    let bar: String = "#".repeat(filled) + &"-".repeat(width - filled);
    let eta = if finished > 0 && finished < total {
        let s = elapsed.as_secs_f64() / finished as f64 * (total - finished) as f64;
        format!("ETA {}", hms(s))
    } else if finished == total {
        format!("took {}", hms(elapsed.as_secs_f64()))
    } else {
        "ETA --".into()
    };
    let per_core_h = if t.cpu_s > 0.0 {
        format!(
            ", {:.0} flight h per core h",
            t.flight_h / (t.cpu_s / 3600.0)
        )
    } else {
        String::new()
    };
    format!(
        "{name} [{bar}] {finished}/{total} runs ({} failed{}), {:.1} flight h{per_core_h}, {eta}",
        t.failed,
        if t.stopped > 0 {
            format!(", {} stopped", t.stopped)
        } else {
            String::new()
        },
        t.flight_h,
    )
}

fn hms(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

enum Ended {
    Result(Box<RunResult>),
    Stopped,
}

/// Runs one run in a child process and returns its result: the child's
/// own, or a failure row written here when the child could not write one
/// (a timeout, a crash). A child stopped from outside leaves the run
/// missing.
fn run_child(
    exe: &Path,
    dir: &Path,
    plan: &Plan,
    index: u64,
    executor: &str,
    timeout: Duration,
    logs: &Path,
) -> Ended {
    let log = logs.join(format!("{index:09}.log"));
    let started = Instant::now();
    let spawn = std::fs::File::create(&log).and_then(|f| {
        Command::new(exe)
            .args(["campaign", "run-one"])
            .arg(dir)
            .args(["--index", &index.to_string(), "--executor", executor])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(f)
            .spawn()
    });
    let fail = |reason: String| -> Ended {
        let o = super::run::Outcomes::failed(
            plan,
            plan.run_id(index).expect("an index of the plan"),
            reason,
        );
        // The run's process is gone: its CPU and memory are not this
        // process's to report.
        let mut cost = super::run::cost(&o, index, 0.0, started, executor);
        cost.peak_rss_mib = 0.0;
        let r = RunResult {
            campaign_sha256: plan.sha256.clone(),
            metrics: o.metrics,
            cost,
        };
        match store::write_result(dir, &r) {
            Ok(_) => Ended::Result(Box::new(r)),
            Err(e) => {
                eprintln!("campaign: run {index}: cannot write its failure row: {e}");
                Ended::Stopped
            }
        }
    };
    // A run that cannot be started has not failed: it stays missing (the
    // log file or the program is what is wrong, and says so).
    let mut child = match spawn {
        Ok(c) => c,
        Err(e) => {
            eprintln!(
                "campaign: run {index}: cannot start its process ({} campaign run-one): {e}; it stays missing",
                exe.display()
            );
            return Ended::Stopped;
        }
    };
    let status = loop {
        match child.try_wait() {
            Ok(Some(st)) => break Some(st),
            Ok(None) if started.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return fail(format!("waiting for the run's process: {e}")),
        }
    };
    // A result the child wrote wins whatever happened after it.
    if let Ok(Some(r)) = store::read_result(dir, index, &plan.sha256) {
        if r.metrics.outcome == Outcome::Ok {
            let _ = std::fs::remove_file(&log);
        }
        return Ended::Result(Box::new(r));
    }
    let tail = std::fs::read_to_string(&log)
        .ok()
        .and_then(|s| {
            s.lines()
                .rev()
                .find(|l| !l.trim().is_empty())
                .map(str::to_owned)
        })
        .unwrap_or_default();
    let Some(status) = status else {
        return fail(format!(
            "timed out after {:.0} s (run.timeout_s)",
            timeout.as_secs_f64()
        ));
    };
    use std::os::unix::process::ExitStatusExt;
    match status.signal() {
        // Stopped from outside: a cancelled job or an operator. Not a
        // failure of the run: it stays missing and runs again.
        Some(sig @ (2 | 9 | 15)) => {
            eprintln!("campaign: run {index} stopped by signal {sig}; it stays missing");
            Ended::Stopped
        }
        Some(sig) => fail(format!("crashed: signal {sig}; {tail}")),
        None => fail(format!(
            "its process ended ({status}) without a result: {tail}"
        )),
    }
}

/// `run-one`: runs one run in this process and writes its result.
pub fn run_one(dir: &Path, index: u64, executor: &str) -> Result<RunResult, CampaignError> {
    let started = Instant::now();
    let (_, plan) = open(dir)?;
    let id = plan.run_id(index).ok_or_else(|| {
        CampaignError::Io(format!(
            "run {index}: the campaign has runs 0..{}",
            plan.runs()
        ))
    })?;
    let o = super::run::run_caught(&plan, id);
    let cost = super::run::cost(&o, index, super::run::process_cpu_s(), started, executor);
    let r = RunResult {
        campaign_sha256: plan.sha256.clone(),
        metrics: o.metrics,
        cost,
    };
    store::write_result(dir, &r).map_err(|e| {
        CampaignError::Io(format!("{}: {e}", store::result_path(dir, index).display()))
    })?;
    Ok(r)
}

/// The counts `campaign status` prints.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Status {
    pub runs: u64,
    pub done: u64,
    pub failed: Vec<(u64, String)>,
    /// Missing runs, and among them those whose file could not be used (why).
    pub missing: Vec<u64>,
    pub unusable: Vec<(u64, String)>,
    pub temporaries: usize,
}

pub fn status(dir: &Path, plan: &Plan) -> Status {
    let mut s = Status {
        runs: plan.runs(),
        temporaries: store::temporaries(dir).len(),
        ..Default::default()
    };
    for (i, st) in states(dir, plan).into_iter().enumerate() {
        let i = i as u64;
        match st {
            RunState::Done => s.done += 1,
            RunState::Failed(r) => s.failed.push((i, r)),
            RunState::Missing(why) => {
                s.missing.push(i);
                if let Some(w) = why {
                    s.unusable.push((i, w));
                }
            }
        }
    }
    s
}

/// Indices as ranges: `0..=3, 7, 9..=12`.
pub fn ranges(v: &[u64]) -> String {
    let mut out = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        out.push(if j == i {
            v[i].to_string()
        } else {
            format!("{}..={}", v[i], v[j])
        });
        i = j + 1;
    }
    out.join(", ")
}

impl Status {
    /// The report `campaign status` prints.
    pub fn text(&self, name: &str) -> String {
        let mut out = format!(
            "campaign {name}: {} runs: {} done, {} failed, {} missing\n",
            self.runs,
            self.done,
            self.failed.len(),
            self.missing.len()
        );
        if !self.missing.is_empty() {
            out += &format!("missing: {}\n", ranges(&self.missing));
        }
        for (i, why) in self.unusable.iter().take(20) {
            out += &format!("  run {i}: result unusable, counted missing: {why}\n");
        }
        if self.unusable.len() > 20 {
            out += &format!(
                "  ... and {} more unusable results\n",
                self.unusable.len() - 20
            );
        }
        if !self.failed.is_empty() {
            let idx: Vec<u64> = self.failed.iter().map(|(i, _)| *i).collect();
            out += &format!("failed: {}\n", ranges(&idx));
            for (i, why) in self.failed.iter().take(20) {
                out += &format!("  run {i}: {why}\n");
            }
            if self.failed.len() > 20 {
                out += &format!("  ... and {} more failed runs\n", self.failed.len() - 20);
            }
        }
        if self.temporaries > 0 {
            out += &format!(
                "{} temporary file(s) of runs killed while writing or still writing (never read as results)\n",
                self.temporaries
            );
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_compress_runs_of_indices() {
        assert_eq!(ranges(&[0, 1, 2, 3, 7, 9, 10, 11, 12]), "0..=3, 7, 9..=12");
        assert_eq!(ranges(&[]), "");
        assert_eq!(ranges(&[5]), "5");
    }

    #[test]
    fn only_ranges_are_checked_against_the_campaign() {
        assert_eq!(parse_range("0..24", 100), Ok(0..24));
        assert_eq!(parse_range("3..=5", 100), Ok(3..6));
        assert_eq!(parse_range("7", 100), Ok(7..8));
        assert_eq!(parse_range("90..", 100), Ok(90..100));
        for bad in [
            "",
            "a..b",
            "5..5",
            "0..101",
            "100",
            "18446744073709551615..=18446744073709551615",
            "-1..3",
        ] {
            assert!(parse_range(bad, 100).is_err(), "{bad:?} accepted");
        }
    }
}
