//! polarnav flight data as Foxglove channels.
//!
//! One mapping from polarnav's records (the navlog's and the wire's) to
//! channels, of an MCAP file written on its own thread ([`mod@file`]) or of a
//! Foxglove [`Context`] (the live view's WebSocket server), so that an MCAP
//! file written by
//! `nav-daemon batch --out F.mcap`, `sensor-replay record --out F.mcap` or
//! `sensor-replay export LOG --mcap F`, and the live view
//! (`sensor-replay view`, over the Foxglove WebSocket protocol) carry the
//! same topics with the same schemas:
//!
//! | topic | schema | from |
//! |---|---|---|
//! | `/imu`, `/NAME` of each aid (`/srs`, `/cns`, ...), `/init` | `polarnav.ImuSample`, the aid's message (`polarnav_proto::AidMessage`), ... (the wire payload) | input records |
//! | `/solution` | `polarnav.Solution`: the solution CSV's columns and units, and more | solutions |
//! | `/solution/fix` | `foxglove.LocationFix` (ENU covariance from σ) | solutions |
//! | `/solution/pose` | `foxglove.FrameTransform` `polar_north|south` → `body` | solutions |
//! | `/solution/nav_frame` | `foxglove.FrameTransform` `polar_north|south` → `nav` (ENU or grid) | solutions |
//! | `/tf/polar` | `foxglove.FrameTransform` `ecef` → `polar_north`, `polar_south` | every 5 s |
//! | `/track` | `foxglove.SceneUpdate`: poles, switch latitudes, solution and truth tracks | 1 point/s |
//! | `/status` | `polarnav.Status` | status records |
//! | `/aid/NAME` of each aid | `polarnav.AidUpdate` (innovation in the aid's units) | each gated update (batch), each new one a status reports (recording, export, live view) |
//! | `/events/switch` | `polarnav.SwitchNote` | a frame change between solutions |
//! | `/events` | `foxglove.Log` | the same switch as a line for Foxglove's Log panel |
//! | `/truth`, `/truth/fix` | `polarnav.Truth` with geodetic position; `foxglove.LocationFix` | truth records |
//! | `/truth/bias` | `polarnav.TruthBias`, the simulated IMU bias | truth-bias records |
//!
//! An MCAP file ([`McapFile`]) lists each channel from its first message.
//! The live view
//! ([`FlightChannels::new_live`]) advertises a channel with its first
//! message, or while the daemon's publisher of its output is up
//! ([`FlightChannels::advertise`], [`FlightChannels::withdraw`]), so a
//! client sees only channels that carry data; each of its channels may be
//! limited to a rate: messages above it are dropped, not queued, and
//! counted ([`FlightChannels::dropped`]).
//!
//! Every message's log time is its sensor time stamp `t_ns`, plus the UTC
//! epoch of the time base when one is given ([`FlightChannels::set_epoch_ns`],
//! `--utc-start`: the log times are then dates). Every channel is
//! protobuf with its schema: Foxglove's well-known messages where one fits,
//! else the messages of `polarnav.proto` (crate `polarnav_proto`: every
//! field's name ends in its unit; the schema is the file's
//! FileDescriptorSet), so Foxglove, PlotJuggler and the `mcap` readers
//! decode every field. `t_ns` is an integer: readers that hold numbers as
//! doubles (JavaScript) lose its last digits after 104 days of sensor time;
//! the message log time is exact.

#![warn(missing_docs)]

use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::messages::{FrameTransform, LocationFix, Log, SceneUpdate, Timestamp, Vector3};
use foxglove::{Context, Encode, PartialMetadata, RawChannel, Schema};
use msgs::navlog::{Header, Record};
use msgs::{AidKind, AidSample, AidStatus, PerAid, Solution, Status, TruthRecord, WireFrame};
use polarnav_proto::{self as pb, AidMessage, FILE_DESCRIPTOR_SET, ProtoName};

pub mod convert;
pub mod file;
pub mod polar;

pub use convert::UpdateAt;

/// Where a run's aid updates come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AidSource {
    /// Every gated update, given by the caller ([`FlightChannels::aid_update`]): `batch`.
    Updates,
    /// The last update each status record reports (1 Hz): recordings, the live view.
    Status,
}

/// Why writing an MCAP file failed.
pub type McapError = file::FileError;

/// A per-channel rate limit on wall-clock time: a message passes when its
/// slot has come, else it is dropped and counted. Slots are one period apart
/// and do not accumulate (after a pause the next message passes and the
/// schedule restarts from it), so over any window T at most T·rate + 1
/// messages pass.
#[derive(Debug, Clone, Copy)]
struct RateGate {
    /// Zero: no limit.
    period: Duration,
    next: Option<Instant>,
    dropped: u64,
}

impl RateGate {
    fn new(max_rate_hz: Option<f64>) -> Self {
        let period = max_rate_hz
            .filter(|hz| hz.is_finite() && *hz > 0.0)
            .map_or(Duration::ZERO, |hz| Duration::from_secs_f64(1.0 / hz));
        Self {
            period,
            next: None,
            dropped: 0,
        }
    }

    /// Whether a message may go now (counts it as dropped when not).
    fn pass(&mut self) -> bool {
        if self.period.is_zero() {
            return true;
        }
        let now = Instant::now();
        match self.next {
            Some(next) if now < next => {
                self.dropped += 1;
                false
            }
            Some(next) if now - next < self.period => {
                self.next = Some(next + self.period);
                true
            }
            _ => {
                self.next = Some(now + self.period);
                true
            }
        }
    }
}

