//! The session: everything between a decoded input and a published output.
//!
//! The live daemon, `batch`, the fault campaign, the tests and the benches
//! all feed this one type, so they take every decision the same way:
//!
//! - **Initialization and its sources**, in this precedence: a checkpoint
//!   the IMU continues from (and no init newer than it); an init message or
//!   record (the newest one whose time the IMU has reached); `[init]` of the
//!   configuration; each optionally followed by a stationary alignment.
//!   An init stamped ahead of the IMU is held until the IMU reaches it (a
//!   future stamp never blocks anything); one stamped at or before the
//!   newest IMU sample re-initializes at once.
//! - **Ordering**: an IMU sample at most `[filter] imu_gap_s` after the
//!   previous one is taken at once. One further ahead (a gap to coast, or a
//!   jump of the clock) is held as a time-jump candidate until
//!   [`TIME_JUMP_CONFIRM`] consecutive, mutually consistent candidates
//!   confirm it: a gap up to `imu_max_coast_s` is then coasted, a longer
//!   jump (either way) re-synchronizes the navigator's time base. Any
//!   sample that fits refutes the candidates, which are counted as
//!   rejected: one absurd stamp costs only itself. A sample behind the
//!   previous one by at most `imu_max_coast_s` is stale and refused at once
//!   (the stream catches up within that time).
//! - **Aids** wait in a bounded queue (at most [`AID_QUEUE`] samples, at
//!   most [`MAX_AID_LEAD_NS`] ahead of the IMU) and are fused in (time,
//!   stream) order, each at its own time (the navigator's state history),
//!   just before the next IMU sample is integrated: the aids between two
//!   IMU samples are fused in the same order whatever order they arrived
//!   in and however a driver grouped them, so a live cycle (which drains
//!   its topics one after the other) and a navlog give the same result.
//! - **Solutions**: the solution of an IMU sample holds every aid stamped
//!   up to that sample's time: it is emitted when the next IMU sample
//!   arrives (after the aids stamped up to the sample's time are fused) or
//!   at the end ([`Session::finish`]), never at the end of a live cycle,
//!   so nothing depends on where a cycle ends. A sink may decline a
//!   solution ([`Sink::wants_solution`]): it is then not built at all.
//! - **IMU loss** (the live loop's wall-clock watchdog, [`Session::imu_lost`])
//!   is reported in the status and changes no decision: aids ahead of the
//!   IMU wait for it as they always do, so a late IMU costs nothing.
//! - **Integrity** of the aids that are not autonomous (GNSS): the
//!   session keeps a reference navigator fed every input but theirs, and
//!   tests each of their samples against it before the main navigator may
//!   fuse it ([`crate::integrity`]): an alarm excludes the aid and the
//!   main navigator takes the reference's state (published as a reset); a
//!   sample of an excluded aid is refused (`rejected_integrity`) until its
//!   samples have agreed for the readmission time. The reference starts
//!   as a copy of the main navigator at the first tested sample, again at
//!   each re-initialization, and follows its time re-synchronizations.
//! - **Accounting**: every input is counted once, per stream:
//!   `received = accepted + rejected_invalid + rejected_time + rejected_gate
//!   + rejected_integrity + not_used`, and inits apart ([`InitCounters`]).
//!
//! Work per input is bounded: no loop in here or in the navigator depends
//! on a value of the input (gaps are bridged in at most
//! [`crate::navigator::MAX_BRIDGE_STEPS`] steps, the queue is fixed).
//! Nothing is logged here: decisions are reported as [`Event`]s to the
//! driver's [`Sink`], which logs them as it sees fit.

use msgs::{
    AidKind, AidSample, AidStatus, ImuSample, InitMethod, InitState, PerAid, Solution, Status,
    StreamCounters,
};

use crate::aids::{AidError, HeadingFix, Levelled, OwnAidSettings, OwnOf};
use crate::align::{AlignError, Alignment, AlignmentAccumulator, aligned_init, best_heading};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::integrity::{IntegritySettings, Monitor, Test, Verdict};
use crate::navigator::{
    IMU_DT_RANGE_S, InputRejection, Navigator, NavigatorConfig, SwitchEvent, check_init,
};
use crate::settings::InitSettings;

/// Consecutive consistent samples that confirm a time jump of the IMU.
pub const TIME_JUMP_CONFIRM: usize = 4;
/// Capacity of the queue of aids waiting for the IMU.
/// (A genuine aid waits a few IMU periods at most; 16 also bounds the work
/// of the IMU sample that releases them, SRS solves being the costliest.)
pub const AID_QUEUE: usize = 16;
/// An aid further ahead of the newest IMU sample than this (1 s) is refused:
/// no transport or sensor delay puts a genuine aid there, and by the time
/// the IMU reached it, it would be refused as late anyway.
pub const MAX_AID_LEAD_NS: u64 = 1_000_000_000;

/// The sensor streams a session counts: the IMU and the aids of the
/// declaration (`msgs::aids`), one value each in a [`PerStream`].
pub use msgs::{PerStream, Stream};

