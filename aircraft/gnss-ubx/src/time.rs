//! The receiver's time of a fix onto the sensor time base.
//!
//! **Assumption.** The flight computer's clock is disciplined to GNSS time
//! (chrony or ptp4l on the receiver's PPS and time messages), and every
//! sensor driver stamps `t_ns` as that clock's nanoseconds since one epoch,
//! the UTC instant `time.epoch_utc` (the same instant as `--utc-start` of
//! `nav-daemon batch` and `sensor-replay record`), counting SI seconds
//! without leap-second jumps, as GPS time does.
//!
//! **Rule.** A NAV-PVT fix is valid at GPS time `week · 604800 s + iTOW`;
//!
//! ```text
//! t_ns = (week · 604 800 000 + iTOW) · 10⁶            (GPS ns since 1980-01-06)
//!      − (epoch_utc − 1980-01-06T00:00:00Z + gps_utc_offset_s) · 10⁹
//!      + offset_s · 10⁹
//! ```
//!
//! where `gps_utc_offset_s` is GPS − UTC at the epoch (leap seconds: 18
//! since 2017; 0 for the default epoch, the GPS epoch itself, which makes
//! `t_ns` GPS time in ns) and `offset_s` a constant the clock's
//! discipline leaves (19 s for a clock kept in TAI, −18 s for one kept in
//! UTC with the epoch taken in GPS time, or a measured delay).
//!
//! **The week.** NAV-PVT has no week number. It is taken from the fix's
//! UTC date and time when both are flagged valid: the week whose start
//! plus iTOW is nearest to that date as GPS time (UTC + 18 s; a wrong
//! leap-second count moves it seconds, the choice tolerates 3.5 days, so
//! iTOW alone sets the instant to the millisecond). Without a valid date
//! the last week found is carried, advanced by one when iTOW falls back by
//! more than half a week (the week rolled over); before any, `time.week`
//! of the settings when given (not 0), else the fix is not published and
//! is counted (`no_week`). A fix before the epoch is counted
//! (`before_epoch`), never published with a wrapped stamp.

/// Milliseconds in a GPS week.
pub const WEEK_MS: u64 = 604_800_000;
/// 1980-01-06T00:00:00Z in Unix seconds.
pub const GPS_EPOCH_UNIX_S: i64 = 315_964_800;
/// GPS − UTC used only to pick the week from a fix's UTC date (any value
/// within days of the truth picks the same week).
pub const WEEK_PICK_LEAP_S: i64 = 18;

/// The date and time fields of a NAV-PVT (UTC) with its `valid` flags.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PvtDate {
    /// Year (UTC).
    pub year: u16,
    /// Month, 1..12.
    pub month: u8,
    /// Day of the month, 1..31.
    pub day: u8,
    /// Hour, 0..23.
    pub hour: u8,
    /// Minute, 0..59.
    pub min: u8,
    /// Second, 0..60.
    pub sec: u8,
    /// NAV-PVT `valid`: bit 0 validDate, bit 1 validTime.
    pub valid: u8,
}

/// Days from 1970-01-01 to a proleptic Gregorian date (H. Hinnant's
/// `days_from_civil`).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

fn days_in_month(y: i64, m: u8) -> u8 {
    match m {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        _ if (y % 4 == 0 && y % 100 != 0) || y % 400 == 0 => 29,
        _ => 28,
    }
}

impl PvtDate {
    /// Unix seconds of the date and time, if both are flagged valid and
    /// are a real date from 1980 to 2200.
    pub fn unix_s(&self) -> Option<i64> {
        if self.valid & 0b11 != 0b11 {
            return None;
        }
        let y = i64::from(self.year);
        let ok = (1980..=2200).contains(&y)
            && (1..=12).contains(&self.month)
            && (1..=days_in_month(y, self.month)).contains(&self.day)
            && self.hour <= 23
            && self.min <= 59
            && self.sec <= 60;
        ok.then(|| {
            days_from_civil(y, i64::from(self.month), i64::from(self.day)) * 86_400
                + i64::from(self.hour) * 3600
                + i64::from(self.min) * 60
                + i64::from(self.sec)
        })
    }

