//! Accuracy of a solution against the truth of its log. All errors are
//! computed frame-free (ECEF differences and body→ECEF quaternions, projected
//! on the local ENU axes of the truth), so they stay meaningful at the pole.

use std::collections::HashMap;

use msgs::TruthRecord;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use polarnav::earth;
use polarnav::frames;
use polarnav::solution_csv::Row;

/// Error of one solution row against the truth at the same time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Epoch {
    pub t_s: f64,
    /// Position error east/north/up (m).
    pub pos_enu: Vector3<f64>,
    /// Velocity error east/north/up (m/s).
    pub vel_enu: Vector3<f64>,
    /// Attitude error angles about east/north/up (rad): tilt = (E, N), heading = U.
    pub att_enu: Vector3<f64>,
    /// Velocity error in the axes of the row's navigation frame (g: E, N, U;
    /// G: grid east, grid north, up), the axes of its σ columns (m/s).
    pub vel_nav: Vector3<f64>,
    /// Attitude error φ in the axes of the row's navigation frame (rad), the
    /// axes of its σ columns; z (up) is the same axis in g and G.
    pub att_nav: Vector3<f64>,
    pub frame: char,
}

/// RMSE and maximum of one error quantity.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stat {
    pub rmse: f64,
    pub max: f64,
}

impl Stat {
    fn of(values: impl Iterator<Item = f64>) -> Self {
        let mut acc = StatAcc::default();
        for v in values {
            acc.push(v);
        }
        acc.stat()
    }
}

/// [`Stat`] of values fed one at a time.
#[derive(Debug, Clone, Copy, Default)]
struct StatAcc {
    n: usize,
    sq: f64,
    mx: f64,
}

impl StatAcc {
    fn push(&mut self, v: f64) {
        self.n += 1;
        self.sq += v * v;
        self.mx = self.mx.max(v.abs());
    }

    fn stat(&self) -> Stat {
        if self.n == 0 {
            Stat {
                rmse: f64::NAN,
                max: f64::NAN,
            }
        } else {
            Stat {
                rmse: (self.sq / self.n as f64).sqrt(),
                max: self.mx,
            }
        }
    }
}

/// The accuracy summary.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Summary {
    pub epochs: usize,
    pub horizontal_m: Stat,
    pub vertical_m: Stat,
    pub velocity_mps: Stat,
    pub tilt_arcmin: Stat,
    pub heading_arcmin: Stat,
    /// Mean position NEES with the CSV's per-axis σ (diagonal approximation; ideal 3).
    pub position_nees: f64,
    pub non_finite_rows: usize,
}

fn quat(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]))
}

/// The key a time (s) is matched by: whole microseconds.
pub fn time_key(t_s: f64) -> i64 {
    (t_s * 1e6).round() as i64
}

/// The key of a truth record's time.
pub fn truth_key(t: &TruthRecord) -> i64 {
    time_key(t.t_ns as f64 * 1e-9)
}

/// Errors at every truth epoch that has a solution row at the same time (to 1 µs).
pub fn epochs(rows: &[Row], truth: &[TruthRecord]) -> Vec<Epoch> {
    let by_time: HashMap<i64, &Row> = rows.iter().map(|r| (time_key(r.t_s), r)).collect();
    truth
        .iter()
        .filter_map(|t| by_time.get(&truth_key(t)).map(|r| epoch_of(r, t)))
        .collect()
}

