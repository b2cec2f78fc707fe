//! Bytes in, stamped fixes out, every byte accounted for: the framer,
//! the decoder and the time rule together, free of any I/O (the loop in
//! [`crate::run`] reads the device and publishes what this returns).

use std::fmt;

use msgs::GnssFix;

use crate::decode::{Decoded, REL_POS_HEADING_VALID, decode};
use crate::framing::{FrameCounters, Framer};
use crate::time::{TimeRule, Unstamped};

/// Everything the driver counts, by cause. Each frame or byte of input is
/// counted under exactly one of: a published fix, `no_week`,
/// `before_epoch`, `relposned`, `unused`, `invalid` (good frames), or
/// `bad_checksum`, `truncated`, `oversize`, `garbage_bytes` (damage).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// The framer's counts (good frames and damage).
    pub framing: FrameCounters,
    /// NAV-PVT decoded.
    pub nav_pvt: u64,
    /// Of those, published.
    pub published: u64,
    /// NAV-PVT without a week (no valid date yet, no `time.week`).
    pub no_week: u64,
    /// NAV-PVT before the epoch of the sensor time base.
    pub before_epoch: u64,
    /// NAV-PVT whose `invalidLlh` cleared gnssFixOK (published).
    pub invalid_llh: u64,
    /// NAV-RELPOSNED decoded (not published: no aid takes it yet).
    pub relposned: u64,
    /// Of those, with `relPosHeadingValid`.
    pub relposned_heading: u64,
    /// Good frames of a class and id the driver does not use.
    pub unused: u64,
    /// NAV-PVT or NAV-RELPOSNED the decoder refused (wrong length).
    pub invalid: u64,
    /// Deliveries dropped because a subscriber's buffer was full.
    pub lost: u64,
    /// Times the device came back after it was lost.
    pub reconnects: u64,
}

impl fmt::Display for Counters {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.framing;
        write!(
            f,
            "published={} nav_pvt={} no_week={} before_epoch={} invalid_llh={} relposned={} \
             relposned_heading={} unused={} invalid={} frames={} bad_checksum={} truncated={} \
             oversize={} garbage_bytes={} lost={} reconnects={}",
            self.published,
            self.nav_pvt,
            self.no_week,
            self.before_epoch,
            self.invalid_llh,
            self.relposned,
            self.relposned_heading,
            self.unused,
            self.invalid,
            c.frames,
            c.bad_checksum,
            c.truncated,
            c.oversize,
            c.garbage_bytes,
            self.lost,
            self.reconnects
        )
    }
}

impl Counters {
    /// Damaged input seen so far (frames and garbage bytes).
    pub fn damage(&self) -> u64 {
        let c = &self.framing;
        c.bad_checksum + c.truncated + c.oversize + c.garbage_bytes + self.invalid
    }
}

/// The pure part of the driver.
#[derive(Debug)]
pub struct Driver {
    framer: Framer,
    rule: TimeRule,
    counters: Counters,
    /// Sequence number of the next published fix.
    seq: u64,
}

impl Driver {
    /// A driver stamping with `rule`.
    pub fn new(rule: TimeRule) -> Self {
        Self {
            framer: Framer::new(),
            rule,
            counters: Counters::default(),
            seq: 0,
        }
    }

    /// Everything counted so far.
    pub fn counters(&self) -> Counters {
        Counters {
            framing: self.framer.counters(),
            ..self.counters
        }
    }

    /// Adds deliveries the publisher dropped.
    pub fn set_lost(&mut self, lost: u64) {
        self.counters.lost = lost;
    }

    /// Counts a reconnection.
    pub fn reconnected(&mut self) {
        self.counters.reconnects += 1;
    }

    /// Feeds bytes; the fixes to publish are appended to `out` (cleared first).
    pub fn feed(&mut self, data: &[u8], out: &mut Vec<GnssFix>) {
        out.clear();
        let Self {
            framer,
            rule,
            counters,
            seq,
        } = self;
        framer.push(data, |frame| match decode(&frame) {
            Decoded::Pvt(p) => {
                counters.nav_pvt += 1;
                match rule.stamp(p.itow_ms, &p.date) {
                    Ok((t_ns, _)) => {
                        if p.invalid_llh() {
                            counters.invalid_llh += 1;
                        }
                        out.push(p.to_fix(t_ns, *seq));
                        *seq += 1;
                        counters.published += 1;
                    }
                    Err(Unstamped::NoWeek) => counters.no_week += 1,
                    Err(Unstamped::BeforeEpoch) => counters.before_epoch += 1,
                }
            }
            Decoded::RelPosNed(r) => {
                counters.relposned += 1;
                if r.flags & REL_POS_HEADING_VALID != 0 {
                    counters.relposned_heading += 1;
                }
            }
            Decoded::Unused => counters.unused += 1,
            Decoded::Invalid => counters.invalid += 1,
        });
    }

    /// The stream ended or the device was lost: what is held is counted
    /// (a truncated frame or garbage).
    pub fn finish(&mut self) {
        self.framer.finish();
    }
}
