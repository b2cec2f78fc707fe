//! Fixed-size records of a long flight kept on disk instead of in memory.
//!
//! A figure picks its points from a sequence with a step that depends on
//! the sequence's length (`plots::decimate`), and its axis from every
//! point: while the flight streams in, neither is known. A [`Spill`]
//! appends each record (`W` words of 8 bytes) to a temporary file, already
//! unlinked so that nothing is left behind, through a 64 KiB buffer; once
//! sealed it is read back sequentially or by index. Memory holds the
//! buffer, whatever the number of records.

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes buffered before a write, and read at a time.
const BUFFER_BYTES: usize = 64 << 10;

/// Why a temporary file could not be made, written or read: the message
/// names the directory (`TMPDIR`) and the operation.
fn spill_error(what: &str, e: &io::Error) -> io::Error {
    io::Error::new(
        e.kind(),
        format!(
            "temporary file in {} ({what}): {e}",
            std::env::temp_dir().display()
        ),
    )
}

/// A growing sequence of records of `W` words on disk.
#[derive(Debug)]
pub struct Spill<const W: usize> {
    file: File,
    buf: Vec<u8>,
    written: u64,
    n: u64,
}

impl<const W: usize> Spill<W> {
    /// An empty spill in a new temporary file (already unlinked).
    pub fn new() -> io::Result<Self> {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let dir = std::env::temp_dir();
        let (file, path) = loop {
            let path = dir.join(format!(
                "polarnav-eval-{}-{}.spill",
                std::process::id(),
                NEXT.fetch_add(1, Ordering::Relaxed)
            ));
            match std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(f) => break (f, path),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(spill_error("create", &e)),
            }
        };
        std::fs::remove_file(&path).map_err(|e| spill_error("unlink", &e))?;
        Ok(Self {
            file,
            buf: Vec::with_capacity(BUFFER_BYTES),
            written: 0,
            n: 0,
        })
    }

    /// Appends a record.
    pub fn push(&mut self, rec: &[u64; W]) -> io::Result<()> {
        for w in rec {
            self.buf.extend_from_slice(&w.to_le_bytes());
        }
        self.n += 1;
        if self.buf.len() >= BUFFER_BYTES {
            self.flush()?;
        }
        Ok(())
    }

    /// Appends a record of floating-point values (kept bit for bit).
    pub fn push_f64(&mut self, rec: &[f64; W]) -> io::Result<()> {
        self.push(&rec.map(f64::to_bits))
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file
            .write_all_at(&self.buf, self.written)
            .map_err(|e| spill_error("write", &e))?;
        self.written += self.buf.len() as u64;
        self.buf.clear();
        Ok(())
    }

    /// Records pushed.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// True without records.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Writes what is buffered; the records can then be read (shared).
    pub fn seal(mut self) -> io::Result<Sealed<W>> {
        self.flush()?;
        Ok(Sealed {
            file: Arc::new(self.file),
            n: self.n,
        })
    }
}

/// The records of a [`Spill`], read-only (cheap to clone: the file is shared,
/// each reader keeps its own position).
#[derive(Debug, Clone)]
pub struct Sealed<const W: usize> {
    file: Arc<File>,
    n: u64,
}

impl<const W: usize> Sealed<W> {
    /// Records held.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// True without records.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Record `i` (`i < len`).
    pub fn get(&self, i: u64) -> io::Result<[u64; W]> {
        let mut b = vec![0u8; 8 * W];
        self.file
            .read_exact_at(&mut b, i * 8 * W as u64)
            .map_err(|e| spill_error("read", &e))?;
        Ok(words(&b))
    }

    /// Record `i` as floating-point values.
    pub fn get_f64(&self, i: u64) -> io::Result<[f64; W]> {
        Ok(self.get(i)?.map(f64::from_bits))
    }

    /// Every record in order, read 64 KiB at a time.
    pub fn iter(&self) -> Records<W> {
        Records {
            file: Arc::clone(&self.file),
            n: self.n,
            next: 0,
            buf: Vec::new(),
            at: 0,
        }
    }

    /// Calls `f` with every record as floating-point values, in order.
    pub fn for_each_f64(&self, mut f: impl FnMut(&[f64; W])) -> io::Result<()> {
        for r in self.iter() {
            f(&r?.map(f64::from_bits));
        }
        Ok(())
    }

    /// The records at indices 0, step, 2·step, … (the points
    /// `plots::decimate` keeps of a sequence of this length).
    pub fn every(&self, step: u64) -> io::Result<Vec<[f64; W]>> {
        let step = step.max(1);
        let mut out = Vec::with_capacity((self.n / step + 1) as usize);
        if step <= 16 {
            // Dense: one sequential read.
            for (i, r) in self.iter().enumerate() {
                let r = r?;
                if (i as u64).is_multiple_of(step) {
                    out.push(r.map(f64::from_bits));
                }
            }
        } else {
            let mut i = 0;
            while i < self.n {
                out.push(self.get_f64(i)?);
                i += step;
            }
        }
        Ok(out)
    }
}

fn words<const W: usize>(b: &[u8]) -> [u64; W] {
    let mut r = [0u64; W];
    for (k, w) in r.iter_mut().enumerate() {
        let mut x = [0u8; 8];
        x.copy_from_slice(&b[8 * k..8 * k + 8]);
        *w = u64::from_le_bytes(x);
    }
    r
}

/// A sequential reader of a [`Sealed`] spill.
#[derive(Debug)]
pub struct Records<const W: usize> {
    file: Arc<File>,
    n: u64,
    next: u64,
    buf: Vec<u8>,
    at: usize,
}