/// Where the channels go: a Foxglove SDK context (the live view's
/// WebSocket server), or an MCAP file written on its own thread.
#[derive(Debug)]
enum Out {
    /// Channels of the context, and the buffer messages are encoded into.
    Sdk { ctx: Arc<Context>, buf: Vec<u8> },
    /// The file's channels; messages are encoded into its batches.
    File(file::FileWriter),
}

/// Which update of an aid a status reports: its gated count and the bits
/// of its innovation (a restarted daemon counts from 0 again).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct UpdateKey(u64, [u64; msgs::aids::MAX_COMPONENTS]);

/// A message type of the mapping: its schema and how it encodes.
trait Msg {
    fn schema() -> Option<Schema>;
    fn encoding() -> String;
    /// Appends the message to `buf`; false when it could not.
    fn encode_into(&self, buf: &mut Vec<u8>) -> bool;
}

/// The messages of `polarnav.proto`.
macro_rules! proto_msg {
    ($($t:ty),*) => {$(
        impl Msg for $t {
            fn schema() -> Option<Schema> {
                Some(proto_schema::<$t>())
            }
            fn encoding() -> String {
                "protobuf".into()
            }
            fn encode_into(&self, buf: &mut Vec<u8>) -> bool {
                // Encoding into a Vec cannot run out of room.
                prost::Message::encode(self, buf).is_ok()
            }
        }
    )*};
}
proto_msg!(
    pb::ImuSample,
    pb::InitState,
    pb::Solution,
    pb::Status,
    pb::AidUpdate,
    pb::SwitchNote,
    pb::Truth,
    pb::TruthBias
);

/// An aid's sample as its protobuf message (`polarnav_proto::AidMessage`).
#[derive(Debug)]
struct AidMsg<M>(M);

impl<M: prost::Message + ProtoName> Msg for AidMsg<M> {
    fn schema() -> Option<Schema> {
        Some(proto_schema::<M>())
    }
    fn encoding() -> String {
        "protobuf".into()
    }
    fn encode_into(&self, buf: &mut Vec<u8>) -> bool {
        prost::Message::encode(&self.0, buf).is_ok()
    }
}

/// An aid's input channel (`/NAME`), whatever the aid's message.
trait AidInput: AnyChannel + std::fmt::Debug + Send {
    /// Logs `sample` (of this channel's aid) at log time `log_ns`.
    fn log_sample(&mut self, out: &mut Out, log_ns: u64, sample: &AidSample);
    fn as_channel(&self) -> &dyn AnyChannel;
    fn as_channel_mut(&mut self) -> &mut dyn AnyChannel;
}

/// The channel of aid `P`'s samples.
#[derive(Debug)]
struct AidInputChan<P: AidMessage> {
    chan: Chan<AidMsg<P::Proto>>,
}

impl<P: AidMessage> AnyChannel for AidInputChan<P> {
    fn lazy_topic(&self) -> &'static str {
        self.chan.lazy_topic()
    }
    fn is_open(&self) -> bool {
        self.chan.is_open()
    }
    fn dropped(&self) -> u64 {
        self.chan.dropped()
    }
    fn open_in(&mut self, out: &mut Out) {
        self.chan.open_in(out);
    }
}

impl<P: AidMessage + std::fmt::Debug> AidInput for AidInputChan<P>
where
    P::Proto: std::fmt::Debug,
{
    fn log_sample(&mut self, out: &mut Out, log_ns: u64, sample: &AidSample) {
        if let Some(x) = P::of(sample) {
            self.chan.log(out, log_ns, || AidMsg(x.to_proto()));
        }
    }
    fn as_channel(&self) -> &dyn AnyChannel {
        self
    }
    fn as_channel_mut(&mut self) -> &mut dyn AnyChannel {
        self
    }
}

/// The input channel of aid `k`.
fn aid_input(k: AidKind, gate: RateGate) -> Box<dyn AidInput> {
    msgs::match_aid_kind!(k, P => {
        Box::new(AidInputChan::<P> {
            chan: Chan::new(k.decl().topic, gate),
        })
    })
}

/// Foxglove's well-known messages.
macro_rules! wkt_msg {
    ($($t:ty),*) => {$(
        impl Msg for $t {
            fn schema() -> Option<Schema> {
                <$t as Encode>::get_schema()
            }
            fn encoding() -> String {
                <$t as Encode>::get_message_encoding()
            }
            fn encode_into(&self, buf: &mut Vec<u8>) -> bool {
                Encode::encode(self, buf).is_ok()
            }
        }
    )*};
}
wkt_msg!(LocationFix, FrameTransform, SceneUpdate, Log);

/// A channel as its destination knows it.
#[derive(Debug)]
enum Handle {
    Sdk(Arc<RawChannel>),
    File(u16),
}

/// A channel of one message type that exists from its first message (or
/// [`Chan::open`]) until [`Chan::close`], behind its rate gate.
#[derive(Debug)]
struct Chan<M> {
    topic: &'static str,
    gate: RateGate,
    handle: Option<Handle>,
    _m: PhantomData<fn(M)>,
}

/// The schema of every `polarnav.proto` channel: the message's full name
/// and the file's descriptor set.
fn proto_schema<M: ProtoName>() -> Schema {
    Schema::new(M::NAME, "protobuf", FILE_DESCRIPTOR_SET)
}

impl<M: Msg> Chan<M> {
    fn new(topic: &'static str, gate: RateGate) -> Self {
        Self {
            topic,
            gate,
            handle: None,
            _m: PhantomData,
        }
    }

