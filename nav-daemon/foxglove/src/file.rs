//! An MCAP file written on its own thread.
//!
//! The caller (the navigation loop of `batch`, the recorder) encodes each
//! message into a batch in memory; full batches go to a writer thread that
//! frames them as MCAP records, compresses the chunks (zstd) and writes the
//! file. The two run on two cores at once: `batch --out F.mcap` costs
//! little more wall time than `--out F.csv`, where through the Foxglove
//! SDK's sink the compression, the record framing and the SDK's per-message
//! dispatch all ran inline, on the navigation thread.
//!
//! Memory is bounded: at most [`BATCHES`] batches of about [`BATCH_BYTES`]
//! exist, and they are reused (no allocation per message once they are
//! grown). When the writer falls behind, the caller waits for a batch to
//! come back: nothing is dropped.
//!
//! The file is laid out as the SDK's sink laid it out: a channel and its
//! schema are written just before the channel's first message (a channel
//! that carries nothing is not in the file, and no chunk holds only
//! definitions, which would start the file's time range at 0), zstd
//! chunks of 1 MiB, message indexes, the summary with statistics, CRCs;
//! sequence numbers count from 1 per channel, the publish time is the log
//! time, and a metadata record without entries is not written.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use foxglove::Schema;
use mcap::records::{MessageHeader, Metadata};

/// A batch is sent to the writer when its messages reach this many bytes.
pub const BATCH_BYTES: usize = 256 << 10;
/// ... or when it holds this many messages (empty messages, which add no
/// bytes, would otherwise grow its list of entries until a flush).
pub const BATCH_MESSAGES: usize = BATCH_BYTES / 32;
/// Batches in flight (being filled, queued, being written) at most.
pub const BATCHES: usize = 6;
/// The zstd level of the chunks. The writer thread is the slower of the
/// two when `batch` writes a file, and compression is nearly all of its
/// work; on the 1 h, 200 Hz bench flight (`cargo bench -p polarnav-tests
/// --bench batch_rtf`), against level 3 (zstd's default), level 2 takes
/// about a tenth less time for a file 6 % larger (238 against 224 MB),
/// which keeps `--out F.mcap` within 1.5x the CSV's wall time; level 1
/// saves little more and costs 12 %.
pub const ZSTD_LEVEL: u32 = 2;
/// The MCAP chunk size (uncompressed bytes).
const CHUNK_BYTES: u64 = 1 << 20;

/// Why the file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The file could not be created or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed (a write, or the summary).
    #[error("{path}: MCAP writer: {}", chain(source))]
    Mcap {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: mcap::McapError,
    },
    /// The writer thread failed (its cause as text), or is gone.
    #[error("{path}: MCAP writer: {why}")]
    Stopped {
        /// The file.
        path: PathBuf,
        /// What stopped it.
        why: String,
    },
}

impl FileError {
    /// What failed, without the path.
    fn cause(&self) -> String {
        match self {
            FileError::Io { source, .. } => chain(source),
            FileError::Mcap { source, .. } => chain(source),
            FileError::Stopped { why, .. } => why.clone(),
        }
    }
}

/// An error and its causes, "error: cause: cause" (the `mcap` crate's I/O
/// error says only "I/O error from writing"; its cause says which).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}

/// One message of a batch: its channel, sequence, log time and where its
/// bytes end in the batch.
#[derive(Debug, Clone, Copy)]
struct Entry {
    channel: u16,
    sequence: u32,
    log_ns: u64,
    end: usize,
}

/// Messages laid end to end, and where each ends.
#[derive(Debug, Default)]
struct Batch {
    bytes: Vec<u8>,
    entries: Vec<Entry>,
}

impl Batch {
    fn with_capacity() -> Self {
        Self {
            bytes: Vec::with_capacity(BATCH_BYTES + (64 << 10)),
            entries: Vec::with_capacity(BATCH_MESSAGES),
        }
    }

    fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// What the writer thread is asked to do, in order.
enum Cmd {
    /// Define a channel (the next index) with its schema; it is written
    /// with its first message.
    Channel {
        topic: String,
        encoding: String,
        schema: Option<Schema>,
    },
    /// Write these messages.
    Batch(Batch),
    /// A metadata record, then answer.
    Metadata(Metadata, SyncSender<Result<(), String>>),
    /// End the chunk and write everything to the file, then answer.
    Flush(SyncSender<Result<(), String>>),
}

/// An MCAP file being written by its thread.
#[derive(Debug)]
pub struct FileWriter {
    path: PathBuf,
    tx: Option<SyncSender<Cmd>>,
    free: Receiver<Batch>,
    batch: Batch,
    /// Batches made so far (at most [`BATCHES`]).
    made: usize,
    /// Per channel (by index): the last sequence number given.
    sequence: Vec<u32>,
    thread: Option<JoinHandle<Result<(), FileError>>>,
    /// Why the thread stopped, once it has been joined.
    stopped: Option<String>,
}

impl FileWriter {
    /// Creates (or truncates) `path` and writes the MCAP header.
    pub fn create(path: &Path) -> Result<Self, FileError> {
        let file = File::create(path).map_err(|source| FileError::Io {
            path: path.to_owned(),
            source,
        })?;
        let options = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(CHUNK_BYTES))
            // The writer thread is the compressor: no zstd worker threads besides.
            .compression_threads(0)
            .compression_level(ZSTD_LEVEL)
            .profile("")
            .library(format!(
                "polarnav {} {}",
                env!("CARGO_PKG_VERSION"),
                mcap::LIBRARY_IDENTIFIER
            ));
        let writer = options
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|source| FileError::Mcap {
                path: path.to_owned(),
                source,
            })?;
        let (tx, rx) = sync_channel::<Cmd>(BATCHES + 4);
        let (free_tx, free) = sync_channel::<Batch>(BATCHES);
        let thread_path = path.to_owned();
        let thread = std::thread::Builder::new()
            .name("mcap-writer".into())
            .spawn(move || write_all(writer, &rx, &free_tx, &thread_path))
            .map_err(|source| FileError::Io {
                path: path.to_owned(),
                source,
            })?;
        Ok(Self {
            path: path.to_owned(),
            tx: Some(tx),
            free,
            batch: Batch::with_capacity(),
            made: 1,
            sequence: Vec::new(),
            thread: Some(thread),
            stopped: None,
        })
    }

    /// Adds a channel; its messages are logged with the index returned.
    pub fn add_channel(&mut self, topic: &str, encoding: &str, schema: Option<Schema>) -> u16 {
        let index = u16::try_from(self.sequence.len()).unwrap_or(u16::MAX);
        self.sequence.push(0);
        self.send(Cmd::Channel {
            topic: topic.to_owned(),
            encoding: encoding.to_owned(),
            schema,
        });
        index
    }

    /// Logs on `channel` (an index from [`Self::add_channel`]) at log
    /// time `log_ns` the message `encode` appends to the buffer it is
    /// given (it returns false when it could not: nothing is logged).
    pub fn log(&mut self, channel: u16, log_ns: u64, encode: impl FnOnce(&mut Vec<u8>) -> bool) {
        let Some(sequence) = self.sequence.get_mut(usize::from(channel)) else {
            return;
        };
        let start = self.batch.bytes.len();
        if !encode(&mut self.batch.bytes) {
            self.batch.bytes.truncate(start);
            return;
        }
        *sequence = sequence.wrapping_add(1);
        self.batch.entries.push(Entry {
            channel,
            sequence: *sequence,
            log_ns,
            end: self.batch.bytes.len(),
        });
        if self.batch.bytes.len() >= BATCH_BYTES || self.batch.entries.len() >= BATCH_MESSAGES {
            self.send_batch();
        }
    }

    /// Sends the batch being filled (if it has messages) and takes an
    /// empty one: one that came back, a new one while fewer than
    /// [`BATCHES`] exist, else the next to come back.
    fn send_batch(&mut self) {
        if self.batch.is_empty() {
            return;
        }
        if self.tx.is_none() {
            // The thread is gone: the messages are lost ([`Self::close`] says why); the batch is reused.
            self.batch.bytes.clear();
            self.batch.entries.clear();
            return;
        }
        let next = match self.free.try_recv() {
            Ok(b) => b,
            Err(_) if self.made < BATCHES => {
                self.made += 1;
                Batch::with_capacity()
            }
            Err(_) => self.free.recv().unwrap_or_else(|_| Batch::with_capacity()),
        };
        let full = std::mem::replace(&mut self.batch, next);
        self.send(Cmd::Batch(full));
    }

    /// Sends a command; when the thread is gone, a batch comes back to be
    /// reused (its messages are lost, and [`Self::close`] says why).
    fn send(&mut self, cmd: Cmd) {
        let Some(tx) = &self.tx else { return };
        if let Err(back) = tx.send(cmd) {
            self.tx = None;
            if let Cmd::Batch(mut b) = back.0 {
                b.bytes.clear();
                b.entries.clear();
                self.batch = b;
            }
        }
    }

    /// A metadata record `name` with the entries of `map`, after every
    /// message logged so far (none when `map` is empty); waits until the
    /// thread has taken it.
    pub fn metadata(&mut self, name: &str, map: BTreeMap<String, String>) -> Result<(), FileError> {
        if map.is_empty() {
            return self.ask(None);
        }
        self.ask(Some(Metadata {
            name: name.to_owned(),
            metadata: map,
        }))
    }

    /// Ends the current chunk and writes everything logged so far to the
    /// file, and waits until it is written.
    pub fn flush(&mut self) -> Result<(), FileError> {
        self.ask(None)
    }

    /// Sends the batch being filled, then a metadata record (or a flush),
    /// and waits for the thread's answer: Ok, or why it failed or stopped.
    fn ask(&mut self, metadata: Option<Metadata>) -> Result<(), FileError> {
        self.send_batch();
        let (reply_tx, reply) = sync_channel(1);
        self.send(match metadata {
            Some(m) => Cmd::Metadata(m, reply_tx),
            None => Cmd::Flush(reply_tx),
        });
        match reply.recv() {
            Ok(Ok(())) => Ok(()),
            Ok(Err(why)) => Err(FileError::Stopped {
                path: self.path.clone(),
                why,
            }),
            // The thread is gone without answering (it panicked).
            Err(_) => Err(self.stop()),
        }
    }

    /// Joins the thread (once) and says why it stopped.
    fn stop(&mut self) -> FileError {
        if self.stopped.is_none() {
            let why = self
                .join()
                .err()
                .map_or_else(|| "closed".into(), |e| e.cause());
            self.stopped = Some(why);
        }
        FileError::Stopped {
            path: self.path.clone(),
            why: self.stopped.clone().unwrap_or_default(),
        }
    }

    /// Joins the thread: what it returned, or the message it panicked with.
    fn join(&mut self) -> Result<(), FileError> {
        self.tx = None;
        let Some(thread) = self.thread.take() else {
            return match &self.stopped {
                Some(why) => Err(FileError::Stopped {
                    path: self.path.clone(),
                    why: why.clone(),
                }),
                None => Ok(()),
            };
        };
        let r = match thread.join() {
            Ok(r) => r,
            Err(panic) => {
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Err(FileError::Stopped {
                    path: self.path.clone(),
                    why: format!("its thread panicked: {what}"),
                })
            }
        };
        if let Err(e) = &r {
            self.stopped = Some(e.cause());
        }
        r
    }

    /// Writes the rest, the summary and the footer, and closes the file.
    pub fn close(mut self) -> Result<(), FileError> {
        self.send_batch();
        self.join()
    }
}

