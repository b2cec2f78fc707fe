//! A campaign through a real Slurm cluster: `campaign submit --slurm`
//! submits the smoke campaign's 24 short flights as an array of chunks,
//! one running task is cancelled with `scancel`, `campaign status` reports
//! its runs missing, a second `submit` asks for that chunk alone, and the
//! merged Parquet equals, bit for bit, the one `campaign run` makes
//! locally.
//!
//! It needs a cluster: `scripts/slurm-local.sh start` (a single node from
//! Debian's packages; `.ci/run` starts it) and `SLURM_CONF` in the
//! environment. It is `#[ignore]`d so that `cargo test --workspace` on a
//! machine without Slurm does not fail; `.ci/run` runs it with
//! `--ignored`, where a missing cluster fails it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use polarnav_tests::{bin, repo};
use sensor_replay::campaign::local;

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-slurm-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn run(cmd: &str, args: &[&str]) -> Output {
    Command::new(cmd).args(args).output().unwrap_or_else(|e| {
        panic!("{cmd}: {e} (is Slurm installed and SLURM_CONF set? scripts/slurm-local.sh start)")
    })
}

fn ok(o: Output, what: &str) -> String {
    assert!(
        o.status.success(),
        "{what}: {}\n{}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Every task of job `job` with its state (`squeue -r -t all`): finished
/// tasks stay listed for the cluster's MinJobAge.
fn tasks(job: &str) -> Vec<(String, String)> {
    let out = ok(
        run(
            "squeue",
            &["-h", "-r", "-t", "all", "-j", job, "-o", "%i %T"],
        ),
        "squeue",
    );
    out.lines()
        .filter_map(|l| {
            l.split_once(' ')
                .map(|(a, b)| (a.to_owned(), b.trim().to_owned()))
        })
        .collect()
}

fn finished(state: &str) -> bool {
    !matches!(
        state,
        "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING" | "SUSPENDED"
    )
}

/// Waits until every task of `job` has ended.
fn wait_job(job: &str, deadline: Duration) -> Vec<(String, String)> {
    let t0 = Instant::now();
    loop {
        let t = tasks(job);
        if !t.is_empty() && t.iter().all(|(_, st)| finished(st)) {
            return t;
        }
        assert!(
            t0.elapsed() < deadline,
            "job {job} not done within {deadline:?}: {t:?}"
        );
        std::thread::sleep(Duration::from_millis(250));
    }
}

fn submit(dir: &Path, chunk: &str) -> String {
    let out = ok(
        run(
            s(&bin("sensor-replay")),
            &[
                "campaign",
                "submit",
                s(&repo("config/campaigns/smoke.toml")),
                "--out",
                s(dir),
                "--slurm",
                "--chunk",
                chunk,
            ],
        ),
        "campaign submit",
    );
    out.split_whitespace()
        .skip_while(|w| *w != "job")
        .nth(1)
        .unwrap_or_else(|| panic!("no job id in {out:?}"))
        .trim_end_matches(':')
        .to_owned()
}

#[test]
#[ignore = "needs a Slurm cluster: scripts/slurm-local.sh start (.ci/run runs it)"]
fn a_campaign_through_slurm_survives_a_cancelled_task_and_merges_as_the_local_run() {
    assert!(
        std::env::var_os("SLURM_CONF").is_some() || Path::new("/etc/slurm/slurm.conf").exists(),
        "no Slurm configuration: eval \"$(scripts/slurm-local.sh start)\" first"
    );
    let d = tmp("array");
    let dir = d.join("slurm");
    // 24 runs in chunks of 4: array tasks 0-5, two at a time on 2 CPUs.
    let job = submit(&dir, "4");
    let script = std::fs::read_to_string(dir.join("slurm/submit-000.sbatch")).expect("script");
    assert!(script.contains("#SBATCH --array=0-5"), "{script}");

    // Cancel a task while it runs, before its chunk is done.
    let (_, plan) = local::open(&dir).expect("campaign dir");
    let t0 = Instant::now();
    let cancelled = loop {
        let running: Vec<String> = tasks(&job)
            .into_iter()
            .filter(|(_, st)| st == "RUNNING")
            .map(|(id, _)| id)
            .collect();
        let pick = running.into_iter().find(|id| {
            let t: u64 = id
                .rsplit('_')
                .next()
                .and_then(|t| t.parse().ok())
                .unwrap_or(u64::MAX);
            // Its last run not yet written: cancelling it leaves runs missing.
            t < 6
                && sensor_replay::campaign::store::read_result(&dir, t * 4 + 3, &plan.sha256)
                    .ok()
                    .flatten()
                    .is_none()
        });
        if let Some(id) = pick {
            ok(run("scancel", &[&id]), "scancel");
            break id;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "no task of job {job} seen running"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let task: u64 = cancelled
        .rsplit('_')
        .next()
        .and_then(|t| t.parse().ok())
        .expect("task id");
    let states = wait_job(&job, Duration::from_secs(300));
    for (id, st) in &states {
        if *id == cancelled {
            assert_eq!(st, "CANCELLED", "{states:?}");
        } else {
            assert_eq!(st, "COMPLETED", "{id}: {states:?}");
        }
    }

    // status: exactly runs of the cancelled chunk are missing.
    let st = local::status(&dir, &plan);
    assert!(
        !st.missing.is_empty(),
        "the cancelled task left nothing missing"
    );
    assert!(
        st.missing.iter().all(|i| i / 4 == task),
        "missing {:?}, but task {task} was cancelled",
        st.missing
    );
    assert!(st.failed.is_empty(), "{:?}", st.failed);
    let text = ok(
        run(s(&bin("sensor-replay")), &["campaign", "status", s(&dir)]),
        "status",
    );
    assert!(
        text.contains(&format!("{} missing", st.missing.len())),
        "{text}"
    );

    // Submit again: only that chunk.
    let job2 = submit(&dir, "4");
    let script = std::fs::read_to_string(dir.join("slurm/submit-001.sbatch")).expect("script");
    assert!(
        script.contains(&format!("#SBATCH --array={task}\n")),
        "{script}"
    );
    let states = wait_job(&job2, Duration::from_secs(300));
    assert!(states.iter().all(|(_, st)| st == "COMPLETED"), "{states:?}");
    let st = local::status(&dir, &plan);
    assert_eq!((st.done, st.missing.len(), st.failed.len()), (24, 0, 0));
    let r = sensor_replay::campaign::store::read_result(&dir, 0, &plan.sha256)
        .expect("run 0")
        .expect("run 0");
    assert!(
        r.cost.executor.starts_with(&format!("slurm {job}_")),
        "{}",
        r.cost.executor
    );

    // The same campaign locally, and both merged: the same table, bit for bit.
    let localdir = d.join("local");
    ok(
        run(
            s(&bin("sensor-replay")),
            &[
                "campaign",
                "run",
                s(&repo("config/campaigns/smoke.toml")),
                "--out",
                s(&localdir),
            ],
        ),
        "campaign run",
    );
    for x in [&dir, &localdir] {
        ok(
            run(s(&bin("sensor-replay")), &["campaign", "merge", s(x)]),
            "campaign merge",
        );
    }
    let a = std::fs::read(dir.join("merged/metrics.parquet")).expect("slurm parquet");
    let b = std::fs::read(localdir.join("merged/metrics.parquet")).expect("local parquet");
    assert!(
        a == b,
        "the Slurm and local merged tables differ ({} and {} bytes)",
        a.len(),
        b.len()
    );
    let _ = std::fs::remove_dir_all(&d);
}