    fn open(&mut self, out: &mut Out) {
        if self.handle.is_some() {
            return;
        }
        self.handle = match out {
            Out::Sdk { ctx, .. } => {
                let b = ctx
                    .channel_builder(self.topic)
                    .message_encoding(M::encoding());
                let b = match M::schema() {
                    Some(schema) => b.schema(schema),
                    None => b,
                };
                // The builder refuses only a channel without a message encoding.
                b.build_raw().ok().map(Handle::Sdk)
            }
            Out::File(f) => Some(Handle::File(f.add_channel(
                self.topic,
                &M::encoding(),
                M::schema(),
            ))),
        };
    }

    /// Closing a channel of the live view removes it from its context
    /// (sinks unadvertise it); a file keeps every channel it listed.
    fn close(&mut self) {
        if let Some(Handle::Sdk(ch)) = &self.handle {
            ch.close();
            self.handle = None;
        }
    }

    /// Logs the message `make` builds (only when the gate passes it and,
    /// live, a sink wants it) at log time `log_ns`.
    fn log(&mut self, out: &mut Out, log_ns: u64, make: impl FnOnce() -> M) {
        if !self.gate.pass() {
            return;
        }
        self.open(out);
        match (&self.handle, out) {
            (Some(Handle::Sdk(ch)), Out::Sdk { buf, .. }) => {
                if !ch.has_sinks() {
                    return;
                }
                buf.clear();
                if make().encode_into(buf) {
                    ch.log_with_meta(
                        buf,
                        PartialMetadata {
                            log_time: Some(log_ns),
                        },
                    );
                }
            }
            (Some(Handle::File(id)), Out::File(f)) => {
                f.log(*id, log_ns, |buf| make().encode_into(buf));
            }
            _ => {}
        }
    }
}

/// A channel of the mapping, whatever its message type.
trait AnyChannel {
    fn lazy_topic(&self) -> &'static str;
    fn is_open(&self) -> bool;
    fn dropped(&self) -> u64;
    fn open_in(&mut self, out: &mut Out);
}

impl<M: Msg> AnyChannel for Chan<M> {
    fn lazy_topic(&self) -> &'static str {
        self.topic
    }
    fn is_open(&self) -> bool {
        self.handle.is_some()
    }
    fn dropped(&self) -> u64 {
        self.gate.dropped
    }
    fn open_in(&mut self, out: &mut Out) {
        self.open(out);
    }
}

/// The channels of one run in one context, and what they need to remember
/// (the last frame, for switch events).
#[derive(Debug)]
pub struct FlightChannels {
    out: Out,
    imu: Chan<pb::ImuSample>,
    /// Each aid's samples, `/NAME`.
    inputs: PerAid<Box<dyn AidInput>>,
    init: Chan<pb::InitState>,
    solution: Chan<pb::Solution>,
    status: Chan<pb::Status>,
    /// Each aid's updates, `/aid/NAME`.
    aid: PerAid<Chan<pb::AidUpdate>>,
    switch: Chan<pb::SwitchNote>,
    truth: Chan<pb::Truth>,
    truth_bias: Chan<pb::TruthBias>,
    fix: Chan<LocationFix>,
    truth_fix: Chan<LocationFix>,
    pose: Chan<FrameTransform>,
    nav_frame: Chan<FrameTransform>,
    tf: Chan<FrameTransform>,
    track: Chan<SceneUpdate>,
    scene: polar::PolarScene,
    log: Chan<Log>,
    aid_source: AidSource,
    last_frame: Option<u8>,
    /// Where the last solution was (frame, latitude, height).
    last_at: UpdateAt,
    /// Per aid: which update the last status
    /// reported (its gated count, accepted + rejected at the gate, and its
    /// innovation) and where that innovation was made. A status repeats
    /// the last update until the next one (ten times for a 0.1 Hz aid and
    /// 1 Hz status), which a frame switch does not clear: it goes on the
    /// `/aid/*` channel once, and is turned into metres in the frame and at
    /// the position of the update, not of the status.
    aid_made: PerAid<(UpdateKey, Option<UpdateAt>)>,
    /// Added to every `t_ns` to make a log time (the UTC epoch of sensor time 0, or 0).
    epoch_ns: u64,
    /// Sensor time of the last solution drawn on the display channels
    /// (`/solution/fix`, `/solution/pose`, `/solution/nav_frame`).
    last_display_ns: Option<u64>,
}

/// The display channels of a solution (`/solution/fix`, `/solution/pose`,
/// `/solution/nav_frame`) carry one solution per this much sensor time
/// (20 Hz), and every solution at a frame switch: the Map and 3D panels
/// need no more, and at the IMU's 200 Hz they would be three quarters of
/// a file's messages. `/solution` keeps every solution. Decided on the
/// stamps, so a file is the same whatever the machine's load.
pub const DISPLAY_PERIOD_NS: u64 = 50_000_000;

/// A daemon output whose channels the live view opens while its publisher
/// is up ([`FlightChannels::advertise`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feed {
    /// `/solution`, `/solution/fix`, `/solution/pose` (and, on their first
    /// message, `/events/switch` and `/events`).
    Solution,
    /// `/status` (and, on their first message, the `/aid/*` updates it reports).
    Status,
}

/// Every topic this mapping writes, in a fixed order (the order an MCAP
/// file lists its channels in): the IMU, each aid's samples, init, the
/// solution and its display channels, the polar frames and track, status,
/// each aid's updates, the events and the truth.
pub fn topics() -> Vec<&'static str> {
    let mut t = vec!["/imu"];
    t.extend(AidKind::ALL.map(|k| k.decl().topic));
    t.extend([
        "/init",
        "/solution",
        "/solution/fix",
        "/solution/pose",
        "/solution/nav_frame",
        "/tf/polar",
        "/track",
        "/status",
    ]);
    t.extend(AidKind::ALL.map(|k| k.decl().update_topic));
    t.extend([
        "/events/switch",
        "/events",
        "/truth",
        "/truth/fix",
        "/truth/bias",
    ]);
    t
}

