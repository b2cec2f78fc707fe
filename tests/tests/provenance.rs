//! Provenance of the files the programs write: a batch MCAP records the
//! program, its version and commit, the command line and every effective
//! setting with its source (read back with the reference reader, PyPI
//! `mcap`), so two runs with different options differ in their metadata;
//! `--utc-start` makes the log times dates; `--version` names the commit.
//! A `sensor-replay record` MCAP records its provenance too.

use std::process::Command;

use polarnav_tests::harness::short_log;
use polarnav_tests::{bin, python, repo};

/// The metadata and time span of an MCAP file, by the reference reader.
fn read_metadata(mcap: &std::path::Path) -> serde_json::Value {
    let out = Command::new(python())
        .arg(repo("tests/python/mcap_metadata.py"))
        .arg(mcap)
        .output()
        .expect("python");
    assert!(
        out.status.success(),
        "the reference reader refused {}: {}",
        mcap.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("mcap_metadata's JSON")
}

fn batch(log: &std::path::Path, out: &std::path::Path, extra: &[&str]) {
    let o = Command::new(bin("nav-daemon"))
        .arg("batch")
        .arg("--config")
        .arg(repo("config/nav-daemon.toml"))
        .arg("--log")
        .arg(log)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .expect("nav-daemon batch");
    assert!(
        o.status.success(),
        "batch {extra:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A commit as `--version` and the metadata carry it: 12 hex digits, with
/// `-dirty` for a build of a modified checkout.
fn is_commit(c: &str) -> bool {
    let hex = c.strip_suffix("-dirty").unwrap_or(c);
    hex.len() == 12 && hex.bytes().all(|b| b.is_ascii_hexdigit())
}

#[test]
fn batch_mcap_metadata_records_program_commit_command_line_and_settings_with_sources() {
    let dir = std::env::temp_dir().join(format!("polarnav-provenance-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let log = short_log(&dir, 20.0);
    let (a, b) = (dir.join("default.mcap"), dir.join("never.mcap"));
    batch(&log, &a, &[]);
    let utc = "2026-11-25T09:30:00Z";
    // `date -u -d 2026-11-25T09:30:00Z +%s`
    let utc_ns: u64 = 1_795_599_000 * 1_000_000_000;
    batch(
        &log,
        &b,
        &["--no-switch", "--conversion", "none", "--utc-start", utc],
    );
    let (ma, mb) = (read_metadata(&a), read_metadata(&b));
    let (pa, pb) = (
        &ma["metadata"]["polarnav.provenance"],
        &mb["metadata"]["polarnav.provenance"],
    );
    for p in [pa, pb] {
        assert_eq!(p["program"], "nav-daemon batch", "{p}");
        assert_eq!(p["version"], env!("CARGO_PKG_VERSION"), "{p}");
        let commit = p["commit"].as_str().expect("commit");
        assert!(is_commit(commit), "commit {commit:?} is not 12 hex digits");
        let cl = p["command_line"].as_str().expect("command line");
        assert!(cl.contains(" batch ") && cl.contains("--log"), "{cl}");
    }
    assert!(
        pb["command_line"]
            .as_str()
            .is_some_and(|c| c.contains("--no-switch --conversion none --utc-start")),
        "{pb}"
    );
    assert!(pa.get("utc_start").is_none(), "{pa}");
    assert_eq!(pb["utc_start"], utc);
    assert_eq!(pb["utc_start_ns"], utc_ns.to_string());

    // Every effective setting, with its source; the options show in both.
    let (sa, sb) = (
        ma["metadata"]["polarnav.settings"]
            .as_object()
            .expect("settings a"),
        mb["metadata"]["polarnav.settings"]
            .as_object()
            .expect("settings b"),
    );
    assert!(sa.len() > 30, "only {} settings: {sa:?}", sa.len());
    let keys =
        |m: &serde_json::Map<String, serde_json::Value>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        keys(sa),
        keys(sb),
        "the same settings, whatever the options"
    );
    let get = |m: &serde_json::Map<String, serde_json::Value>, k: &str| {
        m.get(k)
            .and_then(|v| v.as_str())
            .unwrap_or_else(|| panic!("no setting {k}: {m:?}"))
            .to_owned()
    };
    assert!(
        get(sa, "frame.conversion").starts_with("\"paper\"  # "),
        "{}",
        get(sa, "frame.conversion")
    );
    assert!(!get(sa, "frame.conversion").ends_with("# command line"));
    assert_eq!(get(sb, "frame.conversion"), "\"none\"  # command line");
    assert_eq!(get(sb, "frame.never_switch"), "true  # command line");
    assert!(get(sa, "frame.never_switch").starts_with("false  # "));
    for (k, v) in sa {
        let v = v.as_str().expect("text");
        assert!(
            [
                "# default",
                "# config file ",
                "# navlog header",
                "# command line"
            ]
            .iter()
            .any(|s| v.contains(s)),
            "{k} = {v}: no source"
        );
    }
    let differing: Vec<&String> = sa.keys().filter(|k| sa[*k] != sb[*k]).collect();
    assert!(
        differing.len() >= 2,
        "the options change only {differing:?}"
    );
    // The navlog header's own record is still there.
    assert!(ma["metadata"]["polarnav"]["producer"].is_string(), "{ma}");

    // Log times: sensor time without an epoch (the 20 s log), dates with one.
    let (start_a, start_b) = (
        ma["message_start_time"].as_u64().expect("start a"),
        mb["message_start_time"].as_u64().expect("start b"),
    );
    assert!(start_a < 3_600 * 1_000_000_000, "{start_a}");
    assert_eq!(start_b, utc_ns + start_a, "log time = epoch + sensor time");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn version_of_both_binaries_names_a_hex_commit() {
    for b in ["nav-daemon", "sensor-replay"] {
        let o = Command::new(bin(b)).arg("--version").output().expect(b);
        assert!(o.status.success(), "{b} --version");
        let text = String::from_utf8_lossy(&o.stdout).trim().to_owned();
        let commit = text
            .split_once("(commit ")
            .and_then(|(_, r)| r.strip_suffix(')'))
            .unwrap_or_else(|| panic!("{b}: no commit in {text:?}"));
        assert!(
            text.starts_with(&format!("{b} {} ", env!("CARGO_PKG_VERSION"))),
            "{text}"
        );
        assert!(is_commit(commit), "{b}: {commit:?} is not 12 hex digits");
    }
}

#[test]
fn utc_start_that_is_not_a_date_is_refused_as_usage() {
    let o = Command::new(bin("nav-daemon"))
        .args(["batch", "--log", "x.navlog", "--out", "x.mcap"])
        .args(["--utc-start", "2026-02-30T00:00:00Z"])
        .output()
        .expect("nav-daemon");
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--utc-start") && err.contains("day 30"),
        "{err}"
    );
}

/// `sensor-replay record --out F.mcap` says what produced it, as `export`
/// and `batch` do: program, version, commit and the command line; with
/// `--utc-start` the epoch too. No daemon is needed for the record: the
/// recorder stops after its `--duration` with nothing received (a file of
/// metadata, header and no messages).
#[test]
fn record_mcap_metadata_records_program_commit_and_command_line() {
    let dir = std::env::temp_dir().join(format!("polarnav-rec-prov-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let prefix = format!("rec-prov-{}", std::process::id());
    let utc = "2026-11-25T09:30:00Z";
    let record = |out: &std::path::Path, extra: &[&str]| {
        Command::new(bin("sensor-replay"))
            .args(["record", "--prefix", &prefix, "--duration", "0.3", "--out"])
            .arg(out)
            .args(extra)
            .output()
            .expect("sensor-replay record")
    };
    let (a, b) = (dir.join("plain.mcap"), dir.join("dated.mcap"));
    for (out, extra) in [(&a, &[][..]), (&b, &["--utc-start", utc][..])] {
        let o = record(out, extra);
        assert!(
            o.status.success(),
            "record {extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let (ma, mb) = (read_metadata(&a), read_metadata(&b));
    for (m, out) in [(&ma, &a), (&mb, &b)] {
        let p = &m["metadata"]["polarnav.provenance"];
        assert_eq!(p["program"], "sensor-replay record", "{m}");
        assert_eq!(p["version"], env!("CARGO_PKG_VERSION"), "{p}");
        let commit = p["commit"].as_str().expect("commit");
        assert!(is_commit(commit), "commit {commit:?} is not 12 hex digits");
        let cl = p["command_line"].as_str().expect("command line");
        let want = format!(
            " record --prefix {prefix} --duration 0.3 --out {}",
            out.display()
        );
        assert!(cl.contains(&want), "{cl} lacks {want}");
        // The navlog header's record (producer, settings) is still there.
        assert!(m["metadata"]["polarnav"]["producer"].is_string(), "{m}");
    }
    let (pa, pb) = (
        &ma["metadata"]["polarnav.provenance"],
        &mb["metadata"]["polarnav.provenance"],
    );
    assert!(pa.get("utc_start").is_none(), "{pa}");
    assert!(
        pb["command_line"]
            .as_str()
            .is_some_and(|c| c.ends_with(&format!("--utc-start {utc}"))),
        "{pb}"
    );
    assert_eq!(pb["utc_start"], utc);
    // `date -u -d 2026-11-25T09:30:00Z +%s`
    assert_eq!(
        pb["utc_start_ns"],
        (1_795_599_000u64 * 1_000_000_000).to_string()
    );

    // A navlog output has no log times: --utc-start is refused as usage.
    let o = record(&dir.join("x.navlog"), &["--utc-start", utc]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--utc-start") && err.contains("not .mcap"),
        "{err}"
    );
    assert!(!dir.join("x.navlog").exists());
    std::fs::remove_dir_all(&dir).ok();
}
