//! Flight-state recognition and attitude compensation from the
//! accelerometers (paper 003 §4.5).
//!
//! **Recognition.** The IMU's compensated increments are summed over
//! windows of `window_s`. At each window's end the state is judged from
//! the window's mean specific force f̄ (body axes) and rate ω̄, and from the
//! navigator's own velocity at the window's ends:
//!
//! - *steady* when the body is not accelerating: |‖f̄‖ − γ| (γ the normal
//!   gravity at the nominal position), the centripetal acceleration of a
//!   rotation ‖ω̄‖·‖v‖ and the velocity's change ‖Δv‖/T all stay below
//!   `steady_accel_mps2`, and the rate below `steady_rate_dps`;
//! - *ground* when it is steady below `ground_speed_mps`;
//! - *manoeuvre* otherwise.
//!
//! Why these tests: paper 003 tests ‖f‖ against g, which finds climbs and
//! pulls but not a coordinated turn (‖f‖ = γ / cos φ grows only 0.4 % at a
//! 5° bank) nor an acceleration along the track (‖f‖ = √(γ² + a²)). A turn
//! is a rotation, so its centripetal acceleration ω v is the test; an
//! acceleration along the track is seen in the velocity. The velocity is
//! the navigator's: a tilt error δ shows in it as γ δ of apparent
//! acceleration, so beyond δ ≈ `steady_accel_mps2` / γ (1.2° by default)
//! no window is steady and the compensation stops — it then no longer
//! helps, but it never fuses a wrong level.
//!
//! **Compensation.** In a steady (or ground) window, while no aid that
//! makes the tilt observable (one that observes attitude or velocity:
//! GNSS, SRS, the star tracker, the dual-antenna baseline) has been fused
//! within its timeout, the accelerometers' mean gives the level: the
//! specific force of an unaccelerated body is known in nav axes,
//! f_e = 2 ω_ie × v − g(r) − (v_h² / R) u (gravity, Coriolis and the
//! curvature of a great-circle track), so the horizontal part of
//! (C_b^n f̄ − f) / γ is the tilt error, a 2-component measurement
//! z = [f×]_xy φ / γ − [C_b^n]_xy δb_a / γ ≈ (−φ_y, φ_x) − [C_b^n]_xy δb_a / γ
//! (gravity gives the level of the true position, so, unlike the star
//! tracker's inertial attitude, no frame rotation of a position error). Its noise covers what the tests let
//! through: σ² = (σ_vrw² / T + a_th²) / γ² per axis, a_th the steady
//! threshold (any residual acceleration the tests pass is at most a_th).
//! Never in a manoeuvre.

use nalgebra::{SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};

use crate::aids::Measurement;
use crate::bounds::{Bound, SettingsError};
use crate::earth;
use crate::error_model::idx;
use crate::mech::{AnyNav, Increment};

/// The aircraft's state as the IMU shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum FlightState {
    /// No window has ended yet.
    #[default]
    Unknown = 0,
    /// Steady and slower than `ground_speed_mps`: standing or taxiing.
    Ground = 1,
    /// Unaccelerated flight (cruise, a steady climb).
    Steady = 2,
    /// Turning, accelerating, pulling.
    Manoeuvre = 3,
}

impl FlightState {
    pub fn name(self) -> &'static str {
        match self {
            FlightState::Unknown => "unknown",
            FlightState::Ground => "ground",
            FlightState::Steady => "steady",
            FlightState::Manoeuvre => "manoeuvre",
        }
    }

    /// The state whose flag bits are `flags` (`msgs::solution_flags`).
    pub fn from_flags(flags: u32) -> Self {
        match (flags & msgs::solution_flags::FLIGHT_STATE_MASK)
            >> msgs::solution_flags::FLIGHT_STATE_SHIFT
        {
            1 => FlightState::Ground,
            2 => FlightState::Steady,
            3 => FlightState::Manoeuvre,
            _ => FlightState::Unknown,
        }
    }

    /// Its bits of the solution's flags.
    pub fn flags(self) -> u32 {
        (self as u32) << msgs::solution_flags::FLIGHT_STATE_SHIFT
    }

    /// Whether the accelerometers may level the attitude.
    pub fn is_steady(self) -> bool {
        matches!(self, FlightState::Ground | FlightState::Steady)
    }
}