/// The error of row `r` against truth record `t` (taken at the same time).
pub fn epoch_of(r: &Row, t: &TruthRecord) -> Epoch {
    let r_true = Vector3::from(t.r_e_m);
    let g = earth::ecef_to_geodetic(&r_true);
    let c_e_g = frames::c_e_g(g.lat_rad, g.lon_rad);
    let dp = c_e_g * (Vector3::from(r.r_e_m) - r_true);
    let dv = c_e_g * (Vector3::from(r.v_e_mps) - Vector3::from(t.v_e_mps));
    // C_b^c = (I − φ×) C_b^n  ⇒  φ = −rotvec(q_sol · q_trueᶜ).
    let d = quat(&r.q_b_e) * quat(&t.q_b_e).inverse();
    let phi_e = -d.scaled_axis();
    let att = c_e_g * phi_e;
    // The nav axes at the true position (the filter's own differ by its
    // position error, metres against the kilometres the axes turn over).
    let c_e_n = if r.frame == 'G' {
        frames::c_e_grid(g.lat_rad, g.lon_rad)
    } else {
        c_e_g
    };
    let dv_e = Vector3::from(r.v_e_mps) - Vector3::from(t.v_e_mps);
    Epoch {
        t_s: r.t_s,
        pos_enu: dp,
        vel_enu: dv,
        att_enu: att,
        vel_nav: c_e_n * dv_e,
        att_nav: c_e_n * phi_e,
        frame: r.frame,
    }
}

/// The position NEES of epoch `e` with the row's per-axis σ `s`.
fn nees_of(e: &Epoch, s: &[f64; 3]) -> f64 {
    (0..3).map(|i| (e.pos_enu[i] / s[i]).powi(2)).sum::<f64>()
}

/// True when a row has a non-finite position, velocity or attitude.
fn non_finite(r: &Row) -> bool {
    !(r.r_e_m
        .iter()
        .chain(&r.v_e_mps)
        .chain(&r.q_b_e)
        .all(|x| x.is_finite()))
}

pub fn summarize(rows: &[Row], ep: &[Epoch]) -> Summary {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    let key = time_key;
    let sig: HashMap<i64, [f64; 3]> = rows.iter().map(|r| (key(r.t_s), r.sigma_enu_m)).collect();
    let nees: Vec<f64> = ep
        .iter()
        .filter_map(|e| sig.get(&key(e.t_s)).map(|s| (s, e)))
        .map(|(s, e)| nees_of(e, s))
        .filter(|v| v.is_finite())
        .collect();
    Summary {
        position_nees: if nees.is_empty() {
            f64::NAN
        } else {
            nees.iter().sum::<f64>() / nees.len() as f64
        },
        epochs: ep.len(),
        horizontal_m: Stat::of(ep.iter().map(|e| e.pos_enu.xy().norm())),
        vertical_m: Stat::of(ep.iter().map(|e| e.pos_enu.z)),
        velocity_mps: Stat::of(ep.iter().map(|e| e.vel_enu.norm())),
        tilt_arcmin: Stat::of(ep.iter().map(|e| e.att_enu.xy().norm() * arcmin)),
        heading_arcmin: Stat::of(ep.iter().map(|e| e.att_enu.z * arcmin)),
        non_finite_rows: rows.iter().filter(|r| non_finite(r)).count(),
    }
}

/// [`summarize`] fed as a flight streams in: every row (in any order),
/// and each epoch with the σ of its row, in truth order. Equal to
/// [`summarize`] when each time has one row.
#[derive(Debug, Clone)]
pub struct SummaryAcc {
    epochs: usize,
    horizontal: StatAcc,
    vertical: StatAcc,
    velocity: StatAcc,
    tilt: StatAcc,
    heading: StatAcc,
    nees_sum: f64,
    nees_n: usize,
    non_finite_rows: usize,
}

impl Default for SummaryAcc {
    fn default() -> Self {
        Self {
            epochs: 0,
            horizontal: StatAcc::default(),
            vertical: StatAcc::default(),
            velocity: StatAcc::default(),
            tilt: StatAcc::default(),
            heading: StatAcc::default(),
            // The sum of no value, as `Iterator::sum` starts it.
            nees_sum: std::iter::empty::<f64>().sum(),
            nees_n: 0,
            non_finite_rows: 0,
        }
    }
}

