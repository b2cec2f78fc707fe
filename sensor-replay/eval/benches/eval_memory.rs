//! Peak memory of `eval` on a long flight (not a test): writes a synthetic
//! flight of N solution rows (default 10 000 000: 27.8 h at 100 Hz;
//! `EVAL_ROWS=N` to change) — a navlog with an IMU sample per row and the
//! truth and truth bias at 10 Hz, the same navlog without its truth, and
//! the solution CSV (the project's row writer, with the bias σ columns)
//! whose errors wander and whose frame switches twice — then evaluates it
//! with and without truth, every figure drawn, in this process, and prints
//! the peak resident memory of each (VmHWM, reset before each run through
//! /proc/self/clear_refs) and its time, against the bound eval keeps
//! whatever the flight's length (EVAL_RSS_BOUND_MB). The files (about
//! 11 GB at 10 M rows) go to `EVAL_DIR` (default the temporary directory)
//! and are removed afterwards; `EVAL_KEEP=1` keeps them (to time the
//! `sensor-replay eval` command on them).
//!
//! `cargo bench -p polarnav-eval --bench eval_memory`

use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Instant;

use msgs::navlog::{Header, NavlogWriter, Record, TruthBias};
use msgs::{ImuSample, InitState, Solution, TruthRecord, solution_flags};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic};
use polarnav::solution_csv::{self, RowWriter};
use polarnav_eval::run::{self, Args};

/// The peak resident set eval stays under (MB), whatever the flight's length.
const EVAL_RSS_BOUND_MB: f64 = 128.0;

