//! What the accuracy figures ([`crate::plots`]) draw, gathered as a flight
//! streams in and reduced at its end to what they show.
//!
//! A figure draws the points [`crate::plots`] picks from a sequence with a
//! step of `len / 5000`, scales its axis to every point, and titles its
//! panels with sums over every point. The sums and extremes are kept as
//! the points come; the points themselves go to [`Spill`]s on disk, from
//! which the picked ones are read back once the lengths are known. Memory
//! holds the counters and buffers while streaming, and the picked points
//! (about 5 000 to 10 000 per curve) at the end, whatever the flight's
//! length.

use std::collections::VecDeque;
use std::io;

use msgs::TruthRecord;
use msgs::navlog::TruthBias;
use polarnav::solution_csv::Row;

use crate::eval::Epoch;
use crate::solution_file::{Aids, UpdatesOnDisk};
use crate::spill::{Sealed, Spill, kth_smallest, total_order_key};

/// The figures' units: radians to arcminutes, rad/s to °/h, m/s² to µg.
pub(crate) const ARCMIN: f64 = 60.0 * 180.0 / std::f64::consts::PI;
pub(crate) const DEG_PER_H: f64 = 180.0 / std::f64::consts::PI * 3600.0;
pub(crate) const MICRO_G: f64 = 1e6 / 9.80665;
/// At most this many points per curve (decimated by a fixed step).
pub(crate) const MAX_POINTS: usize = 5000;

/// A frame switch of the solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Switch {
    pub t_s: f64,
    pub lat_deg: f64,
    pub r_e_m: [f64; 3],
    /// e.g. `g→G 88.0°N`.
    pub label: String,
}

/// The frame changes between consecutive rows.
pub fn switches(rows: &[Row]) -> Vec<Switch> {
    rows.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| Switch {
            t_s: w[1].t_s,
            lat_deg: w[1].lat_deg,
            r_e_m: w[1].r_e_m,
            label: format!(
                "{}→{} {:.1}°{}",
                w[0].frame,
                w[1].frame,
                w[1].lat_deg.abs(),
                if w[1].lat_deg >= 0.0 { 'N' } else { 'S' }
            ),
        })
        .collect()
}

/// The row of each epoch's time (rows and epochs both time-ordered).
pub(crate) fn rows_at<'a>(rows: &'a [Row], epochs: &[Epoch]) -> Vec<Option<&'a Row>> {
    let mut k = 0;
    epochs
        .iter()
        .map(|e| {
            while k + 1 < rows.len() && rows[k].t_s < e.t_s - 1e-7 {
                k += 1;
            }
            rows.get(k).filter(|r| (r.t_s - e.t_s).abs() < 1e-6)
        })
        .collect()
}

/// The step `plots` takes through a sequence of `n` points.
pub(crate) fn step_of(n: u64) -> u64 {
    (n / MAX_POINTS as u64).max(1)
}

/// The extremes of the finite values seen (∞, −∞ without any), as the
/// figures fold them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Extent {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
}

impl Default for Extent {
    fn default() -> Self {
        Self {
            lo: f64::INFINITY,
            hi: f64::NEG_INFINITY,
        }
    }
}

impl Extent {
    fn push(&mut self, v: f64) {
        if v.is_finite() {
            self.lo = self.lo.min(v);
            self.hi = self.hi.max(v);
        }
    }
}

/// The sum of no value, as `Iterator::sum` starts it (so that a running
/// sum equals the figures' `sum()` bit for bit).
fn empty_sum() -> f64 {
    std::iter::empty::<f64>().sum()
}

/// The error components of an epoch drawn by the error figures, in their
/// units: position E/N/U (m), velocity nav x/y/z (m/s), attitude nav x/y/z
/// (arcmin).
pub(crate) fn error_components(e: &Epoch) -> [f64; 9] {
    [
        e.pos_enu.x,
        e.pos_enu.y,
        e.pos_enu.z,
        e.vel_nav.x,
        e.vel_nav.y,
        e.vel_nav.z,
        e.att_nav.x * ARCMIN,
        e.att_nav.y * ARCMIN,
        e.att_nav.z * ARCMIN,
    ]
}

/// The σ of a row matching [`error_components`].
pub(crate) fn sigma_components(r: &Row) -> [f64; 9] {
    [
        r.sigma_enu_m[0],
        r.sigma_enu_m[1],
        r.sigma_enu_m[2],
        r.sigma_vel_nav_mps[0],
        r.sigma_vel_nav_mps[1],
        r.sigma_vel_nav_mps[2],
        r.sigma_att_deg[0] * 60.0,
        r.sigma_att_deg[1] * 60.0,
        r.sigma_att_deg[2] * 60.0,
    ]
}

/// The differences `compare_difference` draws of two epochs at one time.
pub(crate) fn difference_components(a: &Epoch, b: &Epoch) -> [f64; 5] {
    [
        b.pos_enu.x - a.pos_enu.x,
        b.pos_enu.y - a.pos_enu.y,
        b.pos_enu.z - a.pos_enu.z,
        (b.vel_enu - a.vel_enu).norm(),
        (b.att_enu.z - a.att_enu.z) * ARCMIN,
    ]
}

/// Words of a row in [`RunFeed::rows`].
const ROW_WORDS: usize = 18;

