//! `nav-daemon batch`: read → session → sink, as fast as possible.
//!
//! Every decision between a record and a solution row is the session's
//! (`polarnav::session`), exactly as in the live daemon; this driver only
//! reads the navlog, builds the effective settings from the configuration
//! file, the log header and the command line, and writes the solution: a
//! CSV, or an MCAP file with every input stream, the solutions, status at
//! 1 Hz of sensor time, every aid update at its gate, frame switches and
//! truth (`polarnav_foxglove`).

use std::io::{BufRead, Write};

use msgs::navlog::{NavlogReader, ReadReport, Record};
use polarnav::align::{AlignError, Alignment};
use polarnav::navigator::SwitchEvent;
use polarnav::row_interval::RowInterval;
use polarnav::session::{Event, InitCounters, Input, PerStream, Session, Sink, Stream};
use polarnav::smoother::{FileStore, SmoothReport, Smoother};

use crate::csv_pipe::RowPipe;
use crate::events::log_event;
use crate::imu_rate::RateCheck;
use crate::mcap_pipe::{Item, McapPipe};
use polarnav::solution_csv;
use polarnav_config::{CliOverrides, ConfigError, ConfigFile, Effective, effective};
use polarnav_foxglove::{McapError, McapFile};

/// Where a batch run writes its solution.
#[derive(Debug)]
pub enum Output<W: Write> {
    /// The solution CSV (DESIGN's 24 columns, then the extra ones).
    Csv(W),
    /// An MCAP file with every channel of `polarnav_foxglove`.
    Mcap(Box<McapFile>),
}

/// Status messages in an MCAP output: one per this much sensor time (as live).
const MCAP_STATUS_PERIOD_NS: u64 = 1_000_000_000;

/// Options of one batch run beyond the configuration file.
#[derive(Debug, Clone, Default)]
pub struct BatchOptions {
    /// Settings given on the command line (they override file and header).
    pub cli: CliOverrides,
    /// Print a progress line to stderr every this many seconds of flight (0 = quiet).
    pub progress_every_s: f64,
    /// Write one solution per this interval of sensor time (and every
    /// first, switch, reset and last row) instead of every one.
    pub every: Option<RowInterval>,
    /// Write the fixed-interval smoothed solution instead of the forward
    /// one (`polarnav::smoother`), keeping its tape in a temporary file in
    /// this directory beyond the first chunk.
    pub smooth: Option<std::path::PathBuf>,
}

/// What a batch run did.
#[derive(Debug, Clone)]
pub struct BatchReport {
    pub read: ReadReport,
    pub rows: u64,
    pub switches: Vec<SwitchEvent>,
    /// The settings used, with their sources.
    pub effective: Effective,
    pub first_t_ns: u64,
    pub last_t_ns: u64,
    /// The alignment, when one ran.
    pub alignment: Option<Alignment>,
    pub inits: InitCounters,
    pub time_resyncs: u64,
    pub covariance_repairs: u64,
    /// The session's status at the end, with every record of the log
    /// accounted for: per stream `received = accepted + rejected_* + not_used`.
    pub status: msgs::Status,
    /// What the smoother did, with `--smooth`.
    pub smoothed: Option<SmoothReport>,
}

