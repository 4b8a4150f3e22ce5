//! Every example in README.md, docs/consumers.md and the Python reader's docstring is executed
//! here, against a small table built under the name the examples use
//! (`tables/rainbow-mie.sbt`: the default Mie table's stage, axes and operators, fewer radii and
//! wavelengths):
//!
//! - the Python blocks and the docstring example run in the tests' Python environment
//!   (`tests/common/python.rs`: numpy and zstandard, provisioned under `target/`); the sampled
//!   point must equal the Rust lookup at the coordinates the example's comment names, in the
//!   table's axis order;
//! - the C block of docs/consumers.md is compiled inside a `main` against the C ABI library and
//!   run, and must print the same value;
//! - every `scatterbake …` command line of a `sh` block or synopsis: each option it names must be
//!   an option of that command (checked against `--help`), and the commands without placeholders
//!   whose input is the fixture table run and must succeed;
//! - the README's manifest example is planned by the library.

#[path = "../../tests/common/python.rs"]
mod python;

use scatterbake::table::Table;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_scatterbake"));
    c.env("SOURCE_DATE_EPOCH", "1700000000");
    c.env_remove("SLURM_ARRAY_TASK_ID");
    c.env_remove("JOB_COMPLETION_INDEX");
    c
}

/// Fenced blocks of a Markdown file: (info string, body).
fn fenced_blocks(md: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(String, String)> = None;
    for line in md.lines() {
        if let Some(info) = line.strip_prefix("```") {
            match cur.take() {
                Some(b) => out.push(b),
                None => cur = Some((info.trim().to_string(), String::new())),
            }
        } else if let Some((_, body)) = cur.as_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    out
}

/// A directory holding `tables/rainbow-mie.sbt` (small), `python/` and the README's other
/// inputs, as a fresh clone after the default build would.
fn fixture() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let manifest = d.path().join("doc-fixture.toml");
    std::fs::write(
        &manifest,
        "[[table]]\nname = \"rainbow-mie\"\nstage = \"mie\"\n[table.params]\n\
         radii_um = [400.0, 500.0]\nwavelengths_nm = [550.0, 650.0, 700.0]\n\
         angle_step_deg = 0.5\nsun_diameter_deg = 0.5\n",
    )
    .unwrap();
    let o = bin()
        .args(["build", "--quiet", "--no-previews", "--out", "tables"])
        .arg(&manifest)
        .current_dir(d.path())
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "fixture build failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::create_dir(d.path().join("python")).unwrap();
    std::fs::copy(
        root().join("python/scatterbake_table.py"),
        d.path().join("python/scatterbake_table.py"),
    )
    .unwrap();
    d
}

/// The coordinates of the example's `sample([a, b, c])` call, checked against the names its
/// comment gives: radius (µm), wavelength (nm), angle (deg), the table's axis order.
fn sampled_point(example: &str) -> [f64; 3] {
    let line = example
        .lines()
        .find(|l| l.contains(".sample(["))
        .unwrap_or_else(|| panic!("no sample call in example:\n{example}"));
    let (call, comment) = line.split_once('#').expect("sample line has a comment");
    let inner = call.split_once(".sample([").unwrap().1;
    let inner = inner.split_once(']').unwrap().0;
    let v: Vec<f64> = inner
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let names: Vec<&str> = comment
        .split(',')
        .map(|w| w.split_whitespace().next().unwrap_or(""))
        .collect();
    assert_eq!(
        &names[..3],
        ["radius", "wavelength", "angle"],
        "the example's comment must name the axes in the table's order: {line}"
    );
    [v[0], v[1], v[2]]
}

/// Rust's lookup of every channel of the fixture table at `at`.
fn rust_sample(dir: &Path, at: [f64; 3]) -> Vec<f64> {
    let t = Table::open(dir.join("tables/rainbow-mie.sbt")).unwrap();
    let names: Vec<&str> = t.axes().iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["radius", "wavelength", "scattering_angle"]);
    // The lookup clamps at the axis ends: a coordinate outside its axis (e.g. a wavelength
    // given where the radius goes) would be silently moved, so refuse it here.
    for (a, &c) in t.axes().iter().zip(&at) {
        let v = a.coords();
        assert!(
            v[0] <= c && c <= v[v.len() - 1],
            "the example samples {} = {c}, outside the axis [{}, {}]: wrong axis order?",
            a.name,
            v[0],
            v[v.len() - 1]
        );
    }
    t.sample(&at).unwrap()
}

