//! Wall-clock replay and the flight recorder over iceoryx2.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use msgs::navlog::{ReadReport, Record};
use msgs::service::Topic;
use msgs::{
    AidSample, EffectiveSettings, ImuSample, InitState, PerStream, STREAM_COUNT, Solution, Status,
    Stream,
};
use polarnav_ipc::{TopicPublisher, TopicSubscriber, TransportConfig, TransportError};

use crate::pieces::{McapProvenance, Opener, Output, Pieces};
use polarnav_eval::logfile::{LoadError, LogReader};

/// Pacing statistics of a replay (lateness of each publication behind its deadline).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pacing {
    pub published: u64,
    /// Samples published per stream (the IMU, then each aid).
    pub per_stream: PerStream<u64>,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
    /// Sends that found a subscriber's input buffer full and waited for
    /// room, and the longest wait (µs).
    pub waits: u64,
    pub max_wait_us: f64,
    /// Deliveries dropped after waiting [`REPLAY_MAX_WAIT`] (one per
    /// subscriber and sample): 0 unless a reader stopped reading.
    pub lost: u64,
}

/// How long a replay waits for room in a subscriber's full input buffer
/// before it drops that sample for that subscriber (and counts it).
pub const REPLAY_MAX_WAIT: Duration = Duration::from_secs(2);

impl Pacing {
    /// The one-line summary `play` prints when it ends.
    pub fn summary(&self) -> String {
        let counts: Vec<String> = self
            .per_stream
            .iter()
            .map(|(s, n)| format!("{} {n}", s.name()))
            .collect();
        format!(
            "play: {} samples published ({}); pacing lateness p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs; full input buffers: {} waits (longest {:.1} ms), {} samples lost",
            self.published,
            counts.join(", "),
            self.p50_us,
            self.p99_us,
            self.max_us,
            self.waits,
            self.max_wait_us * 1e-3,
            self.lost
        )
    }

    /// The per-stream counts read back from text containing a
    /// [`Pacing::summary`] line (e.g. `play`'s captured stdout).
    pub fn published_in(text: &str) -> Option<PerStream<u64>> {
        let line = text.lines().find(|l| l.starts_with("play: "))?;
        let inner = line.split_once('(')?.1.split(')').next()?;
        let counts: Vec<u64> = inner
            .split(", ")
            .map(|kv| kv.split_whitespace().nth(1)?.parse().ok())
            .collect::<Option<_>>()?;
        let counts: [u64; STREAM_COUNT] = counts.try_into().ok()?;
        Some(PerStream(counts))
    }
}

/// A sensor record of the log, owned (an aid's sample stays boxed, as the
/// record has it).
#[derive(Debug, Clone)]
enum Sensor {
    Imu(ImuSample),
    Aid(Box<AidSample>),
}

impl Sensor {
    /// The sensor record of `r`; `None` for any other record.
    fn of(r: Record) -> Option<Self> {
        match r {
            Record::Imu(x) => Some(Sensor::Imu(x)),
            Record::Aid(x) => Some(Sensor::Aid(x)),
            _ => None,
        }
    }

    fn t_ns(&self) -> u64 {
        match self {
            Sensor::Imu(x) => x.t_ns,
            Sensor::Aid(x) => x.t_ns(),
        }
    }

    /// Its stream.
    fn stream(&self) -> Stream {
        match self {
            Sensor::Imu(_) => Stream::Imu,
            Sensor::Aid(x) => Stream::Aid(x.kind()),
        }
    }
}

/// Waits until `deadline`: sleeps, then spins the last 200 µs for precision.
fn wait_until(deadline: Instant) {
    loop {
        let now = Instant::now();
        if now >= deadline {
            return;
        }
        let left = deadline - now;
        if left > Duration::from_micros(300) {
            std::thread::sleep(left - Duration::from_micros(200));
        } else {
            std::hint::spin_loop();
        }
    }
}

