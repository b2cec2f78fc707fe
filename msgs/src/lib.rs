//! polarnav wire types.
//!
//! Every payload that crosses iceoryx2 shared memory is defined here as a
//! `#[repr(C)]`, `Copy`, fixed-size type with an explicit, versioned
//! `ZeroCopySend` type name (feature `iceoryx2`) (opening a service checks only name, size and
//! alignment, so a layout change must bump the `_vN` suffix). Fields are
//! ordered so that no implicit padding exists; where alignment needs it an
//! explicit `_pad` field is present and always zero. That keeps the C header
//! and the Python ctypes mirror one-to-one with the Rust layout.
//!
//! Units are in the field names (`_rad`, `_m`, `_mps`, `_pa`, `_ns`, ...).
//! Frames: `_e` ECEF, `_i` inertial, `_enu` local geographic east-north-up,
//! `_nav` the navigation frame currently in use (g or G, see
//! [`solution::Solution::frame`]); body axes are x right, y forward, z up.
//!
//! The [`navlog`] module defines the on-disk record stream (postcard records,
//! CRC-32 protected, COBS-framed) that the simulator, the recorder and
//! `nav-daemon batch` share.

pub mod aids;
pub mod baseline;
pub mod finite;
pub mod gnss;
pub mod mag;
pub mod navlog;
pub mod payloads;
pub mod service;
pub mod status;

pub use aids::{
    AID_COUNT, AidDecl, AidKind, AidPayload, AidSample, PerAid, PerStream, STREAM_COUNT, Stream,
};
pub use baseline::BaselineSample;
pub use gnss::GnssFix;
pub use mag::MagSample;
pub use payloads::*;
pub use status::{AidStatus, Status, StreamCounters, integrity_state, unavailable};
