//! Provenance of a written file: the program, its version and commit, the
//! command line, the optional UTC epoch of its time base, and every
//! effective setting with its source, as string maps for MCAP metadata
//! records (`polarnav.provenance`, `polarnav.settings`).

use std::collections::BTreeMap;

use crate::Effective;
use crate::build_info;

/// Nanoseconds in a second.
const NS: u64 = 1_000_000_000;

/// The `polarnav.provenance` record: `program` (e.g. `nav-daemon batch`),
/// `version`, `commit`, `command_line` (the arguments as given, each quoted
/// for a POSIX shell where it needs it) and, when given, `utc_start` (the
/// RFC 3339 text) with `utc_start_ns` (nanoseconds since 1970-01-01 UTC).
pub fn provenance(
    program: &str,
    args: &[String],
    utc_start: Option<&UtcStart>,
) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("program".into(), program.into());
    m.insert("version".into(), build_info::VERSION.into());
    m.insert("commit".into(), build_info::COMMIT.into());
    m.insert("command_line".into(), shell_words(args));
    if let Some(u) = utc_start {
        m.insert("utc_start".into(), u.text.clone());
        m.insert("utc_start_ns".into(), u.ns.to_string());
    }
    m
}

/// The `polarnav.settings` record: one entry per effective setting, its key
/// the setting's dotted key, its value `VALUE  # SOURCE` (as the start-up log
/// prints it: default, config file PATH, navlog header, command line).
pub fn settings(eff: &Effective) -> BTreeMap<String, String> {
    eff.settings()
        .into_iter()
        .map(|(k, v, place)| (k, format!("{v}  # {place}")))
        .collect()
}

