//! `scatterbake build --plan [--json]`: computes and writes nothing, and its estimates hold
//! against the build that follows (axes exactly, size on disk within 25 %).

mod common;
use common::text;

use std::path::Path;
use std::process::{Command, Output};

fn scatterbake(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .current_dir(dir)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .unwrap()
}

/// Small tables of six stages: the shapes `--plan` must get right and sizes it must estimate.
const MANIFEST: &str = r#"
[[table]]
name = "plan-water"
stage = "water-index"
[table.params]
wavelength_nm = [380.0, 780.0, 1.0]
temperature_c = [0.0, 20.0, 40.0]

[[table]]
name = "plan-mie"
stage = "mie"
[table.params]
radii_um = [5.0, 20.0]
wavelengths_nm = [450.0, 650.0]
angle_step_deg = 0.25

[[table]]
name = "plan-debye"
stage = "debye"
[table.params]
radii_um = [10.0]
wavelengths_nm = [550.0]
angle_step_deg = 0.25

[[table]]
name = "plan-sphere"
stage = "raytrace"
[table.params]
shape = "sphere"
radii_um = [400.0]
wavelengths_nm = [550.0, 650.0]
angle_step_deg = 0.1

[[table]]
name = "plan-bc"
stage = "raytrace"
[table.params]
shape = "beard-chuang"
radii_um = [1000.0]
wavelengths_nm = [550.0]
sun_elevation_deg = [10.0]
rays = 64
polar_step_deg = 0.5
azimuth_step_deg = 10.0

[[table]]
name = "plan-hair"
stage = "hair-dual"
[table.params]
theta_count = 16
absorption_count = 4
roughness_deg = [5.0, 10.0]
"#;

#[test]
fn the_plan_computes_nothing_and_matches_the_build() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("m.toml"), MANIFEST).unwrap();
    let o = scatterbake(
        d.path(),
        &["build", "m.toml", "--plan", "--json", "--out", "out"],
    );
    assert!(o.status.success(), "{}", text(&o));
    assert!(!d.path().join("out").exists(), "--plan writes nothing");
    let plan: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let tables = plan["tables"].as_array().expect("key `tables`");
    assert_eq!(tables.len(), 6);
    let total: u64 = tables
        .iter()
        .map(|t| t["estimated_bytes"].as_u64().unwrap())
        .sum();
    assert_eq!(plan["total_bytes"].as_u64(), Some(total));

    let o = scatterbake(
        d.path(),
        &["build", "m.toml", "--out", "out", "-q", "--no-previews"],
    );
    assert!(o.status.success(), "{}", text(&o));
    for t in tables {
        let name = t["name"].as_str().unwrap();
        let path = d.path().join("out").join(format!("{name}.sbt"));
        let written = std::fs::metadata(&path).unwrap().len() as f64;
        let estimated = t["estimated_bytes"].as_f64().unwrap();
        assert!(
            (estimated / written - 1.0).abs() <= 0.25,
            "{name}: estimated {estimated} bytes, wrote {written}"
        );
        let table = scatterbake::table::Table::open(&path).unwrap();
        let axes: Vec<(String, u64)> = table
            .header
            .axes
            .iter()
            .map(|a| (a.name.clone(), a.len() as u64))
            .collect();
        let planned: Vec<(String, u64)> = t["axes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| {
                (
                    a["name"].as_str().unwrap().to_string(),
                    a["len"].as_u64().unwrap(),
                )
            })
            .collect();
        assert_eq!(planned, axes, "{name}");
        assert_eq!(
            t["channels"].as_u64(),
            Some(table.header.channels.len() as u64),
            "{name}"
        );
        assert!(t["estimated_cpu_s"].as_f64().unwrap() > 0.0, "{name}");
    }
}

#[test]
fn the_plan_as_text_lists_every_table_and_the_totals() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("m.toml"), MANIFEST).unwrap();
    let o = scatterbake(d.path(), &["build", "m.toml", "--plan"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    for part in [
        "plan-water",
        "plan-bc",
        "outgoing_polar 361 × outgoing_azimuth 36",
        "total: 6 table(s)",
        "on disk",
    ] {
        assert!(t.contains(part), "missing `{part}`: {t}");
    }
}

#[test]
fn json_without_plan_and_bad_manifests_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let o = scatterbake(d.path(), &["build", "--json"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--plan"), "{}", text(&o));
    std::fs::write(
        d.path().join("bad.toml"),
        "[[table]]\nname = \"x\"\nstage = \"mie\"\n[table.params]\nradii_um = [-1.0]\n",
    )
    .unwrap();
    let o = scatterbake(d.path(), &["build", "bad.toml", "--plan"]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(t.contains("bad.toml") && t.contains("radii_um"), "{t}");
    assert!(!t.contains("panicked"), "{t}");
}
