//! Stationary coarse alignment: accelerometer levelling and gyrocompassing
//! from the mean specific force and angular rate of a vehicle at rest at a
//! known latitude.
//!
//! Levelling: the mean specific force is the local up. Gyrocompassing: the
//! component of the mean rate perpendicular to up points along the Earth
//! rate's horizontal component, i.e. true north (scaled by ω_ie cos L). The
//! attainable accuracy is set by the sensor errors, and the σ reported is
//! that budget, not a guess: tilt σ = ∇/g (∇: accelerometer bias σ, plus
//! VRW averaging), heading σ = ε_E/(ω_ie cos L) (ε_E: gyro bias σ, plus ARW
//! averaging) — the classic limits.

use nalgebra::{Matrix3, Vector3};

use crate::earth;

/// Length of the blocks whose scatter measures the sensors' actual noise and drift (s).
pub const BLOCK_S: f64 = 10.0;

/// Running mean and scatter (Welford) of 10 s block means of the rate and specific force.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct BlockStats {
    n: u64,
    mean_w: Vector3<f64>,
    m2_w: Matrix3<f64>,
    mean_f: Vector3<f64>,
    m2_f: Matrix3<f64>,
}

impl BlockStats {
    fn push(&mut self, w: &Vector3<f64>, f: &Vector3<f64>) {
        self.n += 1;
        let n = self.n as f64;
        let dw = w - self.mean_w;
        self.mean_w += dw / n;
        self.m2_w += dw * (w - self.mean_w).transpose();
        let df = f - self.mean_f;
        self.mean_f += df / n;
        self.m2_f += df * (f - self.mean_f).transpose();
    }
    /// Covariances of the overall means (block scatter / number of blocks).
    fn mean_covariances(&self) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
        (self.n >= 3).then(|| {
            let k = 1.0 / ((self.n - 1) as f64 * self.n as f64);
            (self.m2_w * k, self.m2_f * k)
        })
    }
}

/// Accumulates increments of a vehicle at rest.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AlignmentAccumulator {
    sum_theta: Vector3<f64>,
    sum_v: Vector3<f64>,
    time_s: f64,
    samples: u64,
    block_theta: Vector3<f64>,
    block_v: Vector3<f64>,
    block_t: f64,
    blocks: BlockStats,
}

/// Why an alignment failed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum AlignError {
    #[error("no data accumulated")]
    NoData,
    #[error("mean specific force {0:.3} m/s² is not gravity: the vehicle is not at rest")]
    NotAtRest(f64),
    #[error("mean angular rate {0:.2e} rad/s is far above the Earth rate: the vehicle is turning")]
    Rotating(f64),
    #[error("latitude {0:.2}° is too close to a pole for gyrocompassing (cos L too small)")]
    TooCloseToPole(f64),
}

/// Result of a coarse alignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    /// Body → local geographic (ENU) DCM.
    pub c_b_g: Matrix3<f64>,
    pub heading_rad: f64,
    pub pitch_rad: f64,
    pub roll_rad: f64,
    /// 1-σ accuracy from the sensor error budget.
    pub sigma_tilt_rad: f64,
    pub sigma_heading_rad: f64,
    /// Averaging time (s).
    pub time_s: f64,
}

/// Sensor error budget used for the σ of an alignment (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignmentBudget {
    pub gyro_bias_rps: f64,
    pub accel_bias_mps2: f64,
    /// Angle random walk (rad/√s) and velocity random walk (m/s/√s).
    pub arw: f64,
    pub vrw: f64,
}

