//! Filter parameter conversion at a frame switch (papers/001 eqs 30–38):
//! X_G = Φ X_g, P_G = Φ P_g Φᵀ, and the inverse for G→g.
//!
//! Derived for the error definitions of DESIGN (C_b^c = (I − φ×) C_b^n,
//! computed − true), with σ the grid angle at the switch position:
//! - φ^G = C_g^G φ^g − ẑ δσ, δσ = ∂σ/∂L δL + ∂σ/∂λ δλ (T1: its third row is
//!   [∂σ/∂L, ∂σ/∂λ, 0] — the erratum of papers/README);
//! - δv^G = C_g^G δv^g + δσ (ẑ × v^G) (T2);
//! - δr^e = [(R_M+h) N, (R_N+h) cos L E, U] δp^g (T3);
//! - biases unchanged.

use nalgebra::{Matrix3, Vector3};

use crate::earth::{self, Geodetic};
use crate::error_model::{Mat15, idx};
use crate::frames;

/// [∂σ/∂L, ∂σ/∂λ] with D = 1 − cos²L sin²λ.
pub fn grid_angle_gradient(lat_rad: f64, lon_rad: f64) -> (f64, f64) {
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
    let d = 1.0 - cl * cl * so * so;
    (cl * so * co / d, sl / d)
}

/// The blocks T1 (φ), T2 (δv) and T3 (δr) of the conversion at `pos` with grid velocity `v_grid`.
fn blocks(pos: &Geodetic, v_grid: &Vector3<f64>) -> (Matrix3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let (ds_dl, ds_dlon) = grid_angle_gradient(pos.lat_rad, pos.lon_rad);
    let dsigma = Vector3::new(ds_dl, ds_dlon, 0.0).transpose();
    let t1 = Vector3::z() * dsigma;
    let t2 = Vector3::z().cross(v_grid) * dsigma * -1.0;
    let [e, n, u] = frames::enu_axes_e(pos.lat_rad, pos.lon_rad);
    let (rm, rn) = earth::radii(pos.lat_rad);
    let t3 = Matrix3::from_columns(&[
        n * (rm + pos.h_m),
        e * ((rn + pos.h_m) * pos.lat_rad.cos()),
        u,
    ]);
    (t1, t2, t3)
}

/// Φ for the g→G switch at geodetic position `pos`; `v_grid` is the nominal
/// velocity in G after the navigation-parameter conversion.
pub fn phi_geo_to_grid(pos: &Geodetic, v_grid: &Vector3<f64>) -> Mat15 {
    let (t1, t2, t3) = blocks(pos, v_grid);
    let a = frames::c_g_grid(frames::grid_angle(pos.lat_rad, pos.lon_rad));
    let mut phi = Mat15::identity();
    phi.fixed_view_mut::<3, 3>(idx::PHI, idx::PHI).copy_from(&a);
    phi.fixed_view_mut::<3, 3>(idx::PHI, idx::DP)
        .copy_from(&-t1);
    phi.fixed_view_mut::<3, 3>(idx::DV, idx::DV).copy_from(&a);
    phi.fixed_view_mut::<3, 3>(idx::DV, idx::DP).copy_from(&-t2);
    phi.fixed_view_mut::<3, 3>(idx::DP, idx::DP).copy_from(&t3);
    phi
}

