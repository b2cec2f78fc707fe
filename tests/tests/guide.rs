//! The guide's command blocks, run and compared with trycmd: every
//! ```` ```console ```` block of the getting-started and reference chapters
//! (`docs/src/getting-started/*.md`, `docs/src/reference/*.md`) is a
//! command (`$ ...`), its exit status if not 0 (`? 2`) and its output
//! (standard output and error together). A command whose output changes
//! fails here until the guide shows the new output.
//!
//! Update the guide from what the commands print now:
//! `TRYCMD=overwrite cargo test -p polarnav-tests --test guide` (then
//! review the diff: times, paths and versions stay redacted as `[..]`).
//!
//! The commands run as a reader runs them from the repository's root, but
//! in a temporary directory with `config/` and `tests/` linked into it, so
//! the files they write land there. Needs the binaries built
//! (`cargo test --workspace` builds them; alone, `cargo build --bins`).

use std::path::Path;

#[test]
fn the_guides_commands_print_what_the_guide_shows() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace root");
    let bins: Vec<_> = polarnav_tests::BINARIES
        .iter()
        .map(|b| (*b, polarnav_tests::bin(b)))
        .collect();
    let dir = Scratch(std::env::temp_dir().join(format!("polarnav-guide-{}", std::process::id())));
    let _ = std::fs::remove_dir_all(&dir.0);
    std::fs::create_dir_all(&dir.0).expect("a temporary directory");
    for d in ["config", "tests"] {
        std::os::unix::fs::symlink(repo.join(d), dir.0.join(d)).expect("link into it");
    }
    // The commands' working directory: this test binary runs this one test,
    // so the process's directory is nobody else's.
    std::env::set_current_dir(&dir.0).expect("enter it");
    let cases = trycmd::TestCases::new();
    for (name, path) in &bins {
        cases.register_bin(*name, path.as_path());
    }
    cases
        // Log lines as the service's journal shows them, without colour.
        .env("RUST_LOG", "info")
        .env("NO_COLOR", "1")
        .case(repo.join("docs/src/getting-started/*.md"))
        .case(repo.join("docs/src/reference/*.md"));
    let run = std::panic::catch_unwind(|| cases.run());
    std::env::set_current_dir(repo).expect("leave it");
    if run.is_err() {
        panic!(
            "a command of the guide printed other than the guide shows (above). If the new \
             output is right, update the guide with: TRYCMD=overwrite cargo test -p \
             polarnav-tests --test guide (then restore the [..] redactions it replaced, \
             and regenerate docs/src/reference/cli.generated.md with: POLARNAV_BLESS=1 \
             cargo test -p polarnav-tests --test references)"
        );
    }
}

/// A directory removed when dropped, also when the test fails.
struct Scratch(std::path::PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
