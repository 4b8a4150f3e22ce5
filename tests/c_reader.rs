//! The C interface (`c/scatterbake_table.h`, the crate's cdylib) reads tables written by the
//! Rust writer bit for bit, reads newer minor versions with unknown header fields, and refuses
//! corrupt files and newer majors: `c/example.c` is compiled with the system C compiler (`cc`,
//! required: the tests fail without it) against `libscatterbake_table` (workspace crate `capi/`)
//! and run on every test table.

mod common;

use scatterbake::table::Table;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Build the cdylib crate `scatterbake-capi` and return the directory holding
/// libscatterbake_table.{so,dylib}. Uses the cargo that runs this test, the same target
/// directory and the `test` profile. capi depends on the format crate `scatterbake-table` alone,
/// so only that crate's few dependencies are built for it (a no-op when up to date); building
/// the library and its test targets as well is not needed.
fn lib_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    // target/<profile dir>/deps/<test exe> -> target/<profile dir>
    let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    let target_dir = profile_dir.parent().unwrap();
    let out = Command::new(env!("CARGO"))
        .args([
            "build",
            "-p",
            "scatterbake-capi",
            "--profile",
            "test",
            "--lib",
            "--quiet",
        ])
        .arg("--manifest-path")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", target_dir)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "building the cdylib failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    profile_dir
}

fn parse_hex_float(s: &str) -> f64 {
    // C99 %a output, e.g. 0x1.8p+1, -0x0p+0.
    let (neg, s) = s.strip_prefix('-').map_or((false, s), |r| (true, r));
    let s = s.strip_prefix("0x").unwrap();
    let (mant, exp) = s.split_once('p').unwrap();
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut v = u64::from_str_radix(int, 16).unwrap() as f64;
    let mut scale = 1.0 / 16.0;
    for ch in frac.chars() {
        v += ch.to_digit(16).unwrap() as f64 * scale;
        scale /= 16.0;
    }
    let v = v * 2f64.powi(exp.parse().unwrap());
    if neg { -v } else { v }
}

/// Compile `c/example.c` against the cdylib into `dir`; returns the executable.
fn example_exe(dir: &Path) -> PathBuf {
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

/// The values of the `sample` lines printed by `c/example.c` (C99 `%a`).
fn printed_samples(stdout: &str) -> Vec<f64> {
    stdout
        .lines()
        .filter(|l| l.starts_with("sample "))
        .map(|l| l.split_whitespace().nth(2).unwrap())
        .map(|s| {
            if s.contains("nan") {
                f64::NAN
            } else if s.contains("inf") {
                if s.starts_with('-') {
                    f64::NEG_INFINITY
                } else {
                    f64::INFINITY
                }
            } else {
                parse_hex_float(s)
            }
        })
        .collect()
}

/// An interior lookup point: between the first two samples of every axis.
fn interior_point(t: &Table) -> Vec<f64> {
    t.axes()
        .iter()
        .map(|a| {
            if a.len() > 1 {
                0.37 * a.coord(0) + 0.63 * a.coord(1)
            } else {
                a.coord(0)
            }
        })
        .collect()
}

fn same_bits(want: &[f64], got: &[f64]) -> bool {
    want.len() == got.len()
        && want
            .iter()
            .zip(got)
            .all(|(w, g)| w.to_bits() == g.to_bits() || (w.is_nan() && g.is_nan()))
}

#[test]
fn c_reader_is_bit_exact_and_verifies() {
    let dir = tempfile::tempdir().unwrap();
    let exe = example_exe(dir.path());
    for p in common::tables(dir.path()) {
        let t = Table::open(&p).unwrap();
        let coords = interior_point(&t);
        let dump = dir.path().join("dump.bin");
        let out = Command::new(&exe)
            .arg(&p)
            .arg("--dump")
            .arg(&dump)
            .args(coords.iter().map(|c| format!("{c:e}")))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}: {}",
            p.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(
            std::fs::read(&dump).unwrap(),
            common::raw_bytes(&t),
            "{}: payload differs",
            p.display()
        );
        let text = String::from_utf8_lossy(&out.stdout);
        let axes: Vec<&str> = text.lines().filter(|l| l.starts_with("axis ")).collect();
        assert_eq!(axes.len(), t.axes().len());
        for (line, a) in axes.iter().zip(t.axes()) {
            let f: Vec<&str> = line.split_whitespace().collect();
            assert_eq!(f[1], a.name);
            assert_eq!(f[3].parse::<usize>().unwrap(), a.len());
            assert_eq!(parse_hex_float(f[4]).to_bits(), a.coord(0).to_bits());
            assert_eq!(
                parse_hex_float(f[5]).to_bits(),
                a.coord(a.len() - 1).to_bits()
            );
        }
        // The coordinates went through decimal text: sample Rust at the parsed-back values.
        let parsed: Vec<f64> = coords
            .iter()
            .map(|c| format!("{c:e}").parse().unwrap())
            .collect();
        let want = t.sample(&parsed).unwrap();
        let got = printed_samples(&text);
        assert!(
            same_bits(&want, &got),
            "{}: sample {want:?} vs {got:?}",
            p.display()
        );
    }
    let good = dir.path().join("hg.sbt");
    let bad = dir.path().join("bad.sbt");
    common::corrupt_copy(&good, &bad, 10);
    let out = Command::new(&exe).arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("checksum"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    common::newer_major_copy(&good, &bad);
    let out = Command::new(&exe).arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("newer"));
}

