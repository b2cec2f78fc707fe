//! The `nav-daemon` drivers around the estimator core's session: the live
//! iceoryx2 service and `batch` over a navlog.

pub mod batch;
pub mod csv_pipe;
pub mod events;
pub mod imu_rate;
pub mod live;
pub mod mcap_pipe;
pub mod notify;
pub mod owner;
pub mod services;

/// `note!`: a line on standard error that a closed standard error loses
/// without ending the run (the processes' shared macro, in
/// `polarnav_ipc::logging`).
pub use polarnav_ipc::note;
