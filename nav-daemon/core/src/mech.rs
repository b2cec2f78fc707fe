//! Strapdown mechanization from Δθ/Δv increments, in the geographic frame g
//! (position as latitude, longitude, height) and the grid frame G (position
//! in ECEF), as pure functions of (previous state, previous increment,
//! current increment).
//!
//! Algorithm, per interval [t_{k-1}, t_k]:
//! - attitude: body rotation vector with the two-sample "single sample +
//!   previous period" coning correction φ = Δθ_k + (1/12)·Δθ_{k-1}×Δθ_k,
//!   nav-frame rotation ζ = ω_in^n·Δt at mid-interval;
//! - velocity: rotation (½Δθ×Δv) and sculling ((Δθ_{k-1}×Δv_k + Δv_{k-1}×Δθ_k)/12)
//!   compensation, nav-frame rotation (I − ½ζ×), gravity and Coriolis at mid-interval;
//! - position: trapezoidal in the position rates.
//!
//! Mid-interval quantities are the mean of the start and of a predicted end
//! (a predictor step with the start-of-interval environment), so no
//! history beyond the previous increment is needed and a frame switch
//! between two steps needs no extra conversion.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::earth::{self, Geodetic};
use crate::frames::{self, Local};

/// One IMU interval: increments in body axes over `dt_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Increment {
    pub d_theta: Vector3<f64>,
    pub d_v: Vector3<f64>,
    pub dt_s: f64,
}

/// Which navigation frame a state is expressed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameKind {
    /// Local geographic east-north-up; position as latitude/longitude/height.
    Geographic,
    /// Grid frame; position in ECEF.
    Grid,
}

impl FrameKind {
    pub fn to_wire(self) -> msgs::WireFrame {
        match self {
            FrameKind::Geographic => msgs::WireFrame::Geographic,
            FrameKind::Grid => msgs::WireFrame::Grid,
        }
    }
}

/// A navigation frame: how its axes and transport rate follow from the
/// position, and how position is represented and advanced.
pub trait NavFrame: Copy + std::fmt::Debug + PartialEq {
    type Pos: Copy + std::fmt::Debug + PartialEq;
    const KIND: FrameKind;
    fn geodetic(pos: &Self::Pos) -> Geodetic;
    /// The local geometry at a position.
    fn local(pos: &Self::Pos) -> Local {
        Local::new(&Self::geodetic(pos))
    }
    /// C_e^n at a point.
    fn c_e_n(l: &Local) -> Matrix3<f64>;
    /// Transport rate ω_en^n for nav-frame velocity `v_n` (with `c_e_n` at `l`).
    fn omega_en_n(l: &Local, c_e_n: &Matrix3<f64>, v_n: &Vector3<f64>) -> Vector3<f64>;
    /// Trapezoidal position update from `v0` (start, nav axes at the start) to
    /// `v1` (end, nav axes at the end), with the geometry at the start (`l0`,
    /// `c_e_n0`) and at the predicted end (`l1`, `c_e_n1`).
    #[allow(clippy::too_many_arguments)]
    fn advance(
        pos: &Self::Pos,
        l0: &Local,
        l1: &Local,
        c_e_n0: &Matrix3<f64>,
        c_e_n1: &Matrix3<f64>,
        v0: &Vector3<f64>,
        v1: &Vector3<f64>,
        dt: f64,
    ) -> Self::Pos;
}

/// Marker: the local geographic frame g (ENU).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geo;
/// Marker: the grid frame G.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid;