fn status_kb(key: &str) -> Option<u64> {
    std::fs::read_to_string("/proc/self/status")
        .ok()?
        .lines()
        .find(|l| l.starts_with(key))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// The true state at row `k` (100 Hz): a track from 84° N over the pole
/// region and back, at 12 km.
fn truth_at(k: u64, n: u64) -> (Vector3<f64>, [f64; 3], UnitQuaternion<f64>) {
    let f = k as f64 / n as f64;
    let lat = 84.0 + 5.5 * (std::f64::consts::PI * f).sin();
    let lon = 40.0 + 200.0 * f;
    let r = earth::geodetic_to_ecef(&Geodetic::from_deg(lat, lon, 12_000.0));
    let q = UnitQuaternion::from_euler_angles(0.01, -0.02, 0.3 + 2.0 * f);
    (r, [200.0, 100.0 * (f * 7.0).sin(), 0.5], q)
}

fn write_files(dir: &Path, n: u64) -> (u64, u64, u64) {
    let header = Header::new(
        "eval_memory",
        "synthetic-long",
        1,
        "[navigator]\nswitch_enter_deg = 88.0\n",
    );
    let open = |name: &str| {
        BufWriter::with_capacity(
            1 << 20,
            std::fs::File::create(dir.join(name)).expect("create"),
        )
    };
    let mut with = NavlogWriter::new(open("flight.navlog"), header.clone()).expect("header");
    let mut bare = NavlogWriter::new(open("bare.navlog"), header).expect("header");
    let mut csv = open("solution.csv");
    writeln!(csv, "{}", solution_csv::header()).expect("csv header");
    let (r0, _, q0) = truth_at(0, n);
    let init = Record::Init(InitState {
        t_ns: 0,
        r_e_m: r0.into(),
        q_b_e: [q0.w, q0.i, q0.j, q0.k],
        ..Default::default()
    });
    for w in [&mut with, &mut bare] {
        w.write(&init).expect("init");
    }
    let mut rows = RowWriter::new();
    let mut s = Solution::default();
    for k in 0..n {
        // Every 1 000 003rd sample comes 20 ms late (and the solution with
        // it): gaps for the sampling review.
        let late = k / 1_000_003;
        let t_ns = k * 10_000_000 + late * 20_000_000;
        let ts = t_ns as f64 * 1e-9;
        let imu = Record::Imu(ImuSample {
            t_ns,
            seq: k,
            dt_s: if k > 0 && k % 1_000_003 == 0 {
                0.03
            } else {
                0.01
            },
            d_theta_rad: [1e-6, -2e-6, 3e-9],
            d_v_mps: [0.0, 0.0, 0.098],
        });
        for w in [&mut with, &mut bare] {
            w.write(&imu).expect("imu");
        }
        let (r, v, q) = truth_at(k, n);
        if k % 10 == 0 {
            with.write(&Record::Truth(TruthRecord {
                t_ns,
                r_e_m: r.into(),
                v_e_mps: v,
                q_b_e: [q.w, q.i, q.j, q.k],
            }))
            .expect("truth");
            with.write(&Record::TruthBias(TruthBias {
                t_ns,
                gyro_bias_rps: [4.8e-8, -1e-8 * (ts * 1e-4).sin(), 2e-8],
                accel_bias_mps2: [1e-3, -9.8e-4, 2e-5],
            }))
            .expect("truth bias");
        }
        // The solution: the truth with errors that wander, σ that breathe.
        let e = Vector3::new(
            (ts * 1e-3).sin(),
            (ts * 7e-4).cos(),
            0.3 * (ts * 2e-3).sin(),
        ) * 3.0;
        let dq = UnitQuaternion::from_euler_angles(
            1e-4 * (ts * 1e-3).sin(),
            5e-5,
            3e-4 * (ts * 3e-4).cos(),
        );
        let qs = dq * q;
        let g = earth::ecef_to_geodetic(&(r + e));
        s.t_ns = t_ns;
        s.seq = k;
        s.frame = u8::from((n / 3..2 * n / 3).contains(&k));
        s.lat_rad = g.lat_rad;
        s.lon_rad = g.lon_rad;
        s.h_m = g.h_m;
        s.r_e_m = (r + e).into();
        s.v_e_mps = [v[0] + 0.01 * (ts * 1e-2).sin(), v[1], v[2]];
        s.q_b_e = [qs.w, qs.i, qs.j, qs.k];
        let sig = 4.0 + (ts * 1e-4).sin();
        s.sigma_pos_enu_m = [sig, sig * 1.1, sig * 0.5];
        s.sigma_vel_mps = [0.01 * sig; 3];
        s.sigma_att_rad = [1e-4, 1e-4, 3e-4];
        if k % 10 == 0 {
            s.gyro_bias_rps = [4.7e-8, -1e-8 * (ts * 1e-4).sin(), 2.1e-8];
            s.accel_bias_mps2 = [1e-3 * (1.0 + 1e-3 * (ts * 1e-3).sin()), -9.7e-4, 0.0];
            let (g, a) = (4e-8 / (1.0 + ts * 1e-3), 5e-4 / (1.0 + ts * 1e-3));
            s.sigma_gyro_bias_rps = [g; 3];
            s.sigma_accel_bias_mps2 = [a; 3];
        }
        s.flags = solution_flags::SRS_FRESH
            | solution_flags::BARO_FRESH
            | if k % 100_000 < 50 {
                solution_flags::COASTING
            } else {
                solution_flags::CNS_FRESH
            };
        s.switch_count = u32::from(k >= n / 3) + u32::from(k >= 2 * n / 3);
        rows.write(&mut csv, &s).expect("row");
    }
    with.finish().expect("finish").flush().expect("flush");
    bare.finish().expect("finish").flush().expect("flush");
    csv.flush().expect("flush");
    let size = |name: &str| std::fs::metadata(dir.join(name)).map_or(0, |m| m.len());
    (
        size("flight.navlog"),
        size("bare.navlog"),
        size("solution.csv"),
    )
}

fn main() {
    let n: u64 = std::env::var("EVAL_ROWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000_000);
    let base = std::env::var_os("EVAL_DIR").map_or_else(std::env::temp_dir, Into::into);
    let dir = base.join(format!("polarnav-eval-memory-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let t = Instant::now();
    let (log, bare, csv) = write_files(&dir, n);
    println!(
        "eval_memory: {n} rows ({:.1} h at 100 Hz): navlog {:.2} GB, without truth {:.2} GB, solution CSV {:.2} GB, written in {:.0} s",
        n as f64 / 360_000.0,
        log as f64 / 1e9,
        bare as f64 / 1e9,
        csv as f64 / 1e9,
        t.elapsed().as_secs_f64()
    );
    let mut worst: f64 = 0.0;
    for (what, navlog) in [
        ("with truth", "flight.navlog"),
        ("without truth", "bare.navlog"),
    ] {
        let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
        let before = status_kb("VmHWM:").unwrap_or(0);
        let out = dir.join(format!("out-{}", navlog.trim_end_matches(".navlog")));
        let t = Instant::now();
        let e = run::run(&Args {
            log: &dir.join(navlog),
            solution: &dir.join("solution.csv"),
            compare: None,
            reference: None,
            out: Some(&out),
        })
        .expect("eval");
        let secs = t.elapsed().as_secs_f64();
        let peak = status_kb("VmHWM:").unwrap_or(0) as f64 / 1024.0;
        assert!(e.notes.is_empty(), "not streamed: {:?}", e.notes);
        let figures = std::fs::read_dir(&out).map_or(0, |d| d.count());
        println!(
            "eval_memory: {what}: peak RSS {peak:.1} MB{} in {secs:.1} s ({:.2} M rows/s), {figures} figures",
            if reset {
                String::new()
            } else {
                format!(
                    " (VmHWM could not be reset: {:.1} MB before)",
                    before as f64 / 1024.0
                )
            },
            n as f64 / secs / 1e6
        );
        worst = worst.max(peak);
    }
    println!(
        "eval_memory: largest peak {worst:.1} MB, bound {EVAL_RSS_BOUND_MB} MB: {}",
        if worst < EVAL_RSS_BOUND_MB {
            "under"
        } else {
            "OVER"
        }
    );
    if std::env::var_os("EVAL_KEEP").is_none() {
        std::fs::remove_dir_all(&dir).ok();
    } else {
        println!("eval_memory: files kept in {}", dir.display());
    }
    assert!(worst < EVAL_RSS_BOUND_MB, "eval held {worst:.1} MB");
}
