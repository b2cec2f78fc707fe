//! sensor-replay's command line takes the daemon's prefix rule.

use std::process::Command;

#[test]
fn a_bad_prefix_is_refused_by_every_subcommand_that_takes_one() {
    for sub in [
        vec!["listen", "--duration", "0.1"],
        vec!["record", "--out", "/nonexistent/x.navlog"],
        vec!["play", "/nonexistent/x.navlog"],
    ] {
        for bad in ["a b", "x/", "iox2://x"] {
            let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
                .args(&sub)
                .args(["--prefix", bad])
                .output()
                .expect("run");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{sub:?} {bad:?}: {err}");
            assert!(
                err.contains("--prefix") && err.contains(bad),
                "{sub:?} {bad:?}: {err}"
            );
        }
    }
}

#[test]
fn eval_names_a_navlog_passed_as_the_solution_and_exits_2() {
    let dir = std::env::temp_dir().join(format!("sr-cli-navlog-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let log = dir.join("flight.navlog");
    let mut bytes = Vec::new();
    let header = msgs::navlog::Header::new("test", "scenario", 1, "");
    let mut w = msgs::navlog::NavlogWriter::new(&mut bytes, header).expect("writer");
    w.write(&msgs::navlog::Record::Imu(Default::default()))
        .expect("record");
    w.finish().expect("finish");
    std::fs::write(&log, &bytes).expect("write");
    let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .arg("eval")
        .arg("--log")
        .arg(&log)
        .arg("--solution")
        .arg(&log)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("is a navlog, not a solution CSV"), "{err}");
    assert!(!err.contains("valid UTF-8"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn listen_into_a_file_writes_plain_lines_without_escapes() {
    // Nothing publishes on this prefix: listen shows "none yet" and stops.
    let prefix = format!("sr-listen-plain-{}", std::process::id());
    let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .args(["listen", "--duration", "0.6", "--prefix", &prefix])
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("solution: none yet"), "{out:?}");
    assert!(!o.stdout.contains(&0x1b), "escape in {out:?}");
}

/// `cmd` run with standard error a pipe whose reader was closed before
/// the child started (`sensor-replay ... 2>&1 | head` after head exits):
/// its exit code. Every write to it fails with EPIPE, on which
/// `eprintln!` panics.
fn with_stderr_closed(cmd: &mut Command) -> Option<i32> {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    cmd.stdout(std::process::Stdio::null())
        .stderr(writer)
        .status()
        .expect("run sensor-replay")
        .code()
}

#[test]
fn simulate_and_export_with_standard_error_closed_finish_and_write_their_files() {
    let dir = std::env::temp_dir().join(format!("sr-cli-stderr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../config/scenarios/transpolar.toml"),
    )
    .expect("scenario");
    let short = text.replace("duration_s = 4480.0", "duration_s = 20.0");
    assert_ne!(short, text, "the scenario's duration line moved");
    let scenario = dir.join("short.toml");
    std::fs::write(&scenario, short).expect("write scenario");
    let log = dir.join("flight.navlog");
    let code = with_stderr_closed(
        Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
            .arg("simulate")
            .arg("--scenario")
            .arg(&scenario)
            .arg("--out")
            .arg(&log),
    );
    assert_eq!(code, Some(0), "simulate with stderr closed");
    let truth = dir.join("truth.csv");
    let mcap = dir.join("flight.mcap");
    let code = with_stderr_closed(
        Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
            .arg("export")
            .arg(&log)
            .arg("--truth-csv")
            .arg(&truth)
            .arg("--mcap")
            .arg(&mcap),
    );
    assert_eq!(code, Some(0), "export with stderr closed");
    // 20 s of truth at 10 Hz, with its header.
    let rows = std::fs::read_to_string(&truth)
        .expect("truth csv")
        .lines()
        .count();
    assert_eq!(rows, 202, "truth rows and header");
    let summary = mcap::Summary::read(&std::fs::read(&mcap).expect("mcap"))
        .expect("summary")
        .expect("an ended MCAP has a summary");
    assert!(
        summary.stats.is_some_and(|s| s.message_count > 4000),
        "every record exported"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn listen_into_a_closed_pipe_stops_quietly_and_into_a_full_disk_names_standard_output() {
    use std::process::Stdio;
    use std::time::Duration;
    // Nothing publishes on this prefix: listen writes "none yet" every 250 ms.
    let prefix = format!("sr-listen-epipe-{}", std::process::id());
    // `listen | head -0`: the reader is gone before the first block.
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let child = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .args(["listen", "--duration", "60", "--prefix", &prefix])
        .stdout(writer)
        .stderr(Stdio::piped())
        .spawn()
        .expect("run listen");
    // Its end is waited for on a thread, with a deadline here.
    let pid = child.id();
    let (done_tx, done) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = done_tx.send(child.wait_with_output());
    });
    let Ok(o) = done.recv_timeout(Duration::from_secs(20)) else {
        let _ = Command::new("kill").arg("-9").arg(pid.to_string()).status();
        panic!("listen went on writing into a closed pipe for 20 s");
    };
    let o = o.expect("wait");
    let (status, err) = (o.status, String::from_utf8_lossy(&o.stderr).into_owned());
    assert_eq!(status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");

    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    let Ok(full) = full else {
        return; // no /dev/full in this sandbox: the first half stands alone
    };
    let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .args(["listen", "--duration", "20", "--prefix", &prefix])
        .stdout(full)
        .output()
        .expect("run listen");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("standard output") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn man_into_a_closed_pipe_exits_0() {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .arg("man")
        .stdout(writer)
        .output()
        .expect("run sensor-replay man");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.is_empty(), "{err}");
}
