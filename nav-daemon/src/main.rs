//! `nav-daemon`: the polarnav navigation service and its batch mode.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use nav_daemon::batch::{self, BatchOptions};
use polarnav::row_interval::RowInterval;
use polarnav_config::provenance::{UtcStart, provenance};
use polarnav_config::{
    AidSet, CliOverrides, ConfigFile, Conversion, SensorGrade, build_info, effective,
};

#[derive(Debug, Parser)]
#[command(
    name = "nav-daemon",
    version = build_info::LONG_VERSION,
    about = "polarnav navigation daemon (SINS/SRS/CNS/baro, g/G frame switching)",
    after_help = "Without a subcommand, nav-daemon runs the live navigation service: it \
        reads its inputs from and publishes its solution over iceoryx2 under the \
        configuration's prefix until SIGINT or SIGTERM (the systemd unit starts it so)."
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

// Parsed once per process: the size of the `batch` variant costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Cmd {
    /// Run the navigator over a navlog as fast as possible and write the solution
    /// (CSV, or MCAP for Foxglove and PlotJuggler when the name ends in .mcap).
    Batch {
        /// The navlog to navigate (simulated, imported or recorded).
        #[arg(long)]
        log: PathBuf,
        /// Solution file: `.csv` (default format) or `.mcap` (every input stream,
        /// solution, status, aid updates, frame switches and truth).
        #[arg(long)]
        out: PathBuf,
        /// Filter parameter conversion at frame switches: paper or none
        /// (default: the configuration's `[frame] conversion`, paper).
        #[arg(long)]
        conversion: Option<String>,
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
        /// Aids to fuse: a comma-separated list of aid names, or none
        /// (default: the configuration's `[aids] fuse`, all of them).
        #[arg(long, long_help = aids_help())]
        aids: Option<String>,
        /// Print a progress line every this many seconds of flight (0 = quiet).
        #[arg(long, default_value_t = 0.0)]
        progress: f64,
        /// Write one solution row per this many seconds of sensor time (on
        /// whole multiples of it), plus the first and last rows and those at
        /// frame switches, resets and re-initializations. The filter still
        /// runs at the IMU rate and a written row is the full-rate run's row.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        every: Option<f64>,
        /// IMU noise model of a sensor grade: navigation, tactical or mems
        /// (over the configuration's and the log header's `[filter]` noise keys).
        #[arg(long)]
        preset: Option<String>,
        /// Write the fixed-interval smoothed solution (Rauch–Tung–Striebel over
        /// the forward run, through frame switches; breaks at resets) in the
        /// forward solution's columns. Its record of the forward run is kept in
        /// memory up to 384 MiB (about 1.7 h at 200 Hz), beyond that in an
        /// unnamed temporary file in the output's directory (about 0.23 GB per
        /// flight hour at 200 Hz); memory stays under 1 GB whatever the length.
        #[arg(long)]
        smooth: bool,
        /// UTC time of the log's sensor time 0 (RFC 3339, e.g.
        /// 2026-11-25T09:30:00Z): MCAP log times become dates (sensor time
        /// plus this epoch) instead of 1970-01-01. MCAP output only.
        #[arg(long, value_name = "RFC3339")]
        utc_start: Option<String>,
    },
    /// Print the shell completion script (e.g. `nav-daemon completions bash >
    /// /usr/share/bash-completion/completions/nav-daemon`).
    Completions {
        /// The shell to complete in.
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual page (roff; `nav-daemon man > nav-daemon.1`).
    Man,
}

/// Writes the completion script of `shell` for nav-daemon.
fn completions(shell: clap_complete::Shell, out: &mut dyn std::io::Write) {
    use clap::CommandFactory;
    clap_complete::generate(shell, &mut Cli::command(), "nav-daemon", out);
}

/// Writes nav-daemon's manual page (roff).
fn man(out: &mut dyn std::io::Write) -> std::io::Result<()> {
    use clap::CommandFactory;
    clap_mangen::Man::new(Cli::command()).render(out)
}

