//! GNSS position and velocity, loosely coupled (papers 002 and 003): the
//! receiver's fix of its antenna, at the lever arm `l_b` (body axes) from
//! the IMU.
//!
//! The innovation is formed in ECEF, where nothing is singular, and
//! expressed in the axes of the navigation frame in use (g or G; at the
//! exact pole G's):
//!
//! z_pos = C_e^n (r^e + C_b^e l_b − r^e_GNSS),
//! z_vel = C_e^n (v^e + C_b^e (ω_eb^b × l_b) − v^e_GNSS),
//!
//! with r^e_GNSS from the fix's latitude, longitude and ellipsoidal height
//! and v^e_GNSS = C_g^e(fix) [v_E, v_N, −v_D] (the receiver's north-east-
//! down axes are those of its own fix, so a fix at the pole converts
//! whatever longitude it reports). ω_eb^b = ω_ib^b − C_n^b ω_ie^n, ω_ib^b
//! the newest IMU rate with the gyro bias estimate removed.
//!
//! With δx = computed − true, C_b^ĉ = (I − φ×) C_b^n and the frame
//! rotation θ = Θ δp of a position error ([`super::frame_rotation_per_position_error`]),
//! the body→ECEF attitude error is ψ = φ − Θ δp, and to first order
//!
//! z_pos = C_e^n T3 δp + (l_n×) ψ,
//! z_vel = δv − (v^n×) Θ δp + (u^n×) ψ − (l_n×)(ω_ie^n×) ψ + C_b^n (l_b×) ε,
//!
//! where l_n = C_b^n l_b, u^n = C_b^n (ω_eb^b × l_b) (the antenna's
//! velocity about the IMU: the frame rotation's share of it is in ψ),
//! T3 = ∂r^e/∂δp ([`super::ecef_per_position_error`]: identity in G) and ε
//! the gyro bias error (the estimate's error shows in ω_ib^b with the
//! opposite sign). H is checked against central differences of these z in
//! g and in G, at the pole too (`tests` below).
//!
//! R: position diag(σ_h², σ_h², σ_v²) in the local level axes, which g and
//! G share up to a turn about up (so R is the same in either), velocity
//! σ_s² I, each σ the receiver's estimate raised to a floor from the
//! settings. With a correlated share in the settings (`correlated_sigma_h_m`,
//! `correlated_sigma_v_m`, `correlated_tau_s`: the receiver's error that
//! wanders over minutes) the floors apply to the white share, R is the
//! whole, and the measurement declares the correlated share
//! ([`Correlated`]) for the navigator to carry as consider parameters.
//! A fix below 3D, one whose accuracy estimates exceed the
//! settings' bounds or whose PDOP exceeds the DOP gate (paper 003 §4.1) is
//! refused, each counted by its cause.

use msgs::GnssFix;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

use super::{
    Aid, AidError, Context, Correlated, Measured, Measurement, OwnSettings,
    ecef_per_position_error, frame_rotation_per_position_error,
};
use crate::bounds::{Bound, MAX_FLIGHT_S, SettingsError};
use crate::earth::{self, Geodetic};
use crate::error_model::idx;
use crate::frames::{self, skew};
use crate::integrity::IntegritySettings;
use crate::mech::AnyNav;

/// Why a fix is refused before fusion (its cause counters, in order).
pub mod cause {
    /// Non-finite or physically impossible content.
    pub const INVALID: usize = 0;
    /// Not a valid 3D fix.
    pub const NO_3D_FIX: usize = 1;
    /// An accuracy estimate beyond its bound.
    pub const ACCURACY: usize = 2;
    /// PDOP beyond the DOP gate.
    pub const DOP: usize = 3;
}

