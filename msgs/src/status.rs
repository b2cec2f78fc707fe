//! The daemon's health on the wire: per input stream its counters, per
//! aid its status record, and the loop's figures ([`Status`], published
//! at 1 Hz on `<prefix>/status`). The per-stream arrays follow the aid
//! declaration (`crate::aids`).
#![allow(unsafe_code)] // the ZeroCopySend derive emits `unsafe impl`; the layout has no implicit padding (tested)

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

use crate::aids::{AID_COUNT, AidKind, MAX_CAUSES, MAX_COMPONENTS, STREAM_COUNT, Stream};
use crate::payloads::WireFrame;

/// Counters of one input stream. Every received sample is counted once, as
/// accepted or under one rejection reason ([`StreamCounters::decided`]):
/// `received = accepted + rejected_invalid + rejected_time + rejected_gate
/// + rejected_integrity + not_used`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::StreamCounters_v4"))]
pub struct StreamCounters {
    /// Samples received from the transport or log.
    pub received: u64,
    /// Samples that passed validation and were used.
    pub accepted: u64,
    /// Rejected: non-finite or physically impossible values, or refused by
    /// the aid's own quality checks (`AidStatus::refused` says which).
    pub rejected_invalid: u64,
    /// Rejected: time stamp not after the previous one (backwards or duplicate).
    pub rejected_time: u64,
    /// Rejected by the innovation gate (aids only).
    pub rejected_gate: u64,
    /// Rejected because the aid is excluded by its integrity test (aids
    /// that are not autonomous: GNSS).
    pub rejected_integrity: u64,
    /// Not used: the aid is disabled, or there was no navigation state to apply
    /// the sample to (before the first init, or stamped before a re-initialization).
    pub not_used: u64,
    /// Gaps detected in the sequence numbers (samples lost upstream).
    pub seq_gaps: u64,
    /// Time stamp of the last accepted sample (0 = none yet).
    pub last_t_ns: u64,
    /// Samples refused before they were received because another publisher
    /// owns the input service (live only; not part of `received`). The
    /// first publisher to send owns it until it disconnects or its process dies.
    pub refused_publisher: u64,
}

impl StreamCounters {
    /// Every outcome counted: equals `received` when each sample is
    /// counted once.
    pub fn decided(&self) -> u64 {
        self.accepted
            + self.rejected_invalid
            + self.rejected_time
            + self.rejected_gate
            + self.rejected_integrity
            + self.not_used
    }
}

/// The status record every aid reports (one shape for every aid).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::AidStatus_v3"))]
pub struct AidStatus {
    /// Last innovation (measurement − prediction), up to
    /// [`MAX_COMPONENTS`] components (the aid's declaration says how many
    /// and their units); unused ones zero.
    pub innovation: [f64; MAX_COMPONENTS],
    /// Its variance (diagonal of S).
    pub innovation_var: [f64; MAX_COMPONENTS],
    /// χ² test ratio of the last innovation (test statistic / gate threshold).
    pub test_ratio: f64,
    /// Time of the last fused measurement (0 = never).
    pub last_fuse_t_ns: u64,
    /// Exclusions by fault detection so far: SRS lines, and for an aid
    /// that is not autonomous its exclusions by the integrity test.
    pub exclusions: u64,
    /// An aid that is not autonomous: its last integrity test's statistic
    /// over the alarm threshold (above 1 is an alarm; 0: no test yet, and
    /// always 0 for an autonomous aid).
    pub integrity_ratio: f64,
    /// Since when it is excluded (ns; 0 when it is not).
    pub excluded_since_t_ns: u64,
    /// Samples refused before fusion, by the aid's causes (its
    /// declaration's `causes`: the first is invalid content); they sum to
    /// the stream's `rejected_invalid`.
    pub refused: [u64; MAX_CAUSES],
    /// 1 if the last measurement was fused, 0 if rejected.
    pub fused: u8,
    /// 1 if the aid is fresh (within its timeout).
    pub fresh: u8,
    /// The navigation frame the last innovation was made in, as 1 +
    /// [`WireFrame`] (1 geographic, 2 grid), so that a reader converts a
    /// CNS innovation (Δlatitude, Δlongitude in g; metres in G) in the
    /// right frame even when a switch came between the update and this
    /// status. 0: not known (no update yet, or a sender before this field:
    /// the byte was padding, always zero). See [`AidStatus::made_in`].
    pub made_in_frame: u8,
    /// 1 while the integrity test excludes the aid.
    pub excluded: u8,
    /// Why (`polarnav::integrity::cause`: 1 position, 2 velocity, 3 other
    /// components inconsistent with the autonomous solution; 0 none).
    pub exclusion_cause: u8,
    /// An aid that is not autonomous: whether its integrity test could
    /// judge its last sample ([`integrity_state`]: 0 not tested (an
    /// autonomous aid, the test off, or no sample yet), 1 tested, 2
    /// unavailable: the test's horizontal protection level beyond the
    /// alert limit, the sample fused untested unless the aid is excluded).
    /// The last sample's state: it stays through an outage. The byte was
    /// padding (always zero) before: an older sender reads "not tested".
    pub integrity_state: u8,
    /// Always zero.
    pub _pad: [u8; 2],
}

