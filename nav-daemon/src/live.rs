//! The live service: a fixed-rate cycle locked to the IMU over iceoryx2.
//!
//! A WaitSet wakes on the IMU topic's event and on an interval tick at the
//! nominal IMU period (which detects a missing IMU and keeps status flowing).
//! Each cycle drains every subscriber into preallocated buffers, orders the
//! inputs by time, runs the same [`Navigator`] as `batch` and publishes a
//! solution per IMU sample; status goes out at 1 Hz. Aids ahead of the
//! newest IMU sample wait for it; late aids are fused at their own time
//! stamp by the navigator. A new init message re-initializes (and is counted).
//! systemd: READY=1 after the first valid solution, WATCHDOG=1 from this
//! loop only, STATUS= once a second.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::SyncSender;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use msgs::service::Topic;
use msgs::{
    BaroSample, CnsFix, ImuSample, InitState, Solution, SrsSample, Status, StreamCounters,
    solution_flags,
};

use crate::checkpoint::{self, Checkpoint};
use crate::config::Config;
use crate::navigator::{AidOutcome, InputRejection, Navigator, NavigatorConfig};
use crate::transport::{self, TopicPublisher, TopicSubscriber, TransportConfig, TransportError};

/// Settings of the live loop.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveOptions {
    /// Nominal IMU rate (Hz): the interval tick and the overrun budget.
    pub imu_rate_hz: f64,
    /// IMU silent for this many nominal periods → IMU lost.
    pub imu_lost_periods: u32,
    /// Status period.
    pub status_period: Duration,
    /// Periodic checkpoints and resume-on-restart (`None`: disabled).
    pub checkpoint: Option<CheckpointOptions>,
}

/// Checkpoint settings of the live service.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckpointOptions {
    pub path: PathBuf,
    /// Sensor time between checkpoints (ns).
    pub period_ns: u64,
    /// Resume only if the first IMU sample is at most this long after the checkpoint (ns).
    pub max_age_ns: u64,
}

impl CheckpointOptions {
    /// From `[live]`; `None` when `checkpoint_path` is empty.
    pub fn from_config(c: &crate::config::LiveSettings) -> Option<Self> {
        (!c.checkpoint_path.is_empty()).then(|| Self {
            path: PathBuf::from(&c.checkpoint_path),
            period_ns: (c.checkpoint_period_s * 1e9).round() as u64,
            max_age_ns: (c.checkpoint_max_age_s * 1e9).round() as u64,
        })
    }
}

/// Writes checkpoints on its own thread, so that file I/O and fsync never
/// delay the filter cycle. The cycle offers a checkpoint by value through a
/// one-slot channel; if the writer is still busy the offer is skipped.
struct CheckpointWriter {
    tx: Option<SyncSender<Checkpoint>>,
    written: Arc<AtomicU64>,
    handle: Option<std::thread::JoinHandle<()>>,
    last_t_ns: u64,
    period_ns: u64,
}

impl CheckpointWriter {
    fn start(opts: &CheckpointOptions) -> Self {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Checkpoint>(1);
        let written = Arc::new(AtomicU64::new(0));
        let count = Arc::clone(&written);
        let path = opts.path.clone();
        let handle = std::thread::Builder::new()
            .name("checkpoint".into())
            .spawn(move || {
                let mut buf = [0u8; checkpoint::ENCODED_LEN];
                let mut errors = RateLimit::default();
                for c in rx {
                    c.encode(&mut buf);
                    match checkpoint::write_atomic(&path, &buf) {
                        Ok(()) => {
                            count.fetch_add(1, Ordering::Relaxed);
                        }
                        Err(e) => {
                            if let Some(suppressed) = errors.due() {
                                tracing::error!(path = %path.display(), suppressed, "checkpoint not written: {e}");
                            }
                        }
                    }
                }
            })
            .expect("spawn checkpoint writer");
        Self {
            tx: Some(tx),
            written,
            handle: Some(handle),
            last_t_ns: 0,
            period_ns: opts.period_ns,
        }
    }

