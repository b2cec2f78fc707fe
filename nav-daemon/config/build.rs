//! Embeds the git commit of the checkout being built as
//! `POLARNAV_GIT_COMMIT` (`build_info::COMMIT`): `git rev-parse --short=12
//! HEAD`, with `-dirty` when tracked files differ from it, or `unknown`
//! outside a git checkout of this workspace (a source tarball, no git).

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(root)
        .args(args)
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
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
    // changes (dirty or clean again); not on every build.
    if ours {
        for args in [
            ["rev-parse", "--git-dir"],
            ["rev-parse", "--git-common-dir"],
        ] {
            if let Some(d) = git(&root, &args) {
                let d = root.join(d);
                for f in ["HEAD", "index", "packed-refs", "refs"] {
                    println!("cargo:rerun-if-changed={}", d.join(f).display());
                }
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
