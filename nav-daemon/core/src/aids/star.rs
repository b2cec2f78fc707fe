//! Star tracker attitude: the body's attitude against the stars as a fourth
//! aid, which keeps heading observable in straight, level flight.
//!
//! The sensor gives C_b^i (body → DESIGN's inertial frame i, which coincides
//! with e at `t_ns = 0`). With C_i^e(t) and the nav frame of the computed
//! position it becomes a measured body → nav attitude
//! C_b^n,meas = C_e^n(p̂) C_i^e(t) C_b^i,meas. Since C_b^ĉ = (I − φ×) C_b^n and
//! C_e^n(p̂) = (I − θ×) C_e^n(p) with θ = Θ δp (the frame rotation caused by
//! the position error, [`super::frame_rotation_per_position_error`]):
//!
//! C_b^ĉ (C_b^n,meas)ᵀ = (I − φ×)(I + θ×) ≈ I − (φ − θ)×,
//!
//! so the innovation is the small rotation z = φ − Θ δp (rad, nav axes), with
//! H = [I, 0, −Θ, 0, 0] in g (Θ over δL, δλ, δh) and in G (Θ = C_P over δr^e).
//! The sensor noise is a rotation ν about body axes with σ_c across the
//! boresight b and σ_b about it: R = C_b^n (σ_c² I + (σ_b² − σ_c²) b bᵀ) C_n^b.

use msgs::StarSample;
use nalgebra::{Matrix3, Quaternion, SMatrix, UnitQuaternion, Vector3};

use super::{Aid, AidError, Context, Measured, Measurement, NoSettings};
use crate::error_model::idx;
use crate::mech::AnyNav;

/// One arcsecond (rad).
pub const ARCSEC_RAD: f64 = std::f64::consts::PI / (180.0 * 3600.0);

/// Largest departure of the measured quaternion's norm from 1 (a sensor
/// computes it normalized; single-precision output stays within 1e-6). A
/// larger one is a corrupted sample, not an attitude.
pub const QUATERNION_NORM_TOL: f64 = 1e-5;

/// Largest departure of the boresight's norm from 1.
pub const BORESIGHT_NORM_TOL: f64 = 1e-3;

/// C_i^e at `t_ns`: i coincides with e at `t_ns = 0` and e turns about z at
/// ω_ie (the same C_e^i as the SRS aid's).
pub fn q_i_e(t_ns: u64) -> UnitQuaternion<f64> {
    let c_e_i = super::srs::c_e_i(t_ns as f64 * 1e-9);
    UnitQuaternion::from_rotation_matrix(&c_e_i.inverse())
}

/// The measured body → ECEF attitude of a sample (checked).
pub fn measured_q_b_e(s: &StarSample) -> Result<UnitQuaternion<f64>, AidError> {
    let [w, x, y, z] = s.q_b_i;
    let q = Quaternion::new(w, x, y, z);
    let n = q.norm();
    if (n - 1.0).abs() > QUATERNION_NORM_TOL {
        return Err(AidError::OutOfRange {
            what: "star.q_b_i norm",
            value: n,
        });
    }
    Ok(q_i_e(s.t_ns) * UnitQuaternion::from_quaternion(q))
}

/// Checks a sample's content: finite values, unit quaternion and
/// boresight, σ in [`super::SIGMA_RANGE_STAR_RAD`].
fn check(s: &StarSample) -> Result<Vector3<f64>, AidError> {
    let all = s
        .q_b_i
        .iter()
        .chain(&s.boresight_b)
        .chain([&s.sigma_cross_arcsec, &s.sigma_boresight_arcsec]);
    if all.clone().any(|x| !x.is_finite()) {
        return Err(AidError::NonFinite("star"));
    }
    let b = Vector3::from(s.boresight_b);
    if (b.norm() - 1.0).abs() > BORESIGHT_NORM_TOL {
        return Err(AidError::OutOfRange {
            what: "star.boresight_b norm",
            value: b.norm(),
        });
    }
    super::check_sigma(
        "star.sigma_cross_arcsec (rad)",
        s.sigma_cross_arcsec * ARCSEC_RAD,
        super::SIGMA_RANGE_STAR_RAD,
    )?;
    super::check_sigma(
        "star.sigma_boresight_arcsec (rad)",
        s.sigma_boresight_arcsec * ARCSEC_RAD,
        super::SIGMA_RANGE_STAR_RAD,
    )?;
    Ok(b.normalize())
}

