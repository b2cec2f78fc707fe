//! Min/max envelope per time column: a long flight (10 M rows) is drawn
//! as the smallest and largest value of each channel in each of about as
//! many time columns as the figure has pixels, not as every point. Rows
//! stream in once; memory is fixed (columns × channels), whatever the length.
//!
//! The columns start 1 ms wide from the first time seen; when a time falls
//! beyond the last column, neighbouring columns merge pairwise and the width
//! doubles, so a flight always ends with between `COLUMNS / 2` and `COLUMNS`
//! columns in use and no second pass over the data.

/// Columns kept (about the plot width in pixels of the widest figure).
pub const COLUMNS: usize = 2048;

/// The envelope of `k` channels over time.
#[derive(Debug, Clone)]
pub struct Envelope {
    k: usize,
    t0: f64,
    width_s: f64,
    lo: Vec<f64>,
    hi: Vec<f64>,
    count: Vec<u32>,
    /// Samples pushed (rows with a finite time).
    pub samples: u64,
}

impl Envelope {
    pub fn new(k: usize) -> Self {
        Self {
            k,
            t0: f64::NAN,
            width_s: 1e-3,
            lo: vec![f64::INFINITY; k * COLUMNS],
            hi: vec![f64::NEG_INFINITY; k * COLUMNS],
            count: vec![0; COLUMNS],
            samples: 0,
        }
    }

    /// Adds the values of one time (`v.len()` must be the channel count;
    /// extra values are ignored, missing ones count as absent). A non-finite
    /// time is ignored; a time before the first goes into the first column;
    /// a non-finite value is absent from its channel.
    pub fn push(&mut self, t: f64, v: &[f64]) {
        if !t.is_finite() {
            return;
        }
        if self.t0.is_nan() {
            self.t0 = t;
        }
        let mut i = ((t - self.t0) / self.width_s).floor().max(0.0);
        while i >= COLUMNS as f64 {
            self.halve();
            i = ((t - self.t0) / self.width_s).floor().max(0.0);
        }
        let i = i as usize;
        self.count[i] = self.count[i].saturating_add(1);
        self.samples += 1;
        for (c, x) in v.iter().take(self.k).enumerate() {
            if x.is_finite() {
                let j = i * self.k + c;
                self.lo[j] = self.lo[j].min(*x);
                self.hi[j] = self.hi[j].max(*x);
            }
        }
    }

    fn halve(&mut self) {
        let k = self.k;
        for j in 0..COLUMNS / 2 {
            let (a, b) = (2 * j, 2 * j + 1);
            self.count[j] = self.count[a].saturating_add(self.count[b]);
            for c in 0..k {
                self.lo[j * k + c] = self.lo[a * k + c].min(self.lo[b * k + c]);
                self.hi[j * k + c] = self.hi[a * k + c].max(self.hi[b * k + c]);
            }
        }
        for j in COLUMNS / 2..COLUMNS {
            self.count[j] = 0;
            for c in 0..k {
                self.lo[j * k + c] = f64::INFINITY;
                self.hi[j * k + c] = f64::NEG_INFINITY;
            }
        }
        self.width_s *= 2.0;
    }

    /// Column width (s).
    pub fn width_s(&self) -> f64 {
        self.width_s
    }

    /// (time of the column's middle, min, max) of channel `c` for every
    /// column where it has a value.
    pub fn column_range(&self, c: usize) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        (0..COLUMNS).filter_map(move |i| {
            let j = i * self.k + c;
            (c < self.k && self.count[i] > 0 && self.lo[j] <= self.hi[j]).then(|| {
                (
                    self.t0 + (i as f64 + 0.5) * self.width_s,
                    self.lo[j],
                    self.hi[j],
                )
            })
        })
    }

    /// Channel `c` as a polyline through each column's min and max: drawn,
    /// it fills the column's range, as every point would.
    pub fn line(&self, c: usize, scale: f64) -> Vec<(f64, f64)> {
        self.column_range(c)
            .flat_map(|(t, lo, hi)| [(t, lo * scale), (t, hi * scale)])
            .collect()
    }

    /// A band from the minimum of channel `lo` to the maximum of `hi`.
    pub fn band(&self, lo: usize, hi: usize, scale: f64) -> Vec<(f64, f64, f64)> {
        self.column_range(lo)
            .zip(self.column_range(hi))
            .filter(|(a, b)| a.0.to_bits() == b.0.to_bits())
            .map(|(a, b)| (a.0, a.1 * scale, b.2 * scale))
            .collect()
    }

    /// The symmetric band ±`factor`·(max of channel `c`).
    pub fn symmetric_band(&self, c: usize, factor: f64) -> Vec<(f64, f64, f64)> {
        self.column_range(c)
            .map(|(t, _, hi)| (t, -factor * hi, factor * hi))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each column holds exactly the min and max of the samples that fell
    /// into it, computed here independently by brute force.
    #[test]
    fn columns_hold_the_min_and_max_of_their_samples() {
        let n = 100_000;
        let mut e = Envelope::new(2);
        let f = |i: usize| ((i as f64) * 0.37).sin() * (1.0 + (i % 7) as f64);
        for i in 0..n {
            e.push(i as f64 * 0.01, &[f(i), -f(i)]);
        }
        assert_eq!(e.samples, n as u64);
        let w = e.width_s();
        let cols: Vec<_> = e.column_range(0).collect();
        assert!(
            cols.len() > COLUMNS / 2 && cols.len() <= COLUMNS,
            "{}",
            cols.len()
        );
        for (t, lo, hi) in cols {
            let (a, b) = (t - w / 2.0, t + w / 2.0);
            let vals: Vec<f64> = (0..n)
                .filter(|&i| {
                    let ti = i as f64 * 0.01;
                    ti >= a - 1e-9 && ti < b - 1e-9
                })
                .map(f)
                .collect();
            let want_lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
            let want_hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert!(
                (lo - want_lo).abs() < 1e-12 && (hi - want_hi).abs() < 1e-12,
                "t {t}"
            );
        }
    }

    #[test]
    fn absurd_times_and_values_do_not_panic() {
        let mut e = Envelope::new(1);
        e.push(f64::NAN, &[1.0]);
        e.push(5.0, &[f64::NAN]);
        e.push(1.0, &[2.0]); // before the first: first column
        e.push(1e300, &[3.0]);
        e.push(f64::INFINITY, &[4.0]);
        e.push(6.0, &[]);
        assert_eq!(e.samples, 4);
        assert!(e.line(0, 1.0).iter().all(|p| p.1.is_finite()));
        assert_eq!(e.line(5, 1.0).len(), 0);
    }
}
