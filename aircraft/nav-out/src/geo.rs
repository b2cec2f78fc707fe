//! The encodings the output protocols define, from the solution's values:
//! latitude and longitude in 1e-7 degrees (MAVLink `degE7`), longitude
//! wrapped onto one turn, headings in centidegrees, NMEA's degrees and
//! decimal minutes, and heights above mean sea level through the EGM96
//! geoid. Each function is exact at the poles (latitude ±90° is a value
//! like any other; longitude is kept as the solution gives it there) and
//! across the antimeridian (±180° is one meridian).

use std::f64::consts::FRAC_PI_2;

use nalgebra::Matrix3;

/// WGS-84 semi-major axis (m) and first eccentricity squared.
pub const WGS84_A_M: f64 = 6_378_137.0;
pub const WGS84_E2: f64 = 6.694_379_990_141_316e-3;

/// 1e-7 degrees in one degree.
const E7: f64 = 1e7;
/// One turn in 1e-7 degrees.
const TURN_E7: i64 = 3_600_000_000;

/// A longitude in degrees on [-180, 180).
pub fn wrap_lon_deg(lon_deg: f64) -> f64 {
    let w = (lon_deg + 180.0).rem_euclid(360.0) - 180.0;
    // rem_euclid may return 360.0 for a tiny negative argument.
    if w >= 180.0 { w - 360.0 } else { w }
}

/// Latitude in 1e-7 degrees (MAVLink `degE7`), rounded to nearest:
/// ±90° is ±900 000 000 exactly. `None` for a non-finite latitude or one
/// beyond the poles (never a valid solution).
pub fn lat_e7(lat_rad: f64) -> Option<i32> {
    let v = (lat_rad.to_degrees() * E7).round();
    (v.is_finite() && v.abs() <= 900_000_000.0).then_some(v as i32)
}

/// Longitude in 1e-7 degrees, rounded to nearest and wrapped onto
/// [-1 800 000 000, 1 800 000 000): the antimeridian is -180°, and a
/// longitude that rounds up to +180° is sent as -180° (the same meridian).
/// `None` for a non-finite longitude.
pub fn lon_e7(lon_rad: f64) -> Option<i32> {
    if !lon_rad.is_finite() {
        return None;
    }
    // Wrap first (in degrees, exact for |λ| < 2^52 ulp), round, then wrap
    // the rounded integer so that 179.99999996° → -1 800 000 000.
    let v = (wrap_lon_deg(lon_rad.to_degrees()) * E7).round() as i64;
    let w = (v + TURN_E7 / 2).rem_euclid(TURN_E7) - TURN_E7 / 2;
    Some(w as i32)
}

/// A heading (rad, clockwise from north) in centidegrees as MAVLink's
/// `GPS_INPUT.yaw` wants it: 1..=36000, north is 36000 (0 means "not
/// available").
pub fn heading_cdeg(heading_rad: f64) -> Option<u16> {
    if !heading_rad.is_finite() {
        return None;
    }
    let cd = (heading_rad.to_degrees().rem_euclid(360.0) * 100.0).round() as u32;
    Some(if cd == 0 || cd >= 36_000 {
        36_000
    } else {
        cd as u16
    })
}

/// A heading or course in degrees on [0, 360).
pub fn heading_deg(heading_rad: f64) -> f64 {
    let d = heading_rad.to_degrees().rem_euclid(360.0);
    if d >= 360.0 { 0.0 } else { d }
}

/// A latitude or longitude as NMEA 0183 writes it: whole degrees (`dd` or
/// `ddd`), minutes with `decimals` decimals, and the hemisphere letter.
/// Rounding is done once on the whole value in units of the last digit,
/// so 59.9999999' carries into the next degree instead of printing 60'.
/// The longitude is wrapped onto [-180°, 180°) first; the antimeridian is
/// written `18000.000…,W`.
pub fn nmea_angle(deg: f64, decimals: u32, is_lat: bool) -> Option<String> {
    if !deg.is_finite() {
        return None;
    }
    let deg = if is_lat { deg } else { wrap_lon_deg(deg) };
    if is_lat && deg.abs() > 90.0 {
        return None;
    }
    let per_minute = 10u64.pow(decimals);
    let per_degree = 60 * per_minute;
    let mut units = (deg.abs() * per_degree as f64).round() as u64;
    let mut negative = deg < 0.0;
    if !is_lat && units >= 180 * per_degree {
        // +180° after rounding: the same meridian as -180°.
        units = 180 * per_degree;
        negative = true;
    }
    let whole = units / per_degree;
    let rest = units % per_degree;
    let (min, frac) = (rest / per_minute, rest % per_minute);
    let hemi = match (is_lat, negative && units != 0) {
        (true, false) => 'N',
        (true, true) => 'S',
        (false, false) => 'E',
        (false, true) => 'W',
    };
    let width = if is_lat { 2 } else { 3 };
    Some(if decimals == 0 {
        format!("{whole:0width$}{min:02},{hemi}")
    } else {
        format!(
            "{whole:0width$}{min:02}.{frac:0d$},{hemi}",
            d = decimals as usize
        )
    })
}

