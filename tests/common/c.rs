//! The executables the tests run: the C example (`c/example.c`) compiled against
//! the C library (`capi/`), the table format crate's example `open_entry` and the command line
//! (`cli/`), each built with
//! the cargo that runs the tests, into the same target directory and profile.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Build `args` (a `cargo build` of one target) with the cargo that runs this test, the same
/// target directory and the `test` profile, and return that profile's output directory.
fn cargo_build(args: &[&str]) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    // target/<profile dir>/deps/<test exe> -> target/<profile dir>
    let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    let target_dir = profile_dir.parent().unwrap();
    let out = Command::new(env!("CARGO"))
        .arg("build")
        .args(args)
        .args(["--profile", "test", "--quiet"])
        .arg("--manifest-path")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", target_dir)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo build {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    profile_dir
}

/// Build the cdylib crate `scatterbake-capi` and return the directory holding
/// libscatterbake_table.{so,dylib}. Uses the cargo that runs this test, the same target
/// directory and the `test` profile. capi depends on the format crate `scatterbake-table` alone,
/// so only that crate's few dependencies are built for it (a no-op when up to date); building
/// the library and its test targets as well is not needed.
fn lib_dir() -> PathBuf {
    cargo_build(&["-p", "scatterbake-capi", "--lib"])
}

/// Compile `c/example.c` against the cdylib into `dir`; returns the executable.
pub fn example_exe(dir: &Path) -> PathBuf {
    let libdir = lib_dir();
    assert!(
        libdir.join("libscatterbake_table.so").exists()
            || libdir.join("libscatterbake_table.dylib").exists(),
        "cdylib not found in {}",
        libdir.display()
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = dir.join("sbt-example");
    let cc = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-I"])
        .arg(root.join("c"))
        .arg(root.join("c/example.c"))
        .arg("-L")
        .arg(&libdir)
        .arg("-lscatterbake_table")
        .arg(format!("-Wl,-rpath,{}", libdir.display()))
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| {
            panic!("the C reader tests need a C compiler `cc` on PATH (running it failed: {e})")
        });
    assert!(
        cc.status.success(),
        "cc failed: {}",
        String::from_utf8_lossy(&cc.stderr)
    );
    exe
}

/// Build the table format crate's example `open_entry` (`table-format/examples/open_entry.rs`:
/// `Table::open_slice` of one entry) and return the executable.
pub fn open_entry_exe() -> PathBuf {
    let dir = cargo_build(&["-p", "scatterbake-table", "--example", "open_entry"]);
    dir.join("examples").join("open_entry")
}

/// Build the command line (`cli/`, binary `scatterbake`) and return the executable.
pub fn cli_exe() -> PathBuf {
    let dir = cargo_build(&["-p", "scatterbake-cli", "--bin", "scatterbake"]);
    dir.join("scatterbake")
}
