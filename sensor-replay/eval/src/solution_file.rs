//! A solution to evaluate: the solution CSV, or an MCAP file written by
//! `nav-daemon batch --out F.mcap`, whose `/solution` messages give the
//! same rows and whose `/aid/*` messages give the innovations. MCAP
//! messages are protobuf (`polarnav.proto`); files of earlier versions,
//! whose `/solution` and `/aid/*` were JSON, still read.

use std::collections::HashMap;
use std::io::Read;
use std::path::Path;

use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};

use msgs::Solution;
use msgs::aids::{MAX_COMPONENTS, Unit};
use msgs::{AID_COUNT, AidKind, PerAid};
use polarnav::solution_csv::{self, Row};
use polarnav_proto as pb;
use prost::Message as _;
use serde::Deserialize;

use crate::spill::{Sealed, Spill};

/// One gated aid update, as an aid's `/aid/NAME` channel carries it or as
/// a status record reports it.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
pub struct AidPoint {
    pub t_ns: u64,
    /// Up to `MAX_COMPONENTS` components, unused ones with zero variance.
    #[serde(deserialize_with = "components")]
    pub innovation: [f64; MAX_COMPONENTS],
    #[serde(deserialize_with = "components")]
    pub innovation_var: [f64; MAX_COMPONENTS],
    pub test_ratio: f64,
    pub fused: u8,
    /// The innovation is in the aid's one physical unit (m/s, m, m, rad)
    /// whatever the frame, as the protobuf `polarnav.AidUpdate` carries it.
    /// False for the wire's measurement space (a status record, a JSON
    /// message of an earlier version), where a CNS innovation in g is
    /// Δlatitude, Δlongitude in rad.
    #[serde(default)]
    pub physical: bool,
    /// Where a measurement-space innovation was made, as the wire's
    /// `AidStatus::made_in_frame` says (1 + frame: 1 geographic, 2 grid;
    /// 0 not known, then the frame of the solution at `t_ns` is taken).
    #[serde(default)]
    pub made_in_frame: u8,
}

impl AidPoint {
    /// The same update as `other`, whatever the time it is reported at:
    /// equal bit for bit in every other field (NaN test ratios too).
    pub(crate) fn same_update(&self, other: &Self) -> bool {
        let bits = |p: &Self| {
            (
                p.innovation.map(f64::to_bits),
                p.innovation_var.map(f64::to_bits),
                p.test_ratio.to_bits(),
                p.fused,
                p.physical,
                p.made_in_frame,
            )
        };
        bits(self) == bits(other)
    }

    /// The update a protobuf `polarnav.AidUpdate` of aid `aid`'s channel
    /// carries. The components of the aid's innovation (its declaration's)
    /// are in the pair of fields of their units, in order, each
    /// with its σ: a pair may hold fewer (the last ones read as unused) but
    /// not more, and the pairs of units the aid has none of must be empty;
    /// anything else is refused, saying what the message holds.
    pub fn from_proto(u: &pb::AidUpdate, aid: AidKind) -> Result<Self, String> {
        let topic = aid.decl().update_topic;
        let pairs = [
            (Unit::Mps, "mps", &u.innovation_mps, &u.innovation_sigma_mps),
            (Unit::M, "m", &u.innovation_m, &u.innovation_sigma_m),
            (Unit::Rad, "rad", &u.innovation_rad, &u.innovation_sigma_rad),
        ];
        let shown = |c: Unit| match c {
            Unit::LatitudeInG | Unit::LongitudeInG => Unit::M,
            other => other,
        };
        let comps = aid.decl().components;
        let mut next = [0usize; 3];
        let mut innovation = [0.0; MAX_COMPONENTS];
        let mut innovation_var = [0.0; MAX_COMPONENTS];
        for (unit, name, v, sd) in pairs {
            let want = comps.iter().filter(|c| shown(c.unit) == unit).count();
            if v.len() != sd.len() || v.len() > want {
                return Err(format!(
                    "{} innovation components in _{name} with {} σ, but {topic} carries at most {want} there, one σ each",
                    v.len(),
                    sd.len()
                ));
            }
        }
        for (k, c) in comps.iter().take(MAX_COMPONENTS).enumerate() {
            let p = pairs.iter().position(|p| p.0 == shown(c.unit)).unwrap_or(1);
            let (_, _, v, sd) = pairs[p];
            if let (Some(x), Some(d)) = (v.get(next[p]), sd.get(next[p])) {
                innovation[k] = *x;
                innovation_var[k] = d * d;
            }
            next[p] += 1;
        }
        Ok(Self {
            t_ns: u.t_ns,
            innovation,
            innovation_var,
            test_ratio: u.test_ratio,
            fused: u8::from(u.fused),
            physical: true,
            made_in_frame: 0,
        })
    }
}

/// An innovation of up to `MAX_COMPONENTS` components from a JSON message
/// of an earlier version (3 then), the rest zero.
fn components<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; MAX_COMPONENTS], D::Error> {
    let v: Vec<f64> = Vec::deserialize(d)?;
    if v.len() > MAX_COMPONENTS {
        return Err(serde::de::Error::custom(format!(
            "{} innovation components, at most {MAX_COMPONENTS}",
            v.len()
        )));
    }
    let mut out = [0.0; MAX_COMPONENTS];
    out[..v.len()].copy_from_slice(&v);
    Ok(out)
}

impl AidPoint {
    /// Innovation component `k` over its standard deviation (unit-free);
    /// `None` for an unused component (zero variance).
    pub fn normalized(&self, k: usize) -> Option<f64> {
        let v = self.innovation_var[k];
        (v > 0.0 && v.is_finite()).then(|| self.innovation[k] / v.sqrt())
    }
}

/// The CSV row of a protobuf solution. Its angles are in degrees with the
/// CSV's values (the writer converts once, as the CSV does); they are
/// taken as they are, not through the wire's radians and back, which
/// would move them by an ulp.
fn row_of_proto(s: &pb::Solution) -> Row {
    Row {
        lat_deg: s.lat_deg,
        lon_deg: s.lon_deg,
        heading_deg: s.heading_deg,
        pitch_deg: s.pitch_deg,
        roll_deg: s.roll_deg,
        grid_heading_deg: s.grid_heading_deg,
        sigma_att_deg: [s.sig_att_x_deg, s.sig_att_y_deg, s.sig_att_z_deg],
        ..Row::from_solution(&s.to_wire())
    }
}

