//! `sensor-replay eval` reads the log and the solutions once, streaming
//! (bounded memory; `cargo bench -p polarnav-eval --bench eval_memory`
//! prints its peak at 10 million rows): its summary and every figure equal,
//! byte for byte, those of the same evaluation with every record in memory
//! (what eval did before, and still does for files not in time order), with
//! and without truth, CSV and MCAP, a comparison run and a reference.

use std::io::BufWriter;
use std::path::{Path, PathBuf};

use msgs::navlog::{NavlogReader, NavlogWriter, Record};
use nav_daemon::batch::Output;
use polarnav_config::CliOverrides;
use polarnav_eval::run::{self, Args, Evaluated};
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

// This test uses some of the helpers.
#[allow(dead_code)]
mod common;
use common::{batch_to, eval, repo};

/// Every file of `dir` by name with its bytes.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| {
                let e = e.expect("entry");
                (
                    e.file_name().to_string_lossy().into_owned(),
                    std::fs::read(e.path()).expect("read"),
                )
            })
            .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Evaluates `args` streamed and in memory (into `out`/stream and
/// `out`/memory) and checks that both say and draw the same.
fn same_both_ways(name: &str, args: Args<'_>, out: Option<&Path>) -> Evaluated {
    let dirs = out.map(|o| {
        (
            o.join(format!("{name}-stream")),
            o.join(format!("{name}-memory")),
        )
    });
    let streamed = run::run(&Args {
        out: dirs.as_ref().map(|d| d.0.as_path()),
        ..args
    })
    .expect("streamed");
    let in_memory = run::in_memory(&Args {
        out: dirs.as_ref().map(|d| d.1.as_path()),
        ..args
    })
    .expect("in memory");
    assert!(
        streamed.markdown == in_memory.markdown,
        "{name}: the summaries differ:\n--- streamed\n{}\n--- in memory\n{}",
        streamed.markdown,
        in_memory.markdown
    );
    if let Some((s, m)) = &dirs {
        let (fs, fm) = (files(s), files(m));
        assert_eq!(
            fs.iter().map(|f| &f.0).collect::<Vec<_>>(),
            fm.iter().map(|f| &f.0).collect::<Vec<_>>(),
            "{name}: the figures written differ"
        );
        assert!(fs.len() >= 5, "{name}: only {} figures", fs.len());
        for ((n, a), (_, b)) in fs.iter().zip(&fm) {
            assert!(
                a == b,
                "{name}: {n} differs ({} and {} bytes)",
                a.len(),
                b.len()
            );
        }
    }
    streamed
}

/// The records of `from` without its truth, into `to`.
fn without_truth(from: &Path, to: &Path) {
    let mut r = NavlogReader::new(std::io::BufReader::new(
        std::fs::File::open(from).expect("open"),
    ));
    let mut w: Option<NavlogWriter<BufWriter<std::fs::File>>> = None;
    while let Some(rec) = r.next_record().expect("read") {
        match (rec, w.as_mut()) {
            (Record::Header(h), None) => {
                w = Some(
                    NavlogWriter::new(
                        BufWriter::new(std::fs::File::create(to).expect("create")),
                        *h,
                    )
                    .expect("header"),
                );
            }
            (Record::Truth(_) | Record::TruthBias(_), _) => {}
            (other, Some(w)) => w.write(&other).expect("write"),
            (_, None) => panic!("the log does not start with its header"),
        }
    }
    w.expect("header").finish().expect("finish");
}

/// The solution CSV `from` with rows 100 and 101 swapped, into `to`.
fn swapped(from: &Path, to: &Path) {
    let text = std::fs::read_to_string(from).expect("read");
    let mut lines: Vec<&str> = text.lines().collect();
    lines.swap(101, 102);
    std::fs::write(to, lines.join("\n") + "\n").expect("write");
}

#[test]
fn streamed_eval_says_and_draws_what_the_in_memory_eval_does() {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("polarnav-eval-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    // paper-sim shortened to 240 s: it still crosses 88° N at 212 s.
    let text = std::fs::read_to_string(repo("config/scenarios/paper-sim.toml"))
        .expect("scenario")
        .replace("duration_s = 600.0", "duration_s = 240.0");
    assert!(text.contains("duration_s = 240.0"));
    let s = Scenario::parse(&text, "paper-sim (240 s)").expect("scenario");
    let log = dir.join("paper.navlog");
    simulate(
        &s,
        &text,
        SimOptions {
            seed: 3,
            ..Default::default()
        },
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");
    let csv = |name: &str, cli: CliOverrides| {
        let p = dir.join(name);
        batch_to(
            &log,
            Output::Csv(BufWriter::new(std::fs::File::create(&p).expect("create"))),
            cli,
        );
        p
    };
    let sol = csv("run.csv", CliOverrides::default());
    let never = csv(
        "never.csv",
        CliOverrides {
            force_switch_s: Some(Vec::new()),
            ..Default::default()
        },
    );
    let mcap = dir.join("run.mcap");
    batch_to(
        &log,
        Output::Mcap(Box::new(
            polarnav_foxglove::McapFile::create(&mcap, polarnav_foxglove::AidSource::Updates)
                .expect("mcap"),
        )),
        CliOverrides::default(),
    );
    let bare = dir.join("bare.navlog");
    without_truth(&log, &bare);

    // With truth: an MCAP solution (the innovations), a comparison that
    // never switches (the switch transients) and a reference, figures.
    let e = same_both_ways(
        "truth-mcap",
        Args {
            log: &log,
            solution: &mcap,
            compare: Some(&never),
            reference: Some(&never),
            out: None,
        },
        Some(&dir),
    );
    assert!(e.notes.is_empty(), "not streamed: {:?}", e.notes);
    for part in [
        "## Accuracy: ",
        "### compare: error drift",
        "### Switch transients: solution against compare",
        "innovations.png",
        "compare_difference.png",
        "### Forward against the reference",
        "### Noise-model consistency per aid (NIS)",
        "| SRS | 3 |",
    ] {
        assert!(e.markdown.contains(part), "no {part:?} in\n{}", e.markdown);
    }
    // With truth, a CSV solution and an MCAP comparison, no figures.
    let e = same_both_ways(
        "truth-csv",
        Args {
            log: &log,
            solution: &sol,
            compare: Some(&mcap),
            reference: None,
            out: None,
        },
        None,
    );
    assert!(e.notes.is_empty(), "not streamed: {:?}", e.notes);
    // The command prints that summary.
    let printed = eval(&[
        "--log".as_ref(),
        log.as_os_str(),
        "--solution".as_ref(),
        sol.as_os_str(),
        "--compare".as_ref(),
        mcap.as_os_str(),
    ]);
    assert!(printed == format!("{}\n", e.markdown), "{printed}");
    // Without truth: the review, an MCAP solution and reference, figures.
    let e = same_both_ways(
        "bare-mcap",
        Args {
            log: &bare,
            solution: &mcap,
            compare: Some(&sol),
            reference: Some(&mcap),
            out: None,
        },
        Some(&dir),
    );
    assert!(e.notes.is_empty(), "not streamed: {:?}", e.notes);
    assert!(e.markdown.contains("no truth") && e.markdown.contains("aid_srs.png"));

    // A solution whose rows go back in time is read in memory, with a
    // note naming the file and the row, and says what it always said.
    let back = dir.join("back.csv");
    swapped(&sol, &back);
    let e = same_both_ways(
        "unordered",
        Args {
            log: &log,
            solution: &back,
            compare: None,
            reference: None,
            out: None,
        },
        None,
    );
    assert!(
        e.notes.len() == 1
            && e.notes[0].contains(&back.display().to_string())
            && e.notes[0].contains("row 102")
            && e.notes[0].contains("in memory"),
        "{:?}",
        e.notes
    );
    std::fs::remove_dir_all(&dir).ok();
}