    fn offer(&mut self, nav: &Navigator) {
        if nav.t_ns() < self.last_t_ns.saturating_add(self.period_ns) {
            return;
        }
        if let Some(tx) = &self.tx
            && tx.try_send(nav.checkpoint()).is_ok()
        {
            self.last_t_ns = nav.t_ns();
        }
    }

    fn written(&self) -> u64 {
        self.written.load(Ordering::Relaxed)
    }
}

impl Drop for CheckpointWriter {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

impl Default for LiveOptions {
    fn default() -> Self {
        Self {
            imu_rate_hz: 200.0,
            imu_lost_periods: 5,
            status_period: Duration::from_secs(1),
            checkpoint: None,
        }
    }
}

/// Why the service stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    #[error(transparent)]
    Transport(#[from] TransportError),
    #[error("iceoryx2 waitset: {0}")]
    WaitSet(String),
}

/// What a run did (for logs and tests).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LiveReport {
    pub cycles: u64,
    pub solutions: u64,
    pub reinits: u32,
    /// Cycles longer than the period in wall-clock time, and of those the
    /// ones whose own CPU time was longer (not a preemption).
    pub overruns: u64,
    pub overruns_cpu: u64,
}

/// Preallocated capacity of the per-cycle input buffers (a cycle normally
/// sees one IMU sample; 45 ms stalls at 1 kHz leave ~45). It exceeds the sum
/// of the subscriber buffers, so the buffers never grow and nothing drained
/// is dropped.
const CAPACITY: usize = 1024;

/// An aid sample waiting in the preallocated per-cycle buffer. Not boxed on
/// purpose: boxing the SRS variant would allocate in the loop.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Aid {
    Srs(SrsSample),
    Cns(CnsFix),
    Baro(BaroSample),
}

impl Aid {
    fn t_ns(&self) -> u64 {
        match self {
            Aid::Srs(x) => x.t_ns,
            Aid::Cns(x) => x.t_ns,
            Aid::Baro(x) => x.t_ns,
        }
    }

    /// Offers the sample to the navigator, which fuses or rejects and counts it.
    fn offer(&self, nav: &mut Navigator) -> Result<AidOutcome, InputRejection> {
        match self {
            Aid::Srs(x) => nav.on_srs(x),
            Aid::Cns(x) => nav.on_cns(x),
            Aid::Baro(x) => nav.on_baro(x),
        }
    }
}

/// Counts sequence gaps of one stream (samples lost upstream or overwritten
/// by the safe-overflow buffer).
#[derive(Debug, Clone, Copy, Default)]
struct SeqTracker {
    next: Option<u64>,
    gaps: u64,
}

impl SeqTracker {
    fn see(&mut self, seq: u64) {
        if let Some(n) = self.next
            && seq > n
        {
            self.gaps += seq - n;
        }
        self.next = Some(seq.wrapping_add(1));
    }
}

struct Ports {
    imu: TopicSubscriber<ImuSample>,
    srs: TopicSubscriber<SrsSample>,
    cns: TopicSubscriber<CnsFix>,
    baro: TopicSubscriber<BaroSample>,
    init: TopicSubscriber<InitState>,
    solution: TopicPublisher<Solution>,
    status: TopicPublisher<Status>,
}