/// A well-known message's time stamp (seconds saturate at `u32::MAX`, year 2106).
fn stamp(t_ns: u64) -> Timestamp {
    let sec = u32::try_from(t_ns / 1_000_000_000).unwrap_or(u32::MAX);
    Timestamp::new(sec, (t_ns % 1_000_000_000) as u32)
}

fn frame_letter(f: u8) -> String {
    WireFrame::from_u8(f)
        .map_or('?', WireFrame::letter)
        .to_string()
}

/// The log time of a message stamped `t_ns` in a run whose sensor time 0
/// is `epoch_ns` (UTC, ns since 1970; or 0).
fn at(epoch_ns: u64, t_ns: u64) -> u64 {
    epoch_ns.saturating_add(t_ns)
}

impl FlightChannels {
    /// Every channel of the mapping, created now in `ctx` (its sinks see
    /// them all at once), without a rate limit.
    pub fn new(ctx: &Arc<Context>, aid_source: AidSource) -> Self {
        Self::with_every_channel(
            Out::Sdk {
                ctx: Arc::clone(ctx),
                buf: Vec::with_capacity(1024),
            },
            aid_source,
        )
    }

    /// Every channel of the mapping, defined now in `out` (a file writes
    /// each with its first message).
    fn with_every_channel(out: Out, aid_source: AidSource) -> Self {
        let mut c = Self::with_out(out, aid_source, None);
        let (out, channels) = c.out_and_channels();
        for ch in channels {
            ch.open_in(out);
        }
        c
    }

    /// The channels of the live view: each created (advertised) with its
    /// first message or by [`Self::advertise`], and limited to
    /// `max_rate_hz` messages per second of wall-clock time (`None`, zero
    /// or not finite: no limit).
    pub fn new_live(ctx: &Arc<Context>, aid_source: AidSource, max_rate_hz: Option<f64>) -> Self {
        let out = Out::Sdk {
            ctx: Arc::clone(ctx),
            buf: Vec::with_capacity(1024),
        };
        Self::with_out(out, aid_source, max_rate_hz)
    }

    fn with_out(out: Out, aid_source: AidSource, max_rate_hz: Option<f64>) -> Self {
        let g = RateGate::new(max_rate_hz);
        Self {
            out,
            imu: Chan::new("/imu", g),
            inputs: PerAid::from_fn(|k| aid_input(k, g)),
            init: Chan::new("/init", g),
            solution: Chan::new("/solution", g),
            status: Chan::new("/status", g),
            aid: PerAid::from_fn(|k| Chan::new(k.decl().update_topic, g)),
            switch: Chan::new("/events/switch", g),
            truth: Chan::new("/truth", g),
            truth_bias: Chan::new("/truth/bias", g),
            fix: Chan::new("/solution/fix", g),
            truth_fix: Chan::new("/truth/fix", g),
            pose: Chan::new("/solution/pose", g),
            nav_frame: Chan::new("/solution/nav_frame", g),
            tf: Chan::new("/tf/polar", g),
            track: Chan::new("/track", g),
            scene: polar::PolarScene::new(),
            log: Chan::new("/events", g),
            aid_source,
            last_frame: None,
            last_at: UpdateAt {
                frame: WireFrame::Geographic as u8,
                lat_rad: 0.0,
                h_m: 0.0,
            },
            epoch_ns: 0,
            last_display_ns: None,
            aid_made: PerAid::default(),
        }
    }

    /// Every channel, in [`topics`]' order.
    fn channels(&self) -> Vec<&dyn AnyChannel> {
        let mut c: Vec<&dyn AnyChannel> = vec![&self.imu];
        c.extend(self.inputs.0.iter().map(|x| x.as_channel()));
        c.extend([
            &self.init as &dyn AnyChannel,
            &self.solution,
            &self.fix,
            &self.pose,
            &self.nav_frame,
            &self.tf,
            &self.track,
            &self.status,
        ]);
        c.extend(self.aid.0.iter().map(|x| x as &dyn AnyChannel));
        c.extend([
            &self.switch as &dyn AnyChannel,
            &self.log,
            &self.truth,
            &self.truth_fix,
            &self.truth_bias,
        ]);
        c
    }

    /// Where the channels go, and every channel in [`topics`]' order,
    /// borrowed apart so that each can be opened in it.
    fn out_and_channels(&mut self) -> (&mut Out, Vec<&mut dyn AnyChannel>) {
        let mut c: Vec<&mut dyn AnyChannel> = vec![&mut self.imu];
        c.extend(self.inputs.0.iter_mut().map(|x| x.as_channel_mut()));
        c.extend([
            &mut self.init as &mut dyn AnyChannel,
            &mut self.solution,
            &mut self.fix,
            &mut self.pose,
            &mut self.nav_frame,
            &mut self.tf,
            &mut self.track,
            &mut self.status,
        ]);
        c.extend(self.aid.0.iter_mut().map(|x| x as &mut dyn AnyChannel));
        c.extend([
            &mut self.switch as &mut dyn AnyChannel,
            &mut self.log,
            &mut self.truth,
            &mut self.truth_fix,
            &mut self.truth_bias,
        ]);
        (&mut self.out, c)
    }

    /// Log times from now on are `epoch_ns + t_ns`: `epoch_ns` is the UTC
    /// time (ns since 1970) of sensor time 0, so a viewer shows dates.
    pub fn set_epoch_ns(&mut self, epoch_ns: u64) {
        self.epoch_ns = epoch_ns;
    }

