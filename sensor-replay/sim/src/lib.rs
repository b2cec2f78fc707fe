//! polarnav flight simulator: a scenario file (trajectory, sensor errors, aid
//! rates and noise, injected faults) becomes a navlog with truth records.

pub mod aids;
pub mod faults;
pub mod scenario;
pub mod sensors;
pub mod simulate;
pub mod trajectory;
