//! scripts/install.sh as a package build runs it: staged under DESTDIR with
//! a PREFIX of its own (the built binaries, `cargo test --workspace`).

use std::path::{Path, PathBuf};
use std::process::Command;

use polarnav_tests::bin;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace")
        .to_path_buf()
}

/// Runs the install script into a fresh stage; returns the stage.
fn install(name: &str, prefix: &str) -> PathBuf {
    let stage =
        std::env::temp_dir().join(format!("polarnav-install-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&stage);
    std::fs::create_dir_all(&stage).expect("stage");
    let bin_dir = bin("nav-daemon").parent().expect("bin dir").to_path_buf();
    bin("sensor-replay");
    bin("gnss-ubx");
    bin("nav-mavlink");
    bin("nav-nmea");
    let o = Command::new("bash")
        .arg(repo().join("scripts/install.sh"))
        .env("DESTDIR", &stage)
        .env("PREFIX", prefix)
        .env("BIN_DIR", &bin_dir)
        .output()
        .expect("run install.sh");
    assert!(
        o.status.success(),
        "install.sh: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    stage
}

#[test]
fn installed_units_start_the_binaries_under_the_chosen_prefix() {
    let stage = install("usr", "/usr");
    let units = stage.join("etc/systemd/system");
    let mut n = 0;
    for entry in std::fs::read_dir(&units).expect("units") {
        let path = entry.expect("entry").path();
        let text = std::fs::read_to_string(&path).expect("unit");
        assert!(!text.contains("/usr/local"), "{}:\n{text}", path.display());
        for line in text.lines() {
            if let Some(cmd) = line.strip_prefix("ExecStart=") {
                let exe = cmd.split_whitespace().next().expect("ExecStart program");
                assert!(exe.starts_with("/usr/bin/"), "{}: {line}", path.display());
                let staged = stage.join(exe.trim_start_matches('/'));
                assert!(staged.is_file(), "{}: {exe} not installed", path.display());
                n += 1;
            }
            if let Some(doc) = line.strip_prefix("Documentation=file:") {
                let staged = stage.join(doc.trim_start_matches('/'));
                assert!(staged.is_file(), "{}: {doc} not installed", path.display());
            }
        }
    }
    let shipped = std::fs::read_dir(repo().join("systemd"))
        .expect("systemd/")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "service"))
        })
        .count();
    assert_eq!(n, shipped, "one ExecStart per unit, every unit installed");
    std::fs::remove_dir_all(&stage).ok();
}

#[test]
fn completions_and_man_pages_are_installed_under_the_prefix() {
    let stage = install("share", "/usr");
    let share = stage.join("usr/share");
    for b in ["nav-daemon", "sensor-replay"] {
        let bash = std::fs::read_to_string(share.join("bash-completion/completions").join(b))
            .expect("bash completion");
        assert!(bash.contains("completions") && bash.contains("man"), "{b}");
        assert!(
            share.join(format!("zsh/site-functions/_{b}")).is_file(),
            "{b} zsh"
        );
        assert!(
            share
                .join(format!("fish/vendor_completions.d/{b}.fish"))
                .is_file(),
            "{b} fish"
        );
        let page = std::fs::read_to_string(share.join(format!("man/man1/{b}.1"))).expect("man");
        assert!(
            page.lines().any(|l| l.starts_with(&format!(".TH {b} 1"))),
            "{b}: {page}"
        );
    }
    std::fs::remove_dir_all(&stage).ok();
}
