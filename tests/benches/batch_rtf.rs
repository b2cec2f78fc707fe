//! Benchmark (not a test): `nav-daemon batch` over a 1 h, 200 Hz flight with
//! SRS/CNS/baro aids and the full solution CSV written, as real-time factor.
//! Also the breakdown: reading/decoding the log, the navigator alone, and
//! formatting the CSV. Run with `cargo bench -p polarnav-tests --bench batch_rtf`.

use std::io::{BufReader, BufWriter, Write};
use std::time::Instant;

use msgs::navlog::{NavlogReader, Record};
use polarnav::batch::{self, BatchOptions};
use polarnav::config::Config;
use polarnav::navigator::{Navigator, NavigatorConfig};
use polarnav::solution_csv;
use sensor_replay::scenario::Scenario;
use sensor_replay::simulate::{SimOptions, simulate};

const FLIGHT_S: f64 = 3600.0;

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

    // Whole batch, as the command runs it, three times.
    let mut times = Vec::new();
    for _ in 0..3 {
        let out = dir.join("solution.csv");
        let t = Instant::now();
        let r = batch::run(
            BufReader::with_capacity(1 << 20, std::fs::File::open(&log).expect("open")),
            "flight.navlog",
            BufWriter::with_capacity(1 << 20, std::fs::File::create(&out).expect("create")),
            &Config::default(),
            &BatchOptions::default(),
        )
        .expect("batch");
        times.push(t.elapsed().as_secs_f64());
        assert_eq!(r.rows, (FLIGHT_S * 200.0) as u64);
    }
    times.sort_by(f64::total_cmp);
    let best = times[0];

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
    let init = records
        .iter()
        .find_map(|r| {
            if let Record::Init(i) = r {
                Some(*i)
            } else {
                None
            }
        })
        .expect("init");
    let t = Instant::now();
    let mut nav = Navigator::new(&init, &NavigatorConfig::default());
    let mut sols = Vec::with_capacity(records.len());
    for r in &records {
        match r {
            Record::Imu(x) => {
                nav.on_imu(x).expect("imu");
                sols.push(nav.solution());
            }
            Record::Srs(x) => drop(nav.on_srs(x)),
            Record::Cns(x) => drop(nav.on_cns(x)),
            Record::Baro(x) => drop(nav.on_baro(x)),
            _ => {}
        }
    }
    let navigate = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut sink = BufWriter::with_capacity(1 << 20, std::io::sink());
    for s in &sols {
        solution_csv::write_row(&mut sink, s).expect("row");
    }
    sink.flush().expect("flush");
    let csv = t.elapsed().as_secs_f64();

    println!("batch over a {FLIGHT_S:.0} s, 200 Hz flight with SRS/CNS/baro and the full CSV:");
    println!(
        "  wall time best {best:.3} s (runs: {times:.3?}) -> real-time factor {:.0}x",
        FLIGHT_S / best
    );
    println!(
        "  breakdown: decode log {decode:.3} s ({:.0}x), navigator + solutions {navigate:.3} s ({:.0}x), CSV formatting {csv:.3} s ({:.0}x)",
        FLIGHT_S / decode,
        FLIGHT_S / navigate,
        FLIGHT_S / csv
    );
    println!(
        "  per IMU sample: navigator {:.2} µs, CSV {:.2} µs",
        navigate / sols.len() as f64 * 1e6,
        csv / sols.len() as f64 * 1e6
    );
    std::fs::remove_dir_all(&dir).ok();
}