/// `[filter.flight_state]`: recognition thresholds and the compensation.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FlightStateSettings {
    /// Length of the windows the state is judged over (s).
    pub window_s: f64,
    /// Largest acceleration of a steady window (m/s²): of ‖f̄‖ against
    /// gravity, of a rotation's centripetal ω v, and of the velocity's
    /// change. It sets the level's noise too: a residual acceleration
    /// anywhere below it, as a uniform one, σ = a / (√3 γ) per axis.
    /// Default 0.1 m/s² (a level σ of 0.34°): twice the mean vibration a
    /// light aircraft's cruise leaves in a 1 s mean (0.02–0.05 m/s²), and
    /// well below the 0.9 m/s² of the gentlest (5°-bank) turn.
    pub steady_accel_mps2: f64,
    /// Largest mean rate of a steady window (°/s). Default 0.5°/s: a
    /// quarter of the 2–3°/s of a standard-rate turn, and at taxi speeds,
    /// where ω v is small, what tells a turn on the ground from standing.
    pub steady_rate_dps: f64,
    /// Steady below this speed is on the ground (m/s). Default 5 m/s:
    /// below any aircraft's flying speed, above a taxi's walking pace.
    pub ground_speed_mps: f64,
    /// Fuse roll and pitch from the accelerometers in steady windows
    /// while the aids that observe tilt are missing.
    pub compensate: bool,
    /// ... for a gyro whose bias σ (`filter.gyro_bias_dph`) is at least
    /// this (°/h). Default 5°/h: such a gyro tilts its level by the
    /// accelerometers' 0.34° within about four minutes, a MEMS gyro (tens
    /// of °/h) within one; a navigation- or tactical-grade gyro (0.01–1°/h)
    /// holds its Schuler-bounded level better than the accelerometers give
    /// it in flight, and its flights — pure inertial ones too — are not
    /// touched. 0: every gyro.
    pub min_gyro_bias_dph: f64,
}

impl Default for FlightStateSettings {
    fn default() -> Self {
        Self {
            window_s: 1.0,
            steady_accel_mps2: 0.1,
            steady_rate_dps: 0.5,
            ground_speed_mps: 5.0,
            compensate: true,
            min_gyro_bias_dph: 5.0,
        }
    }
}

/// χ² gate of the level measurement (2 degrees of freedom, 99.9 %).
pub const LEVEL_GATE: f64 = 13.816;

impl FlightStateSettings {
    pub fn validate(&self, origin: &str) -> Result<(), SettingsError> {
        Bound {
            lo: 0.05,
            hi: 10.0,
            unit: "s",
            below: "shorter than a few IMU periods of a 100 Hz MEMS: the mean is noise",
            above: "longer than a manoeuvre's onset: a turn would be averaged into steady",
        }
        .check(origin, "filter.flight_state.window_s", self.window_s)?;
        Bound {
            lo: 0.001,
            hi: 5.0,
            unit: "m/s²",
            below: "below any IMU's noise in a window's mean: nothing would be steady",
            above: "half a g of acceleration is no steady flight: a level taken then \
                    would be off by 27°",
        }
        .check(
            origin,
            "filter.flight_state.steady_accel_mps2",
            self.steady_accel_mps2,
        )?;
        Bound {
            lo: 0.001,
            hi: 30.0,
            unit: "°/s",
            below: "below a MEMS gyro's bias: nothing would be steady",
            above: "30°/s is a hard turn",
        }
        .check(
            origin,
            "filter.flight_state.steady_rate_dps",
            self.steady_rate_dps,
        )?;
        Bound {
            lo: 0.0,
            hi: 100.0,
            unit: "m/s",
            below: "a speed is not negative",
            above: "100 m/s is flying, not on the ground",
        }
        .check(
            origin,
            "filter.flight_state.ground_speed_mps",
            self.ground_speed_mps,
        )?;
        Bound {
            lo: 0.0,
            hi: 1e4,
            unit: "°/h",
            below: "a bias σ is not negative",
            above: "no gyro drifts 3° a second",
        }
        .check(
            origin,
            "filter.flight_state.min_gyro_bias_dph",
            self.min_gyro_bias_dph,
        )?;
        Ok(())
    }
}

