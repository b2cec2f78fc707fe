//! `batch --every SECONDS`: the filter runs at the full rate and only the
//! writing is decimated, so every written row is, byte for byte, the
//! full-rate run's row at the same time; the rows of the first sample, of
//! every frame switch and of the last sample are always written.

use nav_daemon::batch::{self, BatchOptions};
use polarnav::row_interval::RowInterval;
use polarnav_config::{CliOverrides, ConfigFile};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};
use polarnav_tests::repo;

/// The CSV `batch` writes for `log` with `every`, as lines (header first).
fn batch_lines(log: &[u8], every: Option<RowInterval>) -> Vec<String> {
    let mut out = Vec::new();
    batch::run(
        log,
        "every.navlog",
        &mut out,
        &ConfigFile::defaults(),
        &BatchOptions {
            cli: CliOverrides {
                force_switch_s: Some(vec![12.3, 27.71, 44.055]),
                ..Default::default()
            },
            every,
            ..Default::default()
        },
    )
    .expect("batch");
    String::from_utf8(out)
        .expect("utf-8")
        .lines()
        .map(str::to_owned)
        .collect()
}

fn column(header: &str, name: &str) -> usize {
    header
        .split(',')
        .position(|c| c == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

#[test]
fn decimated_rows_are_the_full_rate_rows_and_the_events_are_kept() {
    let text = std::fs::read_to_string(repo("config/scenarios/transpolar.toml"))
        .expect("scenario")
        .replace("duration_s = 4480.0", "duration_s = 60.0");
    let s = Scenario::parse(&text, "transpolar").expect("scenario");
    let mut log = Vec::new();
    simulate(&s, &text, SimOptions::default(), &mut log).expect("simulate");

    let full = batch_lines(&log, None);
    let header = &full[0];
    let (t_col, sw_col) = (column(header, "t_s"), column(header, "switch_count"));
    let field = |line: &str, k: usize| line.split(',').nth(k).expect("field").to_owned();
    let rows = &full[1..];
    assert_eq!(rows.len(), 12_000, "200 Hz for 60 s");

    for every_s in [1.0, 0.25, 7.0] {
        let dec = batch_lines(&log, Some(RowInterval::new(every_s).expect("interval")));
        assert_eq!(&dec[0], header, "same header");
        // Independently of RowInterval: the first row, the first row at or
        // after each multiple of the interval, every row whose switch count
        // differs from the row before, the last row.
        let t = |line: &str| field(line, t_col).parse::<f64>().expect("t_s");
        let cell = |line: &str| (t(line) / every_s + 1e-9).floor() as i64;
        let want: Vec<&String> = rows
            .iter()
            .enumerate()
            .filter(|(k, line)| {
                *k == 0
                    || *k == rows.len() - 1
                    || cell(line) != cell(&rows[k - 1])
                    || field(line, sw_col) != field(&rows[k - 1], sw_col)
            })
            .map(|(_, line)| line)
            .collect();
        let got: Vec<&String> = dec[1..].iter().collect();
        let switches = got
            .windows(2)
            .filter(|w| field(w[0], sw_col) != field(w[1], sw_col))
            .count();
        eprintln!(
            "--every {every_s}: {} of {} rows written, {switches} switches among them",
            got.len(),
            rows.len()
        );
        assert_eq!(got.len(), want.len(), "--every {every_s}: rows written");
        // Byte-equal lines: with shortest round-trip formatting, equal
        // text is equal bits.
        if let Some((k, (g, w))) = got.iter().zip(&want).enumerate().find(|(_, (g, w))| g != w) {
            panic!("--every {every_s}: row {k} differs:\n  got  {g}\n  want {w}");
        }
        assert_eq!(switches, 3, "--every {every_s}: every switch row kept");
        assert_eq!(got.last(), rows.last().as_ref(), "the last row");
    }
}