/// What `play` needs of a log before its first pass, from one streaming
/// read of the file (memory holds one record at a time).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LogOutline {
    /// The first init record: every pass publishes it first.
    pub init: Option<InitState>,
    /// IMU records: each pass moves the IMU sequence numbers on by this many.
    pub imu: u64,
    /// The latest time stamp of a sensor record (the passes' length).
    pub last_sensor_t_ns: Option<u64>,
    /// What the read skipped (every pass reads the same intact records).
    pub report: ReadReport,
}

impl LogOutline {
    /// Reads `path` through once.
    pub fn read(path: &Path) -> Result<Self, LoadError> {
        let mut r = LogReader::open(path)?;
        let mut o = Self::default();
        while let Some(rec) = r.next_record()? {
            if let Record::Init(x) = &rec {
                o.init.get_or_insert(*x);
            }
            if let Some(s) = Sensor::of(rec) {
                o.imu += u64::from(matches!(s, Sensor::Imu(_)));
                let t = s.t_ns();
                o.last_sensor_t_ns = Some(o.last_sensor_t_ns.map_or(t, |l| l.max(t)));
            }
        }
        o.report = r.report().clone();
        Ok(o)
    }
}

/// The sensor records of a log in log order, read one at a time: the
/// order a recorder saw them arrive or the simulator emitted them. A
/// sample whose time stamp jumped back stays where the log has it, as it
/// would arrive.
/// One exception: aids stamped exactly at an IMU sample's time that follow
/// it in the log go out just before it, so that the solution at that time
/// includes them, as `batch` computes it. Only that IMU sample is held
/// back meanwhile (the aids go out as they are read), so memory holds one
/// sample whatever the log's length.
#[derive(Debug)]
struct InLogOrder<F> {
    /// The next record of the log, `None` at its end.
    next_record: F,
    /// An IMU sample waiting for the aids stamped at its time that follow it.
    held: Option<ImuSample>,
    /// A sensor read after the held sample and due after it.
    pending: Option<Sensor>,
}

impl<F: FnMut() -> Result<Option<Record>, LoadError>> InLogOrder<F> {
    fn new(next_record: F) -> Self {
        Self {
            next_record,
            held: None,
            pending: None,
        }
    }

    fn next_sensor(&mut self) -> Result<Option<Sensor>, LoadError> {
        while let Some(r) = (self.next_record)()? {
            if let Some(s) = Sensor::of(r) {
                return Ok(Some(s));
            }
        }
        Ok(None)
    }

    /// The next sensor to publish; `None` after the last.
    fn next(&mut self) -> Result<Option<Sensor>, LoadError> {
        if let Some(p) = self.pending.take() {
            return Ok(Some(p));
        }
        loop {
            let read = self.next_sensor()?;
            match (self.held.take(), read) {
                // An aid at the held sample's time goes out before it.
                (Some(imu), Some(aid))
                    if !matches!(aid, Sensor::Imu(_)) && aid.t_ns() == imu.t_ns =>
                {
                    self.held = Some(imu);
                    return Ok(Some(aid));
                }
                // Anything else releases the held sample first.
                (Some(imu), read) => {
                    match read {
                        Some(Sensor::Imu(x)) => self.held = Some(x),
                        other => self.pending = other,
                    }
                    return Ok(Some(Sensor::Imu(imu)));
                }
                (None, Some(Sensor::Imu(x))) => self.held = Some(x),
                (None, read) => return Ok(read),
            }
        }
    }
}

/// Publication lateness (ns) of a replay in bounded memory: exact below
/// 2048 ns, above it in buckets 1/2048 of their value wide (a quantile is
/// the lower edge of its bucket, at most 0.05 % below the exact one; the
/// maximum is exact). About 0.9 MB whatever the number of samples.
#[derive(Debug, Clone)]
struct Lateness {
    counts: Vec<u64>,
    n: u64,
    max: u64,
}

/// Bits of a lateness kept exactly in its bucket (2^11 = 2048).
const LATENESS_BITS: u32 = 11;

impl Lateness {
    fn new() -> Self {
        let sub = 1usize << LATENESS_BITS;
        Self {
            counts: vec![0; sub * (64 - LATENESS_BITS as usize + 1)],
            n: 0,
            max: 0,
        }
    }