/// The sums of one window: the specific force carried into the newest
/// body axes (S ← (I − Δθ×) S + Δv, so a slow rotation during the window
/// does not smear it), the rate, and the velocity at the window's start.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Window {
    sum_dv_b: Vector3<f64>,
    sum_dtheta: Vector3<f64>,
    t_s: f64,
    v_start_e: Option<Vector3<f64>>,
}

/// What a finished window measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowMean {
    /// Mean specific force in the newest body axes, the bias estimate
    /// removed (m/s²).
    pub f_b: Vector3<f64>,
    /// Mean rate against inertial space (rad/s).
    pub omega_b: Vector3<f64>,
    /// The navigator's acceleration over the window, ‖Δv_e‖ / T (m/s²).
    pub accel_mps2: f64,
    pub t_s: f64,
}

impl Window {
    /// Starts a window at the nominal velocity `v_e` if none is open
    /// (once per window: the caller computes `v_e` only then).
    pub fn is_open(&self) -> bool {
        self.v_start_e.is_some()
    }

    pub fn open(&mut self, v_e: &Vector3<f64>) {
        self.v_start_e = Some(*v_e);
    }

    /// Adds one compensated increment.
    pub fn push(&mut self, inc: &Increment) {
        self.sum_dv_b = self.sum_dv_b - inc.d_theta.cross(&self.sum_dv_b) + inc.d_v;
        self.sum_dtheta += inc.d_theta;
        self.t_s += inc.dt_s;
    }

    /// Whether the window spans `window_s`.
    pub fn full(&self, window_s: f64) -> bool {
        self.t_s >= window_s && self.t_s > 0.0
    }

    /// The window's means once it spans `window_s`, with the nominal
    /// velocity `v_e` now; the window starts again.
    pub fn finish(&mut self, window_s: f64, v_e: &Vector3<f64>) -> Option<WindowMean> {
        if self.t_s < window_s || self.t_s <= 0.0 {
            return None;
        }
        let t = self.t_s;
        let mean = WindowMean {
            f_b: self.sum_dv_b / t,
            omega_b: self.sum_dtheta / t,
            accel_mps2: self.v_start_e.map_or(0.0, |v0| (v_e - v0).norm() / t),
            t_s: t,
        };
        *self = Window::default();
        Some(mean)
    }

    /// Forgets the window (a reset, a coast, a new init).
    pub fn clear(&mut self) {
        *self = Window::default();
    }
}

/// The state a window shows, for a body at `geo` moving at `speed_mps`.
pub fn classify(
    w: &WindowMean,
    geo: &earth::Geodetic,
    speed_mps: f64,
    s: &FlightStateSettings,
) -> FlightState {
    let gamma = earth::normal_gravity(geo.lat_rad, geo.h_m);
    let rate = w.omega_b.norm();
    let a_th = s.steady_accel_mps2;
    let steady = (w.f_b.norm() - gamma).abs() < a_th
        && rate * speed_mps < a_th
        && w.accel_mps2 < a_th
        && rate < s.steady_rate_dps.to_radians();
    // NaN anywhere makes every comparison false: a manoeuvre, never fused.
    match (steady, speed_mps < s.ground_speed_mps) {
        (true, true) => FlightState::Ground,
        (true, false) => FlightState::Steady,
        (false, _) => FlightState::Manoeuvre,
    }
}

/// The specific force of an unaccelerated body at the state of `nav`
/// (ECEF axes, m/s²): gravity, Coriolis and a great-circle track's
/// curvature.
pub fn unaccelerated_specific_force_e(nav: &AnyNav) -> Vector3<f64> {
    let ff = nav.frame_free();
    let up = earth::up_e(ff.geo.lat_rad, ff.geo.lon_rad);
    let gamma = earth::normal_gravity(ff.geo.lat_rad, ff.geo.h_m);
    let (rm, rn) = earth::radii(ff.geo.lat_rad);
    let r = (rm * rn).sqrt() + ff.geo.h_m;
    let v_h = ff.v_e - up * ff.v_e.dot(&up);
    2.0 * earth::omega_ie_e().cross(&ff.v_e) + up * gamma - up * (v_h.norm_squared() / r)
}

