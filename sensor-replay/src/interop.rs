//! Import and export of other tools' text formats.
//!
//! - KF-GINS: IMU `time Δθx Δθy Δθz Δvx Δvy Δvz` (rad, m/s; body
//!   forward-right-down) and truth `week time lat lon h vN vE vD roll pitch yaw`
//!   (deg, m, m/s; NED). Converted to our body right-forward-up and ENU.
//!   GNSS `time lat lon h σN σE σD` (s, deg, m; KF-GINS's own file, read by
//!   its `GnssFileLoader`), or 13 columns `time lat lon h vN vE vD σN σE σD
//!   σvN σvE σvD`: GNSS records ([`gnss_fix_of_kfgins`] says how the σ map
//!   onto the fix's accuracies).
//! - PSINS text IMU (`../shared/datasets/psins-lasergyro`): header lines,
//!   then integer gyro/accelerometer counts, body right-forward-up.
//!
//! Malformed or non-finite lines are skipped, each named in a warning and
//! counted; an import fails only when the file is unreadable or not of the
//! format at all.

use std::io::Write;

use msgs::gnss::{fix_flags, fix_type};
use msgs::navlog::{Header, NavlogWriter, Record, WriteError};
use msgs::{GnssFix, ImuSample, InitState, TruthRecord};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic};
use polarnav::frames;
use polarnav::navigator::IMU_DT_RANGE_S;
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

use polarnav_sim::sensors;
use polarnav_sim::simulate::{InitErrors, init_record};
use polarnav_sim::trajectory::TruthSample;

/// Forward-right-down ↔ right-forward-up (also NED ↔ ENU): a proper rotation, its own inverse.
pub fn frd_to_rfu() -> Matrix3<f64> {
    Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0)
}

/// An import failure (exit 2: unreadable or not the format).
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a {format} file: {why}")]
    NotFormat {
        path: String,
        format: &'static str,
        why: String,
    },
    #[error("no initial state: {0}")]
    NoInit(String),
    #[error("writing the navlog: {0}")]
    Write(#[from] WriteError),
}

/// Lines skipped by an importer.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Skipped {
    /// (file, 1-based line number, reason) of the first [`Skipped::MAX_NAMED`]
    /// skipped lines, in file order.
    pub lines: Vec<(String, usize, String)>,
    /// Every skipped line, named or not.
    pub count: u64,
}

impl Skipped {
    /// Skipped lines kept with their reasons; the rest are only counted, so
    /// that a file of garbage costs bounded memory.
    pub const MAX_NAMED: usize = 1000;

    fn note(&mut self, file: &str, line: usize, why: String) {
        self.count += 1;
        if self.lines.len() < Self::MAX_NAMED {
            self.lines.push((file.to_owned(), line, why));
        }
    }
}

/// Longest text line an importer reads (bytes); a longer one is skipped
/// without being held in memory.
pub const MAX_LINE_BYTES: usize = 4096;

/// The text lines of a file with bounded memory: each line is held up to
/// [`MAX_LINE_BYTES`]; a line that is not UTF-8 or is longer is handed out as
/// a reason to skip it, with its 1-based number, and reading goes on.
struct TextLines<R> {
    reader: R,
    path: String,
    buf: Vec<u8>,
    number: usize,
}

/// One line of a text file: its number and its text, or why it cannot be read as text.
type TextLine<'a> = (usize, Result<&'a str, String>);

impl TextLines<std::io::BufReader<std::fs::File>> {
    fn open(path: &std::path::Path) -> Result<Self, ImportError> {
        let f = std::fs::File::open(path).map_err(|source| ImportError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Ok(Self::new(
            std::io::BufReader::with_capacity(1 << 16, f),
            path.display().to_string(),
        ))
    }
}

impl<R: std::io::BufRead> TextLines<R> {
    fn new(reader: R, path: String) -> Self {
        Self {
            reader,
            path,
            buf: Vec::with_capacity(MAX_LINE_BYTES),
            number: 0,
        }
    }

    /// The next line, or `None` at the end of the file; an I/O error makes
    /// the file unreadable.
    fn next_line(&mut self) -> Result<Option<TextLine<'_>>, ImportError> {
        self.buf.clear();
        let mut len = 0usize;
        let mut any = false;
        loop {
            let chunk = match self.reader.fill_buf() {
                Ok(c) => c,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(source) => {
                    return Err(ImportError::Io {
                        path: self.path.clone(),
                        source,
                    });
                }
            };
            if chunk.is_empty() {
                break;
            }
            any = true;
            let (part, done) = match chunk.iter().position(|&b| b == b'\n') {
                Some(i) => (&chunk[..i], Some(i + 1)),
                None => (chunk, None),
            };
            len += part.len();
            let room = MAX_LINE_BYTES.saturating_sub(self.buf.len());
            self.buf.extend_from_slice(&part[..part.len().min(room)]);
            let used = done.unwrap_or(chunk.len());
            self.reader.consume(used);
            if done.is_some() {
                break;
            }
        }
        if !any {
            return Ok(None);
        }
        self.number += 1;
        let line = if len > MAX_LINE_BYTES {
            Err(format!("line of {len} bytes, longer than {MAX_LINE_BYTES}"))
        } else {
            std::str::from_utf8(&self.buf)
                .map(|t| t.trim_end_matches('\r'))
                .map_err(|e| format!("not UTF-8 text (byte {})", e.valid_up_to() + 1))
        };
        Ok(Some((self.number, line)))
    }
}

/// Where a time-stamped line falls on a file's time line.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Step {
    /// The first line: the time base.
    First,
    /// The next line, `dt` seconds after the previous one; `after_skip`
    /// when a line between them was skipped (so `dt` spans lost data).
    Next { dt: f64, after_skip: bool },
    /// The first line after a confirmed gap longer than the longest interval.
    AfterGap,
}