/// The attitude measurement for the nominal state `nav` at the sample's time.
pub fn measurement(nav: &AnyNav, s: &StarSample) -> Result<Measurement<3>, AidError> {
    let b = check(s)?;
    let q_b_e_meas = measured_q_b_e(s)?;
    let ff = nav.frame_free();
    let c_e_n = nav.c_e_n();
    // Small rotation from the measured to the computed attitude, C_b^ĉ =
    // (I − z×) C_b^meas: in ECEF axes, then nav axes.
    let dq = ff.q_b_e * q_b_e_meas.inverse();
    let z = c_e_n * -dq.scaled_axis();
    let mut h = SMatrix::<f64, 3, 15>::zeros();
    h.fixed_view_mut::<3, 3>(0, idx::PHI)
        .copy_from(&Matrix3::identity());
    h.fixed_view_mut::<3, 3>(0, idx::DP)
        .copy_from(&-super::frame_rotation_per_position_error(nav));
    let (sc, sb) = (
        s.sigma_cross_arcsec * ARCSEC_RAD,
        s.sigma_boresight_arcsec * ARCSEC_RAD,
    );
    let r_b = Matrix3::identity() * (sc * sc) + b * b.transpose() * (sb * sb - sc * sc);
    let c_b_n = c_e_n * ff.q_b_e.to_rotation_matrix().into_inner();
    let r = c_b_n * r_b * c_b_n.transpose();
    let r = (r + r.transpose()) * 0.5;
    if !(super::finite3(&z) && r.iter().all(|x| x.is_finite())) {
        return Err(AidError::NonFinite("star measurement"));
    }
    Ok(Measurement { z, h, r })
}

