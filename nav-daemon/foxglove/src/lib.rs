//! polarnav flight data as Foxglove channels.
//!
//! One mapping from polarnav's records (the navlog's and the wire's) to
//! channels of a Foxglove [`Context`], so that an MCAP file written by
//! `nav-daemon batch --out F.mcap`, `sensor-replay record --out F.mcap` or
//! `sensor-replay export LOG --mcap F`, and the live view
//! (`sensor-replay view`, over the Foxglove WebSocket protocol) carry the
//! same topics with the same schemas:
//!
//! | topic | schema | from |
//! |---|---|---|
//! | `/imu`, `/srs`, `/cns`, `/baro`, `/star`, `/init` | JSON, the wire payload | input records |
//! | `/solution` | JSON, every field of `Solution` | solutions |
//! | `/solution/fix` | `foxglove.LocationFix` (ENU covariance from σ) | solutions |
//! | `/solution/pose` | `foxglove.FrameTransform` `polar_north|south` → `body` | solutions |
//! | `/solution/nav_frame` | `foxglove.FrameTransform` `polar_north|south` → `nav` (ENU or grid) | solutions |
//! | `/tf/polar` | `foxglove.FrameTransform` `ecef` → `polar_north`, `polar_south` | every 5 s |
//! | `/track` | `foxglove.SceneUpdate`: poles, switch latitudes, solution and truth tracks | 1 point/s |
//! | `/status` | JSON, every field of `Status` | status records |
//! | `/aid/srs`, `/aid/cns`, `/aid/baro`, `/aid/star` | JSON [`AidUpdate`] | each gated update, or status |
//! | `/events/switch` | JSON [`SwitchNote`] | a frame change between solutions |
//! | `/events` | `foxglove.Log` | the same switch as a line for Foxglove's Log panel |
//! | `/truth`, `/truth/fix` | JSON truth with geodetic position; `foxglove.LocationFix` | truth records |
//! | `/truth/bias` | JSON, the simulated IMU bias (`msgs::navlog::TruthBias`) | truth-bias records |
//!
//! An MCAP file has every channel ([`FlightChannels::new`]). The live view
//! ([`FlightChannels::new_live`]) advertises a channel with its first
//! message, or while the daemon's publisher of its output is up
//! ([`FlightChannels::advertise`], [`FlightChannels::withdraw`]), so a
//! client sees only channels that carry data; each of its channels may be
//! limited to a rate: messages above it are dropped, not queued, and
//! counted ([`FlightChannels::dropped`]).
//!
//! Every message's log time is its sensor time stamp `t_ns`, plus the UTC
//! epoch of the time base when one is given ([`FlightChannels::set_epoch_ns`],
//! `--utc-start`: the log times are then dates). JSON channels
//! carry a JSON Schema derived from the payload's own serialization (field
//! names with units, as on the wire; the `_pad` bytes are left out), so
//! PlotJuggler and Foxglove's plot panel list every field. `t_ns` is an
//! integer: readers that hold numbers as doubles (JavaScript) lose its last
//! digits after 104 days of sensor time; the message log time is exact.

#![warn(missing_docs)]

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::messages::{FrameTransform, LocationFix, Log, SceneUpdate, Timestamp, Vector3};
use foxglove::{Channel, Context, Encode, McapWriterHandle, PartialMetadata, RawChannel, Schema};
use msgs::navlog::{Header, Record};
use msgs::{AidStatus, Solution, Status, TruthRecord, WireFrame};
use serde::Serialize;
use serde_json::Value;

pub mod polar;
pub mod schema;

/// An aid's gated update (or, where only status records exist, its last
/// update as the status reports it).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct AidUpdate {
    /// Time of the measurement (ns, sensor time).
    pub t_ns: u64,
    /// Innovation, up to 3 components, in the aid's measurement space: SRS
    /// velocity (m/s, nav-frame axes); CNS in g Δlatitude, Δlongitude
    /// (rad), in G grid-horizontal position (m); baro height (m); star
    /// tracker attitude (rad, nav-frame axes). Divided
    /// by the square root of its variance it is unit-free in every frame.
    pub innovation: [f64; 3],
    /// Its variance (diagonal of S).
    pub innovation_var: [f64; 3],
    /// Normalized innovation squared over the gate: above 1 is rejected.
    pub test_ratio: f64,
    /// The gate in test-ratio units (always 1): a line for plots.
    pub gate: f64,
    /// 1 if fused, 0 if rejected at the gate.
    pub fused: u8,
    /// SRS lines excluded by fault detection so far.
    pub exclusions: u64,
}

