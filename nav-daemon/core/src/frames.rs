//! Navigation frames: local geographic g (ENU), grid G, and the rotations
//! between them and ECEF. The grid frame is built from its geometric
//! definition (DESIGN): up = ellipsoid normal **n**, grid north =
//! unit(**n** × **ŷ**_e), grid east = grid north × up. It is well defined at
//! both poles and singular only on the equator at λ = ±90°.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

use crate::earth::{self, Geodetic};

/// Skew-symmetric cross-product matrix: `skew(a) * b == a × b`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Inverse of [`skew`] for a (nearly) skew-symmetric matrix.
pub fn unskew(m: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5
}

/// Local geographic axes (east, north, up) in ECEF at (lat, lon). At the
/// exact pole they are those of the meridian `lon`.
pub fn enu_axes_e(lat_rad: f64, lon_rad: f64) -> [Vector3<f64>; 3] {
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
    [
        Vector3::new(-so, co, 0.0),
        Vector3::new(-sl * co, -sl * so, cl),
        Vector3::new(cl * co, cl * so, sl),
    ]
}

/// C_e^g: ECEF → local geographic ENU. Rows are the E, N, U axes.
pub fn c_e_g(lat_rad: f64, lon_rad: f64) -> Matrix3<f64> {
    let [e, n, u] = enu_axes_e(lat_rad, lon_rad);
    Matrix3::from_rows(&[e.transpose(), n.transpose(), u.transpose()])
}

/// Grid axes (grid east, grid north, up) in ECEF, from the geometric
/// definition. Precondition: away from the singular points (equator, λ = ±90°).
pub fn grid_axes_e(lat_rad: f64, lon_rad: f64) -> [Vector3<f64>; 3] {
    let up = earth::up_e(lat_rad, lon_rad);
    let north = up.cross(&Vector3::y()).normalize();
    let east = north.cross(&up);
    [east, north, up]
}

/// C_e^G: ECEF → grid. Rows are grid east, grid north, up.
pub fn c_e_grid(lat_rad: f64, lon_rad: f64) -> Matrix3<f64> {
    let [e, n, u] = grid_axes_e(lat_rad, lon_rad);
    Matrix3::from_rows(&[e.transpose(), n.transpose(), u.transpose()])
}

/// Grid angle σ (rad): clockwise angle from true north to grid north,
/// measured from the geometric grid north against the local E/N axes.
pub fn grid_angle(lat_rad: f64, lon_rad: f64) -> f64 {
    let [e, n, _] = enu_axes_e(lat_rad, lon_rad);
    let [_, grid_north, _] = grid_axes_e(lat_rad, lon_rad);
    grid_north.dot(&e).atan2(grid_north.dot(&n))
}

/// C_g^G (papers/001 eq 25): rotation about up by the grid angle.
pub fn c_g_grid(sigma_rad: f64) -> Matrix3<f64> {
    let (s, c) = sigma_rad.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// The local geometry of one geodetic point, computed once: the trigonometric
/// values, geographic and grid axes in ECEF, radii and normal gravity. The
/// mechanization evaluates C_e^n, transport rate and gravity at three points
/// per step; computing each from this saves ~20 sin/cos per IMU sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Local {
    pub geo: Geodetic,
    pub sin_lat: f64,
    pub cos_lat: f64,
    pub east: Vector3<f64>,
    pub north: Vector3<f64>,
    pub up: Vector3<f64>,
    pub rm: f64,
    pub rn: f64,
    pub gravity: f64,
}

impl Local {
    pub fn new(geo: &Geodetic) -> Self {
        let (sin_lat, cos_lat) = geo.lat_rad.sin_cos();
        let (sin_lon, cos_lon) = geo.lon_rad.sin_cos();
        Self::from_trig(&earth::GeodeticTrig {
            geo: *geo,
            sin_lat,
            cos_lat,
            sin_lon,
            cos_lon,
        })
    }

