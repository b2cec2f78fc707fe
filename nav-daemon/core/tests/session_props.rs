//! Property tests (proptest) of the session at the input boundary.
//!
//! Every case starts from a valid init near 86° N, 18 km (t = 1 s) and a
//! stretch of plausible 200 Hz IMU samples with aids (stationary, or level
//! flight due north at 250 m/s: increments from Earth rate, transport rate
//! and gravity, not exact), then interleaves adversarial inputs of every
//! stream in adversarial orders: duplicates, reversed runs, a second
//! publisher on another time base, floods of one stream, far-future and
//! far-past stamps. Field values are log-uniform over the whole f64 range
//! plus NaN, ±Inf, subnormals and ±0; stamps log-uniform over the whole u64
//! range plus 0, 1, u64::MAX and genuine ± small/large offsets.
//!
//! After every push: (a) every solution emitted is finite, with finite
//! positive σ; (b) the accounting is exact per stream and `received` equals
//! what was pushed, and each aid reported as many updates
//! (`Event::AidUpdate`) as it counts gated samples (accepted or rejected at
//! the gate): none for a sample not used or undone as invalid; (c) the work
//! of one push is bounded; (d) the navigator state is finite. At the end: `finish`, the same checks, and a genuine
//! stream is accepted again (never blinded for more than
//! `TIME_JUMP_CONFIRM` samples). Named tests pin down specific cases,
//! including the library deviations the property found.
//!
//! Runtime (test profile, opt-level 2): about 6 s for the whole file
//! (2048 cases; measured with `SESSION_PROPS_TOLERATE_KNOWN=1`, below).
//! `SESSION_PROPS_CASES=n` changes the number of cases.

use msgs::AidKind;
use msgs::{ImuSample, InitState, Solution, StarSample};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic};
use polarnav::frames;
use polarnav::navigator::MAX_BRIDGE_STEPS;
use polarnav::session::{
    AID_QUEUE, Event, Input, MAX_AID_LEAD_NS, Session, SessionSettings, Sink, Stream,
    TIME_JUMP_CONFIRM,
};
use polarnav::smoother::{MemoryStore, Smoother};
use proptest::prelude::*;

#[path = "common/vehicle.rs"]
mod vehicle;
use vehicle::{DT_NS, DT_S, H0_M, LON0_DEG, Owned, T0_NS, Truth};

/// Most navigator work (mechanization steps + covariance propagations) one
/// push may cause, from the public constants: a push integrates at most
/// `TIME_JUMP_CONFIRM` IMU samples (the held time-jump candidates plus the
/// sample itself, after a resync or a re-initialization), each bridging a gap
/// in at most `MAX_BRIDGE_STEPS` steps plus its own step, each step with at
/// most one covariance propagation (hence × 2); the aids of the bounded
/// queue (`AID_QUEUE`) each at most one propagation; plus a few fixed
/// propagations (resync, coast, frame switch); and all that for each of
/// the session's at most two navigators (the main one and the integrity
/// test's reference, which takes the same IMU samples and every aid but
/// GNSS).
/// = 2 · (4 · 2 · 65 + 16 + 8) = 1088.
const WORK_BOUND: u64 =
    2 * (TIME_JUMP_CONFIRM as u64 * 2 * (MAX_BRIDGE_STEPS + 1) + AID_QUEUE as u64 + 8);

// ---- inputs held by value ---------------------------------------------

impl Owned {
    /// A short description for failure messages (no 8 SRS lines).
    fn describe(&self) -> String {
        match self {
            Owned::Aid(msgs::AidSample::Srs(s)) => format!(
                "Srs {{ t_ns: {}, seq: {}, count: {}, line0: {:?} }}",
                s.t_ns, s.seq, s.count, s.lines[0]
            ),
            other => format!("{other:?}"),
        }
    }
}

// ---- checks -----------------------------------------------------------

fn solution_fields(s: &Solution) -> Vec<(&'static str, f64)> {
    let mut v = vec![
        ("lat_rad", s.lat_rad),
        ("lon_rad", s.lon_rad),
        ("h_m", s.h_m),
        ("grid_angle_rad", s.grid_angle_rad),
        ("heading_rad", s.heading_rad),
        ("grid_heading_rad", s.grid_heading_rad),
        ("pitch_rad", s.pitch_rad),
        ("roll_rad", s.roll_rad),
        ("reset_delta_heading_rad", s.reset_delta_heading_rad),
    ];
    for (name, a) in [
        ("r_e_m", &s.r_e_m[..]),
        ("v_e_mps", &s.v_e_mps[..]),
        ("v_enu_mps", &s.v_enu_mps[..]),
        ("v_nav_mps", &s.v_nav_mps[..]),
        ("q_b_e", &s.q_b_e[..]),
        ("sigma_pos_enu_m", &s.sigma_pos_enu_m[..]),
        ("sigma_vel_mps", &s.sigma_vel_mps[..]),
        ("sigma_att_rad", &s.sigma_att_rad[..]),
        ("gyro_bias_rps", &s.gyro_bias_rps[..]),
        ("accel_bias_mps2", &s.accel_bias_mps2[..]),
        ("reset_delta_pos_e_m", &s.reset_delta_pos_e_m[..]),
        ("reset_delta_vel_e_mps", &s.reset_delta_vel_e_mps[..]),
    ] {
        v.extend(a.iter().map(|x| (name, *x)));
    }
    v
}

fn check_solution(s: &Solution) -> Result<(), String> {
    if let Some((name, x)) = solution_fields(s).into_iter().find(|(_, x)| !x.is_finite()) {
        return Err(format!(
            "solution at {} ns: {name} = {x} not finite",
            s.t_ns
        ));
    }
    let mut sigmas = s
        .sigma_pos_enu_m
        .iter()
        .chain(&s.sigma_vel_mps)
        .chain(&s.sigma_att_rad);
    // Finite already; not NaN, so `<= 0` is "not positive".
    if let Some(x) = sigmas.find(|x| **x <= 0.0) {
        return Err(format!(
            "solution at {} ns: σ = {x} not positive (pos {:?} vel {:?} att {:?})",
            s.t_ns, s.sigma_pos_enu_m, s.sigma_vel_mps, s.sigma_att_rad
        ));
    }
    Ok(())
}

/// A sink that checks every solution as it arrives and keeps the events;
/// with a smoother, it also keeps the tape and the solutions' times.
#[derive(Debug, Default)]
struct Checker {
    solutions: u64,
    first_bad: Option<String>,
    events: Vec<Event>,
    smoother: Option<Smoother<MemoryStore>>,
    times: Vec<u64>,
}

impl Sink for Checker {
    fn tape(&mut self, records: &[u8]) {
        if let Some(sm) = &mut self.smoother {
            sm.records(records);
        }
    }
    fn solution(&mut self, s: &Solution) {
        if self.smoother.is_some() {
            self.times.push(s.t_ns);
        }
        self.solutions += 1;
        if self.first_bad.is_none()
            && let Err(e) = check_solution(s)
        {
            self.first_bad = Some(e);
        }
    }
    fn event(&mut self, e: &Event) {
        self.events.push(*e);
    }
}

#[derive(Debug)]
struct Harness {
    session: Session,
    sink: Checker,
    truth: Truth,
    /// Inputs pushed per stream (`Stream::index`).
    pushed: [u64; msgs::STREAM_COUNT],
    inits: u64,
    /// Newest genuine IMU time and the count of genuine samples.
    t_gen: u64,
    /// Genuine stamps are `t_gen + stamp_offset` (nonzero once the genuine
    /// stream continues on a time base the navigator moved to).
    stamp_offset: u64,
    k_gen: u64,
    last: Option<Owned>,
    max_work_step: u64,
    /// Accept aid `received` counts up to `AID_QUEUE` short of what was
    /// pushed before `finish` (aids waiting in the queue: see
    /// `queued_aid_is_counted_as_received`).
    tolerate_queue: bool,
    pushes: u64,
}

