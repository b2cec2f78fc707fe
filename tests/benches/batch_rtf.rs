//! Benchmark (not a test): `nav-daemon batch` over a 1 h, 200 Hz flight with
//! SRS/CNS/baro aids and the full solution CSV written, as real-time factor.
//! Also the breakdown: reading/decoding the log, the navigator alone, and
//! formatting the CSV, and `batch --every 1` (one row per second written,
//! the filter at the full rate). Each figure is printed beside the one
//! measured for issue 20 on earlier mains and beside its target. Run with
//! `cargo bench -p polarnav-tests --bench batch_rtf`.

use std::io::{BufReader, BufWriter, Write};
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

/// Real-time factors of the full-CSV batch before issue 20 (quiet machine,
/// transpolar, interleaved runs as in the issue): main 228cf9b, before the
/// solution grew its σ, bias and flag columns, and main 06264ed.
const OLD_RTF: [(&str, f64); 2] = [("228cf9b", 2909.0), ("06264ed", 2185.0)];
/// Issue 20's targets: full CSV, and `--every 1`.
const TARGET_FULL_RTF: f64 = 3500.0;
const TARGET_EVERY_1_RTF: f64 = 10_000.0;

/// Wall times of `runs` batch runs over `log` with `opts`, each to a new
/// CSV file (the previous one deleted and the pages flushed before the
/// clock starts, so a run does not pay for truncating the last one).
fn batch_runs(
    log: &std::path::Path,
    out: &std::path::Path,
    opts: &BatchOptions,
    runs: usize,
) -> Vec<f64> {
    (0..runs)
        .map(|_| {
            let _ = std::fs::remove_file(out);
            let _ = std::process::Command::new("sync").status();
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

fn main() {
    let dir = std::env::temp_dir().join(format!("polarnav-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let scen = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../config/scenarios/transpolar.toml");
    let text = std::fs::read_to_string(scen)
        .expect("scenario")
        .replace("duration_s = 4480.0", &format!("duration_s = {FLIGHT_S}"));
    let s = Scenario::parse(&text, "bench").expect("scenario");
    let log = dir.join("flight.navlog");
    let t0 = Instant::now();
    simulate(
        &s,
        &text,
        SimOptions::default(),
        BufWriter::new(std::fs::File::create(&log).expect("create")),
    )
    .expect("simulate");
    eprintln!(
        "simulated {FLIGHT_S} s at 200 Hz with all aids in {:.1} s (not timed)",
        t0.elapsed().as_secs_f64()
    );

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
    let old = OLD_RTF
        .iter()
        .map(|(commit, rtf)| format!("{commit} {rtf:.0}x"))
        .collect::<Vec<_>>()
        .join(", ");
    println!(
        "  full CSV ({full_mb:.0} MB): wall time median {median:.3} s, best {best:.3} s (runs in order: {chrono:.3?}) -> real-time factor median {:.0}x, best {:.0}x; before: {old}; target {TARGET_FULL_RTF:.0}x",
        FLIGHT_S / median,
        FLIGHT_S / best
    );
    println!(
        "  --every 1 ({every_mb:.1} MB): wall time median {median_every:.3} s, best {best_every:.3} s (runs in order: {chrono_every:.3?}) -> real-time factor median {:.0}x, best {:.0}x; before: no such option; target {TARGET_EVERY_1_RTF:.0}x",
        FLIGHT_S / median_every,
        FLIGHT_S / best_every
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
            let _ = std::process::Command::new("sync").status();
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
    let n = 20_000;
    let time = |label: &str, k: &mut dyn FnMut()| {
        let t = Instant::now();
        for _ in 0..n {
            k();
        }
        println!(
            "  micro: {label}: {:.3} µs",
            t.elapsed().as_secs_f64() / f64::from(n) * 1e6
        );
    };
    let mut f = error_model::f_grid(&g.pos, &g.v_n, &c, &f_g);
    time("F in G (f_grid)", &mut || {
        f = std::hint::black_box(error_model::f_grid(&g.pos, &g.v_n, &c, &f_g))
    });
    let noise = NavigatorConfig::default().filter.process_noise();
    let mut p = *nav.covariance();
    time("covariance propagation (Φ, ΦPΦᵀ, Q_d)", &mut || {
        filter::propagate(std::hint::black_box(&mut p), &f, &noise, 0.05)
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
    let geo = state.geodetic();
    time("ecef_to_geodetic", &mut || {
        let _ = std::hint::black_box(polarnav::earth::ecef_to_geodetic(&std::hint::black_box(
            g.pos,
        )));
    });
    let _ = (geo, st);
}
