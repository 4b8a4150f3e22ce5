//! The C interface (`c/scatterbake_table.h`, the crate's cdylib) reads tables written by the
//! Rust writer bit for bit, reads newer minor versions with unknown header fields, and refuses
//! corrupt files and newer majors: `c/example.c` is compiled with the system C compiler (`cc`,
//! required: the tests fail without it) against `libscatterbake_table` (workspace crate `capi/`)
//! and run on every test table.

mod common;

use scatterbake::table::Table;
use std::path::Path;
use std::process::Command;

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

/// `c/example.c` on `table` with `mode` (`--reconstruct`, `--entry I,J`, or nothing), dumping
/// the samples to `dump` and looking up `coords` (printed as decimal text).
fn run_dump(
    exe: &Path,
    table: &Path,
    mode: &[&str],
    dump: &Path,
    coords: &[f64],
) -> std::process::Output {
    Command::new(exe)
        .arg(table)
        .args(mode)
        .arg("--dump")
        .arg(dump)
        .args(coords.iter().map(|c| format!("{c:e}")))
        .output()
        .unwrap()
}

/// Run `c/example.c` on `table` with `mode` (`--reconstruct`, `--entry I,J`, or nothing),
/// dumping the samples and looking up `coords`; checks that it succeeds and dumps exactly
/// `want`'s samples, and returns the printed lookup with the coordinates parsed back from the
/// decimal text it was given.
fn run_checked(
    exe: &Path,
    table: &Path,
    mode: &[&str],
    coords: &[f64],
    want: &Table,
) -> (Vec<f64>, Vec<f64>) {
    let dump = table.with_extension("dump.bin");
    let out = run_dump(exe, table, mode, &dump, coords);
    let what = format!("{} {mode:?}", table.display());
    assert!(
        out.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        std::fs::read(&dump).unwrap() == common::raw_bytes(want),
        "{what}: the samples differ from the Rust reader's"
    );
    let parsed = coords
        .iter()
        .map(|c| format!("{c:e}").parse().unwrap())
        .collect();
    (
        parsed,
        printed_samples(&String::from_utf8_lossy(&out.stdout)),
    )
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
    let exe = common::c::example_exe(dir.path());
    for p in common::tables(dir.path()) {
        let t = Table::open(&p).unwrap();
        let coords = interior_point(&t);
        let dump = dir.path().join("dump.bin");
        let out = run_dump(&exe, &p, &[], &dump, &coords);
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
/// lookups; a 4.0 file with valid checksums is refused with an error naming the version.
#[test]
fn c_reader_reads_newer_minor_and_refuses_newer_major() {
    let dir = tempfile::tempdir().unwrap();
    let exe = common::c::example_exe(dir.path());
    let paths = common::synthetic_tables(dir.path());
    for p in &paths {
        let t = Table::open(p).unwrap();
        let newer = dir.path().join("newer.sbt");
        common::newer_minor_copy(p, &newer);
        let coords = interior_point(&t);
        let dump = dir.path().join("dump.bin");
        let out = run_dump(&exe, &newer, &[], &dump, &coords);
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
    let v4 = dir.path().join("v4.sbt");
    common::newer_major_copy(&paths[0], &v4);
    let out = Command::new(&exe).arg(&v4).output().unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("4.0") && err.contains("newer"), "{err}");
}

/// The crafted corpus through the C library: each valid file opens (exit 0), each invalid one
/// is refused with a message (exit 3); nothing crashes or aborts.
#[test]
fn c_reader_crafted_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let exe = common::c::example_exe(dir.path());
    let mut wrong = Vec::new();
    for case in common::crafted::cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let out = Command::new(&exe).arg(&p).output().unwrap();
        wrong.extend(common::crafted::misread(&case, &out, || true, &[]));
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Format 2.0 files (16-bit values, derived channels) through the C library, which wraps the
/// Rust reader: the valid ones open with the Rust reader's values (the example prints its
/// lookups), each broken rule is refused naming the file and the rule.
#[test]
fn c_reader_top16_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let exe = common::c::example_exe(dir.path());
    let want: Vec<u8> = common::crafted::top16_table()
        .data
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::top16_cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let dump = dir.path().join("dump.bin");
        let out = Command::new(&exe)
            .arg(&p)
            .arg("--dump")
            .arg(&dump)
            .output()
            .unwrap();
        let dumped = || std::fs::read(&dump).unwrap() == want;
        wrong.extend(common::crafted::misread(&case, &out, dumped, &[fragment]));
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
    let exe = common::c::example_exe(dir.path());
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::tensor_train_cases() {
        let p = dir.path().join(format!("{}.sbt", case.name));
        std::fs::write(&p, &case.bytes).unwrap();
        let out = Command::new(&exe)
            .arg(&p)
            .arg("--reconstruct")
            .output()
            .unwrap();
        let rule = ["tensor-train table is not valid", fragment];
        wrong.extend(common::crafted::misread(&case, &out, || true, &rule));
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in scatterbake::fur::assets::ASSET_FILES {
        let p = root.join("assets/fur-medulla").join(file);
        let t = Table::open_reconstructed(&p, &ReadLimits::default()).unwrap();
        let copy = dir.path().join(file);
        std::fs::copy(&p, &copy).unwrap();
        let (parsed, got) = run_checked(&exe, &copy, &["--reconstruct"], &interior_point(&t), &t);
        let want = t.sample(&parsed).unwrap();
        assert!(same_bits(&want, &got), "{file}: sample {want:?} vs {got:?}");
    }
}

/// One entry through `sbt_open_slice` (`c/example.c --entry`): the samples are the Rust entry
/// reader's bit for bit and the lookups at the fixed coordinates equal the whole table's; a bad
/// index is refused naming the axis; the crafted corpus is accepted and refused as by
/// `sbt_open`, with the same message.
#[test]
fn c_reader_opens_one_entry() {
    use scatterbake::table::ReadLimits;
    let dir = tempfile::tempdir().unwrap();
    let exe = common::c::example_exe(dir.path());
    let p = common::entries::entries_table(dir.path());
    let whole = Table::open(&p).unwrap();
    for entry in common::entries::entries() {
        let t = Table::open_slice(&p, &entry, &ReadLimits::default()).unwrap();
        let coords = common::entries::lookup_point(&whole, &entry);
        let list: Vec<String> = entry.iter().map(usize::to_string).collect();
        let (parsed, got) = run_checked(&exe, &p, &["--entry", &list.join(",")], &coords, &t);
        let want = whole.sample(&parsed).unwrap();
        assert!(same_bits(&want, &got), "{entry:?}: {want:?} vs {got:?}");
    }
    let out = Command::new(&exe)
        .arg(&p)
        .args(["--entry", "1,3"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("index 3 of axis `wavelength`"), "{err}");
    let wrong = common::entries::crafted_entry_mismatches(dir.path(), |p, entry| {
        let mut cmd = Command::new(&exe);
        cmd.arg(p);
        if entry {
            cmd.args(["--entry", "0"]);
        }
        cmd.output().unwrap()
    });
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// Format 3.0 files (even-periodic axes) through the C library: the valid ones open with the
/// Rust reader's values, `sbt_axis_period` gives the Rust reader's period (0 where the file
/// declares none or is 1.x or 2.x, which ignore `symmetry`) and `sbt_sample` the Rust reader's
/// lookup bit for bit at 270° (folded to 90° on a symmetric axis); each broken rule is refused
/// naming the file and the rule.
#[test]
fn c_reader_symmetry_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let exe = common::c::example_exe(dir.path());
    let mut wrong = Vec::new();
    for (case, fragment) in common::crafted::symmetry_cases() {
        let p = common::crafted::written(dir.path(), &case);
        let dump = dir.path().join("dump.bin");
        let coords = [450.0, 270.0];
        let out = run_dump(&exe, &p, &[], &dump, &coords);
        let accepted = || {
            let t = Table::open(&p).unwrap();
            let text = String::from_utf8_lossy(&out.stdout);
            let periods: Vec<f64> = text
                .lines()
                .filter(|l| l.starts_with("axis "))
                .map(|l| parse_hex_float(l.split_whitespace().nth(6).unwrap()))
                .collect();
            let want: Vec<f64> = t
                .axes()
                .iter()
                .map(|a| a.symmetry.map_or(0.0, |s| s.period()))
                .collect();
            std::fs::read(&dump).unwrap() == common::raw_bytes(&t)
                && periods == want
                && same_bits(&t.sample(&coords).unwrap(), &printed_samples(&text))
        };
        wrong.extend(common::crafted::misread(&case, &out, accepted, &[fragment]));
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