impl Harness {
    /// A session started from a genuine init at `T0_NS`.
    fn new(truth: Truth) -> Self {
        Self::with_settings(truth, SessionSettings::default())
    }

    /// The same with `settings`.
    fn with_settings(truth: Truth, settings: SessionSettings) -> Self {
        let mut h = Self {
            session: Session::new(settings),
            sink: Checker::default(),
            truth,
            pushed: [0; msgs::STREAM_COUNT],
            inits: 0,
            t_gen: T0_NS,
            stamp_offset: 0,
            k_gen: 0,
            last: None,
            max_work_step: 0,
            tolerate_queue: tolerate_known(),
            pushes: 0,
        };
        h.push(Owned::Init(truth.init(T0_NS, 0)))
            .expect("a genuine init is accepted");
        h
    }

    fn push(&mut self, o: Owned) -> Result<(), String> {
        let before = self.session.work();
        self.session.push(o.input(), &mut self.sink);
        self.pushes += 1;
        match o {
            Owned::Imu(_) => self.pushed[0] += 1,
            Owned::Aid(a) => self.pushed[Stream::Aid(a.kind()).index()] += 1,
            Owned::Init(_) => self.inits += 1,
        }
        self.last = Some(o);
        let after = self.session.work();
        self.check(after.saturating_sub(before), false)
            .map_err(|e| format!("after push #{} {}: {e}", self.pushes, o.describe()))
    }

    /// (a)-(d); `finished`: every held input is accounted for.
    fn check(&mut self, work_step: u64, finished: bool) -> Result<(), String> {
        // (a)
        if let Some(bad) = &self.sink.first_bad {
            return Err(format!("(a) {bad}"));
        }
        // (b)
        let st = self.session.status();
        for ((name, c), n) in Stream::ALL
            .map(|k| (k.name(), *st.counters(k)))
            .iter()
            .zip(self.pushed)
        {
            let sum = c.accepted
                + c.rejected_invalid
                + c.rejected_time
                + c.rejected_gate
                + c.rejected_integrity
                + c.not_used;
            if c.received != sum {
                return Err(format!(
                    "(b) {name}: received {} != accepted + rejected + not_used = {sum} ({c:?})",
                    c.received
                ));
            }
            let queued_tolerance = if self.tolerate_queue && *name != "imu" && !finished {
                AID_QUEUE as u64
            } else {
                0
            };
            if c.received > n || c.received + queued_tolerance < n {
                return Err(format!(
                    "(b) {name}: received {} but {n} pushed ({c:?})",
                    c.received
                ));
            }
        }
        for (stream, c) in AidKind::ALL.map(|k| (Stream::Aid(k), *st.aid_counters(k))) {
            let reported = self
                .sink
                .events
                .iter()
                .filter(|e| matches!(e, Event::AidUpdate { stream: s, .. } if *s == stream))
                .count() as u64;
            if reported != c.accepted + c.rejected_gate {
                return Err(format!(
                    "(b) {stream:?}: {reported} updates reported, {} gated ({c:?})",
                    c.accepted + c.rejected_gate
                ));
            }
        }
        let ic = self.session.init_counters();
        let decided = ic.used + ic.rejected + ic.not_used;
        if ic.received != self.inits
            || decided > ic.received
            || (finished && decided != ic.received)
        {
            return Err(format!("(b) inits: {ic:?}, {} pushed", self.inits));
        }
        // (c)
        self.max_work_step = self.max_work_step.max(work_step);
        if work_step > WORK_BOUND {
            return Err(format!(
                "(c) one push did {work_step} work units > {WORK_BOUND}"
            ));
        }
        // (d)
        if let Some(n) = self.session.navigator() {
            let ff = n.state().frame_free();
            let finite = ff
                .r_e
                .iter()
                .chain(ff.v_e.iter())
                .chain(ff.q_b_e.coords.iter())
                .all(|x| x.is_finite());
            if !finite {
                return Err(format!(
                    "(d) navigator state not finite: r_e {:?} v_e {:?} q {:?}",
                    ff.r_e, ff.v_e, ff.q_b_e
                ));
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), String> {
        let before = self.session.work();
        self.session.finish(&mut self.sink);
        let after = self.session.work();
        self.check(after.saturating_sub(before), true)
            .map_err(|e| format!("after finish: {e}"))
    }

    /// Keeps the smoother's tape from now on (small chunks, so that the
    /// chunk boundaries are exercised too).
    fn with_smoother(mut self) -> Self {
        self.sink.smoother = Some(Smoother::with_limits(
            MemoryStore::default(),
            8 << 10,
            64 << 10,
            128 << 10,
        ));
        self.session.keep_smoother_tape();
        self
    }

    /// The smoothed run: one solution per forward one, at its time, each
    /// finite with positive σ.
    fn check_smoothed(&mut self) -> Result<(), String> {
        let Some(sm) = self.sink.smoother.take() else {
            return Ok(());
        };
        let times = std::mem::take(&mut self.sink.times);
        let mut k = 0;
        let mut bad = None;
        let report = sm
            .finish(|s| {
                if bad.is_none() {
                    if times.get(k) != Some(&s.t_ns) {
                        bad = Some(format!(
                            "smoothed #{k} at {} ns, forward at {:?}",
                            s.t_ns,
                            times.get(k)
                        ));
                    } else if let Err(e) = check_solution(s) {
                        bad = Some(format!("smoothed: {e}"));
                    }
                }
                k += 1;
                Ok(())
            })
            .map_err(|e| format!("smoother: {e}"))?;
        if let Some(b) = bad {
            return Err(b);
        }
        if report.solutions != times.len() as u64 {
            return Err(format!(
                "{} smoothed solutions for {} forward",
                report.solutions,
                times.len()
            ));
        }
        Ok(())
    }

    /// `n` genuine IMU samples continuing the genuine time line, with aids
    /// (baro at 20 Hz, CNS, SRS and star at 5 Hz, slightly late).
    fn genuine(&mut self, n: u64) -> Result<(), String> {
        for _ in 0..n {
            self.t_gen += DT_NS;
            self.k_gen += 1;
            let (t, k, off) = (self.t_gen, self.k_gen, self.stamp_offset);
            self.push(Owned::Imu(self.truth.imu_at(t + off, k, t)))?;
            if k % 10 == 0 {
                let mut b = self.truth.baro(t, k);
                b.t_ns += off;
                self.push(Owned::Aid(msgs::AidSample::Baro(b)))?;
            }
            if k % 40 == 0 {
                let mut c = self.truth.cns(t - 2 * DT_NS, k);
                c.t_ns += off;
                self.push(Owned::Aid(msgs::AidSample::Cns(c)))?;
            }
            if k % 40 == 20 {
                self.push(Owned::Aid(msgs::AidSample::Srs(self.truth.srs_at(
                    t - DT_NS + off,
                    k,
                    t - DT_NS,
                ))))?;
            }
            if k % 40 == 30 {
                let mut s = self.truth.star(t - DT_NS, k);
                s.t_ns += off;
                self.push(Owned::Aid(msgs::AidSample::Star(s)))?;
            }
            if k % 40 == 10 {
                let mut g = self.truth.gnss(t - DT_NS, k);
                g.t_ns += off;
                self.push(Owned::Aid(msgs::AidSample::Gnss(g)))?;
            }
        }
        Ok(())
    }

    fn imu_accepted(&self) -> u64 {
        self.session.status().imu().accepted
    }
}

// ---- generators -------------------------------------------------------

/// sign · 10^U(-320, 308), and the special values.
fn wild_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        8 => (any::<bool>(), -320.0f64..308.0).prop_map(|(neg, e)| {
            let m = 10f64.powf(e);
            if neg { -m } else { m }
        }),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(f64::MIN_POSITIVE / 2.0),
        1 => Just(5e-324),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
    ]
}

/// A field: `None` keeps the genuine value.
fn field() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![3 => Just(None), 1 => wild_f64().prop_map(Some)]
}

