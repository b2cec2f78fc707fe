//! The live service: drain → session → publish, at a fixed rate locked to
//! the IMU over iceoryx2.
//!
//! A WaitSet wakes on the IMU topic's event and on an interval tick at the
//! nominal IMU period (which detects a missing IMU and keeps status flowing).
//! Each cycle drains every subscriber into the preallocated
//! [`polarnav::inbox::Inbox`], which hands the inputs to the same
//! [`Session`] as `batch` in navlog order (an input stamped ahead of every
//! IMU sample waits for the sample after it); the session publishes one
//! solution per accepted IMU sample as it integrates it; status goes out
//! at 1 Hz. Every decision between an
//! input and a solution is the session's. systemd: READY=1 as soon as the
//! services are open and the settings loaded (the daemon can take inputs;
//! STATUS= says which it waits for), WATCHDOG=1 from this loop only (idle
//! or navigating), STATUS= with the one-line health once a second.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::SyncSender;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use msgs::service::Topic;
use msgs::{
    AidKind, AidSample, EffectiveSettings, ImuSample, InitState, PerAid, Solution, Status, Stream,
    solution_flags,
};
use polarnav::checkpoint::{self, Checkpoint};
use polarnav::inbox::{Inbox, Received};
use polarnav::session::{Event, PerStream, Session, Sink};
use polarnav_config::Effective;
use polarnav_ipc::{
    AidSubscriber, TopicPublisher, TopicSubscriber, TransportConfig, TransportError,
};

use crate::events::RateLimit;
use crate::imu_rate::RateCheck;
use crate::owner::Owner;
use crate::services::Service;

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
    pub fn from_config(c: &polarnav_config::LiveSettings) -> Option<Self> {
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

    fn offer(&mut self, session: &Session) {
        let Some(c) = session.checkpoint() else {
            return;
        };
        if c.t_ns >= self.last_t_ns && c.t_ns < self.last_t_ns.saturating_add(self.period_ns) {
            return;
        }
        if let Some(tx) = &self.tx
            && tx.try_send(c).is_ok()
        {
            self.last_t_ns = c.t_ns;
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
    #[error(
        "another nav-daemon already serves prefix {prefix:?}: node {name:?}, pid {pid} ({executable}); stop it or choose another prefix"
    )]
    AlreadyRunning {
        prefix: String,
        name: String,
        pid: i32,
        executable: String,
    },
}

impl LiveError {
    /// Exit status: 2 for a start refused by configuration or another
    /// daemon, 1 for a failure while running.
    pub fn exit_code(&self) -> u8 {
        match self {
            LiveError::AlreadyRunning { .. } => 2,
            _ => 1,
        }
    }
}

/// The node role of the daemon (`nav-daemon:<prefix>` in `iox2 node list`).
pub const NODE_ROLE: &str = "nav-daemon";

/// Refuses to serve a prefix another live daemon serves. `me`: this
/// process, once its own node exists (two daemons started at once both see
/// each other then; the one with the higher pid gives way).
fn refuse_if_served(cfg: &TransportConfig, me: Option<i32>) -> Result<(), LiveError> {
    let others = polarnav_ipc::running(cfg, NODE_ROLE)?;
    if let Some(o) = others
        .into_iter()
        .find(|o| me.is_none_or(|me| o.pid != me && o.pid < me))
    {
        return Err(LiveError::AlreadyRunning {
            prefix: cfg.prefix.clone(),
            name: o.name,
            pid: o.pid,
            executable: o.executable,
        });
    }
    Ok(())
}

/// How often the settings publisher connects new subscribers (and hands
/// them its history): well inside the recorder's `SETTINGS_WAIT` of 100 ms.
const SETTINGS_UPDATE_PERIOD: Duration = Duration::from_millis(25);

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

/// Preallocated capacity of the per-cycle input buffer (a cycle normally
/// sees one IMU sample; 45 ms stalls at 1 kHz leave ~45). It exceeds the sum
/// of the subscriber buffers, which bound what one cycle drains (a drain
/// takes at most one buffer's worth), so the buffer never grows and nothing
/// drained is dropped (test `capacity_holds_one_drain_of_every_input`).
const CAPACITY: usize = 1024;

