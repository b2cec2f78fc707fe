//! Fixed-interval smoother: the Rauch–Tung–Striebel backward pass over the
//! forward filter's own record, for the flight-test reference trajectory.
//!
//! **Why RTS and not a forward–backward (two-filter) combination.** The
//! backward filter of a two-filter smoother needs a second, independent
//! navigation solution run backward in time: a reverse mechanization, its
//! own frame switches at the pole and an information-form start with no
//! prior. RTS needs nothing the forward filter has not already computed: per
//! covariance interval its P before and after propagation and the
//! transition Φ, and per update the correction fed back. Its backward pass
//! is linear algebra on 15×15 matrices per covariance interval (not per IMU
//! sample), and a frame switch is one more transition (Φ of papers/001 eqs
//! 30–38, no noise), so the backward pass carries the error state and
//! covariance through exactly the forward pass's parameter conversion.
//!
//! **The record (tape).** The navigator appends, in the order they happen:
//! - a propagation: the nominal state, mean specific force, interval and
//!   process noise it used, and P before it; Φ and P after are recomputed
//!   here with the same functions, bit for bit (a third of the bytes of
//!   storing them);
//! - a frame conversion: the state before it, the new frame and P before;
//! - an addition to P alone (the covariance of a coasted gap): P before and
//!   after, Φ = I;
//! - an update: the correction δx fed back into the nominal state;
//! - a break, where no information may flow back (a re-initialization, a
//!   reset to an aid, a covariance repair, a time re-synchronization, the
//!   end): P there;
//! - each solution emitted: its time, sequence, flags, counts and reset
//!   record, and the nominal state and bias estimates it was built from
//!   (the backward pass rebuilds it with the same function, bit for bit
//!   where nothing is learned).
//!
//! **The backward pass.** With closed-loop feedback the forward error
//! estimate is zero after every update, so the smoothed error of the state
//! before an update at k is that after it plus the correction (e⁻ = e⁺ +
//! δx), and across a transition e_k = C e_{k+1}⁻, P^s_k = P_k + C (P^s_{k+1}
//! − P_{k+1}⁻) Cᵀ with C = P_k Φᵀ (P_{k+1}⁻)⁻¹, formed through a Cholesky
//! factor of P⁻ scaled to unit diagonal. A solution between two
//! propagations takes e interpolated linearly in time between the ends of
//! its interval and the P^s of the interval's start (the forward solution
//! there reports the unpropagated P as well). Each smoothed solution is the
//! forward nominal corrected by e, the way the filter feeds a correction
//! back, with σ from P^s. Where nothing can be learned (after the last
//! update, before a break) the forward solution is passed through as it is.
//! A step whose algebra fails (P⁻ not positive definite, a non-finite or
//! non-positive result) becomes a break and is counted.
//!
//! **Memory.** The tape is kept in chunks of [`CHUNK_BYTES`]; the first
//! [`MEMORY_BYTES`] of them stay in memory, the later ones go to a
//! [`ChunkStore`] (an unnamed temporary file in `batch`).
//! The backward pass runs over the chunks from the last to the first,
//! keeping the backward state at each chunk boundary and, up to
//! [`CACHE_BYTES`], the state after each transition; then once per chunk
//! in time order from its boundary state (on a second thread, a chunk
//! ahead of the writing, without the algebra where the first pass kept
//! its result) to produce that chunk's smoothed solutions in time order:
//! peak memory is about [`MEMORY_BYTES`] + [`CACHE_BYTES`] + three chunks
//! and their solutions, whatever the flight's length (861 MB measured on
//! 30 h at 200 Hz, `cargo bench -p polarnav-tests --bench smoother`). The
//! tape takes about 1.2 KB per covariance interval and 0.25 KB per
//! solution: at 200 Hz with a 0.1 s interval about 0.23 GB per flight hour
//! (measured: 223 MB for 1 h of transpolar.toml), so a 30 h flight puts
//! about 6.5 GB in the temporary file.

use std::io::{Read, Seek, SeekFrom, Write};

use msgs::Solution;
use nalgebra::{SVector, UnitQuaternion, Vector3};

use crate::earth::Geodetic;
use crate::error_model::{Mat15, idx};
use crate::filter::{self, ProcessNoise};
use crate::mech::{AnyNav, FrameKind, Nav, Nominal};
use crate::navigator::report::navigation_solution;
use crate::navigator::tape::tag;

/// Bytes of tape held in memory before a chunk goes to the store (16 MiB:
/// about 20 s of a 200 Hz flight).
pub const CHUNK_BYTES: usize = 16 << 20;
/// Bytes of tape kept in memory before chunks go to the store (384 MiB:
/// about 1.2 h of a 200 Hz flight; with [`CACHE_BYTES`] a flight of any
/// length then peaks under 1 GB).
pub const MEMORY_BYTES: usize = 384 << 20;

