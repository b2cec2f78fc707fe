//! polarnav sensor-replay: flight simulator, log import/export, evaluation.

pub mod campaign;
pub mod eval;
pub mod export;
pub mod faults;
pub mod interop;
pub mod live;
pub mod logfile;
pub mod monitor;
pub mod pieces;
pub mod plots;
pub mod scenario;
pub mod sensors;
pub mod simulate;
pub mod solution_file;
pub mod trajectory;
pub mod view;