/// The time line of one file: stamps must increase by at least `min_dt_s`;
/// a step longer than `max_dt_s` is held until the next line confirms it (it
/// follows the held line) or shows it an outlier (it follows the line
/// before), so one absurd stamp costs only its own line.
struct Timeline<T> {
    min_dt_s: f64,
    max_dt_s: f64,
    prev: Option<f64>,
    held: Option<(usize, f64, T)>,
    /// A line was skipped since the last one placed.
    lost: bool,
}

impl<T> Timeline<T> {
    fn new(min_dt_s: f64, max_dt_s: f64) -> Self {
        Self {
            min_dt_s,
            max_dt_s,
            prev: None,
            held: None,
            lost: false,
        }
    }

    /// A line between two placed ones was skipped for its content.
    fn mark_lost(&mut self) {
        self.lost = true;
    }

    /// Places the line `line` stamped `t` (s) carrying `item`: `emit` gets
    /// every line that takes its place (a confirmed held line first);
    /// skipped lines are noted with their reasons.
    fn push(
        &mut self,
        line: usize,
        t: f64,
        item: T,
        file: &str,
        skipped: &mut Skipped,
        mut emit: impl FnMut(usize, f64, Step, T),
    ) {
        let Some(p) = self.prev else {
            self.prev = Some(t);
            emit(line, t, Step::First, item);
            return;
        };
        if let Some((hl, ht, hitem)) = self.held.take() {
            if t > ht && t - ht <= self.max_dt_s {
                self.prev = Some(ht);
                self.lost = false;
                emit(hl, ht, Step::AfterGap, hitem);
                return self.push(line, t, item, file, skipped, emit);
            }
            self.lost = true;
            skipped.note(
                file,
                hl,
                format!(
                    "time {ht} is {} s after the line before and the next line (line {line}, time {t}) does not follow it",
                    ht - p
                ),
            );
        }
        let dt = t - p;
        if dt <= 0.0 {
            self.lost = true;
            skipped.note(file, line, format!("time {t} not after {p}"));
        } else if dt < self.min_dt_s {
            self.lost = true;
            skipped.note(
                file,
                line,
                format!("interval {dt:e} s shorter than {:e} s", self.min_dt_s),
            );
        } else if dt > self.max_dt_s {
            self.held = Some((line, t, item));
        } else {
            self.prev = Some(t);
            let after_skip = std::mem::take(&mut self.lost);
            emit(line, t, Step::Next { dt, after_skip }, item);
        }
    }

    /// The end of the file: a held line that nothing confirmed is skipped.
    fn finish(&mut self, file: &str, skipped: &mut Skipped) {
        if let (Some(p), Some((hl, ht, _))) = (self.prev, self.held.take()) {
            skipped.note(
                file,
                hl,
                format!(
                    "time {ht} is {} s after the line before and is the last line, so nothing confirms it",
                    ht - p
                ),
            );
        }
    }
}

/// Aid streams to synthesize from the truth (papers/001 §5.2).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AidSynthesis {
    pub cns_sigma_m: Option<f64>,
    pub baro_sigma_m: Option<f64>,
    pub srs_sigma_mps: Option<f64>,
    pub seed: u64,
    /// The IMU's sensor grade, written to the header as `[navigator]
    /// preset` so that `batch` uses its noise model.
    pub preset: Option<polarnav_config::SensorGrade>,
}

/// The header metadata of an import: the description lines as TOML
/// comments and, with a preset, the `[navigator]` table that names it (so
/// the metadata is TOML that `batch` applies).
fn import_metadata(description: &str, preset: Option<polarnav_config::SensorGrade>) -> String {
    let mut out: String = description.lines().map(|l| format!("# {l}\n")).collect();
    if let Some(g) = preset {
        out += &format!("[navigator]\npreset = \"{}\"\n", g.name());
    }
    out
}

impl AidSynthesis {
    pub fn any(&self) -> bool {
        self.cns_sigma_m.is_some() || self.baro_sigma_m.is_some() || self.srs_sigma_mps.is_some()
    }
}

/// Counts of an import.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ImportSummary {
    pub imu: u64,
    /// IMU lines not imported because their interval starts before the
    /// first truth epoch (the init), and the line that is only the time
    /// base of the next one: with `imu` and the skipped IMU lines, every
    /// data line of the IMU file is counted once.
    pub imu_unused: u64,
    pub truth: u64,
    pub cns: u64,
    pub baro: u64,
    pub srs: u64,
    /// GNSS fixes imported (`import-kfgins --gnss`).
    pub gnss: u64,
    /// Good GNSS lines before the first truth epoch (the init), not imported.
    pub gnss_unused: u64,
    pub skipped: Skipped,
}

fn parse_fields(line: &str, n: usize) -> Result<Vec<f64>, String> {
    let f: Vec<&str> = line
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
        .collect();
    if f.len() < n {
        return Err(format!("{} fields, expected {n}", f.len()));
    }
    let mut out = Vec::with_capacity(n);
    for (i, s) in f.iter().take(n).enumerate() {
        let v: f64 = s
            .parse()
            .map_err(|_| format!("field {} is not a number: {s:?}", i + 1))?;
        if !v.is_finite() {
            return Err(format!("field {} is not finite: {s}", i + 1));
        }
        out.push(v);
    }
    Ok(out)
}

/// Checks a geodetic position for physical sense (degrees, metres).
fn check_position(lat_deg: f64, lon_deg: f64, h_m: f64) -> Result<(), String> {
    if lat_deg.abs() > 90.0 {
        return Err(format!("latitude {lat_deg}° outside [-90, 90]"));
    }
    if lon_deg.abs() > 360.0 {
        return Err(format!("longitude {lon_deg}° outside [-360, 360]"));
    }
    if !(POSITION_H_RANGE_M.0..=POSITION_H_RANGE_M.1).contains(&h_m) {
        return Err(format!(
            "height {h_m} m outside [{}, {}] m",
            POSITION_H_RANGE_M.0, POSITION_H_RANGE_M.1
        ));
    }
    Ok(())
}