    /// The local geometry at an ECEF point: [`Local::new`] of its geodetic
    /// position with the sines and cosines of
    /// [`earth::ecef_to_geodetic_trig`] (no `sin_cos`).
    pub fn from_ecef(r_e: &Vector3<f64>) -> Self {
        let t = earth::ecef_to_geodetic_trig(r_e);
        Self::from_trig(&t)
    }

    /// [`Local::new`] with the sines and cosines already known.
    pub fn from_trig(t: &earth::GeodeticTrig) -> Self {
        let (sl, cl, so, co) = (t.sin_lat, t.cos_lat, t.sin_lon, t.cos_lon);
        let (rm, rn) = earth::radii_from_sin(sl);
        Self {
            geo: t.geo,
            sin_lat: sl,
            cos_lat: cl,
            east: Vector3::new(-so, co, 0.0),
            north: Vector3::new(-sl * co, -sl * so, cl),
            up: Vector3::new(cl * co, cl * so, sl),
            rm,
            rn,
            gravity: earth::normal_gravity_from_sin(sl, t.geo.h_m),
        }
    }

    /// C_e^g: rows east, north, up.
    pub fn c_e_g(&self) -> Matrix3<f64> {
        Matrix3::from_rows(&[
            self.east.transpose(),
            self.north.transpose(),
            self.up.transpose(),
        ])
    }

    /// Grid axes from the geometric definition (grid north = unit(up × ŷ_e)).
    pub fn grid_axes(&self) -> [Vector3<f64>; 3] {
        let north = self.up.cross(&Vector3::y()).normalize();
        [north.cross(&self.up), north, self.up]
    }

    /// C_e^G: rows grid east, grid north, up.
    pub fn c_e_grid(&self) -> Matrix3<f64> {
        let [e, n, u] = self.grid_axes();
        Matrix3::from_rows(&[e.transpose(), n.transpose(), u.transpose()])
    }

    /// u̇ (ECEF) for Earth-relative velocity `v_e`: (v_E/(R_N+h))·E + (v_N/(R_M+h))·N.
    /// Frame-free and finite at the poles (there R_M = R_N, so the arbitrary meridian drops out).
    pub fn up_rate(&self, v_e: &Vector3<f64>) -> Vector3<f64> {
        let h = self.geo.h_m;
        self.east * (v_e.dot(&self.east) / (self.rn + h))
            + self.north * (v_e.dot(&self.north) / (self.rm + h))
    }

    /// ω_eg^g for ENU velocity `v_g`; singular at the poles (tan L).
    pub fn transport_rate_g(&self, v_g: &Vector3<f64>) -> Vector3<f64> {
        let h = self.geo.h_m;
        Vector3::new(
            -v_g.y / (self.rm + h),
            v_g.x / (self.rn + h),
            v_g.x * self.sin_lat / self.cos_lat / (self.rn + h),
        )
    }

    /// ω_eG^G for Earth-relative velocity `v_e` (ECEF axes), from the time
    /// derivative of the geometric grid axes: [−N_G·u̇, E_G·u̇, −E_G·(u̇ × ŷ)/|u × ŷ|].
    pub fn transport_rate_grid(&self, v_e: &Vector3<f64>) -> Vector3<f64> {
        let u_dot = self.up_rate(v_e);
        let cross = self.up.cross(&Vector3::y());
        let d = cross.norm();
        let north = cross / d;
        let east = north.cross(&self.up);
        Vector3::new(
            -north.dot(&u_dot),
            east.dot(&u_dot),
            -east.dot(&u_dot.cross(&Vector3::y())) / d,
        )
    }
}

/// Rate of change of the ellipsoid normal (see [`Local::up_rate`]).
pub fn up_rate_e(pos: &Geodetic, v_e: &Vector3<f64>) -> Vector3<f64> {
    Local::new(pos).up_rate(v_e)
}

/// Transport rate of the geographic frame (see [`Local::transport_rate_g`]).
pub fn transport_rate_g(pos: &Geodetic, v_g: &Vector3<f64>) -> Vector3<f64> {
    Local::new(pos).transport_rate_g(v_g)
}

