//! The payloads of DESIGN "Messages". All `#[repr(C)]`, fixed size, no
//! implicit padding, no pointers: safe to place in shared memory and to
//! mirror in C and Python.
#![allow(unsafe_code)] // the ZeroCopySend derive emits `unsafe impl`; the layout rules above make it sound

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// Maximum number of spectral lines in one SRS message.
pub const SRS_MAX_LINES: usize = 8;

/// One IMU sample: angle and velocity increments over `dt_s` ending at `t_ns`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::ImuSample_v1"))]
pub struct ImuSample {
    /// End of the integration interval, common sensor time base.
    pub t_ns: u64,
    /// Publisher sequence number, +1 per sample.
    pub seq: u64,
    /// Length of the integration interval (s).
    pub dt_s: f64,
    /// Angle increment ∫ω_ib^b dt, body axes (rad).
    pub d_theta_rad: [f64; 3],
    /// Velocity increment ∫f^b dt, body axes (m/s).
    pub d_v_mps: [f64; 3],
}

/// One observed spectral line of one celestial body.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::SrsLine_v1"))]
pub struct SrsLine {
    /// Unit line of sight from the carrier to the body, inertial frame.
    pub los_i: [f64; 3],
    /// Velocity of the body relative to the Earth's centre, inertial frame (m/s), from the ephemeris.
    pub body_vel_i_mps: [f64; 3],
    /// Rest (emitted) wavelength λ0 of the line (m).
    pub rest_wavelength_m: f64,
    /// Measured (received) wavelength λ (m).
    pub measured_wavelength_m: f64,
    /// 1-σ of the line's radial velocity measurement (m/s); wavelength σ = λ0·σ/c.
    pub sigma_mps: f64,
    /// Catalogue identifier of the body.
    pub body_id: u32,
    /// Always zero.
    pub _pad: u32,
}

/// Spectral-redshift observations of up to [`SRS_MAX_LINES`] bodies.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::SrsSample_v1"))]
pub struct SrsSample {
    pub t_ns: u64,
    pub seq: u64,
    /// Number of valid entries at the start of `lines`.
    pub count: u32,
    /// Always zero.
    pub _pad: u32,
    pub lines: [SrsLine; SRS_MAX_LINES],
}

impl SrsSample {
    /// The valid lines (`count` clamped to the capacity, so a corrupt count cannot index out of range).
    pub fn valid_lines(&self) -> &[SrsLine] {
        let n = (self.count as usize).min(SRS_MAX_LINES);
        &self.lines[..n]
    }
}

/// Celestial position fix: geodetic latitude and longitude.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::CnsFix_v1"))]
pub struct CnsFix {
    pub t_ns: u64,
    pub seq: u64,
    pub lat_rad: f64,
    pub lon_rad: f64,
    /// Horizontal 1-σ (m), same in every horizontal direction.
    pub sigma_h_m: f64,
}

/// Barometer: static pressure and temperature.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::BaroSample_v1"))]
pub struct BaroSample {
    pub t_ns: u64,
    pub seq: u64,
    pub pressure_pa: f64,
    pub temperature_k: f64,
    /// 1-σ of the pressure altitude derived from this sample (m).
    pub sigma_m: f64,
}

/// Star tracker: the body's attitude measured against the stars. The
/// inertial frame is DESIGN's *i* (it coincides with ECEF at `t_ns = 0` of
/// the time base and *e* then turns about z at ω_ie), so the receiver needs
/// nothing but the time stamp to bring it into the Earth frame. The sensor's
/// noise is a small rotation about its own axes: σ about the two axes across
/// the boresight, and (larger, for a star tracker) about the boresight.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::StarSample_v1"))]
pub struct StarSample {
    pub t_ns: u64,
    pub seq: u64,
    /// Measured body→inertial attitude quaternion [w, x, y, z] (the sensor's
    /// fixed mounting already applied by its driver).
    pub q_b_i: [f64; 4],
    /// The sensor's boresight, unit vector in body axes.
    pub boresight_b: [f64; 3],
    /// 1-σ of the attitude about each axis across the boresight (arcsec).
    pub sigma_cross_arcsec: f64,
    /// 1-σ of the attitude about the boresight (arcsec).
    pub sigma_boresight_arcsec: f64,
}

