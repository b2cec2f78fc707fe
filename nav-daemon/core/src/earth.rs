//! WGS-84 Earth model: radii, normal gravity, geodetic↔ECEF, ISA atmosphere.
//! Stateless: every function is pure.

use nalgebra::Vector3;

/// Semi-major axis a (m).
pub const A: f64 = 6_378_137.0;
/// Flattening f.
pub const F: f64 = 1.0 / 298.257_223_563;
/// Semi-minor axis b = a(1 − f) (m).
pub const B: f64 = A * (1.0 - F);
/// First eccentricity squared e² = f(2 − f).
pub const E2: f64 = F * (2.0 - F);
/// Earth rotation rate ω_ie (rad/s).
pub const OMEGA_IE: f64 = 7.292_115_146_7e-5;
/// Normal gravity at the equator γ_e (m/s²).
pub const GAMMA_E: f64 = 9.780_325_335_9;
/// Somigliana constant k.
pub const GRAVITY_K: f64 = 0.001_931_852_652_41;
/// m = ω²a²b/GM.
pub const GRAVITY_M: f64 = 0.003_449_786_506_84;
/// Standard gravity g0 (m/s²), used for unit conversions (µg) and geopotential height.
pub const G0: f64 = 9.806_65;

/// Earth rotation vector in ECEF.
pub fn omega_ie_e() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, OMEGA_IE)
}

/// A geodetic position: latitude, longitude (rad), ellipsoidal height (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geodetic {
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub h_m: f64,
}

impl Geodetic {
    pub fn new(lat_rad: f64, lon_rad: f64, h_m: f64) -> Self {
        Self {
            lat_rad,
            lon_rad,
            h_m,
        }
    }
    pub fn from_deg(lat_deg: f64, lon_deg: f64, h_m: f64) -> Self {
        Self::new(lat_deg.to_radians(), lon_deg.to_radians(), h_m)
    }
}

/// Meridian and prime-vertical radii of curvature (R_M, R_N) at latitude `lat`.
pub fn radii(lat_rad: f64) -> (f64, f64) {
    radii_from_sin(lat_rad.sin())
}

/// Metres per radian of latitude and of longitude at `lat_rad`, `h_m`: the
/// meridian arc (R_M + h) and the parallel's radius (R_N + h)·cos φ. A small
/// Δlatitude, Δlongitude (a CNS innovation in g) times these is north and
/// east in metres.
pub fn metres_per_radian(lat_rad: f64, h_m: f64) -> [f64; 2] {
    let (rm, rn) = radii(lat_rad);
    [rm + h_m, (rn + h_m) * lat_rad.cos()]
}

/// [`radii`] from sin L.
pub fn radii_from_sin(sin_lat: f64) -> (f64, f64) {
    let s2 = sin_lat * sin_lat;
    let w2 = 1.0 - E2 * s2;
    let rn = A / w2.sqrt();
    let rm = rn * (1.0 - E2) / w2;
    (rm, rn)
}

/// WGS-84 normal gravity magnitude at latitude `lat` and height `h`
/// (Somigliana with the second-order height correction of DESIGN).
pub fn normal_gravity(lat_rad: f64, h_m: f64) -> f64 {
    normal_gravity_from_sin(lat_rad.sin(), h_m)
}

/// [`normal_gravity`] from sin L.
pub fn normal_gravity_from_sin(sin_lat: f64, h_m: f64) -> f64 {
    let s2 = sin_lat * sin_lat;
    let g0 = GAMMA_E * (1.0 + GRAVITY_K * s2) / (1.0 - E2 * s2).sqrt();
    let hf =
        1.0 - (2.0 / A) * (1.0 + F + GRAVITY_M - 2.0 * F * s2) * h_m + 3.0 * h_m * h_m / (A * A);
    g0 * hf
}

/// Unit ellipsoid normal (local up) in ECEF.
pub fn up_e(lat_rad: f64, lon_rad: f64) -> Vector3<f64> {
    let (sl, cl) = lat_rad.sin_cos();
    let (so, co) = lon_rad.sin_cos();
    Vector3::new(cl * co, cl * so, sl)
}

