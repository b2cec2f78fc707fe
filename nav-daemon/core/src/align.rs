//! Stationary coarse alignment: accelerometer levelling and gyrocompassing
//! from the mean specific force and angular rate of a vehicle at rest at a
//! known latitude — or, for a gyro that cannot sense the Earth's rate (a
//! MEMS gyro), heading from an aid (paper 003 §4.4: the magnetometer or the
//! dual-antenna baseline, through [`crate::aids::Aid::align_heading`]).
//!
//! A gyro can gyrocompass when its bias σ ε is below half the Earth rate's
//! horizontal component ω_ie cos L (heading σ below 30°): a navigation or
//! tactical gyro (0.01–1°/h) against 10.6°/h at 45°. A MEMS gyro (tens of
//! °/h) cannot: its heading would be noise, so gyrocompassing it is
//! refused, and heading comes from an aid or the alignment fails saying
//! why.
//!
//! Levelling: the mean specific force is the local up. Gyrocompassing: the
//! component of the mean rate perpendicular to up points along the Earth
//! rate's horizontal component, i.e. true north (scaled by ω_ie cos L). The
//! attainable accuracy is set by the sensor errors, and the σ reported is
//! that budget, not a guess: tilt σ = ∇/g (∇: accelerometer bias σ, plus
//! VRW averaging), heading σ = ε_E/(ω_ie cos L) (ε_E: gyro bias σ, plus ARW
//! averaging) — the classic limits.

use nalgebra::{Matrix3, Vector3};

use crate::aids::{AidError, HeadingFix, Levelled};
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
    /// Gyrocompassing refused: the gyro's bias σ is not below half the
    /// Earth rate's horizontal component here, and no heading aid gave a
    /// heading during the alignment.
    #[error(
        "gyrocompassing refused: the gyro bias σ of {gyro_bias_dph:.3}°/h is not below half the \
         Earth rate's horizontal component here ({earth_rate_h_dph:.2}°/h): a MEMS gyro cannot \
         sense the Earth's rate. Align heading from the magnetometer or the dual-antenna \
         baseline: {heading_aids}"
    )]
    GyroCannotSenseEarthRate {
        gyro_bias_dph: f64,
        earth_rate_h_dph: f64,
        /// What the heading aids said (none received, or why each refused).
        heading_aids: HeadingAids,
    },
}

/// What the heading aids gave an alignment that could not gyrocompass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeadingAids {
    /// No sample of an aid that observes heading reached the alignment.
    NoneReceived,
    /// The aid's last sample was refused (its cause index in the aid's
    /// declaration).
    Refused { aid: msgs::AidKind, cause: usize },
}

impl std::fmt::Display for HeadingAids {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HeadingAids::NoneReceived => f.write_str("no sample of either reached the alignment"),
            HeadingAids::Refused { aid, cause } => write!(
                f,
                "the {} sample was refused ({})",
                aid.decl().label,
                aid.decl()
                    .causes
                    .get(*cause)
                    .copied()
                    .unwrap_or("invalid content")
            ),
        }
    }
}

/// How the heading of an alignment was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlignMethod {
    /// From the Earth's rate (navigation- and tactical-grade gyros).
    Gyrocompass,
    /// From an aid's heading (a MEMS IMU; paper 003 §4.4).
    Aid(msgs::AidKind),
}

impl AlignMethod {
    /// What the init record it makes says ([`msgs::InitState::method`]).
    pub fn init_method(self) -> msgs::InitMethod {
        match self {
            AlignMethod::Gyrocompass => msgs::InitMethod::Gyrocompass,
            AlignMethod::Aid(k) => msgs::InitMethod::AidHeading(k),
        }
    }
}

