//! `nav-mavlink`: the solution to an autopilot over MAVLink 2.
//!
//! Messages, as one onboard component (`[mavlink] system_id`,
//! `component_id`, `mav_type`):
//!
//! | message | rate | content |
//! |---|---|---|
//! | HEARTBEAT | 1 Hz | `system_status` says the fix ([`crate::mav::heartbeat`]) |
//! | GPS_INPUT | `gps_input_hz`, and at once when the fix gets worse | the newest solution ([`crate::mav::gps_input`]) |
//! | SYSTEM_TIME | `system_time_hz` | the flight computer's UTC clock |
//! | ODOMETRY | `[mavlink.odometry] rate_hz` when enabled | anchored local frame ([`crate::mav::Odometry`]) |
//!
//! **When the daemon stops** the bridge keeps running and says so by fix
//! type: GPS_INPUT goes to `GPS_FIX_TYPE_NO_GPS` (0) as soon as the
//! solution service has no publisher (a clean stop: within one loop
//! period, 20 ms) or, for a daemon that hangs or is killed, once no solution
//! has come for `health.silent_after_s` (0.5 s by default; bounded below
//! 0.9 s) and no status for `health.status_silent_after_s`; a daemon whose
//! status still comes while its solutions do not is `NO_FIX` (1). The
//! first GPS_INPUT of a worse fix is sent at once, not at the next
//! scheduled one, so "said within 1 s" holds at any `gps_input_hz`.
//! HEARTBEAT continues (`MAV_STATE_UNINIT`), ODOMETRY stops.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mavlink::dialects::common::MavType;
use polarnav_ipc::TransportConfig;
use serde::Deserialize;

use crate::bridge::{self, Every, Notify, RunError};
use crate::feed::Feed;
use crate::health::{Fix, HealthSettings, assess};
use crate::mav::{self, Encoder, Odometry, OdometryFrame};
use crate::settings::{
    self, Bound, Checker, HealthFile, OutputFile, SettingsError, Transport, read_toml,
};
use crate::sink::Sink;

/// The file name of the settings (`config/`, `/etc/polarnav/`).
pub const CONFIG_NAME: &str = "nav-mavlink.toml";
/// The shipped settings, used when no file is found.
pub const SHIPPED: &str = include_str!("../../../config/nav-mavlink.toml");