impl AlignmentAccumulator {
    pub fn add(&mut self, d_theta: &Vector3<f64>, d_v: &Vector3<f64>, dt_s: f64) {
        self.sum_theta += d_theta;
        self.sum_v += d_v;
        self.time_s += dt_s;
        self.samples += 1;
        self.block_theta += d_theta;
        self.block_v += d_v;
        self.block_t += dt_s;
        if self.block_t >= BLOCK_S {
            self.blocks.push(
                &(self.block_theta / self.block_t),
                &(self.block_v / self.block_t),
            );
            self.block_theta = Vector3::zeros();
            self.block_v = Vector3::zeros();
            self.block_t = 0.0;
        }
    }

    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Solves the alignment at latitude `lat_rad` and height `h_m`.
    pub fn solve(
        &self,
        lat_rad: f64,
        h_m: f64,
        budget: &AlignmentBudget,
    ) -> Result<Alignment, AlignError> {
        if self.samples == 0 || self.time_s <= 0.0 {
            return Err(AlignError::NoData);
        }
        let f = self.sum_v / self.time_s;
        let w = self.sum_theta / self.time_s;
        let g = earth::normal_gravity(lat_rad, h_m);
        if (f.norm() - g).abs() > 0.05 * g {
            return Err(AlignError::NotAtRest(f.norm()));
        }
        if w.norm() > 10.0 * earth::OMEGA_IE {
            return Err(AlignError::Rotating(w.norm()));
        }
        let w_h = earth::OMEGA_IE * lat_rad.cos();
        if w_h < 0.1 * earth::OMEGA_IE {
            return Err(AlignError::TooCloseToPole(lat_rad.to_degrees()));
        }
        // Up, north, east in body axes.
        let up = f.normalize();
        let north = (w - up * w.dot(&up)).normalize();
        let east = north.cross(&up);
        // Rows of C_b^g are the ENU axes expressed in body axes.
        let c_b_g = Matrix3::from_rows(&[east.transpose(), north.transpose(), up.transpose()]);
        let (heading, pitch, roll) = crate::frames::euler_from_c_b_n(&c_b_g);
        let t = self.time_s;
        // Noise of the means: the larger of the configured random walks and the
        // measured scatter of the block means (which also catches drift).
        let (mut var_w_east, mut var_f_level) = (budget.arw.powi(2) / t, budget.vrw.powi(2) / t);
        if let Some((cw, cf)) = self.blocks.mean_covariances() {
            var_w_east = var_w_east.max((east.transpose() * cw * east)[(0, 0)]);
            let level = 0.5
                * ((east.transpose() * cf * east)[(0, 0)]
                    + (north.transpose() * cf * north)[(0, 0)]);
            var_f_level = var_f_level.max(level);
        }
        let sigma_tilt = (budget.accel_bias_mps2.powi(2) + var_f_level).sqrt() / g;
        let sigma_heading = (budget.gyro_bias_rps.powi(2) + var_w_east).sqrt() / w_h;
        Ok(Alignment {
            c_b_g,
            heading_rad: heading,
            pitch_rad: pitch,
            roll_rad: roll,
            sigma_tilt_rad: sigma_tilt,
            sigma_heading_rad: sigma_heading,
            time_s: t,
        })
    }
}

