//! Magnetometer heading (issue 30, item 2; paper 003 §4.4 uses the
//! magnetometer for heading only): the horizontal direction of the
//! calibrated field against the World Magnetic Model's.
//!
//! **Calibration.** The sample is the raw field `b_raw` in body axes (x
//! right, y forward, z up), nT. Hard iron (a field fixed to the body, `h`)
//! and soft iron (a linear distortion, `S`: `b_raw = S b + h`) come from
//! the settings as `h` and the inverse `W = S⁻¹`:
//!
//! b = W (b_raw − h).
//!
//! **Reference.** The World Magnetic Model (WMM2025, 2025–2030; WMM2020
//! before it) from the `world_magnetic_model` crate, evaluated at the
//! nominal position and at the sample's UTC date (sensor time 0 is the
//! settings' `epoch_utc`). Its north, east, down components become
//! B_e(p) in ECEF and m_n = C_e^n B_e in the axes of the navigation frame
//! in use (g or G, whose third axis is up in both).
//!
//! **Innovation.** With b_n = C_b^n b (the calibrated field in nav axes
//! through the computed attitude), one component: the angle about up
//! from the horizontal projection of b_n to that of m_n,
//!
//! z = atan2(b_x m_y − b_y m_x, b_x m_x + b_y m_y)   (rad, wrapped to ±π),
//!
//! formed in nav axes, so the same formula holds in g and in G and at the
//! pole. It is the heading error (less the measurement noise) plus the
//! tilt error's share through the field's vertical component: with
//! δx = computed − true, C_b^ĉ = (I − φ×) C_b^n, b_n = (I − φ×) m_n at the
//! truth, so ∂b_n/∂φ = (b_n×); the reference at the computed position is
//! (I − θ×) C_e^n(p) B_e(p̂) with θ = Θ δp (the frame rotation,
//! [`super::frame_rotation_per_position_error`]) and B_e(p̂) = B_e(p) +
//! J δr^e (J = ∂B_e/∂r^e, the model's own gradient, by central differences
//! over ±1 km: the declination changes by ~1° per 100–200 km at mid
//! latitudes, 0.9–1.7e-7 rad/m, as much as the frame rotation's 1/R =
//! 1.6e-7 rad/m, and far more near a magnetic pole):
//!
//! H_φ = g_bᵀ (b_n×),   H_δp = g_mᵀ ((m_n×) Θ + C_e^n J T3),
//!
//! g_b = ∂z/∂b_n, g_m = ∂z/∂m_n (horizontal), T3 = ∂r^e/∂δp
//! ([`super::ecef_per_position_error`]). H_φ is up (exactly 1) plus tan(I) times the
//! tilt about the horizontal field: that share is the exact linearization
//! (a tilted magnetometer's horizontal field turns with the tilt), not a
//! tilt measurement.
//!
//! **Why one component, not the 3-axis direction.** The direction of a
//! vector observes the two rotations across it: one about the axis in the
//! magnetic meridian plane perpendicular to the field (it moves the field
//! out of the meridian plane: the azimuth, which is this z) and one about
//! magnetic east (it changes only the dip). The dip component would make
//! the magnetometer a tilt aid, which paper 003 does not do: tilt is the
//! accelerometers' (levelling) and the other aids'; the dip is the part
//! most corrupted by the vertical field of the airframe and of WMM's Z
//! error (σ 141 nT, WMM2025 report), and with inclinations of 70–88° in the
//! polar regions it would carry little heading and much disturbance.
//!
//! **R.** The field noise σ (per axis, raised to the settings' floor)
//! through W and C_b^n onto z, plus the WMM declination error model
//! σ_D = √(σ_c² + (σ_v/H)²) (WMM2025 report §3.4: σ_c = 0.26°, σ_v =
//! 5417 nT·°, as the crate gives it at each place) raised to the heading
//! floor. σ_D is a bias that changes over hundreds of km, fused as white:
//! keep the rate low (1–5 Hz) or the floor high where that matters.
//!
//! **Refusals** ([`cause`]), each counted in the status: invalid content;
//! the model's horizontal field below `min_horizontal_nt` (near a magnetic
//! pole the declination is meaningless: this is how the aid disables
//! itself and says why); the calibrated strength far from the model's (a
//! magnetic disturbance); and a date or height outside the model.

use msgs::MagSample;
use nalgebra::{Matrix3, RowVector3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};
use time::format_description::well_known::Rfc3339;
use time::{Date, OffsetDateTime, UtcOffset};
use world_magnetic_model::GeomagneticField;
use world_magnetic_model::uom::si::angle::{degree, radian};
use world_magnetic_model::uom::si::f32::{Angle, Length};
use world_magnetic_model::uom::si::length::meter;
use world_magnetic_model::uom::si::magnetic_flux_density::nanotesla;

use super::{
    Aid, AidError, Context, HeadingFix, Levelled, Measured, Measurement, OwnSettings,
    ecef_per_position_error, frame_rotation_per_position_error,
};
use crate::bounds::{Bound, SettingsError};
use crate::earth::{self, Geodetic};
use crate::error_model::idx;
use crate::frames::{self, skew};
use crate::mech::AnyNav;

/// Why a sample is refused before fusion (its cause counters, in the
/// declaration's order).
pub mod cause {
    /// Non-finite or physically impossible content.
    pub const INVALID: usize = 0;
    /// The model's horizontal field is below `min_horizontal_nt`: near a
    /// magnetic pole, where the declination is meaningless.
    pub const WEAK_HORIZONTAL: usize = 1;
    /// The calibrated field's strength differs from the model's by more
    /// than `max_strength_error_nt`: a magnetic disturbance.
    pub const STRENGTH: usize = 2;
    /// The sample's date or the vehicle's height is outside the model
    /// (WMM: 2020–2029, −1 km to 850 km).
    pub const OUTSIDE_MODEL: usize = 3;
}

/// Largest raw field component a sample may carry (nT): 10 mT, above the
/// full scale of any magnetometer made for the Earth's field (±1.6 mT for
/// a ±16 G part). Beyond it the sample is not a field but corruption.
pub const MAX_RAW_FIELD_NT: f64 = 1e7;

