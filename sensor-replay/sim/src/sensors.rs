//! Sensor models: IMU errors and aid synthesis from the truth.

use msgs::{BaroSample, CnsFix, SRS_MAX_LINES, SrsLine, SrsSample, StarSample};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use polarnav::earth::{self, isa};
use polarnav::frames;
use rand::Rng;
use rand_chacha::ChaCha20Rng;
use rand_distr::StandardNormal;

use serde::Deserialize;

/// How constant biases are drawn from their magnitudes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BiasModel {
    /// Each axis N(0, value²) from the seed (the filter's prior matches).
    #[default]
    Gaussian,
    /// Each axis exactly +value.
    Fixed,
}

/// IMU rate and error model. Units as in papers/001 Table 1.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ImuSpec {
    pub rate_hz: f64,
    pub bias_model: BiasModel,
    /// Gyro constant bias (deg/h).
    pub gyro_bias_dph: f64,
    /// Accelerometer constant bias (µg).
    pub accel_bias_ug: f64,
    /// Angle random walk (deg/√h).
    pub arw_dpsh: f64,
    /// Velocity random walk (µg/√Hz).
    pub vrw_ug_psqhz: f64,
    /// First-order Gauss–Markov gyro bias: σ (deg/h) and correlation time (s); 0 = off.
    pub gm_gyro_sigma_dph: f64,
    pub gm_gyro_tau_s: f64,
    /// First-order Gauss–Markov accelerometer bias: σ (µg) and correlation time (s); 0 = off.
    pub gm_accel_sigma_ug: f64,
    pub gm_accel_tau_s: f64,
    /// Quantization step of the angle increments (rad) and velocity increments (m/s); 0 = none.
    pub gyro_quant_rad: f64,
    pub accel_quant_mps: f64,
}

impl Default for ImuSpec {
    fn default() -> Self {
        Self {
            rate_hz: 200.0,
            bias_model: BiasModel::Gaussian,
            gyro_bias_dph: 0.0,
            accel_bias_ug: 0.0,
            arw_dpsh: 0.0,
            vrw_ug_psqhz: 0.0,
            gm_gyro_sigma_dph: 0.0,
            gm_gyro_tau_s: 3600.0,
            gm_accel_sigma_ug: 0.0,
            gm_accel_tau_s: 3600.0,
            gyro_quant_rad: 0.0,
            accel_quant_mps: 0.0,
        }
    }
}

/// One truth sample: position, velocity, attitude.
#[derive(Debug, Clone, Copy)]
pub struct TruthSample {
    pub r_e: Vector3<f64>,
    pub v_e: Vector3<f64>,
    pub q_b_e: UnitQuaternion<f64>,
    /// The body's rate against inertial space, body axes (rad/s): what
    /// turns a lever arm into the velocity of an antenna.
    pub omega_ib_b: Vector3<f64>,
}

/// Speed of light (m/s).
pub const C_LIGHT: f64 = 299_792_458.0;
const DPH: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const UG: f64 = 1e-6 * earth::G0;

pub fn normal(rng: &mut ChaCha20Rng) -> f64 {
    rng.sample(StandardNormal)
}

fn normal3(rng: &mut ChaCha20Rng) -> Vector3<f64> {
    Vector3::new(normal(rng), normal(rng), normal(rng))
}

/// The actual (drawn) constant sensor errors of a run, for the record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnImuErrors {
    pub gyro_bias_rps: Vector3<f64>,
    pub accel_bias_mps2: Vector3<f64>,
}

/// IMU error model: constant bias, random walk, Gauss–Markov bias, quantization.
#[derive(Debug, Clone)]
pub struct ImuErrorModel {
    pub drawn: DrawnImuErrors,
    arw: f64,
    vrw: f64,
    gm_gyro: Vector3<f64>,
    gm_accel: Vector3<f64>,
    gm_gyro_sigma: f64,
    gm_gyro_tau: f64,
    gm_accel_sigma: f64,
    gm_accel_tau: f64,
    q_gyro: f64,
    q_accel: f64,
    res_gyro: Vector3<f64>,
    res_accel: Vector3<f64>,
}

