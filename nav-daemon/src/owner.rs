//! Who may publish on an input service: the first publisher to send owns it
//! until it disconnects or its process dies; other publishers' samples are
//! refused and counted (never received by the session).

use std::time::{Duration, Instant};

use crate::events::RateLimit;

/// Who may publish on one input service: the first publisher to send owns
/// it until it disconnects or its process dies (a driver restarted after a
/// crash takes over); samples of any other publisher meanwhile are refused
/// and counted, never received.
#[derive(Debug, Default)]
pub struct Owner {
    id: Option<u128>,
    pub refused: u64,
    pub refused_at_status: u64,
    /// When the owner was last found still connected (a flood of refused
    /// samples checks at most every OWNER_CHECK_PERIOD).
    confirmed: Option<Instant>,
    log: RateLimit,
}

pub const OWNER_CHECK_PERIOD: Duration = Duration::from_millis(20);

impl Owner {
    /// Whether a sample of `origin` is taken; `connected(id)` says whether
    /// publisher `id` is still there.
    pub fn admit(
        &mut self,
        stream: &str,
        origin: u128,
        connected: impl FnOnce(u128) -> bool,
    ) -> bool {
        let Some(owner) = self.id else {
            self.id = Some(origin);
            return true;
        };
        if owner == origin {
            return true;
        }
        let recent = self
            .confirmed
            .is_some_and(|t| t.elapsed() < OWNER_CHECK_PERIOD);
        if !recent {
            if connected(owner) {
                self.confirmed = Some(Instant::now());
            } else {
                tracing::info!(
                    stream,
                    "{stream} publisher {owner:032x} gone: publisher {origin:032x} takes over"
                );
                self.id = Some(origin);
                self.confirmed = None;
                return true;
            }
        }
        self.refused += 1;
        if let Some(suppressed) = self.log.due() {
            tracing::warn!(
                stream,
                suppressed,
                "{stream}: sample of a second publisher {origin:032x} refused (publisher {owner:032x} owns the service)"
            );
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    #[test]
    fn first_publisher_owns_others_are_refused_and_counted_until_it_is_gone() {
        let mut o = Owner::default();
        let asked = Cell::new(0);
        let alive = Cell::new(true);
        let connected = |_: u128| {
            asked.set(asked.get() + 1);
            alive.get()
        };
        assert!(o.admit("IMU", 1, connected));
        assert!(o.admit("IMU", 1, connected));
        assert_eq!(asked.get(), 0, "the owner's own samples need no check");
        // A second publisher while the owner lives: refused, counted; a
        // flood is checked once per OWNER_CHECK_PERIOD, not per sample.
        for _ in 0..1000 {
            assert!(!o.admit("IMU", 2, connected));
        }
        assert_eq!(o.refused, 1000);
        assert_eq!(asked.get(), 1);
        assert!(o.admit("IMU", 1, connected));
        // The owner gone: after the check period the next publisher takes over.
        alive.set(false);
        o.confirmed = Some(Instant::now() - OWNER_CHECK_PERIOD - Duration::from_millis(1));
        assert!(o.admit("IMU", 2, connected));
        assert_eq!(asked.get(), 2);
        assert!(o.admit("IMU", 2, connected));
        // ... and now the former owner is the stranger.
        alive.set(true);
        assert!(!o.admit("IMU", 1, connected));
        assert_eq!(o.refused, 1001);
    }
}
