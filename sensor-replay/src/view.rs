//! `sensor-replay view`: the daemon's solution and health, live, in
//! Foxglove (the Foxglove WebSocket protocol, served by the Foxglove SDK).
//!
//! The view is only a subscriber of the daemon's outputs (`solution`,
//! `status`), whose services overwrite their oldest samples when a reader
//! falls behind: nothing the view does (a slow client, a stalled process)
//! can hold up the daemon. It does not subscribe to the inputs, whose
//! services make their publishers wait for every reader (a replay must not
//! be paced by a viewer); the aid health comes from status. The channels
//! are those of the MCAP files (`polarnav_foxglove`): the map
//! (`/solution/fix`, `foxglove.LocationFix` with its ENU covariance), the
//! pose, `/solution`, `/status`, `/aid/*` and `/events/switch`.
//!
//! Only channels that carry data are advertised: those of an output while
//! its publisher (the daemon) is up, the others from their first message.
//! Each channel is limited to `max_rate_hz` messages per second; above it
//! messages are dropped, not queued, and counted.
//!
//! Clients connect to a small gate in front of the SDK's server: it reads
//! the WebSocket upgrade request, and a client that offers none of the
//! subprotocols the server speaks (`foxglove.sdk.v1`, `foxglove.sdk.v1.1`),
//! such as one that offers only the older `foxglove.websocket.v1`, is
//! answered with HTTP 400 and a log line that names its address, what it
//! offered and what the server needs. Accepted clients are passed through
//! byte for byte to the SDK's server on the loopback interface.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use foxglove::{Context, WebSocketServer};
use msgs::service::Topic;
use msgs::{Solution, Status};
use polarnav_foxglove::{AidSource, Feed, FlightChannels};
use polarnav_ipc::{TopicSubscriber, TransportConfig, TransportError};

/// How often the view drains its subscriptions (the solution service holds
/// a second at the highest rate, so nothing is lost at this period).
const POLL: Duration = Duration::from_millis(10);

/// How often the view looks for the daemon's publishers.
const PUBLISHER_CHECK: Duration = Duration::from_millis(250);

/// The subprotocols the Foxglove SDK's server negotiates.
pub const SUBPROTOCOLS: [&str; 2] = ["foxglove.sdk.v1", "foxglove.sdk.v1.1"];

/// Longest upgrade request the gate reads (a request without its end
/// within this is refused).
const REQUEST_MAX: usize = 16 * 1024;

/// How long the gate waits for a client's upgrade request.
const REQUEST_TIMEOUT: Duration = Duration::from_secs(5);

/// Clients connected at once; more are refused (HTTP 503) with a log line.
pub const MAX_CLIENTS: usize = 32;

/// The default `--max-rate` (messages per second per channel).
pub const DEFAULT_MAX_RATE_HZ: f64 = 50.0;

/// Highest `--max-rate` accepted.
pub const MAX_RATE_LIMIT_HZ: f64 = 1e6;

/// What the view forwarded.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Viewed {
    pub solutions: u64,
    pub status: u64,
    /// Solutions the daemon published that the view did not get (its buffer
    /// overflowed: the view fell more than a second behind).
    pub solution_gaps: u64,
    /// Messages dropped by the rate limit, per topic.
    pub dropped: Vec<(&'static str, u64)>,
    /// Clients refused for their subprotocol, or because too many were connected.
    pub refused_clients: usize,
}

/// Errors of the view.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("Foxglove WebSocket server on {addr}: {source}")]
    Server {
        addr: String,
        source: foxglove::FoxgloveError,
    },
    #[error("Foxglove WebSocket server: cannot listen on {addr}: {source}")]
    Listen {
        addr: String,
        source: std::io::Error,
    },
}

/// Checks a `--max-rate` value: 0 (no limit) or a positive rate up to
/// [`MAX_RATE_LIMIT_HZ`].
pub fn check_max_rate(hz: f64) -> Result<Option<f64>, String> {
    if !hz.is_finite() || !(0.0..=MAX_RATE_LIMIT_HZ).contains(&hz) {
        return Err(format!(
            "expected messages per second per channel in [0, {MAX_RATE_LIMIT_HZ}] (0: no limit), got {hz}"
        ));
    }
    Ok((hz > 0.0).then_some(hz))
}

