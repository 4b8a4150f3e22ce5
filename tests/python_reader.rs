//! The Python reader (`python/scatterbake_table.py`) reads tables written by the Rust writer bit
//! for bit, reproduces the lookup formula, and rejects corrupt files and newer majors.
//! Needs `python3` with numpy and zstandard (`pip install numpy zstandard`); skipped with a
//! message when those are not importable.

mod common;

use scatterbake::table::Table;
use std::path::Path;
use std::process::Command;

fn python_ok() -> bool {
    Command::new("python3")
        .args(["-c", "import numpy, zstandard"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

fn run(table: &Path, dump: &Path, coords: &[f64]) -> std::process::Output {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/test_reader.py");
    Command::new("python3")
        .arg(script)
        .arg(table)
        .arg(dump)
        .args(coords.iter().map(|c| c.to_string()))
        .output()
        .expect("python3 runs")
}

#[test]
fn python_reader_is_bit_exact_and_verifies() {
    if !python_ok() {
        eprintln!(
            "SKIPPED: python3 with numpy and zstandard not importable (pip install numpy zstandard)"
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let paths = common::tables(dir.path());
    for p in &paths {
        let t = Table::open(p).unwrap();
        // Sample at an interior point between grid samples of every axis.
        let coords: Vec<f64> = t
            .axes()
            .iter()
            .map(|a| {
                if a.len() > 1 {
                    0.37 * a.coord(0) + 0.63 * a.coord(1)
                } else {
                    a.coord(0)
                }
            })
            .collect();
        let dump = dir.path().join("dump.bin");
        let out = run(p, &dump, &coords);
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
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        for (a, ja) in t.axes().iter().zip(j["axes"].as_array().unwrap()) {
            assert_eq!(ja["name"], a.name.as_str());
            let c: Vec<u64> = ja["coords_bits"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_u64().unwrap())
                .collect();
            let want: Vec<u64> = a.coords().iter().map(|x| x.to_bits()).collect();
            assert!(
                c == want,
                "{}: axis {} coordinates differ",
                p.display(),
                a.name
            );
        }
        let want = t.sample(&coords).unwrap();
        let got: Vec<f64> = j["sample_bits"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| f64::from_bits(v.as_u64().unwrap()))
            .collect();
        for (w, g) in want.iter().zip(&got) {
            if w.is_finite() {
                assert!(
                    (w - g).abs() <= 1e-12 * w.abs().max(1e-30),
                    "{}: sample {w} vs {g}",
                    p.display()
                );
            }
        }
    }
    // Corruption anywhere in the payload, and a newer major, are refused.
    let bad = dir.path().join("bad.sbt");
    common::corrupt_copy(&paths[0], &bad, 10);
    let out = run(&bad, &dir.path().join("x.bin"), &[]);
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("checksum"));
    common::newer_major_copy(&paths[0], &bad);
    let out = run(&bad, &dir.path().join("x.bin"), &[]);
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("newer"));
}