/// Runs the service until `stop` is set. Publishes a final status before returning.
pub fn run(
    config: &Config,
    transport_cfg: &TransportConfig,
    opts: &LiveOptions,
    stop: &AtomicBool,
) -> Result<LiveReport, LiveError> {
    let node = transport::node(transport_cfg, "nav_daemon")?;
    // Stale resources of dead nodes (e.g. a previous daemon killed with SIGKILL).
    let _ = Node::<ipc::Service>::list(node.config(), |state| {
        if let NodeState::Dead(view) = state {
            let _ = view.try_remove_stale_resources();
        }
        CallbackProgression::Continue
    });
    let ports = Ports {
        imu: TopicSubscriber::new(&node, transport_cfg, Topic::Imu)?,
        srs: TopicSubscriber::new(&node, transport_cfg, Topic::Srs)?,
        cns: TopicSubscriber::new(&node, transport_cfg, Topic::Cns)?,
        baro: TopicSubscriber::new(&node, transport_cfg, Topic::Baro)?,
        init: TopicSubscriber::new(&node, transport_cfg, Topic::Init)?,
        solution: TopicPublisher::new(&node, transport_cfg, Topic::Solution)?,
        status: TopicPublisher::new(&node, transport_cfg, Topic::Status)?,
    };
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?;
    let period = Duration::from_secs_f64(1.0 / opts.imu_rate_hz);
    let imu_guard = waitset
        .attach_notification(ports.imu.listener())
        .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?;
    let _tick = waitset
        .attach_interval(period)
        .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?;
    tracing::info!(prefix = %transport_cfg.prefix, imu_rate_hz = opts.imu_rate_hz, "nav-daemon live: services open, waiting for init and IMU");

    let mut state = LoopState::new(config, opts);
    if let Some(c) = &opts.checkpoint {
        match Checkpoint::load(&c.path) {
            Ok(Some(ck)) => {
                tracing::info!(path = %c.path.display(), t_ns = ck.t_ns, "checkpoint found: resuming if the IMU continues from it");
                state.pending_resume = Some(ck);
            }
            Ok(None) => {
                tracing::info!(path = %c.path.display(), "no checkpoint: cold start");
            }
            Err(e) => tracing::warn!("checkpoint unusable, cold start: {e}"),
        }
    }
    loop {
        let mut imu_event = false;
        let result = waitset.wait_and_process_once(|id| {
            imu_event |= id.has_event_from(&imu_guard);
            CallbackProgression::Continue
        });
        match result {
            Ok(WaitSetRunResult::Interrupt | WaitSetRunResult::TerminationRequest) => break,
            Ok(_) => {}
            Err(e) => return Err(LiveError::WaitSet(format!("{e:?}"))),
        }
        if imu_event {
            ports.imu.clear_events();
        }
        let t0 = Instant::now();
        let cpu0 = cpu_time::ThreadTime::try_now().ok();
        state.cycle(&ports)?;
        let cpu = cpu0.and_then(|c| c.try_elapsed().ok()).unwrap_or_default();
        let status_due = state.account(t0.elapsed(), cpu, period);
        if state.imu_lost {
            state.flush_waiting_aids();
        }
        if status_due {
            let st = state.status();
            ports.status.publish(&st)?;
            let line = status_line(
                &st,
                state
                    .nav
                    .as_ref()
                    .map(|n| n.state().geodetic().lat_rad.to_degrees()),
            );
            let _ = sd_notify::notify(&[sd_notify::NotifyState::Status(&line)]);
            state.reset_window();
        }
        if stop.load(Ordering::Relaxed) {
            break;
        }
    }
    state.flush_waiting_aids();
    ports.status.publish(&state.status())?;
    let _ = sd_notify::notify(&[sd_notify::NotifyState::Stopping]);
    tracing::info!(
        cycles = state.report.cycles,
        solutions = state.report.solutions,
        "nav-daemon live: stopped, final status published"
    );
    Ok(state.report.clone())
}

/// The one-line systemd STATUS=: frame, latitude, aid freshness.
pub fn status_line(s: &Status, lat_deg: Option<f64>) -> String {
    let frame = msgs::WireFrame::from_u8(s.frame).map_or('?', msgs::WireFrame::letter);
    let fresh = |a: &msgs::AidStatus| if a.fresh == 1 { "fresh" } else { "stale" };
    let imu = if s.flags & solution_flags::IMU_LOST != 0 {
        "LOST"
    } else {
        "ok"
    };
    let lat = lat_deg.map_or_else(|| "-".to_owned(), |l| format!("{l:.4}°"));
    format!(
        "frame {frame}, lat {lat}, switches {}, imu {imu}, srs {}, cns {}, baro {}, cycles {}, overruns {} (CPU {})",
        s.switch_count,
        fresh(&s.srs_aid),
        fresh(&s.cns_aid),
        fresh(&s.baro_aid),
        s.cycles,
        s.overruns,
        s.overruns_cpu
    )
}

