//! The solution CSV's text made on a thread of its own.
//!
//! Formatting a row (up to 51 numbers in shortest round-trip form) costs
//! more than the navigator's whole step for that IMU sample, and it
//! depends on nothing the session decides next: `batch` hands the
//! solutions over in chunks to a formatting thread and writes the text it
//! gets back, in order, on its own thread (the writer stays where it is, so
//! it need not be `Send`). The text is byte for byte the one a
//! [`RowWriter`] on the session's thread writes: the same writer, the same
//! rows, in the same order. Chunks and their text buffers go round between
//! the two threads and are reused: after the first few chunks nothing is
//! allocated.

use std::io::Write;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::{Scope, ScopedJoinHandle};

use msgs::Solution;
use polarnav::solution_csv::RowWriter;

/// Solutions per chunk (about 0.5 MB of them, 1 MB of text).
pub const CHUNK_ROWS: usize = 1024;

/// Chunks handed over and not yet written back: the session runs at most
/// this far ahead of the formatting.
const IN_FLIGHT: usize = 2;

/// The formatting thread ended early (it panicked).
fn stopped() -> std::io::Error {
    std::io::Error::other("the CSV formatting thread stopped")
}

/// A chunk of solutions and the text made of it.
type Chunk = (Vec<Solution>, Vec<u8>);

/// The session's end of the pipe.
#[derive(Debug)]
pub struct RowPipe {
    to_format: SyncSender<Chunk>,
    formatted: Receiver<Chunk>,
    filling: Vec<Solution>,
    /// Emptied chunks and text buffers for reuse.
    spare: Vec<Chunk>,
    in_flight: usize,
}

impl RowPipe {
    /// Starts the formatting thread in `scope`. It ends when the pipe is
    /// finished or dropped.
    pub fn start<'scope>(scope: &'scope Scope<'scope, '_>) -> (Self, ScopedJoinHandle<'scope, ()>) {
        let (to_format, rx) = sync_channel::<Chunk>(IN_FLIGHT);
        let (tx, formatted) = sync_channel::<Chunk>(IN_FLIGHT + 1);
        let thread = scope.spawn(move || {
            let mut rows = RowWriter::new();
            for (solutions, mut text) in rx.iter() {
                text.clear();
                for s in &solutions {
                    // Writing into a Vec cannot fail.
                    let _ = rows.write(&mut text, s);
                }
                if tx.send((solutions, text)).is_err() {
                    break;
                }
            }
        });
        let pipe = Self {
            to_format,
            formatted,
            filling: Vec::with_capacity(CHUNK_ROWS),
            spare: Vec::with_capacity(IN_FLIGHT + 1),
            in_flight: 0,
        };
        (pipe, thread)
    }

    /// Takes the row of `s`; writes to `out` the text of earlier rows that
    /// is ready.
    pub fn push<W: Write>(&mut self, out: &mut W, s: &Solution) -> std::io::Result<()> {
        self.filling.push(*s);
        if self.filling.len() >= CHUNK_ROWS {
            self.hand_over(out)?;
        }
        Ok(())
    }

    /// Hands over the last rows and writes the text of every row to `out`.
    pub fn finish<W: Write>(mut self, out: &mut W) -> std::io::Result<()> {
        if !self.filling.is_empty() {
            self.hand_over(out)?;
        }
        while self.in_flight > 0 {
            self.write_back(out)?;
        }
        Ok(())
    }

    fn hand_over<W: Write>(&mut self, out: &mut W) -> std::io::Result<()> {
        while self.in_flight >= IN_FLIGHT {
            self.write_back(out)?;
        }
        let (next, text) = self
            .spare
            .pop()
            .unwrap_or_else(|| (Vec::with_capacity(CHUNK_ROWS), Vec::new()));
        let full = std::mem::replace(&mut self.filling, next);
        self.filling.clear();
        self.to_format.send((full, text)).map_err(|_| stopped())?;
        self.in_flight += 1;
        Ok(())
    }

    /// Waits for the oldest chunk handed over and writes its text.
    fn write_back<W: Write>(&mut self, out: &mut W) -> std::io::Result<()> {
        let (solutions, text) = self.formatted.recv().map_err(|_| stopped())?;
        self.in_flight -= 1;
        let written = out.write_all(&text);
        self.spare.push((solutions, text));
        written
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solution(k: u64) -> Solution {
        let mut s = Solution {
            t_ns: k * 5_000_000,
            seq: k,
            lat_rad: 1.2 + k as f64 * 1e-9,
            lon_rad: -0.3,
            h_m: 18_000.0 + (k % 7) as f64 * 0.125,
            ..Default::default()
        };
        s.q_b_e = [1.0, 0.0, 0.0, 0.0];
        s.sigma_pos_enu_m = [3.0, 3.0, (k / 100) as f64];
        s
    }

    /// Through the pipe, with chunks full and partial, the text is the
    /// one a RowWriter on this thread writes, row for row.
    #[test]
    fn the_text_is_the_same_rows_in_the_same_order() {
        for n in [0, 1, CHUNK_ROWS - 1, CHUNK_ROWS, 3 * CHUNK_ROWS + 17] {
            let solutions: Vec<Solution> = (0..n as u64).map(solution).collect();
            let mut direct = Vec::new();
            let mut rows = RowWriter::new();
            for s in &solutions {
                rows.write(&mut direct, s).expect("vec");
            }
            let mut piped = Vec::new();
            std::thread::scope(|scope| {
                let (mut pipe, _thread) = RowPipe::start(scope);
                for s in &solutions {
                    pipe.push(&mut piped, s).expect("push");
                }
                pipe.finish(&mut piped).expect("finish");
            });
            assert_eq!(piped.len(), direct.len(), "{n} rows");
            assert!(piped == direct, "{n} rows differ");
        }
    }

    /// A writer that fails: the error comes back to the session's side.
    #[test]
    fn a_failing_writer_is_reported() {
        struct Full;
        impl Write for Full {
            fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
                Err(std::io::Error::other("disk full"))
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        std::thread::scope(|scope| {
            let (mut pipe, _thread) = RowPipe::start(scope);
            let mut out = Full;
            let mut failed = None;
            for k in 0..(4 * CHUNK_ROWS as u64) {
                if let Err(e) = pipe.push(&mut out, &solution(k)) {
                    failed = Some(e);
                    break;
                }
            }
            let e = failed.expect("the write failed during the pushes");
            assert!(e.to_string().contains("disk full"), "{e}");
        });
    }
}
