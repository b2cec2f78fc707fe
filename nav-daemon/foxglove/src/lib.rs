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
//! | `/tf/polar` | `foxglove.FrameTransform` `ecef` → `polar_north`, `polar_south` | every 60 s |
//! | `/track` | `foxglove.SceneUpdate`: poles, switch latitudes, solution and truth tracks | 1 point/s |
//! | `/status` | JSON, every field of `Status` | status records |
//! | `/aid/srs`, `/aid/cns`, `/aid/baro`, `/aid/star` | JSON [`AidUpdate`] | each gated update, or status |
//! | `/events/switch` | JSON [`SwitchNote`] | a frame change between solutions |
//! | `/events` | `foxglove.Log` | the same switch as a line for Foxglove's Log panel |
//! | `/truth`, `/truth/fix` | JSON truth with geodetic position; `foxglove.LocationFix` | truth records |
//! | `/truth/bias` | JSON, the simulated IMU bias (`msgs::navlog::TruthBias`) | truth-bias records |
//!
//! Every message's log time is its sensor time stamp `t_ns`. JSON channels
//! carry a JSON Schema derived from the payload's own serialization (field
//! names with units, as on the wire; the `_pad` bytes are left out), so
//! PlotJuggler and Foxglove's plot panel list every field. `t_ns` is an
//! integer: readers that hold numbers as doubles (JavaScript) lose its last
//! digits after 104 days of sensor time; the message log time is exact.

#![warn(missing_docs)]

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use foxglove::messages::{LocationFix, Log, Timestamp, Vector3};
use foxglove::{Channel, Context, McapWriterHandle, PartialMetadata, RawChannel, Schema};
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

/// A JSON channel with its reused encoding buffer.
#[derive(Debug)]
struct JsonChannel {
    ch: Arc<RawChannel>,
    buf: Vec<u8>,
}

impl JsonChannel {
    fn new<T: Serialize>(ctx: &Arc<Context>, topic: &str, title: &str, sample: &T) -> Self {
        let schema = schema::json_schema(title, sample);
        let ch = ctx
            .channel_builder(topic)
            .message_encoding("json")
            .schema(Schema::new(
                title,
                "jsonschema",
                serde_json::to_vec(&schema).unwrap_or_default(),
            ))
            .build_raw()
            .unwrap_or_else(|e| panic!("channel {topic} of a fresh context: {e}"));
        Self {
            ch,
            buf: Vec::with_capacity(2048),
        }
    }

    fn log<T: Serialize>(&mut self, t_ns: u64, v: &T) {
        if !self.ch.has_sinks() {
            return;
        }
        self.buf.clear();
        if schema::write_without_padding(&mut self.buf, v).is_ok() {
            self.ch.log_with_meta(
                &self.buf,
                PartialMetadata {
                    log_time: Some(t_ns),
                },
            );
        }
    }
}

/// The channels of one run in one context, and what they need to remember
/// (the last frame, for switch events).
#[derive(Debug)]
pub struct FlightChannels {
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
    fix: Channel<LocationFix>,
    truth_fix: Channel<LocationFix>,
    polar: polar::PolarScene,
    log: Channel<Log>,
    aid_source: AidSource,
    last_frame: Option<u8>,
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
    /// Creates every channel in `ctx`.
    pub fn new(ctx: &Arc<Context>, aid_source: AidSource) -> Self {
        let aid =
            |topic: &str, title: &str| JsonChannel::new(ctx, topic, title, &AidUpdate::default());
        Self {
            imu: JsonChannel::new(
                ctx,
                "/imu",
                "polarnav.ImuSample",
                &msgs::ImuSample::default(),
            ),
            srs: JsonChannel::new(
                ctx,
                "/srs",
                "polarnav.SrsSample",
                &msgs::SrsSample::default(),
            ),
            cns: JsonChannel::new(ctx, "/cns", "polarnav.CnsFix", &msgs::CnsFix::default()),
            baro: JsonChannel::new(
                ctx,
                "/baro",
                "polarnav.BaroSample",
                &msgs::BaroSample::default(),
            ),
            star: JsonChannel::new(
                ctx,
                "/star",
                "polarnav.StarSample",
                &msgs::StarSample::default(),
            ),
            init: JsonChannel::new(
                ctx,
                "/init",
                "polarnav.InitState",
                &msgs::InitState::default(),
            ),
            solution: JsonChannel::new(ctx, "/solution", "polarnav.Solution", &Solution::default()),
            status: JsonChannel::new(ctx, "/status", "polarnav.Status", &Status::default()),
            aid: [
                aid("/aid/srs", "polarnav.AidUpdate"),
                aid("/aid/cns", "polarnav.AidUpdate"),
                aid("/aid/baro", "polarnav.AidUpdate"),
                aid("/aid/star", "polarnav.AidUpdate"),
            ],
            switch: JsonChannel::new(
                ctx,
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
            ),
            truth: JsonChannel::new(ctx, "/truth", "polarnav.Truth", &TruthOut::default()),
            truth_bias: JsonChannel::new(
                ctx,
                "/truth/bias",
                "polarnav.TruthBias",
                &msgs::navlog::TruthBias::default(),
            ),
            fix: ctx.channel_builder("/solution/fix").build(),
            truth_fix: ctx.channel_builder("/truth/fix").build(),
            polar: polar::PolarScene::new(ctx),
            log: ctx.channel_builder("/events").build(),
            aid_source,
            last_frame: None,
        }
    }

