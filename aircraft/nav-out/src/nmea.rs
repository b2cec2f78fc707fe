//! NMEA 0183 sentences from the solution: GGA, RMC, VTG and HDT.
//!
//! Written here rather than with a crate: a sentence is a formatted line and
//! an XOR checksum, and the Rust NMEA crates are parsers; the independent
//! check is PyPI `pynmeagps` in the tests, which parses every sentence the
//! bridge sends and compares its values with the solution.
//!
//! Resolution of each field (the tests compare to half of it):
//! latitude and longitude in minutes with `minute_decimals` decimals (5 by
//! default: 1.9 cm; up to 7, as u-blox's high-precision mode, whose
//! sentences may pass the standard's 82 characters); altitude above mean
//! sea level and geoid separation in m with 2 decimals; speed over ground
//! in knots and km/h with 3 decimals; courses and heading in degrees with 2
//! decimals; HDOP with 2 decimals. Time (hhmmss.ss, UTC) and date (ddmmyy)
//! are those of the flight computer's clock when the bridge received the
//! solution (the clock is assumed disciplined to GNSS time, as for the
//! GNSS driver).

use std::fmt::Write as _;

use msgs::Solution;

use crate::geo;
use crate::health::{Fix, Quality};

/// m/s in one knot.
pub const KNOT_MPS: f64 = 1852.0 / 3600.0;

/// The sentences this bridge writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sentence {
    Gga,
    Rmc,
    Vtg,
    Hdt,
}

impl Sentence {
    pub const ALL: [Sentence; 4] = [Sentence::Gga, Sentence::Rmc, Sentence::Vtg, Sentence::Hdt];

    pub fn name(self) -> &'static str {
        match self {
            Sentence::Gga => "GGA",
            Sentence::Rmc => "RMC",
            Sentence::Vtg => "VTG",
            Sentence::Hdt => "HDT",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|x| x.name() == s)
    }
}

/// How the sentences are written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Format {
    /// Two-letter talker id (`GP`, `GN`, `IN` for integrated navigation).
    pub talker: String,
    /// The sentences of each epoch, in this order.
    pub sentences: Vec<Sentence>,
    /// Decimals of the minutes of latitude and longitude (4 to 7).
    pub minute_decimals: u32,
}

/// UTC of an epoch, split for NMEA.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Utc {
    pub year: i64,
    pub month: u32,
    pub day: u32,
    pub hour: u32,
    pub minute: u32,
    pub second: u32,
    pub centisecond: u32,
}

impl Utc {
    /// From time since the Unix epoch (rounded down to 1/100 s).
    pub fn from_unix(d: std::time::Duration) -> Self {
        let cs = d.as_millis() / 10;
        let secs = (cs / 100) as i64;
        let days = secs.div_euclid(86_400);
        let sod = secs.rem_euclid(86_400) as u32;
        // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
        let z = days + 719_468;
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
        let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
        let year = yoe + era * 400 + i64::from(month <= 2);
        Self {
            year,
            month,
            day,
            hour: sod / 3600,
            minute: sod / 60 % 60,
            second: sod % 60,
            centisecond: (cs % 100) as u32,
        }
    }

    fn time(&self) -> String {
        format!(
            "{:02}{:02}{:02}.{:02}",
            self.hour, self.minute, self.second, self.centisecond
        )
    }

    fn date(&self) -> String {
        format!(
            "{:02}{:02}{:02}",
            self.day,
            self.month,
            self.year.rem_euclid(100)
        )
    }
}

/// `$BODY*CS\r\n`: the checksum is the XOR of every byte between `$` and `*`.
pub fn frame(body: &str) -> String {
    let cs = body.bytes().fold(0u8, |a, b| a ^ b);
    format!("${body}*{cs:02X}\r\n")
}

/// The values one epoch's sentences are made of.
#[derive(Debug, Clone, Copy)]
pub struct Epoch<'a> {
    pub solution: Option<&'a Solution>,
    pub quality: &'a Quality,
    /// Geoid undulation N (m) at the solution's position.
    pub geoid_m: f64,
    pub utc: Utc,
}

