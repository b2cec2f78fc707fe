//! The fault campaign through the live daemon, over real iceoryx2 shared
//! memory: each fault scenario replayed into the daemon and recorded, as
//! separate processes with their own service prefix and iceoryx2 root and a
//! deadline on every wait. Apart from `live.rs` so that its load, three
//! flights at a time, meets no other live test.

use std::path::Path;
use std::time::Duration;

use msgs::navlog::Record;
use polarnav::solution_csv;
use polarnav_sim::scenario::Scenario;
use polarnav_tests::harness::{Env, status_until, terminate};
use polarnav_tests::repo;

/// The fault campaign through the live daemon: every fault scenario replayed
/// at 50x (daemon, replay and recorder as separate processes), judged like
/// the batch campaign on the recorded solution and status, with the replay's
/// publications accounted for. Three scenarios fly at a time, each on its
/// own prefix (nine one after the other took 258 s, the longest test of the
/// suite); the reports are printed in the scenarios' order. In a test binary
/// of its own: cargo runs binaries one after the other, so its nine
/// processes do not load the other live tests' (one of which records at a
/// rate its recorder keeps up with only when not starved).
#[test]
fn fault_campaign_through_the_live_daemon() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    const AT_A_TIME: usize = 3;
    let files = sensor_replay::campaign::scenario_files(&repo("config/scenarios/faults"))
        .expect("faults dir");
    let next = AtomicUsize::new(0);
    let mut results: Vec<(usize, String, bool)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..AT_A_TIME)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(f) = files.get(i) else {
                            return done;
                        };
                        let (name, report, ok) = fault_scenario_live(f);
                        done.push((i, format!("{name}:\n{report}"), ok));
                    }
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().expect("a scenario's thread panicked"))
            .collect()
    });
    results.sort_by_key(|r| r.0);
    assert_eq!(results.len(), files.len());
    let mut failed = Vec::new();
    for (_, report, ok) in &results {
        eprint!("{report}");
        if !ok {
            failed.push(report.lines().next().unwrap_or_default().to_string());
        }
    }
    assert!(failed.is_empty(), "failed live: {failed:?}");
}

/// One scenario of [`fault_campaign_through_the_live_daemon`]: its name,
/// report and verdict.
fn fault_scenario_live(f: &Path) -> (String, String, bool) {
    use sensor_replay::campaign;
    let r = campaign::run_scenario(f).expect("scenario");
    let env = Env::new(&format!("fc_{}", r.name.replace('-', "_")));
    let log = env.dir.join("faulted.navlog");
    std::fs::write(&log, &r.faulted_log).expect("log");
    let (mut daemon, mut recorder, rec_path) = env.replay_recorded(&log, "50");
    // The daemon's status once every published sample is accounted for
    // (status goes out at 1 Hz, also while the IMU is silent).
    let (s, _) = Scenario::load(f).expect("scenario");
    let injected: Vec<u64> = r.faults.iter().map(|x| x.injected).collect();
    let upstream = campaign::upstream_missing(&s, &injected);
    let status = status_until(&env, Duration::from_secs(20), |st| {
        campaign::streams(st)
            .iter()
            .all(|(k, c)| c.received + c.seq_gaps >= r.published[k] + upstream[k])
    });
    assert_eq!(terminate(&mut daemon, Duration::from_secs(20)), Some(0));
    assert_eq!(terminate(&mut recorder, Duration::from_secs(20)), Some(0));
    let (records, report) = msgs::navlog::read_all(&std::fs::read(&rec_path).expect("rec"));
    assert!(report.is_clean(), "{}: {report}", r.name);
    let mut csv = Vec::new();
    for rec in &records {
        if let Record::Solution(s) = rec {
            solution_csv::write_row(&mut csv, s).expect("row");
        }
    }
    let text = format!(
        "{}\n{}",
        solution_csv::header(),
        String::from_utf8(csv).expect("utf8")
    );
    let rows = solution_csv::parse(&text, "live").expect("rows");
    let live = campaign::ScenarioResult {
        faults: campaign::fault_lines(&s, &injected, &status),
        errors: campaign::judge(&r.truth, &r.fault_free_rows, &rows, &campaign::windows(&s)),
        accounting: campaign::check_accounting(r.published, Some(upstream), &status),
        status,
        ..r.clone()
    };
    (
        live.name.clone(),
        campaign::report(&live, "live, 50x"),
        live.ok(),
    )
}