    /// The GPS week of a fix at `itow_ms` with this date, if the date is valid.
    pub fn week(&self, itow_ms: u32) -> Option<u32> {
        let gps_ms = (self.unix_s()? - GPS_EPOCH_UNIX_S + WEEK_PICK_LEAP_S) * 1000;
        let week = (gps_ms - i64::from(itow_ms) + (WEEK_MS / 2) as i64).div_euclid(WEEK_MS as i64);
        u32::try_from(week).ok()
    }
}

/// Why a fix got no stamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unstamped {
    /// No valid date yet and no `time.week`.
    NoWeek,
    /// Before the epoch of the sensor time base (or beyond u64 ns).
    BeforeEpoch,
}

/// How the week of a fix was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeekFrom {
    /// The fix's own UTC date.
    Date,
    /// The last week, across a rollover.
    Carried,
    /// `time.week` of the settings.
    Setting,
}

/// The rule with its settings, and the week carried between fixes.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeRule {
    /// GPS ns (since 1980-01-06) of sensor time 0.
    epoch_gps_ns: i128,
    gps_utc_offset_s: i64,
    offset_ns: i64,
    fallback_week: Option<u32>,
    /// The last fix's week and iTOW.
    last: Option<(u32, u32)>,
}

impl TimeRule {
    /// `epoch_unix_ns`: the epoch's UTC as Unix ns; the rest as in the
    /// module docs. Refuses an epoch before the GPS epoch.
    pub fn new(
        epoch_unix_ns: u64,
        gps_utc_offset_s: i64,
        offset_s: f64,
        fallback_week: Option<u32>,
    ) -> Result<Self, String> {
        let epoch_gps_ns = i128::from(epoch_unix_ns) - i128::from(GPS_EPOCH_UNIX_S) * 1_000_000_000
            + i128::from(gps_utc_offset_s) * 1_000_000_000;
        if epoch_gps_ns < 0 {
            return Err("expected an epoch at or after the GPS epoch 1980-01-06T00:00:00Z".into());
        }
        Ok(Self {
            epoch_gps_ns,
            gps_utc_offset_s,
            offset_ns: (offset_s * 1e9).round() as i64,
            fallback_week,
            last: None,
        })
    }

    /// GPS − UTC at the epoch (s).
    pub fn gps_utc_offset_s(&self) -> i64 {
        self.gps_utc_offset_s
    }

    /// The constant added to every stamp (ns).
    pub fn offset_ns(&self) -> i64 {
        self.offset_ns
    }

    /// `time.week`, if given.
    pub fn fallback_week(&self) -> Option<u32> {
        self.fallback_week
    }

    /// The week of a fix at `itow_ms` with `date`, and how it was found;
    /// remembers it for the fixes that follow.
    pub fn week(&mut self, itow_ms: u32, date: &PvtDate) -> Option<(u32, WeekFrom)> {
        let found = date
            .week(itow_ms)
            .map(|w| (w, WeekFrom::Date))
            .or_else(|| {
                self.last
                    .map(|(w, last_itow)| {
                        let rolled = u64::from(itow_ms) + WEEK_MS / 2 < u64::from(last_itow);
                        (w + u32::from(rolled), WeekFrom::Carried)
                    })
                    .or(self.fallback_week.map(|w| (w, WeekFrom::Setting)))
            })?;
        self.last = Some((found.0, itow_ms));
        Some(found)
    }

    /// `t_ns` of the GPS time `week`, `itow_ms`.
    pub fn t_ns(&self, week: u32, itow_ms: u32) -> Result<u64, Unstamped> {
        let gps_ns = (i128::from(week) * i128::from(WEEK_MS) + i128::from(itow_ms)) * 1_000_000;
        let t = gps_ns - self.epoch_gps_ns + i128::from(self.offset_ns);
        u64::try_from(t).map_err(|_| Unstamped::BeforeEpoch)
    }

