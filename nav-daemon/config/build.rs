//! Embeds the git commit of the checkout being built as
//! `POLARNAV_GIT_COMMIT` (`build_info::COMMIT`): `git rev-parse --short=12
//! HEAD`, with `-dirty` when tracked files differ from it, or `unknown`
//! outside a git checkout of this workspace (a source tarball, no git).

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(root: &Path, args: &[&str]) -> Option<String> {
    // --no-optional-locks: `git status` must not refresh and rewrite the
    // index, which this script watches (a rewrite during the run would make
    // the next build run it again).
    let out = Command::new("git")
        .arg("--no-optional-locks")
        .arg("-C")
        .arg(root)
        .args(args)
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// The files whose change can change the commit or the dirty mark: this
/// worktree's `HEAD` and `index`, and the ref `HEAD` names. A loose ref is
/// rewritten by every commit; a ref only in `packed-refs` gets a loose file
/// at the next commit, so then `packed-refs` and the nearest existing
/// directory of that loose file are watched (cargo watches a directory's
/// entries, created and removed ones included). The main worktree's `HEAD`
/// and `index` and the other branches are not watched: they change no
/// commit of this one.
fn commit_files(root: &Path) -> Vec<PathBuf> {
    let dir = |arg: &str| git(root, &["rev-parse", arg]).map(|d| root.join(d));
    let (Some(git_dir), Some(common)) = (dir("--git-dir"), dir("--git-common-dir")) else {
        return Vec::new();
    };
    let mut files = vec![git_dir.join("HEAD"), git_dir.join("index")];
    // The reftable format keeps every ref in one directory.
    files.push(common.join("reftable"));
    // A detached HEAD holds the commit itself.
    if let Some(name) = git(root, &["symbolic-ref", "-q", "HEAD"]) {
        let loose = common.join(&name);
        if loose.exists() {
            files.push(loose);
        } else {
            files.push(common.join("packed-refs"));
            if let Some(d) = loose.ancestors().skip(1).find(|d| d.exists()) {
                files.push(d.to_path_buf());
            }
        }
    }
    files
}

fn main() {
    // The checkout this run builds, from cargo's environment at run time:
    // `env!` would bake in the directory the script was compiled in, and
    // cargo reuses a compiled build script for a copy of the checkout
    // elsewhere (its fingerprint does not depend on the path).
    let Some(manifest_dir) = std::env::var_os("CARGO_MANIFEST_DIR") else {
        println!("cargo:rustc-env=POLARNAV_GIT_COMMIT=unknown");
        return;
    };
    let root = PathBuf::from(manifest_dir).join("../..");
    let root = root.canonicalize().unwrap_or(root);
    // Only this workspace's own repository: a tarball unpacked inside some
    // other checkout must not take that checkout's commit.
    let ours = git(&root, &["rev-parse", "--show-toplevel"])
        .and_then(|t| PathBuf::from(t).canonicalize().ok())
        .is_some_and(|t| t == root);
    let commit = ours
        .then(|| git(&root, &["rev-parse", "--short=12", "HEAD"]))
        .flatten()
        .filter(|c| !c.is_empty() && c.bytes().all(|b| b.is_ascii_hexdigit()));
    let text = match commit {
        Some(c) => {
            let dirty = git(&root, &["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty { format!("{c}-dirty") } else { c }
        }
        None => "unknown".to_owned(),
    };
    println!("cargo:rustc-env=POLARNAV_GIT_COMMIT={text}");
    // Again when the commit or the index moves, or a source of the binaries
    // changes (dirty or clean again); not on every build. Only paths that
    // exist: cargo takes a missing one as changed, and would rerun this
    // script, and rebuild every crate after it, on every build (a clone may
    // have no `packed-refs`; a worktree's own git directory has neither it
    // nor the branch refs, which are in the common directory).
    if ours {
        for p in commit_files(&root) {
            if p.exists() {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        }
    }
    for p in [
        "Cargo.toml",
        "Cargo.lock",
        "msgs",
        "nav-daemon",
        "sensor-replay",
    ] {
        println!("cargo:rerun-if-changed={}", root.join(p).display());
    }
}