impl std::fmt::Display for AlignMethod {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.init_method().fmt(f)
    }
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
    /// How the heading was found.
    pub method: AlignMethod,
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

    /// Levels from the mean specific force: the body → ENU DCM of the
    /// attitude with heading 0 and the tilt's σ (for an aid's heading).
    pub fn level(
        &self,
        lat_rad: f64,
        h_m: f64,
        budget: &AlignmentBudget,
    ) -> Result<(Matrix3<f64>, f64), AlignError> {
        let (f, _, g) = self.means(lat_rad, h_m)?;
        let up = f.normalize();
        // Level axes in body axes: x_l along the body's x projected on the
        // level plane (heading 0 puts body y north, so x_l is east).
        let x_b = Vector3::x();
        let east = (x_b - up * x_b.dot(&up)).normalize();
        let north = up.cross(&east);
        let c_b_l = Matrix3::from_rows(&[east.transpose(), north.transpose(), up.transpose()]);
        let (_, pitch, roll) = crate::frames::euler_from_c_b_n(&c_b_l);
        let c_b_l = crate::frames::c_b_n_from_euler(0.0, pitch, roll);
        let mut var_f_level = budget.vrw.powi(2) / self.time_s;
        if let Some((_, cf)) = self.blocks.mean_covariances() {
            let e = c_b_l.row(0).transpose();
            let n = c_b_l.row(1).transpose();
            let level = 0.5 * ((e.transpose() * cf * e)[(0, 0)] + (n.transpose() * cf * n)[(0, 0)]);
            var_f_level = var_f_level.max(level);
        }
        Ok((
            c_b_l,
            (budget.accel_bias_mps2.powi(2) + var_f_level).sqrt() / g,
        ))
    }

    fn means(
        &self,
        lat_rad: f64,
        h_m: f64,
    ) -> Result<(Vector3<f64>, Vector3<f64>, f64), AlignError> {
        if self.samples == 0 || self.time_s <= 0.0 {
            return Err(AlignError::NoData);
        }
        let f = self.sum_v / self.time_s;
        let w = self.sum_theta / self.time_s;
        let g = earth::normal_gravity(lat_rad, h_m);
        if (f.norm() - g).abs() > 0.05 * g || !f.iter().all(|x| x.is_finite()) {
            return Err(AlignError::NotAtRest(f.norm()));
        }
        Ok((f, w, g))
    }

    /// Whether the gyro of `budget` can gyrocompass at `lat_rad`: its bias σ
    /// below half the Earth rate's horizontal component.
    pub fn can_gyrocompass(lat_rad: f64, budget: &AlignmentBudget) -> bool {
        budget.gyro_bias_rps < 0.5 * earth::OMEGA_IE * lat_rad.cos()
    }

    /// Solves the alignment at latitude `lat_rad` and height `h_m` by
    /// levelling and gyrocompassing.
    pub fn solve(
        &self,
        lat_rad: f64,
        h_m: f64,
        budget: &AlignmentBudget,
    ) -> Result<Alignment, AlignError> {
        let (f, w, g) = self.means(lat_rad, h_m)?;
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
            method: AlignMethod::Gyrocompass,
        })
    }
}

/// A heading aid's answer to an alignment: which aid, and its heading or
/// why it could not give one.
pub type HeadingAnswer = (msgs::AidKind, Result<HeadingFix, AidError>);

/// The init record with the aligned attitude (position kept, at rest),
/// valid at `t_ns`, with the alignment's σ and the bias budget of `filter`.
/// A gyro that can sense the Earth's rate gyrocompasses; one that cannot
/// takes its heading from `heading` (the best answer of the heading aids'
/// samples received during the alignment, given the levelled attitude),
/// or the alignment fails saying why.
pub fn aligned_init(
    init: &msgs::InitState,
    filter: &crate::settings::FilterSettings,
    acc: &AlignmentAccumulator,
    t_ns: u64,
    heading: impl FnOnce(&Levelled) -> Option<HeadingAnswer>,
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
    let a = if AlignmentAccumulator::can_gyrocompass(geo.lat_rad, &budget) {
        acc.solve(geo.lat_rad, geo.h_m, &budget)?
    } else {
        let (c_b_l, sigma_tilt) = acc.level(geo.lat_rad, geo.h_m, &budget)?;
        let refused = |heading_aids| AlignError::GyroCannotSenseEarthRate {
            gyro_bias_dph: filter.gyro_bias_dph,
            earth_rate_h_dph: earth::OMEGA_IE * geo.lat_rad.cos() / dph,
            heading_aids,
        };
        let levelled = Levelled {
            c_b_l,
            sigma_tilt_rad: sigma_tilt,
            geo,
            t_ns,
        };
        let (kind, fix) = match heading(&levelled) {
            None => return Err(refused(HeadingAids::NoneReceived)),
            Some((k, Err(e))) => {
                return Err(refused(HeadingAids::Refused {
                    aid: k,
                    cause: e.cause(),
                }));
            }
            Some((k, Ok(fix))) => (k, fix),
        };
        let (_, pitch, roll) = crate::frames::euler_from_c_b_n(&c_b_l);
        let c_b_g = crate::frames::c_b_n_from_euler(fix.heading_rad, pitch, roll);
        Alignment {
            c_b_g,
            heading_rad: fix.heading_rad,
            pitch_rad: pitch,
            roll_rad: roll,
            sigma_tilt_rad: sigma_tilt,
            sigma_heading_rad: fix.sigma_rad,
            time_s: acc.time_s(),
            method: AlignMethod::Aid(kind),
        }
    };
    let c_b_e = crate::frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * a.c_b_g;
    let q = crate::frames::quat_from_dcm(&c_b_e).into_inner();
    let (method, heading_aid) = a.method.init_method().to_wire();
    let aligned = msgs::InitState {
        t_ns,
        v_e_mps: [0.0; 3],
        q_b_e: [q.w, q.i, q.j, q.k],
        sigma_tilt_rad: a.sigma_tilt_rad,
        sigma_heading_rad: a.sigma_heading_rad,
        method,
        heading_aid,
        ..*init
    };
    Ok((aligned, a))
}

