//! The review of a flight that needs no truth: the estimator's health from
//! its own outputs. Per aid the innovations in physical units with their
//! ±1σ/±3σ from the innovation variance, the normalized innovation squared
//! (NIS) against the χ² bounds of its dimension with a verdict on the noise
//! model; a health timeline of the solution flags; the IMU sampling; the
//! σ of position, velocity and attitude; the bias estimates with their σ
//! where the solution carries it; and, given a reference solution (a
//! smoothed run), the forward solution's difference from it with the
//! forward ±3σ.
//!
//! The solution streams through once (a CSV is read a chunk at a time) into
//! min/max envelopes per time column ([`crate::envelope`]), so a flight of
//! 10 M rows costs the parse and a fixed amount of memory.

use std::fmt::Write as _;
use std::path::Path;

use msgs::aids::{MAX_COMPONENTS, Unit};
use msgs::navlog::{Header, Record};
use msgs::{AidKind, PerAid, Status, TruthRecord, solution_flags};
use plotters::coord::Shift;
use plotters::prelude::*;
use polarnav::solution_csv::Row;

use crate::chi2;
use crate::envelope::Envelope;
use crate::eval;
use crate::figures::{self, ARCMIN, DEG_PER_H, MICRO_G, Switch};
use crate::logfile::LogContents;
use crate::plots::{
    self, AXIS_COLORS, BLUE, Figure, Format, GREY, Mark, Panel, RED_, legend, time_panel,
};
use crate::solution_file::{
    self, AID_WORDS, AidPoint, AidSink, Aids, CsvRows, UpdatesOnDisk, aids_to_disk,
    for_each_update, try_map_aids,
};
use crate::spill::{Sealed, Spill, from_total_order_key, kth_smallest, total_order_key};

/// What to review.
#[derive(Debug, Clone, Copy)]
pub struct Options<'a> {
    /// The solution: a CSV or (by extension) an MCAP file of `batch`.
    pub solution: &'a Path,
    /// A reference solution in the same columns (a smoothed run).
    pub reference: Option<&'a Path>,
    /// Where the figures go; none: the summary only.
    pub out: Option<&'a Path>,
}

/// The result: the summary's markdown and the figures written.
#[derive(Debug, Clone, Default)]
pub struct Review {
    pub markdown: String,
    pub figures: Vec<Figure>,
    /// Per aid that had updates: its name and verdict.
    pub verdicts: Vec<(&'static str, Verdict)>,
}

/// The noise model's consistency for one aid over the flight.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    Consistent,
    /// σ too small: NIS too large.
    TooOptimistic,
    /// σ too large: NIS too small.
    TooPessimistic,
}

impl Verdict {
    pub fn text(self) -> &'static str {
        match self {
            Verdict::Consistent => "consistent",
            Verdict::TooOptimistic => "too optimistic",
            Verdict::TooPessimistic => "too pessimistic",
        }
    }
}

/// Practical tolerance of the mean-NIS test: besides the χ² bounds, a mean
/// NIS within this factor of its dimension (a noise σ within √2 of the
/// true one) is consistent. See [`nis_test`].
pub const NIS_TOLERANCE: f64 = 2.0;

/// The rejected fraction above which an aid's model is too optimistic
/// whatever the accepted updates say: ten times the 0.1 % a 99.9 % gate
/// rejects of a consistent aid.
pub const REJECTED_MAX: f64 = 0.01;

/// The mean-NIS test of one aid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NisTest {
    /// Measurement dimension m.
    pub dim: usize,
    /// Accepted updates N.
    pub accepted: usize,
    pub rejected: usize,
    /// Mean NIS over the accepted updates.
    pub mean: f64,
    /// Two-sided 95 % bounds of the mean of N independent χ²(m):
    /// χ²₀.₀₂₅(N·m)/N and χ²₀.₉₇₅(N·m)/N.
    pub lo95: f64,
    pub hi95: f64,
    /// The bounds with the practical tolerance: min(lo95, m/2), max(hi95, 2m).
    pub lo: f64,
    pub hi: f64,
    /// Fraction of all updates whose NIS is inside the per-update 95 %
    /// interval [χ²₀.₀₂₅(m), χ²₀.₉₇₅(m)].
    pub inside: f64,
    pub verdict: Verdict,
}

/// The test: the mean NIS of the accepted updates against the bounds of
/// the mean of N independent χ²(m) variables (two-sided 95 %), widened to
/// a factor [`NIS_TOLERANCE`] of m. The plain χ² bounds shrink as 1/√N
/// (±2.8 % at N = 10 000, m = 1) and assume independent innovations; aid
/// errors on a real flight are correlated over many updates and the
/// accepted updates are truncated at the gate, so the plain bounds would
/// call nearly every long flight inconsistent. A factor 2 in variance is
/// √2 in σ, the resolution at which a noise σ is worth changing; a model
/// 10× off gives a mean NIS near 100 m or 0.01 m. A rejected fraction
/// above [`REJECTED_MAX`] is too optimistic on its own (the gate hides the
/// large NIS of an overconfident model).
pub fn nis_test(nis: &[(f64, bool)], dim: usize) -> Option<NisTest> {
    let mut acc = NisAcc::new(dim);
    for (x, fused) in nis {
        acc.push(*x, *fused);
    }
    acc.finish()
}

/// [`nis_test`] fed one update at a time (the same sums in the same order).
#[derive(Debug, Clone)]
struct NisAcc {
    dim: usize,
    /// Per-update 95 % interval of χ²(dim).
    a: f64,
    b: f64,
    accepted: usize,
    sum: f64,
    rejected: usize,
    tested: usize,
    inside: usize,
}

impl NisAcc {
    fn new(dim: usize) -> Self {
        let m = dim as f64;
        Self {
            dim,
            a: chi2::quantile(0.025, m),
            b: chi2::quantile(0.975, m),
            accepted: 0,
            // The sum of no value, as `Iterator::sum` starts it.
            sum: std::iter::empty::<f64>().sum(),
            rejected: 0,
            tested: 0,
            inside: 0,
        }
    }

    fn push(&mut self, nis: f64, fused: bool) {
        // An infinite NIS (a variance so small its square overflows) is the
        // most overconfident update there is: it counts, and its mean is
        // infinite. Only NaN (no valid component) is no update to test.
        if fused && !nis.is_nan() {
            self.accepted += 1;
            self.sum += nis;
        }
        self.rejected += usize::from(!fused);
        if !nis.is_nan() {
            self.tested += 1;
            self.inside += usize::from(nis >= self.a && nis <= self.b);
        }
    }

    fn finish(&self) -> Option<NisTest> {
        let (n, rejected, dim) = (self.accepted, self.rejected, self.dim);
        if n + rejected == 0 || dim == 0 {
            return None;
        }
        let m = dim as f64;
        let nf = n as f64;
        // No accepted update: no mean (NaN), and every update rejected.
        let mean = self.sum / nf;
        let lo95 = chi2::quantile(0.025, nf * m) / nf;
        let hi95 = chi2::quantile(0.975, nf * m) / nf;
        let lo = lo95.min(m / NIS_TOLERANCE);
        let hi = hi95.max(m * NIS_TOLERANCE);
        let inside = self.inside as f64 / self.tested.max(1) as f64;
        let rej_frac = rejected as f64 / (n + rejected) as f64;
        let verdict = if mean > hi || rej_frac > REJECTED_MAX {
            Verdict::TooOptimistic
        } else if mean < lo {
            Verdict::TooPessimistic
        } else {
            Verdict::Consistent
        };
        Some(NisTest {
            dim,
            accepted: n,
            rejected,
            mean,
            lo95,
            hi95,
            lo,
            hi,
            inside,
            verdict,
        })
    }
}

/// One update: (t, innovation per component, σ per component, accepted, NIS).
type AidSample = (f64, [f64; MAX_COMPONENTS], [f64; MAX_COMPONENTS], bool, f64);

/// A figure's two halves: the panels and the legend strip.
type Halves<DB> = (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>);

