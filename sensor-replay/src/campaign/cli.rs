//! `sensor-replay campaign ...`: the command line of campaigns.

use std::path::PathBuf;
use std::time::Duration;

use clap::Subcommand;

use super::cluster::{self, KubeOptions};
use super::local::{self, CampaignError};
use super::plan::{Frozen, Plan};

#[derive(Debug, Subcommand)]
pub enum CampaignCmd {
    /// Check a campaign file and print its variations and run count.
    Plan {
        /// The campaign file (TOML), e.g. config/campaigns/accuracy.toml.
        file: PathBuf,
    },
    /// Run a campaign's missing and failed runs on this machine.
    Run {
        /// The campaign file (TOML).
        file: PathBuf,
        /// The result directory (created; one campaign per directory).
        #[arg(long)]
        out: PathBuf,
        /// Runs at a time (default: every core).
        #[arg(long)]
        jobs: Option<usize>,
        /// Only these runs: INDEX, A..B or A..=B (e.g. 0..24: one flight of
        /// each of the first 24 variations).
        #[arg(long, value_name = "RANGE")]
        only: Option<String>,
    },
    /// Submit a campaign's missing and failed runs to a cluster: one array
    /// job over chunks of runs, DIR on a file system every node sees.
    #[command(group(clap::ArgGroup::new("executor").required(true).args(["slurm", "kubernetes"])))]
    Submit {
        /// The campaign file (TOML).
        file: PathBuf,
        /// The result directory, on a shared file system.
        #[arg(long)]
        out: PathBuf,
        /// Submit to Slurm with `sbatch --array` (options after `--` go to sbatch).
        #[arg(long)]
        slurm: bool,
        /// Write a Kubernetes Indexed Job manifest (DIR/kubernetes/job.json)
        /// instead; `kubectl apply -f` submits it.
        #[arg(long)]
        kubernetes: bool,
        /// Runs per array task.
        #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
        chunk: u64,
        /// --kubernetes: the image with sensor-replay on its PATH.
        #[arg(long, default_value = "polarnav:latest")]
        image: String,
        /// --kubernetes: the PersistentVolumeClaim holding DIR.
        #[arg(long, default_value = "polarnav-campaigns")]
        claim: String,
        /// --kubernetes: pods at a time.
        #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u64).range(1..=100_000))]
        parallelism: u64,
        /// Options for sbatch (after `--`), e.g. `-- --partition=long --time=2:00:00`.
        #[arg(last = true)]
        sbatch_args: Vec<String>,
    },
    /// Run one array task's chunk of runs (what a submitted job runs).
    RunChunk {
        /// The result directory.
        dir: PathBuf,
        /// Runs per chunk (as submitted).
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
        chunk: u64,
        /// The chunk (default: SLURM_ARRAY_TASK_ID, else JOB_COMPLETION_INDEX).
        #[arg(long)]
        task: Option<u64>,
        /// Runs at a time (default: SLURM_CPUS_PER_TASK, else 1).
        #[arg(long)]
        jobs: Option<usize>,
    },
    /// Run one run in this process and write its result (the executors' worker).
    #[command(hide = true)]
    RunOne {
        /// The result directory.
        dir: PathBuf,
        /// The run's index in the campaign's run list.
        #[arg(long)]
        index: u64,
        /// The executor named in the row's cost (local, slurm, kubernetes).
        #[arg(long, default_value = "local")]
        executor: String,
    },
    /// What a result directory holds: runs done, failed and missing.
    Status {
        /// The result directory.
        dir: PathBuf,
    },
    /// Merge the results: DIR/merged/metrics.parquet, cost.parquet and report.md.
    Merge {
        /// The result directory.
        dir: PathBuf,
    },
}

/// A failure: exit status (2 bad input, 1 other) and message.
pub type Failure = (u8, String);

fn bad(e: CampaignError) -> Failure {
    let code = match e {
        CampaignError::Plan(_)
        | CampaignError::OtherCampaign { .. }
        | CampaignError::NoCampaign { .. } => 2,
        CampaignError::Io(_) => 1,
    };
    (code, e.to_string())
}

fn say(s: &str) -> Result<(), Failure> {
    crate::write_stdout(s.as_bytes())
        .map(|_| ())
        .map_err(|e| (1, format!("stdout: {e}")))
}