/// A decoded input.
#[derive(Debug, Clone, Copy)]
pub enum Input<'a> {
    Imu(&'a ImuSample),
    Aid(&'a AidSample),
    Init(&'a InitState),
}

impl<'a> Input<'a> {
    /// The input a navlog record carries (`None` for header, truth and outputs).
    pub fn from_record(r: &'a msgs::navlog::Record) -> Option<Self> {
        use msgs::navlog::Record;
        match r {
            Record::Imu(x) => Some(Input::Imu(x)),
            Record::Aid(x) => Some(Input::Aid(x)),
            Record::Init(x) => Some(Input::Init(x)),
            Record::Header(_)
            | Record::Truth(_)
            | Record::TruthBias(_)
            | Record::Solution(_)
            | Record::Status(_) => None,
        }
    }

    pub fn t_ns(&self) -> u64 {
        match self {
            Input::Imu(x) => x.t_ns,
            Input::Aid(x) => x.t_ns(),
            Input::Init(x) => x.t_ns,
        }
    }
}

/// The stream of an aid sample.
fn stream_of(a: &AidSample) -> Stream {
    Stream::Aid(a.kind())
}

/// Aids ahead of the IMU, ordered by (time, stream), fixed capacity.
#[derive(Debug, Clone)]
struct AidQueue {
    items: [Option<AidSample>; AID_QUEUE],
    len: usize,
}

impl AidQueue {
    fn new() -> Self {
        Self {
            items: [None; AID_QUEUE],
            len: 0,
        }
    }

    fn key(a: &AidSample) -> (u64, Stream) {
        (a.t_ns(), stream_of(a))
    }

    /// Inserts in order (after equal keys); when full, the oldest is
    /// returned to make room.
    fn insert(&mut self, a: AidSample) -> Option<AidSample> {
        let evicted = if self.len == AID_QUEUE {
            self.pop_front()
        } else {
            None
        };
        let k = Self::key(&a);
        let mut i = self.len;
        while i > 0 && self.items[i - 1].as_ref().is_some_and(|x| Self::key(x) > k) {
            self.items[i] = self.items[i - 1];
            i -= 1;
        }
        self.items[i] = Some(a);
        self.len += 1;
        evicted
    }

    fn front_t_ns(&self) -> Option<u64> {
        self.items[0].filter(|_| self.len > 0).map(|a| a.t_ns())
    }

    fn pop_front(&mut self) -> Option<AidSample> {
        if self.len == 0 {
            return None;
        }
        let a = self.items[0].take();
        for i in 1..self.len {
            self.items[i - 1] = self.items[i];
        }
        self.items[self.len - 1] = None;
        self.len -= 1;
        a
    }
}

/// Where the navigation state came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InitSource {
    /// An init message or navlog init record.
    Message,
    /// `[init]` of the configuration.
    Config,
    /// A checkpoint the IMU continued from.
    Checkpoint,
}

/// A decision of the session, for the driver to log or report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// Navigation started at `t_ns` from `source` (after the alignment, if one ran).
    Started {
        source: InitSource,
        t_ns: u64,
    },
    /// A stationary alignment started on this init (its position kept).
    AlignmentStarted {
        t_ns: u64,
        duration_s: f64,
    },
    /// The alignment was solved.
    Aligned {
        alignment: Alignment,
        /// The init record it made, navigation's start (its `method` says
        /// how the attitude was found).
        init: InitState,
    },
    /// The alignment could not be solved; the session waits for a new init.
    AlignmentFailed(AlignError),
    /// A new init replaced the running state.
    Reinitialized {
        t_ns: u64,
    },
    /// An init stamped ahead of the IMU is held until the IMU reaches it.
    InitHeld {
        t_ns: u64,
        imu_t_ns: u64,
    },
    /// An init refused (content, or too far behind the IMU), or superseded
    /// by a newer one before it was used.
    InitRejected {
        t_ns: u64,
        seq: u64,
        reason: InputRejection,
    },
    InitSuperseded {
        t_ns: u64,
    },
    /// A checkpoint was offered but the IMU does not continue from it, or a
    /// newer init wins: the session starts cold.
    CheckpointNotUsed {
        checkpoint_t_ns: u64,
        first_imu_t_ns: u64,
        newer_init: bool,
    },
    /// An input was refused.
    Rejected {
        stream: Stream,
        t_ns: u64,
        seq: u64,
        reason: InputRejection,
    },
    /// A frame switch.
    Switch(SwitchEvent),
    /// Samples of a stream were lost before they reached the session: the
    /// sequence number `seq` arrived where `expected` was due.
    SequenceGap {
        stream: Stream,
        expected: u64,
        seq: u64,
    },
    /// The IMU time base jumped and was confirmed; the navigator re-synchronized.
    TimeResync {
        from_t_ns: u64,
        to_t_ns: u64,
    },
    /// The covariance lost finiteness or positive variances and was re-inflated.
    CovarianceRepaired {
        t_ns: u64,
    },
    /// An aid sample reached its gate: fused or rejected there, with the
    /// aid's status record after it (innovation, its variance, test ratio).
    /// One per gated sample: sinks that log should log only rejections.
    AidUpdate {
        stream: Stream,
        t_ns: u64,
        /// With the frame the update was made in
        /// ([`AidStatus::made_in_frame`]).
        status: AidStatus,
        /// The position after the update: with the frame, what turns a CNS
        /// innovation in g (Δlatitude, Δlongitude in rad) into metres.
        lat_rad: f64,
        h_m: f64,
    },
    /// A sample of an aid that is not autonomous was tested against the
    /// reference ([`crate::integrity`]): its statistic and what was decided
    /// (one per tested sample; sinks that log should log only
    /// [`Verdict::Exclude`] and [`Verdict::Readmit`]). On an exclusion the
    /// main navigator has taken the reference's state: its reset record
    /// says by how much.
    Integrity {
        stream: Stream,
        t_ns: u64,
        test: Test,
        verdict: Verdict,
        /// The aid's exclusions so far (this one included).
        exclusions: u64,
        /// On an exclusion: the step the main navigator made to the
        /// reference's state.
        step: Option<crate::navigator::ResetRecord>,
    },
    /// The integrity test of an aid that is not autonomous was lost (the
    /// test's horizontal protection level from the reference's covariance
    /// went beyond the alert limit: the aid is fused untested) or
    /// regained; one per change.
    IntegrityAvailability {
        stream: Stream,
        t_ns: u64,
        available: bool,
        protection_m: f64,
        alert_limit_m: f64,
    },
    /// An aid rejected for `[aids] reset_after_s` while consistent reset the
    /// states it observes: the reset as published, the tests' findings, and
    /// the bias model the process noise was widened to if this reset did.
    AidReset {
        stream: Stream,
        reset: crate::navigator::ResetRecord,
        verdict: crate::navigator::StreakVerdict,
        widened: Option<crate::settings::BiasModel>,
    },
}

/// A sample whose values could be navigated on (the navigator checks the
/// rates; this is only what decides whether it may start a held init).
fn plausible(s: &ImuSample) -> bool {
    s.d_theta_rad
        .iter()
        .chain(&s.d_v_mps)
        .all(|x| x.is_finite())
        && (IMU_DT_RANGE_S.0..=IMU_DT_RANGE_S.1).contains(&s.dt_s)
}

/// Where an IMU sample falls relative to the navigator's time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    /// The next sample (at most `imu_gap_s` ahead): taken at once.
    Next,
    /// Behind, by at most the longest coast: refused.
    Stale,
    /// A gap or a jump: held until confirmed.
    Jump,
}

/// Where a session's outputs go.
pub trait Sink {
    /// Whether the solution of the IMU sample at `t_ns` is wanted; `must`
    /// marks a solution a decimating sink keeps whatever its interval: the
    /// first one, a frame switch, a reset or re-initialization at this
    /// sample, and the last one. A declined solution is not built (the
    /// filter runs on regardless). Default: every one.
    fn wants_solution(&mut self, _t_ns: u64, _must: bool) -> bool {
        true
    }
    /// A solution, in time order, one per accepted IMU sample that
    /// [`Sink::wants_solution`] accepted.
    fn solution(&mut self, s: &Solution);
    /// A decision worth a log line (rate-limit recurring ones).
    fn event(&mut self, _e: &Event) {}
    /// The smoother's record ([`crate::smoother`]), when the session keeps
    /// one ([`Session::keep_smoother_tape`]): whole records in order, each
    /// batch delivered before the solution that follows it.
    fn tape(&mut self, _records: &[u8]) {}
}

/// A sink that keeps nothing (for benches and tests that read the session).
#[derive(Debug, Default, Clone, Copy)]
pub struct Discard;

impl Sink for Discard {
    fn solution(&mut self, _s: &Solution) {}
}

/// A sink that keeps every solution and event (tests and tools; it allocates).
#[derive(Debug, Default, Clone)]
pub struct Collect {
    pub solutions: Vec<Solution>,
    pub events: Vec<Event>,
}