impl AidUpdate {
    /// The update a status record reports as the aid's last.
    pub fn from_status(t_ns: u64, a: &AidStatus) -> Self {
        Self {
            t_ns,
            innovation: a.innovation,
            innovation_var: a.innovation_var,
            test_ratio: a.test_ratio,
            gate: 1.0,
            fused: a.fused,
            exclusions: a.exclusions,
        }
    }
}

/// A frame switch, seen as a change of frame between two solutions.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwitchNote {
    /// Time of the first solution in the new frame (ns).
    pub t_ns: u64,
    /// `g` or `G`.
    pub from: String,
    /// `g` or `G`.
    pub to: String,
    /// Switches since start, after this one.
    pub switch_count: u32,
    /// Latitude at the switch (deg).
    pub lat_deg: f64,
    /// `"g -> G at 70.000 deg"`: a label for an event list.
    pub label: String,
}

/// Truth with its geodetic position (derived from ECEF here).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
struct TruthOut {
    t_ns: u64,
    lat_deg: f64,
    lon_deg: f64,
    h_m: f64,
    r_e_m: [f64; 3],
    v_e_mps: [f64; 3],
    q_b_e: [f64; 4],
}

/// Where a run's aid updates come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AidSource {
    /// Every gated update, given by the caller ([`FlightChannels::aid_update`]): `batch`.
    Updates,
    /// The last update each status record reports (1 Hz): recordings, the live view.
    Status,
}

/// An aid channel of this mapping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AidTopic {
    /// `/aid/srs`
    Srs,
    /// `/aid/cns`
    Cns,
    /// `/aid/baro`
    Baro,
    /// `/aid/star`
    Star,
}

/// Why writing an MCAP file failed.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    /// The file could not be created.
    #[error("{path}: {source}")]
    Create {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed (while writing or closing).
    #[error("{path}: MCAP writer: {source}")]
    Writer {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: foxglove::FoxgloveError,
    },
}

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

/// A channel that exists from its first message (or [`Lazy::open`]) until
/// [`Lazy::close`], behind its rate gate.
#[derive(Debug)]
struct Lazy<C> {
    topic: &'static str,
    ch: Option<C>,
    gate: RateGate,
}

impl<C> Lazy<C> {
    fn new(topic: &'static str, gate: RateGate) -> Self {
        Self {
            topic,
            ch: None,
            gate,
        }
    }
}

/// Closing a channel removes it from its context (sinks unadvertise it).
trait Closable {
    fn close_channel(&self);
}

impl Closable for Arc<RawChannel> {
    fn close_channel(&self) {
        self.close();
    }
}

impl<T: Encode> Closable for Channel<T> {
    fn close_channel(&self) {
        self.close();
    }
}

impl<C: Closable> Lazy<C> {
    fn close(&mut self) {
        if let Some(ch) = self.ch.take() {
            ch.close_channel();
        }
    }
}

/// A well-known (protobuf) channel.
type WktChannel<T> = Lazy<Channel<T>>;

impl<T: Encode> WktChannel<T> {
    fn open(&mut self, ctx: &Arc<Context>) -> &Channel<T> {
        let topic = self.topic;
        self.ch
            .get_or_insert_with(|| ctx.channel_builder(topic).build())
    }

    /// Logs the message `make` builds (only when the gate passes it and a
    /// sink wants it) at log time `log_ns`.
    fn log(&mut self, ctx: &Arc<Context>, log_ns: u64, make: impl FnOnce() -> T) {
        if !self.gate.pass() {
            return;
        }
        let ch = self.open(ctx);
        if ch.has_sinks() {
            ch.log_with_time(&make(), log_ns);
        }
    }
}

/// A JSON channel with its schema and reused encoding buffer.
#[derive(Debug)]
struct JsonChannel {
    lazy: Lazy<Arc<RawChannel>>,
    title: &'static str,
    schema: Vec<u8>,
    buf: Vec<u8>,
}

impl JsonChannel {
    fn new<T: Serialize>(
        topic: &'static str,
        title: &'static str,
        sample: &T,
        gate: RateGate,
    ) -> Self {
        let schema = schema::json_schema(title, sample);
        Self {
            lazy: Lazy::new(topic, gate),
            title,
            schema: serde_json::to_vec(&schema).unwrap_or_default(),
            buf: Vec::with_capacity(2048),
        }
    }

