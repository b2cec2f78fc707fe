//! navlog: the record stream of logged, simulated and recorded flights.
//!
//! A file is a sequence of frames. Each frame is
//! `COBS( postcard(Record) ‖ CRC-32(postcard bytes), little endian ) ‖ 0x00`.
//! COBS guarantees that 0x00 appears only as the delimiter, so a damaged
//! frame costs only itself: the reader resynchronises at the next 0x00. The
//! CRC catches bit flips that still decode. The first record is a
//! [`Header`] with [`MAGIC`] and [`FORMAT_VERSION`].
//!
//! [`NavlogReader`] yields every intact record of a truncated or corrupted
//! file and keeps a [`ReadReport`] of what it skipped and why; it never
//! stops early on damage.

use std::io::{BufRead, Write};

use serde::{Deserialize, Serialize};

use crate::aids::{AidKind, AidSample};
use crate::payloads::{ImuSample, InitState, Solution, TruthRecord};
use crate::status::Status;

/// First bytes of every navlog's header record.
pub const MAGIC: [u8; 8] = *b"POLARNAV";
/// Version of the record format; bump on any change of [`Record`].
/// 3: the star tracker record (appended last) and the `_v4` status record
/// (star counters and aid status; a status record of version 2 no longer
/// decodes and is skipped as incompatible, every other record still reads).
///    and [`Record::TruthBias`] appended (a version-2 reader skips those
/// frames as undecodable and reads the rest).
/// 4: the `_v3` solution record (bias σ). A solution record of a format-3
/// (or -2) file is read through its old `_v2` layout and converted, with
/// the bias σ unknown (NaN); a format-3 reader skips a format-4 solution
/// record as undecodable and reads the rest.
/// 5: the `_v5` status record (a sixth component of every aid's status:
/// 6 innovation components, refusals by cause, the integrity test; and
/// `rejected_integrity` per stream). A status record of format 4 or before
/// does not decode and is skipped as incompatible; every other record reads.
/// 6: the GNSS record (variant 11, appended) and the `_v6` status record
/// (a fifth aid in `aids` and `streams`); a status record of format 5 or
/// before is skipped as incompatible, every other record reads.
/// 7: the dual-antenna baseline and magnetometer records (variants 12
/// and 13, appended) and the `_v7` status record (a sixth and a seventh
/// aid in `aids` and `streams`); a status record of format 6 or before is
/// skipped as incompatible, every other record reads.
/// 8: the `_v2` init record (how its attitude was found: `method`,
/// `heading_aid`). An init record of format 7 or before is read through
/// its old `_v1` layout as given from outside (method 0); a format-7
/// reader reads a format-8 init record as `_v1` (postcard ignores the
/// trailing bytes). The status record's layout is unchanged (its new
/// `init_method` bytes were padding).
pub const FORMAT_VERSION: u16 = 8;
/// Frames longer than this are treated as corruption (the largest record is ~1 kB
/// plus the header's scenario text).
pub const MAX_FRAME_BYTES: usize = 1 << 20;

/// File header: identifies the format and the flight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub magic: [u8; 8],
    pub format_version: u16,
    /// Program and version that wrote the file, e.g. `sensor-replay 0.1.0 simulate`.
    pub producer: String,
    /// Scenario or source name.
    pub scenario: String,
    /// Random seed of a simulation (0 if not simulated).
    pub seed: u64,
    /// Free text: the scenario file contents, import source, etc.
    pub metadata: String,
}

impl Header {
    pub fn new(producer: &str, scenario: &str, seed: u64, metadata: &str) -> Self {
        Self {
            magic: MAGIC,
            format_version: FORMAT_VERSION,
            producer: producer.to_owned(),
            scenario: scenario.to_owned(),
            seed,
            metadata: metadata.to_owned(),
        }
    }
}

/// One navlog record. The large, infrequent payloads are boxed so that a
/// record is about the size of an IMU sample (moving 800-byte SRS-sized
/// values per IMU record cost 11 % of batch time).
///
/// Encoded as postcard encodes an enum (variant index, then content) with
/// the indices fixed: the records here at 0, 1, 2, 6, 7, 8 and 10, and
/// each aid's sample at its declaration's `record` (SRS 3, CNS 4, baro 5,
/// star 9, ...). An index is never reused, so a file keeps its encoding
/// whatever aids are declared after it was written.
#[derive(Debug, Clone, PartialEq)]
pub enum Record {
    Header(Box<Header>),
    Init(InitState),
    Imu(ImuSample),
    /// A sample of any aid.
    Aid(Box<AidSample>),
    Truth(TruthRecord),
    Solution(Box<Solution>),
    Status(Box<Status>),
    /// The simulated IMU bias at a truth epoch (constant draw plus
    /// Gauss–Markov part), body axes.
    TruthBias(TruthBias),
}

/// Postcard writes an enum as its variant index and the variant's content;
/// the indices of the records that are not aids are fixed here, and each
/// aid's is its declaration's `record` (indices are never reused, so every
/// file keeps its encoding whatever aids are added after it).
const TAG_HEADER: u32 = 0;
const TAG_INIT: u32 = 1;
const TAG_IMU: u32 = 2;
const TAG_TRUTH: u32 = 6;
const TAG_SOLUTION: u32 = 7;
const TAG_STATUS: u32 = 8;
const TAG_TRUTH_BIAS: u32 = 10;