impl Sink for Collect {
    fn solution(&mut self, s: &Solution) {
        self.solutions.push(*s);
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
}

/// Counts of init messages and records.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InitCounters {
    pub received: u64,
    /// Used to start or re-initialize.
    pub used: u64,
    /// Refused: content, or stamped too far behind the IMU.
    pub rejected: u64,
    /// Superseded by a newer init before use, or never reached by the IMU.
    pub not_used: u64,
}

/// Everything a session needs to know besides its inputs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SessionSettings {
    pub navigator: NavigatorConfig,
    /// Initial state when no init message or record arrives (`[init]`).
    pub init: Option<InitSettings>,
    /// Stationary coarse alignment over this many seconds of IMU data after
    /// the init (its position kept, its attitude replaced).
    pub align_s: Option<f64>,
    /// A checkpoint is resumed only when the first IMU sample is at most
    /// this long after it (ns).
    pub resume_max_age_ns: u64,
}

/// Counts sequence gaps of one stream (samples lost upstream or overwritten).
#[derive(Debug, Clone, Copy, Default)]
struct SeqTracker {
    next: Option<u64>,
    gaps: u64,
}

impl SeqTracker {
    /// Notes `seq`; returns the sequence number expected instead when some
    /// were skipped.
    fn see(&mut self, seq: u64) -> Option<u64> {
        let skipped = self.next.filter(|n| seq > *n);
        if let Some(n) = skipped {
            self.gaps = self.gaps.saturating_add(seq - n);
        }
        self.next = Some(seq.wrapping_add(1));
        skipped
    }
}

/// The session. See the module documentation.
#[derive(Debug, Clone)]
pub struct Session {
    settings: SessionSettings,
    nav: Option<Navigator>,
    /// The integrity test's reference: a navigator fed every input but the
    /// samples of the aids that are not autonomous (from the first tested
    /// sample on).
    reference: Option<Navigator>,
    /// The integrity state of each aid (only those that are not
    /// autonomous are ever tested).
    integrity: PerAid<Monitor>,
    /// Whether navigators keep the smoother's record.
    smoother_tape: bool,
    /// Alignment in progress: the init it started from and the accumulator.
    aligning: Option<(InitState, AlignmentAccumulator)>,
    /// The newest sample of each aid received during the alignment: a
    /// MEMS IMU takes its heading from those that observe it.
    align_samples: PerAid<Option<AidSample>>,
    /// A checkpoint to resume from if the IMU continues from it.
    resume: Option<Checkpoint>,
    /// The newest init not yet applied (ahead of the IMU, or before the start).
    held_init: Option<InitState>,
    queue: AidQueue,
    candidates: [ImuSample; TIME_JUMP_CONFIRM],
    n_candidates: usize,
    /// Counts of what never reached the navigator (refused or not used here).
    outside: PerStream<StreamCounters>,
    seq: PerStream<SeqTracker>,
    inits: InitCounters,
    /// The newest integrated sample's solution is still to be emitted.
    solution_pending: bool,
    /// (switch count, reset count, re-initializations) at the last emitted
    /// or declined solution: a change marks the next one as a must.
    marks: Option<(u32, u32, u32)>,
    imu_lost: bool,
    resumed: bool,
    reinits: u32,
    resyncs: u64,
    repairs_seen: u64,
    alignment: Option<Alignment>,
    /// How the attitude of the init the navigator runs from was found
    /// (the status says; given after a checkpoint's resume).
    init_method: InitMethod,
    first_t_ns: Option<u64>,
    last_imu_t_ns: u64,
}

impl Session {
    pub fn new(settings: SessionSettings) -> Self {
        Self {
            settings,
            nav: None,
            reference: None,
            integrity: PerAid::default(),
            aligning: None,
            align_samples: PerAid::default(),
            resume: None,
            held_init: None,
            queue: AidQueue::new(),
            candidates: [ImuSample::default(); TIME_JUMP_CONFIRM],
            n_candidates: 0,
            outside: PerStream::default(),
            seq: PerStream::default(),
            inits: InitCounters::default(),
            solution_pending: false,
            marks: None,
            imu_lost: false,
            smoother_tape: false,
            resumed: false,
            reinits: 0,
            resyncs: 0,
            repairs_seen: 0,
            alignment: None,
            init_method: InitMethod::Given,
            first_t_ns: None,
            last_imu_t_ns: 0,
        }
    }

    /// Offers a checkpoint to resume from (before the first IMU sample).
    /// Its content is checked here ([`Checkpoint::validate`]): one that is
    /// intact but absurd (a zero quaternion, negative variances) is refused.
    pub fn offer_checkpoint(&mut self, c: Checkpoint) -> Result<(), CheckpointError> {
        c.validate()?;
        if self.nav.is_none() {
            self.resume = Some(c);
        }
        Ok(())
    }

    /// The navigator, once navigation has started.
    pub fn navigator(&self) -> Option<&Navigator> {
        self.nav.as_ref()
    }

    /// The alignment, when one was solved.
    pub fn alignment(&self) -> Option<&Alignment> {
        self.alignment.as_ref()
    }

    pub fn init_counters(&self) -> InitCounters {
        self.inits
    }

    /// Re-initializations so far (inits applied while navigating).
    pub fn reinits(&self) -> u32 {
        self.reinits
    }

    /// Confirmed time jumps of the IMU.
    pub fn time_resyncs(&self) -> u64 {
        self.resyncs
    }

    /// Sensor time of the start of navigation and of the newest IMU sample
    /// handled (ns).
    pub fn span_ns(&self) -> (u64, u64) {
        let first = self.first_t_ns.unwrap_or(0);
        (first, self.last_imu_t_ns.max(first))
    }

    /// True while the session waits for an alignment to complete.
    pub fn aligning(&self) -> bool {
        self.aligning.is_some()
    }

    /// Handles one input, in arrival order ([`Session::arrived`] then
    /// [`Session::handle`]).
    pub fn push(&mut self, input: Input<'_>, sink: &mut impl Sink) {
        if let Some(e) = self.arrived(&input) {
            sink.event(&e);
        }
        self.handle(input, sink);
    }

    /// Notes an input's sequence number in arrival order (sequence gaps
    /// count samples lost before they reached the session). A driver that
    /// reorders the inputs of a cycle calls this as it receives them and
    /// [`Session::handle`] in its order.
    pub fn arrived(&mut self, input: &Input<'_>) -> Option<Event> {
        let (stream, seq) = match input {
            Input::Imu(x) => (Stream::Imu, x.seq),
            Input::Aid(x) => (stream_of(x), x.seq()),
            Input::Init(_) => return None,
        };
        self.seq
            .get_mut(stream)
            .see(seq)
            .map(|expected| Event::SequenceGap {
                stream,
                expected,
                seq,
            })
    }

