//! The dual-antenna GNSS baseline (paper 003; issue 30): a moving-base
//! receiver measures the vector from its primary (moving-base) antenna at
//! `a1_b` to its secondary antenna at `a2_b` (body axes, from the
//! settings) by carrier phase, to millimetres when its ambiguities are
//! fixed. The aid fuses that vector, not the heading the receiver derives
//! from it: heading relative to north is undefined at the pole, the
//! baseline in Earth axes is not.
//!
//! The receiver reports the baseline north-east-down in the axes of its
//! own fix (lat, lon), which the sample carries. It is turned back into
//! ECEF exactly as the receiver turned it into NED (whatever longitude a
//! receiver at the exact pole chose, the vector in ECEF is the one it
//! measured), and the innovation is the difference in ECEF expressed in
//! the axes of the navigation frame in use (g or G; at the exact pole G's):
//!
//! z = C_e^n (C_b^e d_b − b^e_meas),  d_b = a2_b − a1_b,
//! b^e_meas = C_g^e(lat, lon) [b_E, b_N, −b_D].
//!
//! With δx = computed − true, C_b^ĉ = (I − φ×) C_b^n and the frame rotation
//! θ = Θ δp of a position error ([`super::frame_rotation_per_position_error`]),
//! the body→ECEF attitude error in nav axes is ψ = φ − Θ δp (as for the
//! star tracker, [`super::star`]), and C_b^ê d_b = C_n^e (I − ψ×) b_n, so to
//! first order
//!
//! z = (b_n×) ψ = (b_n×) φ − (b_n×) Θ δp,  b_n = C_b^n d_b,
//!
//! H = [(b_n×), 0, −(b_n×) Θ, 0, 0]. A rotation about the baseline itself
//! is unobservable (b_nᵀ (b_n×) = 0): one baseline gives heading and the
//! baseline's elevation (pitch for a fore-aft pair, roll for a lateral
//! one). H is checked against central differences of z in g, in G and at
//! the exact poles (`tests` below).
//!
//! R: the receiver's accuracies of N, E, D, each raised to a floor from
//! the settings (a receiver's carrier-phase σ omits the antennas' phase
//! centre variation and the mounting survey), as a diagonal covariance in
//! the receiver's local axes turned into nav axes.
//!
//! Refused before fusion, each counted by its cause: invalid content
//! (non-finite values, a latitude beyond ±90°, a length outside
//! (0, [`MAX_LENGTH_M`]], accuracies outside [`ACC_RANGE_M`], a vector whose
//! norm disagrees with the reported length), no fixed carrier solution
//! (float or none, `relPosValid` or `gnssFixOK` clear: a float baseline is
//! decimetres, no attitude reference), and a measured length that
//! disagrees with the configured antennas' by more than
//! `length_gate_sigma` of its accuracy (a wrong fix of the ambiguities, a
//! moved antenna, or a spoofer's degenerate baseline: see the declaration
//! in `msgs::aids` on why the aid is autonomous). Non-finite values and
//! an impossible latitude are checked first, then the carrier solution
//! (a receiver without one reports zeros: an outage is counted as such,
//! not as corrupt content), then the ranges, then the length.

use msgs::BaselineSample;
use msgs::baseline::baseline_flags;
use nalgebra::{Matrix3, SMatrix, Vector3};
use serde::{Deserialize, Serialize};

use super::{
    Aid, AidError, Context, HeadingFix, Levelled, Measured, Measurement, OwnSettings,
    frame_rotation_per_position_error,
};
use crate::bounds::{Bound, SettingsError};
use crate::error_model::idx;
use crate::frames::{self, skew};
use crate::mech::AnyNav;

/// Why a baseline is refused before fusion (its cause counters, in order).
pub mod cause {
    /// Non-finite or physically impossible content.
    pub const INVALID: usize = 0;
    /// No valid fixed carrier-phase solution.
    pub const NOT_FIXED: usize = 1;
    /// The measured length disagrees with the configured antennas'.
    pub const LENGTH: usize = 2;
}

/// The longest baseline a sample may report (m): no airframe carries its
/// antennas a kilometre apart; a larger value is corruption.
pub const MAX_LENGTH_M: f64 = 1e3;

/// The range of a reported accuracy (m): below 10 µm no carrier-phase
/// receiver measures (and R would make the update numerically singular);
/// beyond a kilometre the sample is no baseline.
pub const ACC_RANGE_M: (f64, f64) = (1e-5, 1e3);

/// Largest difference between the reported vector's norm and the reported
/// length (m): both come from the same solution at 0.1 mm resolution, so
/// a larger one is a corrupted sample (plus 1e-4 of the length for the
/// receiver's own rounding of long baselines).
pub const NORM_TOL_M: f64 = 0.01;

/// Largest departure of a normalized vector's norm from 1.
pub const UNIT_NORM_TOL: f64 = 1e-3;

/// A baseline whose horizontal part is shorter than this fraction of its
/// length (within 5.7° of vertical) gives no heading for an alignment.
pub const MIN_HORIZONTAL_FRACTION: f64 = 0.1;