impl Serialize for Record {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        const R: &str = "Record";
        match self {
            Record::Header(x) => s.serialize_newtype_variant(R, TAG_HEADER, "Header", x),
            Record::Init(x) => s.serialize_newtype_variant(R, TAG_INIT, "Init", x),
            Record::Imu(x) => s.serialize_newtype_variant(R, TAG_IMU, "Imu", x),
            Record::Truth(x) => s.serialize_newtype_variant(R, TAG_TRUTH, "Truth", x),
            Record::Solution(x) => s.serialize_newtype_variant(R, TAG_SOLUTION, "Solution", x),
            Record::Status(x) => s.serialize_newtype_variant(R, TAG_STATUS, "Status", x),
            Record::TruthBias(x) => s.serialize_newtype_variant(R, TAG_TRUTH_BIAS, "TruthBias", x),
            Record::Aid(a) => {
                let d = a.kind().decl();
                crate::match_aid!(&**a, x => s.serialize_newtype_variant(R, d.record, d.variant, x))
            }
        }
    }
}

impl<'de> Deserialize<'de> for Record {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::{self, EnumAccess, VariantAccess};

        /// A variant index (postcard's) or name (a self-describing format's).
        struct Tag(u32);
        impl<'de> Deserialize<'de> for Tag {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct V;
                impl de::Visitor<'_> for V {
                    type Value = Tag;
                    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                        f.write_str("a navlog record variant")
                    }
                    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Tag, E> {
                        u32::try_from(v)
                            .map(Tag)
                            .map_err(|_| E::custom(format!("record variant {v}")))
                    }
                    fn visit_str<E: de::Error>(self, v: &str) -> Result<Tag, E> {
                        let fixed = [
                            ("Header", TAG_HEADER),
                            ("Init", TAG_INIT),
                            ("Imu", TAG_IMU),
                            ("Truth", TAG_TRUTH),
                            ("Solution", TAG_SOLUTION),
                            ("Status", TAG_STATUS),
                            ("TruthBias", TAG_TRUTH_BIAS),
                        ];
                        fixed
                            .into_iter()
                            .find(|(n, _)| *n == v)
                            .map(|(_, t)| t)
                            .or_else(|| {
                                AidKind::ALL
                                    .into_iter()
                                    .find(|k| k.decl().variant == v)
                                    .map(|k| k.decl().record)
                            })
                            .map(Tag)
                            .ok_or_else(|| E::unknown_variant(v, &[]))
                    }
                }
                d.deserialize_identifier(V)
            }
        }

        struct V;
        impl<'de> de::Visitor<'de> for V {
            type Value = Record;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a navlog record")
            }
            fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<Record, A::Error> {
                let (Tag(t), v) = data.variant::<Tag>()?;
                Ok(match t {
                    TAG_HEADER => Record::Header(v.newtype_variant()?),
                    TAG_INIT => Record::Init(v.newtype_variant()?),
                    TAG_IMU => Record::Imu(v.newtype_variant()?),
                    TAG_TRUTH => Record::Truth(v.newtype_variant()?),
                    TAG_SOLUTION => Record::Solution(v.newtype_variant()?),
                    TAG_STATUS => Record::Status(v.newtype_variant()?),
                    TAG_TRUTH_BIAS => Record::TruthBias(v.newtype_variant()?),
                    other => {
                        let Some(kind) = AidKind::from_record(other) else {
                            return Err(de::Error::custom(format!(
                                "unknown navlog record variant {other}"
                            )));
                        };
                        let sample: AidSample = crate::match_aid_kind!(kind, P => {
                            v.newtype_variant::<P>()?.into()
                        });
                        Record::Aid(Box::new(sample))
                    }
                })
            }
        }
        d.deserialize_enum("Record", &[], V)
    }
}

/// True IMU bias of a simulated flight at `t_ns`, body axes.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TruthBias {
    pub t_ns: u64,
    /// Gyro bias (rad/s).
    pub gyro_bias_rps: [f64; 3],
    /// Accelerometer bias (m/s²).
    pub accel_bias_mps2: [f64; 3],
}

impl Record {
    /// Time stamp of the record (`None` for the header).
    pub fn t_ns(&self) -> Option<u64> {
        match self {
            Record::Header(_) => None,
            Record::Init(r) => Some(r.t_ns),
            Record::Imu(r) => Some(r.t_ns),
            Record::Aid(r) => Some(r.t_ns()),
            Record::Truth(r) => Some(r.t_ns),
            Record::Solution(r) => Some(r.t_ns),
            Record::Status(r) => Some(r.t_ns),
            Record::TruthBias(r) => Some(r.t_ns),
        }
    }

    /// The record of an aid's sample.
    pub fn aid(sample: impl Into<AidSample>) -> Self {
        Record::Aid(Box::new(sample.into()))
    }
}

