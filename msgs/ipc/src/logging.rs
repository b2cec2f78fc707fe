//! Log output of the polarnav processes, the same for the daemon and
//! sensor-replay: journald's native protocol with structured fields when
//! stderr is connected to the journal (a systemd service), plain text on
//! stderr otherwise, coloured only when stderr is a terminal. `RUST_LOG`
//! selects the level (default `info`).

use std::io::IsTerminal;

use tracing_journald::{Priority, PriorityMappings};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

/// Writes one line to standard error, as `eprintln!` does, but a closed
/// standard error (`nav-daemon batch ... 2>&1 | head`, `sensor-replay
/// record ... 2>&1 | head`, a terminal gone) loses the line, not the run:
/// `eprintln!` panics when the write fails. For the lines the tools print
/// for their user (progress, a summary, a warning about a file) beside the
/// log, which already ignores a failed write.
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// Where the log lines go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogOutput {
    Journal,
    Terminal,
    Plain,
}

/// Whether stderr is the journal stream systemd connected (`JOURNAL_STREAM`
/// names its device and inode, as `sd_journal_stream_fd(3)` describes).
pub fn stderr_is_journal() -> bool {
    use std::os::unix::fs::MetadataExt;
    let Some(v) = std::env::var_os("JOURNAL_STREAM") else {
        return false;
    };
    let v = v.to_string_lossy();
    let Some((dev, ino)) = v.split_once(':') else {
        return false;
    };
    let (Ok(dev), Ok(ino)) = (dev.parse::<u64>(), ino.parse::<u64>()) else {
        return false;
    };
    std::fs::metadata("/proc/self/fd/2").is_ok_and(|m| m.dev() == dev && m.ino() == ino)
}

/// The journal priority of each tracing level: syslog's meaning, so that
/// `journalctl -p notice` (or `-p warning`) shows what needs attention and
/// not the routine INFO lines (the settings dump at start). tracing-journald's
/// default gives INFO priority 5, notice.
pub fn journal_priorities() -> PriorityMappings {
    PriorityMappings {
        error: Priority::Error,
        warn: Priority::Warning,
        info: Priority::Informational,
        debug: Priority::Debug,
        trace: Priority::Debug,
    }
}

/// Installs the process's log subscriber; `identifier` is the journal's
/// `SYSLOG_IDENTIFIER`. Returns where the lines go.
pub fn init(identifier: &str) -> LogOutput {
    let filter =
        || tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into());
    if stderr_is_journal() {
        match tracing_journald::layer() {
            Ok(layer) => {
                tracing_subscriber::registry()
                    .with(filter())
                    .with(
                        layer
                            .with_syslog_identifier(identifier.to_owned())
                            .with_priority_mappings(journal_priorities()),
                    )
                    .init();
                return LogOutput::Journal;
            }
            Err(e) => eprintln!("journald unreachable ({e}): logging plain text to stderr"),
        }
    }
    let terminal = std::io::stderr().is_terminal();
    tracing_subscriber::fmt()
        .with_env_filter(filter())
        .with_ansi(terminal)
        .with_writer(std::io::stderr)
        // A closed stderr (`... 2>&1 | head`): the subscriber would report
        // the failed write with `eprintln!`, which panics on that same
        // closed stderr and ends the run. The line is lost, not the run.
        .log_internal_errors(false)
        .init();
    if terminal {
        LogOutput::Terminal
    } else {
        LogOutput::Plain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn info_goes_to_the_journal_as_informational_not_notice() {
        let m = journal_priorities();
        // syslog numbers, as `journalctl -p` takes them.
        let n = |p: Priority| p as u8 - b'0';
        assert_eq!(n(m.error), 3);
        assert_eq!(n(m.warn), 4);
        assert_eq!(n(m.info), 6, "INFO must not pass `journalctl -p notice`");
        assert_eq!(n(m.debug), 7);
        assert_eq!(n(m.trace), 7);
    }
}