/// At most one log line per second for a recurring event; counts the rest.
#[derive(Debug, Default)]
struct RateLimit {
    last: Option<Instant>,
    suppressed: u64,
}

impl RateLimit {
    /// `Some(suppressed since the last line)` when a line may be written now.
    fn due(&mut self) -> Option<u64> {
        if self
            .last
            .is_some_and(|t| t.elapsed() < Duration::from_secs(1))
        {
            self.suppressed += 1;
            return None;
        }
        self.last = Some(Instant::now());
        Some(std::mem::take(&mut self.suppressed))
    }
}

struct LoopState {
    nav_cfg: NavigatorConfig,
    init_cfg: Option<crate::config::InitSettings>,
    opts: LiveOptions,
    nav: Option<Navigator>,
    imu_buf: Vec<ImuSample>,
    aid_buf: Vec<Aid>,
    init_buf: Vec<InitState>,
    seq: [SeqTracker; 4],
    /// Per stream (IMU, SRS, CNS, baro): samples received by this loop but
    /// never handed to a navigator (no state yet, or stamped before a new init).
    not_used: [u64; 4],
    checkpoint: Option<CheckpointWriter>,
    /// A checkpoint to resume from when the IMU continues from it.
    pending_resume: Option<Checkpoint>,
    resumed: bool,
    imu_rejections: RateLimit,
    aid_rejections: RateLimit,
    /// Freshness of SRS, CNS, baro in the last status (for transition events).
    aid_fresh: [bool; 3],
    last_imu_wall: Option<Instant>,
    imu_lost: bool,
    last_status: Instant,
    ready_sent: bool,
    last_watchdog: Instant,
    cycle_time_sum: Duration,
    cycle_time_max: Duration,
    cycle_count_window: u64,
    status_seq: u64,
    report: LiveReport,
}

impl LoopState {
    fn new(config: &Config, opts: &LiveOptions) -> Self {
        Self {
            nav_cfg: config.navigator(),
            init_cfg: config.init.clone(),
            opts: opts.clone(),
            nav: None,
            imu_buf: Vec::with_capacity(CAPACITY),
            aid_buf: Vec::with_capacity(CAPACITY),
            init_buf: Vec::with_capacity(16),
            seq: [SeqTracker::default(); 4],
            not_used: [0; 4],
            checkpoint: opts.checkpoint.as_ref().map(CheckpointWriter::start),
            pending_resume: None,
            resumed: false,
            imu_rejections: RateLimit::default(),
            aid_rejections: RateLimit::default(),
            aid_fresh: [false; 3],
            last_imu_wall: None,
            imu_lost: false,
            last_status: Instant::now(),
            ready_sent: false,
            last_watchdog: Instant::now(),
            cycle_time_sum: Duration::ZERO,
            cycle_time_max: Duration::ZERO,
            cycle_count_window: 0,
            status_seq: 0,
            report: LiveReport::default(),
        }
    }