impl NavFrame for Geo {
    type Pos = Geodetic;
    const KIND: FrameKind = FrameKind::Geographic;
    fn geodetic(pos: &Geodetic) -> Geodetic {
        *pos
    }
    fn c_e_n(l: &Local) -> Matrix3<f64> {
        l.c_e_g()
    }
    fn omega_en_n(l: &Local, _c_e_n: &Matrix3<f64>, v_n: &Vector3<f64>) -> Vector3<f64> {
        l.transport_rate_g(v_n)
    }
    fn advance(
        pos: &Geodetic,
        l0: &Local,
        l1: &Local,
        _c_e_n0: &Matrix3<f64>,
        _c_e_n1: &Matrix3<f64>,
        v0: &Vector3<f64>,
        v1: &Vector3<f64>,
        dt: f64,
    ) -> Geodetic {
        // Trapezoid of L̇ = v_N/(R_M+h), λ̇ = v_E/((R_N+h) cos L), ḣ = v_U.
        let lat_rate = |l: &Local, v: &Vector3<f64>| v.y / (l.rm + l.geo.h_m);
        let lon_rate = |l: &Local, v: &Vector3<f64>| v.x / ((l.rn + l.geo.h_m) * l.cos_lat);
        Geodetic::new(
            pos.lat_rad + 0.5 * (lat_rate(l0, v0) + lat_rate(l1, v1)) * dt,
            earth::wrap_pi(pos.lon_rad + 0.5 * (lon_rate(l0, v0) + lon_rate(l1, v1)) * dt),
            pos.h_m + 0.5 * (v0.z + v1.z) * dt,
        )
    }
}

impl NavFrame for Grid {
    type Pos = Vector3<f64>;
    const KIND: FrameKind = FrameKind::Grid;
    fn geodetic(pos: &Vector3<f64>) -> Geodetic {
        earth::ecef_to_geodetic(pos)
    }
    /// The sines and cosines from the conversion's own intermediates.
    fn local(pos: &Vector3<f64>) -> Local {
        Local::from_ecef(pos)
    }
    fn c_e_n(l: &Local) -> Matrix3<f64> {
        l.c_e_grid()
    }
    fn omega_en_n(l: &Local, c_e_n: &Matrix3<f64>, v_n: &Vector3<f64>) -> Vector3<f64> {
        l.transport_rate_grid(&(c_e_n.transpose() * v_n))
    }
    fn advance(
        pos: &Vector3<f64>,
        _l0: &Local,
        _l1: &Local,
        c_e_n0: &Matrix3<f64>,
        c_e_n1: &Matrix3<f64>,
        v0: &Vector3<f64>,
        v1: &Vector3<f64>,
        dt: f64,
    ) -> Vector3<f64> {
        // v0 is expressed in the grid frame at the start, v1 at the end.
        pos + (c_e_n0.tr_mul(v0) + c_e_n1.tr_mul(v1)) * (0.5 * dt)
    }
}

/// Navigation state in frame `F`: attitude body→nav, Earth-relative
/// velocity in nav axes, position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nav<F: NavFrame> {
    pub q_b_n: UnitQuaternion<f64>,
    pub v_n: Vector3<f64>,
    pub pos: F::Pos,
}

/// Earth rate, transport rate and gravity in nav axes at one instant.
#[derive(Debug, Clone, Copy)]
pub struct Environment {
    pub omega_ie_n: Vector3<f64>,
    pub omega_en_n: Vector3<f64>,
    pub g_n: Vector3<f64>,
}

impl Environment {
    pub fn at<F: NavFrame>(geo: &Geodetic, v_n: &Vector3<f64>) -> Self {
        let l = Local::new(geo);
        Self::with::<F>(&l, &F::c_e_n(&l), v_n)
    }

    /// The environment at a point whose geometry and C_e^n are known.
    pub fn with<F: NavFrame>(l: &Local, c_e_n: &Matrix3<f64>, v_n: &Vector3<f64>) -> Self {
        Self {
            omega_ie_n: c_e_n * earth::omega_ie_e(),
            omega_en_n: F::omega_en_n(l, c_e_n, v_n),
            g_n: Vector3::new(0.0, 0.0, -l.gravity),
        }
    }
    pub fn omega_in_n(&self) -> Vector3<f64> {
        self.omega_ie_n + self.omega_en_n
    }
}

/// Specific-force velocity increment in body axes with rotation and sculling compensation.
fn compensated_dv(prev: &Increment, cur: &Increment) -> Vector3<f64> {
    let rot = cur.d_theta.cross(&cur.d_v) * 0.5;
    let scul = (prev.d_theta.cross(&cur.d_v) + prev.d_v.cross(&cur.d_theta)) / 12.0;
    cur.d_v + rot + scul
}

