//! `sensor-replay eval` without truth (issue 21): on the imported lasergyro
//! record and on a simulated log with its truth removed it exits 0 and writes
//! the figures it names; the per-aid NIS verdicts read "consistent" on
//! paper-sim run with its own sensor model and "too optimistic" when the
//! aids' stated σ is 10× smaller than simulated; `--reference` draws the
//! difference of two runs and its RMS agrees with an independent one.

use msgs::{AidKind, AidSample};
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::process::Command;

use msgs::navlog::{NavlogWriter, Record, read_all};
use nav_daemon::batch::Output;
use polarnav_config::CliOverrides;
use polarnav_eval::review::{self, Verdict};
use polarnav_eval::{logfile, plots};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

mod common;
use common::{eval, png_size, repo};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("polarnav-review-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("dir");
    d
}

fn batch_to(log: &Path, out: &Path) {
    let o = if out.extension().is_some_and(|e| e == "mcap") {
        Output::Mcap(Box::new(
            polarnav_foxglove::McapFile::create(out, polarnav_foxglove::AidSource::Updates)
                .expect("mcap"),
        ))
    } else {
        Output::Csv(BufWriter::new(std::fs::File::create(out).expect("create")))
    };
    common::batch_to(log, o, CliOverrides::default());
}

/// Rewrites `log` into `out` with `f` applied to every record (`None` drops it).
fn rewrite(log: &Path, out: &Path, f: impl Fn(Record) -> Option<Record>) {
    let (records, report) = read_all(&std::fs::read(log).expect("read"));
    assert!(report.is_clean());
    let mut it = records.into_iter();
    let Some(Record::Header(h)) = it.next() else {
        panic!("no header");
    };
    let mut w = NavlogWriter::new(std::fs::File::create(out).expect("create"), *h).expect("w");
    for r in it.filter_map(f) {
        w.write(&r).expect("write");
    }
    w.finish().expect("finish");
}

fn no_truth(r: Record) -> Option<Record> {
    (!matches!(r, Record::Truth(_) | Record::TruthBias(_))).then_some(r)
}