    /// Opens (advertises) the channels `feed` carries before its first
    /// message: the live view does so while the daemon's publisher is up.
    pub fn advertise(&mut self, feed: Feed) {
        let out = &mut self.out;
        match feed {
            Feed::Solution => {
                self.solution.open(out);
                self.fix.open(out);
                self.pose.open(out);
                self.nav_frame.open(out);
            }
            Feed::Status => self.status.open(out),
        }
    }

    /// Closes (unadvertises) every channel `feed` fed: its publisher is gone.
    pub fn withdraw(&mut self, feed: Feed) {
        match feed {
            Feed::Solution => {
                self.solution.close();
                self.fix.close();
                self.pose.close();
                self.nav_frame.close();
                self.tf.close();
                self.track.close();
                self.scene = polar::PolarScene::new();
                self.switch.close();
                self.log.close();
                self.last_frame = None;
                self.last_display_ns = None;
            }
            Feed::Status => {
                self.status.close();
                // A daemon that comes back counts from 0 again: nothing of
                // the old one's updates is carried over to its statuses.
                self.aid_made = PerAid::default();
                for (_, a) in self.aid.iter_mut() {
                    a.close();
                }
            }
        }
    }

    /// The topics that exist now (have carried a message or were advertised).
    pub fn open_topics(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = self
            .channels()
            .into_iter()
            .filter(|c| c.is_open())
            .map(AnyChannel::lazy_topic)
            .collect();
        v.sort_unstable();
        v
    }