    /// Decides on one input (its arrival already noted).
    pub fn handle(&mut self, input: Input<'_>, sink: &mut impl Sink) {
        match input {
            Input::Imu(s) => self.push_imu(s, sink),
            Input::Aid(x) => self.push_aid(*x, sink),
            Input::Init(i) => self.push_init(i, sink),
        }
    }

    /// Fuses the aids stamped up to the navigator's time and emits the
    /// newest sample's solution, for a tool that reads the state after an
    /// epoch's aids. Drivers need not call it: the session does both when
    /// the next IMU sample arrives. The live loop must not call it at the
    /// end of a cycle: an aid of the sample's own time stamp that arrives
    /// in the next cycle would then miss the solution (and be fused in
    /// another order), and live would no longer equal `batch` bit for bit.
    pub fn flush(&mut self, sink: &mut impl Sink) {
        self.fuse_due(sink);
        self.emit_pending(false, sink);
    }

    /// Keeps the record a smoother needs from the next navigator on (and
    /// the current one's from now), delivered through [`Sink::tape`]. For
    /// `batch --smooth`; the live loop keeps none.
    pub fn keep_smoother_tape(&mut self) {
        self.smoother_tape = true;
        self.enable_tape();
    }

    fn enable_tape(&mut self) {
        if self.smoother_tape
            && let Some(n) = &mut self.nav
        {
            n.enable_tape();
        }
    }

    /// The IMU stopped (live: no sample for several periods, by the wall
    /// clock). Reported only: status marks the IMU lost and no aid fresh
    /// until the next IMU sample. Nothing is decided on it: aids ahead of
    /// the IMU keep waiting for it (within [`AID_QUEUE`] and
    /// [`MAX_AID_LEAD_NS`]), as `batch` has them wait, so a late IMU
    /// changes no solution.
    pub fn imu_lost(&mut self, _sink: &mut impl Sink) {
        self.imu_lost = true;
    }

    /// The end of the inputs: the pending solution is emitted (always, as
    /// the last one) and every held input is accounted for (waiting aids as
    /// ahead of the IMU, time-jump candidates as rejected, a held init as
    /// not used).
    pub fn finish(&mut self, sink: &mut impl Sink) {
        self.fuse_due(sink);
        self.emit_pending(true, sink);
        if let Some(n) = &mut self.nav {
            n.end_tape();
            n.drain_tape(|r| sink.tape(r));
        }
        self.drain_queue(sink);
        self.refute_candidates(sink);
        if let Some(i) = self.held_init.take() {
            self.inits.not_used += 1;
            sink.event(&Event::InitSuperseded { t_ns: i.t_ns });
        }
    }

    /// A checkpoint of the running state.
    pub fn checkpoint(&self) -> Option<Checkpoint> {
        self.nav.as_ref().map(Navigator::checkpoint)
    }

    /// Health record: the navigator's, with what the session held back,
    /// sequence gaps, resume and re-initialization counts and IMU loss
    /// (loop timing is the live driver's).
    pub fn status(&self) -> Status {
        let mut s = self.nav.as_ref().map(Navigator::status).unwrap_or_default();
        for k in Stream::ALL {
            let c = s.counters_mut(k);
            let o = self.outside.get(k);
            c.received += o.received;
            c.rejected_invalid += o.rejected_invalid;
            c.rejected_time += o.rejected_time;
            c.not_used += o.not_used;
            c.seq_gaps = self.seq.get(k).gaps;
        }
        // Candidates held for a time-jump decision and aids waiting for the
        // IMU are received but not yet decided: counted as not used until
        // they are.
        let imu = s.counters_mut(Stream::Imu);
        imu.received += self.n_candidates as u64;
        imu.not_used += self.n_candidates as u64;
        for a in self.queue.items[..self.queue.len].iter().flatten() {
            let c = s.counters_mut(stream_of(a));
            c.received += 1;
            c.not_used += 1;
        }
        for (k, m) in self.integrity.iter() {
            if k.decl().autonomous {
                continue;
            }
            let a = &mut s.aids[k as usize];
            a.integrity_ratio = m.last_ratio.unwrap_or(0.0);
            a.excluded = u8::from(m.excluded);
            a.exclusion_cause = m.cause;
            a.excluded_since_t_ns = m.excluded_since_ns;
            a.exclusions = m.exclusions;
            a.integrity_state = match m.available {
                None => msgs::integrity_state::NOT_TESTED,
                Some(true) => msgs::integrity_state::TESTED,
                Some(false) => msgs::integrity_state::UNAVAILABLE,
            };
        }
        s.flags |= self.integrity_flags();
        s.resumed = u8::from(self.resumed);
        (s.init_method, s.init_heading_aid) = self.init_method.to_wire();
        s.reinit_count = self.reinits;
        if self.imu_lost {
            use msgs::solution_flags as f;
            s.flags |= f::IMU_LOST;
            s.flags &= !AidKind::all_fresh_flags();
            for a in &mut s.aids {
                a.fresh = 0;
            }
        }
        if self.nav.is_none() {
            s.flags &= !msgs::solution_flags::ALIGNED;
        }
        s
    }

    /// The solution flags of the aids the integrity test excludes now, and
    /// of those fused untested (their test unavailable): what the session
    /// adds to each solution's flags.
    pub fn integrity_flags(&self) -> u32 {
        let mut f = 0;
        for (k, m) in self.integrity.iter() {
            if m.excluded {
                f |= k.decl().excluded_flag;
            } else if m.available == Some(false) {
                f |= k.decl().untested_flag;
            }
        }
        f
    }

    /// The integrity state of aid `k` (for tools; the status reports it).
    pub fn integrity(&self, k: AidKind) -> &Monitor {
        &self.integrity[k]
    }

    /// The work of the session's navigators so far ([`Navigator::work`]:
    /// the main one's and the reference's since it was last copied).
    pub fn work(&self) -> u64 {
        self.nav.as_ref().map_or(0, Navigator::work)
            + self.reference.as_ref().map_or(0, Navigator::work)
    }

    /// The integrity test's reference navigator, once an aid has been tested.
    pub fn reference(&self) -> Option<&Navigator> {
        self.reference.as_ref()
    }

    fn count_outside(&mut self, stream: Stream, f: impl FnOnce(&mut StreamCounters)) {
        let c = self.outside.get_mut(stream);
        c.received += 1;
        f(c);
    }

    // ---- inits -------------------------------------------------------

    fn push_init(&mut self, i: &InitState, sink: &mut impl Sink) {
        self.inits.received += 1;
        if let Err(reason) = check_init(i) {
            self.reject_init(i, reason, sink);
            return;
        }
        match &self.nav {
            Some(n) if i.t_ns <= n.t_ns() => {
                let age_ns = n.t_ns() - i.t_ns;
                let limit_s = self.settings.navigator.filter.imu_max_coast_s;
                if age_ns as f64 * 1e-9 > limit_s {
                    let reason = InputRejection::TooLate {
                        t_ns: i.t_ns,
                        age_s: age_ns as f64 * 1e-9,
                        limit_s,
                    };
                    self.reject_init(i, reason, sink);
                    return;
                }
                self.flush(sink);
                self.apply_init(*i, sink);
            }
            _ => {
                if let Some(old) = self.held_init.replace(*i) {
                    self.inits.not_used += 1;
                    sink.event(&Event::InitSuperseded { t_ns: old.t_ns });
                }
                if self.nav.is_some() {
                    sink.event(&Event::InitHeld {
                        t_ns: i.t_ns,
                        imu_t_ns: self.last_imu_t_ns,
                    });
                }
            }
        }
    }