impl Epoch<'_> {
    fn position(&self, f: &Format) -> String {
        let pos = self.solution.and_then(|s| {
            Some(format!(
                "{},{}",
                geo::nmea_angle(s.lat_rad.to_degrees(), f.minute_decimals, true)?,
                geo::nmea_angle(s.lon_rad.to_degrees(), f.minute_decimals, false)?
            ))
        });
        pos.unwrap_or_else(|| ",,,".to_owned())
    }

    /// Horizontal speed (m/s) and course over ground (° true), if known.
    fn ground_track(&self) -> Option<(f64, f64)> {
        let s = self.solution?;
        let [ve, vn, _] = s.v_enu_mps;
        (ve.is_finite() && vn.is_finite()).then(|| (ve.hypot(vn), geo::heading_deg(ve.atan2(vn))))
    }

    /// NMEA 2.3 mode indicator: A autonomous, E estimated (dead reckoning), N not valid.
    fn mode(&self) -> char {
        match self.quality.fix {
            Fix::Full => 'A',
            Fix::Degraded => 'E',
            Fix::NoFix | Fix::NoSource => 'N',
        }
    }

    fn gga(&self, f: &Format) -> String {
        let q = self.quality;
        // Fix quality: 1 GPS fix, 6 estimated (dead reckoning), 0 invalid.
        let quality = match q.fix {
            Fix::Full => 1,
            Fix::Degraded => 6,
            Fix::NoFix | Fix::NoSource => 0,
        };
        let hdop = q.hdop.map(|h| format!("{h:.2}")).unwrap_or_default();
        let (alt, sep) = match self.solution {
            Some(s) if s.h_m.is_finite() && self.geoid_m.is_finite() => (
                format!("{:.2}", s.h_m - self.geoid_m),
                format!("{:.2}", self.geoid_m),
            ),
            _ => (String::new(), String::new()),
        };
        format!(
            "{}GGA,{},{},{quality},{:02},{hdop},{alt},M,{sep},M,,",
            f.talker,
            self.utc.time(),
            self.position(f),
            q.satellites
        )
    }

    fn rmc(&self, f: &Format) -> String {
        let status = if self.quality.fix.usable() { 'A' } else { 'V' };
        let (sog, cog) = match self.ground_track() {
            Some((v, c)) => (format!("{:.3}", v / KNOT_MPS), format!("{c:.2}")),
            None => (String::new(), String::new()),
        };
        format!(
            "{}RMC,{},{status},{},{sog},{cog},{},,,{}",
            f.talker,
            self.utc.time(),
            self.position(f),
            self.utc.date(),
            self.mode()
        )
    }

    fn vtg(&self, f: &Format) -> String {
        let (cog, kn, kmh) = match self.ground_track() {
            Some((v, c)) => (
                format!("{c:.2}"),
                format!("{:.3}", v / KNOT_MPS),
                format!("{:.3}", v * 3.6),
            ),
            None => (String::new(), String::new(), String::new()),
        };
        format!("{}VTG,{cog},T,,M,{kn},N,{kmh},K,{}", f.talker, self.mode())
    }

    /// True heading; an empty field (NMEA's null) when the heading is not
    /// defined to `yaw_max_sigma_deg` ([`Quality::heading_rad`]): at and
    /// near the pole, and without a fix.
    fn hdt(&self, f: &Format) -> String {
        let h = self
            .quality
            .heading_rad
            .map(|h| format!("{:.2}", geo::heading_deg(h)))
            .unwrap_or_default();
        format!("{}HDT,{h},T", f.talker)
    }

    /// Every sentence of the epoch, framed, in the configured order.
    pub fn sentences(&self, f: &Format) -> String {
        let mut out = String::with_capacity(400);
        for s in &f.sentences {
            let body = match s {
                Sentence::Gga => self.gga(f),
                Sentence::Rmc => self.rmc(f),
                Sentence::Vtg => self.vtg(f),
                Sentence::Hdt => self.hdt(f),
            };
            let _ = write!(out, "{}", frame(&body));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::health::{HealthSettings, Heard, assess};
    use msgs::solution_flags;
    use std::time::Duration;

    #[test]
    fn checksum_of_a_known_sentence() {
        // The classic example of the NMEA 0183 literature.
        assert_eq!(
            frame("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"),
            "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n"
        );
    }

    #[test]
    fn utc_date_of_known_instants() {
        let u = Utc::from_unix(Duration::from_millis(951_782_400_000 + 3_723_450));
        assert_eq!((u.year, u.month, u.day), (2000, 2, 29));
        assert_eq!(u.time(), "010203.45");
        assert_eq!(u.date(), "290200");
        let u = Utc::from_unix(Duration::ZERO);
        assert_eq!((u.year, u.month, u.day), (1970, 1, 1));
    }

    #[test]
    fn sentences_at_the_north_pole_across_the_antimeridian() {
        let sol = Solution {
            lat_rad: std::f64::consts::FRAC_PI_2,
            lon_rad: std::f64::consts::PI,
            h_m: 18_000.0,
            v_enu_mps: [0.0, -100.0, 0.0],
            heading_rad: std::f64::consts::PI,
            flags: solution_flags::ALIGNED,
            sigma_pos_enu_m: [3.0, 4.0, 6.0],
            ..Default::default()
        };
        let h = HealthSettings::default();
        let q = assess(
            &Heard {
                solution: Some((&sol, 0.0)),
                status_age_s: Some(0.0),
                publisher_present: true,
            },
            &h,
        );
        let e = Epoch {
            solution: Some(&sol),
            quality: &q,
            geoid_m: 13.61,
            utc: Utc::from_unix(Duration::from_secs(0)),
        };
        let f = Format {
            talker: "GP".into(),
            sentences: Sentence::ALL.to_vec(),
            minute_decimals: 5,
        };
        let text = e.sentences(&f);
        let lines: Vec<&str> = text.split_terminator("\r\n").collect();
        assert_eq!(lines.len(), 4, "{text}");
        assert!(
            lines[0].starts_with(
                "$GPGGA,000000.00,9000.00000,N,18000.00000,W,1,11,1.00,17986.39,M,13.61,M,,*"
            ),
            "{}",
            lines[0]
        );
        assert!(
            lines[1].contains(",A,9000.00000,N,18000.00000,W,194.384,180.00,010170,,,A*"),
            "{}",
            lines[1]
        );
        // The heading at the exact pole is withheld: an empty field.
        assert!(lines[3].starts_with("$GPHDT,,T*"), "{}", lines[3]);
        for l in &lines {
            assert!(l.len() <= 80, "{l}: {} characters", l.len());
        }
    }
}