/// `[aids.gnss]`: the antenna and the receiver's quality bounds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GnssSettings {
    /// The antenna's position from the IMU, body axes (x right, y forward,
    /// z up), m.
    pub lever_arm_b_m: [f64; 3],
    /// Floors of the 1-σ taken from the receiver's estimates: horizontal
    /// and vertical position (m), velocity (m/s). A receiver's estimate
    /// below them (an optimistic one, or one that omits its correlated
    /// errors) is raised to them.
    pub sigma_floor_h_m: f64,
    pub sigma_floor_v_m: f64,
    pub sigma_floor_vel_mps: f64,
    /// A fix whose accuracy estimate exceeds these is refused (m, m, m/s).
    pub max_h_acc_m: f64,
    pub max_v_acc_m: f64,
    pub max_s_acc_mps: f64,
    /// The DOP gate: a fix with a larger PDOP is refused.
    pub max_pdop: f64,
    /// The share of the receiver's error that is correlated in time
    /// (multipath, atmosphere, orbits: it wanders over minutes), 1-σ
    /// horizontal per axis and vertical (m), as a first-order
    /// Gauss–Markov process of correlation time `correlated_tau_s`. The
    /// navigator carries it as consider parameters, so repeated fixes do
    /// not average it away and the solution's σ stays at least what it
    /// leaves; the receiver's estimates are the whole error, this share
    /// included. 0 (the default): each fix's error is white.
    pub correlated_sigma_h_m: f64,
    pub correlated_sigma_v_m: f64,
    pub correlated_tau_s: f64,
    /// Test each fix against the autonomous solution before it is fused
    /// (`crate::integrity`); off, GNSS is fused whenever its own χ² gate
    /// passes it, and a spoofer that drags slowly is followed.
    pub integrity: bool,
    /// False alarms the integrity test may raise per flight hour; each
    /// test spends the share of it that the time since the previous test
    /// is of an hour (`crate::integrity`).
    pub integrity_false_alarm_per_hour: f64,
    /// The former setting, a probability per test (`crate::integrity`):
    /// read so that a log recorded with it replays as it flew.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrity_false_alarm: Option<f64>,
    /// The test is available while its horizontal protection level from
    /// the reference's covariance is within this (m); beyond it GNSS is
    /// fused untested (flagged `GNSS_UNTESTED`); a fix whose own claimed
    /// accuracy puts the level beyond it is refused.
    pub integrity_alert_limit_m: f64,
    /// Excluded GNSS is readmitted after its fixes have agreed with the
    /// autonomous solution continuously for this long (s).
    pub readmit_after_s: f64,
}

impl Default for GnssSettings {
    fn default() -> Self {
        Self {
            lever_arm_b_m: [0.0; 3],
            sigma_floor_h_m: 0.5,
            sigma_floor_v_m: 1.0,
            sigma_floor_vel_mps: 0.05,
            max_h_acc_m: 50.0,
            max_v_acc_m: 100.0,
            max_s_acc_mps: 5.0,
            max_pdop: 10.0,
            correlated_sigma_h_m: 0.0,
            correlated_sigma_v_m: 0.0,
            correlated_tau_s: 300.0,
            integrity: IntegritySettings::default().integrity,
            integrity_false_alarm_per_hour: IntegritySettings::default()
                .integrity_false_alarm_per_hour,
            integrity_false_alarm: None,
            integrity_alert_limit_m: IntegritySettings::default().integrity_alert_limit_m,
            readmit_after_s: IntegritySettings::default().readmit_after_s,
        }
    }
}

impl OwnSettings for GnssSettings {
    fn integrity(&self) -> Option<IntegritySettings> {
        Some(IntegritySettings {
            integrity: self.integrity,
            integrity_false_alarm_per_hour: self.integrity_false_alarm_per_hour,
            integrity_false_alarm: self.integrity_false_alarm,
            integrity_alert_limit_m: self.integrity_alert_limit_m,
            readmit_after_s: self.readmit_after_s,
        })
    }

    fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError> {
        if let Some(i) = self.integrity() {
            i.validate(origin, table)?;
        }
        for (i, v) in self.lever_arm_b_m.iter().enumerate() {
            Bound {
                lo: -100.0,
                hi: 100.0,
                unit: "m",
                below: "no antenna of this airframe is 100 m from its IMU",
                above: "no antenna of this airframe is 100 m from its IMU",
            }
            .check(origin, &format!("{table}.lever_arm_b_m[{i}]"), *v)?;
        }
        let floor = |key: &str, v: f64, unit: &str| {
            Bound {
                lo: 1e-3,
                hi: 1e3,
                unit,
                below: "no receiver's error is below a millimetre (or a mm/s): R would make \
                        the update numerically singular",
                above: "a floor above a kilometre (or km/s) makes GNSS worthless",
            }
            .check(origin, &format!("{table}.{key}"), v)
        };
        floor("sigma_floor_h_m", self.sigma_floor_h_m, "m")?;
        floor("sigma_floor_v_m", self.sigma_floor_v_m, "m")?;
        floor("sigma_floor_vel_mps", self.sigma_floor_vel_mps, "m/s")?;
        for (key, v, floor_v, unit) in [
            ("max_h_acc_m", self.max_h_acc_m, self.sigma_floor_h_m, "m"),
            ("max_v_acc_m", self.max_v_acc_m, self.sigma_floor_v_m, "m"),
            (
                "max_s_acc_mps",
                self.max_s_acc_mps,
                self.sigma_floor_vel_mps,
                "m/s",
            ),
        ] {
            Bound {
                lo: floor_v,
                hi: 1e5,
                unit,
                below: "below its floor every fix would be refused",
                above: "beyond 100 km (or km/s) the bound refuses nothing",
            }
            .check(origin, &format!("{table}.{key}"), v)?;
        }
        Bound {
            lo: 1.0,
            hi: 100.0,
            unit: "",
            below: "a PDOP is at least 1: every fix would be refused",
            above: "a PDOP beyond 100 is no geometry: the gate would refuse nothing",
        }
        .check(origin, &format!("{table}.max_pdop"), self.max_pdop)?;
        for (key, v) in [
            ("correlated_sigma_h_m", self.correlated_sigma_h_m),
            ("correlated_sigma_v_m", self.correlated_sigma_v_m),
        ] {
            Bound {
                lo: 0.0,
                hi: 1e3,
                unit: "m",
                below: "a σ is not negative (0: the receiver's error is white)",
                above: "a correlated error beyond a kilometre makes GNSS worthless",
            }
            .check(origin, &format!("{table}.{key}"), v)?;
        }
        Bound {
            lo: 1.0,
            hi: MAX_FLIGHT_S,
            unit: "s",
            below: "an error correlated for less than a second is white at any receiver's rate",
            above: "a correlation time beyond any flight is a constant error: give a long one",
        }
        .check(
            origin,
            &format!("{table}.correlated_tau_s"),
            self.correlated_tau_s,
        )
    }
}

/// The measured antenna position and Earth-relative velocity (ECEF), after
/// the content checks.
fn measured(s: &GnssFix, g: &GnssSettings) -> Result<(Vector3<f64>, Vector3<f64>), AidError> {
    let all = [
        s.lat_rad,
        s.lon_rad,
        s.height_m,
        s.vel_ned_mps[0],
        s.vel_ned_mps[1],
        s.vel_ned_mps[2],
        s.h_acc_m,
        s.v_acc_m,
        s.s_acc_mps,
        s.pdop,
    ];
    if all.iter().any(|x| !x.is_finite()) {
        return Err(AidError::NonFinite("gnss"));
    }
    let invalid = |what: &'static str, value: f64| AidError::Refused {
        cause: cause::INVALID,
        what,
        value,
    };
    if s.lat_rad.abs() > std::f64::consts::FRAC_PI_2 {
        return Err(invalid("gnss.lat_rad", s.lat_rad));
    }
    if !(-1e4..=1e5).contains(&s.height_m) {
        return Err(invalid("gnss.height_m", s.height_m));
    }
    let speed = Vector3::from(s.vel_ned_mps).norm();
    if speed > 1e4 {
        return Err(invalid("gnss speed (m/s)", speed));
    }
    if !s.is_3d() {
        return Err(AidError::Refused {
            cause: cause::NO_3D_FIX,
            what: "gnss.fix_type (a valid 3D fix needed)",
            value: f64::from(s.fix_type),
        });
    }
    for (what, v, max) in [
        ("gnss.h_acc_m", s.h_acc_m, g.max_h_acc_m),
        ("gnss.v_acc_m", s.v_acc_m, g.max_v_acc_m),
        ("gnss.s_acc_mps", s.s_acc_mps, g.max_s_acc_mps),
    ] {
        if what == "gnss.s_acc_mps" && !s.has_velocity() {
            continue;
        }
        if !(0.0..=max).contains(&v) {
            return Err(AidError::Refused {
                cause: cause::ACCURACY,
                what,
                value: v,
            });
        }
    }
    if !(s.pdop >= 0.0 && s.pdop <= g.max_pdop) {
        return Err(AidError::Refused {
            cause: cause::DOP,
            what: "gnss.pdop",
            value: s.pdop,
        });
    }
    let r = earth::geodetic_to_ecef(&Geodetic::new(s.lat_rad, s.lon_rad, s.height_m));
    let [n, e, d] = s.vel_ned_mps;
    let v = frames::c_e_g(s.lat_rad, s.lon_rad).transpose() * Vector3::new(e, n, -d);
    Ok((r, v))
}

