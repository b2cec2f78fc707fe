//! Barometric altitude: static pressure → ISA pressure altitude (geopotential
//! → geometric), standing in for ellipsoidal height (DESIGN "Aids").

use msgs::BaroSample;
use nalgebra::{SMatrix, SVector};

use super::{Aid, AidError, Context, Measured, Measurement, NoSettings};
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
    // Within the modelled atmosphere (up to its 32 km top) and below any
    // pressure an aircraft can see at sea level.
    if !(isa::pressure(isa::MAX_ALTITUDE_M)..=110_000.0).contains(&b.pressure_pa) {
        return Err(AidError::OutOfRange {
            what: "baro.pressure_pa",
            value: b.pressure_pa,
        });
    }
    super::check_sigma("baro.sigma_m", b.sigma_m, super::SIGMA_RANGE_BARO_M)?;
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

impl Aid for BaroSample {
    type Settings = NoSettings;
    /// It observes the position.
    const OBSERVED: &'static [usize] = &[idx::DP];
    fn measure(&self, nav: &AnyNav, _: &Context, _: &NoSettings) -> Result<Measured, AidError> {
        measurement(nav, self).map(Measured::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::earth::{self, Geodetic};
    use crate::mech::{AnyNav, FrameKind};
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn pressures_outside_the_modelled_atmosphere_are_refused() {
        let r = earth::geodetic_to_ecef(&Geodetic::from_deg(45.0, 0.0, 18_000.0));
        let nav = AnyNav::from_frame_free(
            FrameKind::Geographic,
            &r,
            &Vector3::zeros(),
            &UnitQuaternion::identity(),
        );
        let sample = |p: f64| BaroSample {
            t_ns: 1,
            seq: 0,
            pressure_pa: p,
            temperature_k: 220.0,
            sigma_m: 10.0,
        };
        let top = isa::pressure(isa::MAX_ALTITUDE_M);
        assert!(measurement(&nav, &sample(top * 1.001)).is_ok());
        assert!(matches!(
            measurement(&nav, &sample(top * 0.99)),
            Err(AidError::OutOfRange { .. })
        ));
        assert!(matches!(
            measurement(&nav, &sample(120_000.0)),
            Err(AidError::OutOfRange { .. })
        ));
        assert!(matches!(
            measurement(&nav, &sample(f64::NAN)),
            Err(AidError::NonFinite(_))
        ));
    }
}