/// dt: log-uniform 1e-300..1e300 plus the extremes and the edges of the
/// accepted range.
fn dt_field() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![
        4 => Just(None),
        2 => (-300.0f64..300.0).prop_map(|e| Some(10f64.powf(e))),
        1 => wild_f64().prop_map(Some),
        1 => prop::sample::select(vec![1e-5, 0.99e-5, 1.0, 1.0000001, 1e-10, 0.0025, 0.0101])
            .prop_map(Some),
    ]
}

/// σ: log-uniform 1e-300..1e300, NaN, ±Inf, negative, 0.
fn sigma_field() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![
        3 => Just(None),
        3 => (-300.0f64..300.0).prop_map(|e| Some(10f64.powf(e))),
        1 => (-300.0f64..300.0).prop_map(|e| Some(-(10f64.powf(e)))),
        1 => prop::sample::select(vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, 5e-324, f64::MAX])
            .prop_map(Some),
    ]
}

/// A time stamp: absolute, relative to the genuine line, or relative to
/// the navigator's time.
#[derive(Debug, Clone, Copy)]
enum Stamp {
    Abs(u64),
    Gen(i128),
    Nav(i128),
}

fn signed_log_ns(lo: f64, hi: f64) -> impl Strategy<Value = i128> {
    (any::<bool>(), lo..hi).prop_map(|(neg, e)| {
        let m = 10f64.powf(e) as i128;
        if neg { -m } else { m }
    })
}

fn stamp() -> impl Strategy<Value = Stamp> {
    prop_oneof![
        3 => (0.0f64..19.27).prop_map(|e| Stamp::Abs(10f64.powf(e) as u64)),
        1 => prop::sample::select(vec![0, 1, u64::MAX, u64::MAX - 1, 1_000_000_000_000_000_000])
            .prop_map(Stamp::Abs),
        1 => Just(Stamp::Gen(0)),
        3 => signed_log_ns(0.0, 9.5).prop_map(Stamp::Gen),
        2 => signed_log_ns(9.5, 19.3).prop_map(Stamp::Gen),
        2 => (1i128..40).prop_map(|k| Stamp::Gen(k * DT_NS as i128)),
        2 => signed_log_ns(0.0, 11.0).prop_map(Stamp::Nav),
    ]
}

fn seq() -> impl Strategy<Value = Option<u64>> {
    prop_oneof![3 => Just(None), 1 => any::<u64>().prop_map(Some)]
}

#[derive(Debug, Clone)]
enum ImuContent {
    Genuine,
    /// Rates and specific forces up to the plausibility limits.
    Strong([f64; 3], [f64; 3]),
    Wild([Option<f64>; 6]),
}

#[derive(Debug, Clone)]
struct ImuSpec {
    stamp: Stamp,
    seq: Option<u64>,
    dt: Option<f64>,
    content: ImuContent,
}

#[derive(Debug, Clone)]
struct CnsSpec {
    stamp: Stamp,
    seq: Option<u64>,
    lat: Option<f64>,
    lon: Option<f64>,
    sigma: Option<f64>,
}

#[derive(Debug, Clone)]
struct BaroSpec {
    stamp: Stamp,
    seq: Option<u64>,
    p: Option<f64>,
    temp: Option<f64>,
    sigma: Option<f64>,
}

#[derive(Debug, Clone)]
struct StarSpec {
    stamp: Stamp,
    seq: Option<u64>,
    q: [Option<f64>; 4],
    boresight: Option<f64>,
    sigma_cross: Option<f64>,
    sigma_boresight: Option<f64>,
}

/// A GNSS fix: every field wild or genuine, the fix type and flags any
/// byte, or the genuine fix moved (a spoofer) by a log-uniform distance.
#[derive(Debug, Clone)]
struct GnssSpec {
    stamp: Stamp,
    seq: Option<u64>,
    /// lat, lon, height, v_n, v_e, v_d.
    values: [Option<f64>; 6],
    /// h_acc, v_acc, s_acc, pdop.
    sigmas: [Option<f64>; 4],
    fix_type: Option<u8>,
    flags: Option<u8>,
    /// Moved north by this many metres.
    moved_m: Option<f64>,
}

#[derive(Debug, Clone)]
struct SrsSpec {
    stamp: Stamp,
    seq: Option<u64>,
    count: Option<u32>,
    line: usize,
    sigma: Option<f64>,
    measured: Option<f64>,
    los: Option<f64>,
    body_vel: Option<f64>,
}

#[derive(Debug, Clone)]
enum InitContent {
    Genuine,
    /// The genuine state with these σ (pos h, pos v, vel h, vel v, tilt, heading).
    Sigmas([Option<f64>; 6]),
    /// A plausible state elsewhere: position offset (m), velocity (m/s), attitude.
    Moved([f64; 3], [f64; 3], [f64; 4]),
    /// r_e, v_e, q, σ fields.
    Wild(Vec<Option<f64>>),
    /// Level, heading north at 250 m/s, this far (m) from 70° N along the
    /// meridian: the frame switch latitude.
    NearSwitch(f64),
}

#[derive(Debug, Clone)]
struct InitSpec {
    stamp: Stamp,
    seq: Option<u64>,
    content: InitContent,
}

#[derive(Debug, Clone)]
enum InputOp {
    Imu(ImuSpec),
    Srs(SrsSpec),
    Cns(CnsSpec),
    Baro(BaroSpec),
    Star(StarSpec),
    Gnss(GnssSpec),
    Init(InitSpec),
}

#[derive(Debug, Clone)]
enum Op {
    /// Genuine IMU samples (with aids) continuing the genuine line.
    Genuine(u64),
    One(InputOp),
    /// The last input again, this many times.
    Duplicate(u8),
    /// The next genuine samples, pushed newest first.
    Reversed(u8),
    /// Genuine samples interleaved in blocks with a second publisher whose
    /// time base is offset by `offset_ns`.
    SecondPublisher {
        offset: i128,
        n: u8,
        block: u8,
    },
    /// `n` inputs of one kind, the stamp advancing by `step_ns`.
    Flood {
        input: InputOp,
        n: u16,
        step_ns: u64,
    },
    Flush,
    ImuLost,
}

fn imu_spec() -> impl Strategy<Value = ImuSpec> {
    let content = prop_oneof![
        3 => Just(ImuContent::Genuine),
        1 => (prop::array::uniform3(-20.0f64..20.0), prop::array::uniform3(-170.0f64..170.0))
            .prop_map(|(w, f)| ImuContent::Strong(w, f)),
        2 => prop::array::uniform6(field()).prop_map(ImuContent::Wild),
    ];
    (stamp(), seq(), dt_field(), content).prop_map(|(stamp, seq, dt, content)| ImuSpec {
        stamp,
        seq,
        dt,
        content,
    })
}

fn cns_spec() -> impl Strategy<Value = CnsSpec> {
    (stamp(), seq(), field(), field(), sigma_field()).prop_map(|(stamp, seq, lat, lon, sigma)| {
        CnsSpec {
            stamp,
            seq,
            lat,
            lon,
            sigma,
        }
    })
}

fn baro_spec() -> impl Strategy<Value = BaroSpec> {
    (stamp(), seq(), field(), field(), sigma_field()).prop_map(|(stamp, seq, p, temp, sigma)| {
        BaroSpec {
            stamp,
            seq,
            p,
            temp,
            sigma,
        }
    })
}

fn srs_spec() -> impl Strategy<Value = SrsSpec> {
    let count = prop_oneof![3 => Just(None), 1 => (0u32..12).prop_map(Some), 1 => any::<u32>().prop_map(Some)];
    (
        stamp(),
        seq(),
        count,
        0usize..8,
        sigma_field(),
        field(),
        field(),
        field(),
    )
        .prop_map(
            |(stamp, seq, count, line, sigma, measured, los, body_vel)| SrsSpec {
                stamp,
                seq,
                count,
                line,
                sigma,
                measured,
                los,
                body_vel,
            },
        )
}

