//! What built this program: its version and the git commit of the checkout
//! (embedded by `build.rs`), for `--version`, the start-up log and the
//! provenance of every file the programs write.

/// `git rev-parse --short=12 HEAD` of the build, `-dirty` when tracked files
/// differed from it, `unknown` when built outside a git checkout.
pub const COMMIT: &str = env!("POLARNAV_GIT_COMMIT");

/// The package version.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// `--version`'s text after the program name: `0.1.0 (commit 1a2b3c4d5e6f)`.
pub const LONG_VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("POLARNAV_GIT_COMMIT"),
    ")"
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The commit is 12 hex digits (with `-dirty`) in a checkout, or says
    /// it is unknown; never empty, never anything else.
    #[test]
    fn commit_is_hex_or_unknown() {
        let hex = COMMIT.strip_suffix("-dirty").unwrap_or(COMMIT);
        assert!(
            COMMIT == "unknown" || (hex.len() == 12 && hex.bytes().all(|b| b.is_ascii_hexdigit())),
            "{COMMIT:?}"
        );
        assert!(LONG_VERSION.contains(COMMIT) && LONG_VERSION.starts_with(VERSION));
    }
}