impl ImuErrorModel {
    pub fn new(spec: &ImuSpec, rng: &mut ChaCha20Rng) -> Self {
        let draw = |rng: &mut ChaCha20Rng, v: f64| match spec.bias_model {
            BiasModel::Fixed => Vector3::repeat(v),
            BiasModel::Gaussian => normal3(rng) * v,
        };
        let gyro = draw(rng, spec.gyro_bias_dph * DPH);
        let accel = draw(rng, spec.accel_bias_ug * UG);
        let gm_gyro_sigma = spec.gm_gyro_sigma_dph * DPH;
        let gm_accel_sigma = spec.gm_accel_sigma_ug * UG;
        Self {
            drawn: DrawnImuErrors {
                gyro_bias_rps: gyro,
                accel_bias_mps2: accel,
            },
            arw: spec.arw_dpsh * std::f64::consts::PI / 180.0 / 60.0,
            vrw: spec.vrw_ug_psqhz * UG,
            gm_gyro: normal3(rng) * gm_gyro_sigma,
            gm_accel: normal3(rng) * gm_accel_sigma,
            gm_gyro_sigma,
            gm_gyro_tau: spec.gm_gyro_tau_s,
            gm_accel_sigma,
            gm_accel_tau: spec.gm_accel_tau_s,
            q_gyro: spec.gyro_quant_rad,
            q_accel: spec.accel_quant_mps,
            res_gyro: Vector3::zeros(),
            res_accel: Vector3::zeros(),
        }
    }

    /// The bias at the current time (constant draw plus Gauss–Markov part):
    /// gyro (rad/s), accelerometer (m/s²), body axes.
    pub fn bias(&self) -> (Vector3<f64>, Vector3<f64>) {
        (
            self.drawn.gyro_bias_rps + self.gm_gyro,
            self.drawn.accel_bias_mps2 + self.gm_accel,
        )
    }

    /// Applies the errors to exact increments over `dt`.
    pub fn corrupt(
        &mut self,
        rng: &mut ChaCha20Rng,
        d_theta: Vector3<f64>,
        d_v: Vector3<f64>,
        dt: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let mut th = d_theta + (self.drawn.gyro_bias_rps + self.gm_gyro) * dt;
        let mut dv = d_v + (self.drawn.accel_bias_mps2 + self.gm_accel) * dt;
        if self.arw > 0.0 {
            th += normal3(rng) * (self.arw * dt.sqrt());
        }
        if self.vrw > 0.0 {
            dv += normal3(rng) * (self.vrw * dt.sqrt());
        }
        let step_gm = |x: &mut Vector3<f64>, sigma: f64, tau: f64, rng: &mut ChaCha20Rng| {
            if sigma > 0.0 {
                let a = (-dt / tau).exp();
                *x = *x * a + normal3(rng) * (sigma * (1.0 - a * a).sqrt());
            }
        };
        step_gm(&mut self.gm_gyro, self.gm_gyro_sigma, self.gm_gyro_tau, rng);
        step_gm(
            &mut self.gm_accel,
            self.gm_accel_sigma,
            self.gm_accel_tau,
            rng,
        );
        // Quantization with carried residual: the sum of outputs tracks the sum of inputs.
        let quantize = |x: Vector3<f64>, q: f64, res: &mut Vector3<f64>| {
            if q <= 0.0 {
                return x;
            }
            let want = x + *res;
            let out = want.map(|w| (w / q).round() * q);
            *res = want - out;
            out
        };
        th = quantize(th, self.q_gyro, &mut self.res_gyro);
        dv = quantize(dv, self.q_accel, &mut self.res_accel);
        (th, dv)
    }
}