fn velocity_update<F: NavFrame>(
    s: &Nav<F>,
    dv_sf_b: &Vector3<f64>,
    env: &Environment,
    v_mid: &Vector3<f64>,
    dt: f64,
) -> Vector3<f64> {
    let zeta = env.omega_in_n() * dt;
    let dv_sf_n = s.q_b_n * dv_sf_b;
    let dv_sf_n = dv_sf_n - zeta.cross(&dv_sf_n) * 0.5;
    let coriolis = (env.omega_ie_n * 2.0 + env.omega_en_n).cross(v_mid);
    s.v_n + dv_sf_n + (env.g_n - coriolis) * dt
}

/// One mechanization step: the state at t_k from the state at t_{k-1}, the
/// previous increment (for coning/sculling) and the current one.
pub fn mechanize<F: NavFrame>(s: &Nav<F>, prev: &Increment, cur: &Increment) -> Nav<F> {
    mechanize_at(s, &F::geodetic(&s.pos), prev, cur)
}

/// [`mechanize`] with the geodetic position of `s` already known (`geo0`).
pub fn mechanize_at<F: NavFrame>(
    s: &Nav<F>,
    geo0: &Geodetic,
    prev: &Increment,
    cur: &Increment,
) -> Nav<F> {
    mechanize_from(s, &Local::new(geo0), prev, cur)
}

/// [`mechanize`] with the local geometry at the position of `s` already
/// known (`l0`: the nominal state keeps it, so a step converts and takes
/// the trigonometry of one position, the predicted end, not two).
pub fn mechanize_from<F: NavFrame>(
    s: &Nav<F>,
    l0: &Local,
    prev: &Increment,
    cur: &Increment,
) -> Nav<F> {
    let dt = cur.dt_s;
    let dv_sf_b = compensated_dv(prev, cur);

    // Predictor with the start-of-interval environment.
    let l0 = *l0;
    let c0 = F::c_e_n(&l0);
    let env0 = Environment::with::<F>(&l0, &c0, &s.v_n);
    let v_pred = velocity_update(s, &dv_sf_b, &env0, &s.v_n, dt);
    let pos_pred = F::advance(&s.pos, &l0, &l0, &c0, &c0, &s.v_n, &v_pred, dt);

    // Corrector: the mid-interval environment as the mean of the start and
    // the predicted end (trapezoidal; second order like the midpoint rule).
    let l1 = F::local(&pos_pred);
    let c1 = F::c_e_n(&l1);
    let env1 = Environment::with::<F>(&l1, &c1, &v_pred);
    let env_mid = Environment {
        omega_ie_n: (env0.omega_ie_n + env1.omega_ie_n) * 0.5,
        omega_en_n: (env0.omega_en_n + env1.omega_en_n) * 0.5,
        g_n: (env0.g_n + env1.g_n) * 0.5,
    };
    let v_mid_pred = (s.v_n + v_pred) * 0.5;
    let v1 = velocity_update(s, &dv_sf_b, &env_mid, &v_mid_pred, dt);
    let pos1 = F::advance(&s.pos, &l0, &l1, &c0, &c1, &s.v_n, &v1, dt);

    // Attitude: body rotation with coning correction, nav-frame rotation at mid-interval.
    let phi_b = cur.d_theta + prev.d_theta.cross(&cur.d_theta) / 12.0;
    let zeta = env_mid.omega_in_n() * dt;
    let q_b_n =
        UnitQuaternion::from_scaled_axis(-zeta) * s.q_b_n * UnitQuaternion::from_scaled_axis(phi_b);
    Nav {
        q_b_n: q_b_n.normalize_unit(),
        v_n: v1,
        pos: pos1,
    }
}

/// Renormalization helper (nalgebra's `renormalize` works in place).
trait NormalizeUnit {
    fn normalize_unit(self) -> Self;
}
impl NormalizeUnit for UnitQuaternion<f64> {
    fn normalize_unit(mut self) -> Self {
        self.renormalize();
        self
    }
}

/// Converts a geographic-frame state to the grid frame (papers/001 eq 26;
/// position converted exactly to ECEF).
pub fn geo_to_grid(s: &Nav<Geo>) -> Nav<Grid> {
    let sigma = frames::grid_angle(s.pos.lat_rad, s.pos.lon_rad);
    let c_g_grid = frames::c_g_grid(sigma);
    let q_g_grid = frames::quat_from_dcm(&c_g_grid);
    Nav {
        q_b_n: q_g_grid * s.q_b_n,
        v_n: c_g_grid * s.v_n,
        pos: earth::geodetic_to_ecef(&s.pos),
    }
}

