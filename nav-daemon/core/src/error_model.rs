//! Linear INS error model in the geographic frame g (papers/001 eqs 9–12),
//! for X = [φ δv δp ε ∇] with C_b^c = (I − φ×) C_b^n, δv = computed − true,
//! δp = [δL, δλ, δh]. Radius and gravity derivatives are kept (not only the
//! spherical-Earth terms), so F matches finite differences of the exact
//! nonlinear dynamics.

use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::earth::{self, Geodetic};
use crate::frames::{self, skew};

/// Offsets of the state blocks.
pub mod idx {
    pub const PHI: usize = 0;
    pub const DV: usize = 3;
    pub const DP: usize = 6;
    pub const BG: usize = 9;
    pub const BA: usize = 12;
    /// Number of error states.
    pub const N: usize = 15;
    const _: () = assert!(BA + 3 == N);
}

/// 15 × 15 system matrix.
pub type Mat15 = SMatrix<f64, 15, 15>;

/// Derivatives of the radii: (dR_M/dL, dR_N/dL).
pub fn radii_derivatives(lat_rad: f64) -> (f64, f64) {
    let (s, c) = lat_rad.sin_cos();
    let w = 1.0 - earth::E2 * s * s;
    let (rm, rn) = earth::radii(lat_rad);
    (3.0 * rm * earth::E2 * s * c / w, rn * earth::E2 * s * c / w)
}

/// Partial derivatives of normal gravity: (∂γ/∂L, ∂γ/∂h).
pub fn gravity_derivatives(lat_rad: f64, h_m: f64) -> (f64, f64) {
    let s2 = lat_rad.sin().powi(2);
    let sin2l = (2.0 * lat_rad).sin();
    let w = 1.0 - earth::E2 * s2;
    let g0 = earth::GAMMA_E * (1.0 + earth::GRAVITY_K * s2) / w.sqrt();
    let dg0 = earth::GAMMA_E
        * sin2l
        * (earth::GRAVITY_K / w.sqrt()
            + (1.0 + earth::GRAVITY_K * s2) * earth::E2 / (2.0 * w.powf(1.5)));
    let a = earth::A;
    let hf = 1.0 - (2.0 / a) * (1.0 + earth::F + earth::GRAVITY_M - 2.0 * earth::F * s2) * h_m
        + 3.0 * h_m * h_m / (a * a);
    let dhf_dl = (4.0 * earth::F / a) * sin2l * h_m;
    let dhf_dh = -(2.0 / a) * (1.0 + earth::F + earth::GRAVITY_M - 2.0 * earth::F * s2)
        + 6.0 * h_m / (a * a);
    (dg0 * hf + g0 * dhf_dl, g0 * dhf_dh)
}

/// F in g for the nominal state (position, ENU velocity, C_b^g) and the
/// specific force in g. Bias states are constant.
pub fn f_geo(pos: &Geodetic, v: &Vector3<f64>, c_b_g: &Matrix3<f64>, f_g: &Vector3<f64>) -> Mat15 {
    use idx::*;
    let (sl, cl) = pos.lat_rad.sin_cos();
    let tl = sl / cl;
    let w = earth::OMEGA_IE;
    let (rm, rn) = earth::radii(pos.lat_rad);
    let (drm, drn) = radii_derivatives(pos.lat_rad);
    let (rmh, rnh) = (rm + pos.h_m, rn + pos.h_m);
    let (ve, vn) = (v.x, v.y);

    let omega_ie = Vector3::new(0.0, w * cl, w * sl);
    let omega_en = Vector3::new(-vn / rmh, ve / rnh, ve * tl / rnh);
    // ∂ω_ie/∂p, ∂ω_en/∂v, ∂ω_en/∂p (columns δL, δλ, δh).
    let m1 = Matrix3::new(0.0, 0.0, 0.0, -w * sl, 0.0, 0.0, w * cl, 0.0, 0.0);
    let mav = Matrix3::new(
        0.0,
        -1.0 / rmh,
        0.0,
        1.0 / rnh,
        0.0,
        0.0,
        tl / rnh,
        0.0,
        0.0,
    );
    let map = Matrix3::new(
        vn * drm / (rmh * rmh),
        0.0,
        vn / (rmh * rmh),
        -ve * drn / (rnh * rnh),
        0.0,
        -ve / (rnh * rnh),
        ve / (cl * cl) / rnh - ve * tl * drn / (rnh * rnh),
        0.0,
        -ve * tl / (rnh * rnh),
    );
    let (dg_dl, dg_dh) = gravity_derivatives(pos.lat_rad, pos.h_m);
    let mgp = Matrix3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -dg_dl, 0.0, -dg_dh);

    let mut f = Mat15::zeros();
    let mut set =
        |r: usize, c: usize, m: &Matrix3<f64>| f.fixed_view_mut::<3, 3>(r, c).copy_from(m);
    set(PHI, PHI, &-skew(&(omega_ie + omega_en)));
    set(PHI, DV, &mav);
    set(PHI, DP, &(m1 + map));
    set(PHI, BG, &-c_b_g);
    set(DV, PHI, &skew(f_g));
    set(
        DV,
        DV,
        &(skew(v) * mav - skew(&(omega_ie * 2.0 + omega_en))),
    );
    set(DV, DP, &(skew(v) * (m1 * 2.0 + map) + mgp));
    set(DV, BA, c_b_g);
    // Position: L̇ = v_N/(R_M+h), λ̇ = v_E/((R_N+h) cos L), ḣ = v_U.
    let mpv = Matrix3::new(
        0.0,
        1.0 / rmh,
        0.0,
        1.0 / (rnh * cl),
        0.0,
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let mpp = Matrix3::new(
        -vn * drm / (rmh * rmh),
        0.0,
        -vn / (rmh * rmh),
        ve * sl / (cl * cl) / rnh - ve * drn / (rnh * rnh * cl),
        0.0,
        -ve / (rnh * rnh * cl),
        0.0,
        0.0,
        0.0,
    );
    set(DP, DV, &mpv);
    set(DP, DP, &mpp);
    f
}

