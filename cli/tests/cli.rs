//! End-to-end tests of the `scatterbake` binary: errors, verify, exports, interrupted builds,
//! concurrent builds.

mod common;
use common::text;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_scatterbake"));
    c.env("SOURCE_DATE_EPOCH", "1700000000");
    c.env_remove("SLURM_ARRAY_TASK_ID");
    c.env_remove("JOB_COMPLETION_INDEX");
    c
}

fn run(args: &[&str], cwd: &Path) -> Output {
    bin()
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run scatterbake")
}

fn assert_clean_failure(o: &Output, must_contain: &[&str]) {
    let t = text(o);
    assert!(!o.status.success(), "expected failure: {t}");
    assert!(!t.contains("panicked"), "must not panic: {t}");
    for m in must_contain {
        assert!(t.contains(m), "output should mention `{m}`: {t}");
    }
}

/// A manifest of `n` small water-index tasks (one per temperature).
fn manifest(dir: &Path, name: &str, n: usize) -> PathBuf {
    let temps: Vec<String> = (0..n).map(|i| format!("{}.0", i * 90 / n.max(1))).collect();
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(
        &p,
        format!(
            "[[table]]\nname = \"{name}\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = [300.0, 1000.0, 0.5]\ntemperature_c = [{}]\n",
            temps.join(", ")
        ),
    )
    .unwrap();
    p
}