/// The daemon's ports, each service on its own ([`Service`]: one that
/// cannot be opened leaves the others served and is retried).
struct Ports {
    cfg: TransportConfig,
    imu: Service<TopicSubscriber<ImuSample>>,
    /// One subscriber per aid.
    aids: PerAid<Service<Box<dyn AidSubscriber>>>,
    init: Service<TopicSubscriber<InitState>>,
    solution: Service<TopicPublisher<Solution>>,
    status: Service<TopicPublisher<Status>>,
    settings: Service<TopicPublisher<EffectiveSettings>>,
}

/// The port `make` opens on `topic`'s service (bit `bit` of
/// [`Status::unavailable`]), retried while it cannot be opened.
fn port<P: 'static>(
    node: &Node<ipc::Service>,
    cfg: &TransportConfig,
    topic: Topic,
    bit: u32,
    make: fn(&Node<ipc::Service>, &TransportConfig, Topic) -> Result<P, TransportError>,
) -> Service<P> {
    let name = topic.service_name(&cfg.prefix);
    Service::open(
        node,
        cfg,
        name,
        bit,
        Box::new(move |n, c| make(n, c, topic)),
    )
}

fn aid_subscriber(
    node: &Node<ipc::Service>,
    cfg: &TransportConfig,
    k: AidKind,
) -> Service<Box<dyn AidSubscriber>> {
    let topic = Topic::Aid(k);
    Service::open(
        node,
        cfg,
        topic.service_name(&cfg.prefix),
        msgs::unavailable::stream(Stream::Aid(k)),
        Box::new(move |n, c| {
            let s: Box<dyn AidSubscriber> = msgs::match_aid_kind!(k, P => {
                Box::new(TopicSubscriber::<P>::new(n, c, topic)?)
            });
            Ok(s)
        }),
    )
}

impl Ports {
    fn open(node: &Node<ipc::Service>, cfg: &TransportConfig) -> Self {
        use msgs::unavailable as u;
        // The init subscriber first: a publisher hands it the init topic's
        // history (the init sent before this daemon started) at its next send.
        let init = port(
            node,
            cfg,
            Topic::Init,
            u::INIT_SERVICE,
            TopicSubscriber::new,
        );
        Self {
            cfg: cfg.clone(),
            init,
            imu: port(
                node,
                cfg,
                Topic::Imu,
                u::stream(Stream::Imu),
                TopicSubscriber::new,
            ),
            aids: PerAid(AidKind::ALL.map(|k| aid_subscriber(node, cfg, k))),
            solution: port(
                node,
                cfg,
                Topic::Solution,
                u::SOLUTION_SERVICE,
                TopicPublisher::new,
            ),
            status: port(
                node,
                cfg,
                Topic::Status,
                u::STATUS_SERVICE,
                TopicPublisher::new,
            ),
            settings: port(
                node,
                cfg,
                Topic::Settings,
                u::SETTINGS_SERVICE,
                TopicPublisher::new,
            ),
        }
    }

    /// Retries the services that could not be opened (at most once per
    /// [`crate::services::RETRY_PERIOD`] each); true when the settings
    /// service opened now (its publisher has the settings to send).
    fn retry(&self, node: &Node<ipc::Service>) -> bool {
        let now = Instant::now();
        let cfg = &self.cfg;
        self.init.retry(node, cfg, now);
        self.imu.retry(node, cfg, now);
        for (_, a) in self.aids.iter() {
            a.retry(node, cfg, now);
        }
        self.solution.retry(node, cfg, now);
        self.status.retry(node, cfg, now);
        self.settings.retry(node, cfg, now)
    }

    /// [`Status::unavailable`] now.
    fn unavailable(&self) -> u32 {
        let mut bits = self.init.unavailable()
            | self.imu.unavailable()
            | self.solution.unavailable()
            | self.status.unavailable()
            | self.settings.unavailable();
        for (_, a) in self.aids.iter() {
            bits |= a.unavailable();
        }
        bits
    }

    /// Publishes a status (its `unavailable` from the services now), if
    /// the status service is open.
    fn publish_status(&self, mut st: Status) -> Result<(), TransportError> {
        st.unavailable = self.unavailable();
        match self.status.get() {
            Some(p) => p.publish(&st).map(|_| ()),
            None => Ok(()),
        }
    }

