//! The flight recorder on a long flight (issue 20, item 6), over real
//! iceoryx2 between separate processes (replay → daemon → recorder), each
//! test on its own service prefix and iceoryx2 root, every wait with a
//! deadline: rotation and retention bounds, each piece navigable alone,
//! the prefix from the daemon's configuration, a full tmpfs, and the stop
//! order of the shipped units.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use msgs::navlog::Record;
use polarnav_config::{CliOverrides, ConfigFile, effective};
use polarnav_tests::harness::{Env, Proc, short_log, terminate, wait};
use polarnav_tests::{bin, repo};
use sensor_replay::pieces::list_pieces;

fn sigterm(pid: u32) {
    let _ = Command::new("kill")
        .arg("-TERM")
        .arg(pid.to_string())
        .status();
}

/// Every piece reads clean, starts with a header and an init, and
/// `nav-daemon batch` and `sensor-replay export` read it alone.
fn check_pieces_navigate_alone(env: &Env, pieces: &[PathBuf]) {
    for (k, p) in pieces.iter().enumerate() {
        let (records, report) = msgs::navlog::read_all(&std::fs::read(p).expect("piece"));
        assert!(report.is_clean(), "{}: {report}", p.display());
        assert!(matches!(records[0], Record::Header(_)), "{}", p.display());
        assert!(
            matches!(records[1], Record::Init(_)),
            "{}: no init after the header",
            p.display()
        );
        let csv = env.dir.join(format!("piece-{k}.csv"));
        let o = Command::new(bin("nav-daemon"))
            .args(["--config"])
            .arg(env.dir.join("nav.toml"))
            .args(["batch", "--log"])
            .arg(p)
            .arg("--out")
            .arg(&csv)
            .output()
            .expect("batch");
        assert_eq!(
            o.status.code(),
            Some(0),
            "batch {}: {}",
            p.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let rows = std::fs::read_to_string(&csv).expect("csv").lines().count();
        assert!(rows > 10, "batch {}: {rows} lines", p.display());
        let o = Command::new(bin("sensor-replay"))
            .arg("export")
            .arg(p)
            .arg("--solution-csv")
            .arg(env.dir.join(format!("export-{k}.csv")))
            .output()
            .expect("export");
        assert_eq!(
            o.status.code(),
            Some(0),
            "export {}: {}",
            p.display(),
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

/// Rotation at 256 KiB and retention at 1 MiB during a live replay: the
/// pieces never hold more than the bound plus the open piece (checked
/// while recording), the oldest go first, a foreign file stays, the
/// prefix comes from the daemon's configuration, and each piece left is
/// navigable alone.
#[test]
fn rotated_pieces_keep_the_retention_bound_and_each_navigates_alone() {
    let env = Env::new("rotate");
    let log = short_log(&env.dir, 40.0);
    let out = env.dir.join("recordings");
    std::fs::create_dir_all(&out).expect("dir");
    std::fs::write(out.join("operator-notes.txt"), vec![b'n'; 300_000]).expect("foreign");
    let _daemon = env.start_daemon("daemon", None);
    let (rotate, keep) = (256u64 << 10, 1u64 << 20);
    let mut rec = {
        let mut c = env.command("sensor-replay", "record");
        c.args(["record", "--config"])
            .arg(env.dir.join("nav.toml"))
            .arg("--out-dir")
            .arg(&out)
            .args(["--rotate-bytes", "256K", "--keep-bytes", "1M"]);
        Proc(c.spawn().expect("record"))
    };
    env.wait_for(
        "record",
        &format!("subscribed to {}/*", env.cfg.prefix),
        Duration::from_secs(20),
    );
    let mut play = env.start_play("play", &log, "8");
    let t0 = Instant::now();
    let mut worst = 0;
    while play.0.try_wait().expect("play").is_none() {
        assert!(t0.elapsed() < Duration::from_secs(120), "play hangs");
        let total: u64 = list_pieces(&out).iter().map(|p| p.bytes).sum();
        worst = worst.max(total);
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(wait(&mut play.0, Duration::from_secs(5)), Some(0));
    std::thread::sleep(Duration::from_millis(300));
    sigterm(rec.0.id());
    assert_eq!(wait(&mut rec.0, Duration::from_secs(20)), Some(0));
    let err = env.read("record.err");
    let summary = env.read("record.out");
    // Slack of one batch of records over a rotation (a cycle of data,
    // longer when the scheduler stalls the recorder).
    assert!(
        worst <= keep + rotate + (128 << 10),
        "the pieces held {worst} bytes: {err}"
    );
    let pieces = list_pieces(&out);
    let seqs: Vec<u64> = pieces.iter().map(|p| p.seq).collect();
    assert!(seqs.len() >= 3, "{seqs:?}: {summary}");
    assert!(seqs[0] > 1, "nothing was removed: {seqs:?}: {err}");
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    assert!(
        err.contains("removed") && err.contains("--keep-bytes"),
        "{err}"
    );
    assert!(
        out.join("operator-notes.txt").exists(),
        "a foreign file was removed"
    );
    assert!(summary.contains("; 0 records lost"), "{summary}");
    let paths: Vec<PathBuf> = pieces.into_iter().map(|p| p.path).collect();
    check_pieces_navigate_alone(&env, &paths);
}

/// The recorder on an 8 MiB tmpfs that fills up mid-flight: the daemon and
/// the replay lose nothing (the recorder keeps draining), the recorder
/// says so once, counts what it could not write, resumes in a new piece
/// when space returns, and prints the count at exit. The tmpfs is mounted
/// in a user and mount namespace (`unshare -rm`); the test reaches it
/// through `/proc/PID/root`.
#[test]
fn a_full_tmpfs_is_reported_counted_and_survived_and_the_replay_loses_nothing() {
    let unshare_ok = Command::new("unshare")
        .args(["-rm", "true"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !unshare_ok {
        eprintln!(
            "SKIPPED: no user and mount namespaces here (unshare -rm); the full disk is tested \
             with an injected writer in sensor-replay's pieces tests"
        );
        return;
    }
    let env = Env::new("fulldisk");
    let log = short_log(&env.dir, 40.0);
    let mnt = env.dir.join("mnt");
    std::fs::create_dir_all(&mnt).expect("mnt");
    let pidfile = env.dir.join("rec.pid");
    let _daemon = env.start_daemon("daemon", None);
    // The shell keeps the namespace (and the tmpfs) alive after the
    // recorder exits, until the test has copied the pieces out.
    let script = format!(
        "mount -t tmpfs -o size=8m tmpfs '{mnt}' || exit 97; \
         '{rec}' record --config '{cfg}' --out-dir '{mnt}' --rotate-bytes 1M & \
         echo $! > '{pid}'; wait $!; echo \"exit $?\" >&2; sleep 60",
        mnt = mnt.display(),
        rec = bin("sensor-replay").display(),
        cfg = env.dir.join("nav.toml").display(),
        pid = pidfile.display()
    );
    let mut ns = {
        let mut c = env.command_for(Path::new("unshare"), "record");
        c.args(["-rm", "sh", "-c", &script]);
        Proc(c.spawn().expect("unshare"))
    };
    env.wait_for("record", "subscribed", Duration::from_secs(20));
    let rec_pid: u32 = env.read("rec.pid").trim().parse().expect("recorder pid");
    let inside = PathBuf::from(format!("/proc/{}/root{}", ns.0.id(), mnt.display()));
    let mut play = env.start_play("play", &log, "4");
    // Let it write a first 256 KiB, then fill the file system.
    env.wait_for("record", "effective settings", Duration::from_secs(20));
    let t0 = Instant::now();
    while list_pieces(&inside).iter().map(|p| p.bytes).sum::<u64>() < 256 << 10 {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the recorder wrote nothing: {}",
            env.read("record.err")
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let filler = inside.join("filler");
    {
        use std::io::Write;
        let mut f = std::fs::File::create(&filler).expect("filler");
        let block = vec![0u8; 64 << 10];
        while f.write_all(&block).is_ok() {}
        let _ = f.sync_all();
    }
    env.wait_for("record", "cannot write", Duration::from_secs(20));
    std::thread::sleep(Duration::from_secs(2));
    std::fs::remove_file(&filler).expect("free the space");
    env.wait_for("record", "writing again", Duration::from_secs(20));
    assert_eq!(wait(&mut play.0, Duration::from_secs(120)), Some(0));
    std::thread::sleep(Duration::from_millis(300));
    sigterm(rec_pid);
    env.wait_for("record", "exit 0", Duration::from_secs(20));
    let pieces: Vec<PathBuf> = list_pieces(&inside)
        .into_iter()
        .map(|p| {
            let to = env.dir.join(p.path.file_name().expect("name"));
            std::fs::copy(&p.path, &to).expect("copy out");
            to
        })
        .collect();
    let _ = ns.0.kill();
    let _ = ns.0.wait();
    let err = env.read("record.err");
    let out = env.read("record.out");
    assert_eq!(
        err.matches("cannot write").count(),
        1,
        "the full disk is reported once: {err}"
    );
    let lost: u64 = out
        .split("; ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no lost count: {out}"));
    assert!(lost > 0, "{out}");
    // The replay lost nothing: no subscriber (the recorder included) held it up.
    let play_out = env.read("play.out");
    assert!(play_out.contains(", 0 samples lost"), "{play_out}");
    assert!(pieces.len() >= 2, "no new piece after the full disk: {err}");
    // The piece written after the disk had room again navigates alone.
    let last = pieces.last().expect("pieces").clone();
    check_pieces_navigate_alone(&env, &[last]);
    // The torn piece still reads up to its tear.
    let (records, _) = msgs::navlog::read_all(&std::fs::read(&pieces[0]).expect("piece"));
    assert!(records.len() > 100, "{}", records.len());
}

/// The shipped units as systemd orders them: `true` when the recorder
/// starts before the daemon (so is stopped after it), `false` when after.
/// Read from their `After=` and `Before=`; without an order between them
/// systemd would stop both at once, which no recording can rely on.
fn recorder_starts_first() -> bool {
    let unit = |name: &str| std::fs::read_to_string(repo("systemd").join(name)).expect(name);
    let (daemon, recorder) = (unit("nav-daemon.service"), unit("nav-recorder.service"));
    let names = |text: &str, key: &str, of: &str| {
        text.lines()
            .filter_map(|l| l.strip_prefix(&format!("{key}=")))
            .any(|v| v.split_whitespace().any(|u| u == of))
    };
    let before = names(&recorder, "Before", "nav-daemon.service")
        || names(&daemon, "After", "nav-recorder.service");
    let after = names(&recorder, "After", "nav-daemon.service")
        || names(&daemon, "Before", "nav-recorder.service");
    assert!(
        before != after,
        "the units order the recorder and the daemon {}",
        if before { "both ways" } else { "not at all" }
    );
    before
}

/// A flight recorded by the shipped units stopped as systemd stops them at
/// shutdown (the reverse of their start order, each stop complete before
/// the next): the recording ends with the daemon's last solution and its
/// final status, and `batch` on it equals the live run.
#[test]
fn stopped_in_the_units_shutdown_order_the_recording_holds_the_last_solution_and_final_status() {
    let env = Env::new("stoporder");
    let log = short_log(&env.dir, 20.0);
    let rec_path = env.dir.join("recorded.navlog");
    let recorder_first = recorder_starts_first();
    let (mut daemon, mut recorder) = if recorder_first {
        let r = env.start_recorder(&rec_path);
        (env.start_daemon("daemon", None), r)
    } else {
        let d = env.start_daemon("daemon", None);
        (d, env.start_recorder(&rec_path))
    };
    let mut play = env.start_play("play", &log, "10");
    assert_eq!(wait(&mut play, Duration::from_secs(120)), Some(0), "play");
    let stop = |p: &mut Proc, name: &str| {
        assert_eq!(
            terminate(&mut p.0, Duration::from_secs(20)),
            Some(0),
            "{name} did not stop cleanly: {}",
            env.read(&format!("{name}.err"))
        );
    };
    if recorder_first {
        stop(&mut daemon, "daemon");
        stop(&mut recorder, "record");
    } else {
        stop(&mut recorder, "record");
        stop(&mut daemon, "daemon");
    }

    // What the daemon published last: batch's last solution (live equals
    // batch bit for bit), and a final status whose cycle count is the one
    // it logs as it stops.
    let file = ConfigFile::load(&env.dir.join("nav.toml")).expect("config");
    let navigate = |bytes: &[u8]| {
        let (records, report) = msgs::navlog::read_all(bytes);
        assert!(report.is_clean(), "{report}");
        let meta = records.iter().find_map(|r| match r {
            Record::Header(h) => Some(h.metadata.clone()),
            _ => None,
        });
        let eff = effective(&file, meta.as_deref(), &CliOverrides::default()).expect("settings");
        let (out, status) = polarnav::session::navigate(&records, eff.session());
        (records, out.solutions, status)
    };
    let (_, batch, batch_status) = navigate(&std::fs::read(&log).expect("log"));
    let daemon_log = env.read("daemon.err");
    let final_cycles: u64 = daemon_log
        .lines()
        .find(|l| l.contains("final status published"))
        .and_then(|l| l.split_whitespace().find_map(|w| w.strip_prefix("cycles=")))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no final status line with cycles=: {daemon_log}"));

    let recording = std::fs::read(&rec_path).expect("recording");
    let (records, replayed, _) = navigate(&recording);
    let last_solution = records.iter().rev().find_map(|r| match r {
        Record::Solution(s) => Some(**s),
        _ => None,
    });
    let last_status = records.iter().rev().find_map(|r| match r {
        Record::Status(s) => Some(**s),
        _ => None,
    });
    let last_batch = batch.last().copied().expect("batch solutions");
    eprintln!(
        "recorder {} the daemon; recorded last solution t = {:?} ns, batch's t = {} ns; \
         last status cycles {:?}, the daemon's final {final_cycles}",
        if recorder_first {
            "started before"
        } else {
            "started after"
        },
        last_solution.map(|s| s.t_ns),
        last_batch.t_ns,
        last_status.map(|s| s.cycles),
    );
    assert_eq!(
        last_solution,
        Some(last_batch),
        "the recording does not end with the daemon's last solution"
    );
    let last_status = last_status.expect("no status recorded");
    assert_eq!(
        last_status.cycles, final_cycles,
        "the recording's last status is not the daemon's final one"
    );
    let counts = |c: &msgs::StreamCounters| (c.received, c.accepted, c.not_used);
    assert_eq!(
        counts(last_status.imu()),
        counts(batch_status.imu()),
        "the final status's IMU counters (received, accepted, not used) against batch's"
    );
    // batch on the recording: the live run, every solution and the last.
    let by_t: std::collections::HashMap<u64, &msgs::Solution> =
        replayed.iter().map(|s| (s.t_ns, s)).collect();
    let live: Vec<&msgs::Solution> = records
        .iter()
        .filter_map(|r| match r {
            Record::Solution(s) => Some(&**s),
            _ => None,
        })
        .collect();
    let differing = live
        .iter()
        .filter(|s| by_t.get(&s.t_ns).is_none_or(|b| *b != **s))
        .count();
    assert_eq!(
        differing, 0,
        "batch on the recording differs from the live run"
    );
    assert_eq!(replayed.last(), Some(&last_batch), "batch on the recording");
}
