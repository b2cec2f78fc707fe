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

use msgs::{ImuSample, InitState, PerAid, Solution, StreamCounters};
use nalgebra::{UnitQuaternion, Vector3};

use crate::aids::AidError;
use crate::checkpoint::Checkpoint;
use crate::earth;
use crate::error_model::Mat15;
use crate::frame_select::{FramePolicy, FrameSelector};
use crate::mech::{AnyNav, FrameKind, Increment, Nominal};
pub use crate::settings::{AidSet, Conversion};
use crate::settings::{AidSettings, FilterSettings};

mod error_state;
mod gating;
mod history;
mod imu_input;
mod level;
mod recovery;
mod reference;
pub(crate) mod report;
pub(crate) mod tape;
use error_state::ErrorState;
pub(crate) use error_state::phi_to;
use gating::AidGate;
pub use history::HISTORY as STATE_HISTORY_LEN;
use history::History;
use imu_input::ImuLimits;
pub use imu_input::{IMU_DT_RANGE_S, MAX_BRIDGE_STEPS};
pub use level::LevelCounters;
pub use recovery::{Rate, StreakVerdict, chi2_999_per_dof};

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
    /// A code that no sender writes.
    #[error("{field} = {value} is not one of {known}")]
    Unknown {
        field: &'static str,
        value: u8,
        known: &'static str,
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
    /// The measurement reached its gate and the aid's status records it
    /// (fused or rejected there): false for a disabled aid (not used) and
    /// for an update undone as invalid, which leave the status as it was.
    pub gated: bool,
    pub fused: bool,
    pub test_ratio: f64,
    /// SRS only: the body excluded by fault detection.
    pub excluded_body: Option<u32>,
}

/// The navigator state.
#[derive(Debug, Clone)]
pub struct Navigator {
    /// The nominal state and its cached geodetic position.
    nominal: Nominal,
    /// P, the bias estimates and the propagation interval.
    err: ErrorState,
    /// Aid selection, gates, timeouts, latency.
    aids: AidGate,
    prev_inc: Option<Increment>,
    selector: FrameSelector,
    conversion: Conversion,
    t_ns: u64,
    seq: u64,
    switch_count: u32,
    last_switch_t_ns: u64,
    imu: StreamCounters,
    limits: ImuLimits,
    imu_gap_count: u64,
    coasted_ns: u64,
    /// Set by a coasted gap / a checkpoint restore; cleared by the next fused aid.
    coasting: bool,
    resumed: bool,
    reset: ResetRecord,
    history: History,
    /// Flight-state recognition and attitude compensation.
    level: level::Level,
    /// Mechanization steps and covariance propagations since the start: the
    /// work the navigator did, for tests that bound the work per input.
    work: u64,
}

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