#[test]
fn build_verify_inspect_export() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), "w", 4);
    let o = run(
        &["build", m.to_str().unwrap(), "--out", "tables", "-q"],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let table = d.path().join("tables/w.sbt");
    let o = run(&["verify", table.to_str().unwrap()], d.path());
    assert!(o.status.success(), "{}", text(&o));
    let o = run(&["inspect", table.to_str().unwrap()], d.path());
    assert!(text(&o).contains("water-index/1"));
    let o = run(
        &["inspect", table.to_str().unwrap(), "--entry", "1"],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("entry:") && text(&o).contains("samples per channel"));
    let o = run(
        &["inspect", table.to_str().unwrap(), "--entry", "99"],
        d.path(),
    );
    assert_clean_failure(&o, &["w.sbt", "index 99 of axis", "out of range"]);
    let cat: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.path().join("tables/index.json")).unwrap())
            .unwrap();
    assert_eq!(cat["tables"][0]["name"], "w");
    assert_eq!(cat["tables"][0]["schema"], "water-index/1");
    for (fmt, file) in [("csv", "w.csv"), ("json", "w.json"), ("exr", "w.exr")] {
        let o = run(
            &[
                "export",
                table.to_str().unwrap(),
                "--format",
                fmt,
                "--out",
                file,
            ],
            d.path(),
        );
        assert!(o.status.success(), "{}", text(&o));
    }
    let csv = std::fs::read_to_string(d.path().join("w.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4 * 1401);
    assert!(csv.starts_with("temperature [degC],wavelength [nm],n [1]"));
    let exr = exr::prelude::read_all_flat_layers_from_file(d.path().join("w.exr")).unwrap();
    let layer = &exr.layer_data[0];
    assert_eq!(layer.size.width(), 1401);
    assert_eq!(layer.size.height(), 4);
    // Second run: everything up to date.
    let o = run(
        &["build", m.to_str().unwrap(), "--out", "tables", "-q"],
        d.path(),
    );
    assert!(
        text(&o).contains("0 table(s), 1 up to date"),
        "{}",
        text(&o)
    );
}

#[test]
fn bad_inputs_fail_cleanly() {
    let d = tempfile::tempdir().unwrap();
    // Not a table.
    std::fs::write(d.path().join("junk.sbt"), b"hello world, not a table").unwrap();
    let o = run(&["verify", "junk.sbt"], d.path());
    assert_clean_failure(&o, &["junk.sbt", "not a scatterbake table"]);
    // Truncated table.
    let m = manifest(d.path(), "w", 2);
    assert!(
        run(
            &["build", m.to_str().unwrap(), "--out", "t", "-q"],
            d.path()
        )
        .status
        .success()
    );
    let good = std::fs::read(d.path().join("t/w.sbt")).unwrap();
    std::fs::write(d.path().join("cut.sbt"), &good[..good.len() / 2]).unwrap();
    let o = run(&["inspect", "cut.sbt"], d.path());
    assert_clean_failure(&o, &["cut.sbt", "truncated"]);
    let o = run(&["verify", "t/w.sbt", "cut.sbt"], d.path());
    assert_clean_failure(&o, &["1 of 2"]);
    // Missing file.
    assert_clean_failure(&run(&["inspect", "nope.sbt"], d.path()), &["nope.sbt"]);
    // Malformed manifests: syntax, unknown key, wrong type, out of range.
    let cases = [
        ("[[table]\nname=1", "syntax"),
        (
            "[[table]]\nname = \"a\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = [400.0, 500.0, 1.0]\ntemperature_c = [20.0]\ncolour = 2\n",
            "bad.toml:7",
        ),
        (
            "[[table]]\nname = \"a\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = \"blue\"\ntemperature_c = [20.0]\n",
            "bad.toml:5",
        ),
        (
            "[[table]]\nname = \"a\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = [400.0, 500.0, 1.0]\ntemperature_c = [-40.0]\n",
            "bad.toml:6",
        ),
    ];
    for (src, expect) in cases {
        std::fs::write(d.path().join("bad.toml"), src).unwrap();
        let o = run(&["build", "bad.toml", "--out", "t2", "-q"], d.path());
        assert_clean_failure(&o, &[expect]);
    }
    assert!(!d.path().join("t2/a.sbt").exists());
    // Bad CLI arguments.
    assert_clean_failure(
        &run(&["build", m.to_str().unwrap(), "--shard", "3/2"], d.path()),
        &["shard"],
    );
    assert_clean_failure(
        &run(
            &["export", "t/w.sbt", "--format", "png", "--out", "x"],
            d.path(),
        ),
        &["png"],
    );
}

fn chunk_count(out: &Path) -> usize {
    std::fs::read_dir(out.join(".work/w"))
        .map(|r| {
            r.filter(|e| {
                e.as_ref()
                    .unwrap()
                    .path()
                    .extension()
                    .is_some_and(|x| x == "chunk")
            })
            .count()
        })
        .unwrap_or(0)
}

#[test]
fn killed_build_resumes_to_identical_tables_without_recomputing() {
    let d = tempfile::tempdir().unwrap();
    let n = 24;
    let m = manifest(d.path(), "w", n);
    // Reference: an uninterrupted build.
    let o = run(
        &["build", m.to_str().unwrap(), "--out", "ref", "-q"],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    // Interrupted build: slow tasks, killed once some checkpoints exist.
    let mut child = bin()
        .args([
            "build",
            m.to_str().unwrap(),
            "--out",
            "int",
            "-q",
            "--jobs",
            "2",
        ])
        .current_dir(d.path())
        .env("SCATTERBAKE_TEST_TASK_DELAY_MS", "150")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let out = d.path().join("int");
    let t0 = Instant::now();
    while chunk_count(&out) < 6 && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let killed_pid = child.id();
    child.kill().unwrap();
    child.wait().unwrap();
    let done = chunk_count(&out);
    // What a kill during a table or catalog write leaves: a temporary file of the dead process.
    let orphan = out.join(format!(
        ".w.sbt.{}.{killed_pid}.Ab12Cd.tmp",
        scatterbake::table::format::host_tag()
    ));
    std::fs::write(&orphan, b"partial").unwrap();
    assert!(
        done >= 6 && done < n,
        "killed with {done} of {n} tasks done"
    );
    assert!(
        !out.join("w.sbt").exists(),
        "no table before all tasks finish"
    );
    // Resume.
    let o = run(
        &["build", m.to_str().unwrap(), "--out", "int", "-q"],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains(&format!("{} computed, {} reused", n - done, done)),
        "resume must reuse the {done} finished tasks: {t}"
    );
    assert_eq!(
        std::fs::read(out.join("w.sbt")).unwrap(),
        std::fs::read(d.path().join("ref/w.sbt")).unwrap(),
        "resumed table must be byte-identical"
    );
    assert!(!out.join(".work").exists(), "checkpoints cleaned up");
    assert!(
        !orphan.exists(),
        "the killed build's temporary file is removed"
    );
}

#[test]
fn concurrent_builds_leave_valid_tables() {
    let d = tempfile::tempdir().unwrap();
    let m1 = manifest(d.path(), "w", 12);
    let m2 = manifest(d.path(), "v", 12);
    let spawn = || {
        bin()
            .args([
                "build",
                m1.to_str().unwrap(),
                m2.to_str().unwrap(),
                "--out",
                "shared",
                "-q",
                "--jobs",
                "2",
            ])
            .current_dir(d.path())
            .env("SCATTERBAKE_TEST_TASK_DELAY_MS", "20")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let a = spawn();
    let b = spawn();
    let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
    assert!(a.status.success(), "{}", text(&a));
    assert!(b.status.success(), "{}", text(&b));
    let o = run(&["verify", "shared/w.sbt", "shared/v.sbt"], d.path());
    assert!(o.status.success(), "{}", text(&o));
    let cat: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.path().join("shared/index.json")).unwrap())
            .unwrap();
    assert_eq!(cat["tables"].as_array().unwrap().len(), 2, "{cat}");
    assert_eq!(cat["invalid"].as_array().unwrap().len(), 0);
}

#[test]
fn sharded_build_assembles_and_matches_unsharded() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), "w", 10);
    assert!(
        run(
            &["build", m.to_str().unwrap(), "--out", "ref", "-q"],
            d.path()
        )
        .status
        .success()
    );
    let o = run(
        &[
            "build",
            m.to_str().unwrap(),
            "--out",
            "sh",
            "-q",
            "--shard",
            "0/3",
        ],
        d.path(),
    );
    assert!(text(&o).contains("1 pending"), "{}", text(&o));
    let o = bin()
        .args(["build", m.to_str().unwrap(), "--out", "sh", "-q"])
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(text(&o).contains("1 pending"), "{}", text(&o));
    let o = bin()
        .args(["build", m.to_str().unwrap(), "--out", "sh", "-q"])
        .env("JOB_COMPLETION_INDEX", "2")
        .env("SCATTERBAKE_SHARD_COUNT", "3")
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(text(&o).contains("built 1 table"), "{}", text(&o));
    assert_eq!(
        std::fs::read(d.path().join("sh/w.sbt")).unwrap(),
        std::fs::read(d.path().join("ref/w.sbt")).unwrap()
    );
    let o = run(&["catalog", "sh"], d.path());
    assert!(
        o.status.success() && text(&o).contains("1 table(s)"),
        "{}",
        text(&o)
    );
}

