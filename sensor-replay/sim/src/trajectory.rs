//! Truth trajectory and exact IMU increments.
//!
//! The flight is an ODE in frame-free quantities, so nothing is singular at
//! the poles: ECEF position r and a horizontal unit direction of travel t
//! (tangent to the ellipsoid). Along a cruise t is parallel-transported
//! (ṫ = −(t·u̇)u, a great-circle track); a turn adds ψ̇·(t × u). Horizontal
//! speed, climb rate and turn rate are smooth (cosine-ramped) functions of
//! time given by the segments. Body axes follow the velocity (y forward,
//! pitch = flight-path angle) with coordinated bank in turns.
//!
//! The body rate ω_eb^b comes from the analytic derivative of C_b^e,
//! the specific force from the analytic acceleration, and both are
//! integrated together with the trajectory by RK4, so each sample's
//! Δθ = ∫ω_ib^b dt and Δv = ∫f^b dt are consistent with the truth to the
//! integrator's precision (far below the mechanization's own error).

use nalgebra::{Matrix3, Vector3};
use polarnav::earth::{self, Geodetic};
use polarnav::frames;

use crate::scenario::{BankMode, Scenario, Segment};
pub use crate::sensors::TruthSample;

/// Smooth ramp: s(τ) = ½(1 − cos(πτ/r)) rises 0→1 over [0, r].
fn ramp(tau: f64, r: f64) -> (f64, f64, f64) {
    // (value, derivative, integral from 0)
    let k = std::f64::consts::PI / r;
    let (s, c) = (k * tau).sin_cos();
    (0.5 * (1.0 - c), 0.5 * k * s, 0.5 * (tau - s / k))
}

/// A trapezoid-like pulse of height `rate` over [0, T] with ramps of `r`:
/// returns (value, derivative, integral from 0) at τ.
fn pulse(tau: f64, duration: f64, r: f64, rate: f64) -> (f64, f64, f64) {
    if tau <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let total = rate * (duration - r);
    if tau >= duration {
        return (0.0, 0.0, total);
    }
    if tau < r {
        let (s, ds, is) = ramp(tau, r);
        (rate * s, rate * ds, rate * is)
    } else if tau <= duration - r {
        (rate, 0.0, rate * (0.5 * r + (tau - r)))
    } else {
        let (s, ds, is) = ramp(duration - tau, r);
        (rate * s, -rate * ds, total - rate * is)
    }
}

#[derive(Debug, Clone, Copy)]
enum Channel {
    Heading,
    Climb,
    Speed,
}

#[derive(Debug, Clone, Copy)]
struct Pulse {
    channel: Channel,
    t0: f64,
    duration: f64,
    ramp: f64,
    rate: f64,
}

/// Commanded profiles at one instant.
#[derive(Debug, Clone, Copy, Default)]
pub struct Profile {
    pub speed: f64,
    pub speed_dot: f64,
    pub climb: f64,
    pub climb_dot: f64,
    pub turn_rate: f64,
    pub turn_rate_dot: f64,
}

/// Time-dependent commands built from the segments.
#[derive(Debug, Clone)]
pub struct Commands {
    v0: f64,
    pulses: Vec<Pulse>,
    bank: BankMode,
}

impl Commands {
    pub fn new(s: &Scenario) -> Self {
        let mut t0 = 0.0;
        let mut pulses = Vec::new();
        for seg in &s.segments {
            let d = seg.duration_s();
            let default_ramp = (d / 3.0).min(5.0);
            let mut push = |channel, change: f64, ramp: Option<f64>| {
                let r = ramp.unwrap_or(default_ramp);
                pulses.push(Pulse {
                    channel,
                    t0,
                    duration: d,
                    ramp: r,
                    rate: change / (d - r),
                });
            };
            match *seg {
                Segment::Cruise { .. } => {}
                Segment::Turn {
                    heading_change_deg,
                    ramp_s,
                    ..
                } => push(Channel::Heading, heading_change_deg.to_radians(), ramp_s),
                Segment::Climb {
                    altitude_change_m,
                    ramp_s,
                    ..
                } => push(Channel::Climb, altitude_change_m, ramp_s),
                Segment::Accelerate {
                    speed_change_mps,
                    ramp_s,
                    ..
                } => push(Channel::Speed, speed_change_mps, ramp_s),
            }
            t0 += d;
        }
        Self {
            v0: s.start.speed_mps,
            pulses,
            bank: s.start.bank,
        }
    }

