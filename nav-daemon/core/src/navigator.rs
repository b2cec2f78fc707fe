//! The navigator core: a value fed time-stamped inputs, read for solutions.
//! Both the live daemon and `batch` drive this same code.
//!
//! Per IMU sample: bias compensation, mechanization, accumulation of the
//! interval for covariance propagation (every `covariance_interval_s`, and
//! before any update or frame switch). Per aid sample: covariance brought to
//! the current time, measurement model at the aid's own time stamp (the
//! nominal state interpolated from a history of the last 512 IMU epochs,
//! which every correction also shifts), χ²
//! gate, Joseph update, closed-loop feedback. At a frame switch the
//! nominal state is converted and, with `Conversion::Paper`, P = Φ P Φᵀ.
//! Nothing in the steady-state loop allocates.

use msgs::{
    AidStatus, BaroSample, CnsFix, ImuSample, InitState, Solution, SrsSample, Status,
    StreamCounters, solution_flags,
};
use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3};

use crate::aids::control::AidControl;
use crate::aids::{self, AidError, Measurement};
use crate::checkpoint::Checkpoint;
use crate::earth;
use crate::error_model::{self, Mat15, idx};
use crate::filter::{self, ProcessNoise};
use crate::frame_select::{FramePolicy, FrameSelector};
use crate::frames;
use crate::mech::{AnyNav, FrameKind, Increment};
pub use crate::settings::{AidSet, Conversion};
use crate::settings::{AidSettings, FilterSettings};
use crate::switch;

/// Navigator settings.
#[derive(Debug, Clone, PartialEq)]
pub struct NavigatorConfig {
    pub frame_policy: FramePolicy,
    pub conversion: Conversion,
    pub aids: AidSet,
    pub filter: FilterSettings,
    pub aid_settings: AidSettings,
}

impl Default for NavigatorConfig {
    fn default() -> Self {
        Self {
            frame_policy: FramePolicy::default(),
            conversion: Conversion::Paper,
            aids: AidSet::default(),
            filter: FilterSettings::default(),
            aid_settings: AidSettings::default(),
        }
    }
}

/// A frame switch, reported to consumers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchEvent {
    pub t_ns: u64,
    pub from: FrameKind,
    pub to: FrameKind,
    /// Switch count after this switch.
    pub count: u32,
    pub lat_rad: f64,
}

/// Why an input sample was not used.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum InputRejection {
    /// A value is NaN or infinite.
    #[error("non-finite value in {field}")]
    NonFinite { field: &'static str },
    /// The time stamp is not after the previous accepted one.
    #[error("time stamp {t_ns} ns not after the previous {prev_ns} ns")]
    TimeNotIncreasing { t_ns: u64, prev_ns: u64 },
    /// The interval length is not positive or disagrees with the time stamps.
    #[error("interval dt = {dt_s} s inconsistent with the time stamps")]
    BadInterval { dt_s: f64 },
    /// A value outside what the sensor can physically produce.
    #[error("{field} = {value} is physically impossible (limit {limit})")]
    Implausible {
        field: &'static str,
        value: f64,
        limit: f64,
    },
    /// An aid older than the allowed latency.
    #[error("aid at {t_ns} ns is {age_s:.3} s behind the IMU (limit {limit_s} s)")]
    TooLate { t_ns: u64, age_s: f64, limit_s: f64 },
    /// The time since the previous sample is longer than the longest gap that
    /// is coasted (`[filter] imu_max_coast_s`): a time jump, which only the
    /// session may confirm and re-synchronize to.
    #[error(
        "time stamp {t_ns} ns is {gap_s:.3} s after the previous one (longest coast {limit_s} s)"
    )]
    TimeJump { t_ns: u64, gap_s: f64, limit_s: f64 },
    /// An aid ahead of the newest IMU sample (the caller must feed IMU first).
    #[error("aid at {t_ns} ns is ahead of the newest IMU sample at {imu_ns} ns")]
    AheadOfImu { t_ns: u64, imu_ns: u64 },
    /// The aid's content could not be used.
    #[error(transparent)]
    Aid(#[from] AidError),
}

/// Outcome of one accepted IMU sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuOutcome {
    pub switch: Option<SwitchEvent>,
}

/// Outcome of one aid sample that reached the gate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AidOutcome {
    pub fused: bool,
    pub test_ratio: f64,
    /// SRS only: the body excluded by fault detection.
    pub excluded_body: Option<u32>,
}

/// The navigator state.
#[derive(Debug, Clone)]
pub struct Navigator {
    nav: AnyNav,
    /// Geodetic position of `nav`, kept current after every change of `nav`.
    geo: earth::Geodetic,
    prev_inc: Option<Increment>,
    selector: FrameSelector,
    conversion: Conversion,
    aid_set: AidSet,
    noise: ProcessNoise,
    cov_interval_s: f64,
    max_latency_ns: u64,
    t_ns: u64,
    seq: u64,
    switch_count: u32,
    last_switch_t_ns: u64,
    imu: StreamCounters,
    p: Mat15,
    gyro_bias: Vector3<f64>,
    accel_bias: Vector3<f64>,
    acc_dt: f64,
    acc_dv_b: Vector3<f64>,
    srs: AidControl,
    cns: AidControl,
    baro: AidControl,
    last_rejected: bool,
    limits: ImuLimits,
    imu_gap_count: u64,
    coasted_ns: u64,
    /// Set by a coasted gap / a checkpoint restore; cleared by the next fused aid.
    coasting: bool,
    resumed: bool,
    reset: ResetRecord,
    history: History,
    bias_sigma: BiasSigma,
    covariance_repairs: u64,
    /// Mechanization steps and covariance propagations since the start: the
    /// work the navigator did, for tests that bound the work per input.
    work: u64,
}

/// Length of the state history: 0.5 s at 1 kHz, 2.5 s at 200 Hz.
const HISTORY: usize = 512;

/// Nominal states after the last IMU samples (a ring), so that an aid that
/// arrives late is fused against the state at its own time. Stored as they
/// are (a copy per sample); converted only when an aid needs one.
#[derive(Debug, Clone)]
struct History {
    t_ns: [u64; HISTORY],
    nav: [AnyNav; HISTORY],
    /// Index of the newest entry.
    head: usize,
    len: usize,
}

