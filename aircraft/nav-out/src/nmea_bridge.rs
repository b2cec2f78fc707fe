//! `nav-nmea`: the solution to payloads as NMEA 0183 (GGA, RMC, VTG, HDT).
//!
//! Every `[nmea] rate_hz` the bridge writes the configured sentences of
//! the newest solution, in one UDP datagram or back to back on the serial
//! line ([`crate::nmea`] gives each field's resolution). The fix rule is
//! MAVLink's ([`crate::health`]): GGA quality 1 with a 3D fix, 6
//! (estimated) degraded, 0 otherwise; RMC status A or V with mode A, E or
//! N. When the daemon stops, the next epoch (at most one period later, and
//! at once when the fix gets worse) says quality 0, status V, mode N.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use polarnav_ipc::TransportConfig;
use serde::Deserialize;

use crate::bridge::{self, Every, Notify, RunError};
use crate::feed::Feed;
use crate::health::{Fix, HealthSettings, assess};
use crate::nmea::{Epoch, Format, Sentence, Utc};
use crate::settings::{
    self, Bound, Checker, HealthFile, OutputFile, SettingsError, Transport, read_toml,
};
use crate::sink::Sink;

/// The file name of the settings (`config/`, `/etc/polarnav/`).
pub const CONFIG_NAME: &str = "nav-nmea.toml";
/// The shipped settings, used when no file is found.
pub const SHIPPED: &str = include_str!("../../../config/nav-nmea.toml");