/// The format's promise through the C ABI: a 1.1 file with unknown header fields (top level and
/// nested, checksums recomputed) reads bit for bit like the 1.0 original with identical
/// lookups; a 2.0 file with valid checksums is refused with an error naming the version.
#[test]
fn c_reader_reads_newer_minor_and_refuses_newer_major() {
    let dir = tempfile::tempdir().unwrap();
    let exe = example_exe(dir.path());
    let paths = common::synthetic_tables(dir.path());
    for p in &paths {
        let t = Table::open(p).unwrap();
        let newer = dir.path().join("newer.sbt");
        common::newer_minor_copy(p, &newer);
        let coords = interior_point(&t);
        let dump = dir.path().join("dump.bin");
        let out = Command::new(&exe)
            .arg(&newer)
            .arg("--dump")
            .arg(&dump)
            .args(coords.iter().map(|c| format!("{c:e}")))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{} as 1.1: {}",
            p.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(
            std::fs::read(&dump).unwrap(),
            common::raw_bytes(&t),
            "{} as 1.1: payload differs",
            p.display()
        );
        let parsed: Vec<f64> = coords
            .iter()
            .map(|c| format!("{c:e}").parse().unwrap())
            .collect();
        let want = t.sample(&parsed).unwrap();
        let got = printed_samples(&String::from_utf8_lossy(&out.stdout));
        assert!(
            same_bits(&want, &got),
            "{} as 1.1: sample {want:?} vs {got:?}",
            p.display()
        );
    }
    let v2 = dir.path().join("v2.sbt");
    common::newer_major_copy(&paths[0], &v2);
    let out = Command::new(&exe).arg(&v2).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("2.0") && err.contains("newer"), "{err}");
}

/// The crafted corpus through the C library: each valid file opens (exit 0), each invalid one
/// is refused with a message (exit 3); nothing crashes or aborts.
#[test]
fn c_reader_crafted_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let exe = example_exe(dir.path());
    let mut wrong = Vec::new();
    for case in common::crafted::cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let out = Command::new(&exe).arg(&p).output().unwrap();
        let code = out.status.code();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let ok = if case.valid {
            code == Some(0)
        } else {
            code == Some(3) && stderr.contains(case.name)
        };
        if !ok {
            wrong.push(format!(
                "{}: valid={} exit {code:?}: {stderr}",
                case.name, case.valid
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Tensor-train tables through `sbt_open_reconstructed`: the valid crafted one and the shipped
/// medulla assets reconstruct bit for bit like the Rust reader (`Table::open_reconstructed`,
/// the same code), with identical lookups; each crafted inconsistency is refused with a
/// message naming the file and the rule.
#[test]
fn c_reader_reconstructs_tensor_trains() {
    use scatterbake::table::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    let exe = example_exe(dir.path());
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::tensor_train_cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let out = Command::new(&exe)
            .arg(&p)
            .arg("--reconstruct")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        let ok = if case.valid {
            out.status.code() == Some(0)
        } else {
            out.status.code() == Some(3)
                && stderr.contains(case.name)
                && stderr.contains("tensor-train table is not valid")
                && stderr.contains(fragment)
        };
        if !ok {
            wrong.push(format!(
                "{}: exit {:?}: {stderr}",
                case.name,
                out.status.code()
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in scatterbake::fur::assets::ASSET_FILES {
        let p = root.join("assets/fur-medulla").join(file);
        let t = Table::open_reconstructed(&p, &ReadLimits::default()).unwrap();
        let coords = interior_point(&t);
        let dump = dir.path().join("dump.bin");
        let out = Command::new(&exe)
            .arg(&p)
            .arg("--reconstruct")
            .arg("--dump")
            .arg(&dump)
            .args(coords.iter().map(|c| format!("{c:e}")))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{file}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            std::fs::read(&dump).unwrap() == common::raw_bytes(&t),
            "{file}: reconstructed values differ from the Rust reader's"
        );
        let parsed: Vec<f64> = coords
            .iter()
            .map(|c| format!("{c:e}").parse().unwrap())
            .collect();
        let want = t.sample(&parsed).unwrap();
        let got = printed_samples(&String::from_utf8_lossy(&out.stdout));
        assert!(same_bits(&want, &got), "{file}: sample {want:?} vs {got:?}");
    }
}
