//! Checkpoints of the navigator: the nominal state, error covariance and
//! biases, so that a restarted daemon resumes instead of starting cold.
//!
//! Format (little-endian, fixed length [`ENCODED_LEN`]): magic
//! `PNCKPT03`, the fields of [`Checkpoint`] in declaration order, CRC-32 of
//! everything before it. A `PNCKPT02` file (without the GNSS receiver's
//! consider parameters, [`ENCODED_LEN_V2`] bytes) and a `PNCKPT01` file
//! (without the magnetometer's either, [`ENCODED_LEN_V1`] bytes) still
//! read, with the parameters they lack zero. Files are replaced atomically: written to a
//! temporary file beside the target, fsynced, renamed over it, and the
//! directory fsynced, so a crash leaves either the old or the new checkpoint.
//! [`Checkpoint::load`] also refuses an intact file whose content is
//! physically implausible ([`Checkpoint::validate`]).

use std::io::Write;
use std::path::Path;

/// Magic and format version.
pub const MAGIC: &[u8; 8] = b"PNCKPT03";
/// Magic of the second format (the magnetometer's consider parameter only).
pub const MAGIC_V2: &[u8; 8] = b"PNCKPT02";
/// Magic of the first format (no consider parameter).
pub const MAGIC_V1: &[u8; 8] = b"PNCKPT01";

const N_F64_V1: usize = 3 + 3 + 4 + 225 + 3 + 3 + 7 + 4;
const N_F64_V2: usize = N_F64_V1 + 15 + 1;
const N_F64: usize = N_F64_V2 + 45 + 3 + 1;
/// Encoded size in bytes.
pub const ENCODED_LEN: usize = 8 + 8 + 8 + 4 + 4 + 4 + 4 + N_F64 * 8 + 4;
/// Encoded size of a `PNCKPT02` file.
pub const ENCODED_LEN_V2: usize = ENCODED_LEN - (N_F64 - N_F64_V2) * 8;
/// Encoded size of a `PNCKPT01` file.
pub const ENCODED_LEN_V1: usize = ENCODED_LEN - (N_F64 - N_F64_V1) * 8;

/// The navigator state a checkpoint carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checkpoint {
    /// Sensor time of the state (ns).
    pub t_ns: u64,
    /// Solution sequence number at that time.
    pub seq: u64,
    pub switch_count: u32,
    pub reset_count: u32,
    /// Navigation frame of the state and covariance (0 g, 1 G: `WireFrame`).
    pub frame: u8,
    /// Frame-free nominal state: ECEF position, ECEF velocity, body→ECEF quaternion.
    pub r_e_m: [f64; 3],
    pub v_e_mps: [f64; 3],
    pub q_b_e: [f64; 4],
    /// Error covariance in `frame`, row-major 15 × 15.
    pub p: [f64; 225],
    pub gyro_bias_rps: [f64; 3],
    pub accel_bias_mps2: [f64; 3],
    /// The last IMU increment (Δθ, Δv, dt); dt = 0 when there was none.
    pub prev_inc: [f64; 7],
    /// Interval accumulated since the last covariance propagation: time (s)
    /// and body Δv (m/s).
    pub pending_cov: [f64; 4],
    /// The magnetometer's persistent error b as a consider parameter:
    /// cov(δx, b) in `frame` and b's variance (rad²); zero when the
    /// navigator carries none (and in a `PNCKPT01` file).
    pub consider: [f64; 15],
    pub consider_var: f64,
    /// The GNSS receiver's correlated position error b as three consider
    /// parameters: cov(δx, b) in `frame` (row-major 15 × 3), b's
    /// variances per axis (m²) and its correlation time (s); all zero when
    /// the navigator carries none (and in older files).
    pub gnss_consider: [f64; 45],
    pub gnss_consider_var: [f64; 3],
    pub gnss_consider_tau_s: f64,
}

/// Why a checkpoint could not be read.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a polarnav checkpoint ({detail})")]
    Format { path: String, detail: String },
    /// Intact (magic and CRC check) but physically implausible: resuming
    /// from it would poison the filter. `detail` names the offending field
    /// and its value; `path` is the file for [`Checkpoint::load`] and
    /// `"checkpoint"` for [`Checkpoint::validate`].
    #[error("{path}: implausible checkpoint content: {detail}")]
    Content { path: String, detail: String },
}

