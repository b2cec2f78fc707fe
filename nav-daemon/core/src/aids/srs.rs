//! Spectral-redshift velocity (SRS).
//!
//! Each line k gives z_k = (λ_k − λ0_k)/λ0_k; with u_k = −los_k and
//! w = v_p − v_k, papers/001 eq (8) reads
//! r_k(v_p) = w·u_k − (1+z_k)·√(c² − |w|²) + c = 0.
//! It is solved for the carrier's inertial velocity v_p by weighted
//! Gauss–Newton in the cancellation-free form
//! r_k = w·u_k − z_k·s + |w|²/(s + c), s = √(c² − |w|²),
//! with ∂r_k/∂v_p = u_k + (1+z_k)·w/s. A line's residual noise is its
//! radial-velocity σ. With ≥ 5 lines a failed χ² test excludes the one line
//! whose removal passes; with 4 the measurement is rejected. The
//! Earth-relative velocity is v^e = C_i^e v_p − ω_ie × r^e, expressed in the
//! nav frame; its covariance comes from the solution geometry.

use msgs::{SRS_MAX_LINES, SrsLine, SrsSample};
use nalgebra::{Matrix3, Rotation3, SMatrix, Vector3};

use super::{
    Aid, AidError, AnyMeasurement, Context, Measured, Measurement, NoSettings,
    frame_rotation_per_position_error,
};
use crate::earth;
use crate::error_model::idx;
use crate::frames::skew;
use crate::mech::AnyNav;

/// Speed of light (m/s).
pub const C_LIGHT: f64 = 299_792_458.0;

/// Why no velocity could be solved.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SrsError {
    #[error("{0} usable lines, at least 3 non-collinear are needed")]
    TooFewLines(usize),
    #[error("line-of-sight geometry is degenerate (collinear bodies)")]
    Degenerate,
    #[error("line {index} is invalid: {why}")]
    BadLine { index: usize, why: &'static str },
    #[error("Gauss-Newton did not converge")]
    NoConvergence,
    #[error(
        "residual test failed (χ² = {chi2:.1} with {lines} lines) and no single exclusion explains it"
    )]
    Inconsistent { chi2: f64, lines: usize },
}

/// A solved velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SrsSolution {
    /// Carrier velocity in the inertial frame (m/s).
    pub v_p_i: Vector3<f64>,
    /// Its covariance (m²/s²).
    pub cov_i: Matrix3<f64>,
    /// Lines used.
    pub lines_used: usize,
    /// Body id of the excluded line, if one was excluded.
    pub excluded_body: Option<u32>,
    /// Σ (r_k/σ_k)² at the solution.
    pub chi2: f64,
}

#[derive(Debug, Clone, Copy)]
struct Line {
    u: Vector3<f64>,
    v_k: Vector3<f64>,
    z: f64,
    w: f64,
    id: u32,
}

/// χ² quantiles at 99.9 % for 1..=5 degrees of freedom.
const CHI2_999: [f64; 6] = [0.0, 10.828, 13.816, 16.266, 18.467, 20.515];

fn residual_and_gradient(l: &Line, v: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let w = v - l.v_k;
    let w2 = w.norm_squared();
    let s = (C_LIGHT * C_LIGHT - w2).sqrt();
    let r = w.dot(&l.u) - l.z * s + w2 / (s + C_LIGHT);
    (r, l.u + w * ((1.0 + l.z) / s))
}