/// Heights an imported position may have (m): from below the deepest
/// ground to far above any aircraft.
pub const POSITION_H_RANGE_M: (f64, f64) = (-1.0e4, 1.0e5);

/// Largest attitude angle an imported line may state (deg).
const MAX_ANGLE_DEG: f64 = 360.0;

/// Longest gap between two truth epochs before the next line must confirm
/// it (s): one day.
const TRUTH_MAX_GAP_S: f64 = 86_400.0;

fn to_ns(t_s: f64) -> u64 {
    (t_s * 1e9).round() as u64
}

/// Truth record from geodetic position, NED velocity and FRD→NED roll/pitch/yaw (rad).
fn truth_from_kfgins(
    t_ns: u64,
    geo: &Geodetic,
    v_ned: &Vector3<f64>,
    rpy: &Vector3<f64>,
) -> TruthRecord {
    let m = frd_to_rfu();
    let c_frd_ned = nalgebra::Rotation3::from_euler_angles(rpy.x, rpy.y, rpy.z).into_inner();
    let c_b_g = m * c_frd_ned * m.transpose();
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let q = frames::quat_from_dcm(&(c_e_g.transpose() * c_b_g));
    let q = q.into_inner();
    TruthRecord {
        t_ns,
        r_e_m: earth::geodetic_to_ecef(geo).into(),
        v_e_mps: (c_e_g.transpose() * (m * v_ned)).into(),
        q_b_e: [q.w, q.i, q.j, q.k],
    }
}

/// Aid records synthesized at truth epochs: CNS and SRS at 1 Hz, baro at 10 Hz.
fn synthesize_aids(
    truth: &[TruthRecord],
    aids: &AidSynthesis,
    sum: &mut ImportSummary,
) -> Vec<Record> {
    let mut rng = ChaCha20Rng::seed_from_u64(aids.seed);
    let catalogue = sensors::default_catalogue();
    let mut out = Vec::new();
    let (mut next_1hz, mut next_10hz) = (0u64, 0u64);
    for t in truth {
        let r = Vector3::from(t.r_e_m);
        let v = Vector3::from(t.v_e_mps);
        if t.t_ns >= next_1hz {
            next_1hz = (t.t_ns / 1_000_000_000 + 1) * 1_000_000_000;
            if let Some(s) = aids.cns_sigma_m {
                out.push(Record::aid(sensors::cns_fix(
                    &mut rng, t.t_ns, sum.cns, &r, s, true,
                )));
                sum.cns += 1;
            }
            if let Some(s) = aids.srs_sigma_mps {
                let mask = 10f64.to_radians();
                out.push(Record::aid(sensors::srs_sample(
                    &mut rng, t.t_ns, sum.srs, &r, &v, &catalogue, mask, s, true,
                )));
                sum.srs += 1;
            }
        }
        if t.t_ns >= next_10hz {
            next_10hz = (t.t_ns / 100_000_000 + 1) * 100_000_000;
            if let Some(s) = aids.baro_sigma_m {
                let h = earth::ecef_to_geodetic(&r).h_m;
                out.push(Record::aid(sensors::baro_sample(
                    &mut rng, t.t_ns, sum.baro, h, s, true,
                )));
                sum.baro += 1;
            }
        }
    }
    out
}

/// Orders records by time; at equal times IMU first, then aids, then truth.
fn sort_records(records: &mut [Record]) {
    let rank = |r: &Record| match r {
        Record::Header(_) => 0,
        Record::Init(_) => 1,
        Record::Imu(_) => 2,
        Record::Aid(_) => 3,
        _ => 4,
    };
    records.sort_by_key(|r| (r.t_ns().unwrap_or(0), rank(r)));
}

/// Default σ of an imported init record (the truth itself, so only nominal uncertainty).
pub const IMPORT_INIT_SIGMA: InitErrors = InitErrors {
    pos_h_m: 1.0,
    pos_v_m: 1.0,
    vel_h_mps: 0.01,
    vel_v_mps: 0.01,
    tilt_rad: 0.1 / 60.0 * std::f64::consts::PI / 180.0,
    heading_rad: 1.0 / 60.0 * std::f64::consts::PI / 180.0,
};

fn init_from_truth(t: &TruthRecord) -> InitState {
    let [w, x, y, z] = t.q_b_e;
    let sample = TruthSample {
        r_e: Vector3::from(t.r_e_m),
        v_e: Vector3::from(t.v_e_mps),
        q_b_e: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)),
        // The truth file has no rates; an init needs none.
        omega_ib_b: Vector3::zeros(),
    };
    init_record(t.t_ns, &sample, &IMPORT_INIT_SIGMA, None)
}

fn write_log<W: Write>(out: W, header: Header, records: &[Record]) -> Result<(), ImportError> {
    let mut w = NavlogWriter::new(out, header)?;
    for r in records {
        w.write(r)?;
    }
    w.finish()?;
    Ok(())
}

/// The KF-GINS files of an import and, without truth, the initial state.
#[derive(Debug, Clone, Copy)]
pub struct KfginsFiles<'a> {
    /// `imu.txt`: time, angle and velocity increments (body FRD).
    pub imu: &'a std::path::Path,
    /// `truth.nav`: its first epoch is the init and the time base.
    pub truth: Option<&'a std::path::Path>,
    /// KF-GINS's GNSS file, on the IMU file's clock.
    pub gnss: Option<&'a std::path::Path>,
    /// Without truth, the init: the first GNSS fix's position with this
    /// attitude and velocity (KF-GINS's `initatt` and `initvel`).
    pub init: Option<GivenInit>,
}