/// Largest stated noise σ per axis (nT): twice the strongest surface field;
/// a sample noisier than that carries no direction.
pub const MAX_SIGMA_NT: f64 = 1e5;

/// Step of the central differences of the model's field over position (m):
/// 1 km, 2000 times the f32 position rounding inside the crate (0.5 m)
/// and 1/1000 of the scale the field varies over.
pub const GRADIENT_STEP_M: f64 = 1000.0;

/// `[aids.mag]`: the calibration, the date of sensor time 0 and the
/// bounds under which the aid refuses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MagSettings {
    /// Hard iron h (nT, body axes): the field fixed to the airframe,
    /// subtracted from the raw sample.
    pub hard_iron_nt: [f64; 3],
    /// Soft iron, the matrix W applied after: b = W (b_raw − h), rows of W
    /// (W = S⁻¹ for a distortion b_raw = S b + h; the identity without
    /// soft iron).
    pub soft_iron: [[f64; 3]; 3],
    /// The UTC instant of sensor time 0 (RFC 3339), at which the model is
    /// evaluated plus each sample's t_ns: the same epoch as gnss-ubx's
    /// `[time] epoch_utc` and `batch --utc-start`. The default, the GPS
    /// epoch, makes t_ns GPS time. A simulated flight sets its own date.
    pub epoch_utc: String,
    /// Below this horizontal field of the model (nT) the aid disables
    /// itself (refusal cause "horizontal field below bound").
    pub min_horizontal_nt: f64,
    /// A sample whose calibrated strength differs from the model's by more
    /// than this (nT) is a magnetic disturbance and is refused.
    pub max_strength_error_nt: f64,
    /// Floor of the per-axis field noise σ (nT): the sample's σ is raised
    /// to it (calibration residuals, the airframe's changing fields).
    pub sigma_floor_nt: f64,
    /// Floor of the heading σ (deg) from the model: the WMM declination
    /// σ_D of the place is raised to it.
    pub sigma_heading_floor_deg: f64,
}

impl Default for MagSettings {
    /// Defaults and their derivation:
    ///
    /// - `min_horizontal_nt` 6000: the WMM's "caution zone" boundary
    ///   (WMM2025 report §1.8: compasses unreliable below 2000 nT, to be
    ///   used with caution below 6000). At H = 6000 nT the model's own
    ///   declination σ is √(0.26² + (5417/6000)²) = 0.94°, and a 100 nT
    ///   uncompensated airframe field adds up to 100/6000 rad = 0.95°:
    ///   below it a heading is worth less than the ~1.3° that a MEMS
    ///   alignment needs.
    /// - `max_strength_error_nt` 5000: 10 % of a mid-latitude field, 36
    ///   times the model's own intensity σ (138 nT): a calibrated sensor in
    ///   a clean field never reaches it, a ferrous object or a current near
    ///   the sensor does.
    /// - `sigma_floor_nt` 100: a calibrated MEMS magnetometer's residual
    ///   (noise 30–300 nT, calibration residual ~100 nT).
    /// - `sigma_heading_floor_deg` 0.26: WMM2025's σ_c, the declination
    ///   error that does not shrink with a strong field.
    fn default() -> Self {
        Self {
            hard_iron_nt: [0.0; 3],
            soft_iron: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            epoch_utc: "1980-01-06T00:00:00Z".to_owned(),
            min_horizontal_nt: 6000.0,
            max_strength_error_nt: 5000.0,
            sigma_floor_nt: 100.0,
            sigma_heading_floor_deg: 0.26,
        }
    }
}

impl MagSettings {
    /// W, the soft-iron matrix.
    pub fn w(&self) -> Matrix3<f64> {
        let s = &self.soft_iron;
        Matrix3::new(
            s[0][0], s[0][1], s[0][2], s[1][0], s[1][1], s[1][2], s[2][0], s[2][1], s[2][2],
        )
    }

    /// The UTC instant of sensor time 0.
    pub fn epoch(&self) -> Option<OffsetDateTime> {
        OffsetDateTime::parse(&self.epoch_utc, &Rfc3339)
            .ok()?
            .checked_to_offset(UtcOffset::UTC)
    }
}

impl OwnSettings for MagSettings {
    fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError> {
        for (i, v) in self.hard_iron_nt.iter().enumerate() {
            Bound {
                lo: -1e5,
                hi: 1e5,
                unit: "nT",
                below: "a hard iron beyond twice the Earth's field saturates the sensor's use",
                above: "a hard iron beyond twice the Earth's field saturates the sensor's use",
            }
            .check(origin, &format!("{table}.hard_iron_nt[{i}]"), *v)?;
        }
        for (i, row) in self.soft_iron.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                Bound {
                    lo: -10.0,
                    hi: 10.0,
                    unit: "",
                    below: "no airframe distorts the field tenfold",
                    above: "no airframe distorts the field tenfold",
                }
                .check(origin, &format!("{table}.soft_iron[{i}][{j}]"), *v)?;
            }
        }
        // W must be invertible and well conditioned: its singular values
        // are the gains of the calibration along its principal axes.
        let sv = self.w().singular_values();
        let (lo, hi) = (sv.min(), sv.max());
        if !(lo >= 0.1 && hi <= 10.0 && hi / lo <= 20.0) {
            return Err(SettingsError {
                origin: origin.to_owned(),
                key: format!("{table}.soft_iron"),
                message: format!(
                    "expected an invertible calibration with singular values in [0.1, 10] and \
                     a condition number of at most 20, got singular values {lo:e} .. {hi:e}: a \
                     singular or near-singular W would make every calibrated field the \
                     noise of one axis"
                ),
            });
        }
        if self.epoch().is_none() {
            return Err(SettingsError {
                origin: origin.to_owned(),
                key: format!("{table}.epoch_utc"),
                message: format!(
                    "expected an RFC 3339 UTC instant such as 1980-01-06T00:00:00Z, got {:?}",
                    self.epoch_utc
                ),
            });
        }
        Bound {
            lo: 2000.0,
            hi: 20_000.0,
            unit: "nT",
            below: "below 2000 nT (the WMM's blackout zone) the model's declination is not \
                    valid and compasses are unreliable",
            above: "above 20 000 nT the aid would be off over most of the polar regions and \
                    much of Canada, Siberia and Antarctica",
        }
        .check(
            origin,
            &format!("{table}.min_horizontal_nt"),
            self.min_horizontal_nt,
        )?;
        Bound {
            lo: 500.0,
            hi: 50_000.0,
            unit: "nT",
            below: "below 3.6 σ of the model's own intensity error (138 nT) good samples \
                    would be refused",
            above: "beyond the whole field the check refuses nothing",
        }
        .check(
            origin,
            &format!("{table}.max_strength_error_nt"),
            self.max_strength_error_nt,
        )?;
        Bound {
            lo: 1.0,
            hi: 1e4,
            unit: "nT",
            below: "no magnetometer's error is below 1 nT: R would make the update \
                    numerically singular",
            above: "a floor above 10 000 nT makes the heading worthless",
        }
        .check(
            origin,
            &format!("{table}.sigma_floor_nt"),
            self.sigma_floor_nt,
        )?;
        Bound {
            lo: 0.01,
            hi: 30.0,
            unit: "deg",
            below: "the WMM's declination is not known to better than 0.26° (WMM2025 σ_c)",
            above: "a heading floor above 30° makes the aid worthless",
        }
        .check(
            origin,
            &format!("{table}.sigma_heading_floor_deg"),
            self.sigma_heading_floor_deg,
        )
    }
}

