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

/// Steps that are infinite, huge or tiny are refused when planned, naming the key, for every
/// stage with a uniform grid; none reaches a task (a division by a zero count, an overflowing
/// sample count or an allocation the size of the address space).
#[test]
fn hostile_grid_steps_are_refused_when_planned() {
    let stages = [
        (
            "mie",
            "radii_um = [10.0]\nwavelengths_nm = [550.0]\nangle_step_deg = {v}",
            "angle_step_deg",
        ),
        (
            "debye",
            "radii_um = [10.0]\nwavelengths_nm = [550.0]\nangle_step_deg = {v}",
            "angle_step_deg",
        ),
        (
            "mixture",
            "distributions = [{ kind = \"monodisperse\", radius_um = 10.0 }]\nwavelengths_nm = [550.0]\nangle_step_deg = {v}",
            "angle_step_deg",
        ),
        (
            "raytrace",
            "shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [550.0]\nangle_step_deg = {v}",
            "angle_step_deg",
        ),
        (
            "raytrace",
            "shape = \"beard-chuang\"\nradii_um = [1000.0]\nwavelengths_nm = [550.0]\nrays = 16\npolar_step_deg = {v}\nazimuth_step_deg = 10.0",
            "polar_step_deg",
        ),
        (
            "raytrace",
            "shape = \"beard-chuang\"\nradii_um = [1000.0]\nwavelengths_nm = [550.0]\nrays = 16\npolar_step_deg = 1.0\nazimuth_step_deg = {v}",
            "azimuth_step_deg",
        ),
    ];
    let d = tempfile::tempdir().unwrap();
    for v in ["inf", "1e308", "1e-300", "200.0", "nan"] {
        for (stage, params, key) in stages {
            let m = d.path().join("m.toml");
            std::fs::write(
                &m,
                format!(
                    "[[table]]\nname = \"t\"\nstage = \"{stage}\"\n[table.params]\n{}\n",
                    params.replace("{v}", v)
                ),
            )
            .unwrap();
            let t = refused_build(d.path(), &m);
            assert!(
                t.contains(key) && t.contains("m.toml:"),
                "{stage} {key} = {v}: {t}"
            );
            assert!(
                !d.path().join("out").exists(),
                "{stage} {key} = {v}: nothing is written"
            );
        }
    }
    // A water-index step so small that its sample count overflows.
    let m = d.path().join("w.toml");
    std::fs::write(
        &m,
        "[[table]]\nname = \"w\"\nstage = \"water-index\"\n[table.params]\nwavelength_nm = [400.0, 700.0, 1e-300]\ntemperature_c = [20.0]\n",
    )
    .unwrap();
    let t = refused_build(d.path(), &m);
    assert!(
        t.contains("wavelength_nm") && t.contains("1e6 samples"),
        "{t}"
    );
}