/// CNS fix: truth plus a horizontal error drawn in the local tangent plane
/// (frame-free, so the fix stays meaningful at the pole).
pub fn cns_fix(
    rng: &mut ChaCha20Rng,
    t_ns: u64,
    seq: u64,
    r_e: &Vector3<f64>,
    sigma_m: f64,
    noisy: bool,
) -> CnsFix {
    let geo = earth::ecef_to_geodetic(r_e);
    let [e, n, _] = frames::enu_axes_e(geo.lat_rad, geo.lon_rad);
    let r = if noisy {
        r_e + e * (sigma_m * normal(rng)) + n * (sigma_m * normal(rng))
    } else {
        *r_e
    };
    let g = earth::ecef_to_geodetic(&r);
    CnsFix {
        t_ns,
        seq,
        lat_rad: g.lat_rad,
        lon_rad: g.lon_rad,
        sigma_h_m: sigma_m,
    }
}

/// Barometer: ISA pressure at the (noisy) geometric altitude; ellipsoidal height stands in for it.
pub fn baro_sample(
    rng: &mut ChaCha20Rng,
    t_ns: u64,
    seq: u64,
    h_m: f64,
    sigma_m: f64,
    noisy: bool,
) -> BaroSample {
    let z = if noisy {
        h_m + sigma_m * normal(rng)
    } else {
        h_m
    };
    let hgp = isa::geopotential_from_geometric(z);
    BaroSample {
        t_ns,
        seq,
        pressure_pa: isa::pressure(hgp),
        temperature_k: isa::temperature(hgp),
        sigma_m,
    }
}

/// A star tracker's mounting and noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StarSensor {
    /// The boresight, body axes (normalized here).
    pub boresight_b: [f64; 3],
    /// 1-σ across and about the boresight (arcsec).
    pub sigma_cross_arcsec: f64,
    pub sigma_boresight_arcsec: f64,
    /// A fixed mounting rotation about body x, y, z (arcsec).
    pub misalignment_arcsec: [f64; 3],
}

/// One arcsecond (rad).
const ARCSEC: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// Star tracker: the true body→inertial attitude C_b^i = C_e^i(t) C_b^e,
/// turned by the mounting misalignment μ and the sensor noise ν, both small
/// rotations about body axes (C_b^i,meas = C_b^i R(μ) R(ν)); ν has σ across
/// the boresight on the two axes normal to it and σ about it.
pub fn star_sample(
    rng: &mut ChaCha20Rng,
    t_ns: u64,
    seq: u64,
    q_b_e: &UnitQuaternion<f64>,
    star: &StarSensor,
    noisy: bool,
) -> StarSample {
    let b = Vector3::from(star.boresight_b).normalize();
    let (sc, sb) = (star.sigma_cross_arcsec, star.sigma_boresight_arcsec);
    let q_e_i = UnitQuaternion::from_rotation_matrix(&c_e_i(t_ns as f64 * 1e-9));
    let mut q = q_e_i * q_b_e;
    if noisy {
        let mu = Vector3::from(star.misalignment_arcsec) * ARCSEC;
        // Two axes across the boresight.
        let a = if b.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let c1 = b.cross(&a).normalize();
        let c2 = b.cross(&c1);
        let nu =
            (c1 * (sc * normal(rng)) + c2 * (sc * normal(rng)) + b * (sb * normal(rng))) * ARCSEC;
        q = q * UnitQuaternion::from_scaled_axis(mu) * UnitQuaternion::from_scaled_axis(nu);
    }
    let q = q.into_inner();
    StarSample {
        t_ns,
        seq,
        q_b_i: [q.w, q.i, q.j, q.k],
        boresight_b: b.into(),
        sigma_cross_arcsec: sc,
        sigma_boresight_arcsec: sb,
    }
}