    fn bucket(v: u64) -> usize {
        let sub = 1u64 << LATENESS_BITS;
        if v < sub {
            return v as usize;
        }
        // v in [2^e, 2^(e+1)), e >= LATENESS_BITS: its top LATENESS_BITS + 1 bits.
        let e = 63 - v.leading_zeros();
        let shift = e - LATENESS_BITS;
        ((u64::from(shift) + 1) * sub + ((v >> shift) - sub)) as usize
    }

    /// The lower edge of bucket `b`.
    fn lower_edge(b: usize) -> u64 {
        let sub = 1u64 << LATENESS_BITS;
        let b = b as u64;
        if b < sub {
            return b;
        }
        let shift = b / sub - 1;
        (sub + b % sub) << shift
    }

    fn push(&mut self, ns: u64) {
        self.counts[Self::bucket(ns)] += 1;
        self.n += 1;
        self.max = self.max.max(ns);
    }

    /// The value of rank round((n − 1)·f) in increasing order (µs), as of
    /// the sorted samples; 0 without samples.
    fn quantile_us(&self, f: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let rank = ((self.n as f64 - 1.0) * f).round() as u64;
        if rank >= self.n - 1 {
            return self.max as f64 * 1e-3;
        }
        let mut seen = 0;
        for (b, c) in self.counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                return Self::lower_edge(b) as f64 * 1e-3;
            }
        }
        self.max as f64 * 1e-3
    }
}

/// A stalled IMU driver (`play --stall-imu AT:FOR`): from sensor time `at_s`
/// (seconds after the log's init) the IMU stream goes silent for `for_s`
/// seconds of wall-clock time while the aids go on; then the samples held
/// meanwhile go out at once, in order, as a delayed driver catches up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuStall {
    pub at_s: f64,
    pub for_s: f64,
}

impl ImuStall {
    /// Parses `AT:FOR` (seconds); both finite, AT ≥ 0, 0 < FOR ≤ 3600.
    pub fn parse(text: &str) -> Result<Self, String> {
        let (at, dur) = text
            .split_once(':')
            .ok_or_else(|| format!("expected AT:FOR in seconds, got {text:?}"))?;
        let num = |what: &str, v: &str| -> Result<f64, String> {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{what} of {text:?} is not a number"))
        };
        let (at_s, for_s) = (num("AT", at)?, num("FOR", dur)?);
        if !(at_s.is_finite() && at_s >= 0.0) {
            return Err(format!("AT of {text:?}: expected seconds >= 0"));
        }
        if !(for_s.is_finite() && for_s > 0.0 && for_s <= 3600.0) {
            return Err(format!("FOR of {text:?}: expected seconds in (0, 3600]"));
        }
        Ok(Self { at_s, for_s })
    }
}

/// Errors of a replay.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The log could not be read again for a pass (each pass reads the
    /// file from its start; the error names it).
    #[error(transparent)]
    Log(#[from] LoadError),
}