/// Errors of writing a navlog.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The underlying writer failed (disk full, closed pipe, ...).
    #[error("navlog write failed: {0}")]
    Io(#[from] std::io::Error),
    /// The record could not be serialized (should not happen for the types above).
    #[error("navlog record could not be serialized: {0}")]
    Encode(#[from] postcard::Error),
}

/// Where a producer of records (the simulator) puts them: a navlog file
/// ([`NavlogWriter`]) or, for a process that navigates what it produced
/// (a campaign's run), the records themselves ([`RecordVec`]), which are
/// those a reader of the file would return (the encoding round-trips every
/// value exactly), without framing and decoding them.
pub trait RecordSink {
    /// Appends one record.
    fn put(&mut self, record: Record) -> Result<(), WriteError>;
}

impl<W: Write> RecordSink for NavlogWriter<W> {
    fn put(&mut self, record: Record) -> Result<(), WriteError> {
        self.write(&record)
    }
}

/// Records kept in memory, the header first.
#[derive(Debug, Clone, Default)]
pub struct RecordVec(pub Vec<Record>);

impl RecordVec {
    /// Starts with `header` as the first record, as [`NavlogWriter::new`] does.
    pub fn new(header: Header) -> Self {
        Self(vec![Record::Header(Box::new(header))])
    }
}

impl RecordSink for RecordVec {
    fn put(&mut self, record: Record) -> Result<(), WriteError> {
        self.0.push(record);
        Ok(())
    }
}

/// Writes framed records. Buffers are reused: no allocation per record once warm.
#[derive(Debug)]
pub struct NavlogWriter<W: Write> {
    out: W,
    raw: Vec<u8>,
    framed: Vec<u8>,
    records: u64,
}

impl<W: Write> NavlogWriter<W> {
    /// Starts a navlog on `out` and writes `header` as its first record.
    pub fn new(out: W, header: Header) -> Result<Self, WriteError> {
        let mut w = Self {
            out,
            raw: Vec::with_capacity(2048),
            framed: Vec::with_capacity(2048),
            records: 0,
        };
        w.write(&Record::Header(Box::new(header)))?;
        Ok(w)
    }

    /// Appends one record.
    pub fn write(&mut self, record: &Record) -> Result<(), WriteError> {
        self.raw.clear();
        self.raw = postcard::to_extend(record, std::mem::take(&mut self.raw))?;
        let crc = crc32fast::hash(&self.raw);
        self.raw.extend_from_slice(&crc.to_le_bytes());
        self.framed.clear();
        self.framed
            .resize(cobs::max_encoding_length(self.raw.len()) + 1, 0);
        let n = cobs::encode(&self.raw, &mut self.framed);
        self.framed[n] = 0;
        self.out.write_all(&self.framed[..=n])?;
        self.records += 1;
        Ok(())
    }

    /// Records written so far, header included.
    pub fn records_written(&self) -> u64 {
        self.records
    }

    /// Hands every record written so far to the underlying writer and
    /// flushes it (to the kernel for a file: a killed process loses nothing
    /// written before; no fsync).
    pub fn flush(&mut self) -> Result<(), WriteError> {
        self.out.flush()?;
        Ok(())
    }

    /// Flushes and returns the underlying writer.
    pub fn finish(mut self) -> Result<W, WriteError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Why a frame was skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SkipReason {
    /// COBS structure invalid (a byte was damaged).
    Framing,
    /// Decoded, but the CRC does not match (bit flip).
    Checksum,
    /// CRC matched but the record does not deserialize (written by an incompatible version).
    Decode,
    /// The file ends inside a frame (truncated write).
    Truncated,
    /// A frame longer than [`MAX_FRAME_BYTES`] (garbage between delimiters).
    Oversized,
}

/// What the reader skipped, so that damage is reported, never hidden.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadReport {
    /// Intact records returned.
    pub records: u64,
    /// Frames skipped, by reason.
    pub framing: u64,
    pub checksum: u64,
    pub decode: u64,
    pub truncated: u64,
    pub oversized: u64,
    /// Bytes belonging to skipped frames.
    pub skipped_bytes: u64,
    /// Byte offset of the first skipped frame, if any.
    pub first_skip_offset: Option<u64>,
    /// Byte offset of the first frame skipped for a checksum mismatch whose
    /// contents, read without the failed check, are an init record: a
    /// damaged init record, which a reader that finds no init names.
    pub damaged_init_offset: Option<u64>,
}

impl ReadReport {
    /// Total frames skipped for any reason.
    pub fn skipped_frames(&self) -> u64 {
        self.framing + self.checksum + self.decode + self.truncated + self.oversized
    }

    /// True when nothing was skipped.
    pub fn is_clean(&self) -> bool {
        self.skipped_frames() == 0
    }

    fn note(&mut self, reason: SkipReason, offset: u64, len: u64) {
        match reason {
            SkipReason::Framing => self.framing += 1,
            SkipReason::Checksum => self.checksum += 1,
            SkipReason::Decode => self.decode += 1,
            SkipReason::Truncated => self.truncated += 1,
            SkipReason::Oversized => self.oversized += 1,
        }
        self.skipped_bytes += len;
        self.first_skip_offset.get_or_insert(offset);
    }
}

impl std::fmt::Display for ReadReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} records read", self.records)?;
        if self.is_clean() {
            return write!(f, ", nothing skipped");
        }
        write!(
            f,
            "; skipped {} frame(s), {} byte(s) (framing {}, checksum {}, decode {}, truncated {}, oversized {}), first at byte {}",
            self.skipped_frames(),
            self.skipped_bytes,
            self.framing,
            self.checksum,
            self.decode,
            self.truncated,
            self.oversized,
            self.first_skip_offset.unwrap_or(0)
        )?;
        match self.damaged_init_offset {
            Some(at) => write!(f, "; the frame at byte {at} was an init record"),
            None => Ok(()),
        }
    }
}

/// Errors that stop reading altogether (damage inside the file never does).
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The underlying reader failed.
    #[error("navlog read failed: {0}")]
    Io(#[from] std::io::Error),
}

/// Streaming reader: an iterator of intact records; see [`NavlogReader::report`].
#[derive(Debug)]
pub struct NavlogReader<R: BufRead> {
    input: R,
    frame: Vec<u8>,
    decoded: Vec<u8>,
    offset: u64,
    report: ReadReport,
    done: bool,
}

impl<R: BufRead> NavlogReader<R> {
    pub fn new(input: R) -> Self {
        Self {
            input,
            frame: Vec::with_capacity(2048),
            decoded: Vec::with_capacity(2048),
            offset: 0,
            report: ReadReport::default(),
            done: false,
        }
    }

