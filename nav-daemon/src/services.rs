//! The live daemon's services, each opened on its own (issue 43, item 4).
//!
//! A service another process created first with another payload type or
//! other options (a squatter), or that iceoryx2 refuses for another reason,
//! leaves every other service served: it is reported once in the log and
//! in every status ([`msgs::Status::unavailable`]), retried from the loop
//! at most once per [`RETRY_PERIOD`], and served from the attempt that
//! opens it (a squatter gone, its service is created anew).
//!
//! Once every service is open a retry is a flag test and returns: nothing
//! waits, allocates or logs. An attempt on an unavailable service does
//! what opening it does (iceoryx2 allocates its names and, refused, the
//! error's text) once per period, never in steady state.

use std::cell::{Cell, OnceCell};
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use msgs::unavailable;
use polarnav_ipc::{TransportConfig, TransportError};

/// Least time between two attempts to open a service that could not be opened.
pub const RETRY_PERIOD: Duration = Duration::from_secs(1);

/// Opens a port of a service (a subscriber or a publisher).
pub type Opener<P> =
    Box<dyn Fn(&Node<ipc::Service>, &TransportConfig) -> Result<P, TransportError>>;

/// A port of one service: open, or unavailable and retried.
pub struct Service<P> {
    port: OnceCell<P>,
    name: String,
    bit: u32,
    open: Opener<P>,
    /// The last attempt found the service with another payload type or options.
    incompatible: Cell<bool>,
    next_try: Cell<Instant>,
    tries: Cell<u64>,
}

impl<P> std::fmt::Debug for Service<P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Service")
            .field("name", &self.name)
            .field("open", &self.port.get().is_some())
            .field("tries", &self.tries.get())
            .finish()
    }
}

/// Whether iceoryx2 refused a service because it exists with another
/// payload type, other options or another messaging pattern.
pub fn is_incompatible(e: &TransportError) -> bool {
    matches!(e, TransportError::Iceoryx { detail, .. } if detail.contains("Incompatible"))
}

impl<P> Service<P> {
    /// Opens the service `name` (bit `bit` of [`msgs::Status::unavailable`]);
    /// if it cannot be opened, says so once and leaves it to [`Self::retry`].
    pub fn open(
        node: &Node<ipc::Service>,
        cfg: &TransportConfig,
        name: String,
        bit: u32,
        open: Opener<P>,
    ) -> Self {
        let s = Self {
            port: OnceCell::new(),
            name,
            bit,
            open,
            incompatible: Cell::new(false),
            next_try: Cell::new(Instant::now()),
            tries: Cell::new(0),
        };
        s.attempt(node, cfg, Instant::now());
        s
    }

    /// The port, once the service is open.
    pub fn get(&self) -> Option<&P> {
        self.port.get()
    }

    /// The service's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Opens the service if it is unavailable and [`RETRY_PERIOD`] has
    /// passed since the last attempt; true when it opened now.
    pub fn retry(&self, node: &Node<ipc::Service>, cfg: &TransportConfig, now: Instant) -> bool {
        if self.port.get().is_some() || now < self.next_try.get() {
            return false;
        }
        self.attempt(node, cfg, now)
    }

    fn attempt(&self, node: &Node<ipc::Service>, cfg: &TransportConfig, now: Instant) -> bool {
        self.next_try.set(now + RETRY_PERIOD);
        let tries = self.tries.get() + 1;
        self.tries.set(tries);
        match (self.open)(node, cfg) {
            Ok(p) => {
                if tries > 1 {
                    tracing::info!(
                        service = %self.name,
                        tries,
                        "service available: opened, served from now on"
                    );
                }
                self.incompatible.set(false);
                let _ = self.port.set(p);
                true
            }
            Err(e) => {
                self.incompatible.set(is_incompatible(&e));
                if tries == 1 {
                    tracing::error!(
                        service = %self.name,
                        "service unavailable: {e}; every other service is served, this one is \
                         retried every {} s and served once it opens",
                        RETRY_PERIOD.as_secs_f64()
                    );
                }
                false
            }
        }
    }

    /// Its bits of [`msgs::Status::unavailable`] (0 when open).
    pub fn unavailable(&self) -> u32 {
        match self.port.get() {
            Some(_) => 0,
            None if self.incompatible.get() => {
                self.bit | (self.bit << unavailable::INCOMPATIBLE_SHIFT)
            }
            None => self.bit,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::service::Topic;
    use msgs::{GnssFix, ImuSample};
    use polarnav_ipc::{IsolatedCleanup, TopicPublisher, TopicSubscriber};

    /// A service squatted with another payload type is unavailable and
    /// flagged so; it is retried at most once per period, without a log
    /// line each time, and opens once the squatter is gone.
    #[test]
    fn a_squatted_service_is_retried_at_a_bounded_rate_and_opens_once_freed() {
        let cfg = TransportConfig::isolated("squatunit");
        let _cleanup = IsolatedCleanup(cfg.clone());
        let squatter_node = polarnav_ipc::node(&cfg, "squatter").expect("node");
        let squatter =
            TopicPublisher::<GnssFix>::new(&squatter_node, &cfg, Topic::Imu).expect("squatter");
        let node = polarnav_ipc::node(&cfg, "daemon").expect("node");
        let attempts = std::rc::Rc::new(Cell::new(0u32));
        let counted = std::rc::Rc::clone(&attempts);
        let imu = Service::<TopicSubscriber<ImuSample>>::open(
            &node,
            &cfg,
            Topic::Imu.service_name(&cfg.prefix),
            unavailable::stream(msgs::Stream::Imu),
            Box::new(move |n, c| {
                counted.set(counted.get() + 1);
                TopicSubscriber::new(n, c, Topic::Imu)
            }),
        );
        assert!(imu.get().is_none());
        assert_eq!(
            imu.unavailable(),
            1 | (1 << unavailable::INCOMPATIBLE_SHIFT)
        );
        let t0 = Instant::now();
        for _ in 0..100 {
            assert!(!imu.retry(&node, &cfg, Instant::now()));
        }
        assert_eq!(attempts.get(), 1, "retried before the period");
        drop(squatter);
        drop(squatter_node);
        assert!(!imu.retry(&node, &cfg, t0 + RETRY_PERIOD / 2));
        assert!(imu.retry(&node, &cfg, t0 + RETRY_PERIOD));
        assert_eq!(attempts.get(), 2);
        assert!(imu.get().is_some());
        assert_eq!(imu.unavailable(), 0);
        assert!(!imu.retry(&node, &cfg, t0 + 10 * RETRY_PERIOD));
        assert_eq!(attempts.get(), 2, "an open service is not opened again");
    }
}
