//! IMU input: the checks of one sample (finite, physical rates, interval
//! and time stamps), the bridging of missing IMU time on the last
//! increments, the coasting of a longer gap, and the re-synchronization to a
//! confirmed time jump. Every path costs bounded work.

use msgs::ImuSample;
use nalgebra::Vector3;

use crate::mech::Increment;
use crate::settings::FilterSettings;

use super::{InputRejection, Navigator};

/// Input plausibility and gap handling, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ImuLimits {
    pub(super) max_rate_rps: f64,
    pub(super) max_accel_mps2: f64,
    pub(super) gap_s: f64,
    pub(super) max_coast_s: f64,
    pub(super) coast_accel_mps2: f64,
    pub(super) coast_rate_rps: f64,
}

/// Shortest and longest IMU interval a sample may state (s): 100 kHz and
/// 1 Hz, beyond any strapdown IMU this navigator is built for.
pub const IMU_DT_RANGE_S: (f64, f64) = (1e-5, 1.0);

/// Most mechanization steps a bridged or coasted gap takes, so that a gap
/// costs bounded work whatever its length (up to `imu_max_coast_s`).
pub const MAX_BRIDGE_STEPS: u64 = 64;

impl ImuLimits {
    pub(super) fn from_settings(f: &FilterSettings) -> Self {
        Self {
            max_rate_rps: f.max_gyro_rate_dps.to_radians(),
            max_accel_mps2: f.max_accel_mps2,
            gap_s: f.imu_gap_s,
            max_coast_s: f.imu_max_coast_s,
            coast_accel_mps2: f.coast_accel_mps2,
            coast_rate_rps: f.coast_rate_dps.to_radians(),
        }
    }
}

impl Navigator {
    pub(super) fn validate(&self, s: &ImuSample) -> Result<Increment, InputRejection> {
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
        Ok(self.err.compensate(
            &Vector3::from(s.d_theta_rad),
            &Vector3::from(s.d_v_mps),
            s.dt_s,
        ))
    }

    /// Mechanization and covariance bookkeeping of one increment.
    pub(super) fn integrate(&mut self, inc: &Increment) {
        self.work += 1;
        let prev = self.prev_inc.unwrap_or(*inc);
        self.nominal.mechanize(&prev, inc);
        self.prev_inc = Some(*inc);
        if self.err.accumulate(inc) {
            self.propagate_covariance();
        }
    }

    /// Carries the state across `missing_s` of IMU time on the last rates held
    /// constant (steps no longer than the nominal interval). A gap longer than
    /// `imu_gap_s` is coasted: counted, flagged, and its unknown manoeuvre
    /// added to the covariance.
    pub(super) fn bridge(&mut self, missing_s: f64, next: &Increment) {
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
        // The time elapsed is unknown: the smoother carries nothing back.
        self.err.tape_break();
        self.t_ns = t_ns;
        self.err.set_clock(t_ns, true);
        self.history.clear();
        for (_, c) in self.aids.controls.iter_mut() {
            c.counters.last_t_ns = 0;
        }
        self.coast(self.limits.max_coast_s);
    }

    /// A gap of `gap_s` without IMU data: counted, flagged `COASTING`, and
    /// covered by the covariance of an unknown manoeuvre over it.
    pub(super) fn coast(&mut self, missing_s: f64) {
        self.imu_gap_count += 1;
        self.coasted_ns = self
            .coasted_ns
            .saturating_add((missing_s * 1e9).round() as u64);
        self.coasting = true;
        self.propagate_covariance();
        self.err.add_coast(
            &self.nominal,
            self.limits.coast_accel_mps2,
            self.limits.coast_rate_rps,
            missing_s,
        );
    }
}