    fn open(&mut self, ctx: &Arc<Context>) {
        if self.lazy.ch.is_none() {
            // The builder refuses only a channel without a message encoding.
            self.lazy.ch = ctx
                .channel_builder(self.lazy.topic)
                .message_encoding("json")
                .schema(Schema::new(self.title, "jsonschema", self.schema.clone()))
                .build_raw()
                .ok();
        }
    }

    fn log<T: Serialize>(&mut self, ctx: &Arc<Context>, log_ns: u64, v: &T) {
        if !self.lazy.gate.pass() {
            return;
        }
        self.open(ctx);
        let Some(ch) = &self.lazy.ch else { return };
        if !ch.has_sinks() {
            return;
        }
        self.buf.clear();
        if schema::write_without_padding(&mut self.buf, v).is_ok() {
            ch.log_with_meta(
                &self.buf,
                PartialMetadata {
                    log_time: Some(log_ns),
                },
            );
        }
    }
}

/// The channels of one run in one context, and what they need to remember
/// (the last frame, for switch events).
#[derive(Debug)]
pub struct FlightChannels {
    ctx: Arc<Context>,
    imu: JsonChannel,
    srs: JsonChannel,
    cns: JsonChannel,
    baro: JsonChannel,
    star: JsonChannel,
    init: JsonChannel,
    solution: JsonChannel,
    status: JsonChannel,
    aid: [JsonChannel; 4],
    switch: JsonChannel,
    truth: JsonChannel,
    truth_bias: JsonChannel,
    fix: WktChannel<LocationFix>,
    truth_fix: WktChannel<LocationFix>,
    pose: WktChannel<FrameTransform>,
    nav_frame: WktChannel<FrameTransform>,
    tf: WktChannel<FrameTransform>,
    track: WktChannel<SceneUpdate>,
    scene: polar::PolarScene,
    log: WktChannel<Log>,
    aid_source: AidSource,
    last_frame: Option<u8>,
    /// Added to every `t_ns` to make a log time (the UTC epoch of sensor time 0, or 0).
    epoch_ns: u64,
}

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

/// Every topic this mapping writes, in a fixed order.
pub const TOPICS: [&str; 22] = [
    "/imu",
    "/srs",
    "/cns",
    "/baro",
    "/star",
    "/init",
    "/solution",
    "/solution/fix",
    "/solution/pose",
    "/solution/nav_frame",
    "/tf/polar",
    "/track",
    "/status",
    "/aid/srs",
    "/aid/cns",
    "/aid/baro",
    "/aid/star",
    "/events/switch",
    "/events",
    "/truth",
    "/truth/fix",
    "/truth/bias",
];

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

impl FlightChannels {
    /// Every channel of the mapping, created now in `ctx` (an MCAP file
    /// lists them all), without a rate limit.
    pub fn new(ctx: &Arc<Context>, aid_source: AidSource) -> Self {
        let mut c = Self::new_live(ctx, aid_source, None);
        let ctx = Arc::clone(&c.ctx);
        for j in [
            &mut c.imu,
            &mut c.srs,
            &mut c.cns,
            &mut c.baro,
            &mut c.star,
            &mut c.init,
            &mut c.solution,
            &mut c.status,
        ] {
            j.open(&ctx);
        }
        for j in &mut c.aid {
            j.open(&ctx);
        }
        for j in [&mut c.switch, &mut c.truth, &mut c.truth_bias] {
            j.open(&ctx);
        }
        c.fix.open(&ctx);
        c.truth_fix.open(&ctx);
        c.pose.open(&ctx);
        c.nav_frame.open(&ctx);
        c.tf.open(&ctx);
        c.track.open(&ctx);
        c.log.open(&ctx);
        c
    }