/// Values of [`AidStatus::integrity_state`].
pub mod integrity_state {
    pub const NOT_TESTED: u8 = 0;
    pub const TESTED: u8 = 1;
    pub const UNAVAILABLE: u8 = 2;
}

impl AidStatus {
    /// The frame the last innovation was made in, when the sender says.
    pub fn made_in(&self) -> Option<WireFrame> {
        WireFrame::from_made_in(self.made_in_frame)
    }

    /// The value of [`AidStatus::made_in_frame`] for an innovation made in `frame`.
    pub fn made_in_frame_of(frame: WireFrame) -> u8 {
        frame as u8 + 1
    }
}

/// Health of the daemon, published at 1 Hz.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::Status_v7"))]
pub struct Status {
    pub t_ns: u64,
    pub seq: u64,
    /// Counters per input stream: `streams[0]` the IMU's, `streams[1 + k]`
    /// aid k's (k an `AidKind`).
    pub streams: [StreamCounters; STREAM_COUNT],
    /// Status per aid: `aids[k]` aid k's (k an `AidKind`).
    pub aids: [AidStatus; AID_COUNT],
    /// Filter cycles run, and cycles that overran their period in wall-clock
    /// time (including time the thread was preempted).
    pub cycles: u64,
    pub overruns: u64,
    /// Cycles whose own CPU time exceeded the period (the daemon's work, not
    /// preemption by others): `overruns − overruns_cpu` were stalls from outside.
    pub overruns_cpu: u64,
    /// Cycle execution time statistics over the last status period (ns).
    pub cycle_time_mean_ns: u64,
    pub cycle_time_max_ns: u64,
    /// Time of the last frame switch (0 = none).
    pub last_switch_t_ns: u64,
    /// IMU gaps longer than `[filter] imu_gap_s` coasted across, and the
    /// total sensor time coasted (ns).
    pub imu_gap_count: u64,
    pub coasted_ns: u64,
    /// Checkpoints written, and whether this run resumed from one (1) or
    /// started cold (0).
    pub checkpoints_written: u64,
    /// Re-initializations (new init messages) taken.
    pub reinit_count: u32,
    pub switch_count: u32,
    /// Resets of the navigation state (see `Solution::reset_t_ns`).
    pub reset_count: u32,
    /// Bit set of [`solution_flags`] at the time of the status.
    pub flags: u32,
    /// [`WireFrame`] as u8.
    pub frame: u8,
    /// 1 if this run resumed from a checkpoint, 0 after a cold start.
    pub resumed: u8,
    /// How the attitude of the init the navigator runs from was found: the
    /// init's [`InitState::method`](crate::InitState::method) and
    /// [`InitState::heading_aid`](crate::InitState::heading_aid) (0 and 0:
    /// given from outside, also before the first init and after a
    /// resume; a sender before these fields sent padding, always zero).
    /// See [`Status::init_method`].
    pub init_method: u8,
    pub init_heading_aid: u8,
    /// The services the daemon cannot open now, and why ([`unavailable`]):
    /// each is retried, and taken once it opens. 0: every service served
    /// (a sender before this field sent padding, always zero).
    pub unavailable: u32,
}

/// Bits of [`Status::unavailable`]: a service the daemon could not open
/// (another process created it first with another payload type or other
/// options, or iceoryx2 refused it) is served by nobody; the daemon serves
/// every other one, retries it and takes it once it opens. The low half
/// says which service, the high half why: bit `INCOMPATIBLE_SHIFT + b` set with
/// bit `b` when the service exists with another payload type or other
/// options (a squatter), clear for any other failure (the log line says
/// which).
pub mod unavailable {
    use crate::aids::{STREAM_COUNT, Stream};