/// Run a Python example in `dir` and return the first channel of its `p` (`phase`).
fn run_python(dir: &Path, example: &str) -> f64 {
    let code = format!("{example}\nprint('PHASE', float(p[0]))\n");
    let o = Command::new(python::python())
        .arg("-c")
        .arg(&code)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("the tests' Python does not run: {e}"));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "python example failed:\n{code}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    out.lines()
        .find_map(|l| l.strip_prefix("PHASE "))
        .expect("phase printed")
        .trim()
        .parse()
        .unwrap()
}

fn assert_close(what: &str, got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 1e-6 * want.abs(),
        "{what}: {got} vs Rust {want}"
    );
}

#[test]
fn python_examples_run_and_sample_in_axis_order() {
    let d = fixture();
    let mut examples: Vec<(String, String)> = Vec::new();
    for doc in ["README.md", "docs/consumers.md"] {
        let md = std::fs::read_to_string(root().join(doc)).unwrap();
        for (info, body) in fenced_blocks(&md) {
            if info == "python" {
                examples.push((doc.to_string(), body));
            }
        }
    }
    // The docstring example: the indented block after the first line.
    let module = std::fs::read_to_string(root().join("python/scatterbake_table.py")).unwrap();
    let doc = module.split("\"\"\"").nth(1).unwrap();
    let block: String = doc
        .lines()
        .skip_while(|l| !l.starts_with("    "))
        .take_while(|l| l.starts_with("    ") || l.is_empty())
        .map(|l| format!("{}\n", l.strip_prefix("    ").unwrap_or(l)))
        .collect();
    examples.push(("python/scatterbake_table.py docstring".into(), block));
    assert_eq!(
        examples.len(),
        3,
        "README, docs/consumers.md and the docstring"
    );
    for (source, example) in &examples {
        let at = sampled_point(example);
        let want = rust_sample(d.path(), at)[0];
        assert!(want > 0.0, "{source}: the example samples a zero phase");
        let got = run_python(d.path(), example);
        assert_close(source, got, want);
    }
}

/// Build the C ABI library with the cargo running this test (same target directory and
/// profile) and return the directory holding it.
fn capi_lib_dir() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let profile_dir = exe.parent().unwrap().parent().unwrap().to_path_buf();
    let target_dir = profile_dir.parent().unwrap();
    let o = Command::new(env!("CARGO"))
        .args([
            "build",
            "-p",
            "scatterbake-capi",
            "--profile",
            "test",
            "--lib",
        ])
        .arg("--quiet")
        .arg("--manifest-path")
        .arg(root().join("Cargo.toml"))
        .env("CARGO_TARGET_DIR", target_dir)
        .output()
        .expect("cargo runs");
    assert!(
        o.status.success(),
        "building the C ABI library failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    profile_dir
}

#[test]
fn c_example_compiles_runs_and_agrees() {
    let d = fixture();
    let md = std::fs::read_to_string(root().join("docs/consumers.md")).unwrap();
    let blocks: Vec<String> = fenced_blocks(&md)
        .into_iter()
        .filter(|(i, _)| i == "c")
        .map(|(_, b)| b)
        .collect();
    assert_eq!(blocks.len(), 1, "one C example in docs/consumers.md");
    let (includes, body): (Vec<&str>, Vec<&str>) =
        blocks[0].lines().partition(|l| l.starts_with("#include"));
    let body = body.join("\n    ");
    // The example's last statement closes the table: print before it.
    let body = body.replace(
        "sbt_close(t);",
        "printf(\"PHASE %.17g %ld %d\\n\", out[0], ph, data != NULL);\n    sbt_close(t);",
    );
    let src = format!(
        "{}\n#include <stdio.h>\nint main(void) {{\n    {body}\n    return 0;\n}}\n",
        includes.join("\n")
    );
    let c_file = d.path().join("doc_example.c");
    std::fs::write(&c_file, &src).unwrap();
    let lib = capi_lib_dir();
    let exe = d.path().join("doc_example");
    let cc = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Werror", "-I"])
        .arg(root().join("c"))
        .arg(&c_file)
        .arg("-L")
        .arg(&lib)
        .arg("-lscatterbake_table")
        .arg(format!("-Wl,-rpath,{}", lib.display()))
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| panic!("the C example needs a C compiler `cc` on PATH: {e}"));
    assert!(
        cc.status.success(),
        "cc failed on\n{src}\n{}",
        String::from_utf8_lossy(&cc.stderr)
    );
    let o = Command::new(&exe).current_dir(d.path()).output().unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "C example failed: {out}");
    let fields: Vec<&str> = out
        .lines()
        .find_map(|l| l.strip_prefix("PHASE "))
        .expect("printed")
        .split_whitespace()
        .collect();
    let want = rust_sample(d.path(), sampled_c_point(&blocks[0]))[0];
    assert_close("C example", fields[0].parse().unwrap(), want);
    assert_eq!(fields[1], "0", "phase is channel 0");
    assert_eq!(fields[2], "1", "sbt_data returns the samples");
}