impl BatchReport {
    /// Aid samples fused, and refused (content, time or gate), over all aids.
    pub fn aid_totals(&self) -> (u64, u64) {
        let s = &self.status;
        let fused = s.each_aid().map(|(_, c, _)| c.accepted).sum();
        let rejected = s
            .each_aid()
            .map(|(_, c, _)| {
                c.rejected_invalid + c.rejected_time + c.rejected_gate + c.rejected_integrity
            })
            .sum();
        (fused, rejected)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// Invalid settings (exit 2).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The log never gave the session a state to navigate from (exit 2);
    /// `read` says what the reader skipped, which may have been the init.
    #[error(
        "{log}: no init record that the IMU data reached, and no [init] in the configuration; the log cannot be navigated{}",
        skipped_init_note(read)
    )]
    NoInit { log: String, read: ReadReport },
    /// The alignment could not be solved (exit 1).
    #[error("{0}: alignment failed: {1}")]
    Align(String, AlignError),
    /// The log ended before the alignment window was complete (exit 2).
    #[error("{log}: only {have_s:.1} s of IMU data for a {need_s:.1} s alignment")]
    AlignIncomplete {
        log: String,
        have_s: f64,
        need_s: f64,
    },
    /// Reading the log failed (exit 1).
    #[error("{path}: {source}")]
    Read {
        path: String,
        source: msgs::navlog::ReadError,
    },
    /// Writing the solution failed (exit 1).
    #[error("writing the solution: {0}")]
    Write(#[from] std::io::Error),
    /// Writing the MCAP file failed (exit 1).
    #[error(transparent)]
    Mcap(#[from] McapError),
}

impl BatchError {
    /// Process exit status per DESIGN.
    pub fn exit_code(&self) -> i32 {
        match self {
            BatchError::Config(_)
            | BatchError::NoInit { .. }
            | BatchError::AlignIncomplete { .. } => 2,
            BatchError::Read { .. }
            | BatchError::Write(_)
            | BatchError::Mcap(_)
            | BatchError::Align(..) => 1,
        }
    }
}

/// What a log without a usable init skipped: the init record itself when
/// a damaged frame reads as one, else any damaged frame (it may have been).
fn skipped_init_note(read: &ReadReport) -> String {
    match (read.damaged_init_offset, read.first_skip_offset) {
        (Some(at), _) => {
            format!(": its init record at byte {at} is damaged (checksum mismatch) and was skipped")
        }
        (None, Some(at)) => format!(
            ": the reader skipped {} damaged frame(s), the first at byte {at}; the init record may be among them",
            read.skipped_frames()
        ),
        (None, None) => String::new(),
    }
}

/// Where the sink writes.
enum SinkOut<W: Write> {
    Csv(W),
    Mcap(McapOut),
}

/// The MCAP file: here, or on its encoding thread while the log is read
/// (`mcap_pipe`: the same messages in the same order).
struct McapOut {
    file: Option<Box<McapFile>>,
    pipe: Option<McapPipe>,
}

impl McapOut {
    /// A record of the log: an aid's sample by value (no box per sample
    /// on its way to the encoder).
    fn record(&mut self, rec: &Record) -> std::io::Result<()> {
        match (rec, &mut self.pipe, &mut self.file) {
            (Record::Aid(a), Some(p), _) => p.push_aid(a),
            (Record::Aid(a), None, Some(m)) => {
                m.channels().aid_sample(a);
                Ok(())
            }
            _ => self.log(Item::Record(rec.clone())),
        }
    }

    fn log(&mut self, item: Item) -> std::io::Result<()> {
        match (&mut self.pipe, &mut self.file) {
            (Some(p), _) => p.push(item),
            (None, Some(m)) => {
                item.log(m);
                Ok(())
            }
            (None, None) => Ok(()),
        }
    }

    fn status(&mut self, st: &msgs::Status) -> std::io::Result<()> {
        match (&mut self.pipe, &mut self.file) {
            (Some(p), _) => p.push_status(st),
            (None, Some(m)) => {
                m.channels().status(st);
                Ok(())
            }
            (None, None) => Ok(()),
        }
    }
}

/// Writes solution rows and logs the session's decisions (the first few
/// rejections per stream, every start, switch and resync).
struct CsvSink<'a, W: Write> {
    out: SinkOut<W>,
    log_name: &'a str,
    rows: u64,
    error: Option<std::io::Error>,
    progress_ns: u64,
    next_progress_ns: u64,
    switches: Vec<SwitchEvent>,
    align_error: Option<AlignError>,
    rejections_logged: PerStream<u32>,
    gaps_logged: PerStream<u32>,
    every: Option<RowInterval>,
    csv: solution_csv::RowWriter,
    /// With `--smooth`: the forward run's tape and solutions, written
    /// smoothed at the end instead of as they come.
    smoother: Option<Smoother<FileStore>>,
    /// While the log is read: the CSV rows' text is made on a thread of
    /// its own (`csv_pipe`), the same text in the same order.
    pipe: Option<RowPipe>,
}

/// Rejections logged per stream before the rest are only counted (status).
const REJECTIONS_LOGGED: u32 = 10;