    /// An input stream's service: bit [`Stream::index`] (0 the IMU, 1 + k aid k).
    pub const fn stream(s: Stream) -> u32 {
        1 << s.index()
    }
    /// `<prefix>/init`.
    pub const INIT_SERVICE: u32 = 1 << STREAM_COUNT;
    /// `<prefix>/solution`.
    pub const SOLUTION_SERVICE: u32 = 1 << (STREAM_COUNT + 1);
    /// `<prefix>/status` (then only the log and systemd's STATUS= say so).
    pub const STATUS_SERVICE: u32 = 1 << (STREAM_COUNT + 2);
    /// `<prefix>/settings`.
    pub const SETTINGS_SERVICE: u32 = 1 << (STREAM_COUNT + 3);
    /// Shift of the cause bits: `bit << INCOMPATIBLE_SHIFT` set when the service
    /// exists with another payload type or other options.
    pub const INCOMPATIBLE_SHIFT: u32 = 16;
    const _: () = assert!(STREAM_COUNT + 4 <= INCOMPATIBLE_SHIFT as usize);

    /// The services of `bits` by name, each with its cause when it is
    /// another payload type or options (for readers and logs).
    pub fn describe(bits: u32) -> String {
        let outputs = [
            ("init", INIT_SERVICE),
            ("solution", SOLUTION_SERVICE),
            ("status", STATUS_SERVICE),
            ("settings", SETTINGS_SERVICE),
        ];
        Stream::ALL
            .iter()
            .map(|s| (s.name(), stream(*s)))
            .chain(outputs)
            .filter(|(_, b)| bits & b != 0)
            .map(|(name, b)| {
                if bits & (b << INCOMPATIBLE_SHIFT) != 0 {
                    format!("{name} (exists with another payload type or options)")
                } else {
                    name.to_owned()
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    #[cfg(test)]
    mod tests {
        use super::*;
        use crate::AidKind;

        #[test]
        fn every_service_has_its_own_bit_and_is_named_with_its_cause() {
            let mut all: Vec<u32> = Stream::ALL.iter().map(|s| stream(*s)).collect();
            all.extend([
                INIT_SERVICE,
                SOLUTION_SERVICE,
                STATUS_SERVICE,
                SETTINGS_SERVICE,
            ]);
            let or = all.iter().fold(0, |acc, b| {
                assert_eq!(acc & b, 0, "bit {b:#x} shared");
                acc | b
            });
            assert!(or < 1 << INCOMPATIBLE_SHIFT);
            let imu = stream(Stream::Imu);
            let gnss = stream(Stream::Aid(AidKind::Gnss));
            assert_eq!(
                describe(imu | imu << INCOMPATIBLE_SHIFT | gnss | SOLUTION_SERVICE),
                format!(
                    "{} (exists with another payload type or options), {}, solution",
                    Stream::Imu.name(),
                    Stream::Aid(AidKind::Gnss).name()
                )
            );
            assert_eq!(describe(0), "");
        }
    }
}

impl Status {
    /// How the attitude of the init the navigator runs from was found
    /// (`None`: bytes no sender writes).
    pub fn init_method(&self) -> Option<crate::InitMethod> {
        crate::InitMethod::from_wire(self.init_method, self.init_heading_aid)
    }

    /// The counters of `stream`.
    pub fn counters(&self, stream: Stream) -> &StreamCounters {
        &self.streams[stream.index()]
    }
    pub fn counters_mut(&mut self, stream: Stream) -> &mut StreamCounters {
        &mut self.streams[stream.index()]
    }
    /// The IMU's counters.
    pub fn imu(&self) -> &StreamCounters {
        &self.streams[0]
    }
    /// The counters of aid `k`.
    pub fn aid_counters(&self, k: AidKind) -> &StreamCounters {
        self.counters(Stream::Aid(k))
    }
    /// The counters of aid `k`, to change.
    pub fn aid_counters_mut(&mut self, k: AidKind) -> &mut StreamCounters {
        self.counters_mut(Stream::Aid(k))
    }
    /// The status of aid `k`.
    pub fn aid(&self, k: AidKind) -> &AidStatus {
        &self.aids[k as usize]
    }
    /// The status of aid `k`, to change.
    pub fn aid_mut(&mut self, k: AidKind) -> &mut AidStatus {
        &mut self.aids[k as usize]
    }
    /// Each aid with its counters and status.
    pub fn each_aid(&self) -> impl Iterator<Item = (AidKind, &StreamCounters, &AidStatus)> {
        AidKind::ALL
            .into_iter()
            .map(|k| (k, self.aid_counters(k), self.aid(k)))
    }
}
