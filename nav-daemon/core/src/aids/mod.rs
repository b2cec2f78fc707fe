//! Aid measurement models, one module per aid (PX4 `aid_sources/` style):
//! each aid's payload implements [`Aid`] in its module, which builds z, H
//! and R for the current nominal state in either frame. Whether to fuse
//! (gating, timeouts, health) is decided in [`control`] and the
//! navigator's gating, the same for every aid. Which aids exist is
//! declared once, in `msgs::aids`; this module derives from that list the
//! one struct that holds each aid's own settings ([`OwnAidSettings`]).
//!
//! Sign convention: z = (INS prediction) − (aid measurement) = H δx + v, with
//! δx = computed − true as everywhere in the filter.

pub mod baro;
pub mod baseline;
pub mod cns;
pub mod control;
pub mod gnss;
pub mod mag;
pub mod srs;
pub mod star;

use msgs::{AidKind, AidPayload};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::bounds::SettingsError;
use crate::earth;
use crate::mech::AnyNav;

/// What the navigator needs of an aid: its measurement model. Each aid's
/// payload implements it in the aid's own module.
pub trait Aid: AidPayload {
    /// The aid's own settings, its `[aids.NAME]` table ([`NoSettings`]
    /// when it has none).
    type Settings: OwnSettings;
    /// The first state of each 3-state block of the error state that the
    /// aid observes directly (a reset to the aid resets those blocks): at
    /// most two (the reset's widening is sized for six states; checked by
    /// a test in `navigator::gating`).
    const OBSERVED: &'static [usize];
    /// Whether the aid makes roll and pitch observable, so that the
    /// accelerometers' level (paper 003 §4.5, [`crate::flight_state`])
    /// is not needed while it is fresh: by default an aid that observes
    /// attitude or velocity (a velocity error grows with the tilt through
    /// gravity). A heading-only aid (the magnetometer) says false.
    const MAKES_TILT_OBSERVABLE: bool = observes(Self::OBSERVED, crate::error_model::idx::PHI)
        || observes(Self::OBSERVED, crate::error_model::idx::DV);
    /// The linearized measurement of the nominal state `nav` at the
    /// sample's own time.
    fn measure(
        &self,
        nav: &AnyNav,
        ctx: &Context,
        settings: &Self::Settings,
    ) -> Result<Measured, AidError>;
    /// The body's heading from this sample for a stationary alignment of
    /// a MEMS IMU (paper 003 §4.4), given the attitude levelled from the
    /// accelerometers; `None` for an aid that does not observe heading
    /// (the default). An aid that does observe it but cannot give it from
    /// this sample (refused, disabled near a magnetic pole) returns the
    /// error that says why.
    fn align_heading(
        &self,
        _level: &Levelled,
        _settings: &Self::Settings,
    ) -> Option<Result<HeadingFix, AidError>> {
        None
    }
}

/// Whether `blocks` holds the block starting at `first`.
pub const fn observes(blocks: &[usize], first: usize) -> bool {
    let mut i = 0;
    while i < blocks.len() {
        if blocks[i] == first {
            return true;
        }
        i += 1;
    }
    false
}

/// What a stationary alignment knows when it asks an aid for heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levelled {
    /// Body → local geographic (ENU) DCM of the levelled attitude with a
    /// heading of 0: roll and pitch from the accelerometers
    /// ([`crate::frames::c_b_n_from_euler`]`(0, pitch, roll)`; body axes x
    /// right, y forward, z up). The true attitude is `R_z(−ψ) · c_b_l`.
    pub c_b_l: Matrix3<f64>,
    /// 1-σ of each levelled angle (rad).
    pub sigma_tilt_rad: f64,
    /// Where the vehicle stands (the init record's position).
    pub geo: earth::Geodetic,
    /// Time of the alignment (sensor time, ns).
    pub t_ns: u64,
}

