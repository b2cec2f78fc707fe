//! Celestial latitude/longitude fix.
//!
//! In g: z = [L_INS − L_CNS, λ_INS − λ_CNS] (rad). In G (poles): the ECEF
//! difference between the INS position and the fix (placed at the INS
//! height) projected on the grid horizontal axes — pole-safe, unlike
//! latitude/longitude differences.

use msgs::CnsFix;
use nalgebra::{Matrix2, SMatrix, SVector};

use super::{Aid, AidError, Context, Measured, Measurement, NoSettings};
use crate::earth::{self, Geodetic};
use crate::error_model::idx;
use crate::frames;
use crate::mech::AnyNav;

pub fn measurement(nav: &AnyNav, c: &CnsFix) -> Result<Measurement<2>, AidError> {
    if !(c.lat_rad.is_finite() && c.lon_rad.is_finite() && c.sigma_h_m.is_finite()) {
        return Err(AidError::NonFinite("cns"));
    }
    if c.lat_rad.abs() > std::f64::consts::FRAC_PI_2 {
        return Err(AidError::OutOfRange {
            what: "cns.lat_rad",
            value: c.lat_rad,
        });
    }
    super::check_sigma("cns.sigma_h_m", c.sigma_h_m, super::SIGMA_RANGE_CNS_M)?;
    let geo = nav.geodetic();
    let s2 = c.sigma_h_m * c.sigma_h_m;
    let mut h = SMatrix::<f64, 2, 15>::zeros();
    match nav {
        AnyNav::Geographic(s) => {
            let (rm, rn) = earth::radii(s.pos.lat_rad);
            h[(0, idx::DP)] = 1.0;
            h[(1, idx::DP + 1)] = 1.0;
            let rl = rm + s.pos.h_m;
            let ro = (rn + s.pos.h_m) * s.pos.lat_rad.cos();
            Ok(Measurement {
                z: SVector::<f64, 2>::new(
                    s.pos.lat_rad - c.lat_rad,
                    earth::wrap_pi(s.pos.lon_rad - c.lon_rad),
                ),
                h,
                r: Matrix2::new(s2 / (rl * rl), 0.0, 0.0, s2 / (ro * ro)),
            })
        }
        AnyNav::Grid(s) => {
            let [e, n, _] = frames::grid_axes_e(geo.lat_rad, geo.lon_rad);
            let fix = earth::geodetic_to_ecef(&Geodetic::new(c.lat_rad, c.lon_rad, geo.h_m));
            let d = s.pos - fix;
            h.fixed_view_mut::<1, 3>(0, idx::DP)
                .copy_from(&e.transpose());
            h.fixed_view_mut::<1, 3>(1, idx::DP)
                .copy_from(&n.transpose());
            Ok(Measurement {
                z: SVector::<f64, 2>::new(e.dot(&d), n.dot(&d)),
                h,
                r: Matrix2::identity() * s2,
            })
        }
    }
}
impl Aid for CnsFix {
    type Settings = NoSettings;
    /// It observes the position.
    const OBSERVED: &'static [usize] = &[idx::DP];
    fn measure(&self, nav: &AnyNav, _: &Context, _: &NoSettings) -> Result<Measured, AidError> {
        measurement(nav, self).map(Measured::from)
    }
}