/// The init record with the aligned attitude (position kept, at rest),
/// valid at `t_ns`, with the alignment's σ and the bias budget of `filter`.
pub fn aligned_init(
    init: &msgs::InitState,
    filter: &crate::settings::FilterSettings,
    acc: &AlignmentAccumulator,
    t_ns: u64,
) -> Result<(msgs::InitState, Alignment), AlignError> {
    let r_e = Vector3::from(init.r_e_m);
    let geo = earth::ecef_to_geodetic(&r_e);
    let noise = filter.process_noise();
    let dph = std::f64::consts::PI / 180.0 / 3600.0;
    let ug = 1e-6 * earth::G0;
    let budget = AlignmentBudget {
        gyro_bias_rps: filter.gyro_bias_dph * dph,
        accel_bias_mps2: filter.accel_bias_ug * ug,
        arw: noise.arw,
        vrw: noise.vrw,
    };
    let a = acc.solve(geo.lat_rad, geo.h_m, &budget)?;
    let c_b_e = crate::frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * a.c_b_g;
    let q = crate::frames::quat_from_dcm(&c_b_e).into_inner();
    let aligned = msgs::InitState {
        t_ns,
        v_e_mps: [0.0; 3],
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_tilt_rad: a.sigma_tilt_rad,
        sigma_heading_rad: a.sigma_heading_rad,
        ..*init
    };
    Ok((aligned, a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames;

    fn budget() -> AlignmentBudget {
        AlignmentBudget {
            gyro_bias_rps: 0.0,
            accel_bias_mps2: 0.0,
            arw: 0.0,
            vrw: 0.0,
        }
    }

    #[test]
    fn exact_rates_give_the_exact_attitude() {
        for &(lat, h, p, r) in &[
            (34.2_f64, 1.5_f64, 0.016, 0.006),
            (-45.0, 4.0, -0.1, 0.2),
            (60.0, 0.3, 0.0, 0.0),
        ] {
            let lat = lat.to_radians();
            let c_b_g = frames::c_b_n_from_euler(h, p, r);
            let w_g = Vector3::new(
                0.0,
                earth::OMEGA_IE * lat.cos(),
                earth::OMEGA_IE * lat.sin(),
            );
            let f_g = Vector3::new(0.0, 0.0, earth::normal_gravity(lat, 100.0));
            let mut acc = AlignmentAccumulator::default();
            for _ in 0..1000 {
                acc.add(
                    &(c_b_g.transpose() * w_g * 0.01),
                    &(c_b_g.transpose() * f_g * 0.01),
                    0.01,
                );
            }
            let a = acc.solve(lat, 100.0, &budget()).expect("align");
            assert!((a.c_b_g - c_b_g).amax() < 1e-12);
            assert!(
                (a.heading_rad - h).abs() < 1e-12
                    && (a.pitch_rad - p).abs() < 1e-12
                    && (a.roll_rad - r).abs() < 1e-12
            );
        }
    }

    #[test]
    fn an_east_gyro_bias_gives_the_classic_heading_error() {
        // Heading error = ε_E / (ω_ie cos L): the σ formula is this same relation.
        let lat = 34.0f64.to_radians();
        let eps = 0.01 * std::f64::consts::PI / 180.0 / 3600.0;
        let w_g = Vector3::new(
            eps,
            earth::OMEGA_IE * lat.cos(),
            earth::OMEGA_IE * lat.sin(),
        );
        let f_g = Vector3::new(0.0, 0.0, earth::normal_gravity(lat, 0.0));
        let mut acc = AlignmentAccumulator::default();
        acc.add(&(w_g * 100.0), &(f_g * 100.0), 100.0);
        let b = AlignmentBudget {
            gyro_bias_rps: eps,
            ..budget()
        };
        let a = acc.solve(lat, 0.0, &b).expect("align");
        let expected = eps / (earth::OMEGA_IE * lat.cos());
        let err = earth::wrap_pi(a.heading_rad);
        assert!(
            (err.abs() - expected).abs() < 1e-3 * expected,
            "{err} vs {expected}"
        );
        assert!((a.sigma_heading_rad - expected).abs() < 1e-12);
    }

    #[test]
    fn moving_vehicle_and_pole_are_refused() {
        let mut acc = AlignmentAccumulator::default();
        acc.add(&Vector3::zeros(), &Vector3::new(0.0, 5.0, 9.8), 1.0);
        assert!(matches!(
            acc.solve(0.5, 0.0, &budget()),
            Err(AlignError::NotAtRest(_))
        ));
        let mut acc = AlignmentAccumulator::default();
        acc.add(
            &Vector3::new(0.0, 0.0, 0.01),
            &Vector3::new(0.0, 0.0, 9.8),
            1.0,
        );
        assert!(matches!(
            acc.solve(0.5, 0.0, &budget()),
            Err(AlignError::Rotating(_))
        ));
        let mut acc = AlignmentAccumulator::default();
        acc.add(
            &Vector3::new(0.0, 1e-6, 7.3e-5),
            &Vector3::new(0.0, 0.0, 9.83),
            1.0,
        );
        assert!(matches!(
            acc.solve(89.0f64.to_radians(), 0.0, &budget()),
            Err(AlignError::TooCloseToPole(_))
        ));
    }
}
