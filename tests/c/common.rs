//! What the C tests share: the library built, installed into a stage by
//! `scripts/install.sh`, and a C file compiled against it.

use std::path::{Path, PathBuf};
use std::process::Command;

use polarnav_tests::repo;

/// The target directory's profile directory (where `libpolarnav_pub.so` is).
pub fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable");
    exe.parent()
        .and_then(Path::parent)
        .expect("target directory")
        .to_owned()
}

/// The library built (`cargo test` builds its rlib only, not the shared
/// library a C program links) and installed with `scripts/install.sh` into
/// `dir/stage` (PREFIX /usr), once per directory; returns the stage.
pub fn install_stage(dir: &Path) -> PathBuf {
    let profile = if lib_dir().ends_with("release") {
        vec!["--release"]
    } else {
        vec![]
    };
    let st = Command::new(env!("CARGO"))
        .args(["build", "--quiet", "-p", "polarnav-pub", "--lib"])
        .args(&profile)
        .current_dir(repo("."))
        .status()
        .expect("cargo");
    assert!(st.success(), "cargo build -p polarnav-pub failed");
    let stage = dir.join("stage");
    if !stage.join("usr/lib/pkgconfig/polarnav_pub.pc").exists() {
        let o = Command::new("bash")
            .arg(repo("scripts/install.sh"))
            .env("DESTDIR", &stage)
            .env("PREFIX", "/usr")
            .env("BIN_DIR", lib_dir())
            .output()
            .expect("install.sh");
        assert!(
            o.status.success(),
            "install.sh: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    stage
}

/// Compiles `source` (a path in the repository) into `dir/NAME` against
/// the library installed in [`install_stage`], with its pkg-config file's
/// flags, every warning an error.
pub fn compile(source: &str, dir: &Path) -> PathBuf {
    let stage = install_stage(dir);
    let flags = Command::new("pkg-config")
        .args(["--cflags", "--libs", "polarnav_pub"])
        .env("PKG_CONFIG_PATH", stage.join("usr/lib/pkgconfig"))
        .env("PKG_CONFIG_SYSROOT_DIR", &stage)
        .output()
        .expect("pkg-config");
    assert!(flags.status.success(), "pkg-config polarnav_pub");
    let flags = String::from_utf8(flags.stdout).expect("flags");
    let installed = stage.join("usr/lib");
    assert!(
        flags.contains(&format!(
            "-I{}",
            stage.join("usr/include/polarnav").display()
        )) && flags.contains(&format!("-L{}", installed.display())),
        "{flags}"
    );
    let name = Path::new(source)
        .file_stem()
        .and_then(|s| s.to_str())
        .expect("a C file");
    let exe = dir.join(name);
    let out = Command::new("cc")
        .args(["-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic"])
        .arg("-D_POSIX_C_SOURCE=200809L")
        .arg(repo(source))
        .args(flags.split_whitespace())
        .arg("-lm")
        .arg(format!("-Wl,-rpath,{}", installed.display()))
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("cc");
    assert!(
        out.status.success(),
        "cc {source}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}