/// One drawing function per backend.
type DrawPng<'a> = &'a dyn Fn(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>;
type DrawSvg<'a> = &'a dyn Fn(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>;

/// One aid's updates in physical units, reduced to what the summary and
/// its figure show: the NIS test and, per component, the envelopes of the
/// accepted and rejected innovations and of their σ, and of the NIS.
#[derive(Debug, Clone)]
struct AidSeries {
    kind: AidKind,
    /// Its short name (`SRS`, `baro`).
    name: &'static str,
    /// Its figure's file name, `aid_NAME`.
    file: String,
    /// The unit each component is drawn in.
    units: [&'static str; MAX_COMPONENTS],
    comps: [&'static str; MAX_COMPONENTS],
    /// Updates.
    n: u64,
    dim: usize,
    test: Option<NisTest>,
    /// Per component: accepted (innovation, σ), rejected innovation, σ of all.
    acc: [Envelope; MAX_COMPONENTS],
    rej: [Envelope; MAX_COMPONENTS],
    sig: [Envelope; MAX_COMPONENTS],
    /// log10 of the NIS (floored), accepted and rejected.
    nis_acc: Envelope,
    nis_rej: Envelope,
}

impl AidSeries {
    /// The units of its components, distinct, in order ("m/s", "m, m/s").
    fn unit(&self) -> String {
        let mut u: Vec<&str> = Vec::new();
        for x in &self.units[..self.dim.clamp(1, MAX_COMPONENTS)] {
            if !u.contains(x) {
                u.push(x);
            }
        }
        u.join(", ")
    }

    /// Whether a component is a horizontal position in g given in radians
    /// on the wire (and so converted to metres here).
    fn converts_geographic(&self) -> bool {
        self.kind
            .decl()
            .components
            .iter()
            .any(|c| matches!(c.unit, Unit::LatitudeInG | Unit::LongitudeInG))
    }
}

/// The unit a component is drawn in, and the factor from the wire's unit
/// to it (attitude in arcsec; a geographic-frame angle of position is
/// converted where it was made, see [`aid_sample`]).
fn drawn(unit: Unit) -> (&'static str, f64) {
    match unit {
        Unit::M | Unit::LatitudeInG | Unit::LongitudeInG => ("m", 1.0),
        Unit::Mps => ("m/s", 1.0),
        Unit::Rad => ("arcsec", 180.0 / std::f64::consts::PI * 3600.0),
    }
}

/// Where the solution was in time: thinned (t, frame, lat rad, h) for the
/// conversion of CNS innovations in g (radians) to metres, where they come
/// in the wire's measurement space (status records, JSON MCAP files of
/// earlier versions; the protobuf ones are metres already). In memory, or
/// on disk for a flight streamed in time order (then looked up from a
/// cursor, as the updates come mostly in time order).
#[derive(Debug)]
enum Where {
    Memory(Vec<(f64, char, f64, f64)>),
    Disk {
        spill: Spill<4>,
        last: Option<(f64, char)>,
    },
}

impl Default for Where {
    fn default() -> Self {
        Self::Memory(Vec::new())
    }
}

impl Where {
    fn on_disk() -> Result<Self, String> {
        Ok(Self::Disk {
            spill: Spill::new().map_err(|e| e.to_string())?,
            last: None,
        })
    }

    fn push(&mut self, r: &Row) -> Result<(), String> {
        let last = match self {
            Self::Memory(at) => at.last().map(|l| (l.0, l.1)),
            Self::Disk { last, .. } => *last,
        };
        match last {
            Some(l) if r.t_s - l.0 < 0.5 && r.frame == l.1 => {}
            _ => {
                let x = (r.t_s, r.frame, r.lat_deg.to_radians(), r.h_m);
                match self {
                    Self::Memory(at) => at.push(x),
                    Self::Disk { spill, last } => {
                        spill
                            .push_f64(&[x.0, f64::from(u32::from(x.1)), x.2, x.3])
                            .map_err(|e| e.to_string())?;
                        *last = Some((x.0, x.1));
                    }
                }
            }
        }
        Ok(())
    }

    fn seal(self) -> Result<WhereAt, String> {
        Ok(match self {
            Self::Memory(at) => WhereAt::Memory(at),
            Self::Disk { spill, .. } => WhereAt::Disk {
                at: spill.seal().map_err(|e| e.to_string())?,
                cursor: 0,
            },
        })
    }
}

/// A sealed [`Where`] to look times up in.
#[derive(Debug)]
enum WhereAt {
    Memory(Vec<(f64, char, f64, f64)>),
    Disk { at: Sealed<4>, cursor: u64 },
}

impl WhereAt {
    /// (frame, lat rad, h) of the last entry at or before `t`, else of the
    /// first; `None` without entries.
    fn get(&mut self, t: f64) -> Result<Option<(char, f64, f64)>, String> {
        match self {
            Self::Memory(at) => {
                let k = at.partition_point(|x| x.0 <= t);
                let Some(i) = k.checked_sub(1).or((!at.is_empty()).then_some(0)) else {
                    return Ok(None);
                };
                Ok(at.get(i).map(|x| (x.1, x.2, x.3)))
            }
            Self::Disk { at, cursor } => {
                let n = at.len();
                if n == 0 {
                    return Ok(None);
                }
                let e = |i: u64| at.get_f64(i).map_err(|e| e.to_string());
                // The partition point k (entries before it are at or before
                // t): gallop from the cursor, then bisect.
                let (mut lo, mut hi);
                if e(*cursor)?[0] <= t {
                    (lo, hi) = (*cursor + 1, *cursor + 1);
                    let mut step = 1;
                    while hi < n && e(hi)?[0] <= t {
                        lo = hi + 1;
                        hi = (hi + step).min(n);
                        step *= 2;
                    }
                } else {
                    (lo, hi) = (*cursor, *cursor);
                    let mut step = 1;
                    while lo > 0 && e(lo - 1)?[0] > t {
                        hi = lo - 1;
                        lo = lo.saturating_sub(step);
                        step *= 2;
                    }
                }
                // Entries before lo are at or before t, from hi on after it.
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if e(mid)?[0] <= t {
                        lo = mid + 1;
                    } else {
                        hi = mid;
                    }
                }
                let i = lo.saturating_sub(1);
                *cursor = i;
                let x = e(i)?;
                let frame = char::from_u32(x[1] as u32).unwrap_or('?');
                Ok(Some((frame, x[2], x[3])))
            }
        }
    }
}

/// The sample of aid `kind`'s update `a` in physical units, and the
/// number of its valid components.
fn aid_sample(kind: AidKind, a: &AidPoint, at: &mut WhereAt) -> Result<(AidSample, usize), String> {
    let decl = kind.decl();
    let t = a.t_ns as f64 * 1e-9;
    // Scale of each component to the physical unit: a geographic-frame
    // angle of position into metres, in the frame the daemon says it was
    // made in, else the solution's then (looked up only for an aid that
    // has such a component).
    let mut scale = [1.0; MAX_COMPONENTS];
    for (k, c) in decl.components.iter().take(MAX_COMPONENTS).enumerate() {
        scale[k] = drawn(c.unit).1;
    }
    let geographic = |u: Unit| matches!(u, Unit::LatitudeInG | Unit::LongitudeInG);
    if !a.physical
        && decl.components.iter().any(|c| geographic(c.unit))
        && let Some(('g', lat, h)) = at.get(t)?.map(|(frame, lat, h)| {
            let made = msgs::WireFrame::from_made_in(a.made_in_frame)
                .map_or(frame, msgs::WireFrame::letter);
            (made, lat, h)
        })
    {
        let [n, e] = polarnav::earth::metres_per_radian(lat, h);
        for (k, c) in decl.components.iter().take(MAX_COMPONENTS).enumerate() {
            match c.unit {
                Unit::LatitudeInG => scale[k] = n,
                Unit::LongitudeInG => scale[k] = e,
                _ => {}
            }
        }
    }
    let mut nis = 0.0;
    let mut m = 0;
    let mut v = [f64::NAN; MAX_COMPONENTS];
    let mut sig = [f64::NAN; MAX_COMPONENTS];
    for k in 0..MAX_COMPONENTS {
        let var = a.innovation_var[k];
        if var > 0.0 && var.is_finite() {
            nis += a.innovation[k] * a.innovation[k] / var;
            m += 1;
            v[k] = a.innovation[k] * scale[k];
            sig[k] = var.sqrt() * scale[k];
        }
    }
    Ok((
        (t, v, sig, a.fused != 0, if m > 0 { nis } else { f64::NAN }),
        m,
    ))
}

/// Floor of the NIS axis (log10).
const NIS_FLOOR: f64 = -4.0;

fn aid_series(aids: &Aids<UpdatesOnDisk>, at: &mut WhereAt) -> Result<Vec<AidSeries>, String> {
    let mut out = Vec::new();
    let io = |e: std::io::Error| e.to_string();
    for (kind, pts) in aids.iter() {
        if pts.is_empty() {
            continue;
        }
        let decl = kind.decl();
        let mut units = [""; MAX_COMPONENTS];
        let mut comps = [""; MAX_COMPONENTS];
        for (k, c) in decl.components.iter().take(MAX_COMPONENTS).enumerate() {
            units[k] = drawn(c.unit).0;
            comps[k] = c.label;
        }
        // The dimension first (the most valid components of an update):
        // the NIS interval depends on it.
        let mut dim = 0;
        for_each_update(pts, |a| {
            dim = dim.max(
                a.innovation_var
                    .iter()
                    .filter(|v| **v > 0.0 && v.is_finite())
                    .count(),
            );
        })
        .map_err(io)?;
        let mut s = AidSeries {
            kind,
            name: decl.label,
            file: format!("aid_{}", decl.name),
            units,
            comps,
            n: 0,
            dim,
            test: None,
            acc: std::array::from_fn(|_| Envelope::new(2)),
            rej: std::array::from_fn(|_| Envelope::new(1)),
            sig: std::array::from_fn(|_| Envelope::new(1)),
            nis_acc: Envelope::new(1),
            nis_rej: Envelope::new(1),
        };
        let mut nis = NisAcc::new(dim);
        let mut failed = None;
        for_each_update(pts, |a| {
            if failed.is_some() {
                return;
            }
            let p = match aid_sample(kind, &a, at) {
                Ok((p, _)) => p,
                Err(e) => {
                    failed = Some(e);
                    return;
                }
            };
            s.n += 1;
            nis.push(p.4, p.3);
            for k in 0..dim {
                if p.3 {
                    s.acc[k].push(p.0, &[p.1[k], p.2[k]]);
                } else {
                    s.rej[k].push(p.0, &[p.1[k]]);
                }
                s.sig[k].push(p.0, &[p.2[k]]);
            }
            // A point without a NIS (no valid component) is not drawn: max()
            // would put NaN at the floor, among the small, consistent ones.
            if !p.4.is_nan() {
                let v = p.4.max(1e-300).log10().max(NIS_FLOOR);
                if p.3 {
                    s.nis_acc.push(p.0, &[v]);
                } else {
                    s.nis_rej.push(p.0, &[v]);
                }
            }
        })
        .map_err(io)?;
        if let Some(e) = failed {
            return Err(e);
        }
        s.test = nis.finish();
        out.push(s);
    }
    Ok(out)
}

/// [`aids_from_status`] fed one status record at a time, into vectors or
/// spills.
#[derive(Debug)]
pub struct StatusAids<P> {
    aids: Aids<P>,
    last: PerAid<Option<(u64, [u64; MAX_COMPONENTS])>>,
    points: u64,
}

impl<P: AidSink> StatusAids<P> {
    pub fn new(aids: Aids<P>) -> Self {
        Self {
            aids,
            last: PerAid::default(),
            points: 0,
        }
    }

    /// The updates the status record `st` reports that the records before
    /// it did not.
    pub fn push(&mut self, st: &Status) -> std::io::Result<()> {
        for (k, c, s) in st.each_aid() {
            if c.accepted + c.rejected_gate == 0 {
                continue;
            }
            let key = (c.accepted + c.rejected_gate, s.innovation.map(f64::to_bits));
            if self.last[k] == Some(key) {
                continue;
            }
            self.last[k] = Some(key);
            self.points += 1;
            self.aids[k].put(AidPoint {
                t_ns: st.t_ns,
                innovation: s.innovation,
                innovation_var: s.innovation_var,
                test_ratio: s.test_ratio,
                fused: s.fused,
                physical: false,
                made_in_frame: s.made_in_frame,
            })?;
        }
        Ok(())
    }

    /// The updates, if there was any.
    pub fn finish(self) -> Option<Aids<P>> {
        (self.points > 0).then_some(self.aids)
    }
}

/// The last update of each aid as the log's status records report it
/// (a live recording: one per status, 1 Hz), one point per new update.
pub fn aids_from_status(status: &[Status]) -> Option<Aids> {
    let mut a = StatusAids::new(Aids::<Vec<AidPoint>>::default());
    for st in status {
        // Into vectors: cannot fail.
        let _ = a.push(st);
    }
    a.finish()
}

/// The aids that are not autonomous (tested for integrity; `GNSS`).
const NOT_AUTONOMOUS: usize = {
    let mut n = 0;
    let mut k = 0;
    while k < msgs::AID_COUNT {
        if !AidKind::ALL[k].decl().autonomous {
            n += 1;
        }
        k += 1;
    }
    n
};

/// Lanes of the health timeline: COASTING and IMU lost, the flight state
/// (on the ground, manoeuvre) and the accelerometers' level, each aid
/// stale, each aid that is not autonomous excluded, then fused untested
/// (its integrity test unavailable), then aid reset, rejected update and
/// second publisher.
const LANE_COUNT: usize = 8 + msgs::AID_COUNT + 2 * NOT_AUTONOMOUS;

/// What an aid's lane shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AidLane {
    Stale,
    Excluded,
    Untested,
}

/// A lane of the health timeline: set when the flags' bits `mask` equal
/// `value` (or differ, `clear`, for a fresh flag drawn as stale). `aid`:
/// whose freshness, exclusion or untested fusion.
#[derive(Debug)]
struct Lane {
    name: String,
    mask: u32,
    value: u32,
    clear: bool,
    aid: Option<(AidKind, AidLane)>,
}

/// The lanes, the aids' from their declaration (`msgs::for_each_aid!`).
fn lanes() -> &'static [Lane; LANE_COUNT] {
    static LANES: std::sync::OnceLock<[Lane; LANE_COUNT]> = std::sync::OnceLock::new();
    LANES.get_or_init(|| {
        let flag = |name: &str, bit| Lane {
            name: name.into(),
            mask: bit,
            value: bit,
            clear: false,
            aid: None,
        };
        let state = |name: &str, s: u32| Lane {
            name: name.into(),
            mask: solution_flags::FLIGHT_STATE_MASK,
            value: s << solution_flags::FLIGHT_STATE_SHIFT,
            clear: false,
            aid: None,
        };
        let mut v = vec![
            flag("COASTING", solution_flags::COASTING),
            flag("IMU lost", solution_flags::IMU_LOST),
            // Paper 003 §4.5's flight state (1 ground, 3 manoeuvre; steady
            // is neither) and its attitude compensation.
            state("on the ground", 1),
            state("manoeuvre", 3),
            flag("level from accelerometers", solution_flags::LEVEL_FUSED),
        ];
        v.extend(AidKind::ALL.iter().map(|k| Lane {
            name: format!("{} stale", k.decl().label),
            mask: k.decl().fresh_flag,
            value: k.decl().fresh_flag,
            clear: true,
            aid: Some((*k, AidLane::Stale)),
        }));
        for (what, lane) in [
            ("excluded", AidLane::Excluded),
            ("untested", AidLane::Untested),
        ] {
            v.extend(
                AidKind::ALL
                    .iter()
                    .filter(|k| !k.decl().autonomous)
                    .map(|k| {
                        let bit = match lane {
                            AidLane::Untested => k.decl().untested_flag,
                            _ => k.decl().excluded_flag,
                        };
                        Lane {
                            name: format!("{} {what}", k.decl().label),
                            mask: bit,
                            value: bit,
                            clear: false,
                            aid: Some((*k, lane)),
                        }
                    }),
            );
        }
        v.push(flag("aid reset", solution_flags::AID_RESET));
        v.push(flag(
            "last update rejected",
            solution_flags::LAST_INNOVATION_REJECTED,
        ));
        v.push(flag("second publisher", solution_flags::SECOND_PUBLISHER));
        v.try_into().expect("LANE_COUNT lanes")
    })
}

/// The lane of aid `k`'s freshness, exclusion or untested fusion.
fn lane_of(k: AidKind, lane: AidLane) -> Option<usize> {
    lanes().iter().position(|l| l.aid == Some((k, lane)))
}

/// The label of lane `k` of [`lanes`]: a fresh flag that was clear in
/// every row says the aid never fused in this flight (absent from the log,
/// disabled, or always rejected), not that it went stale.
fn lane_label(pass: &Pass, k: usize) -> String {
    let l = &lanes()[k];
    if l.clear && pass.rows > 0 && pass.health_set[k + 1] == pass.rows {
        l.name.replace("stale", "never fused")
    } else {
        l.name.clone()
    }
}

/// Everything gathered in the one pass over the solution.
#[derive(Debug)]
struct Pass {
    rows: u64,
    t_first: f64,
    t_last: f64,
    duplicates: u64,
    out_of_order: u64,
    /// σ: E, N, U (m); nav x, y, z (m/s); attitude x, y, z (arcmin).
    sigma: Envelope,
    /// Bias estimates (°/h, µg) 0..6, est − σ 6..12, est + σ 12..18.
    bias: Envelope,
    rows_with_bias_sigma: u64,
    /// Frame G 0, then the lanes of [`lanes`].
    health: Envelope,
    health_set: [u64; LANE_COUNT + 1],
    /// Exclusions and readmissions of the aids that are not autonomous,
    /// from their flag in the rows: (time, aid, excluded).
    exclusions: Vec<(f64, AidKind, bool)>,
    /// The integrity test's statistic over its threshold of each aid that
    /// is not autonomous, from the log's status records (0: not tested
    /// yet, not drawn), and the status records that had one.
    integrity: Envelope,
    integrity_tested: u64,
    switches: Vec<Switch>,
    resets: Vec<f64>,
    where_: Where,
    reference: Option<RefPass>,
}

/// The forward solution against the reference.
#[derive(Debug)]
struct RefPass {
    path: String,
    rows: u64,
    matched: u64,
    /// Differences E, N, U (m); nav x, y, z (m/s); nav x, y, z (arcmin) 0..9,
    /// and the forward 3σ of each 9..18.
    diff: Envelope,
    sum_sq: [f64; 9],
    inside: [u64; 9],
    horizontal_sq: f64,
}

const EVENTS_MAX: usize = 10_000;

impl Pass {
    fn new() -> Self {
        Self {
            rows: 0,
            t_first: f64::NAN,
            t_last: f64::NAN,
            duplicates: 0,
            out_of_order: 0,
            sigma: Envelope::new(9),
            bias: Envelope::new(18),
            rows_with_bias_sigma: 0,
            health: Envelope::new(LANE_COUNT + 1),
            health_set: [0; LANE_COUNT + 1],
            exclusions: Vec::new(),
            integrity: Envelope::new(2 * NOT_AUTONOMOUS.max(1)),
            integrity_tested: 0,
            switches: Vec::new(),
            resets: Vec::new(),
            where_: Where::default(),
            reference: None,
        }
    }

    fn push(&mut self, r: &Row, sig: Option<[f64; 6]>, prev: Option<&Row>) -> Result<(), String> {
        self.rows += 1;
        let t = r.t_s;
        if self.t_first.is_nan() {
            self.t_first = t;
        }
        match prev {
            Some(p) if t.to_bits() == p.t_s.to_bits() => self.duplicates += 1,
            Some(p) if t < p.t_s => self.out_of_order += 1,
            _ => {}
        }
        if self.t_last.is_nan() || t > self.t_last {
            self.t_last = t;
        }
        let s = &r.sigma_enu_m;
        let v = &r.sigma_vel_nav_mps;
        let a = r.sigma_att_deg.map(|x| x * 60.0);
        self.sigma
            .push(t, &[s[0], s[1], s[2], v[0], v[1], v[2], a[0], a[1], a[2]]);
        let est = [
            r.gyro_bias_rps[0] * DEG_PER_H,
            r.gyro_bias_rps[1] * DEG_PER_H,
            r.gyro_bias_rps[2] * DEG_PER_H,
            r.accel_bias_mps2[0] * MICRO_G,
            r.accel_bias_mps2[1] * MICRO_G,
            r.accel_bias_mps2[2] * MICRO_G,
        ];
        let mut b = [f64::NAN; 18];
        b[..6].copy_from_slice(&est);
        if let Some(sg) = sig {
            self.rows_with_bias_sigma += 1;
            for k in 0..6 {
                let unit = if k < 3 { DEG_PER_H } else { MICRO_G };
                b[6 + k] = est[k] - sg[k] * unit;
                b[12 + k] = est[k] + sg[k] * unit;
            }
        }
        self.bias.push(t, &b);
        let mut h = [0.0; LANE_COUNT + 1];
        h[0] = f64::from(u8::from(r.frame == 'G'));
        for (k, l) in lanes().iter().enumerate() {
            h[k + 1] = f64::from(u8::from((r.flags & l.mask == l.value) != l.clear));
        }
        for k in AidKind::ALL.iter().filter(|k| !k.decl().autonomous) {
            let bit = k.decl().excluded_flag;
            let was = prev.is_some_and(|p| p.flags & bit != 0);
            let is = r.flags & bit != 0;
            if was != is && self.exclusions.len() < EVENTS_MAX {
                self.exclusions.push((t, *k, is));
            }
        }
        for (k, x) in h.iter().enumerate() {
            self.health_set[k] += u64::from(*x > 0.0);
        }
        self.health.push(t, &h);
        if let Some(p) = prev {
            if p.frame != r.frame && self.switches.len() < EVENTS_MAX {
                self.switches.extend(figures::switches(&[*p, *r]));
            }
            if r.reset_count > p.reset_count && self.resets.len() < EVENTS_MAX {
                self.resets.push(t);
            }
        }
        self.where_.push(r)
    }
}

impl RefPass {
    fn add(&mut self, fwd: &[Row], reference: &[TruthRecord]) {
        for e in eval::epochs(fwd, reference) {
            let Some(r) = fwd
                .binary_search_by(|x| x.t_s.total_cmp(&e.t_s))
                .ok()
                .map(|i| &fwd[i])
            else {
                continue;
            };
            self.matched += 1;
            let d = [
                e.pos_enu.x,
                e.pos_enu.y,
                e.pos_enu.z,
                e.vel_nav.x,
                e.vel_nav.y,
                e.vel_nav.z,
                e.att_nav.x * ARCMIN,
                e.att_nav.y * ARCMIN,
                e.att_nav.z * ARCMIN,
            ];
            let s = [
                r.sigma_enu_m[0],
                r.sigma_enu_m[1],
                r.sigma_enu_m[2],
                r.sigma_vel_nav_mps[0],
                r.sigma_vel_nav_mps[1],
                r.sigma_vel_nav_mps[2],
                r.sigma_att_deg[0] * 60.0,
                r.sigma_att_deg[1] * 60.0,
                r.sigma_att_deg[2] * 60.0,
            ];
            let mut v = [0.0; 18];
            for k in 0..9 {
                v[k] = d[k];
                v[9 + k] = 3.0 * s[k];
                self.sum_sq[k] += d[k] * d[k];
                self.inside[k] += u64::from(d[k].abs() <= 3.0 * s[k]);
            }
            self.horizontal_sq += d[0] * d[0] + d[1] * d[1];
            self.diff.push(e.t_s, &v);
        }
    }
}

/// A solution's rows, from a CSV (streamed) or an MCAP file (loaded).
pub type RowIter = Box<dyn Iterator<Item = Result<(Row, Option<[f64; 6]>), String>>>;

fn open_rows(path: &Path) -> Result<(RowIter, Option<Aids>), String> {
    if solution_file::is_mcap(path) {
        let l = solution_file::load(path)?;
        let rows = l.rows.into_iter().zip(l.bias_sigma).map(Ok);
        Ok((Box::new(rows), l.aids))
    } else {
        Ok((Box::new(CsvRows::open(path)?), None))
    }
}

fn truth_of(r: &Row) -> TruthRecord {
    TruthRecord {
        t_ns: (r.t_s * 1e9).round().max(0.0) as u64,
        r_e_m: r.r_e_m,
        v_e_mps: r.v_e_mps,
        q_b_e: r.q_b_e,
    }
}

/// Pairs per batch handed to [`eval::epochs`].
const REF_BATCH: usize = 4096;

/// The review fed as the flight streams in: the log's records
/// ([`Reviewer::log_record`]) and the solution's rows ([`Reviewer::row`]),
/// then [`Reviewer::finish`] with the solution's aid updates. Memory holds
/// envelopes, counters and buffers; what a figure needs of every update or
/// IMU interval goes to a [`Spill`] on disk.
pub struct Reviewer<'a> {
    opts: Options<'a>,
    pass: Pass,
    reference: Option<std::iter::Peekable<RowIter>>,
    prev: Option<Row>,
    fwd_batch: Vec<Row>,
    ref_batch: Vec<TruthRecord>,
    sampling: SamplingAcc,
    status: StatusAids<Spill<AID_WORDS>>,
    header: Option<Header>,
}