    /// What has been read and skipped so far (complete once the iterator ends).
    pub fn report(&self) -> &ReadReport {
        &self.report
    }

    /// Reads the next intact record; damaged frames are counted and skipped.
    /// `Ok(None)` at the end of the input.
    pub fn next_record(&mut self) -> Result<Option<Record>, ReadError> {
        while !self.done {
            let start = self.offset;
            // A frame whose delimiter is in the reader's buffer is decoded
            // where it lies; only one that continues past the buffer's end
            // is copied together first (below). Same frames, same report.
            let buf = loop {
                match self.input.fill_buf() {
                    Ok(b) => break b,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(e) => return Err(e.into()),
                }
            };
            if let Some(i) = memchr::memchr(0, buf)
                && i <= MAX_FRAME_BYTES
            {
                let decoded = (i > 0).then(|| decode_frame(&buf[..i], &mut self.decoded));
                self.input.consume(i + 1);
                self.offset += i as u64 + 1;
                match decoded {
                    // A lone delimiter (e.g. a byte flipped to 0 right after another delimiter).
                    None => continue,
                    Some(Ok(record)) => {
                        self.report.records += 1;
                        return Ok(Some(record));
                    }
                    Some(Err(reason)) => {
                        self.skipped(reason, start, i as u64 + 1);
                        continue;
                    }
                }
            }
            self.frame.clear();
            let n = read_frame(&mut self.input, &mut self.frame)?;
            self.offset += n as u64;
            if n == 0 {
                self.done = true;
                break;
            }
            let terminated = self.frame.last() == Some(&0);
            if terminated {
                self.frame.pop();
            } else {
                self.done = true;
                // Trailing bytes without a delimiter: a truncated final frame.
                self.report.note(SkipReason::Truncated, start, n as u64);
                break;
            }
            if self.frame.is_empty() {
                // A lone delimiter (e.g. a byte flipped to 0 right after another delimiter).
                continue;
            }
            if self.frame.len() > MAX_FRAME_BYTES {
                self.report.note(SkipReason::Oversized, start, n as u64);
                continue;
            }
            match decode_frame(&self.frame, &mut self.decoded) {
                Ok(record) => {
                    self.report.records += 1;
                    return Ok(Some(record));
                }
                Err(reason) => self.skipped(reason, start, n as u64),
            }
        }
        Ok(None)
    }

    /// Notes a frame of `len` bytes at `start` skipped for `reason` (its
    /// decoded bytes, if any, in `self.decoded`).
    fn skipped(&mut self, reason: SkipReason, start: u64, len: u64) {
        self.report.note(reason, start, len);
        if reason == SkipReason::Checksum
            && self.report.damaged_init_offset.is_none()
            && unchecked_is_init(&self.decoded)
        {
            self.report.damaged_init_offset = Some(start);
        }
    }
}

impl<R: BufRead> Iterator for NavlogReader<R> {
    type Item = Result<Record, ReadError>;
    fn next(&mut self) -> Option<Self::Item> {
        self.next_record().transpose()
    }
}

/// Reads up to and including the next 0x00, bounded so that garbage without
/// delimiters cannot exhaust memory: past the bound the rest of the run is
/// consumed but not stored.
fn read_frame<R: BufRead>(input: &mut R, frame: &mut Vec<u8>) -> std::io::Result<usize> {
    let mut total = 0;
    loop {
        let buf = match input.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        if buf.is_empty() {
            return Ok(total);
        }
        let (take, found) = match memchr::memchr(0, buf) {
            Some(i) => (i + 1, true),
            None => (buf.len(), false),
        };
        let room = (MAX_FRAME_BYTES + 2).saturating_sub(frame.len());
        if found && take > room {
            // Keep the delimiter visible so the caller sees a terminated, oversized frame.
            frame.extend_from_slice(&buf[..room.saturating_sub(1)]);
            frame.push(0);
        } else {
            frame.extend_from_slice(&buf[..take.min(room)]);
        }
        input.consume(take);
        total += take;
        if found {
            return Ok(total);
        }
    }
}

/// COBS-decodes one frame (without its 0x00 delimiter) into `out`, block by
/// block (a code byte c is followed by c − 1 data bytes and, unless c = 0xFF
/// or the block ends the frame, an implied zero). `None` if malformed. Same
/// result as `cobs::decode`, without its byte-at-a-time loop.
pub fn cobs_decode(frame: &[u8], out: &mut Vec<u8>) -> Option<()> {
    out.clear();
    if frame.is_empty() {
        return None;
    }
    let mut i = 0;
    while i < frame.len() {
        let code = usize::from(frame[i]);
        if code == 0 {
            return None;
        }
        let end = i + code;
        let data = frame.get(i + 1..end)?;
        if data.contains(&0) {
            return None;
        }
        out.extend_from_slice(data);
        if code != 0xFF && end < frame.len() {
            out.push(0);
        }
        i = end;
    }
    Some(())
}

fn decode_frame(frame: &[u8], decoded: &mut Vec<u8>) -> Result<Record, SkipReason> {
    cobs_decode(frame, decoded).ok_or(SkipReason::Framing)?;
    let n = decoded.len();
    if n < 5 {
        return Err(SkipReason::Framing);
    }
    let (body, crc) = decoded[..n].split_at(n - 4);
    let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if crc32fast::hash(body) != crc {
        return Err(SkipReason::Checksum);
    }
    match postcard::from_bytes::<Record>(body) {
        Ok(r) => Ok(r),
        // A solution record of format 2 or 3 (the `_v2` layout), or an
        // init record of format 7 or before (the `_v1` layout).
        Err(_) => match postcard::from_bytes::<legacy::RecordV3>(body) {
            Ok(legacy::RecordV3::Solution(s)) => Ok(Record::Solution(Box::new((*s).into()))),
            Ok(legacy::RecordV3::Init(i)) => Ok(Record::Init(i.into())),
            _ => Err(SkipReason::Decode),
        },
    }
}