impl<W: Write> CsvSink<'_, W> {
    fn write(&mut self, s: &msgs::Solution) {
        let written = match &mut self.out {
            SinkOut::Csv(w) => match &mut self.pipe {
                Some(p) => p.push(w, s),
                None => self.csv.write(w, s),
            },
            SinkOut::Mcap(m) => m.log(Item::Solution(*s)),
        };
        if let Err(e) = written {
            self.error = Some(e);
            return;
        }
        self.rows += 1;
    }

    fn progress(&mut self, s: &msgs::Solution) {
        if self.progress_ns > 0 && s.t_ns >= self.next_progress_ns {
            self.next_progress_ns = s.t_ns.saturating_add(self.progress_ns);
            let frame = msgs::WireFrame::from_u8(s.frame).map_or('?', msgs::WireFrame::letter);
            crate::note!(
                "batch: t = {:7.1} s  frame {frame}  lat {:9.5}°  lon {:10.5}°  h {:8.1} m  heading {:6.2}°",
                s.t_ns as f64 * 1e-9,
                s.lat_rad.to_degrees(),
                s.lon_rad.to_degrees(),
                s.h_m,
                s.heading_rad.to_degrees()
            );
        }
    }
}

impl<W: Write> Sink for CsvSink<'_, W> {
    fn wants_solution(&mut self, t_ns: u64, must: bool) -> bool {
        self.every.as_mut().is_none_or(|e| e.take(t_ns, must))
    }

    fn tape(&mut self, records: &[u8]) {
        if let Some(sm) = &mut self.smoother {
            sm.records(records);
            // The temporary file failed (a full disk): the run stops here,
            // not hours later at the backward pass.
            if let Some(e) = sm.failed()
                && self.error.is_none()
            {
                self.error = Some(std::io::Error::new(
                    e.kind(),
                    format!("the smoother's temporary file: {e}"),
                ));
            }
        }
    }

    fn solution(&mut self, s: &msgs::Solution) {
        if self.error.is_some() {
            return;
        }
        if self.smoother.is_some() {
            // Written smoothed at the end; the session records it on the tape.
            self.progress(s);
            return;
        }
        self.write(s);
        self.progress(s);
    }

    fn event(&mut self, e: &Event) {
        let log = self.log_name;
        match e {
            Event::Rejected {
                stream,
                t_ns,
                seq,
                reason,
            } => {
                let n = self.rejections_logged.get_mut(*stream);
                *n += 1;
                if *n <= REJECTIONS_LOGGED {
                    tracing::warn!(
                        t_ns,
                        seq,
                        "{log}: {} sample rejected: {reason}",
                        stream.name()
                    );
                }
            }
            Event::Switch(sw) => {
                tracing::info!(t_s = sw.t_ns as f64 * 1e-9, from = ?sw.from, to = ?sw.to, lat_deg = sw.lat_rad.to_degrees(), "frame switch");
                self.switches.push(*sw);
            }
            Event::SequenceGap { stream, .. } => {
                let n = self.gaps_logged.get_mut(*stream);
                *n += 1;
                if *n <= REJECTIONS_LOGGED {
                    log_event(log, e);
                }
            }
            Event::AlignmentFailed(err) => self.align_error = Some(*err),
            Event::Aligned { init, .. } => {
                log_event(log, e);
                // The init record the alignment made, beside the one given.
                if let SinkOut::Mcap(m) = &mut self.out
                    && let Err(e) = m.log(Item::Record(Record::Init(*init)))
                {
                    self.error.get_or_insert(e);
                }
            }
            Event::AidUpdate {
                stream,
                t_ns,
                status,
                lat_rad,
                h_m,
            } => {
                if let (SinkOut::Mcap(m), Stream::Aid(aid)) = (&mut self.out, stream)
                    && let Err(e) = m.log(Item::AidUpdate {
                        aid: *aid,
                        t_ns: *t_ns,
                        status: *status,
                        lat_rad: *lat_rad,
                        h_m: *h_m,
                    })
                {
                    self.error.get_or_insert(e);
                }
            }
            other => log_event(log, other),
        }
    }
}

/// Runs the session over `log`, writing the solution CSV to `out`.
/// `log_name` names the log in errors.
pub fn run<R: BufRead + Send, W: Write>(
    log: R,
    log_name: &str,
    out: W,
    file: &ConfigFile,
    opts: &BatchOptions,
) -> Result<BatchReport, BatchError> {
    run_to(log, log_name, Output::Csv(out), file, opts)
}

/// Records per chunk handed from the decoding thread to the session, and
/// chunks decoded ahead: about 2 MB of records in flight.
const CHUNK_RECORDS: usize = 4096;
const CHUNKS_AHEAD: usize = 2;

