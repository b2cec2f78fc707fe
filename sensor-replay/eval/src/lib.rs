//! measures accuracy against the log's truth when it has some, and draws the
//! figures. Depends on no transport.

pub mod eval;
pub mod logfile;
pub mod plots;
pub mod solution_file;