/// Arguments joined by spaces, each single-quoted when it holds anything
/// but `A-Z a-z 0-9 _ - . / = : , +`.
fn shell_words(args: &[String]) -> String {
    args.iter()
        .map(|a| {
            let plain = !a.is_empty()
                && a.bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"_-./=:,+".contains(&b));
            if plain {
                a.clone()
            } else {
                format!("'{}'", a.replace('\'', r"'\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// A UTC epoch given as RFC 3339 text: the UTC time of sensor time 0 of a
/// log's time base, so that written log times are dates.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UtcStart {
    /// The text as given.
    pub text: String,
    /// Nanoseconds since 1970-01-01T00:00:00Z (leap seconds not counted, as in Unix time).
    pub ns: u64,
}

impl UtcStart {
    /// Parses `YYYY-MM-DDTHH:MM:SS[.fraction](Z|±HH:MM)` (RFC 3339; `t`,
    /// `z` and a space for `T` accepted), from 1970 to 2200. The error
    /// says what was expected and what was found.
    pub fn parse(text: &str) -> Result<Self, String> {
        let ns = parse_rfc3339(text).map_err(|what| {
            format!(
                "expected an RFC 3339 UTC time such as 2026-11-25T18:00:00Z, got {text:?}: {what}"
            )
        })?;
        Ok(Self {
            text: text.to_owned(),
            ns,
        })
    }
}

fn parse_rfc3339(t: &str) -> Result<u64, String> {
    let b = t.as_bytes();
    let digits = |from: usize, n: usize, what: &str| -> Result<u64, String> {
        let s = b
            .get(from..from + n)
            .filter(|s| s.iter().all(u8::is_ascii_digit))
            .ok_or_else(|| format!("{what} is not {n} digits at byte {from}"))?;
        Ok(s.iter().fold(0, |v, d| v * 10 + u64::from(d - b'0')))
    };
    let sep = |at: usize, want: &[u8], what: &str| -> Result<(), String> {
        match b.get(at) {
            Some(c) if want.contains(c) => Ok(()),
            _ => Err(format!("expected {what} at byte {at}")),
        }
    };
    let year = digits(0, 4, "the year")?;
    sep(4, b"-", "'-'")?;
    let month = digits(5, 2, "the month")?;
    sep(7, b"-", "'-'")?;
    let day = digits(8, 2, "the day")?;
    sep(10, b"Tt ", "'T'")?;
    let hour = digits(11, 2, "the hour")?;
    sep(13, b":", "':'")?;
    let minute = digits(14, 2, "the minute")?;
    sep(16, b":", "':'")?;
    let second = digits(17, 2, "the second")?;
    let mut i = 19;
    let mut frac_ns = 0u64;
    if b.get(i) == Some(&b'.') {
        i += 1;
        let start = i;
        while b.get(i).is_some_and(u8::is_ascii_digit) {
            if i - start < 9 {
                frac_ns = frac_ns * 10 + u64::from(b[i] - b'0');
            }
            i += 1;
        }
        if i == start {
            return Err("no digit after '.'".into());
        }
        for _ in (i - start)..9 {
            frac_ns *= 10;
        }
    }
    let offset_s: i64 = match b.get(i) {
        Some(b'Z' | b'z') => {
            i += 1;
            0
        }
        Some(c @ (b'+' | b'-')) => {
            let sign = if *c == b'+' { 1 } else { -1 };
            let oh = digits(i + 1, 2, "the offset hours")?;
            sep(i + 3, b":", "':' in the offset")?;
            let om = digits(i + 4, 2, "the offset minutes")?;
            if oh > 23 || om > 59 {
                return Err(format!("offset {oh:02}:{om:02} out of range"));
            }
            i += 6;
            sign * (oh * 3600 + om * 60) as i64
        }
        _ => return Err(format!("expected Z or an offset ±HH:MM at byte {i}")),
    };
    if i != b.len() {
        return Err(format!("unexpected text after the time at byte {i}"));
    }
    if !(1970..=2200).contains(&year) {
        return Err(format!("year {year} outside 1970..=2200"));
    }
    let leap = year % 4 == 0 && (year % 100 != 0 || year % 400 == 0);
    let days_in = match month {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        2 if leap => 29,
        2 => 28,
        _ => return Err(format!("month {month} outside 1..=12")),
    };
    if !(1..=days_in).contains(&day) {
        return Err(format!("day {day} outside 1..={days_in} of month {month}"));
    }
    // A leap second (:60) is folded onto the next second, as Unix time does.
    if hour > 23 || minute > 59 || second > 60 {
        return Err(format!(
            "time {hour:02}:{minute:02}:{second:02} out of range"
        ));
    }
    let days = days_from_civil(year as i64, month as i64, day as i64);
    let secs = days * 86_400 + (hour * 3600 + minute * 60 + second) as i64 - offset_s;
    let secs = u64::try_from(secs).map_err(|_| "before 1970-01-01T00:00:00Z".to_string())?;
    Ok(secs * NS + frac_ns)
}

/// Days from 1970-01-01 to the proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_times_read_as_unix_nanoseconds() {
        for (text, ns) in [
            ("1970-01-01T00:00:00Z", 0),
            ("2000-03-01T00:00:00Z", 951_868_800 * NS),
            // `date -u -d 2026-11-25T18:30:15 +%s` = 1795631415
            ("2026-11-25T18:30:15Z", 1_795_631_415 * NS),
            ("2026-11-25t18:30:15.25z", 1_795_631_415 * NS + 250_000_000),
            ("2026-11-25 20:30:15+02:00", 1_795_631_415 * NS),
            (
                "2026-11-25T13:00:15.123456789123-05:30",
                1_795_631_415 * NS + 123_456_789,
            ),
            ("2024-02-29T00:00:00Z", 1_709_164_800 * NS),
        ] {
            assert_eq!(UtcStart::parse(text).map(|u| u.ns), Ok(ns), "{text}");
        }
    }

    #[test]
    fn absurd_times_are_refused_with_what_is_wrong() {
        for (text, why) in [
            ("", "year"),
            ("2026-11-25", "'T'"),
            ("2026-11-25T18:30:15", "Z or an offset"),
            ("2026-13-01T00:00:00Z", "month 13"),
            ("2025-02-29T00:00:00Z", "day 29"),
            ("2026-11-25T24:00:00Z", "out of range"),
            ("1969-12-31T23:59:59Z", "year 1969"),
            ("1970-01-01T00:00:00+01:00", "before 1970"),
            ("9999-01-01T00:00:00Z", "year 9999"),
            ("2026-11-25T18:30:15.Z", "no digit"),
            ("2026-11-25T18:30:15Zjunk", "unexpected text"),
            ("2026-11-25T18:30:15+2:00", "offset hours"),
            ("２026-11-25T18:30:15Z", "year"),
        ] {
            let e = UtcStart::parse(text).expect_err(text);
            assert!(e.contains(why) && e.contains("RFC 3339"), "{text}: {e}");
        }
    }

    #[test]
    fn command_lines_quote_what_a_shell_would_split() {
        let args: Vec<String> = ["nav-daemon", "batch", "--out", "a b.mcap", "it's", ""]
            .map(String::from)
            .to_vec();
        assert_eq!(
            shell_words(&args),
            r"nav-daemon batch --out 'a b.mcap' 'it'\''s' ''"
        );
    }
}
