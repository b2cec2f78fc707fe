//! The genuine vehicle of the session property tests and of the push_worst
//! bench: level flight due north near 86° N at 18 km, exact 200 Hz IMU
//! increments and exact aids (any sample can be stamped at another time than
//! the state it describes). Included by both with `#[path]`.
#![allow(dead_code)] // each includer uses part of it

use msgs::gnss::{fix_flags, fix_type};
use msgs::{BaroSample, CnsFix, GnssFix, ImuSample, InitState, SrsLine, SrsSample, StarSample};
use nalgebra::{UnitQuaternion, Vector3};
use polarnav::earth::{self, Geodetic, isa};
use polarnav::frames;
use polarnav::session::Input;

pub const T0_NS: u64 = 1_000_000_000;
pub const DT_NS: u64 = 5_000_000;
pub const DT_S: f64 = 0.005;
pub const LAT0_DEG: f64 = 86.0;
pub const LON0_DEG: f64 = 10.0;
pub const H0_M: f64 = 18_000.0;

/// Level flight due north at `speed_mps` (0: stationary), body axes = local
/// east/north/up.
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    pub speed_mps: f64,
}

impl Truth {
    pub fn geo(&self, t_ns: u64) -> Geodetic {
        let t = (t_ns as f64 - T0_NS as f64) * 1e-9;
        let lat0 = LAT0_DEG.to_radians();
        let (rm, _) = earth::radii(lat0);
        Geodetic::new(
            lat0 + self.speed_mps * t / (rm + H0_M),
            LON0_DEG.to_radians(),
            H0_M,
        )
    }

    pub fn r_e(&self, t_ns: u64) -> Vector3<f64> {
        earth::geodetic_to_ecef(&self.geo(t_ns))
    }

    pub fn v_e(&self, t_ns: u64) -> Vector3<f64> {
        let g = self.geo(t_ns);
        frames::c_e_g(g.lat_rad, g.lon_rad).transpose() * Vector3::new(0.0, self.speed_mps, 0.0)
    }

    pub fn init(&self, t_ns: u64, seq: u64) -> InitState {
        let g = self.geo(t_ns);
        let q = UnitQuaternion::from_matrix(&frames::c_e_g(g.lat_rad, g.lon_rad).transpose());
        InitState {
            t_ns,
            seq,
            r_e_m: self.r_e(t_ns).into(),
            v_e_mps: self.v_e(t_ns).into(),
            q_b_e: [q.w, q.i, q.j, q.k],
            sigma_pos_h_m: 10.0,
            sigma_pos_v_m: 10.0,
            sigma_vel_h_mps: 0.1,
            sigma_vel_v_mps: 0.1,
            sigma_tilt_rad: 3e-4,
            sigma_heading_rad: 1e-3,
            ..Default::default()
        }
    }

    /// The increments of the interval ending at `content_t_ns`, stamped `t_ns`.
    pub fn imu_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> ImuSample {
        let g = self.geo(content_t_ns);
        let (rm, _) = earth::radii(g.lat_rad);
        let w_ie_b = frames::c_e_g(g.lat_rad, g.lon_rad) * earth::omega_ie_e();
        let w_en_b = Vector3::new(-self.speed_mps / (rm + g.h_m), 0.0, 0.0);
        let f_b = Vector3::new(0.0, 0.0, earth::normal_gravity(g.lat_rad, g.h_m));
        ImuSample {
            t_ns,
            seq,
            dt_s: DT_S,
            d_theta_rad: ((w_ie_b + w_en_b) * DT_S).into(),
            d_v_mps: (f_b * DT_S).into(),
        }
    }

    pub fn imu(&self, t_ns: u64, seq: u64) -> ImuSample {
        self.imu_at(t_ns, seq, t_ns)
    }

    pub fn cns(&self, t_ns: u64, seq: u64) -> CnsFix {
        self.cns_at(t_ns, seq, t_ns)
    }

    /// The CNS fix stamped `t_ns` of the vehicle as it is at `content_t_ns`.
    pub fn cns_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> CnsFix {
        let g = self.geo(content_t_ns);
        CnsFix {
            t_ns,
            seq,
            lat_rad: g.lat_rad,
            lon_rad: g.lon_rad,
            sigma_h_m: 30.0,
        }
    }

    pub fn baro(&self, t_ns: u64, seq: u64) -> BaroSample {
        self.baro_at(t_ns, seq, t_ns)
    }

    /// The baro sample stamped `t_ns` of the vehicle as it is at `content_t_ns`.
    pub fn baro_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> BaroSample {
        let g = self.geo(content_t_ns);
        BaroSample {
            t_ns,
            seq,
            pressure_pa: isa::pressure(isa::geopotential_from_geometric(g.h_m)),
            temperature_k: 216.65,
            sigma_m: 10.0,
        }
    }