impl Aid for StarSample {
    type Settings = NoSettings;
    /// It observes the attitude.
    const OBSERVED: &'static [usize] = &[idx::PHI];
    fn measure(&self, nav: &AnyNav, _: &Context, _: &NoSettings) -> Result<Measured, AidError> {
        measurement(nav, self).map(Measured::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::tests::truth;
    use crate::earth;
    use crate::frames;
    use crate::mech::FrameKind;
    use nalgebra::SVector;

    const T_NS: u64 = 3_600_000_000_000;

    /// A perfect sample of the attitude of `t`: C_b^i = C_e^i(t) C_b^e, with
    /// C_e^i built here independently of the model (rotation about z by ω t).
    fn sample_of(t: &AnyNav, t_ns: u64) -> StarSample {
        let a = earth::OMEGA_IE * t_ns as f64 * 1e-9;
        let (s, c) = a.sin_cos();
        let c_e_i = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let c_b_i = c_e_i * t.frame_free().q_b_e.to_rotation_matrix().into_inner();
        let q = UnitQuaternion::from_matrix(&c_b_i).into_inner();
        StarSample {
            t_ns,
            seq: 0,
            q_b_i: [q.w, q.i, q.j, q.k],
            boresight_b: [0.0, 0.6, 0.8],
            sigma_cross_arcsec: 5.0,
            sigma_boresight_arcsec: 40.0,
        }
    }

    fn computed(t: &AnyNav, x: &SVector<f64, 15>) -> AnyNav {
        let mut c = *t;
        let part = |o: usize| Vector3::new(x[o], x[o + 1], x[o + 2]);
        c.correct(&-part(idx::PHI), &-part(idx::DV), &-part(idx::DP));
        c
    }

    fn fd_jacobian(t: &AnyNav, s: &StarSample) -> SMatrix<f64, 3, 15> {
        let pos_steps = match t.kind() {
            FrameKind::Geographic => [1e-7, 1e-7, 10.0],
            FrameKind::Grid => [10.0, 10.0, 10.0],
        };
        let mut h = SMatrix::<f64, 3, 15>::zeros();
        for j in 0..15 {
            let step = match j {
                0..3 => 1e-6,
                3..6 => 1e-3,
                6..9 => pos_steps[j - 6],
                _ => 1e-6,
            };
            let mut x = SVector::<f64, 15>::zeros();
            x[j] = step;
            let zp = measurement(&computed(t, &x), s).expect("star").z;
            let zm = measurement(&computed(t, &-x), s).expect("star").z;
            h.set_column(j, &((zp - zm) / (2.0 * step)));
        }
        h
    }

    #[test]
    fn star_jacobian_matches_central_differences_in_both_frames() {
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Geographic, 69.0, -120.0),
            (FrameKind::Grid, 88.0, -60.0),
            (FrameKind::Grid, 89.99999, 20.0),
            (FrameKind::Grid, 31.94, 118.79),
        ] {
            let t = truth(kind, lat, lon);
            let s = sample_of(&t, T_NS);
            let m = measurement(&t, &s).expect("star");
            assert!(m.z.amax() < 1e-12, "{kind:?} z at the truth {}", m.z);
            let fd = fd_jacobian(&t, &s);
            // Attitude columns are exactly 1 and 0; position columns are
            // ~1/R per metre (1.6e-7): compare each block to its own scale.
            let d = fd - m.h;
            assert!(
                d.fixed_view::<3, 3>(0, idx::PHI).amax() < 1e-6,
                "{kind:?} φ block: H {} FD {}",
                m.h.fixed_view::<3, 3>(0, 0),
                fd.fixed_view::<3, 3>(0, 0)
            );
            let hp = m.h.fixed_view::<3, 3>(0, idx::DP).amax();
            assert!(hp > 0.0);
            assert!(
                d.fixed_view::<3, 3>(0, idx::DP).amax() < 1e-5 * hp,
                "{kind:?} δp block: H {} FD {}",
                m.h.fixed_view::<3, 3>(0, idx::DP),
                fd.fixed_view::<3, 3>(0, idx::DP)
            );
            for j in [3, 4, 5, 9, 10, 11, 12, 13, 14] {
                assert!(fd.column(j).amax() < 1e-9 && m.h.column(j).amax() == 0.0);
            }
        }
    }