/// `scatterbake dual-scattering`: `--absorption R,G,B` in comma form; the lossless fibre
/// conserves energy per θ (ā_f + ā_b = 1, an identity of the model, not of the CLI); a wrong
/// value count is a clean error.
#[test]
fn dual_scattering_command_line() {
    let d = tempfile::tempdir().unwrap();
    let o = run(
        &[
            "dual-scattering",
            "--absorption",
            "0,0,0",
            "--theta-samples",
            "9",
            "--format",
            "json",
        ],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (a_f, a_b) = (v["a_f"].as_array().unwrap(), v["a_b"].as_array().unwrap());
    assert_eq!(a_f.len(), 9);
    for (f, b) in a_f.iter().zip(a_b) {
        for c in 0..3 {
            let s = f[c].as_f64().unwrap() + b[c].as_f64().unwrap();
            assert!((s - 1.0).abs() < 1e-4, "a_f + a_b = {s}");
        }
    }
    let o = run(&["dual-scattering", "--absorption", "0.2,0.3"], d.path());
    assert_clean_failure(&o, &["--absorption", "three"]);
}

/// A reader that closes the pipe early (`scatterbake stages | head -1`) ends the command
/// quietly with exit code 0: no panic message, no "Broken pipe" error.
#[test]
fn closed_stdout_exits_quietly() {
    for args in [
        &["stages"][..],
        &["mie", "--radius-um", "400", "--wavelength-nm", "650"],
    ] {
        let mut child = bin()
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn scatterbake");
        // Close the read end before the command writes: its first write fails with EPIPE.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("wait");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

/// `mie` and `raytrace` speak one vocabulary: with their defaults both use the IAPWS R9-97 index
/// of water (the thesis table by the same name in both), and `i_perp` is the normalised
/// perpendicular component (1/sr) in both, the raw |S1|² being `s1_sq`. At 0.4 mm and 650 nm the
/// ray-traced 1-D sphere path agrees with Lorenz–Mie at 138° (primary bow) within 5 %, compared
/// like with like: the mean of each command's point values over the 0.5° window
/// 137.75–138.25° in 0.01° steps, which averages out the cross-order ripple (period ≈ 0.2°) that
/// point values of both carry.
#[test]
fn mie_and_raytrace_share_the_index_and_the_meaning_of_i_perp() {
    let d = tempfile::tempdir().unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let o = run(args, d.path());
        assert!(o.status.success(), "{}", text(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let query = |command: &str, extra: &[&str]| {
        let mut a = vec![command, "--radius-um", "400", "--wavelength-nm", "650"];
        a.extend(["--angles", "137.75:138.25:0.01", "--format", "json"]);
        a.extend(extra);
        json(&a)
    };
    let col = |v: &serde_json::Value, key: &str| -> Vec<f64> {
        v[key]
            .as_array()
            .unwrap_or_else(|| panic!("no column {key}: {v}"))
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let n = |v: &serde_json::Value| v["m"][0].as_f64().unwrap();
    let (mie, rt) = (query("mie", &[]), query("raytrace", &[]));
    assert_eq!(n(&mie), n(&rt));
    assert!(
        (n(&mie) - 1.33167).abs() < 1e-5,
        "IAPWS n(650 nm) = {}",
        n(&mie)
    );
    let (ip_mie, ip_rt) = (col(&mie, "i_perp"), col(&rt, "i_perp"));
    assert_eq!((ip_mie.len(), ip_rt.len()), (51, 51));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let ratio = mean(&ip_rt) / mean(&ip_mie);
    assert!(
        (ratio - 1.0).abs() < 0.05,
        "i_perp over 137.75–138.25°: raytrace {} / mie {} = {ratio}",
        mean(&ip_rt),
        mean(&ip_mie)
    );
    // i_perp = |S1|²/(π x² Q_sca); |S1|² itself is s1_sq.
    let x = 2.0 * std::f64::consts::PI * 400.0 / 0.65;
    let norm = std::f64::consts::PI * x * x * mie["qsca"].as_f64().unwrap();
    for (s1, ip) in col(&mie, "s1_sq").iter().zip(&ip_mie) {
        assert!((s1 / norm / ip - 1.0).abs() < 1e-9);
    }
    // The thesis table by one name in both commands.
    let thesis = ["--water-index-model", "sadeghi-table-3.2"];
    assert_eq!(n(&query("mie", &thesis)), 1.331);
    assert_eq!(n(&query("raytrace", &thesis)), 1.331);
}

#[test]
fn five_concurrent_builds_all_succeed() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), "w", 8);
    let children: Vec<_> = (0..5)
        .map(|_| {
            bin()
                .args([
                    "build",
                    m.to_str().unwrap(),
                    "--out",
                    "shared",
                    "-q",
                    "--jobs",
                    "1",
                ])
                .current_dir(d.path())
                .env("SCATTERBAKE_TEST_TASK_DELAY_MS", "5")
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", text(&o));
    }
    let o = run(&["verify", "shared/w.sbt"], d.path());
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn concurrent_shards_assemble_every_table() {
    let d = tempfile::tempdir().unwrap();
    let ms: Vec<PathBuf> = (0..4)
        .map(|i| manifest(d.path(), &format!("t{i}"), 3))
        .collect();
    let children: Vec<_> = (0..3)
        .map(|i| {
            let mut c = bin();
            c.arg("build");
            for m in &ms {
                c.arg(m);
            }
            c.args(["--out", "shared", "-q", "--jobs", "1", "--shard"])
                .arg(format!("{i}/3"))
                .current_dir(d.path())
                .env("SCATTERBAKE_TEST_TASK_DELAY_MS", "10")
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", text(&o));
    }
    for i in 0..4 {
        let p = d.path().join(format!("shared/t{i}.sbt"));
        assert!(p.exists(), "table t{i} was not assembled");
    }
}

#[cfg(unix)]
#[test]
fn symlinked_work_dir_is_refused_and_outside_kept() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), "w", 2);
    let outside = d.path().join("outside");
    std::fs::create_dir_all(outside.join("w")).unwrap();
    std::fs::write(outside.join("w/keep.txt"), "x").unwrap();
    std::fs::create_dir_all(d.path().join("out")).unwrap();
    std::os::unix::fs::symlink(&outside, d.path().join("out/.work")).unwrap();
    let o = run(
        &[
            "build",
            m.to_str().unwrap(),
            "--out",
            "out",
            "-q",
            "--force",
        ],
        d.path(),
    );
    assert_clean_failure(&o, &[".work", "symbolic link"]);
    assert!(
        outside.join("w/keep.txt").exists(),
        "a directory outside --out was deleted"
    );
}

#[test]
fn slurm_task_id_without_count_is_an_error() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), "w", 2);
    let o = bin()
        .args(["build", m.to_str().unwrap(), "--out", "out", "-q"])
        .current_dir(d.path())
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env_remove("SLURM_ARRAY_TASK_COUNT")
        .output()
        .unwrap();
    assert_clean_failure(&o, &["SLURM_ARRAY_TASK_COUNT"]);
}