/// Initial state handed to the navigator (transfer alignment from a host, or
/// the truth plus a scenario's initial errors), or the one the navigator's
/// own stationary alignment made of it ([`InitState::method`] says which).
/// Frame-free: valid at the pole.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::InitState_v2"))]
pub struct InitState {
    /// Time of validity.
    pub t_ns: u64,
    pub seq: u64,
    /// Position, ECEF (m).
    pub r_e_m: [f64; 3],
    /// Earth-relative velocity, ECEF axes (m/s).
    pub v_e_mps: [f64; 3],
    /// Body→ECEF attitude quaternion [w, x, y, z].
    pub q_b_e: [f64; 4],
    /// 1-σ of position: horizontal (per axis) and vertical (m).
    pub sigma_pos_h_m: f64,
    pub sigma_pos_v_m: f64,
    /// 1-σ of velocity: horizontal (per axis) and vertical (m/s).
    pub sigma_vel_h_mps: f64,
    pub sigma_vel_v_mps: f64,
    /// 1-σ of attitude: tilt (per level axis) and heading (rad).
    pub sigma_tilt_rad: f64,
    pub sigma_heading_rad: f64,
    /// How the attitude was found ([`init_method`]): 0 given from outside
    /// (a host's transfer alignment, the configuration's `[init]`, a
    /// simulation's truth with its errors; and every init record of a
    /// navlog before format 8), 1 the navigator's levelling and
    /// gyrocompassing, 2 its levelling and an aid's heading
    /// ([`InitState::heading_aid`]). See [`InitMethod`].
    pub method: u8,
    /// With method 2, the [`AidKind`](crate::AidKind) whose heading
    /// aligned (4 star tracker, 5 dual-antenna baseline, 6 magnetometer);
    /// 0 otherwise.
    pub heading_aid: u8,
    /// Always zero.
    pub _pad: [u8; 6],
}

/// Values of [`InitState::method`].
pub mod init_method {
    /// Given from outside the navigator.
    pub const GIVEN: u8 = 0;
    /// The navigator's stationary alignment: levelling and gyrocompassing.
    pub const GYROCOMPASS: u8 = 1;
    /// The navigator's stationary alignment: levelling and an aid's
    /// heading (a MEMS IMU, paper 003 §4.4).
    pub const AID_HEADING: u8 = 2;
}

/// How an initial state's attitude was found: [`InitState::method`] and
/// [`InitState::heading_aid`] as one value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InitMethod {
    Given,
    Gyrocompass,
    AidHeading(crate::AidKind),
}

impl InitMethod {
    /// The method of the bytes `method` and `heading_aid` (of an
    /// [`InitState`] or a [`Status`](crate::Status)); `None` for values no
    /// sender writes.
    pub fn from_wire(method: u8, heading_aid: u8) -> Option<Self> {
        match (method, heading_aid) {
            (init_method::GIVEN, 0) => Some(Self::Given),
            (init_method::GYROCOMPASS, 0) => Some(Self::Gyrocompass),
            (init_method::AID_HEADING, k) => crate::AidKind::ALL
                .get(usize::from(k))
                .copied()
                .map(Self::AidHeading),
            _ => None,
        }
    }

    /// The bytes `(method, heading_aid)`.
    pub fn to_wire(self) -> (u8, u8) {
        match self {
            Self::Given => (init_method::GIVEN, 0),
            Self::Gyrocompass => (init_method::GYROCOMPASS, 0),
            Self::AidHeading(k) => (init_method::AID_HEADING, k as u8),
        }
    }
}

impl core::fmt::Display for InitMethod {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Given => f.write_str("given"),
            Self::Gyrocompass => f.write_str("levelling and gyrocompassing"),
            Self::AidHeading(k) => write!(f, "levelling and the {} heading", k.decl().label),
        }
    }
}

impl InitState {
    /// How its attitude was found (`None`: bytes no sender writes).
    pub fn init_method(&self) -> Option<InitMethod> {
        InitMethod::from_wire(self.method, self.heading_aid)
    }
}

/// Navigation frame tag used on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum WireFrame {
    /// Local geographic east-north-up.
    Geographic = 0,
    /// Grid frame (polar).
    Grid = 1,
}