/// Bounds of [`Checkpoint::validate`].
pub mod bounds {
    /// Range of |r_e_m| (m): 23 km below the polar radius to 100 km above
    /// the equatorial one, as for an init record.
    pub const R_E_M: (f64, f64) = (6_355_000.0, 6_478_137.0);
    /// Largest Earth-relative speed (m/s).
    pub const MAX_SPEED_MPS: f64 = 1000.0;
    /// Largest departure of |q_b_e| from 1 (the quaternion is written normalized).
    pub const QUAT_NORM_TOL: f64 = 1e-6;
    /// Largest variance of any error state (m², rad², (m/s)², …).
    pub const MAX_VARIANCE: f64 = 1e14;
    /// Relative symmetry tolerance of P: |p_ij − p_ji| ≤ tol·√(p_ii p_jj).
    pub const SYMMETRY_REL_TOL: f64 = 1e-9;
    /// Largest gyro bias per axis (rad/s).
    pub const MAX_GYRO_BIAS_RPS: f64 = 0.1;
    /// Largest accelerometer bias per axis (m/s²).
    pub const MAX_ACCEL_BIAS_MPS2: f64 = 10.0;
    /// Largest interval of the stored previous IMU increment (s).
    pub const MAX_PREV_INC_DT_S: f64 = 1.0;
    /// Largest time accumulated since the last covariance propagation (s).
    pub const MAX_PENDING_COV_S: f64 = 10.0;
}

impl Checkpoint {
    /// Encodes into `out`.
    pub fn encode(&self, out: &mut [u8; ENCODED_LEN]) {
        let mut w = 0;
        let mut put = |b: &[u8]| {
            out[w..w + b.len()].copy_from_slice(b);
            w += b.len();
        };
        put(MAGIC);
        put(&self.t_ns.to_le_bytes());
        put(&self.seq.to_le_bytes());
        put(&self.switch_count.to_le_bytes());
        put(&self.reset_count.to_le_bytes());
        put(&u32::from(self.frame).to_le_bytes());
        put(&0u32.to_le_bytes());
        for x in self
            .r_e_m
            .iter()
            .chain(&self.v_e_mps)
            .chain(&self.q_b_e)
            .chain(&self.p)
            .chain(&self.gyro_bias_rps)
            .chain(&self.accel_bias_mps2)
            .chain(&self.prev_inc)
            .chain(&self.pending_cov)
            .chain(&self.consider)
            .chain(std::iter::once(&self.consider_var))
            .chain(&self.gnss_consider)
            .chain(&self.gnss_consider_var)
            .chain(std::iter::once(&self.gnss_consider_tau_s))
        {
            put(&x.to_le_bytes());
        }
        let crc = crc32fast::hash(&out[..ENCODED_LEN - 4]);
        out[ENCODED_LEN - 4..].copy_from_slice(&crc.to_le_bytes());
    }

    /// Decodes and checks magic, length, CRC and finiteness; `path` names the source in errors.
    pub fn decode(bytes: &[u8], path: &str) -> Result<Self, CheckpointError> {
        let bad = |detail: String| CheckpointError::Format {
            path: path.to_owned(),
            detail,
        };
        let (len, n_f64) = match bytes.get(..8) {
            Some(m) if m == MAGIC => (ENCODED_LEN, N_F64),
            Some(m) if m == MAGIC_V2 => (ENCODED_LEN_V2, N_F64_V2),
            Some(m) if m == MAGIC_V1 => (ENCODED_LEN_V1, N_F64_V1),
            _ => return Err(bad("wrong magic or version".into())),
        };
        if bytes.len() != len {
            return Err(bad(format!("{} bytes, expected {len}", bytes.len())));
        }
        let stored = u32::from_le_bytes(bytes[len - 4..].try_into().expect("4 bytes"));
        if crc32fast::hash(&bytes[..len - 4]) != stored {
            return Err(bad("checksum mismatch".into()));
        }
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        // An older file's missing consider parameters read as zero.
        let mut f = [0.0; N_F64];
        for (k, x) in f.iter_mut().take(n_f64).enumerate() {
            *x = f64::from_bits(u64_at(40 + 8 * k));
        }
        if f.iter().any(|x| !x.is_finite()) {
            return Err(bad("non-finite value".into()));
        }
        let frame = u32_at(32);
        if frame > 1 {
            return Err(bad(format!("unknown frame {frame}")));
        }
        let mut c = Checkpoint {
            t_ns: u64_at(8),
            seq: u64_at(16),
            switch_count: u32_at(24),
            reset_count: u32_at(28),
            frame: frame as u8,
            r_e_m: [0.0; 3],
            v_e_mps: [0.0; 3],
            q_b_e: [0.0; 4],
            p: [0.0; 225],
            gyro_bias_rps: [0.0; 3],
            accel_bias_mps2: [0.0; 3],
            prev_inc: [0.0; 7],
            pending_cov: [0.0; 4],
            consider: [0.0; 15],
            consider_var: 0.0,
            gnss_consider: [0.0; 45],
            gnss_consider_var: [0.0; 3],
            gnss_consider_tau_s: 0.0,
        };
        let mut rest = &f[..];
        for dst in [
            &mut c.r_e_m[..],
            &mut c.v_e_mps[..],
            &mut c.q_b_e[..],
            &mut c.p[..],
            &mut c.gyro_bias_rps[..],
            &mut c.accel_bias_mps2[..],
            &mut c.prev_inc[..],
            &mut c.pending_cov[..],
            &mut c.consider[..],
            std::slice::from_mut(&mut c.consider_var),
            &mut c.gnss_consider[..],
            &mut c.gnss_consider_var[..],
            std::slice::from_mut(&mut c.gnss_consider_tau_s),
        ] {
            let (head, tail) = rest.split_at(dst.len());
            dst.copy_from_slice(head);
            rest = tail;
        }
        Ok(c)
    }