/// Words (8 bytes) of an [`AidPoint`] on disk: the time, the innovation
/// and its variance (`MAX_COMPONENTS` each), the test ratio, `fused`, and
/// `physical` with `made_in_frame`.
pub const AID_WORDS: usize = 4 + 2 * MAX_COMPONENTS;

/// One aid's updates on disk, in time order.
pub type UpdatesOnDisk = Sealed<AID_WORDS>;

/// The first word of the innovation, of its variance, and of what follows.
const INNOVATION: usize = 1;
const VARIANCE: usize = INNOVATION + MAX_COMPONENTS;
const REST: usize = VARIANCE + MAX_COMPONENTS;

impl AidPoint {
    /// The point as words, every field kept bit for bit.
    pub fn to_words(&self) -> [u64; AID_WORDS] {
        let mut w = [0u64; AID_WORDS];
        w[0] = self.t_ns;
        for k in 0..MAX_COMPONENTS {
            w[INNOVATION + k] = self.innovation[k].to_bits();
            w[VARIANCE + k] = self.innovation_var[k].to_bits();
        }
        w[REST] = self.test_ratio.to_bits();
        w[REST + 1] = u64::from(self.fused);
        w[REST + 2] = u64::from(self.physical) | u64::from(self.made_in_frame) << 8;
        w
    }

    /// The point of [`AidPoint::to_words`].
    pub fn from_words(w: &[u64; AID_WORDS]) -> Self {
        Self {
            t_ns: w[0],
            innovation: std::array::from_fn(|k| f64::from_bits(w[INNOVATION + k])),
            innovation_var: std::array::from_fn(|k| f64::from_bits(w[VARIANCE + k])),
            test_ratio: f64::from_bits(w[REST]),
            fused: w[REST + 1] as u8,
            physical: w[REST + 2] & 1 != 0,
            made_in_frame: (w[REST + 2] >> 8) as u8,
        }
    }
}

/// Calls `f` with every update of `a`, in order.
pub fn for_each_update(a: &UpdatesOnDisk, mut f: impl FnMut(AidPoint)) -> std::io::Result<()> {
    for w in a.iter() {
        f(AidPoint::from_words(&w?));
    }
    Ok(())
}

/// Aid updates held in memory, written to disk as a streamed flight's are.
pub fn aids_to_disk(a: Aids) -> Result<Aids<UpdatesOnDisk>, String> {
    try_map_aids(a, |v| {
        let mut s = Spill::new()?;
        for p in v {
            s.put(p)?;
        }
        s.seal()
    })
    .map_err(|e: std::io::Error| e.to_string())
}

/// Where aid updates go: a vector in memory or a spill on disk.
pub trait AidSink {
    fn put(&mut self, p: AidPoint) -> std::io::Result<()>;
}

impl AidSink for Vec<AidPoint> {
    fn put(&mut self, p: AidPoint) -> std::io::Result<()> {
        self.push(p);
        Ok(())
    }
}

impl AidSink for Spill<AID_WORDS> {
    fn put(&mut self, p: AidPoint) -> std::io::Result<()> {
        self.push(&p.to_words())
    }
}

/// The aid updates of a run, per aid: in memory, or (`P` a spill) on disk.
pub type Aids<P = Vec<AidPoint>> = PerAid<P>;

/// Each aid's updates through `f`, in the aids' order; the first error
/// stops it.
pub fn try_map_aids<P, Q, E>(
    a: Aids<P>,
    mut f: impl FnMut(P) -> Result<Q, E>,
) -> Result<Aids<Q>, E> {
    let mut done = Vec::with_capacity(AID_COUNT);
    for p in a.0 {
        done.push(f(p)?);
    }
    match <[Q; AID_COUNT]>::try_from(done) {
        Ok(q) => Ok(PerAid(q)),
        Err(_) => unreachable!("one value per aid, from one per aid"),
    }
}

/// A loaded solution.
#[derive(Debug, Clone, Default)]
pub struct Loaded {
    pub rows: Vec<Row>,
    /// Present for an MCAP solution.
    pub aids: Option<Aids>,
    /// The 1-σ of the bias estimates per row (gyro rad/s, accel m/s², body
    /// axes), where the solution carries them; see [`BIAS_SIGMA_COLUMNS`].
    pub bias_sigma: Vec<Option<[f64; 6]>>,
}

/// The solution CSV columns of the bias 1-σ (solution version 3), read by
/// name where a file has them: gyro x/y/z (rad/s), accelerometer x/y/z (m/s²).
pub const BIAS_SIGMA_COLUMNS: [&str; 6] = [
    "sig_bg_x_rps",
    "sig_bg_y_rps",
    "sig_bg_z_rps",
    "sig_ba_x_mps2",
    "sig_ba_y_mps2",
    "sig_ba_z_mps2",
];

/// The JSON `/solution` message fields of the same σ (gyro, then
/// accelerometer), in files of earlier versions.
pub const BIAS_SIGMA_FIELDS: [&str; 2] = ["sigma_gyro_bias_rps", "sigma_accel_bias_mps2"];

/// The longest MCAP record (a chunk, compressed or decompressed) eval reads.
pub const MAX_MCAP_RECORD_BYTES: usize = 64 << 20;

/// How many times its size a file's messages may expand to (chunk
/// decompression), beyond [`MCAP_EXPANSION_ALLOWANCE`]: polarnav's zstd
/// chunks expand about 2.4 times, JSON ones of earlier versions less than
/// 10. More is a file made to expand (a few kilobytes of one repeated
/// message that would decode to gigabytes of rows), refused before it does.
pub const MAX_MCAP_EXPANSION: u64 = 32;
/// Message bytes any file may hold whatever its size.
pub const MCAP_EXPANSION_ALLOWANCE: u64 = 1 << 20;
/// The bytes of a message record besides its data (opcode, length, channel,
/// sequence, log and publish time).
const MESSAGE_RECORD_OVERHEAD: u64 = 31;