/// A heading for the alignment: ψ clockwise from true (geographic) north,
/// as [`crate::frames::euler_from_c_b_n`] gives it, in [0, 2π).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadingFix {
    pub heading_rad: f64,
    /// Its 1-σ (rad), from the aid's noise and, where it matters, the
    /// tilt's σ; it becomes the init record's `sigma_heading_rad`.
    pub sigma_rad: f64,
}

/// What a measurement model may need of the navigator besides the state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Context {
    /// The body's rate against inertial space, body axes (rad/s): the
    /// newest IMU increment's, the gyro bias estimate removed (a lever
    /// arm's velocity).
    pub omega_ib_b: Vector3<f64>,
}

/// An aid's measurement, of its dimension. Held by value on purpose:
/// boxing the largest would allocate for every aid sample.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AnyMeasurement {
    D1(Measurement<1>),
    D2(Measurement<2>),
    D3(Measurement<3>),
    D6(Measurement<6>),
}

/// What [`Aid::measure`] made of a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    pub m: AnyMeasurement,
    /// SRS: the body excluded by fault detection, if one was.
    pub excluded_body: Option<u32>,
    /// The parts of R that are not white noise.
    pub shares: ConsiderShares,
}

/// The parts of a measurement's R that are one error common to many
/// samples rather than noise. The navigator carries their covariance with
/// the states as consider parameters ([`crate::filter::update_considering_block`]),
/// so that repeated samples cannot average them away. Zero and `None`
/// (the default) for white measurements.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ConsiderShares {
    /// The share entering each component that is one error for the
    /// flight (the magnetometer's: the model's declination error, the
    /// local field's departure from the WMM). One aid declares one (the
    /// magnetometer).
    pub persistent_var: f64,
    /// The share of the first three components (a position in the
    /// navigation frame's axes) that is an error correlated in time: a
    /// receiver's multipath, atmosphere and orbits, decaying with its
    /// correlation time. One aid declares one (GNSS, when its settings give
    /// the receiver's correlated σ).
    pub correlated: Option<Correlated>,
}

/// A first-order Gauss–Markov error of a measured position: its stationary
/// variance per axis of the navigation frame (east or grid x, north or
/// grid y, up; m², the two horizontal ones equal, so that the frame's turn
/// about up at a switch leaves it unchanged) and its correlation time (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correlated {
    pub var: Vector3<f64>,
    pub tau_s: f64,
}

impl From<Measurement<1>> for Measured {
    fn from(m: Measurement<1>) -> Self {
        Self {
            m: AnyMeasurement::D1(m),
            excluded_body: None,
            shares: ConsiderShares::default(),
        }
    }
}
impl From<Measurement<2>> for Measured {
    fn from(m: Measurement<2>) -> Self {
        Self {
            m: AnyMeasurement::D2(m),
            excluded_body: None,
            shares: ConsiderShares::default(),
        }
    }
}
impl From<Measurement<3>> for Measured {
    fn from(m: Measurement<3>) -> Self {
        Self {
            m: AnyMeasurement::D3(m),
            excluded_body: None,
            shares: ConsiderShares::default(),
        }
    }
}
impl From<Measurement<6>> for Measured {
    fn from(m: Measurement<6>) -> Self {
        Self {
            m: AnyMeasurement::D6(m),
            excluded_body: None,
            shares: ConsiderShares::default(),
        }
    }
}

/// The settings an aid has of its own: a table `[aids.NAME]` of the
/// configuration, each key with its bound.
pub trait OwnSettings:
    std::fmt::Debug + Clone + PartialEq + Default + Serialize + DeserializeOwned
{
    /// True when the aid has no settings of its own: its table is then not
    /// written.
    const NONE: bool = false;
    /// Checks every key; `table` is the table's dotted name (`aids.gnss`).
    fn validate(&self, origin: &str, table: &str) -> Result<(), SettingsError>;
    /// The integrity test of an aid that is not autonomous (its settings
    /// are among the aid's own); `None` for an autonomous aid.
    fn integrity(&self) -> Option<crate::integrity::IntegritySettings> {
        None
    }
}

