//! Barometric altitude: static pressure → ISA pressure altitude (geopotential
//! → geometric), standing in for ellipsoidal height (DESIGN "Aids").

use msgs::BaroSample;
use nalgebra::{SMatrix, SVector};

use super::{AidError, Measurement};
use crate::earth::isa;
use crate::error_model::idx;
use crate::mech::AnyNav;

/// Geometric pressure altitude (m) of a static pressure (Pa).
pub fn pressure_altitude_m(pressure_pa: f64) -> f64 {
    isa::geometric_from_geopotential(isa::pressure_altitude(pressure_pa))
}

/// z = h_INS − h_baro; H = ∂h/∂δp (1 on δh in g, the normal uᵀ on δr in G).
pub fn measurement(nav: &AnyNav, b: &BaroSample) -> Result<Measurement<1>, AidError> {
    if !(b.pressure_pa.is_finite() && b.sigma_m.is_finite()) {
        return Err(AidError::NonFinite("baro"));
    }
    // Below the ISA top (32 km) and above any pressure an aircraft can see at sea level.
    if !(500.0..=110_000.0).contains(&b.pressure_pa) {
        return Err(AidError::OutOfRange {
            what: "baro.pressure_pa",
            value: b.pressure_pa,
        });
    }
    if b.sigma_m <= 0.0 {
        return Err(AidError::OutOfRange {
            what: "baro.sigma_m",
            value: b.sigma_m,
        });
    }
    let geo = nav.geodetic();
    let mut h = SMatrix::<f64, 1, 15>::zeros();
    match nav {
        AnyNav::Geographic(_) => h[(0, idx::DP + 2)] = 1.0,
        AnyNav::Grid(_) => {
            let u = crate::earth::up_e(geo.lat_rad, geo.lon_rad);
            h.fixed_view_mut::<1, 3>(0, idx::DP)
                .copy_from(&u.transpose());
        }
    }
    Ok(Measurement {
        z: SVector::<f64, 1>::new(geo.h_m - pressure_altitude_m(b.pressure_pa)),
        h,
        r: SMatrix::<f64, 1, 1>::new(b.sigma_m * b.sigma_m),
    })
}