/// Runs the session over `log`, writing the solution to `out` (CSV or MCAP).
pub fn run_to<R: BufRead + Send, W: Write>(
    log: R,
    log_name: &str,
    out: Output<W>,
    file: &ConfigFile,
    opts: &BatchOptions,
) -> Result<BatchReport, BatchError> {
    let mut reader = NavlogReader::new(log);
    let read_err = |source| BatchError::Read {
        path: log_name.to_owned(),
        source,
    };
    // The header, when the log has one, comes first and may carry settings.
    let first = reader.next_record().map_err(read_err)?;
    let metadata = match &first {
        Some(Record::Header(h)) => Some(h.metadata.as_str()),
        _ => None,
    };
    let eff = effective(file, metadata, &opts.cli)?;
    tracing::info!("{log_name}: effective settings:\n{}", eff.describe());
    let mut session = Session::new(eff.session());
    let progress_ns = (opts.progress_every_s.clamp(0.0, 1e9) * 1e9) as u64;
    let mut sink = CsvSink {
        out: match out {
            Output::Csv(w) => SinkOut::Csv(w),
            Output::Mcap(m) => SinkOut::Mcap(McapOut {
                file: Some(m),
                pipe: None,
            }),
        },
        log_name,
        rows: 0,
        error: None,
        progress_ns,
        next_progress_ns: 0,
        switches: Vec::new(),
        align_error: None,
        rejections_logged: PerStream::default(),
        gaps_logged: PerStream::default(),
        every: opts.every,
        csv: solution_csv::RowWriter::new(),
        smoother: match &opts.smooth {
            Some(dir) => Some(Smoother::new(FileStore::new_in(dir)?)),
            None => None,
        },
        pipe: None,
    };
    if sink.smoother.is_some() {
        session.keep_smoother_tape();
    }
    match &mut sink.out {
        SinkOut::Csv(w) => writeln!(w, "{}", solution_csv::header())?,
        SinkOut::Mcap(McapOut {
            file: Some(m),
            pipe: None,
        }) => {
            if let Some(Record::Header(h)) = &first {
                m.header(h)?;
            }
            m.metadata(
                "polarnav.settings",
                polarnav_config::provenance::settings(&eff),
            )?;
        }
        SinkOut::Mcap(_) => {}
    }
    let mut next_status_ns = 0;
    let mut imu_rate = RateCheck::new(eff.config.live.imu_rate_hz);
    let mut push = |rec: &Record, session: &mut Session, sink: &mut CsvSink<'_, W>| {
        if let Record::Imu(x) = rec
            && let Some(d) = imu_rate.observe(x.t_ns)
        {
            tracing::warn!("{log_name}: {d}");
        }
        if let SinkOut::Mcap(m) = &mut sink.out
            // The log's inputs and truth; its own solutions and status (a
            // recording) would mix with this run's.
            && !matches!(rec, Record::Solution(_) | Record::Status(_))
            && let Err(e) = m.record(rec)
        {
            sink.error.get_or_insert(e);
        }
        if let Some(input) = Input::from_record(rec) {
            session.push(input, sink);
        }
        if let SinkOut::Mcap(m) = &mut sink.out {
            let now = session.span_ns().1;
            if session.navigator().is_some() && now >= next_status_ns {
                next_status_ns = now.saturating_add(MCAP_STATUS_PERIOD_NS);
                if let Err(e) = m.status(&session.status()) {
                    sink.error.get_or_insert(e);
                }
            }
        }
    };
    if let Some(rec) = &first {
        push(rec, &mut session, &mut sink);
    }
    // The rest of the log is read and decoded on a second thread, a chunk
    // of records ahead of the session (the navigator's work and the
    // decoding overlap on two cores); chunks go back to it for reuse, so
    // the steady state allocates nothing more than decoding itself does.
    let (read, sink_error) = std::thread::scope(|scope| {
        // The forward solution as CSV: its text is made on a third thread;
        // as MCAP, every message is encoded there.
        match &mut sink.out {
            SinkOut::Csv(_) if sink.smoother.is_none() => {
                sink.pipe = Some(RowPipe::start(scope).0);
            }
            SinkOut::Mcap(m) => {
                if let Some(f) = m.file.take() {
                    m.pipe = Some(McapPipe::start(scope, f));
                }
            }
            SinkOut::Csv(_) => {}
        }
        let (full_tx, full_rx) = std::sync::mpsc::sync_channel::<Vec<Record>>(CHUNKS_AHEAD);
        let (empty_tx, empty_rx) = std::sync::mpsc::sync_channel::<Vec<Record>>(CHUNKS_AHEAD + 2);
        let decoder = scope.spawn(move || {
            loop {
                let mut chunk = empty_rx
                    .try_recv()
                    .unwrap_or_else(|_| Vec::with_capacity(CHUNK_RECORDS));
                chunk.clear();
                let mut end = Ok(false);
                while chunk.len() < CHUNK_RECORDS {
                    match reader.next_record() {
                        Ok(Some(r)) => chunk.push(r),
                        Ok(None) => {
                            end = Ok(true);
                            break;
                        }
                        Err(e) => {
                            end = Err(e);
                            break;
                        }
                    }
                }
                // A closed channel: the session stopped on an output error.
                let sent = full_tx.send(chunk).is_ok();
                match end {
                    Ok(false) if sent => {}
                    Ok(_) => return Ok(reader.report().clone()),
                    Err(e) => return Err(e),
                }
            }
        });
        let mut sink_error = None;
        for mut chunk in full_rx.iter() {
            for rec in &chunk {
                push(rec, &mut session, &mut sink);
                if let Some(e) = sink.error.take() {
                    sink_error = Some(e);
                    break;
                }
            }
            if sink_error.is_some() {
                break;
            }
            chunk.clear();
            // The decoder may have finished: a failed return is harmless.
            let _ = empty_tx.try_send(chunk);
        }
        drop(full_rx);
        // The rows still being formatted are written before the scope ends
        // (the last solution, emitted by `finish` below, is written directly).
        if let (Some(pipe), SinkOut::Csv(w)) = (sink.pipe.take(), &mut sink.out)
            && sink_error.is_none()
            && let Err(e) = pipe.finish(w)
        {
            sink_error = Some(e);
        }
        // The MCAP file comes back once every message is logged (also
        // after an error: it is then closed with what it has).
        if let SinkOut::Mcap(m) = &mut sink.out
            && let Some(pipe) = m.pipe.take()
        {
            match pipe.finish() {
                Ok(f) => m.file = Some(f),
                Err(e) => {
                    sink_error.get_or_insert(e);
                }
            }
        }
        let read = decoder
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        (read, sink_error)
    });
    if let Some(e) = sink_error {
        return Err(e.into());
    }
    let read = read.map_err(read_err)?;
    session.finish(&mut sink);
    if let Some(e) = sink.error.take() {
        return Err(e.into());
    }
    if let Some(e) = sink.align_error {
        return Err(BatchError::Align(log_name.to_owned(), e));
    }
    if let Some(have_s) = session.alignment_progress_s() {
        return Err(BatchError::AlignIncomplete {
            log: log_name.to_owned(),
            have_s,
            need_s: eff.align_s.unwrap_or(0.0),
        });
    }
    let Some(nav) = session.navigator() else {
        return Err(BatchError::NoInit {
            log: log_name.to_owned(),
            read,
        });
    };
    let covariance_repairs = nav.covariance_repairs();
    let smoothed = match sink.smoother.take() {
        Some(sm) => {
            if progress_ns > 0 {
                crate::note!("batch: forward pass done; smoothing (backward pass)");
            }
            let report = sm.finish(|s| {
                sink.write(s);
                sink.error.take().map_or(Ok(()), Err)
            })?;
            tracing::info!(
                "{log_name}: smoothed {} solutions ({} passed through where nothing was learned, {} failed backward steps, tape {:.1} MB, {} chunks stored)",
                report.solutions,
                report.passed_through,
                report.failed_steps,
                report.tape_bytes as f64 / 1e6,
                report.stored_chunks
            );
            Some(report)
        }
        None => None,
    };
    match sink.out {
        SinkOut::Csv(mut w) => w.flush()?,
        SinkOut::Mcap(McapOut {
            file: Some(mut m), ..
        }) => {
            m.channels().status(&session.status());
            m.close()?;
        }
        SinkOut::Mcap(_) => {}
    }
    let (first_t_ns, last_t_ns) = session.span_ns();
    Ok(BatchReport {
        read,
        rows: sink.rows,
        switches: sink.switches,
        effective: eff,
        first_t_ns,
        last_t_ns,
        alignment: session.alignment().copied(),
        inits: session.init_counters(),
        time_resyncs: session.time_resyncs(),
        covariance_repairs,
        status: session.status(),
        smoothed,
    })
}