/// A celestial body of the SRS catalogue.
#[derive(Debug, Clone, Copy)]
pub struct Body {
    pub id: u32,
    pub los_i: Vector3<f64>,
    pub vel_i: Vector3<f64>,
    pub rest_wavelength_m: f64,
}

/// Built-in catalogue: 24 directions spread evenly over the sphere (Fibonacci
/// lattice), each with an ephemeris velocity of tens of km/s (stellar motion
/// plus the Earth's orbital motion) and a Balmer or calcium line.
pub fn default_catalogue() -> Vec<Body> {
    let n = 24;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let earth_orbit = Vector3::new(-29_780.0, 0.0, 0.0);
    let lines = [656.281e-9, 486.135e-9, 393.366e-9, 434.047e-9];
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let rho = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            let los = Vector3::new(rho * a.cos(), rho * a.sin(), z);
            // Deterministic stellar velocity: 5–45 km/s in a direction that varies with i.
            let b = 1.7 * i as f64;
            let dir = Vector3::new(b.cos(), (0.3 * b).sin(), (1.3 * b).cos()).normalize();
            let speed = 5_000.0 + 40_000.0 * ((i * 7 % 11) as f64 / 10.0);
            Body {
                id: i as u32 + 1,
                los_i: los,
                vel_i: dir * speed + earth_orbit,
                rest_wavelength_m: lines[i % lines.len()],
            }
        })
        .collect()
}

/// C_e^i at time t: the e frame coincides with i at t = 0 and turns about z.
pub fn c_e_i(t_s: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), earth::OMEGA_IE * t_s)
}

/// Measured 1 + z for carrier inertial velocity `v_p`, body velocity `v_k`
/// and line of sight `los` (carrier → body), papers/001 eq (8) with u = −los.
pub fn one_plus_z(v_p: &Vector3<f64>, v_k: &Vector3<f64>, los: &Vector3<f64>) -> f64 {
    let v = v_p - v_k;
    let u = -los;
    (C_LIGHT + v.dot(&u)) / (C_LIGHT * C_LIGHT - v.norm_squared()).sqrt()
}