/// True for a file named `*.mcap`.
pub fn is_mcap(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// Loads a solution CSV or (by extension) an MCAP file.
pub fn load(path: &Path) -> Result<Loaded, String> {
    if !is_mcap(path) {
        let mut rows = Vec::new();
        let mut bias_sigma = Vec::new();
        for r in CsvRows::open(path)? {
            let (row, sig) = r?;
            rows.push(row);
            bias_sigma.push(sig);
        }
        if rows.is_empty() {
            return Err(format!(
                "{}: no solution row after the header",
                path.display()
            ));
        }
        return Ok(Loaded {
            rows,
            aids: None,
            bias_sigma,
        });
    }
    let p = path.display();
    let mut rows = Vec::new();
    let mut bias_sigma = Vec::new();
    let mut aids: Aids = Aids::default();
    let mut messages = McapMessages::open(path)?;
    while let Some(m) = messages.next_message()? {
        match item_of(&m, &p)? {
            Some(SolutionItem::Row(row, sig)) => {
                rows.push(row);
                bias_sigma.push(sig);
            }
            Some(SolutionItem::Aid(k, a)) => aids[k].push(a),
            None => {}
        }
    }
    if rows.is_empty() {
        return Err(format!(
            "{p}: no /solution message (write it with nav-daemon batch --out FILE.mcap)"
        ));
    }
    // Chunks are in log-time order already; a stable sort keeps ties as written.
    let mut both: Vec<(Row, Option<[f64; 6]>)> = rows.into_iter().zip(bias_sigma).collect();
    both.sort_by(|a, b| a.0.t_s.total_cmp(&b.0.t_s));
    let (rows, bias_sigma) = both.into_iter().unzip();
    for (_, v) in aids.iter_mut() {
        v.sort_by_key(|a| a.t_ns);
        // Recordings' MCAP files written before each update went on its
        // channel once repeat the last update at every status (1 Hz) until
        // the next one: a point equal to the one before it in everything
        // but its time is that same update. Two distinct updates equal to
        // the bit in innovation, σ and test ratio do not occur.
        v.dedup_by(|later, earlier| later.same_update(earlier));
    }
    Ok(Loaded {
        rows,
        aids: Some(aids),
        bias_sigma,
    })
}

/// One message of an MCAP file, with its channel's topic and message encoding.
#[derive(Debug, Clone, Copy)]
pub struct McapMessage<'a> {
    pub topic: &'a str,
    /// `protobuf`, `json`, ... (empty if the channel was not seen).
    pub encoding: &'a str,
    pub data: &'a [u8],
    pub sequence: u32,
}

/// Calls `f` with every message of the MCAP file `path`, in file order. The file is streamed record by
/// record (chunks decompressed one at a time): memory holds one chunk, not
/// the file. A record or chunk longer than [`MAX_MCAP_RECORD_BYTES`] is
/// refused as damage, so that a corrupt or hostile length cannot make the
/// reader allocate it. Errors name the file.
pub fn for_each_message(
    path: &Path,
    mut f: impl FnMut(McapMessage<'_>) -> Result<(), String>,
) -> Result<(), String> {
    let mut messages = McapMessages::open(path)?;
    while let Some(m) = messages.next_message()? {
        f(m)?;
    }
    Ok(())
}

/// The messages of an MCAP file one at a time, in file order (see
/// [`for_each_message`]: one chunk in memory, lengths and expansion bounded).
pub struct McapMessages {
    path: String,
    file: std::fs::File,
    size: u64,
    limit: u64,
    expanded: u64,
    channel_of: HashMap<u16, (String, String)>,
    reader: LinearReader,
    /// The current message: its channel, sequence and bytes.
    channel: u16,
    sequence: u32,
    data: Vec<u8>,
}

impl std::fmt::Debug for McapMessages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapMessages")
            .field("path", &self.path)
            .field("expanded", &self.expanded)
            .finish_non_exhaustive()
    }
}

impl McapMessages {
    /// Opens `path` (errors name it).
    pub fn open(path: &Path) -> Result<Self, String> {
        let p = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| format!("{p}: {e}"))?;
        let size = file.metadata().map_err(|e| format!("{p}: {e}"))?.len();
        Ok(Self {
            limit: size
                .saturating_mul(MAX_MCAP_EXPANSION)
                .saturating_add(MCAP_EXPANSION_ALLOWANCE),
            path: p,
            file,
            size,
            expanded: 0,
            channel_of: HashMap::new(),
            reader: LinearReader::new_with_options(
                LinearReaderOptions::default().with_record_length_limit(MAX_MCAP_RECORD_BYTES),
            ),
            channel: 0,
            sequence: 0,
            data: Vec::new(),
        })
    }

    /// The next message; `None` at the end of the file.
    pub fn next_message(&mut self) -> Result<Option<McapMessage<'_>>, String> {
        let p = &self.path;
        loop {
            let Some(event) = self.reader.next_event() else {
                return Ok(None);
            };
            match event.map_err(|e| format!("{p}: MCAP: {e}"))? {
                LinearReadEvent::ReadRequest(need) => {
                    let n = self
                        .file
                        .read(self.reader.insert(need))
                        .map_err(|e| format!("{p}: {e}"))?;
                    self.reader.notify_read(n);
                }
                LinearReadEvent::Record { opcode, data } => {
                    match mcap::parse_record(opcode, data).map_err(|e| format!("{p}: MCAP: {e}"))? {
                        Record::Channel(c) => {
                            self.channel_of.insert(c.id, (c.topic, c.message_encoding));
                        }
                        Record::Message { header, data } => {
                            self.expanded = self
                                .expanded
                                .saturating_add(data.len() as u64 + MESSAGE_RECORD_OVERHEAD);
                            if self.expanded > self.limit {
                                let (limit, size) = (self.limit, self.size);
                                return Err(format!(
                                    "{p}: MCAP: its messages expand to more than {limit} bytes, \
                                     {MAX_MCAP_EXPANSION} times the file's {size} (and {MCAP_EXPANSION_ALLOWANCE} more): \
                                     not a file of polarnav's (whose chunks expand about 2.4 times); \
                                     refused before it fills memory"
                                ));
                            }
                            self.channel = header.channel_id;
                            self.sequence = header.sequence;
                            self.data.clear();
                            self.data.extend_from_slice(&data);
                            break;
                        }
                        _ => {}
                    }
                }
            }
        }
        let (topic, encoding) = self
            .channel_of
            .get(&self.channel)
            .map_or(("", ""), |(t, e)| (t.as_str(), e.as_str()));
        Ok(Some(McapMessage {
            topic,
            encoding,
            data: &self.data,
            sequence: self.sequence,
        }))
    }
}

