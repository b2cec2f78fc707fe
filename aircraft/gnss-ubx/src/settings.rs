//! The settings file (`config/gnss-ubx.toml`, installed as
//! `/etc/polarnav/gnss-ubx.toml`): every key known, every number bounded,
//! a refusal names the file and the key (exit status 2).

use std::path::Path;

use polarnav::settings::{Bound, SettingsError};
use polarnav_config::provenance::UtcStart;

use crate::time::TimeRule;

/// The driver's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Where the settings came from (the file, or the built-in defaults).
    pub origin: String,
    /// iceoryx2 service prefix (`<prefix>/gnss`).
    pub prefix: String,
    /// The receiver's serial device.
    pub device: String,
    /// Its baud rate.
    pub baud: u32,
    /// The receiver's navigation rate (NAV-PVT per second): silence is
    /// reported after 5 periods without a NAV-PVT.
    pub rate_hz: f64,
    /// Time between attempts to reopen a lost device (s).
    pub reconnect_s: f64,
    /// Period of the counters' log line (s).
    pub report_s: f64,
    /// `[time]`: the GPS time → sensor time rule.
    pub time: TimeRule,
    /// `time.epoch_utc` as given.
    pub epoch_utc: String,
}

/// The keys of the file, for the refusal of an unknown one.
const KEYS: [&str; 6] = [
    "prefix",
    "device",
    "baud",
    "rate_hz",
    "reconnect_s",
    "report_s",
];
const TIME_KEYS: [&str; 4] = ["epoch_utc", "gps_utc_offset_s", "offset_s", "week"];

/// Why a settings file was refused.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file cannot be read: give an existing, readable file.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not TOML: the message names the line.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// The TOML parser's message (line and column).
        message: String,
    },
    /// A key unknown, of the wrong type or out of its bound.
    #[error(transparent)]
    Invalid(#[from] SettingsError),
}

impl Default for Settings {
    fn default() -> Self {
        Self::parse("", "built-in defaults").expect("the defaults are valid")
    }
}

fn invalid(origin: &str, key: &str, message: impl Into<String>) -> SettingsError {
    SettingsError {
        origin: origin.to_owned(),
        key: key.to_owned(),
        message: message.into(),
    }
}

/// A number (integer or float) of `t[key]`, or `default`.
fn number(t: &toml::Table, origin: &str, key: &str, default: f64) -> Result<f64, SettingsError> {
    match t.get(key.rsplit('.').next().unwrap_or(key)) {
        None => Ok(default),
        Some(toml::Value::Integer(i)) => Ok(*i as f64),
        Some(toml::Value::Float(f)) => Ok(*f),
        Some(v) => Err(invalid(origin, key, format!("expected a number, got {v}"))),
    }
}

/// A whole number of `t[key]` within `bound`.
fn whole(
    t: &toml::Table,
    origin: &str,
    key: &str,
    default: f64,
    bound: Bound<'_>,
) -> Result<f64, SettingsError> {
    let v = number(t, origin, key, default)?;
    bound.check(origin, key, v)?;
    if v.fract() != 0.0 {
        return Err(invalid(
            origin,
            key,
            format!("expected a whole number, got {v}"),
        ));
    }
    Ok(v)
}

fn string(
    t: &toml::Table,
    origin: &str,
    key: &str,
    default: &str,
) -> Result<String, SettingsError> {
    match t.get(key.rsplit('.').next().unwrap_or(key)) {
        None => Ok(default.to_owned()),
        Some(toml::Value::String(s)) => Ok(s.clone()),
        Some(v) => Err(invalid(origin, key, format!("expected a string, got {v}"))),
    }
}

fn unknown_keys(
    t: &toml::Table,
    known: &[&str],
    table: &str,
    origin: &str,
) -> Result<(), SettingsError> {
    match t.keys().find(|k| !known.contains(&k.as_str())) {
        Some(k) => Err(invalid(
            origin,
            &format!("{table}{k}"),
            format!("unknown key (known: {})", known.join(", ")),
        )),
        None => Ok(()),
    }
}