/// One run's sequences.
#[derive(Debug)]
struct RunFeed {
    /// Rows: t, ECEF position (3), latitude (deg), gyro bias (3, rad/s),
    /// accelerometer bias (3, m/s²), their σ (6, NaN where the row has
    /// none), and which σ the row has (1 gyro + 2 accelerometer).
    rows: Spill<ROW_WORDS>,
    last_row: Option<Row>,
    /// Epochs: t, the 9 error components, the cumulative horizontal RMSE.
    epochs: Spill<11>,
    last_epoch_t: Option<f64>,
    cum_sum: f64,
    cum_hi: f64,
    hmax: f64,
}

impl RunFeed {
    fn new() -> io::Result<Self> {
        Ok(Self {
            rows: Spill::new()?,
            last_row: None,
            epochs: Spill::new()?,
            last_epoch_t: None,
            cum_sum: 0.0,
            cum_hi: 1e-3,
            hmax: 0.0,
        })
    }
}

/// The first run's error figures: the errors against its ±3σ, paired in
/// order as the figures zip them.
#[derive(Debug)]
struct ErrorFeed {
    /// Bands: t, the 9 σ of the row at the epoch.
    bands: Spill<10>,
    extent: [Extent; 9],
    sum_sq: [f64; 9],
    inside: [u64; 9],
    /// Finite band values per component (for the 99th percentile).
    finite: [u64; 9],
    errors_waiting: VecDeque<[f64; 9]>,
    bands_waiting: VecDeque<[f64; 9]>,
}

/// The difference of the second run from the first at common epochs.
#[derive(Debug)]
struct PairFeed {
    /// t and the 5 differences.
    pairs: Spill<6>,
    extent: [Extent; 5],
    max_abs: [f64; 5],
}

/// What the figures need, fed in the order of the flight: rows of each
/// run in file order, epochs of each run in truth order, the truth and
/// truth bias in log order.
#[derive(Debug)]
pub struct FigureFeed {
    labels: Vec<String>,
    runs: Vec<RunFeed>,
    errors: ErrorFeed,
    pairs: PairFeed,
    switches: Vec<Switch>,
    /// Truth ECEF positions.
    truth: Spill<3>,
    /// Truth bias: t and gyro (3, rad/s), accelerometer (3, m/s²).
    truth_bias: Spill<7>,
    tb_extent: [Extent; 6],
    tb_last: [f64; 6],
    /// A row of the first run carries the gyro bias σ.
    bias_sigma_any: bool,
}

/// A sequence of points as a panel draws it: the points picked, and the
/// extent of every point.
#[derive(Debug, Clone, Default)]
pub(crate) struct Curve {
    pub(crate) pts: Vec<(f64, f64)>,
    pub(crate) extent: (f64, f64),
}

/// One error component of the first run.
#[derive(Debug, Clone, Default)]
pub(crate) struct ErrorCurve {
    pub(crate) err: Curve,
    /// The ±3σ band picked, and the 99th percentile of |±3σ| over all.
    pub(crate) band: Vec<(f64, f64, f64)>,
    pub(crate) band_q99: f64,
    /// Errors and bands in all, the errors' sum of squares, and the errors
    /// inside the band of the same rank.
    pub(crate) n_err: u64,
    pub(crate) n_band: u64,
    pub(crate) sum_sq: f64,
    pub(crate) inside: u64,
}

/// The reduced data of every accuracy figure.
#[derive(Debug, Clone, Default)]
pub struct FigureData {
    pub(crate) labels: Vec<String>,
    pub(crate) switches: Vec<Switch>,
    pub(crate) t_max: f64,
    /// The first run's 9 error components.
    pub(crate) errors: Vec<ErrorCurve>,
    /// The first run's rows taken with the step `plots` takes through them:
    /// (t, [gyro (°/h), accel (µg)]) per row.
    pub(crate) bias_rows: Vec<(f64, [f64; 6])>,
    /// The σ of the same rows' biases (°/h, µg), where a row carries them
    /// (gyro and accelerometer each), and whether any row of the first run
    /// carries the gyro σ.
    pub(crate) bias_sigma: Vec<[Option<f64>; 6]>,
    pub(crate) bias_sigma_any: bool,
    /// Per bias component, the share of the truth-bias records inside the
    /// ±3σ band ([`bias_band`]) at its last point at or before them; `None`
    /// without a band or a record inside its span.
    pub(crate) truth_bias_inside: [Option<f64>; 6],
    /// The truth bias per component (°/h, µg), its last value.
    pub(crate) truth_bias: Vec<Curve>,
    pub(crate) truth_bias_last: [f64; 6],
    pub(crate) truth_bias_n: u64,
    /// The cumulative horizontal RMSE of each run, and the highest value.
    pub(crate) cumulative: Vec<Curve>,
    pub(crate) cumulative_hi: f64,
    /// Differences (second − first run) per quantity, their largest |Δ|,
    /// and the common epochs.
    pub(crate) compare: Vec<Curve>,
    pub(crate) compare_max: [f64; 5],
    pub(crate) compare_n: u64,
    /// Track: rows of the first run, the latitude of its middle row, the
    /// ECEF positions picked of its rows, of the truth and of the second
    /// run, and the first run's largest horizontal error.
    pub(crate) rows_n: u64,
    pub(crate) middle_lat_deg: f64,
    pub(crate) track: Vec<[f64; 3]>,
    pub(crate) track_truth: Vec<[f64; 3]>,
    pub(crate) track_compare: Option<Vec<[f64; 3]>>,
    pub(crate) hmax: f64,
    /// Each run's horizontal distance from the truth (m) at its epochs
    /// picked with the step `plots` takes through them.
    pub(crate) distance: Vec<Vec<(f64, f64)>>,
    /// The aid updates of the first run (an MCAP solution).
    pub(crate) aids: Option<Aids<UpdatesOnDisk>>,
}

