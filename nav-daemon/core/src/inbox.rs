//! The live loop's inbox: what a cycle received, put into navlog order
//! before the session sees it, so that live equals `batch` bit for bit.
//!
//! A live cycle drains its topics one after the other — init, IMU, then
//! each aid — while the publishers go on. Two things would otherwise make
//! the session see the inputs in another order than a navlog has them:
//! - within a cycle, topics arrive grouped, not interleaved: the inbox
//!   sorts a cycle by (time, init < IMU < the aids in their declared
//!   order), as a navlog is;
//! - an input drained after the IMU topic may be stamped after IMU samples
//!   that were published before it but after the IMU topic was drained:
//!   the inbox keeps it (at most [`CARRY_MAX`] inputs) until an IMU sample
//!   stamped at or after it has been received, so that the session gets it
//!   right before the sample that follows it, where a navlog has it.
//!
//! Sequence gaps are noted in arrival order, as inputs are received. Before
//! the first IMU sample and at the end every input is handed on at once.
//! Nothing here depends on when an input arrived, only on its stamp and on
//! the IMU stamps received: in particular an input keeps waiting while the
//! IMU is late or declared lost (a driver stalled for a few seconds), so a
//! busy machine changes no solution. The buffer is allocated once; a cycle
//! moves inputs without allocating.

use msgs::{AidSample, ImuSample, InitState};

use crate::session::{Event, Input, Session, Sink};

/// Most inputs kept for a later IMU sample; beyond, the oldest go on to the
/// session, which queues or refuses them (as ahead of the IMU). 256 covers
/// an IMU stalled for 5 s while aids arrive at 50 Hz in all (a star tracker
/// and a barometer at 20 Hz, SRS and CNS at 5 Hz), as `batch` would fuse
/// them; a longer stall with the aids still arriving refuses the oldest, as
/// `batch` also refuses aids more than 1 s ahead of the IMU.
pub const CARRY_MAX: usize = 256;

/// An input held by value. Not boxed on purpose: boxing the SRS variant
/// would allocate in the loop.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub enum Received {
    Init(InitState),
    Imu(ImuSample),
    Aid(AidSample),
}

impl Received {
    /// Navlog order: time stamp, then init before IMU before the aids.
    pub fn key(&self) -> (u64, u8) {
        match self {
            Received::Init(x) => (x.t_ns, 0),
            Received::Imu(x) => (x.t_ns, 1),
            Received::Aid(x) => (x.t_ns(), 2 + x.kind() as u8),
        }
    }

    pub fn input(&self) -> Input<'_> {
        match self {
            Received::Init(x) => Input::Init(x),
            Received::Imu(x) => Input::Imu(x),
            Received::Aid(x) => Input::Aid(x),
        }
    }
}

/// See the module documentation.
#[derive(Debug)]
pub struct Inbox {
    buf: Vec<Received>,
    /// The first `kept` inputs of `buf` wait for a later IMU sample.
    kept: usize,
    /// Time of the IMU sample received last (one publisher sends them in
    /// time order; after a stamp that went back, e.g. a new replay or a
    /// restarted driver, the new time line counts, and one absurd stamp
    /// holds nothing beyond the next sample).
    newest_imu_t_ns: Option<u64>,
}

impl Inbox {
    /// An inbox for cycles of up to `cycle_capacity` inputs (it grows, by
    /// allocating, only beyond).
    pub fn with_capacity(cycle_capacity: usize) -> Self {
        Self {
            buf: Vec::with_capacity(cycle_capacity + CARRY_MAX),
            kept: 0,
            newest_imu_t_ns: None,
        }
    }

    /// Receives one input, in arrival order: a sequence gap it reveals is
    /// returned for the driver to log.
    pub fn receive(&mut self, session: &mut Session, r: Received) -> Option<Event> {
        if let Received::Imu(x) = &r {
            self.newest_imu_t_ns = Some(x.t_ns);
        }
        let gap = session.arrived(&r.input());
        self.buf.push(r);
        gap
    }