    /// Checks that the content is physically plausible, so that a resumed
    /// navigator cannot start from NaN or absurd values (see [`bounds`]):
    /// every value finite; |r_e_m| in [`bounds::R_E_M`]; speed, quaternion
    /// norm, frame tag, biases, `prev_inc` dt and `pending_cov` time within
    /// bounds; P with variances in (0, [`bounds::MAX_VARIANCE`]], symmetric
    /// and positive definite (Cholesky of its correlation matrix).
    pub fn validate(&self) -> Result<(), CheckpointError> {
        use bounds::*;
        let bad = |detail: String| {
            Err(CheckpointError::Content {
                path: "checkpoint".into(),
                detail,
            })
        };
        let fields: [(&str, &[f64]); 13] = [
            ("consider", &self.consider),
            ("consider_var", std::slice::from_ref(&self.consider_var)),
            ("gnss_consider", &self.gnss_consider),
            ("gnss_consider_var", &self.gnss_consider_var),
            (
                "gnss_consider_tau_s",
                std::slice::from_ref(&self.gnss_consider_tau_s),
            ),
            ("r_e_m", &self.r_e_m),
            ("v_e_mps", &self.v_e_mps),
            ("q_b_e", &self.q_b_e),
            ("p", &self.p),
            ("gyro_bias_rps", &self.gyro_bias_rps),
            ("accel_bias_mps2", &self.accel_bias_mps2),
            ("prev_inc", &self.prev_inc),
            ("pending_cov", &self.pending_cov),
        ];
        for (name, xs) in fields {
            if let Some((k, x)) = xs.iter().enumerate().find(|(_, x)| !x.is_finite()) {
                return bad(format!("{name}[{k}] = {x} is not finite"));
            }
        }
        let norm = |xs: &[f64]| xs.iter().map(|x| x * x).sum::<f64>().sqrt();
        let r = norm(&self.r_e_m);
        if !(R_E_M.0..=R_E_M.1).contains(&r) {
            return bad(format!(
                "|r_e_m| = {r} m outside [{}, {}] m",
                R_E_M.0, R_E_M.1
            ));
        }
        let v = norm(&self.v_e_mps);
        if v > MAX_SPEED_MPS {
            return bad(format!("|v_e_mps| = {v} m/s exceeds {MAX_SPEED_MPS} m/s"));
        }
        let q = norm(&self.q_b_e);
        if (q - 1.0).abs() > QUAT_NORM_TOL {
            return bad(format!("|q_b_e| = {q}, not within {QUAT_NORM_TOL:e} of 1"));
        }
        if self.frame > 1 {
            return bad(format!(
                "frame = {}, expected 0 (geographic) or 1 (grid)",
                self.frame
            ));
        }
        for (name, xs, limit, unit) in [
            (
                "gyro_bias_rps",
                &self.gyro_bias_rps,
                MAX_GYRO_BIAS_RPS,
                "rad/s",
            ),
            (
                "accel_bias_mps2",
                &self.accel_bias_mps2,
                MAX_ACCEL_BIAS_MPS2,
                "m/s²",
            ),
        ] {
            if let Some((k, x)) = xs.iter().enumerate().find(|(_, x)| x.abs() > limit) {
                return bad(format!("{name}[{k}] = {x} {unit} exceeds ±{limit} {unit}"));
            }
        }
        let dt = self.prev_inc[6];
        if !(0.0..=MAX_PREV_INC_DT_S).contains(&dt) {
            return bad(format!(
                "prev_inc[6] (dt) = {dt} s outside [0, {MAX_PREV_INC_DT_S}] s"
            ));
        }
        let t = self.pending_cov[0];
        if !(0.0..=MAX_PENDING_COV_S).contains(&t) {
            return bad(format!(
                "pending_cov[0] (time) = {t} s outside [0, {MAX_PENDING_COV_S}] s"
            ));
        }
        self.validate_covariance()
            .and_then(|()| self.validate_consider())
            .and_then(|()| self.validate_gnss_consider())
            .or_else(bad)
    }

    /// The consider parameter: b's variance in [0, [`bounds::MAX_VARIANCE`]];
    /// with it zero, no covariance; otherwise the augmented covariance
    /// [[P, c], [cᵀ, a]] positive semi-definite (a ≥ cᵀ P⁻¹ c, to 1e-9 of
    /// a). Called after P is known positive definite.
    fn validate_consider(&self) -> Result<(), String> {
        use bounds::MAX_VARIANCE;
        let a = self.consider_var;
        if !(0.0..=MAX_VARIANCE).contains(&a) {
            return Err(format!(
                "consider_var = {a} is not a variance in [0, {MAX_VARIANCE:e}]"
            ));
        }
        if a == 0.0 {
            return match self.consider.iter().enumerate().find(|(_, x)| **x != 0.0) {
                Some((k, x)) => Err(format!(
                    "consider[{k}] = {x} with consider_var 0 (a covariance with nothing)"
                )),
                None => Ok(()),
            };
        }
        let p = nalgebra::SMatrix::<f64, 15, 15>::from_row_slice(&self.p);
        let c = nalgebra::SVector::<f64, 15>::from(self.consider);
        let explained = p
            .cholesky()
            .map(|l| c.dot(&l.solve(&c)))
            .unwrap_or(f64::INFINITY);
        if explained.is_finite() && explained <= a * (1.0 + 1e-9) {
            Ok(())
        } else {
            Err(format!(
                "consider is not consistent with p: cᵀ P⁻¹ c = {explained:e} exceeds consider_var = {a:e}"
            ))
        }
    }

