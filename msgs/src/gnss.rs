//! The GNSS receiver's payload (the fifth aid, issue 29): what a receiver
//! reports of one fix, modelled on u-blox UBX-NAV-PVT, whose fields a
//! driver copies (converted to SI units) into [`GnssFix`].
#![allow(unsafe_code)] // the ZeroCopySend derive emits `unsafe impl`; the layout is checked in tests

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// Fix types of [`GnssFix::fix_type`] (NAV-PVT `fixType`).
pub mod fix_type {
    /// No fix.
    pub const NONE: u8 = 0;
    /// Dead reckoning only.
    pub const DEAD_RECKONING: u8 = 1;
    pub const FIX_2D: u8 = 2;
    pub const FIX_3D: u8 = 3;
    /// GNSS and dead reckoning combined (a 3D fix).
    pub const GNSS_DEAD_RECKONING: u8 = 4;
    /// Time only.
    pub const TIME_ONLY: u8 = 5;
}

/// Bits of [`GnssFix::flags`]: bits 0 and 1 are NAV-PVT `flags`' (a
/// driver copies those two only: NAV-PVT's other bits, psmState,
/// headVehValid and carrSoln, are not carried); bit 7 is polarnav's own.
pub mod fix_flags {
    /// `gnssFixOK`: the fix is valid (within the receiver's DOP and accuracy masks).
    pub const FIX_OK: u8 = 1 << 0;
    /// `diffSoln`: differential corrections were applied.
    pub const DIFF_SOLN: u8 = 1 << 1;
    /// The source reports no velocity (a position-only solution file, such
    /// as KF-GINS's 7-column GNSS file): `vel_ned_mps` and `s_acc_mps`
    /// are not a measurement and only the position is fused. NAV-PVT has
    /// no such bit (a u-blox receiver always reports its velocity).
    pub const NO_VELOCITY: u8 = 1 << 7;
}

/// One GNSS fix: the position and velocity of the receiver's antenna,
/// with the receiver's own accuracy estimates. Every σ is the receiver's
/// 1-σ estimate; `h_acc_m` is taken as the σ of each horizontal axis (as
/// PX4 and ArduPilot take a u-blox receiver's `hAcc`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::GnssFix_v1"))]
pub struct GnssFix {
    /// Time of validity of the fix on the sensor time base (the driver maps
    /// the receiver's time of the fix onto it).
    pub t_ns: u64,
    pub seq: u64,
    /// Geodetic latitude and longitude (rad), WGS-84 ellipsoidal height (m).
    pub lat_rad: f64,
    pub lon_rad: f64,
    pub height_m: f64,
    /// Velocity north, east, down (m/s), in the axes of the fix's own
    /// latitude and longitude.
    pub vel_ned_mps: [f64; 3],
    /// Horizontal (per axis) and vertical position accuracy estimates (m).
    pub h_acc_m: f64,
    pub v_acc_m: f64,
    /// Speed accuracy estimate (m/s), taken per velocity axis.
    pub s_acc_mps: f64,
    /// Position dilution of precision.
    pub pdop: f64,
    /// The receiver's time of the fix: GPS time of week (ms), NAV-PVT `iTOW`.
    pub itow_ms: u32,
    /// [`fix_type`].
    pub fix_type: u8,
    /// Satellites used in the fix.
    pub num_sv: u8,
    /// [`fix_flags`].
    pub flags: u8,
    /// Always zero.
    pub _pad: u8,
}

impl GnssFix {
    /// A 3D fix the receiver calls valid.
    pub fn is_3d(&self) -> bool {
        matches!(
            self.fix_type,
            fix_type::FIX_3D | fix_type::GNSS_DEAD_RECKONING
        ) && self.flags & fix_flags::FIX_OK != 0
    }

    /// The fix carries a velocity (not [`fix_flags::NO_VELOCITY`]).
    pub fn has_velocity(&self) -> bool {
        self.flags & fix_flags::NO_VELOCITY == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fix_has_no_implicit_padding() {
        assert_eq!(size_of::<GnssFix>(), 16 + 24 + 24 + 32 + 4 + 4);
        assert_eq!(align_of::<GnssFix>(), 8);
    }

    #[test]
    fn only_a_valid_3d_fix_is_3d() {
        let ok = GnssFix {
            fix_type: fix_type::FIX_3D,
            flags: fix_flags::FIX_OK,
            ..Default::default()
        };
        assert!(ok.is_3d());
        assert!(
            GnssFix {
                fix_type: fix_type::GNSS_DEAD_RECKONING,
                ..ok
            }
            .is_3d()
        );
        for t in [
            fix_type::NONE,
            fix_type::DEAD_RECKONING,
            fix_type::FIX_2D,
            fix_type::TIME_ONLY,
            9,
        ] {
            assert!(!GnssFix { fix_type: t, ..ok }.is_3d(), "type {t}");
        }
        assert!(!GnssFix { flags: 0, ..ok }.is_3d(), "not gnssFixOK");
    }
}