/// `double at[3] = {a, b, c}` of the C example, with its comment naming the axes in order.
fn sampled_c_point(example: &str) -> [f64; 3] {
    let line = example
        .lines()
        .find(|l| l.contains("double at[3]"))
        .unwrap();
    let inner = line.split_once('{').unwrap().1.split_once('}').unwrap().0;
    let v: Vec<f64> = inner
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let comment = line.split_once("/*").unwrap().1;
    let names: Vec<&str> = comment
        .split(',')
        .map(|w| w.split_whitespace().next().unwrap_or(""))
        .collect();
    assert_eq!(&names[..3], ["radius", "wavelength", "angle"], "{line}");
    [v[0], v[1], v[2]]
}

/// The `scatterbake …` command lines of the README's and docs/consumers.md's command blocks
/// (continuation lines joined), without trailing comments.
fn command_lines() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for doc in ["README.md", "docs/consumers.md"] {
        let md = std::fs::read_to_string(root().join(doc)).unwrap();
        for (info, body) in fenced_blocks(&md) {
            if !(info.is_empty() || info == "sh") {
                continue;
            }
            let mut current: Option<String> = None;
            for line in body.lines() {
                let code = line.split("  #").next().unwrap().trim_end();
                if code.starts_with("scatterbake ") {
                    if let Some(c) = current.take() {
                        out.push((doc.to_string(), c));
                    }
                    current = Some(code.to_string());
                } else if let Some(c) = current.as_mut() {
                    if line.starts_with("    ") && code.trim_start().starts_with('[')
                        || code.trim_start().starts_with("--")
                    {
                        c.push(' ');
                        c.push_str(code.trim());
                    } else {
                        out.push((doc.to_string(), current.take().unwrap()));
                    }
                }
            }
            if let Some(c) = current {
                out.push((doc.to_string(), c));
            }
        }
        // Inline commands of numbered steps (`1. `scatterbake …``).
        for line in md.lines() {
            if let Some(rest) = line.trim_start().strip_prefix("1. `scatterbake ") {
                let cmd = rest.split('`').next().unwrap();
                out.push((doc.to_string(), format!("scatterbake {cmd}")));
            }
        }
    }
    out
}

/// The subcommand words of a command line (one, or two for `render rainbow`).
fn subcommand(words: &[&str]) -> Vec<String> {
    let mut sub = vec![words[1].to_string()];
    if words[1] == "render" {
        sub.push(words[2].to_string());
    }
    sub
}

#[test]
fn documented_commands_name_real_options_and_run() {
    let lines = command_lines();
    assert!(
        lines.len() >= 20,
        "expected the README's command list: {lines:?}"
    );
    let d = fixture();
    let mut ran = 0;
    for (doc, line) in &lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        let sub = subcommand(&words);
        let help = bin().args(&sub).arg("--help").output().unwrap();
        let help_text = String::from_utf8_lossy(&help.stdout);
        assert!(
            help.status.success(),
            "{doc}: `scatterbake {}` is not a command ({line})",
            sub.join(" ")
        );
        for w in &words {
            let w = w.trim_start_matches(['[', '(']);
            if let Some(flag) = w.strip_prefix("--") {
                let flag: String = flag
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                    .collect();
                assert!(
                    help_text.contains(&format!("--{flag}")),
                    "{doc}: `{line}` names --{flag}, which `scatterbake {}` does not have",
                    sub.join(" ")
                );
            }
        }
        // Concrete commands on the fixture table run.
        let concrete = !line.contains(['[', '|', '…']) && !line.contains("...");
        if concrete && line.contains("tables/rainbow-mie.sbt") && !sub.contains(&"render".into()) {
            let o = bin()
                .args(&words[1..])
                .current_dir(d.path())
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "{doc}: `{line}` failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 1, "at least the rgb-lut step runs");
}

#[test]
fn readme_manifest_example_plans() {
    let md = std::fs::read_to_string(root().join("README.md")).unwrap();
    let toml: Vec<String> = fenced_blocks(&md)
        .into_iter()
        .filter(|(i, _)| i == "toml")
        .map(|(_, b)| b)
        .collect();
    assert_eq!(toml.len(), 1);
    let planned = scatterbake::manifest::parse_manifest(Path::new("README.md"), &toml[0])
        .unwrap_or_else(|e| panic!("README manifest example: {e}"));
    assert_eq!(planned.len(), 1);
    assert_eq!(planned[0].name, "water-index");
}