    /// Publishes the effective settings (history 1, for flight recorders),
    /// if the settings service is open.
    fn publish_settings(&self, settings: &Effective) -> Result<(), TransportError> {
        let Some(p) = self.settings.get() else {
            return Ok(());
        };
        match EffectiveSettings::new(0, &settings.header_toml()) {
            Some(m) => {
                p.publish(&m)?;
            }
            None => tracing::warn!(
                "effective settings longer than {} bytes: not published",
                msgs::SETTINGS_TEXT_MAX
            ),
        }
        Ok(())
    }

    /// Drains `sub` into `take`, keeping only the samples of its owner.
    fn drain_owned<T: std::fmt::Debug + ZeroCopySend + Copy + 'static>(
        &self,
        sub: &Service<TopicSubscriber<T>>,
        owner: &mut Owner,
        stream: &str,
        mut take: impl FnMut(T),
    ) -> Result<(), TransportError> {
        let Some(sub) = sub.get() else {
            return Ok(());
        };
        sub.drain_with_origin(|p, x| {
            if owner.admit(stream, p, |o| self.connected(|id| sub.has_publisher(id), o)) {
                take(x);
            }
        })?;
        Ok(())
    }

    /// Drains aid `k`'s subscriber into `take`, keeping only the samples
    /// of its owner.
    fn drain_aid(
        &self,
        k: AidKind,
        owner: &mut Owner,
        take: &mut dyn FnMut(AidSample),
    ) -> Result<(), TransportError> {
        let Some(sub) = self.aids[k].get() else {
            return Ok(());
        };
        sub.drain_samples(&mut |p, x| {
            if owner.admit(k.decl().label, p, |o| {
                self.connected(|id| sub.has_publisher(id), o)
            }) {
                take(x);
            }
        })?;
        Ok(())
    }

    /// Whether publisher `id` still serves a service (`has_publisher`):
    /// dead processes' publishers are removed first (a driver killed with
    /// SIGKILL and restarted takes over its service).
    fn connected(&self, has_publisher: impl FnOnce(u128) -> bool, id: u128) -> bool {
        if let Err(e) = polarnav_ipc::remove_dead_nodes(&self.cfg) {
            tracing::warn!("dead nodes not removed: {e}");
        }
        has_publisher(id)
    }
}