impl FigureFeed {
    /// A feed for runs named `labels` (the first is the solution, a second
    /// the comparison).
    pub fn new(labels: &[&str]) -> io::Result<Self> {
        Ok(Self {
            labels: labels.iter().map(|l| (*l).to_owned()).collect(),
            runs: labels
                .iter()
                .map(|_| RunFeed::new())
                .collect::<io::Result<_>>()?,
            errors: ErrorFeed {
                bands: Spill::new()?,
                extent: [Extent::default(); 9],
                sum_sq: [empty_sum(); 9],
                inside: [0; 9],
                finite: [0; 9],
                errors_waiting: VecDeque::new(),
                bands_waiting: VecDeque::new(),
            },
            pairs: PairFeed {
                pairs: Spill::new()?,
                extent: [Extent::default(); 5],
                max_abs: [0.0; 5],
            },
            switches: Vec::new(),
            truth: Spill::new()?,
            truth_bias: Spill::new()?,
            tb_extent: [Extent::default(); 6],
            tb_last: [f64::NAN; 6],
            bias_sigma_any: false,
        })
    }

    /// The next row of run `k`, in file order.
    pub fn row(&mut self, k: usize, r: &Row) -> io::Result<()> {
        let run = &mut self.runs[k];
        let [x, y, z] = r.r_e_m;
        let [gx, gy, gz] = r.gyro_bias_rps;
        let [ax, ay, az] = r.accel_bias_mps2;
        let [sgx, sgy, sgz] = r.sigma_gyro_bias_rps.unwrap_or([f64::NAN; 3]);
        let [sax, say, saz] = r.sigma_accel_bias_mps2.unwrap_or([f64::NAN; 3]);
        let has = u8::from(r.sigma_gyro_bias_rps.is_some())
            | u8::from(r.sigma_accel_bias_mps2.is_some()) << 1;
        run.rows.push_f64(&[
            r.t_s,
            x,
            y,
            z,
            r.lat_deg,
            gx,
            gy,
            gz,
            ax,
            ay,
            az,
            sgx,
            sgy,
            sgz,
            sax,
            say,
            saz,
            f64::from(has),
        ])?;
        if k == 0 {
            self.bias_sigma_any |= r.sigma_gyro_bias_rps.is_some();
        }
        if k == 0
            && let Some(p) = &run.last_row
            && p.frame != r.frame
        {
            self.switches.extend(switches(&[*p, *r]));
        }
        run.last_row = Some(*r);
        Ok(())
    }

    /// The next epoch of run `k`, in truth order.
    pub fn epoch(&mut self, k: usize, e: &Epoch) -> io::Result<()> {
        let c = error_components(e);
        let run = &mut self.runs[k];
        run.cum_sum += e.pos_enu.xy().norm_squared();
        let n = run.epochs.len() + 1;
        let cum = (run.cum_sum / n as f64).sqrt();
        run.cum_hi = run.cum_hi.max(cum);
        let mut rec = [0.0; 11];
        rec[0] = e.t_s;
        rec[1..10].copy_from_slice(&c);
        rec[10] = cum;
        run.epochs.push_f64(&rec)?;
        run.last_epoch_t = Some(e.t_s);
        if k == 0 {
            run.hmax = run.hmax.max(e.pos_enu.xy().norm());
            let f = &mut self.errors;
            for (i, v) in c.iter().enumerate() {
                f.extent[i].push(*v);
                f.sum_sq[i] += v * v;
            }
            f.errors_waiting.push_back(c);
            f.pair_up();
        }
        Ok(())
    }

    /// The next ±3σ band of the first run's error figures: the σ of the
    /// row of an epoch at time `t` (the figures' n-th band goes with their
    /// n-th error).
    pub fn band(&mut self, t: f64, sigma: &[f64; 9]) -> io::Result<()> {
        let f = &mut self.errors;
        let mut rec = [0.0; 10];
        rec[0] = t;
        rec[1..].copy_from_slice(sigma);
        f.bands.push_f64(&rec)?;
        for (i, s) in sigma.iter().enumerate() {
            f.finite[i] += u64::from((3.0 * s).is_finite());
        }
        f.bands_waiting.push_back(*sigma);
        f.pair_up();
        Ok(())
    }

    /// An epoch common to both runs (in the first run's epoch order).
    pub fn pair(&mut self, a: &Epoch, b: &Epoch) -> io::Result<()> {
        let d = difference_components(a, b);
        let p = &mut self.pairs;
        p.pairs.push_f64(&[a.t_s, d[0], d[1], d[2], d[3], d[4]])?;
        for (i, v) in d.iter().enumerate() {
            p.extent[i].push(*v);
            p.max_abs[i] = p.max_abs[i].max(v.abs());
        }
        Ok(())
    }

    /// The next truth record of the log.
    pub fn truth(&mut self, t: &TruthRecord) -> io::Result<()> {
        self.truth.push_f64(&t.r_e_m)
    }