/// No settings of the aid's own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoSettings {}

impl OwnSettings for NoSettings {
    const NONE: bool = true;
    fn validate(&self, _origin: &str, _table: &str) -> Result<(), SettingsError> {
        Ok(())
    }
}

/// Where an aid's own settings are in [`OwnAidSettings`].
pub trait OwnOf: Aid {
    fn own(all: &OwnAidSettings) -> &Self::Settings;
}

macro_rules! own_settings {
    ([$(($K:ident, $n:ident, $P:ident, $d:tt)),* $(,)?]) => {
        /// Each aid's own settings (its `[aids.NAME]` table).
        #[derive(Debug, Clone, PartialEq, Default)]
        pub struct OwnAidSettings {
            $(pub $n: <msgs::$P as Aid>::Settings,)*
        }

        $(
            impl OwnOf for msgs::$P {
                fn own(all: &OwnAidSettings) -> &Self::Settings {
                    &all.$n
                }
            }
        )*

        impl OwnAidSettings {
            /// Checks every aid's own settings.
            pub fn validate(&self, origin: &str) -> Result<(), SettingsError> {
                $(self.$n.validate(origin, concat!("aids.", stringify!($n)))?;)*
                Ok(())
            }

            /// Writes the tables of the aids that have settings, as fields
            /// of the `[aids]` struct being serialized.
            pub(crate) fn serialize_into<S: serde::ser::SerializeStruct>(
                &self,
                s: &mut S,
            ) -> Result<(), S::Error> {
                $(
                    if <<msgs::$P as Aid>::Settings as OwnSettings>::NONE {
                        s.skip_field(stringify!($n))?;
                    } else {
                        s.serialize_field(stringify!($n), &self.$n)?;
                    }
                )*
                Ok(())
            }

            /// The integrity test's settings of aid `kind` (`None`: autonomous).
            pub fn integrity(&self, kind: AidKind) -> Option<crate::integrity::IntegritySettings> {
                match kind {
                    $(AidKind::$K => self.$n.integrity(),)*
                }
            }

            /// Reads the table of aid `kind` from `map`.
            pub(crate) fn deserialize_from<'de, A: serde::de::MapAccess<'de>>(
                &mut self,
                kind: AidKind,
                map: &mut A,
            ) -> Result<(), A::Error> {
                match kind {
                    $(AidKind::$K => self.$n = map.next_value()?,)*
                }
                Ok(())
            }
        }
    };
}

msgs::for_each_aid!(own_settings);

/// One linearized measurement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement<const M: usize> {
    pub z: SVector<f64, M>,
    pub h: SMatrix<f64, M, 15>,
    pub r: SMatrix<f64, M, M>,
}

/// Physical range of an aid's stated 1-σ (m for CNS and baro, m/s for an
/// SRS line, rad for the star tracker: 0.01″ to 1 rad). Below the lower bound no real sensor measures (and R would
/// make the update numerically singular); above the upper bound the sample
/// carries no information and R² would overflow the innovation covariance.
pub const SIGMA_RANGE_CNS_M: (f64, f64) = (1e-3, 1e6);
pub const SIGMA_RANGE_BARO_M: (f64, f64) = (1e-3, 1e5);
pub const SIGMA_RANGE_SRS_MPS: (f64, f64) = (1e-4, 1e5);
pub const SIGMA_RANGE_STAR_RAD: (f64, f64) = (0.01 * star::ARCSEC_RAD, 1.0);

/// Checks a stated σ against its physical range.
pub fn check_sigma(what: &'static str, sigma: f64, range: (f64, f64)) -> Result<(), AidError> {
    if !sigma.is_finite() {
        return Err(AidError::NonFinite(what));
    }
    if !(range.0..=range.1).contains(&sigma) {
        return Err(AidError::OutOfRange { what, value: sigma });
    }
    Ok(())
}

