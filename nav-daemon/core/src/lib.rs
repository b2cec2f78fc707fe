//! polarnav estimator core: a value you feed time-stamped inputs and read
//! solutions and status from. It knows no transport, no file format of its
//! settings, no command line and no plotting: the live daemon, `batch`, the
//! fault campaign, the tests and the benches all drive the same
//! [`session::Session`].
//!
//! Glossary of names (KF-GINS style, used everywhere in this crate):
//! - frames: `i` inertial, `e` ECEF, `g` local geographic ENU, `grid`/`G`
//!   grid, `n` whichever nav frame is in use, `b` body (x right, y forward, z up);
//! - `c_a_b`: DCM mapping a vector from frame a to frame b; `q_a_b` the same as a quaternion;
//! - `v_n`: Earth-relative velocity in nav axes; `r_e`: ECEF position;
//! - `omega_ie_n`: Earth rate in nav axes; `omega_en_n`: transport rate; `omega_in_n` their sum;
//! - `f_b`: specific force in body axes; `d_theta`, `d_v`: IMU increments.
//!
//! Units are SI (rad, m, s) inside the math; names carry units at the boundaries.

pub mod aids;
pub mod align;
pub mod bounds;
pub mod checkpoint;
pub mod chi2;
pub mod earth;
pub mod error_model;
pub mod filter;
pub mod flight_state;
pub mod frame_select;
pub mod frames;
pub mod inbox;
pub mod integrity;
pub mod mat15;
pub mod mech;
pub mod navigator;
pub mod row_interval;
pub mod session;
pub mod settings;
pub mod smoother;
pub mod solution_csv;
pub mod switch;