/// The level measurement of a steady window: `f_raw_b` the mean specific
/// force before the bias estimate `ba_hat` is removed (body axes of the
/// state `nav`), `vrw` the accelerometer's velocity random walk (m/s/√s).
pub fn level_measurement(
    nav: &AnyNav,
    f_raw_b: &Vector3<f64>,
    ba_hat: &Vector3<f64>,
    t_s: f64,
    vrw: f64,
    s: &FlightStateSettings,
) -> Option<Measurement<2>> {
    let ff = nav.frame_free();
    let c_e_n = nav.c_e_n();
    let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
    let c_b_n = c_e_n * c_b_e;
    let gamma = earth::normal_gravity(ff.geo.lat_rad, ff.geo.h_m);
    let f_n = c_b_n * (f_raw_b - ba_hat);
    let expected_n = c_e_n * unaccelerated_specific_force_e(nav);
    let d = (f_n - expected_n) / gamma;
    let z = Vector2::new(d.x, d.y);
    // C_b^ĉ = (I − φ×) C_b^n turns the true f into f + f × φ: the x and y
    // rows of [f×] / γ (≈ γ [[0, −1, 0], [1, 0, 0]] / γ, with the Coriolis
    // and curvature terms of f).
    let fx = expected_n.cross_matrix() / gamma;
    let sel = fx.fixed_view::<2, 3>(0, 0).into_owned();
    let mut h = SMatrix::<f64, 2, 15>::zeros();
    h.fixed_view_mut::<2, 3>(0, idx::PHI).copy_from(&sel);
    // No position term: gravity gives the level of the true position and φ
    // is the attitude error against the nav frame of each position (unlike
    // the star tracker's inertial attitude, which sees the frame rotation
    // Θ δp); only the Coriolis and curvature terms move with δp, by less
    // than 1e-9 per metre.
    // Compensated f = f_raw − b̂ = f − δb_a: −C_b^n δb_a / γ, its x and y rows.
    for i in 0..2 {
        for j in 0..3 {
            h[(i, idx::BA + j)] = -c_b_n[(i, j)] / gamma;
        }
    }
    let var = (vrw * vrw / t_s.max(1e-9) + s.steady_accel_mps2.powi(2) / 3.0) / (gamma * gamma);
    let r = SMatrix::<f64, 2, 2>::identity() * var;
    (z.iter().all(|x| x.is_finite()) && h.iter().all(|x| x.is_finite()) && var.is_finite())
        .then_some(Measurement { z, h, r })
}