/// The GNSS measurement of the nominal state `nav` (see the module
/// documentation); `omega_ib_b` is the body rate with the gyro bias
/// estimate removed.
pub fn measurement(
    nav: &AnyNav,
    s: &GnssFix,
    omega_ib_b: &Vector3<f64>,
    g: &GnssSettings,
) -> Result<Measurement<6>, AidError> {
    let (r_gnss, v_gnss) = measured(s, g)?;
    let ff = nav.frame_free();
    let c_e_n = nav.c_e_n();
    let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
    let c_b_n = c_e_n * c_b_e;
    let l_b = Vector3::from(g.lever_arm_b_m);
    let omega_ie_n = c_e_n * earth::omega_ie_e();
    let omega_eb_b = omega_ib_b - c_b_n.transpose() * omega_ie_n;
    let u_b = omega_eb_b.cross(&l_b);
    let (l_n, u_n) = (c_b_n * l_b, c_b_n * u_b);
    let r_ant = ff.r_e + c_b_e * l_b;
    let v_ant = ff.v_e + c_b_e * u_b;
    let v_n = c_e_n * ff.v_e;

    let theta = frame_rotation_per_position_error(nav);
    let t3 = ecef_per_position_error(nav);
    let (lx, ux, wx) = (skew(&l_n), skew(&u_n), skew(&omega_ie_n));
    let mut h = SMatrix::<f64, 6, 15>::zeros();
    // Position rows.
    h.fixed_view_mut::<3, 3>(0, idx::PHI).copy_from(&lx);
    h.fixed_view_mut::<3, 3>(0, idx::DP)
        .copy_from(&(c_e_n * t3 - lx * theta));
    // Velocity rows.
    let psi = ux - lx * wx;
    h.fixed_view_mut::<3, 3>(3, idx::PHI).copy_from(&psi);
    h.fixed_view_mut::<3, 3>(3, idx::DV)
        .copy_from(&Matrix3::identity());
    h.fixed_view_mut::<3, 3>(3, idx::DP)
        .copy_from(&(-skew(&v_n) * theta - psi * theta));
    h.fixed_view_mut::<3, 3>(3, idx::BG)
        .copy_from(&(c_b_n * skew(&l_b)));

    let mut z = SVector::<f64, 6>::zeros();
    z.fixed_rows_mut::<3>(0)
        .copy_from(&(c_e_n * (r_ant - r_gnss)));
    z.fixed_rows_mut::<3>(3)
        .copy_from(&(c_e_n * (v_ant - v_gnss)));

    let ss = s.s_acc_mps.max(g.sigma_floor_vel_mps);
    let (var_h, var_v) = position_var(s, g);
    let mut r = SMatrix::<f64, 6, 6>::zeros();
    for (k, var) in [var_h, var_h, var_v, ss * ss, ss * ss, ss * ss]
        .into_iter()
        .enumerate()
    {
        r[(k, k)] = var;
    }
    Ok(Measurement { z, h, r })
}

