//! Which solutions a decimating output writes (`batch --every SECONDS`):
//! one row per interval of sensor time, on a grid of whole multiples of the
//! interval, plus every row the session marks as a must (the first, a frame
//! switch, a reset or re-initialization, the last). The filter runs at the
//! full rate whatever is written; a row not written is not even built
//! ([`crate::session::Sink::wants_solution`]).

/// Longest interval accepted (s): about 31 years, beyond any flight.
pub const MAX_INTERVAL_S: f64 = 1e9;

/// The decision of a decimating output. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowInterval {
    every_ns: u64,
    /// The first grid time not yet written.
    next_ns: u64,
}

/// An interval that is not a positive, finite number of seconds up to
/// [`MAX_INTERVAL_S`].
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("expected an interval in seconds, above 0 and at most {MAX_INTERVAL_S:e}, got {0}")]
pub struct BadInterval(pub f64);

impl RowInterval {
    /// One row per `every_s` seconds of sensor time. An interval below 1 ns
    /// (the stamps' resolution) writes every row.
    pub fn new(every_s: f64) -> Result<Self, BadInterval> {
        if !(every_s.is_finite() && every_s > 0.0 && every_s <= MAX_INTERVAL_S) {
            return Err(BadInterval(every_s));
        }
        Ok(Self {
            every_ns: ((every_s * 1e9).round() as u64).max(1),
            next_ns: 0,
        })
    }

    /// The interval (ns).
    pub fn every_ns(&self) -> u64 {
        self.every_ns
    }

    /// Whether the solution at `t_ns` is written: the first at or after
    /// the next grid time, or a must. After a stamp that went back (a
    /// re-synchronized clock) the grid restarts from it.
    pub fn take(&mut self, t_ns: u64, must: bool) -> bool {
        let went_back = t_ns < self.next_ns.saturating_sub(self.every_ns);
        if t_ns >= self.next_ns || went_back {
            self.next_ns = (t_ns / self.every_ns)
                .saturating_add(1)
                .saturating_mul(self.every_ns);
            return true;
        }
        must
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows taken, against a direct count of grid cells entered.
    #[test]
    fn one_row_per_grid_cell_plus_the_musts() {
        let mut r = RowInterval::new(1.0).expect("interval");
        // 200 Hz from 0.003 s for 10 s, musts at samples 700 and 701.
        let mut taken = Vec::new();
        for k in 0..2000u64 {
            let t = 3_000_000 + k * 5_000_000;
            if r.take(t, k == 700 || k == 701) {
                taken.push(t);
            }
        }
        // Independent: the first sample of each whole second, by scanning.
        let mut want: Vec<u64> = (0..2000u64)
            .map(|k| 3_000_000 + k * 5_000_000)
            .filter(|t| *t == 3_000_000 || (t - 5_000_000) / 1_000_000_000 != t / 1_000_000_000)
            .collect();
        want.extend([3_503_000_000, 3_508_000_000]);
        want.sort_unstable();
        assert_eq!(taken, want);
    }

    #[test]
    fn absurd_intervals_are_refused_and_tiny_ones_take_every_row() {
        for bad in [
            0.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e300,
            1.0000001e9,
        ] {
            assert!(RowInterval::new(bad).is_err(), "{bad} accepted");
        }
        let mut tiny = RowInterval::new(1e-300).expect("tiny");
        assert!((0..1000).all(|k| tiny.take(k, false)));
        let mut huge = RowInterval::new(1e6).expect("huge");
        assert!(huge.take(5, false));
        assert!(!huge.take(999_999_000_000_000, false));
        assert!(huge.take(999_999_000_000_001, true));
        assert!(huge.take(1_000_000_000_000_000, false));
        // Stamps at the end of the u64 range: the next grid time saturates
        // at u64::MAX instead of wrapping to 0 (which would take every row).
        let mut end = RowInterval::new(1.0).expect("1 s");
        assert!(end.take(u64::MAX - 2_000_000_000, false));
        assert!(!end.take(u64::MAX - 1_999_999_999, false));
        assert!(end.take(u64::MAX - 1, false));
        assert_eq!(end.next_ns, u64::MAX);
        assert!(!end.take(u64::MAX - 1, false));
    }

    #[test]
    fn a_clock_that_went_back_restarts_the_grid() {
        let mut r = RowInterval::new(1.0).expect("1 s");
        assert!(r.take(100_000_000_000, false));
        assert!(!r.take(100_500_000_000, false));
        assert!(r.take(5_000_000_000, false));
        assert!(!r.take(5_500_000_000, false));
        assert!(r.take(6_000_000_000, false));
    }
}