type Vec15 = SVector<f64, 15>;

/// A solution's record: its non-navigation fields and what it was built from.
#[derive(Debug, Clone, Copy)]
struct SolutionRecord {
    meta: Solution,
    nav: AnyNav,
    gyro_bias: Vector3<f64>,
    accel_bias: Vector3<f64>,
}

/// One record read back.
enum Record {
    Propagate {
        t_b: f64,
        t_a: f64,
        phi: Mat15,
        p_b: Mat15,
        p_a: Mat15,
    },
    Convert {
        phi: Mat15,
        p_b: Mat15,
        p_a: Mat15,
    },
    Add {
        p_b: Mat15,
        p_a: Mat15,
    },
    Update(Vec15),
    Break(Mat15),
    Solution(SolutionRecord),
}

struct Cursor<'a> {
    b: &'a [u8],
}

impl Cursor<'_> {
    fn f64(&mut self) -> Option<f64> {
        let (x, rest) = self.b.split_first_chunk::<8>()?;
        self.b = rest;
        Some(f64::from_le_bytes(*x))
    }
    fn sym(&mut self) -> Option<Mat15> {
        let mut p = Mat15::zeros();
        for i in 0..15 {
            for j in i..15 {
                let x = self.f64()?;
                p[(i, j)] = x;
                p[(j, i)] = x;
            }
        }
        Some(p)
    }
    fn nav(&mut self) -> Option<AnyNav> {
        let mut a = [0.0; 11];
        for x in &mut a {
            *x = self.f64()?;
        }
        let q = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(a[1], a[2], a[3], a[4]));
        let v_n = Vector3::new(a[5], a[6], a[7]);
        Some(if a[0] == 0.0 {
            AnyNav::Geographic(Nav {
                q_b_n: q,
                v_n,
                pos: Geodetic::new(a[8], a[9], a[10]),
            })
        } else {
            AnyNav::Grid(Nav {
                q_b_n: q,
                v_n,
                pos: Vector3::new(a[8], a[9], a[10]),
            })
        })
    }
}

/// The tag of the record ending at `end` of `buf`, where it starts and
/// where its payload ends.
fn frame_back(buf: &[u8], end: usize) -> Option<(u8, usize, usize)> {
    let t = *buf.get(end.checked_sub(1)?)?;
    let len_at = end.checked_sub(5)?;
    let len = u32::from_le_bytes(buf.get(len_at..len_at + 4)?.try_into().ok()?) as usize;
    Some((t, len_at.checked_sub(len)?, len_at))
}

/// The interval of a propagation record (None for the other transitions),
/// read without recomputing anything.
fn span_of(buf: &[u8], start: usize, t: u8) -> Option<Option<(f64, f64)>> {
    if t != tag::PROPAGATE {
        return Some(None);
    }
    let mut c = Cursor {
        b: buf.get(start..)?,
    };
    Some(Some((c.f64()?, c.f64()?)))
}