    fn reject_init(&mut self, i: &InitState, reason: InputRejection, sink: &mut impl Sink) {
        self.inits.rejected += 1;
        sink.event(&Event::InitRejected {
            t_ns: i.t_ns,
            seq: i.seq,
            reason,
        });
    }

    /// Starts, aligns or re-initializes from `init`.
    fn apply_init(&mut self, init: InitState, sink: &mut impl Sink) {
        self.inits.used += 1;
        self.resume = None;
        if let Some(align_s) = self.settings.align_s {
            // The running navigator (if any) stops; its counters carry over
            // to the navigator the alignment starts.
            self.aligning = Some((init, AlignmentAccumulator::default()));
            self.align_samples = PerAid::default();
            sink.event(&Event::AlignmentStarted {
                t_ns: init.t_ns,
                duration_s: align_s,
            });
            return;
        }
        self.start_or_reinit(init, InitSource::Message, sink);
    }

    fn start_or_reinit(&mut self, init: InitState, source: InitSource, sink: &mut impl Sink) {
        self.init_method = init.init_method().unwrap_or(InitMethod::Given);
        let cfg = &self.settings.navigator;
        match self.nav.as_mut() {
            Some(n) => {
                n.reinitialize(&init, cfg);
                // The reference starts again from the new state, which
                // holds no aid's sample.
                if self.reference.is_some() {
                    self.reference = Some(n.reference_copy());
                }
                for (_, m) in self.integrity.iter_mut() {
                    m.restart_clock();
                }
                self.reinits += 1;
                sink.event(&Event::Reinitialized { t_ns: init.t_ns });
            }
            None => {
                self.nav = Some(Navigator::new(&init, cfg));
                self.enable_tape();
                self.first_t_ns.get_or_insert(init.t_ns);
                sink.event(&Event::Started {
                    source,
                    t_ns: init.t_ns,
                });
            }
        }
        self.resumed = false;
        self.after_time_base_change(sink);
    }

    /// After the navigator's time moved (init, resync): waiting aids and
    /// time-jump candidates are judged again against it.
    fn after_time_base_change(&mut self, sink: &mut impl Sink) {
        let n = self.n_candidates;
        self.n_candidates = 0;
        let held = self.candidates;
        for s in &held[..n] {
            if self.fits(s) {
                self.integrate(s, sink);
            } else {
                self.reject_imu_outside(s, self.time_reason(s), sink);
            }
        }
    }

    /// The first IMU sample with no navigator: resume, held init or
    /// configuration, in that precedence.
    fn start(&mut self, s: &ImuSample, sink: &mut impl Sink) {
        if let Some(c) = self.resume.take() {
            let continues = s.t_ns > c.t_ns && s.t_ns - c.t_ns <= self.settings.resume_max_age_ns;
            let newer_init = self.held_init.is_some_and(|i| i.t_ns > c.t_ns);
            if continues && !newer_init {
                self.nav = Some(Navigator::from_checkpoint(&c, &self.settings.navigator));
                self.enable_tape();
                self.resumed = true;
                self.first_t_ns.get_or_insert(c.t_ns);
                // An init no newer than the checkpoint describes an older state.
                if self.held_init.take().is_some() {
                    self.inits.not_used += 1;
                }
                sink.event(&Event::Started {
                    source: InitSource::Checkpoint,
                    t_ns: c.t_ns,
                });
                return;
            }
            sink.event(&Event::CheckpointNotUsed {
                checkpoint_t_ns: c.t_ns,
                first_imu_t_ns: s.t_ns,
                newer_init,
            });
        }
        if let Some(i) = self.held_init.filter(|i| i.t_ns < s.t_ns) {
            self.held_init = None;
            self.apply_init(i, sink);
            return;
        }
        // A held init further ahead than the longest coast would leave the
        // IMU unused for that long: the configuration's init starts instead
        // (the held init still applies once the IMU reaches it).
        let limit_ns = self.settings.navigator.filter.imu_max_coast_s * 1e9;
        let init_usable = self
            .held_init
            .is_some_and(|i| ((i.t_ns - s.t_ns.min(i.t_ns)) as f64) <= limit_ns);
        if !init_usable
            && self.aligning.is_none()
            && let Some(ci) = &self.settings.init
        {
            // No init at all: start from the configuration, one sample back.
            let dt_ns = (s.dt_s.clamp(IMU_DT_RANGE_S.0, IMU_DT_RANGE_S.1) * 1e9).round() as u64;
            let init = ci.to_init(s.t_ns.saturating_sub(dt_ns));
            if let Some(align_s) = self.settings.align_s {
                self.aligning = Some((init, AlignmentAccumulator::default()));
                self.align_samples = PerAid::default();
                sink.event(&Event::AlignmentStarted {
                    t_ns: init.t_ns,
                    duration_s: align_s,
                });
            } else {
                self.start_or_reinit(init, InitSource::Config, sink);
            }
        }
    }

    // ---- IMU ---------------------------------------------------------

    fn push_imu(&mut self, s: &ImuSample, sink: &mut impl Sink) {
        self.imu_lost = false;
        self.flush(sink);
        // A held init applies before the sample that continues right after
        // it (a plausible sample at most `imu_gap_s` later): a stray
        // sample far ahead must not let a stray init take over the state.
        let gap_ns = self.settings.navigator.filter.imu_gap_s * 1e9;
        if self.nav.is_some()
            && plausible(s)
            && let Some(i) = self
                .held_init
                .filter(|i| i.t_ns < s.t_ns && ((s.t_ns - i.t_ns) as f64) <= gap_ns)
        {
            self.held_init = None;
            self.apply_init(i, sink);
        }
        if self.nav.is_none() && self.aligning.is_none() {
            self.start(s, sink);
        }
        if self.aligning.is_some() {
            self.align(s, sink);
            return;
        }
        if self.nav.is_none() {
            self.count_outside(Stream::Imu, |c| c.not_used += 1);
            return;
        }
        match self.place(s) {
            Place::Next => {
                self.refute_candidates(sink);
                self.integrate(s, sink);
            }
            Place::Stale => {
                let reason = self.time_reason(s);
                self.reject_imu_outside(s, reason, sink);
            }
            Place::Jump => self.candidate(s, sink),
        }
    }