impl<const W: usize> Iterator for Records<W> {
    type Item = io::Result<[u64; W]>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.next >= self.n {
            return None;
        }
        let size = 8 * W;
        if self.at + size > self.buf.len() {
            let per = (BUFFER_BYTES / size).max(1) as u64;
            let count = per.min(self.n - self.next) as usize;
            self.buf.resize(count * size, 0);
            if let Err(e) = self
                .file
                .read_exact_at(&mut self.buf, self.next * size as u64)
            {
                self.next = self.n;
                return Some(Err(spill_error("read", &e)));
            }
            self.at = 0;
        }
        let r = words(&self.buf[self.at..self.at + size]);
        self.at += size;
        self.next += 1;
        Some(Ok(r))
    }
}

/// The `k`-th smallest (from 0) of the keys that `scan` produces, for each
/// of several channels at once, in bounded memory: four passes over the
/// data, each narrowing every channel's key by 16 bits (65 536 counters a
/// channel). `scan` calls its argument with (channel, key) for every key,
/// the same keys at every call. `None` for a channel with `k` absent or
/// not more than `k` keys.
pub fn kth_smallest(
    ks: &[Option<u64>],
    mut scan: impl FnMut(&mut dyn FnMut(usize, u64)) -> io::Result<()>,
) -> io::Result<Vec<Option<u64>>> {
    let mut prefix: Vec<Option<u64>> = ks.iter().map(|k| k.map(|_| 0)).collect();
    let mut rank: Vec<u64> = ks.iter().map(|k| k.unwrap_or(0)).collect();
    for pass in 0..4u32 {
        let known = 16 * pass;
        let shift = 48 - known;
        let mut counts = vec![0u64; ks.len() << 16];
        scan(&mut |c, key| {
            let Some(Some(p)) = prefix.get(c) else {
                return;
            };
            if known == 0 || key >> (64 - known) == p >> (64 - known) {
                counts[(c << 16) | ((key >> shift) & 0xFFFF) as usize] += 1;
            }
        })?;
        for c in 0..ks.len() {
            let Some(p) = prefix[c] else { continue };
            let mut found = None;
            for (b, n) in counts[c << 16..(c + 1) << 16].iter().enumerate() {
                if rank[c] < *n {
                    found = Some(b as u64);
                    break;
                }
                rank[c] -= n;
            }
            prefix[c] = found.map(|b| p | (b << shift));
        }
    }
    Ok(prefix)
}

/// The key of `x` whose unsigned order is `f64::total_cmp`'s.
pub fn total_order_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

/// The value of a [`total_order_key`].
pub fn from_total_order_key(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: u64) -> impl FnMut() -> u64 {
        let mut s = seed;
        move || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            s ^ (s >> 29)
        }
    }

    /// Records read back bit for bit, in order, by index and with a step,
    /// across the write buffer's boundaries.
    #[test]
    fn records_read_back_bit_for_bit_in_order_by_index_and_by_step() {
        let mut s = Spill::<3>::new().expect("spill");
        let mut r = lcg(1);
        let recs: Vec<[u64; 3]> = (0..50_000).map(|_| [r(), r(), r()]).collect();
        for x in &recs {
            s.push(x).expect("push");
        }
        let s = s.seal().expect("seal");
        assert_eq!(s.len(), 50_000);
        let back: Vec<[u64; 3]> = s.iter().map(|x| x.expect("read")).collect();
        assert_eq!(back, recs);
        assert_eq!(s.get(12_345).expect("get"), recs[12_345]);
        for step in [1, 3, 16, 17, 9_999, 60_000] {
            let picked = s.every(step).expect("every");
            let want: Vec<[f64; 3]> = recs
                .iter()
                .step_by(step as usize)
                .map(|x| x.map(f64::from_bits))
                .collect();
            assert_eq!(
                picked
                    .iter()
                    .map(|x| x.map(f64::to_bits))
                    .collect::<Vec<_>>(),
                want.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>(),
                "step {step}"
            );
        }
        let empty = Spill::<2>::new().expect("spill").seal().expect("seal");
        assert!(empty.is_empty() && empty.iter().next().is_none());
    }

    /// The k-th smallest of each channel equals the sorted values' k-th,
    /// for values spread over the whole f64 range (NaN and ±∞ and ±0
    /// included, in `total_cmp` order) and for many repeats of few values.
    #[test]
    fn kth_smallest_equals_the_sorted_values() {
        let mut r = lcg(7);
        let wide: Vec<f64> = (0..20_000)
            .map(|i| match i % 97 {
                0 => f64::NAN,
                1 => f64::INFINITY,
                2 => f64::NEG_INFINITY,
                3 => -0.0,
                4 => 0.0,
                _ => f64::from_bits(r()),
            })
            .collect();
        let few: Vec<f64> = (0..20_000).map(|i| [0.005, 0.01, 0.0051][i % 3]).collect();
        let chans = [&wide, &few];
        let mut sorted: Vec<Vec<f64>> = chans.iter().map(|v| v.to_vec()).collect();
        for v in &mut sorted {
            v.sort_by(f64::total_cmp);
        }
        for k in [0u64, 1, 9_999, 10_000, 19_999] {
            let got = kth_smallest(&[Some(k), Some(k)], |f| {
                for (c, v) in chans.iter().enumerate() {
                    for x in v.iter() {
                        f(c, total_order_key(*x));
                    }
                }
                Ok(())
            })
            .expect("select");
            for c in 0..2 {
                let v = from_total_order_key(got[c].expect("present"));
                assert_eq!(
                    v.to_bits(),
                    sorted[c][k as usize].to_bits(),
                    "channel {c} k {k}"
                );
            }
        }
        let none = kth_smallest(&[Some(20_000), None], |f| {
            for x in &few {
                f(0, total_order_key(*x));
            }
            Ok(())
        })
        .expect("select");
        assert_eq!(none, [None, None]);
    }
}
