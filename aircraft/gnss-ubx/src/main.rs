//! `gnss-ubx`: a u-blox receiver's UBX stream onto `<prefix>/gnss`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use clap::Parser;
use gnss_ubx::run::{Source, run};
use gnss_ubx::settings::Settings;
use polarnav_ipc::note;

#[derive(Debug, Parser)]
#[command(
    name = "gnss-ubx",
    version,
    about = "u-blox GNSS receiver driver: UBX NAV-PVT from a serial device (or a file) \
             published on <prefix>/gnss over iceoryx2",
    after_help = "Exit status: 0 stopped by SIGINT/SIGTERM or at the end of --file, 2 bad \
        settings or a device that cannot be opened at start (the message names the key), \
        1 other failure. A device lost later is reopened, never a reason to exit."
)]
struct Cli {
    /// Settings file (default: $PWD/config/gnss-ubx.toml, then /etc/polarnav/gnss-ubx.toml).
    #[arg(long)]
    config: Option<PathBuf>,
    /// iceoryx2 service prefix (overrides the settings).
    #[arg(long)]
    prefix: Option<String>,
    /// Serial device (overrides the settings' `device`).
    #[arg(long)]
    device: Option<String>,
    /// Read UBX from this file instead of the device, as fast as the
    /// subscribers take it, and stop at its end. The first fix waits for a
    /// subscriber of <prefix>/gnss (as long as it takes; Ctrl-C stops),
    /// then 0.5 s for the subscribers to connect: a replay nobody hears is
    /// no delivery. Fixes a subscriber missed, or that reached none, count
    /// in `lost`.
    #[arg(long, value_name = "UBX")]
    file: Option<PathBuf>,
    /// Check a settings file and exit (0 valid, 2 invalid).
    #[arg(long, value_name = "FILE")]
    check_config: Option<PathBuf>,
}

fn settings(cli: &Cli) -> Result<Settings, String> {
    let mut s = match &cli.config {
        Some(p) => Settings::load(p).map_err(|e| e.to_string())?,
        None => {
            let mut found = None;
            let mut candidates = Vec::new();
            if let Ok(cwd) = std::env::current_dir() {
                candidates.push(cwd.join("config/gnss-ubx.toml"));
            }
            candidates.push(PathBuf::from("/etc/polarnav/gnss-ubx.toml"));
            for p in &candidates {
                if p.exists() {
                    found = Some(Settings::load(p).map_err(|e| e.to_string())?);
                    break;
                }
            }
            found.unwrap_or_else(|| {
                tracing::warn!(
                    "no settings file ({}): running the built-in defaults",
                    candidates
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                Settings::default()
            })
        }
    };
    if let Some(p) = &cli.prefix {
        msgs::service::validate_prefix(p).map_err(|m| format!("--prefix: {m}"))?;
        s.prefix = p.clone();
    }
    if let Some(d) = &cli.device {
        if d.is_empty() {
            return Err("--device: expected a device path, got an empty one".into());
        }
        s.device = d.clone();
        s.origin = "--device".into();
    }
    Ok(s)
}

fn main() -> ExitCode {
    polarnav_ipc::logging::init("gnss-ubx");
    let cli = Cli::parse();
    if let Some(p) = &cli.check_config {
        return match Settings::load(p) {
            Ok(_) => {
                println!("{}: valid", p.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                note!("error: {e}");
                ExitCode::from(2)
            }
        };
    }
    let s = match settings(&cli) {
        Ok(s) => s,
        Err(m) => {
            note!("error: {m}");
            return ExitCode::from(2);
        }
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    if let Err(e) =
        ctrlc::set_handler(move || flag.store(true, std::sync::atomic::Ordering::Relaxed))
    {
        note!("error: cannot install the SIGINT/SIGTERM handler: {e}");
        return ExitCode::from(1);
    }
    tracing::info!(
        "gnss-ubx {} starting with {}:\n{}",
        env!("CARGO_PKG_VERSION"),
        s.origin,
        s.describe()
    );
    let source = match cli.file {
        Some(f) => Source::File(f),
        None => Source::Device,
    };
    let transport = polarnav_ipc::TransportConfig::new(&s.prefix);
    match run(&s, &source, &transport, &stop) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            note!("error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