    /// The GNSS receiver's parameters: b's variances in
    /// [0, [`bounds::MAX_VARIANCE`]], the two horizontal ones equal (a
    /// frame switch turns b about up); with them zero, no covariance and no
    /// correlation time; otherwise a correlation time in
    /// [1, [`crate::bounds::MAX_FLIGHT_S`]] s and the covariance augmented
    /// with both parameter blocks, [[P, c, C], [cᵀ, a, 0], [Cᵀ, 0, B]],
    /// positive semi-definite (the eigenvalues of diag(a, B) − Xᵀ P⁻¹ X,
    /// X = [c C], not below −1e-9 of the largest variance): the two blocks
    /// each consistent with P can still not be jointly. Called after P is
    /// known positive definite and the magnetometer's block checked.
    fn validate_gnss_consider(&self) -> Result<(), String> {
        use bounds::MAX_VARIANCE;
        use nalgebra::{Matrix4, SMatrix, Vector4};
        let b = self.gnss_consider_var;
        if let Some((k, v)) = b
            .iter()
            .enumerate()
            .find(|(_, v)| !(0.0..=MAX_VARIANCE).contains(*v))
        {
            return Err(format!(
                "gnss_consider_var[{k}] = {v} is not a variance in [0, {MAX_VARIANCE:e}]"
            ));
        }
        // Exactly equal: the navigator writes one value to both.
        if b[0].to_bits() != b[1].to_bits() {
            return Err(format!(
                "gnss_consider_var[0] = {} and gnss_consider_var[1] = {} differ (the horizontal \
                 variances must be equal)",
                b[0], b[1]
            ));
        }
        if b.iter().all(|v| *v == 0.0) {
            if let Some((k, x)) = self
                .gnss_consider
                .iter()
                .enumerate()
                .find(|(_, x)| **x != 0.0)
            {
                return Err(format!(
                    "gnss_consider[{k}] = {x} with gnss_consider_var 0 (a covariance with nothing)"
                ));
            }
            return Ok(());
        }
        let tau = self.gnss_consider_tau_s;
        let max_tau = crate::bounds::MAX_FLIGHT_S;
        if !(1.0..=max_tau).contains(&tau) {
            return Err(format!(
                "gnss_consider_tau_s = {tau} s outside [1, {max_tau:e}] s"
            ));
        }
        let p = SMatrix::<f64, 15, 15>::from_row_slice(&self.p);
        let mut x = SMatrix::<f64, 15, 4>::zeros();
        x.column_mut(0).copy_from_slice(&self.consider);
        x.fixed_view_mut::<15, 3>(0, 1)
            .copy_from(&SMatrix::<f64, 15, 3>::from_row_slice(&self.gnss_consider));
        let a = Matrix4::from_diagonal(&Vector4::new(self.consider_var, b[0], b[1], b[2]));
        let left = p.cholesky().map(|l| a - x.transpose() * l.solve(&x));
        let largest = b.iter().copied().fold(self.consider_var, f64::max);
        let smallest = left
            .map(|m| m.symmetric_eigenvalues().min())
            .unwrap_or(f64::NEG_INFINITY);
        if smallest.is_finite() && smallest >= -1e-9 * largest {
            Ok(())
        } else {
            Err(format!(
                "gnss_consider is not consistent with p and consider: diag(a, B) − Xᵀ P⁻¹ X has the eigenvalue {smallest:e}"
            ))
        }
    }