    /// Messages dropped by the rate limit, per topic (topics with drops only).
    pub fn dropped(&self) -> Vec<(&'static str, u64)> {
        let mut v: Vec<(&'static str, u64)> = self
            .channels()
            .into_iter()
            .map(|c| (c.lazy_topic(), c.dropped()))
            .filter(|(_, n)| *n > 0)
            .collect();
        v.sort_unstable();
        v
    }

    /// Logs one navlog record on its channels (the header is not a message:
    /// see [`McapFile::header`]).
    pub fn record(&mut self, r: &Record) {
        let ctx = &mut self.out;
        let e = self.epoch_ns;
        match r {
            Record::Header(_) => {}
            Record::Init(x) => self.init.log(ctx, at(e, x.t_ns), || convert::init(x)),
            Record::Imu(x) => self.imu.log(ctx, at(e, x.t_ns), || convert::imu(x)),
            Record::Aid(x) => self.aid_sample(x),
            Record::Truth(x) => self.truth(x),
            Record::Solution(x) => self.solution(x),
            Record::Status(x) => self.status(x),
            Record::TruthBias(x) => {
                self.truth_bias
                    .log(ctx, at(e, x.t_ns), || convert::truth_bias(x));
            }
        }
    }

    /// An aid's sample on its input channel, `/NAME` (what
    /// [`Self::record`] does with a record of it).
    pub fn aid_sample(&mut self, x: &AidSample) {
        let at = at(self.epoch_ns, x.t_ns());
        self.inputs[x.kind()].log_sample(&mut self.out, at, x);
    }

    /// A solution: `/solution`, `/solution/fix`, `/solution/pose`, and a
    /// switch event when its frame differs from the previous solution's.
    pub fn solution(&mut self, s: &Solution) {
        let at = at(self.epoch_ns, s.t_ns);
        let switched = self.last_frame.is_some_and(|prev| prev != s.frame);
        let out = self.scene.solution(s, switched, at);
        self.scene_out(out, at);
        let ctx = &mut self.out;
        if let Some(prev) = self.last_frame
            && prev != s.frame
        {
            let (from, to) = (frame_letter(prev), frame_letter(s.frame));
            let lat_deg = s.lat_rad.to_degrees();
            let label = format!("{from} -> {to} at {lat_deg:.3} deg");
            self.log.log(ctx, at, || Log {
                timestamp: Some(stamp(at)),
                // INFO
                level: 2,
                message: format!("frame switch {label}"),
                name: "polarnav".into(),
                ..Default::default()
            });
            self.switch.log(ctx, at, || pb::SwitchNote {
                t_ns: s.t_ns,
                from: i32::from(prev),
                to: i32::from(s.frame),
                switch_count: s.switch_count,
                lat_deg,
                label,
            });
        }
        self.last_frame = Some(s.frame);
        self.last_at = UpdateAt {
            frame: s.frame,
            lat_rad: s.lat_rad,
            h_m: s.h_m,
        };
        self.solution.log(ctx, at, || convert::solution(s));
        let display = switched
            || self
                .last_display_ns
                .is_none_or(|last| s.t_ns < last || s.t_ns - last >= DISPLAY_PERIOD_NS);
        if !display {
            return;
        }
        self.last_display_ns = Some(s.t_ns);
        self.fix.log(ctx, at, || {
            let var = s.sigma_pos_enu_m.map(|x| x * x);
            let v = s.v_enu_mps;
            LocationFix {
                timestamp: Some(stamp(at)),
                frame_id: "body".into(),
                latitude: s.lat_rad.to_degrees(),
                longitude: s.lon_rad.to_degrees(),
                altitude: s.h_m,
                position_covariance: vec![var[0], 0.0, 0.0, 0.0, var[1], 0.0, 0.0, 0.0, var[2]],
                // DIAGONAL_KNOWN
                position_covariance_type: 2,
                heading: Some(s.heading_rad),
                velocity: Some(Vector3 {
                    x: v[0],
                    y: v[1],
                    z: v[2],
                }),
                ..Default::default()
            }
        });
        self.pose.log(ctx, at, || polar::pose_message(s, at));
        self.nav_frame
            .log(ctx, at, || polar::nav_frame_message(s, at));
    }

    /// Logs what the polar scene returned, at log time `at`.
    fn scene_out(&mut self, out: polar::SceneOut, at: u64) {
        let ctx = &mut self.out;
        for t in out.statics {
            self.tf.log(ctx, at, || t);
        }
        if let Some(u) = out.update {
            self.track.log(ctx, at, || u);
        }
    }

    /// The end of a run: the last track segments.
    pub fn finish(&mut self) {
        let (out, at) = self.scene.finish();
        self.scene_out(out, at);
    }

    /// A status record: `/status`, and with [`AidSource::Status`] the last
    /// update of each aid that has had one, when it is new since the
    /// previous status (its gated count or its innovation changed).
    ///
    /// Each aid's innovation is turned into its unit where it was made:
    /// with [`AidSource::Updates`], as [`Self::aid_update`] recorded it;
    /// from status records alone, in the status's frame at the last
    /// solution's position when the aid's gated count changed since the
    /// previous status, else where the previous one put it (a switch or a
    /// long outage since then does not move it). The frame is the one the
    /// status says the update was made in (`AidStatus::made_in_frame`), so
    /// an update in the same status period as a switch but before it is
    /// converted in the frame before the switch; from a sender that does
    /// not say (the byte zero), the status's frame is taken.
    pub fn status(&mut self, st: &Status) {
        let at = at(self.epoch_ns, st.t_ns);
        let (made, new) = self.aids_made(st);
        let ctx = &mut self.out;
        self.status.log(ctx, at, || convert::status(st, &made));
        if self.aid_source == AidSource::Status {
            for (k, c, a) in st.each_aid() {
                if c.accepted + c.rejected_gate > 0 && new[k] {
                    let where_ = made[k];
                    self.aid[k].log(ctx, at, || convert::aid_update(st.t_ns, k, a, where_));
                }
            }
        }
    }

    /// Where each aid's innovation in `st` was made, and whether it is an
    /// update the previous status did not report (see [`Self::status`]).
    fn aids_made(&mut self, st: &Status) -> (PerAid<UpdateAt>, PerAid<bool>) {
        let here = UpdateAt {
            frame: st.frame,
            ..self.last_at
        };
        let mut made = PerAid([here; msgs::AID_COUNT]);
        let mut new = PerAid([false; msgs::AID_COUNT]);
        for (k, c, a) in st.each_aid() {
            let key = UpdateKey(c.accepted + c.rejected_gate, a.innovation.map(f64::to_bits));
            let slot = &mut self.aid_made[k];
            let exact = self.aid_source == AidSource::Updates && slot.1.is_some();
            new[k] = !exact && (slot.1.is_none() || slot.0 != key);
            if new[k] {
                // The frame the daemon says the update was made in, else the status's.
                let frame = a.made_in().map_or(st.frame, |f| f as u8);
                *slot = (key, Some(UpdateAt { frame, ..here }));
            }
            made[k] = slot.1.unwrap_or(here);
        }
        (made, new)
    }

    /// One gated update of an aid (with [`AidSource::Updates`]), made in
    /// the frame its status names (`AidStatus::made_in_frame`; from a
    /// sender that does not say, the last solution's) with the navigator
    /// at `lat_rad`, `h_m` after it.
    pub fn aid_update(&mut self, aid: AidKind, t_ns: u64, a: &AidStatus, lat_rad: f64, h_m: f64) {
        let where_ = UpdateAt {
            frame: a.made_in().map_or(self.last_at.frame, |f| f as u8),
            lat_rad,
            h_m,
        };
        let at = at(self.epoch_ns, t_ns);
        self.aid_made[aid].1 = Some(where_);
        self.aid[aid].log(&mut self.out, at, || {
            convert::aid_update(t_ns, aid, a, where_)
        });
    }

    /// A truth record: `/truth` with its geodetic position, `/truth/fix`.
    pub fn truth(&mut self, t: &TruthRecord) {
        let g = polarnav::earth::ecef_to_geodetic(&t.r_e_m.into());
        let at = at(self.epoch_ns, t.t_ns);
        self.truth.log(&mut self.out, at, || convert::truth(t, &g));
        let scene = self.scene.truth(t, g.lat_rad, at);
        self.scene_out(scene, at);
        self.truth_fix.log(&mut self.out, at, || LocationFix {
            timestamp: Some(stamp(at)),
            frame_id: "truth".into(),
            latitude: g.lat_rad.to_degrees(),
            longitude: g.lon_rad.to_degrees(),
            altitude: g.h_m,
            position_covariance: vec![0.0; 9],
            // UNKNOWN
            position_covariance_type: 0,
            ..Default::default()
        });
    }
}

/// An MCAP file (zstd chunks) with the flight channels, for Foxglove,
/// PlotJuggler and the `mcap` readers. Written on its own thread
/// ([`mod@file`]): logging a message encodes it into memory and returns.
#[derive(Debug)]
pub struct McapFile {
    channels: FlightChannels,
}

impl McapFile {
    /// Creates (or truncates) `path`.
    pub fn create(path: &Path, aid_source: AidSource) -> Result<Self, McapError> {
        let writer = file::FileWriter::create(path)?;
        Ok(Self {
            channels: FlightChannels::with_every_channel(Out::File(writer), aid_source),
        })
    }

    /// The channels to log on.
    pub fn channels(&mut self) -> &mut FlightChannels {
        &mut self.channels
    }

    fn writer(&mut self) -> &mut file::FileWriter {
        match &mut self.channels.out {
            Out::File(w) => w,
            Out::Sdk { .. } => unreachable!("an McapFile's channels go to its file"),
        }
    }