/// The record ending at `end` of `buf` and where it starts; None if the
/// tape is damaged (which only a defect here could cause).
fn read_back(buf: &[u8], end: usize) -> Option<(Record, usize)> {
    let (t, start, len_at) = frame_back(buf, end)?;
    let mut c = Cursor {
        b: &buf[start..len_at],
    };
    let rec = match t {
        tag::PROPAGATE => {
            let (t_b, t_a, dt) = (c.f64()?, c.f64()?, c.f64()?);
            let f_b = Vector3::new(c.f64()?, c.f64()?, c.f64()?);
            let nav = c.nav()?;
            let noise = ProcessNoise {
                arw: c.f64()?,
                vrw: c.f64()?,
                gyro_bias_sigma: c.f64()?,
                gyro_bias_tau_s: c.f64()?,
                accel_bias_sigma: c.f64()?,
                accel_bias_tau_s: c.f64()?,
            };
            let p_b = c.sym()?;
            // The same F, Φ and P⁻ as the forward propagation computed.
            let mut f = nav.error_dynamics(&f_b);
            noise.add_bias_dynamics(&mut f);
            let mut p_a = p_b;
            let phi = filter::propagate(&mut p_a, &f, &noise, dt);
            Record::Propagate {
                t_b,
                t_a,
                phi,
                p_b,
                p_a,
            }
        }
        tag::CONVERT => {
            let to = if c.f64()? == 0.0 {
                FrameKind::Geographic
            } else {
                FrameKind::Grid
            };
            let before = c.nav()?;
            let p_b = c.sym()?;
            let phi = crate::navigator::phi_to(to, &before);
            let mut p_a = phi * p_b * phi.transpose();
            filter::symmetrize(&mut p_a);
            Record::Convert { phi, p_b, p_a }
        }
        tag::ADD => Record::Add {
            p_b: c.sym()?,
            p_a: c.sym()?,
        },
        tag::UPDATE => {
            let mut dx = Vec15::zeros();
            for x in dx.iter_mut() {
                *x = c.f64()?;
            }
            Record::Update(dx)
        }
        tag::BREAK => Record::Break(c.sym()?),
        tag::SOLUTION => {
            let mut a = [0.0; 13];
            for x in &mut a {
                *x = c.f64()?;
            }
            let meta = Solution {
                t_ns: a[0].to_bits(),
                seq: a[1].to_bits(),
                reset_t_ns: a[2].to_bits(),
                flags: a[3] as u32,
                switch_count: a[4] as u32,
                reset_count: a[5] as u32,
                reset_delta_heading_rad: a[6],
                reset_delta_pos_e_m: [a[7], a[8], a[9]],
                reset_delta_vel_e_mps: [a[10], a[11], a[12]],
                ..Default::default()
            };
            let nav = c.nav()?;
            let gyro_bias = Vector3::new(c.f64()?, c.f64()?, c.f64()?);
            let accel_bias = Vector3::new(c.f64()?, c.f64()?, c.f64()?);
            Record::Solution(SolutionRecord {
                meta,
                nav,
                gyro_bias,
                accel_bias,
            })
        }
        _ => return None,
    };
    Some((rec, start))
}

/// Where the chunks of the tape that are not the newest are kept.
pub trait ChunkStore {
    /// Keeps chunk number `k` (chunks arrive in order 0, 1, 2, ...).
    fn put(&mut self, k: usize, bytes: &[u8]) -> std::io::Result<()>;
    /// Reads chunk `k` back into `buf` (cleared first).
    fn get(&mut self, k: usize, buf: &mut Vec<u8>) -> std::io::Result<()>;
}

/// Chunks kept in memory (tests, short logs).
#[derive(Debug, Default)]
pub struct MemoryStore(Vec<Vec<u8>>);

impl ChunkStore for MemoryStore {
    fn put(&mut self, k: usize, bytes: &[u8]) -> std::io::Result<()> {
        debug_assert_eq!(k, self.0.len());
        self.0.push(bytes.to_vec());
        Ok(())
    }
    fn get(&mut self, k: usize, buf: &mut Vec<u8>) -> std::io::Result<()> {
        buf.clear();
        buf.extend_from_slice(&self.0[k]);
        Ok(())
    }
}

/// Chunks kept in an unnamed temporary file: created in `dir` and removed
/// from it at once, so that nothing is left behind however the process ends.
#[derive(Debug)]
pub struct FileStore {
    file: std::fs::File,
    /// (offset, length) of each chunk.
    chunks: Vec<(u64, usize)>,
    end: u64,
}

impl FileStore {
    pub fn new_in(dir: &std::path::Path) -> std::io::Result<Self> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        let path = dir.join(format!(
            ".polarnav-smoother-{}-{nanos}.tape",
            std::process::id()
        ));
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create_new(true)
            .open(&path)?;
        std::fs::remove_file(&path)?;
        Ok(Self {
            file,
            chunks: Vec::new(),
            end: 0,
        })
    }

    /// Bytes written to the file so far.
    pub fn bytes(&self) -> u64 {
        self.end
    }
}

impl ChunkStore for FileStore {
    fn put(&mut self, k: usize, bytes: &[u8]) -> std::io::Result<()> {
        debug_assert_eq!(k, self.chunks.len());
        self.file.seek(SeekFrom::Start(self.end))?;
        self.file.write_all(bytes)?;
        self.chunks.push((self.end, bytes.len()));
        self.end += bytes.len() as u64;
        Ok(())
    }
    fn get(&mut self, k: usize, buf: &mut Vec<u8>) -> std::io::Result<()> {
        let (off, len) = self.chunks[k];
        buf.clear();
        buf.resize(len, 0);
        self.file.seek(SeekFrom::Start(off))?;
        self.file.read_exact(buf)
    }
}

/// What a smoothing run did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SmoothReport {
    /// Solutions written.
    pub solutions: u64,
    /// Of them, passed through as the forward ones (nothing to learn).
    pub passed_through: u64,
    /// Backward steps whose algebra failed and became breaks.
    pub failed_steps: u64,
    /// Tape bytes, and chunks of it that went to the store.
    pub tape_bytes: u64,
    pub stored_chunks: usize,
}