impl std::fmt::Debug for Reviewer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Reviewer")
            .field("opts", &self.opts)
            .field("rows", &self.pass.rows)
            .finish_non_exhaustive()
    }
}

fn io_err(e: std::io::Error) -> String {
    e.to_string()
}

/// A new spill, its error as text.
fn spill<const W: usize>() -> Result<Spill<W>, String> {
    Spill::new().map_err(io_err)
}

impl<'a> Reviewer<'a> {
    /// A reviewer of `opts.solution`, its rows joined with `reference`'s
    /// (the rows of `opts.reference`, in time order). `where_on_disk`: the
    /// solution comes in time order, so its positions over time can be
    /// kept on disk and looked up from a cursor.
    pub fn new(
        opts: Options<'a>,
        reference: Option<RowIter>,
        where_on_disk: bool,
    ) -> Result<Self, String> {
        let mut pass = Pass::new();
        if where_on_disk {
            pass.where_ = Where::on_disk()?;
        }
        if let Some(p) = opts.reference {
            pass.reference = Some(RefPass {
                path: p.display().to_string(),
                rows: 0,
                matched: 0,
                diff: Envelope::new(18),
                sum_sq: [0.0; 9],
                inside: [0; 9],
                horizontal_sq: 0.0,
            });
        }
        Ok(Self {
            opts,
            pass,
            reference: reference.map(Iterator::peekable),
            prev: None,
            fwd_batch: Vec::new(),
            ref_batch: Vec::new(),
            sampling: SamplingAcc::new()?,
            status: StatusAids::new(try_map_aids(PerAid::from_fn(|_| spill()), |s| s)?),
            header: None,
        })
    }

    /// A record of the log: its header (the last one read is the log's),
    /// IMU samples (the sampling) and status records (the aid updates of a
    /// recording); the others are not reviewed.
    pub fn log_record(&mut self, r: &Record) -> Result<(), String> {
        match r {
            Record::Header(h) => self.header = Some((**h).clone()),
            Record::Imu(x) => self.sampling.push(x.t_ns)?,
            Record::Status(st) => self.status_record(st)?,
            _ => {}
        }
        Ok(())
    }

    /// A status record of the log: the aids' last updates and the
    /// integrity test's statistic.
    pub fn status_record(&mut self, st: &Status) -> Result<(), String> {
        self.status.push(st).map_err(io_err)?;
        // Per aid that is not autonomous: its statistic where its test
        // could judge, then (the second half) where it was unavailable.
        let mut v = [f64::NAN; 2 * NOT_AUTONOMOUS];
        let tested = AidKind::ALL.iter().filter(|k| !k.decl().autonomous);
        for (j, k) in tested.enumerate() {
            let a = st.aid(*k);
            if a.integrity_ratio > 0.0 {
                let unavailable = a.integrity_state == msgs::integrity_state::UNAVAILABLE;
                v[j + if unavailable { NOT_AUTONOMOUS } else { 0 }] = a.integrity_ratio;
            }
        }
        if v.iter().any(|x| x.is_finite()) {
            self.pass.integrity_tested += 1;
            self.pass.integrity.push(st.t_ns as f64 * 1e-9, &v);
        }
        Ok(())
    }

    /// The next row of the solution, in file order.
    pub fn row(&mut self, row: Row, sig: Option<[f64; 6]>) -> Result<(), String> {
        let pass = &mut self.pass;
        if !row.t_s.is_finite() {
            return Err(format!(
                "{}: row {} has a non-finite time t_s = {}",
                self.opts.solution.display(),
                pass.rows + 1,
                row.t_s
            ));
        }
        pass.push(&row, sig, self.prev.as_ref())?;
        if let (Some(it), Some(rp)) = (self.reference.as_mut(), pass.reference.as_mut()) {
            // Merge join on time (both in time order; 1 µs tolerance).
            while let Some(next) = it.peek() {
                match next {
                    Err(_) => {
                        if let Some(Err(e)) = it.next() {
                            return Err(e);
                        }
                    }
                    // A time that orders nowhere would stop the join here
                    // and leave every later row unmatched without a word.
                    Ok((x, _)) if !x.t_s.is_finite() => {
                        return Err(format!(
                            "{}: row {} has a non-finite time t_s = {}",
                            rp.path,
                            rp.rows + 1,
                            x.t_s
                        ));
                    }
                    Ok((x, _)) if x.t_s < row.t_s - 1e-6 => {
                        rp.rows += 1;
                        it.next();
                    }
                    Ok((x, _)) if (x.t_s - row.t_s).abs() <= 1e-6 => {
                        rp.rows += 1;
                        self.ref_batch.push(truth_of(x));
                        // The epoch is keyed by the reference's time.
                        let mut f = row;
                        f.t_s = (x.t_s * 1e9).round() * 1e-9;
                        self.fwd_batch.push(f);
                        it.next();
                        break;
                    }
                    Ok(_) => break,
                }
            }
            if self.fwd_batch.len() >= REF_BATCH {
                rp.add(&self.fwd_batch, &self.ref_batch);
                self.fwd_batch.clear();
                self.ref_batch.clear();
            }
        }
        self.prev = Some(row);
        Ok(())
    }

