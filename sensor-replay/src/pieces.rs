//! The flight recorder's files: one file (`record --out FILE`) or a
//! directory of rotated pieces (`record --out-dir DIR`), a retention bound
//! on the directory, and the behaviour on a full disk.
//!
//! Every piece is a complete navlog: a header with the daemon's settings,
//! then an init record (the daemon's last solution as a transfer alignment
//! would give it, or the last init message when no solution was seen yet),
//! then the inputs stamped after that solution that the previous piece
//! already holds, then the live records. `nav-daemon batch --log` and
//! `sensor-replay eval/export` read each piece alone.
//!
//! Nothing here blocks on the disk beyond one `write`: a write that fails
//! (full disk, file-size limit, I/O error) leaves the piece torn, is
//! reported once, and every record from the last successful flush of that
//! piece until writing succeeds again is counted as lost; the recorder
//! keeps draining its subscriptions meanwhile and retries in a new piece
//! every [`RETRY_PERIOD`].

use std::collections::{BTreeMap, VecDeque};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use msgs::navlog::{Header, NavlogWriter, Record};
use msgs::{InitState, Solution};
use polarnav_foxglove::{AidSource, McapFile};

/// How often a recorder that could not write tries again.
pub const RETRY_PERIOD: Duration = Duration::from_secs(1);

/// The inputs a new piece repeats from the previous one (those stamped
/// after the daemon's last solution) are at most this many: 2 s at 1 kHz.
const TAIL_MAX: usize = 2048;

/// Bounds of the rotation and retention options (bytes, seconds).
pub const ROTATE_BYTES_RANGE: (u64, u64) = (64 << 10, 1 << 40);
pub const ROTATE_SECS_RANGE: (f64, f64) = (1.0, 1e7);
pub const KEEP_BYTES_MAX: u64 = 1 << 50;

/// Rotation and retention in a directory of pieces.
#[derive(Debug, Clone, PartialEq)]
pub struct Rotation {
    pub dir: PathBuf,
    /// Start a new piece once the open one holds this many bytes.
    pub rotate_bytes: Option<u64>,
    /// Start a new piece after this long (the recorder's monotonic clock).
    pub rotate_secs: Option<f64>,
    /// Remove the oldest pieces (never the open one) while the directory's
    /// pieces hold more than this.
    pub keep_bytes: Option<u64>,
}

/// What an MCAP file of the recorder carries besides the records, as
/// `sensor-replay export` and `nav-daemon batch` write them: the
/// `polarnav.provenance` metadata record (program, version, commit, command
/// line, UTC start) and the UTC epoch that makes the log times dates.
/// Every MCAP piece has them (a piece resumed after a full disk too).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct McapProvenance {
    /// The `polarnav.provenance` record
    /// ([`polarnav_config::provenance::provenance`]).
    pub provenance: BTreeMap<String, String>,
    /// UTC of sensor time 0 (ns since 1970-01-01), from `--utc-start`.
    pub epoch_ns: Option<u64>,
}

/// Where the recorder writes.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// One file (`.mcap`: MCAP, else navlog). After a full disk tore it, the
    /// recording goes on in `STEM-resumed-N.EXT` beside it.
    File(PathBuf),
    /// Rotated navlog pieces `flight-NNNNNN-YYYYMMDDTHHMMSSZ.navlog`.
    Dir(Rotation),
}

/// Opens the byte sink of a piece (a file; tests inject failing writers).
pub type Opener = Box<dyn FnMut(&Path) -> io::Result<Box<dyn Write + Send>>>;

/// The default opener: creates the file (never overwrites one).
pub fn create_file() -> Opener {
    Box::new(|p: &Path| {
        let f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(p)?;
        Ok(Box::new(f) as Box<dyn Write + Send>)
    })
}

/// Counts the bytes handed on (the size of the open piece).
struct Counting<W: Write> {
    inner: W,
    bytes: Arc<AtomicU64>,
}