/// Bodies above the elevation mask, at most [`SRS_MAX_LINES`], chosen for
/// spread: the highest first, then greedily the one farthest from those chosen.
pub fn visible_bodies(catalogue: &[Body], up_i: &Vector3<f64>, mask_rad: f64) -> Vec<Body> {
    let mut visible: Vec<Body> = catalogue
        .iter()
        .copied()
        .filter(|b| b.los_i.dot(up_i) >= mask_rad.sin())
        .collect();
    if visible.len() <= SRS_MAX_LINES {
        return visible;
    }
    visible.sort_by(|a, b| b.los_i.dot(up_i).total_cmp(&a.los_i.dot(up_i)));
    let mut chosen = vec![visible.remove(0)];
    while chosen.len() < SRS_MAX_LINES {
        let (idx, _) = visible
            .iter()
            .enumerate()
            .map(|(i, b)| {
                (
                    i,
                    chosen
                        .iter()
                        .map(|c| c.los_i.dot(&b.los_i))
                        .fold(f64::MIN, f64::max),
                )
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("non-empty");
        chosen.push(visible.remove(idx));
    }
    chosen
}

/// SRS observation of the visible bodies for a carrier at `r_e` with velocity `v_e`.
#[allow(clippy::too_many_arguments)]
pub fn srs_sample(
    rng: &mut ChaCha20Rng,
    t_ns: u64,
    seq: u64,
    r_e: &Vector3<f64>,
    v_e: &Vector3<f64>,
    catalogue: &[Body],
    mask_rad: f64,
    sigma_mps: f64,
    noisy: bool,
) -> SrsSample {
    let t_s = t_ns as f64 * 1e-9;
    let c = c_e_i(t_s);
    let geo = earth::ecef_to_geodetic(r_e);
    let up_i = c * earth::up_e(geo.lat_rad, geo.lon_rad);
    let v_p = c * (v_e + earth::omega_ie_e().cross(r_e));
    let mut out = SrsSample {
        t_ns,
        seq,
        ..Default::default()
    };
    for (slot, b) in out
        .lines
        .iter_mut()
        .zip(visible_bodies(catalogue, &up_i, mask_rad))
    {
        let noise = if noisy {
            sigma_mps * normal(rng) / C_LIGHT
        } else {
            0.0
        };
        let opz = one_plus_z(&v_p, &b.vel_i, &b.los_i) + noise;
        *slot = SrsLine {
            los_i: b.los_i.into(),
            body_vel_i_mps: b.vel_i.into(),
            rest_wavelength_m: b.rest_wavelength_m,
            measured_wavelength_m: b.rest_wavelength_m * opz,
            sigma_mps,
            body_id: b.id,
            _pad: 0,
        };
        out.count += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn redshift_matches_relativistic_doppler_of_paper_001_eq_2() {
        // 1 + z = (1 + |v| cosθ / c) / sqrt(1 − |v|²/c²), θ between v and the body→carrier direction.
        let v_p: Vector3<f64> = Vector3::new(300.0, -29_000.0, 12.0);
        let v_k: Vector3<f64> = Vector3::new(-1_000.0, 20_000.0, 5_000.0);
        let los: Vector3<f64> = Vector3::new(0.3, 0.4, 0.5).normalize();
        let v = v_p - v_k;
        let cos_theta = v.dot(&-los) / v.norm();
        let expect = (1.0 + v.norm() * cos_theta / C_LIGHT)
            / (1.0_f64 - v.norm_squared() / (C_LIGHT * C_LIGHT)).sqrt();
        assert!((one_plus_z(&v_p, &v_k, &los) - expect).abs() < 1e-15);
        // Approaching the body (v along los) is a blueshift.
        assert!(one_plus_z(&(los * 1e4), &Vector3::zeros(), &los) < 1.0);
    }

    #[test]
    fn quantization_keeps_the_running_sum() {
        let spec = ImuSpec {
            gyro_quant_rad: 1e-6,
            accel_quant_mps: 1e-3,
            ..Default::default()
        };
        let mut rng = ChaCha20Rng::seed_from_u64(1);
        let mut m = ImuErrorModel::new(&spec, &mut rng);
        let (mut sum_in, mut sum_out) = (Vector3::zeros(), Vector3::zeros());
        for k in 0..10_000 {
            let x = Vector3::new(3.3e-7, -1.1e-7 * (k as f64).sin(), 2.0e-6);
            let (th, _) = m.corrupt(&mut rng, x, Vector3::zeros(), 0.005);
            sum_in += x;
            sum_out += th;
            assert!(
                th.iter()
                    .all(|v| ((v / 1e-6).round() * 1e-6 - v).abs() < 1e-18)
            );
        }
        assert!((sum_in - sum_out).amax() <= 0.5e-6 + 1e-18);
    }

    #[test]
    fn catalogue_gives_enough_spread_bodies_everywhere() {
        let cat = default_catalogue();
        for k in 0..200 {
            let z = -1.0 + 2.0 * k as f64 / 199.0;
            let a = 2.4 * k as f64;
            let up = Vector3::new(
                (1.0 - z * z).sqrt() * a.cos(),
                (1.0 - z * z).sqrt() * a.sin(),
                z,
            );
            let vis = visible_bodies(&cat, &up, 10f64.to_radians());
            assert!(vis.len() >= 5, "only {} bodies at {up}", vis.len());
            // Geometry: the normal matrix of the line-of-sight directions is well conditioned.
            let m: nalgebra::Matrix3<f64> = vis.iter().map(|b| b.los_i * b.los_i.transpose()).sum();
            let ev = m.symmetric_eigenvalues();
            assert!(ev.min() > 0.1, "poor geometry at {up}: {ev}");
        }
    }
}