/// Geodetic → ECEF (exact).
pub fn geodetic_to_ecef(p: &Geodetic) -> Vector3<f64> {
    let (sl, cl) = p.lat_rad.sin_cos();
    let (so, co) = p.lon_rad.sin_cos();
    let (_, rn) = radii(p.lat_rad);
    Vector3::new(
        (rn + p.h_m) * cl * co,
        (rn + p.h_m) * cl * so,
        (rn * (1.0 - E2) + p.h_m) * sl,
    )
}

/// ECEF → geodetic, closed form of Vermeille (2004); exact to numerical
/// precision everywhere outside the Earth's deep interior, including on the
/// polar axis (longitude 0 there) and across ±180° (longitude in (−π, π]).
pub fn ecef_to_geodetic(r: &Vector3<f64>) -> Geodetic {
    ecef_to_geodetic_trig(r).geo
}

/// A geodetic position with the sines and cosines of its latitude and
/// longitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeodeticTrig {
    pub geo: Geodetic,
    pub sin_lat: f64,
    pub cos_lat: f64,
    pub sin_lon: f64,
    pub cos_lon: f64,
}

/// [`ecef_to_geodetic`] with the sines and cosines that its intermediate
/// results give without trigonometry: the latitude is 2·atan2(z, d + dz)
/// with dz = √(d² + z²) and d ≥ 0, i.e. the angle of the vector (d, z)
/// (half-angle identity), so sin L = z/dz and cos L = d/dz; off the polar
/// axis sin λ = y/ρ and cos λ = x/ρ. On the axis (ρ = 0, where d = 0 and
/// the longitude is atan2's of the zeros) they are the longitude's own.
/// Two `sin_cos` fewer per conversion than taking them of the angles, and
/// equal to them within 2 ulp (test `trig_from_the_closed_form_is_that_of_its_angles`).
pub fn ecef_to_geodetic_trig(r: &Vector3<f64>) -> GeodeticTrig {
    let (x, y, z) = (r.x, r.y, r.z);
    let e4 = E2 * E2;
    let a2 = A * A;
    let rho2 = x * x + y * y;
    let p = rho2 / a2;
    let q = (1.0 - E2) / a2 * z * z;
    let rr = (p + q - e4) / 6.0;
    let s = e4 * p * q / (4.0 * rr * rr * rr);
    let t = cbrt(1.0 + s + (s * (2.0 + s)).sqrt());
    let u = rr * (1.0 + t + 1.0 / t);
    let v = (u * u + e4 * q).sqrt();
    let w = E2 * (u + v - q) / (2.0 * v);
    let k = (u + v + w * w).sqrt() - w;
    let rho = rho2.sqrt();
    let d = k * rho / (k + E2);
    let dz = (d * d + z * z).sqrt();
    let lat = 2.0 * z.atan2(d + dz);
    let h = (k + E2 - 1.0) / k * dz;
    let lon = y.atan2(x);
    let (sin_lon, cos_lon) = if rho > 0.0 {
        (y / rho, x / rho)
    } else {
        lon.sin_cos()
    };
    let (sin_lat, cos_lat) = if dz > 0.0 {
        (z / dz, d / dz)
    } else {
        lat.sin_cos()
    };
    GeodeticTrig {
        geo: Geodetic::new(lat, lon, h),
        sin_lat,
        cos_lat,
        sin_lon,
        cos_lon,
    }
}

/// The cube root of `x` in [1e-290, 1e290] to within 1 ulp (anything else
/// as `f64::cbrt` has it): an estimate from the
/// exponent's bits divided by three, two Halley steps (cubic
/// convergence: from the estimate's 3 % to 1e-15) and a Newton step on an
/// exact residual.
/// The standard library's is correctly rounded and took a tenth of a
/// campaign's run (the simulator and the navigator convert ECEF to
/// geodetic about 14 times per IMU sample); this one is compared with it
/// over the whole positive range in test `cbrt_within_an_ulp_of_the_correctly_rounded`.
pub fn cbrt(x: f64) -> f64 {
    // Beyond 1e±290 (where 2y³ + x would overflow or y³ lose its bits),
    // zero, negatives, infinities and NaN: the library's.
    if !(1e-290..=1e290).contains(&x) {
        return x.cbrt();
    }
    // (bits − bias)/3 + bias in the exponent field: within about 3 % of
    // the root (the mantissa shares the division).
    const B1: u64 = 715_094_163; // 0x2A9F_7893: fdlibm's bias for the high word
    let mut y = f64::from_bits(x.to_bits() / 3 + (B1 << 32));
    for _ in 0..2 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
    }
    // A last Newton step on a residual y³ − x free of rounding (y² split
    // into its rounded value and its error by a fused multiply-add): the
    // Halley step's own rounding left 2 ulp.
    let y2 = y * y;
    let e2 = y.mul_add(y, -y2);
    let residual = y2.mul_add(y, -x) + e2 * y;
    y - residual / (3.0 * y2)
}