    /// Where a sample falls on the navigator's time line.
    fn place(&self, s: &ImuSample) -> Place {
        let Some(n) = &self.nav else {
            return Place::Jump;
        };
        let f = &self.settings.navigator.filter;
        let now = n.t_ns();
        if s.t_ns > now {
            if ((s.t_ns - now) as f64) <= f.imu_gap_s * 1e9 {
                Place::Next
            } else {
                Place::Jump
            }
        } else if ((now - s.t_ns) as f64) <= f.imu_max_coast_s * 1e9 {
            Place::Stale
        } else {
            Place::Jump
        }
    }

    /// A sample the navigator's time line can take without a resync: after
    /// its time, by at most the longest coast.
    fn fits(&self, s: &ImuSample) -> bool {
        let Some(n) = &self.nav else { return false };
        let limit_ns = self.settings.navigator.filter.imu_max_coast_s * 1e9;
        s.t_ns > n.t_ns() && ((s.t_ns - n.t_ns()) as f64) <= limit_ns
    }

    fn time_reason(&self, s: &ImuSample) -> InputRejection {
        let prev_ns = self.nav.as_ref().map_or(0, Navigator::t_ns);
        if s.t_ns <= prev_ns {
            InputRejection::TimeNotIncreasing {
                t_ns: s.t_ns,
                prev_ns,
            }
        } else {
            InputRejection::TimeJump {
                t_ns: s.t_ns,
                gap_s: (s.t_ns - prev_ns) as f64 * 1e-9,
                limit_s: self.settings.navigator.filter.imu_max_coast_s,
            }
        }
    }

    /// Holds a sample that does not fit; confirms a time jump when enough
    /// consistent ones follow each other.
    fn candidate(&mut self, s: &ImuSample, sink: &mut impl Sink) {
        let consistent = self.n_candidates > 0 && {
            let prev = &self.candidates[self.n_candidates - 1];
            let spacing_s = s.t_ns.saturating_sub(prev.t_ns) as f64 * 1e-9;
            let limit_s = self.settings.navigator.filter.imu_gap_s.max(2.0 * s.dt_s);
            s.t_ns > prev.t_ns && spacing_s <= limit_s
        };
        if !consistent {
            self.refute_candidates(sink);
        }
        self.candidates[self.n_candidates] = *s;
        self.n_candidates += 1;
        if self.n_candidates < TIME_JUMP_CONFIRM {
            return;
        }
        // Confirmed. A held init between the navigator's time and the new
        // samples starts that new stretch (a new flight or pass whose first
        // samples were lost).
        let first = self.candidates[0];
        let now = self.nav.as_ref().map_or(0, Navigator::t_ns);
        if let Some(i) = self
            .held_init
            .filter(|i| i.t_ns > now && i.t_ns < first.t_ns)
        {
            self.held_init = None;
            self.apply_init(i, sink);
            return;
        }
        // A gap the navigator can coast: it does, from the first candidate on.
        if self.fits(&first) {
            self.after_time_base_change(sink);
            return;
        }
        // A jump of the clock: the navigator continues on the new time base.
        let dt_ns = (first.dt_s.clamp(IMU_DT_RANGE_S.0, IMU_DT_RANGE_S.1) * 1e9).round() as u64;
        let to = first.t_ns.saturating_sub(dt_ns);
        let Some(n) = self.nav.as_mut() else { return };
        let from = n.t_ns();
        n.resync(to);
        if let Some(r) = &mut self.reference {
            r.resync(to);
        }
        // The tests' intervals start again on the new time base.
        for (_, m) in self.integrity.iter_mut() {
            m.restart_clock();
        }
        self.resyncs += 1;
        sink.event(&Event::TimeResync {
            from_t_ns: from,
            to_t_ns: to,
        });
        // Aids waiting on the old time base can no longer be placed.
        self.drain_queue(sink);
        self.after_time_base_change(sink);
    }

    /// Time-jump candidates refuted by a fitting sample (or the end).
    fn refute_candidates(&mut self, sink: &mut impl Sink) {
        let n = self.n_candidates;
        self.n_candidates = 0;
        let held = self.candidates;
        for s in &held[..n] {
            self.reject_imu_outside(s, self.time_reason(s), sink);
        }
    }

    fn reject_imu_outside(&mut self, s: &ImuSample, reason: InputRejection, sink: &mut impl Sink) {
        self.count_outside(Stream::Imu, |c| c.rejected_time += 1);
        sink.event(&Event::Rejected {
            stream: Stream::Imu,
            t_ns: s.t_ns,
            seq: s.seq,
            reason,
        });
    }

    /// Feeds one fitting sample to the navigator after the aids stamped up
    /// to the previous one, and emits its solution at once: one per sample,
    /// also when several are integrated in one push (confirmed candidates).
    /// The solution of a sample thus holds every aid stamped before it,
    /// whichever cycle of the live loop brought them, and aids stamped
    /// within its own interval show from the next sample on: the outputs
    /// depend only on the order of the inputs, not on how a driver groups
    /// them.
    fn integrate(&mut self, s: &ImuSample, sink: &mut impl Sink) {
        self.flush(sink);
        let Some(n) = self.nav.as_mut() else { return };
        if let Some(r) = &mut self.reference {
            // The same sample, the same decision (the same time line).
            let _ = r.on_imu(s);
        }
        match n.on_imu(s) {
            Ok(out) => {
                self.last_imu_t_ns = s.t_ns;
                self.solution_pending = true;
                if let Some(sw) = out.switch {
                    sink.event(&Event::Switch(sw));
                }
            }
            Err(reason) => sink.event(&Event::Rejected {
                stream: Stream::Imu,
                t_ns: s.t_ns,
                seq: s.seq,
                reason,
            }),
        }
        self.check_repairs(sink);
    }

    /// Emits the newest sample's solution if it is pending and the sink
    /// wants it (`last`: the end of the inputs, always a must).
    fn emit_pending(&mut self, last: bool, sink: &mut impl Sink) {
        if !std::mem::take(&mut self.solution_pending) {
            return;
        }
        let Some(n) = &mut self.nav else { return };
        n.drain_tape(|r| sink.tape(r));
        let marks = (n.switch_count(), n.last_reset().count, self.reinits);
        let must = last || self.marks != Some(marks);
        self.marks = Some(marks);
        let excluded = self.integrity_flags();
        let Some(n) = &mut self.nav else { return };
        if sink.wants_solution(n.t_ns(), must) {
            let mut s = n.solution();
            s.flags |= excluded;
            sink.solution(&s);
            n.tape_solution(&s);
        }
    }

    fn check_repairs(&mut self, sink: &mut impl Sink) {
        if let Some(n) = &self.nav
            && n.covariance_repairs() > self.repairs_seen
        {
            self.repairs_seen = n.covariance_repairs();
            sink.event(&Event::CovarianceRepaired { t_ns: n.t_ns() });
        }
    }