/// What a solution file gives, one item at a time in file order.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "rows are nearly every item: boxing them would allocate per row"
)]
pub enum SolutionItem {
    /// A row, with its bias σ where the solution carries it.
    Row(Row, Option<[f64; 6]>),
    /// An aid update of an MCAP solution, with its aid.
    Aid(AidKind, AidPoint),
}

/// The item of an MCAP message of file `p`; `None` for a channel eval
/// does not read. A message it cannot read is refused, naming the file,
/// topic, sequence and encoding.
fn item_of(m: &McapMessage<'_>, p: &dyn std::fmt::Display) -> Result<Option<SolutionItem>, String> {
    let bad = |e: &dyn std::fmt::Display| {
        format!(
            "{p}: {} message {} ({}): {e}",
            m.topic, m.sequence, m.encoding
        )
    };
    let json = m.encoding == "json";
    let aid_of = AidKind::ALL
        .into_iter()
        .find(|k| k.decl().update_topic == m.topic);
    let wanted = m.topic == "/solution" || aid_of.is_some();
    if wanted && !json && m.encoding != "protobuf" {
        return Err(bad(
            &"not protobuf (polarnav.proto) nor JSON: cannot read it",
        ));
    }
    if m.topic == "/solution" {
        let (row, sig) = if json {
            let (s, sig) = solution_of_json(m.data).map_err(|e| bad(&e))?;
            (Row::from_solution(&s), sig)
        } else {
            let s = pb::Solution::decode(m.data).map_err(|e| bad(&e))?;
            let sig = [
                s.sig_bg_x_rps,
                s.sig_bg_y_rps,
                s.sig_bg_z_rps,
                s.sig_ba_x_mps2,
                s.sig_ba_y_mps2,
                s.sig_ba_z_mps2,
            ];
            (row_of_proto(&s), Some(sig))
        };
        return Ok(Some(SolutionItem::Row(row, sig)));
    }
    let Some(aid) = aid_of else {
        return Ok(None);
    };
    let a = if json {
        serde_json::from_slice(m.data).map_err(|e| bad(&e))?
    } else {
        AidPoint::from_proto(&pb::AidUpdate::decode(m.data).map_err(|e| bad(&e))?, aid)
            .map_err(|e| bad(&e))?
    };
    Ok(Some(SolutionItem::Aid(aid, a)))
}

/// A solution file read one item at a time: a CSV a chunk of rows at a
/// time ([`CsvRows`]), an MCAP file a chunk at a time ([`McapMessages`]),
/// in file order (unlike [`load`], which sorts an MCAP file's rows and aid
/// updates by time and drops repeated updates).
#[derive(Debug)]
pub struct SolutionStream(Source);

#[derive(Debug)]
enum Source {
    Csv(Box<CsvRows>),
    Mcap(String, Box<McapMessages>),
}

impl SolutionStream {
    /// Opens `path`: MCAP by its extension, else CSV (errors name the file).
    pub fn open(path: &Path) -> Result<Self, String> {
        Ok(Self(if is_mcap(path) {
            Source::Mcap(
                path.display().to_string(),
                Box::new(McapMessages::open(path)?),
            )
        } else {
            Source::Csv(Box::new(CsvRows::open(path)?))
        }))
    }

    /// The next item; `None` at the end of the file.
    pub fn next_item(&mut self) -> Result<Option<SolutionItem>, String> {
        match &mut self.0 {
            Source::Csv(c) => c
                .next()
                .transpose()
                .map(|r| r.map(|(row, sig)| SolutionItem::Row(row, sig))),
            Source::Mcap(path, m) => loop {
                let Some(msg) = m.next_message()? else {
                    return Ok(None);
                };
                if let Some(item) = item_of(&msg, path)? {
                    return Ok(Some(item));
                }
            },
        }
    }
}

/// A `/solution` JSON message of an earlier version (every `Solution`
/// field but the zero padding),
/// and the bias σ when the message has [`BIAS_SIGMA_FIELDS`].
fn solution_of_json(data: &[u8]) -> Result<(Solution, Option<[f64; 6]>), serde_json::Error> {
    let mut v: serde_json::Value = serde_json::from_slice(data)?;
    let triple = |v: &serde_json::Value, k: &str| -> Option<[f64; 3]> {
        let a = v.get(k)?.as_array()?;
        match a.as_slice() {
            [x, y, z] => Some([x.as_f64()?, y.as_f64()?, z.as_f64()?]),
            _ => None,
        }
    };
    let sig = match (
        triple(&v, BIAS_SIGMA_FIELDS[0]),
        triple(&v, BIAS_SIGMA_FIELDS[1]),
    ) {
        (Some(g), Some(a)) => Some([g[0], g[1], g[2], a[0], a[1], a[2]]),
        _ => None,
    };
    if let Some(o) = v.as_object_mut() {
        o.entry("_pad")
            .or_insert_with(|| serde_json::json!([0, 0, 0]));
    }
    Ok((serde_json::from_value(v)?, sig))
}

/// Rows of a solution CSV read a chunk at a time (memory holds one chunk,
/// not the file: a flight of 10 M rows streams through). Each chunk goes
/// through the project's one row parser ([`solution_csv::parse`]) with the
/// header in front, and the error lines are renumbered to the file's; the
/// bias σ columns ([`BIAS_SIGMA_COLUMNS`]), which that parser may not know,
/// are read here by name when the header has all six.
#[derive(Debug)]
pub struct CsvRows {
    reader: std::io::BufReader<std::fs::File>,
    path: String,
    header: String,
    width: usize,
    sigma_idx: Option<[usize; 6]>,
    /// File line number of the next line to read (the header is line 1).
    next_line: usize,
    chunk: std::vec::IntoIter<(Row, Option<[f64; 6]>)>,
    done: bool,
}

/// Lines parsed per chunk.
const CHUNK_LINES: usize = 1 << 14;

/// The longest line a solution CSV may have (a row is under 1 KiB, the
/// header under 2 KiB): a longer one is refused when it is that long, so a
/// large file without line ends is not read whole into one line.
pub const MAX_CSV_LINE_BYTES: u64 = 64 << 10;