/// Rotation of the grid axes caused by a position change: C_e^G(r + δr) =
/// (I − (C_P δr)×) C_e^G(r). Because the grid axes are a function of the
/// ellipsoid normal only, C_P δr is the grid transport-rate formula with δr
/// in place of the velocity (so C_P = ∂ω_eG^G/∂v^e).
pub fn c_p_grid(geo: &Geodetic) -> Matrix3<f64> {
    Matrix3::from_columns(&[
        frames::transport_rate_grid(geo, &Vector3::x()),
        frames::transport_rate_grid(geo, &Vector3::y()),
        frames::transport_rate_grid(geo, &Vector3::z()),
    ])
}

/// ∂ω_eG^G/∂r^e at fixed Earth-relative ECEF velocity `v_e` (curvature change
/// along the position). Of order |v|/R² ≈ 6e-12 rad/s per metre; it has no
/// compact closed form on the ellipsoid, so it is the forward difference
/// (+1 m) of the exact closed-form transport rate (truncation ~|v|/R³ ≈ 1e-18).
fn d_transport_rate_dr(r_e: &Vector3<f64>, geo: &Geodetic, v_e: &Vector3<f64>) -> Matrix3<f64> {
    let base = frames::transport_rate_grid(geo, v_e);
    let col = |k: usize| {
        let mut d = Vector3::zeros();
        d[k] = 1.0;
        frames::transport_rate_grid(&earth::ecef_to_geodetic(&(r_e + d)), v_e) - base
    };
    Matrix3::from_columns(&[col(0), col(1), col(2)])
}