    /// The covariance part of [`Self::validate`]; `Err` carries the detail.
    fn validate_covariance(&self) -> Result<(), String> {
        use bounds::{MAX_VARIANCE, SYMMETRY_REL_TOL};
        const N: usize = 15;
        let p = |i: usize, j: usize| self.p[N * i + j];
        // Standard deviations: the checks below are scale-free, so states in
        // rad² and in m² are treated alike.
        let mut s = [0.0; N];
        for (i, si) in s.iter_mut().enumerate() {
            let d = p(i, i);
            if !(d > 0.0 && d <= MAX_VARIANCE) {
                return Err(format!(
                    "p[{i},{i}] = {d} is not a variance in (0, {MAX_VARIANCE:e}]"
                ));
            }
            *si = d.sqrt();
        }
        // Correlation matrix, lower triangle, checked for symmetry on the way.
        let mut c = [[0.0; N]; N];
        for i in 0..N {
            for j in 0..i {
                let (a, b) = (p(i, j), p(j, i));
                let tol = SYMMETRY_REL_TOL * s[i] * s[j] + f64::MIN_POSITIVE;
                if (a - b).abs() > tol {
                    return Err(format!(
                        "p[{i},{j}] = {a} and p[{j},{i}] = {b} differ by more than {tol:e} (not symmetric)"
                    ));
                }
                c[i][j] = 0.5 * (a + b) / s[i] / s[j];
            }
            c[i][i] = 1.0;
        }
        // Cholesky c = L Lᵀ in place (L in the lower triangle): every pivot
        // must be positive.
        for j in 0..N {
            let pivot = c[j][j] - c[j][..j].iter().map(|x| x * x).sum::<f64>();
            if pivot.is_nan() || pivot <= 0.0 {
                return Err(format!(
                    "p is not positive definite (Cholesky pivot {j} of its correlation matrix = {pivot:e})"
                ));
            }
            let l = pivot.sqrt();
            c[j][j] = l;
            for i in j + 1..N {
                let dot: f64 = c[i][..j].iter().zip(&c[j][..j]).map(|(a, b)| a * b).sum();
                c[i][j] = (c[i][j] - dot) / l;
            }
        }
        Ok(())
    }

    /// Reads a checkpoint file and checks it ([`Self::decode`], then
    /// [`Self::validate`]); `Ok(None)` if there is none.
    pub fn load(path: &Path) -> Result<Option<Self>, CheckpointError> {
        let p = path.display().to_string();
        match std::fs::read(path) {
            Ok(bytes) => {
                let c = Self::decode(&bytes, &p)?;
                c.validate().map_err(|e| match e {
                    CheckpointError::Content { detail, .. } => {
                        CheckpointError::Content { path: p, detail }
                    }
                    other => other,
                })?;
                Ok(Some(c))
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(source) => Err(CheckpointError::Io { path: p, source }),
        }
    }
}

/// Replaces `path` with `bytes` atomically: temporary file, fsync, rename, directory fsync.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = dir.join(name);
    {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)?;
    std::fs::File::open(dir)?.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A realistic checkpoint: 80° N 30° E at 18 km, 250 m/s, grid frame,
    /// a unit quaternion near identity, P with realistic variances and
    /// position–velocity and velocity–tilt correlations.
    fn sample() -> Checkpoint {
        use crate::earth::{Geodetic, geodetic_to_ecef};
        use crate::error_model::idx;
        let r = geodetic_to_ecef(&Geodetic::from_deg(80.0, 30.0, 18_000.0));
        let q = [0.99, 0.01, -0.02, 0.1];
        let qn = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut sd = [0.0; 15];
        sd[idx::PHI..idx::PHI + 3].copy_from_slice(&[1e-3, 1e-3, 5e-3]);
        sd[idx::DV..idx::DV + 3].copy_from_slice(&[0.1, 0.1, 0.05]);
        sd[idx::DP..idx::DP + 3].copy_from_slice(&[30.0, 30.0, 15.0]);
        sd[idx::BG..idx::BG + 3].fill(4.8e-6); // 1 °/h
        sd[idx::BA..idx::BA + 3].fill(1e-3); // 100 µg
        let mut p = [0.0; 225];
        let mut set = |i: usize, j: usize, rho: f64| {
            p[15 * i + j] = rho * sd[i] * sd[j];
            p[15 * j + i] = rho * sd[i] * sd[j];
        };
        for i in 0..15 {
            set(i, i, 1.0);
        }
        for i in 0..3 {
            set(idx::DP + i, idx::DV + i, 0.6);
            set(idx::PHI + i, idx::DV + i, -0.3);
        }
        Checkpoint {
            t_ns: 123_456_789_012,
            seq: 42,
            switch_count: 3,
            reset_count: 1,
            frame: 1,
            r_e_m: r.into(),
            v_e_mps: [-120.0, 35.0, 218.0],
            q_b_e: q.map(|x| x / qn),
            p,
            gyro_bias_rps: [1e-6, -2e-6, 3e-7],
            accel_bias_mps2: [1e-4, 2e-4, -3e-4],
            prev_inc: [1e-5, 2e-5, 3e-5, 0.01, 0.02, 0.049, 0.005],
            pending_cov: [0.045, 0.001, 0.002, 0.44],
            // The heading error 80 % explained by a magnetometer error of
            // 4 mrad (σ).
            consider: {
                let mut c = [0.0; 15];
                c[idx::PHI + 2] = -0.8 * sd[idx::PHI + 2] * 4e-3;
                c
            },
            consider_var: 16e-6,
            // The east position error 70 % explained by a receiver error
            // of 1.5 m (σ) horizontally, 3 m vertically.
            gnss_consider: {
                let mut c = [0.0; 45];
                c[3 * idx::DP] = 0.7 * sd[idx::DP] * 1.5;
                c[3 * (idx::DP + 2) + 2] = 0.5 * sd[idx::DP + 2] * 3.0;
                c
            },
            gnss_consider_var: [2.25, 2.25, 9.0],
            gnss_consider_tau_s: 300.0,
        }
    }