impl Drop for FileWriter {
    /// A writer dropped without [`FileWriter::close`] still ends its file
    /// (summary and footer), so that what was logged can be read.
    fn drop(&mut self) {
        if self.thread.is_some() {
            self.send_batch();
            let _ = self.join();
        }
    }
}

/// The writer thread: every command in order until the sender is gone,
/// then the summary. After a failure it keeps returning batches (so the
/// caller never waits on it) and reports the failure at the end.
fn write_all(
    mut w: mcap::Writer<BufWriter<File>>,
    rx: &Receiver<Cmd>,
    free: &SyncSender<Batch>,
    path: &Path,
) -> Result<(), FileError> {
    let mcap_err = |source| FileError::Mcap {
        path: path.to_owned(),
        source,
    };
    let mut channels: Vec<Channel> = Vec::new();
    let mut failed: Option<mcap::McapError> = None;
    for cmd in rx {
        let r = match cmd {
            Cmd::Batch(mut b) => {
                let r = if failed.is_none() {
                    write_batch(&mut w, &mut channels, &b)
                } else {
                    Ok(())
                };
                b.bytes.clear();
                b.entries.clear();
                // The caller may be gone (closing): the batch is dropped then.
                let _ = free.try_send(b);
                r
            }
            Cmd::Channel {
                topic,
                encoding,
                schema,
            } => {
                channels.push(Channel {
                    topic,
                    encoding,
                    schema,
                    id: None,
                });
                Ok(())
            }
            Cmd::Flush(reply) | Cmd::Metadata(_, reply) if failed.is_some() => {
                let _ = reply.send(Err(failed.as_ref().map_or_else(String::new, |e| chain(e))));
                Ok(())
            }
            Cmd::Metadata(m, reply) => {
                let r = w.write_metadata(&m);
                let _ = reply.send(r.as_ref().map(drop).map_err(|e| chain(e)));
                r
            }
            Cmd::Flush(reply) => {
                let r = w.flush();
                let _ = reply.send(r.as_ref().map(drop).map_err(|e| chain(e)));
                r
            }
        };
        if let Err(e) = r
            && failed.is_none()
        {
            failed = Some(e);
        }
    }
    if let Some(e) = failed {
        return Err(mcap_err(e));
    }
    w.finish().map_err(mcap_err)?;
    w.into_inner().into_inner().map_err(|e| FileError::Io {
        path: path.to_owned(),
        source: e.into_error(),
    })?;
    Ok(())
}