    /// The end of a cycle: the inputs received, in navlog order, go to the
    /// session, but for those stamped after the newest IMU sample received
    /// so far, which wait (at most [`CARRY_MAX`]) for the next cycle, also
    /// while the IMU is late or lost.
    pub fn deliver(&mut self, session: &mut Session, sink: &mut impl Sink) {
        self.buf.sort_unstable_by_key(Received::key);
        let n = match self.newest_imu_t_ns {
            Some(t) => {
                let later = self.buf.iter().rev().take_while(|r| r.key().0 > t).count();
                self.buf.len() - later.min(CARRY_MAX)
            }
            _ => self.buf.len(),
        };
        self.hand(n, session, sink);
    }

    /// Every input held goes to the session (the end of the run).
    pub fn deliver_all(&mut self, session: &mut Session, sink: &mut impl Sink) {
        self.buf.sort_unstable_by_key(Received::key);
        self.hand(self.buf.len(), session, sink);
    }

    /// Inputs waiting for a later IMU sample.
    pub fn waiting(&self) -> usize {
        self.kept
    }

    fn hand(&mut self, n: usize, session: &mut Session, sink: &mut impl Sink) {
        for r in &self.buf[..n] {
            session.handle(r.input(), sink);
        }
        self.buf.drain(..n);
        self.kept = self.buf.len();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::{Collect, SessionSettings};

    fn imu(t_ns: u64, seq: u64) -> Received {
        Received::Imu(ImuSample {
            t_ns,
            seq,
            dt_s: 0.01,
            ..Default::default()
        })
    }

    fn baro(t_ns: u64, seq: u64) -> Received {
        Received::Aid(AidSample::Baro(msgs::BaroSample {
            t_ns,
            seq,
            pressure_pa: 7500.0,
            temperature_k: 216.65,
            sigma_m: 10.0,
        }))
    }

    #[test]
    fn an_input_ahead_of_the_imu_waits_for_the_sample_after_it() {
        let mut s = Session::new(SessionSettings::default());
        let mut sink = Collect::default();
        let mut inbox = Inbox::with_capacity(8);
        // Cycle 1 drained IMU up to 20 ms, then a baro stamped 35 ms.
        for r in [imu(10_000_000, 0), imu(20_000_000, 1), baro(35_000_000, 0)] {
            assert!(inbox.receive(&mut s, r).is_none());
        }
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 1);
        // Cycle 2: IMU 30 ms does not reach it; 40 ms does.
        inbox.receive(&mut s, imu(30_000_000, 2));
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 1);
        inbox.receive(&mut s, imu(40_000_000, 3));
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 0);
        // A stamp equal to the newest IMU sample's goes on (navlog order:
        // the IMU sample, then the aid).
        inbox.receive(&mut s, baro(40_000_000, 1));
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 0);
        // However long the IMU stays away, an input ahead of it waits.
        inbox.receive(&mut s, baro(90_000_000, 2));
        for _ in 0..1000 {
            inbox.deliver(&mut s, &mut sink);
        }
        s.imu_lost(&mut sink);
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 1);
        assert_eq!(s.status().aid_counters(msgs::AidKind::Baro).received, 2);
        inbox.deliver_all(&mut s, &mut sink);
        assert_eq!(s.status().aid_counters(msgs::AidKind::Baro).received, 3);
    }

    #[test]
    fn at_most_carry_max_inputs_wait_and_the_oldest_go_on() {
        let mut s = Session::new(SessionSettings::default());
        let mut sink = Collect::default();
        let mut inbox = Inbox::with_capacity(8);
        inbox.receive(&mut s, imu(10_000_000, 0));
        for k in 0..(CARRY_MAX as u64 + 10) {
            inbox.receive(&mut s, baro(1_000_000_000 + k, k));
        }
        inbox.deliver(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), CARRY_MAX);
        inbox.deliver_all(&mut s, &mut sink);
        assert_eq!(inbox.waiting(), 0);
        let st = s.status();
        assert_eq!(
            st.aid_counters(msgs::AidKind::Baro).received,
            CARRY_MAX as u64 + 10
        );
    }
}