/// The backward state after one transition record (e, the upper triangle
/// of P^s), kept from the first pass for the second.
#[derive(Debug, Clone, Copy)]
struct Cached {
    e: Vec15,
    ps: [f64; 120],
    learned: bool,
}

/// Bytes of first-pass results kept for the second pass (256 MiB: about
/// 2.5 flight hours at 200 Hz, whose second pass then does no algebra).
pub const CACHE_BYTES: usize = 256 << 20;

/// The backward state at one place of the tape.
#[derive(Debug, Clone)]
struct Back {
    /// Smoothed error of the nominal state here and its covariance.
    e: Vec15,
    ps: Mat15,
    /// False where nothing has been learned (after the last update, before
    /// a break): forward solutions pass through.
    learned: bool,
    /// The propagation just behind (in time order: the interval ending
    /// where the tape now stands): its times and smoothed errors at both
    /// ends, for the solutions inside it.
    span: Option<(f64, f64, Vec15, Vec15)>,
    failed: u64,
}

impl Back {
    fn new() -> Self {
        Self {
            e: Vec15::zeros(),
            ps: Mat15::zeros(),
            learned: false,
            span: None,
            failed: 0,
        }
    }

    /// One record, backward. A solution gives its smoothed version (or
    /// itself, passed through).
    fn step(&mut self, rec: Record) -> Option<(Solution, bool)> {
        match rec {
            Record::Solution(s) => {
                if !self.learned {
                    return Some((solution_of(&s, &Vec15::zeros(), &self.ps), true));
                }
                let e = match self.span {
                    Some((t_b, t_a, e_b, e_a)) if t_a > t_b => {
                        let a = ((s.meta.t_ns as f64 - t_b) / (t_a - t_b)).clamp(0.0, 1.0);
                        e_b + (e_a - e_b) * a
                    }
                    _ => self.e,
                };
                Some((solution_of(&s, &e, &self.ps), false))
            }
            Record::Update(dx) => {
                if !self.learned {
                    self.e = Vec15::zeros();
                    self.learned = true;
                }
                self.e += dx;
                self.span = None;
                None
            }
            Record::Break(p) => {
                self.e = Vec15::zeros();
                self.ps = p;
                self.learned = false;
                self.span = None;
                None
            }
            Record::Propagate {
                t_b,
                t_a,
                phi,
                p_b,
                p_a,
            } => {
                let e_a = self.e;
                self.transition(&phi, &p_b, &p_a);
                self.span = Some((t_b, t_a, self.e, e_a));
                None
            }
            Record::Convert { phi, p_b, p_a } => {
                self.transition(&phi, &p_b, &p_a);
                self.span = None;
                None
            }
            Record::Add { p_b, p_a } => {
                self.transition(&Mat15::identity(), &p_b, &p_a);
                self.span = None;
                None
            }
        }
    }

    /// The state a transition step left, to be applied again in the second
    /// pass without the algebra.
    fn after_transition(&self) -> Cached {
        let mut ps = [0.0; 120];
        let mut k = 0;
        for i in 0..15 {
            for j in i..15 {
                ps[k] = self.ps[(i, j)];
                k += 1;
            }
        }
        Cached {
            e: self.e,
            ps,
            learned: self.learned,
        }
    }

    /// One transition record, backward, with its result from the first pass.
    fn step_cached(&mut self, span: Option<(f64, f64)>, c: &Cached) {
        let e_a = self.e;
        self.e = c.e;
        let mut k = 0;
        for i in 0..15 {
            for j in i..15 {
                self.ps[(i, j)] = c.ps[k];
                self.ps[(j, i)] = c.ps[k];
                k += 1;
            }
        }
        self.learned = c.learned;
        self.span = span.map(|(t_b, t_a)| (t_b, t_a, self.e, e_a));
    }

    /// e ← C e, P^s ← P_b + C (P^s − P_a) Cᵀ with C = P_b Φᵀ P_a⁻¹.
    fn transition(&mut self, phi: &Mat15, p_b: &Mat15, p_a: &Mat15) {
        if !self.learned {
            self.e = Vec15::zeros();
            self.ps = *p_b;
            return;
        }
        match rts_step(phi, p_b, p_a, &self.e, &self.ps) {
            Some((e, ps)) => {
                self.e = e;
                self.ps = ps;
            }
            None => {
                self.failed += 1;
                self.e = Vec15::zeros();
                self.ps = *p_b;
                self.learned = false;
            }
        }
    }
}