/// Converts a grid-frame state to the geographic frame (papers/001 eq 27).
pub fn grid_to_geo(s: &Nav<Grid>) -> Nav<Geo> {
    let geo = earth::ecef_to_geodetic(&s.pos);
    let sigma = frames::grid_angle(geo.lat_rad, geo.lon_rad);
    let c_grid_g = frames::c_g_grid(sigma).transpose();
    let q_grid_g = frames::quat_from_dcm(&c_grid_g);
    Nav {
        q_b_n: q_grid_g * s.q_b_n,
        v_n: c_grid_g * s.v_n,
        pos: geo,
    }
}

/// A navigation state in whichever frame is in use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AnyNav {
    Geographic(Nav<Geo>),
    Grid(Nav<Grid>),
}

/// Frame-free view of a navigation state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameFree {
    pub geo: Geodetic,
    pub r_e: Vector3<f64>,
    pub v_e: Vector3<f64>,
    pub q_b_e: UnitQuaternion<f64>,
}

impl AnyNav {
    pub fn kind(&self) -> FrameKind {
        match self {
            AnyNav::Geographic(_) => FrameKind::Geographic,
            AnyNav::Grid(_) => FrameKind::Grid,
        }
    }

    pub fn geodetic(&self) -> Geodetic {
        match self {
            AnyNav::Geographic(s) => s.pos,
            AnyNav::Grid(s) => Grid::geodetic(&s.pos),
        }
    }

    /// The local geometry at the position.
    pub fn local(&self) -> Local {
        match self {
            AnyNav::Geographic(s) => Geo::local(&s.pos),
            AnyNav::Grid(s) => Grid::local(&s.pos),
        }
    }

    /// Builds a state in frame `kind` from frame-free quantities.
    pub fn from_frame_free(
        kind: FrameKind,
        r_e: &Vector3<f64>,
        v_e: &Vector3<f64>,
        q_b_e: &UnitQuaternion<f64>,
    ) -> Self {
        fn build<F: NavFrame>(
            geo: &Geodetic,
            v_e: &Vector3<f64>,
            q_b_e: &UnitQuaternion<f64>,
            pos: F::Pos,
        ) -> Nav<F> {
            let c_e_n = F::c_e_n(&Local::new(geo));
            Nav {
                q_b_n: frames::quat_from_dcm(&c_e_n) * q_b_e,
                v_n: c_e_n * v_e,
                pos,
            }
        }
        let geo = earth::ecef_to_geodetic(r_e);
        match kind {
            FrameKind::Geographic => AnyNav::Geographic(build::<Geo>(&geo, v_e, q_b_e, geo)),
            FrameKind::Grid => AnyNav::Grid(build::<Grid>(&geo, v_e, q_b_e, *r_e)),
        }
    }

    /// Position, velocity and attitude independent of the nav frame.
    pub fn frame_free(&self) -> FrameFree {
        let geo = self.geodetic();
        self.frame_free_at(&geo, &self.c_e_n_at(&geo))
    }

    /// C_e^n of the current frame at the current position.
    pub fn c_e_n(&self) -> Matrix3<f64> {
        self.c_e_n_at(&self.geodetic())
    }

    /// Closed-loop feedback of an estimated error (φ, δv, δp of this frame):
    /// C_b^n ← R(φ) C_b^c (inverse of C_b^c = (I − φ×) C_b^n), v ← v − δv, p ← p − δp.
    pub fn correct(&mut self, phi: &Vector3<f64>, dv: &Vector3<f64>, dp: &Vector3<f64>) {
        self.correct_by(&UnitQuaternion::from_scaled_axis(*phi), dv, dp);
    }

