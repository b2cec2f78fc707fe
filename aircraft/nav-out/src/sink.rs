//! Where the bridges' bytes go: UDP datagrams or a serial line.
//!
//! Opening happens at start and a failure there is a settings error (exit
//! 2 naming the key: a local port in use, a serial device that does not
//! exist or cannot be opened). Once running, nothing stops the bridge: a
//! failed datagram is counted; a serial device that goes away (a USB
//! adapter unplugged) is reported once, its output dropped and counted,
//! and it is reopened every [`REOPEN_EVERY`] until it is back, which is
//! reported too.

use std::io::Write;
use std::net::{SocketAddr, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::settings::{Checker, SettingsError, Transport};

/// How often a lost serial device is tried again.
pub const REOPEN_EVERY: Duration = Duration::from_secs(1);

/// How long a write to the serial line may block (a full UART buffer).
const SERIAL_TIMEOUT: Duration = Duration::from_millis(200);

/// An open output.
#[derive(Debug)]
pub struct Sink {
    kind: Kind,
    /// Messages (datagrams or writes) that did not go out.
    pub dropped: u64,
    /// Serial device losses and recoveries.
    pub reconnects: u64,
}

enum Kind {
    Udp {
        socket: UdpSocket,
        target: SocketAddr,
        /// The last failure logged, to log one a second at most.
        last_warn: Option<Instant>,
    },
    Serial {
        device: PathBuf,
        baud: u32,
        port: Option<Box<dyn serialport::SerialPort>>,
        next_try: Instant,
    },
}

impl std::fmt::Debug for Kind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Kind::Udp { socket, target, .. } => {
                write!(f, "udp {:?} -> {target}", socket.local_addr().ok())
            }
            Kind::Serial {
                device, baud, port, ..
            } => write!(
                f,
                "serial {} at {baud} ({})",
                device.display(),
                if port.is_some() { "open" } else { "lost" }
            ),
        }
    }
}

/// The UDP socket that systemd passed (socket activation: `LISTEN_FDS`,
/// `LISTEN_PID` this process), if any. The unit opens it in the host's
/// network namespace so that the service can run with `PrivateNetwork=yes`:
/// an inherited socket still reaches the host's network.
fn passed_udp_socket() -> Option<UdpSocket> {
    let mut fds = listenfd::ListenFd::from_env();
    (0..fds.len()).find_map(|i| fds.take_udp_socket(i).ok().flatten())
}

fn open_serial(device: &Path, baud: u32) -> serialport::Result<Box<dyn serialport::SerialPort>> {
    serialport::new(device.to_string_lossy(), baud)
        .timeout(SERIAL_TIMEOUT)
        .open()
}

impl Sink {
    /// Opens the transport; a failure names the key that chose it.
    pub fn open(t: &Transport, c: &Checker) -> Result<Self, SettingsError> {
        let kind = match t {
            Transport::Udp { bind, target } => {
                let socket = match passed_udp_socket() {
                    Some(s) => {
                        tracing::info!(
                            local = ?s.local_addr().ok(),
                            "sending from the UDP socket that systemd opened (output.udp_bind is not used)"
                        );
                        s
                    }
                    None => UdpSocket::bind(bind).map_err(|e| {
                        c.key_error("output.udp_bind", format!("cannot bind {bind}: {e}"))
                    })?,
                };
                // A broadcast target (a ground network's x.x.x.255) needs it;
                // harmless otherwise.
                let _ = socket.set_broadcast(true);
                Kind::Udp {
                    socket,
                    target: *target,
                    last_warn: None,
                }
            }
            Transport::Serial { device, baud } => {
                if !device.exists() {
                    return Err(c.key_error(
                        "output.serial_device",
                        format!("{}: no such device", device.display()),
                    ));
                }
                let port = open_serial(device, *baud).map_err(|e| {
                    c.key_error(
                        "output.serial_device",
                        format!("{}: cannot open at {baud} baud: {e}", device.display()),
                    )
                })?;
                Kind::Serial {
                    device: device.clone(),
                    baud: *baud,
                    port: Some(port),
                    next_try: Instant::now(),
                }
            }
        };
        Ok(Self {
            kind,
            dropped: 0,
            reconnects: 0,
        })
    }

    /// The local UDP address (for logs and tests).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        match &self.kind {
            Kind::Udp { socket, .. } => socket.local_addr().ok(),
            Kind::Serial { .. } => None,
        }
    }

    /// Whether the output can take bytes now (a lost serial device cannot).
    pub fn connected(&self) -> bool {
        match &self.kind {
            Kind::Udp { .. } => true,
            Kind::Serial { port, .. } => port.is_some(),
        }
    }

    /// Sends one message (one datagram; on a serial line, its bytes).
    pub fn send(&mut self, bytes: &[u8], now: Instant) {
        match &mut self.kind {
            Kind::Udp {
                socket,
                target,
                last_warn,
            } => {
                if let Err(e) = socket.send_to(bytes, *target) {
                    self.dropped += 1;
                    if last_warn.is_none_or(|t| now.duration_since(t) >= Duration::from_secs(1)) {
                        *last_warn = Some(now);
                        tracing::warn!(
                            target = %target,
                            dropped = self.dropped,
                            "cannot send to {target}: {e} ({} datagrams dropped so far)",
                            self.dropped
                        );
                    }
                }
            }
            Kind::Serial {
                device,
                baud,
                port,
                next_try,
            } => {
                if port.is_none() && now >= *next_try {
                    *next_try = now + REOPEN_EVERY;
                    if device.exists()
                        && let Ok(p) = open_serial(device, *baud)
                    {
                        self.reconnects += 1;
                        tracing::warn!(
                            device = %device.display(),
                            dropped = self.dropped,
                            "serial device {} is back: sending again ({} messages dropped while it was gone)",
                            device.display(),
                            self.dropped
                        );
                        *port = Some(p);
                    }
                }
                let Some(p) = port else {
                    self.dropped += 1;
                    return;
                };
                if let Err(e) = p.write_all(bytes).and_then(|()| p.flush()) {
                    self.dropped += 1;
                    tracing::error!(
                        device = %device.display(),
                        "serial device {} lost: {e}; trying to reopen it every {} s",
                        device.display(),
                        REOPEN_EVERY.as_secs()
                    );
                    *port = None;
                    *next_try = now + REOPEN_EVERY;
                }
            }
        }
    }
}