    /// The star tracker sample stamped `t_ns` of the vehicle's attitude at
    /// `content_t_ns` (body axes = local east/north/up; C_e^i = R_z(ω_ie t)).
    pub fn star_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> StarSample {
        let g = self.geo(content_t_ns);
        let c_b_e = frames::c_e_g(g.lat_rad, g.lon_rad).transpose();
        let a = earth::OMEGA_IE * t_ns as f64 * 1e-9;
        let c_e_i = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), a);
        let q = UnitQuaternion::from_matrix(&(c_e_i.matrix() * c_b_e));
        StarSample {
            t_ns,
            seq,
            q_b_i: [q.w, q.i, q.j, q.k],
            boresight_b: [0.0, 0.0, 1.0],
            sigma_cross_arcsec: 5.0,
            sigma_boresight_arcsec: 40.0,
        }
    }

    pub fn star(&self, t_ns: u64, seq: u64) -> StarSample {
        self.star_at(t_ns, seq, t_ns)
    }

    pub fn gnss(&self, t_ns: u64, seq: u64) -> GnssFix {
        self.gnss_at(t_ns, seq, t_ns)
    }

    /// The GNSS fix stamped `t_ns` of the vehicle as it is at
    /// `content_t_ns` (antenna at the IMU: the default lever arm).
    pub fn gnss_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> GnssFix {
        let g = self.geo(content_t_ns);
        GnssFix {
            t_ns,
            seq,
            lat_rad: g.lat_rad,
            lon_rad: g.lon_rad,
            height_m: g.h_m,
            vel_ned_mps: [self.speed_mps, 0.0, 0.0],
            h_acc_m: 2.0,
            v_acc_m: 3.0,
            s_acc_mps: 0.1,
            pdop: 1.5,
            itow_ms: 0,
            fix_type: fix_type::FIX_3D,
            num_sv: 12,
            flags: fix_flags::FIX_OK,
            _pad: 0,
        }
    }

    pub fn srs(&self, t_ns: u64, seq: u64) -> SrsSample {
        self.srs_at(t_ns, seq, t_ns)
    }

    /// The SRS sample stamped `t_ns` of the vehicle as it is at `content_t_ns`.
    pub fn srs_at(&self, t_ns: u64, seq: u64, content_t_ns: u64) -> SrsSample {
        let c_e_i = polarnav::aids::srs::c_e_i(t_ns as f64 * 1e-9);
        let (r, v) = (self.r_e(content_t_ns), self.v_e(content_t_ns));
        let v_p = c_e_i * (v + earth::omega_ie_e().cross(&r));
        let mut s = SrsSample {
            t_ns,
            seq,
            count: 5,
            ..Default::default()
        };
        let dirs = [
            Vector3::new(1.0, 0.1, 0.5),
            Vector3::new(-0.3, 1.0, 0.4),
            Vector3::new(-0.7, -0.6, 0.6),
            Vector3::new(0.1, 0.2, 1.0),
            Vector3::new(0.5, -0.5, 0.7),
        ];
        let c = polarnav::aids::srs::C_LIGHT;
        for (k, d) in dirs.iter().enumerate() {
            let los = d.normalize();
            let v_k = Vector3::new(-29_780.0, 500.0 * k as f64, 1_000.0);
            let w = v_p - v_k;
            let opz = (c + w.dot(&-los)) / (c * c - w.norm_squared()).sqrt();
            s.lines[k] = SrsLine {
                los_i: los.into(),
                body_vel_i_mps: v_k.into(),
                rest_wavelength_m: 5e-7,
                measured_wavelength_m: 5e-7 * opz,
                sigma_mps: 0.5,
                body_id: k as u32,
                _pad: 0,
            };
        }
        s
    }

    /// 8 lines; `bad_line` gets a 50 m/s radial error (forces the exclusion search).
    pub fn srs8(
        &self,
        t_ns: u64,
        seq: u64,
        content_t_ns: u64,
        bad_line: Option<usize>,
    ) -> SrsSample {
        let mut errs = [0.0; 8];
        if let Some(k) = bad_line {
            errs[k] = 50.0;
        }
        self.srs_errs(t_ns, seq, content_t_ns, &errs)
    }
    /// 8 lines with these radial errors (m/s).
    pub fn srs_errs(&self, t_ns: u64, seq: u64, content_t_ns: u64, errs: &[f64; 8]) -> SrsSample {
        let c_e_i = polarnav::aids::srs::c_e_i(t_ns as f64 * 1e-9);
        let (r, v) = (self.r_e(content_t_ns), self.v_e(content_t_ns));
        let v_p = c_e_i * (v + earth::omega_ie_e().cross(&r));
        let mut s = SrsSample {
            t_ns,
            seq,
            count: 8,
            ..Default::default()
        };
        let c = polarnav::aids::srs::C_LIGHT;
        for (k, l) in s.lines.iter_mut().enumerate() {
            let a = k as f64 * 0.8;
            let los = Vector3::new(a.cos() * 0.6, a.sin() * 0.6, 0.8 - 0.15 * k as f64).normalize();
            let v_k = Vector3::new(-29_780.0, 500.0 * k as f64, 1_000.0);
            let w = v_p - v_k;
            let opz = (c + w.dot(&-los) + errs[k]) / (c * c - w.norm_squared()).sqrt();
            *l = SrsLine {
                los_i: los.into(),
                body_vel_i_mps: v_k.into(),
                rest_wavelength_m: 5e-7,
                measured_wavelength_m: 5e-7 * opz,
                sigma_mps: 0.5,
                body_id: k as u32,
                _pad: 0,
            };
        }
        s
    }
}

/// An input held by value.
#[derive(Debug, Clone, Copy)]
#[allow(clippy::large_enum_variant)]
pub enum Owned {
    Imu(ImuSample),
    Aid(msgs::AidSample),
    Init(InitState),
}

impl Owned {
    pub fn input(&self) -> Input<'_> {
        match self {
            Owned::Imu(x) => Input::Imu(x),
            Owned::Aid(x) => Input::Aid(x),
            Owned::Init(x) => Input::Init(x),
        }
    }
    pub fn t_ns_mut(&mut self) -> &mut u64 {
        match self {
            Owned::Imu(x) => &mut x.t_ns,
            Owned::Aid(x) => x.t_ns_mut(),
            Owned::Init(x) => &mut x.t_ns,
        }
    }
}
