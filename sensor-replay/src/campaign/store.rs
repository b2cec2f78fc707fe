//! A campaign's result directory: one file per run, each written whole or
//! not at all, each carrying its checksum and the hash of the campaign file
//! it belongs to.
//!
//! ```text
//! DIR/campaign.toml        the campaign file as it was first run (its SHA-256 names the campaign)
//! DIR/runs/000000123.run   run 123: one line of JSON, then `sha256 <hex of that line>`
//! DIR/merged/              what `campaign merge` writes
//! DIR/slurm/, DIR/kubernetes/   what `campaign submit` writes
//! ```
//!
//! A result is written to a temporary name in the same directory, flushed
//! to the disk, then renamed over its final name (atomic on a POSIX file
//! system, NFS and Lustre included), so a reader sees the whole file or
//! none. A file that is there but whose checksum does not match its body
//! (a torn write on a file system that broke that promise, a bit flip, an
//! edit) is counted as missing, and run again.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::row::{Cost, Metrics, Outcome};

/// The SHA-256 of bytes, as lowercase hex.
pub fn sha256_hex(bytes: &[u8]) -> String {
    let d = Sha256::digest(bytes);
    let mut s = String::with_capacity(64);
    for b in d {
        s += &format!("{b:02x}");
    }
    s
}

/// The directory of the runs' results.
pub fn runs_dir(dir: &Path) -> PathBuf {
    dir.join("runs")
}

/// Where run `index`'s result goes.
pub fn result_path(dir: &Path, index: u64) -> PathBuf {
    runs_dir(dir).join(format!("{index:09}.run"))
}

/// The body of a result file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunResult {
    /// SHA-256 of the campaign file the run belongs to.
    pub campaign_sha256: String,
    pub metrics: Metrics,
    pub cost: Cost,
}

/// Why a result file cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResultError {
    #[error("{path}: cannot read: {why}")]
    Io { path: String, why: String },
    #[error("{path}: no checksum line (a torn or truncated write)")]
    Torn { path: String },
    #[error("{path}: checksum mismatch (the file was altered or damaged)")]
    Checksum { path: String },
    #[error("{path}: {why}")]
    Malformed { path: String, why: String },
    #[error("{path}: belongs to campaign {found}, not {expected}")]
    OtherCampaign {
        path: String,
        found: String,
        expected: String,
    },
    #[error("{path}: holds run {found}, not {expected}")]
    WrongIndex {
        path: String,
        found: u64,
        expected: u64,
    },
}

/// The bytes of a result file.
pub fn encode(r: &RunResult) -> Vec<u8> {
    let body = serde_json::to_string(r).expect("a result serializes");
    let mut out = body.into_bytes();
    let sum = sha256_hex(&out);
    out.extend_from_slice(format!("\nsha256 {sum}\n").as_bytes());
    out
}

/// Reads a result file's bytes, checking its checksum and its campaign.
pub fn decode(path: &Path, bytes: &[u8], campaign_sha256: &str) -> Result<RunResult, ResultError> {
    let p = || path.display().to_string();
    let text = bytes
        .strip_suffix(b"\n")
        .ok_or(ResultError::Torn { path: p() })?;
    let nl = memchr_last(text).ok_or(ResultError::Torn { path: p() })?;
    let (body, tail) = (&text[..nl], &text[nl + 1..]);
    let sum = tail
        .strip_prefix(b"sha256 ")
        .ok_or(ResultError::Torn { path: p() })?;
    if sum != sha256_hex(body).as_bytes() {
        return Err(ResultError::Checksum { path: p() });
    }
    let r: RunResult = serde_json::from_slice(body).map_err(|e| ResultError::Malformed {
        path: p(),
        why: e.to_string(),
    })?;
    if r.campaign_sha256 != campaign_sha256 {
        return Err(ResultError::OtherCampaign {
            path: p(),
            found: r.campaign_sha256,
            expected: campaign_sha256.to_owned(),
        });
    }
    if r.metrics.index != r.cost.index {
        return Err(ResultError::Malformed {
            path: p(),
            why: format!(
                "metrics of run {} with the cost of run {}",
                r.metrics.index, r.cost.index
            ),
        });
    }
    Ok(r)
}

fn memchr_last(b: &[u8]) -> Option<usize> {
    b.iter().rposition(|&c| c == b'\n')
}

/// Writes run `r`'s result: to a temporary name, synced, renamed.
pub fn write_result(dir: &Path, r: &RunResult) -> std::io::Result<PathBuf> {
    let runs = runs_dir(dir);
    fs::create_dir_all(&runs)?;
    let path = result_path(dir, r.metrics.index);
    let tmp = runs.join(format!(
        ".{:09}.{}.{}.tmp",
        r.metrics.index,
        std::process::id(),
        host_tag()
    ));
    let mut f = fs::File::create(&tmp)?;
    f.write_all(&encode(r))?;
    f.sync_all()?;
    drop(f);
    fs::rename(&tmp, &path)?;
    // The rename itself reaches the disk with the directory.
    if let Ok(d) = fs::File::open(&runs) {
        let _ = d.sync_all();
    }
    Ok(path)
}

/// A short tag of this host for temporary names: two hosts of a cluster
/// writing the same index (a task run twice) never share a temporary file.
fn host_tag() -> String {
    hostname()
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
        .take(32)
        .collect()
}

/// This machine's host name (`/proc/sys/kernel/hostname`, else `HOSTNAME`).
pub fn hostname() -> String {
    fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_owned())
        .ok()
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

