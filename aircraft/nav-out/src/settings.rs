//! The settings files of both bridges (`config/nav-mavlink.toml`,
//! `config/nav-nmea.toml`): parsed strictly (an unknown key is refused), every
//! number checked against a physical bound, every refusal naming the file
//! and the key. Exit status 2 for any of them, as for the daemon.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::health::HealthSettings;

/// A setting that cannot work, or a file that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum SettingsError {
    /// The file cannot be read (missing, permissions).
    #[error("{file}: cannot read: {detail}")]
    Read { file: String, detail: String },
    /// Not TOML, or a key unknown or of the wrong type (the parser's
    /// message names it and its line).
    #[error("{file}: {detail}")]
    Parse { file: String, detail: String },
    /// A key's value is out of its bound or unusable here (a port in use, a
    /// serial device that does not exist).
    #[error("{file}: key `{key}`: {detail}")]
    Key {
        file: String,
        key: String,
        detail: String,
    },
}

impl SettingsError {
    /// The key this error names, if any.
    pub fn key(&self) -> Option<&str> {
        match self {
            SettingsError::Key { key, .. } => Some(key),
            _ => None,
        }
    }
}

/// A numeric bound: what a value below or above it would do.
#[derive(Debug, Clone, Copy)]
pub struct Bound {
    pub lo: f64,
    pub hi: f64,
    pub unit: &'static str,
    pub why: &'static str,
}

thread_local! {
    static RECORD: std::cell::RefCell<Option<Vec<(String, Bound, f64)>>> =
        const { std::cell::RefCell::new(None) };
}

/// Runs `f` and returns, with its result, every (key, bound, value) that
/// [`Checker::num`] or [`Checker::int`] checked on this thread meanwhile, in
/// order. The settings reference (`docs/src/reference/settings.generated.md`,
/// `tests/tests/references.rs`) is made from these, so it lists the bounds
/// the checks apply.
pub fn record<R>(f: impl FnOnce() -> R) -> (R, Vec<(String, Bound, f64)>) {
    let outer = RECORD.replace(Some(Vec::new()));
    let r = f();
    let checked = RECORD.replace(outer).unwrap_or_default();
    RECORD.with_borrow_mut(|o| {
        if let Some(o) = o {
            o.extend(checked.iter().cloned());
        }
    });
    (r, checked)
}

/// Checks numbers against bounds, naming the file and key.
#[derive(Debug, Clone)]
pub struct Checker {
    pub file: String,
}

impl Checker {
    pub fn key_error(&self, key: &str, detail: impl Into<String>) -> SettingsError {
        SettingsError::Key {
            file: self.file.clone(),
            key: key.to_owned(),
            detail: detail.into(),
        }
    }

    /// `v` if finite and inside `b`.
    pub fn num(&self, key: &str, v: f64, b: Bound) -> Result<f64, SettingsError> {
        RECORD.with_borrow_mut(|r| {
            if let Some(r) = r {
                r.push((key.to_owned(), b, v));
            }
        });
        if v.is_finite() && v >= b.lo && v <= b.hi {
            Ok(v)
        } else {
            Err(self.key_error(
                key,
                format!(
                    "expected a number in [{}, {}] {}, got {v}: {}",
                    b.lo, b.hi, b.unit, b.why
                ),
            ))
        }
    }

    /// An integer inside `b`.
    pub fn int(&self, key: &str, v: f64, b: Bound) -> Result<u32, SettingsError> {
        let v = self.num(key, v, b)?;
        if v.fract() != 0.0 {
            return Err(self.key_error(key, format!("expected an integer, got {v}")));
        }
        Ok(v as u32)
    }
}

/// Where the bytes go.
#[derive(Debug, Clone, PartialEq)]
pub enum Transport {
    /// Datagrams from `bind` (a local address; port 0 = any) to `target`.
    Udp {
        bind: SocketAddr,
        target: SocketAddr,
    },
    /// A serial device at a baud rate (8N1, no flow control).
    Serial { device: PathBuf, baud: u32 },
}