/// One RTS step; None when P_a is not positive definite or the result is
/// not finite with positive variances.
fn rts_step(
    phi: &Mat15,
    p_b: &Mat15,
    p_a: &Mat15,
    e_a: &Vec15,
    ps_a: &Mat15,
) -> Option<(Vec15, Mat15)> {
    // P_a scaled to unit diagonal (D P_a D), so that states in rad² and in
    // m² weigh alike in the factorization.
    let mut d = Vec15::zeros();
    for i in 0..15 {
        let v = p_a[(i, i)];
        if !(v.is_finite() && v > 0.0) {
            return None;
        }
        d[i] = 1.0 / v.sqrt();
    }
    let scaled = Mat15::from_fn(|i, j| p_a[(i, j)] * d[i] * d[j]);
    let chol = scaled.cholesky()?;
    // Cᵀ = P_a⁻¹ Φ P_b = D (D P_a D)⁻¹ D Φ P_b.
    let mut m = phi * p_b;
    for i in 0..15 {
        m.row_mut(i).scale_mut(d[i]);
    }
    let mut ct = chol.solve(&m);
    for i in 0..15 {
        ct.row_mut(i).scale_mut(d[i]);
    }
    let c = ct.transpose();
    let e = c * e_a;
    let mut ps = p_b + c * (ps_a - p_a) * ct;
    filter::symmetrize(&mut ps);
    let sound = e.iter().all(|x| x.is_finite())
        && ps.iter().all(|x| x.is_finite())
        && (0..15).all(|i| ps[(i, i)] > 0.0);
    sound.then_some((e, ps))
}

/// The solution of record `r` corrected by the smoothed error `e` (zero:
/// the forward solution, rebuilt bit for bit), with σ from `ps`: the
/// nominal state corrected as the filter feeds a correction back, and
/// built by the function that built the forward one.
fn solution_of(r: &SolutionRecord, e: &Vec15, ps: &Mat15) -> Solution {
    let mut nav = r.nav;
    let part = |o: usize| Vector3::new(e[o], e[o + 1], e[o + 2]);
    let (mut gb, mut ab) = (r.gyro_bias, r.accel_bias);
    if e.iter().any(|x| *x != 0.0) {
        nav.correct(&part(idx::PHI), &part(idx::DV), &part(idx::DP));
        gb += part(idx::BG);
        ab += part(idx::BA);
    }
    let mut s = navigation_solution(&Nominal::new(nav), ps, &gb, &ab);
    let m = &r.meta;
    s.t_ns = m.t_ns;
    s.seq = m.seq;
    s.reset_t_ns = m.reset_t_ns;
    s.reset_delta_pos_e_m = m.reset_delta_pos_e_m;
    s.reset_delta_vel_e_mps = m.reset_delta_vel_e_mps;
    s.reset_delta_heading_rad = m.reset_delta_heading_rad;
    s.flags = m.flags;
    s.switch_count = m.switch_count;
    s.reset_count = m.reset_count;
    s
}

/// Where a complete chunk of the tape is.
#[derive(Debug, Clone, Copy)]
enum Place {
    Memory(usize),
    Store(usize),
}

/// Collects the forward run's tape, then writes the smoothed solutions in
/// time order.
#[derive(Debug)]
pub struct Smoother<S: ChunkStore> {
    newest: Vec<u8>,
    memory: Vec<Vec<u8>>,
    places: Vec<Place>,
    store: S,
    stored: usize,
    bytes: u64,
    chunk_bytes: usize,
    memory_bytes: usize,
    cache_bytes: usize,
    error: Option<std::io::Error>,
}

impl<S: ChunkStore> Smoother<S> {
    /// Chunks of [`CHUNK_BYTES`], the first [`MEMORY_BYTES`] of them kept in
    /// memory and the rest in `store`, and [`CACHE_BYTES`] of first-pass
    /// results.
    pub fn new(store: S) -> Self {
        Self::with_limits(store, CHUNK_BYTES, MEMORY_BYTES, CACHE_BYTES)
    }

    /// With chunks of `chunk_bytes`, up to `memory_bytes` of them in memory
    /// and `cache_bytes` of first-pass results (tests use small ones to
    /// exercise the store and the second pass's algebra).
    pub fn with_limits(
        store: S,
        chunk_bytes: usize,
        memory_bytes: usize,
        cache_bytes: usize,
    ) -> Self {
        Self {
            newest: Vec::new(),
            memory: Vec::new(),
            places: Vec::new(),
            store,
            stored: 0,
            bytes: 0,
            chunk_bytes: chunk_bytes.max(1),
            memory_bytes,
            cache_bytes,
            error: None,
        }
    }