/// Φ⁻¹ for the G→g switch (papers/001 eq 38), in closed form: T3⁻¹ has rows
/// Nᵀ/(R_M+h), Eᵀ/((R_N+h) cos L), Uᵀ.
pub fn phi_grid_to_geo(pos: &Geodetic, v_grid: &Vector3<f64>) -> Mat15 {
    let (t1, t2, _) = blocks(pos, v_grid);
    let [e, n, u] = frames::enu_axes_e(pos.lat_rad, pos.lon_rad);
    let (rm, rn) = earth::radii(pos.lat_rad);
    let t3_inv = Matrix3::from_rows(&[
        n.transpose() / (rm + pos.h_m),
        e.transpose() / ((rn + pos.h_m) * pos.lat_rad.cos()),
        u.transpose(),
    ]);
    let at = frames::c_g_grid(frames::grid_angle(pos.lat_rad, pos.lon_rad)).transpose();
    let mut phi = Mat15::identity();
    phi.fixed_view_mut::<3, 3>(idx::PHI, idx::PHI)
        .copy_from(&at);
    phi.fixed_view_mut::<3, 3>(idx::PHI, idx::DP)
        .copy_from(&(at * t1 * t3_inv));
    phi.fixed_view_mut::<3, 3>(idx::DV, idx::DV).copy_from(&at);
    phi.fixed_view_mut::<3, 3>(idx::DV, idx::DP)
        .copy_from(&(at * t2 * t3_inv));
    phi.fixed_view_mut::<3, 3>(idx::DP, idx::DP)
        .copy_from(&t3_inv);
    phi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mech::{Geo, Nav, geo_to_grid};
    use nalgebra::{SMatrix, UnitQuaternion};

    fn nominal(lat: f64, lon: f64) -> Nav<Geo> {
        Nav {
            q_b_n: UnitQuaternion::from_matrix(&frames::c_b_n_from_euler(0.7, 0.03, -0.1)),
            v_n: Vector3::new(120.0, 210.0, 3.0),
            pos: Geodetic::from_deg(lat, lon, 15_000.0),
        }
    }

    /// Error state between a computed and a true state of the same frame.
    fn error_grid(c: &Nav<crate::mech::Grid>, t: &Nav<crate::mech::Grid>) -> SMatrix<f64, 15, 1> {
        let mut x = SMatrix::<f64, 15, 1>::zeros();
        // C_c = (I − φ×) C_t  ⇒  φ = −rotvec(C_c C_tᵀ).
        x.fixed_rows_mut::<3>(idx::PHI)
            .copy_from(&-(c.q_b_n * t.q_b_n.inverse()).scaled_axis());
        x.fixed_rows_mut::<3>(idx::DV).copy_from(&(c.v_n - t.v_n));
        x.fixed_rows_mut::<3>(idx::DP).copy_from(&(c.pos - t.pos));
        x
    }

    /// The computed g-frame state that has error `x` relative to `t`.
    fn perturb(t: &Nav<Geo>, x: &SMatrix<f64, 15, 1>) -> Nav<Geo> {
        let phi = x.fixed_rows::<3>(idx::PHI).into_owned();
        Nav {
            q_b_n: UnitQuaternion::from_scaled_axis(-phi) * t.q_b_n,
            v_n: t.v_n + x.fixed_rows::<3>(idx::DV),
            pos: Geodetic::new(
                t.pos.lat_rad + x[idx::DP],
                t.pos.lon_rad + x[idx::DP + 1],
                t.pos.h_m + x[idx::DP + 2],
            ),
        }
    }

    #[test]
    fn phi_matches_exact_conversion_of_perturbed_states() {
        for &(lat, lon) in &[
            (88.0_f64, 30.0_f64),
            (70.0, -150.0),
            (-75.0, 100.0),
            (31.94, 118.79),
        ] {
            let t = nominal(lat, lon);
            let t_grid = geo_to_grid(&t);
            let phi = phi_geo_to_grid(&t.pos, &t_grid.v_n);
            let scale = [
                1e-5, 1e-5, 1e-5, 1e-2, 1e-2, 1e-2, 1e-7, 1e-7, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0,
            ];
            for (j, &h) in scale.iter().enumerate().take(9) {
                let mut e = SMatrix::<f64, 15, 1>::zeros();
                e[j] = h;
                let plus = error_grid(&geo_to_grid(&perturb(&t, &e)), &t_grid);
                let minus = error_grid(&geo_to_grid(&perturb(&t, &-e)), &t_grid);
                let col = (plus - minus) / (2.0 * h);
                for blk in [idx::PHI, idx::DV, idx::DP] {
                    let a = phi.fixed_view::<3, 1>(blk, j).into_owned();
                    let b = col.fixed_rows::<3>(blk).into_owned();
                    let tol = 1e-6 * a.amax().max(b.amax()) + 1e-12;
                    assert!(
                        (a - b).amax() < tol,
                        "at {lat},{lon}: Φ[{blk}.., {j}] = {a} vs exact {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn forward_then_inverse_switch_returns_x_and_p() {
        let t = nominal(70.2, 12.0);
        let v_grid = geo_to_grid(&t).v_n;
        let phi = phi_geo_to_grid(&t.pos, &v_grid);
        let inv = phi_grid_to_geo(&t.pos, &v_grid);
        // A realistic, badly scaled X and P (radians of latitude next to metres and m/s).
        let sig = [
            3e-4, 3e-4, 9e-4, 0.1, 0.1, 0.1, 1.6e-6, 4.6e-6, 10.0, 4.8e-8, 4.8e-8, 4.8e-8, 1e-3,
            1e-3, 1e-3,
        ];
        let mut x = SMatrix::<f64, 15, 1>::zeros();
        let mut p = Mat15::zeros();
        for i in 0..15 {
            x[i] = sig[i] * ((i as f64) * 0.77).sin();
            for j in 0..15 {
                let rho = if i == j {
                    1.0
                } else {
                    0.3 * ((i * 7 + j * 7) as f64).cos() / 15.0
                };
                p[(i, j)] = rho * sig[i] * sig[j];
            }
        }
        let x_back = inv * (phi * x);
        let p_back = inv * (phi * p * phi.transpose()) * inv.transpose();
        for i in 0..15 {
            assert!((x_back[i] - x[i]).abs() <= 1e-12 * sig[i], "x[{i}]");
            for j in 0..15 {
                assert!(
                    (p_back[(i, j)] - p[(i, j)]).abs() <= 1e-12 * sig[i] * sig[j],
                    "P[{i},{j}]"
                );
            }
        }
        assert!(((phi * inv) - Mat15::identity()).amax() < 1e-9);
    }
}
