//! Benchmark (not a test): the cost of `nav-daemon batch --smooth`.
//!
//! 1. The 1 h, 200 Hz flight of `batch_rtf` (transpolar, SRS/CNS/baro),
//!    full solution CSV: the forward batch and the smoothed batch, three
//!    runs each, and the backward pass as their difference, against the
//!    target "the smoothed pass costs at most as much wall time as the
//!    forward pass"; peak resident memory of each.
//! 2. A long flight (30 h at 200 Hz by default; `POLARNAV_BENCH_LONG_H`
//!    sets the hours), simulated into a pipe on a second thread (no log on
//!    disk) and smoothed with the CSV thrown away: wall time, the tape's
//!    size and the chunks that went to the temporary file, and the peak
//!    resident memory of the process (the simulator thread included: an
//!    upper bound), against the target of 1 GB. The tape needs about
//!    0.23 GB of disk per flight hour in the temporary directory; the part
//!    is skipped, saying so, when the disk has not that much free.
//!
//! Run with `cargo bench -p polarnav-tests --bench smoother`.

use std::io::{BufReader, BufWriter};
use std::time::Instant;

use nav_daemon::batch::{self, BatchOptions};
use polarnav_config::ConfigFile;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

const FLIGHT_S: f64 = 3600.0;
const TARGET_PEAK_BYTES: f64 = 1e9;

/// Resets the peak resident set size of this process (Linux `clear_refs` 5).
fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// Peak resident set size of this process since the last reset (bytes).
fn peak_bytes() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| {
                l.split_whitespace()
                    .nth(1)
                    .and_then(|k| k.parse::<f64>().ok())
            })
        })
        .map_or(f64::NAN, |kb| kb * 1024.0)
}

fn scenario_text(seconds: f64) -> String {
    let scen = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../config/scenarios/transpolar.toml");
    std::fs::read_to_string(scen)
        .expect("scenario")
        .replace("duration_s = 4480.0", &format!("duration_s = {seconds}"))
}

/// One batch run over `log` to a CSV file in `dir`: wall time (s), peak
/// resident memory (bytes) and the report.
fn one_run(
    log: &std::path::Path,
    dir: &std::path::Path,
    smooth: bool,
) -> (f64, f64, batch::BatchReport) {
    let out = dir.join("solution.csv");
    let _ = std::fs::remove_file(&out);
    let _ = std::process::Command::new("sync").status();
    reset_peak();
    let t = Instant::now();
    let r = batch::run(
        BufReader::with_capacity(1 << 20, std::fs::File::open(log).expect("open")),
        "flight.navlog",
        BufWriter::with_capacity(1 << 20, std::fs::File::create(&out).expect("create")),
        &ConfigFile::defaults(),
        &BatchOptions {
            smooth: smooth.then(|| dir.to_path_buf()),
            ..Default::default()
        },
    )
    .expect("batch");
    (t.elapsed().as_secs_f64(), peak_bytes(), r)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Free bytes on the file system of `dir` (`df`), if it can be read.
fn free_bytes(dir: &std::path::Path) -> Option<f64> {
    let out = std::process::Command::new("df")
        .args(["--output=avail", "-B1"])
        .arg(dir)
        .output()
        .ok()?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .nth(1)?
        .trim()
        .parse()
        .ok()
}

fn main() {
    let dir = std::env::temp_dir().join(format!("polarnav-bench-smoother-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    };

    // 1. The 1 h flight, forward and smoothed, interleaved.
    let text = scenario_text(FLIGHT_S);
    let s = Scenario::parse(&text, "bench").expect("scenario");
    let log = dir.join("flight.navlog");
    simulate(
        &s,
        &text,
        SimOptions::default(),
        BufWriter::new(std::fs::File::create(&log).expect("create")),
    )
    .expect("simulate");
    let (mut fwd, mut smo, mut fwd_peak, mut smo_peak) = (Vec::new(), Vec::new(), 0.0f64, 0.0f64);
    let mut report = None;
    for _ in 0..3 {
        let (t, p, _) = one_run(&log, &dir, false);
        fwd.push(t);
        fwd_peak = fwd_peak.max(p);
        let (t, p, r) = one_run(&log, &dir, true);
        smo.push(t);
        smo_peak = smo_peak.max(p);
        report = r.smoothed;
    }
    let (f, sm) = (median(fwd.clone()), median(smo.clone()));
    let back = sm - f;
    let r = report.expect("smoothed");
    println!(
        "smoother over a {FLIGHT_S:.0} s, 200 Hz flight with SRS/CNS/baro, full CSV (load average at the end: {})",
        load()
    );
    println!(
        "  forward batch: median {f:.3} s (runs {fwd:.3?}), peak memory {:.0} MB",
        fwd_peak / 1e6
    );
    println!(
        "  smoothed batch: median {sm:.3} s (runs {smo:.3?}), peak memory {:.0} MB; tape {:.0} MB, {} chunks to the temporary file, {} failed backward steps",
        smo_peak / 1e6,
        r.tape_bytes as f64 / 1e6,
        r.stored_chunks,
        r.failed_steps
    );
    println!(
        "  smoothed pass (smoothed − forward batch): {back:.3} s = {:.2} × the forward pass; target at most 1 × ({})",
        back / f,
        if back <= f { "met" } else { "NOT met" }
    );

    // 2. The long flight, simulated into a pipe.
    let hours: f64 = std::env::var("POLARNAV_BENCH_LONG_H")
        .ok()
        .and_then(|h| h.parse().ok())
        .unwrap_or(30.0);
    let need = hours * 0.3e9;
    match free_bytes(&dir) {
        Some(free) if free < need => {
            println!(
                "  {hours} h flight: skipped, {:.1} GB free in {} and the tape needs about {:.1} GB",
                free / 1e9,
                dir.display(),
                need / 1e9
            );
        }
        _ => {
            let text = scenario_text(hours * 3600.0);
            let s = Scenario::parse(&text, "bench-long").expect("scenario");
            let (reader, writer) = std::io::pipe().expect("pipe");
            reset_peak();
            let t = Instant::now();
            let sim = std::thread::spawn(move || {
                simulate(
                    &s,
                    &text,
                    SimOptions::default(),
                    BufWriter::with_capacity(1 << 20, writer),
                )
                .expect("simulate");
            });
            let r = batch::run(
                BufReader::with_capacity(1 << 20, reader),
                "long.navlog",
                BufWriter::with_capacity(1 << 20, std::io::sink()),
                &ConfigFile::defaults(),
                &BatchOptions {
                    smooth: Some(dir.clone()),
                    ..Default::default()
                },
            )
            .expect("batch");
            sim.join().expect("simulator");
            let wall = t.elapsed().as_secs_f64();
            let peak = peak_bytes();
            let sr = r.smoothed.expect("smoothed");
            println!(
                "  {hours} h flight at 200 Hz ({} solutions, {} switches): simulated, navigated and smoothed in {wall:.0} s; tape {:.2} GB, {} chunks to the temporary file; peak memory {:.0} MB (simulator included); target at most {:.0} MB ({})",
                sr.solutions,
                r.switches.len(),
                sr.tape_bytes as f64 / 1e9,
                sr.stored_chunks,
                peak / 1e6,
                TARGET_PEAK_BYTES / 1e6,
                if peak <= TARGET_PEAK_BYTES {
                    "met"
                } else {
                    "NOT met"
                }
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
