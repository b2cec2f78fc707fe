//! The review of a long flight: writes a synthetic solution CSV of N rows
//! (default 10 000 000, a 14 h flight at 200 Hz; `REVIEW_ROWS=N` to change)
//! with the project's row writer (its header, bias σ and aid columns
//! included), then times `review` on it with
//! every figure drawn, and prints both times. Issue 21 asks for under a minute
//! at 10 M rows. The file (several GB) is removed afterwards.
//!
//! `cargo bench -p polarnav-eval --bench review_rows`

use std::io::{BufWriter, Write};
use std::time::Instant;

use msgs::{Solution, solution_flags};
use polarnav::solution_csv::{RowWriter, header};
use polarnav_eval::logfile::LogContents;
use polarnav_eval::review::{self, Options};

fn main() {
    let n: u64 = std::env::var("REVIEW_ROWS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10_000_000);
    let dir = std::env::temp_dir().join(format!("polarnav-review-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let csv = dir.join("long.csv");
    let t = Instant::now();
    {
        let mut f = BufWriter::with_capacity(1 << 20, std::fs::File::create(&csv).expect("csv"));
        writeln!(f, "{}", header()).expect("header");
        let mut w = RowWriter::new();
        let mut s = Solution::default();
        for i in 0..n {
            let ts = i as f64 * 0.005;
            s.t_ns = i * 5_000_000;
            s.frame = u8::from(i >= n / 2);
            s.lat_rad = (85.0 + 4.0 * (i as f64 / n as f64)).to_radians();
            s.h_m = 10_000.0 + (ts * 1e-3).sin();
            s.r_e_m = [1.0e5 + ts, 2.0e5, 6.3e6];
            s.q_b_e = [1.0, 0.0, 0.0, 0.0];
            let sig = 5.0 + (ts * 1e-4).sin();
            s.sigma_pos_enu_m = [sig, sig * 1.1, sig * 0.5];
            s.sigma_vel_mps = [0.01 * sig; 3];
            s.sigma_att_rad = [1e-4, 1e-4, 3e-4];
            // Filter steps every 0.1 s: the writer reuses unchanged texts, as in batch.
            if i % 20 == 0 {
                s.gyro_bias_rps = [1e-8 * (ts * 1e-3).cos(), 2e-8, -1e-8];
                s.accel_bias_mps2 = [1e-4 * (ts * 1e-3).sin(), 5e-5, 0.0];
                let (g, a) = (4e-8 / (1.0 + ts * 1e-3), 5e-4 / (1.0 + ts * 1e-3));
                s.sigma_gyro_bias_rps = [g; 3];
                s.sigma_accel_bias_mps2 = [a; 3];
            }
            s.flags = solution_flags::SRS_FRESH
                | solution_flags::BARO_FRESH
                | if i % 200_000 < 100 {
                    solution_flags::COASTING
                } else {
                    solution_flags::CNS_FRESH
                };
            s.switch_count = u32::from(i >= n / 2);
            w.write(&mut f, &s).expect("row");
        }
        f.flush().expect("flush");
    }
    let size = std::fs::metadata(&csv).map_or(0, |m| m.len());
    let write_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let r = review::review(
        &LogContents::default(),
        &Options {
            solution: &csv,
            reference: None,
            out: Some(&dir.join("figs")),
        },
    )
    .expect("review");
    let review_s = t.elapsed().as_secs_f64();
    assert!(
        !r.markdown.contains("without σ bands"),
        "the bias σ columns were not read"
    );
    println!(
        "review_rows: {n} rows (with the bias σ columns), {:.2} GB CSV written in {write_s:.1} s; review with {} figures in {review_s:.1} s ({:.2} M rows/s)",
        size as f64 / 1e9,
        r.figures.len(),
        n as f64 / review_s / 1e6
    );
    std::fs::remove_dir_all(&dir).ok();
}