    fn align(&mut self, s: &ImuSample, sink: &mut impl Sink) {
        let Some((init, acc)) = self.aligning.as_mut() else {
            return;
        };
        let finite = s
            .d_theta_rad
            .iter()
            .chain(&s.d_v_mps)
            .all(|x| x.is_finite());
        let ok =
            s.t_ns > init.t_ns && (IMU_DT_RANGE_S.0..=IMU_DT_RANGE_S.1).contains(&s.dt_s) && finite;
        if !ok {
            self.count_outside(Stream::Imu, |c| c.rejected_invalid += 1);
            return;
        }
        acc.add(&s.d_theta_rad.into(), &s.d_v_mps.into(), s.dt_s);
        self.count_outside(Stream::Imu, |c| c.accepted += 1);
        let need_s = self.settings.align_s.unwrap_or(0.0);
        let Some((init, acc)) = self.aligning.as_ref() else {
            return;
        };
        if acc.time_s() < need_s {
            return;
        }
        let nav = &self.settings.navigator;
        let samples = std::mem::take(&mut self.align_samples);
        let heading = |l: &Levelled| {
            best_heading(AidKind::ALL.into_iter().filter_map(|k| {
                let x = samples[k].as_ref()?;
                // An aid switched off, a sample stamped after the
                // alignment's end (a future stamp, 1e18 ns) or older than
                // its timeout does not align.
                let age_s = s.t_ns.saturating_sub(x.t_ns()) as f64 * 1e-9;
                if !nav.aids.has(k) || x.t_ns() > s.t_ns || age_s > nav.aid_settings.timeout_s[k] {
                    return None;
                }
                msgs::match_aid!(x, p => heading_of(p, l, &nav.aid_settings.own)).map(|r| (k, r))
            }))
        };
        let result = aligned_init(init, &nav.filter, acc, s.t_ns, heading);
        self.aligning = None;
        match result {
            Ok((aligned, a)) => {
                self.alignment = Some(a);
                sink.event(&Event::Aligned {
                    alignment: a,
                    init: aligned,
                });
                // Its `method` tells the navigator how the heading was found
                // (a magnetometer's heading error is that aid's persistent
                // error: `navigator::error_state`).
                self.start_or_reinit(aligned, InitSource::Message, sink);
            }
            Err(e) => sink.event(&Event::AlignmentFailed(e)),
        }
    }

    /// Whether the settings give an initial state (`[init]`), so that the
    /// first IMU sample starts navigation without an init message.
    pub fn has_config_init(&self) -> bool {
        self.settings.init.is_some()
    }

    /// Alignment still running at the end: how much IMU time it had.
    pub fn alignment_progress_s(&self) -> Option<f64> {
        self.aligning.as_ref().map(|(_, acc)| acc.time_s())
    }

    // ---- aids --------------------------------------------------------

    fn push_aid(&mut self, a: AidSample, sink: &mut impl Sink) {
        if let Some((init, _)) = &self.aligning {
            // Not fused (nothing navigates yet): kept for a heading, the
            // newest by stamp within the alignment's span (a sample
            // stamped beyond it, 1e18 ns, cannot displace a good one).
            let end_ns = init
                .t_ns
                .saturating_add((self.settings.align_s.unwrap_or(0.0) * 1e9) as u64);
            let newer = self.align_samples[a.kind()].is_none_or(|old| a.t_ns() >= old.t_ns());
            if a.t_ns() <= end_ns && newer {
                self.align_samples[a.kind()] = Some(a);
            }
        }
        let Some(n) = self.nav.as_ref().filter(|_| self.aligning.is_none()) else {
            self.count_outside(stream_of(&a), |c| c.not_used += 1);
            return;
        };
        let now = n.t_ns();
        if a.t_ns().saturating_sub(now) > MAX_AID_LEAD_NS {
            self.count_outside(stream_of(&a), |c| c.rejected_time += 1);
            sink.event(&Event::Rejected {
                stream: stream_of(&a),
                t_ns: a.t_ns(),
                seq: a.seq(),
                reason: InputRejection::AheadOfImu {
                    t_ns: a.t_ns(),
                    imu_ns: now,
                },
            });
            return;
        }
        if let Some(old) = self.queue.insert(a) {
            // The queue is full: the oldest is offered now (fused if the
            // IMU has reached it, else refused as ahead of the IMU).
            self.offer(&old, sink);
        }
    }

    /// The integrity settings of aid `k` when its samples are tested: an
    /// aid that is not autonomous, selected, with its test on.
    fn tested(&self, k: AidKind) -> Option<IntegritySettings> {
        let n = &self.settings.navigator;
        if k.decl().autonomous || !n.aids.has(k) {
            return None;
        }
        n.aid_settings.own.integrity(k).filter(|s| s.integrity)
    }

    /// The integrity test of a sample of a tested aid; whether the sample
    /// is barred from the main navigator (the aid excluded, or the sample
    /// untestable). A sample the navigator would not take to its model
    /// (late, a repeat) is not tested: the navigator refuses it for that.
    fn judge(&mut self, a: &AidSample, is: &IntegritySettings, sink: &mut impl Sink) -> bool {
        let Some(n) = self.nav.as_mut() else {
            return false;
        };
        if !n.aid_reaches_model(a) {
            return false;
        }
        let r = self.reference.get_or_insert_with(|| n.reference_copy());
        let k = a.kind();
        let threshold = self.integrity[k].threshold(a.t_ns(), is, k.decl().dof());
        let Some(test) = r.test_aid(a, is, threshold) else {
            // Refused content is counted as such by the navigator; a sample
            // whose S is not positive definite is not trusted.
            self.integrity[k].untestable();
            return true;
        };
        let m = &mut self.integrity[k];
        let readmit_ns = (is.readmit_after_s * 1e9).round() as u64;
        // Continuous agreement: no gap longer than the aid's timeout, nor
        // than the readmission time itself (a timeout set longer must not
        // let two fixes that far apart readmit; half of it would never
        // readmit a 1 Hz aid with a 1 s readmission time).
        let max_gap_ns = ((self.settings.navigator.aid_settings.timeout_s[k] * 1e9).round() as u64)
            .min(readmit_ns);
        let was = m.available;
        let verdict = m.decide(a.t_ns(), &test, readmit_ns, max_gap_ns);
        if m.available != was && (was.is_some() || !test.available()) {
            sink.event(&Event::IntegrityAvailability {
                stream: stream_of(a),
                t_ns: a.t_ns(),
                available: test.available(),
                protection_m: test.protection_m,
                alert_limit_m: test.alert_limit_m,
            });
        }
        let mut step = None;
        if verdict == Verdict::Exclude {
            // What the main navigator fused of the aid is dropped: it
            // continues from the reference (which keeps running, to judge
            // the aid and any other that is not autonomous).
            if let Some(sw) = n.adopt(r.reference_copy()) {
                sink.event(&Event::Switch(sw));
            }
            step = Some(*n.last_reset());
        }
        sink.event(&Event::Integrity {
            stream: stream_of(a),
            t_ns: a.t_ns(),
            test,
            verdict,
            exclusions: m.exclusions,
            step,
        });
        matches!(
            verdict,
            Verdict::Exclude | Verdict::Refuse | Verdict::Unverifiable
        )
    }

