//! `nav-daemon`: the polarnav navigation service and its batch mode.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use polarnav::batch::{self, AidSet, BatchOptions, Conversion};
use polarnav::config::Config;

#[derive(Debug, Parser)]
#[command(
    name = "nav-daemon",
    version,
    about = "polarnav navigation daemon (SINS/SRS/CNS/baro, g/G frame switching)"
)]
struct Cli {
    /// Configuration file (default: $PWD/config/nav-daemon.toml, then /etc/polarnav/nav-daemon.toml).
    #[arg(long, global = true)]
    config: Option<PathBuf>,
    /// iceoryx2 service prefix (overrides the config).
    #[arg(long)]
    prefix: Option<String>,
    /// Check a configuration file and exit (0 valid, 2 invalid).
    #[arg(long, value_name = "FILE")]
    check_config: Option<PathBuf>,
    #[command(subcommand)]
    cmd: Option<Cmd>,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Run the navigator over a navlog as fast as possible and write the solution CSV.
    Batch {
        #[arg(long)]
        log: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// Filter parameter conversion at frame switches: paper or none.
        #[arg(long, default_value = "paper")]
        conversion: String,
        /// Forced frame-switch times in seconds, comma-separated (disables the latitude rule).
        #[arg(long, value_delimiter = ',')]
        force_switch: Option<Vec<f64>>,
        /// Stationary coarse alignment over this many seconds after the init record
        /// (its position is kept, its attitude replaced).
        #[arg(long, value_name = "SECONDS")]
        align: Option<f64>,
        /// Never switch frames: stay in g throughout (the reference run of the switching experiments).
        #[arg(long, conflicts_with = "force_switch")]
        no_switch: bool,
        /// Aids to fuse: a list of srs, cns, baro, or none.
        #[arg(long, default_value = "srs,cns,baro")]
        aids: String,
        /// Print a progress line every this many seconds of flight (0 = quiet).
        #[arg(long, default_value_t = 0.0)]
        progress: f64,
    },
}

fn find_config(explicit: Option<&PathBuf>) -> Result<Config, (String, i32)> {
    let candidates: Vec<PathBuf> = match explicit {
        Some(p) => vec![p.clone()],
        None => {
            let mut v = Vec::new();
            if let Ok(cwd) = std::env::current_dir() {
                v.push(cwd.join("config/nav-daemon.toml"));
            }
            v.push(PathBuf::from("/etc/polarnav/nav-daemon.toml"));
            v
        }
    };
    for p in &candidates {
        if explicit.is_some() || p.exists() {
            return Config::load(p).map_err(|e| (e.to_string(), 2));
        }
    }
    Ok(Config::default())
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    if let Some(path) = &cli.check_config {
        return match Config::load(path) {
            Ok(_) => {
                println!("{}: valid", path.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        };
    }
    let mut config = match find_config(cli.config.as_ref()) {
        Ok(c) => c,
        Err((msg, code)) => {
            eprintln!("error: {msg}");
            return ExitCode::from(code as u8);
        }
    };
    if let Some(p) = cli.prefix {
        config.prefix = p;
    }
    match cli.cmd {
        Some(Cmd::Batch {
            log,
            out,
            conversion,
            force_switch,
            aids,
            progress,
            no_switch,
            align,
        }) => {
            let usage = |m: String| {
                eprintln!("error: {m}");
                ExitCode::from(2)
            };
            let aids = match AidSet::parse(&aids) {
                Ok(a) => a,
                Err(m) => return usage(format!("--aids: {m}")),
            };
            let conversion = match conversion.as_str() {
                "paper" => Conversion::Paper,
                "none" => Conversion::None,
                other => {
                    return usage(format!(
                        "--conversion: expected paper or none, got {other:?}"
                    ));
                }
            };
            let opts = BatchOptions {
                aids,
                conversion,
                force_switch_s: if no_switch {
                    Some(Vec::new())
                } else {
                    force_switch
                },
                progress_every_s: progress,
                align_s: align,
            };
            let log_name = log.display().to_string();
            let input = match File::open(&log) {
                Ok(f) => BufReader::with_capacity(1 << 20, f),
                Err(e) => return usage(format!("{log_name}: cannot open: {e}")),
            };
            let output = match File::create(&out) {
                Ok(f) => BufWriter::with_capacity(1 << 20, f),
                Err(e) => {
                    eprintln!("error: {}: cannot create: {e}", out.display());
                    return ExitCode::from(1);
                }
            };
            let t0 = std::time::Instant::now();
            match batch::run(input, &log_name, output, &config, &opts) {
                Ok(r) => {
                    let wall = t0.elapsed().as_secs_f64();
                    let span = (r.last_t_ns.saturating_sub(r.first_t_ns)) as f64 * 1e-9;
                    eprintln!(
                        "batch: {} rows, {:.1} s of flight in {:.2} s ({:.0}x real time), {} frame switch(es), {} IMU rejected, {} IMU before init; aids: {} fused, {} rejected, {} not selected, {} SRS line exclusions; log: {}",
                        r.rows,
                        span,
                        wall,
                        span / wall.max(1e-9),
                        r.switches.len(),
                        r.imu_rejected,
                        r.imu_before_init,
                        r.aid_fused,
                        r.aid_rejected,
                        r.aid_records_unused,
                        r.srs_exclusions,
                        r.read
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(e.exit_code() as u8)
                }
            }
        }
        None => {
            let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            let flag = std::sync::Arc::clone(&stop);
            if let Err(e) =
                ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
            {
                eprintln!("error: cannot install the SIGINT/SIGTERM handler: {e}");
                return ExitCode::from(1);
            }
            let transport = polarnav::transport::TransportConfig::new(&config.prefix);
            let opts = polarnav::live::LiveOptions {
                imu_rate_hz: config.live.imu_rate_hz,
                imu_lost_periods: config.live.imu_lost_periods,
                checkpoint: polarnav::live::CheckpointOptions::from_config(&config.live),
                ..Default::default()
            };
            match polarnav::live::run(&config, &transport, &opts, &stop) {
                Ok(r) => {
                    tracing::info!(
                        cycles = r.cycles,
                        solutions = r.solutions,
                        reinits = r.reinits,
                        overruns = r.overruns,
                        overruns_cpu = r.overruns_cpu,
                        "nav-daemon: clean exit"
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(1)
                }
            }
        }
    }
}