/// Wraps an angle to (−π, π].
pub fn wrap_pi(a: f64) -> f64 {
    use std::f64::consts::TAU;
    // `rem_euclid(TAU)` is `a % TAU`, plus TAU if negative; strictly
    // within ±2π the remainder is `a` itself, exactly (at −2π it is −0), so
    // the same value comes without
    // the call to fmod (which cost as much as the rest of a mechanization
    // step's position update).
    let w = if (0.0..TAU).contains(&a) {
        a
    } else if a > -TAU && a < 0.0 {
        a + TAU
    } else {
        a.rem_euclid(TAU)
    };
    if w > std::f64::consts::PI { w - TAU } else { w }
}

/// ICAO standard atmosphere (troposphere and the isothermal lower
/// stratosphere, 0–20 km geopotential, extended to 32 km with the +1 K/km
/// layer) as functions of geopotential altitude.
pub mod isa {
    use super::G0;

    /// Sea-level pressure (Pa) and temperature (K).
    pub const P0: f64 = 101_325.0;
    pub const T0: f64 = 288.15;
    /// Specific gas constant of dry air (J/(kg·K)).
    pub const R_AIR: f64 = 287.052_87;
    /// Layer bases (geopotential m), lapse rates (K/m).
    const H1: f64 = 11_000.0;
    const H2: f64 = 20_000.0;
    const H3: f64 = 32_000.0;
    const L0: f64 = -0.0065;
    const L2: f64 = 0.001;
    const T1: f64 = T0 + L0 * H1; // 216.65 K

    fn p1() -> f64 {
        P0 * (T1 / T0).powf(-G0 / (L0 * R_AIR))
    }
    fn p2() -> f64 {
        p1() * (-G0 * (H2 - H1) / (R_AIR * T1)).exp()
    }

    /// Geopotential altitude H from geometric altitude z (both m), with the
    /// ICAO Earth radius convention r0 = 6356766 m.
    pub fn geopotential_from_geometric(z_m: f64) -> f64 {
        const R0: f64 = 6_356_766.0;
        R0 * z_m / (R0 + z_m)
    }
    /// Inverse of [`geopotential_from_geometric`].
    pub fn geometric_from_geopotential(hgp_m: f64) -> f64 {
        const R0: f64 = 6_356_766.0;
        R0 * hgp_m / (R0 - hgp_m)
    }
    /// Temperature (K) at geopotential altitude H (m).
    pub fn temperature(hgp_m: f64) -> f64 {
        if hgp_m <= H1 {
            T0 + L0 * hgp_m
        } else if hgp_m <= H2 {
            T1
        } else {
            T1 + L2 * (hgp_m - H2)
        }
    }

    /// Pressure (Pa) at geopotential altitude H (m), valid up to 32 km.
    pub fn pressure(hgp_m: f64) -> f64 {
        if hgp_m <= H1 {
            P0 * (temperature(hgp_m) / T0).powf(-G0 / (L0 * R_AIR))
        } else if hgp_m <= H2 {
            p1() * (-G0 * (hgp_m - H1) / (R_AIR * T1)).exp()
        } else {
            p2() * (temperature(hgp_m) / T1).powf(-G0 / (L2 * R_AIR))
        }
    }

    /// Geopotential pressure altitude (m) of a static pressure (Pa); inverse of [`pressure`].
    pub fn pressure_altitude(p_pa: f64) -> f64 {
        if p_pa >= p1() {
            T0 / L0 * ((p_pa / P0).powf(-L0 * R_AIR / G0) - 1.0)
        } else if p_pa >= p2() {
            H1 - R_AIR * T1 / G0 * (p_pa / p1()).ln()
        } else {
            H2 + T1 / L2 * ((p_pa / p2()).powf(-L2 * R_AIR / G0) - 1.0)
        }
    }