fn find_config(explicit: Option<&PathBuf>) -> Result<ConfigFile, (String, i32)> {
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
            return ConfigFile::load(p).map_err(|e| (e.to_string(), 2));
        }
    }
    tracing::warn!(
        "no configuration file ({}): running the built-in defaults",
        candidates
            .iter()
            .map(|p| format!("{} not found", p.display()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(ConfigFile::defaults())
}

/// The `--aids` help, naming the declared aids.
fn aids_help() -> String {
    format!(
        "Aids to fuse: a comma-separated list of {}, or none (default: the configuration's \
         `[aids] fuse`, all of them)",
        msgs::AidKind::names()
    )
}

fn main() -> ExitCode {
    polarnav_ipc::logging::init("nav-daemon");
    let cli = Cli::parse();
    // Neither needs a configuration.
    match &cli.cmd {
        Some(Cmd::Completions { shell }) => {
            completions(*shell, &mut std::io::stdout());
            return ExitCode::SUCCESS;
        }
        Some(Cmd::Man) => {
            // `nav-daemon man | head`: a reader that stopped is not an error.
            return match man(&mut std::io::stdout()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
                Err(e) => {
                    nav_daemon::note!("error: man: {e}");
                    ExitCode::from(1)
                }
            };
        }
        _ => {}
    }
    if let Some(path) = &cli.check_config {
        // Exactly the validation the daemon runs at start.
        let cli_overrides = CliOverrides {
            prefix: cli.prefix.clone(),
            ..Default::default()
        };
        let checked = ConfigFile::load(path).and_then(|f| effective(&f, None, &cli_overrides));
        return match checked {
            Ok(_) => {
                println!("{}: valid", path.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                nav_daemon::note!("error: {e}");
                ExitCode::from(2)
            }
        };
    }
    let config = match find_config(cli.config.as_ref()) {
        Ok(c) => c,
        Err((msg, code)) => {
            nav_daemon::note!("error: {msg}");
            return ExitCode::from(code as u8);
        }
    };
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
            preset,
            every,
            smooth,
            utc_start,
        }) => {
            let usage = |m: String| {
                nav_daemon::note!("error: {m}");
                ExitCode::from(2)
            };
            let fuse = match aids.as_deref().map(AidSet::parse).transpose() {
                Ok(a) => a,
                Err(m) => return usage(format!("--aids: {m}")),
            };
            let preset = match preset.as_deref().map(SensorGrade::parse).transpose() {
                Ok(g) => g,
                Err(m) => return usage(format!("--preset: {m}")),
            };
            let every = match every.map(RowInterval::new).transpose() {
                Ok(e) => e,
                Err(e) => return usage(format!("--every: {e}")),
            };
            let utc_start = match utc_start.as_deref().map(UtcStart::parse).transpose() {
                Ok(u) => u,
                Err(m) => return usage(format!("--utc-start: {m}")),
            };
            let conversion = match conversion.as_deref() {
                None => None,
                Some("paper") => Some(Conversion::Paper),
                Some("none") => Some(Conversion::None),
                Some(other) => {
                    return usage(format!(
                        "--conversion: expected paper or none, got {other:?}"
                    ));
                }
            };
            let opts = BatchOptions {
                cli: CliOverrides {
                    conversion,
                    fuse,
                    force_switch_s: if no_switch {
                        Some(Vec::new())
                    } else {
                        force_switch
                    },
                    align_s: align,
                    prefix: None,
                    preset,
                },
                progress_every_s: progress,
                every,
                smooth: smooth.then(|| match out.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                    _ => PathBuf::from("."),
                }),
            };
            let log_name = log.display().to_string();
            let input = match File::open(&log) {
                Ok(f) => BufReader::with_capacity(1 << 20, f),
                Err(e) => return usage(format!("{log_name}: cannot open: {e}")),
            };
            // An output directory that does not exist is bad usage (exit 2, as
            // DESIGN's CLI section says), not a failure of the run.
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
                && !dir.is_dir()
            {
                return usage(format!(
                    "--out {}: cannot create: directory {} does not exist",
                    out.display(),
                    dir.display()
                ));
            }
            // The format by the extension: `.mcap` writes MCAP, anything else the CSV.
            let is_mcap = out
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
            if utc_start.is_some() && !is_mcap {
                return usage(format!(
                    "--utc-start: only an MCAP output has log times (the CSV's t_s is sensor time); --out {} is not .mcap",
                    out.display()
                ));
            }
            let output = if is_mcap {
                let created = polarnav_foxglove::McapFile::create(
                    &out,
                    polarnav_foxglove::AidSource::Updates,
                )
                .and_then(|mut m| {
                    if let Some(u) = &utc_start {
                        m.channels().set_epoch_ns(u.ns);
                    }
                    let args: Vec<String> = std::env::args().collect();
                    m.metadata(
                        "polarnav.provenance",
                        provenance("nav-daemon batch", &args, utc_start.as_ref()),
                    )?;
                    Ok(m)
                });
                match created {
                    Ok(m) => batch::Output::Mcap(Box::new(m)),
                    Err(e) => {
                        nav_daemon::note!("error: {e}");
                        return ExitCode::from(1);
                    }
                }
            } else {
                match File::create(&out) {
                    Ok(f) => batch::Output::Csv(BufWriter::with_capacity(1 << 20, f)),
                    Err(e) => {
                        nav_daemon::note!("error: {}: cannot create: {e}", out.display());
                        return ExitCode::from(1);
                    }
                }
            };
            let t0 = std::time::Instant::now();
            match batch::run_to(input, &log_name, output, &config, &opts) {
                Ok(r) => {
                    let wall = t0.elapsed().as_secs_f64();
                    let span = (r.last_t_ns.saturating_sub(r.first_t_ns)) as f64 * 1e-9;
                    let s = &r.status;
                    let (fused, rejected) = r.aid_totals();
                    let not_used: u64 = s.each_aid().map(|(_, c, _)| c.not_used).sum();
                    let exclusions: u64 = s.each_aid().map(|(_, _, a)| a.exclusions).sum();
                    nav_daemon::note!(
                        "batch: {} rows, {:.1} s of flight in {:.2} s ({:.0}x real time), {} frame switch(es), {} IMU rejected, {} IMU not used, {} time resync(s), {} covariance repair(s); aids: {} fused, {} rejected, {} not used, {} excluded by fault detection (SRS lines); inits: {} used, {} rejected, {} not used; log: {}",
                        r.rows,
                        span,
                        wall,
                        span / wall.max(1e-9),
                        r.switches.len(),
                        s.imu().rejected_invalid + s.imu().rejected_time,
                        s.imu().not_used,
                        r.time_resyncs,
                        r.covariance_repairs,
                        fused,
                        rejected,
                        not_used,
                        exclusions,
                        r.inits.used,
                        r.inits.rejected,
                        r.inits.not_used,
                        r.read
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    nav_daemon::note!("error: {e}");
                    ExitCode::from(e.exit_code() as u8)
                }
            }
        }
        Some(Cmd::Completions { .. } | Cmd::Man) => ExitCode::SUCCESS,
        None => {
            let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
            let flag = std::sync::Arc::clone(&stop);
            if let Err(e) =
                ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
            {
                nav_daemon::note!("error: cannot install the SIGINT/SIGTERM handler: {e}");
                return ExitCode::from(1);
            }
            let cli_overrides = CliOverrides {
                prefix: cli.prefix,
                ..Default::default()
            };
            let settings = match effective(&config, None, &cli_overrides) {
                Ok(s) => s,
                Err(e) => {
                    nav_daemon::note!("error: {e}");
                    return ExitCode::from(2);
                }
            };
            tracing::info!(
                version = build_info::VERSION,
                commit = build_info::COMMIT,
                config = %config.origin,
                prefix = %settings.config.prefix,
                "nav-daemon {} starting with {}",
                build_info::LONG_VERSION,
                config.origin
            );
            tracing::info!("effective settings:\n{}", settings.describe());
            let config = &settings.config;
            let transport = polarnav_ipc::TransportConfig::new(&config.prefix);
            let opts = nav_daemon::live::LiveOptions {
                imu_rate_hz: config.live.imu_rate_hz,
                imu_lost_periods: config.live.imu_lost_periods,
                checkpoint: nav_daemon::live::CheckpointOptions::from_config(&config.live),
                ..Default::default()
            };
            match nav_daemon::live::run(&settings, &transport, &opts, &stop) {
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
                    nav_daemon::note!("error: {e}");
                    ExitCode::from(e.exit_code())
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// The arguments (path of subcommands, then id) and subcommands without help text.
    fn undocumented(cmd: &clap::Command, path: &str, out: &mut Vec<String>) {
        for a in cmd.get_arguments() {
            if a.get_help().is_none() && a.get_long_help().is_none() {
                out.push(format!("{path} {}", a.get_id()));
            }
        }
        for s in cmd.get_subcommands() {
            let sub = format!("{path} {}", s.get_name());
            if s.get_about().is_none() && s.get_long_about().is_none() {
                out.push(sub.clone());
            }
            undocumented(s, &sub, out);
        }
    }

    #[test]
    fn help_says_that_no_subcommand_runs_the_live_service() {
        let mut cmd = Cli::command();
        for help in [cmd.render_help(), cmd.render_long_help()] {
            let text = help.to_string();
            assert!(
                text.contains("Without a subcommand, nav-daemon runs the live navigation service"),
                "{text}"
            );
        }
    }

    #[test]
    fn bash_completion_knows_the_subcommands_and_options() {
        let mut out = Vec::new();
        completions(clap_complete::Shell::Bash, &mut out);
        let text = String::from_utf8(out).expect("utf8");
        for word in [
            "nav-daemon",
            "batch",
            "completions",
            "man",
            "--log",
            "--check-config",
        ] {
            assert!(text.contains(word), "{word} missing");
        }
    }

    #[test]
    fn man_page_is_roff_naming_the_program() {
        let mut out = Vec::new();
        man(&mut out).expect("render");
        let text = String::from_utf8(out).expect("utf8");
        assert!(text.starts_with('.'), "{text}");
        assert!(
            text.lines().any(|l| l.starts_with(".TH nav-daemon 1")),
            "{text}"
        );
        assert!(text.contains("batch"), "{text}");
    }

    #[test]
    fn version_names_the_commit() {
        let v = Cli::command().render_version();
        assert!(
            v.starts_with(&format!("nav-daemon {} (commit ", build_info::VERSION)),
            "{v}"
        );
        assert!(v.contains(build_info::COMMIT), "{v}");
    }

    #[test]
    fn every_argument_and_subcommand_has_help_text() {
        let mut missing = Vec::new();
        undocumented(&Cli::command(), "nav-daemon", &mut missing);
        assert!(missing.is_empty(), "no help text for {missing:?}");
    }
}
