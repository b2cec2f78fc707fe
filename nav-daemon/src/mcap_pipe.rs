//! The MCAP output's messages encoded on a thread of their own.
//!
//! `batch --out F.mcap` logs every input record, every solution, the status
//! once a second and every aid update. Encoding each into its Foxglove
//! message (protobuf, the polar scene's geometry) ran on the navigation
//! loop: on `transpolar-gnss` it is 8.5 % of the run's CPU, the session and
//! the log's decoding 42 %, the writer's zstd 49 % (`perf report --sort
//! comm`; on 2 cores the writer sets the wall time, so this thread frees
//! the loop without shortening such a run). None of it
//! feeds back into the session, so the session hands over what it would
//! have logged, in chunks of [`Item`]s, to an encoding thread that owns
//! the [`McapFile`] and logs each item exactly as the loop did: the same
//! calls on the same channels in the same order, so the file is byte for
//! byte the one the loop wrote (`tests/pinned_outputs.rs` pins it). The
//! file's own writer thread (framing, zstd) is unchanged behind it.
//!
//! Chunks go round between the two threads and are reused: after the first
//! [`IN_FLIGHT`] nothing is allocated. A status, larger than any item
//! (`a_status_travels_beside_the_items`), and an aid's sample, which a record holds in a box, travel
//! in their chunk's own lists (so that every item is not as large as a
//! status, and no box is made per sample).
//!
//! The encoder never takes the session down with it: a panic while encoding
//! is caught and returned as the error of the next call (with its message),
//! and the file is closed with what it had. When the encoder falls behind, the
//! session waits for a chunk to come back: nothing is dropped.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::Scope;

use msgs::navlog::Record;
use msgs::{AidKind, AidSample, AidStatus, Solution, Status};
use polarnav_foxglove::McapFile;

/// Items per chunk.
pub const CHUNK_ITEMS: usize = 512;

/// Chunks in existence at most (being filled, queued, being encoded).
const IN_FLIGHT: usize = 3;

/// What the session logs to the MCAP file, by value.
// A solution is the largest item and the most frequent: boxing it would
// allocate per solution; the items live in chunks that are reused.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
pub enum Item {
    /// An input or truth record of the log (or the init an alignment made);
    /// not an aid's sample, which is [`Item::AidSample`].
    Record(Record),
    /// An aid's sample: the chunk's next one.
    AidSample,
    /// A solution.
    Solution(Solution),
    /// The session's status: the chunk's next one.
    Status,
    /// An aid's update at its gate.
    AidUpdate {
        aid: AidKind,
        t_ns: u64,
        status: AidStatus,
        lat_rad: f64,
        h_m: f64,
    },
}

/// Items in order, and the statuses they log.
#[derive(Debug, Default)]
struct Chunk {
    items: Vec<Item>,
    statuses: Vec<Status>,
    aids: Vec<AidSample>,
}

impl Chunk {
    fn with_capacity() -> Self {
        Self {
            items: Vec::with_capacity(CHUNK_ITEMS),
            statuses: Vec::with_capacity(CHUNK_ITEMS / 16),
            aids: Vec::with_capacity(CHUNK_ITEMS),
        }
    }

    fn clear(&mut self) {
        self.items.clear();
        self.statuses.clear();
        self.aids.clear();
    }

    /// Logs every item on `m`'s channels, in order.
    fn log(&self, m: &mut McapFile) {
        let (mut statuses, mut aids) = (self.statuses.iter(), self.aids.iter());
        for item in &self.items {
            match item {
                // Each marker has its entry: the pipe pushes both together.
                Item::Status => {
                    if let Some(st) = statuses.next() {
                        m.channels().status(st);
                    }
                }
                Item::AidSample => {
                    if let Some(a) = aids.next() {
                        m.channels().aid_sample(a);
                    }
                }
                other => other.log(m),
            }
        }
    }
}

impl Item {
    /// Logs the item on `m`'s channels (a status and an aid's sample are
    /// logged by their chunk).
    pub fn log(&self, m: &mut McapFile) {
        let c = m.channels();
        match self {
            Item::Record(r) => c.record(r),
            Item::Solution(s) => c.solution(s),
            Item::Status | Item::AidSample => {}
            Item::AidUpdate {
                aid,
                t_ns,
                status,
                lat_rad,
                h_m,
            } => c.aid_update(*aid, *t_ns, status, *lat_rad, *h_m),
        }
    }
}

/// What the encoder gives back at its end: the file, or why it stopped.
type Ended = Result<Box<McapFile>, String>;

