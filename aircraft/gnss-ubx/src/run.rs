//! The live loop: read the device (or file), feed the [`Driver`], publish
//! on `<prefix>/gnss` and `<prefix>/baseline`, reopen a lost device, report.
//!
//! Reads wait at most [`READ_TIMEOUT`], so a stop request, the watchdog,
//! the reports and the silence check are served within that however the
//! device behaves; nothing in the loop waits on a subscriber (in flight
//! the publisher discards and counts; from a file it waits at most 2 s,
//! as a replay does, and waits for a first subscriber before its first fix:
//! [`Source::File`]).

use std::io::Read;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use msgs::service::Topic;
use msgs::{BaselineSample, GnssFix};
use polarnav_ipc::{Delivery, TopicPublisher, TransportConfig, TransportError};
use serialport::SerialPort;

use crate::driver::{Counters, Driver};
use crate::settings::Settings;

/// Longest a read waits for bytes.
pub const READ_TIMEOUT: Duration = Duration::from_millis(100);
/// NAV-PVT periods without one before the receiver is reported silent.
pub const SILENT_PERIODS: f64 = 5.0;
/// How long a publisher waits for a full subscriber when reading a file.
pub const FILE_MAX_WAIT: Duration = Duration::from_secs(2);
/// How long `--file` lets its subscribers connect before its first fix,
/// once one exists: an input subscriber receives at least once per
/// [`polarnav_ipc::INPUT_BUFFER_S`] (what the input buffers are sized on),
/// and one that existed before the driver connects only at a receive.
pub const FILE_SETTLE: Duration = Duration::from_millis(500);
/// How often `--file` looks for a first subscriber.
const SUBSCRIBER_POLL: Duration = Duration::from_millis(10);

/// Where the bytes come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// The settings' serial device at their baud rate.
    Device,
    /// A file of UBX (recorded from a receiver), read as fast as the
    /// subscribers take it; the driver stops at its end.
    ///
    /// A replay nobody hears is no delivery: before its first fix the
    /// driver waits, as long as it takes (until stopped), for a subscriber
    /// of `<prefix>/gnss`, wakes the subscribers and gives them
    /// [`FILE_SETTLE`] to connect (iceoryx2 0.10 connects a subscriber that
    /// existed before the publisher only at its next receive; until then
    /// its buffer fills and the rest is dropped). A subscriber that
    /// subscribes later gets the fixes from then on. Every fix a subscriber
    /// missed counts in `lost`, and so does every fix that reached no
    /// subscriber at all (all of them gone mid-file). A file without a
    /// fix never waits.
    File(PathBuf),
}

/// Why the driver could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The device or file named in the settings cannot be opened: exit 2
    /// (fix the setting, free the port, or plug the receiver in).
    #[error("{origin}: key `{key}`: {message}")]
    Open {
        /// The settings file (or option) that named it.
        origin: String,
        /// The key.
        key: &'static str,
        /// What failed.
        message: String,
    },
    /// The transport failed: exit 1.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// Reading the file failed: exit 1.
    #[error("{0}: read failed: {1}")]
    Read(String, std::io::Error),
}

impl RunError {
    /// The process's exit status (DESIGN "Command-line contract").
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Open { .. } => 2,
            _ => 1,
        }
    }
}

/// Opens the serial device, raw, exclusively (TIOCEXCL and an exclusive
/// `flock`, so a second driver, or `gpsd`, `picocom`, cannot read it too).
pub fn open_device(path: &str, baud: u32) -> Result<Box<dyn SerialPort>, String> {
    match serialport::new(path, baud)
        .timeout(READ_TIMEOUT)
        .open_native()
    {
        Ok(p) => Ok(Box::new(p)),
        Err(e) => Err(describe_open_error(path, &e)),
    }
}

fn describe_open_error(path: &str, e: &serialport::Error) -> String {
    let text = e.to_string();
    let busy = text.contains("lock") || text.contains("busy") || text.contains("EBUSY");
    if busy {
        format!("{path}: in use by another process ({text})")
    } else if !std::path::Path::new(path).exists() {
        format!("{path}: no such device ({text})")
    } else {
        format!("{path}: cannot open as a serial device: {text}")
    }
}

enum Input {
    Device(Option<Box<dyn SerialPort>>),
    File(std::fs::File, String),
}

/// What the run did.
#[derive(Debug, Clone, Copy)]
pub struct Summary {
    /// The counters at exit.
    pub counters: Counters,
}

/// Systemd notifications (READY, STATUS, WATCHDOG): failures ignored, a
/// driver never stops for its supervisor.
struct Notify {
    watchdog: Option<Duration>,
    last: Instant,
}

