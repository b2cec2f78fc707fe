//! Helpers of the eval tests: the repository's files, batch in-process,
//! `sensor-replay eval` as a process, and the size of a PNG.

use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};
use std::process::Command;

use nav_daemon::batch::{self, BatchOptions, Output};
use polarnav_config::{CliOverrides, ConfigFile};

/// A path of the repository (relative to its top).
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// `nav-daemon batch` of `log` into `out` with the shipped defaults.
pub fn batch_to(log: &Path, out: Output<BufWriter<std::fs::File>>, cli: CliOverrides) {
    let report = batch::run_to(
        BufReader::new(std::fs::File::open(log).expect("open log")),
        "test.navlog",
        out,
        &ConfigFile::defaults(),
        &BatchOptions {
            cli,
            ..Default::default()
        },
    )
    .expect("batch");
    assert!(report.rows > 0);
}

/// `sensor-replay eval ARGS`, which must succeed; its standard output.
pub fn eval(args: &[&std::ffi::OsStr]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .arg("eval")
        .args(args)
        .output()
        .expect("run sensor-replay eval");
    assert!(
        o.status.success(),
        "eval failed ({}): {}",
        o.status,
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).expect("utf-8 summary")
}

/// A PNG's width and height from its IHDR chunk, after checking the signature.
pub fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    (be(16), be(20))
}