/// Publishes the log at `path` at wall-clock rate (scaled by `speed`)
/// against absolute deadlines, in log order (a record never goes out
/// before the one the log has before it). Each pass starts with an init
/// message and reads the file again from its start, one record at a time,
/// so memory is bounded whatever the log's length (`outline` is what the
/// caller read of it first, [`LogOutline::read`]); with `loops` > 1 the
/// time base keeps increasing from pass to pass. `stalls` (first pass only)
/// hold the IMU stream back for a while, as a delayed driver would (the
/// samples held are those of the stall's wall-clock time).
pub fn play(
    path: &Path,
    outline: &LogOutline,
    cfg: &TransportConfig,
    speed: f64,
    loops: u64,
    stalls: &[ImuStall],
    stop: &AtomicBool,
) -> Result<Pacing, PlayError> {
    let node = polarnav_ipc::node(cfg, "sensor-replay-play")?;
    // A replay waits for a slow reader rather than lose its inputs (a
    // sensor driver in flight would use Delivery::Discard and count).
    let wait = polarnav_ipc::Delivery::Wait(REPLAY_MAX_WAIT);
    let imu = TopicPublisher::<ImuSample>::with_delivery(&node, cfg, Topic::Imu, wait)?;
    let aids = polarnav_ipc::aid_publishers(&node, cfg, wait)?;
    let init_pub = TopicPublisher::<InitState>::new(&node, cfg, Topic::Init)?;

    let init = outline.init.unwrap_or_default();
    let t0 = init.t_ns;
    let span = outline.last_sensor_t_ns.map_or(0, |t| t.saturating_sub(t0)) + 1_000_000;

    let sidereal_ns = (std::f64::consts::TAU / polarnav::earth::OMEGA_IE * 1e9).round() as u64;
    let span_sidereal = span.div_ceil(sidereal_ns) * sidereal_ns;
    let mut lateness = Lateness::new();
    let mut per_stream = PerStream::<u64>::default();
    let progress_every = (span / 10).max(1);
    let mut next_progress = progress_every;
    let start = Instant::now() + Duration::from_millis(100);
    // IMU samples held by a stall (the aids keep their schedule).
    let mut held: Vec<ImuSample> = Vec::new();
    let mut stalls: Vec<ImuStall> = stalls.to_vec();
    stalls.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    let mut stalls = stalls.into_iter().peekable();
    // The end (a wall-clock instant) of the stall in progress.
    let mut stalled_until: Option<Instant> = None;
    'passes: for pass in 0..loops.max(1) {
        // Whole sidereal days (of the WGS-84 Earth rate) between passes: the
        // Earth has the same orientation at every pass's time stamps, so
        // observations made in the inertial frame (SRS) stay consistent.
        let offset = pass * span_sidereal;
        // Wall-clock: the passes follow each other without a pause.
        let wall_offset = pass * span;
        let at = |t_ns: u64| {
            start + Duration::from_secs_f64((t_ns - t0 + wall_offset) as f64 * 1e-9 / speed)
        };
        let mut log = LogReader::open(path)?;
        let mut sensors = InLogOrder::new(|| log.next_record());
        wait_until(at(t0));
        let mut last_deadline = at(t0);
        init_pub.publish(&InitState {
            t_ns: init.t_ns + offset,
            seq: pass,
            ..init
        })?;
        while let Some(s) = sensors.next()? {
            if stop.load(Ordering::Relaxed) {
                break 'passes;
            }
            // Never earlier than the previous sample: a time stamp that jumped
            // back goes out at once, in log order.
            let deadline = at(s.t_ns().max(t0)).max(last_deadline);
            last_deadline = deadline;
            wait_until(deadline);
            // A stall ends: the held IMU samples go out at once, in order.
            if let Some(end) = stalled_until
                && Instant::now() >= end
            {
                stalled_until = None;
                for x in held.drain(..) {
                    imu.publish(&x)?;
                    lateness.push(end.elapsed().as_nanos() as u64);
                }
            }
            if let Sensor::Imu(x) = &s
                && pass == 0
            {
                let t_s = x.t_ns.saturating_sub(t0) as f64 * 1e-9;
                if stalled_until.is_none()
                    && let Some(st) = stalls.next_if(|st| st.at_s <= t_s)
                {
                    let d = Duration::from_secs_f64(st.for_s);
                    polarnav_ipc::note!(
                        "play: IMU stalled at t = {t_s:.3} s for {:.3} s (aids go on)",
                        st.for_s
                    );
                    stalled_until = Some(Instant::now() + d);
                }
                if stalled_until.is_some() {
                    per_stream[Stream::Imu] += 1;
                    held.push(ImuSample {
                        t_ns: x.t_ns + offset,
                        seq: x.seq + pass * outline.imu,
                        ..*x
                    });
                    continue;
                }
            }
            per_stream[s.stream()] += 1;
            // A daemon that subscribed after this pass's init went out gets
            // it now, from the init topic's history, before the IMU it needs.
            init_pub.update_connections()?;
            match &s {
                Sensor::Imu(x) => imu.publish(&ImuSample {
                    t_ns: x.t_ns + offset,
                    seq: x.seq + pass * outline.imu,
                    ..*x
                })?,
                // Whole sidereal days later an inertial observation (SRS,
                // star tracker) is the same.
                Sensor::Aid(x) => {
                    let mut x = **x;
                    *x.t_ns_mut() += offset;
                    aids[x.kind()].publish_sample(&x)?
                }
            };
            lateness.push(deadline.elapsed().as_nanos() as u64);
            let done = s.t_ns().saturating_sub(t0);
            if done >= next_progress {
                next_progress += progress_every;
                polarnav_ipc::note!(
                    "play: pass {} at t = {:.0} s of {:.0} s ({:.0} %)",
                    pass + 1,
                    done as f64 * 1e-9,
                    span as f64 * 1e-9,
                    100.0 * done as f64 / span as f64
                );
            }
        }
    }
    // A stall still running at the end: its samples go out now.
    if let Some(end) = stalled_until {
        wait_until(end);
        for x in held.drain(..) {
            imu.publish(&x)?;
            lateness.push(end.elapsed().as_nanos() as u64);
        }
    }
    let (mut waits, mut max_wait, mut lost) = (0, Duration::ZERO, 0);
    let per_publisher = std::iter::once((imu.waits().0, imu.waits().1, imu.lost())).chain(
        aids.iter()
            .map(|(_, p)| (p.waits().0, p.waits().1, p.lost())),
    );
    for (w, m, l) in per_publisher {
        waits += w;
        max_wait = max_wait.max(m);
        lost += l;
    }
    Ok(Pacing {
        published: lateness.n,
        per_stream,
        p50_us: lateness.quantile_us(0.5),
        p99_us: lateness.quantile_us(0.99),
        max_us: lateness.quantile_us(1.0),
        waits,
        max_wait_us: max_wait.as_secs_f64() * 1e6,
        lost,
    })
}