impl WireFrame {
    /// The frame an [`AidStatus::made_in_frame`](crate::AidStatus::made_in_frame) byte names (1 + the
    /// frame); `None` for 0 (not known) or any other value.
    pub fn from_made_in(v: u8) -> Option<Self> {
        v.checked_sub(1).and_then(Self::from_u8)
    }

    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Geographic),
            1 => Some(Self::Grid),
            _ => None,
        }
    }
    /// The single-letter name used in the solution CSV (`g` or `G`).
    pub fn letter(self) -> char {
        match self {
            Self::Geographic => 'g',
            Self::Grid => 'G',
        }
    }
}

/// Bits of [`Solution::flags`].
pub mod solution_flags {
    pub const ALIGNED: u32 = 1 << 0;
    pub const SRS_FRESH: u32 = 1 << 1;
    pub const CNS_FRESH: u32 = 1 << 2;
    pub const BARO_FRESH: u32 = 1 << 3;
    pub const LAST_INNOVATION_REJECTED: u32 = 1 << 4;
    pub const IMU_LOST: u32 = 1 << 5;
    /// The IMU stream had a gap longer than `[filter] imu_gap_s`: the state was
    /// carried across it on extrapolated increments with inflated covariance.
    /// Cleared by the next fused aid.
    pub const COASTING: u32 = 1 << 6;
    /// The navigator was resumed from a checkpoint (cleared by the next fused aid).
    pub const RESUMED: u32 = 1 << 7;
    /// The state was reset to an aid that had been rejected at the gate for
    /// `[aids] reset_after_s` while consistent (the step is in the reset
    /// block; cleared when that aid is next fused).
    pub const AID_RESET: u32 = 1 << 8;
    /// The star tracker's attitude was fused within its timeout.
    pub const STAR_FRESH: u32 = 1 << 9;
    /// A second publisher sent on an input service in the last status period:
    /// its samples were refused (`StreamCounters::refused_publisher`).
    pub const SECOND_PUBLISHER: u32 = 1 << 10;
    /// A GNSS fix was fused within its timeout.
    pub const GNSS_FRESH: u32 = 1 << 11;
    /// GNSS is excluded by its integrity test (it disagreed with the
    /// autonomous solution; the solution is the autonomous one).
    pub const GNSS_EXCLUDED: u32 = 1 << 12;
    /// A dual-antenna GNSS baseline was fused within its timeout.
    pub const BASELINE_FRESH: u32 = 1 << 13;
    /// A magnetometer heading was fused within its timeout. (The
    /// magnetometer disabled near a magnetic pole has no bit of its own:
    /// its status counts and names the cause.)
    pub const MAG_FRESH: u32 = 1 << 14;
    /// Bits 15–16: the flight state the IMU shows (paper 003 §4.5): 0 not
    /// yet known, 1 ground, 2 steady, 3 manoeuvre.
    pub const FLIGHT_STATE_SHIFT: u32 = 15;
    pub const FLIGHT_STATE_MASK: u32 = 0b11 << FLIGHT_STATE_SHIFT;
    /// Roll and pitch were fused from the accelerometers (a steady window
    /// while no aid observing tilt was fresh) within the last two windows.
    pub const LEVEL_FUSED: u32 = 1 << 17;
    /// GNSS's integrity test is unavailable (at its last fix), so its
    /// fixes are fused untested: its horizontal protection level from the
    /// reference's covariance is beyond the alert limit (`[aids.gnss]
    /// integrity_alert_limit_m`), so the reference cannot tell a spoofed
    /// position from its own error (an INS without a horizontal
    /// autonomous aid, such as a MEMS INS with only baro and magnetometer).
    pub const GNSS_UNTESTED: u32 = 1 << 18;
}