/// The World Magnetic Model's field at one place and date.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelField {
    /// East, north, up (nT).
    pub b_enu_nt: Vector3<f64>,
    /// 1-σ of the declination (rad), from the model's error model.
    pub sigma_declination_rad: f64,
}

impl ModelField {
    /// Horizontal intensity H (nT).
    pub fn horizontal_nt(&self) -> f64 {
        self.b_enu_nt.x.hypot(self.b_enu_nt.y)
    }
    /// Declination D (rad): from true north to the horizontal field,
    /// positive east.
    pub fn declination_rad(&self) -> f64 {
        self.b_enu_nt.x.atan2(self.b_enu_nt.y)
    }
    /// Inclination I (rad): positive down.
    pub fn inclination_rad(&self) -> f64 {
        (-self.b_enu_nt.z).atan2(self.horizontal_nt())
    }
}

fn outside(what: &'static str, value: f64) -> AidError {
    AidError::Refused {
        cause: cause::OUTSIDE_MODEL,
        what,
        value,
    }
}

/// The UTC date of sensor time `t_ns` (the model changes by at most
/// 0.2°/year: a day's resolution is 5e-4°).
pub fn date_of(t_ns: u64, settings: &MagSettings) -> Result<Date, AidError> {
    let epoch = settings
        .epoch()
        .ok_or(outside("mag: epoch_utc not an RFC 3339 instant", f64::NAN))?;
    let secs = i64::try_from(t_ns / 1_000_000_000)
        .map_err(|_| outside("mag: sample time (s)", t_ns as f64 * 1e-9))?;
    let nanos = (t_ns % 1_000_000_000) as i32;
    epoch
        .checked_add(time::Duration::new(secs, nanos))
        .map(|t| t.date())
        .ok_or(outside("mag: sample time (s)", t_ns as f64 * 1e-9))
}

