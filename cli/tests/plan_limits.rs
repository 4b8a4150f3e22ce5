//! A table larger than the reader accepts is refused when the build is planned, before any task
//! runs or any file is written.

use std::path::Path;
use std::process::Command;

/// Build manifest `m` into `dir/out`; the build must fail cleanly. Returns its output.
fn refused_build(dir: &Path, m: &Path) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(["build", m.to_str().unwrap(), "--out", "out", "-q"])
        .current_dir(dir)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap();
    let t = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!o.status.success(), "{t}");
    assert!(!t.contains("panicked"), "{t}");
    t
}

#[test]
fn a_36_gb_water_index_grid_is_refused_at_plan_time() {
    let d = tempfile::tempdir().unwrap();
    // 10 000 temperatures × ~900 000 wavelengths × 4 bytes ≈ 36 GB (33.5 GiB).
    let temps: Vec<String> = (0..10_000)
        .map(|i| format!("{}", i as f64 * 0.01))
        .collect();
    let m = d.path().join("huge.toml");
    std::fs::write(
        &m,
        format!(
            "[[table]]\nname = \"water-huge\"\nstage = \"water-index\"\n[table.params]\n\
             wavelength_nm = [200.0, 1100.0, 0.001]\ntemperature_c = [{}]\n",
            temps.join(", ")
        ),
    )
    .unwrap();
    let t = refused_build(d.path(), &m);
    for part in [
        "table `water-huge`",
        "huge.toml",
        "bytes of values (33.5 GiB)",
        "reader's limit of 4294967296 bytes",
    ] {
        assert!(t.contains(part), "missing `{part}`: {t}");
    }
    assert!(!d.path().join("out").exists(), "nothing is written");
}

/// A thesis-resolution Beard–Chuang table of 33 wavelengths and 4 sun elevations (140 GiB) is
/// refused when planned, like every stage's table over the limit, and nothing else in the
/// manifest is built.
#[test]
fn a_140_gib_ray_traced_table_is_refused_at_plan_time() {
    let d = tempfile::tempdir().unwrap();
    let m = d.path().join("bc.toml");
    std::fs::write(
        &m,
        "[[table]]\nname = \"small\"\nstage = \"water-index\"\n[table.params]\n\
         wavelength_nm = [400.0, 700.0, 10.0]\ntemperature_c = [20.0]\n\n\
         [[table]]\nname = \"bc-huge\"\nstage = \"raytrace\"\n[table.params]\n\
         shape = \"beard-chuang\"\nradii_um = [1000.0]\nsun_elevation_deg = [0.0, 20.0, 25.0, 40.0]\n\
         rays = 3000\npolar_step_deg = 0.0125\nazimuth_step_deg = 0.2\n",
    )
    .unwrap();
    let t = refused_build(d.path(), &m);
    for part in ["table `bc-huge`", "bc.toml", "GiB", "reader's limit"] {
        assert!(t.contains(part), "missing `{part}`: {t}");
    }
    assert!(!d.path().join("out").exists(), "nothing is written");
}
