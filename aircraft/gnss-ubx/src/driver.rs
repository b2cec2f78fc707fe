//! Bytes in, stamped fixes and baselines out, every byte accounted for:
//! the framer, the decoder and the time rule together, free of any I/O
//! (the loop in [`crate::run`] reads the device and publishes what this
//! returns).
//!
//! A NAV-RELPOSNED is published paired with the NAV-PVT of the same
//! `iTOW`, the last one before it (a u-blox receiver sends an epoch's NAV
//! messages in the order of their ids, NAV-PVT 0x07 before NAV-RELPOSNED
//! 0x3C): that fix stamps it and gives the latitude and longitude whose
//! north-east-down axes the baseline is in. One without such a fix
//! (another epoch's, or a fix without a week) is counted unpaired.

use std::fmt;

use msgs::{BaselineSample, GnssFix};

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
    /// NAV-RELPOSNED decoded.
    pub relposned: u64,
    /// Of those, with `relPosHeadingValid`.
    pub relposned_heading: u64,
    /// Of those, published (paired with a stamped NAV-PVT of their `iTOW`).
    pub relposned_published: u64,
    /// Of those, without a stamped NAV-PVT of their `iTOW` before them.
    pub relposned_unpaired: u64,
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
             relposned_heading={} relposned_published={} relposned_unpaired={} unused={} \
             invalid={} frames={} bad_checksum={} truncated={} oversize={} garbage_bytes={} \
             lost={} reconnects={}",
            self.published,
            self.nav_pvt,
            self.no_week,
            self.before_epoch,
            self.invalid_llh,
            self.relposned,
            self.relposned_heading,
            self.relposned_published,
            self.relposned_unpaired,
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
    /// Sequence number of the next published baseline.
    baseline_seq: u64,
    /// The last NAV-PVT, for the NAV-RELPOSNED of its epoch.
    last_pvt: Option<LastPvt>,
}

/// The last NAV-PVT: its `iTOW`, and if it was stamped its time and fix.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LastPvt {
    itow_ms: u32,
    stamped: Option<Stamped>,
}

/// A published fix's time (ns) and position (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stamped {
    t_ns: u64,
    lat_rad: f64,
    lon_rad: f64,
}