    /// The review: `mcap_aids` are the solution's own aid updates (an MCAP
    /// solution), else those of the log's status records are reviewed.
    pub fn finish(mut self, mcap_aids: Option<Aids<UpdatesOnDisk>>) -> Result<Review, String> {
        if let Some(rp) = self.pass.reference.as_mut() {
            rp.add(&self.fwd_batch, &self.ref_batch);
            if let Some(it) = self.reference.as_mut() {
                for r in it {
                    r?;
                    rp.rows += 1;
                }
            }
        }
        if self.pass.rows == 0 {
            return Err(format!("{}: no solution row", self.opts.solution.display()));
        }
        let status = match self.status.finish() {
            Some(a) => Some(try_map_aids(a, Spill::seal).map_err(io_err)?),
            None => None,
        };
        let samp = self.sampling.finish()?;
        let mut at = std::mem::take(&mut self.pass.where_).seal()?;
        report(
            &self.pass,
            mcap_aids,
            status,
            &mut at,
            samp,
            self.header.as_ref(),
            &self.opts,
        )
    }
}

/// The IMU sampling of the log.
#[derive(Debug)]
struct Sampling {
    samples: u64,
    nominal_s: f64,
    /// interval (ms) over time.
    dt: Envelope,
    /// Histogram of the intervals: 80 bins from 0 to 3× nominal, and one
    /// for longer ones (and non-finite).
    counts: [u64; HIST_BINS + 1],
    /// Intervals longer than 1.5× the nominal: how many, their total length
    /// (s), and the longest 20 (start t, length s), longest first (in time
    /// order where equal).
    gaps: u64,
    gaps_s: f64,
    longest: Vec<(f64, f64)>,
    backwards: u64,
    duplicates: u64,
}

/// Bins of the interval histogram (besides the one for longer intervals).
const HIST_BINS: usize = 80;
/// Gaps listed in the summary.
const GAPS_LISTED: usize = 20;

/// The sampling read one IMU time at a time: each interval (with the time
/// it starts at) goes to disk, as the nominal interval (the median) and
/// what depends on it are known only at the end.
#[derive(Debug)]
struct SamplingAcc {
    samples: u64,
    prev: Option<u64>,
    dt: Envelope,
    intervals: Spill<2>,
}

impl SamplingAcc {
    fn new() -> Result<Self, String> {
        Ok(Self {
            samples: 0,
            prev: None,
            dt: Envelope::new(1),
            intervals: spill()?,
        })
    }

    fn push(&mut self, t_ns: u64) -> Result<(), String> {
        if let Some(p) = self.prev {
            let d = (t_ns as f64 - p as f64) * 1e-9;
            self.dt.push(t_ns as f64 * 1e-9, &[d * 1e3]);
            self.intervals
                .push_f64(&[p as f64 * 1e-9, d])
                .map_err(io_err)?;
        }
        self.prev = Some(t_ns);
        self.samples += 1;
        Ok(())
    }

    fn finish(self) -> Result<Option<Sampling>, String> {
        if self.samples < 2 {
            return Ok(None);
        }
        let intervals = self.intervals.seal().map_err(io_err)?;
        // The median as `select_nth_unstable_by(len / 2, total_cmp)` picks it.
        let mid = intervals.len() / 2;
        let nominal = kth_smallest(&[Some(mid)], |f| {
            intervals.for_each_f64(|x| f(0, total_order_key(x[1])))
        })
        .map_err(io_err)?[0]
            .map_or(f64::NAN, from_total_order_key);
        let nominal_ms = (nominal * 1e3).max(1e-6);
        let top_ms = 3.0 * nominal_ms;
        let mut s = Sampling {
            samples: self.samples,
            nominal_s: nominal,
            dt: self.dt,
            counts: [0; HIST_BINS + 1],
            gaps: 0,
            gaps_s: std::iter::empty::<f64>().sum(),
            longest: Vec::new(),
            backwards: 0,
            duplicates: 0,
        };
        intervals
            .for_each_f64(|&[t0, d]| {
                if d < 0.0 {
                    s.backwards += 1;
                } else if d == 0.0 {
                    s.duplicates += 1;
                } else if nominal > 0.0 && d > 1.5 * nominal {
                    s.gaps += 1;
                    s.gaps_s += d;
                    let at = s
                        .longest
                        .partition_point(|g| g.1.total_cmp(&d) != std::cmp::Ordering::Less);
                    if at < GAPS_LISTED {
                        s.longest.insert(at, (t0, d));
                        s.longest.truncate(GAPS_LISTED);
                    }
                }
                let ms = d * 1e3;
                let i = if ms >= top_ms || !ms.is_finite() {
                    HIST_BINS
                } else {
                    ((ms.max(0.0) / top_ms) * HIST_BINS as f64) as usize
                };
                s.counts[i.min(HIST_BINS)] += 1;
            })
            .map_err(io_err)?;
        Ok(Some(s))
    }
}

/// The settings text's value of `key = number` (the first such line).
fn setting(text: &str, key: &str) -> Option<f64> {
    text.lines().find_map(|l| {
        let (k, v) = l.split_once('=')?;
        (k.trim() == key).then(|| v.split('#').next()?.trim().parse().ok())?
    })
}

/// Reviews the flight of `log` and `opts.solution` (read through once;
/// an MCAP solution, and reference, in memory, sorted by time).
pub fn review(log: &LogContents, opts: &Options<'_>) -> Result<Review, String> {
    let (rows, mcap_aids) = open_rows(opts.solution)?;
    let reference = match opts.reference {
        Some(p) => Some(open_rows(p)?.0),
        None => None,
    };
    let mut r = Reviewer::new(*opts, reference, false)?;
    for row in rows {
        let (row, sig) = row?;
        r.row(row, sig)?;
    }
    if let Some(h) = &log.header {
        r.header = Some(h.clone());
    }
    for x in &log.imu {
        r.sampling.push(x.t_ns)?;
    }
    for st in &log.status {
        r.status_record(st)?;
    }
    let mcap_aids = match mcap_aids {
        Some(a) => Some(aids_to_disk(a)?),
        None => None,
    };
    r.finish(mcap_aids)
}

