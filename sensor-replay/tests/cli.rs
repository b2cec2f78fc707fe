//! sensor-replay's command line takes the daemon's prefix rule.

use std::process::Command;

#[test]
fn a_bad_prefix_is_refused_by_every_subcommand_that_takes_one() {
    for sub in [
        vec!["listen", "--duration", "0.1"],
        vec!["record", "--out", "/nonexistent/x.navlog"],
        vec!["play", "/nonexistent/x.navlog"],
    ] {
        for bad in ["a b", "x/", "iox2://x"] {
            let o = Command::new(env!("CARGO_BIN_EXE_sensor-replay"))
                .args(&sub)
                .args(["--prefix", bad])
                .output()
                .expect("run");
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{sub:?} {bad:?}: {err}");
            assert!(
                err.contains("--prefix") && err.contains(bad),
                "{sub:?} {bad:?}: {err}"
            );
        }
    }
}