    /// Logs one navlog record on its channels (the header is not a message:
    /// see [`McapFile::header`]).
    pub fn record(&mut self, r: &Record) {
        match r {
            Record::Header(_) => {}
            Record::Init(x) => self.init.log(x.t_ns, x),
            Record::Imu(x) => self.imu.log(x.t_ns, x),
            Record::Srs(x) => self.srs.log(x.t_ns, x.as_ref()),
            Record::Cns(x) => self.cns.log(x.t_ns, x),
            Record::Baro(x) => self.baro.log(x.t_ns, x),
            Record::Star(x) => self.star.log(x.t_ns, x),
            Record::Truth(x) => self.truth(x),
            Record::Solution(x) => self.solution(x),
            Record::Status(x) => self.status(x),
            Record::TruthBias(x) => self.truth_bias.log(x.t_ns, x),
        }
    }

    /// A solution: `/solution`, `/solution/fix`, `/solution/pose`, and a
    /// switch event when its frame differs from the previous solution's.
    pub fn solution(&mut self, s: &Solution) {
        let switched = self.last_frame.is_some_and(|prev| prev != s.frame);
        self.polar.solution(s, switched);
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
            if self.log.has_sinks() {
                self.log.log_with_time(
                    &Log {
                        timestamp: Some(stamp(s.t_ns)),
                        // INFO
                        level: 2,
                        message: format!("frame switch {}", note.label),
                        name: "polarnav".into(),
                        ..Default::default()
                    },
                    s.t_ns,
                );
            }
            self.switch.log(s.t_ns, &note);
        }
        self.last_frame = Some(s.frame);
        self.solution.log(s.t_ns, s);
        if self.fix.has_sinks() {
            let var = s.sigma_pos_enu_m.map(|x| x * x);
            let v = s.v_enu_mps;
            self.fix.log_with_time(
                &LocationFix {
                    timestamp: Some(stamp(s.t_ns)),
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
                },
                s.t_ns,
            );
        }
    }

    /// The end of a run: what is still held (the last track segments).
    pub fn finish(&mut self) {
        self.polar.finish();
    }

    /// A status record: `/status`, and with [`AidSource::Status`] the last
    /// update of each aid that has had one.
    pub fn status(&mut self, st: &Status) {
        self.status.log(st.t_ns, st);
        if self.aid_source == AidSource::Status {
            for (topic, a, c) in [
                (AidTopic::Srs, &st.srs_aid, &st.srs),
                (AidTopic::Cns, &st.cns_aid, &st.cns),
                (AidTopic::Baro, &st.baro_aid, &st.baro),
                (AidTopic::Star, &st.star_aid, &st.star),
            ] {
                if c.accepted + c.rejected_gate > 0 {
                    self.aid[topic as usize].log(st.t_ns, &AidUpdate::from_status(st.t_ns, a));
                }
            }
        }
    }

    /// One gated update of an aid (with [`AidSource::Updates`]).
    pub fn aid_update(&mut self, topic: AidTopic, u: &AidUpdate) {
        self.aid[topic as usize].log(u.t_ns, u);
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
        self.truth.log(t.t_ns, &out);
        self.polar.truth(t, g.lat_rad);
        if self.truth_fix.has_sinks() {
            self.truth_fix.log_with_time(
                &LocationFix {
                    timestamp: Some(stamp(t.t_ns)),
                    frame_id: "truth".into(),
                    latitude: out.lat_deg,
                    longitude: out.lon_deg,
                    altitude: out.h_m,
                    position_covariance: vec![0.0; 9],
                    // UNKNOWN
                    position_covariance_type: 0,
                    ..Default::default()
                },
                t.t_ns,
            );
        }
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
        self.writer
            .write_metadata("polarnav", meta)
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
