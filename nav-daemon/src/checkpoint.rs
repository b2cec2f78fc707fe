//! Checkpoints of the navigator: the nominal state, error covariance and
//! biases, so that a restarted daemon resumes instead of starting cold.
//!
//! Format (little-endian, fixed length [`ENCODED_LEN`]): magic
//! `PNCKPT01`, the fields of [`Checkpoint`] in declaration order, CRC-32 of
//! everything before it. Files are replaced atomically: written to a
//! temporary file beside the target, fsynced, renamed over it, and the
//! directory fsynced, so a crash leaves either the old or the new checkpoint.

use std::io::Write;
use std::path::Path;

/// Magic and format version.
pub const MAGIC: &[u8; 8] = b"PNCKPT01";

const N_F64: usize = 3 + 3 + 4 + 225 + 3 + 3 + 7 + 4;
/// Encoded size in bytes.
pub const ENCODED_LEN: usize = 8 + 8 + 8 + 4 + 4 + 4 + 4 + N_F64 * 8 + 4;

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
        if bytes.len() != ENCODED_LEN {
            return Err(bad(format!(
                "{} bytes, expected {ENCODED_LEN}",
                bytes.len()
            )));
        }
        if &bytes[..8] != MAGIC {
            return Err(bad("wrong magic or version".into()));
        }
        let stored = u32::from_le_bytes(bytes[ENCODED_LEN - 4..].try_into().expect("4 bytes"));
        if crc32fast::hash(&bytes[..ENCODED_LEN - 4]) != stored {
            return Err(bad("checksum mismatch".into()));
        }
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let mut f = [0.0; N_F64];
        for (k, x) in f.iter_mut().enumerate() {
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
        ] {
            let (head, tail) = rest.split_at(dst.len());
            dst.copy_from_slice(head);
            rest = tail;
        }
        Ok(c)
    }

    /// Reads a checkpoint file; `Ok(None)` if there is none.
    pub fn load(path: &Path) -> Result<Option<Self>, CheckpointError> {
        let p = path.display().to_string();
        match std::fs::read(path) {
            Ok(bytes) => Self::decode(&bytes, &p).map(Some),
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

    fn sample() -> Checkpoint {
        let mut p = [0.0; 225];
        for (k, x) in p.iter_mut().enumerate() {
            *x = (k as f64 * 0.37).sin() * 1e-3;
        }
        Checkpoint {
            t_ns: 123_456_789_012,
            seq: 42,
            switch_count: 3,
            reset_count: 1,
            frame: 1,
            r_e_m: [1.0e5, -2.5e5, 6.3e6],
            v_e_mps: [250.0, -1.5, 0.25],
            q_b_e: [0.5, 0.5, -0.5, 0.5],
            p,
            gyro_bias_rps: [1e-8, -2e-8, 3e-8],
            accel_bias_mps2: [1e-4, 2e-4, -3e-4],
            prev_inc: [1e-5, 2e-5, 3e-5, 0.01, 0.02, 0.049, 0.005],
            pending_cov: [0.045, 0.001, 0.002, 0.44],
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