/// The position's variances of R, horizontal per axis and vertical: the
/// receiver's estimates, their white share (what is left of them beyond
/// the correlated share of the settings) raised to the floors. Without a
/// correlated share this is the estimate raised to its floor, to the bit
/// (squaring is monotone and adding 0 is exact).
fn position_var(s: &GnssFix, g: &GnssSettings) -> (f64, f64) {
    let var = |acc: f64, floor: f64, correlated: f64| {
        let c2 = correlated * correlated;
        (acc * acc - c2).max(floor * floor) + c2
    };
    (
        var(s.h_acc_m, g.sigma_floor_h_m, g.correlated_sigma_h_m),
        var(s.v_acc_m, g.sigma_floor_v_m, g.correlated_sigma_v_m),
    )
}

/// The receiver's correlated error as the settings give it (`None`: white).
fn correlated(g: &GnssSettings) -> Option<Correlated> {
    let (h, v) = (g.correlated_sigma_h_m, g.correlated_sigma_v_m);
    (h > 0.0 || v > 0.0).then(|| Correlated {
        var: Vector3::new(h * h, h * h, v * v),
        tau_s: g.correlated_tau_s,
    })
}

impl Aid for GnssFix {
    type Settings = GnssSettings;
    /// Position and velocity.
    const OBSERVED: &'static [usize] = &[idx::DP, idx::DV];
    fn measure(&self, nav: &AnyNav, ctx: &Context, g: &GnssSettings) -> Result<Measured, AidError> {
        let m = measurement(nav, self, &ctx.omega_ib_b, g)?;
        let measured = if self.has_velocity() {
            Measured::from(m)
        } else {
            Measured::from(position_only(&m))
        };
        Ok(Measured {
            shares: super::ConsiderShares {
                persistent_var: 0.0,
                correlated: correlated(g),
            },
            ..measured
        })
    }
}

