//! Cross-crate pipeline: scenario → simulator → navlog → nav-daemon batch →
//! solution CSV → eval, as the quick start runs it.

use std::io::BufReader;
use std::path::Path;

use nav_daemon::batch::{self, BatchOptions};
use polarnav::mech::FrameKind;
use polarnav::solution_csv;
use polarnav_config::ConfigFile;
use polarnav_eval::eval;
use polarnav_eval::logfile;
use polarnav_sim::scenario::Scenario;
use polarnav_sim::simulate::{SimOptions, simulate};

#[test]
fn paper_sim_switches_at_88n_at_212s_through_the_header_override() {
    let dir = std::env::temp_dir().join(format!("polarnav-pipeline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let scen = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenarios/paper-sim.toml");
    let (s, text) = Scenario::load(&scen).expect("scenario");
    let log = dir.join("paper.navlog");
    simulate(
        &s,
        &text,
        SimOptions {
            perfect: true,
            ..Default::default()
        },
        std::fs::File::create(&log).expect("create"),
    )
    .expect("simulate");

    let csv = dir.join("paper.csv");
    let report = batch::run(
        BufReader::new(std::fs::File::open(&log).expect("open")),
        "paper.navlog",
        std::io::BufWriter::new(std::fs::File::create(&csv).expect("create")),
        &ConfigFile::defaults(),
        &BatchOptions::default(),
    )
    .expect("batch");
    // The scenario's [navigator] table (88°) reached the navigator through the navlog header.
    let frame = &report.effective.config.frame;
    assert!((frame.switch_enter_deg - 88.0).abs() < 1e-12);
    assert_eq!(
        report.effective.source("frame.switch_enter_deg"),
        Some(&polarnav_config::Source::Header)
    );
    assert_eq!(report.switches.len(), 1, "{:?}", report.switches);
    let sw = report.switches[0];
    assert_eq!((sw.from, sw.to), (FrameKind::Geographic, FrameKind::Grid));
    let t_switch = sw.t_ns as f64 * 1e-9;
    assert!((t_switch - 212.0).abs() < 0.05, "switch at {t_switch} s");
    assert!((sw.lat_rad.to_degrees() - 88.0).abs() < 1e-3);

    // Perfect sensors: the evaluated solution is the truth.
    let rows = solution_csv::read(&csv).expect("csv");
    let truth = logfile::load(&log).expect("log").truth;
    let ep = eval::epochs(&rows, &truth);
    assert_eq!(ep.len(), truth.len() - 1); // every truth epoch after t = 0
    let sum = eval::summarize(&rows, &ep);
    assert!(
        sum.horizontal_m.max < 1e-3 && sum.vertical_m.max < 1e-3,
        "{sum:?}"
    );
    assert!(sum.heading_arcmin.max < 1e-4, "{sum:?}");
    assert_eq!(sum.non_finite_rows, 0);
    assert!(rows.iter().any(|r| r.frame == 'g') && rows.iter().any(|r| r.frame == 'G'));
    std::fs::remove_dir_all(&dir).ok();
}
