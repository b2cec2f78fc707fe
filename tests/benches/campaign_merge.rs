//! `campaign merge` against its bounds (not a test): writes a synthetic
//! result set of 100 000 runs (`MERGE_RUNS=N` to change it) with
//! `store::write_result`, as the executors do (each file synced: written
//! on 8 threads, not timed), then merges it in a child process of its own
//! (this binary again) and prints the merge's time and the child's peak
//! resident set (`VmHWM`: the merge alone, not the generation, whose
//! memory this process keeps), against the bounds: under 10 s and 500 MB.
//! It merges twice: with the files in the page cache as just written, and
//! after dropping them from it (`posix_fadvise` through `python3`; skipped
//! without it), so that the second reads them from the disk as a merge on
//! another machine of the cluster would. Exits non-zero over either bound.
//!
//! The set: 12 variations (6 scenarios: two clean, three spoofer profiles,
//! one jammer; each with a tactical and a MEMS IMU), flights of 0.5 to 3 h,
//! log-normal errors, about 0.3 % failed runs with four reasons, five
//! runs missing and one result damaged; the MEMS attitude NEES a tenth too
//! high (the report shows it OUTSIDE its band).
//!
//! `MERGE_KEEP=1` keeps the directory (its path is printed) to read the
//! report; `MERGE_DIR=path` merges an existing set instead of writing one.
//!
//! `cargo bench -p polarnav-tests --bench campaign_merge`

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

use sensor_replay::campaign::merge::merge;
use sensor_replay::campaign::row::{Cost, Metrics, Outcome};
use sensor_replay::campaign::store::{self, RunResult};

const SECONDS_BOUND: f64 = 10.0;
const RSS_BOUND_MB: f64 = 500.0;
const CHILD_ENV: &str = "POLARNAV_MERGE_BENCH_CHILD";
const TITLE: &str = "synthetic campaign (campaign_merge bench)";
/// Runs with no result file, and the one whose file is damaged.
const MISSING: [u64; 5] = [4711, 4712, 4713, 50_000, 99_999];
const DAMAGED: u64 = 77_777;

const SCENARIOS: [(&str, Option<&str>); 6] = [
    ("transpolar-gnss", None),
    ("svalbard-survey", None),
    ("spoof-ramp", Some("spoof")),
    ("spoof-step", Some("spoof")),
    ("spoof-meaconing", Some("spoof")),
    ("jam-barrage", Some("jam")),
];
const PRESETS: [&str; 2] = ["tactical", "mems"];
const REASONS: [&str; 4] = [
    "timed out after 900 s",
    "panicked at 'attitude quaternion not finite' (nav-daemon/core/src/ins.rs:412)",
    "scenario could not be simulated: the track leaves the terrain model",
    "the navigator never started (no init in the log)",
];

fn sha() -> String {
    store::sha256_hex(TITLE.as_bytes())
}

/// SplitMix64: the rows are a function of their index alone.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        let v = self.uniform();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
    /// Log-normal with median `m` and log-σ `s`.
    fn lognormal(&mut self, m: f64, s: f64) -> f64 {
        m * (s * self.normal()).exp()
    }
    fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }
}