/// The review's summary and figures from what the pass gathered.
fn report(
    pass: &Pass,
    mcap_aids: Option<Aids<UpdatesOnDisk>>,
    status_aids: Option<Aids<UpdatesOnDisk>>,
    at: &mut WhereAt,
    samp: Option<Sampling>,
    header: Option<&Header>,
    opts: &Options<'_>,
) -> Result<Review, String> {
    let faults = injected(header);
    let integrity = (pass.integrity_tested > 0).then_some(&pass.integrity);
    let (aids, aid_source) = match mcap_aids {
        Some(a) => (
            Some(a),
            "every gated update, from the MCAP solution's /aid/* channels",
        ),
        None => match status_aids {
            Some(a) => (
                Some(a),
                "the last update of each aid per status record of the log (a recording: 1 Hz), not every update",
            ),
            None => (None, ""),
        },
    };
    let series = match &aids {
        Some(a) => aid_series(a, at)?,
        None => Vec::new(),
    };
    let mut md = String::new();
    let mut figures = Vec::new();
    let mut missing: Vec<String> = Vec::new();
    let mut verdicts = Vec::new();

    let _ = writeln!(md, "## Review without truth: {}\n", opts.solution.display());
    let _ = writeln!(
        md,
        "{} solution rows, t = {:.3} … {:.3} s{}{}.\n",
        pass.rows,
        pass.t_first,
        pass.t_last,
        if pass.duplicates > 0 {
            format!(", {} rows repeat the previous time", pass.duplicates)
        } else {
            String::new()
        },
        if pass.out_of_order > 0 {
            format!(", {} rows go back in time", pass.out_of_order)
        } else {
            String::new()
        },
    );

    // Settings and versions.
    md.push_str("### Settings and versions\n\n");
    let _ = writeln!(
        md,
        "- reviewed by polarnav-eval {}",
        env!("CARGO_PKG_VERSION")
    );
    let settings_text = match header {
        Some(h) => {
            let _ = writeln!(
                md,
                "- log written by `{}` (navlog format {}), scenario/source `{}`, seed {}",
                h.producer, h.format_version, h.scenario, h.seed
            );
            h.metadata.clone()
        }
        None => {
            md.push_str("- the log has no header: producer and settings unknown\n");
            String::new()
        }
    };
    md.push_str(
        "- the solution file does not record the batch command's own configuration file or command-line overrides: `nav-daemon batch` prints them at start (keep that log beside the run); the settings below are those the log carried, which batch applies over its configuration file\n",
    );
    if settings_text.trim().is_empty() {
        md.push_str("- the log header carries no settings text\n\n");
    } else {
        let _ = writeln!(md, "\n```toml\n{}\n```\n", settings_text.trim());
    }

    // Consistency per aid.
    md.push_str("### Noise-model consistency per aid (NIS)\n\n");
    if series.is_empty() {
        md.push_str(
            "- no aid updates: a solution CSV has no innovations, and the log has no status records; \
             write the run as MCAP (`nav-daemon batch --log LOG --out run.mcap`) and pass `--solution run.mcap`\n\n",
        );
        missing.push(
            "no `innovations` figure (nor `aid_*` and their NIS): a solution CSV has no innovations; write the run as MCAP (`nav-daemon batch --log LOG --out run.mcap`) and pass `--solution run.mcap`".into(),
        );
    } else {
        let _ = writeln!(md, "Innovations: {aid_source}.\n");
        md.push_str(
            "Test: the mean normalized innovation squared (NIS = Σ νₖ²/Sₖₖ over the m components, \
             whose mean is m whatever the correlation between components) over the N accepted updates, \
             against the two-sided 95 % bounds of the mean of N independent χ²(m), χ²₀.₀₂₅(N·m)/N … \
             χ²₀.₉₇₅(N·m)/N, widened to m/2 … 2m: aid errors are correlated over many updates and \
             the accepted ones are truncated at the gate, so the plain bounds (±2.8 % at N = 10 000) \
             would fail nearly every long flight; a factor 2 in variance is √2 in σ. \
             More than 1 % rejected at the gate (a consistent aid loses 0.1 % at the 99.9 % gate) is too optimistic on its own. \
             \"inside\" is the fraction of updates whose NIS is within χ²₀.₀₂₅(m) … χ²₀.₉₇₅(m) (95 % expected).\n\n",
        );
        md.push_str("| aid | m | accepted | rejected | mean NIS | 95 % bounds | with tolerance | inside | verdict |\n|---|---|---|---|---|---|---|---|---|\n");
        for s in &series {
            match s.test {
                Some(t) => {
                    let _ = writeln!(
                        md,
                        "| {} | {} | {} | {} | {:.3} | {:.3} … {:.3} | {:.3} … {:.3} | {:.1} % | **{}** |",
                        s.name,
                        t.dim,
                        t.accepted,
                        t.rejected,
                        t.mean,
                        t.lo95,
                        t.hi95,
                        t.lo,
                        t.hi,
                        100.0 * t.inside,
                        t.verdict.text()
                    );
                    verdicts.push((s.name, t.verdict));
                }
                None => {
                    let _ = writeln!(
                        md,
                        "| {} | {} | 0 | {} | – | – | – | – | no accepted update |",
                        s.name, s.dim, s.n
                    );
                }
            }
        }
        md.push('\n');
        let preset =
            setting(&settings_text, "preset").is_some() || settings_text.contains("preset =");
        for (name, v) in &verdicts {
            match v {
                Verdict::Consistent => {}
                Verdict::TooOptimistic => {
                    let _ = writeln!(
                        md,
                        "- {name} is **too optimistic**: its innovations are larger than the filter predicts. \
                         Either the σ its records state is too small for this sensor (raise it at the source), \
                         or the IMU drifts more than the filter's model: if your IMU's biases drift, take the \
                         `[filter] preset` of its grade in `config/nav-daemon.toml` (`navigation`, `tactical` \
                         or `mems`: one Gauss–Markov process per bias){}.",
                        if preset {
                            " (the log's settings already name a preset: take the next coarser grade)"
                        } else {
                            ""
                        }
                    );
                }
                Verdict::TooPessimistic => {
                    let _ = writeln!(
                        md,
                        "- {name} is **too pessimistic**: its innovations are smaller than the filter predicts. \
                         Either the σ its records state is larger than the sensor's noise, or the IMU model is \
                         of a coarser grade than the sensor: in `config/nav-daemon.toml` leave `[filter] preset` \
                         unset (constant biases, the papers/001 Table 1 defaults) or take a finer grade."
                    );
                }
            }
        }
        md.push('\n');
    }

    // Figures.
    let fmt = plots::init_fonts();
    let (t0, t1) = (pass.t_first, pass.t_last.max(pass.t_first + 1.0));
    let x = Some((t0, t1));
    if let Some(dir) = opts.out {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut fig = |name: &str,
                       size: (u32, u32),
                       what: &str,
                       f: DrawPng<'_>,
                       g: DrawSvg<'_>|
         -> Result<(), String> {
            let path = dir.join(format!("{name}.{}", fmt.ext()));
            match fmt {
                Format::Png => {
                    let root = BitMapBackend::new(&path, size).into_drawing_area();
                    root.fill(&WHITE).map_err(plots::s)?;
                    f(&root)?;
                    root.present().map_err(plots::s)?;
                }
                Format::Svg => {
                    let root = SVGBackend::new(&path, size).into_drawing_area();
                    root.fill(&WHITE).map_err(plots::s)?;
                    g(&root)?;
                    root.present().map_err(plots::s)?;
                }
            }
            figures.push(Figure {
                path,
                what: what.into(),
            });
            Ok(())
        };
        let sw = &pass.switches;
        for s in &series {
            let h = 330 * (s.dim as u32 + 1) + 80;
            let what = format!(
                "{} innovations ({}) with ±1σ/±3σ, accepted and rejected, and NIS against χ²({})",
                s.kind.decl().title,
                s.unit(),
                s.kind.decl().dof()
            );
            fig(
                &s.file,
                (1700, h),
                &what,
                &|r| aid_figure(r, s, sw, x),
                &|r| aid_figure(r, s, sw, x),
            )?;
        }
        fig(
            "health",
            (1700, 900),
            "health timeline: frame, switches, resets, COASTING, IMU lost, stale aids, second publisher",
            &|r| health_figure(r, pass, x),
            &|r| health_figure(r, pass, x),
        )?;
        fig(
            "aids",
            (1700, 220 + 90 * msgs::AID_COUNT as u32),
            "which aids navigated when: fused within their timeout, excluded by the integrity test, and the faults injected",
            &|r| aids_figure(r, pass, &faults, x),
            &|r| aids_figure(r, pass, &faults, x),
        )?;
        match integrity {
            Some(env) => fig(
                "integrity",
                (1700, 700),
                "the integrity test of the aids that are not autonomous: statistic over its threshold (log scale), exclusions, readmissions and the time to alarm",
                &|r| integrity_figure(r, env, pass, &faults, x),
                &|r| integrity_figure(r, env, pass, &faults, x),
            )?,
            None => missing.push(
                "no `integrity` figure: the log has no status record with an integrity test (a live recording has them; `batch` writes none)".into(),
            ),
        }
        if let Some(sm) = &samp {
            fig(
                "imu_sampling",
                (1700, 900),
                "IMU sampling: interval per sample over time (ms) and its histogram",
                &|r| sampling_figure(r, sm, sw),
                &|r| sampling_figure(r, sm, sw),
            )?;
        } else {
            missing.push("no `imu_sampling` figure: the log has fewer than two IMU samples".into());
        }
        fig(
            "sigma",
            (1700, 1100),
            "1-σ of position (m), velocity (m/s) and attitude (arcmin) over time, log scale",
            &|r| sigma_figure(r, pass, x),
            &|r| sigma_figure(r, pass, x),
        )?;
        fig(
            "biases",
            (1700, 1000),
            "gyro (°/h) and accelerometer (µg) bias estimates with ±1σ where the solution carries it",
            &|r| bias_figure(r, pass, x),
            &|r| bias_figure(r, pass, x),
        )?;
        if let Some(rp) = &pass.reference {
            if rp.matched > 0 {
                fig(
                    "reference_difference",
                    (1700, 1250),
                    "forward − reference: position (m), velocity (m/s), attitude (arcmin) with the forward ±3σ",
                    &|r| reference_figure(r, rp, sw, x),
                    &|r| reference_figure(r, rp, sw, x),
                )?;
            } else {
                missing.push(format!(
                    "no `reference_difference` figure: no row of {} has the time of a solution row",
                    rp.path
                ));
            }
        }
    }
    if pass.rows_with_bias_sigma == 0 {
        missing.push(format!(
            "`biases` without σ bands: the solution has no bias σ (CSV columns and protobuf `/solution` fields {}, JSON `/solution` fields {} of earlier MCAP files; written by solution version 3 and later)",
            solution_file::BIAS_SIGMA_COLUMNS.join(", "),
            solution_file::BIAS_SIGMA_FIELDS.join(", ")
        ));
    }

    // Reference.
    if let Some(rp) = &pass.reference {
        let _ = writeln!(
            md,
            "### Forward against the reference {}\n\n{} reference rows, {} at the time of a forward row.\n",
            rp.path, rp.rows, rp.matched
        );
        if rp.matched > 0 {
            let n = rp.matched as f64;
            let rms = |k: usize| (rp.sum_sq[k] / n).sqrt();
            let inside = |k: usize| 100.0 * rp.inside[k] as f64 / n;
            let _ = writeln!(
                md,
                "Horizontal position RMS {:.3} m, vertical {:.3} m.\n",
                (rp.horizontal_sq / n).sqrt(),
                rms(2)
            );
            md.push_str("| component | RMS | inside forward ±3σ |\n|---|---|---|\n");
            let names = [
                "east (m)",
                "north (m)",
                "up (m)",
                "velocity nav x (m/s)",
                "velocity nav y (m/s)",
                "velocity nav z (m/s)",
                "tilt nav x (arcmin)",
                "tilt nav y (arcmin)",
                "heading (arcmin)",
            ];
            for (k, name) in names.iter().enumerate() {
                let _ = writeln!(md, "| {name} | {:.4} | {:.1} % |", rms(k), inside(k));
            }
            md.push('\n');
        }
    }

    // IMU sampling.
    md.push_str("### IMU sampling\n\n");
    match &samp {
        Some(s) => {
            let _ = writeln!(
                md,
                "{} samples, nominal interval {:.3} ms (median); {} intervals longer than 1.5× nominal{}{}.\n",
                s.samples,
                s.nominal_s * 1e3,
                s.gaps,
                if s.duplicates > 0 {
                    format!(", {} repeated stamps", s.duplicates)
                } else {
                    String::new()
                },
                if s.backwards > 0 {
                    format!(", {} stamps going back", s.backwards)
                } else {
                    String::new()
                },
            );
            if s.gaps > 0 {
                let _ = writeln!(
                    md,
                    "Gaps (longest first, at most 20 of {}; {:.3} s in all):\n\n| starts at t (s) | length (ms) |\n|---|---|",
                    s.gaps, s.gaps_s
                );
                for (t, d) in &s.longest {
                    let _ = writeln!(md, "| {t:.4} | {:.3} |", d * 1e3);
                }
                md.push('\n');
            }
        }
        None => md.push_str("The log has fewer than two IMU samples.\n\n"),
    }

    // Health counts.
    md.push_str("### Health\n\n");
    let pct = |k: usize| 100.0 * pass.health_set[k] as f64 / pass.rows.max(1) as f64;
    let _ = writeln!(
        md,
        "- frame G (grid): {:.1} % of rows; {} frame switches; {} resets",
        pct(0),
        pass.switches.len(),
        pass.resets.len()
    );
    for k in 0..LANE_COUNT {
        let name = lane_label(pass, k);
        if name.contains("never fused") {
            let _ = writeln!(
                md,
                "- {name}: its fresh flag is clear in every row (the aid is absent from the log, disabled, or always rejected)"
            );
        } else {
            let _ = writeln!(md, "- {name}: {:.2} % of rows", pct(k + 1));
        }
    }
    md.push('\n');
    md.push_str(&aids_section(pass, &faults));

    Ok(Review {
        markdown: md,
        figures,
        verdicts,
    })
    .map(|mut r| {
        if opts.out.is_some() {
            r.markdown.push_str("### Figures (review)\n\n");
            for f in &r.figures {
                let n = f
                    .path
                    .file_name()
                    .map_or_else(String::new, |x| x.to_string_lossy().into_owned());
                let _ = writeln!(r.markdown, "- `{n}`: {}\n\n  ![{n}]({n})", f.what);
            }
            for m in &missing {
                let _ = writeln!(r.markdown, "- {m}");
            }
            r.markdown.push('\n');
        }
        r
    })
}

/// Faults injected into the aids that are not autonomous, from the
/// simulated scenario's text in the log's header (its `metadata`:
/// `[[faults.event]]` tables whose
/// `kind` starts with the aid's name): (aid, kind, start s). Empty for a
/// real flight.
fn injected(header: Option<&Header>) -> Vec<(AidKind, String, f64)> {
    let Some(h) = header else {
        return Vec::new();
    };
    h.metadata
        .split("[[faults.event]]")
        .skip(1)
        .filter_map(|block| {
            // The table ends where the next one starts.
            let block = block.split("\n[").next()?;
            let kind = block.lines().find_map(|l| {
                let (k, v) = l.split_once('=')?;
                (k.trim() == "kind").then(|| {
                    v.split('#')
                        .next()
                        .unwrap_or("")
                        .trim()
                        .trim_matches('"')
                        .to_owned()
                })
            })?;
            let aid = AidKind::ALL.into_iter().find(|k| {
                !k.decl().autonomous && kind.starts_with(&format!("{}_", k.decl().name))
            })?;
            Some((aid, kind, setting(block, "start_s")?))
        })
        .collect()
}

/// The first exclusion of `aid` at or after `t0` (s).
fn first_exclusion(pass: &Pass, aid: AidKind, t0: f64) -> Option<f64> {
    pass.exclusions
        .iter()
        .find(|(t, k, ex)| *k == aid && *ex && *t >= t0)
        .map(|e| e.0)
}

/// The review's words on which aids navigated, the exclusions and the time
/// to alarm of each injected fault.
fn aids_section(pass: &Pass, faults: &[(AidKind, String, f64)]) -> String {
    let mut md = String::from("### Which aids navigated\n\n");
    let rows = pass.rows.max(1) as f64;
    for k in AidKind::ALL {
        let Some(c) = lane_of(k, AidLane::Stale) else {
            continue;
        };
        let fresh = pass.rows - pass.health_set[c + 1];
        let _ = write!(
            md,
            "- {} ({}): fused within its timeout in {:.2} % of rows",
            k.decl().label,
            k.decl().title,
            100.0 * fresh as f64 / rows
        );
        if let Some(e) = lane_of(k, AidLane::Excluded) {
            let ex: Vec<&(f64, AidKind, bool)> =
                pass.exclusions.iter().filter(|x| x.1 == k).collect();
            let n = ex.iter().filter(|x| x.2).count();
            let _ = write!(
                md,
                "; excluded by its integrity test in {:.2} % of rows, {n} exclusion{}",
                100.0 * pass.health_set[e + 1] as f64 / rows,
                if n == 1 { "" } else { "s" }
            );
            let times: Vec<String> = ex
                .iter()
                .take(20)
                .map(|(t, _, on)| {
                    format!(
                        "{} at {t:.3} s",
                        if *on { "excluded" } else { "readmitted" }
                    )
                })
                .collect();
            if !times.is_empty() {
                let _ = write!(md, " ({})", times.join(", "));
            }
        }
        if let Some(u) = lane_of(k, AidLane::Untested) {
            let _ = write!(
                md,
                "; its integrity test unavailable (its horizontal protection level from the \
                 reference beyond the alert limit: its samples fused untested) in {:.2} % of rows",
                100.0 * pass.health_set[u + 1] as f64 / rows
            );
        }
        md.push('\n');
    }
    for (aid, kind, t0) in faults {
        let _ = match first_exclusion(pass, *aid, *t0) {
            Some(t) => writeln!(
                md,
                "- fault `{kind}` injected at {t0:.3} s: {} excluded at {t:.3} s, time to alarm {:.3} s",
                aid.decl().label,
                t - t0
            ),
            None => writeln!(
                md,
                "- fault `{kind}` injected at {t0:.3} s: {} never excluded after it (a jammed receiver stops giving fixes: the aid goes stale instead)",
                aid.decl().label
            ),
        };
    }
    md.push('\n');
    md
}

/// A chart of horizontal lanes over time, `names[0]` at the top, each lane
/// `i` centred on y = `names.len() − 1 − i` (the health and aids figures).
fn lane_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    names: &[String],
    (t0, t1): (f64, f64),
    label_width: u32,
) -> Result<
    ChartContext<
        'a,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    String,
> {
    let n = names.len() as f64;
    let mut chart = ChartBuilder::on(area)
        .margin_left(10)
        .margin_right(25)
        .margin_top(10)
        .x_label_area_size(42)
        .y_label_area_size(label_width)
        .build_cartesian_2d(t0..t1, -0.5..n - 0.5)
        .map_err(plots::s)?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_labels(names.len())
        .y_label_formatter(&|v| {
            let i = (n - 1.0 - v).round();
            if (v - v.round()).abs() < 1e-6 && i >= 0.0 && (i as usize) < names.len() {
                names[i as usize].clone()
            } else {
                String::new()
            }
        })
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(plots::s)?;
    Ok(chart)
}