/// Weighted Gauss–Newton over the lines selected by `mask`.
fn gauss_newton(
    lines: &[Line],
    mask: u32,
    v0: &Vector3<f64>,
) -> Result<(Vector3<f64>, Matrix3<f64>, f64), SrsError> {
    let mut v = *v0;
    for _ in 0..20 {
        let mut a = Matrix3::zeros();
        let mut b = Vector3::zeros();
        for (k, l) in lines.iter().enumerate() {
            if mask & (1 << k) == 0 {
                continue;
            }
            let (r, g) = residual_and_gradient(l, &v);
            a += g * g.transpose() * l.w;
            b += g * (r * l.w);
        }
        // Non-collinear geometry: the weakest direction must carry information.
        let ev = a.symmetric_eigenvalues();
        if ev.min().is_nan() || ev.min() <= 1e-9 * ev.max() {
            return Err(SrsError::Degenerate);
        }
        let chol = a.cholesky().ok_or(SrsError::Degenerate)?;
        let step = chol.solve(&-b);
        v += step;
        if step.norm() < 1e-7 {
            let chi2 = lines
                .iter()
                .enumerate()
                .filter(|(k, _)| mask & (1 << k) != 0)
                .map(|(_, l)| residual_and_gradient(l, &v).0.powi(2) * l.w)
                .sum();
            return Ok((v, chol.inverse(), chi2));
        }
    }
    Err(SrsError::NoConvergence)
}

/// Solves the carrier's inertial velocity from the valid lines of `s`.
/// `v0` is the starting guess (the INS inertial velocity).
pub fn solve(s: &SrsSample, v0: &Vector3<f64>) -> Result<SrsSolution, SrsError> {
    let mut buf = [Line {
        u: Vector3::zeros(),
        v_k: Vector3::zeros(),
        z: 0.0,
        w: 0.0,
        id: 0,
    }; SRS_MAX_LINES];
    let mut n = 0;
    for (index, l) in s.valid_lines().iter().enumerate() {
        buf[n] = to_line(index, l)?;
        n += 1;
    }
    let lines = &buf[..n];
    if n < 3 {
        return Err(SrsError::TooFewLines(n));
    }
    let all = (1u32 << n) - 1;
    let (v, cov, chi2) = gauss_newton(lines, all, v0)?;
    let dof = n - 3;
    if dof == 0 || chi2 <= CHI2_999[dof] {
        return Ok(SrsSolution {
            v_p_i: v,
            cov_i: cov,
            lines_used: n,
            excluded_body: None,
            chi2,
        });
    }
    if n < 5 {
        return Err(SrsError::Inconsistent { chi2, lines: n });
    }
    // Exclude the single line whose removal leaves the smallest residual.
    let mut best: Option<(usize, Vector3<f64>, Matrix3<f64>, f64)> = None;
    for k in 0..n {
        if let Ok((vk, ck, x2)) = gauss_newton(lines, all & !(1 << k), &v)
            && best.as_ref().is_none_or(|b| x2 < b.3)
        {
            best = Some((k, vk, ck, x2));
        }
    }
    match best {
        Some((k, vk, ck, x2)) if x2 <= CHI2_999[dof - 1] => Ok(SrsSolution {
            v_p_i: vk,
            cov_i: ck,
            lines_used: n - 1,
            excluded_body: Some(lines[k].id),
            chi2: x2,
        }),
        _ => Err(SrsError::Inconsistent { chi2, lines: n }),
    }
}

fn to_line(index: usize, l: &SrsLine) -> Result<Line, SrsError> {
    let bad = |why| SrsError::BadLine { index, why };
    let los = Vector3::from(l.los_i);
    if !(super::finite3(&los) && super::finite3(&Vector3::from(l.body_vel_i_mps))) {
        return Err(bad("non-finite line of sight or body velocity"));
    }
    if (los.norm() - 1.0).abs() > 1e-6 {
        return Err(bad("line of sight is not a unit vector"));
    }
    if !(l.rest_wavelength_m.is_finite()
        && l.rest_wavelength_m > 0.0
        && l.measured_wavelength_m.is_finite()
        && l.measured_wavelength_m > 0.0)
    {
        return Err(bad("wavelengths must be positive"));
    }
    let (lo, hi) = super::SIGMA_RANGE_SRS_MPS;
    if !(l.sigma_mps.is_finite() && (lo..=hi).contains(&l.sigma_mps)) {
        return Err(bad("sigma_mps outside [1e-4, 1e5] m/s"));
    }
    let z = (l.measured_wavelength_m - l.rest_wavelength_m) / l.rest_wavelength_m;
    // |z| ≤ 1e-3 is ±300 km/s: far beyond any ephemeris body plus aircraft.
    if z.abs() > 1e-3 {
        return Err(bad("redshift beyond ±300 km/s"));
    }
    Ok(Line {
        u: -los,
        v_k: Vector3::from(l.body_vel_i_mps),
        z,
        w: 1.0 / (l.sigma_mps * l.sigma_mps),
        id: l.body_id,
    })
}