impl History {
    fn new(nav: AnyNav) -> Self {
        Self {
            t_ns: [0; HISTORY],
            nav: [nav; HISTORY],
            head: HISTORY - 1,
            len: 0,
        }
    }

    fn clear(&mut self) {
        self.len = 0;
    }

    fn push(&mut self, t_ns: u64, nav: &AnyNav) {
        self.head = (self.head + 1) % HISTORY;
        self.t_ns[self.head] = t_ns;
        self.nav[self.head] = *nav;
        self.len = (self.len + 1).min(HISTORY);
    }

    /// Converts the stored states to the frame `to` (at a frame switch).
    fn convert(&mut self, to: FrameKind) {
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            self.nav[i] = self.nav[i].converted(to);
        }
    }

    /// Applies the correction just made to the current state to the stored
    /// states from `oldest_ns` on (older ones can no longer be used and are
    /// dropped). Stored states are in the current frame (the history is
    /// converted at a frame switch), so the same error-state feedback applies;
    /// they differ from the current state by at most the latency limit.
    fn correct(
        &mut self,
        oldest_ns: u64,
        phi: &Vector3<f64>,
        dv: &Vector3<f64>,
        dp: &Vector3<f64>,
    ) {
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            if self.t_ns[i] < oldest_ns {
                self.len = k;
                break;
            }
            self.nav[i].correct(phi, dv, dp);
        }
    }

    /// The frame-free state at `t_ns`, linear between the stored states
    /// around it (attitude by slerp); `None` outside.
    fn at(&self, t_ns: u64) -> Option<(Vector3<f64>, Vector3<f64>, UnitQuaternion<f64>)> {
        let mut newer = self.head;
        for k in 0..self.len {
            let i = (self.head + HISTORY - k) % HISTORY;
            let t = self.t_ns[i];
            if t == t_ns {
                let ff = self.nav[i].frame_free();
                return Some((ff.r_e, ff.v_e, ff.q_b_e));
            }
            if t < t_ns {
                if k == 0 {
                    return None;
                }
                let w = (t_ns - t) as f64 / (self.t_ns[newer] - t) as f64;
                let (a, b) = (self.nav[i].frame_free(), self.nav[newer].frame_free());
                let q = a.q_b_e.try_slerp(&b.q_b_e, w, 1e-12).unwrap_or(b.q_b_e);
                return Some((a.r_e.lerp(&b.r_e, w), a.v_e.lerp(&b.v_e, w), q));
            }
            newer = i;
        }
        None
    }
}

/// Input plausibility and gap handling, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ImuLimits {
    max_rate_rps: f64,
    max_accel_mps2: f64,
    gap_s: f64,
    max_coast_s: f64,
    coast_accel_mps2: f64,
    coast_rate_rps: f64,
}

/// Shortest and longest IMU interval a sample may state (s): 100 kHz and
/// 1 Hz, beyond any strapdown IMU this navigator is built for.
pub const IMU_DT_RANGE_S: (f64, f64) = (1e-5, 1.0);

/// Most mechanization steps a bridged or coasted gap takes, so that a gap
/// costs bounded work whatever its length (up to `imu_max_coast_s`).
pub const MAX_BRIDGE_STEPS: u64 = 64;

/// The last reset of the navigation state and the step it made.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ResetRecord {
    pub count: u32,
    pub t_ns: u64,
    pub delta_pos_e_m: [f64; 3],
    pub delta_vel_e_mps: [f64; 3],
    pub delta_heading_rad: f64,
}