    /// The next truth-bias record of the log.
    pub fn truth_bias(&mut self, b: &TruthBias) -> io::Result<()> {
        let t = b.t_ns as f64 * 1e-9;
        let [gx, gy, gz] = b.gyro_bias_rps;
        let [ax, ay, az] = b.accel_bias_mps2;
        self.truth_bias.push_f64(&[t, gx, gy, gz, ax, ay, az])?;
        for (i, v) in bias_units(&[gx, gy, gz, ax, ay, az]).iter().enumerate() {
            self.tb_extent[i].push(*v);
            self.tb_last[i] = *v;
        }
        Ok(())
    }

    /// The reduced data, with the first run's aid updates.
    pub fn finish(self, aids: Option<Aids<UpdatesOnDisk>>) -> io::Result<FigureData> {
        let mut d = FigureData {
            labels: self.labels,
            switches: self.switches,
            aids,
            t_max: 1.0,
            cumulative_hi: 1e-3,
            truth_bias_last: self.tb_last,
            bias_sigma_any: self.bias_sigma_any,
            middle_lat_deg: f64::NAN,
            ..FigureData::default()
        };
        let mut runs = Vec::new();
        for r in self.runs {
            let RunFeed {
                rows,
                epochs,
                last_row,
                last_epoch_t,
                cum_hi,
                hmax,
                ..
            } = r;
            for t in last_row.map(|x| x.t_s).into_iter().chain(last_epoch_t) {
                d.t_max = d.t_max.max(t);
            }
            d.cumulative_hi = d.cumulative_hi.max(cum_hi);
            runs.push((rows.seal()?, epochs.seal()?, hmax));
        }
        for (k, (rows, epochs, _)) in runs.iter().enumerate() {
            let picked = epochs.every(step_of(epochs.len()))?;
            // The figure's axis is fixed by the highest value of all runs.
            d.cumulative.push(Curve {
                pts: picked.iter().map(|x| (x[0], x[10])).collect(),
                extent: (f64::INFINITY, f64::NEG_INFINITY),
            });
            d.distance.push(
                picked
                    .iter()
                    .map(|x| (x[0], nalgebra::Vector2::new(x[1], x[2]).norm()))
                    .collect(),
            );
            let step = step_of(rows.len());
            let picked = rows.every(step)?;
            let positions: Vec<[f64; 3]> = picked.iter().map(|x| [x[1], x[2], x[3]]).collect();
            if k == 0 {
                d.rows_n = rows.len();
                if !rows.is_empty() {
                    d.middle_lat_deg = rows.get_f64(rows.len() / 2)?[4];
                }
                d.track = positions;
                d.bias_rows = picked
                    .iter()
                    .map(|x| (x[0], bias_units(&[x[5], x[6], x[7], x[8], x[9], x[10]])))
                    .collect();
                d.bias_sigma = picked
                    .iter()
                    .map(|x| {
                        let sigma = bias_units(&[x[11], x[12], x[13], x[14], x[15], x[16]]);
                        let has = x[17] as u8;
                        std::array::from_fn(|i| {
                            let bit = if i < 3 { 1 } else { 2 };
                            (has & bit != 0).then_some(sigma[i])
                        })
                    })
                    .collect();
            } else if k == 1 {
                d.track_compare = Some(positions);
            }
        }
        if let Some((_, epochs, hmax)) = runs.first() {
            d.hmax = *hmax;
            d.errors = errors(epochs, self.errors)?;
        }
        let truth = self.truth.seal()?;
        d.track_truth = truth
            .every(step_of(truth.len()))?
            .into_iter()
            .map(|x| [x[0], x[1], x[2]])
            .collect();
        let tb = self.truth_bias.seal()?;
        d.truth_bias_n = tb.len();
        let picked = tb.every(step_of(tb.len()))?;
        d.truth_bias = (0..6)
            .map(|i| Curve {
                pts: picked
                    .iter()
                    .map(|x| (x[0], bias_units(&[x[1], x[2], x[3], x[4], x[5], x[6]])[i]))
                    .collect(),
                extent: (self.tb_extent[i].lo, self.tb_extent[i].hi),
            })
            .collect();
        let bands: Vec<Vec<(f64, f64, f64)>> = (0..6).map(|i| bias_band(&d, i)).collect();
        let mut inside: Vec<TruthInside<'_>> = bands.iter().map(|b| TruthInside::new(b)).collect();
        tb.for_each_f64(|x| {
            let v = bias_units(&[x[1], x[2], x[3], x[4], x[5], x[6]]);
            for (i, c) in inside.iter_mut().enumerate() {
                c.push(x[0], v[i]);
            }
        })?;
        d.truth_bias_inside = std::array::from_fn(|i| inside[i].share());
        if runs.len() > 1 {
            let pairs = self.pairs.pairs.seal()?;
            d.compare_n = pairs.len();
            d.compare_max = self.pairs.max_abs;
            let picked = pairs.every(step_of(pairs.len()))?;
            d.compare = (0..5)
                .map(|i| Curve {
                    pts: picked.iter().map(|x| (x[0], x[1 + i])).collect(),
                    extent: (self.pairs.extent[i].lo, self.pairs.extent[i].hi),
                })
                .collect();
        }
        Ok(d)
    }
}

impl ErrorFeed {
    /// Counts the errors inside the band of the same rank.
    fn pair_up(&mut self) {
        while !self.errors_waiting.is_empty() && !self.bands_waiting.is_empty() {
            let (Some(e), Some(s)) = (
                self.errors_waiting.pop_front(),
                self.bands_waiting.pop_front(),
            ) else {
                break;
            };
            for i in 0..9 {
                let (lo, hi) = (-3.0 * s[i], 3.0 * s[i]);
                self.inside[i] += u64::from(e[i] >= lo && e[i] <= hi);
            }
        }
    }
}

