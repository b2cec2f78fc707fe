//! The dual-antenna GNSS receiver's payload (the sixth aid, issue 30): the
//! baseline from the moving-base (primary) antenna to the rover
//! (secondary) antenna, modelled on u-blox UBX-NAV-RELPOSNED (version 1),
//! whose fields a driver copies (converted to SI units) into
//! [`BaselineSample`].
//!
//! Besides NAV-RELPOSNED's content the sample carries the latitude and
//! longitude whose north-east-down axes the baseline is expressed in (the
//! receiver's own fix of the same epoch, NAV-PVT with the same `iTOW`).
//! With them the navigator turns the baseline back into Earth axes
//! exactly as the receiver turned it into NED, so the measurement holds
//! at the exact pole, where north depends on the longitude the receiver
//! chose (GNSS's velocity is converted the same way, from its own fix).
#![allow(unsafe_code)] // the ZeroCopySend derive emits `unsafe impl`; the layout is checked in tests

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// Carrier-phase solutions of [`BaselineSample::carr_soln`] (NAV-RELPOSNED
/// `flags.carrSoln`).
pub mod carr_soln {
    /// No carrier-phase solution (u-blox: 0; named apart from
    /// `fix_type::NONE`, as the C header has one namespace).
    pub const NO_CARRIER: u8 = 0;
    /// Float ambiguities: decimetres, not a heading reference.
    pub const FLOAT: u8 = 1;
    /// Fixed ambiguities: millimetres.
    pub const FIXED: u8 = 2;
}

/// Bits of [`BaselineSample::flags`]: NAV-RELPOSNED `flags` without its
/// two-bit `carrSoln` (which is [`BaselineSample::carr_soln`]), packed.
pub mod baseline_flags {
    /// `gnssFixOK`: the receiver's fix is valid.
    pub const GNSS_FIX_OK: u8 = 1 << 0;
    /// `diffSoln`: differential corrections were applied (named apart
    /// from `fix_flags::DIFF_SOLN`, as the C header has one namespace).
    pub const DIFF_CORRECTED: u8 = 1 << 1;
    /// `relPosValid`: the relative position components and accuracies are valid.
    pub const REL_POS_VALID: u8 = 1 << 2;
    /// `isMoving`: the receiver runs in moving-base mode.
    pub const IS_MOVING: u8 = 1 << 3;
    /// `refPosMiss`: the moving base's position was extrapolated this epoch.
    pub const REF_POS_MISS: u8 = 1 << 4;
    /// `refObsMiss`: the moving base's observations were extrapolated this epoch.
    pub const REF_OBS_MISS: u8 = 1 << 5;
    /// `relPosHeadingValid`: `heading_rad` and `acc_heading_rad` are valid.
    pub const HEADING_VALID: u8 = 1 << 6;
    /// `relPosNormalized`: `rel_pos_ned_m` is a unit vector (the length is
    /// `length_m`).
    pub const NORMALIZED: u8 = 1 << 7;
}

/// One baseline of a moving-base receiver: the vector from the primary
/// (moving-base) antenna to the secondary (rover) antenna in the
/// north-east-down axes of (`lat_rad`, `lon_rad`), with the receiver's own
/// 1-σ accuracy estimates.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::BaselineSample_v1"))]
pub struct BaselineSample {
    /// Time of validity on the sensor time base (the driver maps the
    /// receiver's time of the epoch onto it).
    pub t_ns: u64,
    pub seq: u64,
    /// The position whose north-east-down axes the baseline is in (rad):
    /// the receiver's fix of the same epoch.
    pub lat_rad: f64,
    pub lon_rad: f64,
    /// Baseline north, east, down (m): `relPosN/E/D` with their
    /// high-precision parts.
    pub rel_pos_ned_m: [f64; 3],
    /// Baseline length (m): `relPosLength` with its high-precision part.
    pub length_m: f64,
    /// Heading of the baseline, clockwise from north (rad), and its
    /// accuracy (rad): `relPosHeading`, `accHeading`; valid with
    /// [`baseline_flags::HEADING_VALID`]. Informative: the navigator fuses
    /// the vector, which holds at the pole, where heading does not.
    pub heading_rad: f64,
    pub acc_heading_rad: f64,
    /// Accuracy (1-σ) of the north, east, down components (m): `accN/E/D`.
    pub acc_ned_m: [f64; 3],
    /// GPS time of week of the epoch (ms), NAV-RELPOSNED `iTOW`.
    pub itow_ms: u32,
    /// [`carr_soln`].
    pub carr_soln: u8,
    /// [`baseline_flags`].
    pub flags: u8,
    /// Always zero.
    pub _pad: u16,
}

impl BaselineSample {
    /// A carrier-phase solution with fixed ambiguities that the receiver
    /// calls valid.
    pub fn is_fixed(&self) -> bool {
        use baseline_flags::{GNSS_FIX_OK, REL_POS_VALID};
        self.carr_soln == carr_soln::FIXED
            && self.flags & REL_POS_VALID != 0
            && self.flags & GNSS_FIX_OK != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_baseline_has_no_implicit_padding() {
        assert_eq!(size_of::<BaselineSample>(), 16 + 16 + 24 + 24 + 24 + 8);
        assert_eq!(align_of::<BaselineSample>(), 8);
    }

    #[test]
    fn only_a_valid_fixed_solution_is_fixed() {
        use baseline_flags::*;
        let ok = BaselineSample {
            carr_soln: carr_soln::FIXED,
            flags: GNSS_FIX_OK | REL_POS_VALID,
            ..Default::default()
        };
        assert!(ok.is_fixed());
        for c in [carr_soln::NO_CARRIER, carr_soln::FLOAT, 3] {
            assert!(!BaselineSample { carr_soln: c, ..ok }.is_fixed(), "{c}");
        }
        assert!(
            !BaselineSample {
                flags: GNSS_FIX_OK,
                ..ok
            }
            .is_fixed()
        );
        assert!(
            !BaselineSample {
                flags: REL_POS_VALID,
                ..ok
            }
            .is_fixed()
        );
    }
}
