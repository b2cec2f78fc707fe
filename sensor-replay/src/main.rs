//! `sensor-replay`: simulate flights, import/export logs, evaluate solutions.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use sensor_replay::scenario::Scenario;
use sensor_replay::simulate::{self, SimOptions};
use sensor_replay::{eval, export, logfile};

#[derive(Debug, Parser)]
#[command(
    name = "sensor-replay",
    version,
    about = "polarnav flight simulator, log tools and evaluator"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Simulate a scenario into a navlog (IMU, aids, init, truth).
    Simulate {
        #[arg(long)]
        scenario: PathBuf,
        #[arg(long)]
        out: PathBuf,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Error-free sensors and initial state.
        #[arg(long)]
        perfect: bool,
    },
    /// Export a navlog's truth (and more) to text formats.
    Export {
        log: PathBuf,
        #[arg(long)]
        truth_csv: Option<PathBuf>,
    },
    /// Accuracy of a solution CSV against the log's truth.
    Eval {
        #[arg(long)]
        log: PathBuf,
        #[arg(long)]
        solution: PathBuf,
        /// Directory for summary.md.
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// A failure with its exit status (2 bad input, 1 other).
struct Fail(u8, String);

fn run(cli: Cli) -> Result<(), Fail> {
    let bad = |m: String| Fail(2, m);
    match cli.cmd {
        Cmd::Simulate {
            scenario,
            out,
            seed,
            perfect,
        } => {
            let (s, text) = Scenario::load(&scenario).map_err(|e| bad(e.to_string()))?;
            let f = File::create(&out)
                .map_err(|e| Fail(1, format!("{}: cannot create: {e}", out.display())))?;
            let t0 = std::time::Instant::now();
            eprintln!(
                "simulate: {} ({:.0} s of flight, seed {seed}{})",
                s.name,
                s.duration_s(),
                if perfect { ", perfect sensors" } else { "" }
            );
            let sum = simulate::simulate(
                &s,
                &text,
                SimOptions {
                    seed,
                    perfect,
                    ..Default::default()
                },
                BufWriter::with_capacity(1 << 20, f),
            )
            .map_err(|e| Fail(1, format!("{}: {e}", out.display())))?;
            eprintln!(
                "simulate: wrote {} in {:.1} s: {} IMU, {} SRS, {} CNS, {} baro, {} truth records",
                out.display(),
                t0.elapsed().as_secs_f64(),
                sum.imu,
                sum.srs,
                sum.cns,
                sum.baro,
                sum.truth
            );
            Ok(())
        }
        Cmd::Export { log, truth_csv } => {
            let c = logfile::load(&log).map_err(|e| bad(e.to_string()))?;
            if !c.report.is_clean() {
                eprintln!("warning: {}: {}", log.display(), c.report);
            }
            if let Some(p) = truth_csv {
                let f = File::create(&p).map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                export::write_truth_csv(BufWriter::new(f), &c.truth)
                    .map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                eprintln!("export: {} truth rows to {}", c.truth.len(), p.display());
            }
            Ok(())
        }
        Cmd::Eval { log, solution, out } => {
            let c = logfile::load(&log).map_err(|e| bad(e.to_string()))?;
            if !c.report.is_clean() {
                eprintln!("warning: {}: {}", log.display(), c.report);
            }
            let rows = polarnav::solution_csv::read(&solution).map_err(|e| bad(e.to_string()))?;
            let ep = eval::epochs(&rows, &c.truth);
            if ep.is_empty() {
                return Err(bad(format!(
                    "{}: no solution row matches a truth epoch of {}",
                    solution.display(),
                    log.display()
                )));
            }
            let s = eval::summarize(&rows, &ep);
            let name = c
                .header
                .as_ref()
                .map_or("solution".to_owned(), |h| h.scenario.clone());
            let md = eval::markdown(&format!("Accuracy: {name}"), &s);
            println!("{md}");
            if let Some(dir) = out {
                std::fs::create_dir_all(&dir)
                    .map_err(|e| Fail(1, format!("{}: {e}", dir.display())))?;
                let p = dir.join("summary.md");
                let mut f =
                    File::create(&p).map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
                f.write_all(md.as_bytes())
                    .map_err(|e| Fail(1, format!("{}: {e}", p.display())))?;
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Fail(code, msg)) => {
            eprintln!("error: {msg}");
            ExitCode::from(code)
        }
    }
}