    /// One cycle: drain, order, navigate, publish.
    fn cycle(&mut self, ports: &Ports) -> Result<(), LiveError> {
        self.report.cycles += 1;
        let (imu_buf, aid_buf, init_buf, seq) = (
            &mut self.imu_buf,
            &mut self.aid_buf,
            &mut self.init_buf,
            &mut self.seq,
        );
        init_buf.clear();
        ports.init.drain(|x| init_buf.push(x))?;
        self.init_buf
            .retain(|i| match crate::navigator::check_init(i) {
                Ok(()) => true,
                Err(e) => {
                    tracing::error!(t_ns = i.t_ns, seq = i.seq, "init message rejected: {e}");
                    false
                }
            });
        ports.imu.drain(|x| {
            seq[0].see(x.seq);
            imu_buf.push(x);
        })?;
        ports.srs.drain(|x| {
            seq[1].see(x.seq);
            aid_buf.push(Aid::Srs(x));
        })?;
        ports.cns.drain(|x| {
            seq[2].see(x.seq);
            aid_buf.push(Aid::Cns(x));
        })?;
        ports.baro.drain(|x| {
            seq[3].see(x.seq);
            aid_buf.push(Aid::Baro(x));
        })?;
        ports.srs.clear_events();
        ports.cns.clear_events();
        ports.baro.clear_events();
        ports.init.clear_events();

        // An init no newer than the checkpoint (e.g. the init topic's history
        // delivered to a restarted daemon) describes an older state: resume instead.
        if let Some(c) = &self.pending_resume {
            let n = self.init_buf.len();
            self.init_buf.retain(|i| i.t_ns > c.t_ns);
            if self.init_buf.len() < n {
                tracing::info!(
                    "init message older than the checkpoint ignored: resuming from the checkpoint"
                );
            }
        }
        if let Some(init) = self.init_buf.iter().max_by_key(|i| i.t_ns).copied() {
            if self.nav.is_some() {
                self.report.reinits += 1;
                tracing::info!(
                    t_ns = init.t_ns,
                    reinit = self.report.reinits,
                    "new init message: re-initializing"
                );
            } else {
                tracing::info!(t_ns = init.t_ns, "init message received");
            }
            match self.nav.as_mut() {
                Some(nav) => nav.reinitialize(&init, &self.nav_cfg),
                None => self.nav = Some(Navigator::new(&init, &self.nav_cfg)),
            }
            if self.pending_resume.take().is_some() {
                tracing::info!("init message received: the checkpoint is not used (cold start)");
            }
            // Inputs from before the new init belong to the previous pass.
            let n = self.imu_buf.len();
            self.imu_buf.retain(|s| s.t_ns > init.t_ns);
            self.not_used[0] += (n - self.imu_buf.len()) as u64;
            self.drop_aids(|a| a.t_ns() <= init.t_ns);
        }
        self.imu_buf.sort_unstable_by_key(|s| s.t_ns);
        self.aid_buf.sort_unstable_by_key(Aid::t_ns);

        if !self.imu_buf.is_empty() {
            self.last_imu_wall = Some(Instant::now());
            if self.imu_lost {
                tracing::info!("IMU back");
            }
            self.imu_lost = false;
        }
        if self.nav.is_none()
            && let Some(first) = self.imu_buf.first()
            && let Some(c) = self.pending_resume.take()
        {
            let max_age = self.opts.checkpoint.as_ref().map_or(0, |o| o.max_age_ns);
            if first.t_ns > c.t_ns && first.t_ns - c.t_ns <= max_age {
                tracing::info!(
                    checkpoint_t_ns = c.t_ns,
                    gap_s = (first.t_ns - c.t_ns) as f64 * 1e-9,
                    "resumed from checkpoint (no re-alignment); the gap to the first IMU sample is coasted"
                );
                self.nav = Some(Navigator::from_checkpoint(&c, &self.nav_cfg));
                self.resumed = true;
            } else {
                tracing::warn!(
                    checkpoint_t_ns = c.t_ns,
                    first_imu_t_ns = first.t_ns,
                    max_age_s = max_age as f64 * 1e-9,
                    "checkpoint not used: the IMU does not continue from it; cold start"
                );
            }
        }
        if self.nav.is_none()
            && let (Some(ci), Some(first)) = (&self.init_cfg, self.imu_buf.first())
        {
            let t0 = first.t_ns.saturating_sub((first.dt_s * 1e9).round() as u64);
            tracing::info!(
                t_ns = t0,
                "no init message: initializing from the configuration"
            );
            self.nav = Some(Navigator::new(&ci.to_init(t0), &self.nav_cfg));
        }
        let Some(nav) = self.nav.as_mut() else {
            self.not_used[0] += self.imu_buf.len() as u64;
            self.imu_buf.clear();
            self.drop_aids(|_| true);
            return Ok(());
        };

        let mut next_aid = 0;
        for k in 0..self.imu_buf.len() {
            let s = self.imu_buf[k];
            match nav.on_imu(&s) {
                Ok(out) => {
                    if let Some(sw) = out.switch {
                        tracing::info!(t_s = sw.t_ns as f64 * 1e-9, from = ?sw.from, to = ?sw.to, lat_deg = sw.lat_rad.to_degrees(), count = sw.count, "frame switch");
                    }
                }
                Err(e) => {
                    if let Some(suppressed) = self.imu_rejections.due() {
                        tracing::warn!(
                            t_ns = s.t_ns,
                            seq = s.seq,
                            suppressed,
                            "IMU sample rejected: {e}"
                        );
                    }
                    continue;
                }
            }
            // Aids up to this IMU time, in time order.
            while next_aid < self.aid_buf.len() && self.aid_buf[next_aid].t_ns() <= nav.t_ns() {
                if let Err(e) = self.aid_buf[next_aid].offer(nav)
                    && let Some(suppressed) = self.aid_rejections.due()
                {
                    tracing::warn!(
                        t_ns = self.aid_buf[next_aid].t_ns(),
                        suppressed,
                        "aid sample rejected: {e}"
                    );
                }
                next_aid += 1;
            }
            let mut sol = nav.solution();
            if self.imu_lost {
                sol.flags |= solution_flags::IMU_LOST;
            }
            ports.solution.publish(&sol)?;
            self.report.solutions += 1;
            if !self.ready_sent {
                let _ = sd_notify::notify(&[sd_notify::NotifyState::Ready]);
                self.ready_sent = true;
                tracing::info!(t_ns = sol.t_ns, "first valid solution published: ready");
            }
        }
        self.imu_buf.clear();
        // Aids ahead of the newest IMU sample wait for it.
        self.aid_buf.drain(..next_aid);
        if let (Some(w), Some(nav)) = (self.checkpoint.as_mut(), self.nav.as_ref()) {
            w.offer(nav);
        }
        Ok(())
    }