/// Why an aid sample could not be turned into a measurement.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum AidError {
    #[error("non-finite value in {0}")]
    NonFinite(&'static str),
    #[error("{what} out of range: {value}")]
    OutOfRange { what: &'static str, value: f64 },
    #[error("SRS: {0}")]
    Srs(#[from] srs::SrsError),
    /// Refused by the aid's own quality checks: `cause` indexes its
    /// declaration's `causes`.
    #[error("{what} = {value}: refused ({})", cause)]
    Refused {
        cause: usize,
        what: &'static str,
        value: f64,
    },
}

impl AidError {
    /// The refusal cause this error counts under (0: invalid content).
    pub fn cause(&self) -> usize {
        match self {
            AidError::Refused { cause, .. } => *cause,
            _ => 0,
        }
    }
}

/// Rotation of the nav frame caused by a position error, θ = Θ δp, so that
/// C_e^n(computed) = (I − θ×) C_e^n(true). Columns over the frame's δp.
pub fn frame_rotation_per_position_error(nav: &AnyNav) -> Matrix3<f64> {
    let geo = nav.geodetic();
    match nav {
        AnyNav::Geographic(_) => {
            let (s, c) = geo.lat_rad.sin_cos();
            // δL rotates about −east, δλ about the Earth's axis (cos L north + sin L up).
            Matrix3::new(-1.0, 0.0, 0.0, 0.0, c, 0.0, 0.0, s, 0.0)
        }
        AnyNav::Grid(_) => crate::error_model::c_p_grid(&geo),
    }
}

/// ∂r^e/∂δp of the current frame: T3 in g (papers/001 eq 34), identity in G.
pub fn ecef_per_position_error(nav: &AnyNav) -> Matrix3<f64> {
    match nav {
        AnyNav::Geographic(s) => {
            let [e, n, u] = crate::frames::enu_axes_e(s.pos.lat_rad, s.pos.lon_rad);
            let (rm, rn) = earth::radii(s.pos.lat_rad);
            Matrix3::from_columns(&[
                n * (rm + s.pos.h_m),
                e * ((rn + s.pos.h_m) * s.pos.lat_rad.cos()),
                u,
            ])
        }
        AnyNav::Grid(_) => Matrix3::identity(),
    }
}

pub(crate) fn finite3(v: &Vector3<f64>) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::earth::{Geodetic, isa};
    use crate::frames;
    use crate::mech::FrameKind;
    use msgs::{BaroSample, CnsFix, SrsLine, SrsSample};
    use nalgebra::{SVector, UnitQuaternion};

    const T_NS: u64 = 1_000_000_000_000;

    /// A navigation state at (lat, lon) in `kind`, turned and moving (the
    /// aids' measurement-model tests share it).
    pub(crate) fn truth(kind: FrameKind, lat: f64, lon: f64) -> AnyNav {
        let geo = Geodetic::from_deg(lat, lon, 17_000.0);
        let c_e_g = frames::c_e_g(geo.lat_rad, geo.lon_rad);
        let q = UnitQuaternion::from_matrix(
            &(c_e_g.transpose() * frames::c_b_n_from_euler(0.4, 0.02, 0.05)),
        );
        let v_e = c_e_g.transpose() * Vector3::new(150.0, -190.0, 2.0);
        AnyNav::from_frame_free(kind, &earth::geodetic_to_ecef(&geo), &v_e, &q)
    }

    /// The computed state with error x = computed − true.
    pub(crate) fn computed(t: &AnyNav, x: &SVector<f64, 15>) -> AnyNav {
        let mut c = *t;
        let part = |o: usize| Vector3::new(x[o], x[o + 1], x[o + 2]);
        c.correct(
            &-part(crate::error_model::idx::PHI),
            &-part(crate::error_model::idx::DV),
            &-part(crate::error_model::idx::DP),
        );
        c
    }

    fn srs_from_truth(t: &AnyNav) -> SrsSample {
        let ff = t.frame_free();
        let c = srs::c_e_i(T_NS as f64 * 1e-9);
        let v_p = c * (ff.v_e + earth::omega_ie_e().cross(&ff.r_e));
        let dirs = [
            Vector3::new(1.0, 0.1, 0.5),
            Vector3::new(-0.3, 1.0, 0.4),
            Vector3::new(-0.7, -0.6, 0.6),
            Vector3::new(0.1, 0.2, 1.0),
        ];
        let mut s = SrsSample {
            t_ns: T_NS,
            count: 4,
            ..Default::default()
        };
        for (k, d) in dirs.iter().enumerate() {
            let los = d.normalize();
            let v_k = Vector3::new(-29_780.0, 1000.0 * k as f64, 3000.0);
            let w = v_p - v_k;
            let c2 = srs::C_LIGHT * srs::C_LIGHT;
            let opz = (srs::C_LIGHT + w.dot(&-los)) / (c2 - w.norm_squared()).sqrt();
            s.lines[k] = SrsLine {
                los_i: los.into(),
                body_vel_i_mps: v_k.into(),
                rest_wavelength_m: 5e-7,
                measured_wavelength_m: 5e-7 * opz,
                sigma_mps: 0.5,
                body_id: k as u32,
                _pad: 0,
            };
        }
        s
    }

    /// Checks H against central differences of z(computed state) for each error state.
    fn check<const M: usize>(t: &AnyNav, z_of: impl Fn(&AnyNav) -> Measurement<M>, name: &str) {
        let h = z_of(t).h;
        let steps = [1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-3];
        let pos_steps = match t.kind() {
            FrameKind::Geographic => [1e-8, 1e-8, 1.0],
            FrameKind::Grid => [1.0, 1.0, 1.0],
        };
        for j in 0..9 {
            let step = if j < 6 { steps[j] } else { pos_steps[j - 6] };
            let mut x = SVector::<f64, 15>::zeros();
            x[j] = step;
            let col = (z_of(&computed(t, &x)).z - z_of(&computed(t, &-x)).z) / (2.0 * step);
            // Relative to the largest sensitivity of this H: near-zero columns
            // (e.g. ∂h/∂x at the pole, 1.6e-7) sit at the finite-difference roundoff.
            let scale = h.amax();
            assert!(
                (col - h.column(j)).amax() <= 1e-6 * scale,
                "{name} {:?}: H[.., {j}] = {} vs FD {}",
                t.kind(),
                h.column(j).transpose(),
                col.transpose()
            );
        }
    }

    #[test]
    fn aid_jacobians_match_finite_differences_in_both_frames() {
        for (kind, lat, lon) in [
            (FrameKind::Geographic, 45.0, 10.0),
            (FrameKind::Grid, 88.0, -60.0),
            (FrameKind::Grid, 89.99999, 20.0),
            (FrameKind::Grid, 31.94, 118.79),
        ] {
            let t = truth(kind, lat, lon);
            let geo = t.geodetic();
            let cns = CnsFix {
                t_ns: T_NS,
                seq: 0,
                lat_rad: geo.lat_rad,
                lon_rad: geo.lon_rad,
                sigma_h_m: 20.0,
            };
            check(&t, |s| cns::measurement(s, &cns).expect("cns"), "CNS");
            let p = isa::pressure(isa::geopotential_from_geometric(geo.h_m));
            let baro = BaroSample {
                t_ns: T_NS,
                seq: 0,
                pressure_pa: p,
                temperature_k: 216.65,
                sigma_m: 10.0,
            };
            check(&t, |s| baro::measurement(s, &baro).expect("baro"), "baro");
            let srs_s = srs_from_truth(&t);
            check(&t, |s| srs::measurement(s, &srs_s).expect("srs").0, "SRS");
            // At the truth every innovation vanishes.
            assert!(cns::measurement(&t, &cns).expect("cns").z.amax() < 1e-6);
            assert!(baro::measurement(&t, &baro).expect("baro").z.amax() < 1e-6);
            assert!(srs::measurement(&t, &srs_s).expect("srs").0.z.amax() < 1e-5);
        }
    }
}