    /// [`AnyNav::correct`] with the rotation R(φ) already made (the state
    /// history applies one correction to many states).
    pub fn correct_by(&mut self, rot: &UnitQuaternion<f64>, dv: &Vector3<f64>, dp: &Vector3<f64>) {
        match self {
            AnyNav::Geographic(s) => {
                s.q_b_n = rot * s.q_b_n;
                s.v_n -= dv;
                s.pos = Geodetic::new(
                    s.pos.lat_rad - dp.x,
                    earth::wrap_pi(s.pos.lon_rad - dp.y),
                    s.pos.h_m - dp.z,
                );
            }
            AnyNav::Grid(s) => {
                s.q_b_n = rot * s.q_b_n;
                s.v_n -= dv;
                s.pos -= dp;
            }
        }
    }

    /// Nav-frame velocity.
    pub fn v_n(&self) -> Vector3<f64> {
        match self {
            AnyNav::Geographic(s) => s.v_n,
            AnyNav::Grid(s) => s.v_n,
        }
    }

    /// One mechanization step in the current frame.
    pub fn mechanize(&self, prev: &Increment, cur: &Increment) -> Self {
        self.mechanize_at(&self.geodetic(), prev, cur)
    }

    /// [`AnyNav::mechanize`] with the current geodetic position already known.
    pub fn mechanize_at(&self, geo: &Geodetic, prev: &Increment, cur: &Increment) -> Self {
        self.mechanize_from(&Local::new(geo), prev, cur)
    }

    /// [`AnyNav::mechanize`] with the local geometry of the current
    /// position already known.
    pub fn mechanize_from(&self, l0: &Local, prev: &Increment, cur: &Increment) -> Self {
        match self {
            AnyNav::Geographic(s) => AnyNav::Geographic(mechanize_from(s, l0, prev, cur)),
            AnyNav::Grid(s) => AnyNav::Grid(mechanize_from(s, l0, prev, cur)),
        }
    }

    /// Frame-free view when the geodetic position and C_e^n are already known.
    pub fn frame_free_at(&self, geo: &Geodetic, c_e_n: &Matrix3<f64>) -> FrameFree {
        let (q_b_n, v_n, r_e) = match self {
            AnyNav::Geographic(s) => (s.q_b_n, s.v_n, earth::geodetic_to_ecef(&s.pos)),
            AnyNav::Grid(s) => (s.q_b_n, s.v_n, s.pos),
        };
        let q_n_e = frames::quat_from_dcm(&c_e_n.transpose());
        FrameFree {
            geo: *geo,
            r_e,
            v_e: c_e_n.transpose() * v_n,
            q_b_e: q_n_e * q_b_n,
        }
    }

    /// C_e^n at a known geodetic position.
    pub fn c_e_n_at(&self, geo: &Geodetic) -> Matrix3<f64> {
        match self {
            AnyNav::Geographic(_) => Geo::c_e_n(&Local::new(geo)),
            AnyNav::Grid(_) => Grid::c_e_n(&Local::new(geo)),
        }
    }