/// `[output]` as written in the file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputFile {
    /// "udp" or "serial".
    pub transport: String,
    pub udp_target: Option<String>,
    pub udp_bind: Option<String>,
    pub serial_device: Option<PathBuf>,
    pub serial_baud: Option<f64>,
}

/// `[health]` as written in the file (each key optional: defaults of
/// [`HealthSettings`]).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HealthFile {
    pub silent_after_s: Option<f64>,
    pub status_silent_after_s: Option<f64>,
    pub fix3d_max_h_acc_m: Option<f64>,
    pub fix3d_max_v_acc_m: Option<f64>,
    pub fix_max_h_acc_m: Option<f64>,
    pub dop_uere_m: Option<f64>,
    pub yaw_max_sigma_deg: Option<f64>,
}

/// Serial baud rates the bridges accept.
pub const BAUD: Bound = Bound {
    lo: 1200.0,
    hi: 4_000_000.0,
    unit: "baud",
    why: "below 1200 baud not even one message per second fits; above 4 Mbaud no UART on the flight computer runs",
};

impl OutputFile {
    /// The transport, checked; `default_baud` when `serial_baud` is absent.
    pub fn check(&self, c: &Checker, default_baud: u32) -> Result<Transport, SettingsError> {
        match self.transport.as_str() {
            "udp" => {
                let addr = |key: &str, v: Option<&String>, default: Option<&str>| {
                    let s = v.map(String::as_str).or(default).ok_or_else(|| {
                        c.key_error(key, "required with transport = \"udp\" (ADDRESS:PORT)")
                    })?;
                    s.parse::<SocketAddr>().map_err(|e| {
                        c.key_error(
                            key,
                            format!("expected an IP address and port, got {s:?}: {e}"),
                        )
                    })
                };
                let target = addr("output.udp_target", self.udp_target.as_ref(), None)?;
                if target.port() == 0 || target.ip().is_unspecified() {
                    return Err(c.key_error(
                        "output.udp_target",
                        format!("expected a destination with an address and a port, got {target}"),
                    ));
                }
                let bind = addr("output.udp_bind", self.udp_bind.as_ref(), Some("0.0.0.0:0"))?;
                if bind.is_ipv4() != target.is_ipv4() {
                    return Err(c.key_error(
                        "output.udp_bind",
                        format!(
                            "{bind} and output.udp_target {target} are of different IP versions"
                        ),
                    ));
                }
                Ok(Transport::Udp { bind, target })
            }
            "serial" => {
                let device = self.serial_device.clone().ok_or_else(|| {
                    c.key_error(
                        "output.serial_device",
                        "required with transport = \"serial\"",
                    )
                })?;
                let baud = match self.serial_baud {
                    Some(b) => c.int("output.serial_baud", b, BAUD)?,
                    None => default_baud,
                };
                Ok(Transport::Serial { device, baud })
            }
            other => Err(c.key_error(
                "output.transport",
                format!("expected \"udp\" or \"serial\", got {other:?}"),
            )),
        }
    }
}