impl<W: Write> Write for Counting<W> {
    fn write(&mut self, b: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(b)?;
        self.bytes.fetch_add(n as u64, Ordering::Relaxed);
        Ok(n)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

enum Sink {
    Navlog(NavlogWriter<Counting<BufWriter<Box<dyn Write + Send>>>>),
    Mcap(Box<McapFile>),
}

struct Piece {
    path: PathBuf,
    sink: Sink,
    /// Bytes written to the piece so far (navlog pieces).
    bytes: Arc<AtomicU64>,
    opened: Instant,
    /// Records of the stream (not the header, init and repeated inputs a
    /// piece starts with) handed to the piece since its last successful
    /// flush: written once a flush succeeds, lost if it fails.
    unflushed: u64,
}

impl Piece {
    fn bytes(&self) -> u64 {
        self.bytes.load(Ordering::Relaxed)
    }

    fn write(&mut self, r: &Record) -> Result<(), String> {
        match &mut self.sink {
            Sink::Navlog(w) => w.write(r).map_err(|e| e.to_string())?,
            Sink::Mcap(m) => match r {
                Record::Header(h) => m.header(h).map_err(|e| e.to_string())?,
                other => m.channels().record(other),
            },
        }
        Ok(())
    }

    /// Flushes; returns the records this made written.
    fn flush(&mut self) -> Result<u64, String> {
        match &mut self.sink {
            Sink::Navlog(w) => w.flush().map_err(|e| e.to_string())?,
            Sink::Mcap(m) => m.flush().map_err(|e| e.to_string())?,
        }
        Ok(std::mem::take(&mut self.unflushed))
    }

    fn finish(self) -> Result<u64, String> {
        let n = self.unflushed;
        match self.sink {
            Sink::Navlog(w) => w.finish().map(|_| n).map_err(|e| e.to_string()),
            Sink::Mcap(m) => m.close().map(|()| n).map_err(|e| e.to_string()),
        }
    }
}

/// What the recorder wrote and lost.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PieceCounts {
    /// Records written (headers and repeated records of new pieces not counted).
    pub written: u64,
    /// Records that could not be written (full disk or another write error).
    pub lost: u64,
    /// Pieces opened, and pieces removed by the retention bound.
    pub opened: u64,
    pub removed: u64,
    /// Times writing failed (each reported once) and resumed.
    pub failures: u64,
}

impl std::fmt::Debug for Pieces {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pieces")
            .field("out", &self.out)
            .field("current", &self.current())
            .field("counts", &self.counts)
            .finish_non_exhaustive()
    }
}

/// The recorder's files: opens, rotates, removes and survives a full disk.
pub struct Pieces {
    out: Output,
    open: Opener,
    producer: String,
    scenario: String,
    settings: Option<String>,
    mcap: Option<McapProvenance>,
    piece: Option<Piece>,
    /// Set while writing fails: when it started and when to try again.
    failed: Option<(Instant, Instant)>,
    next_seq: u64,
    resumed: u64,
    counts: PieceCounts,
    last_init: Option<InitState>,
    last_solution: Option<Solution>,
    /// Inputs written after the last solution, stamped after it.
    tail: VecDeque<Record>,
}

impl Pieces {
    /// Nothing is opened until [`Pieces::start`] (the header waits for the
    /// daemon's settings).
    pub fn new(out: Output, open: Opener, producer: &str, scenario: &str) -> Self {
        let next_seq = match &out {
            Output::Dir(r) => list_pieces(&r.dir)
                .iter()
                .map(|p| p.seq + 1)
                .max()
                .unwrap_or(1),
            Output::File(_) => 1,
        };
        Self {
            out,
            open,
            producer: producer.to_owned(),
            scenario: scenario.to_owned(),
            settings: None,
            mcap: None,
            piece: None,
            failed: None,
            next_seq,
            resumed: 0,
            counts: PieceCounts::default(),
            last_init: None,
            last_solution: None,
            tail: VecDeque::new(),
        }
    }