/// The largest 1-σ an init may state (defined with the settings, which
/// check a configured init against it before any navigator exists).
pub use crate::settings::INIT_SIGMA_MAX;
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
    if init.init_method().is_none() {
        // A known method with a heading aid it cannot have names the aid byte.
        let known = init.method <= msgs::init_method::AID_HEADING;
        let (field, value) = if known {
            ("init.heading_aid", init.heading_aid)
        } else {
            ("init.method", init.method)
        };
        return Err(InputRejection::Unknown {
            field,
            value,
            known: "method 0 given, 1 gyrocompass, 2 an aid's heading (with heading_aid an aid \
                    kind, else 0)",
        });
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
        // One initialization path in either frame: the state and P₀ are
        // built in g and, for a start in G, converted as a switch would
        // (papers/001 eqs 26, 32–36).
        let nav_g = AnyNav::from_frame_free(FrameKind::Geographic, &r_e, &v_e, &q_b_e);
        let nav = nav_g.converted(kind);
        Self {
            err: ErrorState::new(&nav_g, kind, init, f),
            work: 0,
            nominal: Nominal::new(nav),
            prev_inc: None,
            selector,
            conversion: config.conversion,
            t_ns: init.t_ns,
            seq: 0,
            switch_count: 0,
            last_switch_t_ns: 0,
            imu: StreamCounters::default(),
            aids: AidGate::new(a, config.aids),
            limits: ImuLimits::from_settings(f),
            imu_gap_count: 0,
            coasted_ns: 0,
            coasting: false,
            resumed: false,
            reset: ResetRecord::default(),
            history: History::new(nav),
            level: level::Level::new(&f.flight_state, f.process_noise().vrw, f.gyro_bias_dph),
        }
    }

    /// Takes a new init while running: the state and covariance start again
    /// from `init`; counters, sequence numbers and switch count carry on, and
    /// the step from the old state is published as a reset.
    pub fn reinitialize(&mut self, init: &InitState, config: &NavigatorConfig) {
        let old = self.solution();
        let mut fresh = Navigator::new(init, config);
        self.carry_accounting(&mut fresh);
        for (_, n) in fresh.aids.controls.iter_mut() {
            n.counters.last_t_ns = 0;
        }
        // The smoother's record goes on, broken here: nothing learned after
        // a new init says anything about the state before it.
        self.err.tape_break();
        fresh.err.tape = self.err.tape.take();
        fresh.err.set_clock(fresh.t_ns, true);
        *self = fresh;
        self.record_reset(&old);
    }

    /// What a navigator that replaces this one (a new init, or the
    /// integrity test's reference adopted) carries on: sequence numbers,
    /// switch count, the IMU's and every aid's counters, gaps and coasting,
    /// work, and the last reset.
    pub(super) fn carry_accounting(&self, new: &mut Navigator) {
        new.seq = self.seq;
        new.switch_count = self.switch_count;
        new.last_switch_t_ns = self.last_switch_t_ns;
        new.imu = self.imu;
        new.imu_gap_count = self.imu_gap_count;
        new.coasted_ns = self.coasted_ns;
        new.err.repairs = self.err.repairs;
        new.err.propagations = self.err.propagations;
        new.work = self.work;
        for ((_, n), (_, o)) in new.aids.controls.iter_mut().zip(self.aids.controls.iter()) {
            n.counters = o.counters;
        }
        new.reset = self.reset;
    }

    /// Keeps the smoother's record from now on ([`crate::smoother`]),
    /// starting with a break at the current state.
    pub fn enable_tape(&mut self) {
        if self.err.tape.is_none() {
            self.err.tape = Some(Vec::new());
            self.err.set_clock(self.t_ns, true);
            self.err.tape_break();
        }
    }

    /// Ends the smoother's record with a break at the current state (the end
    /// of the inputs: nothing is learned after it).
    pub fn end_tape(&mut self) {
        self.err.tape_break();
    }

    /// Records the solution `s` just emitted of the current state for the
    /// smoother (nothing when no record is kept).
    pub fn tape_solution(&mut self, s: &Solution) {
        if let Some(t) = &mut self.err.tape {
            tape::write::solution(
                t,
                s,
                self.nominal.nav(),
                &self.err.gyro_bias,
                &self.err.accel_bias,
            );
        }
    }

    /// The smoother's records since the last call (whole records, in the
    /// order they happened); empty when no record is kept. The buffer keeps
    /// its capacity, so the steady state allocates nothing.
    pub fn drain_tape(&mut self, mut to: impl FnMut(&[u8])) {
        if let Some(t) = &mut self.err.tape
            && !t.is_empty()
        {
            to(t);
            t.clear();
        }
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
        let ff = self.nominal.nav().frame_free();
        let q = ff.q_b_e.into_inner();
        let mut p = [0.0; 225];
        for (k, x) in p.iter_mut().enumerate() {
            *x = self.err.p[(k / 15, k % 15)];
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
            frame: self.nominal.nav().kind().to_wire() as u8,
            r_e_m: ff.r_e.into(),
            v_e_mps: ff.v_e.into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            p,
            gyro_bias_rps: self.err.gyro_bias.into(),
            accel_bias_mps2: self.err.accel_bias.into(),
            consider: self.err.consider.into(),
            consider_var: self.err.consider_var,
            // Row-major: the transpose's column-major storage.
            gnss_consider: self
                .err
                .gnss_c
                .transpose()
                .as_slice()
                .try_into()
                .expect("15 × 3"),
            gnss_consider_var: self.err.gnss_b.into(),
            // 0 while there is none (a checkpoint holds finite numbers).
            gnss_consider_tau_s: if self.err.gnss_b == Vector3::zeros() {
                0.0
            } else {
                self.err.gnss_tau_s
            },
            prev_inc,
            pending_cov: [
                self.err.acc_dt,
                self.err.acc_dv_b.x,
                self.err.acc_dv_b.y,
                self.err.acc_dv_b.z,
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
        n.nominal = Nominal::new(AnyNav::from_frame_free(
            kind,
            &Vector3::from(c.r_e_m),
            &Vector3::from(c.v_e_mps),
            &q,
        ));
        n.err.p = Mat15::from_row_slice(&c.p);
        n.err.gyro_bias = Vector3::from(c.gyro_bias_rps);
        n.err.accel_bias = Vector3::from(c.accel_bias_mps2);
        n.err.consider = c.consider.into();
        n.err.consider_var = c.consider_var;
        n.err.gnss_c = nalgebra::SMatrix::<f64, 15, 3>::from_row_slice(&c.gnss_consider);
        n.err.gnss_b = Vector3::from(c.gnss_consider_var);
        n.err.gnss_tau_s = if n.err.gnss_b == Vector3::zeros() {
            f64::INFINITY
        } else {
            c.gnss_consider_tau_s
        };
        let i = c.prev_inc;
        n.prev_inc = (i[6] > 0.0).then(|| Increment {
            d_theta: Vector3::new(i[0], i[1], i[2]),
            d_v: Vector3::new(i[3], i[4], i[5]),
            dt_s: i[6],
        });
        n.err.acc_dt = c.pending_cov[0];
        n.err.acc_dv_b = Vector3::new(c.pending_cov[1], c.pending_cov[2], c.pending_cov[3]);
        n.seq = c.seq;
        n.switch_count = c.switch_count;
        n.reset.count = c.reset_count;
        n.resumed = true;
        n
    }

    pub fn last_reset(&self) -> &ResetRecord {
        &self.reset
    }

    /// Resets to each aid so far.
    pub fn aid_resets(&self) -> PerAid<u32> {
        self.aids.resets
    }

    /// The tests' findings for the last reset to an aid.
    pub fn last_aid_reset(&self) -> Option<&StreakVerdict> {
        self.aids.last_reset_verdict.as_ref()
    }

    /// The bias model the last reset to an aid widened the process noise
    /// to; None if it did not (no reset yet, or one before had already).
    pub fn last_aid_reset_widened(&self) -> Option<&crate::settings::BiasModel> {
        self.aids.last_reset_widened.as_ref()
    }

    /// IMU gaps coasted and the sensor time coasted (ns).
    pub fn gaps(&self) -> (u64, u64) {
        (self.imu_gap_count, self.coasted_ns)
    }

    pub fn state(&self) -> &AnyNav {
        self.nominal.nav()
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
        &self.err.p
    }
    /// Estimated gyro (rad/s) and accelerometer (m/s²) biases.
    pub fn biases(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.err.gyro_bias, self.err.accel_bias)
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
        self.flight_step(&inc);
        self.t_ns = s.t_ns;
        self.err.set_clock(s.t_ns, false);
        self.seq += 1;
        self.history.push(self.t_ns, self.nominal.nav());

        let from = self.nominal.nav().kind();
        let lat = self.nominal.geo().lat_rad;
        let to = self.selector.decide(from, lat, self.t_ns);
        let switch = (to != from).then(|| self.switch_frame(to, lat));
        Ok(ImuOutcome { switch })
    }

    /// P brought up to the current time (a repair, if one was needed, is
    /// flagged `COASTING` until the next fused aid).
    fn propagate_covariance(&mut self) {
        if self.err.propagate(&self.nominal) {
            self.coasting = true;
        }
    }

    fn switch_frame(&mut self, to: FrameKind, lat: f64) -> SwitchEvent {
        self.propagate_covariance();
        let from = self.nominal.nav().kind();
        let before = *self.nominal.nav();
        self.nominal.convert(to);
        self.history.convert(to);
        if self.conversion == Conversion::Paper {
            self.err.convert(to, &before);
        } else {
            // The error state keeps the old frame's axes: the smoother
            // cannot carry its backward state across this switch.
            self.err.tape_break();
        }
        // The aids' innovations change axes with the frame.
        self.aids.clear_streaks();
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

    /// Mechanization steps plus covariance propagations so far (a measure of
    /// work that does not depend on the machine).
    pub fn work(&self) -> u64 {
        self.work + self.err.propagations
    }

    /// Covariance repairs since the start (a non-finite or non-positive P replaced).
    pub fn covariance_repairs(&self) -> u64 {
        self.err.repairs
    }
}