/// The position rows of a fix that reports no velocity
/// ([`msgs::gnss::fix_flags::NO_VELOCITY`]): its velocity rows are no
/// measurement, so they are dropped rather than given a large R.
fn position_only(m: &Measurement<6>) -> Measurement<3> {
    Measurement {
        z: m.z.fixed_rows::<3>(0).into_owned(),
        h: m.h.fixed_rows::<3>(0).into_owned(),
        r: m.r.fixed_view::<3, 3>(0, 0).into_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::AnyMeasurement;
    use crate::aids::tests::{computed, truth};
    use crate::mech::FrameKind;
    use msgs::gnss::{fix_flags, fix_type};

    /// The fix of the antenna of the true state `t` at lever arm `l_b`,
    /// rotating at `omega_ib_b` (error-free).
    fn fix_of(t: &AnyNav, l_b: &Vector3<f64>, omega_ib_b: &Vector3<f64>) -> GnssFix {
        let ff = t.frame_free();
        let c_b_e = ff.q_b_e.to_rotation_matrix().into_inner();
        let omega_eb_b = omega_ib_b - c_b_e.transpose() * earth::omega_ie_e();
        let r = ff.r_e + c_b_e * l_b;
        let v = ff.v_e + c_b_e * omega_eb_b.cross(l_b);
        let g = earth::ecef_to_geodetic(&r);
        let enu = frames::c_e_g(g.lat_rad, g.lon_rad) * v;
        GnssFix {
            t_ns: 1,
            lat_rad: g.lat_rad,
            lon_rad: g.lon_rad,
            height_m: g.h_m,
            vel_ned_mps: [enu.y, enu.x, -enu.z],
            h_acc_m: 2.0,
            v_acc_m: 3.0,
            s_acc_mps: 0.1,
            pdop: 1.5,
            fix_type: fix_type::FIX_3D,
            flags: fix_flags::FIX_OK,
            num_sv: 12,
            ..Default::default()
        }
    }

    fn settings() -> GnssSettings {
        GnssSettings {
            lever_arm_b_m: [0.7, 2.5, 1.2],
            ..Default::default()
        }
    }

    /// H against central differences of z over every error state,
    /// the gyro bias (through ω_ib^b) included, in g and in G, at the pole.
    #[test]
    fn gnss_jacobian_matches_finite_differences_in_both_frames_and_at_the_pole() {
        let g = settings();
        let l_b = Vector3::from(g.lever_arm_b_m);
        let omega = Vector3::new(0.05, -0.03, 0.2);
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Geographic, 69.0, -170.0),
            (FrameKind::Grid, 88.0, -60.0),
            (FrameKind::Grid, 90.0, 0.0),
            (FrameKind::Grid, -90.0, 0.0),
            (FrameKind::Grid, 89.999_999, 137.0),
            (FrameKind::Grid, 31.94, 118.79),
        ] {
            let t = truth(kind, lat, lon);
            let fix = fix_of(&t, &l_b, &omega);
            let m = measurement(&t, &fix, &omega, &g).expect("fix");
            // At the truth the innovation vanishes.
            assert!(
                m.z.fixed_rows::<3>(0).amax() < 1e-6 && m.z.fixed_rows::<3>(3).amax() < 1e-9,
                "{kind:?} {lat}: z {}",
                m.z.transpose()
            );
            let pos_steps = match kind {
                FrameKind::Geographic => [1e-8, 1e-8, 1.0],
                FrameKind::Grid => [1.0, 1.0, 1.0],
            };
            for j in 0..15 {
                // Attitude steps of 1 mrad: the position rows difference
                // ECEF coordinates of 6.4e6 m, whose rounding (8 ulp) over a
                // step of 1 µrad would be 6e-3 of a 2.5 m lever arm's
                // column; the third-order term of a 1 mrad step is 2e-7 of it.
                let step = match j {
                    0..=2 => 1e-3,
                    3..=5 => 1e-3,
                    6..=8 => pos_steps[j - 6],
                    9..=11 => 1e-6,
                    _ => 1e-3,
                };
                let z_at = |sign: f64| {
                    let mut x = SVector::<f64, 15>::zeros();
                    x[j] = sign * step;
                    // The gyro bias estimate's error shows in ω_ib^b.
                    let w = omega - Vector3::new(x[idx::BG], x[idx::BG + 1], x[idx::BG + 2]);
                    measurement(&computed(&t, &x), &fix, &w, &g).expect("fix").z
                };
                let col = (z_at(1.0) - z_at(-1.0)) / (2.0 * step);
                for block in [0, 3] {
                    // Relative to the column's largest sensitivity in this
                    // block of rows, plus the rounding of the differenced
                    // ECEF coordinates (position rows).
                    let scale = m.h.fixed_view::<3, 1>(block, j).amax().max(1.0);
                    let rounding = if block == 0 {
                        8.0 * 6.4e6 * f64::EPSILON / step
                    } else {
                        0.0
                    };
                    for row in block..block + 3 {
                        assert!(
                            (col[row] - m.h[(row, j)]).abs() <= 1e-6 * scale + rounding,
                            "{kind:?} {lat}°: H[{row}, {j}] = {} vs FD {}",
                            m.h[(row, j)],
                            col[row]
                        );
                    }
                }
            }
        }
    }

    /// The noise model: the receiver's σ, each raised to its floor.
    /// With a correlated share the receiver's estimate is the whole error:
    /// R stays the estimate where the white share it leaves is above its
    /// floor, the white share is raised to the floor where not, and the
    /// measurement declares the share (variances per axis, τ); without one
    /// it declares none and R is the estimate raised to the floor.
    #[test]
    fn a_correlated_share_splits_r_and_is_declared() {
        let mut g = settings();
        g.correlated_sigma_h_m = 1.5;
        g.correlated_sigma_v_m = 3.0;
        g.correlated_tau_s = 120.0;
        let t = truth(FrameKind::Geographic, 45.0, 20.0);
        let mut fix = fix_of(&t, &Vector3::from(g.lever_arm_b_m), &Vector3::zeros());
        fix.h_acc_m = 2.5;
        fix.v_acc_m = 5.0;
        let ctx = Context {
            omega_ib_b: Vector3::zeros(),
        };
        let out = fix.measure(&t, &ctx, &g).expect("fix");
        let AnyMeasurement::D6(m) = out.m else {
            panic!("position and velocity")
        };
        // 2.5² = 1.5² + 2²: a white 2 m, above the 0.5 m floor.
        assert!((m.r[(0, 0)] - 6.25).abs() < 1e-12 && (m.r[(1, 1)] - 6.25).abs() < 1e-12);
        assert!((m.r[(2, 2)] - 25.0).abs() < 1e-12);
        let c = out.shares.correlated.expect("declared");
        assert_eq!(c.var, Vector3::new(2.25, 2.25, 9.0));
        assert_eq!(c.tau_s.to_bits(), 120.0f64.to_bits());
        // An estimate below the correlated share: the white share at its
        // floor (0.5 m, 1 m), R = floor² + share².
        fix.h_acc_m = 1.0;
        fix.v_acc_m = 1.0;
        let AnyMeasurement::D6(m) = fix.measure(&t, &ctx, &g).expect("fix").m else {
            panic!("position and velocity")
        };
        assert!((m.r[(0, 0)] - (0.25 + 2.25)).abs() < 1e-12);
        assert!((m.r[(2, 2)] - (1.0 + 9.0)).abs() < 1e-12);
        // Without a share: nothing declared.
        let out = fix.measure(&t, &ctx, &settings()).expect("fix");
        assert_eq!(out.shares.correlated, None);
    }

    #[test]
    fn r_is_the_receivers_accuracy_raised_to_the_floors() {
        let g = settings();
        let t = truth(FrameKind::Grid, 89.0, 20.0);
        let mut fix = fix_of(&t, &Vector3::from(g.lever_arm_b_m), &Vector3::zeros());
        let m = measurement(&t, &fix, &Vector3::zeros(), &g).expect("fix");
        let d: Vec<f64> = (0..6).map(|k| m.r[(k, k)].sqrt()).collect();
        assert_eq!(d, [2.0, 2.0, 3.0, 0.1, 0.1, 0.1]);
        fix.h_acc_m = 0.01;
        fix.v_acc_m = 0.0;
        fix.s_acc_mps = 0.001;
        let m = measurement(&t, &fix, &Vector3::zeros(), &g).expect("fix");
        let d: Vec<f64> = (0..6).map(|k| m.r[(k, k)].sqrt()).collect();
        assert_eq!(d, [0.5, 0.5, 1.0, 0.05, 0.05, 0.05]);
    }

    /// Each refusal names its cause: a fix below 3D or not valid, an
    /// accuracy beyond its bound, a PDOP beyond the gate, and non-finite
    /// or impossible content.
    #[test]
    fn fixes_are_refused_by_cause() {
        let g = settings();
        let t = truth(FrameKind::Geographic, 60.0, 5.0);
        let good = fix_of(&t, &Vector3::from(g.lever_arm_b_m), &Vector3::zeros());
        let cause_of = |f: GnssFix| match measurement(&t, &f, &Vector3::zeros(), &g) {
            Err(AidError::Refused { cause, .. }) => Some(cause),
            Err(AidError::NonFinite(_)) => Some(cause::INVALID),
            Err(e) => panic!("{e}"),
            Ok(_) => None,
        };
        assert_eq!(cause_of(good), None);
        for (bad, want) in [
            (
                GnssFix {
                    fix_type: fix_type::FIX_2D,
                    ..good
                },
                cause::NO_3D_FIX,
            ),
            (
                GnssFix {
                    fix_type: fix_type::NONE,
                    ..good
                },
                cause::NO_3D_FIX,
            ),
            (GnssFix { flags: 0, ..good }, cause::NO_3D_FIX),
            (
                GnssFix {
                    h_acc_m: 50.1,
                    ..good
                },
                cause::ACCURACY,
            ),
            (
                GnssFix {
                    v_acc_m: 1e300,
                    ..good
                },
                cause::ACCURACY,
            ),
            (
                GnssFix {
                    s_acc_mps: -1.0,
                    ..good
                },
                cause::ACCURACY,
            ),
            (GnssFix { pdop: 10.5, ..good }, cause::DOP),
            (
                GnssFix {
                    lat_rad: f64::NAN,
                    ..good
                },
                cause::INVALID,
            ),
            (
                GnssFix {
                    h_acc_m: f64::INFINITY,
                    ..good
                },
                cause::INVALID,
            ),
            (
                GnssFix {
                    lat_rad: 2.0,
                    ..good
                },
                cause::INVALID,
            ),
            (
                GnssFix {
                    height_m: 1e7,
                    ..good
                },
                cause::INVALID,
            ),
        ] {
            assert_eq!(cause_of(bad), Some(want), "{bad:?}");
        }
    }

    /// A fix without velocity is its position rows alone, whatever its
    /// velocity fields hold, and its speed accuracy is not checked.
    #[test]
    fn a_fix_without_velocity_fuses_its_position_only() {
        let g = settings();
        let t = truth(FrameKind::Geographic, 30.0, 114.0);
        let good = fix_of(&t, &Vector3::from(g.lever_arm_b_m), &Vector3::zeros());
        let ctx = Context {
            omega_ib_b: Vector3::zeros(),
        };
        let full = measurement(&t, &good, &Vector3::zeros(), &g).expect("fix");
        let no_vel = GnssFix {
            flags: fix_flags::FIX_OK | fix_flags::NO_VELOCITY,
            vel_ned_mps: [0.0; 3],
            s_acc_mps: 1e9,
            ..good
        };
        match good.measure(&t, &ctx, &g).expect("fix").m {
            AnyMeasurement::D6(m) => assert_eq!(m, full),
            other => panic!("{other:?}"),
        }
        match no_vel.measure(&t, &ctx, &g).expect("fix").m {
            AnyMeasurement::D3(m) => {
                assert_eq!(m.z, full.z.fixed_rows::<3>(0));
                assert_eq!(m.h, full.h.fixed_rows::<3>(0));
                assert_eq!(m.r, full.r.fixed_view::<3, 3>(0, 0));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn settings_outside_their_bounds_are_refused_naming_the_key() {
        assert!(GnssSettings::default().validate("t", "aids.gnss").is_ok());
        for (bad, key) in [
            (
                GnssSettings {
                    lever_arm_b_m: [0.0, f64::NAN, 0.0],
                    ..Default::default()
                },
                "aids.gnss.lever_arm_b_m[1]",
            ),
            (
                GnssSettings {
                    sigma_floor_h_m: 0.0,
                    ..Default::default()
                },
                "aids.gnss.sigma_floor_h_m",
            ),
            (
                GnssSettings {
                    max_h_acc_m: 0.1,
                    ..Default::default()
                },
                "aids.gnss.max_h_acc_m",
            ),
            (
                GnssSettings {
                    max_pdop: 0.5,
                    ..Default::default()
                },
                "aids.gnss.max_pdop",
            ),
            (
                GnssSettings {
                    max_s_acc_mps: 1e300,
                    ..Default::default()
                },
                "aids.gnss.max_s_acc_mps",
            ),
            (
                GnssSettings {
                    correlated_sigma_h_m: -1e-300,
                    ..Default::default()
                },
                "aids.gnss.correlated_sigma_h_m",
            ),
            (
                GnssSettings {
                    correlated_sigma_v_m: f64::INFINITY,
                    ..Default::default()
                },
                "aids.gnss.correlated_sigma_v_m",
            ),
            (
                GnssSettings {
                    correlated_tau_s: 1e-10,
                    ..Default::default()
                },
                "aids.gnss.correlated_tau_s",
            ),
            (
                GnssSettings {
                    correlated_tau_s: 1e18,
                    ..Default::default()
                },
                "aids.gnss.correlated_tau_s",
            ),
        ] {
            let e = bad.validate("t", "aids.gnss").expect_err(key);
            assert_eq!(e.key, key);
        }
    }
}