/// Counts of a recording.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Recorded {
    /// Records written (each once, whatever pieces repeat at their start).
    pub records: u64,
    pub solutions: u64,
    /// Records that could not be written (full disk or another write error).
    pub lost: u64,
    /// Pieces opened and pieces removed by the retention bound.
    pub pieces: u64,
    pub removed: u64,
}

/// Records held while the recorder waits for the daemon's settings.
const HOLD_RECORDS: usize = 100_000;

/// The recorder hands what it wrote to the kernel at least this often, so
/// that a recorder killed with SIGKILL loses at most this much (plus one
/// wake-up) of what it received.
pub const RECORD_FLUSH_PERIOD: Duration = Duration::from_millis(50);

/// How long the recorder holds the daemon's outputs waiting for its
/// settings (for the header) before it starts the file without them.
pub const SETTINGS_WAIT: Duration = Duration::from_millis(100);

/// Subscribes to every service and writes what arrives to `out` (one file
/// or rotated pieces, see [`crate::pieces`]) until `stop` is set (or
/// `max_duration` passes). The subscriptions are drained every cycle
/// whatever the disk does: a write that fails costs the records it could
/// not write (counted), never a wait of the publishers.
/// An MCAP output carries `mcap`'s provenance record and epoch.
pub fn record(
    cfg: &TransportConfig,
    out: Output,
    open: Opener,
    mcap: McapProvenance,
    stop: &AtomicBool,
    max_duration: Option<Duration>,
) -> Result<Recorded, RecordError> {
    use iceoryx2::prelude::*;
    let node = polarnav_ipc::node(cfg, "sensor-replay-record")?;
    let imu = TopicSubscriber::<ImuSample>::new(&node, cfg, Topic::Imu)?;
    let aids = polarnav_ipc::aid_subscribers(&node, cfg)?;
    let init = TopicSubscriber::<InitState>::new(&node, cfg, Topic::Init)?;
    let sol = TopicSubscriber::<Solution>::new(&node, cfg, Topic::Solution)?;
    let status = TopicSubscriber::<Status>::new(&node, cfg, Topic::Status)?;
    let settings = TopicSubscriber::<EffectiveSettings>::new(&node, cfg, Topic::Settings)?;
    polarnav_ipc::note!("record: subscribed to {}/*", cfg.prefix);
    // The header carries the daemon's effective settings, so the writer
    // starts once they arrive (or, without a daemon, when the records held
    // meanwhile reach HOLD_RECORDS, or at the end).
    let mut pieces = Pieces::new(
        out,
        open,
        &format!(
            "sensor-replay {} record",
            polarnav_config::build_info::LONG_VERSION
        ),
        &cfg.prefix,
    )
    .with_mcap_provenance(mcap);
    let mut started = false;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| RecordError::WaitSet(format!("{e:?}")))?;
    let _tick = waitset
        .attach_interval(Duration::from_millis(5))
        .map_err(|e| RecordError::WaitSet(format!("{e:?}")))?;
    let t_start = Instant::now();
    let mut n = Recorded::default();
    let mut buf: Vec<Record> = Vec::with_capacity(4096);
    let mut last_flush = Instant::now();
    let mut first_output: Option<Instant> = None;
    loop {
        let r = waitset
            .wait_and_process_once(|_| CallbackProgression::Continue)
            .map_err(|e| RecordError::WaitSet(format!("{e:?}")))?;
        // An interrupted wait (EINTR after SIGSTOP/SIGCONT or any handled
        // signal) is not a stop request: SIGINT/SIGTERM set `stop`.
        let done = stop.load(Ordering::Relaxed)
            || matches!(r, iceoryx2::waitset::WaitSetRunResult::TerminationRequest)
            || max_duration.is_some_and(|d| t_start.elapsed() >= d);
        init.drain(|x| buf.push(Record::Init(x)))?;
        imu.drain(|x| buf.push(Record::Imu(x)))?;
        for (_, sub) in aids.iter() {
            sub.drain_samples(&mut |_, x| buf.push(Record::aid(x)))?;
        }
        sol.drain(|x| {
            n.solutions += 1;
            buf.push(Record::Solution(Box::new(x)));
        })?;
        status.drain(|x| buf.push(Record::Status(Box::new(x))))?;
        if first_output.is_none()
            && buf
                .iter()
                .any(|r| matches!(r, Record::Solution(_) | Record::Status(_)))
        {
            first_output = Some(Instant::now());
        }
        if !started {
            let mut text: Option<String> = None;
            settings.drain(|m| text = m.text().map(str::to_owned))?;
            if let Some(t) = text {
                polarnav_ipc::note!("record: the daemon's effective settings go into the header");
                pieces.start(Some(t)).map_err(RecordError::Create)?;
                started = true;
            } else if buf.len() >= HOLD_RECORDS
                || done
                || first_output.is_some_and(|t: Instant| t.elapsed() >= SETTINGS_WAIT)
            {
                // A daemon hands its settings to a new subscriber within
                // 25 ms: none by SETTINGS_WAIT after its first output means
                // a daemon without them. Outputs are held no longer, so a
                // kill loses at most that much of them at the start.
                pieces.start(None).map_err(RecordError::Create)?;
                started = true;
            }
        }
        for s in [
            imu.listener(),
            init.listener(),
            sol.listener(),
            status.listener(),
        ] {
            let _ = s.try_wait(|_| {});
        }
        for (_, sub) in aids.iter() {
            sub.clear_events();
        }
        if !started {
            continue;
        }
        // Time order within the batch (inputs and outputs of a cycle arrive together).
        buf.sort_by_key(|r| r.t_ns().unwrap_or(0));
        pieces.write_all(buf.drain(..));
        if last_flush.elapsed() >= RECORD_FLUSH_PERIOD {
            pieces.flush();
            last_flush = Instant::now();
        }
        if done {
            break;
        }
    }
    let finished = pieces.finish();
    let c = pieces.counts();
    n.records = c.written;
    n.lost = c.lost;
    n.pieces = c.opened;
    n.removed = c.removed;
    if let Err(e) = finished {
        polarnav_ipc::note!("record: the last piece could not be closed: {e}");
    }
    Ok(n)
}