impl SummaryAcc {
    pub fn row(&mut self, r: &Row) {
        self.non_finite_rows += usize::from(non_finite(r));
    }

    /// Epoch `e` of the row whose per-axis position σ is `sigma_enu_m`.
    pub fn epoch(&mut self, e: &Epoch, sigma_enu_m: &[f64; 3]) {
        let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
        self.epochs += 1;
        let v = nees_of(e, sigma_enu_m);
        if v.is_finite() {
            self.nees_sum += v;
            self.nees_n += 1;
        }
        self.horizontal.push(e.pos_enu.xy().norm());
        self.vertical.push(e.pos_enu.z);
        self.velocity.push(e.vel_enu.norm());
        self.tilt.push(e.att_enu.xy().norm() * arcmin);
        self.heading.push(e.att_enu.z * arcmin);
    }

    pub fn summary(&self) -> Summary {
        Summary {
            position_nees: if self.nees_n == 0 {
                f64::NAN
            } else {
                self.nees_sum / self.nees_n as f64
            },
            epochs: self.epochs,
            horizontal_m: self.horizontal.stat(),
            vertical_m: self.vertical.stat(),
            velocity_mps: self.velocity.stat(),
            tilt_arcmin: self.tilt.stat(),
            heading_arcmin: self.heading.stat(),
            non_finite_rows: self.non_finite_rows,
        }
    }
}

/// Markdown table of a summary.
pub fn markdown(title: &str, s: &Summary) -> String {
    let mut m = format!("## {title}\n\n{} epochs compared with truth", s.epochs);
    if s.non_finite_rows > 0 {
        m.push_str(&format!(
            ", **{} rows with non-finite values**",
            s.non_finite_rows
        ));
    }
    m.push_str(&format!(
        "; mean position NEES {:.2} (per-axis σ of the CSV; ideal 3, NaN without a filter)",
        s.position_nees
    ));
    m.push_str("\n\n| quantity | RMSE | max |\n|---|---|---|\n");
    for (name, st, unit) in [
        ("horizontal position", s.horizontal_m, "m"),
        ("vertical position", s.vertical_m, "m"),
        ("velocity", s.velocity_mps, "m/s"),
        ("tilt", s.tilt_arcmin, "′"),
        ("heading", s.heading_arcmin, "′"),
    ] {
        m.push_str(&format!(
            "| {name} | {:.4} {unit} | {:.4} {unit} |\n",
            st.rmse, st.max
        ));
    }
    m
}

/// How a frame switch disturbed the solution: maximum deviation of the
/// heading error and of the velocity-error magnitude from their linear trend
/// over the `before_s` preceding the switch, within `after_s` after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchTransient {
    pub t_s: f64,
    pub from: char,
    pub to: char,
    pub heading_dev_arcmin: f64,
    pub velocity_dev_mps: f64,
    pub horizontal_dev_m: f64,
}

fn linear_fit(pts: &[(f64, f64)]) -> (f64, f64) {
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx).powi(2))
    });
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (slope, my - slope * mx)
}

fn max_dev(ep: &[Epoch], t_sw: f64, before_s: f64, after_s: f64, f: impl Fn(&Epoch) -> f64) -> f64 {
    let pre: Vec<(f64, f64)> = ep
        .iter()
        .filter(|e| e.t_s > t_sw - before_s && e.t_s <= t_sw)
        .map(|e| (e.t_s, f(e)))
        .collect();
    if pre.len() < 2 {
        return f64::NAN;
    }
    let (a, b) = linear_fit(&pre);
    ep.iter()
        .filter(|e| e.t_s > t_sw && e.t_s <= t_sw + after_s)
        .map(|e| (f(e) - (a * e.t_s + b)).abs())
        .fold(0.0, f64::max)
}