/// Runs the service until `stop` is set. Publishes a final status before returning.
pub fn run(
    settings: &Effective,
    transport_cfg: &TransportConfig,
    opts: &LiveOptions,
    stop: &AtomicBool,
) -> Result<LiveReport, LiveError> {
    // One daemon per prefix (this also removes what dead nodes left, e.g.
    // a previous daemon killed with SIGKILL).
    refuse_if_served(transport_cfg, None)?;
    let node = polarnav_ipc::node(transport_cfg, NODE_ROLE)?;
    refuse_if_served(transport_cfg, Some(std::process::id() as i32))?;
    // Every service it can open; one it cannot is said once, reported
    // in every status and retried from the loop.
    let ports = Ports::open(&node, transport_cfg);
    // The effective settings, for flight recorders (history 1).
    ports.publish_settings(settings)?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?;
    let period = Duration::from_secs_f64(1.0 / opts.imu_rate_hz);
    // The IMU's event wakes the loop once its service is open (attached
    // in the loop; the interval tick runs it meanwhile).
    let mut imu_guard = None;
    let _tick = waitset
        .attach_interval(period)
        .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?;
    tracing::info!(prefix = %transport_cfg.prefix, imu_rate_hz = opts.imu_rate_hz, "nav-daemon live: services open, waiting for init and IMU");

    let mut state = LoopState::new(settings, opts);
    let mut notify = crate::notify::Notifier::from_env();
    if let Some(c) = &opts.checkpoint {
        match Checkpoint::load(&c.path) {
            Ok(Some(ck)) => {
                tracing::info!(path = %c.path.display(), t_s = crate::events::secs(ck.t_ns), "checkpoint found: resuming if the IMU continues from it");
                if let Err(e) = state.session.offer_checkpoint(ck) {
                    tracing::warn!("checkpoint unusable, cold start: {e}");
                }
            }
            Ok(None) => {
                tracing::info!(path = %c.path.display(), "no checkpoint: cold start");
            }
            Err(e) => tracing::warn!("checkpoint unusable, cold start: {e}"),
        }
    }
    // Inputs can be taken from here on: systemd may start the producers
    // ordered after this unit (replay, recorder) now, not at the first
    // solution, which needs their data.
    notify.ready(&waiting_line(&state.session, &transport_cfg.prefix));
    tracing::info!(
        watchdog_interval_ms = notify.watchdog_interval().as_millis() as u64,
        notify = notify.active(),
        "ready: {}",
        waiting_line(&state.session, &transport_cfg.prefix)
    );
    loop {
        if ports.retry(&node) {
            ports.publish_settings(settings)?;
        }
        if imu_guard.is_none()
            && let Some(imu) = ports.imu.get()
        {
            imu_guard = Some(
                waitset
                    .attach_notification(imu.listener())
                    .map_err(|e| LiveError::WaitSet(format!("{e:?}")))?,
            );
        }
        let mut imu_event = false;
        let result = waitset.wait_and_process_once(|id| {
            imu_event |= imu_guard.as_ref().is_some_and(|g| id.has_event_from(g));
            CallbackProgression::Continue
        });
        match result {
            // An interrupted wait is not a stop request: epoll returns EINTR
            // after SIGSTOP/SIGCONT (a debugger, a frozen cgroup) and any
            // signal with a handler; SIGINT/SIGTERM set `stop` (checked below).
            Ok(WaitSetRunResult::TerminationRequest) => break,
            Ok(_) => {}
            Err(e) => return Err(LiveError::WaitSet(format!("{e:?}"))),
        }
        if imu_event && let Some(imu) = ports.imu.get() {
            imu.clear_events();
        }
        let t0 = Instant::now();
        let cpu0 = cpu_time::ThreadTime::try_now().ok();
        state.cycle(&ports)?;
        let cpu = cpu0.and_then(|c| c.try_elapsed().ok()).unwrap_or_default();
        let status_due = state.account(t0.elapsed(), cpu, period);
        notify.watchdog();
        if status_due {
            let st = state.status();
            ports.publish_status(st)?;
            let mut line = match state.session.navigator() {
                Some(n) => status_line(&st, Some(n.state().geodetic().lat_rad.to_degrees())),
                None => waiting_line(&state.session, &transport_cfg.prefix),
            };
            let unavailable = ports.unavailable();
            if unavailable != 0 {
                line.push_str("; UNAVAILABLE: ");
                line.push_str(&msgs::unavailable::describe(unavailable));
            }
            notify.status(&line);
            state.reset_window();
        }
        // A recorder that subscribed since gets the settings (history 1)
        // within this period, before it has to start its file.
        if state.last_settings_update.elapsed() >= SETTINGS_UPDATE_PERIOD {
            if let Some(p) = ports.settings.get() {
                p.update_connections()?;
            }
            state.last_settings_update = Instant::now();
        }
        if stop.load(Ordering::Relaxed) {
            break;
        }
    }
    {
        // Nothing received is lost: what waited for the IMU goes first.
        let mut sink = PublishSink::new(ports.solution.get(), &mut state.out);
        state.inbox.deliver_all(&mut state.session, &mut sink);
        state.session.finish(&mut sink);
        state.report.solutions += sink.done()?;
    }
    ports.publish_status(state.status())?;
    notify.stopping(&format!(
        "stopping after {} solutions",
        state.report.solutions
    ));
    tracing::info!(
        cycles = state.report.cycles,
        solutions = state.report.solutions,
        "nav-daemon live: stopped, final status published"
    );
    Ok(state.report.clone())
}

/// STATUS= before navigation starts: what the daemon waits for.
pub fn waiting_line(session: &Session, prefix: &str) -> String {
    let imu = Topic::Imu.service_name(prefix);
    let init = Topic::Init.service_name(prefix);
    if let Some(done) = session.alignment_progress_s() {
        return format!("aligning: {done:.1} s of IMU data so far");
    }
    let imu_seen = session.status().imu().received > 0;
    match (session.has_config_init(), imu_seen) {
        (true, false) => {
            format!(
                "waiting for IMU on {imu} (init from the configuration at the first sample, or {init})"
            )
        }
        (false, false) => format!("waiting for init on {init} and IMU on {imu}"),
        (false, true) => {
            format!("waiting for init on {init} (IMU arriving on {imu} is not used until then)")
        }
        (true, true) => format!("waiting for a usable IMU sample on {imu}"),
    }
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
    let aids: String = s
        .each_aid()
        .map(|(k, _, a)| format!("{} {}, ", k.name(), fresh(a)))
        .collect();
    format!(
        "frame {frame}, lat {lat}, switches {}, imu {imu}, {aids}cycles {}, overruns {} (CPU {})",
        s.switch_count, s.cycles, s.overruns, s.overruns_cpu
    )
}