/// The ±3σ band (t, lo, hi) of the bias estimate component `k` of `d`
/// (0..3 gyro °/h, 3..6 accelerometer µg) at the rows picked that carry
/// its σ.
pub(crate) fn bias_band(d: &FigureData, k: usize) -> Vec<(f64, f64, f64)> {
    d.bias_rows
        .iter()
        .zip(&d.bias_sigma)
        .filter_map(|((t, b), sigma)| {
            let sigma = sigma[k]?;
            Some((*t, b[k] - 3.0 * sigma, b[k] + 3.0 * sigma))
        })
        .collect()
}

/// The share of truth points (t, value), fed in time order, that lie
/// inside a band (t, lo, hi) at the band's last point at or before their
/// time; points before the band are not counted.
#[derive(Debug)]
pub(crate) struct TruthInside<'a> {
    band: &'a [(f64, f64, f64)],
    k: usize,
    n: u64,
    inside: u64,
}

impl<'a> TruthInside<'a> {
    pub(crate) fn new(band: &'a [(f64, f64, f64)]) -> Self {
        Self {
            band,
            k: 0,
            n: 0,
            inside: 0,
        }
    }

    /// The next truth point.
    pub(crate) fn push(&mut self, t: f64, v: f64) {
        if self.band.first().is_none_or(|b| b.0 > t) {
            return;
        }
        while self.k + 1 < self.band.len() && self.band[self.k + 1].0 <= t {
            self.k += 1;
        }
        self.n += 1;
        let b = self.band[self.k];
        self.inside += u64::from(v >= b.1 && v <= b.2);
    }

    /// The share inside; `None` without a band or a point inside its span.
    pub(crate) fn share(&self) -> Option<f64> {
        (self.n > 0).then(|| self.inside as f64 / self.n as f64)
    }
}

/// Biases in the figures' units: gyro °/h, accelerometer µg.
fn bias_units(b: &[f64; 6]) -> [f64; 6] {
    [
        b[0] * DEG_PER_H,
        b[1] * DEG_PER_H,
        b[2] * DEG_PER_H,
        b[3] * MICRO_G,
        b[4] * MICRO_G,
        b[5] * MICRO_G,
    ]
}

/// The first run's error curves from its epochs and bands.
fn errors(epochs: &Sealed<11>, f: ErrorFeed) -> io::Result<Vec<ErrorCurve>> {
    let bands = f.bands.seal()?;
    let picked = epochs.every(step_of(epochs.len()))?;
    let picked_bands = bands.every(step_of(bands.len()))?;
    // The 99th percentile of |±3σ| as the panel takes it of every band
    // value (each |3σ| twice: once as −3σ, once as +3σ).
    let ks: Vec<Option<u64>> = f
        .finite
        .iter()
        .map(|&n| (n > 0).then(|| ((2 * n - 1) as f64 * 0.99).round() as u64 / 2))
        .collect();
    let q = kth_smallest(&ks, |put| {
        bands.for_each_f64(|x| {
            for i in 0..9 {
                let v = 3.0 * x[1 + i];
                if v.is_finite() {
                    put(i, total_order_key(v.abs()));
                }
            }
        })
    })?;
    Ok((0..9)
        .map(|i| ErrorCurve {
            err: Curve {
                pts: picked.iter().map(|x| (x[0], x[1 + i])).collect(),
                extent: (f.extent[i].lo, f.extent[i].hi),
            },
            band: picked_bands
                .iter()
                .map(|x| (x[0], -3.0 * x[1 + i], 3.0 * x[1 + i]))
                .collect(),
            band_q99: q[i].map_or(f64::NAN, crate::spill::from_total_order_key),
            n_err: epochs.len(),
            n_band: bands.len(),
            sum_sq: f.sum_sq[i],
            inside: f.inside[i],
        })
        .collect())
}