fn result(index: u64) -> RunResult {
    let mut rng = Rng(index.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5EED);
    let variation = (index % 12) as u32;
    let (scenario, fault) = SCENARIOS[variation as usize / 2];
    let preset = PRESETS[variation as usize % 2];
    let label = format!("scenario={scenario} preset={preset} gnss=on seed=derived");
    let seed = rng.next();
    let mems = preset == "mems";
    let flight_h = 0.5 + 2.5 * rng.uniform();
    let cpu_s = flight_h * 3600.0 / rng.lognormal(600.0, 0.1);
    let cost = Cost {
        index,
        flight_h,
        cpu_s,
        simulate_cpu_s: 0.2 * cpu_s,
        navigate_cpu_s: 0.65 * cpu_s,
        evaluate_cpu_s: 0.1 * cpu_s,
        wall_s: cpu_s * 1.02,
        peak_rss_mib: 60.0 + 30.0 * rng.uniform(),
        host: format!("node-{:02}", index % 16),
        executor: if index.is_multiple_of(2) {
            "local".into()
        } else {
            format!("slurm 812345_{index}")
        },
        version: "0.1.0".into(),
        commit: "fe4cb00".into(),
    };
    if rng.chance(0.003) {
        let reason = REASONS[(rng.next() % 4) as usize].to_owned();
        let metrics = Metrics::failed(index, variation, &label, scenario, seed, reason);
        let cost = Cost {
            flight_h: 0.0,
            ..cost
        };
        return RunResult {
            campaign_sha256: sha(),
            metrics,
            cost,
        };
    }
    let mut m = Metrics::failed(index, variation, &label, scenario, seed, String::new());
    m.outcome = Outcome::Ok;
    m.flight_h = Some(flight_h);
    let epochs = (flight_h * 36_000.0) as u64;
    m.epochs = Some(epochs);
    m.non_finite_epochs = Some(0);
    let h = rng.lognormal(if mems { 12.0 } else { 3.0 }, 0.5);
    m.horizontal_rmse_m = Some(h);
    m.horizontal_max_m = Some(h * (2.5 + rng.normal().abs()));
    let v = 0.6 * h * rng.lognormal(1.0, 0.2);
    m.vertical_rmse_m = Some(v);
    m.vertical_max_m = Some(v * (2.5 + rng.normal().abs()));
    let vel = rng.lognormal(if mems { 0.2 } else { 0.05 }, 0.3);
    m.velocity_rmse_mps = Some(vel);
    m.velocity_max_mps = Some(vel * (3.0 + rng.normal().abs()));
    let att = rng.lognormal(if mems { 6.0 } else { 1.5 }, 0.3);
    m.attitude_rmse_arcmin = Some(att);
    m.attitude_max_arcmin = Some(att * (3.0 + rng.normal().abs()));
    // A run's mean NEES scatters about 3 (about 20 independent epochs'
    // worth); the MEMS attitude is a tenth too confident.
    let nees = |rng: &mut Rng, mean: f64| mean * (1.0 + 0.3 * rng.normal()).max(0.05);
    m.nees_position = Some(nees(&mut rng, 3.0));
    m.nees_velocity = Some(nees(&mut rng, 3.0));
    m.nees_attitude = Some(nees(&mut rng, if mems { 3.3 } else { 3.0 }));
    m.switches = Some(u32::from(scenario == "transpolar-gnss"));
    let fixes = (flight_h * 3600.0) as u64;
    m.gnss_fixes = Some(fixes);
    let untested = fixes / 40;
    m.gnss_tested = Some(fixes - untested);
    m.gnss_untested = Some(untested);
    m.reinits = Some(0);
    m.covariance_repairs = Some(u64::from(rng.chance(0.01)));
    m.max_q_ratio = Some(rng.lognormal(0.3, 0.3));
    let mut exclusions = 0;
    let mut false_exclusions = 0;
    if rng.chance(1e-4) {
        false_exclusions = 1;
        exclusions = 1;
    }
    m.fault = fault.map(str::to_owned);
    if fault == Some("spoof") {
        m.fault_start_s = Some(600.0 + 1200.0 * rng.uniform());
        let detected = rng.chance(0.9995);
        m.fault_detected = Some(detected);
        if detected {
            exclusions += 1;
            // A step is caught at once, a slow ramp or a meaconer later
            // and further off.
            let (tte, err) = match scenario {
                "spoof-step" => (3.0, 25.0),
                "spoof-ramp" => (12.0, 45.0),
                _ => (25.0, 90.0),
            };
            m.time_to_exclusion_s = Some(rng.lognormal(tte, 0.5));
            m.error_at_exclusion_m = Some(15.0 + rng.lognormal(err, 0.6));
            m.max_q_ratio = Some(rng.lognormal(30.0, 0.5));
        }
    } else if fault == Some("jam") {
        m.fault_start_s = Some(600.0 + 1200.0 * rng.uniform());
    }
    m.gnss_exclusions = Some(exclusions);
    m.gnss_readmissions = Some(exclusions);
    m.gnss_false_exclusions = Some(false_exclusions);
    m.resets = Some(exclusions as u32);
    m.resets_aid = Some(0);
    m.resets_integrity = Some(exclusions as u32);
    m.reset_causes = Some(if exclusions > 0 {
        format!("gnss:{exclusions}")
    } else {
        String::new()
    });
    RunResult {
        campaign_sha256: sha(),
        metrics: m,
        cost,
    }
}

/// Writes runs `0..runs` (but the missing ones) on 8 threads: the
/// executors' write, synced file by file, is bound by the disk's syncs.
fn generate(dir: &Path, runs: u64) {
    let threads = 8u64;
    let per = runs.div_ceil(threads);
    std::thread::scope(|s| {
        for t in 0..threads {
            s.spawn(move || {
                for i in t * per..((t + 1) * per).min(runs) {
                    if MISSING.contains(&i) {
                        continue;
                    }
                    store::write_result(dir, &result(i)).expect("write a result");
                }
            });
        }
    });
    if DAMAGED < runs {
        let p = store::result_path(dir, DAMAGED);
        let mut bytes = std::fs::read(&p).expect("read");
        let k = bytes.len() / 2;
        bytes[k] ^= 0x20;
        std::fs::write(&p, bytes).expect("damage");
    }
}

fn vm_kb(field: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(field))?
                .split_whitespace()
                .nth(1)?
                .parse()
                .ok()
        })
        .unwrap_or(0)
}