fn init_spec() -> impl Strategy<Value = InitSpec> {
    let content = prop_oneof![
        1 => Just(InitContent::Genuine),
        3 => prop::array::uniform6(sigma_field()).prop_map(InitContent::Sigmas),
        2 => (
            prop::array::uniform3(-1e5f64..1e5),
            prop::array::uniform3(-600.0f64..600.0),
            prop::array::uniform4(-1.0f64..1.0),
        )
            .prop_map(|(dr, v, q)| InitContent::Moved(dr, v, q)),
        1 => (-300.0f64..300.0).prop_map(InitContent::NearSwitch),
        2 => prop::collection::vec(field(), 16).prop_map(InitContent::Wild),
    ];
    (stamp(), seq(), content).prop_map(|(stamp, seq, content)| InitSpec {
        stamp,
        seq,
        content,
    })
}

fn star_spec() -> impl Strategy<Value = StarSpec> {
    (
        stamp(),
        seq(),
        [field(), field(), field(), field()],
        field(),
        sigma_field(),
        sigma_field(),
    )
        .prop_map(
            |(stamp, seq, q, boresight, sigma_cross, sigma_boresight)| StarSpec {
                stamp,
                seq,
                q,
                boresight,
                sigma_cross,
                sigma_boresight,
            },
        )
}

fn gnss_spec() -> impl Strategy<Value = GnssSpec> {
    let byte = prop_oneof![3 => Just(None), 1 => any::<u8>().prop_map(Some)];
    let moved = prop_oneof![
        2 => Just(None),
        1 => (-3.0f64..7.0).prop_map(|e| Some(10f64.powf(e))),
    ];
    (
        stamp(),
        seq(),
        prop::array::uniform6(field()),
        prop::array::uniform4(sigma_field()),
        byte.clone(),
        byte,
        moved,
    )
        .prop_map(
            |(stamp, seq, values, sigmas, fix_type, flags, moved_m)| GnssSpec {
                stamp,
                seq,
                values,
                sigmas,
                fix_type,
                flags,
                moved_m,
            },
        )
}