impl HealthFile {
    pub fn check(&self, c: &Checker) -> Result<HealthSettings, SettingsError> {
        let d = HealthSettings::default();
        let acc = Bound {
            lo: 0.01,
            hi: 1e6,
            unit: "m",
            why: "a 1-σ under 1 cm no navigator gives; over 1000 km is no position",
        };
        let s = HealthSettings {
            silent_after_s: c.num(
                "health.silent_after_s",
                self.silent_after_s.unwrap_or(d.silent_after_s),
                Bound {
                    lo: 0.02,
                    hi: 0.9,
                    unit: "s",
                    why: "under 20 ms a 200 Hz solution stream on a loaded machine looks silent; \
                          over 0.9 s a stopped daemon is not said within 1 s",
                },
            )?,
            status_silent_after_s: c.num(
                "health.status_silent_after_s",
                self.status_silent_after_s
                    .unwrap_or(d.status_silent_after_s),
                Bound {
                    lo: 1.1,
                    hi: 60.0,
                    unit: "s",
                    why: "the status comes at 1 Hz: under 1.1 s a live daemon looks silent; \
                          over a minute a dead one looks alive",
                },
            )?,
            fix3d_max_h_acc_m: c.num(
                "health.fix3d_max_h_acc_m",
                self.fix3d_max_h_acc_m.unwrap_or(d.fix3d_max_h_acc_m),
                acc,
            )?,
            fix3d_max_v_acc_m: c.num(
                "health.fix3d_max_v_acc_m",
                self.fix3d_max_v_acc_m.unwrap_or(d.fix3d_max_v_acc_m),
                acc,
            )?,
            fix_max_h_acc_m: c.num(
                "health.fix_max_h_acc_m",
                self.fix_max_h_acc_m.unwrap_or(d.fix_max_h_acc_m),
                acc,
            )?,
            dop_uere_m: c.num(
                "health.dop_uere_m",
                self.dop_uere_m.unwrap_or(d.dop_uere_m),
                Bound {
                    lo: 0.1,
                    hi: 100.0,
                    unit: "m",
                    why: "a GNSS user range error is metres: outside, the pseudo-DOPs mean nothing to a GNSS consumer",
                },
            )?,
            yaw_max_sigma_deg: c.num(
                "health.yaw_max_sigma_deg",
                self.yaw_max_sigma_deg.unwrap_or(d.yaw_max_sigma_deg),
                Bound {
                    lo: 0.01,
                    hi: 90.0,
                    unit: "°",
                    why: "under 0.01° no heading would ever be sent; over 90° it says nothing",
                },
            )?,
        };
        if s.fix_max_h_acc_m < s.fix3d_max_h_acc_m {
            return Err(c.key_error(
                "health.fix_max_h_acc_m",
                format!(
                    "expected at least health.fix3d_max_h_acc_m ({} m), got {} m: a 3D fix would be no fix",
                    s.fix3d_max_h_acc_m, s.fix_max_h_acc_m
                ),
            ));
        }
        Ok(s)
    }
}

/// Reads a settings file into its raw form.
pub fn read_toml<T: for<'de> Deserialize<'de>>(path: &Path) -> Result<T, SettingsError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| SettingsError::Read {
        file: file.clone(),
        detail: e.to_string(),
    })?;
    toml::from_str(&text).map_err(|e| SettingsError::Parse {
        file,
        detail: e.to_string().trim_end().replace('\n', " "),
    })
}

/// The service prefix, checked by the project's one rule.
pub fn check_prefix(c: &Checker, key: &str, prefix: &str) -> Result<String, SettingsError> {
    msgs::service::validate_prefix(prefix).map_err(|e| c.key_error(key, e))?;
    Ok(prefix.to_owned())
}

/// A rate in Hz within `[lo, hi]`.
pub fn rate(c: &Checker, key: &str, v: f64, lo: f64, hi: f64) -> Result<f64, SettingsError> {
    c.num(
        key,
        v,
        Bound {
            lo,
            hi,
            unit: "Hz",
            why: "below, the consumer times the stream out; above, the link or the consumer is flooded",
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_returns_the_bounds_checked_inside_it() {
        let c = Checker { file: "f".into() };
        let b = Bound {
            lo: 1.0,
            hi: 9.0,
            unit: "Hz",
            why: "because",
        };
        c.num("outside", 2.0, b).unwrap();
        let (r, checked) = record(|| {
            c.num("a.rate_hz", 2.0, b).unwrap();
            c.int("a.count", 10.0, b)
        });
        assert!(r.is_err(), "a recorded check still refuses");
        let got: Vec<(&str, f64, &str)> = checked
            .iter()
            .map(|(k, b, v)| (k.as_str(), *v, b.why))
            .collect();
        assert_eq!(
            got,
            [("a.rate_hz", 2.0, "because"), ("a.count", 10.0, "because")]
        );
    }
}
