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

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use foxglove::{Context, WebSocketServer};
use msgs::service::Topic;
use msgs::{Solution, Status};
use polarnav_foxglove::{AidSource, FlightChannels};
use polarnav_ipc::{TopicSubscriber, TransportConfig, TransportError};

/// How often the view drains its subscriptions (the solution service holds
/// a second at the highest rate, so nothing is lost at this period).
const POLL: Duration = Duration::from_millis(10);

/// What the view forwarded.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Viewed {
    pub solutions: u64,
    pub status: u64,
    /// Solutions the daemon published that the view did not get (its buffer
    /// overflowed: the view fell more than a second behind).
    pub solution_gaps: u64,
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
}

/// Serves the outputs of the daemon on `cfg`'s prefix at `host:port`
/// (port 0: any free port) until `stop` or `duration`. `started` is told
/// the port once the server listens.
pub fn view(
    cfg: &TransportConfig,
    host: &str,
    port: u16,
    stop: &AtomicBool,
    duration: Option<Duration>,
    started: impl FnOnce(u16),
) -> Result<Viewed, ViewError> {
    let node = polarnav_ipc::node(cfg, "sensor-replay-view")?;
    let sol = TopicSubscriber::<Solution>::new(&node, cfg, Topic::Solution)?;
    let st = TopicSubscriber::<Status>::new(&node, cfg, Topic::Status)?;
    let ctx = Context::new();
    let server = WebSocketServer::new()
        .name(format!("polarnav {}", cfg.prefix))
        .bind(host, port)
        .context(&ctx)
        .start_blocking()
        .map_err(|source| ViewError::Server {
            addr: format!("{host}:{port}"),
            source,
        })?;
    let mut channels = FlightChannels::new(&ctx, AidSource::Status);
    started(server.port());
    let begun = Instant::now();
    let mut n = Viewed::default();
    let mut next_seq: Option<u64> = None;
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
    }
    drop(channels);
    server.stop().wait_blocking();
    Ok(n)
}