/// Largest MAVLink 2 frames of each message this bridge sends (bytes,
/// unsigned: 12 of header and checksum plus the payload), for the serial
/// capacity check.
const HEARTBEAT_BYTES: f64 = 21.0;
const GPS_INPUT_BYTES: f64 = 75.0;
const SYSTEM_TIME_BYTES: f64 = 24.0;
const ODOMETRY_BYTES: f64 = 244.0;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSettings {
    prefix: Option<String>,
    #[serde(default)]
    mavlink: MavlinkTable,
    output: OutputFile,
    #[serde(default)]
    health: HealthFile,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct MavlinkTable {
    system_id: Option<f64>,
    component_id: Option<f64>,
    mav_type: Option<f64>,
    gps_id: Option<f64>,
    gps_input_hz: Option<f64>,
    system_time_hz: Option<f64>,
    gps_leap_s: Option<f64>,
    #[serde(default)]
    odometry: OdometryTable,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct OdometryTable {
    enabled: Option<bool>,
    rate_hz: Option<f64>,
    frame: Option<String>,
    reanchor_km: Option<f64>,
}

/// ODOMETRY's settings, when enabled.
#[derive(Debug, Clone, PartialEq)]
pub struct OdometrySettings {
    pub rate_hz: f64,
    pub frame: OdometryFrame,
    pub reanchor_m: f64,
}

/// nav-mavlink's checked settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MavlinkSettings {
    /// Where they came from (a file, or "shipped settings").
    pub origin: String,
    pub prefix: String,
    pub system_id: u8,
    pub component_id: u8,
    pub mav_type: MavType,
    pub gps_id: u8,
    pub gps_input_hz: f64,
    pub system_time_hz: f64,
    pub gps_leap_s: u32,
    pub odometry: Option<OdometrySettings>,
    pub transport: Transport,
    pub health: HealthSettings,
}

fn id_bound(what: &'static str) -> Bound {
    Bound {
        lo: 1.0,
        hi: 255.0,
        unit: "",
        why: what,
    }
}

impl MavlinkSettings {
    /// Reads and checks `path`, or the shipped settings when `None`;
    /// `prefix` (the command line's) replaces the file's.
    pub fn load(path: Option<&Path>, prefix: Option<&str>) -> Result<Self, SettingsError> {
        let (raw, origin): (FileSettings, String) = match path {
            Some(p) => (read_toml(p)?, p.display().to_string()),
            None => (
                toml::from_str(SHIPPED).map_err(|e| SettingsError::Parse {
                    file: "shipped nav-mavlink.toml".into(),
                    detail: e.to_string(),
                })?,
                "shipped settings".into(),
            ),
        };
        let c = Checker {
            file: origin.clone(),
        };
        let m = &raw.mavlink;
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
        let system_id = c.int(
            "mavlink.system_id",
            m.system_id.unwrap_or(1.0),
            id_bound("MAVLink system ids are 1 to 255 (0 is broadcast, not a sender)"),
        )? as u8;
        let component_id = c.int(
            "mavlink.component_id",
            m.component_id.unwrap_or(191.0),
            id_bound("MAVLink component ids are 1 to 255 (0 is broadcast, not a sender)"),
        )? as u8;
        let mav_type_n = c.int(
            "mavlink.mav_type",
            m.mav_type.unwrap_or(18.0),
            Bound {
                lo: 0.0,
                hi: 255.0,
                unit: "",
                why: "MAV_TYPE is a uint8",
            },
        )?;
        let mav_type = mav_type_from(mav_type_n).ok_or_else(|| {
            c.key_error(
                "mavlink.mav_type",
                format!("{mav_type_n} is not a MAV_TYPE of the common dialect (18 = MAV_TYPE_ONBOARD_CONTROLLER)"),
            )
        })?;
        let gps_id = c.int(
            "mavlink.gps_id",
            m.gps_id.unwrap_or(0.0),
            Bound {
                lo: 0.0,
                hi: 9.0,
                unit: "",
                why: "autopilots take a handful of GPS instances (ArduPilot 0 and 1)",
            },
        )? as u8;
        let gps_input_hz = c.num(
            "mavlink.gps_input_hz",
            m.gps_input_hz.unwrap_or(5.0),
            Bound {
                lo: 1.0,
                hi: 50.0,
                unit: "Hz",
                why: "under 1 Hz an autopilot's GPS driver and EKF time the stream out between messages; \
                      over 50 Hz no autopilot's GPS driver fuses more, and the link is flooded",
            },
        )?;
        let system_time_hz = c.num(
            "mavlink.system_time_hz",
            m.system_time_hz.unwrap_or(1.0),
            Bound {
                lo: 0.1,
                hi: 10.0,
                unit: "Hz",
                why: "a clock needs no more than 10 per second, and a GCS shows one older than 10 s as stale",
            },
        )?;
        let gps_leap_s = c.int(
            "mavlink.gps_leap_s",
            m.gps_leap_s.unwrap_or(18.0),
            Bound {
                lo: 10.0,
                hi: 40.0,
                unit: "s",
                why: "GPS − UTC is 18 s since 2017 and changes by one second at a time, years apart",
            },
        )?;
        let o = &m.odometry;
        let odometry = if o.enabled.unwrap_or(false) {
            Some(OdometrySettings {
                rate_hz: c.num(
                    "mavlink.odometry.rate_hz",
                    o.rate_hz.unwrap_or(30.0),
                    Bound {
                        lo: 1.0,
                        hi: 200.0,
                        unit: "Hz",
                        why: "external navigation under 1 Hz is timed out by PX4 and ArduPilot; over 200 Hz \
                              exceeds what their estimators fuse",
                    },
                )?,
                frame: match o.frame.as_deref().unwrap_or("local_ned") {
                    "local_ned" => OdometryFrame::LocalNed,
                    "local_frd" => OdometryFrame::LocalFrd,
                    other => {
                        return Err(c.key_error(
                            "mavlink.odometry.frame",
                            format!("expected \"local_ned\" or \"local_frd\", got {other:?}"),
                        ));
                    }
                },
                reanchor_m: 1000.0
                    * c.num(
                        "mavlink.odometry.reanchor_km",
                        o.reanchor_km.unwrap_or(100.0),
                        Bound {
                            lo: 1.0,
                            hi: 1000.0,
                            unit: "km",
                            why: "under 1 km the frame jumps every few seconds at cruise; over 1000 km its \
                                  vertical is 9° off the local one",
                        },
                    )?,
            })
        } else {
            None
        };
        let transport = raw.output.check(&c, 115_200)?;
        let health = raw.health.check(&c)?;
        let s = Self {
            origin,
            prefix,
            system_id,
            component_id,
            mav_type,
            gps_id,
            gps_input_hz,
            system_time_hz,
            gps_leap_s,
            odometry,
            transport,
            health,
        };
        s.check_serial_capacity(&c)?;
        Ok(s)
    }

    /// A serial line must carry every message at its rate (10 bits a byte).
    fn check_serial_capacity(&self, c: &Checker) -> Result<(), SettingsError> {
        let Transport::Serial { baud, .. } = self.transport else {
            return Ok(());
        };
        let bytes_per_s = HEARTBEAT_BYTES
            + self.gps_input_hz * GPS_INPUT_BYTES
            + self.system_time_hz * SYSTEM_TIME_BYTES
            + self
                .odometry
                .as_ref()
                .map_or(0.0, |o| o.rate_hz * ODOMETRY_BYTES);
        let need = bytes_per_s * 10.0;
        if need > f64::from(baud) {
            return Err(c.key_error(
                "output.serial_baud",
                format!(
                    "{baud} baud cannot carry the messages at their rates ({need:.0} bit/s needed): \
                     raise the baud rate or lower mavlink.gps_input_hz / mavlink.odometry.rate_hz"
                ),
            ));
        }
        Ok(())
    }

    /// One line per setting, for the log at start.
    pub fn describe(&self) -> String {
        format!(
            "settings from {}: prefix {}, system {} component {} type {:?}, GPS_INPUT {} Hz (gps_id {}), \
             SYSTEM_TIME {} Hz, GPS−UTC {} s, ODOMETRY {}, output {:?}, health {:?}",
            self.origin,
            self.prefix,
            self.system_id,
            self.component_id,
            self.mav_type,
            self.gps_input_hz,
            self.gps_id,
            self.system_time_hz,
            self.gps_leap_s,
            match &self.odometry {
                Some(o) => format!(
                    "{} Hz in {:?} re-anchored every {} km",
                    o.rate_hz,
                    o.frame,
                    o.reanchor_m / 1000.0
                ),
                None => "off".into(),
            },
            self.transport,
            self.health
        )
    }
}

/// The common dialect's MAV_TYPE of a number.
fn mav_type_from(n: u32) -> Option<MavType> {
    <MavType as num_traits::FromPrimitive>::from_u32(n)
}

/// What a run did, for the log at the end.
#[derive(Debug, Default, Clone, Copy)]
pub struct Summary {
    pub heartbeats: u64,
    pub gps_inputs: u64,
    pub odometries: u64,
    pub solutions: u64,
    pub missed: u64,
    pub dropped: u64,
}

/// Runs the bridge until `stop`.
pub fn run(
    s: &MavlinkSettings,
    transport: &TransportConfig,
    stop: &AtomicBool,
) -> Result<Summary, RunError> {
    let c = Checker {
        file: s.origin.clone(),
    };
    let mut sink = Sink::open(&s.transport, &c)?;
    let mut feed = Feed::open(transport, "nav-mavlink")?;
    let mut notify = Notify::from_env();
    let start = Instant::now();
    let mut enc = Encoder::new(s.system_id, s.component_id);
    let mut hb = Every::new(Duration::from_secs(1), start);
    let mut gps = Every::from_hz(s.gps_input_hz, start);
    let mut clock = Every::from_hz(s.system_time_hz, start);
    let mut odo = s.odometry.as_ref().map(|o| {
        (
            Every::from_hz(o.rate_hz, start),
            Odometry::new(o.frame, o.reanchor_m),
        )
    });
    let mut sum = Summary::default();
    let mut last_fix: Option<Fix> = None;
    // The geoid of the last solution sent (seq, N): one evaluation per solution.
    let mut geoid: Option<(u64, f64)> = None;
    tracing::info!(
        output = ?s.transport,
        local = ?sink.local_addr(),
        "nav-mavlink sending as system {} component {} on {:?}",
        s.system_id,
        s.component_id,
        s.transport
    );
    notify.ready("waiting for the daemon");
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        feed.poll(now)?;
        let q = assess(&feed.heard(now), &s.health);
        let worse = last_fix.is_some_and(|f| q.fix < f);
        if last_fix != Some(q.fix) {
            let text = format!("fix {}", q.fix.name());
            if q.fix.usable() {
                tracing::info!(fix = q.fix.mavlink_fix_type(), "{text}");
            } else {
                tracing::warn!(fix = q.fix.mavlink_fix_type(), "{text}");
            }
            notify.status(&text);
            last_fix = Some(q.fix);
        }
        if hb.due(now) {
            sink.send(enc.encode(&mav::heartbeat(s.mav_type, q.fix)), now);
            sum.heartbeats += 1;
        }
        if gps.due(now) || worse {
            let sol = feed.solution();
            let n = match (sol, geoid) {
                (Some(x), Some((seq, n))) if seq == x.seq => n,
                (Some(x), _) => {
                    let n = crate::geo::geoid_undulation_m(x.lat_rad, x.lon_rad);
                    geoid = Some((x.seq, n));
                    n
                }
                (None, _) => 0.0,
            };
            let unix = bridge::unix_time_of(feed.solution_at().unwrap_or(now), now);
            let msg = mav::gps_input(sol, &q, n, s.gps_id, mav::gps_time(unix, s.gps_leap_s));
            sink.send(enc.encode(&msg), now);
            sum.gps_inputs += 1;
        }
        if clock.due(now) {
            let unix = bridge::unix_time_of(now, now);
            sink.send(enc.encode(&mav::system_time(unix, now - start)), now);
        }
        if let Some((every, o)) = &mut odo
            && every.due(now)
            && let Some(sol) = feed.solution()
            && let Some(msg) = o.message(sol, &q)
        {
            sink.send(enc.encode(&msg), now);
            sum.odometries += 1;
        }
        notify.ping(now);
        let odo_next = odo.as_ref().map_or(hb.next(), |(e, _)| e.next());
        bridge::sleep_until(
            &[hb.next(), gps.next(), clock.next(), odo_next],
            Instant::now(),
        );
    }
    notify.stopping();
    sum.solutions = feed.received;
    sum.missed = feed.missed;
    sum.dropped = sink.dropped;
    Ok(sum)
}