/// F in the grid frame for X = [φ^G δv^G δr^e ε ∇] (derived here rather than
/// taken from the doubtful extraction of papers/001 eq 18; every block is
/// checked against finite differences of the exact nonlinear dynamics):
/// - φ̇ = −ω_iG×φ + C_v δv + ([ω_ie^G×] C_P + ∂ω_eG/∂r) δr − C_b^G ε, with C_v = C_P C_G^e
/// - δv̇ = f^G×φ + ([v×] C_v − [(2ω_ie + ω_eG)×]) δv + ([v×](2[ω_ie×] C_P + ∂ω_eG/∂r) + ∂g/∂r) δr + C_b^G ∇
/// - δṙ = C_G^e δv − C_G^e [v^G×] C_P δr
pub fn f_grid(
    r_e: &Vector3<f64>,
    v_grid: &Vector3<f64>,
    c_b_grid: &Matrix3<f64>,
    f_grid_vec: &Vector3<f64>,
) -> Mat15 {
    use idx::*;
    let geo = earth::ecef_to_geodetic(r_e);
    let c_e_grid = frames::c_e_grid(geo.lat_rad, geo.lon_rad);
    let c_grid_e = c_e_grid.transpose();
    let v_e = c_grid_e * v_grid;
    let omega_ie = c_e_grid * earth::omega_ie_e();
    let omega_eg = frames::transport_rate_grid(&geo, &v_e);
    let c_p = c_p_grid(&geo);
    // ω_eG^G = C_P C_G^e v^G: linear in v.
    let c_v = c_p * c_grid_e;
    // Total ∂ω_eG^G/∂r: curvature change at fixed v^e, plus v^e = C_G^e(r) v^G turning with the frame.
    let d_omega_eg_dr = d_transport_rate_dr(r_e, &geo, &v_e) - c_v * skew(v_grid) * c_p;
    let d_omega_ie_dr = skew(&omega_ie) * c_p;
    // Gravity: g^G = [0, 0, −γ(L, h)]; δL = N·δr/(R_M+h), δh = u·δr (true-north axes).
    let [_, n_g, u] = frames::enu_axes_e(geo.lat_rad, geo.lon_rad);
    let (rm, _) = earth::radii(geo.lat_rad);
    let (dg_dl, dg_dh) = gravity_derivatives(geo.lat_rad, geo.h_m);
    let dg_dr = -(n_g.transpose() * (dg_dl / (rm + geo.h_m)) + u.transpose() * dg_dh);
    let mut mgp = Matrix3::zeros();
    mgp.set_row(2, &dg_dr);

    let mut f = Mat15::zeros();
    let mut set =
        |r: usize, c: usize, m: &Matrix3<f64>| f.fixed_view_mut::<3, 3>(r, c).copy_from(m);
    set(PHI, PHI, &-skew(&(omega_ie + omega_eg)));
    set(PHI, DV, &c_v);
    set(PHI, DP, &(d_omega_ie_dr + d_omega_eg_dr));
    set(PHI, BG, &-c_b_grid);
    set(DV, PHI, &skew(f_grid_vec));
    set(
        DV,
        DV,
        &(skew(v_grid) * c_v - skew(&(omega_ie * 2.0 + omega_eg))),
    );
    set(
        DV,
        DP,
        &(skew(v_grid) * (d_omega_ie_dr * 2.0 + d_omega_eg_dr) + mgp),
    );
    set(DV, BA, c_b_grid);
    set(DP, DV, &c_grid_e);
    set(DP, DP, &(-c_grid_e * skew(v_grid) * c_p));
    f
}

impl crate::mech::AnyNav {
    /// The error dynamics F of this state's frame for the specific force
    /// `f_b` (body axes): [`f_geo`] in g, [`f_grid`] in G.
    pub fn error_dynamics(&self, f_b: &Vector3<f64>) -> Mat15 {
        match self {
            crate::mech::AnyNav::Geographic(s) => {
                let c = s.q_b_n.to_rotation_matrix().into_inner();
                f_geo(&s.pos, &s.v_n, &c, &(c * f_b))
            }
            crate::mech::AnyNav::Grid(s) => {
                let c = s.q_b_n.to_rotation_matrix().into_inner();
                f_grid(&s.pos, &s.v_n, &c, &(c * f_b))
            }
        }
    }