/// paper-sim shortened to `seconds` (it crosses 88° N, the switch, at 212 s).
fn paper_sim(dir: &Path, seconds: u32, seed: u64) -> PathBuf {
    let text = std::fs::read_to_string(repo("config/scenarios/paper-sim.toml"))
        .expect("scenario")
        .replace("duration_s = 600.0", &format!("duration_s = {seconds}.0"));
    assert!(text.contains(&format!("duration_s = {seconds}.0")));
    let s = Scenario::parse(&text, "paper-sim (short)").expect("scenario");
    let log = dir.join(format!("paper-{seed}.navlog"));
    simulate(
        &s,
        &text,
        SimOptions {
            seed,
            ..Default::default()
        },
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");
    log
}

/// Every figure file the summary names (`- \`name.png\``) exists in `dir`
/// and is a real image: a PNG signature, an IHDR of at least 1000×600 and
/// more than 20 kB (an empty canvas compresses to a few kB); or SVG text
/// when no font was found.
fn check_named_figures(summary: &str, dir: &Path) -> Vec<String> {
    let ext = match plots::init_fonts() {
        plots::Format::Png => "png",
        plots::Format::Svg => "svg",
    };
    let names: Vec<String> = summary
        .lines()
        .filter_map(|l| l.strip_prefix("- `"))
        .filter_map(|l| l.split_once('`').map(|x| x.0.to_owned()))
        .filter(|n| n.ends_with(&format!(".{ext}")))
        .collect();
    for n in &names {
        let bytes = std::fs::read(dir.join(n)).unwrap_or_else(|e| panic!("{n}: {e}"));
        if ext == "png" {
            let (w, h) = png_size(&bytes);
            assert!(w >= 1000 && h >= 600, "{n}: {w}×{h}");
        } else {
            assert!(bytes.starts_with(b"<svg"), "{n}");
        }
        assert!(bytes.len() > 20_000, "{n}: only {} bytes", bytes.len());
    }
    names
}

/// The PSINS laser-gyro record of the project's shared data (`../shared`
/// beside this checkout); a test without it says so.
fn lasergyro() -> PathBuf {
    let p = repo("../shared/datasets/psins-lasergyro/lasergyro.imu");
    let shared = "the tests read the project's shared data from ../shared, beside this checkout \
                  (README, Quick start): clone or link it there";
    assert!(p.exists(), "{} is missing: {shared}", p.display());
    p
}

#[test]
fn eval_without_truth_on_the_lasergyro_import_writes_the_review() {
    let dir = tmp("lasergyro");
    let imported = dir.join("lg-truth.navlog");
    let st = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
        .arg("import-psins")
        .arg(lasergyro())
        .args(["--cns-sigma", "10", "--baro-sigma", "5", "--out"])
        .arg(&imported)
        .status()
        .expect("import");
    assert!(st.success());
    // The importer writes the file's reference as truth; a real flight has none.
    let log = dir.join("lg.navlog");
    rewrite(&imported, &log, no_truth);
    assert!(logfile::load(&log).expect("load").truth.is_empty());
    let mcap = dir.join("lg.mcap");
    batch_to(&log, &mcap);
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        mcap.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    let on_disk = std::fs::read_to_string(figs.join("summary.md")).expect("summary.md");
    assert_eq!(on_disk.trim(), summary.trim());
    assert!(summary.contains("no truth"), "{summary}");
    let names = check_named_figures(&summary, &figs);
    for want in [
        "aid_cns",
        "aid_baro",
        "health",
        "imu_sampling",
        "sigma",
        "biases",
    ] {
        assert!(
            names.iter().any(|n| n.starts_with(want)),
            "{want} not named in:\n{summary}"
        );
    }
    // The accuracy figures need truth and are said to be missing.
    assert!(!names.iter().any(|n| n.starts_with("position_errors")));
    assert!(summary.contains("no accuracy figures"), "{summary}");
    // The settings and the producer of the run are stated.
    assert!(summary.contains("import-psins") && summary.contains("polarnav-eval"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn eval_on_a_log_without_truth_and_a_csv_solution_exits_0_and_says_what_is_missing() {
    let dir = tmp("notruth");
    let full = paper_sim(&dir, 60, 3);
    let log = dir.join("no-truth.navlog");
    rewrite(&full, &log, no_truth);
    let csv = dir.join("run.csv");
    batch_to(&log, &csv);
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        csv.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    check_named_figures(&summary, &figs);
    // No innovations in a CSV: the summary says how to get them.
    assert!(
        summary.contains("no `innovations` figure") && summary.contains("--out run.mcap"),
        "{summary}"
    );
    // Today's CSV carries the bias σ (solution version 3): the bias figure
    // has its bands, and the summary does not call them missing.
    assert!(!summary.contains("without σ bands"), "{summary}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The first minute of `transpolar-gnss` with a dual-antenna baseline and
/// a magnetometer added (every aid of the declaration, GNSS with its 6
/// innovation components) without truth, batch-processed to MCAP: the
/// review draws one figure per aid, each component in a panel of its own.
/// It starts at 60° N, not 85°: there the horizontal field is below the
/// magnetometer's bound and it would refuse every sample.
#[test]
fn eval_of_a_flight_with_every_aid_draws_each_aids_figure_gnss_with_its_six_components() {
    let dir = tmp("every-aid");
    let text = std::fs::read_to_string(repo("config/scenarios/transpolar-gnss.toml"))
        .expect("scenario")
        .replace("duration_s = 4480.0", "duration_s = 60.0")
        .replace("lat_deg = 85.0", "lat_deg = 60.0")
        .replace(
            "[init_error]",
            "[baseline]\nrate_hz = 5.0\n\n[mag]\nrate_hz = 5.0\nepoch_utc = \"2026-06-01T00:00:00Z\"\n\n\
             [navigator.aids.mag]\nepoch_utc = \"2026-06-01T00:00:00Z\"\n\n[init_error]",
        );
    assert!(
        text.contains("duration_s = 60.0")
            && text.contains("lat_deg = 60.0")
            && text.contains("[baseline]")
            && text.contains("[mag]")
    );
    let s = Scenario::parse(&text, "transpolar-gnss (short)").expect("scenario");
    let full = dir.join("gnss-truth.navlog");
    simulate(
        &s,
        &text,
        SimOptions::default(),
        std::fs::File::create(&full).expect("create"),
    )
    .expect("simulate");
    let log = dir.join("gnss.navlog");
    rewrite(&full, &log, no_truth);
    let mcap = dir.join("gnss.mcap");
    batch_to(&log, &mcap);
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        mcap.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    let names = check_named_figures(&summary, &figs);
    for kind in AidKind::ALL {
        let want = format!("aid_{}.", kind.decl().name);
        assert!(
            names.iter().any(|n| n.starts_with(&want)),
            "{want} not named in:\n{summary}"
        );
    }
    assert_eq!(AidKind::Gnss.decl().components.len(), 6);
    std::fs::remove_dir_all(&dir).ok();
}

fn verdicts(log: &Path, dir: &Path) -> Vec<(&'static str, Verdict)> {
    let mcap = dir.join(format!(
        "{}.mcap",
        log.file_stem().expect("stem").to_string_lossy()
    ));
    batch_to(log, &mcap);
    let c = logfile::load(log).expect("load");
    let r = review::review(
        &c,
        &review::Options {
            solution: &mcap,
            reference: None,
            out: None,
        },
    )
    .expect("review");
    println!("{}", r.markdown);
    r.verdicts
}

/// paper-sim (600 s shortened to 300 s: SRS and CNS 300 updates each, baro
/// 3000) batch-processed with the shipped settings, which are its own
/// sensor model (papers/001 Table 1): every aid is consistent. The test can
/// fail: a mean NIS outside m/2 … 2m or over 1 % rejected fails it, and
/// with the aids' σ 10× too small (below) it does.
#[test]
fn verdicts_are_consistent_with_the_scenarios_own_noise_and_too_optimistic_with_10x_smaller() {
    let dir = tmp("verdicts");
    let log = paper_sim(&dir, 300, 11);
    let v = verdicts(&log, &dir);
    let names: Vec<&str> = v.iter().map(|x| x.0).collect();
    assert_eq!(names, ["SRS", "CNS", "baro"], "{v:?}");
    for (aid, verdict) in &v {
        assert_eq!(*verdict, Verdict::Consistent, "{aid}: {v:?}");
    }
    // The same flight, the aids stating a σ 10× smaller than the simulated noise.
    let tight = dir.join("tight.navlog");
    rewrite(&log, &tight, |r| {
        Some(match r {
            Record::Aid(a) => match *a {
                AidSample::Srs(mut s) => {
                    for l in s.lines.iter_mut() {
                        l.sigma_mps *= 0.1;
                    }
                    Record::aid(s)
                }
                AidSample::Cns(mut c) => {
                    c.sigma_h_m *= 0.1;
                    Record::aid(c)
                }
                AidSample::Baro(mut b) => {
                    b.sigma_m *= 0.1;
                    Record::aid(b)
                }
                other => Record::aid(other),
            },
            other => other,
        })
    });
    let v = verdicts(&tight, &dir);
    assert_eq!(v.len(), 3, "{v:?}");
    for (aid, verdict) in &v {
        assert_eq!(*verdict, Verdict::TooOptimistic, "{aid}: {v:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `--reference`: a run without CNS judged against the run with every aid.
/// The vertical RMS the summary prints agrees with one computed here from
/// the two CSVs' heights (the up component of a metre-sized offset is the
/// height difference to well under 1 %), and no truth is needed.
#[test]
fn reference_difference_and_its_rms_without_truth() {
    let dir = tmp("reference");
    let full = paper_sim(&dir, 120, 5);
    let log = dir.join("no-truth.navlog");
    rewrite(&full, &log, no_truth);
    let no_cns = dir.join("no-cns.navlog");
    rewrite(&log, &no_cns, |r| {
        (!matches!(r, Record::Aid(ref a) if a.kind() == AidKind::Cns)).then_some(r)
    });
    let (fwd, reference) = (dir.join("no-cns.csv"), dir.join("all.csv"));
    batch_to(&no_cns, &fwd);
    batch_to(&log, &reference);
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        fwd.as_os_str(),
        "--reference".as_ref(),
        reference.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    let names = check_named_figures(&summary, &figs);
    assert!(
        names.iter().any(|n| n.starts_with("reference_difference")),
        "{summary}"
    );
    let a = polarnav::solution_csv::read(&fwd).expect("fwd");
    let b = polarnav::solution_csv::read(&reference).expect("ref");
    assert_eq!(a.len(), b.len());
    let ms: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x.h_m - y.h_m).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    let line = summary
        .lines()
        .find(|l| l.starts_with("Horizontal position RMS"))
        .expect("RMS line");
    let vertical: f64 = line
        .split("vertical ")
        .nth(1)
        .and_then(|x| x.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("vertical RMS");
    assert!(
        (vertical - ms.sqrt()).abs() <= 0.01 * ms.sqrt() + 1e-3,
        "summary {vertical} m vs independent {} m",
        ms.sqrt()
    );
    assert!(summary.contains("inside forward ±3σ"), "{summary}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Absurd solution files: an error naming the file (and line), never a panic.
#[test]
fn absurd_solution_files_are_refused_naming_file_and_line() {
    let dir = tmp("absurd");
    let log = paper_sim(&dir, 5, 1);
    let csv = dir.join("run.csv");
    batch_to(&log, &csv);
    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut lines = text.lines();
    let header = lines.next().expect("header").to_owned();
    let row = lines.next().expect("row").to_owned();
    let nan_row = {
        let mut f: Vec<&str> = row.split(',').collect();
        f[0] = "NaN";
        f.join(",")
    };
    let cases: [(&str, String, &str); 5] = [
        ("empty.csv", String::new(), "empty"),
        ("header-only.csv", format!("{header}\n"), "no solution row"),
        (
            "nan.csv",
            format!("{header}\n{row}\n{nan_row}\n"),
            "non-finite",
        ),
        ("short.csv", format!("{header}\n{row}\n1,g\n"), ":3:"),
        ("bin.csv", "t_s\u{0}\u{1}".to_owned(), "bin.csv"),
    ];
    for (name, body, want) in cases {
        let p = dir.join(name);
        std::fs::write(&p, body).expect("write");
        let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
            .arg("eval")
            .arg("--log")
            .arg(&log)
            .arg("--solution")
            .arg(&p)
            .output()
            .expect("run");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(err.contains(name) && err.contains(want), "{name}: {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
    }
    // The same NaN time in the reference: refused naming it, not a join
    // that stops there and leaves every later row unmatched.
    let c = logfile::load(&log).expect("load");
    let e = review::review(
        &c,
        &review::Options {
            solution: &csv,
            reference: Some(&dir.join("nan.csv")),
            out: None,
        },
    )
    .expect_err("a reference with a NaN time");
    assert!(
        e.contains("nan.csv") && e.contains("row 2 has a non-finite time"),
        "{e}"
    );
    // A BOM, one row and a duplicated stamp are fine.
    let p = dir.join("bom.csv");
    std::fs::write(&p, format!("\u{feff}{header}\n{row}\n{row}\n")).expect("write");
    let c = logfile::load(&log).expect("load");
    let r = review::review(
        &c,
        &review::Options {
            solution: &p,
            reference: None,
            out: Some(&dir.join("figs")),
        },
    )
    .expect("review of a BOM, one row repeated");
    assert!(
        r.markdown.contains("1 rows repeat the previous time"),
        "{}",
        r.markdown
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `sensor-replay eval ... | head`: a reader that closes the pipe before
/// the summary is printed costs no panic (`println!` panics on a broken
/// pipe, as Rust ignores SIGPIPE); eval exits 0, quietly, and still
/// writes its summary file.
#[test]
fn eval_into_a_closed_pipe_exits_0_quietly_and_writes_its_summary() {
    use std::io::Read;
    use std::process::Stdio;
    let dir = tmp("pipe");
    let log = paper_sim(&dir, 20, 1);
    let csv = dir.join("run.csv");
    batch_to(&log, &csv);
    let run = |out: &Path, read_first: usize| {
        let mut child = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
            .arg("eval")
            .arg("--log")
            .arg(&log)
            .arg("--solution")
            .arg(&csv)
            .arg("--out")
            .arg(out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run sensor-replay eval");
        let mut stdout = child.stdout.take().expect("stdout");
        let mut head = vec![0u8; read_first];
        stdout.read_exact(&mut head).expect("the first bytes");
        // The only read end: from here on every write to stdout fails
        // with EPIPE.
        drop(stdout);
        let o = child.wait_with_output().expect("wait");
        (head, o)
    };
    // Closed before eval writes anything (it writes the summary at the
    // end, in one piece, after seconds of work): its write meets EPIPE.
    // And closed after `head -c 2` of it (a summary larger than the pipe's
    // buffer meets EPIPE there too; a smaller one is already written).
    for (name, read_first) in [("closed", 0), ("head", 2)] {
        let out = dir.join(name);
        let (head, o) = run(&out, read_first);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(!err.to_lowercase().contains("broken pipe"), "{name}: {err}");
        assert_eq!(o.status.code(), Some(0), "{name}: {err}");
        let summary = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
        assert!(summary.starts_with("## Accuracy"), "{summary}");
        assert!(summary.as_bytes().starts_with(&head));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A spoofed flight reviewed without truth: the aids figure and section say
/// when GNSS was excluded and the time to alarm of the injected fault, and
/// the integrity figure draws the status records' test statistic. (The
/// statistic's values are written into the log here, 1 Hz as a recorder
/// would have them: their computation is tested in the core and in
/// `tests/gnss.rs`; this tests the review.)
#[test]
fn review_of_a_spoofed_flight_says_which_aids_navigated_and_the_time_to_alarm() {
    let dir = tmp("spoofed");
    let text = std::fs::read_to_string(repo("config/scenarios/transpolar-gnss.toml"))
        .expect("scenario")
        .replace("duration_s = 4480.0", "duration_s = 60.0")
        + "\n[[faults.event]]\nkind = \"gnss_spoof\"\nstream = \"gnss\"\nstart_s = 20.0\nduration_s = 20.0\noffset_m = 500.0\ndelay_s = 0.2\n";
    let s = Scenario::parse(&text, "transpolar-gnss (short, meaconed)").expect("scenario");
    let full = dir.join("full.navlog");
    simulate(
        &s,
        &text,
        SimOptions::default(),
        std::fs::File::create(&full).expect("create"),
    )
    .expect("simulate");
    let (records, report) = read_all(&std::fs::read(&full).expect("read"));
    assert!(report.is_clean());
    let log = dir.join("spoofed.navlog");
    let mut it = records.into_iter();
    let Some(Record::Header(h)) = it.next() else {
        panic!("no header");
    };
    let mut w = NavlogWriter::new(std::fs::File::create(&log).expect("create"), *h).expect("w");
    for r in it.filter_map(no_truth) {
        let second = match &r {
            Record::Imu(x) if x.t_ns % 1_000_000_000 == 0 => Some(x.t_ns),
            _ => None,
        };
        w.write(&r).expect("write");
        if let Some(t_ns) = second {
            let mut st = msgs::Status {
                t_ns,
                ..Default::default()
            };
            let t = t_ns as f64 * 1e-9;
            st.aid_mut(AidKind::Gnss).integrity_ratio = if (20.0..40.0).contains(&t) {
                12.0
            } else if t >= 48.0 {
                // The test unavailable at the end: its statistic is drawn
                // apart (not acted on), however large.
                st.aid_mut(AidKind::Gnss).integrity_state = msgs::integrity_state::UNAVAILABLE;
                2.0 + (t - 48.0)
            } else {
                0.1 + 0.05 * (t * 0.7).sin()
            };
            w.write(&Record::Status(Box::new(st))).expect("status");
        }
    }
    w.finish().expect("finish");
    let csv = dir.join("spoofed.csv");
    batch_to(&log, &csv);
    let figs = dir.join("figs");
    let summary = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        csv.as_os_str(),
        "--out".as_ref(),
        figs.as_os_str(),
    ]);
    let names = check_named_figures(&summary, &figs);
    for want in ["aids.", "integrity."] {
        assert!(
            names.iter().any(|n| n.starts_with(want)),
            "{want} not named in:\n{summary}"
        );
    }
    // Meaconing is excluded at its first fix (tests/gnss.rs): 20 s, the
    // first fix after the 0.2 s delay.
    let line = summary
        .lines()
        .find(|l| l.contains("fault `gnss_spoof` injected at 20.000 s"))
        .unwrap_or_else(|| panic!("no time to alarm in:\n{summary}"));
    let alarm: f64 = line
        .split("time to alarm ")
        .nth(1)
        .and_then(|x| x.trim_end_matches(" s").parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((0.0..=0.5).contains(&alarm), "{line}");
    assert!(
        summary.contains("1 exclusion (excluded at 20."),
        "{summary}"
    );
    // Every autonomous aid holds the reference: GNSS was never fused
    // untested (its solutions' GNSS_UNTESTED bit), and the summary says so.
    assert!(
        summary.contains(
            "its integrity test unavailable (its horizontal protection level from the reference \
             beyond the alert limit: its samples fused untested) in 0.00 % of rows"
        ),
        "{summary}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