fn secs_to_ns(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

/// The largest 1-σ an init may state: position 100 km, velocity 1 km/s,
/// tilt 1 rad, heading 2π (beyond these the state carries no information
/// and P₀ would span more magnitudes than a double resolves).
pub const INIT_SIGMA_MAX: [f64; 6] = [1e5, 1e5, 1e3, 1e3, 1.0, std::f64::consts::TAU];
/// The smallest 1-σ P₀ is built from (smaller ones, an "exact" init
/// included, are raised to these): position 1 cm, velocity 1 mm/s, attitude
/// 1 µrad.
pub const INIT_SIGMA_FLOOR: [f64; 6] = [1e-2, 1e-2, 1e-3, 1e-3, 1e-6, 1e-6];

/// Checks an init record before a navigator is built from it: finite
/// values, a position between 1 km below and 100 km above the ellipsoid's
/// radius range, a speed below 1 km/s, a quaternion of unit norm (±10 %),
/// and σ that are not negative and not above [`INIT_SIGMA_MAX`].
pub fn check_init(init: &InitState) -> Result<(), InputRejection> {
    let sigmas = [
        init.sigma_pos_h_m,
        init.sigma_pos_v_m,
        init.sigma_vel_h_mps,
        init.sigma_vel_v_mps,
        init.sigma_tilt_rad,
        init.sigma_heading_rad,
    ];
    let all = init
        .r_e_m
        .iter()
        .chain(&init.v_e_mps)
        .chain(&init.q_b_e)
        .chain(&sigmas);
    if all.clone().any(|x| !x.is_finite()) {
        return Err(InputRejection::NonFinite { field: "init" });
    }
    let implausible = |field, value: f64, limit| {
        Err(InputRejection::Implausible {
            field,
            value,
            limit,
        })
    };
    let r = Vector3::from(init.r_e_m).norm();
    if !(6_355_000.0..=6_478_137.0).contains(&r) {
        return implausible("init |r_e| (m)", r, 6_478_137.0);
    }
    let v = Vector3::from(init.v_e_mps).norm();
    if v > 1000.0 {
        return implausible("init speed (m/s)", v, 1000.0);
    }
    let q = init.q_b_e.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(0.9..=1.1).contains(&q) {
        return implausible("init quaternion norm", q, 1.1);
    }
    if let Some(neg) = sigmas.iter().find(|x| **x < 0.0) {
        return implausible("init σ", *neg, 0.0);
    }
    const NAMES: [&str; 6] = [
        "init.sigma_pos_h_m",
        "init.sigma_pos_v_m",
        "init.sigma_vel_h_mps",
        "init.sigma_vel_v_mps",
        "init.sigma_tilt_rad",
        "init.sigma_heading_rad",
    ];
    for ((x, max), name) in sigmas.iter().zip(INIT_SIGMA_MAX).zip(NAMES) {
        if *x > max {
            return implausible(name, *x, max);
        }
    }
    Ok(())
}

impl Navigator {
    /// Starts from an init record (see [`check_init`] for what a caller
    /// should verify first).
    pub fn new(init: &InitState, config: &NavigatorConfig) -> Self {
        let r_e = Vector3::from(init.r_e_m);
        let v_e = Vector3::from(init.v_e_mps);
        let [w, x, y, z] = init.q_b_e;
        let q_b_e = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let selector = FrameSelector::new(config.frame_policy.clone());
        let lat = earth::ecef_to_geodetic(&r_e).lat_rad;
        let kind = selector.initial(lat);
        let a = &config.aid_settings;
        let f = &config.filter;
        let bias_sigma = BiasSigma::from_settings(f);
        // One initialization path in either frame: P₀ is stated in g (the
        // init's σ are horizontal/vertical), and a start in G is the start in
        // g converted with Φ, as a switch would (papers/001 eqs 26, 32–36).
        let nav_g = AnyNav::from_frame_free(FrameKind::Geographic, &r_e, &v_e, &q_b_e);
        let p_g = initial_covariance(&nav_g, init, &bias_sigma);
        let nav = nav_g.converted(kind);
        let mut n = Self {
            p: p_g,
            bias_sigma,
            covariance_repairs: 0,
            work: 0,
            geo: nav.geodetic(),
            nav,
            prev_inc: None,
            selector,
            conversion: config.conversion,
            aid_set: config.aids,
            noise: f.process_noise(),
            cov_interval_s: f.covariance_interval_s,
            max_latency_ns: secs_to_ns(a.max_latency_s),
            t_ns: init.t_ns,
            seq: 0,
            switch_count: 0,
            last_switch_t_ns: 0,
            imu: StreamCounters::default(),
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            acc_dt: 0.0,
            acc_dv_b: Vector3::zeros(),
            srs: AidControl::new(a.srs_gate, secs_to_ns(a.srs_timeout_s)),
            cns: AidControl::new(a.cns_gate, secs_to_ns(a.cns_timeout_s)),
            baro: AidControl::new(a.baro_gate, secs_to_ns(a.baro_timeout_s)),
            last_rejected: false,
            limits: ImuLimits {
                max_rate_rps: f.max_gyro_rate_dps.to_radians(),
                max_accel_mps2: f.max_accel_mps2,
                gap_s: f.imu_gap_s,
                max_coast_s: f.imu_max_coast_s,
                coast_accel_mps2: f.coast_accel_mps2,
                coast_rate_rps: f.coast_rate_dps.to_radians(),
            },
            imu_gap_count: 0,
            coasted_ns: 0,
            coasting: false,
            resumed: false,
            reset: ResetRecord::default(),
            history: History::new(nav),
        };
        if kind == FrameKind::Grid {
            let phi = n.phi_to(FrameKind::Grid, &nav_g);
            n.p = phi * n.p * phi.transpose();
            filter::symmetrize(&mut n.p);
        }
        n
    }

    /// Takes a new init while running: the state and covariance start again
    /// from `init`; counters, sequence numbers and switch count carry on, and
    /// the step from the old state is published as a reset.
    pub fn reinitialize(&mut self, init: &InitState, config: &NavigatorConfig) {
        let old = self.solution();
        let mut fresh = Navigator::new(init, config);
        fresh.seq = self.seq;
        fresh.switch_count = self.switch_count;
        fresh.last_switch_t_ns = self.last_switch_t_ns;
        fresh.imu = self.imu;
        fresh.imu_gap_count = self.imu_gap_count;
        fresh.coasted_ns = self.coasted_ns;
        fresh.covariance_repairs = self.covariance_repairs;
        fresh.work = self.work;
        for (n, o) in [
            (&mut fresh.srs, &self.srs),
            (&mut fresh.cns, &self.cns),
            (&mut fresh.baro, &self.baro),
        ] {
            n.counters = o.counters;
            n.counters.last_t_ns = 0;
        }
        fresh.reset = self.reset;
        *self = fresh;
        self.record_reset(&old);
    }

    /// Records the step from `old` to the current state as a reset.
    fn record_reset(&mut self, old: &Solution) {
        let new = self.solution();
        let d = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let pi = std::f64::consts::PI;
        self.reset = ResetRecord {
            count: self.reset.count + 1,
            t_ns: self.t_ns,
            delta_pos_e_m: d(new.r_e_m, old.r_e_m),
            delta_vel_e_mps: d(new.v_e_mps, old.v_e_mps),
            delta_heading_rad: (new.heading_rad - old.heading_rad + pi).rem_euclid(2.0 * pi) - pi,
        };
    }

    /// The state to resume from after a restart.
    pub fn checkpoint(&self) -> Checkpoint {
        let ff = self.nav.frame_free();
        let q = ff.q_b_e.into_inner();
        let mut p = [0.0; 225];
        for (k, x) in p.iter_mut().enumerate() {
            *x = self.p[(k / 15, k % 15)];
        }
        let prev_inc = self.prev_inc.map_or([0.0; 7], |i| {
            [
                i.d_theta.x,
                i.d_theta.y,
                i.d_theta.z,
                i.d_v.x,
                i.d_v.y,
                i.d_v.z,
                i.dt_s,
            ]
        });
        Checkpoint {
            t_ns: self.t_ns,
            seq: self.seq,
            switch_count: self.switch_count,
            reset_count: self.reset.count,
            frame: self.nav.kind().to_wire() as u8,
            r_e_m: ff.r_e.into(),
            v_e_mps: ff.v_e.into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            p,
            gyro_bias_rps: self.gyro_bias.into(),
            accel_bias_mps2: self.accel_bias.into(),
            prev_inc,
            pending_cov: [
                self.acc_dt,
                self.acc_dv_b.x,
                self.acc_dv_b.y,
                self.acc_dv_b.z,
            ],
        }
    }

    /// Resumes from a checkpoint: the state, covariance and biases as they were
    /// (in the checkpoint's frame), flagged `RESUMED` until the next fused aid.
    /// The time between the checkpoint and the next IMU sample is bridged like
    /// any IMU gap.
    pub fn from_checkpoint(c: &Checkpoint, config: &NavigatorConfig) -> Self {
        let kind = if c.frame == msgs::WireFrame::Grid as u8 {
            FrameKind::Grid
        } else {
            FrameKind::Geographic
        };
        let [w, x, y, z] = c.q_b_e;
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let init = InitState {
            t_ns: c.t_ns,
            r_e_m: c.r_e_m,
            v_e_mps: c.v_e_mps,
            q_b_e: c.q_b_e,
            ..Default::default()
        };
        let mut n = Navigator::new(&init, config);
        n.nav =
            AnyNav::from_frame_free(kind, &Vector3::from(c.r_e_m), &Vector3::from(c.v_e_mps), &q);
        n.geo = n.nav.geodetic();
        n.p = Mat15::from_row_slice(&c.p);
        n.gyro_bias = Vector3::from(c.gyro_bias_rps);
        n.accel_bias = Vector3::from(c.accel_bias_mps2);
        let i = c.prev_inc;
        n.prev_inc = (i[6] > 0.0).then(|| Increment {
            d_theta: Vector3::new(i[0], i[1], i[2]),
            d_v: Vector3::new(i[3], i[4], i[5]),
            dt_s: i[6],
        });
        n.acc_dt = c.pending_cov[0];
        n.acc_dv_b = Vector3::new(c.pending_cov[1], c.pending_cov[2], c.pending_cov[3]);
        n.seq = c.seq;
        n.switch_count = c.switch_count;
        n.reset.count = c.reset_count;
        n.resumed = true;
        n
    }

    pub fn last_reset(&self) -> &ResetRecord {
        &self.reset
    }

    /// IMU gaps coasted and the sensor time coasted (ns).
    pub fn gaps(&self) -> (u64, u64) {
        (self.imu_gap_count, self.coasted_ns)
    }

    pub fn state(&self) -> &AnyNav {
        &self.nav
    }
    pub fn t_ns(&self) -> u64 {
        self.t_ns
    }
    pub fn imu_counters(&self) -> &StreamCounters {
        &self.imu
    }
    pub fn switch_count(&self) -> u32 {
        self.switch_count
    }
    /// The error covariance in the current frame.
    pub fn covariance(&self) -> &Mat15 {
        &self.p
    }
    /// Estimated gyro (rad/s) and accelerometer (m/s²) biases.
    pub fn biases(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.gyro_bias, self.accel_bias)
    }

    fn validate(&self, s: &ImuSample) -> Result<Increment, InputRejection> {
        let finite = |a: &[f64; 3]| a.iter().all(|x| x.is_finite());
        if !finite(&s.d_theta_rad) {
            return Err(InputRejection::NonFinite {
                field: "imu.d_theta_rad",
            });
        }
        if !finite(&s.d_v_mps) {
            return Err(InputRejection::NonFinite {
                field: "imu.d_v_mps",
            });
        }
        if !s.dt_s.is_finite() {
            return Err(InputRejection::NonFinite { field: "imu.dt_s" });
        }
        let (dt_min, dt_max) = IMU_DT_RANGE_S;
        if !(dt_min..=dt_max).contains(&s.dt_s) {
            return Err(InputRejection::Implausible {
                field: "imu.dt_s (s)",
                value: s.dt_s,
                limit: if s.dt_s < dt_min { dt_min } else { dt_max },
            });
        }
        {
            let norm = |a: &[f64; 3]| Vector3::from(*a).norm();
            let rate = norm(&s.d_theta_rad) / s.dt_s;
            if rate > self.limits.max_rate_rps {
                return Err(InputRejection::Implausible {
                    field: "imu angular rate (rad/s)",
                    value: rate,
                    limit: self.limits.max_rate_rps,
                });
            }
            let accel = norm(&s.d_v_mps) / s.dt_s;
            if accel > self.limits.max_accel_mps2 {
                return Err(InputRejection::Implausible {
                    field: "imu specific force (m/s²)",
                    value: accel,
                    limit: self.limits.max_accel_mps2,
                });
            }
        }
        if s.t_ns <= self.t_ns {
            return Err(InputRejection::TimeNotIncreasing {
                t_ns: s.t_ns,
                prev_ns: self.t_ns,
            });
        }
        // The interval must be positive and may not exceed the time since the
        // previous sample by more than 1 %: a longer dt would claim motion over
        // time already integrated.
        let span_s = (s.t_ns - self.t_ns) as f64 * 1e-9;
        if span_s > self.limits.max_coast_s {
            return Err(InputRejection::TimeJump {
                t_ns: s.t_ns,
                gap_s: span_s,
                limit_s: self.limits.max_coast_s,
            });
        }
        if s.dt_s <= 0.0 || s.dt_s > span_s * 1.01 {
            return Err(InputRejection::BadInterval { dt_s: s.dt_s });
        }
        let d_theta = Vector3::from(s.d_theta_rad) - self.gyro_bias * s.dt_s;
        let d_v = Vector3::from(s.d_v_mps) - self.accel_bias * s.dt_s;
        Ok(Increment {
            d_theta,
            d_v,
            dt_s: s.dt_s,
        })
    }

    /// Integrates one IMU sample; the frame switch, if due, happens after the step.
    pub fn on_imu(&mut self, s: &ImuSample) -> Result<ImuOutcome, InputRejection> {
        self.imu.received += 1;
        let inc = match self.validate(s) {
            Ok(inc) => inc,
            Err(e) => {
                match e {
                    InputRejection::TimeNotIncreasing { .. } | InputRejection::TimeJump { .. } => {
                        self.imu.rejected_time += 1
                    }
                    _ => self.imu.rejected_invalid += 1,
                }
                return Err(e);
            }
        };
        self.imu.accepted += 1;
        self.imu.last_t_ns = s.t_ns;
        // Time not covered by any interval (samples lost upstream): bridge it.
        let missing_s = (s.t_ns - self.t_ns) as f64 * 1e-9 - inc.dt_s;
        if missing_s > 0.5 * inc.dt_s {
            self.bridge(missing_s, &inc);
        }
        self.integrate(&inc);
        self.t_ns = s.t_ns;
        self.seq += 1;
        self.history.push(self.t_ns, &self.nav);

        let from = self.nav.kind();
        let lat = self.geo.lat_rad;
        let to = self.selector.decide(from, lat, self.t_ns);
        let switch = (to != from).then(|| self.switch_frame(to, lat));
        Ok(ImuOutcome { switch })
    }

    /// Mechanization and covariance bookkeeping of one increment.
    fn integrate(&mut self, inc: &Increment) {
        self.work += 1;
        let prev = self.prev_inc.unwrap_or(*inc);
        self.nav = self.nav.mechanize_at(&self.geo, &prev, inc);
        self.geo = self.nav.geodetic();
        self.prev_inc = Some(*inc);
        self.acc_dt += inc.dt_s;
        self.acc_dv_b += inc.d_v;
        if self.acc_dt >= self.cov_interval_s * (1.0 - 1e-9) {
            self.propagate_covariance();
        }
    }

    /// Carries the state across `missing_s` of IMU time on the last rates held
    /// constant (steps no longer than the nominal interval). A gap longer than
    /// `imu_gap_s` is coasted: counted, flagged, and its unknown manoeuvre
    /// added to the covariance.
    fn bridge(&mut self, missing_s: f64, next: &Increment) {
        let last = self.prev_inc.unwrap_or(*next);
        // At most MAX_BRIDGE_STEPS steps: bounded work for any gap up to the
        // longest coast (longer ones are time jumps, refused in `validate`).
        let n = (missing_s / last.dt_s)
            .ceil()
            .clamp(1.0, MAX_BRIDGE_STEPS as f64);
        let h = missing_s / n;
        let step = Increment {
            d_theta: last.d_theta * (h / last.dt_s),
            d_v: last.d_v * (h / last.dt_s),
            dt_s: h,
        };
        for _ in 0..n as u64 {
            self.integrate(&step);
        }
        if missing_s > self.limits.gap_s {
            self.coast(missing_s);
        }
    }

    /// Re-synchronizes to a confirmed time jump: the state is kept, the time
    /// base moves to `t_ns` (the start of the first sample after the jump),
    /// and the covariance grows as for a coast of the longest coasted gap
    /// (the true time elapsed is unknown). The state history and the aids'
    /// time order start again.
    pub fn resync(&mut self, t_ns: u64) {
        self.propagate_covariance();
        self.t_ns = t_ns;
        self.history.clear();
        for c in [&mut self.srs, &mut self.cns, &mut self.baro] {
            c.counters.last_t_ns = 0;
        }
        self.coast(self.limits.max_coast_s);
    }

    /// A gap of `gap_s` without IMU data: counted, flagged `COASTING`, and
    /// covered by the covariance of an unknown manoeuvre over it.
    fn coast(&mut self, missing_s: f64) {
        self.imu_gap_count += 1;
        self.coasted_ns = self
            .coasted_ns
            .saturating_add((missing_s * 1e9).round() as u64);
        self.coasting = true;
        self.propagate_covariance();
        let (sa, sw, t) = (
            self.limits.coast_accel_mps2,
            self.limits.coast_rate_rps,
            missing_s,
        );
        // Unknown acceleration a over the gap: δv = a t, δp = a t²/2 (per axis).
        let var_v = (sa * t).powi(2);
        let var_p = (0.5 * sa * t * t).powi(2);
        let var_phi = (sw * t).powi(2);
        let geo = self.geo;
        let m = self.position_map_enu(&frames::c_e_g(geo.lat_rad, geo.lon_rad));
        let m_inv = m.try_inverse().unwrap_or_else(Matrix3::identity);
        let add_p = m_inv * m_inv.transpose() * var_p;
        for i in 0..3 {
            self.p[(idx::DV + i, idx::DV + i)] += var_v;
            self.p[(idx::PHI + i, idx::PHI + i)] += var_phi;
            for j in 0..3 {
                self.p[(idx::DP + i, idx::DP + j)] += add_p[(i, j)];
            }
        }
    }

    /// P brought up to the current time with the mean specific force of the interval.
    fn propagate_covariance(&mut self) {
        if self.acc_dt <= 0.0 {
            return;
        }
        self.work += 1;
        let f_b = self.acc_dv_b / self.acc_dt;
        let mut f = match &self.nav {
            AnyNav::Geographic(s) => {
                let c = s.q_b_n.to_rotation_matrix().into_inner();
                error_model::f_geo(&s.pos, &s.v_n, &c, &(c * f_b))
            }
            AnyNav::Grid(s) => {
                let c = s.q_b_n.to_rotation_matrix().into_inner();
                error_model::f_grid(&s.pos, &s.v_n, &c, &(c * f_b))
            }
        };
        self.noise.add_bias_dynamics(&mut f);
        filter::propagate(&mut self.p, &f, &self.noise, self.acc_dt);
        self.acc_dt = 0.0;
        self.acc_dv_b = Vector3::zeros();
        if !covariance_usable(&self.p) {
            self.repair_covariance();
        }
    }

    fn switch_frame(&mut self, to: FrameKind, lat: f64) -> SwitchEvent {
        self.propagate_covariance();
        let from = self.nav.kind();
        let before = self.nav;
        self.nav = self.nav.converted(to);
        self.geo = self.nav.geodetic();
        self.history.convert(to);
        if self.conversion == Conversion::Paper {
            let phi = self.phi_to(to, &before);
            self.p = phi * self.p * phi.transpose();
            filter::symmetrize(&mut self.p);
        }
        self.switch_count += 1;
        self.last_switch_t_ns = self.t_ns;
        SwitchEvent {
            t_ns: self.t_ns,
            from,
            to,
            count: self.switch_count,
            lat_rad: lat,
        }
    }

    /// Checks an aid's time stamp; returns its age behind the IMU (s).
    fn aid_age(&self, t_ns: u64) -> Result<f64, InputRejection> {
        if t_ns > self.t_ns {
            return Err(InputRejection::AheadOfImu {
                t_ns,
                imu_ns: self.t_ns,
            });
        }
        let age = self.t_ns - t_ns;
        if age > self.max_latency_ns {
            return Err(InputRejection::TooLate {
                t_ns,
                age_s: age as f64 * 1e-9,
                limit_s: self.max_latency_ns as f64 * 1e-9,
            });
        }
        Ok(age as f64 * 1e-9)
    }

    /// The nominal state at an aid's time `t_ns`, `age_s` behind the newest
    /// IMU sample: interpolated from the state history (kept consistent with
    /// every correction since), so a late aid is fused at its own time. If the
    /// history does not reach back that far (just after a start), the
    /// position is moved back along the velocity instead.
    fn state_at(&self, t_ns: u64, age_s: f64) -> AnyNav {
        if age_s == 0.0 {
            return self.nav;
        }
        if let Some((r, v, q)) = self.history.at(t_ns) {
            return AnyNav::from_frame_free(self.nav.kind(), &r, &v, &q);
        }
        let ff = self.nav.frame_free();
        AnyNav::from_frame_free(
            self.nav.kind(),
            &(ff.r_e - ff.v_e * age_s),
            &ff.v_e,
            &ff.q_b_e,
        )
    }

    /// Replaces a covariance that lost finiteness or positive variances by
    /// the re-inflated one a cold start would have (P₀ from the largest σ an
    /// init may state, in the current frame), counts it and flags
    /// `COASTING` until an aid is fused: a published σ is never a NaN in
    /// disguise.
    fn repair_covariance(&mut self) {
        let wide = InitState {
            sigma_pos_h_m: REPAIR_SIGMA.0,
            sigma_pos_v_m: REPAIR_SIGMA.0,
            sigma_vel_h_mps: REPAIR_SIGMA.1,
            sigma_vel_v_mps: REPAIR_SIGMA.1,
            sigma_tilt_rad: REPAIR_SIGMA.2,
            sigma_heading_rad: REPAIR_SIGMA.2,
            ..Default::default()
        };
        let geo_nav = self.nav.converted(FrameKind::Geographic);
        let p_g = initial_covariance(&geo_nav, &wide, &self.bias_sigma);
        self.p = match self.nav.kind() {
            FrameKind::Geographic => p_g,
            FrameKind::Grid => {
                let phi = self.phi_to(FrameKind::Grid, &geo_nav);
                phi * p_g * phi.transpose()
            }
        };
        filter::symmetrize(&mut self.p);
        self.covariance_repairs += 1;
        self.coasting = true;
    }

    /// Φ of the parameter conversion from `from` (a state in the other
    /// frame) to `to` (papers/001 eqs 32–38).
    fn phi_to(&self, to: FrameKind, from: &AnyNav) -> Mat15 {
        let geo = from.geodetic();
        let v_grid = match (from, &from.converted(FrameKind::Grid)) {
            (AnyNav::Grid(g), _) | (_, AnyNav::Grid(g)) => g.v_n,
            _ => unreachable!("conversion to grid gives the grid frame"),
        };
        match to {
            FrameKind::Grid => switch::phi_geo_to_grid(&geo, &v_grid),
            FrameKind::Geographic => switch::phi_grid_to_geo(&geo, &v_grid),
        }
    }

    /// Mechanization steps plus covariance propagations so far (a measure of
    /// work that does not depend on the machine).
    pub fn work(&self) -> u64 {
        self.work
    }

    /// Covariance repairs since the start (a non-finite or non-positive P replaced).
    pub fn covariance_repairs(&self) -> u64 {
        self.covariance_repairs
    }

    /// Gate, update and feedback for one measurement. An update that would
    /// leave P or the correction non-finite (σ at the edge of the range, a
    /// degenerate geometry) is undone and counted as invalid.
    fn fuse<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        m: &Measurement<M>,
    ) -> AidOutcome {
        let gate = self.control(which).gate;
        let before = self.p;
        let out = filter::update(&mut self.p, &m.z, &m.h, &m.r, gate)
            .filter(|o| o.dx.iter().all(|x| x.is_finite()) && o.test_ratio.is_finite());
        if out.is_none() || !covariance_usable(&self.p) {
            self.p = before;
        }
        let Some(out) = out.filter(|_| covariance_usable(&self.p)) else {
            self.control_mut(which).rejected_invalid();
            return AidOutcome {
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            };
        };
        self.control_mut(which).record(t_ns, &out);
        self.last_rejected = !out.fused;
        if out.fused {
            self.coasting = false;
            self.resumed = false;
            let dx = out.dx;
            let part = |o: usize| Vector3::new(dx[o], dx[o + 1], dx[o + 2]);
            let (phi, dv, dp) = (part(idx::PHI), part(idx::DV), part(idx::DP));
            self.nav.correct(&phi, &dv, &dp);
            self.geo = self.nav.geodetic();
            // Only states an aid may still be fused against (within the latency limit).
            let oldest = t_ns.min(self.t_ns).saturating_sub(self.max_latency_ns);
            self.history.correct(oldest, &phi, &dv, &dp);
            self.gyro_bias += part(idx::BG);
            self.accel_bias += part(idx::BA);
        }
        AidOutcome {
            fused: out.fused,
            test_ratio: out.test_ratio,
            excluded_body: None,
        }
    }

    fn control(&self, which: AidKind) -> &AidControl {
        match which {
            AidKind::Srs => &self.srs,
            AidKind::Cns => &self.cns,
            AidKind::Baro => &self.baro,
        }
    }
    fn control_mut(&mut self, which: AidKind) -> &mut AidControl {
        match which {
            AidKind::Srs => &mut self.srs,
            AidKind::Cns => &mut self.cns,
            AidKind::Baro => &mut self.baro,
        }
    }

    /// Common path of every aid: counters, time check, model, fusion.
    fn on_aid<const M: usize>(
        &mut self,
        which: AidKind,
        t_ns: u64,
        model: impl FnOnce(&AnyNav) -> Result<(Measurement<M>, Option<u32>), AidError>,
    ) -> Result<AidOutcome, InputRejection> {
        self.control_mut(which).received();
        let enabled = match which {
            AidKind::Srs => self.aid_set.srs,
            AidKind::Cns => self.aid_set.cns,
            AidKind::Baro => self.aid_set.baro,
        };
        if !enabled {
            self.control_mut(which).counters.not_used += 1;
            return Ok(AidOutcome {
                fused: false,
                test_ratio: f64::NAN,
                excluded_body: None,
            });
        }
        let age = match self.aid_age(t_ns) {
            Ok(a) => a,
            Err(e) => {
                self.control_mut(which).rejected_time();
                return Err(e);
            }
        };
        if t_ns <= self.control(which).counters.last_t_ns
            && self.control(which).counters.accepted > 0
        {
            self.control_mut(which).rejected_time();
            return Err(InputRejection::TimeNotIncreasing {
                t_ns,
                prev_ns: self.control(which).counters.last_t_ns,
            });
        }
        self.propagate_covariance();
        let at = self.state_at(t_ns, age);
        let (m, excluded) = match model(&at) {
            Ok(x) => x,
            Err(e) => {
                self.control_mut(which).rejected_invalid();
                return Err(e.into());
            }
        };
        let mut out = self.fuse(which, t_ns, &m);
        out.excluded_body = excluded;
        if excluded.is_some() {
            self.control_mut(which).status.exclusions += 1;
        }
        Ok(out)
    }

    pub fn on_srs(&mut self, s: &SrsSample) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Srs, s.t_ns, |n| {
            aids::srs::measurement(n, s).map(|(m, sol)| (m, sol.excluded_body))
        })
    }
    pub fn on_cns(&mut self, c: &CnsFix) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Cns, c.t_ns, |n| {
            aids::cns::measurement(n, c).map(|m| (m, None))
        })
    }
    pub fn on_baro(&mut self, b: &BaroSample) -> Result<AidOutcome, InputRejection> {
        self.on_aid(AidKind::Baro, b.t_ns, |n| {
            aids::baro::measurement(n, b).map(|m| (m, None))
        })
    }

    /// Covariances of position (m²), velocity (m²/s²) and attitude error (rad²),
    /// all in local east/north/up axes: the filter's P mapped out of its frame.
    pub fn covariances_enu(&self) -> (Matrix3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let geo = self.geo;
        self.covariances_enu_at(
            &self.nav.c_e_n_at(&geo),
            &frames::c_e_g(geo.lat_rad, geo.lon_rad),
        )
    }

    /// δp → local ENU metres (g: from δL, δλ, δh; G: C_e^g on ECEF δr).
    fn position_map_enu(&self, c_e_g: &Matrix3<f64>) -> Matrix3<f64> {
        match &self.nav {
            AnyNav::Geographic(s) => {
                let (rm, rn) = earth::radii(s.pos.lat_rad);
                let e = (rn + s.pos.h_m) * s.pos.lat_rad.cos();
                Matrix3::new(0.0, e, 0.0, rm + s.pos.h_m, 0.0, 0.0, 0.0, 0.0, 1.0)
            }
            AnyNav::Grid(_) => *c_e_g,
        }
    }

    fn block_in(&self, o: usize, m: &Matrix3<f64>) -> Matrix3<f64> {
        m * self.p.fixed_view::<3, 3>(o, o) * m.transpose()
    }

    fn covariances_enu_at(
        &self,
        c_e_n: &Matrix3<f64>,
        c_e_g: &Matrix3<f64>,
    ) -> (Matrix3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let nav_to_enu = match &self.nav {
            AnyNav::Geographic(_) => Matrix3::identity(),
            AnyNav::Grid(_) => c_e_g * c_e_n.transpose(),
        };
        (
            self.block_in(idx::DP, &self.position_map_enu(c_e_g)),
            self.block_in(idx::DV, &nav_to_enu),
            self.block_in(idx::PHI, &nav_to_enu),
        )
    }

    /// 1-σ of position in local east/north/up (m).
    pub fn sigma_pos_enu(&self) -> Vector3<f64> {
        self.covariances_enu()
            .0
            .diagonal()
            .map(|v| v.max(0.0).sqrt())
    }

    fn flags(&self) -> u32 {
        let mut f = solution_flags::ALIGNED;
        if self.srs.fresh(self.t_ns) {
            f |= solution_flags::SRS_FRESH;
        }
        if self.cns.fresh(self.t_ns) {
            f |= solution_flags::CNS_FRESH;
        }
        if self.baro.fresh(self.t_ns) {
            f |= solution_flags::BARO_FRESH;
        }
        if self.last_rejected {
            f |= solution_flags::LAST_INNOVATION_REJECTED;
        }
        if self.coasting {
            f |= solution_flags::COASTING;
        }
        if self.resumed {
            f |= solution_flags::RESUMED;
        }
        f
    }

    /// The current solution.
    pub fn solution(&self) -> Solution {
        let geo = self.geo;
        let c_e_n = self.nav.c_e_n_at(&geo);
        let c_e_g = match &self.nav {
            AnyNav::Geographic(_) => c_e_n,
            AnyNav::Grid(_) => frames::c_e_g(geo.lat_rad, geo.lon_rad),
        };
        let ff = self.nav.frame_free_at(&geo, &c_e_n);
        let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
        let c_b_g = c_e_g * c_b_e;
        let (heading, pitch, roll) = frames::euler_from_c_b_n(&c_b_g);
        // σ from grid north's components on the local east and north axes.
        let sigma = match &self.nav {
            AnyNav::Grid(_) => {
                let grid_north = c_e_n.row(1);
                grid_north
                    .dot(&c_e_g.row(0))
                    .atan2(grid_north.dot(&c_e_g.row(1)))
            }
            AnyNav::Geographic(_) => frames::grid_angle(geo.lat_rad, geo.lon_rad),
        };
        // Only the position block is needed here (this runs every IMU sample).
        let cov_pos = self.block_in(idx::DP, &self.position_map_enu(&c_e_g));
        let grid_heading = (heading - sigma).rem_euclid(std::f64::consts::TAU);
        let q = ff.q_b_e.into_inner();
        let diag_sqrt = |o: usize| {
            Vector3::new(
                self.p[(o, o)],
                self.p[(o + 1, o + 1)],
                self.p[(o + 2, o + 2)],
            )
            .map(|v| v.max(0.0).sqrt())
        };
        Solution {
            t_ns: self.t_ns,
            seq: self.seq,
            lat_rad: geo.lat_rad,
            lon_rad: geo.lon_rad,
            h_m: geo.h_m,
            r_e_m: ff.r_e.into(),
            v_e_mps: ff.v_e.into(),
            v_enu_mps: (c_e_g * ff.v_e).into(),
            v_nav_mps: self.nav.v_n().into(),
            grid_angle_rad: sigma,
            q_b_e: [q.w, q.i, q.j, q.k],
            heading_rad: heading,
            grid_heading_rad: grid_heading,
            pitch_rad: pitch,
            roll_rad: roll,
            sigma_pos_enu_m: cov_pos.diagonal().map(|v| v.max(0.0).sqrt()).into(),
            sigma_vel_mps: diag_sqrt(idx::DV).into(),
            sigma_att_rad: diag_sqrt(idx::PHI).into(),
            gyro_bias_rps: self.gyro_bias.into(),
            accel_bias_mps2: self.accel_bias.into(),
            reset_t_ns: self.reset.t_ns,
            reset_delta_pos_e_m: self.reset.delta_pos_e_m,
            reset_delta_vel_e_mps: self.reset.delta_vel_e_mps,
            reset_delta_heading_rad: self.reset.delta_heading_rad,
            flags: self.flags(),
            switch_count: self.switch_count,
            reset_count: self.reset.count,
            frame: self.nav.kind().to_wire() as u8,
            _pad: [0; 3],
        }
    }

    /// Health record (loop timing is filled in by the live driver).
    pub fn status(&self) -> Status {
        let aid = |c: &AidControl| -> (StreamCounters, AidStatus) {
            (c.counters, c.status_at(self.t_ns))
        };
        let (srs, srs_aid) = aid(&self.srs);
        let (cns, cns_aid) = aid(&self.cns);
        let (baro, baro_aid) = aid(&self.baro);
        Status {
            t_ns: self.t_ns,
            imu: self.imu,
            srs,
            cns,
            baro,
            srs_aid,
            cns_aid,
            baro_aid,
            last_switch_t_ns: self.last_switch_t_ns,
            switch_count: self.switch_count,
            imu_gap_count: self.imu_gap_count,
            coasted_ns: self.coasted_ns,
            reset_count: self.reset.count,
            resumed: u8::from(self.resumed),
            flags: self.flags(),
            frame: self.nav.kind().to_wire() as u8,
            ..Default::default()
        }
    }
}

