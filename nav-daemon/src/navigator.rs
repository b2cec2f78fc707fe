//! The navigator core: a value fed time-stamped inputs, read for solutions.
//! Both the live daemon and `batch` drive this same code.
//!
//! This build runs the strapdown INS with the live frame switch; the
//! error-state filter and aids attach here (see the Estimator issue).

use msgs::{ImuSample, InitState, Solution, StreamCounters, solution_flags};
use nalgebra::{UnitQuaternion, Vector3};

use crate::frame_select::{FramePolicy, FrameSelector};
use crate::frames;
use crate::mech::{AnyNav, FrameKind, Increment};

/// Navigator settings.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NavigatorConfig {
    pub frame_policy: FramePolicy,
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
}

/// Outcome of one accepted IMU sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuOutcome {
    pub switch: Option<SwitchEvent>,
}

/// The navigator state.
#[derive(Debug, Clone)]
pub struct Navigator {
    nav: AnyNav,
    prev_inc: Option<Increment>,
    selector: FrameSelector,
    t_ns: u64,
    seq: u64,
    switch_count: u32,
    last_switch_t_ns: u64,
    imu: StreamCounters,
}

impl Navigator {
    /// Starts from an init record.
    pub fn new(init: &InitState, config: &NavigatorConfig) -> Self {
        let r_e = Vector3::from(init.r_e_m);
        let v_e = Vector3::from(init.v_e_mps);
        let [w, x, y, z] = init.q_b_e;
        let q_b_e = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let selector = FrameSelector::new(config.frame_policy.clone());
        let lat = crate::earth::ecef_to_geodetic(&r_e).lat_rad;
        let kind = selector.initial(lat);
        Self {
            nav: AnyNav::from_frame_free(kind, &r_e, &v_e, &q_b_e),
            prev_inc: None,
            selector,
            t_ns: init.t_ns,
            seq: 0,
            switch_count: 0,
            last_switch_t_ns: 0,
            imu: StreamCounters::default(),
        }
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
        if s.dt_s <= 0.0 || s.dt_s > span_s * 1.01 {
            return Err(InputRejection::BadInterval { dt_s: s.dt_s });
        }
        Ok(Increment {
            d_theta: Vector3::from(s.d_theta_rad),
            d_v: Vector3::from(s.d_v_mps),
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
                    InputRejection::TimeNotIncreasing { .. } => self.imu.rejected_time += 1,
                    _ => self.imu.rejected_invalid += 1,
                }
                return Err(e);
            }
        };
        self.imu.accepted += 1;
        self.imu.last_t_ns = s.t_ns;
        let prev = self.prev_inc.unwrap_or(inc);
        self.nav = self.nav.mechanize(&prev, &inc);
        self.prev_inc = Some(inc);
        self.t_ns = s.t_ns;
        self.seq += 1;

        let from = self.nav.kind();
        let lat = self.nav.geodetic().lat_rad;
        let to = self.selector.decide(from, lat, self.t_ns);
        let switch = (to != from).then(|| {
            self.nav = self.nav.converted(to);
            self.switch_count += 1;
            self.last_switch_t_ns = self.t_ns;
            SwitchEvent {
                t_ns: self.t_ns,
                from,
                to,
                count: self.switch_count,
                lat_rad: lat,
            }
        });
        Ok(ImuOutcome { switch })
    }

    /// The current solution.
    pub fn solution(&self) -> Solution {
        let ff = self.nav.frame_free();
        let geo = ff.geo;
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
        let c_b_g = c_e_g * c_b_e;
        let (heading, pitch, roll) = frames::euler_from_c_b_n(&c_b_g);
        let sigma = frames::grid_angle(geo.lat_rad, geo.lon_rad);
        let grid_heading = (heading - sigma).rem_euclid(std::f64::consts::TAU);
        let q = ff.q_b_e.into_inner();
        let nan3 = [f64::NAN; 3];
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
            // No covariance is propagated without the filter: reported as unknown.
            sigma_pos_enu_m: nan3,
            sigma_vel_mps: nan3,
            sigma_att_rad: nan3,
            gyro_bias_rps: [0.0; 3],
            accel_bias_mps2: [0.0; 3],
            flags: solution_flags::ALIGNED,
            switch_count: self.switch_count,
            frame: self.nav.kind().to_wire() as u8,
            _pad: [0; 7],
        }
    }
}
