//! The `nav-daemon` drivers around the estimator core's session: the live
//! iceoryx2 service and `batch` over a navlog.

pub mod batch;
pub mod events;
pub mod live;
pub mod notify;
pub mod owner;

/// Writes one line to standard error, as `eprintln!` does, but a closed
/// standard error (`nav-daemon batch ... 2>&1 | head`) loses the line, not
/// the run: `eprintln!` panics when the write fails.
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