    /// The provenance record and epoch of an MCAP output (a navlog output
    /// has its own header and ignores them).
    pub fn with_mcap_provenance(mut self, p: McapProvenance) -> Self {
        self.mcap = Some(p);
        self
    }

    pub fn counts(&self) -> PieceCounts {
        self.counts
    }

    /// The open piece, if any.
    pub fn current(&self) -> Option<&Path> {
        self.piece.as_ref().map(|p| p.path.as_path())
    }

    /// Opens the first piece with the daemon's settings (`None`: none received).
    pub fn start(&mut self, settings: Option<String>) -> Result<(), String> {
        self.settings = settings;
        if let Err(e) = self.open_next() {
            if matches!(self.out, Output::File(_)) && self.counts.opened == 0 {
                // The file named on the command line cannot be created at all.
                return Err(e);
            }
            self.fail(&e);
        }
        Ok(())
    }

    /// Writes a batch of records (time-ordered), rotating and retrying as needed.
    pub fn write_all(&mut self, records: impl IntoIterator<Item = Record>) {
        if self
            .failed
            .is_some_and(|(_, retry)| Instant::now() >= retry)
        {
            self.retry();
        }
        for r in records {
            self.track(&r);
            let Some(p) = self.piece.as_mut() else {
                self.counts.lost += 1;
                continue;
            };
            match p.write(&r) {
                Ok(()) => p.unflushed += 1,
                Err(e) => {
                    self.counts.lost += 1;
                    self.fail(&e);
                }
            }
        }
        if self.rotation_due() {
            self.rotate();
        }
    }

    /// Hands what was written to the kernel.
    pub fn flush(&mut self) {
        if let Some(p) = self.piece.as_mut() {
            match p.flush() {
                Ok(n) => self.counts.written += n,
                Err(e) => self.fail(&e),
            }
        }
    }

    /// Closes the open piece.
    pub fn finish(&mut self) -> Result<(), String> {
        match self.piece.take() {
            Some(p) => {
                let unflushed = p.unflushed;
                let path = p.path.clone();
                match p.finish() {
                    Ok(n) => {
                        self.counts.written += n;
                        Ok(())
                    }
                    Err(e) => {
                        self.counts.lost += unflushed;
                        Err(format!("{}: {e}", path.display()))
                    }
                }
            }
            None => Ok(()),
        }
    }

    /// Remembers what a new piece needs to start from.
    fn track(&mut self, r: &Record) {
        match r {
            Record::Init(i) => {
                self.last_init = Some(*i);
                self.tail.clear();
            }
            Record::Solution(s) => {
                self.last_solution = Some(**s);
                while self
                    .tail
                    .front()
                    .is_some_and(|x| x.t_ns().is_some_and(|t| t <= s.t_ns))
                {
                    self.tail.pop_front();
                }
            }
            Record::Imu(_) | Record::Aid(_) if self.last_solution.is_some() => {
                if self.tail.len() == TAIL_MAX {
                    self.tail.pop_front();
                }
                self.tail.push_back(r.clone());
            }
            _ => {}
        }
    }

    /// The init record a new piece starts with: the daemon's last solution
    /// (unless an init message came after it), or the last init message.
    fn start_state(&self) -> Option<InitState> {
        match (self.last_solution, self.last_init) {
            (Some(s), Some(i)) if i.t_ns >= s.t_ns => Some(i),
            (Some(s), _) => Some(init_from_solution(&s)),
            (None, i) => i,
        }
    }

    fn rotation_due(&self) -> bool {
        let (Output::Dir(r), Some(p)) = (&self.out, &self.piece) else {
            return false;
        };
        r.rotate_bytes.is_some_and(|b| p.bytes() >= b)
            || r.rotate_secs
                .is_some_and(|s| p.opened.elapsed().as_secs_f64() >= s)
    }