/// The innovation's χ² against `p` (used by tests and the report).
pub fn nis(m: &Measurement<2>, p: &SMatrix<f64, 15, 15>) -> f64 {
    let s = m.h * p * m.h.transpose() + m.r;
    s.try_inverse()
        .map_or(f64::INFINITY, |si| (m.z.transpose() * si * m.z)[(0, 0)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::tests::{computed, truth};
    use crate::mech::FrameKind;
    use nalgebra::SVector;

    /// The mean specific force the accelerometers of the true state `t`
    /// measure in unaccelerated flight, built independently of the model:
    /// from the ENU gravity vector, the Coriolis term in ENU and the track's
    /// curvature, then through the true attitude into body axes.
    fn steady_f_b(t: &AnyNav) -> Vector3<f64> {
        let geo = t.geodetic();
        let c_e_g = crate::frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let v_g = c_e_g * t.frame_free().v_e;
        let (sl, cl) = geo.lat_rad.sin_cos();
        let w_ie_g = Vector3::new(0.0, cl, sl) * earth::OMEGA_IE;
        let gamma = earth::normal_gravity(geo.lat_rad, geo.h_m);
        let (rm, rn) = earth::radii(geo.lat_rad);
        let r = (rm * rn).sqrt() + geo.h_m;
        let v_h2 = v_g.x * v_g.x + v_g.y * v_g.y;
        let f_g = 2.0 * w_ie_g.cross(&v_g) + Vector3::new(0.0, 0.0, gamma - v_h2 / r);
        let c_b_e = t.frame_free().q_b_e.to_rotation_matrix().into_inner();
        c_b_e.transpose() * c_e_g.transpose() * f_g
    }

    fn z_of(nav: &AnyNav, f_raw: &Vector3<f64>, ba: &Vector3<f64>) -> Vector2<f64> {
        level_measurement(nav, f_raw, ba, 1.0, 1e-3, &FlightStateSettings::default())
            .expect("level")
            .z
    }

    #[test]
    fn level_jacobian_matches_central_differences_in_g_and_in_grid() {
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Geographic, -69.0, -120.0),
            (FrameKind::Grid, 88.0, -60.0),
            (FrameKind::Grid, 89.99999, 20.0),
            (FrameKind::Grid, -90.0, 0.0),
        ] {
            let t = truth(kind, lat, lon);
            let f = steady_f_b(&t);
            let ba0 = Vector3::zeros();
            let m = level_measurement(&t, &f, &ba0, 1.0, 1e-3, &FlightStateSettings::default())
                .expect("level");
            assert!(m.z.amax() < 1e-12, "{kind:?} {lat}: z at the truth {}", m.z);
            let pos_steps = match kind {
                FrameKind::Geographic => [1e-7, 1e-7, 10.0],
                FrameKind::Grid => [10.0, 10.0, 10.0],
            };
            let mut fd = SMatrix::<f64, 2, 15>::zeros();
            for j in 0..15 {
                let step = match j {
                    0..3 => 1e-6,
                    3..6 => 1e-3,
                    6..9 => pos_steps[j - 6],
                    _ => 1e-4,
                };
                let mut x = SVector::<f64, 15>::zeros();
                x[j] = step;
                // δx = computed − true; the bias states are the estimate's
                // error: b̂ = b + δb with the true bias 0.
                let ba = |s: f64| {
                    if (idx::BA..idx::BA + 3).contains(&j) {
                        let mut b = Vector3::zeros();
                        b[j - idx::BA] = s;
                        b
                    } else {
                        Vector3::zeros()
                    }
                };
                let zp = z_of(&computed(&t, &x), &f, &ba(step));
                let zm = z_of(&computed(&t, &-x), &f, &ba(-step));
                fd.set_column(j, &((zp - zm) / (2.0 * step)));
            }
            let d = fd - m.h;
            assert!(
                d.fixed_view::<2, 3>(0, idx::PHI).amax() < 1e-6,
                "{kind:?} {lat}: φ block H {} FD {}",
                m.h.fixed_view::<2, 3>(0, idx::PHI),
                fd.fixed_view::<2, 3>(0, idx::PHI)
            );
            // Per metre of position error the level moves by < 1e-9 (the
            // Coriolis and curvature terms): H leaves it out.
            let per_metre = fd.fixed_view::<2, 3>(0, idx::DP)
                * crate::aids::ecef_per_position_error(&t)
                    .try_inverse()
                    .expect("T3");
            assert!(
                per_metre.amax() < 1e-9 && m.h.fixed_view::<2, 3>(0, idx::DP).amax() == 0.0,
                "{kind:?} {lat}: δp block FD per metre {per_metre}"
            );
            assert!(
                d.fixed_view::<2, 3>(0, idx::BA).amax() < 1e-8,
                "{kind:?} {lat}: δb_a block H {} FD {}",
                m.h.fixed_view::<2, 3>(0, idx::BA),
                fd.fixed_view::<2, 3>(0, idx::BA)
            );
            // The velocity changes only the tiny Coriolis and curvature
            // terms (≲ 2 ω_ie / γ per m/s); the model leaves them out of H.
            assert!(fd.fixed_view::<2, 3>(0, idx::DV).amax() < 2e-5);
            assert!(fd.fixed_view::<2, 3>(0, idx::BG).amax() < 1e-12);
        }
    }

    #[test]
    fn a_window_carries_the_specific_force_through_a_rotation() {
        // A body turning at 10°/s about its z axis for 1 s under a constant
        // specific force fixed in the turning axes' start: the sum in the
        // newest axes equals the exact rotated mean (independently: the
        // integral of R_z(−ωt) f over the window in the end axes).
        let w = 10f64.to_radians();
        let n = 1000;
        let dt = 1.0 / n as f64;
        let f0 = Vector3::new(1.0, 2.0, 9.8);
        let mut win = Window::default();
        for k in 0..n {
            let t = (k as f64 + 0.5) * dt;
            // f in body axes at t: the inertially fixed f0 seen from a body
            // rotated by ωt about z.
            let rot = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), -w * t);
            let dv = rot * f0 * dt;
            if !win.is_open() {
                win.open(&Vector3::zeros());
            }
            win.push(&Increment {
                d_theta: Vector3::new(0.0, 0.0, w * dt),
                d_v: dv,
                dt_s: dt,
            });
        }
        let m = win.finish(1.0 - 1e-9, &Vector3::zeros()).expect("window");
        let end = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), -w) * f0;
        assert!(
            (m.f_b - end).norm() < 1e-4 * f0.norm(),
            "{} vs {}",
            m.f_b,
            end
        );
        assert!((m.omega_b.z - w).abs() < 1e-12);
    }

    fn window(f_b: Vector3<f64>, omega_b: Vector3<f64>, accel: f64) -> WindowMean {
        WindowMean {
            f_b,
            omega_b,
            accel_mps2: accel,
            t_s: 1.0,
        }
    }

    #[test]
    fn states_are_told_apart_by_the_tests_that_define_them() {
        let s = FlightStateSettings::default();
        let geo = earth::Geodetic::from_deg(45.0, 10.0, 1000.0);
        let g = earth::normal_gravity(geo.lat_rad, geo.h_m);
        let up = Vector3::new(0.0, 0.0, g);
        let still = Vector3::zeros();
        assert_eq!(
            classify(&window(up, still, 0.0), &geo, 0.0, &s),
            FlightState::Ground
        );
        assert_eq!(
            classify(&window(up, still, 0.01), &geo, 60.0, &s),
            FlightState::Steady
        );
        // A coordinated 5° bank at 60 m/s: ‖f‖ grows only 0.4 %, the
        // rotation's centripetal ω v = g tan 5° is what shows it.
        let bank = 5f64.to_radians();
        let rate = g * bank.tan() / 60.0;
        let f_turn = Vector3::new(0.0, 0.0, g / bank.cos());
        assert!((f_turn.norm() - g).abs() < s.steady_accel_mps2);
        assert_eq!(
            classify(
                &window(f_turn, Vector3::new(0.0, 0.0, rate), 0.0),
                &geo,
                60.0,
                &s
            ),
            FlightState::Manoeuvre
        );
        // Accelerating along the track at 0.5 m/s²: ‖f‖ changes 0.013 m/s².
        let f_acc = Vector3::new(0.0, 0.5, g);
        assert!((f_acc.norm() - g).abs() < s.steady_accel_mps2);
        assert_eq!(
            classify(&window(f_acc, still, 0.5), &geo, 60.0, &s),
            FlightState::Manoeuvre
        );
        // A pull-up at 1.2 g.
        assert_eq!(
            classify(&window(up * 1.2, still, 2.0), &geo, 60.0, &s),
            FlightState::Manoeuvre
        );
        // Turning on the spot on the ground.
        assert_eq!(
            classify(&window(up, Vector3::new(0.0, 0.0, 0.2), 0.0), &geo, 0.0, &s),
            FlightState::Manoeuvre
        );
        // NaN is never steady.
        assert_eq!(
            classify(&window(up * f64::NAN, still, 0.0), &geo, 0.0, &s),
            FlightState::Manoeuvre
        );
        for st in [
            FlightState::Unknown,
            FlightState::Ground,
            FlightState::Steady,
            FlightState::Manoeuvre,
        ] {
            assert_eq!(FlightState::from_flags(st.flags() | 0x1ff | (1 << 17)), st);
        }
    }

    #[test]
    fn settings_outside_their_bounds_are_refused_naming_the_key() {
        for (key, set) in [
            (
                "window_s",
                (|s: &mut FlightStateSettings| s.window_s = 1e-10) as fn(&mut _),
            ),
            ("window_s", |s| s.window_s = 1e6),
            ("steady_accel_mps2", |s| s.steady_accel_mps2 = f64::NAN),
            ("steady_accel_mps2", |s| s.steady_accel_mps2 = 1e300),
            ("steady_rate_dps", |s| s.steady_rate_dps = 0.0),
            ("ground_speed_mps", |s| s.ground_speed_mps = -1.0),
            ("ground_speed_mps", |s| s.ground_speed_mps = f64::INFINITY),
            ("min_gyro_bias_dph", |s| s.min_gyro_bias_dph = -1.0),
            ("min_gyro_bias_dph", |s| s.min_gyro_bias_dph = f64::NAN),
        ] {
            let mut s = FlightStateSettings::default();
            set(&mut s);
            let e = s.validate("test.toml").expect_err(key);
            assert_eq!(e.key, format!("filter.flight_state.{key}"));
        }
        FlightStateSettings::default()
            .validate("x")
            .expect("defaults");
    }
}