/// Full navigation solution, one per filter cycle.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::Solution_v3"))]
pub struct Solution {
    pub t_ns: u64,
    pub seq: u64,
    /// Geodetic latitude, longitude (rad), ellipsoidal height (m).
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub h_m: f64,
    /// Position, ECEF (m).
    pub r_e_m: [f64; 3],
    /// Earth-relative velocity in ECEF axes (m/s).
    pub v_e_mps: [f64; 3],
    /// Earth-relative velocity, local east-north-up (m/s). At the exact pole the
    /// east/north axes are those of longitude `lon_rad`.
    pub v_enu_mps: [f64; 3],
    /// Earth-relative velocity in the current navigation frame (m/s).
    pub v_nav_mps: [f64; 3],
    /// Grid angle σ (rad), clockwise from true north to grid north.
    pub grid_angle_rad: f64,
    /// Body→ECEF attitude quaternion [w, x, y, z]; frame-free, valid at the pole.
    pub q_b_e: [f64; 4],
    /// True heading (clockwise from true north), grid heading, pitch, roll (rad).
    pub heading_rad: f64,
    pub grid_heading_rad: f64,
    pub pitch_rad: f64,
    pub roll_rad: f64,
    /// 1-σ of position, local east/north/up (m).
    pub sigma_pos_enu_m: [f64; 3],
    /// 1-σ of velocity in the navigation frame (m/s).
    pub sigma_vel_mps: [f64; 3],
    /// 1-σ of attitude error φ in the navigation frame (rad).
    pub sigma_att_rad: [f64; 3],
    /// Estimated gyro bias (rad/s) and accelerometer bias (m/s²), body axes.
    pub gyro_bias_rps: [f64; 3],
    pub accel_bias_mps2: [f64; 3],
    /// 1-σ of the gyro bias (rad/s) and accelerometer bias (m/s²)
    /// estimates, body axes: the square roots of the bias diagonal of the
    /// filter covariance (`_v3`). A JSON solution written before `_v3`
    /// (an older MCAP `/solution`) reads with NaN here: not known.
    #[serde(default = "unknown3")]
    pub sigma_gyro_bias_rps: [f64; 3],
    #[serde(default = "unknown3")]
    pub sigma_accel_bias_mps2: [f64; 3],
    /// The last reset of the navigation state (re-initialization, checkpoint
    /// restore, aid reset): its time (0 = none) and the step it made, so that a
    /// consumer integrating the solution can remove it. Position and velocity
    /// steps are ECEF (new − old); heading is true heading (new − old, wrapped).
    pub reset_t_ns: u64,
    pub reset_delta_pos_e_m: [f64; 3],
    pub reset_delta_vel_e_mps: [f64; 3],
    pub reset_delta_heading_rad: f64,
    /// Bit set of [`solution_flags`].
    pub flags: u32,
    /// Number of frame switches since start.
    pub switch_count: u32,
    /// Number of resets since start (see `reset_t_ns`).
    pub reset_count: u32,
    /// [`WireFrame`] as u8.
    pub frame: u8,
    /// Always zero.
    pub _pad: [u8; 3],
}

/// Three NaN: a value the record's producer did not know (serde default).
fn unknown3() -> [f64; 3] {
    [f64::NAN; 3]
}

/// Truth record of a simulated or reference flight (navlog only, not on the wire).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[repr(C)]
pub struct TruthRecord {
    pub t_ns: u64,
    /// Position, ECEF (m).
    pub r_e_m: [f64; 3],
    /// Earth-relative velocity, ECEF axes (m/s).
    pub v_e_mps: [f64; 3],
    /// Body→ECEF quaternion [w, x, y, z].
    pub q_b_e: [f64; 4],
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aids::{AID_COUNT, MAX_CAUSES, MAX_COMPONENTS, STREAM_COUNT};
    use crate::status::{AidStatus, Status, StreamCounters};
    use core::mem::{align_of, size_of};