fn input_op() -> impl Strategy<Value = InputOp> {
    prop_oneof![
        4 => imu_spec().prop_map(InputOp::Imu),
        1 => srs_spec().prop_map(InputOp::Srs),
        1 => cns_spec().prop_map(InputOp::Cns),
        1 => baro_spec().prop_map(InputOp::Baro),
        1 => star_spec().prop_map(InputOp::Star),
        1 => gnss_spec().prop_map(InputOp::Gnss),
        2 => init_spec().prop_map(InputOp::Init),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    let step = prop_oneof![
        Just(0u64),
        Just(1),
        Just(DT_NS),
        Just(1_000_000_000),
        (0.0f64..19.0).prop_map(|e| 10f64.powf(e) as u64),
    ];
    prop_oneof![
        4 => (1u64..60).prop_map(Op::Genuine),
        8 => input_op().prop_map(Op::One),
        1 => (1u8..6).prop_map(Op::Duplicate),
        1 => (2u8..20).prop_map(Op::Reversed),
        1 => (signed_log_ns(6.0, 19.3), 1u8..40, 1u8..6)
            .prop_map(|(offset, n, block)| Op::SecondPublisher { offset, n, block }),
        1 => (input_op(), 1u16..200, step)
            .prop_map(|(input, n, step_ns)| Op::Flood { input, n, step_ns }),
        1 => Just(Op::Flush),
        1 => Just(Op::ImuLost),
    ]
}

// ---- building and applying ----------------------------------------------

fn offset_u64(base: u64, off: i128) -> u64 {
    (base as i128 + off).clamp(0, u64::MAX as i128) as u64
}

impl Harness {
    fn resolve(&self, s: Stamp) -> u64 {
        match s {
            Stamp::Abs(t) => t,
            Stamp::Gen(off) => offset_u64(self.t_gen, off),
            Stamp::Nav(off) => {
                let nav = self.session.navigator().map_or(self.t_gen, |n| n.t_ns());
                offset_u64(nav, off)
            }
        }
    }

    fn build(&self, op: &InputOp) -> Owned {
        let tr = self.truth;
        let tg = self.t_gen;
        let k = self.k_gen;
        let or = |f: Option<f64>, v: f64| f.unwrap_or(v);
        match op {
            InputOp::Imu(s) => {
                let mut x = tr.imu_at(self.resolve(s.stamp), s.seq.unwrap_or(k), tg);
                x.dt_s = or(s.dt, DT_S);
                match &s.content {
                    ImuContent::Genuine => {}
                    ImuContent::Strong(w, f) => {
                        let dt = if x.dt_s.is_finite() { x.dt_s } else { DT_S };
                        x.d_theta_rad = w.map(|w| w * dt);
                        x.d_v_mps = f.map(|f| f * dt);
                    }
                    ImuContent::Wild(v) => {
                        for i in 0..3 {
                            x.d_theta_rad[i] = or(v[i], x.d_theta_rad[i]);
                            x.d_v_mps[i] = or(v[i + 3], x.d_v_mps[i]);
                        }
                    }
                }
                Owned::Imu(x)
            }
            InputOp::Cns(s) => {
                let mut x = tr.cns(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                x.lat_rad = or(s.lat, x.lat_rad);
                x.lon_rad = or(s.lon, x.lon_rad);
                x.sigma_h_m = or(s.sigma, x.sigma_h_m);
                Owned::Aid(msgs::AidSample::Cns(x))
            }
            InputOp::Baro(s) => {
                let mut x = tr.baro(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                x.pressure_pa = or(s.p, x.pressure_pa);
                x.temperature_k = or(s.temp, x.temperature_k);
                x.sigma_m = or(s.sigma, x.sigma_m);
                Owned::Aid(msgs::AidSample::Baro(x))
            }
            InputOp::Star(s) => {
                let mut x = tr.star(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                for (q, f) in x.q_b_i.iter_mut().zip(s.q) {
                    *q = or(f, *q);
                }
                x.boresight_b[2] = or(s.boresight, x.boresight_b[2]);
                x.sigma_cross_arcsec = or(s.sigma_cross, x.sigma_cross_arcsec);
                x.sigma_boresight_arcsec = or(s.sigma_boresight, x.sigma_boresight_arcsec);
                Owned::Aid(msgs::AidSample::Star(x))
            }
            InputOp::Gnss(s) => {
                let mut x = tr.gnss(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                if let Some(m) = s.moved_m {
                    x.lat_rad += m / earth::A;
                }
                let [lat, lon, h, vn, ve, vd] = s.values;
                x.lat_rad = or(lat, x.lat_rad);
                x.lon_rad = or(lon, x.lon_rad);
                x.height_m = or(h, x.height_m);
                x.vel_ned_mps = [
                    or(vn, x.vel_ned_mps[0]),
                    or(ve, x.vel_ned_mps[1]),
                    or(vd, x.vel_ned_mps[2]),
                ];
                let [ha, va, sa, pdop] = s.sigmas;
                x.h_acc_m = or(ha, x.h_acc_m);
                x.v_acc_m = or(va, x.v_acc_m);
                x.s_acc_mps = or(sa, x.s_acc_mps);
                x.pdop = or(pdop, x.pdop);
                x.fix_type = s.fix_type.unwrap_or(x.fix_type);
                x.flags = s.flags.unwrap_or(x.flags);
                Owned::Aid(msgs::AidSample::Gnss(x))
            }
            InputOp::Srs(s) => {
                let mut x = tr.srs(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                x.count = s.count.unwrap_or(x.count);
                if let Some(sig) = s.sigma {
                    for l in &mut x.lines {
                        l.sigma_mps = sig;
                    }
                }
                let l = &mut x.lines[s.line];
                l.measured_wavelength_m = or(s.measured, l.measured_wavelength_m);
                l.los_i[s.line % 3] = or(s.los, l.los_i[s.line % 3]);
                l.body_vel_i_mps[s.line % 3] = or(s.body_vel, l.body_vel_i_mps[s.line % 3]);
                Owned::Aid(msgs::AidSample::Srs(x))
            }
            InputOp::Init(s) => {
                let mut x = tr.init(tg, s.seq.unwrap_or(k));
                x.t_ns = self.resolve(s.stamp);
                match &s.content {
                    InitContent::Genuine => {}
                    InitContent::Sigmas(sg) => {
                        for (dst, v) in sigmas_mut(&mut x).into_iter().zip(sg) {
                            *dst = or(*v, *dst);
                        }
                    }
                    InitContent::Moved(dr, v, q) => {
                        for (r, d) in x.r_e_m.iter_mut().zip(dr) {
                            *r += d;
                        }
                        x.v_e_mps = *v;
                        let n = q.iter().map(|a| a * a).sum::<f64>().sqrt();
                        if n > 1e-3 {
                            x.q_b_e = q.map(|a| a / n);
                        }
                    }
                    InitContent::NearSwitch(d_m) => {
                        let lat = 70f64.to_radians() + d_m / 6_400_000.0;
                        let g = Geodetic::new(lat, LON0_DEG.to_radians(), H0_M);
                        let c = frames::c_e_g(g.lat_rad, g.lon_rad);
                        let q = UnitQuaternion::from_matrix(&c.transpose());
                        x.r_e_m = earth::geodetic_to_ecef(&g).into();
                        x.v_e_mps = (c.transpose() * Vector3::new(0.0, 250.0, 0.0)).into();
                        x.q_b_e = [q.w, q.i, q.j, q.k];
                    }
                    InitContent::Wild(f) => {
                        for (dst, v) in init_fields_mut(&mut x).into_iter().zip(f) {
                            *dst = or(*v, *dst);
                        }
                    }
                }
                if tolerate_known() {
                    for v in sigmas_mut(&mut x) {
                        if v.is_finite() && *v >= 0.0 {
                            *v = v.clamp(0.1, 1e4);
                        }
                    }
                    if x.r_e_m[0].hypot(x.r_e_m[1]) < 1e5 {
                        let r = tr.r_e(tg);
                        x.r_e_m[0] = r.x;
                        x.r_e_m[1] = r.y;
                    }
                }
                Owned::Init(x)
            }
        }
    }

    fn apply(&mut self, op: &Op) -> Result<(), String> {
        match op {
            Op::Genuine(n) => self.genuine(*n)?,
            Op::One(i) => self.push(self.build(i))?,
            Op::Duplicate(n) => {
                if let Some(o) = self.last {
                    for _ in 0..*n {
                        self.push(o)?;
                    }
                }
            }
            Op::Reversed(n) => {
                let n = u64::from(*n);
                let samples: Vec<ImuSample> = (1..=n)
                    .map(|j| self.truth.imu(self.t_gen + j * DT_NS, self.k_gen + j))
                    .collect();
                self.t_gen += n * DT_NS;
                self.k_gen += n;
                for s in samples.iter().rev() {
                    self.push(Owned::Imu(*s))?;
                }
            }
            Op::SecondPublisher { offset, n, block } => {
                let mut other = offset_u64(self.t_gen, *offset);
                for j in 0..u64::from(*n) {
                    if j % u64::from(*block) == 0 {
                        self.genuine(u64::from(*block))?;
                    }
                    other = other.saturating_add(DT_NS);
                    let s = self.truth.imu_at(other, 1_000_000 + j, self.t_gen);
                    self.push(Owned::Imu(s))?;
                }
            }
            Op::Flood { input, n, step_ns } => {
                let mut o = self.build(input);
                for _ in 0..*n {
                    self.push(o)?;
                    let t = o.t_ns_mut();
                    *t = t.saturating_add(*step_ns);
                }
            }
            Op::Flush => {
                self.session.flush(&mut self.sink);
                self.check(0, false)
                    .map_err(|e| format!("after flush: {e}"))?;
            }
            Op::ImuLost => {
                let before = self.session.work();
                self.session.imu_lost(&mut self.sink);
                let after = self.session.work();
                self.check(after.saturating_sub(before), false)
                    .map_err(|e| format!("after imu_lost: {e}"))?;
            }
        }
        Ok(())
    }
}

fn sigmas_mut(x: &mut InitState) -> [&mut f64; 6] {
    [
        &mut x.sigma_pos_h_m,
        &mut x.sigma_pos_v_m,
        &mut x.sigma_vel_h_mps,
        &mut x.sigma_vel_v_mps,
        &mut x.sigma_tilt_rad,
        &mut x.sigma_heading_rad,
    ]
}

/// r_e (3), v_e (3), q (4), σ (6).
fn init_fields_mut(x: &mut InitState) -> Vec<&mut f64> {
    let InitState {
        r_e_m,
        v_e_mps,
        q_b_e,
        sigma_pos_h_m,
        sigma_pos_v_m,
        sigma_vel_h_mps,
        sigma_vel_v_mps,
        sigma_tilt_rad,
        sigma_heading_rad,
        ..
    } = x;
    let mut v: Vec<&mut f64> = r_e_m
        .iter_mut()
        .chain(v_e_mps.iter_mut())
        .chain(q_b_e.iter_mut())
        .collect();
    v.extend([
        sigma_pos_h_m,
        sigma_pos_v_m,
        sigma_vel_h_mps,
        sigma_vel_v_mps,
        sigma_tilt_rad,
        sigma_heading_rad,
    ]);
    v
}

/// The whole property: genuine start, adversarial inputs, finish, genuine
/// continuation.
fn run_case(speed_mps: f64, warmup: u64, ops: &[Op]) -> Result<(), String> {
    run_case_with(Harness::new(Truth { speed_mps }), warmup, ops)
}

fn run_case_with(mut h: Harness, warmup: u64, ops: &[Op]) -> Result<(), String> {
    h.genuine(warmup)?;
    for (i, op) in ops.iter().enumerate() {
        h.apply(op).map_err(|e| format!("op #{i} {op:?}: {e}"))?;
    }
    h.finish()?;
    // The genuine stream goes on. If the adversarial inputs confirmed a
    // move of the navigator's time base ahead of the genuine line (a jump,
    // or a coasted gap), the publisher that goes on is the one on that base:
    // the genuine stream continues from the navigator's time. (Whether the
    // original line itself is blinded is pinned down by a named test below.)
    // Otherwise it continues on its own line; either way it must be taken
    // again within TIME_JUMP_CONFIRM samples.
    if let Some(nav_t) = h.session.navigator().map(|n| n.t_ns())
        && nav_t > h.t_gen
        && nav_t < u64::MAX / 2
    {
        h.stamp_offset = nav_t - h.t_gen;
    }
    let before = h.imu_accepted();
    h.genuine(400)?;
    let grown = h.imu_accepted() - before;
    let min = 400 - TIME_JUMP_CONFIRM as u64;
    if grown < min {
        return Err(format!(
            "genuine continuation blinded: {grown} of 400 accepted (at least {min} expected), \
             navigator at {:?} ns, genuine stamps up to {} ns",
            h.session.navigator().map(|n| n.t_ns()),
            h.t_gen + h.stamp_offset
        ));
    }
    h.finish()?;
    h.check_smoothed()
}

/// Proptest cases of the main property (about 5 s in the test profile).
const CASES: u32 = 2048;

/// With `SESSION_PROPS_TOLERATE_KNOWN` set, the property tolerates the two
/// deviations the named tests below pin down (aids waiting in the queue
/// missing from `status().received`; init σ so large or small that P
/// loses positive definiteness; an init on the polar axis), so
/// that it can look for further ones. Unset, every check is strict.
fn tolerate_known() -> bool {
    std::env::var_os("SESSION_PROPS_TOLERATE_KNOWN").is_some()
}

#[test]
fn adversarial_inputs_keep_the_session_sound() {
    // The strategies' value trees and the session are large: a big stack.
    let worker = std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(|| {
            let config = ProptestConfig {
                cases: std::env::var("SESSION_PROPS_CASES")
                    .ok()
                    .and_then(|c| c.parse().ok())
                    .unwrap_or(CASES),
                failure_persistence: None,
                ..ProptestConfig::default()
            };
            let mut runner = proptest::test_runner::TestRunner::new(config);
            let strategy = (
                prop_oneof![Just(0.0f64), Just(250.0)],
                20u64..200,
                prop::collection::vec(op(), 1..40),
            );
            runner
                .run(&strategy, |(speed, warmup, ops)| {
                    run_case(speed, warmup, &ops).map_err(TestCaseError::fail)
                })
                .map_err(|e| e.to_string())
        })
        .expect("spawn");
    if let Err(e) = worker.join().expect("no panic in the property") {
        panic!("{e}");
    }
}

/// The smoother over the same adversarial runs (the forward checks hold as
/// above): as many smoothed solutions as forward ones, at the same times,
/// every one finite with positive σ, whatever resets, re-inits, repairs,
/// coasts and resyncs the inputs caused.
#[test]
fn adversarial_inputs_keep_the_smoother_sound() {
    let worker = std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(|| {
            let config = ProptestConfig {
                cases: std::env::var("SESSION_PROPS_CASES")
                    .ok()
                    .and_then(|c| c.parse().ok())
                    .unwrap_or(CASES / 4),
                failure_persistence: None,
                ..ProptestConfig::default()
            };
            let mut runner = proptest::test_runner::TestRunner::new(config);
            let strategy = (
                prop_oneof![Just(0.0f64), Just(250.0)],
                20u64..200,
                prop::collection::vec(op(), 1..40),
            );
            runner
                .run(&strategy, |(speed, warmup, ops)| {
                    let h = Harness::new(Truth { speed_mps: speed }).with_smoother();
                    run_case_with(h, warmup, &ops).map_err(TestCaseError::fail)
                })
                .map_err(|e| e.to_string())
        })
        .expect("spawn");
    if let Err(e) = worker.join().expect("no panic in the property") {
        panic!("{e}");
    }
}

// ---- named regression cases ----------------------------------------------

fn started(speed_mps: f64) -> Harness {
    let mut h = Harness::new(Truth { speed_mps });
    h.genuine(400).expect("genuine start");
    h
}

fn ok(r: Result<(), String>) {
    if let Err(e) = r {
        panic!("{e}");
    }
}

#[test]
fn imu_stamped_1e18_costs_only_itself() {
    let mut h = started(250.0);
    let before = h.imu_accepted();
    let bad = h.truth.imu_at(1_000_000_000_000_000_000, 99, h.t_gen);
    ok(h.push(Owned::Imu(bad)));
    ok(h.genuine(400));
    assert_eq!(
        h.imu_accepted() - before,
        400,
        "every genuine sample accepted"
    );
    ok(h.finish());
    assert_eq!(h.session.status().imu().rejected_time, 1);
    assert_eq!(h.session.time_resyncs(), 0);
}

#[test]
fn imu_60_s_ahead_then_genuine() {
    for ahead_ns in [59_990_000_000u64, 60_000_000_000, 60_010_000_000] {
        let mut h = started(250.0);
        let before = h.imu_accepted();
        let bad = h.truth.imu_at(h.t_gen + ahead_ns, 99, h.t_gen);
        ok(h.push(Owned::Imu(bad)));
        ok(h.genuine(400));
        let grown = h.imu_accepted() - before;
        assert!(
            grown >= 400,
            "{ahead_ns} ns ahead: {grown} accepted of 400 genuine (+1 bad)"
        );
        ok(h.finish());
    }
}

#[test]
fn two_samples_with_dt_1e_10() {
    let mut h = started(0.0);
    let before = h.imu_accepted();
    for _ in 0..2 {
        h.t_gen += DT_NS;
        h.k_gen += 1;
        let mut s = h.truth.imu(h.t_gen, h.k_gen);
        s.dt_s = 1e-10;
        ok(h.push(Owned::Imu(s)));
    }
    assert_eq!(h.session.status().imu().rejected_invalid, 2);
    ok(h.genuine(400));
    assert_eq!(h.imu_accepted() - before, 400);
    ok(h.finish());
}

#[test]
fn time_jump_of_1e6_s_is_followed() {
    let mut h = started(250.0);
    let before = h.imu_accepted();
    let resyncs = h.session.time_resyncs();
    // The publisher's clock jumps by 1e6 s; its samples stay consistent.
    h.t_gen += 1_000_000 * 1_000_000_000;
    // Content continues from before the jump (the truth is parametrized by
    // the stamp, so keep the vehicle where it was).
    let content_t = T0_NS + 400 * DT_NS;
    for j in 1..=400u64 {
        h.t_gen += DT_NS;
        h.k_gen += 1;
        let s = h.truth.imu_at(h.t_gen, h.k_gen, content_t + j * DT_NS);
        ok(h.push(Owned::Imu(s)));
    }
    assert_eq!(h.session.time_resyncs(), resyncs + 1);
    assert!(
        h.sink
            .events
            .iter()
            .any(|e| matches!(e, Event::TimeResync { to_t_ns, .. } if *to_t_ns > 1_000_000 * 1_000_000_000)),
        "a TimeResync event to the new time base"
    );
    assert_eq!(
        h.imu_accepted() - before,
        400,
        "the candidates are used after the resync"
    );
    assert_eq!(h.session.navigator().map(|n| n.t_ns()), Some(h.t_gen));
    ok(h.finish());
}

#[test]
fn aid_with_sigma_1e160_is_rejected() {
    let mut h = started(0.0);
    // A fresh IMU epoch, so that no aid stream has used this stamp yet.
    ok(h.genuine(1));
    let t = h.t_gen;
    let st0 = h.session.status();
    let mut c = h.truth.cns(t, 1);
    c.sigma_h_m = 1e160;
    let mut b = h.truth.baro(t, 1);
    b.sigma_m = 1e160;
    let mut s = h.truth.srs(t, 1);
    for l in &mut s.lines {
        l.sigma_mps = 1e160;
    }
    let mut star = h.truth.star(t, 1);
    star.sigma_cross_arcsec = 1e160;
    ok(h.push(Owned::Aid(msgs::AidSample::Star(star))));
    ok(h.push(Owned::Aid(msgs::AidSample::Cns(c))));
    ok(h.push(Owned::Aid(msgs::AidSample::Baro(b))));
    ok(h.push(Owned::Aid(msgs::AidSample::Srs(s))));
    // Aids are fused (or refused) before the next IMU sample or at a flush.
    h.session.flush(&mut h.sink);
    let st = h.session.status();
    assert_eq!(
        st.aid_counters(AidKind::Cns).rejected_invalid,
        st0.aid_counters(AidKind::Cns).rejected_invalid + 1
    );
    assert_eq!(
        st.aid_counters(AidKind::Baro).rejected_invalid,
        st0.aid_counters(AidKind::Baro).rejected_invalid + 1
    );
    assert_eq!(
        st.aid_counters(AidKind::Srs).rejected_invalid,
        st0.aid_counters(AidKind::Srs).rejected_invalid + 1
    );
    assert_eq!(
        st.aid_counters(AidKind::Star).rejected_invalid,
        st0.aid_counters(AidKind::Star).rejected_invalid + 1
    );
    let n = h.session.navigator().expect("navigating");
    assert!(n.covariance().iter().all(|x| x.is_finite()));
    assert!((0..15).all(|i| n.covariance()[(i, i)] > 0.0));
    ok(h.genuine(40));
    ok(h.finish());
}

/// The star tracker's impossible content (NaN and ±Inf in the quaternion or
/// a σ, a quaternion or boresight off unit norm, σ of 1e-300 or 1e300) is
/// refused and counted as invalid, once each; the state stays finite and a
/// genuine sample of the same time is fused after them.
#[test]
fn star_tracker_impossible_content_is_refused_and_counted() {
    let mut h = started(250.0);
    ok(h.genuine(1));
    let t = h.t_gen;
    let st0 = h.session.status();
    let good = h.truth.star(t, 1);
    let q = good.q_b_i;
    let bad = [
        StarSample {
            q_b_i: [f64::NAN, q[1], q[2], q[3]],
            ..good
        },
        StarSample {
            q_b_i: [q[0], f64::INFINITY, q[2], q[3]],
            ..good
        },
        StarSample {
            q_b_i: [q[0], q[1], f64::NEG_INFINITY, q[3]],
            ..good
        },
        StarSample {
            q_b_i: q.map(|x| x * 1.001),
            ..good
        },
        StarSample {
            q_b_i: [0.0; 4],
            ..good
        },
        StarSample {
            boresight_b: [0.0, 0.0, 2.0],
            ..good
        },
        StarSample {
            sigma_cross_arcsec: 1e-300,
            ..good
        },
        StarSample {
            sigma_boresight_arcsec: 1e300,
            ..good
        },
        StarSample {
            sigma_cross_arcsec: f64::NAN,
            ..good
        },
        StarSample {
            sigma_boresight_arcsec: f64::INFINITY,
            ..good
        },
    ];
    for b in bad {
        ok(h.push(Owned::Aid(msgs::AidSample::Star(b))));
    }
    h.session.flush(&mut h.sink);
    let st = h.session.status();
    assert_eq!(
        st.aid_counters(AidKind::Star).rejected_invalid,
        st0.aid_counters(AidKind::Star).rejected_invalid + bad.len() as u64,
        "{:?}",
        st.aid_counters(AidKind::Star)
    );
    assert_eq!(
        st.aid_counters(AidKind::Star).accepted,
        st0.aid_counters(AidKind::Star).accepted
    );
    ok(h.push(Owned::Aid(msgs::AidSample::Star(good))));
    h.session.flush(&mut h.sink);
    assert_eq!(
        h.session.status().aid_counters(AidKind::Star).accepted,
        st0.aid_counters(AidKind::Star).accepted + 1
    );
    let n = h.session.navigator().expect("navigating");
    assert!(n.covariance().iter().all(|x| x.is_finite()));
    ok(h.genuine(40));
    ok(h.finish());
}

#[test]
fn future_aids_do_not_block_genuine_ones() {
    let mut h = started(0.0);
    let far = 1_000_000_000_000_000_000;
    let st0 = h.session.status();
    ok(h.push(Owned::Aid(msgs::AidSample::Srs(h.truth.srs(far, 1)))));
    ok(h.push(Owned::Aid(msgs::AidSample::Cns(h.truth.cns(far, 1)))));
    ok(h.push(Owned::Aid(msgs::AidSample::Baro(h.truth.baro(far, 1)))));
    ok(h.genuine(400));
    let st = h.session.status();
    assert_eq!(
        st.aid_counters(AidKind::Srs).rejected_time,
        st0.aid_counters(AidKind::Srs).rejected_time + 1
    );
    assert!(
        st.aid_counters(AidKind::Srs).accepted >= st0.aid_counters(AidKind::Srs).accepted + 9,
        "srs {st0:?} -> {st:?}"
    );
    assert!(
        st.aid_counters(AidKind::Cns).accepted >= st0.aid_counters(AidKind::Cns).accepted + 9,
        "cns {:?}",
        st.aid_counters(AidKind::Cns)
    );
    assert!(
        st.aid_counters(AidKind::Baro).accepted >= st0.aid_counters(AidKind::Baro).accepted + 39,
        "baro {:?}",
        st.aid_counters(AidKind::Baro)
    );
    ok(h.finish());
}

#[test]
fn init_stamped_1e18_while_navigating_is_held() {
    let mut h = started(250.0);
    let before = h.imu_accepted();
    let i = h.truth.init(1_000_000_000_000_000_000, 7);
    ok(h.push(Owned::Init(i)));
    ok(h.genuine(400));
    assert_eq!(h.imu_accepted() - before, 400);
    assert_eq!(h.session.reinits(), 0);
    ok(h.finish());
    let ic = h.session.init_counters();
    assert_eq!(
        (ic.received, ic.used, ic.rejected, ic.not_used),
        (2, 1, 0, 1)
    );
}

#[test]
fn flood_of_10000_aids_half_a_second_ahead() {
    let mut h = started(0.0);
    // Bounded: at most AID_QUEUE waiting (uncounted) at any time; exact
    // after `finish` (checked by `h.finish()`).
    h.tolerate_queue = true;
    let t = h.t_gen + MAX_AID_LEAD_NS / 2;
    let st0 = h.session.status();
    for j in 0..10_000u64 {
        let o = match j % 3 {
            0 => Owned::Aid(msgs::AidSample::Baro(h.truth.baro(t + j, j))),
            1 => Owned::Aid(msgs::AidSample::Cns(h.truth.cns(t + j, j))),
            _ => Owned::Aid(msgs::AidSample::Srs(h.truth.srs(t + j, j))),
        };
        ok(h.push(o));
    }
    ok(h.genuine(200));
    ok(h.finish());
    let st = h.session.status();
    let grown = |a: u64, b: u64| a - b;
    assert_eq!(
        grown(
            st.aid_counters(AidKind::Srs).received,
            st0.aid_counters(AidKind::Srs).received
        ) + grown(
            st.aid_counters(AidKind::Cns).received,
            st0.aid_counters(AidKind::Cns).received
        ) + grown(
            st.aid_counters(AidKind::Baro).received,
            st0.aid_counters(AidKind::Baro).received
        ),
        10_000 + 20 + 5 + 5
    );
    assert!(h.max_work_step <= WORK_BOUND);
}

/// Aids waiting in the queue for the IMU have been received: `status()`
/// must count them (as it counts the held time-jump candidates).
/// A disabled aid's samples are counted as not used and reported as no
/// update: `Event::AidUpdate` (batch's `/aid/*` messages, eval's gate
/// statistics) comes only from a sample that reached the gate. It used to
/// come for every sample the navigator did not refuse, disabled or undone
/// as invalid, repeating the aid's last status (all zero here).
#[test]
fn a_disabled_aid_reports_no_update() {
    let mut settings = SessionSettings::default();
    settings.navigator.aids = settings.navigator.aids.with(AidKind::Cns, false);
    settings.navigator.aids = settings.navigator.aids.with(AidKind::Star, false);
    let mut h = Harness::with_settings(Truth { speed_mps: 200.0 }, settings);
    h.genuine(2000).expect("genuine flight");
    h.finish().expect("finish");
    let st = h.session.status();
    assert!(
        st.aid_counters(AidKind::Cns).not_used >= 40
            && st.aid_counters(AidKind::Star).not_used >= 40,
        "{st:?}"
    );
    assert!(
        st.aid_counters(AidKind::Baro).accepted >= 150,
        "{:?}",
        st.aid_counters(AidKind::Baro)
    );
    let updates = |stream| {
        h.sink
            .events
            .iter()
            .filter(|e| matches!(e, Event::AidUpdate { stream: s, .. } if *s == stream))
            .count()
    };
    assert_eq!(
        (
            updates(Stream::Aid(AidKind::Cns)),
            updates(Stream::Aid(AidKind::Star))
        ),
        (0, 0)
    );
    assert_eq!(
        updates(Stream::Aid(AidKind::Baro)) as u64,
        st.aid_counters(AidKind::Baro).accepted + st.aid_counters(AidKind::Baro).rejected_gate
    );
}

#[test]
fn queued_aid_is_counted_as_received() {
    let mut h = started(0.0);
    let before = *h.session.status().aid_counters(AidKind::Baro);
    // Half a second ahead of the IMU: it waits in the queue.
    let b = h.truth.baro(h.t_gen + 100 * DT_NS, 1);
    h.session.push(Input::Aid(&b.into()), &mut h.sink);
    let after = *h.session.status().aid_counters(AidKind::Baro);
    assert_eq!(
        after.received,
        before.received + 1,
        "a baro sample waiting in the queue is missing from status().aid_counters(AidKind::Baro).received: \
         {before:?} -> {after:?}"
    );
}

/// Init σ that `check_init` accepts (finite, not negative) must give
/// solutions with finite, positive σ.
#[test]
fn init_sigma_extremes_keep_published_sigma_positive_and_finite() {
    let cases: [(usize, f64); 5] = [
        (1, 0.0),   // σ_pos_v = 0: an exact init
        (1, 1e10),  // σ_pos_v
        (2, 1e12),  // σ_vel_h
        (0, 1e200), // σ_pos_h
        (5, 1e200), // σ_heading
    ];
    let mut failures = Vec::new();
    for (field, sigma) in cases {
        let mut h = started(0.0);
        let mut i = h.truth.init(h.t_gen, 3);
        *sigmas_mut(&mut i)[field] = sigma;
        let r = h
            .push(Owned::Init(i))
            .and_then(|_| h.genuine(400))
            .and_then(|_| h.finish());
        if let Err(e) = r {
            failures.push(format!("σ[{field}] = {sigma:e}: {e}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// An init on the polar axis (x = y = 0) with a plausible attitude (the
/// vehicle's, 4° from the local level there) must keep σ positive.
#[test]
fn init_on_the_polar_axis_keeps_sigma_positive() {
    let mut h = started(0.0);
    let mut i = h.truth.init(h.t_gen, 3);
    i.r_e_m[0] = 0.0;
    i.r_e_m[1] = 0.0;
    ok(h.push(Owned::Init(i)));
    ok(h.genuine(400));
    ok(h.finish());
}

/// A known limit, pinned: four consistent samples of a second publisher 3 s
/// ahead, with no genuine sample between them, confirm a gap, and the
/// navigator coasts to them. The genuine stream is then stale until its
/// time passes the coasted time (here 3 s, at most `imu_max_coast_s`), and
/// from then on it is taken again. (Interleaved with the genuine stream, a
/// second publisher never confirms anything: see the property test.)
#[test]
fn second_publisher_burst_ahead_blinds_the_genuine_stream_only_until_it_catches_up() {
    let mut h = started(250.0);
    let other = h.t_gen + 3_000_000_000;
    for j in 1..=TIME_JUMP_CONFIRM as u64 {
        let s = h.truth.imu_at(other + j * DT_NS, 1_000_000 + j, h.t_gen);
        ok(h.push(Owned::Imu(s)));
    }
    let coasted_to = h.session.navigator().map_or(0, |n| n.t_ns());
    assert!(coasted_to >= other, "the burst did not confirm a gap");
    // 3 s of the genuine stream at 200 Hz are stale, and so are the genuine
    // samples with the burst's own stamps; then it is taken again.
    let before = h.imu_accepted();
    ok(h.genuine(600 + 400));
    let grown = h.imu_accepted() - before;
    assert!(
        grown >= 400 - TIME_JUMP_CONFIRM as u64,
        "genuine stream still blinded after catching up: {grown} of the last 400 accepted; navigator at {:?} ns, genuine at {} ns",
        h.session.navigator().map(|n| n.t_ns()),
        h.t_gen
    );
}

/// A stray init stamped 1e18 ns and a stray IMU sample stamped beyond it
/// (with a NaN interval) while navigating: the init must not take over the
/// state (it applies only before a plausible sample that continues right
/// after it); the genuine stream goes on.
#[test]
fn a_stray_init_and_a_stray_imu_sample_do_not_take_over_the_state() {
    let mut h = started(250.0);
    let mut i = h.truth.init(h.t_gen, 3);
    i.t_ns = 1_000_000_000_000_000_000;
    i.r_e_m = [0.0, 0.0, 6_356_752.3];
    ok(h.push(Owned::Init(i)));
    let mut s = h.truth.imu_at(u64::MAX, 99, h.t_gen);
    s.dt_s = f64::NAN;
    ok(h.push(Owned::Imu(s)));
    let before = h.imu_accepted();
    ok(h.genuine(400));
    assert_eq!(h.session.reinits(), 0, "the stray init was applied");
    assert!(h.imu_accepted() - before >= 400 - TIME_JUMP_CONFIRM as u64);
    let nav = h.session.navigator().expect("navigating");
    let lat = earth::ecef_to_geodetic(&nav.state().frame_free().r_e).lat_rad;
    assert!(
        lat.to_degrees() < 89.0,
        "the state moved to the pole: {}",
        lat.to_degrees()
    );
}

/// The aids between two IMU samples are fused in (time, stream) order
/// whatever order they arrive in, and whether they arrive before or after
/// their IMU sample: a live cycle drains its topics one after the other, so
/// an SRS sample published before a CNS fix can reach the session after it.
/// Every arrangement gives the same solutions, bit for bit.
#[test]
fn aid_arrival_order_within_an_epoch_does_not_change_the_solution() {
    use polarnav::session::Collect;
    let truth = Truth { speed_mps: 250.0 };
    let arrangements: [&[usize]; 4] = [
        // 0 = IMU, 1 = SRS, 2 = CNS, 3 = baro (all stamped at the IMU time)
        &[0, 1, 2, 3],
        &[2, 0, 3, 1],
        &[3, 2, 1, 0],
        &[1, 3, 0, 2],
    ];
    let mut runs = Vec::new();
    for arrangement in arrangements {
        let mut session = Session::new(SessionSettings::default());
        let mut sink = Collect::default();
        session.push(Input::Init(&truth.init(T0_NS, 0)), &mut sink);
        for k in 1..=2_000u64 {
            let t = T0_NS + k * DT_NS;
            let imu = Owned::Imu(truth.imu_at(t, k, t));
            let epoch = [
                Some(imu),
                (k % 200 == 0).then(|| Owned::Aid(msgs::AidSample::Srs(truth.srs(t, k)))),
                (k % 200 == 0).then(|| Owned::Aid(msgs::AidSample::Cns(truth.cns(t, k)))),
                (k % 20 == 0).then(|| Owned::Aid(msgs::AidSample::Baro(truth.baro(t, k)))),
            ];
            for &i in arrangement {
                if let Some(x) = &epoch[i] {
                    session.push(x.input(), &mut sink);
                }
            }
            // A live cycle ends now and then in the middle of an epoch.
            if k % 7 == 0 {
                session.flush(&mut sink);
            }
        }
        session.finish(&mut sink);
        let st = session.status();
        assert!(
            st.aid_counters(AidKind::Srs).accepted >= 9
                && st.aid_counters(AidKind::Cns).accepted >= 9
                && st.aid_counters(AidKind::Baro).accepted >= 90
        );
        runs.push(sink.solutions);
    }
    for (k, r) in runs.iter().enumerate().skip(1) {
        assert_eq!(r.len(), runs[0].len(), "arrangement {k}");
        let differing = r.iter().zip(&runs[0]).filter(|(a, b)| a != b).count();
        assert_eq!(
            differing, 0,
            "arrangement {k}: {differing} solutions differ"
        );
    }
}

/// Regression (found by the property above in CI on 2026-11-25; its
/// minimal case): an init stamped one period before the genuine line, a
/// hair off the polar axis (x = 1e-308 m, y = 1e-150 m), a CNS fix, then
/// one sample of a second publisher 1 ms ahead. The covariance is then
/// repaired in the grid frame at latitude 90° exactly; built in g and
/// converted, that P₀ had σ east = 0 (g's δλ is singular there). It is now
/// stated in G directly (`initial_covariance`).
#[test]
fn an_init_a_hair_off_the_polar_axis_then_a_second_publisher_keeps_sigma_positive() {
    let mut wild = vec![None; 16];
    wild[0] = Some(1.112_536_929_253_600_7e-308);
    wild[1] = Some(1.348_825_649_853_351_2e-150);
    wild[8] = Some(1.259_689_362_172_209_6e-206);
    let ops = [
        Op::One(InputOp::Init(InitSpec {
            stamp: Stamp::Gen(-1),
            seq: None,
            content: InitContent::Wild(wild),
        })),
        Op::One(InputOp::Cns(CnsSpec {
            stamp: Stamp::Gen(0),
            seq: None,
            lat: None,
            lon: None,
            sigma: None,
        })),
        Op::SecondPublisher {
            offset: 1_000_000,
            n: 1,
            block: 1,
        },
    ];
    ok(run_case(0.0, 20, &ops));
}