    fn rotate(&mut self) {
        if let Some(p) = self.piece.take() {
            let unflushed = p.unflushed;
            match p.finish() {
                Ok(n) => self.counts.written += n,
                Err(e) => {
                    self.counts.lost += unflushed;
                    self.fail(&e);
                    return;
                }
            }
        }
        if let Err(e) = self.open_next() {
            self.fail(&e);
        }
    }

    /// Writing failed: reported once per failure, the piece is left as it
    /// is (torn), and a new one is tried every RETRY_PERIOD.
    fn fail(&mut self, e: &str) {
        if let Some(p) = self.piece.take() {
            // Whatever was not flushed may or may not be on disk: lost.
            self.counts.lost += p.unflushed;
            let path = p.path.clone();
            drop_torn(p);
            if self.failed.is_none() {
                self.counts.failures += 1;
                polarnav_ipc::note!(
                    "record: cannot write {}: {e}; the disk is full or failing: records are \
                     counted as lost and the subscriptions drained until a new piece can be \
                     written (tried every {} s)",
                    path.display(),
                    RETRY_PERIOD.as_secs()
                );
            }
        } else if self.failed.is_none() {
            self.counts.failures += 1;
            polarnav_ipc::note!(
                "record: cannot start a piece: {e}; the disk is full or failing: records are \
                 counted as lost until one can be written (tried every {} s)",
                RETRY_PERIOD.as_secs()
            );
        }
        let now = Instant::now();
        let since = self.failed.map_or(now, |(s, _)| s);
        self.failed = Some((since, now + RETRY_PERIOD));
    }

    fn retry(&mut self) {
        let Some((since, _)) = self.failed else {
            return;
        };
        match self.open_next() {
            Ok(()) => {
                self.failed = None;
                polarnav_ipc::note!(
                    "record: writing again to {} after {:.1} s; {} records lost so far",
                    self.current()
                        .map_or(String::new(), |p| p.display().to_string()),
                    since.elapsed().as_secs_f64(),
                    self.counts.lost
                );
            }
            Err(_) => self.failed = Some((since, Instant::now() + RETRY_PERIOD)),
        }
    }

    /// The path of the next piece.
    fn next_path(&mut self) -> PathBuf {
        match &self.out {
            Output::Dir(r) => {
                let name = piece_name(self.next_seq, SystemTime::now());
                self.next_seq += 1;
                r.dir.join(name)
            }
            Output::File(f) => {
                if self.counts.opened == 0 {
                    return f.clone();
                }
                self.resumed += 1;
                let stem = f
                    .file_stem()
                    .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
                let ext = f
                    .extension()
                    .map_or_else(String::new, |e| format!(".{}", e.to_string_lossy()));
                f.with_file_name(format!("{stem}-resumed-{}{ext}", self.resumed))
            }
        }
    }