    /// Sum of field sizes equals the struct size: no implicit padding, so the
    /// C and Python mirrors can be written field by field.
    #[test]
    fn payloads_have_no_implicit_padding() {
        assert_eq!(size_of::<ImuSample>(), 8 + 8 + 8 + 24 + 24);
        assert_eq!(size_of::<SrsLine>(), 24 + 24 + 8 + 8 + 8 + 4 + 4);
        assert_eq!(
            size_of::<SrsSample>(),
            8 + 8 + 4 + 4 + SRS_MAX_LINES * size_of::<SrsLine>()
        );
        assert_eq!(size_of::<CnsFix>(), 5 * 8);
        assert_eq!(size_of::<BaroSample>(), 5 * 8);
        assert_eq!(size_of::<StarSample>(), 16 + 32 + 24 + 16);
        assert_eq!(
            size_of::<InitState>(),
            16 + 24 + 24 + 32 + 6 * 8 + 1 + 1 + 6
        );
        assert_eq!(
            size_of::<Solution>(),
            16 + 24
                + 24
                + 24
                + 24
                + 24
                + 8
                + 32
                + 32
                + 24 * 7
                + 8
                + 24
                + 24
                + 8
                + 4
                + 4
                + 4
                + 1
                + 3
        );
        assert_eq!(size_of::<StreamCounters>(), 10 * 8);
        assert_eq!(
            size_of::<AidStatus>(),
            2 * MAX_COMPONENTS * 8 + 5 * 8 + MAX_CAUSES * 8 + 8
        );
        assert_eq!(
            size_of::<Status>(),
            16 + STREAM_COUNT * size_of::<StreamCounters>()
                + AID_COUNT * size_of::<AidStatus>()
                + 9 * 8
                + 4 * 4
                + 8
        );
        for a in [
            align_of::<ImuSample>(),
            align_of::<Solution>(),
            align_of::<Status>(),
        ] {
            assert_eq!(a, 8);
        }
    }

    #[cfg(feature = "iceoryx2")]
    #[test]
    fn type_names_are_versioned() {
        // SAFETY-free: `type_name` is an unsafe fn only to discourage casual use.
        #[allow(unsafe_code)]
        let names = unsafe {
            [
                ImuSample::type_name(),
                SrsSample::type_name(),
                CnsFix::type_name(),
                BaroSample::type_name(),
                StarSample::type_name(),
                InitState::type_name(),
                Solution::type_name(),
                Status::type_name(),
            ]
        };
        for n in names {
            assert!(n.starts_with("polarnav::") && n.contains("_v"), "{n}");
        }
    }

    #[test]
    fn srs_valid_lines_clamps_a_corrupt_count() {
        let s = SrsSample {
            count: 200,
            ..Default::default()
        };
        assert_eq!(s.valid_lines().len(), SRS_MAX_LINES);
        let s = SrsSample {
            count: 3,
            ..Default::default()
        };
        assert_eq!(s.valid_lines().len(), 3);
    }

    #[test]
    fn wire_frame_round_trips() {
        for f in [WireFrame::Geographic, WireFrame::Grid] {
            assert_eq!(WireFrame::from_u8(f as u8), Some(f));
        }
        assert_eq!(WireFrame::from_u8(7), None);
    }
}

/// Longest effective-settings text (bytes of UTF-8).
pub const SETTINGS_TEXT_MAX: usize = 8192;

/// The daemon's effective settings as TOML text: the navlog header's
/// `[navigator]` table, every key. Published once at start on
/// `<prefix>/settings` (history 1, so a flight recorder started at any time
/// receives it), so that `batch` on a recording uses exactly the settings
/// the daemon flew with.
#[derive(Clone, Copy)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::EffectiveSettings_v1"))]
pub struct EffectiveSettings {
    /// Zero (the settings hold from the daemon's start).
    pub t_ns: u64,
    pub seq: u64,
    /// Bytes of `text` used.
    pub len: u32,
    pub _pad: u32,
    pub text: [u8; SETTINGS_TEXT_MAX],
}

impl EffectiveSettings {
    /// `None` when `text` is longer than [`SETTINGS_TEXT_MAX`].
    pub fn new(seq: u64, text: &str) -> Option<Self> {
        let b = text.as_bytes();
        if b.len() > SETTINGS_TEXT_MAX {
            return None;
        }
        let mut s = Self {
            t_ns: 0,
            seq,
            len: b.len() as u32,
            _pad: 0,
            text: [0; SETTINGS_TEXT_MAX],
        };
        s.text[..b.len()].copy_from_slice(b);
        Some(s)
    }

    /// The text; `None` when the length or the UTF-8 is not valid.
    pub fn text(&self) -> Option<&str> {
        let n = usize::try_from(self.len)
            .ok()
            .filter(|n| *n <= SETTINGS_TEXT_MAX)?;
        std::str::from_utf8(&self.text[..n]).ok()
    }
}

impl std::fmt::Debug for EffectiveSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EffectiveSettings")
            .field("seq", &self.seq)
            .field("len", &self.len)
            .field("text", &self.text())
            .finish()
    }
}
