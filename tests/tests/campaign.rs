//! Campaigns through the `sensor-replay campaign` command line: bad
//! campaign files refused with exit 2 naming file and key, a result
//! directory bound to its campaign, the same index giving the same metrics
//! under any executor, results that survive SIGKILL whole or not at all,
//! and the Kubernetes manifest against the Job's schema.
//!
//! The Slurm executor's own test is `campaign_slurm.rs` (it needs a
//! cluster: `.ci/run` starts one with `scripts/slurm-local.sh`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use polarnav_tests::{bin, python, repo};
use sensor_replay::campaign::local;
use sensor_replay::campaign::store::{self, RunResult};

/// A fresh temporary directory of this test.
fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-campaign-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

fn campaign(args: &[&str]) -> Output {
    Command::new(bin("sensor-replay"))
        .arg("campaign")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("sensor-replay runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Every run's result of a directory, by index.
fn results(dir: &Path, runs: u64) -> Vec<Option<RunResult>> {
    let (_, plan) = local::open(dir).expect("a campaign directory");
    (0..runs)
        .map(|i| store::read_result(dir, i, &plan.sha256).expect("a usable result or none"))
        .collect()
}

const SPOOF: &str = "config/scenarios/gnss/spoof-drag-1.toml";

/// A campaign file in `dir` with `body` after a valid head.
fn write_campaign(dir: &Path, name: &str, body: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, body.replace("SCENARIO", s(&repo(SPOOF)))).expect("write campaign");
    p
}

/// A campaign file with an unknown key, an empty matrix, a seed range out
/// of bounds, a missing scenario or a swept key the scenario lacks exits
/// 2 with a message naming the file and the key; so does `run` on it.
#[test]
fn bad_campaign_files_exit_2_naming_the_file_and_the_key() {
    let d = tmp("bad");
    let head = "name = \"t\"\nscenarios = [\"SCENARIO\"]\n";
    let seeds = "[seeds]\nbase = 1\ncount = 2\n";
    let cases: [(&str, String, &str); 9] = [
        (
            "unknown.toml",
            format!("{head}colour = 3\n{seeds}"),
            "colour",
        ),
        (
            "unknown-run.toml",
            format!("{head}{seeds}[run]\nsmoth = true\n"),
            "run.smoth",
        ),
        (
            "empty.toml",
            format!("{head}{seeds}[matrix]\naids = []\n"),
            "matrix.aids",
        ),
        (
            "empty-set.toml",
            format!("{head}{seeds}[matrix.set]\n\"faults.event.0.start_s\" = []\n"),
            "matrix.set",
        ),
        (
            "seeds0.toml",
            format!("{head}[seeds]\nbase = 1\ncount = 0\n"),
            "seeds.count",
        ),
        (
            "seeds-huge.toml",
            format!("{head}[seeds]\nbase = 1\ncount = 1000000000000\n"),
            "seeds.count",
        ),
        (
            "seeds-negative.toml",
            format!("{head}[seeds]\nbase = -1\ncount = 2\n"),
            "seeds.base",
        ),
        (
            "missing.toml",
            format!("name = \"t\"\nscenarios = [\"SCENARIO\", \"no/such/scenario.toml\"]\n{seeds}"),
            "scenarios[1]",
        ),
        (
            "timeout.toml",
            format!("{head}{seeds}[run]\ntimeout_s = 1e300\n"),
            "run.timeout_s",
        ),
    ];
    for (name, body, key) in &cases {
        let f = write_campaign(&d, name, body);
        for verb in ["plan", "run"] {
            let out_dir = d.join(format!("out-{name}"));
            let o = match verb {
                "plan" => campaign(&["plan", s(&f)]),
                _ => campaign(&["run", s(&f), "--out", s(&out_dir)]),
            };
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{verb} {name}: {e}");
            assert!(
                e.contains(name) && e.contains(key),
                "{verb} {name}: the message does not name the file and {key:?}: {e}"
            );
            assert!(
                !out_dir.exists(),
                "{verb} {name}: a refused campaign created {}",
                out_dir.display()
            );
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A result directory belongs to one campaign: running another campaign
/// file into it is refused (exit 2, both hashes named); an edit of a
/// scenario the campaign flies makes another campaign too.
#[test]
fn a_result_directory_of_another_campaign_is_refused() {
    let d = tmp("other");
    let scen = d.join("flight.toml");
    std::fs::copy(repo(SPOOF), &scen).expect("copy scenario");
    let body = "name = \"t\"\nscenarios = [\"flight.toml\"]\n[seeds]\nbase = 1\ncount = 1\n[run]\nduration_s = 20.0\n".to_owned();
    let f = d.join("c.toml");
    std::fs::write(&f, &body).expect("write");
    let out = d.join("out");
    let o = campaign(&["run", s(&f), "--out", s(&out), "--jobs", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same file again: nothing to run.
    let o = campaign(&["run", s(&f), "--out", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("0 of runs 0..1 to run"),
        "{}",
        stderr(&o)
    );

    std::fs::write(&f, body.replace("base = 1", "base = 2")).expect("edit");
    let o = campaign(&["run", s(&f), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("holds campaign"), "{}", stderr(&o));

    std::fs::write(&f, &body).expect("restore");
    let text = std::fs::read_to_string(&scen).expect("scenario");
    std::fs::write(&scen, text.replace("sigma_h_m = 1.0", "sigma_h_m = 1.5"))
        .expect("edit scenario");
    let o = campaign(&["run", s(&f), "--out", s(&out)]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "an edited scenario was taken for the same campaign: {}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The same index gives bit-identical metrics whatever runs it: the local
/// pool with two workers, the pool with one, and array tasks
/// (`run-chunk --task`), in another directory and in another order.
#[test]
fn the_same_index_gives_the_same_metrics_under_any_executor() {
    let d = tmp("same");
    let smoke = repo("config/campaigns/smoke.toml");
    let a = d.join("a");
    let b = d.join("b");
    let o = campaign(&[
        "run",
        s(&smoke),
        "--out",
        s(&a),
        "--only",
        "0..6",
        "--jobs",
        "2",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The other directory: chunks of 4 as array tasks, the second first.
    let o = campaign(&["run", s(&smoke), "--out", s(&b), "--only", "23"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for task in ["1", "0"] {
        let o = campaign(&[
            "run-chunk",
            s(&b),
            "--chunk",
            "4",
            "--task",
            task,
            "--jobs",
            "1",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let ra = results(&a, 24);
    let rb = results(&b, 24);
    for i in 0..6 {
        let (x, y) = (
            ra[i].as_ref().expect("run in a"),
            rb[i].as_ref().expect("run in b"),
        );
        assert_eq!(x.metrics, y.metrics, "run {i}");
        assert_eq!(
            serde_json::to_string(&x.metrics).expect("json"),
            serde_json::to_string(&y.metrics).expect("json"),
            "run {i}: not bit for bit"
        );
        assert_eq!(
            x.metrics.outcome,
            sensor_replay::campaign::row::Outcome::Ok,
            "run {i}: {}",
            x.metrics.reason
        );
        assert_eq!(
            y.cost.executor,
            "local task ".to_owned() + if i < 4 { "0" } else { "1" }
        );
    }
    // What was not asked for was not run.
    assert!(ra[6].is_none() && rb[8].is_none());
    assert!(rb[23].is_some());
    // Every run of the spoofed flights found the spoofer.
    for r in ra.iter().flatten() {
        assert_eq!(r.metrics.fault.as_deref(), Some("spoof"));
        assert_eq!(
            r.metrics.fault_detected,
            Some(true),
            "run {}",
            r.metrics.index
        );
        assert_eq!(
            r.metrics.gnss_false_exclusions,
            Some(0),
            "run {}",
            r.metrics.index
        );
    }
    let st = campaign(&["status", s(&a)]);
    let text = String::from_utf8_lossy(&st.stdout);
    assert!(
        text.contains("24 runs: 6 done, 0 failed, 18 missing"),
        "{text}"
    );
    assert!(text.contains("missing: 6..=23"), "{text}");
    let _ = std::fs::remove_dir_all(&d);
}

/// Kill a local campaign (the runner and its workers, SIGKILL) at random
/// moments, again and again: every result file there is whole and valid,
/// a torn temporary is never read, `status` counts the rest missing, and
/// running again runs only those, ending with the metrics of a run never
/// interrupted. A result file torn by a file system that broke rename's
/// promise is counted missing and run again.
#[test]
fn sigkill_mid_run_leaves_no_partial_result() {
    use std::os::unix::process::CommandExt;
    let d = tmp("kill");
    let smoke = repo("config/campaigns/smoke.toml");
    let out = d.join("out");
    let mut rng = 0x2545_f491_4f6c_dd1du64;
    let mut kills = 0;
    let t0 = Instant::now();
    loop {
        let mut child = Command::new(bin("sensor-replay"))
            .args([
                "campaign",
                "run",
                s(&smoke),
                "--out",
                s(&out),
                "--only",
                "0..12",
                "--jobs",
                "2",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .process_group(0)
            .spawn()
            .expect("spawn");
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        // Later kills later: a run takes about a second, and each kill
        // loses the runs under way.
        let after = Duration::from_millis(200 + 300 * kills + rng % 700);
        let started = Instant::now();
        let finished = loop {
            if let Some(st) = child.try_wait().expect("wait") {
                break Some(st);
            }
            if started.elapsed() >= after {
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        if finished.is_some() {
            break;
        }
        // The whole group: the runner and the run it has going.
        let killed = Command::new("kill")
            .args(["-s", "KILL", "--", &format!("-{}", child.id())])
            .status()
            .expect("kill");
        assert!(killed.success(), "kill -s KILL -- -{} failed", child.id());
        let _ = child.wait();
        kills += 1;
        // Whatever is there is whole.
        // (Killed before it froze the campaign or wrote a result: nothing to check yet.)
        let Ok((_, plan)) = local::open(&out) else {
            continue;
        };
        let Ok(entries) = std::fs::read_dir(store::runs_dir(&out)) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if name.ends_with(".run") {
                let bytes = std::fs::read(e.path()).expect("read");
                store::decode(&e.path(), &bytes, &plan.sha256)
                    .unwrap_or_else(|err| panic!("after kill {kills}: a partial result: {err}"));
            } else {
                assert!(
                    name.starts_with('.') && name.ends_with(".tmp"),
                    "unexpected file {name}"
                );
            }
        }
        assert!(
            t0.elapsed() < Duration::from_secs(600), // a deadline: a campaign that never finishes fails, not hangs
            "the campaign did not finish between kills"
        );
    }
    assert!(
        kills >= 2,
        "only {kills} kills before the campaign finished: the test killed nothing mid-run"
    );

    // A torn result (as on a file system without atomic rename) and a
    // torn temporary: the first counted missing, the second ignored.
    let (_, plan) = local::open(&out).expect("campaign dir");
    let p3 = store::result_path(&out, 3);
    let whole = std::fs::read(&p3).expect("run 3");
    std::fs::write(&p3, &whole[..whole.len() / 2]).expect("tear");
    std::fs::write(
        store::runs_dir(&out).join(".000000004.999999.x.tmp"),
        &whole[..10],
    )
    .expect("tmp");
    let st = campaign(&["status", s(&out)]);
    let text = String::from_utf8_lossy(&st.stdout).into_owned();
    assert!(
        text.contains("run 3: result unusable, counted missing"),
        "{text}"
    );
    assert!(text.contains("temporary file"), "{text}");
    let o = campaign(&["run", s(&smoke), "--out", s(&out), "--only", "0..12"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("1 of runs 0..12 to run"),
        "{}",
        stderr(&o)
    );

    // The same metrics as a campaign never interrupted.
    let clean = d.join("clean");
    let o = campaign(&["run", s(&smoke), "--out", s(&clean), "--only", "0..12"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (results(&out, 12), results(&clean, 12));
    for i in 0..12 {
        assert_eq!(
            a[i].as_ref().map(|r| &r.metrics),
            b[i].as_ref().map(|r| &r.metrics),
            "run {i} after {kills} kills"
        );
    }
    assert_eq!(plan.runs(), 24);
    let _ = std::fs::remove_dir_all(&d);
}

/// A run that cannot finish in its `timeout_s` is killed and written as a
/// failure row with its reason; the campaign goes on and exits 1.
#[test]
fn a_run_past_its_timeout_is_a_failure_row() {
    let d = tmp("timeout");
    let f = write_campaign(
        &d,
        "slow.toml",
        "name = \"slow\"\nscenarios = [\"SCENARIO\"]\n[seeds]\nbase = 1\ncount = 2\n[run]\ntimeout_s = 1.0\nduration_s = 1200.0\nsmooth = true\n",
    );
    let out = d.join("out");
    let t0 = Instant::now();
    let o = campaign(&["run", s(&f), "--out", s(&out), "--jobs", "2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(t0.elapsed() < Duration::from_secs(60));
    for r in results(&out, 2) {
        let r = r.expect("a failure row");
        assert_eq!(
            r.metrics.outcome,
            sensor_replay::campaign::row::Outcome::Failed
        );
        assert!(
            r.metrics.reason.contains("timed out after 1 s"),
            "{}",
            r.metrics.reason
        );
        assert!(r.metrics.horizontal_rmse_m.is_none());
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The Kubernetes Indexed Job written for a campaign, checked field by
/// field against the Job schema of the official Kubernetes Python client
/// (its models' declared attributes and types, an implementation of the
/// API's schema independent of this one), and for the same contract as a
/// Slurm array task.
#[test]
fn the_kubernetes_job_matches_the_job_schema() {
    let d = tmp("kube");
    let smoke = repo("config/campaigns/smoke.toml");
    let out = d.join("out");
    let o = campaign(&[
        "submit",
        s(&smoke),
        "--out",
        s(&out),
        "--kubernetes",
        "--chunk",
        "5",
        "--parallelism",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let job_path = out.join("kubernetes/job.json");
    let job: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&job_path).expect("job.json")).expect("json");
    assert_eq!(job["spec"]["completionMode"], "Indexed");
    assert_eq!(job["spec"]["completions"], 5, "24 runs in chunks of 5");
    assert_eq!(job["spec"]["parallelism"], 3);
    let c = &job["spec"]["template"]["spec"]["containers"][0];
    let cmd: Vec<&str> = c["command"]
        .as_array()
        .expect("command")
        .iter()
        .map(|v| v.as_str().expect("str"))
        .collect();
    let abs = std::path::absolute(&out).expect("abs");
    assert_eq!(
        cmd,
        [
            "sensor-replay",
            "campaign",
            "run-chunk",
            s(&abs),
            "--chunk",
            "5"
        ]
    );
    assert_eq!(c["volumeMounts"][0]["mountPath"], s(&abs));
    let o = Command::new(python())
        .arg(repo("tests/python/check_k8s_job.py"))
        .arg(&job_path)
        .output()
        .expect("python");
    assert!(
        o.status.success(),
        "the Job does not match the client's schema:\n{}{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(&o)
    );
    // The index a pod gets is the chunk a Slurm task gets.
    let o = Command::new(bin("sensor-replay"))
        .args(["campaign", "run-chunk", s(&out), "--chunk", "5"])
        .env("JOB_COMPLETION_INDEX", "4")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .expect("run-chunk");
    assert!(o.status.success(), "{}", stderr(&o));
    let r = results(&out, 24);
    for (i, x) in r.iter().enumerate() {
        assert_eq!(x.is_some(), i >= 20, "run {i}");
        if let Some(x) = x {
            assert_eq!(x.cost.executor, "kubernetes 4");
        }
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// The merged metrics table reads in pandas (on pyarrow) and polars with
/// every column of the row, its type and its nulls, the rows in index
/// order; merging again gives the same bytes.
#[test]
fn the_merged_table_reads_in_pandas_and_polars() {
    let d = tmp("parquet");
    let smoke = repo("config/campaigns/smoke.toml");
    let out = d.join("out");
    let o = campaign(&["run", s(&smoke), "--out", s(&out), "--only", "0..6"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = campaign(&["merge", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains("24 runs: 6 done, 0 failed, 18 missing"),
        "{text}"
    );
    let table = out.join("merged/metrics.parquet");
    let first = std::fs::read(&table).expect("metrics.parquet");
    let rows: Vec<_> = results(&out, 24)
        .into_iter()
        .flatten()
        .map(|r| r.metrics)
        .collect();
    assert_eq!(rows.len(), 6);
    let expect = sensor_replay::campaign::merge::parquet_expectations(&rows);
    let o = Command::new(python())
        .arg(repo("tests/python/check_campaign_parquet.py"))
        .arg(&table)
        .arg(&expect)
        .output()
        .expect("python");
    assert!(
        o.status.success(),
        "the readers disagree with the rows:\n{}{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(&o)
    );
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("polars") && said.contains("pandas"), "{said}");
    let o = campaign(&["merge", s(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        std::fs::read(&table).expect("again") == first,
        "a second merge wrote other bytes"
    );
    let report = std::fs::read_to_string(out.join("merged/report.md")).expect("report");
    assert!(report.contains("Spoofing detection"), "{report}");
    let _ = std::fs::remove_dir_all(&d);
}

/// The program replaced while a campaign runs (a rebuild, an upgrade):
/// the runs still started are flown by the build that started the
/// campaign, none fails for it.
#[test]
fn a_program_replaced_under_a_running_campaign_keeps_flying_its_build() {
    let d = tmp("replaced");
    let exe = d.join("sensor-replay");
    std::fs::copy(bin("sensor-replay"), &exe).expect("copy the program");
    let smoke = repo("config/campaigns/smoke.toml");
    let out = d.join("out");
    let mut child = Command::new(&exe)
        .args([
            "campaign",
            "run",
            s(&smoke),
            "--out",
            s(&out),
            "--only",
            "0..6",
            "--jobs",
            "1",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    // After the first result, the file is replaced by another (as cargo
    // and package managers do: a new file renamed over the old name).
    let t0 = Instant::now();
    while !store::result_path(&out, 0).exists() {
        assert!(t0.elapsed() < Duration::from_secs(120), "no first result");
        std::thread::sleep(Duration::from_millis(20));
    }
    let other = d.join("sensor-replay.new");
    std::fs::write(&other, "#!/bin/sh\nexit 3\n").expect("write");
    std::fs::rename(&other, &exe).expect("replace the program");
    let st = child.wait().expect("wait");
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().expect("stderr"), &mut err).expect("read");
    assert!(st.success(), "{err}");
    for (i, r) in results(&out, 24).iter().enumerate().take(6) {
        let r = r
            .as_ref()
            .unwrap_or_else(|| panic!("run {i} missing: {err}"));
        assert_eq!(
            r.metrics.outcome,
            sensor_replay::campaign::row::Outcome::Ok,
            "run {i}: {}",
            r.metrics.reason
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}
