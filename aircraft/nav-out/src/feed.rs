//! The daemon's outputs as the bridges hear them: the newest solution and
//! status from iceoryx2, each with the bridge's clock time of arrival, and
//! whether the solution service still has a publisher.

use std::time::Instant;

use msgs::service::Topic;
use msgs::{Solution, Status};
use polarnav_ipc::{TopicSubscriber, TransportConfig, TransportError};

use crate::health::Heard;

/// Subscribers of `<prefix>/solution` and `<prefix>/status`.
#[derive(Debug)]
pub struct Feed {
    // Field order is drop order: ports before their node.
    solution: TopicSubscriber<Solution>,
    status: TopicSubscriber<Status>,
    _node: iceoryx2::node::Node<iceoryx2::prelude::ipc::Service>,
    last_solution: Option<(Solution, Instant)>,
    last_status: Option<(Status, Instant)>,
    /// Solutions received, and those missed (sequence gaps: the
    /// subscriber's buffer overran while the bridge was not scheduled).
    pub received: u64,
    pub missed: u64,
}

impl Feed {
    /// Opens (or creates) both services under the prefix as node `role`.
    pub fn open(cfg: &TransportConfig, role: &str) -> Result<Self, TransportError> {
        let node = polarnav_ipc::node(cfg, role)?;
        let solution = TopicSubscriber::<Solution>::new(&node, cfg, Topic::Solution)?;
        let status = TopicSubscriber::<Status>::new(&node, cfg, Topic::Status)?;
        Ok(Self {
            solution,
            status,
            _node: node,
            last_solution: None,
            last_status: None,
            received: 0,
            missed: 0,
        })
    }

    /// Takes everything received since the last call, keeping the newest.
    pub fn poll(&mut self, now: Instant) -> Result<(), TransportError> {
        let mut newest: Option<Solution> = None;
        let prev_seq = self.last_solution.as_ref().map(|(s, _)| s.seq);
        let (mut received, mut missed) = (0u64, 0u64);
        let mut last_seq = prev_seq;
        self.solution.drain(|s| {
            received += 1;
            if let Some(p) = last_seq
                && s.seq > p + 1
            {
                missed += s.seq - p - 1;
            }
            last_seq = Some(s.seq);
            newest = Some(s);
        })?;
        self.received += received;
        self.missed += missed;
        if let Some(s) = newest {
            self.last_solution = Some((s, now));
        }
        let mut st = None;
        self.status.drain(|s| st = Some(s))?;
        if let Some(s) = st {
            self.last_status = Some((s, now));
        }
        self.solution.clear_events();
        self.status.clear_events();
        Ok(())
    }

    /// The newest solution, if any.
    pub fn solution(&self) -> Option<&Solution> {
        self.last_solution.as_ref().map(|(s, _)| s)
    }

    /// When the newest solution arrived.
    pub fn solution_at(&self) -> Option<Instant> {
        self.last_solution.as_ref().map(|(_, t)| *t)
    }

    /// What is heard at `now`, for [`crate::health::assess`].
    pub fn heard(&self, now: Instant) -> Heard<'_> {
        let age = |t: Instant| now.saturating_duration_since(t).as_secs_f64();
        Heard {
            solution: self.last_solution.as_ref().map(|(s, t)| (s, age(*t))),
            status_age_s: self.last_status.as_ref().map(|(_, t)| age(*t)),
            publisher_present: self.solution.publishers() > 0,
        }
    }
}