/// Which aids navigated when: one lane per aid, green where it was fused
/// within its timeout, red where its integrity test excluded it; the
/// faults the scenario injected as marks.
fn aids_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pass: &Pass,
    faults: &[(AidKind, String, f64)],
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(root, "Which aids navigated: one lane per aid")?;
    let (t0, t1) = x.unwrap_or((0.0, 1.0));
    let names: Vec<String> = AidKind::ALL
        .iter()
        .map(|k| format!("{} ({})", k.decl().label, k.decl().name))
        .collect();
    let n = names.len() as f64;
    let mut chart = lane_chart(&main, &names, (t0, t1), 130)?;
    let w = pass.health.width_s();
    // A column's state holds until the next column with rows (a solution
    // written every N samples leaves empty columns between its rows).
    let spans = |c: usize| {
        let cols: Vec<(f64, f64, f64)> = pass.health.column_range(c).collect();
        let ends: Vec<f64> = cols
            .iter()
            .skip(1)
            .map(|p| p.0 - w / 2.0)
            .chain(cols.last().map(|p| p.0 + w / 2.0))
            .collect();
        cols.into_iter()
            .zip(ends)
            .map(|((t, lo, hi), end)| (t - w / 2.0, end, lo, hi))
            .collect::<Vec<_>>()
    };
    for (i, k) in AidKind::ALL.iter().enumerate() {
        let y = n - 1.0 - i as f64;
        let Some(c) = lane_of(*k, AidLane::Stale) else {
            continue;
        };
        // The stale lane: min 0 = fused somewhere in the column, max 0 = throughout.
        chart
            .draw_series(
                spans(c + 1)
                    .into_iter()
                    .filter(|p| p.2 < 0.5)
                    .map(|(a, b, _, hi)| {
                        let shade = if hi < 0.5 { 0.85 } else { 0.35 };
                        Rectangle::new(
                            [(a, y - 0.3), (b, y + 0.3)],
                            plots::GREEN.mix(shade).filled(),
                        )
                    }),
            )
            .map_err(plots::s)?;
        // Under the lane: excluded by the integrity test (red), its test
        // unavailable (orange).
        for (lane, colour) in [
            (AidLane::Excluded, RED_),
            (AidLane::Untested, plots::ORANGE),
        ] {
            let Some(e) = lane_of(*k, lane) else {
                continue;
            };
            chart
                .draw_series(
                    spans(e + 1)
                        .into_iter()
                        .filter(|p| p.3 > 0.5)
                        .map(|(a, b, _, _)| {
                            Rectangle::new([(a, y - 0.42), (b, y - 0.3)], colour.mix(0.9).filled())
                        }),
                )
                .map_err(plots::s)?;
        }
        for (aid, _, t) in faults.iter().filter(|f| f.0 == *k) {
            let _ = aid;
            chart
                .draw_series(std::iter::once(TriangleMarker::new(
                    (*t, y + 0.38),
                    9,
                    BLACK.filled(),
                )))
                .map_err(plots::s)?;
        }
    }
    let mut notes = vec![format!(
        "a column is {}: dark green fused throughout it, light green in part of it",
        if w < 1.0 {
            format!("{:.0} ms", w * 1e3)
        } else {
            format!("{w:.1} s")
        }
    )];
    for (aid, kind, t0) in faults {
        notes.push(match first_exclusion(pass, *aid, *t0) {
            Some(t) => format!("{kind} at {t0:.1} s: alarm after {:.2} s", t - t0),
            None => format!("{kind} at {t0:.1} s: no exclusion"),
        });
    }
    legend(
        &side,
        "aids",
        &[
            ("fused (within timeout)".into(), Mark::Square(plots::GREEN)),
            ("excluded (integrity)".into(), Mark::Square(RED_)),
            (
                "integrity unavailable (fused untested)".into(),
                Mark::Square(plots::ORANGE),
            ),
            ("fault injected".into(), Mark::Triangle),
        ],
        &notes,
    )
}

/// The integrity test's statistic over its threshold (the status records'
/// `integrity_ratio`: q / χ² quantile; above 1 excludes) of each aid that is
/// not autonomous, with its exclusions and readmissions from the rows.
fn integrity_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    env: &Envelope,
    pass: &Pass,
    faults: &[(AidKind, String, f64)],
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(
        root,
        "Integrity test: statistic q over its threshold (log scale; above 1 excludes while the test is available)",
    )?;
    let tested: Vec<AidKind> = AidKind::ALL
        .into_iter()
        .filter(|k| !k.decl().autonomous)
        .collect();
    let colors = [BLUE, plots::GREEN, GREY];
    let mut bands = Vec::new();
    let mut entries = Vec::new();
    let band = |column: usize| -> Vec<(f64, f64, f64)> {
        env.column_range(column)
            .filter(|p| p.1 > 0.0)
            .map(|(t, lo, hi)| (t, lo.log10(), hi.log10()))
            .collect()
    };
    for (j, k) in tested.iter().enumerate() {
        let c = colors[j % colors.len()];
        bands.push((band(j), c));
        entries.push((format!("{} q / threshold", k.decl().label), Mark::Band(c)));
        let unavailable = band(NOT_AUTONOMOUS + j);
        if !unavailable.is_empty() {
            bands.push((unavailable, plots::ORANGE));
            entries.push((
                format!(
                    "{} q / threshold, test unavailable (not acted on)",
                    k.decl().label
                ),
                Mark::Band(plots::ORANGE),
            ));
        }
    }
    let (lo, hi) = bands
        .iter()
        .flat_map(|b| b.0.iter().flat_map(|p| [p.1, p.2]))
        .fold((-1.0f64, 0.5f64), |a, v| (a.0.min(v), a.1.max(v)));
    let mut crosses = Vec::new();
    let mut dots = Vec::new();
    for (t, k, on) in &pass.exclusions {
        if tested.contains(k) {
            if *on {
                crosses.push((*t, 0.0));
            } else {
                dots.push((*t, 0.0));
            }
        }
    }
    let p = Panel {
        title: "each status record's last test (min and max of each time column)".into(),
        bands,
        hlines: vec![(0.0, RED_)],
        crosses: vec![(crosses, RED_)],
        dots: vec![(dots, plots::GREEN)],
        y: Some((lo - 0.2, hi + 0.2)),
        y_fmt: Some(log_fmt),
        x,
        y_desc: Some("q / threshold".into()),
        ..Default::default()
    };
    time_panel(&main, &p, x.map_or(1.0, |r| r.1), &pass.switches)?;
    entries.push(("threshold (χ² quantile)".into(), Mark::Line(RED_, 2)));
    entries.push(("excluded".into(), Mark::Cross(RED_)));
    entries.push(("readmitted".into(), Mark::Dot(plots::GREEN)));
    let mut notes = vec![
        "the threshold: the χ² quantile of the settings' false-alarm probability per test"
            .to_owned(),
        "unavailable: the test's horizontal protection level beyond the alert limit; its samples fused untested".to_owned(),
    ];
    for (aid, kind, t0) in faults {
        notes.push(match first_exclusion(pass, *aid, *t0) {
            Some(t) => format!("{kind} from {t0:.1} s: time to alarm {:.2} s", t - t0),
            None => format!("{kind} from {t0:.1} s: no exclusion"),
        });
    }
    legend(&side, "integrity", &entries, &notes)
}

fn split_title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<Halves<DB>, String> {
    plots::layout(root, title)
}

fn aid_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &AidSeries,
    sw: &[Switch],
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(
        root,
        &format!("{} innovations ({}) and NIS", s.name, s.unit()),
    )?;
    let cells = main.split_evenly((s.dim + 1, 1));
    let tm = x.map_or(1.0, |r| r.1);
    for k in 0..s.dim {
        let (acc, rej, sig) = (&s.acc[k], &s.rej[k], &s.sig[k]);
        let panel = Panel {
            title: format!("{} {} ({})", s.name, s.comps[k], s.units[k]),
            bands: vec![
                (sig.symmetric_band(0, 3.0), GREY),
                (sig.symmetric_band(0, 1.0), BLUE),
            ],
            // Each component has a panel of its own: an aid of more than
            // three (GNSS: position and velocity) takes the colours again.
            dots: vec![(acc.line(0, 1.0), AXIS_COLORS[k % AXIS_COLORS.len()])],
            crosses: vec![(rej.line(0, 1.0), RED_)],
            hlines: vec![(0.0, GREY)],
            symmetric: true,
            x,
            y_desc: Some(format!("innovation ({})", s.units[k])),
            ..Default::default()
        };
        time_panel(&cells[k], &panel, tm, sw)?;
    }
    // NIS on a log axis.
    let m = s.dim as f64;
    let (a, b) = (chi2::quantile(0.025, m), chi2::quantile(0.975, m));
    let gate = chi2::quantile(0.999, m);
    let (acc, rej) = (&s.nis_acc, &s.nis_rej);
    const FLOOR: f64 = NIS_FLOOR;
    let t = s.test;
    let hi = acc
        .line(0, 1.0)
        .iter()
        .chain(&rej.line(0, 1.0))
        .map(|p| p.1)
        .fold(gate.log10(), f64::max);
    let panel = Panel {
        title: match t {
            Some(t) => format!(
                "NIS, m = {}: mean {:.2} (consistent {:.2} … {:.2}), inside 95 % interval {:.1} %: {}",
                s.dim,
                t.mean,
                t.lo,
                t.hi,
                100.0 * t.inside,
                t.verdict.text()
            ),
            None => format!("NIS, m = {}: no accepted update", s.dim),
        },
        dots: vec![(acc.line(0, 1.0), BLACK)],
        crosses: vec![(rej.line(0, 1.0), RED_)],
        hlines: vec![(a.log10(), BLUE), (b.log10(), BLUE), (gate.log10(), RED_)],
        y: Some((FLOOR - 0.1, hi + 0.2)),
        y_fmt: Some(|v| {
            let x = 10f64.powf(v);
            if x >= 1.0 {
                format!("{x:.0}")
            } else {
                let d = (-x.log10()).ceil().max(1.0) as usize;
                format!("{x:.d$}")
            }
        }),
        x,
        y_desc: Some("NIS (unit-free, log)".into()),
        ..Default::default()
    };
    time_panel(&cells[s.dim], &panel, tm, sw)?;
    let mut notes = vec![
        format!(
            "NIS bounds: χ²({}) 2.5 % = {:.3} and 97.5 % = {:.3}; gate 99.9 % = {:.3}",
            s.dim, a, b, gate
        ),
        "points: min and max of each time column (long flights read as an envelope)".to_owned(),
    ];
    if s.converts_geographic() {
        notes.push(format!(
            "{} in g: Δlatitude, Δlongitude converted to metres north, east; in G: grid x, y (m)",
            s.name
        ));
    }
    notes.extend(plots::switch_notes(sw));
    legend(
        &side,
        s.name,
        &[
            ("accepted update".into(), Mark::Dot(BLUE)),
            ("rejected at the gate".into(), Mark::Cross(RED_)),
            ("±1σ (innovation variance)".into(), Mark::Band(BLUE)),
            ("±3σ".into(), Mark::Band(GREY)),
            ("NIS 95 % interval".into(), Mark::Line(BLUE, 1)),
            ("gate".into(), Mark::Line(RED_, 1)),
            ("frame switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

fn health_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pass: &Pass,
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(root, "Health timeline: one lane per flag")?;
    let (t0, t1) = x.unwrap_or((0.0, 1.0));
    let mut names: Vec<String> = vec![
        "frame G (grid)".into(),
        "frame switch".into(),
        "reset".into(),
    ];
    names.extend((0..LANE_COUNT).map(|k| lane_label(pass, k)));
    let n = names.len() as f64;
    let mut chart = lane_chart(&main, &names, (t0, t1), 200)?;
    let lane_y = |i: usize| n - 1.0 - i as f64;
    let w = pass.health.width_s();
    // Frame and flag lanes: a bar over each time column where the flag was set.
    let lane_of = |c: usize| if c == 0 { 0 } else { c + 2 };
    for c in 0..=LANE_COUNT {
        let y = lane_y(lane_of(c));
        let color = if c == 0 { BLUE } else { RED_ };
        chart
            .draw_series(
                pass.health
                    .column_range(c)
                    .filter(|x| x.2 > 0.0)
                    .map(|(t, _, _)| {
                        Rectangle::new(
                            [(t - w / 2.0, y - 0.35), (t + w / 2.0, y + 0.35)],
                            color.mix(0.8).filled(),
                        )
                    }),
            )
            .map_err(plots::s)?;
    }
    for (i, ev, c) in [
        (
            1,
            pass.switches.iter().map(|s| s.t_s).collect::<Vec<_>>(),
            BLACK,
        ),
        (2, pass.resets.clone(), RED_),
    ] {
        let y = lane_y(i);
        chart
            .draw_series(
                ev.iter()
                    .map(|t| PathElement::new([(*t, y - 0.4), (*t, y + 0.4)], c.stroke_width(3))),
            )
            .map_err(plots::s)?;
    }
    let mut notes = vec![
        format!(
            "{} rows; a bar: the flag was set in some row of that time column ({})",
            pass.rows,
            if w < 1.0 {
                format!("{:.0} ms", w * 1e3)
            } else {
                format!("{w:.1} s")
            }
        ),
        "stale: the aid's fresh column is 0 (nothing fused within its timeout)".into(),
    ];
    notes.push(format!(
        "{} switches, {} resets",
        pass.switches.len(),
        pass.resets.len()
    ));
    legend(
        &side,
        "flags",
        &[
            ("grid frame G".into(), Mark::Square(BLUE)),
            ("flag set".into(), Mark::Square(RED_)),
            ("switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

fn sampling_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    s: &Sampling,
    sw: &[Switch],
) -> Result<(), String> {
    let (main, side) = split_title(root, "IMU sampling: interval per sample")?;
    let (top, bottom) = main.split_vertically(main.dim_in_pixel().1 / 2);
    let line = s.dt.line(0, 1.0);
    let (t0, t1) = line
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.min(p.0), a.1.max(p.0))
        });
    let x = (t0.is_finite() && t1.is_finite()).then(|| (t0, t1.max(t0 + 1.0)));
    let p = Panel {
        title: format!(
            "interval (ms): nominal {:.3} ms, {} gaps over 1.5× nominal",
            s.nominal_s * 1e3,
            s.gaps
        ),
        y: Some((
            0.0,
            line.iter()
                .map(|p| p.1)
                .fold(3.0 * s.nominal_s * 1e3, f64::max)
                .max(1e-3)
                * 1.05,
        )),
        lines: vec![(line, BLUE, 1)],
        hlines: vec![(s.nominal_s * 1e3, GREY)],
        x,
        y_desc: Some("interval (ms)".into()),
        ..Default::default()
    };
    time_panel(&top, &p, x.map_or(1.0, |r| r.1), sw)?;
    // Histogram: 80 bins from 0 to 3× nominal, and one for longer intervals.
    let nominal_ms = (s.nominal_s * 1e3).max(1e-6);
    let top_ms = 3.0 * nominal_ms;
    const BINS: usize = HIST_BINS;
    let counts = s.counts;
    let bw = top_ms / BINS as f64;
    let max = counts.iter().copied().max().unwrap_or(1).max(1) as f64;
    let mut chart = ChartBuilder::on(&bottom)
        .caption(
            format!(
                "histogram of intervals (log count); the last bar: ≥ {:.3} ms ({} samples)",
                top_ms, counts[BINS]
            ),
            ("sans-serif", 19),
        )
        .margin_left(10)
        .margin_right(25)
        .x_label_area_size(42)
        .y_label_area_size(95)
        .build_cartesian_2d(0.0..top_ms + bw, (0.8..max * 2.0).log_scale())
        .map_err(plots::s)?;
    chart
        .configure_mesh()
        .x_desc("interval (ms)")
        .y_desc("samples")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(plots::s)?;
    chart
        .draw_series(
            counts
                .iter()
                .enumerate()
                .filter(|c| *c.1 > 0)
                .map(|(i, c)| {
                    let x0 = i as f64 * bw;
                    let color = if i == BINS { RED_ } else { BLUE };
                    Rectangle::new([(x0, 0.8), (x0 + bw * 0.9, *c as f64)], color.filled())
                }),
        )
        .map_err(plots::s)?;
    let mut notes = vec![format!("{} samples", s.samples)];
    if s.duplicates > 0 {
        notes.push(format!("{} repeated stamps (interval 0)", s.duplicates));
    }
    if s.backwards > 0 {
        notes.push(format!(
            "{} stamps going back (negative interval)",
            s.backwards
        ));
    }
    notes.push("interval over time: min and max per time column".into());
    legend(
        &side,
        "IMU",
        &[
            ("interval".into(), Mark::Line(BLUE, 1)),
            ("nominal (median)".into(), Mark::Line(GREY, 1)),
            ("≥ 3× nominal".into(), Mark::Square(RED_)),
        ],
        &notes,
    )
}

fn log_fmt(v: f64) -> String {
    let x = 10f64.powf(v);
    if x >= 100.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.1e}")
    }
}