/// The EGM96 geoid undulation N (m, geoid above the WGS-84 ellipsoid) at a
/// geodetic latitude and longitude: the NGA's spherical-harmonic model to
/// degree and order 360 (crate `egm96`, its coefficients built in). A
/// height above mean sea level is `h − N`. At the poles the series has no
/// longitude term, so N is one value per pole whatever the longitude.
/// About 1 ms per call (a degree-360 series): the bridges evaluate it once
/// per solution they send, not per solution received.
pub fn geoid_undulation_m(lat_rad: f64, lon_rad: f64) -> f64 {
    egm96::egm96_compute_altitude_offset(
        lat_rad.to_degrees().clamp(-90.0, 90.0),
        wrap_lon_deg(lon_rad.to_degrees()),
    )
}

/// Prime-vertical radius of curvature N(L) (m).
pub fn prime_vertical_radius_m(lat_rad: f64) -> f64 {
    let s = lat_rad.sin();
    WGS84_A_M / (1.0 - WGS84_E2 * s * s).sqrt()
}

/// Geodetic to ECEF (m): exact at the poles and for any longitude.
pub fn geodetic_to_ecef(lat_rad: f64, lon_rad: f64, h_m: f64) -> [f64; 3] {
    let n = prime_vertical_radius_m(lat_rad);
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
    [
        (n + h_m) * cl * co,
        (n + h_m) * cl * so,
        (n * (1.0 - WGS84_E2) + h_m) * sl,
    ]
}