/// `[aids.baseline]`: the two antennas and the noise floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BaselineSettings {
    /// The primary (moving-base) antenna's position from the IMU, body
    /// axes (x right, y forward, z up), m.
    pub primary_antenna_b_m: [f64; 3],
    /// The secondary (rover) antenna's position, the baseline's head, m.
    pub secondary_antenna_b_m: [f64; 3],
    /// Floor of the 1-σ taken from the receiver's accuracy of each
    /// component (m): the antennas' phase centre variation and the
    /// survey of their positions, which the receiver does not know.
    pub sigma_floor_m: f64,
    /// A baseline whose length differs from the configured antennas' by
    /// more than this many σ of its length is refused.
    pub length_gate_sigma: f64,
}

impl Default for BaselineSettings {
    /// A fore-aft pair 1 m apart on the body's y axis: heading and pitch.
    fn default() -> Self {
        Self {
            primary_antenna_b_m: [0.0, -0.5, 0.0],
            secondary_antenna_b_m: [0.0, 0.5, 0.0],
            sigma_floor_m: 0.005,
            length_gate_sigma: 5.0,
        }
    }
}

impl BaselineSettings {
    /// The configured baseline d_b = a2_b − a1_b (body axes, m).
    pub fn baseline_b(&self) -> Vector3<f64> {
        Vector3::from(self.secondary_antenna_b_m) - Vector3::from(self.primary_antenna_b_m)
    }
}

impl OwnSettings for BaselineSettings {
    fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError> {
        let arm = Bound {
            lo: -100.0,
            hi: 100.0,
            unit: "m",
            below: "no antenna of this airframe is 100 m from its IMU",
            above: "no antenna of this airframe is 100 m from its IMU",
        };
        for (key, a) in [
            ("primary_antenna_b_m", self.primary_antenna_b_m),
            ("secondary_antenna_b_m", self.secondary_antenna_b_m),
        ] {
            for (i, v) in a.iter().enumerate() {
                arm.check(origin, &format!("{table}.{key}[{i}]"), *v)?;
            }
        }
        Bound {
            lo: 0.1,
            hi: 400.0,
            unit: "m (the antennas' separation)",
            below: "antennas closer than 10 cm give a heading worse than a few \
                    degrees, and the length check could not tell their baseline \
                    from a spoofer's degenerate one",
            above: "two antennas 100 m from the IMU are at most 346 m apart",
        }
        .check(
            origin,
            &format!("{table}.secondary_antenna_b_m"),
            self.baseline_b().norm(),
        )?;
        Bound {
            lo: 1e-4,
            hi: 1.0,
            unit: "m",
            below: "no carrier-phase baseline is better than 0.1 mm: R would make \
                    the update numerically singular",
            above: "a floor above a metre leaves a fixed baseline (millimetres) \
                    no information on attitude",
        }
        .check(
            origin,
            &format!("{table}.sigma_floor_m"),
            self.sigma_floor_m,
        )?;
        Bound {
            lo: 1.0,
            hi: 100.0,
            unit: "σ",
            below: "below 1 σ a third of good baselines would be refused",
            above: "beyond 100 σ the check refuses nothing",
        }
        .check(
            origin,
            &format!("{table}.length_gate_sigma"),
            self.length_gate_sigma,
        )
    }
}

/// A baseline that passed every check: the vector in ECEF, the
/// receiver's local ENU → ECEF rotation and the floored σ of its east,
/// north, up components.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Checked {
    b_e: Vector3<f64>,
    c_rx_e: Matrix3<f64>,
    sigma_enu: Vector3<f64>,
}

fn invalid(what: &'static str, value: f64) -> AidError {
    AidError::Refused {
        cause: cause::INVALID,
        what,
        value,
    }
}

