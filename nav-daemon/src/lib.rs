//! The `nav-daemon` drivers around the estimator core's session: the live
//! iceoryx2 service and `batch` over a navlog.

pub mod batch;
pub mod events;
pub mod live;
pub mod notify;
pub mod owner;