/// True when a decoded frame whose checksum failed still reads, without
/// its checksum, as an init record (the last 4 bytes are the CRC). Only a
/// hint for messages: its values are not to be trusted.
fn unchecked_is_init(decoded: &[u8]) -> bool {
    let Some(body) = decoded
        .len()
        .checked_sub(4)
        .filter(|n| *n >= 1)
        .map(|n| &decoded[..n])
    else {
        return false;
    };
    matches!(postcard::from_bytes::<Record>(body), Ok(Record::Init(_)))
        || matches!(
            postcard::from_bytes::<legacy::RecordV3>(body),
            Ok(legacy::RecordV3::Init(_))
        )
}

/// The records of earlier formats whose layout changed, as they were
/// encoded, for reading older files.
mod legacy {
    use serde::{Deserialize, Serialize};

    use crate::payloads::{
        BaroSample, CnsFix, ImuSample, InitState, Solution, SrsSample, TruthRecord,
    };

    /// [`super::Record`] of formats 2 and 3 up to its solution variant (the
    /// variant index is the encoding's first byte: the variants other than
    /// the init and the solution are listed only to keep their indices, 1
    /// and 7; the init record kept its `_v1` layout up to format 7).
    #[derive(Debug, Serialize, Deserialize)]
    pub(super) enum RecordV3 {
        Header(Box<super::Header>),
        Init(InitStateV1),
        Imu(ImuSample),
        Srs(Box<SrsSample>),
        Cns(CnsFix),
        Baro(BaroSample),
        Truth(TruthRecord),
        Solution(Box<SolutionV2>),
    }

    /// `polarnav::Solution_v2`: [`Solution`] without the bias σ.
    #[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
    pub(super) struct SolutionV2 {
        pub t_ns: u64,
        pub seq: u64,
        pub lat_rad: f64,
        pub lon_rad: f64,
        pub h_m: f64,
        pub r_e_m: [f64; 3],
        pub v_e_mps: [f64; 3],
        pub v_enu_mps: [f64; 3],
        pub v_nav_mps: [f64; 3],
        pub grid_angle_rad: f64,
        pub q_b_e: [f64; 4],
        pub heading_rad: f64,
        pub grid_heading_rad: f64,
        pub pitch_rad: f64,
        pub roll_rad: f64,
        pub sigma_pos_enu_m: [f64; 3],
        pub sigma_vel_mps: [f64; 3],
        pub sigma_att_rad: [f64; 3],
        pub gyro_bias_rps: [f64; 3],
        pub accel_bias_mps2: [f64; 3],
        pub reset_t_ns: u64,
        pub reset_delta_pos_e_m: [f64; 3],
        pub reset_delta_vel_e_mps: [f64; 3],
        pub reset_delta_heading_rad: f64,
        pub flags: u32,
        pub switch_count: u32,
        pub reset_count: u32,
        pub frame: u8,
        pub _pad: [u8; 3],
    }

    /// `polarnav::InitState_v1`: [`InitState`] without how its attitude
    /// was found.
    #[derive(Debug, Clone, Copy, Default, Serialize, Deserialize)]
    pub(super) struct InitStateV1 {
        pub t_ns: u64,
        pub seq: u64,
        pub r_e_m: [f64; 3],
        pub v_e_mps: [f64; 3],
        pub q_b_e: [f64; 4],
        pub sigma_pos_h_m: f64,
        pub sigma_pos_v_m: f64,
        pub sigma_vel_h_mps: f64,
        pub sigma_vel_v_mps: f64,
        pub sigma_tilt_rad: f64,
        pub sigma_heading_rad: f64,
    }

    impl From<InitStateV1> for InitState {
        /// Every field kept; given from outside (no sender of `_v1` aligned).
        fn from(i: InitStateV1) -> Self {
            InitState {
                t_ns: i.t_ns,
                seq: i.seq,
                r_e_m: i.r_e_m,
                v_e_mps: i.v_e_mps,
                q_b_e: i.q_b_e,
                sigma_pos_h_m: i.sigma_pos_h_m,
                sigma_pos_v_m: i.sigma_pos_v_m,
                sigma_vel_h_mps: i.sigma_vel_h_mps,
                sigma_vel_v_mps: i.sigma_vel_v_mps,
                sigma_tilt_rad: i.sigma_tilt_rad,
                sigma_heading_rad: i.sigma_heading_rad,
                method: crate::init_method::GIVEN,
                heading_aid: 0,
                _pad: [0; 6],
            }
        }
    }