/// A channel as the writer thread knows it: its definition, and its id in
/// the file once its first message has been written.
struct Channel {
    topic: String,
    encoding: String,
    schema: Option<Schema>,
    id: Option<u16>,
}

/// The id of `channel` in the file, writing its schema and channel records
/// first if it has none yet.
fn channel_id(
    w: &mut mcap::Writer<BufWriter<File>>,
    channels: &mut [Channel],
    channel: u16,
) -> Result<u16, mcap::McapError> {
    let Some(c) = channels.get_mut(usize::from(channel)) else {
        return Err(mcap::McapError::UnknownChannel(0, channel));
    };
    if let Some(id) = c.id {
        return Ok(id);
    }
    let schema_id = match &c.schema {
        Some(s) => w.add_schema(&s.name, &s.encoding, &s.data)?,
        None => 0,
    };
    let id = w.add_channel(schema_id, &c.topic, &c.encoding, &BTreeMap::new())?;
    c.id = Some(id);
    Ok(id)
}

/// The messages of one batch, in order.
fn write_batch(
    w: &mut mcap::Writer<BufWriter<File>>,
    channels: &mut [Channel],
    b: &Batch,
) -> Result<(), mcap::McapError> {
    let mut start = 0;
    for e in &b.entries {
        let channel_id = channel_id(w, channels, e.channel)?;
        w.write_to_known_channel(
            &MessageHeader {
                channel_id,
                sequence: e.sequence,
                log_time: e.log_ns,
                publish_time: e.log_ns,
            },
            // An encoder that took bytes back broke the batch: an error, not a panic.
            b.bytes.get(start..e.end).ok_or_else(|| {
                mcap::McapError::Io(std::io::Error::other(format!(
                    "a message's bytes ({start}..{}) are not in its batch ({} bytes): an encoder removed bytes it had not written",
                    e.end,
                    b.bytes.len()
                )))
            })?,
        )?;
        start = e.end;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn schema() -> Option<Schema> {
        Some(Schema::new(
            "test.Blob",
            "protobuf",
            b"not a real descriptor".to_vec(),
        ))
    }

    /// A message whose bytes say which it is: channel, index, and a length
    /// that varies so batches fill unevenly.
    fn payload(channel: u16, k: u64) -> Vec<u8> {
        let mut v = Vec::new();
        v.extend_from_slice(&channel.to_le_bytes());
        v.extend_from_slice(&k.to_le_bytes());
        v.resize(10 + (k % 97) as usize * 7, (k % 251) as u8);
        v
    }

    /// A new directory for one test's file, and the file's path in it.
    fn temp_file(test: &str, name: &str) -> (PathBuf, PathBuf) {
        let dir = std::env::temp_dir().join(format!("polarnav-{test}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        (dir, path)
    }

    /// Logs [`payload`]`(c, k)` at log time `k` for every `k` of `ks`.
    fn log_payloads(w: &mut FileWriter, c: u16, ks: std::ops::Range<u64>) {
        for k in ks {
            w.log(c, k, |buf| {
                buf.extend_from_slice(&payload(c, k));
                true
            });
        }
    }

    /// Many batches' worth of messages on three channels (the batches are
    /// reused several times over) come back from the `mcap` reader in
    /// order, each with its channel, its bytes, its log time and a
    /// sequence counting from 1 per channel; a flush in the middle, a
    /// metadata record and a message that failed to encode change nothing
    /// else; the summary counts every message.
    #[test]
    fn every_message_comes_back_in_order_with_its_sequence() {
        let (dir, path) = temp_file("file", "order.mcap");
        let mut w = FileWriter::create(&path).unwrap();
        let topics = ["/a", "/b", "/c"];
        let ids: Vec<u16> = topics
            .iter()
            .map(|t| w.add_channel(t, "protobuf", schema()))
            .collect();
        let n = 60_000u64;
        let mut sent = Vec::new();
        for k in 0..n {
            let c = ids[(k % 3) as usize];
            let p = payload(c, k);
            w.log(c, 1_000 + k * 5, |buf| {
                buf.extend_from_slice(&p);
                true
            });
            sent.push((c, p, 1_000 + k * 5));
            if k == n / 2 {
                w.flush().unwrap();
                let mut map = BTreeMap::new();
                map.insert("k".to_owned(), k.to_string());
                w.metadata("middle", map).unwrap();
            }
            if k % 1000 == 0 {
                // Refused by its encoder: nothing logged, the bytes written are taken back.
                w.log(c, 0, |buf| {
                    buf.extend_from_slice(b"half a message");
                    false
                });
            }
        }
        assert!(
            sent.iter().map(|m| m.1.len()).sum::<usize>() > 10 * BATCHES * BATCH_BYTES,
            "the test must cycle the batches"
        );
        w.close().unwrap();

        let bytes = std::fs::read(&path).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
        assert_eq!(summary.stats.as_ref().unwrap().message_count, n);
        let mut per_channel = [0u32; 3];
        let mut got = 0;
        for (m, (c, p, t)) in mcap::MessageStream::new(&bytes).unwrap().zip(&sent) {
            let m = m.unwrap();
            assert_eq!(m.channel.topic, topics[usize::from(*c)]);
            assert_eq!(m.channel.message_encoding, "protobuf");
            assert_eq!(m.channel.schema.as_ref().unwrap().name, "test.Blob");
            assert_eq!(&m.data[..], &p[..]);
            assert_eq!((m.log_time, m.publish_time), (*t, *t));
            per_channel[usize::from(*c)] += 1;
            assert_eq!(m.sequence, per_channel[usize::from(*c)]);
            got += 1;
        }
        assert_eq!(got, n);
        let meta = mcap::read::LinearReader::new(&bytes)
            .unwrap()
            .filter_map(|r| match r.unwrap() {
                mcap::records::Record::Metadata(m) => Some(m),
                _ => None,
            })
            .collect::<Vec<_>>();
        assert_eq!(meta.len(), 1);
        assert_eq!(meta[0].metadata["k"], (n / 2).to_string());
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A file that cannot be written (`/dev/full`: every write fails with
    /// "no space left"): logging goes on without blocking or growing, and
    /// `close` says what failed and where.
    #[test]
    fn a_failing_disk_is_reported_at_close_and_never_blocks() {
        let path = Path::new("/dev/full");
        if !path.exists() {
            return;
        }
        let mut w = FileWriter::create(path).unwrap();
        let c = w.add_channel("/a", "protobuf", schema());
        log_payloads(&mut w, c, 0..200_000);
        assert!(w.made <= BATCHES);
        let flushed = w.flush();
        assert!(flushed.is_err(), "{flushed:?}");
        let e = w
            .close()
            .expect_err("writing to /dev/full fails")
            .to_string();
        assert!(
            e.contains("/dev/full") && e.contains("No space left"),
            "{e}"
        );
        let f = flushed.unwrap_err().to_string();
        assert!(
            f.starts_with("/dev/full: MCAP writer: ") && f.contains("No space left"),
            "{f}"
        );
    }

    /// A writer dropped without `close` (a run that ends in an error)
    /// still ends its file: what was logged is read back with its summary.
    #[test]
    fn a_dropped_writer_still_ends_its_file() {
        let (dir, path) = temp_file("drop", "dropped.mcap");
        {
            let mut w = FileWriter::create(&path).unwrap();
            let c = w.add_channel("/a", "protobuf", schema());
            log_payloads(&mut w, c, 0..1000);
        }
        let bytes = std::fs::read(&path).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
        assert_eq!(summary.stats.unwrap().message_count, 1000);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Any run of messages: sizes log-uniform from 0 bytes to 1 MiB (four
    /// times a batch: one message may fill several), log times anywhere in
    /// u64 (0, 1e18, u64::MAX, out of order), on up to 5 channels, with
    /// flushes anywhere. Every message comes back once, in order, with its
    /// bytes, time and per-channel sequence; the summary counts them all;
    /// the batches in flight never exceed their bound.
    #[test]
    fn any_run_of_messages_comes_back_whole() {
        use proptest::prelude::*;
        let size = prop_oneof![
            Just(0usize),
            (0.0f64..20.0).prop_map(|e| (e.exp2() as usize).min(1 << 20)),
        ];
        let time = prop_oneof![
            Just(0u64),
            Just(1_000_000_000_000_000_000u64),
            Just(u64::MAX),
            (0.0f64..64.0).prop_map(|e| e.exp2() as u64),
        ];
        let msg = (0u16..5, size, time, any::<u8>());
        // Runs of empty messages, longer than a batch holds.
        let run = prop_oneof![Just(0usize), Just(BATCH_MESSAGES + 7)];
        let (dir, path) = temp_file("prop", "prop.mcap");
        proptest!(ProptestConfig::with_cases(24), |(
            channels in 1u16..=5,
            msgs in proptest::collection::vec(msg, 0..120),
            flush_every in 1usize..200,
            empties in run,
        )| {
            let mut w = FileWriter::create(&path).unwrap();
            for c in 0..channels {
                w.add_channel(&format!("/t{c}"), "protobuf", schema());
            }
            let mut sent = Vec::new();
            let empty = std::iter::repeat_n((0u16, 0usize, 5u64, 0u8), empties);
            let msgs: Vec<_> = empty.chain(msgs.iter().copied()).collect();
            for (k, (c, len, t, fill)) in msgs.iter().enumerate() {
                let c = c % channels;
                w.log(c, *t, |buf| {
                    buf.resize(buf.len() + len, *fill);
                    true
                });
                sent.push((c, *len, *fill, *t));
                prop_assert!(w.made <= BATCHES);
                prop_assert!(w.batch.entries.len() < BATCH_MESSAGES);
                if k % flush_every == flush_every - 1 {
                    w.flush().unwrap();
                }
            }
            w.close().unwrap();
            let bytes = std::fs::read(&path).unwrap();
            let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
            prop_assert_eq!(summary.stats.unwrap().message_count, sent.len() as u64);
            let mut seq = [0u32; 5];
            let mut got = 0;
            for (m, (c, len, fill, t)) in mcap::MessageStream::new(&bytes).unwrap().zip(&sent) {
                let m = m.unwrap();
                prop_assert_eq!(&m.channel.topic, &format!("/t{c}"));
                prop_assert_eq!(m.data.len(), *len);
                prop_assert!(m.data.iter().all(|b| b == fill));
                prop_assert_eq!(m.log_time, *t);
                seq[usize::from(*c)] += 1;
                prop_assert_eq!(m.sequence, seq[usize::from(*c)]);
                got += 1;
            }
            prop_assert_eq!(got, sent.len());
        });
        std::fs::remove_dir_all(&dir).ok();
    }

    /// An encoder that takes back bytes it did not write breaks its batch:
    /// the writer thread stops writing with an error that says so (it does
    /// not panic), and every later flush, metadata record and the close
    /// report that error; nothing blocks.
    #[test]
    fn a_broken_batch_is_an_error_reported_by_every_later_call() {
        let (dir, path) = temp_file("broken", "broken.mcap");
        let mut w = FileWriter::create(&path).unwrap();
        let c = w.add_channel("/a", "protobuf", schema());
        log_payloads(&mut w, c, 0..100);
        w.log(c, 100, |buf| {
            buf.clear();
            buf.push(1);
            true
        });
        let f = w.flush().expect_err("the batch is broken").to_string();
        assert!(f.contains("not in its batch"), "{f}");
        let mut map = BTreeMap::new();
        map.insert("k".to_owned(), "v".to_owned());
        let m = w
            .metadata("after", map)
            .expect_err("still broken")
            .to_string();
        assert!(m.contains("not in its batch"), "{m}");
        log_payloads(&mut w, c, 0..50_000);
        let e = w.close().expect_err("still broken").to_string();
        assert!(
            e.contains("broken.mcap") && e.contains("not in its batch"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A metadata record without entries is not written (as the SDK's
    /// sink did not); one with entries is.
    #[test]
    fn an_empty_metadata_record_is_not_written() {
        let (dir, path) = temp_file("meta", "meta.mcap");
        let mut w = FileWriter::create(&path).unwrap();
        w.metadata("empty", BTreeMap::new()).unwrap();
        let mut map = BTreeMap::new();
        map.insert("k".to_owned(), "v".to_owned());
        w.metadata("full", map).unwrap();
        w.close().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let names: Vec<String> = mcap::read::LinearReader::new(&bytes)
            .unwrap()
            .filter_map(|r| match r.unwrap() {
                mcap::records::Record::Metadata(m) => Some(m.name),
                _ => None,
            })
            .collect();
        assert_eq!(names, ["full"]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