/// Checks a sample's content, its carrier solution and its length against
/// the settings' antennas, in the order of the causes.
fn checked(s: &BaselineSample, g: &BaselineSettings) -> Result<Checked, AidError> {
    let all = [
        s.lat_rad,
        s.lon_rad,
        s.rel_pos_ned_m[0],
        s.rel_pos_ned_m[1],
        s.rel_pos_ned_m[2],
        s.length_m,
        s.heading_rad,
        s.acc_heading_rad,
        s.acc_ned_m[0],
        s.acc_ned_m[1],
        s.acc_ned_m[2],
    ];
    if all.iter().any(|x| !x.is_finite()) {
        return Err(AidError::NonFinite("baseline"));
    }
    if s.lat_rad.abs() > std::f64::consts::FRAC_PI_2 {
        return Err(invalid("baseline.lat_rad", s.lat_rad));
    }
    // Before the ranges: a receiver without a solution reports zeros
    // (relPosValid clear), an outage rather than corrupt content.
    if !s.is_fixed() {
        return Err(AidError::Refused {
            cause: cause::NOT_FIXED,
            what: "baseline.carr_soln (a valid fixed solution needed)",
            value: f64::from(s.carr_soln),
        });
    }
    if !(s.length_m > 0.0 && s.length_m <= MAX_LENGTH_M) {
        return Err(invalid("baseline.length_m", s.length_m));
    }
    for a in s.acc_ned_m {
        if !(ACC_RANGE_M.0..=ACC_RANGE_M.1).contains(&a) {
            return Err(invalid("baseline.acc_ned_m", a));
        }
    }
    let v = Vector3::from(s.rel_pos_ned_m);
    let b_ned = if s.flags & baseline_flags::NORMALIZED != 0 {
        if (v.norm() - 1.0).abs() > UNIT_NORM_TOL {
            return Err(invalid("baseline |rel_pos_ned_m| (normalized)", v.norm()));
        }
        v * s.length_m
    } else {
        if (v.norm() - s.length_m).abs() > NORM_TOL_M + 1e-4 * s.length_m {
            return Err(invalid(
                "baseline |rel_pos_ned_m| − length_m (m)",
                v.norm() - s.length_m,
            ));
        }
        v
    };
    let floor = g.sigma_floor_m;
    let sigma_ned = Vector3::from(s.acc_ned_m).map(|a| a.max(floor));
    // σ of the length: the accuracies projected on the baseline's direction.
    let n = b_ned.norm();
    let u = if n > 0.0 { b_ned / n } else { Vector3::zeros() };
    let sigma_len = u.component_mul(&sigma_ned).norm().max(floor);
    let d_len = s.length_m - g.baseline_b().norm();
    if d_len.abs() > g.length_gate_sigma * sigma_len {
        return Err(AidError::Refused {
            cause: cause::LENGTH,
            what: "baseline.length_m − configured length (m)",
            value: d_len,
        });
    }
    let c_rx_e = frames::c_e_g(s.lat_rad, s.lon_rad).transpose();
    let b_enu = Vector3::new(b_ned.y, b_ned.x, -b_ned.z);
    Ok(Checked {
        b_e: c_rx_e * b_enu,
        c_rx_e,
        sigma_enu: Vector3::new(sigma_ned.y, sigma_ned.x, sigma_ned.z),
    })
}

/// The baseline measurement of the nominal state `nav` (see the module
/// documentation).
pub fn measurement(
    nav: &AnyNav,
    s: &BaselineSample,
    g: &BaselineSettings,
) -> Result<Measurement<3>, AidError> {
    let m = checked(s, g)?;
    let c_e_n = nav.c_e_n();
    let c_b_e = nav.frame_free().q_b_e.to_rotation_matrix().into_inner();
    let b_e = c_b_e * g.baseline_b();
    let bx = skew(&(c_e_n * b_e));
    let z = c_e_n * (b_e - m.b_e);
    let mut h = SMatrix::<f64, 3, 15>::zeros();
    h.fixed_view_mut::<3, 3>(0, idx::PHI).copy_from(&bx);
    h.fixed_view_mut::<3, 3>(0, idx::DP)
        .copy_from(&(-bx * frame_rotation_per_position_error(nav)));
    let c_rx_n = c_e_n * m.c_rx_e;
    let r = c_rx_n
        * Matrix3::from_diagonal(&m.sigma_enu.component_mul(&m.sigma_enu))
        * c_rx_n.transpose();
    let r = (r + r.transpose()) * 0.5;
    if !(super::finite3(&z) && r.iter().all(|x| x.is_finite()) && h.iter().all(|x| x.is_finite())) {
        return Err(AidError::NonFinite("baseline measurement"));
    }
    Ok(Measurement { z, h, r })
}

/// The body's heading from a baseline and the levelled attitude (see
/// [`Aid::align_heading`]): the measured baseline in the local ENU axes of
/// the alignment's position is the configured one turned by the levelled
/// attitude and then by −ψ about up, C_b^l = R_z(−ψ) C_b^l0, so ψ is the
/// azimuth of the measured baseline's horizontal part less that of
/// C_b^l0 d_b (a turn about up keeps the vertical part and turns the
/// horizontal one by ψ, exactly). Its σ: the measurement's across the
/// horizontal baseline over its length, and the tilt's σ through the
/// azimuth's sensitivity to a levelling error about east and north.
pub fn heading(
    s: &BaselineSample,
    level: &Levelled,
    g: &BaselineSettings,
) -> Result<HeadingFix, AidError> {
    let m = checked(s, g)?;
    let c_e_l = frames::c_e_g(level.geo.lat_rad, level.geo.lon_rad);
    let b_l = c_e_l * m.b_e;
    let d_l = level.c_b_l * g.baseline_b();
    let h_meas = b_l.x.hypot(b_l.y);
    let h_pred = d_l.x.hypot(d_l.y);
    if h_pred < MIN_HORIZONTAL_FRACTION * d_l.norm() {
        return Err(AidError::OutOfRange {
            what: "baseline's levelled horizontal part (m; near vertical: no heading)",
            value: h_pred,
        });
    }
    if h_meas < MIN_HORIZONTAL_FRACTION * b_l.norm() {
        return Err(AidError::OutOfRange {
            what: "measured baseline's horizontal part (m; near vertical: no heading)",
            value: h_meas,
        });
    }
    // Azimuths clockwise from north: atan2(east, north).
    let mut psi = (b_l.x.atan2(b_l.y) - d_l.x.atan2(d_l.y)).rem_euclid(std::f64::consts::TAU);
    if psi >= std::f64::consts::TAU {
        psi = 0.0;
    }
    // The measurement across the horizontal baseline.
    let c_rx_l = c_e_l * m.c_rx_e;
    let r_l = c_rx_l
        * Matrix3::from_diagonal(&m.sigma_enu.component_mul(&m.sigma_enu))
        * c_rx_l.transpose();
    let across = Vector3::new(-b_l.y, b_l.x, 0.0) / h_meas;
    let var_meas = (across.transpose() * r_l * across)[0] / (h_meas * h_meas);
    // ∂az/∂d = (d_N, −d_E) / h²; a levelling error ε turns d by ε × d.
    let daz = |dd: Vector3<f64>| (d_l.y * dd.x - d_l.x * dd.y) / (h_pred * h_pred);
    let g_e = daz(Vector3::x().cross(&d_l));
    let g_n = daz(Vector3::y().cross(&d_l));
    let var_tilt = level.sigma_tilt_rad.powi(2) * (g_e * g_e + g_n * g_n);
    let sigma_rad = (var_meas + var_tilt).sqrt();
    if !(psi.is_finite() && sigma_rad.is_finite()) {
        return Err(AidError::NonFinite("baseline heading"));
    }
    Ok(HeadingFix {
        heading_rad: psi,
        sigma_rad,
    })
}