/// Errors of the recorder.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error(transparent)]
    Write(#[from] msgs::navlog::WriteError),
    #[error(transparent)]
    Mcap(#[from] polarnav_foxglove::McapError),
    #[error("iceoryx2 waitset: {0}")]
    WaitSet(String),
    /// The output file named on the command line cannot be created.
    #[error("cannot create {0}")]
    Create(String),
}

#[cfg(test)]
mod tests {
    use super::{ImuStall, InLogOrder, Lateness, LogOutline, Pacing, PerStream, Sensor};
    use msgs::navlog::{Header, NavlogWriter, Record};
    use msgs::{BaroSample, CnsFix, ImuSample, InitState, StarSample, TruthRecord};

    fn imu(t_ns: u64, seq: u64) -> Record {
        Record::Imu(ImuSample {
            t_ns,
            seq,
            ..Default::default()
        })
    }

    fn baro(t_ns: u64, seq: u64) -> Record {
        Record::aid(BaroSample {
            t_ns,
            seq,
            ..Default::default()
        })
    }

    /// (stream, t, seq) of each sensor as `play` sends it.
    fn sent(records: Vec<Record>) -> Vec<(&'static str, u64, u64)> {
        let mut it = records.into_iter();
        let mut order = InLogOrder::new(|| Ok(it.next()));
        let mut out = Vec::new();
        while let Some(s) = order.next().expect("in memory") {
            let seq = match &s {
                Sensor::Imu(x) => x.seq,
                Sensor::Aid(x) => x.seq(),
            };
            out.push((s.stream().name(), s.t_ns(), seq));
        }
        out
    }

    /// The aids stamped at an IMU sample's time that follow it in the log
    /// go out before it (the records between them that are no sensor's do
    /// not part them); anything else keeps the log's order, a time stamp
    /// that jumped back included. Worked out by hand from the rule.
    #[test]
    fn aids_at_an_imu_samples_time_go_out_before_it_and_nothing_else_moves() {
        let log = vec![
            Record::Header(Box::new(Header::new("test", "order", 0, ""))),
            Record::Init(InitState::default()),
            imu(10, 0),
            baro(10, 1),
            Record::Truth(TruthRecord {
                t_ns: 10,
                ..Default::default()
            }),
            Record::aid(CnsFix {
                t_ns: 10,
                seq: 2,
                ..Default::default()
            }),
            baro(15, 3),
            imu(20, 4),
            imu(20, 5),
            Record::aid(StarSample {
                t_ns: 20,
                seq: 6,
                ..Default::default()
            }),
            baro(5, 7),
            imu(30, 8),
        ];
        assert_eq!(
            sent(log),
            [
                ("baro", 10, 1),
                ("cns", 10, 2),
                ("imu", 10, 0),
                ("baro", 15, 3),
                ("imu", 20, 4),
                ("star", 20, 6),
                ("imu", 20, 5),
                ("baro", 5, 7),
                ("imu", 30, 8),
            ]
        );
        assert!(sent(Vec::new()).is_empty());
        assert_eq!(sent(vec![imu(1, 0)]), [("imu", 1, 0)]);
    }

    /// The quantiles of the bounded lateness histogram against those of
    /// the sorted samples: exact below 2048 ns and for the maximum, at
    /// most 1/2048 below the exact value above.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "both sides are whole nanoseconds times 1e-3, computed alike"
    )]
    fn lateness_quantiles_are_within_a_2048th_of_the_sorted_samples() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for scale in [1_000u64, 100_000, 10_000_000_000] {
            let mut h = Lateness::new();
            let mut v: Vec<u64> = (0..20_001).map(|_| next() % scale).collect();
            v.push(u64::MAX);
            for x in &v {
                h.push(*x);
            }
            v.sort_unstable();
            for f in [0.0, 0.25, 0.5, 0.99, 1.0] {
                let exact = v[((v.len() as f64 - 1.0) * f).round() as usize] as f64 * 1e-3;
                let got = h.quantile_us(f);
                let tol = if exact < 2.048 || f >= 1.0 {
                    0.0
                } else {
                    exact / 2048.0
                };
                assert!(
                    got <= exact && exact - got <= tol,
                    "scale {scale} f {f}: {got} µs against {exact} µs"
                );
            }
        }
        assert_eq!(Lateness::new().quantile_us(0.5), 0.0);
        for v in [0, 1, 2047, 2048, 2049, 4095, 4096, 1 << 40, u64::MAX] {
            let b = Lateness::bucket(v);
            assert!(Lateness::lower_edge(b) <= v, "{v}");
            assert!(v - Lateness::lower_edge(b) <= v / 2048, "{v}");
        }
    }

    /// The outline of a log file: its first init, its IMU records and its
    /// latest sensor time (a truth record later than it does not count).
    #[test]
    fn the_outline_has_the_first_init_the_imu_count_and_the_last_sensor_time() {
        let p =
            std::env::temp_dir().join(format!("polarnav-outline-{}.navlog", std::process::id()));
        let mut w = NavlogWriter::new(
            std::fs::File::create(&p).expect("create"),
            Header::new("test", "outline", 0, ""),
        )
        .expect("header");
        for r in [
            imu(5, 0),
            Record::Init(InitState {
                t_ns: 7,
                ..Default::default()
            }),
            baro(90, 1),
            imu(50, 2),
            Record::Init(InitState {
                t_ns: 8,
                ..Default::default()
            }),
            Record::Truth(TruthRecord {
                t_ns: 500,
                ..Default::default()
            }),
        ] {
            w.write(&r).expect("write");
        }
        w.finish().expect("finish");
        let o = LogOutline::read(&p).expect("outline");
        assert_eq!(o.init.map(|i| i.t_ns), Some(7));
        assert_eq!((o.imu, o.last_sensor_t_ns), (2, Some(90)));
        assert!(o.report.is_clean());
        let _ = std::fs::remove_file(&p);
        let e = LogOutline::read(&p).expect_err("gone");
        assert!(e.to_string().contains(&p.display().to_string()), "{e}");
    }

    #[test]
    fn imu_stalls_parse_and_absurd_ones_are_refused_naming_the_part() {
        let ok = ImuStall::parse("35:2").expect("35:2");
        assert_eq!((ok.at_s, ok.for_s), (35.0, 2.0));
        let ok = ImuStall::parse(" 0 : 1e-10 ").expect("tiny stall");
        assert_eq!((ok.at_s, ok.for_s), (0.0, 1e-10));
        assert_eq!(
            ImuStall::parse("1e18:3600").expect("late").at_s.to_bits(),
            1e18f64.to_bits()
        );
        for (bad, names) in [
            ("35", "AT:FOR"),
            ("", "AT:FOR"),
            ("x:2", "AT"),
            ("1:y", "FOR"),
            ("-1:2", "AT"),
            ("NaN:2", "AT"),
            ("inf:2", "AT"),
            ("1:0", "FOR"),
            ("1:-2", "FOR"),
            ("1:NaN", "FOR"),
            ("1:3600.5", "FOR"),
            ("1:1e300", "FOR"),
        ] {
            let e = ImuStall::parse(bad).expect_err(bad);
            assert!(e.contains(names), "{bad:?}: {e}");
        }
    }

    #[test]
    fn summary_counts_read_back() {
        let p = Pacing {
            published: 1_234_567 + 89 + 1011 + 12_131 + 7 + 3 + 5 + 2,
            per_stream: PerStream(std::array::from_fn(|k| {
                [1_234_567, 89, 1011, 12_131, 7, 3, 5, 2, 11, 13][k]
            })),
            p50_us: 3.25,
            p99_us: 41.0,
            max_us: 1200.5,
            waits: 3,
            max_wait_us: 12_500.0,
            lost: 0,
        };
        let out = format!("progress line (not it)\n{}\n", p.summary());
        assert_eq!(Pacing::published_in(&out), Some(p.per_stream));
        assert_eq!(Pacing::published_in("play: nothing here"), None);
        assert_eq!(Pacing::published_in(""), None);
    }
}