    /// The channels of the live view: each created (advertised) with its
    /// first message or by [`Self::advertise`], and limited to
    /// `max_rate_hz` messages per second of wall-clock time (`None`, zero
    /// or not finite: no limit).
    pub fn new_live(ctx: &Arc<Context>, aid_source: AidSource, max_rate_hz: Option<f64>) -> Self {
        let g = RateGate::new(max_rate_hz);
        let aid = |topic: &'static str| {
            JsonChannel::new(topic, "polarnav.AidUpdate", &AidUpdate::default(), g)
        };
        Self {
            ctx: Arc::clone(ctx),
            imu: JsonChannel::new("/imu", "polarnav.ImuSample", &msgs::ImuSample::default(), g),
            srs: JsonChannel::new("/srs", "polarnav.SrsSample", &msgs::SrsSample::default(), g),
            cns: JsonChannel::new("/cns", "polarnav.CnsFix", &msgs::CnsFix::default(), g),
            baro: JsonChannel::new(
                "/baro",
                "polarnav.BaroSample",
                &msgs::BaroSample::default(),
                g,
            ),
            star: JsonChannel::new(
                "/star",
                "polarnav.StarSample",
                &msgs::StarSample::default(),
                g,
            ),
            init: JsonChannel::new(
                "/init",
                "polarnav.InitState",
                &msgs::InitState::default(),
                g,
            ),
            solution: JsonChannel::new("/solution", "polarnav.Solution", &Solution::default(), g),
            status: JsonChannel::new("/status", "polarnav.Status", &Status::default(), g),
            aid: [
                aid("/aid/srs"),
                aid("/aid/cns"),
                aid("/aid/baro"),
                aid("/aid/star"),
            ],
            switch: JsonChannel::new(
                "/events/switch",
                "polarnav.SwitchNote",
                &SwitchNote {
                    t_ns: 0,
                    from: String::new(),
                    to: String::new(),
                    switch_count: 0,
                    lat_deg: 0.0,
                    label: String::new(),
                },
                g,
            ),
            truth: JsonChannel::new("/truth", "polarnav.Truth", &TruthOut::default(), g),
            truth_bias: JsonChannel::new(
                "/truth/bias",
                "polarnav.TruthBias",
                &msgs::navlog::TruthBias::default(),
                g,
            ),
            fix: Lazy::new("/solution/fix", g),
            truth_fix: Lazy::new("/truth/fix", g),
            pose: Lazy::new("/solution/pose", g),
            nav_frame: Lazy::new("/solution/nav_frame", g),
            tf: Lazy::new("/tf/polar", g),
            track: Lazy::new("/track", g),
            scene: polar::PolarScene::new(),
            log: Lazy::new("/events", g),
            aid_source,
            last_frame: None,
            epoch_ns: 0,
        }
    }

    /// Log times from now on are `epoch_ns + t_ns`: `epoch_ns` is the UTC
    /// time (ns since 1970) of sensor time 0, so a viewer shows dates.
    pub fn set_epoch_ns(&mut self, epoch_ns: u64) {
        self.epoch_ns = epoch_ns;
    }

    fn log_ns(&self, t_ns: u64) -> u64 {
        self.epoch_ns.saturating_add(t_ns)
    }

    /// Opens (advertises) the channels `feed` carries before its first
    /// message: the live view does so while the daemon's publisher is up.
    pub fn advertise(&mut self, feed: Feed) {
        let ctx = Arc::clone(&self.ctx);
        match feed {
            Feed::Solution => {
                self.solution.open(&ctx);
                self.fix.open(&ctx);
                self.pose.open(&ctx);
                self.nav_frame.open(&ctx);
            }
            Feed::Status => self.status.open(&ctx),
        }
    }

    /// Closes (unadvertises) every channel `feed` fed: its publisher is gone.
    pub fn withdraw(&mut self, feed: Feed) {
        match feed {
            Feed::Solution => {
                self.solution.lazy.close();
                self.fix.close();
                self.pose.close();
                self.nav_frame.close();
                self.tf.close();
                self.track.close();
                self.scene = polar::PolarScene::new();
                self.switch.lazy.close();
                self.log.close();
                self.last_frame = None;
            }
            Feed::Status => {
                self.status.lazy.close();
                for a in &mut self.aid {
                    a.lazy.close();
                }
            }
        }
    }

    /// The topics that exist now (have carried a message or were advertised).
    pub fn open_topics(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = self
            .json_channels()
            .filter(|c| c.lazy.ch.is_some())
            .map(|c| c.lazy.topic)
            .collect();
        for (topic, open) in [
            (self.fix.topic, self.fix.ch.is_some()),
            (self.truth_fix.topic, self.truth_fix.ch.is_some()),
            (self.pose.topic, self.pose.ch.is_some()),
            (self.nav_frame.topic, self.nav_frame.ch.is_some()),
            (self.tf.topic, self.tf.ch.is_some()),
            (self.track.topic, self.track.ch.is_some()),
            (self.log.topic, self.log.ch.is_some()),
        ] {
            if open {
                v.push(topic);
            }
        }
        v.sort_unstable();
        v
    }

    /// Messages dropped by the rate limit, per topic (topics with drops only).
    pub fn dropped(&self) -> Vec<(&'static str, u64)> {
        let mut v: Vec<(&'static str, u64)> = self
            .json_channels()
            .map(|c| (c.lazy.topic, c.lazy.gate.dropped))
            .chain([
                (self.fix.topic, self.fix.gate.dropped),
                (self.truth_fix.topic, self.truth_fix.gate.dropped),
                (self.pose.topic, self.pose.gate.dropped),
                (self.nav_frame.topic, self.nav_frame.gate.dropped),
                (self.tf.topic, self.tf.gate.dropped),
                (self.track.topic, self.track.gate.dropped),
                (self.log.topic, self.log.gate.dropped),
            ])
            .filter(|(_, n)| *n > 0)
            .collect();
        v.sort_unstable();
        v
    }

    fn json_channels(&self) -> impl Iterator<Item = &JsonChannel> {
        [
            &self.imu,
            &self.srs,
            &self.cns,
            &self.baro,
            &self.star,
            &self.init,
            &self.solution,
            &self.status,
            &self.switch,
            &self.truth,
            &self.truth_bias,
        ]
        .into_iter()
        .chain(self.aid.iter())
    }

    /// Logs one navlog record on its channels (the header is not a message:
    /// see [`McapFile::header`]).
    pub fn record(&mut self, r: &Record) {
        let ctx = &self.ctx;
        let at = |t_ns: u64| self.epoch_ns.saturating_add(t_ns);
        match r {
            Record::Header(_) => {}
            Record::Init(x) => self.init.log(ctx, at(x.t_ns), x),
            Record::Imu(x) => self.imu.log(ctx, at(x.t_ns), x),
            Record::Srs(x) => self.srs.log(ctx, at(x.t_ns), x.as_ref()),
            Record::Cns(x) => self.cns.log(ctx, at(x.t_ns), x),
            Record::Baro(x) => self.baro.log(ctx, at(x.t_ns), x),
            Record::Star(x) => self.star.log(ctx, at(x.t_ns), x),
            Record::Truth(x) => self.truth(x),
            Record::Solution(x) => self.solution(x),
            Record::Status(x) => self.status(x),
            Record::TruthBias(x) => self.truth_bias.log(ctx, at(x.t_ns), x),
        }
    }

    /// A solution: `/solution`, `/solution/fix`, `/solution/pose`, and a
    /// switch event when its frame differs from the previous solution's.
    pub fn solution(&mut self, s: &Solution) {
        let at = self.log_ns(s.t_ns);
        let switched = self.last_frame.is_some_and(|prev| prev != s.frame);
        let out = self.scene.solution(s, switched, at);
        self.scene_out(out, at);
        let ctx = &self.ctx;
        if let Some(prev) = self.last_frame
            && prev != s.frame
        {
            let (from, to) = (frame_letter(prev), frame_letter(s.frame));
            let lat_deg = s.lat_rad.to_degrees();
            let note = SwitchNote {
                t_ns: s.t_ns,
                label: format!("{from} -> {to} at {lat_deg:.3} deg"),
                from,
                to,
                switch_count: s.switch_count,
                lat_deg,
            };
            self.log.log(ctx, at, || Log {
                timestamp: Some(stamp(at)),
                // INFO
                level: 2,
                message: format!("frame switch {}", note.label),
                name: "polarnav".into(),
                ..Default::default()
            });
            self.switch.log(ctx, at, &note);
        }
        self.last_frame = Some(s.frame);
        self.solution.log(ctx, at, s);
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
        let ctx = &self.ctx;
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
    /// update of each aid that has had one.
    pub fn status(&mut self, st: &Status) {
        let ctx = &self.ctx;
        let at = self.log_ns(st.t_ns);
        self.status.log(ctx, at, st);
        if self.aid_source == AidSource::Status {
            for (topic, a, c) in [
                (AidTopic::Srs, &st.srs_aid, &st.srs),
                (AidTopic::Cns, &st.cns_aid, &st.cns),
                (AidTopic::Baro, &st.baro_aid, &st.baro),
                (AidTopic::Star, &st.star_aid, &st.star),
            ] {
                if c.accepted + c.rejected_gate > 0 {
                    self.aid[topic as usize].log(ctx, at, &AidUpdate::from_status(st.t_ns, a));
                }
            }
        }
    }

    /// One gated update of an aid (with [`AidSource::Updates`]).
    pub fn aid_update(&mut self, topic: AidTopic, u: &AidUpdate) {
        let at = self.log_ns(u.t_ns);
        self.aid[topic as usize].log(&self.ctx, at, u);
    }

    /// A truth record: `/truth` with its geodetic position, `/truth/fix`.
    pub fn truth(&mut self, t: &TruthRecord) {
        let g = polarnav::earth::ecef_to_geodetic(&t.r_e_m.into());
        let out = TruthOut {
            t_ns: t.t_ns,
            lat_deg: g.lat_rad.to_degrees(),
            lon_deg: g.lon_rad.to_degrees(),
            h_m: g.h_m,
            r_e_m: t.r_e_m,
            v_e_mps: t.v_e_mps,
            q_b_e: t.q_b_e,
        };
        let at = self.log_ns(t.t_ns);
        self.truth.log(&self.ctx, at, &out);
        let scene = self.scene.truth(t, g.lat_rad, at);
        self.scene_out(scene, at);
        self.truth_fix.log(&self.ctx, at, || LocationFix {
            timestamp: Some(stamp(at)),
            frame_id: "truth".into(),
            latitude: out.lat_deg,
            longitude: out.lon_deg,
            altitude: out.h_m,
            position_covariance: vec![0.0; 9],
            // UNKNOWN
            position_covariance_type: 0,
            ..Default::default()
        });
    }
}

/// An MCAP file (zstd chunks) with the flight channels, for Foxglove,
/// PlotJuggler and the `mcap` readers.
#[derive(Debug)]
pub struct McapFile {
    path: PathBuf,
    // The channels and the writer hold the context; it goes last.
    channels: FlightChannels,
    writer: McapWriterHandle<BufWriter<File>>,
    _ctx: Arc<Context>,
}

impl McapFile {
    /// Creates (or truncates) `path`.
    pub fn create(path: &Path, aid_source: AidSource) -> Result<Self, McapError> {
        let ctx = Context::new();
        let file = File::create(path).map_err(|source| McapError::Create {
            path: path.to_owned(),
            source,
        })?;
        let options = foxglove::McapWriteOptions::default()
            .compression(Some(foxglove::McapCompression::Zstd))
            .chunk_size(Some(1 << 20))
            .profile("");
        let writer = ctx
            .mcap_writer_with_options(options)
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|source| McapError::Writer {
                path: path.to_owned(),
                source,
            })?;
        // Channels after the writer: it subscribes to every channel as it is advertised.
        let channels = FlightChannels::new(&ctx, aid_source);
        Ok(Self {
            path: path.to_owned(),
            channels,
            writer,
            _ctx: ctx,
        })
    }

    /// The channels to log on.
    pub fn channels(&mut self) -> &mut FlightChannels {
        &mut self.channels
    }

    /// The navlog header as MCAP metadata `polarnav` (producer, scenario,
    /// seed, format version, and the settings text).
    pub fn header(&self, h: &Header) -> Result<(), McapError> {
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
    /// settings).
    pub fn metadata(&self, name: &str, map: BTreeMap<String, String>) -> Result<(), McapError> {
        self.writer
            .write_metadata(name, map)
            .map_err(|source| McapError::Writer {
                path: self.path.clone(),
                source,
            })
    }

    /// Ends the current chunk and writes everything so far to the file (a
    /// recorder killed after this loses nothing before it; a reader without
    /// the summary section still reads every complete chunk).
    pub fn flush(&self) -> Result<(), McapError> {
        self.writer.flush().map_err(|source| McapError::Writer {
            path: self.path.clone(),
            source,
        })
    }

    /// Writes the summary and closes the file.
    pub fn close(self) -> Result<(), McapError> {
        let path = self.path;
        let mut channels = self.channels;
        channels.finish();
        drop(channels);
        self.writer
            .close()
            .map(drop)
            .map_err(|source| McapError::Writer { path, source })
    }
}

/// The JSON object of a payload without its `_pad` fields (what the JSON
/// channels carry), for tests and tools that compare.
pub fn json_of<T: Serialize>(v: &T) -> Value {
    let mut value = serde_json::to_value(v).unwrap_or(Value::Null);
    schema::strip_padding(&mut value);
    value
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
        for t in TOPICS {
            assert!(ctx.get_channel_by_topic(t).is_some(), "{t} missing");
        }
        assert_eq!(all.open_topics().len(), TOPICS.len());

        let ctx = Context::new();
        let mut live = FlightChannels::new_live(&ctx, AidSource::Status, None);
        assert!(live.open_topics().is_empty());
        assert!(TOPICS.iter().all(|t| ctx.get_channel_by_topic(t).is_none()));
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