/// The initial attitude and velocity of a flight without truth, as KF-GINS's
/// configuration gives them (`initatt`, `initvel` and their σ); the
/// position is the first GNSS fix's, with that fix's σ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GivenInit {
    /// Roll, pitch, yaw of the FRD body against NED (deg), KF-GINS `initatt`.
    pub att_rpy_deg: [f64; 3],
    /// Velocity north, east, down (m/s), KF-GINS `initvel`.
    pub vel_ned_mps: [f64; 3],
    /// 1-σ of roll and pitch (per axis) and of yaw (deg).
    pub sigma_tilt_deg: f64,
    pub sigma_heading_deg: f64,
    /// 1-σ of the velocity, horizontal (per axis) and vertical (m/s).
    pub sigma_vel_h_mps: f64,
    pub sigma_vel_v_mps: f64,
}

impl GivenInit {
    /// Checks every value for physical sense; the message names the value.
    pub fn check(&self) -> Result<(), String> {
        if let Some(a) = self
            .att_rpy_deg
            .iter()
            .find(|a| !(a.is_finite() && a.abs() <= MAX_ANGLE_DEG))
        {
            return Err(format!("attitude angle {a}° not within ±{MAX_ANGLE_DEG}°"));
        }
        if let Some(v) = self
            .vel_ned_mps
            .iter()
            .find(|v| !(v.is_finite() && v.abs() <= MAX_SPEED_MPS))
        {
            return Err(format!("velocity {v} m/s not within ±{MAX_SPEED_MPS} m/s"));
        }
        for (what, v, max) in [
            ("tilt σ (deg)", self.sigma_tilt_deg, 90.0),
            ("heading σ (deg)", self.sigma_heading_deg, 180.0),
            (
                "horizontal velocity σ (m/s)",
                self.sigma_vel_h_mps,
                MAX_SPEED_MPS,
            ),
            (
                "vertical velocity σ (m/s)",
                self.sigma_vel_v_mps,
                MAX_SPEED_MPS,
            ),
        ] {
            if !(v > 0.0 && v <= max) {
                return Err(format!("{what} {v} not in (0, {max}]"));
            }
        }
        Ok(())
    }
}

/// Largest speed an imported line may state (m/s).
const MAX_SPEED_MPS: f64 = 1.0e4;

/// Largest position σ of a GNSS line (m): a fix less certain than this
/// carries nothing, and its square would swamp the innovation covariance.
const GNSS_MAX_SIGMA_M: f64 = 1.0e4;
/// Largest velocity σ of a GNSS line (m/s).
const GNSS_MAX_SIGMA_MPS: f64 = 1.0e3;

/// The fix of one KF-GINS GNSS line: `v` is `time lat lon h σN σE σD` (7
/// columns) or `time lat lon h vN vE vD σN σE σD σvN σvE σvD` (13).
///
/// The payload has one horizontal accuracy, taken by the GNSS model as
/// the σ of each horizontal axis (R = diag(h², h², v²) in the level axes).
/// So h_acc = √((σN² + σE²)/2): R's north and east variances are then
/// σN² and σE² exactly when σN = σE, and their sum (the horizontal error's
/// mean square) is kept always; what is lost is the split between north and
/// east when they differ (KF-GINS's own R is diag(σN², σE², σD²)).
/// v_acc = σD. With velocity, s_acc = √((σvN² + σvE² + σvD²)/3) likewise;
/// without it the fix is flagged [`fix_flags::NO_VELOCITY`] and only its
/// position is fused, as KF-GINS fuses only position. The file has no DOP
/// nor satellite count: both are 0 (not known; the DOP gate passes 0).
pub fn gnss_fix_of_kfgins(v: &[f64]) -> Result<(f64, GnssFix), String> {
    let (vel, sig, sig_v) = match v.len() {
        7 => (None, &v[4..7], None),
        13 => (Some(&v[4..7]), &v[7..10], Some(&v[10..13])),
        n => return Err(format!("{n} fields, expected 7 or 13")),
    };
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("a field is not finite: {x}"));
    }
    check_position(v[1], v[2], v[3])?;
    for (name, s) in ["σ north", "σ east", "σ down"].iter().zip(sig) {
        if !(*s > 0.0 && *s <= GNSS_MAX_SIGMA_M) {
            return Err(format!("{name} {s} m not in (0, {GNSS_MAX_SIGMA_M}] m"));
        }
    }
    let mut fix = GnssFix {
        lat_rad: v[1].to_radians(),
        lon_rad: v[2].to_radians(),
        height_m: v[3],
        h_acc_m: ((sig[0] * sig[0] + sig[1] * sig[1]) / 2.0).sqrt(),
        v_acc_m: sig[2],
        // GPS time of week (ms); the file's time is GPS seconds of week.
        itow_ms: (v[0].rem_euclid(604_800.0) * 1e3).round() as u32,
        fix_type: fix_type::FIX_3D,
        flags: fix_flags::FIX_OK | fix_flags::NO_VELOCITY,
        ..Default::default()
    };
    if let (Some(vel), Some(sig_v)) = (vel, sig_v) {
        if let Some(x) = vel.iter().find(|x| x.abs() > MAX_SPEED_MPS) {
            return Err(format!("velocity {x} m/s beyond ±{MAX_SPEED_MPS} m/s"));
        }
        for (name, s) in ["σ vN", "σ vE", "σ vD"].iter().zip(sig_v) {
            if !(*s > 0.0 && *s <= GNSS_MAX_SIGMA_MPS) {
                return Err(format!(
                    "{name} {s} m/s not in (0, {GNSS_MAX_SIGMA_MPS}] m/s"
                ));
            }
        }
        fix.vel_ned_mps = [vel[0], vel[1], vel[2]];
        fix.s_acc_mps = (sig_v.iter().map(|s| s * s).sum::<f64>() / 3.0).sqrt();
        fix.flags = fix_flags::FIX_OK;
    }
    Ok((v[0], fix))
}