/// σ of the re-inflated covariance after a repair: position (m), velocity
/// (m/s), attitude (rad).
const REPAIR_SIGMA: (f64, f64, f64) = (1000.0, 10.0, 0.1);

/// A covariance the filter can go on with: every entry finite and every
/// variance positive (and not beyond 1e30: σ of 1e15 m or rad is no
/// information at all, and squaring it again would overflow).
fn covariance_usable(p: &Mat15) -> bool {
    p.iter().all(|x| x.is_finite())
        && (0..15).all(|i| p[(i, i)] > 0.0 && p[(i, i)] < 1e30)
        && positive_definite(p)
}

/// Cholesky factorization of the correlation matrix D^-½ P D^-½ (so that
/// states in rad² and m² weigh alike): every pivot must stay above 1e-12.
/// On the stack, about 600 flops.
fn positive_definite(p: &Mat15) -> bool {
    let mut d = [0.0; 15];
    for (i, x) in d.iter_mut().enumerate() {
        *x = 1.0 / p[(i, i)].sqrt();
    }
    let mut l = [[0.0f64; 15]; 15];
    for j in 0..15 {
        let pivot = 1.0 - l[j][..j].iter().map(|x| x * x).sum::<f64>();
        // NaN fails too.
        if pivot.partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let ljj = pivot.sqrt();
        l[j][j] = ljj;
        for i in j + 1..15 {
            let dot: f64 = l[i][..j].iter().zip(&l[j][..j]).map(|(a, b)| a * b).sum();
            l[i][j] = (p[(i, j)] * d[i] * d[j] - dot) / ljj;
        }
    }
    true
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AidKind {
    Srs,
    Cns,
    Baro,
}

/// Initial 1-σ of the biases in SI units (from `[filter]`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct BiasSigma {
    gyro_rps: f64,
    accel_mps2: f64,
}

