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
use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;

use crate::sensors;
use crate::simulate::{InitErrors, init_record};
use crate::trajectory::TruthSample;

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
    /// (file, 1-based line number, reason) of every skipped line.
    pub lines: Vec<(String, usize, String)>,
}

impl Skipped {
    fn note(&mut self, file: &str, line: usize, why: String) {
        self.lines.push((file.to_owned(), line, why));
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

fn read_text(path: &std::path::Path) -> Result<String, ImportError> {
    std::fs::read_to_string(path).map_err(|source| ImportError::Io {
        path: path.display().to_string(),
        source,
    })
}

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
                out.push(Record::Cns(sensors::cns_fix(
                    &mut rng, t.t_ns, sum.cns, &r, s, true,
                )));
                sum.cns += 1;
            }
            if let Some(s) = aids.srs_sigma_mps {
                let mask = 10f64.to_radians();
                out.push(Record::Srs(Box::new(sensors::srs_sample(
                    &mut rng, t.t_ns, sum.srs, &r, &v, &catalogue, mask, s, true,
                ))));
                sum.srs += 1;
            }
        }
        if t.t_ns >= next_10hz {
            next_10hz = (t.t_ns / 100_000_000 + 1) * 100_000_000;
            if let Some(s) = aids.baro_sigma_m {
                let h = earth::ecef_to_geodetic(&r).h_m;
                out.push(Record::Baro(sensors::baro_sample(
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
        Record::Srs(_) | Record::Cns(_) | Record::Baro(_) => 3,
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

    let mut truth_rows: Vec<(f64, TruthRecord)> = Vec::new();
    let truth_text = read_text(truth_path)?;
    for (i, line) in truth_text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with('%') {
            continue;
        }
        match parse_fields(line, 11) {
            Ok(v) => {
                let geo = Geodetic::from_deg(v[2], v[3], v[4]);
                let rpy = Vector3::new(v[8], v[9], v[10]).map(f64::to_radians);
                truth_rows.push((
                    v[1],
                    truth_from_kfgins(0, &geo, &Vector3::new(v[5], v[6], v[7]), &rpy),
                ));
            }
            Err(why) => sum.skipped.note(&truth_name, i + 1, why),
        }
    }
    if truth_rows.is_empty() {
        return Err(ImportError::NotFormat {
            path: truth_name,
            format: "KF-GINS truth",
            why: "no valid 11-column line".into(),
        });
    }
    let t0 = truth_rows[0].0;
    let mut records: Vec<Record> = Vec::new();
    let mut truth: Vec<TruthRecord> = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    for (t, mut rec) in truth_rows {
        if t <= last_t {
            sum.skipped
                .note(&truth_name, 0, format!("truth time {t} not after {last_t}"));
            continue;
        }
        last_t = t;
        rec.t_ns = to_ns(t - t0);
        truth.push(rec);
    }

    let imu_text = read_text(imu_path)?;
    let mut prev_t: Option<f64> = None;
    let mut seq = 0;
    let mut valid_lines = 0;
    for (i, line) in imu_text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with('%') {
            continue;
        }
        let v = match parse_fields(line, 7) {
            Ok(v) => v,
            Err(why) => {
                sum.skipped.note(&imu_name, i + 1, why);
                continue;
            }
        };
        valid_lines += 1;
        let t = v[0];
        if let Some(p) = prev_t
            && t <= p
        {
            sum.skipped
                .note(&imu_name, i + 1, format!("time {t} not after {p}"));
            continue;
        }
        let dt = prev_t.map(|p| t - p);
        prev_t = Some(t);
        let Some(dt) = dt else { continue }; // the first line has no interval
        if t - dt < t0 - 1e-9 {
            continue; // interval starts before the init epoch
        }
        let d_theta = m * Vector3::new(v[1], v[2], v[3]);
        let d_v = m * Vector3::new(v[4], v[5], v[6]);
        records.push(Record::Imu(ImuSample {
            t_ns: to_ns(t - t0),
            seq,
            dt_s: dt,
            d_theta_rad: d_theta.into(),
            d_v_mps: d_v.into(),
        }));
        seq += 1;
    }
    if valid_lines == 0 {
        return Err(ImportError::NotFormat {
            path: imu_name,
            format: "KF-GINS IMU",
            why: "no valid 7-column line".into(),
        });
    }
    sum.imu = seq;
    sum.truth = truth.len() as u64;
    records.push(Record::Init(init_from_truth(&truth[0])));
    records.extend(synthesize_aids(&truth, aids, &mut sum));
    records.extend(truth.iter().copied().map(Record::Truth));
    sort_records(&mut records);
    let meta = format!(
        "imported from KF-GINS\nimu = {imu_name:?}\ntruth = {truth_name:?}\ntime_offset_s = {t0}\naids = {aids:?}\nskipped_lines = {}\n",
        sum.skipped.lines.len()
    );
    write_log(
        out,
        Header::new(
            concat!(
                "sensor-replay ",
                env!("CARGO_PKG_VERSION"),
                " import-kfgins"
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
    let text = read_text(path)?;
    let not = |why: String| ImportError::NotFormat {
        path: name.clone(),
        format: "PSINS text IMU",
        why,
    };
    let mut lines = text.lines().enumerate().filter(|(_, l)| {
        let l = l.trim();
        !l.is_empty() && !l.starts_with('%')
    });
    let mut header = |what: &str| -> Result<Vec<f64>, ImportError> {
        let (i, l) = lines
            .next()
            .ok_or_else(|| not(format!("missing header line: {what}")))?;
        parse_fields(l, 6).map_err(|e| not(format!("line {}: {what}: {e}", i + 1)))
    };
    let att = header("pitch, roll, yaw, vE, vN, vU")?;
    let pos = header("lat, lon, h, t0, interval (ms), g")?;
    let scale = header("scale factors")?;
    let ts = pos[4] * 1e-3;
    if ts <= 0.0 {
        return Err(not(format!(
            "sample interval {} ms is not positive",
            pos[4]
        )));
    }
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

    let mut sum = ImportSummary::default();
    let mut records = Vec::new();
    let dt_ns = to_ns(ts);
    let mut k: u64 = 0;
    for (i, line) in lines {
        match parse_fields(line, 6) {
            Ok(v) => {
                k += 1;
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
                records.push(Record::Imu(ImuSample {
                    t_ns: k * dt_ns,
                    seq: k - 1,
                    dt_s: ts,
                    d_theta_rad: th.into(),
                    d_v_mps: dv.into(),
                }));
            }
            Err(why) => sum.skipped.note(&name, i + 1, why),
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
        att[0],
        att[1],
        att[2],
        pos[3],
        sum.skipped.lines.len()
    );
    write_log(
        out,
        Header::new(
            concat!("sensor-replay ", env!("CARGO_PKG_VERSION"), " import-psins"),
            "psins",
            aids.seed,
            &import_metadata(&meta, aids.preset),
        ),
        &records,
    )?;
    Ok(sum)
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
