//! What the commands say to a new user: one spelling of each option across commands, help text
//! for every option, errors that name the problem once and without a made-up location, option
//! values used as given or refused, and file names printed with their control characters
//! escaped.

mod common;
use common::text;

use std::path::Path;
use std::process::{Command, Output};

fn scatterbake(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .current_dir(cwd)
        .env("SOURCE_DATE_EPOCH", "1700000000")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env_remove("JOB_COMPLETION_INDEX")
        .output()
        .expect("run scatterbake")
}

fn fails_with(args: &[&str], cwd: &Path, must_contain: &[&str]) -> String {
    let o = scatterbake(args, cwd);
    let t = text(&o);
    assert!(!o.status.success(), "{args:?} should fail: {t}");
    assert!(!t.contains("panicked"), "{t}");
    for m in must_contain {
        assert!(t.contains(m), "{args:?}: output should contain `{m}`: {t}");
    }
    t
}

fn succeeds(args: &[&str], cwd: &Path) -> String {
    let o = scatterbake(args, cwd);
    assert!(o.status.success(), "{args:?}: {}", text(&o));
    text(&o)
}

/// A small Mie table with two radii (5 and 10 µm), two wavelengths and 0.5° bins.
fn mie_table(dir: &Path) -> String {
    std::fs::write(
        dir.join("mie.toml"),
        "[[table]]\nname = \"mie\"\nstage = \"mie\"\n[table.params]\nradii_um = [5.0, 10.0]\n\
         wavelengths_nm = [450.0, 650.0]\nangle_step_deg = 0.5\n",
    )
    .unwrap();
    succeeds(&["build", "mie.toml", "--out", "tables", "-q"], dir);
    "tables/mie.sbt".into()
}

#[test]
fn airy_takes_angles_like_mie_and_raytrace() {
    let d = tempfile::tempdir().unwrap();
    let common = ["airy", "--radius-um", "400", "--wavelength-nm", "650"];
    fn with<'a>(common: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        common.iter().chain(extra).copied().collect()
    }
    let out = succeeds(
        &with(&common, &["--angles", "137:139:0.5", "--format", "csv"]),
        d.path(),
    );
    let angles: Vec<f64> = out
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("angle"))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(angles, [137.0, 137.5, 138.0, 138.5, 139.0]);
    fails_with(
        &with(&common, &["--angles-deg", "137"]),
        d.path(),
        &["--angles"],
    );
    fails_with(
        &with(&common, &["--angles", "0:139:0.5"]),
        d.path(),
        &["strictly between 0 and 180"],
    );
    // The same parser as `mie --angles`: a malformed range is refused the same way.
    let airy = fails_with(
        &with(&common, &["--angles", "1:2"]),
        d.path(),
        &["START:STOP:STEP"],
    );
    let mie = fails_with(
        &["mie", "--x", "10", "--n", "1.33", "--angles", "1:2"],
        d.path(),
        &["START:STOP:STEP"],
    );
    let reason = |t: &str| t.lines().next().unwrap_or("").to_string();
    assert_eq!(reason(&airy), reason(&mie));
}

#[test]
fn help_explains_entry_and_export_formats() {
    let d = tempfile::tempdir().unwrap();
    for cmd in [&["plot", "--help"][..], &["render", "rainbow", "--help"]] {
        let help = succeeds(cmd, d.path());
        let lines: Vec<&str> = help.lines().collect();
        let k = lines
            .iter()
            .position(|l| l.trim_start().starts_with("--entry"))
            .unwrap_or_else(|| panic!("{cmd:?}: no --entry: {help}"));
        assert!(
            lines[k + 1].contains("Entry selection"),
            "{cmd:?}: --entry without help: {help}"
        );
    }
    let top = succeeds(&["--help"], d.path());
    let export_line = top
        .lines()
        .find(|l| l.trim_start().starts_with("export"))
        .unwrap();
    assert!(export_line.contains("rgb-lut"), "{export_line}");
    let help = succeeds(&["export", "--help"], d.path());
    assert!(help.contains("rgb-lut"), "{help}");
    let lut = help.lines().find(|l| l.contains("rgb-lut:")).unwrap();
    assert!(
        lut.contains(".exr") && lut.contains(".png") && lut.contains(".csv"),
        "{lut}"
    );
    assert!(
        help.contains("required for csv, json, exr and rgb-lut"),
        "--out help names every format that needs it: {help}"
    );
}

#[test]
fn missing_files_are_named_once_without_a_location() {
    let d = tempfile::tempdir().unwrap();
    for args in [
        &["inspect", "nope.sbt"][..],
        &["export", "nope.sbt", "--format", "csv", "--out", "x.csv"],
        &["verify", "nope.sbt"],
    ] {
        let t = fails_with(args, d.path(), &["nope.sbt", "(os error 2)"]);
        assert_eq!(t.matches("(os error 2)").count(), 1, "{args:?}: {t}");
    }
    let t = fails_with(
        &["build", "nope.toml", "--out", "t"],
        d.path(),
        &["nope.toml: the manifest could not be read"],
    );
    assert!(!t.contains(":0:0"), "no made-up location: {t}");
    assert_eq!(t.matches("(os error 2)").count(), 1, "{t}");
}