    /// Aids waiting for an IMU sample at or after their time, when none will
    /// come (IMU lost, or stopping): offered to the navigator, which rejects
    /// them as ahead of the IMU and counts them, so every received sample is
    /// accounted for.
    fn flush_waiting_aids(&mut self) {
        if self.aid_buf.is_empty() {
            return;
        }
        let Some(nav) = self.nav.as_mut() else {
            self.drop_aids(|_| true);
            return;
        };
        for a in self.aid_buf.drain(..) {
            let _ = a.offer(nav);
        }
    }

    /// Removes the buffered aids matching `pred`, counting them as not used.
    fn drop_aids(&mut self, pred: impl Fn(&Aid) -> bool) {
        let not_used = &mut self.not_used;
        self.aid_buf.retain(|a| {
            if !pred(a) {
                return true;
            }
            let k = match a {
                Aid::Srs(_) => 1,
                Aid::Cns(_) => 2,
                Aid::Baro(_) => 3,
            };
            not_used[k] += 1;
            false
        });
    }

    /// Timing, IMU-lost detection and watchdog; true when a status is due.
    fn account(&mut self, elapsed: Duration, cpu: Duration, period: Duration) -> bool {
        self.cycle_time_sum += elapsed;
        self.cycle_time_max = self.cycle_time_max.max(elapsed);
        self.cycle_count_window += 1;
        if elapsed > period {
            self.report.overruns += 1;
            if cpu > period {
                self.report.overruns_cpu += 1;
            }
        }
        if let Some(t) = self.last_imu_wall
            && !self.imu_lost
            && t.elapsed() > period * self.opts.imu_lost_periods
        {
            self.imu_lost = true;
            tracing::warn!(
                "IMU lost: no sample for {} nominal periods",
                self.opts.imu_lost_periods
            );
        }
        if self.last_watchdog.elapsed() >= Duration::from_millis(100) {
            let _ = sd_notify::notify(&[sd_notify::NotifyState::Watchdog]);
            self.last_watchdog = Instant::now();
        }
        self.last_status.elapsed() >= self.opts.status_period
    }