/// Runs a campaign command.
pub fn run(cmd: CampaignCmd) -> Result<(), Failure> {
    match cmd {
        CampaignCmd::Plan { file } => {
            let f = Frozen::read(&file).map_err(|e| bad(e.into()))?;
            let plan = Plan::new(&f).map_err(|e| bad(e.into()))?;
            let mut out = format!(
                "campaign {} ({}): {} variations × {} seeds = {} runs; campaign SHA-256 {}\n",
                plan.name,
                file.display(),
                plan.variations.len(),
                plan.seeds.count,
                plan.runs(),
                plan.sha256
            );
            let hours: f64 = plan
                .variations
                .iter()
                .map(|v| v.scenario.duration_s() / 3600.0)
                .sum::<f64>()
                * plan.seeds.count as f64;
            out += &format!("flight hours: {hours:.1}\n");
            for (i, v) in plan.variations.iter().enumerate() {
                out += &format!(
                    "  variation {i:>4}: {} ({:.0} s)\n",
                    v.label,
                    v.scenario.duration_s()
                );
            }
            say(&out)
        }
        CampaignCmd::Run {
            file,
            out,
            jobs,
            only,
        } => {
            let (_, plan) = local::open_for(&file, &out).map_err(bad)?;
            let range = match &only {
                Some(s) => local::parse_range(s, plan.runs()).map_err(|m| (2, m))?,
                None => 0..plan.runs(),
            };
            let todo = local::to_run(&out, &plan, range.clone());
            let jobs = jobs
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
                .max(1);
            eprintln!(
                "campaign {}: {} of runs {}..{} to run ({} done already), {jobs} at a time; results in {}",
                plan.name,
                todo.len(),
                range.start,
                range.end,
                (range.end - range.start) - todo.len() as u64,
                out.display()
            );
            let t = local::execute(&out, &plan, todo, jobs, "local", Duration::from_secs(10))
                .map_err(bad)?;
            let st = local::status(&out, &plan);
            say(&st.text(&plan.name))?;
            say(&format!(
                "merge: sensor-replay campaign merge {}\n",
                out.display()
            ))?;
            if t.failed > 0 || t.stopped > 0 {
                return Err((
                    1,
                    format!("{} run(s) failed, {} stopped", t.failed, t.stopped),
                ));
            }
            Ok(())
        }
        CampaignCmd::Submit {
            file,
            out,
            slurm,
            kubernetes,
            chunk,
            image,
            claim,
            parallelism,
            sbatch_args,
        } => {
            let (_, plan) = local::open_for(&file, &out).map_err(bad)?;
            if kubernetes {
                if !sbatch_args.is_empty() {
                    return Err((
                        2,
                        "options after -- are sbatch's: not with --kubernetes".into(),
                    ));
                }
                let dir = std::path::absolute(&out)
                    .map_err(|e| (1, format!("{}: {e}", out.display())))?;
                let job = cluster::kube_job(
                    &dir,
                    &plan,
                    chunk,
                    &KubeOptions {
                        image,
                        claim,
                        parallelism,
                    },
                );
                let kdir = dir.join("kubernetes");
                std::fs::create_dir_all(&kdir)
                    .map_err(|e| (1, format!("{}: {e}", kdir.display())))?;
                let path = kdir.join("job.json");
                let text =
                    serde_json::to_string_pretty(&job).expect("a manifest serializes") + "\n";
                std::fs::write(&path, text).map_err(|e| (1, format!("{}: {e}", path.display())))?;
                return say(&format!(
                    "wrote {} ({} indexed completions of {chunk} runs); submit it with: kubectl apply -f {}\n",
                    path.display(),
                    plan.runs().div_ceil(chunk),
                    path.display()
                ));
            }
            debug_assert!(slurm);
            let missing = local::to_run(&out, &plan, 0..plan.runs());
            match cluster::submit_slurm(&out, &plan, &missing, chunk, &sbatch_args).map_err(bad)? {
                None => say(&format!(
                    "campaign {}: every run is done; nothing submitted\n",
                    plan.name
                )),
                Some((job, chunks)) => say(&format!(
                    "submitted Slurm job {job}: array {} ({} tasks of up to {chunk} runs, {} runs missing or failed); follow it with: sensor-replay campaign status {}\n",
                    cluster::array_spec(&chunks),
                    chunks.len(),
                    missing.len(),
                    out.display()
                )),
            }
        }
        CampaignCmd::RunChunk {
            dir,
            chunk,
            task,
            jobs,
        } => {
            let (_, plan) = local::open(&dir).map_err(bad)?;
            let (task, executor) = cluster::task_of(task).map_err(bad)?;
            let runs = cluster::chunk_runs(task, chunk, plan.runs());
            let todo = local::to_run(&dir, &plan, runs.clone());
            let jobs = jobs
                .or_else(|| {
                    std::env::var("SLURM_CPUS_PER_TASK")
                        .ok()
                        .and_then(|v| v.parse().ok())
                })
                .unwrap_or(1);
            eprintln!(
                "campaign {} chunk {task} (runs {}..{}): {} to run, {jobs} at a time ({executor})",
                plan.name,
                runs.start,
                runs.end,
                todo.len()
            );
            let t = local::execute(&dir, &plan, todo, jobs, &executor, Duration::from_secs(60))
                .map_err(bad)?;
            if t.stopped > 0 {
                return Err((1, format!("{} run(s) stopped", t.stopped)));
            }
            Ok(())
        }
        CampaignCmd::RunOne {
            dir,
            index,
            executor,
        } => {
            let r = local::run_one(&dir, index, &executor).map_err(bad)?;
            if r.metrics.outcome == super::row::Outcome::Failed {
                eprintln!("run {index}: failed: {}", r.metrics.reason);
            }
            Ok(())
        }
        CampaignCmd::Status { dir } => {
            let (_, plan) = local::open(&dir).map_err(bad)?;
            say(&local::status(&dir, &plan).text(&plan.name))
        }
        CampaignCmd::Merge { dir } => {
            let (_, plan) = local::open(&dir).map_err(bad)?;
            let s = super::merge::merge(&dir, &plan.sha256, plan.runs(), &plan.name)
                .map_err(|e| (1, e.to_string()))?;
            say(&format!("{s}\n"))
        }
    }
}
