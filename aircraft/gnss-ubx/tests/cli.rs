//! The driver's command line, run as the installed binary: the shipped
//! settings are valid, settings that cannot work exit 2 naming the file and
//! the key, a `--file` that cannot be opened exits 2 naming it, and a file
//! of garbage ends with exit 0 and every byte counted. (The pseudo-terminal,
//! pyubx2 and 10-minute tests are in `tests/tests/gnss_ubx.rs`; this file
//! also makes `cargo test --workspace` build the binary they run.)

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_gnss-ubx");

fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gnss-ubx-cli-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch directory");
    d
}

/// The binary with an isolated iceoryx2 prefix and root, so no test meets a
/// real daemon or another test.
fn isolated(args: &[&std::ffi::OsStr]) -> Output {
    let cfg = polarnav_ipc::TransportConfig::isolated("ubxcli");
    let out = Command::new(BIN)
        .args(args)
        .arg("--prefix")
        .arg(&cfg.prefix)
        .env(
            "POLARNAV_IOX_PREFIX",
            cfg.iox_prefix.clone().expect("isolated"),
        )
        .env("POLARNAV_IOX_ROOT", cfg.iox_root.clone().expect("isolated"))
        .output();
    // Its iceoryx2 root and shared-memory files go with it.
    polarnav_ipc::remove_isolated(&cfg);
    out.expect("run gnss-ubx")
}

fn check(path: &Path) -> (i32, String) {
    let out = Command::new(BIN)
        .arg("--check-config")
        .arg(path)
        .output()
        .expect("run gnss-ubx");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_shipped_settings_are_valid() {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/gnss-ubx.toml");
    let (code, err) = check(&shipped);
    assert_eq!(code, 0, "{}: {err}", shipped.display());
}

#[test]
fn absurd_settings_exit_2_naming_the_file_and_the_key() {
    let dir = scratch("bad");
    for (text, key) in [
        ("baud = 0\n", "baud"),
        ("baud = 4000000000\n", "baud"),
        ("rate_hz = 0\n", "rate_hz"),
        ("rate_hz = 1e9\n", "rate_hz"),
        ("rate_hz = nan\n", "rate_hz"),
        ("reconnect_s = 1e-10\n", "reconnect_s"),
        ("reconnect_s = inf\n", "reconnect_s"),
        ("report_s = 1e18\n", "report_s"),
        ("[time]\noffset_s = 1e6\n", "offset_s"),
        ("[time]\ngps_utc_offset_s = -1\n", "gps_utc_offset_s"),
        ("[time]\nweek = 99999\n", "week"),
        ("bogus = 1\n", "bogus"),
    ] {
        let path = dir.join("bad.toml");
        std::fs::write(&path, text).expect("settings");
        let (code, err) = check(&path);
        assert_eq!(code, 2, "{text:?}: exit {code}, {err}");
        assert!(
            err.contains(key) && err.contains("bad.toml"),
            "{text:?}: the message names the file and `{key}`: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_that_cannot_be_opened_exits_2_naming_it() {
    let dir = scratch("missing");
    let missing = dir.join("no-such.ubx");
    let out = isolated(&["--file".as_ref(), missing.as_os_str()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no-such.ubx"), "names the file: {err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_of_garbage_ends_with_every_byte_counted() {
    let dir = scratch("garbage");
    let path = dir.join("garbage.ubx");
    // No 0xB5 sync byte anywhere: every byte is garbage between frames.
    let bytes: Vec<u8> = (0..4096u32).map(|i| (i % 0xB0) as u8).collect();
    std::fs::write(&path, &bytes).expect("file");
    let out = isolated(&["--file".as_ref(), path.as_os_str()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("published=0 ")
            && err.contains("frames=0 ")
            && err.contains("garbage_bytes=4096 "),
        "every byte counted as garbage, nothing published: {err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