/// Reads a KF-GINS GNSS file: every good line with its time (s), bad ones
/// noted in `skipped`.
fn read_kfgins_gnss(
    path: &std::path::Path,
    skipped: &mut Skipped,
) -> Result<Vec<(f64, GnssFix)>, ImportError> {
    let name = path.display().to_string();
    let mut out = Vec::new();
    let mut valid = 0usize;
    let mut timeline = Timeline::new(0.0, TRUTH_MAX_GAP_S);
    let mut lines = TextLines::open(path)?;
    while let Some((no, line)) = lines.next_line()? {
        let line = match line {
            Ok(l) => l.trim(),
            Err(why) => {
                skipped.note(&name, no, why);
                continue;
            }
        };
        if line.is_empty() || line.starts_with('#') || line.starts_with('%') {
            continue;
        }
        let fields = line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .count();
        let fix = match parse_fields(line, fields).and_then(|v| gnss_fix_of_kfgins(&v)) {
            Ok(f) => f,
            Err(why) => {
                skipped.note(&name, no, why);
                continue;
            }
        };
        valid += 1;
        timeline.push(no, fix.0, fix.1, &name, skipped, |_, t, _, f| {
            out.push((t, f));
        });
    }
    timeline.finish(&name, skipped);
    if valid == 0 {
        return Err(ImportError::NotFormat {
            path: name,
            format: "KF-GINS GNSS",
            why: "no valid 7- or 13-column line".into(),
        });
    }
    Ok(out)
}

/// Reads a KF-GINS truth file: every good epoch with its time (s).
fn read_kfgins_truth(
    path: &std::path::Path,
    skipped: &mut Skipped,
) -> Result<Vec<(f64, TruthRecord)>, ImportError> {
    let name = path.display().to_string();
    let mut truth = Vec::new();
    let mut valid_truth = 0usize;
    let mut timeline = Timeline::new(0.0, TRUTH_MAX_GAP_S);
    let mut lines = TextLines::open(path)?;
    while let Some((no, line)) = lines.next_line()? {
        let line = match line {
            Ok(l) => l.trim(),
            Err(why) => {
                skipped.note(&name, no, why);
                continue;
            }
        };
        if line.is_empty() || line.starts_with('#') || line.starts_with('%') {
            continue;
        }
        let v = match parse_fields(line, 11).and_then(|v| {
            check_position(v[2], v[3], v[4])?;
            if let Some(a) = v[8..11].iter().find(|a| a.abs() > MAX_ANGLE_DEG) {
                return Err(format!("attitude angle {a}° beyond ±{MAX_ANGLE_DEG}°"));
            }
            Ok(v)
        }) {
            Ok(v) => v,
            Err(why) => {
                skipped.note(&name, no, why);
                continue;
            }
        };
        valid_truth += 1;
        let geo = Geodetic::from_deg(v[2], v[3], v[4]);
        let rpy = Vector3::new(v[8], v[9], v[10]).map(f64::to_radians);
        let rec = truth_from_kfgins(0, &geo, &Vector3::new(v[5], v[6], v[7]), &rpy);
        timeline.push(no, v[1], rec, &name, skipped, |_, t, _, rec| {
            truth.push((t, rec));
        });
    }
    timeline.finish(&name, skipped);
    if truth.is_empty() {
        return Err(ImportError::NotFormat {
            path: name,
            format: "KF-GINS truth",
            why: if valid_truth == 0 {
                "no valid 11-column line".into()
            } else {
                "no line with a usable time".into()
            },
        });
    }
    Ok(truth)
}

/// The init of a flight without truth: the first fix's position (its σ
/// from the fix's accuracies) with the given attitude and velocity.
fn init_from_fix(fix: &GnssFix, given: &GivenInit) -> InitState {
    let geo = Geodetic::new(fix.lat_rad, fix.lon_rad, fix.height_m);
    let rpy = Vector3::from(given.att_rpy_deg).map(f64::to_radians);
    let t = truth_from_kfgins(fix.t_ns, &geo, &Vector3::from(given.vel_ned_mps), &rpy);
    let [w, x, y, z] = t.q_b_e;
    let sample = TruthSample {
        r_e: Vector3::from(t.r_e_m),
        v_e: Vector3::from(t.v_e_mps),
        q_b_e: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z)),
        omega_ib_b: Vector3::zeros(),
    };
    let sigma = InitErrors {
        pos_h_m: fix.h_acc_m,
        pos_v_m: fix.v_acc_m,
        vel_h_mps: given.sigma_vel_h_mps,
        vel_v_mps: given.sigma_vel_v_mps,
        tilt_rad: given.sigma_tilt_deg.to_radians(),
        heading_rad: given.sigma_heading_deg.to_radians(),
    };
    init_record(t.t_ns, &sample, &sigma, None)
}

/// Imports a KF-GINS IMU file and truth file into a navlog. Time base:
/// t_ns = 0 at the first truth epoch (the init record); IMU samples ending
/// at or before it are dropped.
pub fn import_kfgins<W: Write>(
    imu_path: &std::path::Path,
    truth_path: &std::path::Path,
    aids: &AidSynthesis,
    out: W,
) -> Result<ImportSummary, ImportError> {
    import_kfgins_files(
        &KfginsFiles {
            imu: imu_path,
            truth: Some(truth_path),
            gnss: None,
            init: None,
        },
        aids,
        out,
    )
}