/// Transients at every frame change in the solution rows.
pub fn switch_transients(
    rows: &[Row],
    ep: &[Epoch],
    before_s: f64,
    after_s: f64,
) -> Vec<SwitchTransient> {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    rows.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| {
            let t = w[1].t_s;
            SwitchTransient {
                t_s: t,
                from: w[0].frame,
                to: w[1].frame,
                heading_dev_arcmin: max_dev(ep, t, before_s, after_s, |e| e.att_enu.z * arcmin),
                velocity_dev_mps: max_dev(ep, t, before_s, after_s, |e| e.vel_enu.norm()),
                horizontal_dev_m: max_dev(ep, t, before_s, after_s, |e| e.pos_enu.xy().norm()),
            }
        })
        .collect()
}

/// [`switch_transients`] fed as a flight streams in: every row in file
/// order and every epoch in time order (rows and epochs strictly
/// increasing in time, the rows at an epoch's time before it). Memory
/// holds the epochs of the last `before_s` and the switches within
/// `after_s` of the newest epoch.
#[derive(Debug, Clone)]
pub struct TransientAcc {
    before_s: f64,
    after_s: f64,
    prev_frame: Option<char>,
    /// Recent epochs: t and heading (′), velocity (m/s), horizontal (m) errors.
    window: std::collections::VecDeque<(f64, [f64; 3])>,
    /// Switches whose 'after' window is open: their index in `out` and,
    /// once an epoch after them came, their pre-switch trends.
    open: Vec<(usize, Option<Trends>)>,
    out: Vec<SwitchTransient>,
}

/// The linear trends (slope, intercept) of the three quantities of a
/// switch transient before the switch.
type Trends = [(f64, f64); 3];

/// The three quantities of a switch transient of epoch `e`.
fn transient_values(e: &Epoch) -> [f64; 3] {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    [
        e.att_enu.z * arcmin,
        e.vel_enu.norm(),
        e.pos_enu.xy().norm(),
    ]
}

impl TransientAcc {
    pub fn new(before_s: f64, after_s: f64) -> Self {
        Self {
            before_s,
            after_s,
            prev_frame: None,
            window: std::collections::VecDeque::new(),
            open: Vec::new(),
            out: Vec::new(),
        }
    }

    pub fn row(&mut self, r: &Row) {
        if let Some(from) = self.prev_frame
            && from != r.frame
        {
            self.open.push((self.out.len(), None));
            self.out.push(SwitchTransient {
                t_s: r.t_s,
                from,
                to: r.frame,
                heading_dev_arcmin: 0.0,
                velocity_dev_mps: 0.0,
                horizontal_dev_m: 0.0,
            });
        }
        self.prev_frame = Some(r.frame);
    }

    /// The trends before switch `k` (`None` with fewer than two epochs:
    /// its deviations are NaN).
    fn fit(&mut self, k: usize) -> Option<Trends> {
        let t_sw = self.out[k].t_s;
        let pre: Vec<&(f64, [f64; 3])> = self
            .window
            .iter()
            .filter(|e| e.0 > t_sw - self.before_s && e.0 <= t_sw)
            .collect();
        if pre.len() < 2 {
            let x = &mut self.out[k];
            (x.heading_dev_arcmin, x.velocity_dev_mps, x.horizontal_dev_m) =
                (f64::NAN, f64::NAN, f64::NAN);
            return None;
        }
        Some(std::array::from_fn(|q| {
            linear_fit(&pre.iter().map(|e| (e.0, e.1[q])).collect::<Vec<_>>())
        }))
    }