/// The session's end of the pipe.
#[derive(Debug)]
pub struct McapPipe {
    to_encode: SyncSender<Chunk>,
    /// Chunks the encoder has emptied.
    emptied: Receiver<Chunk>,
    /// The file, once the encoder has logged everything (or its panic).
    file_back: Receiver<Ended>,
    filling: Chunk,
    /// Chunks made so far (at most [`IN_FLIGHT`]).
    made: usize,
}

impl McapPipe {
    /// Starts the encoding thread in `scope` with the file `m`; it logs
    /// until the pipe is finished (or dropped: the file then ends with
    /// what it was given).
    pub fn start<'scope>(scope: &'scope Scope<'scope, '_>, mut m: Box<McapFile>) -> Self {
        let (to_encode, rx) = sync_channel::<Chunk>(IN_FLIGHT);
        let (empty_tx, emptied) = sync_channel::<Chunk>(IN_FLIGHT);
        let (file_tx, file_back) = sync_channel::<Ended>(1);
        let encoder = move || {
            let encoded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
                for mut chunk in rx.iter() {
                    chunk.log(&mut m);
                    chunk.clear();
                    // The session may have stopped taking chunks back.
                    let _ = empty_tx.try_send(chunk);
                }
                m
            }));
            let _ = file_tx.send(encoded.map_err(|panic| {
                panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default()
            }));
        };
        // Named, so that a profile tells its share (`perf report --sort comm`);
        // a thread that cannot be started encodes nothing, and the session's
        // first hand-over says so.
        let _ = std::thread::Builder::new()
            .name("mcap-encoder".into())
            .spawn_scoped(scope, encoder);
        Self {
            to_encode,
            emptied,
            file_back,
            filling: Chunk::with_capacity(),
            made: 1,
        }
    }

    /// Takes `item` to be logged after every item before it.
    pub fn push(&mut self, item: Item) -> std::io::Result<()> {
        self.filling.items.push(item);
        if self.filling.items.len() >= CHUNK_ITEMS {
            self.hand_over()?;
        }
        Ok(())
    }

    /// Takes the status `st` to be logged after every item before it.
    pub fn push_status(&mut self, st: &Status) -> std::io::Result<()> {
        self.filling.statuses.push(*st);
        self.push(Item::Status)
    }

    /// Takes the aid's sample `a` to be logged after every item before it.
    pub fn push_aid(&mut self, a: &AidSample) -> std::io::Result<()> {
        self.filling.aids.push(*a);
        self.push(Item::AidSample)
    }

    /// Why the encoder stopped before it was asked to: its panic's
    /// message (it is waited for: the thread is ending).
    fn stopped(&self) -> std::io::Error {
        match self.file_back.recv() {
            Ok(Err(why)) => {
                std::io::Error::other(format!("the MCAP encoding thread panicked: {why}"))
            }
            _ => std::io::Error::other("the MCAP encoding thread stopped"),
        }
    }

    /// Hands over the last items, waits until every item is logged and
    /// gives the file back.
    pub fn finish(mut self) -> std::io::Result<Box<McapFile>> {
        if !self.filling.items.is_empty() {
            self.hand_over()?;
        }
        let McapPipe {
            to_encode,
            file_back,
            ..
        } = self;
        drop(to_encode);
        match file_back.recv() {
            Ok(Ok(m)) => Ok(m),
            Ok(Err(why)) => Err(std::io::Error::other(format!(
                "the MCAP encoding thread panicked: {why}"
            ))),
            Err(_) => Err(std::io::Error::other("the MCAP encoding thread stopped")),
        }
    }

    /// Sends the chunk being filled and takes an empty one: one that came
    /// back, a new one while fewer than [`IN_FLIGHT`] exist, else the next
    /// to come back.
    fn hand_over(&mut self) -> std::io::Result<()> {
        let next = match self.emptied.try_recv() {
            Ok(c) => c,
            Err(_) if self.made < IN_FLIGHT => {
                self.made += 1;
                Chunk::with_capacity()
            }
            Err(_) => match self.emptied.recv() {
                Ok(c) => c,
                Err(_) => return Err(self.stopped()),
            },
        };
        let full = std::mem::replace(&mut self.filling, next);
        if self.to_encode.send(full).is_err() {
            return Err(self.stopped());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::{BaroSample, ImuSample};
    use polarnav_foxglove::AidSource;

    /// What a flight logs, in its order: IMU records, a baro sample every
    /// tenth, a solution each, an aid update and a status now and then
    /// (4 000 items: chunks full and one part-filled, statuses and samples
    /// across their boundaries).
    fn flight(n: u64) -> Vec<(Item, Option<Status>, Option<AidSample>)> {
        let mut out = Vec::new();
        for i in 1..=n {
            let t_ns = i * 5_000_000;
            let imu = ImuSample {
                t_ns,
                seq: i,
                dt_s: 0.005,
                d_theta_rad: [1e-5 * i as f64, 0.0, -1e-6],
                d_v_mps: [0.01, 0.0, 0.049],
            };
            out.push((Item::Record(Record::Imu(imu)), None, None));
            if i % 10 == 0 {
                let baro = AidSample::Baro(BaroSample {
                    t_ns,
                    seq: i / 10,
                    pressure_pa: 7_000.0 + i as f64,
                    temperature_k: 216.65,
                    sigma_m: 1.0,
                });
                out.push((Item::AidSample, None, Some(baro)));
                out.push((
                    Item::AidUpdate {
                        aid: AidKind::Baro,
                        t_ns,
                        status: AidStatus::default(),
                        lat_rad: 1.5,
                        h_m: 18_000.0,
                    },
                    None,
                    None,
                ));
            }
            let sol = Solution {
                t_ns,
                lat_rad: 1.5 + 1e-7 * i as f64,
                h_m: 18_000.0,
                frame: (i / 700 % 2) as u8,
                ..Default::default()
            };
            out.push((Item::Solution(sol), None, None));
            if i % 200 == 0 {
                let st = Status {
                    seq: i / 200,
                    cycles: i,
                    ..Default::default()
                };
                out.push((Item::Status, Some(st), None));
            }
        }
        out
    }

    fn path(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("polarnav-mcap-pipe-{}-{name}", std::process::id()))
    }

    /// Piped, the file is byte for byte the one logged inline with the
    /// same calls (this is `batch`'s promise; `tests/pinned_outputs.rs`
    /// holds it for a whole flight against hashes from before the pipe).
    #[test]
    fn a_piped_file_is_the_inline_file() {
        let items = flight(1_300);
        assert!(items.len() > 3 * CHUNK_ITEMS, "{}", items.len());
        let (inline, piped) = (path("inline.mcap"), path("piped.mcap"));
        let mut m = Box::new(McapFile::create(&inline, AidSource::Updates).expect("inline"));
        for (item, st, aid) in &items {
            match (item, st, aid) {
                (Item::Status, Some(st), _) => m.channels().status(st),
                (Item::AidSample, _, Some(a)) => m.channels().aid_sample(a),
                (other, _, _) => other.log(&mut m),
            }
        }
        m.close().expect("close inline");
        let m = Box::new(McapFile::create(&piped, AidSource::Updates).expect("piped"));
        let m = std::thread::scope(|scope| {
            let mut pipe = McapPipe::start(scope, m);
            for (item, st, aid) in &items {
                match (item, st, aid) {
                    (Item::Status, Some(st), _) => pipe.push_status(st),
                    (Item::AidSample, _, Some(a)) => pipe.push_aid(a),
                    (other, _, _) => pipe.push(other.clone()),
                }
                .expect("pushed");
            }
            pipe.finish().expect("finished")
        });
        m.close().expect("close piped");
        let (a, b) = (
            std::fs::read(&inline).expect("inline"),
            std::fs::read(&piped).expect("piped"),
        );
        let _ = (std::fs::remove_file(&inline), std::fs::remove_file(&piped));
        assert!(a.len() > 100_000, "{} bytes", a.len());
        assert!(a == b, "{} bytes inline, {} piped", a.len(), b.len());
    }

    /// Why statuses have a list of their own: as an item, a status would
    /// make every item (a solution, an IMU record) at least its size.
    #[test]
    fn a_status_travels_beside_the_items() {
        let (status, item) = (size_of::<Status>(), size_of::<Item>());
        assert!(status > item, "Status {status} B, Item {item} B");
    }

    /// A pipe dropped without `finish` (the session stopped on an error):
    /// nothing hangs, and the file ends readable with what it was given.
    #[test]
    fn a_dropped_pipe_still_ends_its_file() {
        let p = path("dropped.mcap");
        let m = Box::new(McapFile::create(&p, AidSource::Updates).expect("file"));
        std::thread::scope(|scope| {
            let mut pipe = McapPipe::start(scope, m);
            for (item, _, _) in flight(600)
                .into_iter()
                .filter(|(i, _, _)| matches!(i, Item::Record(_) | Item::Solution(_)))
            {
                pipe.push(item).expect("pushed");
            }
        });
        let bytes = std::fs::read(&p).expect("file");
        let _ = std::fs::remove_file(&p);
        let summary = mcap::Summary::read(&bytes)
            .expect("readable")
            .expect("a summary");
        let stats = summary.stats.expect("statistics");
        assert!(stats.message_count > 600, "{}", stats.message_count);
    }
}
