//! Benchmark (not a test): what a campaign run costs against the same
//! flight as separate processes, and where its time goes.
//!
//! For runs `0..N` of `config/campaigns/integrity-clean.toml` (the 1.24 h
//! transpolar flight with GNSS tested against every autonomous aid), in
//! interleaved pairs, the CPU time (user + system, as the shell's `time`
//! counts it for the processes it waits for) of:
//!
//! - the campaign's run: `sensor-replay campaign run-one DIR --index i`
//!   (simulation, navigation and evaluation in one process, one row out);
//! - the same flight as separate processes: `sensor-replay simulate` (the
//!   same scenario and seed) into a navlog, `nav-daemon batch --every 1`
//!   into a CSV and `sensor-replay eval` of it against the truth.
//!
//! It prints each pair, the flight hours per core hour of both, their
//! ratio (the issue asks ≥ 0.9), and the campaign run's shares of
//! simulation, navigation and evaluation (its cost row). It exits 1 when
//! the ratio is below 0.9 or the two disagree on the flight's accuracy.
//!
//! `cargo build --release --bins && cargo bench -p polarnav-tests --bench campaign_cost [-- N]`
//! (N pairs, default 4; the binaries are the release ones when built,
//! else the debug ones).

use std::path::{Path, PathBuf};
use std::process::Command;

use sensor_replay::campaign::{local, plan, store};

fn binary(name: &str) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for p in ["target/release", "target/debug"] {
        let b = root.join(p).join(name);
        if b.exists() {
            return b;
        }
    }
    panic!("{name} is not built: cargo build --release --bins");
}

/// CPU seconds (user + system) of a shell command line, from bash's `time`.
fn cpu_of(cmd: &str) -> f64 {
    let out = Command::new("bash")
        .args(["-c", &format!("TIMEFORMAT='%3U %3S'; time ( {{ {cmd} ; }} > /dev/null 2>/tmp/polarnav-bench-cost.err )")])
        .output()
        .expect("bash");
    assert!(
        out.status.success(),
        "{cmd}: {}\n{}",
        out.status,
        std::fs::read_to_string("/tmp/polarnav-bench-cost.err").unwrap_or_default()
    );
    let t = String::from_utf8_lossy(&out.stderr);
    let last = t.lines().last().unwrap_or_default().to_owned();
    let v: Vec<f64> = last
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    assert_eq!(v.len(), 2, "time printed {t:?}");
    v[0] + v[1]
}

fn main() {
    let n: u64 = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .and_then(|a| a.parse().ok())
        .unwrap_or(4);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let file = root.join("config/campaigns/integrity-clean.toml");
    let work = std::env::temp_dir().join(format!("polarnav-bench-cost-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    let dir = work.join("campaign");
    let (_, plan) = local::open_for(&file, &dir).expect("the campaign");
    let sr = binary("sensor-replay");
    let nd = binary("nav-daemon");
    let scenario = root.join("config/scenarios/transpolar-gnss.toml");
    println!(
        "campaign {} ({}): {} pairs; binaries {} and {}",
        plan.name,
        plan.sha256,
        n,
        sr.display(),
        nd.display()
    );
    let (mut cpu_campaign, mut cpu_separate, mut hours) = (0.0, 0.0, 0.0);
    let mut parts = [0.0f64; 3];
    let mut worst_disagreement: f64 = 0.0;
    for i in 0..n {
        let seed = plan::seed_of(plan.seeds.base, i);
        let log = work.join("flight.navlog");
        let csv = work.join("solution.csv");
        let run_one = format!(
            "{} campaign run-one {} --index {i}",
            sr.display(),
            dir.display()
        );
        let separate = format!(
            "{sr} simulate --scenario {sc} --seed {seed} --out {log} && {nd} batch --log {log} --out {csv} --every 1 && {sr} eval --log {log} --solution {csv}",
            sr = sr.display(),
            nd = nd.display(),
            sc = scenario.display(),
            log = log.display(),
            csv = csv.display(),
        );
        // Interleaved, the order alternating.
        let (a, b) = if i % 2 == 0 {
            let a = cpu_of(&run_one);
            (a, cpu_of(&separate))
        } else {
            let b = cpu_of(&separate);
            (cpu_of(&run_one), b)
        };
        let r = store::read_result(&dir, i, &plan.sha256)
            .expect("result")
            .expect("result");
        let h = r.metrics.flight_h.expect("flight hours");
        // The separate pipeline's accuracy: eval's table, horizontal RMSE.
        let eval = Command::new(&sr)
            .args(["eval", "--log"])
            .arg(&log)
            .arg("--solution")
            .arg(&csv)
            .output()
            .expect("eval");
        let text = String::from_utf8_lossy(&eval.stdout);
        let sep_h = text
            .lines()
            .find(|l| l.starts_with("| horizontal position"))
            .and_then(|l| {
                l.split('|')
                    .filter_map(|c| c.split_whitespace().next()?.parse::<f64>().ok())
                    .next()
            });
        if let (Some(x), Some(y)) = (sep_h, r.metrics.horizontal_rmse_m) {
            worst_disagreement = worst_disagreement.max((x - y).abs() / y);
        }
        println!(
            "pair {i}: seed {seed}: {h:.3} flight h; campaign run {a:.2} s CPU ({:.0} flight h per core h), separate processes {b:.2} s ({:.0}); horizontal RMSE {:.3} m in the row, {} in eval's table",
            h / (a / 3600.0),
            h / (b / 3600.0),
            r.metrics.horizontal_rmse_m.unwrap_or(f64::NAN),
            sep_h.map_or("?".into(), |x| format!("{x:.3} m"))
        );
        cpu_campaign += a;
        cpu_separate += b;
        hours += h;
        parts[0] += r.cost.simulate_cpu_s;
        parts[1] += r.cost.navigate_cpu_s;
        parts[2] += r.cost.evaluate_cpu_s;
    }
    let fa = hours / (cpu_campaign / 3600.0);
    let fb = hours / (cpu_separate / 3600.0);
    let ratio = fa / fb;
    let total: f64 = parts.iter().sum();
    println!(
        "campaign runs: {fa:.0} flight h per core h; separate processes: {fb:.0}; ratio {ratio:.3} (required ≥ 0.9)"
    );
    println!(
        "campaign run's CPU: simulation {:.1} %, navigation with its in-stream evaluation {:.1} %, after the flight {:.1} %, the rest (start, plan, result) {:.1} %",
        100.0 * parts[0] / cpu_campaign,
        100.0 * parts[1] / cpu_campaign,
        100.0 * parts[2] / cpu_campaign,
        100.0 * (cpu_campaign - total) / cpu_campaign
    );
    let _ = std::fs::remove_dir_all(&work);
    if ratio < 0.9 {
        eprintln!("campaign runs cost more than 1/0.9 of separate processes");
        std::process::exit(1);
    }
    println!(
        "horizontal RMSE: the campaign's row against eval's table of the separate run, largest relative difference {:.2e} (eval prints 4 decimals)",
        worst_disagreement
    );
    if worst_disagreement > 1e-3 {
        eprintln!(
            "the campaign's horizontal RMSE and eval's differ by {:.1} %",
            100.0 * worst_disagreement
        );
        std::process::exit(1);
    }
}