/// The child: merges and prints `seconds rss_before_kb vmhwm_kb summary`.
fn child(dir: &Path, runs: u64) -> ExitCode {
    let before = vm_kb("VmRSS:");
    let t = Instant::now();
    match merge(dir, &sha(), runs, TITLE) {
        Ok(s) => {
            let secs = t.elapsed().as_secs_f64();
            println!("{secs} {before} {}", vm_kb("VmHWM:"));
            println!("{s}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("merge failed: {e}");
            ExitCode::from(2)
        }
    }
}

fn size_mb(p: &Path) -> f64 {
    std::fs::metadata(p).map_or(0.0, |m| m.len() as f64 / 1e6)
}

/// A merge in a child process: its seconds, resident set before it and
/// peak (kB), and the wall time around the child.
struct Measured {
    secs: f64,
    before_kb: f64,
    hwm_kb: f64,
    wall: f64,
}

fn measure(exe: &Path, dir: &Path, runs: u64, echo: bool) -> Result<Measured, String> {
    let t = Instant::now();
    let out = Command::new(exe)
        .env(CHILD_ENV, dir)
        .env("MERGE_RUNS", runs.to_string())
        .output()
        .map_err(|e| format!("cannot start the merge: {e}"))?;
    let wall = t.elapsed().as_secs_f64();
    if !out.status.success() {
        return Err(format!(
            "the merge failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    let nums: Vec<f64> = lines
        .next()
        .unwrap_or("")
        .split_whitespace()
        .filter_map(|v| v.parse().ok())
        .collect();
    let [secs, before_kb, hwm_kb] = nums[..] else {
        return Err(format!("the merge printed {text}"));
    };
    if echo {
        for l in lines {
            println!("campaign_merge: {l}");
        }
    }
    Ok(Measured {
        secs,
        before_kb,
        hwm_kb,
        wall,
    })
}

/// Drops the result files from the page cache (`posix_fadvise` DONTNEED,
/// through Python's `os`: the standard library has no call for it), so
/// that the next merge reads them from the disk. The files are synced.
fn evict(dir: &Path) -> Result<(), String> {
    let script = "import os, sys\n\
        d = sys.argv[1]\n\
        for f in os.listdir(d): fd = os.open(os.path.join(d, f), os.O_RDONLY); \
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED); os.close(fd)\n";
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .arg(store::runs_dir(dir))
        .output()
        .map_err(|e| format!("no python3 ({e})"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).trim().to_owned())
    }
}

fn report(what: &str, runs: u64, m: &Measured) -> bool {
    let rss_mb = m.hwm_kb / 1024.0;
    println!(
        "campaign_merge: {what}: merge of {runs} runs {:.2} s (bound {SECONDS_BOUND} s; {:.2} s with the process's start and exit), peak RSS of the merging process {rss_mb:.0} MB (bound {RSS_BOUND_MB} MB; {:.1} MB before the merge)",
        m.secs,
        m.wall,
        m.before_kb / 1024.0
    );
    m.secs < SECONDS_BOUND && rss_mb < RSS_BOUND_MB
}

fn main() -> ExitCode {
    let runs: u64 = std::env::var("MERGE_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100_000);
    if let Ok(dir) = std::env::var(CHILD_ENV) {
        return child(Path::new(&dir), runs);
    }
    let (dir, generated) = match std::env::var("MERGE_DIR") {
        Ok(d) => (PathBuf::from(d), false),
        Err(_) => (
            std::env::temp_dir().join(format!("polarnav-bench-merge-{}", std::process::id())),
            true,
        ),
    };
    if generated {
        let t = Instant::now();
        generate(&dir, runs);
        println!(
            "campaign_merge: wrote {runs} runs' results ({} missing, {} damaged) in {:.1} s to {} (not timed; this process's peak RSS {:.0} MB)",
            MISSING.iter().filter(|i| **i < runs).count(),
            u8::from(DAMAGED < runs),
            t.elapsed().as_secs_f64(),
            dir.display(),
            vm_kb("VmHWM:") as f64 / 1024.0
        );
    }
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("campaign_merge: cannot find this binary: {e}");
            return ExitCode::from(2);
        }
    };
    let mut ok = true;
    // The files as just written (in the page cache), then read from the disk.
    match measure(&exe, &dir, runs, true) {
        Ok(m) => ok &= report("page cache warm", runs, &m),
        Err(e) => {
            eprintln!("campaign_merge: {e}");
            return ExitCode::from(2);
        }
    }
    match evict(&dir) {
        Ok(()) => match measure(&exe, &dir, runs, false) {
            Ok(m) => ok &= report("page cache cold", runs, &m),
            Err(e) => {
                eprintln!("campaign_merge: {e}");
                return ExitCode::from(2);
            }
        },
        Err(e) => println!("campaign_merge: page cache cold: not measured: {e}"),
    }
    let merged = dir.join("merged");
    println!(
        "campaign_merge: metrics.parquet {:.1} MB, cost.parquet {:.1} MB, report.md {:.0} kB",
        size_mb(&merged.join("metrics.parquet")),
        size_mb(&merged.join("cost.parquet")),
        size_mb(&merged.join("report.md")) * 1e3
    );
    println!(
        "campaign_merge: {}",
        if ok { "within bounds" } else { "OVER a bound" }
    );
    if generated {
        if std::env::var_os("MERGE_KEEP").is_some() {
            println!("campaign_merge: kept {}", dir.display());
        } else {
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