    impl From<SolutionV2> for Solution {
        /// Every field kept; the bias σ, which `_v2` did not carry, NaN.
        fn from(s: SolutionV2) -> Self {
            Solution {
                t_ns: s.t_ns,
                seq: s.seq,
                lat_rad: s.lat_rad,
                lon_rad: s.lon_rad,
                h_m: s.h_m,
                r_e_m: s.r_e_m,
                v_e_mps: s.v_e_mps,
                v_enu_mps: s.v_enu_mps,
                v_nav_mps: s.v_nav_mps,
                grid_angle_rad: s.grid_angle_rad,
                q_b_e: s.q_b_e,
                heading_rad: s.heading_rad,
                grid_heading_rad: s.grid_heading_rad,
                pitch_rad: s.pitch_rad,
                roll_rad: s.roll_rad,
                sigma_pos_enu_m: s.sigma_pos_enu_m,
                sigma_vel_mps: s.sigma_vel_mps,
                sigma_att_rad: s.sigma_att_rad,
                gyro_bias_rps: s.gyro_bias_rps,
                accel_bias_mps2: s.accel_bias_mps2,
                sigma_gyro_bias_rps: [f64::NAN; 3],
                sigma_accel_bias_mps2: [f64::NAN; 3],
                reset_t_ns: s.reset_t_ns,
                reset_delta_pos_e_m: s.reset_delta_pos_e_m,
                reset_delta_vel_e_mps: s.reset_delta_vel_e_mps,
                reset_delta_heading_rad: s.reset_delta_heading_rad,
                flags: s.flags,
                switch_count: s.switch_count,
                reset_count: s.reset_count,
                frame: s.frame,
                _pad: [0; 3],
            }
        }
    }
}

/// The first init record of a log (the initial state handed to the navigator).
pub fn first_init(records: &[Record]) -> Option<InitState> {
    records.iter().find_map(|r| {
        if let Record::Init(i) = r {
            Some(*i)
        } else {
            None
        }
    })
}

/// The metadata of a log's first header record (the scenario's text and
/// what its producer added), if it has one.
pub fn header_metadata(records: &[Record]) -> Option<&str> {
    records.iter().find_map(|r| match r {
        Record::Header(h) => Some(h.metadata.as_str()),
        _ => None,
    })
}

/// True when `bytes`, the start of a file, begin with a navlog header record
/// (its first frame decodes to a [`Header`] with [`MAGIC`]): how a reader of
/// another format recognizes a navlog passed by mistake. Reads at most one
/// frame's worth of `bytes`.
pub fn starts_as_navlog(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(MAX_FRAME_BYTES + 1)];
    matches!(
        NavlogReader::new(head).next_record(),
        Ok(Some(Record::Header(h))) if h.magic == MAGIC
    )
}