/// Transport rate of the grid frame (see [`Local::transport_rate_grid`]); finite at the poles.
pub fn transport_rate_grid(pos: &Geodetic, v_e: &Vector3<f64>) -> Vector3<f64> {
    Local::new(pos).transport_rate_grid(v_e)
}

/// Unit quaternion of an orthonormal DCM, closed form (Shepperd): the
/// largest of the four squared components is taken from the diagonal and
/// the others from off-diagonal sums, so it is stable for every rotation.
/// For matrices that are orthonormal to rounding (all DCMs built here);
/// nalgebra's `from_matrix` iterates and is ~20× slower.
pub fn quat_from_dcm(m: &Matrix3<f64>) -> UnitQuaternion<f64> {
    let tr = m[(0, 0)] + m[(1, 1)] + m[(2, 2)];
    let q = if tr > m[(0, 0)].max(m[(1, 1)]).max(m[(2, 2)]) {
        let s = (1.0 + tr).sqrt() * 2.0;
        Quaternion::new(
            0.25 * s,
            (m[(2, 1)] - m[(1, 2)]) / s,
            (m[(0, 2)] - m[(2, 0)]) / s,
            (m[(1, 0)] - m[(0, 1)]) / s,
        )
    } else if m[(0, 0)] >= m[(1, 1)] && m[(0, 0)] >= m[(2, 2)] {
        let s = (1.0 + m[(0, 0)] - m[(1, 1)] - m[(2, 2)]).sqrt() * 2.0;
        Quaternion::new(
            (m[(2, 1)] - m[(1, 2)]) / s,
            0.25 * s,
            (m[(0, 1)] + m[(1, 0)]) / s,
            (m[(0, 2)] + m[(2, 0)]) / s,
        )
    } else if m[(1, 1)] >= m[(2, 2)] {
        let s = (1.0 + m[(1, 1)] - m[(0, 0)] - m[(2, 2)]).sqrt() * 2.0;
        Quaternion::new(
            (m[(0, 2)] - m[(2, 0)]) / s,
            (m[(0, 1)] + m[(1, 0)]) / s,
            0.25 * s,
            (m[(1, 2)] + m[(2, 1)]) / s,
        )
    } else {
        let s = (1.0 + m[(2, 2)] - m[(0, 0)] - m[(1, 1)]).sqrt() * 2.0;
        Quaternion::new(
            (m[(1, 0)] - m[(0, 1)]) / s,
            (m[(0, 2)] + m[(2, 0)]) / s,
            (m[(1, 2)] + m[(2, 1)]) / s,
            0.25 * s,
        )
    };
    UnitQuaternion::from_quaternion(q)
}

/// Body→nav DCM from heading (clockwise from the nav frame's north), pitch
/// and roll (rad), for body axes x right, y forward, z up and an
/// east-north-up-type nav frame: C_b^n = R_z(−ψ)·R_x(θ)·R_y(φ).
pub fn c_b_n_from_euler(heading_rad: f64, pitch_rad: f64, roll_rad: f64) -> Matrix3<f64> {
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), -heading_rad);
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), pitch_rad);
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), roll_rad);
    (rz * rx * ry).into_inner()
}

