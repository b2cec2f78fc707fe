//! One run's result: its metrics ([`Metrics`], a function of the campaign
//! file and the run's index alone: bit for bit the same on any machine and
//! under any executor) and its cost ([`Cost`], measured: CPU seconds, peak
//! memory, where and by which build it ran).
//!
//! The two are kept apart so that the merged metrics table of a campaign run
//! on a laptop equals, bit for bit, the one its Slurm array made; the cost
//! goes to a table of its own.
//!
//! A metric that a run did not produce (a failed run, a group the campaign
//! does not keep, an exclusion that never came) is `None`, never a
//! made-up number: it is a null in the Parquet table.

use serde::{Deserialize, Serialize};

/// Whether a run produced its metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Ok,
    /// It panicked, timed out, its scenario could not be simulated or its
    /// log not navigated: [`Metrics::reason`] says which.
    Failed,
}

impl Outcome {
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Ok => "ok",
            Outcome::Failed => "failed",
        }
    }
}

/// The metrics of one run. Errors are against the simulated truth at its
/// records (every `[truth]` epoch, or those on the `every_s` grid), computed
/// frame-free as `sensor-replay eval` does; NEES uses the solution's
/// per-axis σ (the published diagonal), as `eval` does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Metrics {
    /// The run's index in the campaign's run list.
    pub index: u64,
    /// The index of its variation (a point of the matrix) and its label
    /// (`scenario=transpolar-gnss preset=mems gnss=off ...`).
    pub variation: u32,
    pub variation_label: String,
    /// The scenario's `name`.
    pub scenario: String,
    /// The seed of the flight, derived from the campaign's seed and the index.
    pub seed: u64,
    pub outcome: Outcome,
    /// Why it failed (empty when it did not).
    pub reason: String,
    /// Flight time navigated (h).
    pub flight_h: Option<f64>,
    /// Epochs compared with the truth, and those with a non-finite error or σ
    /// (left out of every statistic).
    pub epochs: Option<u64>,
    pub non_finite_epochs: Option<u64>,
    pub horizontal_rmse_m: Option<f64>,
    pub horizontal_max_m: Option<f64>,
    pub vertical_rmse_m: Option<f64>,
    pub vertical_max_m: Option<f64>,
    pub velocity_rmse_mps: Option<f64>,
    pub velocity_max_mps: Option<f64>,
    /// The attitude error's angle (the norm of φ).
    pub attitude_rmse_arcmin: Option<f64>,
    pub attitude_max_arcmin: Option<f64>,
    /// Mean NEES over the run's epochs (3 degrees of freedom each; ideal 3).
    pub nees_position: Option<f64>,
    pub nees_velocity: Option<f64>,
    pub nees_attitude: Option<f64>,
    /// Frame switches.
    pub switches: Option<u32>,
    /// Resets of the navigation state, all causes; those by an aid that a
    /// wrong model kept rejecting, those by a GNSS exclusion (the reference's
    /// state taken), and the causes as `stream:count` pairs (`cns:1 gnss:2`).
    pub resets: Option<u32>,
    pub resets_aid: Option<u32>,
    pub resets_integrity: Option<u32>,
    pub reset_causes: Option<String>,
    /// Re-initializations and covariance repairs.
    pub reinits: Option<u32>,
    pub covariance_repairs: Option<u64>,
    /// GNSS fixes received; tested by the integrity test against the
    /// autonomous aids (a verdict of admit, exclude, refuse or readmit);
    /// fused untested (the test unavailable); exclusions; readmissions; and
    /// exclusions with no injected GNSS fault active ("false exclusions").
    pub gnss_fixes: Option<u64>,
    pub gnss_tested: Option<u64>,
    pub gnss_untested: Option<u64>,
    pub gnss_exclusions: Option<u64>,
    pub gnss_readmissions: Option<u64>,
    pub gnss_false_exclusions: Option<u64>,
    /// The largest q over its threshold of any tested fix (above 1 is an alarm).
    pub max_q_ratio: Option<f64>,
    /// The injected GNSS fault (`spoof`, `jam`; `None` when the flight has
    /// none), when it starts, whether the integrity test excluded the
    /// receiver while it was active, how long after its start, and the
    /// horizontal error at that moment.
    pub fault: Option<String>,
    pub fault_start_s: Option<f64>,
    pub fault_detected: Option<bool>,
    pub time_to_exclusion_s: Option<f64>,
    pub error_at_exclusion_m: Option<f64>,
    /// A `fault-judge` run (the fault campaign): whether every injected
    /// fault was detected, the accounting held and the error stayed within
    /// its bound against the fault-free twin.
    pub judgement_pass: Option<bool>,
    /// What failed that judgement, `; `-separated (empty when it passed).
    pub judgement_failures: Option<String>,
}

impl Metrics {
    /// The row of a run that produced no metrics.
    pub fn failed(
        index: u64,
        variation: u32,
        variation_label: &str,
        scenario: &str,
        seed: u64,
        reason: String,
    ) -> Self {
        Metrics {
            index,
            variation,
            variation_label: variation_label.to_owned(),
            scenario: scenario.to_owned(),
            seed,
            outcome: Outcome::Failed,
            reason,
            flight_h: None,
            epochs: None,
            non_finite_epochs: None,
            horizontal_rmse_m: None,
            horizontal_max_m: None,
            vertical_rmse_m: None,
            vertical_max_m: None,
            velocity_rmse_mps: None,
            velocity_max_mps: None,
            attitude_rmse_arcmin: None,
            attitude_max_arcmin: None,
            nees_position: None,
            nees_velocity: None,
            nees_attitude: None,
            switches: None,
            resets: None,
            resets_aid: None,
            resets_integrity: None,
            reset_causes: None,
            reinits: None,
            covariance_repairs: None,
            gnss_fixes: None,
            gnss_tested: None,
            gnss_untested: None,
            gnss_exclusions: None,
            gnss_readmissions: None,
            gnss_false_exclusions: None,
            max_q_ratio: None,
            fault: None,
            fault_start_s: None,
            fault_detected: None,
            time_to_exclusion_s: None,
            error_at_exclusion_m: None,
            judgement_pass: None,
            judgement_failures: None,
        }
    }
}

/// What one run cost and where it ran: measured, so it differs from run to
/// run of the same index (kept out of [`Metrics`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cost {
    pub index: u64,
    /// Flight time of the run (h), as in its metrics (0 for a failed run).
    pub flight_h: f64,
    /// CPU seconds of the whole run, and of its parts: simulation and
    /// navigation (with the integrity test's reference navigator) and the
    /// evaluation against the truth.
    pub cpu_s: f64,
    pub simulate_cpu_s: f64,
    pub navigate_cpu_s: f64,
    pub evaluate_cpu_s: f64,
    pub wall_s: f64,
    /// The peak resident memory of the process that ran it (MiB).
    pub peak_rss_mib: f64,
    pub host: String,
    /// `local`, `slurm JOB_TASK` or `kubernetes INDEX`.
    pub executor: String,
    /// polarnav's version and the commit it was built from.
    pub version: String,
    pub commit: String,
}