/// Imports KF-GINS files into a navlog: the IMU, the truth and/or KF-GINS's
/// GNSS file. Time base: t_ns = 0 at the first truth epoch, or without
/// truth at the first GNSS fix, which is then the init's position (with
/// [`KfginsFiles::init`]'s attitude and velocity). IMU samples whose
/// interval starts before it and GNSS fixes before it are not imported.
/// Aids can be synthesized only from a truth.
pub fn import_kfgins_files<W: Write>(
    files: &KfginsFiles,
    aids: &AidSynthesis,
    out: W,
) -> Result<ImportSummary, ImportError> {
    if files.truth.is_none() && aids.any() {
        return Err(ImportError::NoInit(
            "aids are synthesized from a truth file, and none was given".into(),
        ));
    }
    let mut sum = ImportSummary::default();
    let imu_path = files.imu;
    let imu_name = imu_path.display().to_string();
    let m = frd_to_rfu();

    let truth = match files.truth {
        Some(p) => read_kfgins_truth(p, &mut sum.skipped)?,
        None => Vec::new(),
    };
    let gnss = match files.gnss {
        Some(p) => read_kfgins_gnss(p, &mut sum.skipped)?,
        None => Vec::new(),
    };
    let t0 = match (truth.first(), gnss.first(), &files.init) {
        (Some(&(t, _)), _, _) => t,
        (None, Some(&(t, _)), Some(_)) => t,
        (None, Some(_), None) => {
            return Err(ImportError::NoInit(
                "without a truth file the initial attitude and velocity must be given".into(),
            ));
        }
        (None, None, _) => {
            return Err(ImportError::NoInit(
                "a truth file or a GNSS file is needed (the init and the time base)".into(),
            ));
        }
    };
    let truth: Vec<TruthRecord> = truth
        .into_iter()
        .map(|(t, mut rec)| {
            rec.t_ns = to_ns(t - t0);
            rec
        })
        .collect();
    let mut fixes: Vec<GnssFix> = Vec::with_capacity(gnss.len());
    for (t, mut fix) in gnss {
        if t < t0 {
            sum.gnss_unused += 1;
            continue;
        }
        fix.t_ns = to_ns(t - t0);
        fix.seq = fixes.len() as u64;
        fixes.push(fix);
    }
    let mut records: Vec<Record> = Vec::new();

    let mut timeline = Timeline::new(IMU_DT_RANGE_S.0, IMU_DT_RANGE_S.1);
    let mut gap_lines: Vec<usize> = Vec::with_capacity(1);
    let mut unused = 0u64;
    let mut last_dt: Option<f64> = None;
    let mut seq = 0;
    let mut valid_lines = 0;
    let mut lines = TextLines::open(imu_path)?;
    while let Some((no, line)) = lines.next_line()? {
        let line = match line {
            Ok(l) => l.trim(),
            Err(why) => {
                sum.skipped.note(&imu_name, no, why);
                timeline.mark_lost();
                continue;
            }
        };
        if line.is_empty() || line.starts_with('#') || line.starts_with('%') {
            continue;
        }
        let v = match parse_fields(line, 7) {
            Ok(v) => v,
            Err(why) => {
                sum.skipped.note(&imu_name, no, why);
                timeline.mark_lost();
                continue;
            }
        };
        valid_lines += 1;
        let (t, d_theta, d_v) = (
            v[0],
            m * Vector3::new(v[1], v[2], v[3]),
            m * Vector3::new(v[4], v[5], v[6]),
        );
        let skipped = &mut sum.skipped;
        timeline.push(
            no,
            t,
            (d_theta, d_v),
            &imu_name,
            skipped,
            |line, t, step, (d_theta, d_v)| {
                // A KF-GINS line holds the increments over its own interval,
                // which ends at its time and starts at the previous line's. When
                // a line before it was skipped or a gap precedes it, its own
                // interval is estimated by the last whole one, and the navigator
                // bridges or coasts the missing time before it.
                let dt = match step {
                    // The first line has no interval: it is the time base.
                    Step::First => {
                        unused += 1;
                        return;
                    }
                    Step::AfterGap => match last_dt {
                        Some(d) => d,
                        None => {
                            gap_lines.push(line);
                            return;
                        }
                    },
                    Step::Next {
                        dt,
                        after_skip: false,
                    } => {
                        last_dt = Some(dt);
                        dt
                    }
                    Step::Next {
                        dt,
                        after_skip: true,
                    } => last_dt.map_or(dt, |d| d.min(dt)),
                };
                if t - dt < t0 - 1e-9 {
                    unused += 1; // the interval starts before the init epoch
                    return;
                }
                records.push(Record::Imu(ImuSample {
                    t_ns: to_ns(t - t0),
                    seq,
                    dt_s: dt,
                    d_theta_rad: d_theta.into(),
                    d_v_mps: d_v.into(),
                }));
                seq += 1;
            },
        );
        for line in gap_lines.drain(..) {
            sum.skipped.note(
                &imu_name,
                line,
                format!(
                    "first line after a gap longer than {} s, before any whole interval: its own interval is unknown",
                    IMU_DT_RANGE_S.1
                ),
            );
        }
    }
    timeline.finish(&imu_name, &mut sum.skipped);
    if valid_lines == 0 {
        return Err(ImportError::NotFormat {
            path: imu_name,
            format: "KF-GINS IMU",
            why: "no valid 7-column line".into(),
        });
    }
    sum.imu = seq;
    sum.imu_unused = unused;
    sum.truth = truth.len() as u64;
    sum.gnss = fixes.len() as u64;
    let init = match (truth.first(), fixes.first(), &files.init) {
        (Some(t), _, _) => init_from_truth(t),
        (None, Some(f), Some(given)) => init_from_fix(f, given),
        // t0 above came from one of them.
        _ => unreachable!("the time base has an init"),
    };
    records.push(Record::Init(init));
    records.extend(synthesize_aids(&truth, aids, &mut sum));
    records.extend(truth.iter().copied().map(Record::Truth));
    records.extend(fixes.into_iter().map(Record::aid));
    sort_records(&mut records);
    let path_or_none = |p: Option<&std::path::Path>| {
        p.map_or("none".to_owned(), |p| {
            format!("{:?}", p.display().to_string())
        })
    };
    let mut meta = format!(
        "imported from KF-GINS\nimu = {imu_name:?}\ntruth = {}\ngnss = {}\ntime_offset_s = {t0}\naids = {aids:?}\nskipped_lines = {}\n",
        path_or_none(files.truth),
        path_or_none(files.gnss),
        sum.skipped.count
    );
    if files.truth.is_none()
        && let Some(g) = &files.init
    {
        meta += &format!("init = first GNSS fix with {g:?}\n");
    }
    write_log(
        out,
        Header::new(
            &format!(
                "sensor-replay {} import-kfgins",
                polarnav_config::build_info::LONG_VERSION
            ),
            "kfgins",
            aids.seed,
            &import_metadata(&meta, aids.preset),
        ),
        &records,
    )?;
    Ok(sum)
}