    #[test]
    fn a_realistic_checkpoint_validates() {
        sample().validate().expect("realistic checkpoint");
        let mut c = sample();
        c.frame = 0;
        c.prev_inc = [0.0; 7];
        c.pending_cov = [0.0; 4];
        c.validate()
            .expect("geographic, no increment, nothing pending");
    }

    /// A genuine checkpoint of a running navigator validates (so that
    /// the check cannot turn every restart into a cold start).
    #[test]
    fn a_running_navigators_checkpoint_validates() {
        use crate::earth::{Geodetic, OMEGA_IE, geodetic_to_ecef, normal_gravity, up_e};
        use crate::navigator::{Navigator, NavigatorConfig};
        let (lat, lon, h) = (80f64.to_radians(), 30f64.to_radians(), 18_000.0);
        let r = geodetic_to_ecef(&Geodetic::new(lat, lon, h));
        let init = msgs::InitState {
            t_ns: 1_000_000_000,
            r_e_m: r.into(),
            v_e_mps: [0.0; 3],
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            sigma_pos_h_m: 10.0,
            sigma_pos_v_m: 5.0,
            sigma_vel_h_mps: 0.1,
            sigma_vel_v_mps: 0.1,
            sigma_tilt_rad: 1e-3,
            sigma_heading_rad: 1e-2,
            ..Default::default()
        };
        let mut nav = Navigator::new(&init, &NavigatorConfig::default());
        nav.checkpoint().validate().expect("checkpoint at init");
        // Body axes = ECEF axes, at rest on the rotating Earth: the IMU
        // senses the Earth rate and (approximately) minus gravity.
        let dt = 0.01;
        let f = up_e(lat, lon) * normal_gravity(lat, h);
        for k in 1..=1000u64 {
            let s = msgs::ImuSample {
                t_ns: init.t_ns + k * 10_000_000,
                seq: k,
                dt_s: dt,
                d_theta_rad: [0.0, 0.0, OMEGA_IE * dt],
                d_v_mps: (f * dt).into(),
            };
            nav.on_imu(&s).expect("imu sample");
        }
        nav.checkpoint().validate().expect("checkpoint after 10 s");
    }

