//! Benchmark (not a test): `nav-daemon batch` over a 1 h, 200 Hz flight with
//! SRS/CNS/baro aids, with the full solution CSV written and with `--every
//! 1`, against references measured in the same run, in interleaved pairs:
//!
//! - `POLARNAV_REFERENCE_BIN=/path/to/nav-daemon`: the `nav-daemon` of an
//!   earlier commit, built from a checkout outside this repository; both
//!   binaries run `batch` on the same log, alternately;
//! - `POLARNAV_KFGINS_BIN=/path/to/KF-GINS`: KF-GINS (i2Nav-WHU), built from
//!   its own source outside this repository, on the same 1 h, 200 Hz flight
//!   at 45° N (its IMU file from `sensor-replay export --kfgins`, the 1 Hz
//!   CNS fixes with the true height as its GNSS file), against `batch` on
//!   that flight, full CSV and `--every 1`.
//!
//! A reference that is not given is skipped, and the bench says so. Each
//! pair's ratio (reference time / this build's time) is printed, then the
//! median and the range over `POLARNAV_PAIRS` pairs (default 7); the order
//! within a pair alternates, and every run starts after `sync` with its
//! output file removed. In-process figures follow: the breakdown per IMU
//! sample (decoding, navigator, CSV row), the MCAP output against the CSV,
//! and the micro-benchmarks of one filter cycle's pieces
//! (`cargo bench -p polarnav-tests --bench batch_rtf -- micro` runs only
//! those).
//!
//! `cargo build --release --bins && POLARNAV_REFERENCE_BIN=... POLARNAV_KFGINS_BIN=... cargo bench -p polarnav-tests --bench batch_rtf`