/// Publishes the session's solutions and logs its decisions (rejections at
/// most once a second per stream).
struct PublishSink<'a> {
    /// `None` while the solution service cannot be opened: the session
    /// runs on, its solutions go nowhere (the status says so).
    solution: Option<&'a TopicPublisher<Solution>>,
    error: Option<TransportError>,
    published: u64,
    out: &'a mut OutputState,
}

/// What the publishing sink keeps from cycle to cycle.
#[derive(Debug, Default)]
struct OutputState {
    first_sent: bool,
    /// A second publisher was refused in the last status period: flagged
    /// in every solution until a period passes without one.
    second_publisher: bool,
    rejections: PerStream<RateLimit>,
    gaps: RateLimit,
}

impl<'a> PublishSink<'a> {
    fn new(solution: Option<&'a TopicPublisher<Solution>>, out: &'a mut OutputState) -> Self {
        Self {
            solution,
            error: None,
            published: 0,
            out,
        }
    }

    fn done(self) -> Result<u64, LiveError> {
        match self.error {
            Some(e) => Err(e.into()),
            None => Ok(self.published),
        }
    }
}

impl Sink for PublishSink<'_> {
    fn solution(&mut self, s: &Solution) {
        if self.error.is_some() {
            return;
        }
        let flagged;
        let s = if self.out.second_publisher {
            flagged = Solution {
                flags: s.flags | solution_flags::SECOND_PUBLISHER,
                ..*s
            };
            &flagged
        } else {
            s
        };
        let Some(solution) = self.solution else {
            return;
        };
        if let Err(e) = solution.publish(s) {
            self.error = Some(e);
            return;
        }
        self.published += 1;
        if !self.out.first_sent {
            self.out.first_sent = true;
            tracing::info!(
                t_s = crate::events::secs(s.t_ns),
                "first solution published"
            );
        }
    }

    fn event(&mut self, e: &Event) {
        if let Event::Rejected {
            stream,
            t_ns,
            seq,
            reason,
        } = e
        {
            if let Some(suppressed) = self.out.rejections.get_mut(*stream).due() {
                tracing::warn!(
                    t_s = crate::events::secs(*t_ns),
                    seq,
                    suppressed,
                    "{} sample rejected: {reason}",
                    stream.name()
                );
            }
            return;
        }
        crate::events::log_event("live", e);
    }
}

struct LoopState {
    session: Session,
    opts: LiveOptions,
    inbox: Inbox,
    checkpoint: Option<CheckpointWriter>,
    out: OutputState,
    /// Owner of the init service.
    init_owner: Owner,
    /// Owners of the IMU and each aid's service.
    owners: PerStream<Owner>,
    /// Freshness of each aid in the last status (for transition events).
    aid_fresh: PerAid<bool>,
    last_imu_wall: Option<Instant>,
    /// The stream's rate against `[live] imu_rate_hz`, said once.
    imu_rate: RateCheck,
    imu_lost: bool,
    last_status: Instant,
    last_settings_update: Instant,
    cycle_time_sum: Duration,
    cycle_time_max: Duration,
    cycle_count_window: u64,
    status_seq: u64,
    report: LiveReport,
}

impl LoopState {
    fn new(settings: &Effective, opts: &LiveOptions) -> Self {
        Self {
            session: Session::new(settings.session()),
            opts: opts.clone(),
            inbox: Inbox::with_capacity(CAPACITY),
            checkpoint: opts.checkpoint.as_ref().map(CheckpointWriter::start),
            out: OutputState::default(),
            init_owner: Owner::default(),
            owners: PerStream::default(),
            aid_fresh: PerAid::default(),
            last_imu_wall: None,
            imu_rate: RateCheck::new(opts.imu_rate_hz),
            imu_lost: false,
            last_status: Instant::now(),
            last_settings_update: Instant::now(),
            cycle_time_sum: Duration::ZERO,
            cycle_time_max: Duration::ZERO,
            cycle_count_window: 0,
            status_seq: 0,
            report: LiveReport::default(),
        }
    }

