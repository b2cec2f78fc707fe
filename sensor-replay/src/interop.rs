//! Import and export of other tools' text formats.
//!
//! - KF-GINS: IMU `time Δθx Δθy Δθz Δvx Δvy Δvz` (rad, m/s; body
//!   forward-right-down) and truth `week time lat lon h vN vE vD roll pitch yaw`
//!   (deg, m, m/s; NED). Converted to our body right-forward-up and ENU.
//! - PSINS text IMU (`../shared/datasets/psins-lasergyro`): header lines,
//!   then integer gyro/accelerometer counts, body right-forward-up.
//!
//! Malformed or non-finite lines are skipped, each named in a warning and
//! counted; an import fails only when the file is unreadable or not of the
//! format at all.

use std::io::Write;

use msgs::navlog::{Header, NavlogWriter, Record, WriteError};
use msgs::{ImuSample, InitState, TruthRecord};
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

/// Imports a KF-GINS IMU file and truth file into a navlog. Time base:
/// t_ns = 0 at the first truth epoch (the init record); IMU samples ending
/// at or before it are dropped.
pub fn import_kfgins<W: Write>(
    imu_path: &std::path::Path,
    truth_path: &std::path::Path,
    aids: &AidSynthesis,
    out: W,
) -> Result<ImportSummary, ImportError> {
    let mut sum = ImportSummary::default();
    let imu_name = imu_path.display().to_string();
    let truth_name = truth_path.display().to_string();
    let m = frd_to_rfu();

    let mut truth: Vec<TruthRecord> = Vec::new();
    let mut t0: Option<f64> = None;
    let mut valid_truth = 0usize;
    let mut timeline = Timeline::new(0.0, TRUTH_MAX_GAP_S);
    let mut lines = TextLines::open(truth_path)?;
    while let Some((no, line)) = lines.next_line()? {
        let line = match line {
            Ok(l) => l.trim(),
            Err(why) => {
                sum.skipped.note(&truth_name, no, why);
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
                sum.skipped.note(&truth_name, no, why);
                continue;
            }
        };
        valid_truth += 1;
        let geo = Geodetic::from_deg(v[2], v[3], v[4]);
        let rpy = Vector3::new(v[8], v[9], v[10]).map(f64::to_radians);
        let rec = truth_from_kfgins(0, &geo, &Vector3::new(v[5], v[6], v[7]), &rpy);
        timeline.push(
            no,
            v[1],
            rec,
            &truth_name,
            &mut sum.skipped,
            |_, t, _, mut rec| {
                let t0 = *t0.get_or_insert(t);
                rec.t_ns = to_ns(t - t0);
                truth.push(rec);
            },
        );
    }
    timeline.finish(&truth_name, &mut sum.skipped);
    let Some(t0) = t0 else {
        return Err(ImportError::NotFormat {
            path: truth_name,
            format: "KF-GINS truth",
            why: if valid_truth == 0 {
                "no valid 11-column line".into()
            } else {
                "no line with a usable time".into()
            },
        });
    };
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
    records.push(Record::Init(init_from_truth(&truth[0])));
    records.extend(synthesize_aids(&truth, aids, &mut sum));
    records.extend(truth.iter().copied().map(Record::Truth));
    sort_records(&mut records);
    let meta = format!(
        "imported from KF-GINS\nimu = {imu_name:?}\ntruth = {truth_name:?}\ntime_offset_s = {t0}\naids = {aids:?}\nskipped_lines = {}\n",
        sum.skipped.count
    );
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