/// What the directory holds for one run.
#[derive(Debug, Clone, PartialEq)]
pub enum RunState {
    Done,
    Failed(String),
    /// No usable result: none, or one that cannot be used (the reason).
    Missing(Option<String>),
}

/// Reads run `index`'s result, if it has a usable one.
pub fn read_result(
    dir: &Path,
    index: u64,
    campaign_sha256: &str,
) -> Result<Option<RunResult>, ResultError> {
    let path = result_path(dir, index);
    let bytes = match fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(ResultError::Io {
                path: path.display().to_string(),
                why: e.to_string(),
            });
        }
    };
    let r = decode(&path, &bytes, campaign_sha256)?;
    if r.metrics.index != index {
        return Err(ResultError::WrongIndex {
            path: path.display().to_string(),
            found: r.metrics.index,
            expected: index,
        });
    }
    Ok(Some(r))
}

/// The state of run `index`.
pub fn state(dir: &Path, index: u64, campaign_sha256: &str) -> RunState {
    match read_result(dir, index, campaign_sha256) {
        Ok(None) => RunState::Missing(None),
        Ok(Some(r)) => match r.metrics.outcome {
            Outcome::Ok => RunState::Done,
            Outcome::Failed => RunState::Failed(r.metrics.reason),
        },
        Err(e) => RunState::Missing(Some(e.to_string())),
    }
}

/// Temporary files left behind by runs that were killed while writing
/// (never read as results; `campaign status` counts them and
/// [`remove_stale_temporaries`] clears them before a new run).
pub fn temporaries(dir: &Path) -> Vec<PathBuf> {
    let Ok(rd) = fs::read_dir(runs_dir(dir)) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with('.') && n.ends_with(".tmp"))
        })
        .collect();
    v.sort();
    v
}

/// Removes the temporaries of this host whose process is gone (a process
/// of another host, or one still running, keeps its own).
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let tag = host_tag();
    let mut n = 0;
    for p in temporaries(dir) {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        let mut parts = name.trim_start_matches('.').split('.');
        let (_index, pid, host) = (parts.next(), parts.next(), parts.next());
        let alive = pid
            .and_then(|p| p.parse::<u32>().ok())
            .is_some_and(|pid| Path::new(&format!("/proc/{pid}")).exists());
        if host == Some(tag.as_str()) && !alive && fs::remove_file(&p).is_ok() {
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(index: u64) -> RunResult {
        let mut m = Metrics::failed(index, 2, "scenario=x", "x", 7, String::new());
        m.outcome = Outcome::Ok;
        m.horizontal_rmse_m = Some(1.25);
        m.time_to_exclusion_s = Some(f64::MIN_POSITIVE);
        RunResult {
            campaign_sha256: "ab".repeat(32),
            metrics: m,
            cost: Cost {
                index,
                flight_h: 0.5,
                cpu_s: 1.0,
                simulate_cpu_s: 0.5,
                navigate_cpu_s: 0.4,
                evaluate_cpu_s: 0.1,
                wall_s: 1.1,
                peak_rss_mib: 20.0,
                host: "h".into(),
                executor: "local".into(),
                version: "0.1.0".into(),
                commit: "abc".into(),
            },
        }
    }

    #[test]
    fn a_result_round_trips_bit_for_bit() {
        let r = result(12);
        let back = decode(Path::new("x"), &encode(&r), &"ab".repeat(32)).expect("decodes");
        assert_eq!(back, r);
        assert_eq!(
            back.metrics.time_to_exclusion_s.map(f64::to_bits),
            Some(f64::MIN_POSITIVE.to_bits())
        );
    }

    /// Every prefix of a result file (a write torn anywhere) and every
    /// single flipped bit is refused.
    #[test]
    fn every_torn_or_flipped_file_is_refused() {
        let bytes = encode(&result(3));
        let hash = "ab".repeat(32);
        for n in 0..bytes.len() {
            assert!(
                decode(Path::new("x"), &bytes[..n], &hash).is_err(),
                "a prefix of {n} of {} bytes was accepted",
                bytes.len()
            );
        }
        for i in 0..bytes.len() {
            for bit in 0..8 {
                let mut b = bytes.clone();
                b[i] ^= 1 << bit;
                assert!(
                    decode(Path::new("x"), &b, &hash).is_err(),
                    "byte {i} bit {bit} flipped was accepted"
                );
            }
        }
    }

    #[test]
    fn a_result_of_another_campaign_is_refused() {
        let bytes = encode(&result(3));
        let e = decode(Path::new("x"), &bytes, &"cd".repeat(32)).unwrap_err();
        assert!(matches!(e, ResultError::OtherCampaign { .. }), "{e}");
    }

    mod fuzz {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

            /// Any bytes as a result file: refused with a reason, or (only
            /// when they are a valid encoding) read; never a panic.
            #[test]
            fn any_bytes_are_refused_or_read(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
                if let Ok(r) = decode(Path::new("x"), &bytes, &"ab".repeat(32)) {
                    prop_assert_eq!(encode(&r), bytes);
                }
            }

            /// A valid body with its checksum recomputed but any value
            /// changed is read as that value, or refused by the schema.
            #[test]
            fn a_result_with_changed_numbers_round_trips(h in any::<u64>().prop_map(f64::from_bits)) {
                let mut r = result(5);
                r.metrics.horizontal_rmse_m = h.is_finite().then_some(h);
                let back = decode(Path::new("x"), &encode(&r), &"ab".repeat(32)).expect("decodes");
                prop_assert_eq!(back.metrics.horizontal_rmse_m.map(f64::to_bits), r.metrics.horizontal_rmse_m.map(f64::to_bits));
            }
        }
    }
}