    pub fn at(&self, t: f64) -> Profile {
        let mut p = Profile {
            speed: self.v0,
            ..Default::default()
        };
        for pl in &self.pulses {
            let (v, dv, iv) = pulse(t - pl.t0, pl.duration, pl.ramp, pl.rate);
            match pl.channel {
                Channel::Heading => {
                    p.turn_rate += v;
                    p.turn_rate_dot += dv;
                }
                Channel::Climb => {
                    p.climb += v;
                    p.climb_dot += dv;
                }
                Channel::Speed => {
                    p.speed += iv;
                    p.speed_dot += v;
                }
            }
        }
        p
    }
}

/// Integrated state: position, direction of travel, and the running
/// integrals of ω_ib^b and f^b since the last sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    pub r_e: Vector3<f64>,
    pub dir_e: Vector3<f64>,
    pub int_omega_b: Vector3<f64>,
    pub int_f_b: Vector3<f64>,
}

/// Everything the kinematics give at one instant.
#[derive(Debug, Clone, Copy)]
pub struct Kinematics {
    pub v_e: Vector3<f64>,
    pub dir_dot: Vector3<f64>,
    pub c_b_e: Matrix3<f64>,
    pub omega_ib_b: Vector3<f64>,
    pub f_b: Vector3<f64>,
}

/// Kinematics of the flight at time `t` in state (r, dir).
pub fn kinematics(cmd: &Commands, t: f64, r_e: &Vector3<f64>, dir: &Vector3<f64>) -> Kinematics {
    kinematics_at(cmd, t, &frames::Local::from_ecef(r_e), dir)
}

/// [`kinematics`] with the local geometry at the position known: its up,
/// up's rate and gravity are the formulas of earth::up_e,
/// frames::up_rate_e and earth::normal_gravity, from the sines and cosines
/// of the ECEF → geodetic conversion (no `sin_cos`).
pub fn kinematics_at(
    cmd: &Commands,
    t: f64,
    local: &frames::Local,
    dir: &Vector3<f64>,
) -> Kinematics {
    let u = local.up;
    let p = cmd.at(t);
    let v_e = dir * p.speed + u * p.climb;
    let u_dot = local.up_rate(&v_e);
    let dir_dot = -u * dir.dot(&u_dot) + dir.cross(&u) * p.turn_rate;
    let a_e = dir * p.speed_dot + dir_dot * p.speed + u * p.climb_dot + u_dot * p.climb;

    // Level axes: forward `dir`, right s = dir × u, up u.
    let s = dir.cross(&u);
    let s_dot = dir_dot.cross(&u) + dir.cross(&u_dot);
    // Pitch = flight-path angle.
    let (theta, theta_dot) = {
        let d = p.speed * p.speed + p.climb * p.climb;
        if d > 0.0 {
            (
                p.climb.atan2(p.speed),
                (p.speed * p.climb_dot - p.climb * p.speed_dot) / d,
            )
        } else {
            (0.0, 0.0)
        }
    };
    let (phi, phi_dot) = match cmd.bank {
        BankMode::Level => (0.0, 0.0),
        BankMode::Coordinated => {
            let k = p.speed * p.turn_rate / earth::G0;
            let k_dot = (p.speed_dot * p.turn_rate + p.speed * p.turn_rate_dot) / earth::G0;
            (k.atan(), k_dot / (1.0 + k * k))
        }
    };
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    let fwd = dir * ct + u * st;
    let fwd_dot = dir_dot * ct + u_dot * st + (u * ct - dir * st) * theta_dot;
    let upp = u * ct - dir * st;
    let upp_dot = u_dot * ct - dir_dot * st - (dir * ct + u * st) * theta_dot;
    let x_b = s * cp - upp * sp;
    let x_dot = s_dot * cp - upp_dot * sp - (s * sp + upp * cp) * phi_dot;
    let z_b = s * sp + upp * cp;
    let z_dot = s_dot * sp + upp_dot * cp + (s * cp - upp * sp) * phi_dot;
    let c_b_e = Matrix3::from_columns(&[x_b, fwd, z_b]);
    let c_dot = Matrix3::from_columns(&[x_dot, fwd_dot, z_dot]);
    let omega_eb_b = frames::unskew(&(c_b_e.transpose() * c_dot));
    let omega_ie_e = earth::omega_ie_e();
    let omega_ib_b = omega_eb_b + c_b_e.transpose() * omega_ie_e;
    let gamma = local.gravity;
    let f_e = a_e + omega_ie_e.cross(&v_e) * 2.0 + u * gamma;
    Kinematics {
        v_e,
        dir_dot,
        c_b_e,
        omega_ib_b,
        f_b: c_b_e.transpose() * f_e,
    }
}