    /// The filter's records since the last call (whole records, in order).
    /// After a chunk could not be stored ([`Self::failed`]) nothing more is
    /// kept: the backward pass cannot run, and a tape growing in memory
    /// instead of the full disk would end a long flight out of memory.
    pub fn records(&mut self, bytes: &[u8]) {
        if self.error.is_some() {
            return;
        }
        if self.newest.capacity() == 0 {
            // One allocation per chunk (records arrive a few hundred bytes
            // at a time; doubling would copy each chunk twice on average).
            self.newest.reserve(
                self.chunk_bytes.min(CHUNK_BYTES) + (self.chunk_bytes.min(CHUNK_BYTES) >> 4),
            );
        }
        self.newest.extend_from_slice(bytes);
        self.bytes += bytes.len() as u64;
        if self.newest.len() < self.chunk_bytes {
            return;
        }
        let in_memory = self.memory.len() * self.chunk_bytes;
        if in_memory + self.newest.len() <= self.memory_bytes {
            self.places.push(Place::Memory(self.memory.len()));
            let next = Vec::with_capacity(self.chunk_bytes + (self.chunk_bytes >> 4));
            self.memory.push(std::mem::replace(&mut self.newest, next));
            return;
        }
        match self.store.put(self.stored, &self.newest) {
            Ok(()) => {
                self.places.push(Place::Store(self.stored));
                self.stored += 1;
                self.newest.clear();
            }
            Err(e) => self.error = Some(e),
        }
    }

    /// The failure to store a chunk of the tape, if one happened: the
    /// smoother keeps nothing more and [`Self::finish`] returns it, so a
    /// driver can stop the forward pass at once instead of at its end.
    pub fn failed(&self) -> Option<&std::io::Error> {
        self.error.as_ref()
    }