/// C_e^i at time t: e coincides with i at t = 0 and turns about z.
pub fn c_e_i(t_s: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), earth::OMEGA_IE * t_s)
}

/// The SRS velocity measurement z = v^n_INS − C_e^n (C_i^e v_p − ω_ie × r^e_INS).
/// H: I on δv, and on δp the nav-frame rotation and the ω × r term.
pub fn measurement(nav: &AnyNav, s: &SrsSample) -> Result<(Measurement<3>, SrsSolution), AidError> {
    let t_s = s.t_ns as f64 * 1e-9;
    let c_e_i = c_e_i(t_s);
    let ff = nav.frame_free();
    let omega = earth::omega_ie_e();
    let v_p_guess = c_e_i * (ff.v_e + omega.cross(&ff.r_e));
    let sol = solve(s, &v_p_guess)?;
    let c_i_e = c_e_i.inverse();
    let v_e = c_i_e * sol.v_p_i - omega.cross(&ff.r_e);
    let c_e_n = nav.c_e_n();
    let v_n = nav.v_n();
    let mut h = SMatrix::<f64, 3, 15>::zeros();
    h.fixed_view_mut::<3, 3>(0, idx::DV)
        .copy_from(&Matrix3::identity());
    let d_r = super::ecef_per_position_error(nav);
    let h_p = -skew(&v_n) * frame_rotation_per_position_error(nav) + c_e_n * skew(&omega) * d_r;
    h.fixed_view_mut::<3, 3>(0, idx::DP).copy_from(&h_p);
    let c = c_e_n * c_i_e.matrix();
    Ok((
        Measurement {
            z: v_n - c_e_n * v_e,
            h,
            r: c * sol.cov_i * c.transpose(),
        },
        sol,
    ))
}