impl Notify {
    fn new() -> Self {
        let mut usec = 0;
        let watchdog =
            sd_notify::watchdog_enabled(false, &mut usec).then(|| Duration::from_micros(usec / 4));
        Self {
            watchdog,
            last: Instant::now(),
        }
    }
    fn send(&self, state: &[sd_notify::NotifyState<'_>]) {
        let _ = sd_notify::notify(false, state);
    }
    fn tick(&mut self) {
        if let Some(p) = self.watchdog
            && self.last.elapsed() >= p
        {
            self.last = Instant::now();
            self.send(&[sd_notify::NotifyState::Watchdog]);
        }
    }
}

/// Runs until `stop` (or the end of the file).
pub fn run(
    settings: &Settings,
    source: &Source,
    transport: &TransportConfig,
    stop: &AtomicBool,
) -> Result<Summary, RunError> {
    let device = settings.device.as_str();
    let mut input = match source {
        Source::Device => Input::Device(Some(open_device(device, settings.baud).map_err(
            |message| RunError::Open {
                origin: settings.origin.clone(),
                key: "device",
                message,
            },
        )?)),
        Source::File(p) => {
            let name = p.display().to_string();
            let f = std::fs::File::open(p).map_err(|e| RunError::Open {
                origin: "--file".into(),
                key: "file",
                message: format!("{name}: cannot open: {e}"),
            })?;
            Input::File(f, name)
        }
    };
    let node = polarnav_ipc::node(transport, "gnss-ubx")?;
    let delivery = match source {
        Source::Device => Delivery::Discard,
        Source::File(_) => Delivery::Wait(FILE_MAX_WAIT),
    };
    let publisher = TopicPublisher::<GnssFix>::with_delivery(
        &node,
        transport,
        Topic::Aid(msgs::AidKind::Gnss),
        delivery,
    )?;
    // NAV-RELPOSNED of a moving-base receiver, paired with its epoch's
    // NAV-PVT (issue 30); a receiver without a second antenna sends none.
    let baseline_publisher = TopicPublisher::<BaselineSample>::with_delivery(
        &node,
        transport,
        Topic::Aid(msgs::AidKind::Baseline),
        delivery,
    )?;
    let service = Topic::Aid(msgs::AidKind::Gnss).service_name(&transport.prefix);
    let baseline_service = Topic::Aid(msgs::AidKind::Baseline).service_name(&transport.prefix);
    let what = match source {
        Source::Device => format!("{device} at {} baud", settings.baud),
        Source::File(p) => format!("file {}", p.display()),
    };
    tracing::info!(
        "gnss-ubx: reading {what}, publishing NAV-PVT on {service} and NAV-RELPOSNED on \
         {baseline_service}"
    );
    // Subscribers that existed before these publishers connect at their
    // next receive: wake them now, not at the first fix.
    publisher.notify()?;
    baseline_publisher.notify()?;
    let from_file = matches!(source, Source::File(_));
    // `--file`: whether a subscriber was there (and had FILE_SETTLE to
    // connect) before the first fix, and the fixes that reached no one.
    let mut heard = !from_file;
    let mut unheard: u64 = 0;
    let mut notify = Notify::new();
    notify.send(&[
        sd_notify::NotifyState::Ready,
        sd_notify::NotifyState::Status(&format!("reading {what}")),
    ]);

    let mut driver = Driver::new(settings.time.clone());
    let mut fixes = Vec::with_capacity(64);
    let mut baselines = Vec::with_capacity(64);
    let mut buf = vec![0u8; 4096];
    let silent_after = Duration::from_secs_f64(SILENT_PERIODS / settings.rate_hz);
    let report_every = Duration::from_secs_f64(settings.report_s);
    let reconnect_every = Duration::from_secs_f64(settings.reconnect_s);
    let mut last_report = Instant::now();
    let mut last_pvt = Instant::now();
    let mut silent = false;
    let mut lost_at: Option<Instant> = None;
    let mut next_try = Instant::now();
    let mut failed_tries: u64 = 0;
    let mut reported = Counters::default();

    while !stop.load(Ordering::Relaxed) {
        notify.tick();
        let read = match &mut input {
            Input::Device(Some(port)) => Some(port.read(&mut buf)),
            Input::Device(None) => {
                let now = Instant::now();
                if now < next_try {
                    std::thread::sleep((next_try - now).min(READ_TIMEOUT));
                } else {
                    match open_device(device, settings.baud) {
                        Ok(p) => {
                            let away = lost_at.map_or(0.0, |t| t.elapsed().as_secs_f64());
                            driver.reconnected();
                            tracing::info!(
                                "gnss-ubx: {device} reconnected after {away:.1} s \
                                 (reconnection {})",
                                driver.counters().reconnects
                            );
                            input = Input::Device(Some(p));
                            lost_at = None;
                            failed_tries = 0;
                            last_pvt = Instant::now();
                        }
                        Err(m) => {
                            failed_tries += 1;
                            if failed_tries.is_power_of_two() {
                                tracing::warn!(
                                    "gnss-ubx: {m}; still trying every {} s ({failed_tries} tries)",
                                    settings.reconnect_s
                                );
                            }
                            next_try = now + reconnect_every;
                        }
                    }
                }
                None
            }
            Input::File(f, _) => Some(f.read(&mut buf)),
        };
        match read {
            None => {}
            Some(Ok(0)) => match &input {
                Input::File(..) => {
                    driver.finish();
                    break;
                }
                Input::Device(_) => {
                    lose(
                        &mut input,
                        &mut driver,
                        device,
                        "end of stream",
                        &mut lost_at,
                    );
                    next_try = Instant::now() + reconnect_every;
                }
            },
            Some(Ok(n)) => {
                driver.feed(&buf[..n], &mut fixes, &mut baselines);
                if !fixes.is_empty() {
                    last_pvt = Instant::now();
                    if silent {
                        silent = false;
                        tracing::info!("gnss-ubx: NAV-PVT again");
                    }
                }
                if !heard && (!fixes.is_empty() || !baselines.is_empty()) {
                    if !await_subscriber(&publisher, &baseline_publisher, &service, stop)? {
                        break;
                    }
                    heard = true;
                }
                for f in &fixes {
                    let no_one = reached_no_one(|| publisher.lost(), || publisher.publish(f))?;
                    unheard += u64::from(no_one && from_file);
                }
                for b in &baselines {
                    let no_one = reached_no_one(
                        || baseline_publisher.lost(),
                        || baseline_publisher.publish(b),
                    )?;
                    unheard += u64::from(no_one && from_file);
                }
                driver.set_lost(publisher.lost() + baseline_publisher.lost() + unheard);
            }
            Some(Err(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Some(Err(e)) => match &input {
                Input::File(_, name) => return Err(RunError::Read(name.clone(), e)),
                Input::Device(_) => {
                    lose(
                        &mut input,
                        &mut driver,
                        device,
                        &e.to_string(),
                        &mut lost_at,
                    );
                    next_try = Instant::now() + reconnect_every;
                }
            },
        }
        if matches!(input, Input::Device(Some(_))) && !silent && last_pvt.elapsed() >= silent_after
        {
            silent = true;
            tracing::warn!(
                "gnss-ubx: no NAV-PVT from {device} for {:.1} s (expected {} Hz)",
                last_pvt.elapsed().as_secs_f64(),
                settings.rate_hz
            );
        }
        if last_report.elapsed() >= report_every {
            last_report = Instant::now();
            let c = driver.counters();
            if c != reported {
                report(&c, &reported);
                reported = c;
            }
            notify.send(&[sd_notify::NotifyState::Status(&format!(
                "{what}: {} fixes published, {} damaged",
                c.published,
                c.damage()
            ))]);
        }
    }
    if let Input::Device(Some(_)) = input {
        driver.finish();
    }
    driver.set_lost(publisher.lost() + baseline_publisher.lost() + unheard);
    let counters = driver.counters();
    notify.send(&[sd_notify::NotifyState::Stopping]);
    tracing::info!("gnss-ubx: exit: {counters}");
    Ok(Summary { counters })
}

/// Publishes `x`; `true` when it reached no subscriber and none missed it
/// (no subscriber at all: a miss is already in the publisher's `lost`).
fn reached_no_one(
    lost: impl Fn() -> u64,
    publish: impl FnOnce() -> Result<usize, TransportError>,
) -> Result<bool, TransportError> {
    let before = lost();
    Ok(publish()? == 0 && lost() == before)
}

/// `--file`, before the first fix: waits for a subscriber of `service`,
/// then wakes the subscribers and waits [`FILE_SETTLE`] for them to
/// connect. `false`: stopped meanwhile.
fn await_subscriber(
    publisher: &TopicPublisher<GnssFix>,
    baseline_publisher: &TopicPublisher<BaselineSample>,
    service: &str,
    stop: &AtomicBool,
) -> Result<bool, RunError> {
    if publisher.subscribers() == 0 {
        tracing::info!(
            "gnss-ubx: no subscriber on {service} yet: the file's first fix waits for one \
             (stop with Ctrl-C)"
        );
        while publisher.subscribers() == 0 {
            if stop.load(Ordering::Relaxed) {
                return Ok(false);
            }
            std::thread::sleep(SUBSCRIBER_POLL);
        }
    }
    publisher.notify()?;
    baseline_publisher.notify()?;
    let t0 = Instant::now();
    while t0.elapsed() < FILE_SETTLE {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        std::thread::sleep(SUBSCRIBER_POLL);
    }
    tracing::info!(
        "gnss-ubx: {} subscriber(s) on {service}: publishing the file",
        publisher.subscribers()
    );
    Ok(true)
}

fn lose(
    input: &mut Input,
    driver: &mut Driver,
    device: &str,
    why: &str,
    lost_at: &mut Option<Instant>,
) {
    tracing::warn!("gnss-ubx: {device} lost ({why}); reopening it");
    driver.finish();
    *input = Input::Device(None);
    *lost_at = Some(Instant::now());
}

fn report(c: &Counters, before: &Counters) {
    if c.damage() > before.damage() || c.lost > before.lost {
        tracing::warn!("gnss-ubx: counters: {c}");
    } else {
        tracing::info!("gnss-ubx: counters: {c}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--file` gives its subscribers the time every input subscriber
    /// receives within, by the contract the input buffers are sized on.
    #[test]
    fn file_settle_is_the_input_buffers_time() {
        assert_eq!(
            FILE_SETTLE,
            Duration::from_secs_f64(polarnav_ipc::INPUT_BUFFER_S)
        );
    }
}