/// Reads every intact record of a whole byte buffer (convenience for tests and small files).
pub fn read_all(bytes: &[u8]) -> (Vec<Record>, ReadReport) {
    let mut reader = NavlogReader::new(bytes);
    let mut out = Vec::new();
    // Reading from a slice cannot fail.
    while let Ok(Some(r)) = reader.next_record() {
        out.push(r);
    }
    (out, reader.report().clone())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::payloads::*;

    fn sample_records() -> Vec<Record> {
        let mut srs = SrsSample {
            t_ns: 3,
            seq: 1,
            count: 2,
            ..Default::default()
        };
        srs.lines[0] = SrsLine {
            los_i: [0.6, 0.8, 0.0],
            body_vel_i_mps: [1.0, -2.0, 3.0e4],
            rest_wavelength_m: 656.28e-9,
            measured_wavelength_m: 656.29e-9,
            sigma_mps: 0.5,
            body_id: 7,
            _pad: 0,
        };
        srs.lines[1].body_id = 9;
        let mut sol = Solution {
            t_ns: 8,
            seq: 4,
            frame: WireFrame::Grid as u8,
            ..Default::default()
        };
        sol.q_b_e = [0.5, 0.5, -0.5, 0.5];
        sol.flags = solution_flags::ALIGNED | solution_flags::CNS_FRESH;
        let mut status = Status {
            t_ns: 9,
            seq: 5,
            ..Default::default()
        };
        status.streams[0].received = 1000;
        status.aids[AidKind::Cns as usize].test_ratio = 0.3;
        vec![
            Record::Header(Box::new(Header::new("test", "unit", 42, "key = 1"))),
            Record::Init(InitState {
                t_ns: 1,
                r_e_m: [1.0, 2.0, 3.0],
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                sigma_heading_rad: 1e-3,
                ..Default::default()
            }),
            Record::Imu(ImuSample {
                t_ns: 2,
                seq: 0,
                dt_s: 0.005,
                d_theta_rad: [1e-6, -2e-6, 3e-9],
                d_v_mps: [0.0, 0.0, 0.049],
            }),
            Record::aid(srs),
            Record::aid(CnsFix {
                t_ns: 4,
                seq: 2,
                lat_rad: 1.5,
                lon_rad: -3.1,
                sigma_h_m: 20.0,
            }),
            Record::aid(BaroSample {
                t_ns: 5,
                seq: 3,
                pressure_pa: 7565.0,
                temperature_k: 216.65,
                sigma_m: 10.0,
            }),
            Record::Truth(TruthRecord {
                t_ns: 6,
                r_e_m: [0.0, 0.0, 6.4e6],
                v_e_mps: [250.0, 0.0, 0.0],
                q_b_e: [0.0, 1.0, 0.0, 0.0],
            }),
            Record::Solution(Box::new(sol)),
            Record::Status(Box::new(status)),
            Record::aid(StarSample {
                t_ns: 10,
                seq: 6,
                q_b_i: [0.5, 0.5, -0.5, 0.5],
                boresight_b: [0.0, 0.0, 1.0],
                sigma_cross_arcsec: 5.0,
                sigma_boresight_arcsec: 40.0,
            }),
            Record::TruthBias(TruthBias {
                t_ns: 7,
                gyro_bias_rps: [4.8e-8, -1e-9, 0.0],
                accel_bias_mps2: [1e-3, -9.8e-4, 2e-5],
            }),
        ]
    }

    fn encode(records: &[Record]) -> Vec<u8> {
        let Record::Header(h) = &records[0] else {
            panic!("first must be header")
        };
        let mut w = NavlogWriter::new(Vec::new(), (**h).clone()).expect("header");
        for r in &records[1..] {
            w.write(r).expect("write");
        }
        w.finish().expect("finish")
    }

    #[test]
    fn records_stay_small() {
        assert!(size_of::<Record>() <= 160, "{}", size_of::<Record>());
    }

    #[test]
    fn every_record_type_round_trips() {
        let records = sample_records();
        let bytes = encode(&records);
        let (back, report) = read_all(&bytes);
        assert!(report.is_clean(), "{report}");
        assert_eq!(back, records);
        assert_eq!(report.records, records.len() as u64);
        assert_eq!(first_init(&back).map(|i| i.t_ns), Some(1));
        assert_eq!(first_init(&back[2..]), None);
    }

    #[test]
    fn zero_appears_only_as_delimiter() {
        let records = sample_records();
        let bytes = encode(&records);
        let zeros = bytes.iter().filter(|&&b| b == 0).count();
        assert_eq!(zeros, records.len());
    }

    #[test]
    fn truncated_file_yields_every_complete_record() {
        let records = sample_records();
        let bytes = encode(&records);
        // Cut at every possible position: the records whose delimiter survives are returned.
        for cut in 0..bytes.len() {
            let part = &bytes[..cut];
            let complete = part.iter().filter(|&&b| b == 0).count();
            let (back, report) = read_all(part);
            assert_eq!(back.len(), complete, "cut at {cut}");
            assert_eq!(back[..], records[..complete]);
            let tail = cut - part.iter().rposition(|&b| b == 0).map_or(0, |i| i + 1);
            assert_eq!(report.truncated, u64::from(tail > 0), "cut at {cut}");
            assert_eq!(report.skipped_bytes, tail as u64);
        }
    }

    #[test]
    fn bit_flip_costs_only_the_damaged_record() {
        let records = sample_records();
        let bytes = encode(&records);
        let ends: Vec<usize> = bytes
            .iter()
            .enumerate()
            .filter(|(_, b)| **b == 0)
            .map(|(i, _)| i)
            .collect();
        for pos in 0..bytes.len() {
            for bit in [0u8, 3, 7] {
                let mut damaged = bytes.clone();
                damaged[pos] ^= 1 << bit;
                let (back, report) = read_all(&damaged);
                // The damaged record; flipping its delimiter merges it with the next one.
                let hit = ends.iter().position(|&e| e >= pos).expect("inside file");
                let lost = |i: usize| i == hit || (pos == ends[hit] && i == hit + 1);
                let expected: Vec<Record> = records
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !lost(*i))
                    .map(|(_, r)| r.clone())
                    .collect();
                assert_eq!(back, expected, "flip at byte {pos} bit {bit}");
                assert!(
                    report.skipped_frames() >= 1,
                    "flip at {pos} not reported: {report}"
                );
                assert!(report.first_skip_offset.is_some());
                assert_eq!(report.records, back.len() as u64);
            }
        }
    }

    /// One flipped bit in an init record's contents is a checksum
    /// mismatch that the report names as a damaged init record at the
    /// frame's offset; damage to another record is not named so.
    #[test]
    fn a_damaged_init_record_is_named_with_its_offset() {
        let records = sample_records();
        let bytes = encode(&records);
        let starts: Vec<usize> = std::iter::once(0)
            .chain(
                bytes
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| **b == 0)
                    .map(|(i, _)| i + 1),
            )
            .collect();
        let init = records
            .iter()
            .position(|r| matches!(r, Record::Init(_)))
            .expect("sample has an init");
        // A byte in the middle of the init record's values, well after its
        // variant tag: the flip leaves the COBS structure as it is.
        let mut named = 0;
        for pos in starts[init] + 8..starts[init + 1] - 8 {
            let mut damaged = bytes.clone();
            damaged[pos] ^= 0x04;
            let (back, report) = read_all(&damaged);
            assert!(!back.iter().any(|r| matches!(r, Record::Init(_))));
            if report.checksum == 1 {
                assert_eq!(report.damaged_init_offset, Some(starts[init] as u64));
                assert!(
                    report.to_string().contains(&format!(
                        "the frame at byte {} was an init record",
                        starts[init]
                    )),
                    "{report}"
                );
                named += 1;
            }
        }
        assert!(named > 20, "only {named} flips named the init record");
        // The same flip in the record after it names no init record.
        let pos = (starts[init + 1] + starts[init + 2]) / 2;
        let mut damaged = bytes.clone();
        damaged[pos] ^= 0x04;
        let (_, report) = read_all(&damaged);
        assert!(report.skipped_frames() == 1, "{report}");
        assert_eq!(report.damaged_init_offset, None, "{report}");
    }

    /// Frames that lie whole in the reader's buffer are decoded in place,
    /// the others copied together first: through buffers of every small
    /// size (frames split anywhere), with a damaged frame and a truncated
    /// end, the records and the report are those of reading it whole.
    #[test]
    fn frames_split_across_the_readers_buffer_read_as_whole_ones() {
        let records = sample_records();
        let mut bytes = encode(&records);
        let mid = bytes.len() / 3;
        bytes[mid] ^= 0x10;
        bytes.truncate(bytes.len() - 3);
        let (whole, whole_report) = read_all(&bytes);
        assert!(!whole_report.is_clean());
        for cap in 1..64 {
            let mut reader = NavlogReader::new(std::io::BufReader::with_capacity(cap, &bytes[..]));
            let mut got = Vec::new();
            while let Some(r) = reader.next_record().expect("read") {
                got.push(r);
            }
            assert_eq!(got, whole, "buffer of {cap} bytes");
            assert_eq!(reader.report(), &whole_report, "buffer of {cap} bytes");
        }
    }

    /// Frames `body` (postcard bytes) as the writer does.
    fn frame_of(body: &[u8]) -> Vec<u8> {
        let mut raw = body.to_vec();
        raw.extend_from_slice(&crc32fast::hash(body).to_le_bytes());
        let mut out = vec![0; cobs::max_encoding_length(raw.len()) + 1];
        let n = cobs::encode(&raw, &mut out);
        out.truncate(n);
        out.push(0);
        out
    }

    /// A format-3 file's solution record (the `_v2` layout, encoded here
    /// with the old record enum) reads as a solution with every old field
    /// and the bias σ unknown; the records around it are untouched.
    #[test]
    #[allow(clippy::float_cmp)] // the values are copied, not computed
    fn a_format_3_solution_record_reads_with_unknown_bias_sigma() {
        let old = legacy::SolutionV2 {
            t_ns: 77,
            seq: 5,
            lat_rad: 1.5,
            gyro_bias_rps: [1e-6, -2e-6, 3e-7],
            accel_bias_mps2: [1e-3, 2e-3, -3e-3],
            reset_count: 4,
            switch_count: 2,
            frame: 1,
            flags: solution_flags::COASTING,
            ..Default::default()
        };
        let body =
            postcard::to_allocvec(&legacy::RecordV3::Solution(Box::new(old))).expect("encode");
        let mut bytes = encode(&sample_records()[..3]);
        bytes.extend(frame_of(&body));
        bytes.extend(encode(&sample_records()[..1]));
        let (back, report) = read_all(&bytes);
        assert!(report.is_clean(), "{report}");
        assert_eq!(back.len(), 5);
        let Record::Solution(s) = &back[3] else {
            panic!("expected a solution, got {:?}", back[3])
        };
        assert_eq!((s.t_ns, s.seq, s.lat_rad), (77, 5, 1.5));
        assert_eq!(s.gyro_bias_rps, old.gyro_bias_rps);
        assert_eq!(s.accel_bias_mps2, old.accel_bias_mps2);
        assert_eq!(
            (s.reset_count, s.switch_count, s.frame, s.flags),
            (4, 2, 1, 64)
        );
        assert!(s.sigma_gyro_bias_rps.iter().all(|v| v.is_nan()));
        assert!(s.sigma_accel_bias_mps2.iter().all(|v| v.is_nan()));
        // A record of the new layout is not taken for the old one.
        let new = Solution {
            sigma_gyro_bias_rps: [1e-7; 3],
            sigma_accel_bias_mps2: [2e-5; 3],
            ..**s
        };
        let (back, _) = read_all(&encode(&[
            sample_records()[0].clone(),
            Record::Solution(Box::new(new)),
        ]));
        assert_eq!(back[1], Record::Solution(Box::new(new)));
    }

    /// A format-7 init record (the `_v1` layout, encoded here with the old
    /// record enum) reads as an init given from outside with every old
    /// field; a format-8 one keeps its method; and the old layout's bytes
    /// of a format-8 record are what a format-7 reader takes (postcard
    /// stops at the fields it knows).
    #[test]
    #[allow(clippy::float_cmp)] // the values are copied, not computed
    fn a_format_7_init_record_reads_as_given_from_outside() {
        let old = legacy::InitStateV1 {
            t_ns: 99,
            seq: 3,
            r_e_m: [6.4e6, 1.0, 2.0],
            q_b_e: [0.5, 0.5, 0.5, 0.5],
            sigma_heading_rad: 0.01,
            ..Default::default()
        };
        let body = postcard::to_allocvec(&legacy::RecordV3::Init(old)).expect("encode");
        let mut bytes = encode(&sample_records()[..1]);
        bytes.extend(frame_of(&body));
        let (back, report) = read_all(&bytes);
        assert!(report.is_clean(), "{report}");
        let Record::Init(i) = &back[1] else {
            panic!("expected an init, got {:?}", back[1])
        };
        assert_eq!(
            (i.t_ns, i.seq, i.r_e_m, i.q_b_e),
            (99, 3, old.r_e_m, old.q_b_e)
        );
        assert_eq!(i.sigma_heading_rad, 0.01);
        assert_eq!(i.init_method(), Some(InitMethod::Given));
        let aligned = InitState {
            method: init_method::AID_HEADING,
            heading_aid: AidKind::Mag as u8,
            ..*i
        };
        let (back, _) = read_all(&encode(&[
            sample_records()[0].clone(),
            Record::Init(aligned),
        ]));
        assert_eq!(back[1], Record::Init(aligned));
        assert_eq!(
            aligned.init_method(),
            Some(InitMethod::AidHeading(AidKind::Mag))
        );
        let new_body = postcard::to_allocvec(&Record::Init(aligned)).expect("encode");
        let (as_old, rest) =
            postcard::take_from_bytes::<legacy::RecordV3>(&new_body).expect("a format-7 reader");
        assert!(matches!(as_old, legacy::RecordV3::Init(o) if o.t_ns == 99 && o.seq == 3));
        assert_eq!(rest.len(), 2 + 6, "method, heading_aid and the padding");
    }

    #[test]
    fn garbage_without_delimiters_is_bounded_and_reported() {
        let mut bytes = encode(&sample_records());
        let n = bytes.len();
        bytes.extend(std::iter::repeat_n(0xAB, MAX_FRAME_BYTES + 10));
        bytes.push(0);
        bytes.extend(encode(&sample_records()));
        let (back, report) = read_all(&bytes);
        assert_eq!(back.len(), 2 * sample_records().len());
        assert_eq!(report.oversized, 1);
        assert_eq!(report.first_skip_offset, Some(n as u64));
    }
}