/// Longest sentence of each kind with 7 decimals of minutes (bytes with
/// CR LF), for the serial capacity check.
const SENTENCE_BYTES: f64 = 100.0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSettings {
    prefix: Option<String>,
    #[serde(default)]
    nmea: NmeaTable,
    output: OutputFile,
    #[serde(default)]
    health: HealthFile,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct NmeaTable {
    rate_hz: Option<f64>,
    talker: Option<String>,
    sentences: Option<Vec<String>>,
    minute_decimals: Option<f64>,
}

/// nav-nmea's checked settings.
#[derive(Debug, Clone, PartialEq)]
pub struct NmeaSettings {
    pub origin: String,
    pub prefix: String,
    pub rate_hz: f64,
    pub format: Format,
    pub transport: Transport,
    pub health: HealthSettings,
}

impl NmeaSettings {
    /// Reads and checks `path`, or the shipped settings when `None`;
    /// `prefix` (the command line's) replaces the file's.
    pub fn load(path: Option<&Path>, prefix: Option<&str>) -> Result<Self, SettingsError> {
        let (raw, origin): (FileSettings, String) = match path {
            Some(p) => (read_toml(p)?, p.display().to_string()),
            None => (
                toml::from_str(SHIPPED).map_err(|e| SettingsError::Parse {
                    file: "shipped nav-nmea.toml".into(),
                    detail: e.to_string(),
                })?,
                "shipped settings".into(),
            ),
        };
        let c = Checker {
            file: origin.clone(),
        };
        let (prefix_key, prefix) = match prefix {
            Some(p) => ("--prefix", p.to_owned()),
            None => (
                "prefix",
                raw.prefix
                    .clone()
                    .unwrap_or_else(|| msgs::service::DEFAULT_PREFIX.into()),
            ),
        };
        let prefix = settings::check_prefix(&c, prefix_key, &prefix)?;
        let n = &raw.nmea;
        let rate_hz = c.num(
            "nmea.rate_hz",
            n.rate_hz.unwrap_or(5.0),
            Bound {
                lo: 0.1,
                hi: 20.0,
                unit: "Hz",
                why: "NMEA consumers time a source out after seconds; over 20 Hz none reads them",
            },
        )?;
        let talker = n.talker.clone().unwrap_or_else(|| "GP".into());
        if !(talker.len() == 2 && talker.bytes().all(|b| b.is_ascii_uppercase())) {
            return Err(c.key_error(
                "nmea.talker",
                format!("expected two capital letters (GP, GN, IN), got {talker:?}"),
            ));
        }
        let names = n
            .sentences
            .clone()
            .unwrap_or_else(|| Sentence::ALL.iter().map(|s| s.name().to_owned()).collect());
        let mut sentences = Vec::new();
        for name in &names {
            let s = Sentence::parse(name).ok_or_else(|| {
                c.key_error(
                    "nmea.sentences",
                    format!("expected some of \"GGA\", \"RMC\", \"VTG\", \"HDT\", got {name:?}"),
                )
            })?;
            if sentences.contains(&s) {
                return Err(c.key_error("nmea.sentences", format!("{name} is listed twice")));
            }
            sentences.push(s);
        }
        if sentences.is_empty() {
            return Err(c.key_error("nmea.sentences", "expected at least one sentence"));
        }
        let minute_decimals = c.int(
            "nmea.minute_decimals",
            n.minute_decimals.unwrap_or(5.0),
            Bound {
                lo: 4.0,
                hi: 7.0,
                unit: "decimals",
                why: "under 4 decimals of a minute the position is rounded to more than 18 cm; \
                      over 7 (0.2 mm) no consumer reads them",
            },
        )?;
        let transport = raw.output.check(&c, 38_400)?;
        let health = raw.health.check(&c)?;
        if let Transport::Serial { baud, .. } = transport {
            let need = rate_hz * sentences.len() as f64 * SENTENCE_BYTES * 10.0;
            if need > f64::from(baud) {
                return Err(c.key_error(
                    "output.serial_baud",
                    format!(
                        "{baud} baud cannot carry {} sentences at {rate_hz} Hz ({need:.0} bit/s needed): \
                         raise the baud rate or lower nmea.rate_hz",
                        sentences.len()
                    ),
                ));
            }
        }
        Ok(Self {
            origin,
            prefix,
            rate_hz,
            format: Format {
                talker,
                sentences,
                minute_decimals,
            },
            transport,
            health,
        })
    }

    pub fn describe(&self) -> String {
        format!(
            "settings from {}: prefix {}, {} Hz of {:?} as talker {} with {} decimals of minutes, output {:?}, health {:?}",
            self.origin,
            self.prefix,
            self.rate_hz,
            self.format
                .sentences
                .iter()
                .map(|s| s.name())
                .collect::<Vec<_>>(),
            self.format.talker,
            self.format.minute_decimals,
            self.transport,
            self.health
        )
    }
}

/// What a run did.
#[derive(Debug, Default, Clone, Copy)]
pub struct Summary {
    pub epochs: u64,
    pub solutions: u64,
    pub missed: u64,
    pub dropped: u64,
}

/// Runs the bridge until `stop`.
pub fn run(
    s: &NmeaSettings,
    transport: &TransportConfig,
    stop: &AtomicBool,
) -> Result<Summary, RunError> {
    let c = Checker {
        file: s.origin.clone(),
    };
    let mut sink = Sink::open(&s.transport, &c)?;
    let mut feed = Feed::open(transport, "nav-nmea")?;
    let mut notify = Notify::from_env();
    let start = Instant::now();
    let mut every = Every::from_hz(s.rate_hz, start);
    let mut last_fix: Option<Fix> = None;
    let mut geoid: Option<(u64, f64)> = None;
    let mut sum = Summary::default();
    tracing::info!(output = ?s.transport, local = ?sink.local_addr(), "nav-nmea sending on {:?}", s.transport);
    notify.ready("waiting for the daemon");
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        feed.poll(now)?;
        let q = assess(&feed.heard(now), &s.health);
        let worse = last_fix.is_some_and(|f| q.fix < f);
        if last_fix != Some(q.fix) {
            let text = format!("fix {}", q.fix.name());
            if q.fix.usable() {
                tracing::info!("{text}");
            } else {
                tracing::warn!("{text}");
            }
            notify.status(&text);
            last_fix = Some(q.fix);
        }
        if every.due(now) || worse {
            let sol = feed.solution();
            let n = match (sol, geoid) {
                (Some(x), Some((seq, n))) if seq == x.seq => n,
                (Some(x), _) => {
                    let n = crate::geo::geoid_undulation_m(x.lat_rad, x.lon_rad);
                    geoid = Some((x.seq, n));
                    n
                }
                (None, _) => f64::NAN,
            };
            let epoch = Epoch {
                solution: sol,
                quality: &q,
                geoid_m: n,
                utc: Utc::from_unix(bridge::unix_time_of(feed.solution_at().unwrap_or(now), now)),
            };
            sink.send(epoch.sentences(&s.format).as_bytes(), now);
            sum.epochs += 1;
        }
        notify.ping(now);
        bridge::sleep_until(&[every.next()], Instant::now());
    }
    notify.stopping();
    sum.solutions = feed.received;
    sum.missed = feed.missed;
    sum.dropped = sink.dropped;
    Ok(sum)
}