    pub fn epoch(&mut self, e: &Epoch) {
        let v = transient_values(e);
        let mut open = std::mem::take(&mut self.open);
        open.retain_mut(|(k, fit)| {
            let t_sw = self.out[*k].t_s;
            if e.t_s <= t_sw {
                return true;
            }
            let f = match fit {
                Some(f) => *f,
                None => match self.fit(*k) {
                    Some(f) => *fit.insert(f),
                    None => return false,
                },
            };
            if e.t_s > t_sw + self.after_s {
                return false;
            }
            let x = &mut self.out[*k];
            for (q, dev) in [
                &mut x.heading_dev_arcmin,
                &mut x.velocity_dev_mps,
                &mut x.horizontal_dev_m,
            ]
            .into_iter()
            .enumerate()
            {
                let (a, b) = f[q];
                *dev = dev.max((v[q] - (a * e.t_s + b)).abs());
            }
            true
        });
        self.open = open;
        self.window.push_back((e.t_s, v));
        while self
            .window
            .front()
            .is_some_and(|x| x.0 <= e.t_s - self.before_s)
        {
            self.window.pop_front();
        }
    }

    pub fn finish(mut self) -> Vec<SwitchTransient> {
        for (k, fit) in std::mem::take(&mut self.open) {
            if fit.is_none() {
                self.fit(k);
            }
        }
        self.out
    }
}

/// Markdown table of switch transients.
pub fn transients_markdown(title: &str, t: &[SwitchTransient]) -> String {
    let mut m = format!(
        "### {title}: error drift around each switch (largest deviation of the error from its 60 s pre-switch trend within 200 s after)\n\n\
         This is the filter's own wander over 200 s, not the switch: the switch's transient is the \
         deviation from a run of the same log without that switch, given to `eval --compare` \
         (`nav-daemon batch --force-switch 0`: the grid frame throughout; `--no-switch` where the \
         flight stays away from the pole), in the table after the figures.\n\n"
    );
    if t.is_empty() {
        m.push_str("no frame switch\n");
        return m;
    }
    m.push_str("| t (s) | switch | heading (′) | velocity (m/s) | horizontal (m) |\n|---|---|---|---|---|\n");
    for x in t {
        m.push_str(&format!(
            "| {:.2} | {}→{} | {:.4} | {:.4} | {:.3} |\n",
            x.t_s, x.from, x.to, x.heading_dev_arcmin, x.velocity_dev_mps, x.horizontal_dev_m
        ));
    }
    m
}

/// Deviation of one run from a reference run (e.g. never switching) after
/// each switch of the first: maxima over `after_s` of the attitude
/// difference about the local vertical, the velocity and position differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunDeviation {
    pub t_s: f64,
    pub from: char,
    pub to: char,
    pub heading_arcmin: f64,
    pub tilt_arcmin: f64,
    pub velocity_mps: f64,
    pub position_m: f64,
}

pub fn deviation_after_switches(a: &[Row], b: &[Row], after_s: f64) -> Vec<RunDeviation> {
    let key = time_key;
    let by_time: HashMap<i64, &Row> = b.iter().map(|r| (key(r.t_s), r)).collect();
    a.windows(2)
        .filter(|w| w[0].frame != w[1].frame)
        .map(|w| {
            let t0 = w[1].t_s;
            let mut d = RunDeviation {
                t_s: t0,
                from: w[0].frame,
                to: w[1].frame,
                heading_arcmin: 0.0,
                tilt_arcmin: 0.0,
                velocity_mps: 0.0,
                position_m: 0.0,
            };
            for ra in a.iter().filter(|r| r.t_s >= t0 && r.t_s <= t0 + after_s) {
                let Some(rb) = by_time.get(&key(ra.t_s)) else {
                    continue;
                };
                deviate(&mut d, ra, rb);
            }
            d
        })
        .collect()
}

/// Takes the difference of `ra` from `rb` (one time) into `d`'s maxima.
fn deviate(d: &mut RunDeviation, ra: &Row, rb: &Row) {
    let arcmin = 60.0 * 180.0 / std::f64::consts::PI;
    let r = Vector3::from(rb.r_e_m);
    let g = earth::ecef_to_geodetic(&r);
    let c = frames::c_e_g(g.lat_rad, g.lon_rad);
    let att = c * (quat(&ra.q_b_e) * quat(&rb.q_b_e).inverse()).scaled_axis();
    d.heading_arcmin = d.heading_arcmin.max(att.z.abs() * arcmin);
    d.tilt_arcmin = d.tilt_arcmin.max(att.xy().norm() * arcmin);
    d.velocity_mps = d
        .velocity_mps
        .max((Vector3::from(ra.v_e_mps) - Vector3::from(rb.v_e_mps)).norm());
    d.position_m = d.position_m.max((Vector3::from(ra.r_e_m) - r).norm());
}