/// Feeds `feed` from runs held in memory, as the figures read them: every
/// row, every epoch, the σ of the row at each epoch's time (the first row
/// at or after the one of the previous epoch within 1 µs), and the epochs
/// common to the first two runs (the second run's last epoch at the time).
pub fn feed_from_memory(
    feed: &mut FigureFeed,
    runs: &[(&[Row], &[Epoch])],
    truth: &[TruthRecord],
    truth_bias: &[TruthBias],
) -> io::Result<()> {
    for (k, (rows, epochs)) in runs.iter().enumerate() {
        for r in *rows {
            feed.row(k, r)?;
        }
        for e in *epochs {
            feed.epoch(k, e)?;
        }
        if k == 0 {
            for (e, r) in epochs.iter().zip(rows_at(rows, epochs)) {
                if let Some(r) = r {
                    feed.band(e.t_s, &sigma_components(r))?;
                }
            }
        }
    }
    if let [(_, a), (_, b), ..] = runs {
        let key = |t: f64| (t * 1e6).round() as i64;
        let by_t: std::collections::HashMap<i64, &Epoch> =
            b.iter().map(|e| (key(e.t_s), e)).collect();
        for ea in *a {
            if let Some(eb) = by_t.get(&key(ea.t_s)) {
                feed.pair(ea, eb)?;
            }
        }
    }
    for t in truth {
        feed.truth(t)?;
    }
    for b in truth_bias {
        feed.truth_bias(b)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::epochs;
    use msgs::Solution;

    fn lcg(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// What the figures took from every point, computed here from the
    /// vectors as plots.rs did before it streamed: `decimate`, the finite
    /// extremes, the 99th percentile of |band|, and the titles' sums.
    fn decimate<T: Copy>(v: &[T]) -> Vec<T> {
        v.iter()
            .step_by((v.len() / MAX_POINTS).max(1))
            .copied()
            .collect()
    }

    fn extent(v: impl Iterator<Item = f64>) -> (f64, f64) {
        v.filter(|x| x.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            })
    }

    fn q99(v: impl Iterator<Item = f64>) -> f64 {
        let mut v: Vec<f64> = v.filter(|x| x.is_finite()).map(f64::abs).collect();
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * 0.99).round() as usize]
    }

    /// The share of true-bias points inside the estimate's band, each
    /// judged at the band's last point at or before it; points before the
    /// band are not counted.
    #[test]
    fn truth_inside_the_band_is_counted_at_the_band_point_before_it() {
        let share = |band: &[(f64, f64, f64)], truth: &[(f64, f64)]| {
            let mut c = TruthInside::new(band);
            for (t, v) in truth {
                c.push(*t, *v);
            }
            c.share()
        };
        let band = [(1.0, -1.0, 1.0), (2.0, 5.0, 6.0), (3.0, -1.0, 1.0)];
        // t 0.5: before the band; 1.5 inside [-1, 1]; 2.0 outside [5, 6];
        // 2.5 inside [5, 6]; 9.0 outside [-1, 1].
        let truth = [(0.5, 0.0), (1.5, 0.5), (2.0, 0.0), (2.5, 5.5), (9.0, 2.0)];
        let f = share(&band, &truth).expect("a share");
        assert!((f - 0.5).abs() < 1e-12, "{f}");
        assert_eq!(share(&[], &truth), None);
        assert_eq!(share(&band, &[(0.1, 0.0)]), None);
    }

    fn bits(v: &[(f64, f64)]) -> Vec<(u64, u64)> {
        v.iter().map(|p| (p.0.to_bits(), p.1.to_bits())).collect()
    }

    /// Two runs of 23 456 rows (every point picked with a step of 4) and
    /// 11 729 epochs (step 2), σ now and then NaN or infinite, errors
    /// now and then NaN, the second run at other times: the reduced data
    /// equal, bit for bit, what the figures took from every point.
    #[test]
    fn figure_data_equals_what_the_figures_took_from_every_point() {
        let mut u = lcg(5);
        let mut rows: [Vec<Row>; 2] = [Vec::new(), Vec::new()];
        for (k, run) in rows.iter_mut().enumerate() {
            for i in 0..23_456u64 {
                let t_ns = i * 10_000_000 + k as u64 * 5_000_000;
                let mut s = Solution {
                    t_ns,
                    lat_rad: (80.0 + 9.0 * u()).to_radians(),
                    r_e_m: [1e5 * u(), 2e5 * u(), 6.3e6],
                    v_e_mps: [250.0 * u(), 1.0, 0.0],
                    q_b_e: [1.0, 0.0, 0.0, 0.0],
                    gyro_bias_rps: [1e-8 * u(), -2e-8, u() * 1e-7],
                    accel_bias_mps2: [1e-4 * u(), 5e-5, 0.0],
                    sigma_pos_enu_m: [5.0 * u(), 3.0, 1.0 + u()],
                    sigma_vel_mps: [0.1 * u(), 0.1, 0.01],
                    sigma_att_rad: [1e-4 * u(), 1e-4, 3e-4],
                    frame: u8::from((7000..15_000).contains(&i)),
                    ..Default::default()
                };
                s.sigma_gyro_bias_rps = [1e-9 * u(), 2e-9, 1e-9];
                s.sigma_accel_bias_mps2 = [1e-5 * u(), 1e-5, 2e-5];
                match i % 997 {
                    // A row without the bias σ (as a CSV of an earlier
                    // version), and one without the accelerometer's.
                    1 => s.sigma_gyro_bias_rps = [f64::NAN; 3],
                    2 => s.sigma_accel_bias_mps2 = [f64::NAN; 3],
                    3 => s.sigma_pos_enu_m[0] = f64::NAN,
                    5 => s.sigma_vel_mps[1] = f64::INFINITY,
                    7 => s.r_e_m[2] = f64::NAN,
                    _ => {}
                }
                run.push(Row::from_solution(&s));
            }
        }
        let truth: Vec<TruthRecord> = (0..23_456u64)
            .filter(|i| i % 2 == 0 || i % 7 == 0)
            .map(|i| TruthRecord {
                t_ns: i * 10_000_000,
                r_e_m: [1e5 * u(), 2e5 * u(), 6.3e6 + u()],
                v_e_mps: [250.0 * u(), 1.0, 0.0],
                q_b_e: [1.0, 0.0, 0.0, 0.0],
            })
            .collect();
        let truth_bias: Vec<TruthBias> = (0..9_000u64)
            .map(|i| TruthBias {
                t_ns: i * 25_000_000,
                gyro_bias_rps: [u() * 1e-8, 1e-8, -u() * 1e-8],
                accel_bias_mps2: [u() * 1e-3, 0.0, 1e-4],
            })
            .collect();
        // The second run's epochs are at other times but for the truth at
        // whole 10 ms: put a few of its rows there.
        for r in rows[1].iter_mut().step_by(3) {
            r.t_s = (r.t_s * 100.0).floor() / 100.0;
        }
        rows[1].sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
        rows[1].dedup_by(|a, b| a.t_s.to_bits() == b.t_s.to_bits());
        let ep: [Vec<Epoch>; 2] = [epochs(&rows[0], &truth), epochs(&rows[1], &truth)];
        assert!(
            ep[0].len() > 10_000 && ep[1].len() > 1000,
            "{} {}",
            ep[0].len(),
            ep[1].len()
        );

        let mut feed = FigureFeed::new(&["a", "b"]).expect("feed");
        let runs: Vec<(&[Row], &[Epoch])> = vec![(&rows[0], &ep[0]), (&rows[1], &ep[1])];
        feed_from_memory(&mut feed, &runs, &truth, &truth_bias).expect("feed");
        let d = feed.finish(None).expect("finish");

        // The error figures of the first run.
        let at = rows_at(&rows[0], &ep[0]);
        for (c, e) in d.errors.iter().enumerate() {
            let err: Vec<(f64, f64)> = ep[0]
                .iter()
                .map(|x| (x.t_s, error_components(x)[c]))
                .collect();
            let band: Vec<(f64, f64, f64)> = ep[0]
                .iter()
                .zip(&at)
                .filter_map(|(x, r)| {
                    r.map(|r| {
                        (
                            x.t_s,
                            -3.0 * sigma_components(r)[c],
                            3.0 * sigma_components(r)[c],
                        )
                    })
                })
                .collect();
            assert_eq!(bits(&e.err.pts), bits(&decimate(&err)), "channel {c}");
            let want = extent(err.iter().map(|p| p.1));
            assert_eq!(
                (e.err.extent.0.to_bits(), e.err.extent.1.to_bits()),
                (want.0.to_bits(), want.1.to_bits())
            );
            let picked: Vec<(f64, f64)> = decimate(&band).iter().map(|b| (b.1, b.2)).collect();
            let got: Vec<(f64, f64)> = e.band.iter().map(|b| (b.1, b.2)).collect();
            assert_eq!(bits(&got), bits(&picked), "band {c}");
            let q = q99(band.iter().flat_map(|b| [b.1, b.2]));
            assert_eq!(
                e.band_q99.to_bits(),
                q.to_bits(),
                "q99 {c}: {} {q}",
                e.band_q99
            );
            let sum_sq = err.iter().map(|p| p.1 * p.1).sum::<f64>();
            assert_eq!(e.sum_sq.to_bits(), sum_sq.to_bits());
            let inside = err
                .iter()
                .zip(&band)
                .filter(|(x, b)| x.1 >= b.1 && x.1 <= b.2)
                .count();
            assert_eq!(
                (e.inside, e.n_err, e.n_band),
                (inside as u64, err.len() as u64, band.len() as u64)
            );
        }
        assert!(d.errors[0].band_q99.is_finite() && d.errors[4].band_q99.is_finite());
        // The cumulative RMSE of both runs and its highest value.
        let mut hi = 1e-3f64;
        for (k, c) in d.cumulative.iter().enumerate() {
            let mut sum = 0.0;
            let curve: Vec<(f64, f64)> = ep[k]
                .iter()
                .enumerate()
                .map(|(i, e)| {
                    sum += e.pos_enu.xy().norm_squared();
                    (e.t_s, (sum / (i + 1) as f64).sqrt())
                })
                .collect();
            hi = curve.iter().map(|p| p.1).fold(hi, f64::max);
            assert_eq!(bits(&c.pts), bits(&decimate(&curve)), "run {k}");
        }
        assert_eq!(d.cumulative_hi.to_bits(), hi.to_bits());
        // The differences at common epochs.
        let by_t: std::collections::HashMap<i64, &Epoch> = ep[1]
            .iter()
            .map(|e| (crate::eval::time_key(e.t_s), e))
            .collect();
        let pairs: Vec<(&Epoch, &Epoch)> = ep[0]
            .iter()
            .filter_map(|a| by_t.get(&crate::eval::time_key(a.t_s)).map(|b| (a, *b)))
            .collect();
        assert_eq!(d.compare_n, pairs.len() as u64);
        for q in 0..5 {
            let v: Vec<(f64, f64)> = pairs
                .iter()
                .map(|(a, b)| (a.t_s, difference_components(a, b)[q]))
                .collect();
            assert_eq!(
                bits(&d.compare[q].pts),
                bits(&decimate(&v)),
                "difference {q}"
            );
            let want = extent(v.iter().map(|p| p.1));
            assert_eq!(d.compare[q].extent.0.to_bits(), want.0.to_bits());
            assert_eq!(d.compare[q].extent.1.to_bits(), want.1.to_bits());
            let mx = v.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
            assert_eq!(d.compare_max[q].to_bits(), mx.to_bits());
        }
        // Track, biases, truth bias, time axis, switches.
        let r3 = |v: &[f64; 3]| v.map(f64::to_bits);
        let want: Vec<[u64; 3]> = decimate(&rows[0]).iter().map(|r| r3(&r.r_e_m)).collect();
        assert_eq!(d.track.iter().map(r3).collect::<Vec<_>>(), want);
        let want: Vec<[u64; 3]> = decimate(&rows[1]).iter().map(|r| r3(&r.r_e_m)).collect();
        assert_eq!(
            d.track_compare
                .as_ref()
                .expect("compare")
                .iter()
                .map(r3)
                .collect::<Vec<_>>(),
            want
        );
        let want: Vec<[u64; 3]> = decimate(&truth).iter().map(|t| r3(&t.r_e_m)).collect();
        assert_eq!(d.track_truth.iter().map(r3).collect::<Vec<_>>(), want);
        assert_eq!(
            d.middle_lat_deg.to_bits(),
            rows[0][rows[0].len() / 2].lat_deg.to_bits()
        );
        let hmax = ep[0]
            .iter()
            .map(|e| e.pos_enu.xy().norm())
            .fold(0.0, f64::max);
        assert_eq!(d.hmax.to_bits(), hmax.to_bits());
        let step = (rows[0].len() / MAX_POINTS).max(1);
        assert_eq!(step, 4);
        // The bias σ of the rows picked, their ±3σ bands and the share of
        // the truth inside each, as imu_biases took them from the rows.
        assert_eq!(d.bias_rows.len(), d.bias_sigma.len());
        assert!(d.bias_sigma_any);
        let picked: Vec<&Row> = rows[0].iter().step_by(step).collect();
        for k in 0..6 {
            let band: Vec<(f64, f64, f64)> = picked
                .iter()
                .filter_map(|r| {
                    let (e, sigma) = if k < 3 {
                        (
                            r.gyro_bias_rps[k] * DEG_PER_H,
                            r.sigma_gyro_bias_rps.map(|s| s[k] * DEG_PER_H),
                        )
                    } else {
                        (
                            r.accel_bias_mps2[k - 3] * MICRO_G,
                            r.sigma_accel_bias_mps2.map(|s| s[k - 3] * MICRO_G),
                        )
                    };
                    sigma.map(|s| (r.t_s, e - 3.0 * s, e + 3.0 * s))
                })
                .collect();
            let got = bias_band(&d, k);
            assert!(got.len() < picked.len(), "rows without σ are left out");
            let b3 = |v: &[(f64, f64, f64)]| -> Vec<[u64; 3]> {
                v.iter()
                    .map(|p| [p.0.to_bits(), p.1.to_bits(), p.2.to_bits()])
                    .collect()
            };
            assert_eq!(b3(&got), b3(&band), "bias band {k}");
            let truth: Vec<(f64, f64)> = truth_bias
                .iter()
                .map(|b| {
                    let x = if k < 3 {
                        b.gyro_bias_rps[k] * DEG_PER_H
                    } else {
                        b.accel_bias_mps2[k - 3] * MICRO_G
                    };
                    (b.t_ns as f64 * 1e-9, x)
                })
                .collect();
            // As imu_biases counted them over every truth record.
            let (mut j, mut n, mut inside) = (0, 0u64, 0u64);
            for (t, v) in &truth {
                if band.first().is_none_or(|b| b.0 > *t) {
                    continue;
                }
                while j + 1 < band.len() && band[j + 1].0 <= *t {
                    j += 1;
                }
                n += 1;
                inside += u64::from(*v >= band[j].1 && *v <= band[j].2);
            }
            let want = (n > 0).then(|| inside as f64 / n as f64);
            assert_eq!(
                d.truth_bias_inside[k].map(f64::to_bits),
                want.map(f64::to_bits),
                "truth inside {k}"
            );
            assert!(want.is_some());
        }
        // Each run's horizontal distance from the truth under the track.
        for (k, dist) in d.distance.iter().enumerate() {
            let v: Vec<(f64, f64)> = ep[k]
                .iter()
                .map(|e| (e.t_s, e.pos_enu.xy().norm()))
                .collect();
            assert_eq!(bits(dist), bits(&decimate(&v)), "distance {k}");
        }
        assert_eq!(d.distance.len(), 2);
        for (i, r) in rows[0].iter().step_by(step).enumerate() {
            let (t, b) = d.bias_rows[i];
            assert_eq!(t.to_bits(), r.t_s.to_bits());
            assert_eq!(b[1].to_bits(), (r.gyro_bias_rps[1] * DEG_PER_H).to_bits());
            assert_eq!(b[3].to_bits(), (r.accel_bias_mps2[0] * MICRO_G).to_bits());
        }
        for k in 0..6 {
            let v: Vec<(f64, f64)> = truth_bias
                .iter()
                .map(|b| {
                    let x = if k < 3 {
                        b.gyro_bias_rps[k] * DEG_PER_H
                    } else {
                        b.accel_bias_mps2[k - 3] * MICRO_G
                    };
                    (b.t_ns as f64 * 1e-9, x)
                })
                .collect();
            assert_eq!(
                bits(&d.truth_bias[k].pts),
                bits(&decimate(&v)),
                "truth bias {k}"
            );
            let want = extent(v.iter().map(|p| p.1));
            assert_eq!(d.truth_bias[k].extent.0.to_bits(), want.0.to_bits());
            assert_eq!(d.truth_bias_last[k].to_bits(), v[v.len() - 1].1.to_bits());
        }
        let t_max = [&rows[0], &rows[1]]
            .iter()
            .zip(&ep)
            .flat_map(|(r, e)| {
                r.last()
                    .map(|x| x.t_s)
                    .into_iter()
                    .chain(e.last().map(|e| e.t_s))
            })
            .fold(1.0, f64::max);
        assert_eq!(d.t_max.to_bits(), t_max.to_bits());
        assert_eq!(d.switches, switches(&rows[0]));
        assert_eq!(d.switches.len(), 2);
    }
}