    fn reset_window(&mut self) {
        self.last_status = Instant::now();
        self.cycle_time_sum = Duration::ZERO;
        self.cycle_time_max = Duration::ZERO;
        self.cycle_count_window = 0;
    }

    fn status(&mut self) -> Status {
        let mut s = self.nav.as_ref().map(Navigator::status).unwrap_or_default();
        self.status_seq += 1;
        s.seq = self.status_seq;
        let gaps = |c: &mut StreamCounters, t: &SeqTracker| c.seq_gaps = t.gaps;
        gaps(&mut s.imu, &self.seq[0]);
        gaps(&mut s.srs, &self.seq[1]);
        gaps(&mut s.cns, &self.seq[2]);
        gaps(&mut s.baro, &self.seq[3]);
        // Samples that never reached a navigator were received and not used.
        for (c, n) in [&mut s.imu, &mut s.srs, &mut s.cns, &mut s.baro]
            .into_iter()
            .zip(self.not_used)
        {
            c.received += n;
            c.not_used += n;
        }
        s.checkpoints_written = self
            .checkpoint
            .as_ref()
            .map_or(0, CheckpointWriter::written);
        s.resumed = u8::from(self.resumed);
        s.cycles = self.report.cycles;
        s.overruns = self.report.overruns;
        s.overruns_cpu = self.report.overruns_cpu;
        let n = self.cycle_count_window.max(1) as u32;
        s.cycle_time_mean_ns = (self.cycle_time_sum / n).as_nanos() as u64;
        s.cycle_time_max_ns = self.cycle_time_max.as_nanos() as u64;
        s.reinit_count = self.report.reinits;
        if self.imu_lost {
            // Aid freshness is judged in sensor time, which stops with the IMU:
            // without it no aid can be called fresh.
            s.flags |= solution_flags::IMU_LOST;
            s.flags &= !(solution_flags::SRS_FRESH
                | solution_flags::CNS_FRESH
                | solution_flags::BARO_FRESH);
            for a in [&mut s.srs_aid, &mut s.cns_aid, &mut s.baro_aid] {
                a.fresh = 0;
            }
        }
        if self.nav.is_none() {
            s.flags &= !solution_flags::ALIGNED;
        }
        // Aid timeouts and recoveries, once per transition.
        for (k, (name, a)) in [
            ("SRS", &s.srs_aid),
            ("CNS", &s.cns_aid),
            ("baro", &s.baro_aid),
        ]
        .into_iter()
        .enumerate()
        {
            let fresh = a.fresh == 1;
            if fresh != self.aid_fresh[k] {
                if fresh {
                    tracing::info!(aid = name, "aid fresh: fusing");
                } else if self.nav.is_some() {
                    tracing::warn!(
                        aid = name,
                        last_fuse_t_ns = a.last_fuse_t_ns,
                        "aid stale: timed out"
                    );
                }
                self.aid_fresh[k] = fresh;
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_limit_allows_one_line_per_second_and_counts_the_rest() {
        let mut r = RateLimit::default();
        assert_eq!(r.due(), Some(0));
        assert_eq!(r.due(), None);
        assert_eq!(r.due(), None);
        // A second later the next line reports the two suppressed.
        r.last = Some(Instant::now() - Duration::from_millis(1001));
        assert_eq!(r.due(), Some(2));
        assert_eq!(r.due(), None);
    }

    #[test]
    fn seq_tracker_counts_lost_samples() {
        let mut t = SeqTracker::default();
        for s in [0, 1, 2, 5, 6, 10] {
            t.see(s);
        }
        assert_eq!(t.gaps, 2 + 3);
    }
}