    /// Opens the next piece and writes its header, init and repeated
    /// inputs; flushed at once, so a full disk shows here. A piece that
    /// cannot be started is removed again (it is ours and holds nothing).
    fn open_next(&mut self) -> Result<(), String> {
        let path = self.next_path();
        let metadata = match &self.settings {
            Some(t) => format!(
                "# recorded live (piece {} of this recording); the daemon's effective settings:\n{t}",
                self.counts.opened + 1
            ),
            None => "recorded live (no daemon settings received)".to_owned(),
        };
        let header = Header::new(&self.producer, &self.scenario, 0, &metadata);
        let mcap = matches!(self.out, Output::File(_)) && is_mcap(&path);
        let bytes = Arc::new(AtomicU64::new(0));
        let result = (|| -> Result<Piece, String> {
            let sink = if mcap {
                let mut m =
                    McapFile::create(&path, AidSource::Status).map_err(|e| e.to_string())?;
                if let Some(p) = &self.mcap {
                    if let Some(e) = p.epoch_ns {
                        m.channels().set_epoch_ns(e);
                    }
                    m.metadata("polarnav.provenance", p.provenance.clone())
                        .map_err(|e| e.to_string())?;
                }
                m.header(&header).map_err(|e| e.to_string())?;
                Sink::Mcap(Box::new(m))
            } else {
                let raw = (self.open)(&path).map_err(|e| e.to_string())?;
                let w = Counting {
                    inner: BufWriter::with_capacity(1 << 20, raw),
                    bytes: Arc::clone(&bytes),
                };
                Sink::Navlog(NavlogWriter::new(w, header).map_err(|e| e.to_string())?)
            };
            let mut p = Piece {
                path: path.clone(),
                sink,
                bytes: Arc::clone(&bytes),
                opened: Instant::now(),
                unflushed: 0,
            };
            if (self.counts.opened > 0 || self.failed.is_some())
                && let Some(i) = self.start_state()
            {
                p.write(&Record::Init(i))?;
                if self.last_solution.is_some_and(|s| s.t_ns >= i.t_ns) {
                    for r in &self.tail {
                        p.write(r)?;
                    }
                }
            }
            p.flush()?;
            p.unflushed = 0;
            Ok(p)
        })();
        match result {
            Ok(p) => {
                self.counts.opened += 1;
                self.piece = Some(p);
                self.retain();
                Ok(())
            }
            Err(e) => {
                if path.exists() && self.counts.opened > 0 {
                    let _ = std::fs::remove_file(&path);
                }
                Err(format!("{}: {e}", path.display()))
            }
        }
    }

    /// Removes the oldest pieces of the directory (never the open one)
    /// while all of them together hold more than `keep_bytes`.
    fn retain(&mut self) {
        let Output::Dir(Rotation {
            dir,
            keep_bytes: Some(keep),
            ..
        }) = &self.out
        else {
            return;
        };
        let open = self.piece.as_ref().map(|p| p.path.clone());
        let pieces = list_pieces(dir);
        let mut total: u64 = pieces.iter().map(|p| p.bytes).sum();
        for p in &pieces {
            if total <= *keep {
                break;
            }
            if Some(&p.path) == open.as_ref() {
                continue;
            }
            match std::fs::remove_file(&p.path) {
                Ok(()) => {
                    total -= p.bytes;
                    self.counts.removed += 1;
                    polarnav_ipc::note!(
                        "record: removed {} ({} bytes): the recordings exceed --keep-bytes {keep}",
                        p.path.display(),
                        p.bytes
                    );
                }
                Err(e) => polarnav_ipc::note!("record: cannot remove {}: {e}", p.path.display()),
            }
        }
    }
}

/// A torn piece is closed as it is: its buffer's last attempt to write
/// (on drop) may add a partial frame, which readers skip.
fn drop_torn(p: Piece) {
    drop(p);
}

/// An output named `*.mcap` is written as MCAP.
pub fn is_mcap(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
}

/// The init record a transfer alignment from the daemon's solution `s`
/// would give: its position, velocity and attitude with its σ (within the
/// navigator's accepted range).
pub fn init_from_solution(s: &Solution) -> InitState {
    let max = polarnav::navigator::INIT_SIGMA_MAX;
    let [se, sn, su] = s.sigma_pos_enu_m;
    let [vx, vy, vz] = s.sigma_vel_mps;
    let [ax, ay, az] = s.sigma_att_rad;
    let clamp = |v: f64, hi: f64| if v.is_finite() { v.clamp(0.0, hi) } else { hi };
    InitState {
        t_ns: s.t_ns,
        seq: 0,
        r_e_m: s.r_e_m,
        v_e_mps: s.v_e_mps,
        q_b_e: s.q_b_e,
        sigma_pos_h_m: clamp(se.max(sn), max[0]),
        sigma_pos_v_m: clamp(su, max[1]),
        sigma_vel_h_mps: clamp(vx.max(vy), max[2]),
        sigma_vel_v_mps: clamp(vz, max[3]),
        sigma_tilt_rad: clamp(ax.max(ay), max[4]),
        sigma_heading_rad: clamp(az, max[5]),
        ..Default::default()
    }
}