/// The best of the heading aids' answers: the heading of smallest σ, or,
/// when every one refused, the first refusal.
pub fn best_heading(answers: impl IntoIterator<Item = HeadingAnswer>) -> Option<HeadingAnswer> {
    let mut best: Option<HeadingAnswer> = None;
    for a in answers {
        best = match (best, &a.1) {
            (None, _) => Some(a),
            (Some(b @ (_, Ok(_))), Err(_)) => Some(b),
            (Some((_, Err(_))), Ok(_)) => Some(a),
            (Some(b @ (_, Ok(fb))), Ok(fa)) => {
                Some(if fa.sigma_rad < fb.sigma_rad { a } else { b })
            }
            (Some(b @ (_, Err(_))), Err(_)) => Some(b),
        };
    }
    best
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

    /// `n` exact 10 ms increments of a body at rest at `lat_rad`, height
    /// `h_m`, with attitude `c_b_g` (body → ENU).
    fn exact_at_rest(
        lat_rad: f64,
        h_m: f64,
        c_b_g: &Matrix3<f64>,
        n: usize,
    ) -> AlignmentAccumulator {
        let w_g = Vector3::new(
            0.0,
            earth::OMEGA_IE * lat_rad.cos(),
            earth::OMEGA_IE * lat_rad.sin(),
        );
        let f_g = Vector3::new(0.0, 0.0, earth::normal_gravity(lat_rad, h_m));
        let mut acc = AlignmentAccumulator::default();
        for _ in 0..n {
            acc.add(
                &(c_b_g.transpose() * w_g * 0.01),
                &(c_b_g.transpose() * f_g * 0.01),
                0.01,
            );
        }
        acc
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
            let acc = exact_at_rest(lat, 100.0, &c_b_g, 1000);
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

    fn mems_filter() -> crate::settings::FilterSettings {
        crate::settings::SensorGrade::Mems.apply(&crate::settings::FilterSettings::default())
    }

    /// A MEMS IMU at rest with heading `h`, pitch `p`, roll `r` at `lat`:
    /// exact increments (its gyro sees the Earth's rate exactly; the
    /// alignment must still refuse to gyrocompass, by its budget).
    fn at_rest(lat: f64, h: f64, p: f64, r: f64) -> (msgs::InitState, AlignmentAccumulator) {
        let lat = lat.to_radians();
        let acc = exact_at_rest(lat, 10.0, &frames::c_b_n_from_euler(h, p, r), 6000);
        let geo = earth::Geodetic::new(lat, 0.3, 10.0);
        let init = msgs::InitState {
            r_e_m: earth::geodetic_to_ecef(&geo).into(),
            q_b_e: [1.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        (init, acc)
    }

    #[test]
    fn a_mems_gyro_is_refused_gyrocompassing_with_a_message_that_says_why() {
        let (init, acc) = at_rest(45.0, 0.7, 0.02, -0.03);
        let e = aligned_init(&init, &mems_filter(), &acc, 60_000_000_000, |_| None)
            .expect_err("a MEMS gyro must not gyrocompass");
        let text = e.to_string();
        assert!(
            matches!(
                e,
                AlignError::GyroCannotSenseEarthRate {
                    heading_aids: HeadingAids::NoneReceived,
                    ..
                }
            ) && text.contains("a MEMS gyro cannot sense the Earth's rate")
                && text.contains("50.000°/h")
                && text.contains("magnetometer"),
            "{text}"
        );
        // A heading aid that refused its sample is named with its cause.
        let e = aligned_init(&init, &mems_filter(), &acc, 60_000_000_000, |_| {
            Some((
                msgs::AidKind::Gnss,
                Err(AidError::Refused {
                    cause: 1,
                    what: "test",
                    value: 0.0,
                }),
            ))
        })
        .expect_err("refused");
        assert!(e.to_string().contains("fix below 3D"), "{e}");
    }

    #[test]
    fn a_mems_imu_levels_from_its_accelerometers_and_takes_heading_from_an_aid() {
        for &(lat, h, p, r) in &[
            (45.0, 0.7, 0.02, -0.03),
            (-31.9, 5.9, -0.1, 0.2),
            (60.0, 3.1, 0.0, 0.0),
        ] {
            let (init, acc) = at_rest(lat, h, p, r);
            let mut asked = None;
            let (aligned, a) = aligned_init(&init, &mems_filter(), &acc, 60_000_000_000, |l| {
                asked = Some(*l);
                Some((
                    msgs::AidKind::Srs,
                    Ok(HeadingFix {
                        heading_rad: h,
                        sigma_rad: 0.01,
                    }),
                ))
            })
            .expect("aligned");
            let l = asked.expect("the aid was asked");
            // The levelled attitude given to the aid: heading 0, the true
            // pitch and roll, to the integration's precision.
            let (h0, p0, r0) = frames::euler_from_c_b_n(&l.c_b_l);
            assert!(
                (h0.sin()).abs() < 1e-12 && (p0 - p).abs() < 1e-9 && (r0 - r).abs() < 1e-9,
                "levelled {h0} {p0} {r0}"
            );
            assert!((a.c_b_g - frames::c_b_n_from_euler(h, p, r)).amax() < 1e-9);
            assert_eq!(a.method, AlignMethod::Aid(msgs::AidKind::Srs));
            // The aid's σ, passed through unchanged.
            assert!(a.sigma_heading_rad.to_bits() == 0.01f64.to_bits());
            assert!(aligned.sigma_heading_rad.to_bits() == 0.01f64.to_bits());
            // The tilt's σ is the accelerometer budget: 2 mg / g.
            assert!(
                (a.sigma_tilt_rad
                    - 2e-3 * earth::G0 / earth::normal_gravity(lat.to_radians(), 10.0))
                .abs()
                    < 1e-4
            );
        }
    }

    #[test]
    fn a_navigation_grade_gyro_still_gyrocompasses_with_a_heading_aid_at_hand() {
        let (init, acc) = at_rest(45.0, 0.7, 0.02, -0.03);
        let (_, a) = aligned_init(
            &init,
            &crate::settings::FilterSettings::default(),
            &acc,
            60_000_000_000,
            |_| panic!("a gyro that senses the Earth's rate asks no aid"),
        )
        .expect("aligned");
        assert_eq!(a.method, AlignMethod::Gyrocompass);
        assert!((a.heading_rad - 0.7).abs() < 1e-9);
    }

    #[test]
    fn the_best_heading_is_the_smallest_sigma_and_a_refusal_only_without_one() {
        use msgs::AidKind::{Cns, Gnss, Star};
        let fix = |s| {
            Ok(HeadingFix {
                heading_rad: s,
                sigma_rad: s,
            })
        };
        let no = || Err(AidError::NonFinite("x"));
        let b = best_heading([(Cns, no()), (Gnss, fix(0.2)), (Star, fix(0.1))]).expect("best");
        assert_eq!(b.0, Star);
        let b = best_heading([(Gnss, fix(0.2)), (Cns, no())]).expect("best");
        assert_eq!(b.0, Gnss);
        let b = best_heading([(Cns, no()), (Gnss, no())]).expect("best");
        assert_eq!(b.0, Cns);
        assert!(best_heading([]).is_none());
    }
}