fn deriv(cmd: &Commands, t: f64, y: &TruthState) -> TruthState {
    deriv_at(cmd, t, y, &frames::Local::from_ecef(&y.r_e))
}

fn deriv_at(cmd: &Commands, t: f64, y: &TruthState, local: &frames::Local) -> TruthState {
    let k = kinematics_at(cmd, t, local, &y.dir_e);
    TruthState {
        r_e: k.v_e,
        dir_e: k.dir_dot,
        int_omega_b: k.omega_ib_b,
        int_f_b: k.f_b,
    }
}

fn axpy(y: &TruthState, h: f64, d: &TruthState) -> TruthState {
    TruthState {
        r_e: y.r_e + d.r_e * h,
        dir_e: y.dir_e + d.dir_e * h,
        int_omega_b: y.int_omega_b + d.int_omega_b * h,
        int_f_b: y.int_f_b + d.int_f_b * h,
    }
}

/// Generates the flight sample by sample.
#[derive(Debug, Clone)]
pub struct Flight {
    cmd: Commands,
    y: TruthState,
    /// The local geometry at `y.r_e`, which each step's first derivative
    /// and the truth use (its direction's projection computed it).
    local: frames::Local,
    t: f64,
    substeps: usize,
}

impl Flight {
    /// Starts at the scenario's start point; `substeps` RK4 steps per IMU interval.
    pub fn new(s: &Scenario, substeps: usize) -> Self {
        let geo = Geodetic::from_deg(s.start.lat_deg, s.start.lon_deg, s.start.h_m);
        let [e, n, _] = frames::enu_axes_e(geo.lat_rad, geo.lon_rad);
        let (sh, ch) = s.start.heading_deg.to_radians().sin_cos();
        let y = TruthState {
            r_e: earth::geodetic_to_ecef(&geo),
            dir_e: e * sh + n * ch,
            int_omega_b: Vector3::zeros(),
            int_f_b: Vector3::zeros(),
        };
        Self {
            cmd: Commands::new(s),
            local: frames::Local::from_ecef(&y.r_e),
            y,
            t: 0.0,
            substeps: substeps.max(1),
        }
    }

    pub fn time_s(&self) -> f64 {
        self.t
    }

    /// The truth at the current time.
    pub fn truth(&self) -> TruthSample {
        let k = kinematics_at(&self.cmd, self.t, &self.local, &self.y.dir_e);
        let q = frames::quat_from_dcm(&k.c_b_e);
        TruthSample {
            r_e: self.y.r_e,
            v_e: k.v_e,
            q_b_e: q,
            omega_ib_b: k.omega_ib_b,
        }
    }