    /// The map from this frame's position error δp to local east, north,
    /// up metres: from δL, δλ, δh in g; `c_e_g` on the ECEF δr in G.
    pub fn position_error_to_enu(&self, c_e_g: &Matrix3<f64>) -> Matrix3<f64> {
        match self {
            crate::mech::AnyNav::Geographic(s) => {
                let (rm, rn) = earth::radii(s.pos.lat_rad);
                let e = (rn + s.pos.h_m) * s.pos.lat_rad.cos();
                Matrix3::new(0.0, e, 0.0, rm + s.pos.h_m, 0.0, 0.0, 0.0, 0.0, 1.0)
            }
            crate::mech::AnyNav::Grid(_) => *c_e_g,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_and_radius_derivatives_match_central_differences() {
        for &(lat, h) in &[(0.3_f64, 100.0_f64), (1.0, 18_000.0), (-0.8, 5_000.0)] {
            let e = 1e-6;
            let (dg_dl, dg_dh) = gravity_derivatives(lat, h);
            let fd_l =
                (earth::normal_gravity(lat + e, h) - earth::normal_gravity(lat - e, h)) / (2.0 * e);
            let fd_h =
                (earth::normal_gravity(lat, h + 1.0) - earth::normal_gravity(lat, h - 1.0)) / 2.0;
            assert!((dg_dl - fd_l).abs() < 1e-8, "{dg_dl} {fd_l}");
            assert!((dg_dh - fd_h).abs() < 1e-12, "{dg_dh} {fd_h}");
            let (drm, drn) = radii_derivatives(lat);
            let fd_rm = (earth::radii(lat + e).0 - earth::radii(lat - e).0) / (2.0 * e);
            let fd_rn = (earth::radii(lat + e).1 - earth::radii(lat - e).1) / (2.0 * e);
            assert!((drm - fd_rm).abs() < 1e-3 && (drn - fd_rn).abs() < 1e-3);
        }
    }

    /// Exact nonlinear dynamics of (attitude, velocity, position) in g,
    /// written independently of F: returns (C_b^g rate as ω, v̇, ṗ).
    fn nonlinear_rates(
        pos: &Geodetic,
        v: &Vector3<f64>,
        c_b_g: &Matrix3<f64>,
        f_b: &Vector3<f64>,
        w_ib_b: &Vector3<f64>,
    ) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        let (rm, rn) = earth::radii(pos.lat_rad);
        let c_e_g = frames::c_e_g(pos.lat_rad, pos.lon_rad);
        let w_ie = c_e_g * earth::omega_ie_e();
        let w_en = frames::transport_rate_g(pos, v);
        let g = Vector3::new(0.0, 0.0, -earth::normal_gravity(pos.lat_rad, pos.h_m));
        let c_dot = c_b_g * skew(w_ib_b) - skew(&(w_ie + w_en)) * c_b_g;
        let v_dot = c_b_g * f_b - (w_ie * 2.0 + w_en).cross(v) + g;
        let p_dot = Vector3::new(
            v.y / (rm + pos.h_m),
            v.x / ((rn + pos.h_m) * pos.lat_rad.cos()),
            v.z,
        );
        (c_dot, v_dot, p_dot)
    }

    #[test]
    fn f_geo_matches_finite_differences_of_the_nonlinear_dynamics() {
        let pos = Geodetic::from_deg(55.0, 20.0, 12_000.0);
        let v = Vector3::new(180.0, -120.0, 4.0);
        let c_b_g = frames::c_b_n_from_euler(0.8, 0.05, 0.2);
        let f_b = Vector3::new(0.3, 0.6, 9.9);
        let w_ib_b = Vector3::new(1e-3, -2e-3, 3e-3);
        let f = f_geo(&pos, &v, &c_b_g, &(c_b_g * f_b));
        // Error-state derivative by central differences: perturb the computed state by X,
        // compute d/dt(computed − true) with the same sensor outputs (corrected by the biases).
        let rate_of_error = |x: &SMatrix<f64, 15, 1>| -> SMatrix<f64, 15, 1> {
            let phi = x.fixed_rows::<3>(idx::PHI).into_owned();
            let dv = x.fixed_rows::<3>(idx::DV).into_owned();
            let dp = x.fixed_rows::<3>(idx::DP).into_owned();
            let eps = x.fixed_rows::<3>(idx::BG).into_owned();
            let nab = x.fixed_rows::<3>(idx::BA).into_owned();
            let c_c = (Matrix3::identity() - skew(&phi)) * c_b_g;
            let pc = Geodetic::new(pos.lat_rad + dp.x, pos.lon_rad + dp.y, pos.h_m + dp.z);
            let (cdot_c, vdot_c, pdot_c) =
                nonlinear_rates(&pc, &(v + dv), &c_c, &(f_b + nab), &(w_ib_b + eps));
            let (cdot_t, vdot_t, pdot_t) = nonlinear_rates(&pos, &v, &c_b_g, &f_b, &w_ib_b);
            // φ× = I − C_c C_tᵀ  ⇒  φ̇× = −(Ċ_c C_tᵀ + C_c Ċ_tᵀ).
            let phidot = -(cdot_c * c_b_g.transpose() + c_c * cdot_t.transpose());
            let mut out = SMatrix::<f64, 15, 1>::zeros();
            out.fixed_rows_mut::<3>(idx::PHI)
                .copy_from(&frames::unskew(&phidot));
            out.fixed_rows_mut::<3>(idx::DV)
                .copy_from(&(vdot_c - vdot_t));
            out.fixed_rows_mut::<3>(idx::DP)
                .copy_from(&(pdot_c - pdot_t));
            out
        };
        let scale = [
            1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-3, 1e-7, 1e-7, 1.0, 1e-8, 1e-8, 1e-8, 1e-5, 1e-5, 1e-5,
        ];
        for (j, &h) in scale.iter().enumerate() {
            let mut e = SMatrix::<f64, 15, 1>::zeros();
            e[j] = h;
            let col = (rate_of_error(&e) - rate_of_error(&-e)) / (2.0 * h);
            for i in 0..9 {
                let tol = 1e-6 * f.column(j).amax().max(1e-9) + 1e-12;
                assert!(
                    (col[i] - f[(i, j)]).abs() < tol.max(1e-7 * col[i].abs()),
                    "F[{i},{j}] = {} vs FD {}",
                    f[(i, j)],
                    col[i]
                );
            }
        }
    }

    /// Exact nonlinear dynamics in G, written independently of F.
    fn nonlinear_rates_grid(
        r: &Vector3<f64>,
        v: &Vector3<f64>,
        c_b: &Matrix3<f64>,
        f_b: &Vector3<f64>,
        w_ib_b: &Vector3<f64>,
    ) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        let geo = earth::ecef_to_geodetic(r);
        let c_e_n = frames::c_e_grid(geo.lat_rad, geo.lon_rad);
        let w_ie = c_e_n * earth::omega_ie_e();
        let w_en = frames::transport_rate_grid(&geo, &(c_e_n.transpose() * v));
        let g = Vector3::new(0.0, 0.0, -earth::normal_gravity(geo.lat_rad, geo.h_m));
        let c_dot = c_b * skew(w_ib_b) - skew(&(w_ie + w_en)) * c_b;
        let v_dot = c_b * f_b - (w_ie * 2.0 + w_en).cross(v) + g;
        (c_dot, v_dot, c_e_n.transpose() * v)
    }