/// One line of `reader` into `line` (appended), at most
/// [`MAX_CSV_LINE_BYTES`]; the bytes read (0 at the end of the file).
fn read_bounded_line(
    reader: &mut impl std::io::BufRead,
    line: &mut String,
) -> std::io::Result<usize> {
    use std::io::{BufRead as _, Read as _};
    let n = reader.take(MAX_CSV_LINE_BYTES + 1).read_line(line)?;
    if n as u64 > MAX_CSV_LINE_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("a line longer than {MAX_CSV_LINE_BYTES} bytes"),
        ));
    }
    Ok(n)
}

impl CsvRows {
    /// Opens `path` and checks its header (an error names the file, and the
    /// file's kind when it is a navlog, MCAP or binary data).
    pub fn open(path: &Path) -> Result<Self, String> {
        use std::io::BufRead;
        let p = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| format!("{p}: {e}"))?;
        let mut reader = std::io::BufReader::with_capacity(1 << 20, file);
        let head = reader.fill_buf().map_err(|e| format!("{p}: {e}"))?;
        if msgs::navlog::starts_as_navlog(head) {
            return Err(solution_csv::ReadCsvError::Navlog { path: p }.to_string());
        }
        if head.starts_with(b"\x89MCAP") {
            return Err(solution_csv::ReadCsvError::Mcap { path: p }.to_string());
        }
        let mut header = String::new();
        read_bounded_line(&mut reader, &mut header).map_err(|e| {
            solution_csv::ReadCsvError::NotText {
                path: p.clone(),
                at: 0,
            }
            .to_string()
                + &format!(" ({e})")
        })?;
        let header = header
            .strip_prefix('\u{feff}')
            .unwrap_or(&header)
            .trim_end()
            .to_owned();
        // The header alone: a missing column is named here.
        solution_csv::parse(&header, &p).map_err(|e| e.to_string())?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let mut idx = [0usize; 6];
        let mut all = true;
        for (k, want) in BIAS_SIGMA_COLUMNS.iter().enumerate() {
            match names.iter().position(|n| n == want) {
                Some(i) => idx[k] = i,
                None => all = false,
            }
        }
        Ok(Self {
            reader,
            width: names.len(),
            sigma_idx: all.then_some(idx),
            header,
            path: p,
            next_line: 2,
            chunk: Vec::new().into_iter(),
            done: false,
        })
    }

    /// True when the header has the bias σ columns.
    pub fn has_bias_sigma(&self) -> bool {
        self.sigma_idx.is_some()
    }

    fn fill(&mut self) -> Result<(), String> {
        let first = self.next_line;
        let mut text = String::with_capacity((self.header.len() + 8) * (CHUNK_LINES + 1));
        text.push_str(&self.header);
        text.push('\n');
        let mut sig = Vec::new();
        let mut line = String::new();
        for _ in 0..CHUNK_LINES {
            line.clear();
            let n = read_bounded_line(&mut self.reader, &mut line).map_err(|e| {
                format!(
                    "{}:{}: {e} (a solution CSV is UTF-8 text)",
                    self.path, self.next_line
                )
            })?;
            if n == 0 {
                self.done = true;
                break;
            }
            let l = line.trim_end_matches(['\n', '\r']);
            if let Some(idx) = self.sigma_idx {
                let f: Vec<&str> = l.split(',').collect();
                let mut v = [f64::NAN; 6];
                if f.len() == self.width {
                    for (k, i) in idx.iter().enumerate() {
                        v[k] = f[*i].trim().parse().map_err(|_| {
                            format!(
                                "{}:{}: column {} is not a number: {:?}",
                                self.path, self.next_line, BIAS_SIGMA_COLUMNS[k], f[*i]
                            )
                        })?;
                    }
                }
                sig.push(Some(v));
            } else {
                sig.push(None);
            }
            text.push_str(l);
            text.push('\n');
            self.next_line += 1;
        }
        let rows = solution_csv::parse(&text, &self.path).map_err(|e| match e {
            solution_csv::ReadCsvError::Row { path, line, what } => {
                format!("{path}:{}: {what}", first + line - 2)
            }
            other => other.to_string(),
        })?;
        self.chunk = rows.into_iter().zip(sig).collect::<Vec<_>>().into_iter();
        Ok(())
    }
}

impl Iterator for CsvRows {
    type Item = Result<(Row, Option<[f64; 6]>), String>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(r) = self.chunk.next() {
                return Some(Ok(r));
            }
            if self.done {
                return None;
            }
            if let Err(e) = self.fill() {
                self.done = true;
                return Some(Err(e));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p =
            std::env::temp_dir().join(format!("polarnav-sf-{}-{name}.mcap", std::process::id()));
        std::fs::write(&p, bytes).expect("write");
        p
    }

    /// A record whose length field claims u64::MAX, 1e18 or just over the
    /// limit is refused as damage before anything of that size is allocated.
    #[test]
    fn an_absurd_record_length_is_refused_without_allocating_it() {
        for (k, len) in [
            u64::MAX,
            1_000_000_000_000_000_000,
            MAX_MCAP_RECORD_BYTES as u64 + 1,
        ]
        .into_iter()
        .enumerate()
        {
            let mut bytes = b"\x89MCAP0\r\n".to_vec();
            // A chunk (opcode 0x06) that says it is `len` bytes long.
            bytes.push(0x06);
            bytes.extend_from_slice(&len.to_le_bytes());
            bytes.extend_from_slice(&[0u8; 64]);
            let p = write(&format!("len{k}"), &bytes);
            let e = load(&p).expect_err("absurd length");
            assert!(e.contains("MCAP"), "{e}");
            let _ = std::fs::remove_file(&p);
        }
    }