/// A piece of a rotated recording found in its directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PieceFile {
    pub path: PathBuf,
    pub seq: u64,
    pub bytes: u64,
}

/// The name of piece `seq` started at `at`: `flight-NNNNNN-YYYYMMDDTHHMMSSZ.navlog`.
/// The sequence number orders the pieces (a wall clock may jump; it is
/// in the name for the reader only).
pub fn piece_name(seq: u64, at: SystemTime) -> String {
    let secs = at.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!(
        "flight-{seq:06}-{y:04}{m:02}{d:02}T{:02}{:02}{:02}Z.navlog",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// The sequence number of a file the recorder named, `None` for any other
/// file (the retention bound never touches those).
pub fn piece_seq(name: &str) -> Option<u64> {
    let rest = name.strip_prefix("flight-")?.strip_suffix("Z.navlog")?;
    let (seq, stamp) = rest.split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let (date, time) = stamp.split_once('T')?;
    let well_formed = (6..=19).contains(&seq.len())
        && digits(seq)
        && date.len() == 8
        && digits(date)
        && time.len() == 6
        && digits(time);
    if !well_formed {
        return None;
    }
    seq.parse().ok()
}

/// The recorder's pieces in `dir`, oldest (lowest sequence number) first.
pub fn list_pieces(dir: &Path) -> Vec<PieceFile> {
    let mut out: Vec<PieceFile> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name();
            let seq = piece_seq(name.to_str()?)?;
            let meta = e.metadata().ok()?;
            meta.is_file().then(|| PieceFile {
                path: e.path(),
                seq,
                bytes: meta.len(),
            })
        })
        .collect();
    out.sort_by_key(|p| p.seq);
    out
}