/// `C_e^n`: ECEF axes to the local north-east-down axes at (L, λ). At the
/// pole the north and east axes are those of the meridian λ.
pub fn c_e_ned(lat_rad: f64, lon_rad: f64) -> Matrix3<f64> {
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
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

/// How far the direction of true north at the solution's position is
/// uncertain because the position is (rad, 1σ): an east error δx moves the
/// meridian by δx·tan|L|/N(L). Infinite at the exact pole, where true north
/// depends on the longitude alone.
pub fn meridian_convergence_sigma_rad(lat_rad: f64, sigma_h_m: f64) -> f64 {
    if lat_rad.abs() >= FRAC_PI_2 {
        return f64::INFINITY;
    }
    sigma_h_m * lat_rad.abs().tan() / prime_vertical_radius_m(lat_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn lat_e7_is_exact_at_both_poles_and_the_equator() {
        assert_eq!(lat_e7(FRAC_PI_2), Some(900_000_000));
        assert_eq!(lat_e7(-FRAC_PI_2), Some(-900_000_000));
        assert_eq!(lat_e7(0.0), Some(0));
        assert_eq!(lat_e7(89.999_999_96_f64.to_radians()), Some(900_000_000));
        assert_eq!(lat_e7(f64::NAN), None);
        assert_eq!(lat_e7(1.6), None);
    }

    #[test]
    fn lon_e7_wraps_across_the_antimeridian() {
        assert_eq!(lon_e7(PI), Some(-1_800_000_000));
        assert_eq!(lon_e7(-PI), Some(-1_800_000_000));
        assert_eq!(
            lon_e7(179.999_999_96_f64.to_radians()),
            Some(-1_800_000_000)
        );
        assert_eq!(lon_e7(179.999_999_9_f64.to_radians()), Some(1_799_999_999));
        assert_eq!(
            lon_e7(-179.999_999_9_f64.to_radians()),
            Some(-1_799_999_999)
        );
        assert_eq!(lon_e7(190f64.to_radians()), Some(-1_700_000_000));
        assert_eq!(lon_e7(-190f64.to_radians()), Some(1_700_000_000));
        assert_eq!(lon_e7(3.0 * PI), Some(-1_800_000_000));
        assert_eq!(lon_e7(f64::INFINITY), None);
        // Every longitude of a crossing decodes to within half a unit.
        for k in -2000..=2000 {
            let lon = 180.0 + k as f64 * 1.234_567e-5;
            let e7 = lon_e7(lon.to_radians()).unwrap();
            let back = e7 as f64 * 1e-7;
            let d = (back - lon + 180.0).rem_euclid(360.0) - 180.0;
            assert!(d.abs() <= 0.5e-7 + 1e-12, "{lon} -> {e7}");
        }
    }

    #[test]
    fn heading_north_is_36000_centidegrees_never_zero() {
        assert_eq!(heading_cdeg(0.0), Some(36_000));
        assert_eq!(heading_cdeg(2.0 * PI), Some(36_000));
        assert_eq!(heading_cdeg(-1e-9), Some(36_000));
        assert_eq!(heading_cdeg(PI / 2.0), Some(9_000));
        assert_eq!(heading_cdeg(-PI / 2.0), Some(27_000));
        assert_eq!(heading_cdeg(f64::NAN), None);
    }

    #[test]
    fn nmea_angles_carry_rounding_and_wrap_the_antimeridian() {
        assert_eq!(nmea_angle(90.0, 5, true).unwrap(), "9000.00000,N");
        assert_eq!(nmea_angle(-90.0, 5, true).unwrap(), "9000.00000,S");
        assert_eq!(nmea_angle(0.0, 5, true).unwrap(), "0000.00000,N");
        assert_eq!(nmea_angle(180.0, 5, false).unwrap(), "18000.00000,W");
        assert_eq!(nmea_angle(-180.0, 5, false).unwrap(), "18000.00000,W");
        assert_eq!(
            nmea_angle(179.999_999_999, 5, false).unwrap(),
            "18000.00000,W"
        );
        assert_eq!(nmea_angle(-179.5, 5, false).unwrap(), "17930.00000,W");
        assert_eq!(nmea_angle(179.5, 5, false).unwrap(), "17930.00000,E");
        assert_eq!(nmea_angle(12.999_999_999, 5, true).unwrap(), "1300.00000,N");
        assert_eq!(nmea_angle(48.1173, 4, true).unwrap(), "4807.0380,N");
        assert_eq!(nmea_angle(11.516_666_67, 3, false).unwrap(), "01131.000,E");
        assert!(nmea_angle(91.0, 5, true).is_none());
    }

    /// The NGA's published check points of EGM96 (its distribution's six
    /// test points: latitude, longitude east, undulation in m, given to
    /// 1 mm). Those values come from its program that interpolates the 15'
    /// grid; the spherical-harmonic synthesis here agrees within 3.2 mm.
    #[test]
    fn geoid_matches_the_nga_check_points() {
        let points = [
            (38.628_155, 269.779_155, -31.628),
            (-14.621_217, 305.021_114, -2.969),
            (46.874_319, 102.448_729, -43.575),
            (-23.617_446, 133.874_712, 15.871),
            (38.625_473, 359.999_500, 50.066),
            (-0.466_744, 0.002_300, 17.329),
        ];
        let mut worst = 0f64;
        for (lat, lon, n) in points {
            let got = geoid_undulation_m(f64::to_radians(lat), f64::to_radians(lon));
            worst = worst.max((got - n).abs());
        }
        assert!(worst < 0.005, "largest difference {worst} m");
    }

    /// At each pole the undulation is one value whatever the longitude
    /// (EGM96: +13.61 m at the North Pole, −29.53 m at the South Pole).
    #[test]
    fn geoid_at_the_poles_is_independent_of_longitude() {
        for (lat, n) in [(FRAC_PI_2, 13.61), (-FRAC_PI_2, -29.53)] {
            let n0 = geoid_undulation_m(lat, 0.0);
            assert!((n0 - n).abs() < 0.02, "{lat}: {n0}");
            for lon in [-PI, -2.0, 1.0, PI] {
                let x = geoid_undulation_m(lat, lon);
                assert!((x - n0).abs() < 1e-6, "{lat} {lon}: {x} vs {n0}");
            }
        }
        // Continuous across the antimeridian.
        let a = geoid_undulation_m(0.5, PI - 1e-9);
        let b = geoid_undulation_m(0.5, -PI + 1e-9);
        assert!((a - b).abs() < 1e-4, "{a} {b}");
    }

    #[test]
    fn ned_axes_are_orthonormal_at_the_pole() {
        for lat in [FRAC_PI_2, -FRAC_PI_2, 1.0] {
            let c = c_e_ned(lat, 0.3);
            let e = c * c.transpose() - Matrix3::identity();
            assert!(e.abs().max() < 1e-15);
            assert!((c.determinant() - 1.0).abs() < 1e-15);
        }
        // Down at the North Pole is -z.
        let c = c_e_ned(FRAC_PI_2, 2.0);
        assert!((c[(2, 2)] + 1.0).abs() < 1e-15);
    }

    #[test]
    #[allow(clippy::float_cmp)] // infinity and zero are exact
    fn convergence_grows_to_infinity_at_the_pole() {
        assert_eq!(
            meridian_convergence_sigma_rad(FRAC_PI_2, 10.0),
            f64::INFINITY
        );
        assert_eq!(
            meridian_convergence_sigma_rad(-FRAC_PI_2, 10.0),
            f64::INFINITY
        );
        assert!(meridian_convergence_sigma_rad(0.0, 10.0) == 0.0);
        let near = meridian_convergence_sigma_rad(89.99f64.to_radians(), 10.0);
        // 1.1 km from the pole, 10 m of position error: about 0.5°.
        assert!(
            (near.to_degrees() - 0.51).abs() < 0.02,
            "{}",
            near.to_degrees()
        );
    }
}