/// Writes KF-GINS `imu.txt` and `truth.nav` from a navlog's IMU and truth records.
pub fn export_kfgins(
    dir: &std::path::Path,
    imu: &[ImuSample],
    truth: &[TruthRecord],
) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let m = frd_to_rfu();
    let mut f = std::io::BufWriter::new(std::fs::File::create(dir.join("imu.txt"))?);
    // The first sample's start time, so that an importer can recover its interval.
    if let Some(first) = imu.first() {
        writeln!(f, "{} 0 0 0 0 0 0", (first.t_ns as f64 * 1e-9) - first.dt_s)?;
    }
    for s in imu {
        let th = m * Vector3::from(s.d_theta_rad);
        let dv = m * Vector3::from(s.d_v_mps);
        writeln!(
            f,
            "{} {} {} {} {} {} {}",
            s.t_ns as f64 * 1e-9,
            th.x,
            th.y,
            th.z,
            dv.x,
            dv.y,
            dv.z
        )?;
    }
    f.flush()?;
    let mut f = std::io::BufWriter::new(std::fs::File::create(dir.join("truth.nav"))?);
    for t in truth {
        let r = Vector3::from(t.r_e_m);
        let g = earth::ecef_to_geodetic(&r);
        let c_e_g = frames::c_e_g(g.lat_rad, g.lon_rad);
        let v_ned = m * (c_e_g * Vector3::from(t.v_e_mps));
        let [w, x, y, z] = t.q_b_e;
        let c_b_e = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
            .to_rotation_matrix()
            .into_inner();
        let c_frd_ned = m.transpose() * (c_e_g * c_b_e) * m;
        let (roll, pitch, yaw) =
            nalgebra::Rotation3::from_matrix_unchecked(c_frd_ned).euler_angles();
        writeln!(
            f,
            "0 {} {} {} {} {} {} {} {} {} {}",
            t.t_ns as f64 * 1e-9,
            g.lat_rad.to_degrees(),
            g.lon_rad.to_degrees(),
            g.h_m,
            v_ned.x,
            v_ned.y,
            v_ned.z,
            roll.to_degrees(),
            pitch.to_degrees(),
            yaw.to_degrees()
        )?;
    }
    f.flush()
}

/// Imports a PSINS text IMU file. The unit is taken as static at the header
/// position (the dataset's truth); truth records at 1 Hz carry that position,
/// zero velocity and the header attitude (approximate, as the file warns).
pub fn import_psins<W: Write>(
    path: &std::path::Path,
    aids: &AidSynthesis,
    out: W,
) -> Result<ImportSummary, ImportError> {
    let name = path.display().to_string();
    let not = |why: String| ImportError::NotFormat {
        path: name.clone(),
        format: "PSINS text IMU",
        why,
    };
    let mut lines = TextLines::open(path)?;
    let mut sum = ImportSummary::default();
    // The three header lines: the first three lines of data (not comments).
    let mut header = Vec::with_capacity(3);
    while header.len() < 3 {
        let Some((no, line)) = lines.next_line()? else {
            return Err(not(format!(
                "missing header line {} of 3 (attitude and velocity; position, time and interval; scale factors)",
                header.len() + 1
            )));
        };
        let line = line.map_err(|why| not(format!("line {no}: header: {why}")))?;
        let line = line.trim();
        if line.is_empty() || line.starts_with('%') {
            continue;
        }
        let v = parse_fields(line, 6).map_err(|e| not(format!("line {no}: header: {e}")))?;
        let check = match header.len() {
            0 => psins_attitude_check(&v),
            1 => psins_position_check(&v),
            _ => psins_scale_check(&v),
        };
        check.map_err(|e| not(format!("line {no}: header: {e}")))?;
        header.push(v);
    }
    let (att, pos, scale) = (&header[0], &header[1], &header[2]);
    let ts = pos[4] * 1e-3;
    let gyro_scale = scale[0..3]
        .iter()
        .map(|s| s / 3600.0 * std::f64::consts::PI / 180.0)
        .collect::<Vec<_>>();
    let accel_scale = scale[3..6]
        .iter()
        .map(|s| s * 1e-6 * pos[5])
        .collect::<Vec<_>>();
    let geo = Geodetic::from_deg(pos[0], pos[1], pos[2]);
    let c_b_g = frames::c_b_n_from_euler(
        -att[2].to_radians(),
        att[0].to_radians(),
        att[1].to_radians(),
    );
    let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
    let q = frames::quat_from_dcm(&(c_e_g.transpose() * c_b_g)).into_inner();
    let v_e = c_e_g.transpose() * Vector3::new(att[3], att[4], att[5]);
    let truth_at = |t_ns: u64| TruthRecord {
        t_ns,
        r_e_m: earth::geodetic_to_ecef(&geo).into(),
        v_e_mps: v_e.into(),
        q_b_e: [q.w, q.i, q.j, q.k],
    };

    let mut records = Vec::new();
    let dt_ns = to_ns(ts);
    let mut k: u64 = 0;
    while let Some((no, line)) = lines.next_line()? {
        let v = match line {
            Ok(l) if l.trim().is_empty() || l.trim().starts_with('%') => continue,
            Ok(l) => parse_fields(l, 6),
            Err(why) => Err(why),
        };
        let v = v.and_then(|v| {
            let th = Vector3::new(
                v[0] * gyro_scale[0],
                v[1] * gyro_scale[1],
                v[2] * gyro_scale[2],
            );
            let dv = Vector3::new(
                v[3] * accel_scale[0],
                v[4] * accel_scale[1],
                v[5] * accel_scale[2],
            );
            if th.iter().chain(dv.iter()).all(|x| x.is_finite()) {
                Ok((th, dv))
            } else {
                Err("increment not finite once scaled".to_owned())
            }
        });
        match v {
            Ok((th, dv)) => {
                k += 1;
                records.push(Record::Imu(ImuSample {
                    t_ns: k * dt_ns,
                    seq: k - 1,
                    dt_s: ts,
                    d_theta_rad: th.into(),
                    d_v_mps: dv.into(),
                }));
            }
            Err(why) => sum.skipped.note(&name, no, why),
        }
    }
    if k == 0 {
        return Err(not("no data lines".into()));
    }
    sum.imu = k;
    let end_ns = k * dt_ns;
    let truth: Vec<TruthRecord> = (0..=end_ns / 1_000_000_000)
        .map(|s| truth_at(s * 1_000_000_000))
        .collect();
    sum.truth = truth.len() as u64;
    records.push(Record::Init(init_from_truth(&truth[0])));
    records.extend(synthesize_aids(&truth, aids, &mut sum));
    records.extend(truth.into_iter().map(Record::Truth));
    sort_records(&mut records);
    let meta = format!(
        "imported from PSINS text IMU\nfile = {name:?}\nheader_attitude_deg = [{}, {}, {}] # pitch, roll, yaw (ccw); approximate per the file\nt0_s = {}\naids = {aids:?}\nskipped_lines = {}\n",
        att[0], att[1], att[2], pos[3], sum.skipped.count
    );
    write_log(
        out,
        Header::new(
            &format!(
                "sensor-replay {} import-psins",
                polarnav_config::build_info::LONG_VERSION
            ),
            "psins",
            aids.seed,
            &import_metadata(&meta, aids.preset),
        ),
        &records,
    )?;
    Ok(sum)
}