    /// One cycle: drain, then hand to the session in navlog order (it
    /// publishes the solutions).
    fn cycle(&mut self, ports: &Ports) -> Result<(), LiveError> {
        self.report.cycles += 1;
        let mut imu_seen = false;
        let (inbox, session, gaps) = (&mut self.inbox, &mut self.session, &mut self.out.gaps);
        let imu_rate = &mut self.imu_rate;
        // Sequence gaps are noted in arrival order.
        let mut receive = |r: Received| {
            if let Some(e) = inbox.receive(session, r)
                && let Some(suppressed) = gaps.due()
            {
                tracing::warn!(suppressed, "{e:?}");
            }
        };
        ports.drain_owned(&ports.init, &mut self.init_owner, "init", |x| {
            receive(Received::Init(x));
        })?;
        ports.drain_owned(&ports.imu, &mut self.owners[Stream::Imu], "IMU", |x| {
            imu_seen = true;
            if let Some(d) = imu_rate.observe(x.t_ns) {
                tracing::warn!("{d}");
            }
            receive(Received::Imu(x));
        })?;
        for k in AidKind::ALL {
            let owner = &mut self.owners[Stream::Aid(k)];
            ports.drain_aid(k, owner, &mut |x| receive(Received::Aid(x)))?;
        }
        for (_, sub) in ports.aids.iter() {
            if let Some(sub) = sub.get() {
                sub.clear_events();
            }
        }
        if let Some(init) = ports.init.get() {
            init.clear_events();
        }
        if imu_seen {
            self.last_imu_wall = Some(Instant::now());
            if self.imu_lost {
                tracing::info!("IMU back");
            }
            self.imu_lost = false;
        }
        // No flush at the end of the cycle: the session emits each solution
        // as its sample is integrated and fuses aids before the next sample,
        // so where a cycle ends changes nothing.
        let mut sink = PublishSink::new(ports.solution.get(), &mut self.out);
        self.inbox.deliver(&mut self.session, &mut sink);
        self.report.solutions += sink.done()?;
        if let Some(w) = self.checkpoint.as_mut() {
            w.offer(&self.session);
        }
        Ok(())
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
                waiting = self.inbox.waiting(),
                "IMU lost: no sample for {} nominal periods; inputs stamped after it keep waiting for it",
                self.opts.imu_lost_periods
            );
            // Reported only: the inputs that wait for the IMU keep waiting
            // (decisions come from the stamps, never from the wall clock).
            self.session.imu_lost(&mut polarnav::session::Discard);
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
        let mut s = self.session.status();
        self.status_seq += 1;
        s.seq = self.status_seq;
        s.checkpoints_written = self
            .checkpoint
            .as_ref()
            .map_or(0, CheckpointWriter::written);
        s.cycles = self.report.cycles;
        let mut second = false;
        for (k, o) in self.owners.iter_mut() {
            s.counters_mut(k).refused_publisher = o.refused;
            second |= o.refused > o.refused_at_status;
            o.refused_at_status = o.refused;
        }
        let init = &mut self.init_owner;
        second |= init.refused > init.refused_at_status;
        init.refused_at_status = init.refused;
        if second {
            s.flags |= solution_flags::SECOND_PUBLISHER;
        }
        self.out.second_publisher = second;
        s.overruns = self.report.overruns;
        s.overruns_cpu = self.report.overruns_cpu;
        let n = self.cycle_count_window.max(1) as u32;
        s.cycle_time_mean_ns = (self.cycle_time_sum / n).as_nanos() as u64;
        s.cycle_time_max_ns = self.cycle_time_max.as_nanos() as u64;
        self.report.reinits = s.reinit_count;
        // Aid timeouts and recoveries, once per transition.
        for (k, _, a) in s.each_aid() {
            let name = k.decl().label;
            let fresh = a.fresh == 1;
            if fresh != self.aid_fresh[k] {
                if fresh {
                    tracing::info!(aid = name, "aid fresh: fusing");
                } else if self.session.navigator().is_some() {
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
    use super::CAPACITY;
    use msgs::service::Topic;
    use polarnav_ipc::qos;

    #[test]
    fn capacity_holds_one_drain_of_every_input() {
        let inputs = qos(Topic::Imu).buffer
            + qos(Topic::Init).buffer
            + msgs::AidKind::ALL
                .iter()
                .map(|k| qos(Topic::Aid(*k)).buffer)
                .sum::<usize>();
        assert!(
            inputs <= CAPACITY,
            "{inputs} inputs per cycle, capacity {CAPACITY}"
        );
    }
}