impl Aid for BaselineSample {
    type Settings = BaselineSettings;
    /// The attitude.
    const OBSERVED: &'static [usize] = &[idx::PHI];
    fn measure(
        &self,
        nav: &AnyNav,
        _: &Context,
        g: &BaselineSettings,
    ) -> Result<Measured, AidError> {
        measurement(nav, self, g).map(Measured::from)
    }
    fn align_heading(
        &self,
        level: &Levelled,
        g: &BaselineSettings,
    ) -> Option<Result<HeadingFix, AidError>> {
        Some(heading(self, level, g))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::tests::computed;
    use crate::earth::{self, Geodetic};
    use crate::mech::FrameKind;
    use msgs::baseline::carr_soln;
    use nalgebra::SVector;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Receiver accuracy of each component in the tests (m).
    const ACC: [f64; 3] = [0.004, 0.003, 0.008];

    fn settings() -> BaselineSettings {
        BaselineSettings {
            primary_antenna_b_m: [0.3, -1.1, 0.4],
            secondary_antenna_b_m: [-0.2, 1.3, 0.9],
            sigma_floor_m: 0.002,
            length_gate_sigma: 5.0,
        }
    }

    /// A state at (lat, lon) in `kind` with the attitude (ψ, θ, φ) against
    /// the local geographic axes of meridian `lon` (at the pole too).
    fn state(kind: FrameKind, lat: f64, lon: f64, att: (f64, f64, f64)) -> AnyNav {
        let geo = Geodetic::from_deg(lat, lon, 3_000.0);
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        // (nalgebra's iterative `UnitQuaternion::from_matrix` converges to
        // a wrong rotation for some of these, e.g. ψ = 13° at the south
        // pole: the closed form is used.)
        let q = frames::quat_from_dcm(
            &(c_e_g.transpose() * frames::c_b_n_from_euler(att.0, att.1, att.2)),
        );
        let v_e = c_e_g.transpose() * Vector3::new(40.0, -25.0, 1.0);
        AnyNav::from_frame_free(kind, &earth::geodetic_to_ecef(&geo), &v_e, &q)
    }

    /// The receiver's ECEF → NED rotation, written out here from the
    /// textbook formula (independent of `frames`).
    fn c_e_ned(lat: f64, lon: f64) -> Matrix3<f64> {
        let (sl, cl) = lat.sin_cos();
        let (so, co) = lon.sin_cos();
        Matrix3::new(
            -sl * co,
            -sl * so,
            cl, //
            -so,
            co,
            0.0, //
            -cl * co,
            -cl * so,
            -sl,
        )
    }

    /// The error-free sample of the true state `t` that a receiver whose
    /// fix is at (`rx_lat`, `rx_lon`) reports.
    fn sample_at(t: &AnyNav, g: &BaselineSettings, rx_lat: f64, rx_lon: f64) -> BaselineSample {
        let c_b_e = t.frame_free().q_b_e.to_rotation_matrix().into_inner();
        let ned = c_e_ned(rx_lat, rx_lon) * (c_b_e * g.baseline_b());
        BaselineSample {
            t_ns: 1,
            seq: 0,
            lat_rad: rx_lat,
            lon_rad: rx_lon,
            rel_pos_ned_m: ned.into(),
            length_m: ned.norm(),
            heading_rad: ned.y.atan2(ned.x).rem_euclid(std::f64::consts::TAU),
            acc_heading_rad: 0.003,
            acc_ned_m: ACC,
            itow_ms: 0,
            carr_soln: carr_soln::FIXED,
            flags: baseline_flags::GNSS_FIX_OK
                | baseline_flags::DIFF_CORRECTED
                | baseline_flags::REL_POS_VALID
                | baseline_flags::IS_MOVING
                | baseline_flags::HEADING_VALID,
            _pad: 0,
        }
    }

    /// The sample of a receiver whose fix is the state's own position.
    fn sample_of(t: &AnyNav, g: &BaselineSettings) -> BaselineSample {
        let geo = t.geodetic();
        sample_at(t, g, geo.lat_rad, geo.lon_rad)
    }

    const ATTITUDES: [(f64, f64, f64); 6] = [
        (0.4, 0.02, 0.05),
        (0.0, 0.0, 0.0),
        (3.0, -0.7, 1.2),
        (5.9, 1.3, -2.8),
        (1.57, -1.5, 3.1),
        (4.4, 0.3, -0.9),
    ];

    /// The places: g and G at mid and high latitudes, G over both exact
    /// poles and a micrometre from one.
    const PLACES: [(FrameKind, f64, f64); 8] = [
        (FrameKind::Geographic, 45.0, 10.0),
        (FrameKind::Geographic, 69.0, -170.0),
        (FrameKind::Grid, 31.94, 118.79),
        (FrameKind::Grid, 88.0, -60.0),
        (FrameKind::Grid, 89.999_999_99, 137.0),
        (FrameKind::Grid, 90.0, 0.0),
        (FrameKind::Grid, -90.0, 0.0),
        (FrameKind::Grid, 90.0, 75.0),
    ];

    /// A noiseless sample gives z = 0 at every attitude and place, over
    /// the exact poles too, whatever longitude the receiver at the pole
    /// reports (its NED axes are those of its longitude's meridian).
    #[test]
    fn a_noiseless_baseline_has_no_innovation_anywhere_and_at_any_attitude() {
        let g = settings();
        let mut worst: f64 = 0.0;
        for (kind, lat, lon) in PLACES {
            for att in ATTITUDES {
                let t = state(kind, lat, lon, att);
                let mut rx = vec![sample_of(&t, &g)];
                if lat.abs() >= 90.0 {
                    for rx_lon in [0.0f64, 137.0, -90.0, 180.0] {
                        rx.push(sample_at(&t, &g, lat.to_radians(), rx_lon.to_radians()));
                    }
                }
                for s in rx {
                    let m = measurement(&t, &s, &g).expect("baseline");
                    worst = worst.max(m.z.amax());
                    assert!(m.z.amax() < 1e-12, "{kind:?} {lat} {att:?}: z {}", m.z);
                }
            }
        }
        eprintln!("largest |z| of a noiseless baseline: {worst:e} m");
    }

    /// H against central differences of z over every error state in g, in
    /// G and at the exact poles.
    #[test]
    fn baseline_jacobian_matches_central_differences_in_both_frames_and_over_the_poles() {
        let g = settings();
        let mut worst = (0.0f64, 0.0f64);
        for (kind, lat, lon) in PLACES {
            for att in [ATTITUDES[0], ATTITUDES[2], ATTITUDES[3]] {
                let t = state(kind, lat, lon, att);
                let s = sample_of(&t, &g);
                let m = measurement(&t, &s, &g).expect("baseline");
                let pos_steps = match kind {
                    FrameKind::Geographic => [1e-7, 1e-7, 10.0],
                    FrameKind::Grid => [10.0, 10.0, 10.0],
                };
                let mut fd = SMatrix::<f64, 3, 15>::zeros();
                for j in 0..15 {
                    let step = match j {
                        0..3 => 1e-6,
                        3..6 => 1e-3,
                        6..9 => pos_steps[j - 6],
                        _ => 1e-6,
                    };
                    let mut x = SVector::<f64, 15>::zeros();
                    x[j] = step;
                    let zp = measurement(&computed(&t, &x), &s, &g).expect("+").z;
                    let zm = measurement(&computed(&t, &-x), &s, &g).expect("−").z;
                    fd.set_column(j, &((zp - zm) / (2.0 * step)));
                }
                let d = fd - m.h;
                // φ block: entries of the order of the baseline (2.5 m).
                let e_phi = d.fixed_view::<3, 3>(0, idx::PHI).amax();
                assert!(
                    e_phi < 1e-6 * g.baseline_b().norm(),
                    "{kind:?} {lat}° {att:?}: φ block H {} FD {}",
                    m.h.fixed_view::<3, 3>(0, idx::PHI),
                    fd.fixed_view::<3, 3>(0, idx::PHI)
                );
                // δp block: ~|b|/R per metre (4e-7), or |b| per radian in g.
                let hp = m.h.fixed_view::<3, 3>(0, idx::DP).amax();
                assert!(hp > 0.0);
                let e_p = d.fixed_view::<3, 3>(0, idx::DP).amax() / hp;
                assert!(
                    e_p < 1e-5,
                    "{kind:?} {lat}° {att:?}: δp block H {} FD {}",
                    m.h.fixed_view::<3, 3>(0, idx::DP),
                    fd.fixed_view::<3, 3>(0, idx::DP)
                );
                for j in (3..6).chain(9..15) {
                    assert!(m.h.column(j).amax() == 0.0 && fd.column(j).amax() < 1e-12);
                }
                worst = (worst.0.max(e_phi), worst.1.max(e_p));
            }
        }
        eprintln!(
            "H vs central differences: φ block max |ΔH| {:e} m/rad, δp block max relative {:e}",
            worst.0, worst.1
        );
    }

    /// R is the receiver's accuracies (floored) in its own axes, turned
    /// into nav axes: in g at the receiver's position it is the diagonal.
    #[test]
    fn r_is_the_receivers_accuracy_raised_to_the_floor() {
        let g = settings();
        let t = state(FrameKind::Geographic, 60.0, 5.0, ATTITUDES[0]);
        let mut s = sample_of(&t, &g);
        let m = measurement(&t, &s, &g).expect("baseline");
        let want = Matrix3::from_diagonal(&Vector3::new(
            ACC[1].powi(2),
            ACC[0].powi(2),
            ACC[2].powi(2),
        ));
        assert!((m.r - want).amax() < 1e-18, "{}", m.r);
        s.acc_ned_m = [1e-4, 0.003, 1e-5];
        let m = measurement(&t, &s, &g).expect("baseline");
        let want = Matrix3::from_diagonal(&Vector3::new(
            0.003f64.powi(2),
            0.002f64.powi(2),
            0.002f64.powi(2),
        ));
        assert!((m.r - want).amax() < 1e-18, "{}", m.r);
        // In G over the pole the trace is the same.
        let t = state(FrameKind::Grid, 90.0, 0.0, ATTITUDES[2]);
        let s = sample_of(&t, &g);
        let m = measurement(&t, &s, &g).expect("baseline");
        assert!((m.r.trace() - ACC.iter().map(|a| a * a).sum::<f64>()).abs() < 1e-18);
    }

    fn cause_of(t: &AnyNav, s: &BaselineSample, g: &BaselineSettings) -> Option<usize> {
        match measurement(t, s, g) {
            Err(e) => Some(e.cause()),
            Ok(m) => {
                assert!(
                    m.z.iter()
                        .chain(m.h.iter())
                        .chain(m.r.iter())
                        .all(|x| x.is_finite())
                );
                None
            }
        }
    }

    /// Each refusal names its cause: invalid content first, then no fixed
    /// carrier solution, then a length that disagrees; adversarial values
    /// are refused without a panic, and what is accepted is finite.
    #[test]
    fn baselines_are_refused_by_cause_and_adversarial_ones_without_panic() {
        let g = settings();
        let t = state(FrameKind::Grid, 89.5, 20.0, ATTITUDES[3]);
        let good = sample_of(&t, &g);
        assert_eq!(cause_of(&t, &good, &g), None);
        let l = good.length_m;
        let ned = good.rel_pos_ned_m;
        let mut cases: Vec<(BaselineSample, usize)> = Vec::new();
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            cases.push((BaselineSample { lat_rad: v, ..good }, cause::INVALID));
            cases.push((BaselineSample { lon_rad: v, ..good }, cause::INVALID));
            cases.push((
                BaselineSample {
                    length_m: v,
                    ..good
                },
                cause::INVALID,
            ));
            cases.push((
                BaselineSample {
                    heading_rad: v,
                    ..good
                },
                cause::INVALID,
            ));
            cases.push((
                BaselineSample {
                    rel_pos_ned_m: [ned[0], v, ned[2]],
                    ..good
                },
                cause::INVALID,
            ));
            cases.push((
                BaselineSample {
                    acc_ned_m: [0.01, 0.01, v],
                    ..good
                },
                cause::INVALID,
            ));
        }
        for a in [0.0, -0.01, 1e-300, 1e300, 2e3] {
            cases.push((
                BaselineSample {
                    acc_ned_m: [a, 0.01, 0.01],
                    ..good
                },
                cause::INVALID,
            ));
        }
        cases.push((
            BaselineSample {
                lat_rad: 1.6,
                ..good
            },
            cause::INVALID,
        ));
        for len in [0.0, -l, 1e300, 2e3] {
            cases.push((
                BaselineSample {
                    length_m: len,
                    ..good
                },
                cause::INVALID,
            ));
        }
        // A reported length that is not the vector's.
        cases.push((
            BaselineSample {
                length_m: l + 0.05,
                ..good
            },
            cause::INVALID,
        ));
        cases.push((
            BaselineSample {
                flags: good.flags | baseline_flags::NORMALIZED,
                ..good
            },
            cause::INVALID,
        ));
        // Float, none, or not valid: no fixed solution, whatever the
        // (meaningless) vector and length of an epoch without one.
        cases.push((
            BaselineSample {
                carr_soln: carr_soln::NO_CARRIER,
                flags: 0,
                rel_pos_ned_m: [0.0; 3],
                length_m: 0.0,
                ..good
            },
            cause::NOT_FIXED,
        ));
        cases.push((
            BaselineSample {
                carr_soln: carr_soln::FLOAT,
                ..good
            },
            cause::NOT_FIXED,
        ));
        cases.push((
            BaselineSample {
                carr_soln: carr_soln::NO_CARRIER,
                ..good
            },
            cause::NOT_FIXED,
        ));
        cases.push((
            BaselineSample {
                carr_soln: 3,
                ..good
            },
            cause::NOT_FIXED,
        ));
        cases.push((
            BaselineSample {
                flags: good.flags & !baseline_flags::REL_POS_VALID,
                ..good
            },
            cause::NOT_FIXED,
        ));
        cases.push((
            BaselineSample {
                flags: good.flags & !baseline_flags::GNSS_FIX_OK,
                ..good
            },
            cause::NOT_FIXED,
        ));
        // A length off by 6 σ (σ of the length ≤ 8 mm here), a spoofer's
        // degenerate baseline (1e-300 m) and a far too long one.
        let scaled = |k: f64| BaselineSample {
            rel_pos_ned_m: [ned[0] * k, ned[1] * k, ned[2] * k],
            length_m: l * k,
            ..good
        };
        cases.push((scaled(1.0 + 0.06 / l), cause::LENGTH));
        cases.push((scaled(1e-300 / l), cause::LENGTH));
        cases.push((scaled(2.0), cause::LENGTH));
        // Invalid content is refused first, whatever else is wrong.
        cases.push((
            BaselineSample {
                carr_soln: carr_soln::FLOAT,
                length_m: f64::NAN,
                ..good
            },
            cause::INVALID,
        ));
        let mut counts = [0usize; 3];
        for (bad, want) in &cases {
            assert_eq!(cause_of(&t, bad, &g), Some(*want), "{bad:?}");
            assert!(heading(bad, &level_of(&t, 0.0), &g).is_err(), "{bad:?}");
            counts[*want] += 1;
        }
        // A normalized vector is taken with its length; a length 1 cm off
        // passes (σ of the length ≥ 3 mm here, gate 5 σ).
        let n = Vector3::from(ned) / l;
        let normalized = BaselineSample {
            rel_pos_ned_m: n.into(),
            flags: good.flags | baseline_flags::NORMALIZED,
            ..good
        };
        let m0 = measurement(&t, &good, &g).expect("good");
        let m1 = measurement(&t, &normalized, &g).expect("normalized");
        assert!((m0.z - m1.z).amax() < 1e-12);
        assert_eq!(cause_of(&t, &scaled(1.0 + 0.01 / l), &g), None);
        eprintln!("refused by cause (invalid, not fixed, length): {counts:?}");
    }