    /// The same physical error seen in g and, converted with the switch's Φ,
    /// in G gives the same innovation rotated into G axes: H_G Φ = C_g^G H_g
    /// and z_G = C_g^G z_g, R_G = C_g^G R_g C_G^g, checked on an error that
    /// moves the computed state (nonlinear z, not only H).
    #[test]
    fn star_measurement_agrees_across_the_frame_switch() {
        let t_g = truth(FrameKind::Geographic, 88.5, 33.0);
        let t_gg = t_g.converted(FrameKind::Grid);
        let s = sample_of(&t_g, T_NS);
        let geo = t_g.geodetic();
        let a = frames::c_g_grid(frames::grid_angle(geo.lat_rad, geo.lon_rad));
        let phi = crate::switch::phi_geo_to_grid(&geo, &t_gg.v_n());
        let m_g = measurement(&t_g, &s).expect("g");
        let m_gg = measurement(&t_gg, &s).expect("G");
        let lhs = m_gg.h * phi;
        let rhs = a * m_g.h;
        let scale = m_g.h.fixed_view::<3, 3>(0, idx::DP).amax();
        assert!(
            (lhs.fixed_view::<3, 3>(0, idx::PHI) - rhs.fixed_view::<3, 3>(0, idx::PHI)).amax()
                < 1e-12
        );
        assert!(
            (lhs.fixed_view::<3, 3>(0, idx::DP) - rhs.fixed_view::<3, 3>(0, idx::DP)).amax()
                < 1e-6 * scale,
            "H_G Φ {} vs C H_g {}",
            lhs.fixed_view::<3, 3>(0, idx::DP),
            rhs.fixed_view::<3, 3>(0, idx::DP)
        );
        assert!((m_gg.r - a * m_g.r * a.transpose()).amax() < 1e-9 * m_g.r.amax());
        // A state with an error (200 m, 1e-4 rad): its innovations in the two
        // frames are one rotation vector in two sets of axes.
        let mut x = SVector::<f64, 15>::zeros();
        x[0] = 1e-4;
        x[1] = -2e-4;
        x[2] = 3e-4;
        x[6] = 200.0 / 6.4e6;
        x[7] = -300.0 / 2.0e5;
        let c_g = computed(&t_g, &x);
        let c_gg = c_g.converted(FrameKind::Grid);
        let z_g = measurement(&c_g, &s).expect("g").z;
        let z_gg = measurement(&c_gg, &s).expect("G").z;
        let geo_c = c_g.geodetic();
        let a_c = frames::c_g_grid(frames::grid_angle(geo_c.lat_rad, geo_c.lon_rad));
        assert!((z_gg - a_c * z_g).amax() < 1e-12, "{z_gg} vs {}", a_c * z_g);
    }

    /// The noise model: R is the covariance of rotations drawn about body
    /// axes with σ_c across and σ_b about the boresight, in nav axes.
    #[test]
    fn star_noise_is_larger_about_the_boresight_in_nav_axes() {
        let t = truth(FrameKind::Geographic, 60.0, 5.0);
        let s = sample_of(&t, T_NS);
        let m = measurement(&t, &s).expect("star");
        let c_b_n = t.c_e_n() * t.frame_free().q_b_e.to_rotation_matrix().into_inner();
        let b_n = c_b_n * Vector3::from(s.boresight_b);
        let sb = s.sigma_boresight_arcsec * ARCSEC_RAD;
        let sc = s.sigma_cross_arcsec * ARCSEC_RAD;
        assert!(((b_n.transpose() * m.r * b_n)[0] - sb * sb).abs() < 1e-6 * sb * sb);
        let across = b_n.cross(&Vector3::x()).normalize();
        assert!(((across.transpose() * m.r * across)[0] - sc * sc).abs() < 1e-6 * sc * sc);
    }

    #[test]
    fn star_refuses_what_no_sensor_gives() {
        let t = truth(FrameKind::Grid, 89.0, 0.0);
        let good = sample_of(&t, T_NS);
        assert!(measurement(&t, &good).is_ok());
        let mut bad = Vec::new();
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            bad.push(StarSample {
                q_b_i: [v, 0.0, 0.0, 0.0],
                ..good
            });
            bad.push(StarSample {
                sigma_cross_arcsec: v,
                ..good
            });
            bad.push(StarSample {
                boresight_b: [0.0, v, 1.0],
                ..good
            });
        }
        for sigma in [1e-300, 1e300, 0.0, -5.0, 1e-3, 3e5] {
            bad.push(StarSample {
                sigma_cross_arcsec: sigma,
                ..good
            });
            bad.push(StarSample {
                sigma_boresight_arcsec: sigma,
                ..good
            });
        }
        let q = good.q_b_i;
        bad.push(StarSample {
            q_b_i: [q[0] * 1.01, q[1], q[2], q[3]],
            ..good
        });
        bad.push(StarSample {
            q_b_i: [0.0; 4],
            ..good
        });
        bad.push(StarSample {
            boresight_b: [0.0, 0.0, 0.0],
            ..good
        });
        for b in bad {
            assert!(measurement(&t, &b).is_err(), "{b:?}");
        }
    }
}