/// Days since 1970-01-01 to (year, month, day), proleptic Gregorian
/// (H. Hinnant's `civil_from_days`).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// Parses a byte count: an integer with an optional binary suffix
/// (`K`, `M`, `G`, `T`, also `KiB`...), within `[lo, hi]`.
pub fn parse_bytes(s: &str, lo: u64, hi: u64) -> Result<u64, String> {
    let t = s.trim();
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (num, suffix) = t.split_at(split);
    let shift = match suffix.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 0,
        "K" | "KIB" => 10,
        "M" | "MIB" => 20,
        "G" | "GIB" => 30,
        "T" | "TIB" => 40,
        other => {
            return Err(format!(
                "{s:?}: unknown unit {other:?} (expected a byte count with K, M, G or T)"
            ));
        }
    };
    let n: u64 = num
        .parse()
        .map_err(|_| format!("{s:?}: expected a whole number of bytes (K, M, G, T allowed)"))?;
    let v = n
        .checked_mul(1u64 << shift)
        .filter(|v| (lo..=hi).contains(v))
        .ok_or_else(|| format!("{s:?}: expected between {lo} and {hi} bytes"))?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicBool;

    #[test]
    fn piece_names_are_recognised_and_nothing_else_is() {
        let n = piece_name(42, UNIX_EPOCH + Duration::from_secs(1_700_000_000));
        assert_eq!(n, "flight-000042-20231114T221320Z.navlog");
        assert_eq!(piece_seq(&n), Some(42));
        for foreign in [
            "flight.navlog",
            "flight-000042-20231114T221320Z.navlog.bak",
            "flight-42-20231114T221320Z.navlog",
            "flight-000042-2023111T221320Z.navlog",
            "flight-0000x2-20231114T221320Z.navlog",
            "notes.txt",
            "flight-20231114T221320Z.navlog",
        ] {
            assert_eq!(piece_seq(foreign), None, "{foreign}");
        }
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
    }

    #[test]
    fn byte_counts_are_bounded_and_adversarial_ones_refused() {
        let (lo, hi) = ROTATE_BYTES_RANGE;
        assert_eq!(parse_bytes("256M", lo, hi), Ok(256 << 20));
        assert_eq!(parse_bytes("65536", lo, hi), Ok(65536));
        assert_eq!(parse_bytes("20GiB", lo, KEEP_BYTES_MAX), Ok(20 << 30));
        for bad in [
            "0",
            "1",
            "1000000000000000000",
            "18446744073709551615T",
            "NaN",
            "-5M",
            "1.5G",
            "",
            "12 parsecs",
        ] {
            assert!(parse_bytes(bad, lo, hi).is_err(), "{bad}");
        }
    }

    /// A writer that fails with ENOSPC while `full` is set, as a full
    /// file system does (an injected writer: this test needs no tmpfs).
    struct Disk {
        inner: std::fs::File,
        full: Arc<AtomicBool>,
    }

    impl Write for Disk {
        fn write(&mut self, b: &[u8]) -> io::Result<usize> {
            if self.full.load(Ordering::Relaxed) {
                return Err(io::Error::from_raw_os_error(28)); // ENOSPC
            }
            self.inner.write(b)
        }
        fn flush(&mut self) -> io::Result<()> {
            if self.full.load(Ordering::Relaxed) {
                return Err(io::Error::from_raw_os_error(28));
            }
            self.inner.flush()
        }
    }

    fn imu(t_ns: u64) -> Record {
        Record::Imu(msgs::ImuSample {
            t_ns,
            seq: t_ns,
            dt_s: 0.005,
            ..Default::default()
        })
    }

    fn solution(t_ns: u64) -> Record {
        Record::Solution(Box::new(Solution {
            t_ns,
            r_e_m: [0.0, 0.0, 6_356_752.0],
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            sigma_pos_enu_m: [3.0, 4.0, 5.0],
            sigma_vel_mps: [0.1, 0.2, 0.3],
            sigma_att_rad: [1e-4, 2e-4, 3e-4],
            ..Default::default()
        }))
    }

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("pn-pieces-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("dir");
        d
    }

    /// A full disk: reported, every record not written counted, nothing
    /// blocks, and writing resumes in a new piece that starts from the
    /// daemon's last solution; the torn piece reads up to its tear.
    #[test]
    fn a_full_disk_counts_what_is_lost_and_writing_resumes_in_a_new_piece() {
        let dir = tmp("full");
        let full = Arc::new(AtomicBool::new(false));
        let f2 = Arc::clone(&full);
        let opener: Opener = Box::new(move |p: &Path| {
            let inner = std::fs::File::create(p)?;
            if f2.load(Ordering::Relaxed) {
                return Err(io::Error::from_raw_os_error(28));
            }
            Ok(Box::new(Disk {
                inner,
                full: Arc::clone(&f2),
            }) as Box<dyn Write + Send>)
        });
        let out = Output::Dir(Rotation {
            dir: dir.clone(),
            rotate_bytes: None,
            rotate_secs: None,
            keep_bytes: None,
        });
        let mut p = Pieces::new(out, opener, "test", "p");
        p.start(Some("[navigator]\n".into())).expect("start");
        let ms = 1_000_000;
        p.write_all((1..=10).flat_map(|k| [imu(k * 5 * ms), solution(k * 5 * ms)]));
        p.flush();
        assert_eq!(p.counts().written, 20);
        full.store(true, Ordering::Relaxed);
        // 20 more records land in the buffer; the flush fails: all lost.
        p.write_all((11..=20).flat_map(|k| [imu(k * 5 * ms), solution(k * 5 * ms)]));
        p.flush();
        assert!(p.current().is_none());
        // While full: records are counted, nothing waits.
        let t0 = Instant::now();
        p.write_all((21..=30).flat_map(|k| [imu(k * 5 * ms), solution(k * 5 * ms)]));
        assert!(t0.elapsed() < Duration::from_millis(100));
        assert_eq!(p.counts().lost, 40);
        assert_eq!(p.counts().failures, 1);
        // Space returns; the next write after RETRY_PERIOD resumes.
        full.store(false, Ordering::Relaxed);
        std::thread::sleep(RETRY_PERIOD + Duration::from_millis(50));
        p.write_all([imu(31 * 5 * ms)]);
        p.write_all([solution(31 * 5 * ms)]);
        p.finish().expect("finish");
        let c = p.counts();
        assert_eq!((c.written, c.lost, c.opened), (22, 40, 2), "{c:?}");
        let pieces = list_pieces(&dir);
        assert_eq!(pieces.len(), 2);
        let (first, _) = msgs::navlog::read_all(&std::fs::read(&pieces[0].path).expect("read"));
        assert_eq!(
            first
                .iter()
                .filter(|r| matches!(r, Record::Solution(_)))
                .count(),
            10
        );
        let (second, report) =
            msgs::navlog::read_all(&std::fs::read(&pieces[1].path).expect("read"));
        assert!(report.is_clean(), "{report}");
        // Header, the init from the last solution written (t = 150 ms),
        // then the new records.
        assert!(matches!(second[0], Record::Header(_)));
        let Record::Init(i) = second[1] else {
            panic!("{:?}", second[1]);
        };
        assert_eq!(i.t_ns, 150 * ms);
        assert!(
            (i.sigma_pos_h_m - 4.0).abs() < 1e-12 && (i.sigma_heading_rad - 3e-4).abs() < 1e-12
        );
        assert_eq!(second[2], imu(155 * ms));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Rotation by size and the retention bound: the directory never holds
    /// more than keep_bytes plus the open piece, the oldest go first, the
    /// open piece and foreign files are never removed, and each piece
    /// starts with a header and an init.
    #[test]
    fn rotation_and_retention_keep_their_bounds_and_foreign_files() {
        let dir = tmp("rotate");
        std::fs::write(dir.join("notes.txt"), vec![b'x'; 200_000]).expect("foreign");
        std::fs::write(dir.join("flight.navlog"), vec![b'x'; 200_000]).expect("foreign");
        let (rotate, keep) = (64 << 10, 256 << 10);
        let out = Output::Dir(Rotation {
            dir: dir.clone(),
            rotate_bytes: Some(rotate),
            rotate_secs: None,
            keep_bytes: Some(keep),
        });
        let mut p = Pieces::new(out, create_file(), "test", "p");
        p.start(Some("[navigator]\n".into())).expect("start");
        let ms = 1_000_000;
        let mut t = 0;
        for _ in 0..200 {
            let batch: Vec<Record> = (0..20)
                .flat_map(|_| {
                    t += 5 * ms;
                    [imu(t), solution(t)]
                })
                .collect();
            p.write_all(batch);
            p.flush();
            let pieces = list_pieces(&dir);
            let total: u64 = pieces.iter().map(|x| x.bytes).sum();
            let open = p.current().expect("open").to_path_buf();
            assert!(pieces.iter().any(|x| x.path == open), "open piece removed");
            assert!(total <= keep + rotate + (64 << 10), "{total} bytes");
        }
        p.finish().expect("finish");
        let c = p.counts();
        assert!(c.opened > 10 && c.removed > 5, "{c:?}");
        let pieces = list_pieces(&dir);
        // The newest are kept, oldest removed first: consecutive up to the last.
        let seqs: Vec<u64> = pieces.iter().map(|x| x.seq).collect();
        assert_eq!(*seqs.last().expect("pieces"), c.opened);
        assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
        for x in &pieces {
            let (recs, report) = msgs::navlog::read_all(&std::fs::read(&x.path).expect("read"));
            assert!(report.is_clean(), "{}: {report}", x.path.display());
            assert!(matches!(recs[0], Record::Header(_)));
            assert!(matches!(recs[1], Record::Init(_)), "{}", x.path.display());
        }
        assert!(dir.join("notes.txt").exists() && dir.join("flight.navlog").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