#[test]
fn entry_between_samples_names_the_axis_without_inventing_a_plural() {
    let d = tempfile::tempdir().unwrap();
    let table = mie_table(d.path());
    let t = fails_with(
        &[
            "export", &table, "--format", "mieplot", "--entry", "radius=7",
        ],
        d.path(),
        &["two different values of `radius`", "nearest is 5 um"],
    );
    assert!(!t.contains("radiuss"), "{t}");
}

#[test]
fn option_values_are_used_as_given_or_refused() {
    let d = tempfile::tempdir().unwrap();
    let table = mie_table(d.path());
    succeeds(
        &[
            "export",
            &table,
            "--format",
            "rgb-lut",
            "--samples",
            "4096",
            "--out",
            "lut.csv",
        ],
        d.path(),
    );
    let csv = std::fs::read_to_string(d.path().join("lut.csv")).unwrap();
    let rows: Vec<&str> = csv
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("angle"))
        .collect();
    assert_eq!(rows.len(), 4096);
    assert!(rows[4095].starts_with("180,"), "{}", rows[4095]);
    succeeds(
        &[
            "export",
            &table,
            "--format",
            "mitsuba",
            "--samples",
            "4096",
            "--out",
            "m.xml",
        ],
        d.path(),
    );
    let xml = std::fs::read_to_string(d.path().join("m.xml")).unwrap();
    let first = xml
        .lines()
        .find_map(|l| l.trim().strip_prefix("<string name=\"values\" value=\""))
        .unwrap();
    assert_eq!(first.trim_end_matches("\"/>").split(", ").count(), 4096);
    fails_with(
        &[
            "render", "rainbow", "--table", &table, "--height", "1", "--out", "s.png",
        ],
        d.path(),
        &["--height 1", "at least 2"],
    );
    assert!(!d.path().join("s.png").exists());
    // A range whose STEP does not reach STOP is refused, not cut short.
    fails_with(
        &["mie", "--x", "10", "--n", "1.33", "--angles", "0:1:0.3"],
        d.path(),
        &["does not divide", "the last angle would be 0.9, not 1"],
    );
    // "Nearest table wavelength" options say which wavelength they use.
    let t = succeeds(
        &[
            "export",
            &table,
            "--format",
            "legendre",
            "--wavelength-nm",
            "500",
            "--out",
            "l.txt",
        ],
        d.path(),
    );
    assert!(
        t.contains(
            "--wavelength-nm 500: the table has no such wavelength; using the nearest, 450 nm"
        ),
        "{t}"
    );
    let t = succeeds(
        &[
            "export",
            &table,
            "--format",
            "legendre",
            "--wavelength-nm",
            "650",
            "--out",
            "l.txt",
        ],
        d.path(),
    );
    assert!(!t.contains("note:"), "{t}");
}

/// A name holding a newline, an escape sequence and a carriage return is printed with those
/// characters escaped by `verify`, `catalog` and `inspect`, so it cannot forge a line or
/// recolour the terminal.
#[test]
fn control_characters_in_file_names_are_escaped() {
    let d = tempfile::tempdir().unwrap();
    let table = mie_table(d.path());
    let dir = d.path().join("odd");
    std::fs::create_dir(&dir).unwrap();
    let forged = "a\nok   forged.sbt";
    let red = "b\u{1b}[31mred.sbt";
    let junk = "c\rjunk.sbt";
    std::fs::copy(d.path().join(&table), dir.join(forged)).unwrap();
    std::fs::copy(d.path().join(&table), dir.join(red)).unwrap();
    std::fs::write(dir.join(junk), b"not a table").unwrap();
    let clean = |t: &str| {
        assert!(
            !t.contains('\u{1b}') && !t.contains('\r'),
            "raw control character: {t:?}"
        );
        assert!(
            !t.lines().any(|l| l.starts_with("ok   forged")),
            "forged line: {t}"
        );
    };
    let paths: Vec<String> = [forged, red, junk]
        .iter()
        .map(|n| format!("odd/{n}"))
        .collect();
    let mut args = vec!["verify"];
    args.extend(paths.iter().map(String::as_str));
    let t = fails_with(
        &args,
        d.path(),
        &[
            "odd/a\\nok   forged.sbt",
            "odd/b\\u{1b}[31mred.sbt",
            "odd/c\\rjunk.sbt",
        ],
    );
    clean(&t);
    let t = fails_with(
        &["catalog", "odd"],
        d.path(),
        &["c\\rjunk.sbt", "2 table(s), 1 invalid"],
    );
    clean(&t);
    let t = succeeds(&["inspect", &paths[0]], d.path());
    assert!(t.contains("odd/a\\nok   forged.sbt"), "{t}");
    clean(&t);
    let t = fails_with(&["inspect", &paths[2]], d.path(), &["c\\rjunk.sbt"]);
    clean(&t);
}