    /// Upper end of the modelled atmosphere (geopotential m).
    pub const MAX_ALTITUDE_M: f64 = H3;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast path of `wrap_pi` gives `rem_euclid`'s result bit for bit:
    /// at the edges (±0, ±π, ±2π and their neighbours), inside, outside
    /// and for NaN.
    #[test]
    fn wrap_pi_is_rem_euclids_bit_for_bit() {
        use std::f64::consts::{PI, TAU};
        let reference = |a: f64| {
            let w = a.rem_euclid(TAU);
            if w > PI { w - TAU } else { w }
        };
        let mut values = vec![
            0.0,
            -0.0,
            PI,
            -PI,
            TAU,
            -TAU,
            3.0 * PI,
            -3.0 * PI,
            1e300,
            -1e300,
        ];
        for e in [PI, -PI, TAU, -TAU, 0.0] {
            values.push(f64::from_bits(e.to_bits() + 1));
            values.push(f64::from_bits(e.to_bits().wrapping_sub(1)));
        }
        let mut s = 11u64;
        for _ in 0..100_000 {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            values.push(((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 30.0);
        }
        for a in values {
            assert_eq!(wrap_pi(a).to_bits(), reference(a).to_bits(), "{a:e}");
        }
        assert!(wrap_pi(f64::NAN).is_nan());
    }
    use std::f64::consts::{FRAC_PI_2, PI};

    /// Independent inverse: Newton iteration on latitude (Bowring form), used
    /// only to cross-check the closed form away from the axis.
    fn ecef_to_geodetic_iterative(r: &Vector3<f64>) -> Geodetic {
        let rho = (r.x * r.x + r.y * r.y).sqrt();
        let mut lat = r.z.atan2(rho * (1.0 - E2));
        let mut h = 0.0;
        for _ in 0..50 {
            let (_, rn) = radii(lat);
            h = rho / lat.cos() - rn;
            lat = r.z.atan2(rho * (1.0 - E2 * rn / (rn + h)));
        }
        Geodetic::new(lat, r.y.atan2(r.x), h)
    }

    #[test]
    fn geodetic_ecef_round_trip_below_a_millimetre_including_poles_and_antimeridian() {
        let lats = [
            -90.0,
            -89.999_999,
            -89.9,
            -70.0,
            -45.0,
            -1e-9,
            0.0,
            30.0,
            69.5,
            88.0,
            89.999_999_9,
            90.0,
        ];
        let lons = [
            -180.0,
            -179.999_999,
            -90.0,
            0.0,
            45.0,
            90.0,
            179.999_999,
            180.0,
        ];
        let hs = [-500.0, 0.0, 18_000.0, 100_000.0];
        let mut worst: f64 = 0.0;
        for &lat in &lats {
            for &lon in &lons {
                for &h in &hs {
                    let g = Geodetic::from_deg(lat, lon, h);
                    let r = geodetic_to_ecef(&g);
                    let back = ecef_to_geodetic(&r);
                    let r2 = geodetic_to_ecef(&back);
                    let err = (r2 - r).norm();
                    worst = worst.max(err);
                    assert!(err < 1e-3, "lat {lat} lon {lon} h {h}: {err} m");
                    assert!((back.h_m - h).abs() < 1e-3, "height at {lat},{lon},{h}");
                    assert!(
                        (back.lat_rad - g.lat_rad).abs() < 1e-3 / A,
                        "lat at {lat},{lon}"
                    );
                    if lat.abs() < 90.0 {
                        let dlon = wrap_pi(back.lon_rad - g.lon_rad);
                        assert!(
                            dlon.abs() * A * g.lat_rad.cos() < 1e-3,
                            "lon at {lat},{lon}"
                        );
                    }
                }
            }
        }
        assert!(worst < 1e-6, "worst round trip {worst} m");
    }

    #[test]
    fn ecef_z_uses_the_corrected_eq_23_term() {
        // papers/001 eq (23) erratum: z = (R_N(1 − e²) + h) sin L, and R_N(1 − e²) = R_N(1 − f)².
        assert!(((1.0 - E2) - (1.0 - F).powi(2)).abs() < 1e-16);
        let g = Geodetic::from_deg(60.0, 0.0, 0.0);
        let (_, rn) = radii(g.lat_rad);
        let z = geodetic_to_ecef(&g).z;
        assert!((z - rn * (1.0 - F).powi(2) * g.lat_rad.sin()).abs() < 1e-8);
        // The extraction's R_N(1 − f²) would put the point ~21 km off the ellipsoid.
        let wrong = rn * (1.0 - F * F) * g.lat_rad.sin();
        assert!((wrong - z).abs() > 10_000.0);
    }

    #[test]
    fn exact_poles_give_plus_minus_ninety() {
        for (z_sign, lat) in [(1.0, FRAC_PI_2), (-1.0, -FRAC_PI_2)] {
            let r = Vector3::new(0.0, 0.0, z_sign * (B + 18_000.0));
            let g = ecef_to_geodetic(&r);
            assert!((g.lat_rad - lat).abs() < 1e-15);
            assert!((g.h_m - 18_000.0).abs() < 1e-6, "{}", g.h_m);
        }
    }

    /// Log-uniform over [2^-1022, 2^1024) and the values the geodetic
    /// conversion takes (1 to 2, its argument's range above the Earth's
    /// deep interior), against the standard library's correctly rounded
    /// root: within 1 ulp, and exact on perfect cubes.
    #[test]
    fn cbrt_within_an_ulp_of_the_correctly_rounded() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let mut worst = 0;
        for i in 0..400_000 {
            let x = if i % 2 == 0 {
                (2f64).powf(-1022.0 + 2045.9 * next())
            } else {
                1.0 + next()
            };
            let d = ulps(cbrt(x), x.cbrt());
            assert!(
                d <= 1,
                "cbrt({x:e}) = {:e}, correctly rounded {:e}",
                cbrt(x),
                x.cbrt()
            );
            worst = worst.max(d);
        }
        for k in 1..2000u32 {
            let c = f64::from(k);
            assert_eq!(cbrt(c * c * c).to_bits(), c.to_bits(), "{c}");
        }
        for x in [0.0, -0.0, -8.0, 1e-310, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(cbrt(x).to_bits(), x.cbrt().to_bits(), "{x:e}");
        }
        assert!(cbrt(f64::NAN).is_nan());
        assert!(worst <= 1);
    }

    /// The sines and cosines from the closed form's intermediates against
    /// those of the angles it returns, over the whole sphere (the poles,
    /// the axis and ±180° among them) and heights from −10 km to 1000 km.
    #[test]
    fn trig_from_the_closed_form_is_that_of_its_angles() {
        let mut worst = 0.0f64;
        for lat in (-900..=900).step_by(25).map(|l| f64::from(l) / 10.0) {
            for lon in [
                -180.0, -179.999, -90.0, -1e-7, 0.0, 33.0, 120.0, 179.99, 180.0,
            ] {
                for h in [-10_000.0, 0.0, 18_000.0, 1e6] {
                    let r = geodetic_to_ecef(&Geodetic::from_deg(lat, lon, h));
                    let t = ecef_to_geodetic_trig(&r);
                    assert_eq!(t.geo, ecef_to_geodetic(&r));
                    let (sl, cl) = t.geo.lat_rad.sin_cos();
                    let (so, co) = t.geo.lon_rad.sin_cos();
                    for (a, b) in [
                        (t.sin_lat, sl),
                        (t.cos_lat, cl),
                        (t.sin_lon, so),
                        (t.cos_lon, co),
                    ] {
                        worst = worst.max((a - b).abs());
                        assert!(
                            (a - b).abs() <= 4.0 * f64::EPSILON,
                            "{lat} {lon} {h}: {a:e} vs {b:e}"
                        );
                    }
                    let unit = |s: f64, c: f64| (s * s + c * c - 1.0).abs();
                    assert!(unit(t.sin_lat, t.cos_lat) <= 4.0 * f64::EPSILON);
                    assert!(unit(t.sin_lon, t.cos_lon) <= 4.0 * f64::EPSILON);
                }
            }
        }
        // On the axis: longitude 0 (or π for x = −0), and its own sin/cos.
        for z in [B + 18_000.0, -(B + 18_000.0)] {
            let t = ecef_to_geodetic_trig(&Vector3::new(0.0, 0.0, z));
            assert_eq!((t.sin_lon, t.cos_lon), t.geo.lon_rad.sin_cos());
            assert_eq!(t.cos_lat.to_bits(), 0f64.to_bits());
            assert_eq!(t.sin_lat.to_bits(), z.signum().to_bits());
        }
        assert!(worst > 0.0, "the two computations are not the same one");
    }

    #[test]
    fn closed_form_inverse_agrees_with_newton_iteration() {
        for &lat in &[-80.0, -33.3, 0.5, 45.0, 75.0, 85.0] {
            for &lon in &[-170.0, 10.0, 120.0] {
                let r = geodetic_to_ecef(&Geodetic::from_deg(lat, lon, 12_345.0));
                let a = ecef_to_geodetic(&r);
                let b = ecef_to_geodetic_iterative(&r);
                assert!((a.lat_rad - b.lat_rad).abs() < 1e-13);
                assert!((a.h_m - b.h_m).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn longitude_stays_in_half_open_range_across_antimeridian() {
        let g = ecef_to_geodetic(&geodetic_to_ecef(&Geodetic::from_deg(10.0, 180.0, 0.0)));
        assert!(g.lon_rad > -PI && g.lon_rad <= PI);
        assert!((wrap_pi(g.lon_rad - PI)).abs() < 1e-14);
        assert!((wrap_pi(3.0 * PI) - PI).abs() < 1e-15);
    }

    #[test]
    fn normal_gravity_matches_published_values() {
        // WGS-84 normal gravity on the ellipsoid: equator 9.7803253359, pole 9.8321849378.
        assert!((normal_gravity(0.0, 0.0) - 9.780_325_335_9).abs() < 1e-10);
        assert!((normal_gravity(FRAC_PI_2, 0.0) - 9.832_184_937_8).abs() < 1e-8);
        // Free-air gradient ≈ −3.086e-6 s⁻² at mid latitudes.
        let dg = (normal_gravity(0.785, 100.0) - normal_gravity(0.785, -100.0)) / 200.0;
        assert!((dg + 3.086e-6).abs() < 0.01e-6, "{dg}");
    }

    #[test]
    fn radii_match_finite_difference_of_the_meridian_arc() {
        // R_M = |d r / dL| along a meridian, R_N·cosL = |d r / dλ|, at h = 0.
        for &lat in &[0.1_f64, 0.7, 1.3] {
            let d = 1e-6;
            let r = |l: f64, o: f64| geodetic_to_ecef(&Geodetic::new(l, o, 0.0));
            let rm_fd = (r(lat + d, 0.3) - r(lat - d, 0.3)).norm() / (2.0 * d);
            let rn_fd = (r(lat, 0.3 + d) - r(lat, 0.3 - d)).norm() / (2.0 * d) / lat.cos();
            let (rm, rn) = radii(lat);
            assert!((rm - rm_fd).abs() < 1e-3, "{rm} {rm_fd}");
            assert!((rn - rn_fd).abs() < 1e-3, "{rn} {rn_fd}");
        }
    }

    #[test]
    fn isa_matches_standard_table_and_inverts() {
        // ICAO table: 11 km 22632.06 Pa, 20 km 5474.89 Pa, 5 km 54019.9 Pa.
        assert!((isa::pressure(11_000.0) - 22_632.06).abs() < 0.1);
        assert!((isa::pressure(20_000.0) - 5_474.89).abs() < 0.1);
        assert!((isa::pressure(5_000.0) - 54_019.9).abs() < 1.0);
        assert!((isa::temperature(15_000.0) - 216.65).abs() < 1e-9);
        for h in [
            0.0, 1500.0, 10_999.0, 11_001.0, 18_000.0, 19_999.0, 20_001.0, 25_000.0,
        ] {
            let back = isa::pressure_altitude(isa::pressure(h));
            assert!((back - h).abs() < 1e-6, "{h} -> {back}");
        }
        let z = 18_000.0;
        let hgp = isa::geopotential_from_geometric(z);
        assert!((hgp - 17_949.2).abs() < 0.5, "{hgp}");
        assert!((isa::geometric_from_geopotential(hgp) - z).abs() < 1e-9);
    }
}