    /// The levelled attitude of the true state `t` (heading 0 against the
    /// local geographic axes), and its position.
    fn level_of(t: &AnyNav, sigma_tilt_rad: f64) -> Levelled {
        level_at(t, sigma_tilt_rad, t.geodetic())
    }

    /// The same with the alignment's position `geo` given (at a pole its
    /// longitude names the meridian whose north the heading is from).
    fn level_at(t: &AnyNav, sigma_tilt_rad: f64, geo: Geodetic) -> Levelled {
        let c_b_g = frames::c_e_g(geo.lat_rad, geo.lon_rad)
            * t.frame_free().q_b_e.to_rotation_matrix().into_inner();
        let (_, pitch, roll) = frames::euler_from_c_b_n(&c_b_g);
        Levelled {
            c_b_l: frames::c_b_n_from_euler(0.0, pitch, roll),
            sigma_tilt_rad,
            geo,
            t_ns: 1,
        }
    }

    /// With perfect data the heading comes back to 1e-9 rad at every
    /// heading, tilt and place, a pole's own meridian included.
    #[test]
    fn align_heading_recovers_the_true_heading_from_a_perfect_baseline() {
        let g = settings();
        let mut worst: f64 = 0.0;
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Geographic, -33.0, 151.0),
            (FrameKind::Grid, 90.0, 0.0),
            (FrameKind::Grid, -90.0, 60.0),
        ] {
            for k in 0..36 {
                let psi = (k as f64 * 10.0 + 3.0).to_radians();
                for (pitch, roll) in [(0.0, 0.0), (0.1, -0.05), (-0.3, 0.4)] {
                    let t = state(kind, lat, lon, (psi, pitch, roll));
                    let s = sample_of(&t, &g);
                    let lv = level_at(&t, 0.0, Geodetic::from_deg(lat, lon, 3_000.0));
                    let fix = s
                        .align_heading(&lv, &g)
                        .expect("a heading aid")
                        .expect("heading");
                    let e = (fix.heading_rad - psi + std::f64::consts::PI)
                        .rem_euclid(std::f64::consts::TAU)
                        - std::f64::consts::PI;
                    assert!(
                        e.abs() < 1e-9,
                        "{lat} ψ {psi} θ {pitch} φ {roll}: {} ({e:e})",
                        fix.heading_rad
                    );
                    assert!((0.0..std::f64::consts::TAU).contains(&fix.heading_rad));
                    worst = worst.max(e.abs());
                }
            }
        }
        eprintln!("align_heading, perfect data: largest heading error {worst:e} rad");
    }

    /// The stated σ is the spread of the heading over noisy baselines
    /// (Monte Carlo, 4000 draws of the receiver's noise and of the
    /// levelling error): within 10 %.
    #[test]
    fn align_heading_sigma_is_the_spread_of_its_heading() {
        let g = settings();
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(30);
        for (att, sigma_tilt) in [((0.7, 0.05, -0.02), 0.0), ((2.2, 0.2, 0.3), 2e-3)] {
            let t = state(FrameKind::Geographic, 50.0, 7.0, att);
            let s = sample_of(&t, &g);
            let lv = level_of(&t, sigma_tilt);
            let stated = heading(&s, &lv, &g).expect("heading").sigma_rad;
            let n = 4000;
            let mut sum2 = 0.0;
            for _ in 0..n {
                let mut noisy = s;
                for (x, acc) in noisy.rel_pos_ned_m.iter_mut().zip(ACC) {
                    let w: f64 = StandardNormal.sample(&mut rng);
                    *x += acc * w;
                }
                noisy.length_m = Vector3::from(noisy.rel_pos_ned_m).norm();
                let (ex, ey): (f64, f64) = (
                    StandardNormal.sample(&mut rng),
                    StandardNormal.sample(&mut rng),
                );
                let tilt =
                    nalgebra::Rotation3::from_scaled_axis(Vector3::new(ex, ey, 0.0) * sigma_tilt);
                let lv_noisy = Levelled {
                    c_b_l: tilt.into_inner() * lv.c_b_l,
                    ..lv
                };
                let h = heading(&noisy, &lv_noisy, &g).expect("heading").heading_rad;
                let e = (h - att.0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                sum2 += e * e;
            }
            let rms = (sum2 / n as f64).sqrt();
            eprintln!(
                "align_heading σ: stated {stated:e} rad, Monte-Carlo RMS {rms:e} rad (tilt σ {sigma_tilt})"
            );
            assert!((rms / stated - 1.0).abs() < 0.1, "stated {stated} vs {rms}");
            // σ ≈ σ_carrier / L for a level baseline: 3-4 mm over 2.5 m.
            assert!(
                stated > 1e-3 && stated < 3e-3 + 2.0 * sigma_tilt,
                "{stated}"
            );
        }
    }

    /// A baseline within 5.7° of vertical gives no heading: refused.
    #[test]
    fn a_vertical_baseline_gives_no_heading() {
        let g = BaselineSettings {
            primary_antenna_b_m: [0.0, 0.0, 0.0],
            secondary_antenna_b_m: [0.0, 0.05, 1.0],
            ..settings()
        };
        let t = state(FrameKind::Geographic, 45.0, 10.0, (1.0, 0.0, 0.0));
        let s = sample_of(&t, &g);
        assert!(
            measurement(&t, &s, &g).is_ok(),
            "the vector is still a measurement"
        );
        assert!(matches!(
            heading(&s, &level_of(&t, 0.0), &g),
            Err(AidError::OutOfRange { .. })
        ));
    }

    #[test]
    fn settings_outside_their_bounds_are_refused_naming_the_key() {
        assert!(
            BaselineSettings::default()
                .validate("t", "aids.baseline")
                .is_ok()
        );
        assert!(settings().validate("t", "aids.baseline").is_ok());
        for (bad, key) in [
            (
                BaselineSettings {
                    primary_antenna_b_m: [0.0, f64::NAN, 0.0],
                    ..Default::default()
                },
                "aids.baseline.primary_antenna_b_m[1]",
            ),
            (
                BaselineSettings {
                    secondary_antenna_b_m: [0.0, 0.0, 1e300],
                    ..Default::default()
                },
                "aids.baseline.secondary_antenna_b_m[2]",
            ),
            (
                BaselineSettings {
                    primary_antenna_b_m: [-101.0, 0.0, 0.0],
                    ..Default::default()
                },
                "aids.baseline.primary_antenna_b_m[0]",
            ),
            (
                BaselineSettings {
                    primary_antenna_b_m: [0.0, 0.0, 0.0],
                    secondary_antenna_b_m: [0.0, 0.05, 0.0],
                    ..Default::default()
                },
                "aids.baseline.secondary_antenna_b_m",
            ),
            (
                BaselineSettings {
                    sigma_floor_m: 0.0,
                    ..Default::default()
                },
                "aids.baseline.sigma_floor_m",
            ),
            (
                BaselineSettings {
                    sigma_floor_m: f64::INFINITY,
                    ..Default::default()
                },
                "aids.baseline.sigma_floor_m",
            ),
            (
                BaselineSettings {
                    length_gate_sigma: 0.5,
                    ..Default::default()
                },
                "aids.baseline.length_gate_sigma",
            ),
            (
                BaselineSettings {
                    length_gate_sigma: 1e3,
                    ..Default::default()
                },
                "aids.baseline.length_gate_sigma",
            ),
        ] {
            let e = bad.validate("t", "aids.baseline").expect_err(key);
            assert_eq!(e.key, key, "{e}");
        }
    }
}