    /// The same state expressed in frame `kind` (identity if already there).
    pub fn converted(&self, kind: FrameKind) -> Self {
        match (self, kind) {
            (AnyNav::Geographic(s), FrameKind::Grid) => AnyNav::Grid(geo_to_grid(s)),
            (AnyNav::Grid(s), FrameKind::Geographic) => AnyNav::Geographic(grid_to_geo(s)),
            _ => *self,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_geo() -> Nav<Geo> {
        Nav {
            q_b_n: UnitQuaternion::from_matrix(&frames::c_b_n_from_euler(0.7, 0.05, -0.1)),
            v_n: Vector3::new(150.0, -190.0, 3.0),
            pos: Geodetic::from_deg(72.0, -160.0, 18_000.0),
        }
    }

    #[test]
    fn geo_grid_conversion_round_trips_and_preserves_frame_free_quantities() {
        let g = sample_geo();
        let grid = geo_to_grid(&g);
        let back = grid_to_geo(&grid);
        assert!((back.pos.lat_rad - g.pos.lat_rad).abs() < 1e-14);
        assert!((back.pos.h_m - g.pos.h_m).abs() < 1e-7);
        assert!((back.v_n - g.v_n).norm() < 1e-11);
        assert!(back.q_b_n.angle_to(&g.q_b_n) < 1e-14);
        let a = AnyNav::Geographic(g).frame_free();
        let b = AnyNav::Grid(grid).frame_free();
        assert!((a.r_e - b.r_e).norm() < 1e-7);
        assert!((a.v_e - b.v_e).norm() < 1e-11);
        assert!(a.q_b_e.angle_to(&b.q_b_e) < 1e-14);
    }

    #[test]
    fn conversion_matches_second_formulation_through_ecef() {
        // C_b^G = C_e^G C_g^e C_b^g, computed without the grid angle.
        let g = sample_geo();
        let grid = geo_to_grid(&g);
        let c_e_grid = frames::c_e_grid(g.pos.lat_rad, g.pos.lon_rad);
        let c_g_e = frames::c_e_g(g.pos.lat_rad, g.pos.lon_rad).transpose();
        let expect = c_e_grid * c_g_e * g.q_b_n.to_rotation_matrix().into_inner();
        assert!(
            (grid.q_b_n.to_rotation_matrix().into_inner() - expect)
                .abs()
                .max()
                < 1e-14
        );
    }

    #[test]
    fn stationary_level_imu_stays_put_in_both_frames() {
        // A body at rest: the exact increments are f = −g (up) and ω = Earth rate.
        for lat_deg in [31.94_f64, 75.0, 89.9] {
            let geo = Geodetic::from_deg(lat_deg, 118.79, 10.0);
            let c_b_g = frames::c_b_n_from_euler(0.3, 0.0, 0.0);
            let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
            let dt = 0.005;
            let w_b = c_b_g.transpose() * c_e_g * earth::omega_ie_e();
            let f_b = c_b_g.transpose()
                * Vector3::new(0.0, 0.0, earth::normal_gravity(geo.lat_rad, geo.h_m));
            let inc = Increment {
                d_theta: w_b * dt,
                d_v: f_b * dt,
                dt_s: dt,
            };
            let r0 = earth::geodetic_to_ecef(&geo);
            for kind in [FrameKind::Geographic, FrameKind::Grid] {
                let q_b_e = UnitQuaternion::from_matrix(&(c_e_g.transpose() * c_b_g));
                let mut s = AnyNav::from_frame_free(kind, &r0, &Vector3::zeros(), &q_b_e);
                for _ in 0..(600.0 / dt) as usize {
                    s = s.mechanize(&inc, &inc);
                }
                let ff = s.frame_free();
                assert!(
                    (ff.r_e - r0).norm() < 1e-3,
                    "{kind:?} at {lat_deg}: drift {}",
                    (ff.r_e - r0).norm()
                );
                assert!(
                    ff.v_e.norm() < 1e-5,
                    "{kind:?} at {lat_deg}: {}",
                    ff.v_e.norm()
                );
            }
        }
    }
}

/// The nominal navigation state with its geodetic position and local
/// geometry (trigonometry of latitude and longitude, radii, gravity)
/// cached: every change goes through a method that refreshes the cache, so
/// it cannot go stale (the mechanization and the solution read it instead
/// of converting ECEF → geodetic and taking the same sines again).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nominal {
    nav: AnyNav,
    local: Local,
}

impl Nominal {
    pub fn new(nav: AnyNav) -> Self {
        Self {
            local: nav.local(),
            nav,
        }
    }

    pub fn nav(&self) -> &AnyNav {
        &self.nav
    }

    pub fn geo(&self) -> Geodetic {
        self.local.geo
    }

    /// The local geometry at the current position.
    pub fn local(&self) -> &Local {
        &self.local
    }

    pub fn kind(&self) -> FrameKind {
        self.nav.kind()
    }

    /// One strapdown step.
    pub fn mechanize(&mut self, prev: &Increment, cur: &Increment) {
        *self = Self::new(self.nav.mechanize_from(&self.local, prev, cur));
    }

    /// The same state in frame `to`.
    pub fn convert(&mut self, to: FrameKind) {
        *self = Self::new(self.nav.converted(to));
    }

    /// Closed-loop feedback of an error-state correction.
    pub fn correct(&mut self, phi: &Vector3<f64>, dv: &Vector3<f64>, dp: &Vector3<f64>) {
        self.nav.correct(phi, dv, dp);
        self.local = self.nav.local();
    }
}