/// [`deviation_after_switches`] fed as the flights stream in: every row of
/// the first in time order, each with the second's row at its time (if
/// any). Memory holds the switches within `after_s` of the newest row.
#[derive(Debug, Clone)]
pub struct DeviationAcc {
    after_s: f64,
    prev_frame: Option<char>,
    open: Vec<usize>,
    out: Vec<RunDeviation>,
}

impl DeviationAcc {
    pub fn new(after_s: f64) -> Self {
        Self {
            after_s,
            prev_frame: None,
            open: Vec::new(),
            out: Vec::new(),
        }
    }

    pub fn row(&mut self, ra: &Row, rb: Option<&Row>) {
        if let Some(from) = self.prev_frame
            && from != ra.frame
        {
            self.open.push(self.out.len());
            self.out.push(RunDeviation {
                t_s: ra.t_s,
                from,
                to: ra.frame,
                heading_arcmin: 0.0,
                tilt_arcmin: 0.0,
                velocity_mps: 0.0,
                position_m: 0.0,
            });
        }
        self.prev_frame = Some(ra.frame);
        let out = &mut self.out;
        let after_s = self.after_s;
        self.open.retain(|&k| {
            let t0 = out[k].t_s;
            if ra.t_s >= t0
                && ra.t_s <= t0 + after_s
                && let Some(rb) = rb
            {
                deviate(&mut out[k], ra, rb);
            }
            ra.t_s <= t0 + after_s
        });
    }

    pub fn finish(self) -> Vec<RunDeviation> {
        self.out
    }
}

