//! What both bridges' loops share: fixed-rate schedules, the wall clock of
//! a solution, systemd notifications, errors with their exit status, and
//! the command line's configuration lookup.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use polarnav_ipc::TransportError;

use crate::settings::SettingsError;

/// The longest the loop sleeps: the daemon's silence is noticed at most
/// this late after `silent_after_s`.
pub const MAX_SLEEP: Duration = Duration::from_millis(20);

/// A fixed-rate schedule on absolute deadlines, so the mean rate is exact
/// however late each wake-up is; after a stall longer than a period it
/// restarts from now instead of sending a burst.
#[derive(Debug, Clone, Copy)]
pub struct Every {
    period: Duration,
    next: Instant,
}

impl Every {
    /// First due at `start`.
    pub fn new(period: Duration, start: Instant) -> Self {
        Self {
            period,
            next: start,
        }
    }

    pub fn from_hz(hz: f64, start: Instant) -> Self {
        Self::new(Duration::from_secs_f64(1.0 / hz), start)
    }

    /// Whether due at `now` (then the next deadline is one period on).
    pub fn due(&mut self, now: Instant) -> bool {
        if now < self.next {
            return false;
        }
        self.next += self.period;
        if self.next <= now {
            self.next = now + self.period;
        }
        true
    }

    pub fn next(&self) -> Instant {
        self.next
    }
}

/// The wall-clock time (since the Unix epoch) of the monotonic instant
/// `at`, through the clock now: when a solution arrived.
pub fn unix_time_of(at: Instant, now: Instant) -> Duration {
    let wall = SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .unwrap_or_default();
    wall.saturating_sub(now.saturating_duration_since(at))
}

/// Why a bridge stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A setting that cannot work (exit 2): a port in use, a missing device.
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// iceoryx2 could not be set up or read (exit 1).
    #[error(transparent)]
    Transport(#[from] TransportError),
}

impl RunError {
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Settings(_) => 2,
            RunError::Transport(_) => 1,
        }
    }
}

/// systemd's notifications (`sd_notify(3)`); no-ops without a manager.
#[derive(Debug)]
pub struct Notify {
    watchdog: Option<Duration>,
    last_ping: Option<Instant>,
}

impl Notify {
    pub fn from_env() -> Self {
        let mut usec = 0u64;
        let watchdog =
            sd_notify::watchdog_enabled(false, &mut usec).then(|| Duration::from_micros(usec / 4));
        Self {
            watchdog,
            last_ping: None,
        }
    }

    /// READY=1 with a first STATUS=.
    pub fn ready(&self, status: &str) {
        let _ = sd_notify::notify(
            false,
            &[
                sd_notify::NotifyState::Ready,
                sd_notify::NotifyState::Status(status),
            ],
        );
    }

    pub fn status(&self, status: &str) {
        let _ = sd_notify::notify(false, &[sd_notify::NotifyState::Status(status)]);
    }

    /// WATCHDOG=1 every quarter of WatchdogSec, from the loop.
    pub fn ping(&mut self, now: Instant) {
        if let Some(p) = self.watchdog
            && self.last_ping.is_none_or(|t| now.duration_since(t) >= p)
        {
            self.last_ping = Some(now);
            let _ = sd_notify::notify(false, &[sd_notify::NotifyState::Watchdog]);
        }
    }

    pub fn stopping(&self) {
        let _ = sd_notify::notify(false, &[sd_notify::NotifyState::Stopping]);
    }
}

/// The settings file: `--config FILE`, else `$PWD/config/NAME`, else
/// `/etc/polarnav/NAME`; `None` when neither exists (the shipped settings
/// built into the binary are used then).
pub fn find_config(explicit: Option<&Path>, name: &str) -> Option<PathBuf> {
    if let Some(p) = explicit {
        return Some(p.to_path_buf());
    }
    let mut candidates = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        candidates.push(cwd.join("config").join(name));
    }
    candidates.push(Path::new("/etc/polarnav").join(name));
    candidates.into_iter().find(|p| p.exists())
}

/// Sleeps until the earliest deadline, at most [`MAX_SLEEP`].
pub fn sleep_until(deadlines: &[Instant], now: Instant) {
    let until = deadlines
        .iter()
        .copied()
        .min()
        .map_or(now + MAX_SLEEP, |d| d.min(now + MAX_SLEEP));
    if until > now {
        std::thread::sleep(until - now);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_keeps_its_mean_rate_through_late_wakeups() {
        let t0 = Instant::now();
        let mut e = Every::new(Duration::from_millis(100), t0);
        let mut n = 0;
        // Woken 30 ms late each time: still 10 per second.
        let mut t = t0;
        while t < t0 + Duration::from_secs(10) {
            if e.due(t) {
                n += 1;
            }
            t = e.next() + Duration::from_millis(30);
        }
        assert!((99..=101).contains(&n), "{n}");
        // A stall of 1 s gives one message, not ten.
        let mut e = Every::new(Duration::from_millis(100), t0);
        assert!(e.due(t0 + Duration::from_secs(1)));
        assert!(!e.due(t0 + Duration::from_millis(1050)));
    }
}