    fn offer(&mut self, a: &AidSample, sink: &mut impl Sink) {
        let barred = match self.tested(a.kind()) {
            Some(is) => self.judge(a, &is, sink),
            None => false,
        };
        if a.kind().decl().autonomous
            && let Some(r) = &mut self.reference
        {
            let _ = r.on_aid(a);
        }
        let Some(n) = self.nav.as_mut() else {
            self.count_outside(stream_of(a), |c| c.not_used += 1);
            return;
        };
        let resets = n.aid_resets();
        let result = if barred {
            n.on_barred_aid(a)
        } else {
            n.on_aid(a)
        };
        match result {
            // Not used (the aid disabled) or undone as invalid: counted in
            // the status, but no update to report.
            Ok(o) if !o.gated => {}
            Ok(_) => {
                let status = n.aid_status(a.kind());
                let geo = n.state().geodetic();
                sink.event(&Event::AidUpdate {
                    stream: stream_of(a),
                    t_ns: a.t_ns(),
                    status,
                    lat_rad: geo.lat_rad,
                    h_m: geo.h_m,
                });
            }
            Err(reason) => sink.event(&Event::Rejected {
                stream: stream_of(a),
                t_ns: a.t_ns(),
                seq: a.seq(),
                reason,
            }),
        }
        if n.aid_resets() != resets
            && let Some(verdict) = n.last_aid_reset()
        {
            sink.event(&Event::AidReset {
                stream: stream_of(a),
                reset: *n.last_reset(),
                verdict: *verdict,
                widened: n.last_aid_reset_widened().copied(),
            });
        }
        self.check_repairs(sink);
    }

    /// Fuses the waiting aids the IMU has reached, in (time, stream) order:
    /// whatever order they arrived in, the aids between two IMU samples are
    /// fused in the same order (a live cycle drains its topics one after
    /// the other, so arrival order across streams is not the publishers').
    fn fuse_due(&mut self, sink: &mut impl Sink) {
        let Some(now) = self.nav.as_ref().map(Navigator::t_ns) else {
            return;
        };
        while self.queue.front_t_ns().is_some_and(|t| t <= now) {
            if let Some(a) = self.queue.pop_front() {
                self.offer(&a, sink);
            }
        }
    }

    fn drain_queue(&mut self, sink: &mut impl Sink) {
        while let Some(a) = self.queue.pop_front() {
            self.offer(&a, sink);
        }
    }
}

/// Runs a session over navlog records in memory (header settings are the
/// caller's: pass the effective settings): every solution and event, and
/// the final status. For tools and tests; it allocates the result.
pub fn navigate(records: &[msgs::navlog::Record], settings: SessionSettings) -> (Collect, Status) {
    let mut session = Session::new(settings);
    let mut sink = Collect::default();
    for r in records {
        if let Some(input) = Input::from_record(r) {
            session.push(input, &mut sink);
        }
    }
    session.finish(&mut sink);
    (sink, session.status())
}

/// An aid sample's heading for an alignment, with its own settings.
fn heading_of<A: OwnOf>(
    x: &A,
    l: &Levelled,
    own: &OwnAidSettings,
) -> Option<Result<HeadingFix, AidError>> {
    x.align_heading(l, A::own(own))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn init() -> InitState {
        let geo = crate::earth::Geodetic::from_deg(80.0, 30.0, 18_000.0);
        let c_e_g = crate::frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let q = crate::frames::quat_from_dcm(&c_e_g.transpose()).into_inner();
        InitState {
            t_ns: 1_000_000_000,
            r_e_m: crate::earth::geodetic_to_ecef(&geo).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            sigma_pos_h_m: 10.0,
            sigma_pos_v_m: 10.0,
            sigma_vel_h_mps: 0.1,
            sigma_vel_v_mps: 0.1,
            sigma_tilt_rad: 3e-4,
            sigma_heading_rad: 1e-3,
            ..Default::default()
        }
    }

    #[test]
    fn an_absurd_checkpoint_is_refused_whoever_offers_it() {
        let good = Navigator::new(&init(), &NavigatorConfig::default()).checkpoint();
        let mut s = Session::new(SessionSettings::default());
        s.offer_checkpoint(good)
            .expect("a navigator's own checkpoint");
        let mut zero_q = good;
        zero_q.q_b_e = [0.0; 4];
        let mut negative = good;
        negative.p[0] = -1.0;
        let mut nan = good;
        nan.r_e_m[2] = f64::NAN;
        for (what, bad) in [("quaternion", zero_q), ("variance", negative), ("NaN", nan)] {
            let mut s = Session::new(SessionSettings::default());
            assert!(s.offer_checkpoint(bad).is_err(), "{what} accepted");
            assert!(s.resume.is_none(), "{what} kept");
        }
    }

    /// An init's method bytes are checked like the rest of it: bytes no
    /// sender writes refuse it with the field named; every known method
    /// is taken and the status says it (an init from outside may say it
    /// was aligned; the navigator reports what it was handed).
    #[test]
    fn an_init_with_an_unknown_method_is_refused_naming_the_field() {
        #[derive(Default)]
        struct Rejections(Vec<String>);
        impl Sink for Rejections {
            fn solution(&mut self, _: &Solution) {}
            fn event(&mut self, e: &Event) {
                if let Event::InitRejected { reason, .. } = e {
                    self.0.push(reason.to_string());
                }
            }
        }
        let cases = [
            (3u8, 0u8, Some("init.method = 3")),
            (255, 0, Some("init.method = 255")),
            (1, 4, Some("init.heading_aid = 4")),
            (0, 1, Some("init.heading_aid = 1")),
            (2, msgs::AID_COUNT as u8, Some("init.heading_aid = 7")),
            (2, 255, Some("init.heading_aid = 255")),
            (0, 0, None),
            (1, 0, None),
            (2, AidKind::Mag as u8, None),
        ];
        for (method, heading_aid, refused) in cases {
            let mut s = Session::new(SessionSettings::default());
            let mut sink = Rejections::default();
            let i = InitState {
                method,
                heading_aid,
                ..init()
            };
            s.push(Input::Init(&i), &mut sink);
            s.push(
                Input::Imu(&ImuSample {
                    t_ns: i.t_ns + 10_000_000,
                    dt_s: 0.01,
                    ..Default::default()
                }),
                &mut sink,
            );
            match refused {
                Some(want) => {
                    assert_eq!(sink.0.len(), 1, "{method}/{heading_aid}: {:?}", sink.0);
                    assert!(sink.0[0].starts_with(want), "{}", sink.0[0]);
                    assert!(s.navigator().is_none());
                }
                None => {
                    assert!(sink.0.is_empty(), "{method}/{heading_aid}: {:?}", sink.0);
                    assert!(s.navigator().is_some());
                    let st = s.status();
                    assert_eq!((st.init_method, st.init_heading_aid), (method, heading_aid));
                }
            }
        }
    }
}