impl Settings {
    /// Reads and validates a settings file.
    pub fn load(path: &Path) -> Result<Self, LoadError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| LoadError::Io {
            path: p.clone(),
            source,
        })?;
        Self::parse(&text, &p)
    }

    /// Parses and validates settings text; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, LoadError> {
        let t: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| LoadError::Parse {
                path: origin.to_owned(),
                message: e.to_string(),
            })?;
        let mut known: Vec<&str> = KEYS.to_vec();
        known.push("time");
        unknown_keys(&t, &known, "", origin)?;
        let prefix = string(&t, origin, "prefix", msgs::service::DEFAULT_PREFIX)?;
        msgs::service::validate_prefix(&prefix).map_err(|m| invalid(origin, "prefix", m))?;
        let device = string(&t, origin, "device", "/dev/ttyACM0")?;
        if device.is_empty() {
            return Err(
                invalid(origin, "device", "expected a device path, got an empty one").into(),
            );
        }
        let baud = whole(
            &t,
            origin,
            "baud",
            115_200.0,
            Bound {
                lo: 4800.0,
                hi: 921_600.0,
                unit: "baud",
                below: "below the slowest rate of a u-blox UART, and too slow for NAV-PVT at 1 Hz",
                above: "above the fastest rate of a u-blox UART",
            },
        )? as u32;
        let rate_hz = number(&t, origin, "rate_hz", 10.0)?;
        Bound {
            lo: 0.1,
            hi: polarnav_ipc::MAX_AID_RATE_HZ,
            unit: "Hz",
            below: "a fix every 10 s or less is no aid to the navigator (and its silence \
                    report would come after minutes)",
            above: "the aid services' buffers are sized for 50 Hz (and no u-blox receiver \
                    computes NAV-PVT faster)",
        }
        .check(origin, "rate_hz", rate_hz)?;
        let reconnect_s = number(&t, origin, "reconnect_s", 1.0)?;
        Bound {
            lo: 0.05,
            hi: 60.0,
            unit: "s",
            below: "reopening a missing device faster than 20 times a second only loads the CPU",
            above: "a receiver back after a minute would be ignored that long",
        }
        .check(origin, "reconnect_s", reconnect_s)?;
        let report_s = number(&t, origin, "report_s", 60.0)?;
        Bound {
            lo: 1.0,
            hi: 86_400.0,
            unit: "s",
            below: "more than one counter line a second floods the journal",
            above: "a report less than daily hides a failing receiver",
        }
        .check(origin, "report_s", report_s)?;

        let empty = toml::Table::new();
        let tt = match t.get("time") {
            None => &empty,
            Some(toml::Value::Table(tt)) => tt,
            Some(v) => {
                return Err(invalid(origin, "time", format!("expected a table, got {v}")).into());
            }
        };
        unknown_keys(tt, &TIME_KEYS, "time.", origin)?;
        let epoch_utc = string(tt, origin, "time.epoch_utc", "1980-01-06T00:00:00Z")?;
        let epoch =
            UtcStart::parse(&epoch_utc).map_err(|m| invalid(origin, "time.epoch_utc", m))?;
        let gps_utc_offset_s = whole(
            tt,
            origin,
            "time.gps_utc_offset_s",
            0.0,
            Bound {
                lo: 0.0,
                hi: 100.0,
                unit: "s",
                below: "GPS time is ahead of UTC (18 s since 2017)",
                above: "leap seconds accumulate at about one a year and may stop in 2035",
            },
        )? as i64;
        let offset_s = number(tt, origin, "time.offset_s", 0.0)?;
        Bound {
            lo: -86_400.0,
            hi: 86_400.0,
            unit: "s",
            below: "a clock disciplined to GNSS differs from GPS time by a time-system \
                    difference (TAI 19 s, UTC 18 s) and a delay: a day is a wrong epoch",
            above: "a clock disciplined to GNSS differs from GPS time by a time-system \
                    difference (TAI 19 s, UTC 18 s) and a delay: a day is a wrong epoch",
        }
        .check(origin, "time.offset_s", offset_s)?;
        let week = whole(
            tt,
            origin,
            "time.week",
            0.0,
            Bound {
                lo: 0.0,
                hi: 16_383.0,
                unit: "",
                below: "GPS weeks count from 0 (1980-01-06)",
                above: "beyond the 14-bit week of CNAV (year 2293)",
            },
        )? as u32;
        let time = TimeRule::new(
            epoch.ns,
            gps_utc_offset_s,
            offset_s,
            (week > 0).then_some(week),
        )
        .map_err(|m| invalid(origin, "time.epoch_utc", m))?;
        Ok(Self {
            origin: origin.to_owned(),
            prefix,
            device,
            baud,
            rate_hz,
            reconnect_s,
            report_s,
            time,
            epoch_utc,
        })
    }

    /// One line per setting, for the start-up log.
    pub fn describe(&self) -> String {
        format!(
            "prefix = {:?}\ndevice = {:?}\nbaud = {}\nrate_hz = {}\nreconnect_s = {}\nreport_s = {}\n\
             time.epoch_utc = {:?}\ntime.gps_utc_offset_s = {}\ntime.offset_s = {}\ntime.week = {}",
            self.prefix,
            self.device,
            self.baud,
            self.rate_hz,
            self.reconnect_s,
            self.report_s,
            self.epoch_utc,
            self.time.gps_utc_offset_s(),
            self.time.offset_ns() as f64 * 1e-9,
            self.time.fallback_week().unwrap_or(0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(text: &str) -> SettingsError {
        match Settings::parse(text, "g.toml") {
            Err(LoadError::Invalid(e)) => e,
            other => panic!("{text:?} not refused by a key: {other:?}"),
        }
    }

    #[test]
    fn the_shipped_file_is_valid() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/gnss-ubx.toml");
        let s = Settings::load(&path).expect("config/gnss-ubx.toml");
        assert_eq!(s.prefix, "polarnav");
        assert_eq!(s.baud, 115_200);
    }

    #[test]
    fn settings_that_can_never_work_are_refused_naming_the_key() {
        for (text, key) in [
            ("baud = 0", "baud"),
            ("baud = 1e9", "baud"),
            ("baud = 1000000000", "baud"),
            ("baud = 115200.5", "baud"),
            ("baud = \"fast\"", "baud"),
            ("rate_hz = 0", "rate_hz"),
            ("rate_hz = 1e9", "rate_hz"),
            ("rate_hz = nan", "rate_hz"),
            ("reconnect_s = 0", "reconnect_s"),
            ("report_s = inf", "report_s"),
            ("device = \"\"", "device"),
            ("prefix = \"a b\"", "prefix"),
            ("bauds = 9600", "bauds"),
            ("[time]\nepoch_utc = \"yesterday\"", "time.epoch_utc"),
            ("[time]\ngps_utc_offset_s = -1", "time.gps_utc_offset_s"),
            ("[time]\noffset_s = 1e6", "time.offset_s"),
            ("[time]\nweek = 99999", "time.week"),
            ("[time]\nwek = 2", "time.wek"),
        ] {
            let e = refused(text);
            assert_eq!(e.key, key, "{text}: {e}");
            assert!(e.to_string().starts_with("g.toml: key `"), "{e}");
        }
    }

    #[test]
    fn defaults_are_gps_time_since_the_gps_epoch() {
        let s = Settings::default();
        assert_eq!(s.time.offset_ns(), 0);
        assert_eq!(s.epoch_utc, "1980-01-06T00:00:00Z");
    }
}