impl Driver {
    /// A driver stamping with `rule`.
    pub fn new(rule: TimeRule) -> Self {
        Self {
            framer: Framer::new(),
            rule,
            counters: Counters::default(),
            seq: 0,
            baseline_seq: 0,
            last_pvt: None,
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

    /// Feeds bytes; the fixes and baselines to publish are appended to
    /// `out` and `baselines` (both cleared first).
    pub fn feed(
        &mut self,
        data: &[u8],
        out: &mut Vec<GnssFix>,
        baselines: &mut Vec<BaselineSample>,
    ) {
        out.clear();
        baselines.clear();
        let Self {
            framer,
            rule,
            counters,
            seq,
            baseline_seq,
            last_pvt,
        } = self;
        framer.push(data, |frame| match decode(&frame) {
            Decoded::Pvt(p) => {
                counters.nav_pvt += 1;
                let stamped = match rule.stamp(p.itow_ms, &p.date) {
                    Ok((t_ns, _)) => {
                        if p.invalid_llh() {
                            counters.invalid_llh += 1;
                        }
                        let fix = p.to_fix(t_ns, *seq);
                        out.push(fix);
                        *seq += 1;
                        counters.published += 1;
                        Some(Stamped {
                            t_ns,
                            lat_rad: fix.lat_rad,
                            lon_rad: fix.lon_rad,
                        })
                    }
                    Err(Unstamped::NoWeek) => {
                        counters.no_week += 1;
                        None
                    }
                    Err(Unstamped::BeforeEpoch) => {
                        counters.before_epoch += 1;
                        None
                    }
                };
                *last_pvt = Some(LastPvt {
                    itow_ms: p.itow_ms,
                    stamped,
                });
            }
            Decoded::RelPosNed(r) => {
                counters.relposned += 1;
                if r.flags & REL_POS_HEADING_VALID != 0 {
                    counters.relposned_heading += 1;
                }
                match *last_pvt {
                    Some(LastPvt {
                        itow_ms,
                        stamped: Some(f),
                    }) if itow_ms == r.itow_ms => {
                        baselines.push(r.to_baseline(f.t_ns, *baseline_seq, f.lat_rad, f.lon_rad));
                        *baseline_seq += 1;
                        counters.relposned_published += 1;
                    }
                    _ => counters.relposned_unpaired += 1,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::time::TimeRule;

    /// A UBX frame of `class`, `id` and `payload`, with its checksum.
    fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
        let mut f = vec![0xB5, 0x62, class, id];
        f.extend_from_slice(&(payload.len() as u16).to_le_bytes());
        f.extend_from_slice(payload);
        let (mut a, mut b) = (0u8, 0u8);
        for x in &f[2..] {
            a = a.wrapping_add(*x);
            b = b.wrapping_add(a);
        }
        f.extend_from_slice(&[a, b]);
        f
    }

    /// A dated NAV-PVT of `itow` at 45° N, 7° E.
    fn pvt(itow: u32) -> Vec<u8> {
        let mut p = vec![0u8; 92];
        p[0..4].copy_from_slice(&itow.to_le_bytes());
        p[4..6].copy_from_slice(&2026u16.to_le_bytes());
        p[6..12].copy_from_slice(&[11, 26, 20, 0, 0, 0b0111]);
        p[20] = 3;
        p[21] = 1;
        p[24..28].copy_from_slice(&70_000_000i32.to_le_bytes());
        p[28..32].copy_from_slice(&450_000_000i32.to_le_bytes());
        frame(1, 7, &p)
    }

    /// A NAV-RELPOSNED of `itow`: 1.5 m north, fixed.
    fn relposned(itow: u32) -> Vec<u8> {
        let mut p = vec![0u8; 64];
        p[0] = 1;
        p[4..8].copy_from_slice(&itow.to_le_bytes());
        p[8..12].copy_from_slice(&150i32.to_le_bytes());
        p[20..24].copy_from_slice(&150i32.to_le_bytes());
        p[36..40].copy_from_slice(&30u32.to_le_bytes());
        p[60..64].copy_from_slice(&0b1_0011_0101u32.to_le_bytes());
        frame(1, 0x3C, &p)
    }

    /// A NAV-RELPOSNED after the NAV-PVT of its epoch is published with
    /// that fix's time and position; one of another epoch, or before any
    /// fix, is counted unpaired; sequence numbers are the baselines' own.
    #[test]
    fn a_baseline_is_published_with_the_fix_of_its_epoch_and_counted() {
        // Sensor time 0 at 2026-01-01T00:00:00Z, GPS − UTC 18 s.
        let rule = TimeRule::new(1_767_225_600_000_000_000, 18, 0.0, None).expect("rule");
        let mut d = Driver::new(rule);
        let (mut fixes, mut baselines) = (Vec::new(), Vec::new());
        let mut bytes = relposned(1000); // before any fix
        bytes.extend(pvt(1000));
        bytes.extend(relposned(1000)); // paired
        bytes.extend(pvt(1200));
        bytes.extend(relposned(1100)); // another epoch's
        bytes.extend(relposned(1200)); // paired
        d.feed(&bytes, &mut fixes, &mut baselines);
        assert_eq!(fixes.len(), 2);
        assert_eq!(baselines.len(), 2);
        for (b, f) in baselines.iter().zip(&fixes) {
            assert_eq!(
                (b.t_ns, b.itow_ms, b.lat_rad, b.lon_rad),
                (f.t_ns, f.itow_ms, f.lat_rad, f.lon_rad)
            );
            assert!((b.rel_pos_ned_m[0] - 1.5).abs() < 1e-12 && b.is_fixed());
        }
        assert_eq!((baselines[0].seq, baselines[1].seq), (0, 1));
        let c = d.counters();
        assert_eq!(
            (
                c.relposned,
                c.relposned_published,
                c.relposned_unpaired,
                c.relposned_heading
            ),
            (4, 2, 2, 4)
        );
        assert_eq!((c.nav_pvt, c.published, c.framing.frames), (2, 2, 6));
    }
}