    /// The backward pass: `out` receives every smoothed solution in time
    /// order (one per forward solution).
    pub fn finish(
        mut self,
        mut out: impl FnMut(&Solution) -> std::io::Result<()>,
    ) -> std::io::Result<SmoothReport>
    where
        S: Send,
    {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        let n = self.places.len() + 1;
        let damaged = || std::io::Error::other("smoother tape damaged (a defect: please report)");
        // Pass 1, last chunk to first: the backward state where each chunk
        // ends, and the state after each transition while the cache lasts.
        let mut entry = vec![Back::new(); n];
        let mut cache: Vec<Option<Vec<Cached>>> = vec![None; n];
        let mut cache_left = self.cache_bytes / size_of::<Cached>();
        let mut back = Back::new();
        let mut buf = Vec::new();
        for k in (0..n).rev() {
            entry[k] = back.clone();
            let chunk = self.chunk(k, &mut buf)?;
            let mut kept = Vec::new();
            let mut end = chunk.len();
            while end > 0 {
                let (t, start, _) = frame_back(chunk, end).ok_or_else(damaged)?;
                if t != tag::SOLUTION {
                    let (rec, _) = read_back(chunk, end).ok_or_else(damaged)?;
                    let transition = matches!(
                        rec,
                        Record::Propagate { .. } | Record::Convert { .. } | Record::Add { .. }
                    );
                    back.step(rec);
                    if transition && cache_left > 0 {
                        kept.push(back.after_transition());
                        cache_left -= 1;
                    }
                }
                end = start;
            }
            // A chunk is cached whole or not at all.
            if cache_left > 0 {
                cache[k] = Some(kept);
            }
        }
        let failed = back.failed;
        // Pass 2, first chunk to last: each chunk's solutions from its entry
        // state, computed on a second thread one chunk ahead of the writing.
        let mut report = SmoothReport {
            tape_bytes: self.bytes,
            stored_chunks: self.stored,
            ..Default::default()
        };
        let passed = std::thread::scope(|scope| -> std::io::Result<u64> {
            let (tx, rx) = std::sync::mpsc::sync_channel::<std::io::Result<Vec<Solution>>>(1);
            let this = &mut self;
            let worker = scope.spawn(move || {
                let mut passed = 0;
                let mut buf = Vec::new();
                for ((k, mut back), kept) in entry.into_iter().enumerate().zip(cache) {
                    let mut smoothed = Vec::new();
                    let result = this.chunk(k, &mut buf).and_then(|chunk| {
                        let mut kept = kept.as_deref().map(<[Cached]>::iter);
                        let mut end = chunk.len();
                        while end > 0 {
                            let (t, start, _) = frame_back(chunk, end).ok_or_else(damaged)?;
                            let transition = matches!(t, tag::PROPAGATE | tag::CONVERT | tag::ADD);
                            if let (true, Some(it)) = (transition, kept.as_mut()) {
                                let c = it.next().ok_or_else(damaged)?;
                                back.step_cached(span_of(chunk, start, t).ok_or_else(damaged)?, c);
                            } else {
                                let (rec, _) = read_back(chunk, end).ok_or_else(damaged)?;
                                if let Some((s, through)) = back.step(rec) {
                                    passed += u64::from(through);
                                    smoothed.push(s);
                                }
                            }
                            end = start;
                        }
                        smoothed.reverse();
                        Ok(smoothed)
                    });
                    let stop = result.is_err();
                    // The writer stopped (an output error): nothing more to do.
                    if tx.send(result).is_err() || stop {
                        break;
                    }
                }
                passed
            });
            for chunk in rx.iter() {
                for s in &chunk? {
                    out(s)?;
                    report.solutions += 1;
                }
            }
            Ok(worker
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p)))
        })?;
        report.failed_steps = failed;
        report.passed_through = passed;
        Ok(report)
    }

    /// Chunk `k`: the newest, one kept in memory, or one from the store.
    fn chunk<'a>(&'a mut self, k: usize, buf: &'a mut Vec<u8>) -> std::io::Result<&'a [u8]> {
        match self.places.get(k) {
            None => Ok(&self.newest),
            Some(Place::Memory(i)) => Ok(&self.memory[*i]),
            Some(Place::Store(i)) => {
                self.store.get(*i, buf)?;
                Ok(buf)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector, SMatrix};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_spd(rng: &mut ChaCha8Rng, scale: &[f64; 15]) -> Mat15 {
        let a = Mat15::from_fn(|_, _| rng.gen_range(-1.0..1.0));
        let mut p = a * a.transpose() * 0.1 + Mat15::identity();
        for i in 0..15 {
            for j in 0..15 {
                p[(i, j)] *= scale[i] * scale[j];
            }
        }
        p
    }

    /// A store that fails every write (a full disk).
    struct FullDisk;
    impl ChunkStore for FullDisk {
        fn put(&mut self, _k: usize, _bytes: &[u8]) -> std::io::Result<()> {
            Err(std::io::Error::from(std::io::ErrorKind::StorageFull))
        }
        fn get(&mut self, _k: usize, _buf: &mut Vec<u8>) -> std::io::Result<()> {
            Err(std::io::Error::other("nothing was stored"))
        }
    }

    /// When a chunk cannot be stored, the smoother says so at once and
    /// keeps nothing more: 100 MB of tape offered after the failure leave
    /// less than a chunk in memory (they all stayed there before), and the
    /// backward pass returns the store's error.
    #[test]
    fn a_full_disk_is_reported_at_once_and_the_tape_stops_growing() {
        let chunk = 64 << 10;
        let mut sm = Smoother::with_limits(FullDisk, chunk, 0, 0);
        let piece = vec![0u8; 4096];
        let mut first_failure = None;
        for k in 0..(100_000_000 / piece.len()) {
            sm.records(&piece);
            if first_failure.is_none() && sm.failed().is_some() {
                first_failure = Some(k);
            }
        }
        assert_eq!(first_failure, Some(chunk / piece.len() - 1));
        assert_eq!(
            sm.failed().map(std::io::Error::kind),
            Some(std::io::ErrorKind::StorageFull)
        );
        assert!(sm.newest.len() <= chunk, "{} bytes kept", sm.newest.len());
        let e = sm.finish(|_| Ok(())).expect_err("no backward pass");
        assert_eq!(e.kind(), std::io::ErrorKind::StorageFull);
    }

    /// The backward pass over a closed-loop filter's tape on a linear
    /// Gaussian system (random Φ, Q, H, R; states scaled from 1e-5 to 1e3
    /// as rad and m are) gives the smoothed states and covariances of an
    /// independent computation: the weighted least-squares solution of the
    /// whole interval at once (prior, every transition and every
    /// measurement in one normal equation), to 1e-7 of σ.
    #[test]
    fn backward_pass_equals_the_least_squares_solution_of_the_whole_interval() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let scale: [f64; 15] = std::array::from_fn(|i| 10f64.powf(-5.0 + 8.0 * i as f64 / 14.0));
        let n_steps = 6;
        let p0 = random_spd(&mut rng, &scale);
        let q = random_spd(&mut rng, &scale.map(|s| s * 0.05));
        let mut phis = Vec::new();
        for _ in 0..n_steps {
            let mut phi = Mat15::identity();
            for i in 0..15 {
                for j in 0..15 {
                    phi[(i, j)] += 0.2 * rng.gen_range(-1.0..1.0) * scale[i] / scale[j] / 15.0;
                }
            }
            phis.push(phi);
        }
        let h = SMatrix::<f64, 3, 15>::from_fn(|_, j| rng.gen_range(-1.0..1.0) / scale[j]);
        let r = SMatrix::<f64, 3, 3>::identity() * 0.3;
        let zs: Vec<SVector<f64, 3>> = (0..n_steps)
            .map(|_| SVector::<f64, 3>::from_fn(|_, _| rng.gen_range(-2.0..2.0)))
            .collect();
        let m0 = Vec15::from_fn(|i, _| rng.gen_range(-1.0..1.0) * scale[i]);

        // The closed-loop filter, writing its tape: x̂ is the nominal state,
        // the error is x̂ − x, an update feeds dx back as x̂ ← x̂ − dx.
        let mut tape = Vec::new();
        let mut x = m0;
        let mut p = p0;
        let mut filtered = vec![x];
        for k in 0..n_steps {
            let p_b = p;
            x = phis[k] * x;
            p = phis[k] * p * phis[k].transpose() + q;
            filter::symmetrize(&mut p);
            tape.push(Record::Propagate {
                t_b: k as f64,
                t_a: k as f64 + 1.0,
                phi: phis[k],
                p_b,
                p_a: p,
            });
            let y = h * x - zs[k];
            let s = h * p * h.transpose() + r;
            let k_gain = p * h.transpose() * s.try_inverse().expect("S");
            let dx = k_gain * y;
            x -= dx;
            p = (Mat15::identity() - k_gain * h) * p;
            filter::symmetrize(&mut p);
            tape.push(Record::Update(dx));
            filtered.push(x);
        }
        tape.push(Record::Break(p));

        // Backward: the smoothed state at k is x̂_k⁺ − e after the transition out of k.
        let mut back = Back::new();
        let mut smoothed = vec![(filtered[n_steps], p)];
        let mut k = n_steps;
        for rec in tape.into_iter().rev() {
            let is_prop = matches!(rec, Record::Propagate { .. });
            back.step(rec);
            if is_prop {
                k -= 1;
                smoothed.push((filtered[k] - back.e, back.ps));
            }
        }
        smoothed.reverse();
        assert_eq!(back.failed, 0);

        // Least squares over X = [x_0 … x_N].
        let n = 15 * (n_steps + 1);
        let mut j = DMatrix::<f64>::zeros(n, n);
        let mut b = DVector::<f64>::zeros(n);
        let mut add = |rows: &DMatrix<f64>, w: &DMatrix<f64>, rhs: &DVector<f64>| {
            let at_w = rows.transpose() * w;
            j += &at_w * rows;
            b += at_w * rhs;
        };
        let dm = |m: &dyn Fn(usize, usize) -> f64, r: usize, c: usize| DMatrix::from_fn(r, c, m);
        let mut a = DMatrix::<f64>::zeros(15, n);
        a.view_mut((0, 0), (15, 15))
            .copy_from(&DMatrix::identity(15, 15));
        let p0_inv = p0.try_inverse().expect("P0");
        add(
            &a,
            &dm(&|i, c| p0_inv[(i, c)], 15, 15),
            &DVector::from_column_slice(m0.as_slice()),
        );
        let q_inv = q.try_inverse().expect("Q");
        for (k, phi) in phis.iter().enumerate() {
            let mut a = DMatrix::<f64>::zeros(15, n);
            a.view_mut((0, 15 * (k + 1)), (15, 15))
                .copy_from(&DMatrix::identity(15, 15));
            let mphi = dm(&|i, c| -phi[(i, c)], 15, 15);
            a.view_mut((0, 15 * k), (15, 15)).copy_from(&mphi);
            add(&a, &dm(&|i, c| q_inv[(i, c)], 15, 15), &DVector::zeros(15));
            let mut a = DMatrix::<f64>::zeros(3, n);
            a.view_mut((0, 15 * (k + 1)), (3, 15))
                .copy_from(&dm(&|i, c| h[(i, c)], 3, 15));
            let r_inv = r.try_inverse().expect("R");
            add(
                &a,
                &dm(&|i, c| r_inv[(i, c)], 3, 3),
                &DVector::from_column_slice(zs[k].as_slice()),
            );
        }
        let cov = j.clone().try_inverse().expect("J");
        let xs = &cov * b;
        for (k, (xk, pk)) in smoothed.iter().enumerate() {
            for i in 0..15 {
                let sigma = cov[(15 * k + i, 15 * k + i)].sqrt();
                let dx = (xk[i] - xs[15 * k + i]).abs();
                assert!(
                    dx < 1e-7 * sigma,
                    "step {k} state {i}: {} vs {} (σ {sigma})",
                    xk[i],
                    xs[15 * k + i]
                );
                let ds = (pk[(i, i)].sqrt() - sigma).abs();
                assert!(
                    ds < 1e-7 * sigma,
                    "step {k} state {i}: σ {} vs {sigma}",
                    pk[(i, i)].sqrt()
                );
            }
        }
    }
}
