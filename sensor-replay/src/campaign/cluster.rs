//! Campaigns on a cluster: one array job whose tasks each run a chunk of
//! the run list through `sensor-replay campaign run-chunk`, on a result
//! directory every node sees (a shared file system).
//!
//! Chunk `c` is the runs `c·K .. (c+1)·K` (K = `--chunk`). A task takes its
//! chunk number from `SLURM_ARRAY_TASK_ID` (Slurm) or
//! `JOB_COMPLETION_INDEX` (a Kubernetes Indexed Job), runs those of its runs
//! that are missing or failed ([`super::local::execute`], one child process
//! per run), and writes each result on its own. A submission asks only for
//! the chunks that still have such runs, so submitting again after a
//! cancelled task, a node lost or a failed run runs only those.
//!
//! Slurm schedules; polarnav only writes the job script and hands it to
//! `sbatch`.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use super::local::{CampaignError, ranges};
use super::plan::Plan;

/// The chunks that hold any of `indices`.
pub fn chunks_of(indices: &[u64], chunk: u64) -> Vec<u64> {
    let mut c: Vec<u64> = indices.iter().map(|i| i / chunk).collect();
    c.dedup();
    c
}

/// Slurm's `--array` list: `0-3,7,9-12` (ranges with `-`, Slurm's syntax).
pub fn array_spec(chunks: &[u64]) -> String {
    ranges(chunks).replace("..=", "-").replace(' ', "")
}

/// The runs of chunk `c` (within the campaign's `runs`).
pub fn chunk_runs(c: u64, chunk: u64, runs: u64) -> std::ops::Range<u64> {
    let a = c.saturating_mul(chunk).min(runs);
    a..a.saturating_add(chunk).min(runs)
}