/// Serves the outputs of the daemon on `cfg`'s prefix at `host:port`
/// (port 0: any free port) until `stop` or `duration`, each channel limited
/// to `max_rate_hz` (`None`: no limit). `started` is told the port once the
/// server listens.
pub fn view(
    cfg: &TransportConfig,
    host: &str,
    port: u16,
    max_rate_hz: Option<f64>,
    stop: &AtomicBool,
    duration: Option<Duration>,
    started: impl FnOnce(u16),
) -> Result<Viewed, ViewError> {
    let node = polarnav_ipc::node(cfg, "sensor-replay-view")?;
    let sol = TopicSubscriber::<Solution>::new(&node, cfg, Topic::Solution)?;
    let st = TopicSubscriber::<Status>::new(&node, cfg, Topic::Status)?;
    let addr = format!("{host}:{port}");
    let public = TcpListener::bind(&addr).map_err(|source| ViewError::Listen {
        addr: addr.clone(),
        source,
    })?;
    let public_port = public.local_addr().map_or(port, |a| a.port());
    let ctx = Context::new();
    let server = WebSocketServer::new()
        .name(format!("polarnav {}", cfg.prefix))
        .bind("127.0.0.1", 0)
        .context(&ctx)
        .start_blocking()
        .map_err(|source| ViewError::Server {
            addr: addr.clone(),
            source,
        })?;
    let inner: SocketAddr = ([127, 0, 0, 1], server.port()).into();
    let gate_stop = Arc::new(AtomicBool::new(false));
    let refused = Arc::new(AtomicUsize::new(0));
    let gate = {
        let (gate_stop, refused) = (Arc::clone(&gate_stop), Arc::clone(&refused));
        std::thread::Builder::new()
            .name("view-gate".into())
            .spawn(move || serve_gate(&public, inner, &gate_stop, &refused))
            .map_err(|source| ViewError::Listen {
                addr: addr.clone(),
                source,
            })?
    };
    let mut channels = FlightChannels::new_live(&ctx, AidSource::Status, max_rate_hz);
    started(public_port);
    let begun = Instant::now();
    let mut n = Viewed::default();
    let mut next_seq: Option<u64> = None;
    let mut live = [(Feed::Solution, false), (Feed::Status, false)];
    let mut next_check = Instant::now();
    let result = (|| -> Result<(), ViewError> {
        while !stop.load(Ordering::Relaxed) && duration.is_none_or(|d| begun.elapsed() < d) {
            std::thread::sleep(POLL);
            sol.drain(|s| {
                if let Some(want) = next_seq
                    && s.seq > want
                {
                    n.solution_gaps += s.seq - want;
                }
                next_seq = Some(s.seq.wrapping_add(1));
                channels.solution(&s);
                n.solutions += 1;
            })?;
            st.drain(|s| {
                channels.status(&s);
                n.status += 1;
            })?;
            if Instant::now() >= next_check {
                next_check = Instant::now() + PUBLISHER_CHECK;
                for (feed, up) in &mut live {
                    let now_up = match feed {
                        Feed::Solution => sol.publishers(),
                        Feed::Status => st.publishers(),
                    } > 0;
                    if now_up && !*up {
                        channels.advertise(*feed);
                        tracing::info!("view: {feed:?} publisher up: its channels advertised");
                    } else if !now_up && *up {
                        channels.withdraw(*feed);
                        tracing::info!("view: {feed:?} publisher gone: its channels withdrawn");
                    }
                    *up = now_up;
                }
            }
        }
        Ok(())
    })();
    n.dropped = channels.dropped();
    drop(channels);
    gate_stop.store(true, Ordering::Relaxed);
    let _ = gate.join();
    n.refused_clients = refused.load(Ordering::Relaxed);
    server.stop().wait_blocking();
    result.map(|()| n)
}

