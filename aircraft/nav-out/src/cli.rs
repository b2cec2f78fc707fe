//! The command line both bridges share: `--config FILE`, `--prefix P`,
//! `--check-config FILE`; exit 0 on a clean stop (SIGINT, SIGTERM), 2 for
//! settings that cannot work (naming the file and key), 1 otherwise.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::bridge::{RunError, find_config};
use crate::settings::SettingsError;

/// The options of both binaries.
#[derive(Debug, clap::Args)]
pub struct Options {
    /// Settings file (default: $PWD/config/NAME.toml, then
    /// /etc/polarnav/NAME.toml, then the shipped settings built in).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// iceoryx2 service prefix (overrides the settings' `prefix`).
    #[arg(long)]
    pub prefix: Option<String>,
    /// Check a settings file and exit (0 valid, 2 invalid). Opening the
    /// output (a UDP port in use, a serial device) is checked at start.
    #[arg(long, value_name = "FILE")]
    pub check_config: Option<PathBuf>,
}

/// What a binary plugs into [`main`].
#[derive(Debug)]
pub struct Bridge<S, R> {
    pub name: &'static str,
    pub config_name: &'static str,
    pub load: fn(Option<&Path>, Option<&str>) -> Result<S, SettingsError>,
    pub describe: fn(&S) -> String,
    pub prefix: fn(&S) -> &str,
    pub run: fn(&S, &polarnav_ipc::TransportConfig, &AtomicBool) -> Result<R, RunError>,
}

/// Writes a line on stderr without panicking on a closed stderr.
fn note(line: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "{line}");
}

/// The whole process.
pub fn main<S, R: std::fmt::Debug>(b: &Bridge<S, R>, opts: Options) -> ExitCode {
    if let Some(path) = &opts.check_config {
        return match (b.load)(Some(path), opts.prefix.as_deref()) {
            Ok(_) => {
                println!("{}: valid", path.display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                note(&format!("error: {e}"));
                ExitCode::from(2)
            }
        };
    }
    let path = find_config(opts.config.as_deref(), b.config_name);
    if path.is_none() {
        tracing::warn!(
            "no {} in ./config or /etc/polarnav: running the shipped settings",
            b.config_name
        );
    }
    let settings = match (b.load)(path.as_deref(), opts.prefix.as_deref()) {
        Ok(s) => s,
        Err(e) => {
            note(&format!("error: {e}"));
            return ExitCode::from(2);
        }
    };
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)) {
        note(&format!(
            "error: cannot install the SIGINT/SIGTERM handler: {e}"
        ));
        return ExitCode::from(1);
    }
    tracing::info!("{} {} starting", b.name, env!("CARGO_PKG_VERSION"));
    tracing::info!("{}", (b.describe)(&settings));
    let transport = polarnav_ipc::TransportConfig::new((b.prefix)(&settings));
    match (b.run)(&settings, &transport, &stop) {
        Ok(summary) => {
            tracing::info!("{}: clean exit: {summary:?}", b.name);
            ExitCode::SUCCESS
        }
        Err(e) => {
            note(&format!("error: {e}"));
            ExitCode::from(e.exit_code())
        }
    }
}