    /// The bias σ of a `/solution` message is read by field name when the
    /// message has it (solution version 3) and absent otherwise.
    #[test]
    fn bias_sigma_fields_are_read_when_present() {
        let s = Solution {
            t_ns: 5,
            ..Default::default()
        };
        let mut v = serde_json::to_value(s).expect("json");
        // A version 2 message: without the bias σ fields.
        for f in BIAS_SIGMA_FIELDS {
            v.as_object_mut().expect("object").remove(f);
        }
        let plain = serde_json::to_vec(&v).expect("bytes");
        let (back, sig) = solution_of_json(&plain).expect("v2 message");
        assert_eq!(back.t_ns, 5);
        assert!(sig.is_none());
        let o = v.as_object_mut().expect("object");
        o.insert(
            BIAS_SIGMA_FIELDS[0].into(),
            serde_json::json!([1e-7, 2e-7, 3e-7]),
        );
        o.insert(
            BIAS_SIGMA_FIELDS[1].into(),
            serde_json::json!([1e-3, 2e-3, 3e-3]),
        );
        let (_, sig) = solution_of_json(&serde_json::to_vec(&v).expect("bytes")).expect("v3");
        assert_eq!(
            sig.map(|x| x.map(f64::to_bits)),
            Some([1e-7, 2e-7, 3e-7, 1e-3, 2e-3, 3e-3].map(f64::to_bits))
        );
    }

    /// The bias σ columns of a CSV are read by name, in any position; a
    /// CSV without them reads as before.
    #[test]
    fn bias_sigma_columns_are_read_by_name() {
        let row = solution_csv::RowWriter::new()
            .row(&Solution {
                t_ns: 1_000_000_000,
                ..Default::default()
            })
            .trim_end()
            .to_owned();
        // A CSV written before the bias σ columns: the header and the row
        // without them (they close today's header).
        let header = solution_csv::HEADER
            .split(',')
            .filter(|c| !BIAS_SIGMA_COLUMNS.contains(c))
            .collect::<Vec<_>>()
            .join(",");
        let n = header.split(',').count();
        let row = row.split(',').take(n).collect::<Vec<_>>().join(",");
        let dir = std::env::temp_dir();
        let plain = dir.join(format!("polarnav-sf-{}-plain.csv", std::process::id()));
        std::fs::write(&plain, format!("{header}\n{row}\n")).expect("write");
        let l = load(&plain).expect("plain");
        assert_eq!(l.bias_sigma, vec![None]);
        let extra = dir.join(format!("polarnav-sf-{}-v3.csv", std::process::id()));
        std::fs::write(
            &extra,
            format!(
                "{},{header}\n0.25,0.5,0.75,1.5,2.5,3.5,{row}\n",
                BIAS_SIGMA_COLUMNS.join(",")
            ),
        )
        .expect("write");
        let l = load(&extra).expect("v3");
        assert_eq!(
            l.bias_sigma[0].map(|x| x.map(f64::to_bits)),
            Some([0.25, 0.5, 0.75, 1.5, 2.5, 3.5].map(f64::to_bits))
        );
        assert_eq!(l.rows[0].t_s.to_bits(), 1.0f64.to_bits());
        let bad = dir.join(format!("polarnav-sf-{}-bad.csv", std::process::id()));
        std::fs::write(
            &bad,
            format!(
                "{},{header}\n0.25,x,0.75,1.5,2.5,3.5,{row}\n",
                BIAS_SIGMA_COLUMNS.join(",")
            ),
        )
        .expect("write");
        let e = load(&bad).expect_err("not a number");
        assert!(
            e.contains("bad.csv:2:") && e.contains("sig_bg_y_rps"),
            "{e}"
        );
        for p in [plain, extra, bad] {
            let _ = std::fs::remove_file(p);
        }
    }

    /// Not MCAP, or MCAP without any solution: an error that names the file.
    #[test]
    fn a_file_without_solutions_is_refused_naming_it() {
        let p = write("empty", b"\x89MCAP0\r\n");
        let e = load(&p).expect_err("no solution");
        assert!(e.contains(&p.display().to_string()), "{e}");
        let _ = std::fs::remove_file(&p);
        let p = write("text", b"t_s,frame\n1,g\n");
        assert!(load(&p).is_err());
        let _ = std::fs::remove_file(&p);
    }

    /// A file without line ends (a renamed binary or a damaged copy) is
    /// refused at the first line longer than 64 KiB, in the header or in
    /// a row, naming the file and the line, not read whole into one line.
    #[test]
    fn a_line_longer_than_64_kib_is_refused_naming_the_line() {
        let p = write("long-header", &vec![b'a'; 4 << 20]);
        let e = CsvRows::open(&p).expect_err("no header");
        assert!(
            e.contains(&p.display().to_string()) && e.contains("longer than 65536 bytes"),
            "{e}"
        );
        let _ = std::fs::remove_file(&p);
        let mut text = format!("{}\n", solution_csv::HEADER).into_bytes();
        text.extend(std::iter::repeat_n(b'1', 4 << 20));
        let p = write("long-row", &text);
        let e = CsvRows::open(&p)
            .expect("the header is whole")
            .find_map(Result::err)
            .expect("the row is refused");
        assert!(
            e.contains(&format!("{}:2:", p.display())) && e.contains("longer than 65536 bytes"),
            "{e}"
        );
        let _ = std::fs::remove_file(&p);
    }

    /// A small MCAP file with one `/solution` channel of `encoding` and the
    /// given messages.
    fn mcap_with(name: &str, encoding: &str, messages: &[Vec<u8>]) -> std::path::PathBuf {
        mcap_of(
            name,
            encoding,
            &[("/solution", "polarnav.Solution", messages)],
        )
    }

    /// A small MCAP file with channels (topic, schema name, messages) of
    /// `encoding`, their messages in turn, logged 1 ns apart.
    fn mcap_of(
        name: &str,
        encoding: &str,
        channels: &[(&str, &str, &[Vec<u8>])],
    ) -> std::path::PathBuf {
        let p =
            std::env::temp_dir().join(format!("polarnav-sf-{}-{name}.mcap", std::process::id()));
        let mut w = mcap::WriteOptions::new()
            .compression(None)
            .create(std::io::BufWriter::new(
                std::fs::File::create(&p).expect("create"),
            ))
            .expect("writer");
        let mut t = 0;
        for (topic, schema_name, messages) in channels {
            let schema = w
                .add_schema(schema_name, encoding, pb::FILE_DESCRIPTOR_SET)
                .expect("schema");
            let ch = w
                .add_channel(schema, topic, encoding, &std::collections::BTreeMap::new())
                .expect("channel");
            for (k, m) in messages.iter().enumerate() {
                let header = mcap::records::MessageHeader {
                    channel_id: ch,
                    sequence: k as u32 + 1,
                    log_time: t,
                    publish_time: t,
                };
                t += 1;
                w.write_to_known_channel(&header, m).expect("message");
            }
        }
        w.finish().expect("finish");
        p
    }