    /// The navlog header as MCAP metadata `polarnav` (producer, scenario,
    /// seed, format version, and the settings text).
    pub fn header(&mut self, h: &Header) -> Result<(), McapError> {
        let meta = [
            ("producer", h.producer.clone()),
            ("scenario", h.scenario.clone()),
            ("seed", h.seed.to_string()),
            ("navlog_format_version", h.format_version.to_string()),
            ("settings", h.metadata.clone()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v))
        .collect();
        self.metadata("polarnav", meta)
    }

    /// A metadata record `name` with the entries of `map` (provenance,
    /// settings), after every message logged so far.
    pub fn metadata(&mut self, name: &str, map: BTreeMap<String, String>) -> Result<(), McapError> {
        self.writer().metadata(name, map)
    }

    /// Ends the current chunk and writes everything so far to the file (a
    /// recorder killed after this loses nothing before it; a reader without
    /// the summary section still reads every complete chunk).
    pub fn flush(&mut self) -> Result<(), McapError> {
        self.writer().flush()
    }

    /// Writes the rest, the summary and the footer, and closes the file.
    pub fn close(self) -> Result<(), McapError> {
        let mut channels = self.channels;
        channels.finish();
        match channels.out {
            Out::File(w) => w.close(),
            Out::Sdk { .. } => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solution(t_ns: u64) -> Solution {
        Solution {
            t_ns,
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        }
    }

    /// Files list every channel; the live mapping creates a channel with
    /// its first message or while its feed's publisher is up, and closes
    /// it (removes it from the context) when the publisher goes.
    #[test]
    fn live_channels_exist_only_with_data_or_a_publisher() {
        let ctx = Context::new();
        let all = FlightChannels::new(&ctx, AidSource::Updates);
        for t in topics() {
            assert!(ctx.get_channel_by_topic(t).is_some(), "{t} missing");
        }
        assert_eq!(all.open_topics().len(), topics().len());

        let ctx = Context::new();
        let mut live = FlightChannels::new_live(&ctx, AidSource::Status, None);
        assert!(live.open_topics().is_empty());
        assert!(
            topics()
                .iter()
                .all(|t| ctx.get_channel_by_topic(t).is_none())
        );
        live.advertise(Feed::Status);
        assert_eq!(live.open_topics(), ["/status"]);
        live.solution(&solution(1));
        assert_eq!(
            live.open_topics(),
            [
                "/solution",
                "/solution/fix",
                "/solution/nav_frame",
                "/solution/pose",
                "/status",
                "/tf/polar",
                "/track"
            ]
        );
        // A frame change creates the event channels.
        live.solution(&Solution {
            frame: 1,
            ..solution(2)
        });
        assert!(live.open_topics().contains(&"/events/switch"));
        live.withdraw(Feed::Solution);
        assert_eq!(live.open_topics(), ["/status"]);
        assert!(ctx.get_channel_by_topic("/solution").is_none());
        assert!(ctx.get_channel_by_topic("/events").is_none());
        live.withdraw(Feed::Status);
        assert!(live.open_topics().is_empty());
    }

    /// A file lists a channel from its first message, as the SDK's sink
    /// did: no chunk holds only definitions, so with a UTC epoch every
    /// chunk (and Foxglove's timeline, which starts at the earliest chunk)
    /// starts at the first message's date, not at 1970; channels without
    /// messages are not listed.
    #[test]
    fn a_file_starts_at_its_first_message_and_lists_the_channels_that_carry_data() {
        let dir = std::env::temp_dir().join(format!("polarnav-epoch-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("epoch.mcap");
        let epoch = 1_764_000_000_000_000_000;
        let mut m = McapFile::create(&path, AidSource::Updates).unwrap();
        m.channels().set_epoch_ns(epoch);
        let mut meta = BTreeMap::new();
        meta.insert("program".to_owned(), "test".to_owned());
        m.metadata("polarnav.provenance", meta).unwrap();
        for k in 1..=100u64 {
            m.channels().solution(&solution(k * 5_000_000));
        }
        m.close().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let s = mcap::Summary::read(&bytes).unwrap().unwrap();
        let stats = s.stats.unwrap();
        assert_eq!(stats.message_start_time, epoch + 5_000_000);
        assert!(!s.chunk_indexes.is_empty());
        for c in &s.chunk_indexes {
            assert!(
                c.message_start_time >= epoch,
                "a chunk starts at {}",
                c.message_start_time
            );
        }
        let mut topics: Vec<&str> = s.channels.values().map(|c| c.topic.as_str()).collect();
        topics.sort_unstable();
        assert_eq!(
            topics,
            [
                "/solution",
                "/solution/fix",
                "/solution/nav_frame",
                "/solution/pose",
                "/tf/polar",
                "/track"
            ]
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// From status records (a recording), an aid's update goes on its
    /// `/aid/*` channel once, at the first status that reports it, not at
    /// every status until the next update: eval counts each message of
    /// the channel as one gated update. A new count, or a new innovation
    /// at the same count (a restarted daemon), is a new update.
    #[test]
    fn from_status_records_each_update_is_logged_once() {
        let dir = std::env::temp_dir().join(format!("polarnav-aid-once-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("status.mcap");
        let mut m = McapFile::create(&path, AidSource::Status).unwrap();
        m.channels().solution(&solution(1));
        let status = |k: u64, star: u64, innovation: f64| {
            let mut st = Status {
                t_ns: k * 1_000_000_000,
                ..Status::default()
            };
            st.aid_counters_mut(AidKind::Star).accepted = star;
            st.aid_mut(AidKind::Star).innovation = [innovation, 0.0, 0.0, 0.0, 0.0, 0.0];
            st.aid_mut(AidKind::Star).innovation_var = [1.0; 6];
            st.aid_mut(AidKind::Star).fused = 1;
            st
        };
        // A 0.1 Hz star tracker under 1 Hz status, then a restart whose
        // first update has the count the old run had.
        let mut expected = Vec::new();
        for k in 0..30u64 {
            let (n, innovation) = if k < 25 {
                (k / 10, 1.0 + (k / 10) as f64)
            } else {
                (1, 9.0)
            };
            m.channels().status(&status(k, n, innovation));
            if n > 0 && expected.last() != Some(&innovation) {
                expected.push(innovation);
            }
        }
        assert_eq!(expected, [2.0, 3.0, 9.0]);
        m.close().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let mut got = Vec::new();
        for msg in mcap::MessageStream::new(&bytes).unwrap() {
            let msg = msg.unwrap();
            if msg.channel.topic == "/aid/star" {
                let u = <pb::AidUpdate as prost::Message>::decode(&msg.data[..]).unwrap();
                got.push(u.innovation_rad[0]);
            }
        }
        assert_eq!(got, expected);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A status repeats an aid's last innovation until the next update; a
    /// switch in between does not move where it was made: the CNS
    /// innovation of g stays converted in g at the update's latitude. With
    /// every update given (batch), each one's own place is used.
    #[test]
    fn a_repeated_innovation_is_converted_where_it_was_made() {
        let ctx = Context::new();
        let mut c = FlightChannels::new_live(&ctx, AidSource::Status, None);
        let sol = |frame: u8, lat_rad: f64| Solution {
            frame,
            lat_rad,
            h_m: 1000.0,
            ..solution(1)
        };
        let status = |frame: u8, cns: u64| {
            let mut st = Status {
                frame,
                ..Default::default()
            };
            st.aid_counters_mut(AidKind::Cns).accepted = cns;
            st
        };
        c.solution(&sol(0, 1.2));
        let m = c.aids_made(&status(0, 5)).0[AidKind::Cns];
        assert_eq!((m.frame, m.lat_rad), (0, 1.2));
        // Switched to G at 1.25 rad; no CNS update since: still g at 1.2.
        c.solution(&sol(1, 1.25));
        let m = c.aids_made(&status(1, 5)).0[AidKind::Cns];
        assert_eq!((m.frame, m.lat_rad), (0, 1.2));
        // A new CNS update: made in G, here.
        let m = c.aids_made(&status(1, 6)).0[AidKind::Cns];
        assert_eq!((m.frame, m.lat_rad), (1, 1.25));
        // An update the daemon says it made in g, reported by a status in
        // G (the switch came between them): converted in g.
        let mut said = status(1, 7);
        said.aid_mut(AidKind::Cns).made_in_frame =
            AidStatus::made_in_frame_of(WireFrame::Geographic);
        let m = c.aids_made(&said).0[AidKind::Cns];
        assert_eq!((m.frame, m.lat_rad), (0, 1.25));
        said.aid_counters_mut(AidKind::Cns).accepted = 8;
        said.aid_mut(AidKind::Cns).made_in_frame = AidStatus::made_in_frame_of(WireFrame::Grid);
        assert_eq!(c.aids_made(&said).0[AidKind::Cns].frame, 1);
        // The daemon goes away and a new one comes at 1.3 rad whose first
        // status has the old one's count by chance: its update is placed
        // where it now is, not where the old one's was.
        c.withdraw(Feed::Status);
        c.solution(&sol(1, 1.3));
        let m = c.aids_made(&status(1, 8)).0[AidKind::Cns];
        assert_eq!((m.frame, m.lat_rad), (1, 1.3));

        let ctx = Context::new();
        let mut b = FlightChannels::new_live(&ctx, AidSource::Updates, None);
        b.solution(&sol(1, 1.3));
        // An update whose status says g, after a solution in G: made in g.
        let in_g = AidStatus {
            made_in_frame: AidStatus::made_in_frame_of(WireFrame::Geographic),
            ..AidStatus::default()
        };
        b.aid_update(AidKind::Cns, 1, &in_g, 1.1, 5.0);
        let at = UpdateAt {
            frame: 0,
            lat_rad: 1.1,
            h_m: 5.0,
        };
        assert_eq!(b.aids_made(&status(1, 9)).0[AidKind::Cns], at);
        // One whose status does not say: in the last solution's frame (G).
        b.aid_update(AidKind::Cns, 2, &AidStatus::default(), 1.2, 5.0);
        assert_eq!(b.aids_made(&status(1, 10)).0[AidKind::Cns].frame, 1);
    }

    /// A 100 Hz limit passes at most one message per 10 ms and counts the
    /// rest as dropped; no limit drops nothing.
    #[test]
    fn the_rate_gate_drops_and_counts_what_comes_too_fast() {
        let mut g = RateGate::new(Some(100.0));
        let t0 = Instant::now();
        let mut passed = 0u64;
        let mut offered = 0u64;
        while t0.elapsed() < Duration::from_millis(200) {
            offered += 1;
            passed += u64::from(g.pass());
        }
        let elapsed_s = t0.elapsed().as_secs_f64();
        assert!(
            (passed as f64) <= 100.0 * elapsed_s + 1.0,
            "{passed} passed in {elapsed_s} s"
        );
        assert!(passed >= 10, "{passed} passed in {elapsed_s} s");
        assert_eq!(passed + g.dropped, offered);
        let mut free = RateGate::new(None);
        assert!((0..1000).all(|_| free.pass()));
        assert_eq!(free.dropped, 0);
        for absurd in [Some(0.0), Some(-5.0), Some(f64::NAN), Some(f64::INFINITY)] {
            assert!(RateGate::new(absurd).period.is_zero(), "{absurd:?}");
        }
    }
}