/// Quotes a word for a POSIX shell.
fn sh_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-=:,+@".contains(c))
    {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// The batch script of a submission: an array over `chunks`, each task
/// one `run-chunk`, its output in `DIR/slurm/`.
pub fn sbatch_script(exe: &Path, dir: &Path, plan: &Plan, chunks: &[u64], chunk: u64) -> String {
    let d = dir.display().to_string();
    let mut s = String::new();
    let _ = writeln!(s, "#!/bin/bash");
    let _ = writeln!(s, "# polarnav campaign {} ({})", plan.name, plan.sha256);
    let _ = writeln!(
        s,
        "# written by `sensor-replay campaign submit --slurm`: chunk c of {chunk} runs per array task"
    );
    let _ = writeln!(
        s,
        "#SBATCH --job-name={}",
        sh_quote(&format!("polarnav-{}", plan.name))
    );
    let _ = writeln!(s, "#SBATCH --array={}", array_spec(chunks));
    let _ = writeln!(
        s,
        "#SBATCH --output={}",
        sh_quote(&format!("{d}/slurm/%A_%a.out"))
    );
    let _ = writeln!(s, "#SBATCH --cpus-per-task=1");
    let _ = writeln!(s, "#SBATCH --ntasks=1");
    let _ = writeln!(
        s,
        "exec {} campaign run-chunk {} --chunk {chunk}",
        sh_quote(&exe.display().to_string()),
        sh_quote(&d)
    );
    s
}

/// Writes the script and submits it with `sbatch --parsable`, with
/// `sbatch_args` before the script (they override its `#SBATCH` lines).
/// Returns the job id, or `None` when nothing is left to run.
pub fn submit_slurm(
    dir: &Path,
    plan: &Plan,
    missing: &[u64],
    chunk: u64,
    sbatch_args: &[String],
) -> Result<Option<(String, Vec<u64>)>, CampaignError> {
    let chunks = chunks_of(missing, chunk);
    if chunks.is_empty() {
        return Ok(None);
    }
    let exe = std::env::current_exe()
        .map_err(|e| CampaignError::Io(format!("this program's path: {e}")))?;
    let dir = std::path::absolute(dir)
        .map_err(|e| CampaignError::Io(format!("{}: {e}", dir.display())))?;
    let sdir = dir.join("slurm");
    std::fs::create_dir_all(&sdir)
        .map_err(|e| CampaignError::Io(format!("{}: {e}", sdir.display())))?;
    let n = std::fs::read_dir(&sdir).map_or(0, |r| {
        r.filter_map(Result::ok)
            .filter(|e| e.file_name().to_string_lossy().ends_with(".sbatch"))
            .count()
    });
    let script = sdir.join(format!("submit-{n:03}.sbatch"));
    std::fs::write(&script, sbatch_script(&exe, &dir, plan, &chunks, chunk))
        .map_err(|e| CampaignError::Io(format!("{}: {e}", script.display())))?;
    let out = Command::new("sbatch")
        .arg("--parsable")
        .args(sbatch_args)
        .arg(&script)
        .output()
        .map_err(|e| {
            CampaignError::Io(format!(
                "sbatch: {e} (is Slurm installed and SLURM_CONF set?)"
            ))
        })?;
    if !out.status.success() {
        return Err(CampaignError::Io(format!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let id = String::from_utf8_lossy(&out.stdout)
        .trim()
        .split(';')
        .next()
        .unwrap_or_default()
        .to_owned();
    Ok(Some((id, chunks)))
}

/// Options of a Kubernetes Indexed Job.
#[derive(Debug, Clone)]
pub struct KubeOptions {
    /// The container image that has `sensor-replay` on its PATH.
    pub image: String,
    /// The PersistentVolumeClaim of the shared file system, mounted at the
    /// result directory's own absolute path (so the paths in it hold).
    pub claim: String,
    /// Pods at a time.
    pub parallelism: u64,
}

/// The Indexed Job of a campaign, as JSON (which `kubectl apply -f`
/// reads as it reads YAML): `completions` = the number of chunks, each
/// index `JOB_COMPLETION_INDEX` one `run-chunk`, the same contract as a
/// Slurm array task.
pub fn kube_job(dir: &Path, plan: &Plan, chunk: u64, o: &KubeOptions) -> serde_json::Value {
    let chunks = plan.runs().div_ceil(chunk);
    let d = dir.display().to_string();
    let name: String = format!("polarnav-campaign-{}", plan.name)
        .to_ascii_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .take(52)
        .collect::<String>()
        .trim_end_matches('-')
        .to_owned();
    serde_json::json!({
        "apiVersion": "batch/v1",
        "kind": "Job",
        "metadata": {
            "name": name,
            "labels": { "app.kubernetes.io/name": "polarnav-campaign" },
            "annotations": { "polarnav/campaign-sha256": plan.sha256 }
        },
        "spec": {
            "completionMode": "Indexed",
            "completions": chunks,
            "parallelism": o.parallelism.min(chunks).max(1),
            // A chunk whose pod fails is retried on its own, the others go on.
            "backoffLimitPerIndex": 2,
            "template": {
                "spec": {
                    "restartPolicy": "Never",
                    "containers": [{
                        "name": "run-chunk",
                        "image": o.image,
                        "command": ["sensor-replay", "campaign", "run-chunk", d, "--chunk", chunk.to_string()],
                        "resources": {
                            "requests": { "cpu": "1", "memory": "1Gi" },
                            "limits": { "memory": "4Gi" }
                        },
                        "volumeMounts": [{ "name": "campaign", "mountPath": d }]
                    }],
                    "volumes": [{
                        "name": "campaign",
                        "persistentVolumeClaim": { "claimName": o.claim }
                    }]
                }
            }
        }
    })
}

/// The chunk number of this array task: `--task`, else
/// `SLURM_ARRAY_TASK_ID`, else `JOB_COMPLETION_INDEX`; and what the cost
/// rows say ran it.
pub fn task_of(task: Option<u64>) -> Result<(u64, String), CampaignError> {
    if let Some(t) = task {
        return Ok((t, format!("local task {t}")));
    }
    let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
    if let Some(v) = var("SLURM_ARRAY_TASK_ID") {
        let t = v.parse().map_err(|_| {
            CampaignError::Io(format!("SLURM_ARRAY_TASK_ID={v:?} is not a task number"))
        })?;
        let job = var("SLURM_ARRAY_JOB_ID").unwrap_or_else(|| "?".into());
        return Ok((t, format!("slurm {job}_{t}")));
    }
    if let Some(v) = var("JOB_COMPLETION_INDEX") {
        let t = v.parse().map_err(|_| {
            CampaignError::Io(format!("JOB_COMPLETION_INDEX={v:?} is not an index"))
        })?;
        return Ok((t, format!("kubernetes {t}")));
    }
    Err(CampaignError::Io(
        "run-chunk: no task number: give --task, or run it as a Slurm array task (SLURM_ARRAY_TASK_ID) or a Kubernetes Indexed Job (JOB_COMPLETION_INDEX)".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_and_array_lists() {
        assert_eq!(chunks_of(&[0, 1, 5, 6, 7, 23], 4), vec![0, 1, 5]);
        assert_eq!(array_spec(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(chunk_runs(5, 4, 22), 20..22);
        assert_eq!(chunk_runs(9, 4, 22), 22..22);
        assert_eq!(chunk_runs(u64::MAX, 4, 22), 22..22);
    }

    #[test]
    fn shell_quoting() {
        assert_eq!(sh_quote("/a/b-c_d.e"), "/a/b-c_d.e");
        assert_eq!(sh_quote("a b"), "'a b'");
        assert_eq!(sh_quote("it's"), r"'it'\''s'");
        assert_eq!(sh_quote(""), "''");
    }
}