#[test]
fn verify_refuses_non_table_files_from_the_magic() {
    let d = tempfile::tempdir().unwrap();
    // A non-table file is refused from its magic.
    std::fs::write(d.path().join("zeros.sbt"), vec![0u8; 4096]).unwrap();
    let o = run(&["verify", "zeros.sbt"], d.path());
    assert_clean_failure(&o, &["zeros.sbt", "bad magic"]);
    let o = run(&["verify", "/dev/zero"], d.path());
    assert_clean_failure(&o, &["/dev/zero", "bad magic"]);
}

/// `mie --n-medium`: a sphere in a medium is the sphere of relative index and size parameter in
/// the medium; both Q_back conventions are stated.
#[test]
fn mie_in_a_medium_is_the_relative_sphere() {
    let d = tempfile::tempdir().unwrap();
    let json = |args: &[&str]| -> serde_json::Value {
        let o = run(args, d.path());
        assert!(o.status.success(), "{}", text(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let medium = json(&[
        "mie",
        "--radius-um",
        "1",
        "--wavelength-nm",
        "500",
        "--index",
        "1.5+0.01i",
        "--n-medium",
        "1.25",
        "--angles-deg",
        "0,180",
        "--format",
        "json",
    ]);
    let x = 2.0 * std::f64::consts::PI * 1.25 / 0.5;
    let relative = json(&[
        "mie",
        "--x",
        &x.to_string(),
        "--index",
        "1.2+0.008i",
        "--angles-deg",
        "0,180",
        "--format",
        "json",
    ]);
    for key in ["qext", "qsca", "qback", "g"] {
        let (a, b) = (
            medium[key].as_f64().unwrap(),
            relative[key].as_f64().unwrap(),
        );
        assert!((a - b).abs() <= 1e-12 * b.abs(), "{key}: {a} vs {b}");
    }
    assert_eq!(medium["n_medium"].as_f64(), Some(1.25));
    let (qb, per_sr) = (
        medium["qback"].as_f64().unwrap(),
        medium["qback_per_sr"].as_f64().unwrap(),
    );
    assert!((qb / per_sr / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-12);
}

/// A coated sphere from the command line, with both Q_back conventions in every format; a core
/// larger than the sphere and Debye orders of a coated sphere are refused.
#[test]
fn mie_coated_sphere_and_both_backscatter_conventions() {
    let d = tempfile::tempdir().unwrap();
    for format in ["table", "csv"] {
        let o = run(
            &[
                "mie",
                "--x",
                "50",
                "--core-x",
                "10",
                "--index",
                "1.33",
                "--core-index",
                "1.95+0.79i",
                "--angle-step-deg",
                "30",
                "--format",
                format,
            ],
            d.path(),
        );
        let t = text(&o);
        assert!(o.status.success(), "{t}");
        for needle in [
            "coated sphere: core x_c = 10",
            "Q_back = ",
            "radar",
            "Q_back_per_sr = ",
            "MiePlot",
        ] {
            assert!(t.contains(needle), "{format} output lacks `{needle}`: {t}");
        }
    }
    assert_clean_failure(
        &run(
            &[
                "mie",
                "--x",
                "50",
                "--core-x",
                "60",
                "--index",
                "1.33",
                "--core-index",
                "2",
            ],
            d.path(),
        ),
        &["core size parameter"],
    );
    assert_clean_failure(
        &run(
            &[
                "mie",
                "--x",
                "50",
                "--core-x",
                "10",
                "--index",
                "1.33",
                "--core-index",
                "2",
                "--debye-orders",
                "2",
            ],
            d.path(),
        ),
        &["homogeneous spheres only"],
    );
}

/// `validate` reads a MiePlot text file (title lines, a tab-separated header naming the
/// columns) and compares one sphere computed on the spot: MiePlot's gold intensities agree to
/// 1e-9; another index is reported as a real difference and fails the tolerance.
#[test]
fn validate_reads_a_mieplot_file_for_one_sphere() {
    let d = tempfile::tempdir().unwrap();
    let reference =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/mieplot_gold_x10.txt");
    let reference = reference.to_str().unwrap();
    let ok = run(
        &[
            "validate",
            "--reference",
            reference,
            "--x",
            "10",
            "--index",
            "0.1425812+3.6813284i",
            "--tolerance",
            "1e-9",
        ],
        d.path(),
    );
    let t = text(&ok);
    assert!(ok.status.success(), "{t}");
    assert!(
        t.contains("10 rows") && t.contains("named by the header"),
        "{t}"
    );
    assert!(
        t.contains("large absorbing x") && t.contains("agreement"),
        "{t}"
    );
    let off = run(
        &[
            "validate",
            "--reference",
            reference,
            "--x",
            "10",
            "--index",
            "0.15+3.68i",
            "--tolerance",
            "1e-9",
        ],
        d.path(),
    );
    assert_clean_failure(&off, &["REAL DIFFERENCE", "exceeds tolerance"]);
}

/// `validate TABLE --reference POINTS` compares like with like: the point output of
/// `scatterbake mie` is taken through the table's bin and sun-disc averages (read from its
/// header), the entry and wavelength come from the reference's own lines, and the default
/// table settings agree to 1e-4. The same data in a MiePlot layout (raw |S|², titles giving the
/// radius in mm and the wavelength in µm) agrees after --rescale; without it, compared point
/// by point, or sampled too coarsely, the failure says why.
#[test]
fn validate_a_table_against_point_references_like_with_like() {
    let d = tempfile::tempdir().unwrap();
    let points = validate_bow_table_against_points(d.path());
    validate_mieplot_layout_after_rescale(d.path(), &points);
    validate_names_coarse_and_ambiguous_references(d.path(), &points);
}

/// Builds `t/bow.sbt` (radii 40 and 50 µm) in `dir`, writes `points.txt` (`mie` at 50 µm,
/// 0.005°), checks that it validates the table, and returns it.
fn validate_bow_table_against_points(dir: &Path) -> String {
    std::fs::write(
        dir.join("m.toml"),
        "[[table]]\nname = \"bow\"\nstage = \"mie\"\n[table.params]\nradii_um = [40.0, 50.0]\n\
         wavelengths_nm = [650.0]\nangle_step_deg = 0.05\nsun_diameter_deg = 0.5\n",
    )
    .unwrap();
    let b = run(&["build", "m.toml", "--out", "t"], dir);
    assert!(b.status.success(), "{}", text(&b));
    let mie = run(
        &[
            "mie",
            "--radius-um",
            "50",
            "--wavelength-nm",
            "650",
            "--angle-step-deg",
            "0.005",
        ],
        dir,
    );
    assert!(mie.status.success(), "{}", text(&mie));
    let points = String::from_utf8(mie.stdout).unwrap();
    std::fs::write(dir.join("points.txt"), &points).unwrap();
    let ok = run(
        &[
            "validate",
            "t/bow.sbt",
            "--reference",
            "points.txt",
            "--tolerance",
            "1e-4",
        ],
        dir,
    );
    let t = text(&ok);
    assert!(ok.status.success(), "{t}");
    assert!(
        t.contains("[radius=50 um]") && t.contains("at 650 nm"),
        "{t}"
    );
    assert!(t.contains("taken through the table's operators"), "{t}");
    assert!(t.contains("0.5 deg uniform sun disc"), "{t}");
    points
}

/// The points of [`validate_bow_table_against_points`] in a MiePlot layout (raw intensities on
/// another scale, titles in mm and µm): they validate after --rescale only.
fn validate_mieplot_layout_after_rescale(dir: &Path, points: &str) {
    // the same numbers in a MiePlot layout: raw intensities (any scale), titles in mm and µm
    let mut mieplot = String::from(
        "MiePlot-style export\nRadius = 0.05 mm\nWavelength = 0.65 um\n\nAngle\tIntensity (perpendicular)\tIntensity (parallel)\n",
    );
    for line in points.lines().filter(|l| !l.starts_with('#')) {
        let f: Vec<f64> = line
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        mieplot.push_str(&format!(
            "{}\t{:e}\t{:e}\n",
            f[0],
            3.7e4 * f[1],
            3.7e4 * f[2]
        ));
    }
    std::fs::write(dir.join("mieplot.txt"), mieplot).unwrap();
    let args = |extra: &[&'static str]| {
        let mut a = vec![
            "validate",
            "t/bow.sbt",
            "--reference",
            "mieplot.txt",
            "--tolerance",
            "1e-4",
        ];
        a.extend_from_slice(extra);
        a
    };
    let rescaled = run(&args(&["--rescale"]), dir);
    assert!(rescaled.status.success(), "{}", text(&rescaled));
    assert!(text(&rescaled).contains("[radius=50 um]"));
    assert_clean_failure(&run(&args(&[]), dir), &["try --rescale"]);
    assert_clean_failure(
        &run(&args(&["--rescale", "--reference-kind", "binned"]), dir),
        &["--reference-kind point"],
    );
}

/// A reference sampled too coarsely names its sampling error; one that does not say which radius
/// it is, against a table of two, is refused.
fn validate_names_coarse_and_ambiguous_references(dir: &Path, points: &str) {
    // a coarse reference: the sampling error is named
    let coarse = run(
        &[
            "mie",
            "--radius-um",
            "50",
            "--wavelength-nm",
            "650",
            "--angle-step-deg",
            "0.05",
        ],
        dir,
    );
    std::fs::write(dir.join("coarse.txt"), coarse.stdout).unwrap();
    assert_clean_failure(
        &run(
            &[
                "validate",
                "t/bow.sbt",
                "--reference",
                "coarse.txt",
                "--tolerance",
                "1e-4",
            ],
            dir,
        ),
        &["angle step (0.05 deg) limits"],
    );
    // a table of two radii and a reference that does not say which: refused, not guessed
    let bare: String = points
        .lines()
        .filter(|l| !l.starts_with("# radius_um"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.join("bare.txt"), bare).unwrap();
    assert_clean_failure(
        &run(&["validate", "t/bow.sbt", "--reference", "bare.txt"], dir),
        &["--entry radius=VALUE"],
    );
}

/// `scatterbake raytrace` refuses what the `raytrace` stage refuses, with the same reasons (one
/// domain, `raytrace::domain`), naming the option.
#[test]
fn raytrace_options_outside_the_tracers_domain_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let base = [
        "raytrace",
        "--wavelength-nm",
        "550",
        "--angles",
        "130:140:0.5",
    ];
    for (extra, expected) in [
        (
            vec!["--radius-um", "5"],
            "--radius-um 5 µm is outside 10–5000 µm",
        ),
        (
            vec![
                "--radius-um",
                "1000",
                "--shape",
                "beard-chuang",
                "--rays",
                "4",
            ],
            "--rays 4 is outside 8–20000",
        ),
        (
            vec![
                "--radius-um",
                "1000",
                "--shape",
                "beard-chuang",
                "--sun-elevation-deg",
                "95",
            ],
            "--sun-elevation-deg 95° is outside 0–90°",
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        assert_clean_failure(&run(&args, d.path()), &[expected]);
    }
}

/// A compact table of mirror symmetric entries stores 0°–180° of azimuth (table format 3.0):
/// `inspect` says the axis is even-periodic, `verify` accepts it, and `plot-raytrace` reads
/// it on the full circle (the bows at 180°, the mirror image of no stored knot beyond it).
#[test]
fn compact_symmetric_tables_inspect_verify_and_plot() {
    let d = tempfile::tempdir().unwrap();
    let m = d.path().join("compact.toml");
    std::fs::write(
        &m,
        "[[table]]\nname = \"c\"\nstage = \"raytrace\"\n[table.params]\nshape = \"beard-chuang\"\nradii_um = [1500.0]\nwavelengths_nm = [550.0]\nsun_elevation_deg = [30.0]\nrays = 60\npolar_step_deg = 0.25\nazimuth_step_deg = 10.0\ndiagnostic_channels = false\ncompression = { kind = \"sun-disc-resampled\", tolerance = 0.05, norm = \"rms\", values = \"top16\", mantissa_bits = 7 }\n",
    )
    .unwrap();
    let o = run(
        &[
            "build",
            m.to_str().unwrap(),
            "--out",
            "tables",
            "-q",
            "--no-previews",
        ],
        d.path(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let table = d.path().join("tables/c.sbt");
    assert_eq!(&std::fs::read(&table).unwrap()[8..12], &[3, 0, 0, 0]);
    let o = run(&["verify", table.to_str().unwrap()], d.path());
    assert!(o.status.success(), "{}", text(&o));
    let o = run(&["inspect", table.to_str().unwrap()], d.path());
    let out = text(&o);
    let azimuth = (out.lines())
        .find(|l| l.trim_start().starts_with("outgoing_azimuth"))
        .unwrap();
    assert!(
        azimuth.contains("… 180") && azimuth.contains("even-periodic, period 360"),
        "{azimuth}"
    );
    let png = d.path().join("bows.png");
    let o = run(
        &[
            "plot-raytrace",
            table.to_str().unwrap(),
            "--out",
            png.to_str().unwrap(),
        ],
        d.path(),
    );
    assert!(o.status.success() && png.is_file(), "{}", text(&o));
}