use std::io::{BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use msgs::navlog::{NavlogReader, Record};
use nav_daemon::batch::{self, BatchOptions};
use polarnav::navigator::{Navigator, NavigatorConfig};
use polarnav::row_interval::RowInterval;
use polarnav::solution_csv;
use polarnav_config::ConfigFile;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

const FLIGHT_S: f64 = 3600.0;

/// Wall times of `runs` batch runs over `log` with `opts`, each to a new
/// CSV file (the previous one deleted and the pages flushed before the
/// clock starts, so a run does not pay for truncating the last one).
fn batch_runs(log: &Path, out: &Path, opts: &BatchOptions, runs: usize) -> Vec<f64> {
    (0..runs)
        .map(|_| {
            let _ = std::fs::remove_file(out);
            let _ = Command::new("sync").status();
            let t = Instant::now();
            let r = batch::run(
                BufReader::with_capacity(1 << 20, std::fs::File::open(log).expect("open")),
                "flight.navlog",
                BufWriter::with_capacity(1 << 20, std::fs::File::create(out).expect("create")),
                &ConfigFile::defaults(),
                opts,
            )
            .expect("batch");
            let dt = t.elapsed().as_secs_f64();
            assert_eq!(r.status.imu().accepted, (FLIGHT_S * 200.0) as u64);
            dt
        })
        .collect()
}

/// Median and best of `times`.
fn median_best(times: &[f64]) -> (f64, f64) {
    let mut t = times.to_vec();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

/// The transpolar flight's first `seconds`, started at `lat_deg` (its own
/// 85° N when `None`), simulated into `path`.
fn simulate_flight(path: &Path, seconds: f64, lat_deg: Option<f64>) {
    let scen = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenarios/transpolar.toml");
    let mut text = std::fs::read_to_string(scen)
        .expect("scenario")
        .replace("duration_s = 4480.0", &format!("duration_s = {seconds}"));
    if let Some(lat) = lat_deg {
        assert!(
            text.contains("lat_deg = 85.0"),
            "transpolar.toml starts elsewhere"
        );
        text = text.replace("lat_deg = 85.0", &format!("lat_deg = {lat:.1}"));
    }
    let s = Scenario::parse(&text, "bench").expect("scenario");
    let t0 = Instant::now();
    simulate(
        &s,
        &text,
        SimOptions::default(),
        BufWriter::new(std::fs::File::create(path).expect("create")),
    )
    .expect("simulate");
    eprintln!(
        "simulated {seconds} s at 200 Hz with all aids from {} in {:.1} s (not timed)",
        lat_deg.map_or_else(|| "85° N".to_owned(), |l| format!("{l}° N")),
        t0.elapsed().as_secs_f64()
    );
}

fn main() {
    let dir = std::env::temp_dir().join(format!("polarnav-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    if std::env::args().skip(1).any(|a| a == "micro") {
        let log = dir.join("short.navlog");
        simulate_flight(&log, 600.0, None);
        let bytes = std::fs::read(&log).expect("log");
        let (records, _) = msgs::navlog::read_all(&bytes);
        micro(&msgs::navlog::first_init(&records).expect("init"));
        micro_decode(&bytes, records.len());
        std::fs::remove_dir_all(&dir).ok();
        return;
    }
    let log = dir.join("flight.navlog");
    simulate_flight(&log, FLIGHT_S, None);
    paired_runs(&dir, &log);

    // Whole batch, as the command runs it, five times; then with --every 1.
    let out = dir.join("solution.csv");
    let chrono = batch_runs(&log, &out, &BatchOptions::default(), 5);
    let full_mb = std::fs::metadata(&out).map_or(0.0, |m| m.len() as f64 / 1e6);
    let (median, best) = median_best(&chrono);
    let every = BatchOptions {
        every: Some(RowInterval::new(1.0).expect("1 s")),
        ..Default::default()
    };
    let chrono_every = batch_runs(&log, &out, &every, 5);
    let every_mb = std::fs::metadata(&out).map_or(0.0, |m| m.len() as f64 / 1e6);
    let (median_every, best_every) = median_best(&chrono_every);

    // Breakdown: decode only; navigator only (records in memory); CSV formatting only.
    let t = Instant::now();
    let mut reader = NavlogReader::new(BufReader::with_capacity(
        1 << 20,
        std::fs::File::open(&log).expect("open"),
    ));
    let mut records = Vec::new();
    while let Some(r) = reader.next_record().expect("read") {
        records.push(r);
    }
    let decode = t.elapsed().as_secs_f64();
    let init = msgs::navlog::first_init(&records).expect("init");
    let t = Instant::now();
    let mut nav = Navigator::new(&init, &NavigatorConfig::default());
    let mut sols = Vec::with_capacity(records.len());
    for r in &records {
        match r {
            Record::Imu(x) => {
                nav.on_imu(x).expect("imu");
                sols.push(nav.solution());
            }
            Record::Aid(x) => drop(nav.on_aid(x)),
            _ => {}
        }
    }
    let navigate = t.elapsed().as_secs_f64();
    // The same without assembling solutions, and solution assembly alone.
    let t = Instant::now();
    let mut nav2 = Navigator::new(&init, &NavigatorConfig::default());
    for r in &records {
        match r {
            Record::Imu(x) => drop(nav2.on_imu(x).expect("imu")),
            Record::Aid(x) => drop(nav2.on_aid(x)),
            _ => {}
        }
    }
    let filter_only = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut acc = 0.0;
    for _ in 0..sols.len() {
        acc += std::hint::black_box(&nav2).solution().h_m;
    }
    std::hint::black_box(acc);
    let solution_only = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut sink = BufWriter::with_capacity(1 << 20, std::io::sink());
    let mut rows = solution_csv::RowWriter::new();
    for s in &sols {
        rows.write(&mut sink, s).expect("row");
    }
    sink.flush().expect("flush");
    let csv = t.elapsed().as_secs_f64();

    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "batch over a {FLIGHT_S:.0} s, 200 Hz flight with SRS/CNS/baro (load average at the end: {})",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    println!(
        "  in process, full CSV ({full_mb:.0} MB): wall time median {median:.3} s, best {best:.3} s (runs in order: {chrono:.3?})"
    );
    println!(
        "  in process, --every 1 ({every_mb:.1} MB): wall time median {median_every:.3} s, best {best_every:.3} s (runs in order: {chrono_every:.3?})"
    );
    println!(
        "  breakdown: decode log {decode:.3} s ({:.0}x), navigator + solutions {navigate:.3} s ({:.0}x), CSV formatting {csv:.3} s ({:.0}x)",
        FLIGHT_S / decode,
        FLIGHT_S / navigate,
        FLIGHT_S / csv
    );
    let n = sols.len() as f64;
    println!(
        "  per IMU sample: decode {:.2} µs, navigator {:.2} µs (filter and mechanization {:.2} µs, solution {:.2} µs), CSV row {:.2} µs",
        decode / n * 1e6,
        navigate / n * 1e6,
        filter_only / n * 1e6,
        solution_only / n * 1e6,
        csv / n * 1e6
    );
    // The same batch writing MCAP (every channel of polarnav-foxglove,
    // protobuf messages, zstd chunks) instead of the CSV: what `--out
    // F.mcap` costs, run as often as the CSV and set beside it against
    // issue 22's targets (at most 1.5x the CSV's wall time, at most
    // 150 MB per flight hour).
    let out = dir.join("solution.mcap");
    let mcap_times: Vec<f64> = (0..5)
        .map(|_| {
            let _ = std::fs::remove_file(&out);
            let _ = Command::new("sync").status();
            let t = Instant::now();
            let r = batch::run_to::<_, std::io::Sink>(
                BufReader::with_capacity(1 << 20, std::fs::File::open(&log).expect("open")),
                "flight.navlog",
                batch::Output::Mcap(Box::new(
                    polarnav_foxglove::McapFile::create(
                        &out,
                        polarnav_foxglove::AidSource::Updates,
                    )
                    .expect("mcap"),
                )),
                &ConfigFile::defaults(),
                &BatchOptions::default(),
            )
            .expect("batch mcap");
            assert_eq!(r.rows, (FLIGHT_S * 200.0) as u64);
            t.elapsed().as_secs_f64()
        })
        .collect();
    let (mcap_s, mcap_best) = median_best(&mcap_times);
    let mcap_mb = std::fs::metadata(&out).map_or(0.0, |m| m.len() as f64 / 1e6);
    let hours = FLIGHT_S / 3600.0;
    println!(
        "  MCAP output instead of CSV: {mcap_s:.3} s median, {mcap_best:.3} s best ({:.0}x real time), {mcap_mb:.1} MB ({:.2} µs and {:.0} bytes per IMU sample, inputs included)",
        FLIGHT_S / mcap_s,
        mcap_s / n * 1e6,
        mcap_mb * 1e6 / n
    );
    println!(
        "  MCAP beside CSV (medians): wall time {mcap_s:.3} s vs {median:.3} s = {:.2}x (target <= 1.5x); size {:.0} MB vs {:.0} MB per flight hour (MCAP target <= 150)",
        mcap_s / median,
        mcap_mb / hours,
        full_mb / hours
    );
    // What cannot be compressed away: the full-rate /solution messages and
    // the /imu increments, each compressed alone as the file's chunks are
    // (zstd at the file's level, 1 MB), per flight hour. Their sum is a floor under the
    // size of a full-rate file with its inputs.
    let per_hour = |bytes: usize| bytes as f64 / 1e6 / hours;
    let solution_mb =
        per_hour(compressed_alone(sols.iter().map(|s| {
            prost::Message::encode_to_vec(&polarnav_foxglove::convert::solution(s))
        })));
    let imu_mb = per_hour(compressed_alone(records.iter().filter_map(|r| match r {
        Record::Imu(x) => Some(prost::Message::encode_to_vec(
            &polarnav_foxglove::convert::imu(x),
        )),
        _ => None,
    })));
    // The message indexes: 16 bytes per message after each chunk, stored
    // uncompressed. They are not optional for the files' users: Foxglove's
    // reader (@mcap/core McapIndexedReader.readMessages) finds a chunk's
    // messages only through them, and shows nothing of a chunk without.
    let file = std::fs::read(&out).expect("read the MCAP back");
    let summary = mcap::Summary::read(&file)
        .expect("summary")
        .expect("the file has a summary");
    let index_mb = per_hour(
        summary
            .chunk_indexes
            .iter()
            .map(|c| usize::try_from(c.message_index_length).expect("index length"))
            .sum(),
    );
    let index_at = |rate_hz: f64| per_hour((16.0 * rate_hz * FLIGHT_S) as usize);
    println!(
        "  MCAP floor at full rate, per flight hour: /solution alone {solution_mb:.0} MB, /imu alone {imu_mb:.0} MB, together {:.0} MB; message indexes of the file {index_mb:.0} MB, of /solution alone {:.1} MB, so /solution with its index {:.0} MB",
        solution_mb + imu_mb,
        index_at(200.0),
        solution_mb + index_at(200.0)
    );
    // A file for viewing: one solution per 20 ms (50 Hz), inputs whole.
    let _ = std::fs::remove_file(&out);
    let t = Instant::now();
    batch::run_to::<_, std::io::Sink>(
        BufReader::with_capacity(1 << 20, std::fs::File::open(&log).expect("open")),
        "flight.navlog",
        batch::Output::Mcap(Box::new(
            polarnav_foxglove::McapFile::create(&out, polarnav_foxglove::AidSource::Updates)
                .expect("mcap"),
        )),
        &ConfigFile::defaults(),
        &BatchOptions {
            every: Some(RowInterval::new(0.02).expect("20 ms")),
            ..BatchOptions::default()
        },
    )
    .expect("batch mcap --every 0.02");
    let every_s = t.elapsed().as_secs_f64();
    let every_mcap_mb = std::fs::metadata(&out).map_or(0.0, |m| m.len() as f64 / 1e6);
    println!(
        "  MCAP --every 0.02 (50 Hz solutions, inputs whole): {every_s:.3} s, {:.0} MB per flight hour",
        every_mcap_mb / hours
    );
    micro(&init);
    std::fs::remove_dir_all(&dir).ok();
}

/// The `nav-daemon` built beside this bench (`cargo build --release --bins`).
fn this_build() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let bin = exe.parent()?.parent()?.join("nav-daemon");
    bin.exists().then_some(bin)
}

/// A program given by an environment variable, if it names an executable
/// file; says why it is skipped otherwise.
fn reference(var: &str, what: &str) -> Option<PathBuf> {
    match std::env::var_os(var) {
        Some(p) if Path::new(&p).is_file() => Some(PathBuf::from(p)),
        Some(p) => {
            println!(
                "  {what}: skipped, {var}={} is not a file",
                p.to_string_lossy()
            );
            None
        }
        None => {
            println!("  {what}: skipped, {var} is not set");
            None
        }
    }
}

/// Wall time of one run of `cmd` (which must succeed), after `sync` and
/// with `out` removed, so no run pays for the last one's pages.
fn timed(cmd: &mut Command, out: &Path) -> f64 {
    if out.is_dir() {
        for e in std::fs::read_dir(out).expect("output dir").flatten() {
            let _ = std::fs::remove_file(e.path());
        }
    } else {
        let _ = std::fs::remove_file(out);
    }
    let _ = Command::new("sync").status();
    let t = Instant::now();
    let o = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .expect("run");
    let dt = t.elapsed().as_secs_f64();
    assert!(
        o.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    dt
}

/// `nav-daemon batch` of `bin` on `log` into `out`.
fn batch_cmd(bin: &Path, log: &Path, out: &Path, every: bool) -> Command {
    let mut c = Command::new(bin);
    c.arg("batch").arg("--log").arg(log).arg("--out").arg(out);
    if every {
        c.args(["--every", "1"]);
    }
    c
}

/// Median and range of the ratios, with every pair's.
fn ratio_line(label: &str, ratios: &[f64], ours: &[f64], theirs: &[f64]) -> String {
    let mut r = ratios.to_vec();
    r.sort_by(f64::total_cmp);
    let med = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    format!(
        "  {label}: ratio median {:.2} (range {:.2} to {:.2} over {} pairs; in order {:.2?}); median times: reference {:.3} s, this build {:.3} s",
        med(&r),
        r[0],
        r[r.len() - 1],
        r.len(),
        ratios,
        med(theirs),
        med(ours)
    )
}

/// This build's `nav-daemon batch` against the references given (see the
/// crate documentation), in interleaved pairs.
fn paired_runs(dir: &Path, log: &Path) {
    let pairs: usize = std::env::var("POLARNAV_PAIRS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|n| *n > 0)
        .unwrap_or(7);
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    };
    println!(
        "paired runs (ratio = reference's wall time / this build's; load average at the start: {})",
        load()
    );
    let Some(ours) = this_build() else {
        println!(
            "  all pairs skipped: no nav-daemon beside this bench (cargo build --release --bins first)"
        );
        return;
    };
    let out_ours = dir.join("ours.csv");
    if let Some(reference) = reference("POLARNAV_REFERENCE_BIN", "earlier commit") {
        let version = Command::new(&reference)
            .arg("--version")
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_default();
        let out_ref = dir.join("reference.csv");
        for every in [false, true] {
            let (mut a, mut b, mut r) = (Vec::new(), Vec::new(), Vec::new());
            for k in 0..pairs {
                let run_ours = || timed(&mut batch_cmd(&ours, log, &out_ours, every), &out_ours);
                let run_ref = || timed(&mut batch_cmd(&reference, log, &out_ref, every), &out_ref);
                let (t_ours, t_ref) = if k % 2 == 0 {
                    let x = run_ours();
                    (x, run_ref())
                } else {
                    let y = run_ref();
                    (run_ours(), y)
                };
                a.push(t_ours);
                b.push(t_ref);
                r.push(t_ref / t_ours);
            }
            let same = std::fs::read(&out_ours).ok() == std::fs::read(&out_ref).ok();
            println!(
                "{}; outputs {}",
                ratio_line(
                    &format!(
                        "{version} against this build, transpolar 1 h 200 Hz, {}",
                        if every { "--every 1" } else { "full CSV" }
                    ),
                    &r,
                    &a,
                    &b
                ),
                if same { "identical" } else { "DIFFERENT" }
            );
        }
    }
    if let Some(kfgins) = reference("POLARNAV_KFGINS_BIN", "KF-GINS") {
        kfgins_pairs(dir, &ours, &kfgins, pairs);
    }
    println!("  load average at the end: {}", load());
}

/// KF-GINS's input files for the navlog's flight in `kf`: its IMU file
/// (`sensor-replay export --kfgins`), a GNSS file of the 1 Hz CNS fixes
/// with the true height (σ: the fix's horizontal σ, 10 m up), and its
/// configuration (initial state from the init record, the scenario's
/// noise in KF-GINS's units). Returns the configuration's path and the
/// number of IMU samples.
fn kfgins_inputs(log: &Path, kf: &Path) -> (PathBuf, usize) {
    let (records, _) = msgs::navlog::read_all(&std::fs::read(log).expect("log"));
    let imu: Vec<msgs::ImuSample> = records
        .iter()
        .filter_map(|r| match r {
            Record::Imu(x) => Some(*x),
            _ => None,
        })
        .collect();
    let truth: Vec<msgs::TruthRecord> = records
        .iter()
        .filter_map(|r| match r {
            Record::Truth(x) => Some(*x),
            _ => None,
        })
        .collect();
    sensor_replay::interop::export_kfgins(kf, &imu, &truth).expect("KF-GINS IMU file");
    let mut gnss = String::new();
    let mut k = 0;
    for r in &records {
        if let Record::Aid(a) = r
            && let msgs::AidSample::Cns(c) = **a
        {
            while k + 1 < truth.len() && truth[k + 1].t_ns <= c.t_ns {
                k += 1;
            }
            let h = polarnav::earth::ecef_to_geodetic(&truth[k].r_e_m.into()).h_m;
            gnss.push_str(&format!(
                "{} {} {} {} {} {} 10\n",
                c.t_ns as f64 * 1e-9,
                c.lat_rad.to_degrees(),
                c.lon_rad.to_degrees(),
                h,
                c.sigma_h_m,
                c.sigma_h_m
            ));
        }
    }
    std::fs::write(kf.join("gnss.txt"), gnss).expect("gnss");
    let init = msgs::navlog::first_init(&records).expect("init");
    let geo = polarnav::earth::ecef_to_geodetic(&init.r_e_m.into());
    let c_e_g = polarnav::frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let v_enu = c_e_g * nalgebra::Vector3::from(init.v_e_mps);
    let out = kf.join("out");
    std::fs::create_dir_all(&out).expect("out");
    // Table 1 noise (the scenario's): ARW 0.001 °/√h, VRW 10 µg/√Hz =
    // 0.0059 m/s/√h, bias 0.01 °/h and 100 µg = 98.1 mGal, scale factors
    // 10 ppm; heading north: roll, pitch, yaw 0.
    let yaml = format!(
        "imupath: \"{}\"\ngnsspath: \"{}\"\noutputpath: \"{}\"\nimudatalen: 7\nimudatarate: 200\n\
         starttime: 0\nendtime: -1\ninitpos: [ {}, {}, {} ]\ninitvel: [ {}, {}, {} ]\ninitatt: [ 0.0, 0.0, 0.0 ]\n\
         initgyrbias: [ 0, 0, 0 ]\ninitaccbias: [ 0, 0, 0 ]\ninitgyrscale: [ 0, 0, 0 ]\ninitaccscale: [ 0, 0, 0 ]\n\
         initposstd: [ 10, 10, 10 ]\ninitvelstd: [ 0.1, 0.1, 0.1 ]\ninitattstd: [ 0.02, 0.02, 0.05 ]\n\
         imunoise:\n  arw: [0.001, 0.001, 0.001]\n  vrw: [0.0059, 0.0059, 0.0059]\n  gbstd: [0.01, 0.01, 0.01]\n\
         \x20 abstd: [98.1, 98.1, 98.1]\n  gsstd: [10.0, 10.0, 10.0]\n  asstd: [10.0, 10.0, 10.0]\n  corrtime: 1.0\n\
         antlever: [ 0, 0, 0 ]\n",
        kf.join("imu.txt").display(),
        kf.join("gnss.txt").display(),
        out.display(),
        geo.lat_rad.to_degrees(),
        geo.lon_rad.to_degrees(),
        geo.h_m,
        v_enu.y,
        v_enu.x,
        -v_enu.z
    );
    let cfg = kf.join("kf-gins.yaml");
    std::fs::write(&cfg, yaml).expect("yaml");
    (cfg, imu.len())
}

/// `batch` (full CSV and `--every 1`) against KF-GINS on the 1 h, 200 Hz
/// flight at 45° N, in interleaved triples.
fn kfgins_pairs(dir: &Path, ours: &Path, kfgins: &Path, pairs: usize) {
    let log = dir.join("flight45.navlog");
    simulate_flight(&log, FLIGHT_S, Some(45.0));
    let kf = dir.join("kfgins");
    let (cfg, samples) = kfgins_inputs(&log, &kf);
    let kf_out = kf.join("out");
    let out_ours = dir.join("ours45.csv");
    let run_kf = || {
        let mut c = Command::new(kfgins);
        c.arg(&cfg);
        let t = timed(&mut c, &kf_out);
        let rows = std::fs::read_to_string(kf_out.join("KF_GINS_Navresult.nav"))
            .map_or(0, |s| s.lines().count());
        // It navigates the whole file (all but its first sample).
        assert!(
            rows + 1 >= samples,
            "KF-GINS wrote {rows} of {samples} rows"
        );
        t
    };
    let (mut t_full, mut t_every, mut t_kf) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..pairs {
        let full = || timed(&mut batch_cmd(ours, &log, &out_ours, false), &out_ours);
        let every = || timed(&mut batch_cmd(ours, &log, &out_ours, true), &out_ours);
        // The order rotates: ours, KF-GINS, ours; then KF-GINS between...
        match k % 3 {
            0 => {
                t_full.push(full());
                t_kf.push(run_kf());
                t_every.push(every());
            }
            1 => {
                t_kf.push(run_kf());
                t_every.push(every());
                t_full.push(full());
            }
            _ => {
                t_every.push(every());
                t_full.push(full());
                t_kf.push(run_kf());
            }
        }
    }
    let r_full: Vec<f64> = t_kf.iter().zip(&t_full).map(|(k, o)| k / o).collect();
    let r_every: Vec<f64> = t_kf.iter().zip(&t_every).map(|(k, o)| k / o).collect();
    println!(
        "{}",
        ratio_line(
            "KF-GINS against this build, 45° N 1 h 200 Hz, full CSV",
            &r_full,
            &t_full,
            &t_kf
        )
    );
    println!(
        "{}",
        ratio_line(
            "KF-GINS against this build, 45° N 1 h 200 Hz, --every 1",
            &r_every,
            &t_every,
            &t_kf
        )
    );
}

/// Bytes of `messages` laid end to end and compressed in 1 MB chunks at
/// the zstd level of the MCAP writer's chunks.
fn compressed_alone(messages: impl Iterator<Item = Vec<u8>>) -> usize {
    let mut chunk = Vec::with_capacity(1 << 21);
    let mut total = 0;
    let mut flush = |chunk: &mut Vec<u8>| {
        let level = i32::try_from(polarnav_foxglove::file::ZSTD_LEVEL).expect("level");
        total += zstd::bulk::compress(chunk, level).expect("zstd").len();
        chunk.clear();
    };
    for m in messages {
        chunk.extend_from_slice(&m);
        if chunk.len() >= 1 << 20 {
            flush(&mut chunk);
        }
    }
    if !chunk.is_empty() {
        flush(&mut chunk);
    }
    total
}

/// Decoding a navlog held in memory (`records` of them), per record: the
/// fastest of 15 passes and the median.
fn micro_decode(bytes: &[u8], records: usize) {
    let mut per_record: Vec<f64> = (0..15)
        .map(|_| {
            let t = Instant::now();
            let mut reader = NavlogReader::new(BufReader::with_capacity(1 << 20, bytes));
            let mut n = 0;
            while let Some(r) = reader.next_record().expect("read") {
                std::hint::black_box(&r);
                n += 1;
            }
            assert_eq!(n, records);
            t.elapsed().as_secs_f64() / records as f64 * 1e6
        })
        .collect();
    per_record.sort_by(f64::total_cmp);
    println!(
        "  micro: navlog decoding: {:.3} µs per record (fastest of 15 passes over {records}; median {:.3} µs)",
        per_record[0], per_record[7]
    );
}

/// Cost of the pieces of one filter cycle, each timed over many calls.
fn micro(init: &msgs::InitState) {
    use nalgebra::Vector3;
    use polarnav::error_model;
    use polarnav::filter;
    use polarnav::mech::Increment;
    let nav = Navigator::new(init, &NavigatorConfig::default());
    let state = *nav.state();
    let polarnav::mech::AnyNav::Grid(g) = state else {
        return;
    };
    let c = g.q_b_n.to_rotation_matrix().into_inner();
    let f_g = Vector3::new(0.0, 0.0, 9.8);
    // Each piece timed over 20 000 calls, 15 times: the fastest of the 15
    // (the least disturbed by the rest of the machine) and the median.
    let n = 20_000;
    let time = |label: &str, k: &mut dyn FnMut()| {
        let mut per_call: Vec<f64> = (0..15)
            .map(|_| {
                let t = Instant::now();
                for _ in 0..n {
                    k();
                }
                t.elapsed().as_secs_f64() / f64::from(n) * 1e6
            })
            .collect();
        per_call.sort_by(f64::total_cmp);
        println!(
            "  micro: {label}: {:.3} µs (fastest of 15 × {n} calls; median {:.3} µs)",
            per_call[0], per_call[7]
        );
    };
    let mut f = error_model::f_grid(&g.pos, &g.v_n, &c, &f_g);
    time("F in G (f_grid)", &mut || {
        f = std::hint::black_box(error_model::f_grid(&g.pos, &g.v_n, &c, &f_g))
    });
    let noise = NavigatorConfig::default().filter.process_noise();
    let mut p = *nav.covariance();
    time("covariance propagation (Φ, ΦPΦᵀ, Q_d)", &mut || {
        std::hint::black_box(filter::propagate(
            std::hint::black_box(&mut p),
            &f,
            &noise,
            0.05,
        ));
    });
    let inc = Increment {
        d_theta: Vector3::new(1e-7, 2e-7, 3e-7),
        d_v: Vector3::new(0.0, 0.0, 0.049),
        dt_s: 0.005,
    };
    let mut st = state;
    time("mechanization step in G", &mut || {
        st = std::hint::black_box(state).mechanize(&inc, &inc)
    });
    let state_g = state.converted(polarnav::mech::FrameKind::Geographic);
    time("mechanization step in g", &mut || {
        st = std::hint::black_box(state_g).mechanize(&inc, &inc)
    });
    let geo = state.geodetic();
    time("ecef_to_geodetic", &mut || {
        let _ = std::hint::black_box(polarnav::earth::ecef_to_geodetic(&std::hint::black_box(
            g.pos,
        )));
    });
    let _ = (geo, st);
}
