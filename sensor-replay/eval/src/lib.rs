//! polarnav flight review: reads a navlog and a solution (CSV or MCAP),
//! measures accuracy against the log's truth when it has some, reviews the
//! estimator's health from its own outputs when it has none, and draws the
//! figures. Depends on no transport.

/// The χ² distribution (the core's, shared with its integrity test).
pub use polarnav::chi2;
pub mod envelope;
pub mod eval;
pub mod figures;
pub mod logfile;
pub mod plots;
pub mod review;
pub mod run;
pub mod solution_file;
pub mod spill;