    #[test]
    fn each_implausible_field_is_refused_and_named() {
        use crate::error_model::idx;
        type Defect = (&'static str, fn(&mut Checkpoint));
        let defects: &[Defect] = &[
            ("q_b_e", |c| c.q_b_e = [0.0; 4]),
            ("q_b_e", |c| c.q_b_e = [1.0 + 1e-5, 0.0, 0.0, 0.0]),
            ("q_b_e[2]", |c| c.q_b_e[2] = f64::NAN),
            ("p[0,0]", |c| c.p[0] = -1e-6),
            ("p[48]", |c| c.p[48] = f64::NAN),
            ("p[16]", |c| c.p[16] = f64::INFINITY),
            ("p[7,7]", |c| c.p[7 * 16] = 0.0),
            ("p[14,14]", |c| c.p[14 * 16] = 1e15),
            ("p[1,0]", |c| c.p[1] = 1e-9),
            ("p is not positive definite", |c| {
                // Symmetric, but a correlation beyond 1.
                let (i, j) = (idx::DP, idx::DV);
                let v = 1.5 * (c.p[16 * i] * c.p[16 * j]).sqrt();
                c.p[15 * i + j] = v;
                c.p[15 * j + i] = v;
            }),
            ("p is not positive definite", |c| {
                // Pairwise correlations of 0.9 that no covariance can have.
                let b = idx::BG;
                for (i, j, rho) in [(b, b + 1, 0.9), (b, b + 2, 0.9), (b + 1, b + 2, -0.9)] {
                    let v = rho * (c.p[16 * i] * c.p[16 * j]).sqrt();
                    c.p[15 * i + j] = v;
                    c.p[15 * j + i] = v;
                }
            }),
            ("r_e_m[0]", |c| c.r_e_m[0] = f64::INFINITY),
            ("|r_e_m|", |c| c.r_e_m = c.r_e_m.map(|x| 2.0 * x)),
            ("|r_e_m|", |c| c.r_e_m = [0.0; 3]),
            ("|r_e_m|", |c| c.r_e_m = [0.0, 0.0, 6_300_000.0]),
            ("v_e_mps[1]", |c| c.v_e_mps[1] = f64::NAN),
            ("|v_e_mps|", |c| c.v_e_mps = [800.0, 0.0, 800.0]),
            ("gyro_bias_rps[1]", |c| c.gyro_bias_rps[1] = -0.2),
            ("accel_bias_mps2[2]", |c| c.accel_bias_mps2[2] = 20.0),
            ("accel_bias_mps2[0]", |c| {
                c.accel_bias_mps2[0] = f64::NEG_INFINITY
            }),
            ("frame = 2", |c| c.frame = 2),
            ("frame = 255", |c| c.frame = 255),
            ("prev_inc[6]", |c| c.prev_inc[6] = -0.005),
            ("prev_inc[6]", |c| c.prev_inc[6] = f64::NAN),
            ("prev_inc[6]", |c| c.prev_inc[6] = 3600.0),
            ("prev_inc[3]", |c| c.prev_inc[3] = f64::INFINITY),
            ("pending_cov[0]", |c| c.pending_cov[0] = -1e-3),
            ("pending_cov[0]", |c| c.pending_cov[0] = f64::NAN),
            ("pending_cov[0]", |c| c.pending_cov[0] = 1e6),
            ("pending_cov[2]", |c| c.pending_cov[2] = f64::NAN),
            ("consider[3]", |c| c.consider[3] = f64::NAN),
            ("consider_var", |c| c.consider_var = f64::INFINITY),
            ("consider_var", |c| c.consider_var = -1e-6),
            ("consider_var", |c| c.consider_var = 1e15),
            ("consider[8] = 0.5 with consider_var 0", |c| {
                c.consider = [0.0; 15];
                c.consider[8] = 0.5;
                c.consider_var = 0.0;
            }),
            ("consider is not consistent with p", |c| {
                // A correlation of 1.5 between the heading error and b.
                c.consider[idx::PHI + 2] =
                    -1.5 * (c.p[16 * (idx::PHI + 2)] * c.consider_var).sqrt();
            }),
            ("gnss_consider[4]", |c| c.gnss_consider[4] = f64::INFINITY),
            ("gnss_consider_var[2]", |c| c.gnss_consider_var[2] = -1.0),
            ("gnss_consider_var[0]", |c| c.gnss_consider_var[0] = 1e300),
            ("gnss_consider_tau_s", |c| c.gnss_consider_tau_s = f64::NAN),
            ("gnss_consider_tau_s = 0", |c| c.gnss_consider_tau_s = 0.0),
            ("gnss_consider_tau_s = 1000000000000000000 s", |c| {
                c.gnss_consider_tau_s = 1e18
            }),
            ("gnss_consider[0] = 1 with gnss_consider_var 0", |c| {
                c.gnss_consider = [0.0; 45];
                c.gnss_consider[0] = 1.0;
                c.gnss_consider_var = [0.0; 3];
            }),
            (
                "gnss_consider_var[0] = 2.25 and gnss_consider_var[1] = 3",
                |c| c.gnss_consider_var[1] = 3.0,
            ),
            ("gnss_consider is not consistent with p and consider", |c| {
                // Each block alone consistent with P, not the two together:
                // both explain most of the same heading error.
                let k = 16 * (idx::PHI + 2);
                c.consider[idx::PHI + 2] = -0.8 * (c.p[k] * c.consider_var).sqrt();
                c.gnss_consider = [0.0; 45];
                c.gnss_consider[3 * (idx::PHI + 2)] = 0.8 * (c.p[k] * 2.25).sqrt();
            }),
            ("gnss_consider is not consistent with p", |c| {
                // A correlation of 1.2 between the east error and b's east.
                c.gnss_consider[3 * idx::DP] = 1.2 * (c.p[16 * idx::DP] * 2.25).sqrt();
            }),
        ];
        for (k, (field, defect)) in defects.iter().enumerate() {
            let mut c = sample();
            defect(&mut c);
            let err = c
                .validate()
                .expect_err(&format!("defect {k} ({field}) accepted"));
            assert!(
                matches!(err, CheckpointError::Content { .. }),
                "defect {k}: {err:?}"
            );
            let msg = err.to_string();
            assert!(
                msg.contains(field),
                "defect {k}: {msg:?} does not name {field:?}"
            );
        }
    }

    #[test]
    fn load_refuses_an_intact_file_with_implausible_content() {
        let t = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let path = std::env::temp_dir().join(format!(
            "polarnav-ckpt-content-{}-{t}.ckpt",
            std::process::id()
        ));
        let mut buf = [0u8; ENCODED_LEN];
        for (field, defect) in [
            ("q_b_e", (|c| c.q_b_e = [0.0; 4]) as fn(&mut Checkpoint)),
            ("p[3,3]", |c| c.p[3 * 16] = -0.01),
            ("prev_inc[6]", |c| c.prev_inc[6] = -1.0),
        ] {
            let mut c = sample();
            defect(&mut c);
            c.encode(&mut buf);
            assert_eq!(Checkpoint::decode(&buf, "mem").expect("intact"), c);
            write_atomic(&path, &buf).expect("write");
            let err = Checkpoint::load(&path).expect_err("implausible content");
            let msg = err.to_string();
            assert!(matches!(err, CheckpointError::Content { .. }), "{msg}");
            assert!(msg.contains(field), "{msg}");
            assert!(msg.contains(&path.display().to_string()), "{msg}");
        }
        sample().encode(&mut buf);
        write_atomic(&path, &buf).expect("write");
        assert_eq!(Checkpoint::load(&path).expect("load"), Some(sample()));
        let _ = std::fs::remove_file(&path);
    }

    /// `c` written in an older format: `magic`, the header and the first
    /// `n_f64` numbers of the current encoding, its own CRC (`c` must have
    /// zero in the fields that format lacks).
    fn older_format(c: &Checkpoint, magic: &[u8; 8], n_f64: usize) -> Vec<u8> {
        let mut cur = [0u8; ENCODED_LEN];
        c.encode(&mut cur);
        let mut old = magic.to_vec();
        old.extend_from_slice(&cur[8..40 + 8 * n_f64]);
        let crc = crc32fast::hash(&old);
        old.extend_from_slice(&crc.to_le_bytes());
        old
    }

    /// A `PNCKPT01` file (written here field by field in the first
    /// format: no consider parameter, its magic) reads with every field
    /// and the parameter zero, and validates; its truncations and a flipped
    /// bit are refused like the current format's.
    #[test]
    fn a_first_format_checkpoint_reads_with_no_consider_parameter() {
        let mut c = sample();
        c.consider = [0.0; 15];
        c.consider_var = 0.0;
        c.gnss_consider = [0.0; 45];
        c.gnss_consider_var = [0.0; 3];
        c.gnss_consider_tau_s = 0.0;
        let mut cur = [0u8; ENCODED_LEN];
        c.encode(&mut cur);
        let old = older_format(&c, MAGIC_V1, N_F64_V1);
        assert_eq!(old.len(), ENCODED_LEN_V1);
        let back = Checkpoint::decode(&old, "v1").expect("a PNCKPT01 file");
        assert_eq!(back, c);
        back.validate().expect("valid");
        for len in 0..ENCODED_LEN_V1 {
            assert!(
                Checkpoint::decode(&old[..len], "v1").is_err(),
                "{len} bytes"
            );
        }
        let mut flipped = old.clone();
        flipped[100] ^= 4;
        assert!(Checkpoint::decode(&flipped, "v1").is_err());
        // The current magic on the old length, and the old on the new.
        let mut wrong = old.clone();
        wrong[..8].copy_from_slice(MAGIC);
        assert!(Checkpoint::decode(&wrong, "v1").is_err());
        let mut wrong = cur.to_vec();
        wrong[..8].copy_from_slice(MAGIC_V1);
        assert!(Checkpoint::decode(&wrong, "v2").is_err());
    }

    /// A `PNCKPT02` file (the magnetometer's parameter, not the
    /// receiver's) reads with every field and the receiver's parameters
    /// zero, and validates; truncated, or with the other formats' magic,
    /// it is refused.
    #[test]
    fn a_second_format_checkpoint_reads_with_no_gnss_consider_parameters() {
        let mut c = sample();
        c.gnss_consider = [0.0; 45];
        c.gnss_consider_var = [0.0; 3];
        c.gnss_consider_tau_s = 0.0;
        let old = older_format(&c, MAGIC_V2, N_F64_V2);
        assert_eq!(old.len(), ENCODED_LEN_V2);
        let back = Checkpoint::decode(&old, "v2").expect("a PNCKPT02 file");
        assert_eq!(back, c);
        back.validate().expect("valid");
        for len in 0..ENCODED_LEN_V2 {
            assert!(
                Checkpoint::decode(&old[..len], "v2").is_err(),
                "{len} bytes"
            );
        }
        for magic in [MAGIC, MAGIC_V1] {
            let mut wrong = old.clone();
            wrong[..8].copy_from_slice(magic);
            assert!(Checkpoint::decode(&wrong, "v2").is_err());
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let c = sample();
        let mut buf = [0u8; ENCODED_LEN];
        c.encode(&mut buf);
        assert_eq!(Checkpoint::decode(&buf, "mem").expect("decode"), c);
    }

    #[test]
    fn every_flipped_bit_and_every_truncation_is_detected() {
        let mut buf = [0u8; ENCODED_LEN];
        sample().encode(&mut buf);
        for byte in 0..ENCODED_LEN {
            for bit in [0, 3, 7] {
                let mut b = buf;
                b[byte] ^= 1 << bit;
                assert!(
                    Checkpoint::decode(&b, "mem").is_err(),
                    "flip at byte {byte} bit {bit} not detected"
                );
            }
        }
        for len in 0..ENCODED_LEN {
            assert!(Checkpoint::decode(&buf[..len], "mem").is_err());
        }
    }

    #[test]
    fn atomic_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("polarnav-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("nav.ckpt");
        assert!(Checkpoint::load(&path).expect("absent is fine").is_none());
        let mut c = sample();
        let mut buf = [0u8; ENCODED_LEN];
        for k in 0..3 {
            c.seq = k;
            c.encode(&mut buf);
            write_atomic(&path, &buf).expect("write");
            assert_eq!(Checkpoint::load(&path).expect("load"), Some(c));
        }
        let names: Vec<_> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("nav.ckpt")]);
        std::fs::write(&path, b"garbage").expect("write");
        let err = Checkpoint::load(&path).expect_err("garbage");
        assert!(err.to_string().contains("nav.ckpt"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