    /// `t_ns` of a fix: [`Self::week`] then [`Self::t_ns`].
    pub fn stamp(&mut self, itow_ms: u32, date: &PvtDate) -> Result<(u64, WeekFrom), Unstamped> {
        let (week, from) = self.week(itow_ms, date).ok_or(Unstamped::NoWeek)?;
        Ok((self.t_ns(week, itow_ms)?, from))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GPS_EPOCH_NS: u64 = GPS_EPOCH_UNIX_S as u64 * 1_000_000_000;

    fn date(year: u16, month: u8, day: u8, hour: u8, min: u8, sec: u8) -> PvtDate {
        PvtDate {
            year,
            month,
            day,
            hour,
            min,
            sec,
            valid: 0b111,
        }
    }

    #[test]
    fn the_gps_epoch_is_week_zero_and_a_known_date_its_week() {
        assert_eq!(date(1980, 1, 6, 0, 0, 0).week(0), Some(0));
        // 2026-11-25 (a Wednesday) 18:00:00 UTC = GPS 18:00:18: week 2446,
        // iTOW = 3 days + 18 h + 18 s.
        let itow = ((3 * 24 + 18) * 3600 + 18) * 1000;
        assert_eq!(date(2026, 11, 25, 18, 0, 0).week(itow), Some(2446));
        // Sunday just after the GPS week start, UTC still Saturday.
        assert_eq!(date(2026, 11, 28, 23, 59, 50).week(8_000), Some(2447));
        // Days or a leap second off change nothing.
        assert_eq!(date(2026, 11, 27, 18, 0, 0).week(itow), Some(2446));
    }

    #[test]
    fn an_invalid_date_carries_the_last_week_across_a_rollover() {
        let mut r = TimeRule::new(GPS_EPOCH_NS, 0, 0.0, None).expect("rule");
        let none = PvtDate::default();
        assert_eq!(r.stamp(1000, &none), Err(Unstamped::NoWeek));
        let itow = WEEK_MS as u32 - 100;
        let (_, from) = r
            .stamp(itow, &date(2026, 11, 28, 23, 59, 42))
            .expect("dated");
        assert_eq!(from, WeekFrom::Date);
        let (t, from) = r.stamp(0, &none).expect("carried");
        assert_eq!(from, WeekFrom::Carried);
        assert_eq!(t, 2447 * WEEK_MS * 1_000_000);
    }

    #[test]
    fn the_stamp_is_gps_time_since_the_epoch_plus_the_offset() {
        // Epoch 2026-11-25T18:00:00Z, 18 leap seconds: a fix at that instant is t = 0.
        let epoch_unix_ns = 1_795_629_600u64 * 1_000_000_000;
        let itow = ((3 * 24 + 18) * 3600 + 18) * 1000;
        let mut r = TimeRule::new(epoch_unix_ns, 18, 0.0, None).expect("rule");
        let d = date(2026, 11, 25, 18, 0, 0);
        assert_eq!(r.stamp(itow, &d), Ok((0, WeekFrom::Date)));
        assert_eq!(r.stamp(itow + 100, &d).map(|x| x.0), Ok(100_000_000));
        assert_eq!(r.stamp(itow - 1, &d), Err(Unstamped::BeforeEpoch));
        let mut r = TimeRule::new(epoch_unix_ns, 18, 19.0, None).expect("rule");
        assert_eq!(r.stamp(itow, &d).map(|x| x.0), Ok(19_000_000_000));
        let mut r = TimeRule::new(GPS_EPOCH_NS, 0, 0.0, Some(2446)).expect("rule");
        assert!(
            TimeRule::new(0, 0, 0.0, None).is_err(),
            "an epoch before 1980"
        );
        assert_eq!(
            r.stamp(5, &PvtDate::default()).map(|x| x.1),
            Ok(WeekFrom::Setting)
        );
    }

    #[test]
    fn dates_that_do_not_exist_give_no_week() {
        for d in [
            date(2026, 2, 29, 0, 0, 0),
            date(2026, 13, 1, 0, 0, 0),
            date(2026, 0, 1, 0, 0, 0),
            date(1979, 12, 31, 0, 0, 0),
            date(2026, 1, 1, 24, 0, 0),
            PvtDate {
                valid: 0b01,
                ..date(2026, 1, 1, 0, 0, 0)
            },
        ] {
            assert_eq!(d.week(0), None, "{d:?}");
        }
        assert!(date(2024, 2, 29, 0, 0, 0).week(0).is_some());
    }
}
