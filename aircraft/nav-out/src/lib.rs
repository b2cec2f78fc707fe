//! polarnav's outputs to the rest of the aircraft: `nav-mavlink` (MAVLink 2
//! to an autopilot) and `nav-nmea` (NMEA 0183 to payloads). Each is a
//! bridge from the daemon's `<prefix>/solution` and `<prefix>/status`
//! services to a UDP or serial link, in a process of its own (its own
//! systemd unit) so that a stalled link never touches the navigator.
//!
//! Glossary (the workspace's): `lat_rad`, `lon_rad` geodetic, `h_m`
//! ellipsoidal height, `r_e` ECEF position, `v_e` ECEF velocity, `v_enu`
//! local east-north-up velocity, `q_b_e` body→ECEF attitude with body axes
//! x right, y forward, z up; `c_e_n` ECEF→north-east-down. MAVLink's body
//! frame is front-right-down (FRD).
//!
//! - [`geo`]: the encodings (1e-7 degrees, centidegrees, NMEA minutes) and
//!   the EGM96 geoid;
//! - [`health`]: the one fix rule both protocols use;
//! - [`mav`], [`nmea`]: the messages, pure functions of solution and quality;
//! - [`feed`], [`sink`], [`bridge`]: iceoryx2 in, UDP or serial out, the loop's parts;
//! - [`mavlink_bridge`], [`nmea_bridge`]: settings and loop of each binary;
//! - [`cli`]: their common command line.

pub mod bridge;
pub mod cli;
pub mod feed;
pub mod geo;
pub mod health;
pub mod mav;
pub mod mavlink_bridge;
pub mod nmea;
pub mod nmea_bridge;
pub mod settings;
pub mod sink;
