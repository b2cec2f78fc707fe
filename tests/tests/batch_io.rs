//! `batch` decodes the log on a second thread, a few chunks ahead of the
//! session: a log that fails to read mid-way and an output that fails to
//! write end the run with the error (no hang, no lost report), after
//! exactly the rows a serial run would have written, and a clean run's
//! output and read report do not depend on the threading.

use std::io::{BufReader, Read, Write};

use nav_daemon::batch::{self, BatchError, BatchOptions};
use polarnav_config::ConfigFile;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};
use polarnav_tests::repo;

fn log_bytes(seconds: f64) -> Vec<u8> {
    let text = std::fs::read_to_string(repo("config/scenarios/transpolar.toml"))
        .expect("scenario")
        .replace("duration_s = 4480.0", &format!("duration_s = {seconds}"));
    let s = Scenario::parse(&text, "transpolar").expect("scenario");
    let mut log = Vec::new();
    simulate(&s, &text, SimOptions::default(), &mut log).expect("simulate");
    log
}

/// Gives `ok` bytes of `data`, then an I/O error.
struct FailingReader<'a> {
    data: &'a [u8],
    ok: usize,
}

impl Read for FailingReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.ok == 0 {
            return Err(std::io::Error::other("device went away"));
        }
        let n = buf.len().min(self.ok).min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        self.ok -= n;
        Ok(n)
    }
}

/// Accepts `room` bytes, then fails as a full disk does.
struct FullDisk<'a> {
    out: &'a mut Vec<u8>,
    room: usize,
}

impl Write for FullDisk<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.room == 0 {
            return Err(std::io::Error::from_raw_os_error(28));
        }
        let n = buf.len().min(self.room);
        self.out.extend_from_slice(&buf[..n]);
        self.room -= n;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn run(
    log: impl std::io::BufRead + Send,
    out: impl Write,
) -> Result<batch::BatchReport, BatchError> {
    batch::run(
        log,
        "test.navlog",
        out,
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
}

#[test]
fn a_log_that_fails_mid_way_ends_with_the_error_after_every_row_before_it() {
    // 30 s at 200 Hz: 6000 IMU records, many chunks.
    let log = log_bytes(30.0);
    let mut full = Vec::new();
    let report = run(log.as_slice(), &mut full).expect("clean run");
    assert!(report.read.is_clean());
    assert_eq!(report.rows, 6000);
    // A run on the first 60 % of the bytes that ends cleanly (truncated).
    let cut = log.len() * 3 / 5;
    let mut truncated = Vec::new();
    let t = run(&log[..cut], &mut truncated).expect("truncated run");
    assert_eq!(t.read.truncated, 1, "{}", t.read);
    // The same bytes, then an I/O error: the run fails naming the log,
    // and everything written before is the truncated run's, row for row
    // (the row of the last sample before the error is pending, not
    // written: a solution goes out when the next sample arrives).
    let mut partial = Vec::new();
    let e = run(
        BufReader::with_capacity(
            1 << 12,
            FailingReader {
                data: &log,
                ok: cut,
            },
        ),
        &mut partial,
    )
    .expect_err("the read error");
    assert!(
        matches!(&e, BatchError::Read { path, .. } if path == "test.navlog"),
        "{e}"
    );
    let (a, b) = (
        String::from_utf8(partial).expect("utf-8"),
        String::from_utf8(truncated).expect("utf-8"),
    );
    let (a, b): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    assert!(a.len() > 3000, "{} rows before the error", a.len());
    assert_eq!(a.len(), b.len() - 1, "every row but the pending last one");
    assert_eq!(a[..], b[..a.len()], "the rows before the error");
}

#[test]
fn a_full_disk_ends_the_run_with_the_write_error() {
    let log = log_bytes(30.0);
    let mut out = Vec::new();
    let e = run(
        log.as_slice(),
        std::io::BufWriter::with_capacity(
            1 << 12,
            FullDisk {
                out: &mut out,
                room: 100_000,
            },
        ),
    )
    .expect_err("the write error");
    assert!(
        matches!(&e, BatchError::Write(io) if io.raw_os_error() == Some(28)),
        "{e}"
    );
    assert_eq!(out.len(), 100_000);
}