    /// Advances to `t_end` and returns the exact increments (Δθ, Δv) over the interval.
    pub fn advance_to(&mut self, t_end: f64) -> (Vector3<f64>, Vector3<f64>) {
        self.y.int_omega_b = Vector3::zeros();
        self.y.int_f_b = Vector3::zeros();
        let h = (t_end - self.t) / self.substeps as f64;
        for i in 0..self.substeps {
            let t0 = self.t + h * i as f64;
            let y = self.y;
            let k1 = deriv_at(&self.cmd, t0, &y, &self.local);
            let k2 = deriv(&self.cmd, t0 + 0.5 * h, &axpy(&y, 0.5 * h, &k1));
            let k3 = deriv(&self.cmd, t0 + 0.5 * h, &axpy(&y, 0.5 * h, &k2));
            let k4 = deriv(&self.cmd, t0 + h, &axpy(&y, h, &k3));
            let mut next = y;
            let w = h / 6.0;
            for (k, c) in [(&k1, w), (&k2, 2.0 * w), (&k3, 2.0 * w), (&k4, w)] {
                next = axpy(&next, c, k);
            }
            // Keep the direction a horizontal unit vector at the new position.
            self.local = frames::Local::from_ecef(&next.r_e);
            let u = self.local.up;
            next.dir_e = (next.dir_e - u * next.dir_e.dot(&u)).normalize();
            self.y = next;
        }
        self.t = t_end;
        (self.y.int_omega_b, self.y.int_f_b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pulse_integral_matches_quadrature_and_reaches_the_commanded_change() {
        let (d, r, rate) = (40.0, 5.0, 0.3);
        let n = 400_000;
        let h = d / n as f64;
        let mut sum = 0.0;
        for i in 0..n {
            sum += pulse((i as f64 + 0.5) * h, d, r, rate).0 * h;
        }
        let (_, _, total) = pulse(d, d, r, rate);
        assert!((sum - total).abs() < 1e-9, "{sum} vs {total}");
        // Derivative against a central difference.
        for tau in [1.0, 4.9, 20.0, 36.0, 39.5] {
            let e = 1e-6;
            let fd = (pulse(tau + e, d, r, rate).0 - pulse(tau - e, d, r, rate).0) / (2.0 * e);
            assert!((fd - pulse(tau, d, r, rate).1).abs() < 1e-7);
        }
    }

    fn scenario(text: &str) -> Scenario {
        Scenario::parse(text, "test").expect("scenario")
    }

    /// One RK4 step per IMU interval (the simulator's default) against
    /// eight, over the North Pole with a banked turn, a climb and an
    /// acceleration, at 200 Hz and 100 Hz: the increments differ by less
    /// than a thousandth of papers/001 Table 1's noise in one sample
    /// (ARW 0.001 °/√h, VRW 10 µg/√Hz), and the positions by less than a
    /// micrometre, so the eight steps' truth is not a different flight.
    #[test]
    fn one_rk4_step_per_sample_is_the_truth_of_eight() {
        let s = scenario(
            r#"
name = "t"
[start]
lat_deg = 89.98
lon_deg = 20.0
h_m = 18000.0
heading_deg = 0.0
speed_mps = 250.0
[[segment]]
kind = "turn"
duration_s = 20.0
heading_change_deg = 60.0
ramp_s = 4.0
[[segment]]
kind = "climb"
duration_s = 20.0
altitude_change_m = 300.0
ramp_s = 5.0
[[segment]]
kind = "accelerate"
duration_s = 20.0
speed_change_mps = -40.0
ramp_s = 5.0
"#,
        );
        for rate in [200.0f64, 100.0] {
            let dt = 1.0 / rate;
            let arw = 0.001f64.to_radians() / 60.0 * dt.sqrt();
            let vrw = 10e-6 * earth::G0 * dt.sqrt();
            let (mut one, mut eight) = (Flight::new(&s, 1), Flight::new(&s, 8));
            let (mut dth, mut dv) = (0.0f64, 0.0f64);
            for k in 1..=(60.0 * rate) as usize {
                let t = k as f64 * dt;
                let (a_th, a_v) = one.advance_to(t);
                let (b_th, b_v) = eight.advance_to(t);
                dth = dth.max((a_th - b_th).norm());
                dv = dv.max((a_v - b_v).norm());
            }
            let dr = (one.truth().r_e - eight.truth().r_e).norm();
            println!(
                "{rate} Hz: |Δθ| {dth:.2e} rad ({:.1e} of the ARW's), |Δv| {dv:.2e} m/s ({:.1e} of the VRW's), |Δr| {dr:.2e} m",
                dth / arw,
                dv / vrw
            );
            assert!(dth < 1e-3 * arw, "{rate} Hz: {dth:e} rad");
            assert!(dv < 1e-3 * vrw, "{rate} Hz: {dv:e} m/s");
            assert!(dr < 1e-6, "{rate} Hz: {dr:e} m");
        }
    }

    #[test]
    fn body_rate_matches_finite_difference_of_the_attitude() {
        let s = scenario(
            r#"
name = "t"
[start]
lat_deg = 60.0
lon_deg = 10.0
h_m = 1000.0
heading_deg = 30.0
speed_mps = 200.0
[[segment]]
kind = "turn"
duration_s = 30.0
heading_change_deg = 90.0
"#,
        );
        let cmd = Commands::new(&s);
        let r = earth::geodetic_to_ecef(&Geodetic::from_deg(60.0, 10.0, 1000.0));
        let [e, n, _] = frames::enu_axes_e(60f64.to_radians(), 10f64.to_radians());
        let dir = (e + n).normalize();
        for t in [2.0, 3.7, 15.0, 28.0] {
            let k = kinematics(&cmd, t, &r, &dir);
            let h = 1e-5;
            let step = |sgn: f64| {
                let rr = r + k.v_e * (sgn * h);
                let dd = dir + k.dir_dot * (sgn * h);
                kinematics(&cmd, t + sgn * h, &rr, &dd).c_b_e
            };
            let c_dot = (step(1.0) - step(-1.0)) / (2.0 * h);
            let w_fd = frames::unskew(&(k.c_b_e.transpose() * c_dot));
            let w = k.omega_ib_b - k.c_b_e.transpose() * earth::omega_ie_e();
            assert!((w - w_fd).norm() < 1e-8, "t={t}: {w} vs {w_fd}");
        }
    }
}
