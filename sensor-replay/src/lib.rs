//! polarnav sensor-replay: the command line, log import/export, the fault
//! campaign and the live tools (play, record, listen, view). The simulator is
//! `polarnav-sim`, the evaluation `polarnav-eval`.

pub mod campaign;
pub mod export;
pub mod interop;
pub mod live;
pub mod monitor;
pub mod pieces;
pub mod scene;
pub mod view;
