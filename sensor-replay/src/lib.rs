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

/// Writes `bytes` to standard output and flushes it. `Ok(false)` when the
/// reader stopped reading (`sensor-replay ... | head`: a broken pipe),
/// which is not an error: the caller drops the rest and goes on or stops
/// as it sees fit. Rust ignores SIGPIPE, so `print!` would panic there.
pub fn write_stdout(bytes: &[u8]) -> std::io::Result<bool> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    match out.write_all(bytes).and_then(|()| out.flush()) {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(false),
        Err(e) => Err(e),
    }
}