/// PSINS header line 1: pitch, roll, yaw (deg), v_E, v_N, v_U (m/s).
fn psins_attitude_check(v: &[f64]) -> Result<(), String> {
    if v[0].abs() > 90.0 {
        return Err(format!("pitch {}° outside [-90, 90]", v[0]));
    }
    if let Some(a) = v[1..3].iter().find(|a| a.abs() > MAX_ANGLE_DEG) {
        return Err(format!("angle {a}° beyond ±{MAX_ANGLE_DEG}°"));
    }
    let speed = Vector3::new(v[3], v[4], v[5]).norm();
    if speed > PSINS_MAX_SPEED_MPS {
        return Err(format!(
            "speed {speed} m/s beyond {PSINS_MAX_SPEED_MPS} m/s"
        ));
    }
    Ok(())
}

/// Fastest initial speed a PSINS header may state (m/s).
const PSINS_MAX_SPEED_MPS: f64 = 1000.0;

/// Local gravity a PSINS header may state (m/s²): the Earth's, with margin.
const PSINS_GRAVITY_RANGE_MPS2: (f64, f64) = (9.7, 9.9);

/// PSINS header line 2: latitude, longitude (deg), height (m), t0 (s),
/// sample interval (ms), local gravity (m/s²).
fn psins_position_check(v: &[f64]) -> Result<(), String> {
    check_position(v[0], v[1], v[2])?;
    let (lo, hi) = (IMU_DT_RANGE_S.0 * 1e3, IMU_DT_RANGE_S.1 * 1e3);
    if !(lo..=hi).contains(&v[4]) {
        return Err(format!(
            "sample interval {} ms outside [{lo}, {hi}] ms",
            v[4]
        ));
    }
    let (glo, ghi) = PSINS_GRAVITY_RANGE_MPS2;
    if !(glo..=ghi).contains(&v[5]) {
        return Err(format!("gravity {} m/s² outside [{glo}, {ghi}] m/s²", v[5]));
    }
    Ok(())
}

/// PSINS header line 3: gyro (arcsec/count) and accelerometer (µg·s/count)
/// scale factors, each positive and finite.
fn psins_scale_check(v: &[f64]) -> Result<(), String> {
    match v.iter().position(|s| *s <= 0.0) {
        Some(i) => Err(format!("scale factor {} is {}, not positive", i + 1, v[i])),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frd_rfu_is_a_proper_involution() {
        let m = frd_to_rfu();
        assert!((m * m - Matrix3::identity()).norm() < 1e-15);
        assert!((m.determinant() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn kfgins_attitude_conversion_matches_heading_convention() {
        // Yaw 30° in NED/FRD is heading 30° clockwise from north in our frames.
        let geo = Geodetic::from_deg(40.0, 10.0, 0.0);
        let rec = truth_from_kfgins(
            0,
            &geo,
            &Vector3::zeros(),
            &Vector3::new(0.0, 0.0, 30f64.to_radians()),
        );
        let [w, x, y, z] = rec.q_b_e;
        let c_b_e = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
            .to_rotation_matrix()
            .into_inner();
        let (h, p, r) =
            frames::euler_from_c_b_n(&(frames::c_e_g(geo.lat_rad, geo.lon_rad) * c_b_e));
        assert!((h - 30f64.to_radians()).abs() < 1e-12 && p.abs() < 1e-12 && r.abs() < 1e-12);
    }
}
