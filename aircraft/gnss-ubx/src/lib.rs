//! `gnss-ubx`: the driver of a u-blox GNSS receiver. It reads the UBX
//! stream from a serial device (or a file), decodes NAV-PVT and
//! NAV-RELPOSNED, stamps each fix on the sensor time base and publishes
//! NAV-PVT as [`msgs::GnssFix`] on `<prefix>/gnss` and a moving-base
//! receiver's NAV-RELPOSNED, paired with its epoch's NAV-PVT, as
//! [`msgs::BaselineSample`] on `<prefix>/baseline`.
//!
//! - [`framing`]: frames found in the byte stream, every other byte
//!   counted by cause;
//! - [`decode`]: payloads decoded (the `ublox` crate) and mapped onto the
//!   wire type, units converted;
//! - [`time`]: the GPS time → sensor time rule;
//! - [`driver`]: the three together, without I/O;
//! - [`settings`]: the settings file;
//! - [`run`]: the loop around the device and the publisher.
#![warn(missing_docs)]

pub mod decode;
pub mod driver;
pub mod framing;
pub mod run;
pub mod settings;
pub mod time;