pub fn deviation_markdown(t: &[RunDeviation], after_s: f64) -> String {
    let mut m = format!(
        "### Switch transients: solution against compare after each switch of solution (max over {after_s:.0} s)\n\n\
         With compare a run of the same log without the switch (grid throughout, or geographic \
         throughout away from the pole), this is what the switch itself changed.\n\n"
    );
    if t.is_empty() {
        m.push_str("no frame switch in solution\n");
        return m;
    }
    m.push_str("| t (s) | switch | heading (′) | tilt (′) | velocity (m/s) | position (m) |\n|---|---|---|---|---|---|\n");
    for x in t {
        m.push_str(&format!(
            "| {:.2} | {}→{} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |\n",
            x.t_s, x.from, x.to, x.heading_arcmin, x.tilt_arcmin, x.velocity_mps, x.position_m
        ));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use msgs::Solution;

    /// A flight of rows at 10 Hz for 3000 s whose frame switches at 500 s,
    /// at 600 s and 600.5 s (within each other's 200 s) and at 2000 s, with
    /// errors that wander; the truth at 1 Hz with no truth from 1930 s to
    /// 2000 s (fewer than two epochs before that switch), and a second run
    /// at every other row time with other errors.
    fn flight() -> (Vec<Row>, Vec<Row>, Vec<TruthRecord>) {
        let pos = |k: f64| {
            earth::geodetic_to_ecef(&earth::Geodetic::from_deg(
                80.0 + k * 1e-5,
                10.0 + k * 1e-4,
                12_000.0,
            ))
        };
        let frame = |k: u64| u8::from(matches!(k, 5000..6000 | 6005..20_000));
        let row = |k: u64, wobble: f64| {
            let t = k as f64 * 0.1;
            let e =
                Vector3::new((t * 0.01).sin(), (t * 0.013).cos(), 0.1 * (t * 0.02).sin()) * wobble;
            let q = UnitQuaternion::from_euler_angles(
                1e-4 * (t * 0.003).sin() * wobble,
                2e-4,
                0.3 + t * 1e-5,
            );
            Row::from_solution(&Solution {
                t_ns: k * 100_000_000,
                r_e_m: (pos(k as f64) + e).into(),
                v_e_mps: [250.0 + 0.01 * wobble * (t * 0.05).sin(), 1.0, 0.0],
                q_b_e: [q.w, q.i, q.j, q.k],
                sigma_pos_enu_m: [3.0 + (t * 1e-3).sin(), 3.0, 1.0],
                frame: frame(k),
                ..Default::default()
            })
        };
        let a: Vec<Row> = (0..30_000).map(|k| row(k, 1.0)).collect();
        let b: Vec<Row> = (0..30_000).step_by(2).map(|k| row(k, 1.7)).collect();
        let truth = (0..3000u64)
            .filter(|s| !(1930..2000).contains(s))
            .map(|s| {
                let q = UnitQuaternion::from_euler_angles(0.0, 2e-4, 0.3 + s as f64 * 1e-4);
                TruthRecord {
                    t_ns: s * 1_000_000_000,
                    r_e_m: pos(s as f64 * 10.0).into(),
                    v_e_mps: [250.0, 1.0, 0.0],
                    q_b_e: [q.w, q.i, q.j, q.k],
                }
            })
            .collect();
        (a, b, truth)
    }

    /// The accuracy, transients and deviations fed as the files stream in
    /// (rows and truth merged in time, rows first at one time) equal those
    /// computed from every row and epoch in memory, bit for bit.
    #[test]
    fn streamed_summary_transients_and_deviations_equal_the_in_memory_ones() {
        let (a, b, truth) = flight();
        let ep = epochs(&a, &truth);
        let want = (
            summarize(&a, &ep),
            switch_transients(&a, &ep, 60.0, 200.0),
            deviation_after_switches(&a, &b, 200.0),
        );
        assert_eq!(want.1.len(), 4);
        assert!(want.1[3].heading_dev_arcmin.is_nan(), "{:?}", want.1[3]);
        assert!(want.1[1].heading_dev_arcmin > 0.0, "{:?}", want.1[1]);
        assert!(want.2[2].position_m > 0.0, "{:?}", want.2);

        let (mut sum, mut tr, mut dev) = (
            SummaryAcc::default(),
            TransientAcc::new(60.0, 200.0),
            DeviationAcc::new(200.0),
        );
        let (mut ai, mut bi, mut ti) = (0, 0, 0);
        let (mut last_a, mut last_b): (Option<Row>, Option<Row>) = (None, None);
        loop {
            let (ka, kb, kt) = (
                a.get(ai).map(|r| time_key(r.t_s)),
                b.get(bi).map(|r| time_key(r.t_s)),
                truth.get(ti).map(truth_key),
            );
            let never = i64::MAX;
            if let Some(k) = kb
                && k <= ka.unwrap_or(never)
                && k <= kt.unwrap_or(never)
            {
                last_b = Some(b[bi]);
                bi += 1;
            } else if let Some(k) = ka
                && k <= kt.unwrap_or(never)
            {
                let r = a[ai];
                sum.row(&r);
                tr.row(&r);
                dev.row(&r, last_b.as_ref().filter(|x| time_key(x.t_s) == k));
                last_a = Some(r);
                ai += 1;
            } else if let Some(k) = kt {
                if let Some(r) = last_a.filter(|x| time_key(x.t_s) == k) {
                    let e = epoch_of(&r, &truth[ti]);
                    sum.epoch(&e, &r.sigma_enu_m);
                    tr.epoch(&e);
                }
                ti += 1;
            } else {
                break;
            }
        }
        let got = (sum.summary(), tr.finish(), dev.finish());
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
    }
}