/// Accepts clients on `public` until `stop`: each gets a thread that reads
/// its upgrade request and either refuses it or passes it through to `inner`.
fn serve_gate(
    public: &TcpListener,
    inner: SocketAddr,
    stop: &AtomicBool,
    refused: &Arc<AtomicUsize>,
) {
    if let Err(e) = public.set_nonblocking(true) {
        tracing::error!("view: cannot poll the listening socket: {e}; no client can connect");
        return;
    }
    let active = Arc::new(AtomicUsize::new(0));
    while !stop.load(Ordering::Relaxed) {
        match public.accept() {
            Ok((client, peer)) => {
                if active.load(Ordering::Relaxed) >= MAX_CLIENTS {
                    refused.fetch_add(1, Ordering::Relaxed);
                    tracing::warn!(
                        "view: refused client {peer}: {MAX_CLIENTS} clients are connected already"
                    );
                    refuse(client, "503 Service Unavailable", "too many clients\n");
                    continue;
                }
                active.fetch_add(1, Ordering::Relaxed);
                let (active, refused) = (Arc::clone(&active), Arc::clone(refused));
                // Detached: it ends with its connection (the server's end
                // closes when the view stops).
                let spawned = std::thread::Builder::new()
                    .name("view-client".into())
                    .spawn({
                        let active = Arc::clone(&active);
                        move || {
                            if !pass_client(client, peer, inner) {
                                refused.fetch_add(1, Ordering::Relaxed);
                            }
                            active.fetch_sub(1, Ordering::Relaxed);
                        }
                    });
                if let Err(e) = spawned {
                    active.fetch_sub(1, Ordering::Relaxed);
                    tracing::warn!("view: client {peer} dropped: no thread for it: {e}");
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                tracing::warn!("view: accept failed: {e}");
                std::thread::sleep(Duration::from_millis(100));
            }
        }
    }
}

/// The `Sec-WebSocket-Protocol` tokens of an HTTP request head, in order.
pub fn offered_subprotocols(head: &str) -> Vec<String> {
    head.lines()
        .skip(1)
        .filter_map(|l| l.split_once(':'))
        .filter(|(k, _)| k.trim().eq_ignore_ascii_case("sec-websocket-protocol"))
        .flat_map(|(_, v)| v.split(','))
        .map(|t| t.trim().to_owned())
        .filter(|t| !t.is_empty())
        .collect()
}

/// Reads the client's upgrade request; refuses a client that offers none of
/// [`SUBPROTOCOLS`] (false), else passes the connection through to `inner`
/// until either end closes it (true).
fn pass_client(mut client: TcpStream, peer: SocketAddr, inner: SocketAddr) -> bool {
    let _ = client.set_nonblocking(false);
    let _ = client.set_read_timeout(Some(REQUEST_TIMEOUT));
    let mut head = Vec::with_capacity(1024);
    let mut buf = [0u8; 2048];
    let end = loop {
        if let Some(i) = head.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
        if head.len() > REQUEST_MAX {
            tracing::warn!(
                "view: refused client {peer}: no end of its HTTP request in {REQUEST_MAX} bytes"
            );
            refuse(
                client,
                "431 Request Header Fields Too Large",
                "request too long\n",
            );
            return false;
        }
        match client.read(&mut buf) {
            Ok(0) => return true,
            Ok(k) => head.extend_from_slice(&buf[..k]),
            Err(e) => {
                tracing::info!("view: client {peer} sent no complete request: {e}");
                return true;
            }
        }
    };
    let text = String::from_utf8_lossy(&head[..end]);
    let offered = offered_subprotocols(&text);
    if !offered.iter().any(|o| SUBPROTOCOLS.contains(&o.as_str())) {
        let offered_text = if offered.is_empty() {
            "no subprotocol".to_owned()
        } else {
            format!("only {}", offered.join(", "))
        };
        let why = format!(
            "this server speaks the Foxglove WebSocket subprotocols {} (the Foxglove app, the Foxglove SDK clients); a client of the older foxglove.websocket.v1 protocol (e.g. npm @foxglove/ws-protocol 0.8) cannot connect",
            SUBPROTOCOLS.join(" and ")
        );
        tracing::warn!("view: refused client {peer}: it offered {offered_text}; {why}");
        refuse(
            client,
            "400 Bad Request",
            &format!("offered {offered_text}; {why}\n"),
        );
        return false;
    }
    let _ = client.set_read_timeout(None);
    let mut server = match TcpStream::connect(inner) {
        Ok(s) => s,
        Err(e) => {
            tracing::warn!("view: client {peer} dropped: the Foxglove server at {inner}: {e}");
            return true;
        }
    };
    if server.write_all(&head).is_err() {
        return true;
    }
    let _ = client.set_nodelay(true);
    let _ = server.set_nodelay(true);
    let (Ok(mut client_in), Ok(mut server_out)) = (client.try_clone(), server.try_clone()) else {
        return true;
    };
    let upstream = std::thread::Builder::new()
        .name("view-upstream".into())
        .spawn(move || {
            let _ = std::io::copy(&mut client_in, &mut server_out);
            let _ = server_out.shutdown(std::net::Shutdown::Write);
        });
    let _ = std::io::copy(&mut server, &mut client);
    let _ = client.shutdown(std::net::Shutdown::Both);
    let _ = server.shutdown(std::net::Shutdown::Both);
    if let Ok(h) = upstream {
        let _ = h.join();
    }
    true
}

/// Answers `status` with `body` and closes the connection.
fn refuse(mut client: TcpStream, status: &str, body: &str) {
    let _ = client.set_nonblocking(false);
    let _ = client.set_write_timeout(Some(REQUEST_TIMEOUT));
    let _ = write!(
        client,
        "HTTP/1.1 {status}\r\nContent-Type: text/plain; charset=utf-8\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let _ = client.shutdown(std::net::Shutdown::Both);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subprotocols_are_read_from_every_header_line_in_any_case() {
        let head = "GET / HTTP/1.1\r\nHost: x\r\nsec-websocket-protocol: foxglove.websocket.v1\r\nSec-WebSocket-Protocol: a , b\r\n\r\n";
        assert_eq!(
            offered_subprotocols(head),
            ["foxglove.websocket.v1", "a", "b"]
        );
        assert!(offered_subprotocols("GET / HTTP/1.1\r\nHost: x\r\n\r\n").is_empty());
    }

    #[test]
    fn max_rate_outside_its_range_is_refused() {
        assert_eq!(check_max_rate(50.0), Ok(Some(50.0)));
        assert_eq!(check_max_rate(0.0), Ok(None));
        for bad in [-1.0, f64::NAN, f64::INFINITY, 2e6] {
            let e = check_max_rate(bad).expect_err("absurd");
            assert!(e.contains("messages per second"), "{e}");
        }
    }
}
