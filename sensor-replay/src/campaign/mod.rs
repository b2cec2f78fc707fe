//! Campaigns: many flights, each one run, one row of metrics.
//!
//! - [`faults`]: the fault campaign's judgement of a faulted flight against
//!   its fault-free twin (also a run kind of a campaign file).
//! - [`plan`]: the campaign file and its deterministic run list.
//! - [`run`]: one run in process: simulate, navigate, evaluate, one row.
//! - [`row`]: the row: metrics (bit for bit the same anywhere) and cost.
//! - [`store`]: the result directory: one checksummed file per run.
//! - [`local`], [`cluster`]: the executors (this machine; Slurm and
//!   Kubernetes array jobs over a shared directory).
//! - [`stats`], [`merge`]: the merged table and the report.

pub mod cli;
pub mod cluster;
pub mod faults;
pub mod local;
pub mod merge;
pub mod plan;
pub mod row;
pub mod run;
pub mod stats;
pub mod store;

pub use faults::*;
