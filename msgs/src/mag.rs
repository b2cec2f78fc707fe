//! The magnetometer's payload (issue 30, item 2): one three-axis sample of
//! the magnetic field in body axes, as the sensor's driver reads it, before
//! the hard- and soft-iron calibration (the navigator applies that from
//! its settings, `[aids.mag]`).
#![allow(unsafe_code)] // the ZeroCopySend derive emits `unsafe impl`; the layout is checked in tests

#[cfg(feature = "iceoryx2")]
use iceoryx2::prelude::ZeroCopySend;
use serde::{Deserialize, Serialize};

/// One magnetometer sample: the raw (uncalibrated) field in body axes
/// (x right, y forward, z up) in nanotesla, and the sensor's white noise.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "iceoryx2", derive(ZeroCopySend))]
#[repr(C)]
#[cfg_attr(feature = "iceoryx2", type_name("polarnav::MagSample_v1"))]
pub struct MagSample {
    /// Time of validity on the sensor time base.
    pub t_ns: u64,
    pub seq: u64,
    /// The measured field, body axes, nT (1 µT = 1000 nT; the Earth's field
    /// is 22 000–67 000 nT at the surface). Raw: hard and soft iron are
    /// still in it.
    pub field_b_nt: [f64; 3],
    /// 1-σ of the white noise of each axis (nT).
    pub sigma_nt: [f64; 3],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sample_has_no_implicit_padding() {
        assert_eq!(size_of::<MagSample>(), 16 + 24 + 24);
        assert_eq!(align_of::<MagSample>(), 8);
    }
}