    #[test]
    fn f_grid_matches_finite_differences_of_the_nonlinear_dynamics_including_the_pole() {
        for &(lat, lon) in &[
            (75.0_f64, 20.0_f64),
            (89.9999, -100.0),
            (90.0, 0.0),
            (-86.0, 170.0),
            (31.94, 118.79),
        ] {
            let r = earth::geodetic_to_ecef(&Geodetic::from_deg(lat, lon, 18_000.0));
            let v = Vector3::new(180.0, -150.0, 4.0);
            let c_b = frames::c_b_n_from_euler(2.0, 0.05, -0.2);
            let f_b = Vector3::new(0.3, 0.6, 9.9);
            let w_ib_b = Vector3::new(1e-3, -2e-3, 3e-3);
            let f = f_grid(&r, &v, &c_b, &(c_b * f_b));
            let rate_of_error = |x: &SMatrix<f64, 15, 1>| -> SMatrix<f64, 15, 1> {
                let phi = x.fixed_rows::<3>(idx::PHI).into_owned();
                let dv = x.fixed_rows::<3>(idx::DV).into_owned();
                let dr = x.fixed_rows::<3>(idx::DP).into_owned();
                let eps = x.fixed_rows::<3>(idx::BG).into_owned();
                let nab = x.fixed_rows::<3>(idx::BA).into_owned();
                let c_c = (Matrix3::identity() - skew(&phi)) * c_b;
                let (cd_c, vd_c, rd_c) =
                    nonlinear_rates_grid(&(r + dr), &(v + dv), &c_c, &(f_b + nab), &(w_ib_b + eps));
                let (cd_t, vd_t, rd_t) = nonlinear_rates_grid(&r, &v, &c_b, &f_b, &w_ib_b);
                let phidot = -(cd_c * c_b.transpose() + c_c * cd_t.transpose());
                let mut out = SMatrix::<f64, 15, 1>::zeros();
                out.fixed_rows_mut::<3>(idx::PHI)
                    .copy_from(&frames::unskew(&phidot));
                out.fixed_rows_mut::<3>(idx::DV).copy_from(&(vd_c - vd_t));
                out.fixed_rows_mut::<3>(idx::DP).copy_from(&(rd_c - rd_t));
                out
            };
            let scale = [
                1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-3, 10.0, 10.0, 10.0, 1e-8, 1e-8, 1e-8, 1e-5, 1e-5,
                1e-5,
            ];
            for (j, &h) in scale.iter().enumerate() {
                let mut e = SMatrix::<f64, 15, 1>::zeros();
                e[j] = h;
                let col = (rate_of_error(&e) - rate_of_error(&-e)) / (2.0 * h);
                for blk in [idx::PHI, idx::DV, idx::DP] {
                    let fb = f.fixed_view::<3, 1>(blk, j).into_owned();
                    let cb = col.fixed_rows::<3>(blk).into_owned();
                    let tol = 1e-6 * fb.amax().max(cb.amax()) + 1e-16;
                    assert!(
                        (fb - cb).amax() < tol,
                        "at {lat},{lon}: F[{blk}.., {j}] = {fb} vs FD {cb}"
                    );
                }
            }
        }
    }
}
