//! The IMU stream's own rate against the configured one (`[live]
//! imu_rate_hz`). What depends on the configured rate keeps it: the bounds
//! checked at start (`filter.imu_gap_s`, `aids.max_latency_s`,
//! `live.imu_lost_periods`) and, live, the IMU-lost report and the cycle
//! overrun budget. When the stream's stamps say otherwise, the drivers say
//! so once, with both rates, instead of leaving the reader to find out.

/// Intervals measured before the rates are compared.
pub const SAMPLES: usize = 64;

/// Relative difference of the rates above which they disagree (an IMU's
/// clock is off by parts per million, a wrong setting by a factor).
pub const TOLERANCE: f64 = 0.1;

/// Measures the stream's rate from its first [`SAMPLES`] intervals
/// (their median, so a gap or a jump among them does not count), with no
/// allocation.
#[derive(Debug, Clone)]
pub struct RateCheck {
    configured_hz: f64,
    last_t_ns: Option<u64>,
    intervals_ns: [u64; SAMPLES],
    n: usize,
    done: bool,
}

/// The stream's rate disagrees with the configured one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disagreement {
    pub configured_hz: f64,
    pub measured_hz: f64,
    /// Median interval of the first [`SAMPLES`] samples (s).
    pub median_interval_s: f64,
}

impl RateCheck {
    pub fn new(configured_hz: f64) -> Self {
        Self {
            configured_hz,
            last_t_ns: None,
            intervals_ns: [0; SAMPLES],
            n: 0,
            done: false,
        }
    }

    /// Takes the stamp of an IMU sample as it is received. Returns the
    /// disagreement once, when the first [`SAMPLES`] intervals are in and
    /// their rate is off the configured one by more than [`TOLERANCE`];
    /// `None` before, after, and when they agree.
    pub fn observe(&mut self, t_ns: u64) -> Option<Disagreement> {
        if self.done {
            return None;
        }
        if let Some(prev) = self.last_t_ns
            && t_ns > prev
        {
            self.intervals_ns[self.n] = t_ns - prev;
            self.n += 1;
        }
        self.last_t_ns = Some(t_ns);
        if self.n < SAMPLES {
            return None;
        }
        self.done = true;
        let mut sorted = self.intervals_ns;
        sorted.sort_unstable();
        let median_interval_s = sorted[SAMPLES / 2] as f64 * 1e-9;
        let measured_hz = 1.0 / median_interval_s;
        ((measured_hz - self.configured_hz).abs() > TOLERANCE * self.configured_hz).then_some(
            Disagreement {
                configured_hz: self.configured_hz,
                measured_hz,
                median_interval_s,
            },
        )
    }
}

impl std::fmt::Display for Disagreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the IMU stream runs at {:.1} Hz (median interval {:.3} ms of its first {SAMPLES} \
             samples) but [live] imu_rate_hz = {} Hz: the bounds checked at start \
             (filter.imu_gap_s, aids.max_latency_s, live.imu_lost_periods) and, in the live \
             daemon, the IMU-lost report and the cycle overrun budget take the configured rate; \
             set imu_rate_hz = {:.0} to make them the stream's",
            self.measured_hz,
            self.median_interval_s * 1e3,
            self.configured_hz,
            self.measured_hz
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `n` samples every `period_ns` from `t0`; the reports returned.
    fn feed(check: &mut RateCheck, t0: u64, period_ns: u64, n: u64) -> Vec<Disagreement> {
        (0..n)
            .filter_map(|k| check.observe(t0 + k * period_ns))
            .collect()
    }

    #[test]
    fn a_100_hz_stream_under_a_200_hz_setting_is_reported_once_with_both_rates() {
        let mut c = RateCheck::new(200.0);
        let seen = feed(&mut c, 5_000_000_000, 10_000_000, 1000);
        assert_eq!(seen.len(), 1, "{seen:?}");
        let d = seen[0];
        assert!((d.measured_hz - 100.0).abs() < 1e-9, "{d:?}");
        assert!((d.median_interval_s - 0.01).abs() < 1e-15, "{d:?}");
        let text = d.to_string();
        assert!(
            text.contains("100.0 Hz") && text.contains("imu_rate_hz = 200 Hz"),
            "{text}"
        );
        // Once: a later stream at yet another rate says nothing more.
        assert!(feed(&mut c, 20_000_000_000, 1_000_000, 1000).is_empty());
    }

    #[test]
    fn a_stream_at_the_configured_rate_is_not_reported_whatever_gaps_it_has() {
        let mut c = RateCheck::new(200.0);
        // 200 Hz with a 3 s gap, a duplicate and a stamp that goes back
        // among its first samples: the median is still 5 ms.
        let mut stamps: Vec<u64> = (0..40).map(|k| k * 5_000_000).collect();
        stamps.push(stamps[39]);
        stamps.push(stamps[39] - 2_000_000);
        stamps.extend((0..60).map(|k| 3_200_000_000 + k * 5_000_000));
        assert!(stamps.iter().all(|t| c.observe(*t).is_none()));
        assert!(c.done, "the check ended");
    }

    #[test]
    fn the_tolerance_is_ten_percent() {
        // 5.5 ms (181.8 Hz) is 9.1 % off 200 Hz; 5.6 ms (178.6 Hz) 10.7 %.
        assert!(feed(&mut RateCheck::new(200.0), 0, 5_500_000, 100).is_empty());
        assert_eq!(feed(&mut RateCheck::new(200.0), 0, 5_600_000, 100).len(), 1);
    }
}