    /// One protobuf `/solution` at 1 ns.
    fn one_solution() -> Vec<u8> {
        let s = Solution {
            t_ns: 1,
            lat_rad: 1.2,
            h_m: 100.0,
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        prost::Message::encode_to_vec(&pb::Solution::from_wire(&s))
    }

    /// A few kilobytes of zstd chunks of one repeated `/solution` (a
    /// decompression bomb: here 40 MB of messages) are refused, naming the
    /// file, once the messages pass 32 times its size; the same messages
    /// in a file that is their own size are read.
    #[test]
    fn a_file_that_expands_beyond_32_times_its_size_is_refused() {
        let one = one_solution();
        let messages = vec![one.clone(); 40_000_000 / (one.len() + 31)];
        let write = |name: &str, compression| {
            let p = std::env::temp_dir()
                .join(format!("polarnav-sf-{}-{name}.mcap", std::process::id()));
            // Large chunks without message indexes, every message stamped
            // alike (unlike mcap_of's, whose stamps count up and leave the
            // file a tenth of its messages): what a bomb would be.
            let mut w = mcap::WriteOptions::new()
                .compression(compression)
                .chunk_size(Some(32 << 20))
                .emit_message_indexes(false)
                .create(std::io::BufWriter::new(
                    std::fs::File::create(&p).expect("create"),
                ))
                .expect("writer");
            let schema = w
                .add_schema("polarnav.Solution", "protobuf", pb::FILE_DESCRIPTOR_SET)
                .expect("schema");
            let ch = w
                .add_channel(
                    schema,
                    "/solution",
                    "protobuf",
                    &std::collections::BTreeMap::new(),
                )
                .expect("channel");
            for m in &messages {
                let header = mcap::records::MessageHeader {
                    channel_id: ch,
                    sequence: 0,
                    log_time: 0,
                    publish_time: 0,
                };
                w.write_to_known_channel(&header, m).expect("message");
            }
            w.finish().expect("finish");
            p
        };
        let bomb = write("bomb", Some(mcap::Compression::Zstd));
        let size = std::fs::metadata(&bomb).unwrap().len();
        assert!(size < 2_000_000, "the bomb is {size} bytes");
        let e = load(&bomb).expect_err("refused");
        assert!(
            e.contains(&bomb.display().to_string()) && e.contains("expand"),
            "{e}"
        );
        let _ = std::fs::remove_file(&bomb);
        let plain = write("plain", None);
        assert_eq!(load(&plain).expect("read").rows.len(), messages.len());
        let _ = std::fs::remove_file(&plain);
    }

    /// A recording's MCAP written before each update went on its channel
    /// once repeats an aid's last update at every status until the next:
    /// each is read as one update, a new one (another innovation, test
    /// ratio or verdict) as another.
    #[test]
    fn an_update_repeated_by_status_records_is_read_once() {
        let solution = [one_solution()];
        let update = |t_ns: u64, innovation: f64, fused: bool| {
            prost::Message::encode_to_vec(&pb::AidUpdate {
                t_ns,
                innovation_rad: vec![innovation, 0.0, 0.0],
                innovation_sigma_rad: vec![1e-5; 3],
                test_ratio: 0.5,
                fused,
                ..Default::default()
            })
        };
        // Status at 1 Hz, star tracker at 0.1 Hz; the third update has the
        // second's innovation but was rejected.
        let mut star = Vec::new();
        for k in 0..30u64 {
            let (innovation, fused) = match k {
                0..10 => (1e-5, true),
                10..20 => (2e-5, true),
                _ => (2e-5, false),
            };
            star.push(update(k * 1_000_000_000, innovation, fused));
        }
        let p = mcap_of(
            "repeated",
            "protobuf",
            &[
                ("/solution", "polarnav.Solution", &solution),
                ("/aid/star", "polarnav.AidUpdate", &star),
            ],
        );
        let l = load(&p).expect("load");
        let star = l.aids.expect("aids")[AidKind::Star].clone();
        let t: Vec<u64> = star.iter().map(|a| a.t_ns).collect();
        assert_eq!(t, [0, 10_000_000_000, 20_000_000_000]);
        let _ = std::fs::remove_file(&p);
    }

    /// Protobuf `/solution` messages read back to the wire solution (angles
    /// through degrees, to rounding) with their bias σ, as do the JSON ones
    /// of earlier versions; a message that does not decode is refused with
    /// the file, topic, sequence and encoding.
    #[test]
    fn protobuf_solutions_read_back_and_a_damaged_one_is_named() {
        let s = Solution {
            t_ns: 2_000_000_000,
            lat_rad: 1.2,
            lon_rad: -0.4,
            h_m: 12_000.0,
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            sigma_gyro_bias_rps: [1e-7, 2e-7, 3e-7],
            sigma_accel_bias_mps2: [1e-4, 2e-4, 3e-4],
            frame: 1,
            ..Default::default()
        };
        let good = prost::Message::encode_to_vec(&pb::Solution::from_wire(&s));
        let p = mcap_with("pb", "protobuf", std::slice::from_ref(&good));
        let l = load(&p).expect("load");
        assert_eq!(l.rows.len(), 1);
        assert!((l.rows[0].lat_deg - 1.2f64.to_degrees()).abs() < 1e-12);
        assert_eq!(l.rows[0].frame, 'G');
        let sig = l.bias_sigma[0].expect("bias σ");
        assert!((sig[2] - 3e-7).abs() < 1e-20 && (sig[5] - 3e-4).abs() < 1e-17);
        let _ = std::fs::remove_file(&p);

        // An MCAP file of an earlier version, its /solution JSON, reads the same.
        let p = mcap_with("json", "json", &[serde_json::to_vec(&s).expect("json")]);
        let l = load(&p).expect("load JSON");
        assert_eq!(l.rows.len(), 1);
        assert!((l.rows[0].lat_deg - 1.2f64.to_degrees()).abs() < 1e-12);
        let _ = std::fs::remove_file(&p);

        // A channel in another encoding is refused, not decoded as protobuf.
        let p = mcap_with("cbor", "cbor", std::slice::from_ref(&good));
        let e = load(&p).expect_err("cbor");
        assert!(e.contains("(cbor)") && e.contains("not protobuf"), "{e}");
        let _ = std::fs::remove_file(&p);

        // A truncated message and a run of 0xff bytes do not decode.
        for (k, bad) in [good[..good.len() / 2].to_vec(), vec![0xff; 16]]
            .into_iter()
            .enumerate()
        {
            let p = mcap_with(&format!("bad{k}"), "protobuf", &[good.clone(), bad]);
            let e = load(&p).expect_err("damaged message");
            assert!(e.contains(&p.display().to_string()), "{e}");
            assert!(e.contains("/solution message 2 (protobuf)"), "{e}");
            let _ = std::fs::remove_file(&p);
        }
    }

    /// An aid update is read from the pair of fields of its channel's
    /// unit; a pair of another unit, a σ missing or extra, or more
    /// components than the aid has are refused with what the message holds.
    #[test]
    #[allow(
        clippy::float_cmp,
        reason = "values are copied (σ squared exactly), so equal bit for bit"
    )]
    fn an_aid_update_is_read_only_in_its_channels_unit() {
        let cns = pb::AidUpdate {
            t_ns: 7,
            innovation_m: vec![3.0, -4.0],
            innovation_sigma_m: vec![2.0, 0.5],
            test_ratio: 0.25,
            fused: true,
            ..Default::default()
        };
        let p = AidPoint::from_proto(&cns, AidKind::Cns).unwrap();
        assert_eq!(p.innovation, [3.0, -4.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(p.innovation_var, [4.0, 0.25, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            (p.t_ns, p.test_ratio, p.fused, p.physical),
            (7, 0.25, 1, true)
        );
        // Baro's one component in metres: two are refused.
        let e = AidPoint::from_proto(&cns, AidKind::Baro).unwrap_err();
        assert!(
            e.contains("_m") && e.contains("/aid/baro") && e.contains("at most 1"),
            "{e}"
        );
        let e = AidPoint::from_proto(&cns, AidKind::Srs).unwrap_err();
        assert!(
            e.contains("_m") && e.contains("/aid/srs") && e.contains("at most 0"),
            "{e}"
        );
        let short = pb::AidUpdate {
            innovation_sigma_m: vec![2.0],
            ..cns.clone()
        };
        let e = AidPoint::from_proto(&short, AidKind::Cns).unwrap_err();
        assert!(e.contains("2 innovation components in _m with 1"), "{e}");
        let four = pb::AidUpdate {
            innovation_m: vec![1.0; 4],
            innovation_sigma_m: vec![1.0; 4],
            ..cns.clone()
        };
        assert!(AidPoint::from_proto(&four, AidKind::Cns).is_err());
        let star = pb::AidUpdate {
            innovation_rad: vec![1e-5; 3],
            innovation_sigma_rad: vec![2e-5; 3],
            ..Default::default()
        };
        assert_eq!(
            AidPoint::from_proto(&star, AidKind::Star)
                .unwrap()
                .innovation,
            [1e-5, 1e-5, 1e-5, 0.0, 0.0, 0.0]
        );
        // No innovation at all (no component): read as zeros without σ.
        let none = AidPoint::from_proto(&pb::AidUpdate::default(), AidKind::Srs).unwrap();
        assert!(none.normalized(0).is_none());
    }

    /// A solution read from a protobuf `/solution` equals, bit for bit,
    /// the same solution read from the CSV row the batch writes for it,
    /// angles included: 2 000 solutions with angles, σ and positions drawn
    /// over their ranges (many of whose degrees do not survive a trip
    /// through radians and back).
    #[test]
    fn a_protobuf_solution_reads_as_its_csv_row_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut u = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut msgs = Vec::new();
        let mut csv = String::from(solution_csv::header());
        csv.push('\n');
        let mut writer = solution_csv::RowWriter::new();
        let mut moved = 0;
        for k in 0..2000u64 {
            let s = Solution {
                t_ns: (k + 1) * 5_000_000,
                lat_rad: (u() - 0.5) * std::f64::consts::PI,
                lon_rad: (u() - 0.5) * std::f64::consts::TAU,
                h_m: u() * 20_000.0,
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                heading_rad: u() * std::f64::consts::TAU,
                grid_heading_rad: u() * std::f64::consts::TAU,
                pitch_rad: (u() - 0.5) * 0.5,
                roll_rad: (u() - 0.5) * 0.5,
                sigma_att_rad: [u() * 1e-3, u() * 1e-3, u() * 1e-2],
                frame: (k % 2) as u8,
                ..Default::default()
            };
            let deg = s.lat_rad.to_degrees();
            moved += usize::from(deg.to_radians().to_degrees().to_bits() != deg.to_bits());
            msgs.push(prost::Message::encode_to_vec(&pb::Solution::from_wire(&s)));
            csv.push_str(writer.row(&s));
        }
        assert!(moved > 100, "only {moved} latitudes would have moved");
        let mcap = mcap_with("bits", "protobuf", &msgs);
        let csv_path =
            std::env::temp_dir().join(format!("polarnav-sf-{}-bits.csv", std::process::id()));
        std::fs::write(&csv_path, csv).expect("write");
        let (from_mcap, from_csv) = (load(&mcap).expect("mcap"), load(&csv_path).expect("csv"));
        assert_eq!(from_mcap.rows.len(), 2000);
        for (a, b) in from_mcap.rows.iter().zip(&from_csv.rows) {
            let bits = |r: &Row| {
                [
                    r.t_s,
                    r.lat_deg,
                    r.lon_deg,
                    r.h_m,
                    r.heading_deg,
                    r.pitch_deg,
                    r.roll_deg,
                    r.grid_heading_deg,
                ]
                .into_iter()
                .chain(r.sigma_att_deg)
                .map(f64::to_bits)
                .collect::<Vec<_>>()
            };
            assert_eq!(bits(a), bits(b), "{a:?}\n{b:?}");
            assert_eq!(a.frame, b.frame);
        }
        let _ = std::fs::remove_file(&mcap);
        let _ = std::fs::remove_file(&csv_path);
    }
}