/// The model's field at `geo` on `date` (any longitude; a date or height
/// outside the model is refused with [`cause::OUTSIDE_MODEL`]).
pub fn model_field(geo: &Geodetic, date: Date) -> Result<ModelField, AidError> {
    if !(geo.lat_rad.is_finite() && geo.lon_rad.is_finite() && geo.h_m.is_finite()) {
        return Err(AidError::NonFinite("mag: position"));
    }
    let lat_deg = geo.lat_rad.to_degrees().clamp(-90.0, 90.0);
    let lon_deg = (geo.lon_rad.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
    let f = GeomagneticField::new(
        Length::new::<meter>(geo.h_m as f32),
        Angle::new::<degree>(lat_deg as f32),
        Angle::new::<degree>(lon_deg.clamp(-180.0, 180.0) as f32),
        date,
    )
    .map_err(|e| match e {
        world_magnetic_model::Error::DateOutsideOfValidityRange { .. } => outside(
            "mag: date outside the magnetic model (year)",
            f64::from(date.year()),
        ),
        world_magnetic_model::Error::HeightOutsideOfValidityRange { .. } => {
            outside("mag: height outside the magnetic model (m)", geo.h_m)
        }
        _ => outside(
            "mag: position outside the magnetic model (lat, deg)",
            lat_deg,
        ),
    })?;
    let nt = |b: world_magnetic_model::uom::si::f32::MagneticFluxDensity| {
        f64::from(b.get::<nanotesla>())
    };
    Ok(ModelField {
        b_enu_nt: Vector3::new(nt(f.y()), nt(f.x()), -nt(f.z())),
        sigma_declination_rad: f64::from(f.declination_uncertainty().get::<radian>()),
    })
}

/// The model's field in ECEF axes at the ECEF point `r_e` (nT).
fn field_e(r_e: &Vector3<f64>, date: Date) -> Result<Vector3<f64>, AidError> {
    let geo = earth::ecef_to_geodetic(r_e);
    let f = model_field(&geo, date)?;
    Ok(frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * f.b_enu_nt)
}

/// J = ∂B_e/∂r^e (nT/m) by central differences over ±[`GRADIENT_STEP_M`]
/// along each ECEF axis (well defined at the pole, where ENU steps are not).
fn gradient_e(r_e: &Vector3<f64>, date: Date) -> Result<Matrix3<f64>, AidError> {
    let mut j = Matrix3::zeros();
    for k in 0..3 {
        let mut d = Vector3::zeros();
        d[k] = GRADIENT_STEP_M;
        let col =
            (field_e(&(r_e + d), date)? - field_e(&(r_e - d), date)?) / (2.0 * GRADIENT_STEP_M);
        j.set_column(k, &col);
    }
    Ok(j)
}

/// The calibrated field b = W (b_raw − h) (nT, body axes) and the
/// covariance of its noise, after the content checks.
fn calibrated(s: &MagSample, m: &MagSettings) -> Result<(Vector3<f64>, Matrix3<f64>), AidError> {
    if s.field_b_nt
        .iter()
        .chain(&s.sigma_nt)
        .any(|x| !x.is_finite())
    {
        return Err(AidError::NonFinite("mag"));
    }
    for v in s.field_b_nt {
        if v.abs() > MAX_RAW_FIELD_NT {
            return Err(AidError::OutOfRange {
                what: "mag.field_b_nt",
                value: v,
            });
        }
    }
    for v in s.sigma_nt {
        if !(0.0..=MAX_SIGMA_NT).contains(&v) {
            return Err(AidError::OutOfRange {
                what: "mag.sigma_nt",
                value: v,
            });
        }
    }
    let w = m.w();
    let b = w * (Vector3::from(s.field_b_nt) - Vector3::from(m.hard_iron_nt));
    let var = Vector3::from(s.sigma_nt).map(|x| x.max(m.sigma_floor_nt).powi(2));
    let r_b = w * Matrix3::from_diagonal(&var) * w.transpose();
    Ok((b, r_b))
}

/// The model's field at `geo` on the sample's date, and the checks that
/// need it: the horizontal field's bound and the strength's agreement.
fn checked_model(
    geo: &Geodetic,
    date: Date,
    b: &Vector3<f64>,
    m: &MagSettings,
) -> Result<ModelField, AidError> {
    let f = model_field(geo, date)?;
    let h = f.horizontal_nt();
    if h < m.min_horizontal_nt {
        return Err(AidError::Refused {
            cause: cause::WEAK_HORIZONTAL,
            what: "mag: the model's horizontal field (nT)",
            value: h,
        });
    }
    let d = b.norm() - f.b_enu_nt.norm();
    if d.abs() > m.max_strength_error_nt {
        return Err(AidError::Refused {
            cause: cause::STRENGTH,
            what: "mag: calibrated strength minus the model's (nT)",
            value: d,
        });
    }
    Ok(f)
}

/// The angle about up from the horizontal part of `b` to that of `m`
/// (rad, ±π), and its gradients over `b` and over `m`.
fn angle_about_up(b: &Vector3<f64>, m: &Vector3<f64>) -> (f64, RowVector3<f64>, RowVector3<f64>) {
    let s = b.x * m.y - b.y * m.x;
    let c = b.x * m.x + b.y * m.y;
    let q = s * s + c * c;
    let ds_db = RowVector3::new(m.y, -m.x, 0.0);
    let dc_db = RowVector3::new(m.x, m.y, 0.0);
    let ds_dm = RowVector3::new(-b.y, b.x, 0.0);
    let dc_dm = RowVector3::new(b.x, b.y, 0.0);
    (
        s.atan2(c),
        (ds_db * c - dc_db * s) / q,
        (ds_dm * c - dc_dm * s) / q,
    )
}

/// The magnetometer's heading measurement of the nominal state `nav` (see
/// the module documentation).
pub fn measurement(
    nav: &AnyNav,
    s: &MagSample,
    m: &MagSettings,
) -> Result<Measurement<1>, AidError> {
    measurement_and_declination_var(nav, s, m).map(|(x, _)| x)
}

/// [`measurement`] and the share of its R that is the model's declination
/// error (rad²): one error for the whole flight near one place, not noise.
fn measurement_and_declination_var(
    nav: &AnyNav,
    s: &MagSample,
    m: &MagSettings,
) -> Result<(Measurement<1>, f64), AidError> {
    let (b_b, r_b) = calibrated(s, m)?;
    let date = date_of(s.t_ns, m)?;
    let geo = nav.geodetic();
    let f = checked_model(&geo, date, &b_b, m)?;
    let ff = nav.frame_free();
    let c_e_n = nav.c_e_n();
    let c_b_n = c_e_n * ff.q_b_e.to_rotation_matrix().into_inner();
    let c_g_e = frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose();
    let b_n = c_b_n * b_b;
    let m_n = c_e_n * (c_g_e * f.b_enu_nt);
    let (z, g_b, g_m) = angle_about_up(&b_n, &m_n);
    let j = gradient_e(&ff.r_e, date)?;

    let mut h = SMatrix::<f64, 1, 15>::zeros();
    h.fixed_view_mut::<1, 3>(0, idx::PHI)
        .copy_from(&(g_b * skew(&b_n)));
    let theta = frame_rotation_per_position_error(nav);
    let t3 = ecef_per_position_error(nav);
    h.fixed_view_mut::<1, 3>(0, idx::DP)
        .copy_from(&(g_m * (skew(&m_n) * theta + c_e_n * j * t3)));

    let r_n = c_b_n * r_b * c_b_n.transpose();
    let sigma_d = f
        .sigma_declination_rad
        .max(m.sigma_heading_floor_deg.to_radians());
    let var = (g_b * r_n * g_b.transpose())[0] + sigma_d * sigma_d;
    if !(z.is_finite() && var.is_finite() && var > 0.0 && h.iter().all(|x| x.is_finite())) {
        return Err(AidError::NonFinite("mag measurement"));
    }
    Ok((
        Measurement {
            z: SVector::<f64, 1>::new(z),
            h,
            r: SMatrix::<f64, 1, 1>::new(var),
        },
        sigma_d * sigma_d,
    ))
}

/// The heading of a levelled, stationary body from a sample (paper 003
/// §4.4): the calibrated field levelled with `c_b_l` (heading 0) has the
/// azimuth α = atan2(b_E, b_N); the true attitude R_z(−ψ) c_b_l turns it
/// by ψ clockwise onto the field's azimuth, the declination D, so
/// ψ = D − α. Its σ: the field noise across the levelled horizontal field,
/// the tilt's σ times tan(I) (a tilt of the levelling turns the levelled
/// field's azimuth by up to tan I per radian) and the model's declination
/// σ (raised to the heading floor), in quadrature.
pub fn heading_fix(
    s: &MagSample,
    level: &Levelled,
    m: &MagSettings,
) -> Result<HeadingFix, AidError> {
    let (b_b, r_b) = calibrated(s, m)?;
    if !(level.c_b_l.iter().all(|x| x.is_finite()) && level.sigma_tilt_rad.is_finite()) {
        return Err(AidError::NonFinite("mag: levelled attitude"));
    }
    let date = date_of(level.t_ns, m)?;
    let f = checked_model(&level.geo, date, &b_b, m)?;
    let b_l = level.c_b_l * b_b;
    let h2 = b_l.x * b_l.x + b_l.y * b_l.y;
    if h2.is_nan() || h2 <= 0.0 {
        return Err(AidError::Refused {
            cause: cause::WEAK_HORIZONTAL,
            what: "mag: levelled horizontal field (nT)",
            value: h2.sqrt(),
        });
    }
    let alpha = b_l.x.atan2(b_l.y);
    let heading = (f.declination_rad() - alpha).rem_euclid(std::f64::consts::TAU);
    // ∂α/∂b_l = (b_N, −b_E, 0)/H².
    let g = RowVector3::new(b_l.y, -b_l.x, 0.0) / h2;
    let r_l = level.c_b_l * r_b * level.c_b_l.transpose();
    let var_noise = (g * r_l * g.transpose())[0];
    let tan_i = f.inclination_rad().tan().abs();
    let var_tilt = (level.sigma_tilt_rad * tan_i).powi(2);
    let sigma_d = f
        .sigma_declination_rad
        .max(m.sigma_heading_floor_deg.to_radians());
    let sigma = (var_noise + var_tilt + sigma_d * sigma_d).sqrt();
    if !(heading.is_finite() && sigma.is_finite()) {
        return Err(AidError::NonFinite("mag heading"));
    }
    Ok(HeadingFix {
        heading_rad: heading,
        sigma_rad: sigma,
    })
}

impl Aid for MagSample {
    type Settings = MagSettings;
    /// The attitude (its heading, with the tilt's share through the
    /// inclination).
    const OBSERVED: &'static [usize] = &[idx::PHI];
    /// Heading only (its tilt term in H is the linearization of the
    /// horizontal projection, not a measurement of the tilt): paper 003
    /// fuses it beside the accelerometers' roll and pitch in an outage.
    const MAKES_TILT_OBSERVABLE: bool = false;
    fn measure(&self, nav: &AnyNav, _: &Context, m: &MagSettings) -> Result<Measured, AidError> {
        measurement_and_declination_var(nav, self, m).map(|(x, persistent_var)| Measured {
            shares: super::ConsiderShares {
                persistent_var,
                correlated: None,
            },
            ..Measured::from(x)
        })
    }
    fn align_heading(
        &self,
        level: &Levelled,
        m: &MagSettings,
    ) -> Option<Result<HeadingFix, AidError>> {
        Some(heading_fix(self, level, m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::tests::{computed, truth};
    use crate::mech::FrameKind;
    use nalgebra::UnitQuaternion;
    use rand::{Rng, SeedableRng};

    const T_NS: u64 = 3_600_000_000_000;

    /// A calibration with hard and soft iron (W well conditioned).
    fn settings() -> MagSettings {
        MagSettings {
            hard_iron_nt: [1200.0, -800.0, 300.0],
            soft_iron: [[1.05, 0.02, -0.01], [0.02, 0.97, 0.03], [-0.01, 0.03, 1.01]],
            epoch_utc: "2026-06-01T00:00:00Z".to_owned(),
            ..Default::default()
        }
    }

    /// The raw sample a perfect sensor with the settings' iron gives in the
    /// attitude and at the position of `t`: b = C_e^b B_e, b_raw = W⁻¹ b + h.
    fn sample_of(t: &AnyNav, m: &MagSettings, t_ns: u64) -> MagSample {
        let ff = t.frame_free();
        let geo = earth::ecef_to_geodetic(&ff.r_e);
        let date = date_of(t_ns, m).expect("date");
        let f = model_field(&geo, date).expect("model");
        let b_e = frames::c_e_g(geo.lat_rad, geo.lon_rad).transpose() * f.b_enu_nt;
        let b = ff.q_b_e.inverse() * b_e;
        let raw = m.w().try_inverse().expect("W") * b + Vector3::from(m.hard_iron_nt);
        MagSample {
            t_ns,
            seq: 0,
            field_b_nt: raw.into(),
            sigma_nt: [150.0, 150.0, 200.0],
        }
    }

    /// NOAA's WMM2025 test values (WMM2025 report, table of test values;
    /// the file WMM2025_TestValues.txt shipped with the coefficients):
    /// date, height (km), latitude, longitude (deg), X, Y, Z (nT), I, D
    /// (deg), Xdot, Ydot, Zdot (nT/yr). Longitude 240 is −120 here.
    const NOAA_WMM2025: [[f64; 12]; 12] = [
        [
            2025.0, 0.0, 80.0, 0.0, 6521.6, 145.9, 54791.5, 83.21, 1.28, -8.3, 59.5, 31.1,
        ],
        [
            2025.0, 0.0, 0.0, 120.0, 39677.8, -109.6, -10580.2, -14.93, -0.16, 9.5, -23.1, 79.4,
        ],
        [
            2025.0, 0.0, -80.0, 240.0, 6117.5, 15751.9, -52022.5, -72.00, 68.78, 33.3, -8.6, 95.5,
        ],
        [
            2025.0, 100.0, 80.0, 0.0, 6216.0, 92.4, 52598.8, 83.26, 0.85, -7.7, 56.5, 28.7,
        ],
        [
            2025.0, 100.0, 0.0, 120.0, 37688.6, -96.2, -10152.1, -15.08, -0.15, 9.2, -21.0, 72.9,
        ],
        [
            2025.0, 100.0, -80.0, 240.0, 5907.6, 14780.3, -49540.7, -72.19, 68.21, 30.6, -8.0, 89.2,
        ],
        [
            2027.5, 0.0, 80.0, 0.0, 6500.8, 294.5, 54869.4, 83.24, 2.59, -8.3, 59.5, 31.1,
        ],
        [
            2027.5, 0.0, 0.0, 120.0, 39701.6, -167.4, -10381.8, -14.65, -0.24, 9.5, -23.1, 79.4,
        ],
        [
            2027.5, 0.0, -80.0, 240.0, 6200.7, 15730.3, -51783.7, -71.92, 68.49, 33.3, -8.6, 95.5,
        ],
        [
            2027.5, 100.0, 80.0, 0.0, 6196.7, 233.8, 52670.5, 83.29, 2.16, -7.7, 56.5, 28.7,
        ],
        [
            2027.5, 100.0, 0.0, 120.0, 37711.5, -148.7, -9969.8, -14.81, -0.23, 9.2, -21.0, 72.9,
        ],
        [
            2027.5, 100.0, -80.0, 240.0, 5984.0, 14760.1, -49317.7, -72.10, 67.93, 30.6, -8.0, 89.2,
        ],
    ];

    /// The crate against NOAA's independent test values, to their printed
    /// precision: half the last printed digit (0.05 nT, 0.005°), plus what
    /// the crate's day-resolution date can move (2027.5 is noon of 2 July;
    /// half a day of the printed secular variation), plus f32 rounding
    /// (3e-7 of the field).
    #[test]
    fn the_wmm_crate_reproduces_noaas_wmm2025_test_values() {
        let mut worst = [0.0f64; 2];
        for row in NOAA_WMM2025 {
            let [year, h_km, lat, lon, x, y, z, inc, dec, xd, yd, zd] = row;
            // 2025.0 is 1 January; 2027.5 is 182.5 days into 2027.
            let at_epoch = year < 2026.0;
            let date = if at_epoch {
                Date::from_ordinal_date(2025, 1).expect("date")
            } else {
                Date::from_ordinal_date(2027, 183).expect("date")
            };
            let half_day_yr = if at_epoch { 0.0 } else { 0.5 / 365.0 };
            let f = model_field(&Geodetic::from_deg(lat, lon, h_km * 1000.0), date).expect("wmm");
            let got = [f.b_enu_nt.y, f.b_enu_nt.x, -f.b_enu_nt.z];
            for (k, (want, rate)) in [(x, xd), (y, yd), (z, zd)].into_iter().enumerate() {
                let tol = 0.05 + rate.abs() * half_day_yr + 3e-7 * f.b_enu_nt.norm();
                let e = (got[k] - want).abs();
                worst[0] = worst[0].max(e);
                assert!(
                    e <= tol,
                    "{row:?}: component {k} = {} vs {want} (tol {tol})",
                    got[k]
                );
            }
            // Declination and inclination to 0.01° (their rates are at most
            // 0.53°/yr: 0.0007° over half a day).
            let d = f.declination_rad().to_degrees();
            let i = f.inclination_rad().to_degrees();
            for (g, w) in [(d, dec), (i, inc)] {
                worst[1] = worst[1].max((g - w).abs());
                assert!((g - w).abs() <= 0.005 + 0.0008, "{row:?}: {g} vs {w}");
            }
        }
        eprintln!(
            "WMM2025 vs NOAA's 12 test values: worst field error {:.3} nT, worst angle error {:.4}°",
            worst[0], worst[1]
        );
    }

    /// H against central differences of z over every error state, in g and
    /// in G, near and at the geographic pole. The attitude block is exact to
    /// 1e-6; the position block differences the f32 model (its horizontal
    /// direction rounds to ~6e-7 rad where H is 7000 nT) over ±4 km steps
    /// (g: 6.3e-4 rad of latitude), so it is compared to 5e-3 of its scale
    /// (rounding 2e-4 over the step, truncation (4 km/L)² for the field's
    /// scale L of a few hundred km near the magnetic poles).
    #[test]
    fn mag_jacobian_matches_central_differences_in_both_frames_and_near_the_pole() {
        // The model itself near the poles, where the aid would refuse
        // (at the geographic pole H = 1760 nT in 2026): the bound lowered past its range.
        let m = MagSettings {
            min_horizontal_nt: 500.0,
            ..settings()
        };
        let mut worst = [0.0f64; 2];
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Geographic, 69.0, -120.0),
            (FrameKind::Grid, 88.0, -60.0),
            (FrameKind::Grid, 89.99999, 20.0),
            (FrameKind::Grid, 31.94, 118.79),
            (FrameKind::Grid, -75.0, 100.0),
        ] {
            let t = truth(kind, lat, lon);
            let s = sample_of(&t, &m, T_NS);
            let meas = measurement(&t, &s, &m).expect("mag");
            assert!(meas.z[0].abs() < 1e-6, "{kind:?} {lat}: z {}", meas.z[0]);
            let pos_steps = match kind {
                FrameKind::Geographic => [6.3e-4, 6.3e-4, 4000.0],
                FrameKind::Grid => [4000.0, 4000.0, 4000.0],
            };
            let mut fd = SMatrix::<f64, 1, 15>::zeros();
            for j in 0..15 {
                let step = match j {
                    0..=2 => 1e-5,
                    6..=8 => pos_steps[j - 6],
                    _ => 1e-3,
                };
                let z_at = |sign: f64| {
                    let mut x = SVector::<f64, 15>::zeros();
                    x[j] = sign * step;
                    measurement(&computed(&t, &x), &s, &m).expect("mag").z[0]
                };
                fd[j] = (z_at(1.0) - z_at(-1.0)) / (2.0 * step);
            }
            let d = fd - meas.h;
            // Relative to the block's scale (tan I reaches 30 near the poles).
            let phi = d.fixed_view::<1, 3>(0, idx::PHI).amax()
                / meas.h.fixed_view::<1, 3>(0, idx::PHI).amax().max(1.0);
            let hp = meas.h.fixed_view::<1, 3>(0, idx::DP).amax();
            let dp = d.fixed_view::<1, 3>(0, idx::DP).amax() / hp;
            worst = [worst[0].max(phi), worst[1].max(dp)];
            assert!(
                phi < 1e-6,
                "{kind:?} {lat}°: φ block H {} FD {}",
                meas.h.fixed_view::<1, 3>(0, idx::PHI),
                fd.fixed_view::<1, 3>(0, idx::PHI)
            );
            assert!(
                dp < 5e-3,
                "{kind:?} {lat}°: δp block H {} FD {} ({dp:e} of its scale)",
                meas.h.fixed_view::<1, 3>(0, idx::DP),
                fd.fixed_view::<1, 3>(0, idx::DP)
            );
            // About up exactly 1 (the heading); the tilt's share is in the
            // level columns.
            assert!((meas.h[(0, idx::PHI + 2)] - 1.0).abs() < 1e-9);
            for j in [3, 4, 5, 9, 10, 11, 12, 13, 14] {
                assert!(
                    fd[j].abs() < 1e-9 && meas.h[j] == 0.0,
                    "{kind:?}: column {j}"
                );
            }
        }
        eprintln!(
            "mag H vs central differences: φ block {:.2e} rad/rad, δp block {:.2e} of its scale",
            worst[0], worst[1]
        );
    }

    /// A noiseless sample gives z ≈ 0 whatever the attitude, in g and G:
    /// 200 random attitudes (pitch and roll within ±80°) at random places
    /// where the aid is enabled.
    #[test]
    fn a_noiseless_sample_has_no_innovation_at_any_attitude_in_both_frames() {
        let m = settings();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(30);
        let mut worst = 0.0f64;
        let mut n = 0;
        while n < 200 {
            let lat = rng.gen_range(-89.9..89.9);
            let lon = rng.gen_range(-180.0..180.0);
            let kind = if n % 2 == 0 {
                FrameKind::Geographic
            } else {
                FrameKind::Grid
            };
            let t0 = truth(kind, lat, lon);
            let geo = t0.geodetic();
            let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
            let c_b_g = frames::c_b_n_from_euler(
                rng.gen_range(0.0..std::f64::consts::TAU),
                rng.gen_range(-1.4..1.4),
                rng.gen_range(-1.4..1.4),
            );
            let q = UnitQuaternion::from_matrix(&(c_e_g.transpose() * c_b_g));
            let ff = t0.frame_free();
            let t = AnyNav::from_frame_free(kind, &ff.r_e, &ff.v_e, &q);
            let s = sample_of(&t, &m, T_NS);
            match measurement(&t, &s, &m) {
                Ok(meas) => {
                    worst = worst.max(meas.z[0].abs());
                    n += 1;
                }
                Err(AidError::Refused { cause, .. }) if cause == cause::WEAK_HORIZONTAL => {}
                Err(e) => panic!("{lat} {lon}: {e}"),
            }
        }
        eprintln!("noiseless samples at 200 random attitudes: worst |z| {worst:.2e} rad");
        assert!(worst < 1e-6, "{worst}");
    }

    /// The measured heading's noise is the field's across the horizontal
    /// field plus the model's declination σ: R at a level attitude is
    /// σ²/H² + σ_D² to 1e-9.
    #[test]
    fn r_is_the_field_noise_across_the_horizontal_field_and_the_models_declination() {
        let m = MagSettings {
            hard_iron_nt: [0.0; 3],
            soft_iron: MagSettings::default().soft_iron,
            ..settings()
        };
        let geo = Geodetic::from_deg(50.0, 5.0, 1000.0);
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let q = UnitQuaternion::from_matrix(&c_e_g.transpose());
        let t = AnyNav::from_frame_free(
            FrameKind::Geographic,
            &earth::geodetic_to_ecef(&geo),
            &Vector3::zeros(),
            &q,
        );
        let mut s = sample_of(&t, &m, T_NS);
        s.sigma_nt = [300.0; 3];
        let f = model_field(&geo, date_of(T_NS, &m).expect("date")).expect("wmm");
        let meas = measurement(&t, &s, &m).expect("mag");
        let want = (300.0 / f.horizontal_nt()).powi(2) + f.sigma_declination_rad.powi(2);
        assert!(
            (meas.r[0] - want).abs() < 1e-9 * want,
            "{} vs {want}",
            meas.r[0]
        );
    }

    #[test]
    fn the_aid_disables_itself_where_the_horizontal_field_is_weak() {
        let m = settings();
        // Near the north magnetic pole (2026: ~85.7° N, 140° E) H < 2000 nT.
        let t = truth(FrameKind::Grid, 85.7, 140.0);
        let s = sample_of(&t, &m, T_NS);
        match measurement(&t, &s, &m) {
            Err(AidError::Refused { cause, value, .. }) => {
                assert_eq!(cause, cause::WEAK_HORIZONTAL);
                assert!(value < 2000.0, "H {value}");
            }
            other => panic!("{other:?}"),
        }
        // And the alignment refuses there with the same cause.
        let level = Levelled {
            c_b_l: Matrix3::identity(),
            sigma_tilt_rad: 1e-3,
            geo: t.geodetic(),
            t_ns: T_NS,
        };
        assert_eq!(
            heading_fix(&s, &level, &m).map_err(|e| e.cause()),
            Err(cause::WEAK_HORIZONTAL)
        );
    }

    /// Each refusal names its cause; nothing panics and every output is
    /// finite, whatever the sample holds.
    #[test]
    fn adversarial_samples_are_refused_by_cause_without_panics() {
        let m = settings();
        let t = truth(FrameKind::Geographic, 50.0, 8.0);
        let good = sample_of(&t, &m, T_NS);
        assert!(measurement(&t, &good, &m).is_ok());
        let mut cases: Vec<(MagSample, usize)> = Vec::new();
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for k in 0..3 {
                let mut s = good;
                s.field_b_nt[k] = v;
                cases.push((s, cause::INVALID));
                let mut s = good;
                s.sigma_nt[k] = v;
                cases.push((s, cause::INVALID));
            }
        }
        for sigma in [1e300, -1.0, 1.1e5] {
            let mut s = good;
            s.sigma_nt = [sigma; 3];
            cases.push((s, cause::INVALID));
        }
        cases.push((
            MagSample {
                field_b_nt: [1e300; 3],
                ..good
            },
            cause::INVALID,
        ));
        // A vanishing field (1e-300 nT) is a disturbance, not a heading.
        cases.push((
            MagSample {
                field_b_nt: [1e-300; 3],
                ..good
            },
            cause::STRENGTH,
        ));
        cases.push((
            MagSample {
                field_b_nt: [0.0; 3],
                ..good
            },
            cause::STRENGTH,
        ));
        let raw = Vector3::from(good.field_b_nt);
        cases.push((
            MagSample {
                field_b_nt: (raw * 1.2).into(),
                ..good
            },
            cause::STRENGTH,
        ));
        // Before 2020 and after 2029 there is no model.
        cases.push((
            MagSample {
                t_ns: u64::MAX,
                ..good
            },
            cause::OUTSIDE_MODEL,
        ));
        for (s, want) in cases {
            match measurement(&t, &s, &m) {
                Err(e) => assert_eq!(e.cause(), want, "{s:?}: {e}"),
                Ok(x) => panic!("{s:?} accepted: {x:?}"),
            }
            let level = Levelled {
                c_b_l: Matrix3::identity(),
                sigma_tilt_rad: 1e-3,
                geo: t.geodetic(),
                t_ns: s.t_ns,
            };
            assert!(heading_fix(&s, &level, &m).is_err(), "{s:?}");
        }
        // σ of 0 is raised to the floor, σ of 1e-300 too: accepted, finite.
        for sigma in [0.0, 1e-300] {
            let s = MagSample {
                sigma_nt: [sigma; 3],
                ..good
            };
            let x = measurement(&t, &s, &m).expect("σ raised to the floor");
            assert!(x.r[0].is_finite() && x.r[0] > 0.0 && x.z[0].is_finite());
        }
        // The default epoch (the GPS epoch) puts a simulated t_ns ≈ 0 in 1980.
        let d = MagSettings::default();
        assert_eq!(
            measurement(&t, &good, &d).map_err(|e| e.cause()).err(),
            Some(cause::OUTSIDE_MODEL)
        );
        // A non-finite levelled attitude is refused.
        let level = Levelled {
            c_b_l: Matrix3::from_element(f64::NAN),
            sigma_tilt_rad: 1e-3,
            geo: t.geodetic(),
            t_ns: T_NS,
        };
        assert!(heading_fix(&good, &level, &m).is_err());
    }

    /// With perfect data the alignment's heading is the true one to 1e-6
    /// rad, at 36 headings, levelled with pitch and roll, in either
    /// hemisphere; its σ is at least the model's declination σ.
    #[test]
    fn align_heading_recovers_a_known_heading_with_perfect_data() {
        let m = settings();
        let mut worst = 0.0f64;
        for (lat, lon) in [(48.0, 11.0), (-33.9, 151.2), (78.2, 15.6), (64.8, -147.7)] {
            let geo = Geodetic::from_deg(lat, lon, 300.0);
            let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
            let date = date_of(T_NS, &m).expect("date");
            let f = model_field(&geo, date).expect("wmm");
            for k in 0..36 {
                let psi = f64::from(k) * 10.0_f64.to_radians() + 0.01;
                let (pitch, roll) = (0.05, -0.08);
                let c_b_g = frames::c_b_n_from_euler(psi, pitch, roll);
                let q = UnitQuaternion::from_matrix(&(c_e_g.transpose() * c_b_g));
                let t = AnyNav::from_frame_free(
                    FrameKind::Geographic,
                    &earth::geodetic_to_ecef(&geo),
                    &Vector3::zeros(),
                    &q,
                );
                let s = sample_of(&t, &m, T_NS);
                let level = Levelled {
                    c_b_l: frames::c_b_n_from_euler(0.0, pitch, roll),
                    sigma_tilt_rad: 1e-3,
                    geo,
                    t_ns: T_NS,
                };
                let fix = s
                    .align_heading(&level, &m)
                    .expect("observes heading")
                    .expect("fix");
                let e = (fix.heading_rad - psi + std::f64::consts::PI)
                    .rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                worst = worst.max(e.abs());
                assert!(
                    e.abs() < 1e-6,
                    "{lat}° ψ {psi}: {} ({e:e})",
                    fix.heading_rad
                );
                assert!((0.0..std::f64::consts::TAU).contains(&fix.heading_rad));
                assert!(fix.sigma_rad >= f.sigma_declination_rad * 0.999_999);
                let tan_i = f.inclination_rad().tan().abs();
                assert!(fix.sigma_rad >= 1e-3 * tan_i);
            }
        }
        eprintln!("align_heading with perfect data: worst heading error {worst:.2e} rad");
    }

    #[test]
    fn settings_outside_their_bounds_are_refused_naming_the_key() {
        assert!(MagSettings::default().validate("t", "aids.mag").is_ok());
        assert!(settings().validate("t", "aids.mag").is_ok());
        let d = MagSettings::default;
        for (bad, key) in [
            (
                MagSettings {
                    hard_iron_nt: [0.0, f64::NAN, 0.0],
                    ..d()
                },
                "aids.mag.hard_iron_nt[1]",
            ),
            (
                MagSettings {
                    hard_iron_nt: [2e5, 0.0, 0.0],
                    ..d()
                },
                "aids.mag.hard_iron_nt[0]",
            ),
            (
                MagSettings {
                    soft_iron: [[1.0, 0.0, 0.0], [0.0, 11.0, 0.0], [0.0, 0.0, 1.0]],
                    ..d()
                },
                "aids.mag.soft_iron[1][1]",
            ),
            // Singular: two equal rows.
            (
                MagSettings {
                    soft_iron: [[1.0, 0.5, 0.0], [1.0, 0.5, 0.0], [0.0, 0.0, 1.0]],
                    ..d()
                },
                "aids.mag.soft_iron",
            ),
            (
                MagSettings {
                    soft_iron: [[0.0; 3]; 3],
                    ..d()
                },
                "aids.mag.soft_iron",
            ),
            (
                MagSettings {
                    epoch_utc: "yesterday".into(),
                    ..d()
                },
                "aids.mag.epoch_utc",
            ),
            (
                MagSettings {
                    min_horizontal_nt: 1000.0,
                    ..d()
                },
                "aids.mag.min_horizontal_nt",
            ),
            (
                MagSettings {
                    max_strength_error_nt: 100.0,
                    ..d()
                },
                "aids.mag.max_strength_error_nt",
            ),
            (
                MagSettings {
                    sigma_floor_nt: 0.0,
                    ..d()
                },
                "aids.mag.sigma_floor_nt",
            ),
            (
                MagSettings {
                    sigma_heading_floor_deg: f64::INFINITY,
                    ..d()
                },
                "aids.mag.sigma_heading_floor_deg",
            ),
        ] {
            let e = bad.validate("t", "aids.mag").expect_err(key);
            assert_eq!(e.key, key, "{}", e.message);
        }
    }
}