fn sigma_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pass: &Pass,
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(root, "1-σ of the solution over time (log scale)")?;
    let cells = main.split_evenly((3, 1));
    let tm = x.map_or(1.0, |r| r.1);
    let groups = [
        ("position σ east / north / up (m)", "σ position (m)", 0),
        ("velocity σ nav x / y / z (m/s)", "σ velocity (m/s)", 3),
        (
            "attitude σ tilt x / y, heading (arcmin)",
            "σ attitude (arcmin)",
            6,
        ),
    ];
    for (cell, (title, yd, c0)) in cells.iter().zip(groups) {
        let lines: Vec<plots::Line> = AXIS_COLORS
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let l: Vec<(f64, f64)> = pass
                    .sigma
                    .line(c0 + k, 1.0)
                    .into_iter()
                    .filter(|p| p.1 > 0.0)
                    .map(|p| (p.0, p.1.log10()))
                    .collect();
                (l, *c, 2)
            })
            .collect();
        let (lo, hi) = lines
            .iter()
            .flat_map(|l| l.0.iter().map(|p| p.1))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, v| {
                (a.0.min(v), a.1.max(v))
            });
        let p = Panel {
            title: title.into(),
            lines,
            y: (lo.is_finite() && hi.is_finite()).then_some((lo - 0.1, hi + 0.1)),
            y_fmt: Some(log_fmt),
            x,
            y_desc: Some(yd.into()),
            ..Default::default()
        };
        time_panel(cell, &p, tm, &pass.switches)?;
    }
    let mut notes = vec!["min and max of each time column".to_owned()];
    notes.extend(plots::switch_notes(&pass.switches));
    legend(
        &side,
        "σ",
        &[
            ("x / east".into(), Mark::Line(AXIS_COLORS[0], 2)),
            ("y / north".into(), Mark::Line(AXIS_COLORS[1], 2)),
            ("z / up, heading".into(), Mark::Line(AXIS_COLORS[2], 2)),
            ("frame switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

fn bias_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    pass: &Pass,
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let with_sigma = pass.rows_with_bias_sigma > 0;
    let (main, side) = split_title(
        root,
        if with_sigma {
            "IMU bias estimates with ±1σ, body axes"
        } else {
            "IMU bias estimates, body axes (the solution carries no bias σ)"
        },
    )?;
    let tm = x.map_or(1.0, |r| r.1);
    for (k, area) in main.split_evenly((2, 3)).iter().enumerate() {
        let gyro = k < 3;
        let axis = ["x", "y", "z"][k % 3];
        let unit = if gyro { "°/h" } else { "µg" };
        let mut p = Panel {
            title: format!("{} {axis} ({unit})", if gyro { "gyro" } else { "accel" }),
            lines: vec![(pass.bias.line(k, 1.0), AXIS_COLORS[k % 3], 2)],
            hlines: vec![(0.0, GREY)],
            x,
            y_desc: Some(format!("bias ({unit})")),
            ..Default::default()
        };
        if with_sigma {
            p.bands
                .push((pass.bias.band(6 + k, 12 + k, 1.0), AXIS_COLORS[k % 3]));
        }
        time_panel(area, &p, tm, &pass.switches)?;
    }
    let mut notes = vec!["min and max of each time column".to_owned()];
    if !with_sigma {
        notes.push(format!(
            "no σ band: the solution has no columns {}",
            solution_file::BIAS_SIGMA_COLUMNS.join(", ")
        ));
    }
    notes.extend(plots::switch_notes(&pass.switches));
    legend(
        &side,
        "biases",
        &[
            ("estimate".into(), Mark::Line(BLUE, 2)),
            ("±1σ".into(), Mark::Band(BLUE)),
            ("frame switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

fn reference_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    rp: &RefPass,
    sw: &[Switch],
    x: Option<(f64, f64)>,
) -> Result<(), String> {
    let (main, side) = split_title(root, "Forward solution − reference, with the forward ±3σ")?;
    let tm = x.map_or(1.0, |r| r.1);
    let names = [
        ("east (m)", "Δ position (m)"),
        ("north (m)", "Δ position (m)"),
        ("up (m)", "Δ position (m)"),
        ("velocity nav x (m/s)", "Δ velocity (m/s)"),
        ("velocity nav y (m/s)", "Δ velocity (m/s)"),
        ("velocity nav z (m/s)", "Δ velocity (m/s)"),
        ("tilt nav x (arcmin)", "Δ attitude (arcmin)"),
        ("tilt nav y (arcmin)", "Δ attitude (arcmin)"),
        ("heading (arcmin)", "Δ attitude (arcmin)"),
    ];
    let n = rp.matched.max(1) as f64;
    for (k, area) in main.split_evenly((3, 3)).iter().enumerate() {
        let c = AXIS_COLORS[k % 3];
        let p = Panel {
            title: format!(
                "{}: RMS {}, inside ±3σ {:.1} %",
                names[k].0,
                plots::tick((rp.sum_sq[k] / n).sqrt(), (rp.sum_sq[k] / n).sqrt()),
                100.0 * rp.inside[k] as f64 / n
            ),
            bands: vec![(rp.diff.symmetric_band(9 + k, 1.0), c)],
            lines: vec![(rp.diff.line(k, 1.0), c, 2)],
            hlines: vec![(0.0, GREY)],
            symmetric: true,
            x,
            y_desc: Some(names[k].1.into()),
            ..Default::default()
        };
        time_panel(area, &p, tm, sw)?;
    }
    let mut notes = vec![
        format!("{} rows at common times", rp.matched),
        "position in local east/north/up of the reference; velocity and attitude in the forward nav axes".into(),
        "min and max of each time column".into(),
    ];
    notes.extend(plots::switch_notes(sw));
    legend(
        &side,
        "forward − reference",
        &[
            ("difference".into(), Mark::Line(BLUE, 2)),
            ("forward ±3σ".into(), Mark::Band(BLUE)),
            ("frame switch".into(), Mark::Switch),
        ],
        &notes,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent check of the verdict: NIS drawn as sums of m squared
    /// standard normals (Box–Muller from a fixed LCG), scaled.
    fn draws(n: usize, m: usize, scale: f64) -> Vec<(f64, bool)> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut u = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let s: f64 = (0..m)
                    .map(|_| {
                        let z = (-2.0 * u().ln()).sqrt() * (std::f64::consts::TAU * u()).cos();
                        z * z
                    })
                    .sum();
                (s * scale, true)
            })
            .collect()
    }

    /// An aid whose fresh flag is clear in every row is labelled as never
    /// fused, not as stale; one that was fresh at times keeps "stale".
    #[test]
    fn an_aid_never_fresh_is_labelled_never_fused_not_stale() {
        let mut pass = Pass::new();
        let mut prev: Option<Row> = None;
        for k in 0..100u64 {
            let flags = if k < 50 { solution_flags::CNS_FRESH } else { 0 };
            let row = Row::from_solution(&msgs::Solution {
                t_ns: k * 10_000_000,
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                flags,
                ..Default::default()
            });
            pass.push(&row, None, prev.as_ref()).expect("in memory");
            prev = Some(row);
        }
        let label = |name: &str| {
            let k = lanes().iter().position(|l| l.name == name).expect("lane");
            lane_label(&pass, k)
        };
        assert_eq!(label("SRS stale"), "SRS never fused");
        assert_eq!(label("baro stale"), "baro never fused");
        assert_eq!(label("CNS stale"), "CNS stale");
        assert_eq!(label("COASTING"), "COASTING");
    }

    /// The faults of a simulated scenario in the log's header, for the aids
    /// that are not autonomous; the time to alarm from the rows' flags.
    #[test]
    fn time_to_alarm_from_the_scenario_and_the_exclusion_flag() {
        let scenario = "name = \"x\"\n[gnss]\nrate_hz = 5.0\n\n[[faults.event]]\nkind = \"baro_spike\"\nstream = \"baro\"\nstart_s = 10.0\n\n[[faults.event]]\nkind = \"gnss_spoof\" # drag\nstream = \"gnss\"\nstart_s = 0.25\nmagnitude = 1.0\n[other]\nstart_s = 99.0\n";
        let h = Header::new("test", "x", 1, scenario);
        let f = injected(Some(&h));
        assert_eq!(f, vec![(AidKind::Gnss, "gnss_spoof".to_owned(), 0.25)]);
        let mut pass = Pass::new();
        let mut prev: Option<Row> = None;
        for k in 0..100u64 {
            let flags = if (40..70).contains(&k) {
                solution_flags::GNSS_EXCLUDED
            } else {
                0
            };
            let row = Row::from_solution(&msgs::Solution {
                t_ns: k * 10_000_000,
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                flags,
                ..Default::default()
            });
            pass.push(&row, None, prev.as_ref()).expect("in memory");
            prev = Some(row);
        }
        assert_eq!(pass.exclusions.len(), 2);
        assert_eq!(first_exclusion(&pass, AidKind::Gnss, 0.25), Some(0.4));
        let md = aids_section(&pass, &f);
        assert!(md.contains("time to alarm 0.150 s"), "{md}");
        assert!(
            md.contains("1 exclusion (excluded at 0.400 s, readmitted at 0.700 s)"),
            "{md}"
        );
    }

    #[test]
    fn verdicts_of_drawn_nis() {
        for m in [1, 2, 3] {
            let t = nis_test(&draws(5000, m, 1.0), m).expect("test");
            assert_eq!(t.verdict, Verdict::Consistent, "{t:?}");
            // 95 % of the draws inside the per-update interval (±2 %).
            assert!((t.inside - 0.95).abs() < 0.02, "{t:?}");
            assert!(t.mean > t.lo95 && t.mean < t.hi95, "{t:?}");
            // σ 10× too small: NIS 100× larger.
            let t = nis_test(&draws(5000, m, 100.0), m).expect("test");
            assert_eq!(t.verdict, Verdict::TooOptimistic);
            let t = nis_test(&draws(5000, m, 0.01), m).expect("test");
            assert_eq!(t.verdict, Verdict::TooPessimistic);
        }
        assert!(nis_test(&[], 3).is_none());
        assert!(nis_test(&[(f64::NAN, true)], 1).is_none());
        // One accepted update with an infinite NIS (innovation 1 over a
        // variance of 1e-320) among 999 consistent ones: it counts, and it
        // makes the aid too optimistic; it is outside the interval.
        let mut d = draws(999, 1, 1.0);
        let without = nis_test(&d, 1).expect("test");
        d.push((f64::INFINITY, true));
        let t = nis_test(&d, 1).expect("test");
        assert_eq!(
            (t.accepted, t.verdict),
            (1000, Verdict::TooOptimistic),
            "{t:?}"
        );
        assert!(
            (t.inside - without.inside * 999.0 / 1000.0).abs() < 1e-12,
            "{t:?} {without:?}"
        );
        // Every update rejected: too optimistic, no mean.
        let t = nis_test(&[(50.0, false), (80.0, false)], 1).expect("test");
        assert_eq!(t.verdict, Verdict::TooOptimistic);
        assert!(t.mean.is_nan());
        // 2 % rejected: too optimistic whatever the accepted mean.
        let mut d = draws(1000, 1, 1.0);
        for x in d.iter_mut().take(20) {
            x.1 = false;
        }
        assert_eq!(
            nis_test(&d, 1).expect("test").verdict,
            Verdict::TooOptimistic
        );
    }

    /// A recording's status records give one point per new update: a
    /// status that repeats the last update (same counters, same innovation)
    /// adds nothing, an aid without updates gives no series.
    #[test]
    fn status_records_give_one_point_per_update() {
        let mut st = Status::default();
        assert!(aids_from_status(&[st]).is_none());
        st.t_ns = 1_000_000_000;
        st.aid_counters_mut(AidKind::Baro).accepted = 1;
        st.aid_mut(AidKind::Baro).innovation = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        st.aid_mut(AidKind::Baro).innovation_var = [4.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        st.aid_mut(AidKind::Baro).fused = 1;
        let mut later = st;
        later.t_ns = 2_000_000_000;
        let mut next = later;
        next.t_ns = 3_000_000_000;
        next.aid_counters_mut(AidKind::Baro).rejected_gate = 1;
        next.aid_mut(AidKind::Baro).innovation = [40.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        next.aid_mut(AidKind::Baro).fused = 0;
        let a = aids_from_status(&[st, later, next]).expect("aids");
        assert!(
            a[AidKind::Srs].is_empty() && a[AidKind::Cns].is_empty() && a[AidKind::Star].is_empty()
        );
        assert_eq!(a[AidKind::Baro].len(), 2);
        assert_eq!(
            (a[AidKind::Baro][0].fused, a[AidKind::Baro][1].fused),
            (1, 0)
        );
        let mut at = WhereAt::Memory(Vec::new());
        let s = aid_series(&aids_to_disk(a.clone()).expect("disk"), &mut at).expect("series");
        assert_eq!((s.len(), s[0].dim, s[0].n), (1, 1, 2));
        // NIS = ν²/S: 4/4 and 1600/4.
        let nis: Vec<f64> = a[AidKind::Baro]
            .iter()
            .map(|p| aid_sample(AidKind::Baro, p, &mut at).expect("sample").0.4)
            .collect();
        assert!((nis[0] - 1.0).abs() < 1e-12 && (nis[1] - 400.0).abs() < 1e-9);
        let t = s[0].test.expect("test");
        assert_eq!((t.accepted, t.rejected), (1, 1));
        assert!((t.mean - 1.0).abs() < 1e-12, "{t:?}");
    }

    /// The positions kept on disk give, from their cursor, the entry that
    /// a binary search over them in memory gives, for times in order, at
    /// and between the entries, before the first and after the last, and
    /// in no order.
    #[test]
    fn positions_on_disk_are_looked_up_as_in_memory() {
        let (mut mem, mut disk) = (Where::default(), Where::on_disk().expect("spill"));
        for k in 0..5000u32 {
            let row = Row::from_solution(&msgs::Solution {
                t_ns: u64::from(k) * 100_000_000,
                lat_rad: f64::from(k) * 1e-4,
                h_m: f64::from(k),
                frame: u8::from(k / 1000 % 2 == 1),
                q_b_e: [1.0, 0.0, 0.0, 0.0],
                ..Default::default()
            });
            mem.push(&row).expect("memory");
            disk.push(&row).expect("disk");
        }
        let (mut mem, mut disk) = (mem.seal().expect("seal"), disk.seal().expect("seal"));
        let WhereAt::Memory(m) = &mem else {
            panic!("in memory")
        };
        assert!(m.len() > 900, "{} entries", m.len());
        let mut state = 12345u64;
        let mut times: Vec<f64> = (0..5000).map(|k| f64::from(k) * 0.1 - 1.0).collect();
        times.extend((0..3000).map(|_| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 600.0 - 50.0
        }));
        times.extend([0.0, 0.5, 499.9, 1e9, -1e9]);
        for t in times {
            let (a, b) = (mem.get(t).expect("memory"), disk.get(t).expect("disk"));
            assert_eq!(
                a.map(|x| (x.0, x.1.to_bits(), x.2.to_bits())),
                b.map(|x| (x.0, x.1.to_bits(), x.2.to_bits())),
                "t = {t}"
            );
        }
        let mut empty = Where::on_disk().expect("spill").seal().expect("seal");
        assert_eq!(empty.get(1.0).expect("disk"), None);
    }

    /// A recording's CNS innovation (Δlatitude, Δlongitude in rad when
    /// made in g, metres in G) is put in metres in the frame the daemon
    /// says it was made in: an update made in g just before a switch and
    /// reported by a status after it (solution in G) is scaled by the
    /// metres per radian there; one made in G is not scaled; one from a
    /// sender that does not say takes the solution's frame then.
    #[test]
    fn a_recorded_cns_innovation_is_scaled_in_the_frame_it_was_made_in() {
        let lat = 88.0f64.to_radians();
        let h = 12_000.0;
        let mut at = WhereAt::Memory(vec![(0.0, 'g', lat, h), (5.0, 'G', lat, h)]);
        let mut st = Status {
            t_ns: 6_000_000_000,
            frame: 1,
            ..Status::default()
        };
        st.aid_counters_mut(AidKind::Cns).accepted = 1;
        st.aid_mut(AidKind::Cns).innovation = [1e-6, -2e-6, 0.0, 0.0, 0.0, 0.0];
        st.aid_mut(AidKind::Cns).innovation_var = [1e-12, 1e-12, 0.0, 0.0, 0.0, 0.0];
        st.aid_mut(AidKind::Cns).fused = 1;
        let [n, e] = polarnav::earth::metres_per_radian(lat, h);
        for (made_in_frame, scale) in [(1u8, [n, e]), (2, [1.0, 1.0]), (0, [1.0, 1.0])] {
            st.aid_mut(AidKind::Cns).made_in_frame = made_in_frame;
            let a = aids_from_status(&[st]).expect("aids");
            assert_eq!(a[AidKind::Cns][0].made_in_frame, made_in_frame);
            let v = aid_sample(AidKind::Cns, &a[AidKind::Cns][0], &mut at)
                .expect("sample")
                .0
                .1;
            assert!(
                (v[0] - 1e-6 * scale[0]).abs() <= 1e-12 * scale[0]
                    && (v[1] + 2e-6 * scale[1]).abs() <= 1e-12 * scale[1],
                "made in {made_in_frame}: {v:?}"
            );
        }
        // Metres per radian at 88° N, 12 km: about 6.4e6 north and 2.2e5 east.
        assert!(
            (6.3e6..6.5e6).contains(&n) && (2.1e5..2.3e5).contains(&e),
            "{n} {e}"
        );
    }

    /// Gaps are the intervals over 1.5× the median, listed with their
    /// start and length; repeated and backward stamps are counted apart.
    #[test]
    fn imu_gaps_repeats_and_backward_stamps() {
        let mut log = LogContents::default();
        let mut t = 0u64;
        for k in 0..1000u64 {
            t += match k {
                500 => 100_000_000, // a 100 ms gap
                700 => 0,           // a repeated stamp
                _ => 5_000_000,
            };
            log.imu.push(msgs::ImuSample {
                t_ns: t,
                ..Default::default()
            });
        }
        log.imu.push(msgs::ImuSample {
            t_ns: t - 1_000_000,
            ..Default::default()
        });
        let s = sampling_of(log.imu.iter().map(|x| x.t_ns)).expect("sampling");
        assert!((s.nominal_s - 0.005).abs() < 1e-12);
        assert_eq!((s.duplicates, s.backwards), (1, 1));
        assert_eq!(s.gaps, 1);
        let (start, len) = s.longest[0];
        assert!(
            (len - 0.1).abs() < 1e-9 && (start - 500.0 * 0.005).abs() < 1e-9,
            "{start} {len}"
        );
        assert!(sampling_of(std::iter::empty()).is_none());
        assert!(sampling_of(std::iter::once(5)).is_none());
    }

    fn sampling_of(t_ns: impl Iterator<Item = u64>) -> Option<Sampling> {
        let mut acc = SamplingAcc::new().expect("spill");
        for t in t_ns {
            acc.push(t).expect("push");
        }
        acc.finish().expect("finish")
    }

    /// The sampling read one time at a time against the same figures
    /// computed from every interval in memory (as the review computed
    /// them before it streamed): the median, the gap count and total, the
    /// 20 longest (ties in time order) and the histogram, on a jittery
    /// clock with many gaps of equal lengths.
    #[test]
    fn streamed_sampling_equals_every_interval_in_memory() {
        let mut state = 99u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            state >> 33
        };
        let mut t = 1_000_000_000u64;
        let mut times = vec![t];
        for _ in 0..30_000 {
            t = match next() % 50 {
                0 => t + 20_000_000,                   // a 20 ms gap (ties)
                1 => t + 5_000_000 * (2 + next() % 5), // longer ones
                2 => t - 1_000,                        // back
                3 => t,                                // repeated
                _ => t + 5_000_000 + next() % 2_000 - 1_000,
            };
            times.push(t);
        }
        let s = sampling_of(times.iter().copied()).expect("sampling");
        let d: Vec<(f64, f64)> = times
            .windows(2)
            .map(|w| (w[0] as f64 * 1e-9, (w[1] as f64 - w[0] as f64) * 1e-9))
            .collect();
        let mut sorted: Vec<f64> = d.iter().map(|x| x.1).collect();
        let mid = sorted.len() / 2;
        let nominal = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
        assert_eq!(s.nominal_s.to_bits(), nominal.to_bits());
        let gaps: Vec<(f64, f64)> = d
            .iter()
            .copied()
            .filter(|x| x.1 > 0.0 && x.1 > 1.5 * nominal)
            .collect();
        assert!(gaps.len() > 500, "{} gaps", gaps.len());
        assert_eq!(s.gaps, gaps.len() as u64);
        let total: f64 = gaps.iter().map(|x| x.1).sum();
        assert_eq!(s.gaps_s.to_bits(), total.to_bits());
        let mut longest = gaps.clone();
        longest.sort_by(|a, b| b.1.total_cmp(&a.1));
        longest.truncate(20);
        assert_eq!(s.longest, longest);
        let top_ms = 3.0 * (nominal * 1e3).max(1e-6);
        let mut counts = [0u64; HIST_BINS + 1];
        for (_, x) in &d {
            let ms = x * 1e3;
            let i = if ms >= top_ms || !ms.is_finite() {
                HIST_BINS
            } else {
                ((ms.max(0.0) / top_ms) * HIST_BINS as f64) as usize
            };
            counts[i.min(HIST_BINS)] += 1;
        }
        assert_eq!(s.counts, counts);
        assert_eq!(
            (s.backwards, s.duplicates),
            (
                d.iter().filter(|x| x.1 < 0.0).count() as u64,
                d.iter().filter(|x| x.1 == 0.0).count() as u64
            )
        );
    }

    #[test]
    fn settings_values_are_read_by_key() {
        let t = "[aids]\nsrs_gate = 16.5 # comment\ncns_gate=3\n";
        assert_eq!(setting(t, "srs_gate"), Some(16.5));
        assert_eq!(setting(t, "cns_gate"), Some(3.0));
        assert_eq!(setting(t, "baro_gate"), None);
    }
}