/// Heading (0..2π, clockwise from north), pitch, roll of a body→nav DCM
/// (inverse of [`c_b_n_from_euler`]).
pub fn euler_from_c_b_n(c: &Matrix3<f64>) -> (f64, f64, f64) {
    let pitch = c[(2, 1)].clamp(-1.0, 1.0).asin();
    let roll = (-c[(2, 0)]).atan2(c[(2, 2)]);
    let heading = c[(0, 1)].atan2(c[(1, 1)]).rem_euclid(std::f64::consts::TAU);
    (heading, pitch, roll)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::{Geodetic, geodetic_to_ecef};

    /// papers/002 eq (1): closed form of the grid angle.
    fn sigma_002(lat: f64, lon: f64) -> (f64, f64) {
        let d = (1.0 - lat.cos().powi(2) * lon.sin().powi(2)).sqrt();
        (lat.sin() * lon.sin() / d, lon.cos() / d)
    }

    /// papers/002 eq (2): closed form of C_e^G.
    fn c_e_grid_002(lat: f64, lon: f64) -> Matrix3<f64> {
        let (ss, cs) = sigma_002(lat, lon);
        let (sl, cl) = lat.sin_cos();
        let (so, co) = lon.sin_cos();
        Matrix3::new(
            -cs * so + ss * sl * co,
            cs * co + ss * sl * so,
            -ss * cl,
            -ss * so - cs * sl * co,
            ss * co - cs * sl * so,
            cs * cl,
            cl * co,
            cl * so,
            sl,
        )
    }

    fn grid_points() -> Vec<(f64, f64)> {
        let mut pts = Vec::new();
        for lat in [
            -90.0, -89.99, -75.0, -45.0, -10.0, 0.0, 10.0, 31.94, 60.0, 70.0, 88.0, 90.0,
        ] {
            for lon in [
                -180.0, -135.0, -89.0, -30.0, 0.0, 45.0, 91.0, 118.79, 179.9, 180.0,
            ] {
                pts.push((f64::to_radians(lat), f64::to_radians(lon)));
            }
        }
        pts
    }

    #[test]
    fn grid_frame_from_geometry_equals_closed_forms_of_paper_002() {
        let mut worst: f64 = 0.0;
        for (lat, lon) in grid_points() {
            let geo = c_e_grid(lat, lon);
            let closed = c_e_grid_002(lat, lon);
            worst = worst.max((geo - closed).abs().max());
            let (ss, cs) = sigma_002(lat, lon);
            let s = grid_angle(lat, lon);
            worst = worst.max((s.sin() - ss).abs()).max((s.cos() - cs).abs());
        }
        assert!(worst < 1e-12, "max difference {worst}");
    }

    #[test]
    fn grid_frame_equals_rotated_geographic_frame() {
        // C_e^G = C_g^G(σ)·C_e^g (001 eq 25 with 002 eq 2).
        for (lat, lon) in grid_points() {
            let lhs = c_e_grid(lat, lon);
            let rhs = c_g_grid(grid_angle(lat, lon)) * c_e_g(lat, lon);
            assert!((lhs - rhs).abs().max() < 1e-12, "at {lat} {lon}");
        }
    }

    #[test]
    fn grid_north_equals_true_north_on_greenwich() {
        for lat in [-60.0_f64, 0.0, 45.0, 89.0] {
            assert!(grid_angle(lat.to_radians(), 0.0).abs() < 1e-15);
        }
    }

    #[test]
    fn grid_is_defined_at_both_poles() {
        for lat in [90.0_f64, -90.0] {
            let c = c_e_grid(lat.to_radians(), 0.3);
            assert!(c.iter().all(|x| x.is_finite()));
            assert!((c * c.transpose() - Matrix3::identity()).abs().max() < 1e-15);
            // Independent of the (meaningless) longitude at the pole.
            assert!((c - c_e_grid(lat.to_radians(), -2.0)).abs().max() < 1e-15);
        }
    }

    #[test]
    fn closed_form_quaternion_matches_nalgebra_for_every_branch() {
        // Rotations whose largest quaternion component is w, x, y and z in turn, and near-180° cases.
        let axes = [
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            Vector3::new(1.0, 1.0, -1.0),
        ];
        for axis in axes {
            for angle in [
                0.0,
                0.4,
                1.7,
                3.0,
                std::f64::consts::PI - 1e-9,
                std::f64::consts::PI,
            ] {
                let q =
                    UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
                let m = q.to_rotation_matrix().into_inner();
                let back = quat_from_dcm(&m);
                assert!(back.angle_to(&q) < 1e-12, "axis {axis} angle {angle}");
                let na = UnitQuaternion::from_matrix(&m);
                assert!(back.angle_to(&na) < 1e-12);
            }
        }
    }

    #[test]
    fn euler_round_trip_and_heading_convention() {
        for &(h, p, r) in &[
            (0.0, 0.0, 0.0),
            (1.0, 0.2, -0.3),
            (4.0, -1.2, 2.9),
            (6.2, 0.01, 0.5),
        ] {
            let c = c_b_n_from_euler(h, p, r);
            let (h2, p2, r2) = euler_from_c_b_n(&c);
            assert!((h - h2).abs() < 1e-12 && (p - p2).abs() < 1e-12 && (r - r2).abs() < 1e-12);
        }
        // Heading 90° points the forward axis east; positive pitch raises it; positive roll drops the right wing.
        let c = c_b_n_from_euler(std::f64::consts::FRAC_PI_2, 0.0, 0.0);
        assert!((c * Vector3::y() - Vector3::x()).norm() < 1e-15);
        assert!((c_b_n_from_euler(0.0, 0.1, 0.0) * Vector3::y()).z > 0.0);
        assert!((c_b_n_from_euler(0.0, 0.0, 0.1) * Vector3::x()).z < 0.0);
    }

    /// A position moving with `v_e` for time `dt` (exact straight line in ECEF;
    /// frame rates are first-order quantities so a straight line suffices).
    fn moved(pos: &Geodetic, v_e: &Vector3<f64>, dt: f64) -> Geodetic {
        earth::ecef_to_geodetic(&(geodetic_to_ecef(pos) + v_e * dt))
    }

    /// ω from finite differences of a frame's axes: [ė2·e3, ė3·e1, ė1·e2].
    fn omega_fd(
        axes: impl Fn(&Geodetic) -> [Vector3<f64>; 3],
        pos: &Geodetic,
        v_e: &Vector3<f64>,
    ) -> Vector3<f64> {
        let dt = 1e-3;
        let a = axes(pos);
        let p = axes(&moved(pos, v_e, dt));
        let m = axes(&moved(pos, v_e, -dt));
        let d: Vec<Vector3<f64>> = (0..3).map(|i| (p[i] - m[i]) / (2.0 * dt)).collect();
        Vector3::new(d[1].dot(&a[2]), d[2].dot(&a[0]), d[0].dot(&a[1]))
    }

    #[test]
    fn grid_transport_rate_matches_finite_differences_including_the_pole() {
        for &(lat, lon) in &[
            (70.0_f64, 10.0_f64),
            (85.0, -120.0),
            (89.999, 45.0),
            (90.0, 0.0),
            (-88.0, 170.0),
            (31.94, 118.79),
        ] {
            let pos = Geodetic::from_deg(lat, lon, 18_000.0);
            let v_e = Vector3::new(120.0, -200.0, 15.0);
            let w = transport_rate_grid(&pos, &v_e);
            let w_fd = omega_fd(|p| grid_axes_e(p.lat_rad, p.lon_rad), &pos, &v_e);
            assert!((w - w_fd).norm() < 1e-11, "at {lat},{lon}: {w} vs {w_fd}");
        }
    }

    #[test]
    fn geographic_transport_rate_matches_finite_differences() {
        for &(lat, lon) in &[(10.0_f64, 10.0_f64), (45.0, -120.0), (69.0, 179.0)] {
            let pos = Geodetic::from_deg(lat, lon, 500.0);
            let v_e = Vector3::new(120.0, -200.0, 15.0);
            let v_g = c_e_g(pos.lat_rad, pos.lon_rad) * v_e;
            let w = transport_rate_g(&pos, &v_g);
            let w_fd = omega_fd(|p| enu_axes_e(p.lat_rad, p.lon_rad), &pos, &v_e);
            assert!((w - w_fd).norm() < 1e-12, "at {lat},{lon}: {w} vs {w_fd}");
        }
    }
}