impl Aid for SrsSample {
    type Settings = NoSettings;
    /// It observes the velocity.
    const OBSERVED: &'static [usize] = &[idx::DV];
    fn measure(&self, nav: &AnyNav, _: &Context, _: &NoSettings) -> Result<Measured, AidError> {
        measurement(nav, self).map(|(m, sol)| Measured {
            m: AnyMeasurement::D3(m),
            excluded_body: sol.excluded_body,
            shares: super::ConsiderShares::default(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Builds lines for carrier velocity `v_p` with per-line radial errors `err` (m/s).
    fn sample(v_p: &Vector3<f64>, dirs: &[Vector3<f64>], err: &[f64]) -> SrsSample {
        let mut s = SrsSample {
            count: dirs.len() as u32,
            ..Default::default()
        };
        for (k, d) in dirs.iter().enumerate() {
            let los = d.normalize();
            let v_k = Vector3::new(
                -29_780.0 + 1000.0 * k as f64,
                5_000.0 * (k as f64).sin(),
                12_000.0,
            );
            let w = v_p - v_k;
            // Exact relativistic Doppler, papers/001 eq (2): 1+z = (1 + |w|cosθ/c)/√(1 − |w|²/c²), cosθ = ŵ·(−los).
            let opz = (1.0 + w.dot(&-los) / C_LIGHT)
                / (1.0 - w.norm_squared() / (C_LIGHT * C_LIGHT)).sqrt()
                + err[k] / C_LIGHT;
            s.lines[k] = SrsLine {
                los_i: los.into(),
                body_vel_i_mps: v_k.into(),
                rest_wavelength_m: 656.281e-9,
                measured_wavelength_m: 656.281e-9 * opz,
                sigma_mps: 0.5,
                body_id: k as u32 + 1,
                _pad: 0,
            };
        }
        s
    }

    fn dirs() -> Vec<Vector3<f64>> {
        vec![
            Vector3::new(1.0, 0.1, 0.5),
            Vector3::new(-0.3, 1.0, 0.4),
            Vector3::new(-0.7, -0.6, 0.6),
            Vector3::new(0.2, -0.9, 0.3),
            Vector3::new(0.1, 0.2, 1.0),
            Vector3::new(0.9, 0.8, 0.2),
        ]
    }

    #[test]
    fn noise_free_lines_give_the_velocity_to_micrometres_per_second() {
        let v_p = Vector3::new(250.0, -30_100.0, 340.0);
        for n in 3..=6 {
            let s = sample(&v_p, &dirs()[..n], &[0.0; 6]);
            let sol = solve(&s, &Vector3::zeros()).expect("solve");
            assert!(
                (sol.v_p_i - v_p).norm() < 1e-6,
                "{n} lines: {}",
                (sol.v_p_i - v_p).norm()
            );
            assert_eq!(sol.lines_used, n);
        }
    }

    #[test]
    fn covariance_from_geometry_matches_monte_carlo() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha20Rng::seed_from_u64(5);
        let v_p = Vector3::new(100.0, 200.0, -50.0);
        let n = 2000;
        let mut mean = Vector3::zeros();
        let mut errs = Vec::with_capacity(n);
        let mut cov_model = Matrix3::zeros();
        for _ in 0..n {
            let e: Vec<f64> = (0..5)
                .map(|_| {
                    let x: f64 = StandardNormal.sample(&mut rng);
                    0.5 * x
                })
                .collect();
            let sol = solve(&sample(&v_p, &dirs()[..5], &e), &Vector3::zeros()).expect("solve");
            let d = sol.v_p_i - v_p;
            mean += d / n as f64;
            errs.push(d);
            cov_model = sol.cov_i;
        }
        let mut cov = Matrix3::zeros();
        for d in &errs {
            cov += (d - mean) * (d - mean).transpose() / (n as f64 - 1.0);
        }
        // Sample covariance within ~10 % (2000 samples: relative σ ≈ 3 %) of the model.
        for i in 0..3 {
            let ratio = cov[(i, i)] / cov_model[(i, i)];
            assert!((ratio - 1.0).abs() < 0.1, "axis {i}: ratio {ratio}");
        }
        assert!(mean.norm() < 0.1);
    }

    #[test]
    fn one_faulty_line_of_five_or_more_is_excluded() {
        let v_p = Vector3::new(250.0, -30_100.0, 340.0);
        let mut err = [0.1, -0.2, 0.05, 0.3, -0.1, 0.2];
        err[2] = 40.0; // a 80σ fault on body 3
        for n in [5, 6] {
            let sol = solve(&sample(&v_p, &dirs()[..n], &err), &Vector3::zeros())
                .expect("solve with exclusion");
            assert_eq!(sol.excluded_body, Some(3));
            assert!(
                (sol.v_p_i - v_p).norm() < 2.0,
                "{}",
                (sol.v_p_i - v_p).norm()
            );
        }
        // With 4 lines the fault is detected but cannot be isolated.
        assert!(matches!(
            solve(&sample(&v_p, &dirs()[..4], &err), &Vector3::zeros()),
            Err(SrsError::Inconsistent { .. })
        ));
    }

    #[test]
    fn collinear_and_too_few_lines_are_refused() {
        let v_p = Vector3::new(1.0, 2.0, 3.0);
        let d = Vector3::new(0.3, 0.4, 0.5);
        let s = sample(&v_p, &[d, -d, d], &[0.0; 3]);
        assert_eq!(solve(&s, &Vector3::zeros()), Err(SrsError::Degenerate));
        let s = sample(&v_p, &dirs()[..2], &[0.0; 2]);
        assert_eq!(solve(&s, &Vector3::zeros()), Err(SrsError::TooFewLines(2)));
        let mut s = sample(&v_p, &dirs()[..3], &[0.0; 3]);
        s.lines[1].measured_wavelength_m = f64::NAN;
        assert!(matches!(
            solve(&s, &Vector3::zeros()),
            Err(SrsError::BadLine { index: 1, .. })
        ));
    }
}