impl BiasSigma {
    fn from_settings(f: &FilterSettings) -> Self {
        let dph = std::f64::consts::PI / 180.0 / 3600.0;
        let ug = 1e-6 * earth::G0;
        Self {
            gyro_rps: f.gyro_bias_dph * dph,
            accel_mps2: f.accel_bias_ug * ug,
        }
    }
}

/// P₀ of a state in the frame of `nav`, from the init record's σ and the
/// configured bias uncertainty. Only the geographic form is used to start:
/// a start in G converts it with Φ (see [`Navigator::new`]).
fn initial_covariance(nav: &AnyNav, init: &InitState, b: &BiasSigma) -> Mat15 {
    let mut p = Mat15::zeros();
    let sq = |x: f64| x * x;
    let f = INIT_SIGMA_FLOOR;
    let init = &InitState {
        sigma_pos_h_m: init.sigma_pos_h_m.max(f[0]),
        sigma_pos_v_m: init.sigma_pos_v_m.max(f[1]),
        sigma_vel_h_mps: init.sigma_vel_h_mps.max(f[2]),
        sigma_vel_v_mps: init.sigma_vel_v_mps.max(f[3]),
        sigma_tilt_rad: init.sigma_tilt_rad.max(f[4]),
        sigma_heading_rad: init.sigma_heading_rad.max(f[5]),
        ..*init
    };
    let mut set_diag = |o: usize, v: [f64; 3]| {
        for (i, x) in v.iter().enumerate() {
            p[(o + i, o + i)] = *x;
        }
    };
    set_diag(
        idx::PHI,
        [
            sq(init.sigma_tilt_rad),
            sq(init.sigma_tilt_rad),
            sq(init.sigma_heading_rad),
        ],
    );
    set_diag(
        idx::DV,
        [
            sq(init.sigma_vel_h_mps),
            sq(init.sigma_vel_h_mps),
            sq(init.sigma_vel_v_mps),
        ],
    );
    set_diag(idx::BG, [sq(b.gyro_rps); 3]);
    set_diag(idx::BA, [sq(b.accel_mps2); 3]);
    let (h, v) = (sq(init.sigma_pos_h_m), sq(init.sigma_pos_v_m));
    let geo = nav.geodetic();
    let pos: SMatrix<f64, 3, 3> = match nav {
        AnyNav::Geographic(_) => {
            let (rm, rn) = earth::radii(geo.lat_rad);
            Matrix3::from_diagonal(&Vector3::new(
                h / sq(rm + geo.h_m),
                // Within one position σ of the pole the longitude is unknown
                // by up to a radian, not more (the parallel's radius is held
                // at least that σ, and 1 m).
                h / sq(((rn + geo.h_m) * geo.lat_rad.cos()).max(init.sigma_pos_h_m.max(1.0))),
                v,
            ))
        }
        AnyNav::Grid(_) => {
            let c = frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose();
            c * Matrix3::from_diagonal(&Vector3::new(h, h, v)) * c.transpose()
        }
    };
    p.fixed_view_mut::<3, 3>(idx::DP, idx::DP).copy_from(&pos);
    // Variances of zero (an exact init) would make P singular: floor them.
    for i in 0..15 {
        p[(i, i)] = p[(i, i)].max(1e-30);
    }
    p
}
