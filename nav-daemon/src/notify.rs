//! systemd's notification protocol (`sd_notify(3)`), without ever blocking
//! the filter loop.
//!
//! The datagram socket named by `NOTIFY_SOCKET` is non-blocking: if systemd
//! (or whatever reads the socket) stops reading and its buffer fills, a
//! notification is dropped and counted instead of stalling the loop that
//! feeds the watchdog. A path starting with `@` is an abstract socket.
//! `WATCHDOG_USEC` (set by systemd from `WatchdogSec=`) gives the watchdog
//! period; the daemon pings at a quarter of it.

use std::io::ErrorKind;
use std::os::unix::net::{SocketAddr, UnixDatagram};
use std::time::{Duration, Instant};

/// Watchdog ping interval when `WATCHDOG_USEC` is not set (a manager that
/// reads the socket without configuring a watchdog still sees the loop live).
pub const DEFAULT_WATCHDOG_INTERVAL: Duration = Duration::from_millis(100);

/// Sends notifications to the service manager, if there is one.
#[derive(Debug)]
pub struct Notifier {
    target: Option<(UnixDatagram, SocketAddr)>,
    watchdog_interval: Duration,
    last_watchdog: Option<Instant>,
    dropped: u64,
    /// The last STATUS= sent, to skip repeating an unchanged one.
    last_status: String,
}

impl Notifier {
    /// From `NOTIFY_SOCKET` and `WATCHDOG_USEC` (`WATCHDOG_PID`, when set,
    /// must be this process). Without `NOTIFY_SOCKET` every call is a no-op.
    /// An unusable socket is reported once and then ignored: notifications
    /// must never stop the service.
    pub fn from_env() -> Self {
        let target = std::env::var_os("NOTIFY_SOCKET").and_then(|p| {
            let p = p.to_string_lossy().into_owned();
            match connect(&p) {
                Ok(t) => Some(t),
                Err(e) => {
                    tracing::warn!("NOTIFY_SOCKET={p}: unusable, not notifying: {e}");
                    None
                }
            }
        });
        let for_us = std::env::var("WATCHDOG_PID")
            .ok()
            .and_then(|p| p.parse::<u32>().ok())
            .is_none_or(|pid| pid == std::process::id());
        let watchdog_interval = std::env::var("WATCHDOG_USEC")
            .ok()
            .and_then(|u| u.parse::<u64>().ok())
            .filter(|&u| u > 0 && for_us)
            .map_or(DEFAULT_WATCHDOG_INTERVAL, |u| Duration::from_micros(u / 4));
        Self {
            target,
            watchdog_interval,
            last_watchdog: None,
            dropped: 0,
            last_status: String::new(),
        }
    }

    /// Whether a service manager listens.
    pub fn active(&self) -> bool {
        self.target.is_some()
    }

    pub fn watchdog_interval(&self) -> Duration {
        self.watchdog_interval
    }

    /// Notifications dropped because the socket was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// `READY=1` with the first `STATUS=`.
    pub fn ready(&mut self, status: &str) {
        self.last_status = status.to_owned();
        self.send(&format!("READY=1\nSTATUS={status}"));
    }

    /// `STATUS=` when it changed.
    pub fn status(&mut self, status: &str) {
        if status != self.last_status {
            self.last_status = status.to_owned();
            self.send(&format!("STATUS={status}"));
        }
    }

    /// `WATCHDOG=1` when the interval has passed since the last one. Call it
    /// from the filter loop only, so that a stalled loop trips the watchdog.
    pub fn watchdog(&mut self) {
        if self
            .last_watchdog
            .is_some_and(|t| t.elapsed() < self.watchdog_interval)
        {
            return;
        }
        self.last_watchdog = Some(Instant::now());
        self.send("WATCHDOG=1");
    }

    /// `STOPPING=1` with a last status.
    pub fn stopping(&mut self, status: &str) {
        self.send(&format!("STOPPING=1\nSTATUS={status}"));
    }

    fn send(&mut self, msg: &str) {
        let Some((sock, addr)) = &self.target else {
            return;
        };
        match sock.send_to_addr(msg.as_bytes(), addr) {
            Ok(_) => {}
            Err(e) if e.kind() == ErrorKind::WouldBlock => self.dropped += 1,
            Err(e) => {
                self.dropped += 1;
                if self.dropped.is_power_of_two() {
                    tracing::warn!(dropped = self.dropped, "systemd notification not sent: {e}");
                }
            }
        }
    }
}

fn connect(path: &str) -> std::io::Result<(UnixDatagram, SocketAddr)> {
    let addr = match path.strip_prefix('@') {
        Some(name) => {
            use std::os::linux::net::SocketAddrExt;
            SocketAddr::from_abstract_name(name.as_bytes())?
        }
        None => SocketAddr::from_pathname(path)?,
    };
    let sock = UnixDatagram::unbound()?;
    sock.set_nonblocking(true)?;
    Ok((sock, addr))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn notifier_to(path: &std::path::Path, interval: Duration) -> Notifier {
        let p = path.display().to_string();
        Notifier {
            target: Some(connect(&p).expect("connect")),
            watchdog_interval: interval,
            last_watchdog: None,
            dropped: 0,
            last_status: String::new(),
        }
    }

    #[test]
    fn a_full_socket_drops_and_counts_instead_of_blocking() {
        let dir = std::env::temp_dir().join(format!("pn-notify-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("full.sock");
        let _ = std::fs::remove_file(&path);
        // Bound but never read: its buffer fills after a few hundred datagrams.
        let _reader = UnixDatagram::bind(&path).expect("bind");
        let mut n = notifier_to(&path, Duration::ZERO);
        let t0 = Instant::now();
        for k in 0..100_000 {
            n.status(&format!("status {k}"));
        }
        let took = t0.elapsed();
        assert!(n.dropped() > 90_000, "dropped {}", n.dropped());
        // Blocking would never return; this bound only says "did not wait".
        assert!(took < Duration::from_secs(20), "{took:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn messages_arrive_in_the_protocol_format_and_unchanged_status_is_not_repeated() {
        let dir = std::env::temp_dir().join(format!("pn-notify2-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("n.sock");
        let _ = std::fs::remove_file(&path);
        let reader = UnixDatagram::bind(&path).expect("bind");
        reader.set_nonblocking(true).expect("nonblocking");
        let mut n = notifier_to(&path, Duration::from_secs(3600));
        n.ready("waiting for IMU");
        n.status("waiting for IMU");
        n.status("navigating");
        n.watchdog();
        n.watchdog(); // within the interval: not sent
        n.stopping("stopped");
        let mut got = Vec::new();
        let mut buf = [0u8; 512];
        while let Ok(k) = reader.recv(&mut buf) {
            got.push(String::from_utf8_lossy(&buf[..k]).into_owned());
        }
        assert_eq!(
            got,
            [
                "READY=1\nSTATUS=waiting for IMU",
                "STATUS=navigating",
                "WATCHDOG=1",
                "STOPPING=1\nSTATUS=stopped"
            ]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
