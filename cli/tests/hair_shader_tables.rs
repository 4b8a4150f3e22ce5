//! `scatterbake dual-scattering --format c|rsl`: the arrays and lookup for the thesis's App. C
//! shader hold the table's values. The C header is compiled with the system C compiler (`cc`,
//! required) and its `ds_lookup` is compared with linear interpolation of the JSON export of the
//! same table at random angles; the RSL arrays are parsed back and compared with the JSON.

use std::path::Path;
use std::process::Command;

fn scatterbake(args: &[&str], cwd: &Path) {
    let o = Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "scatterbake {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

const NAMES: [&str; 12] = [
    "a_f", "a_b", "alpha_f", "alpha_b", "beta_f2", "beta_b2", "A_b", "delta_b", "sigma_b2",
    "N_G_R", "N_G_TT", "N_G_TRT",
];

/// The JSON export of the default set: its θ samples and one column per (name, channel).
struct Exported {
    theta: Vec<f64>,
    json: serde_json::Value,
}

impl Exported {
    fn channel(&self, name: &str, c: usize) -> Vec<f64> {
        self.json[name]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v[c].as_f64().unwrap())
            .collect()
    }
}

#[test]
fn c_header_lookup_matches_the_table_and_rsl_holds_the_same_arrays() {
    let d = tempfile::tempdir().unwrap();
    let common = ["dual-scattering", "--theta-samples", "33"];
    let run = |format: &str, out: &str| {
        let mut a = common.to_vec();
        a.extend(["--format", format, "--out", out]);
        scatterbake(&a, d.path());
    };
    run("json", "ds.json");
    run("c", "ds.h");
    run("rsl", "ds.sl");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("ds.json")).unwrap()).unwrap();
    let theta: Vec<f64> = json["theta_deg"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    let e = Exported { theta, json };
    c_lookup_matches(d.path(), &e);
    rsl_arrays_match(
        &std::fs::read_to_string(d.path().join("ds.sl")).unwrap(),
        &e,
    );
}

/// Compiles a program printing `ds_lookup` of `ds.h` (in `dir`) at random angles and compares
/// with linear interpolation of the JSON.
fn c_lookup_matches(dir: &Path, e: &Exported) {
    // Random angles (fixed LCG), including the ends and beyond them (clamped).
    let mut state = 0x2012_u64;
    let mut angles = vec![-90.0, 90.0, -95.0, 0.0];
    for _ in 0..40 {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        angles.push(-90.0 + 180.0 * (state >> 11) as f64 / (1u64 << 53) as f64);
    }
    let got = run_c_lookups(dir, &angles);
    let mut k = 0;
    let mut worst: f64 = 0.0;
    for a in &angles {
        for name in NAMES {
            for c in 0..3 {
                let v = e.channel(name, c);
                let want = scatterbake::table::interp::interp1(&e.theta, &v, *a);
                let scale = v.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
                worst = worst.max((got[k] - want).abs() / scale);
                k += 1;
            }
        }
    }
    assert!(worst < 1e-12, "C lookup vs table: {worst:e}");
    let g = (-0.01f64 / 0.08).exp() / (2.0 * std::f64::consts::PI * 0.04).sqrt();
    assert!((got[k] - g).abs() < 1e-15 * g);
}

/// What the compiled program prints: `ds_lookup` per angle, name and channel, then `g(0.1, 0.04)`.
fn run_c_lookups(dir: &Path, angles: &[f64]) -> Vec<f64> {
    let mut main = String::from("#include <stdio.h>\n#include \"ds.h\"\nint main(void) {\n");
    for a in angles {
        for name in NAMES {
            for c in 0..3 {
                main.push_str(&format!(
                    "    printf(\"%.17g\\n\", ds_lookup({name}, {:e} * M_PI / 180.0, {c}));\n",
                    a
                ));
            }
        }
    }
    main.push_str("    printf(\"%.17g\\n\", g(0.1, 0.04));\n    return 0;\n}\n");
    std::fs::write(dir.join("main.c"), main).unwrap();
    let cc = Command::new("cc")
        .args(["-std=c99", "-D_DEFAULT_SOURCE", "-Wall", "-Werror", "-O1"])
        .args(["main.c", "-lm", "-o", "ds_test"])
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("this test needs a C compiler `cc` on PATH: {e}"));
    assert!(
        cc.status.success(),
        "cc: {}",
        String::from_utf8_lossy(&cc.stderr)
    );
    let out = Command::new(dir.join("ds_test")).output().unwrap();
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.parse().unwrap())
        .collect()
}

/// RSL: every array holds the JSON's values in order.
fn rsl_arrays_match(rsl: &str, e: &Exported) {
    for name in NAMES {
        let line = rsl
            .lines()
            .find(|l| l.starts_with(&format!("uniform color {name}[")))
            .unwrap_or_else(|| panic!("no RSL array {name}"));
        let nums: Vec<f64> = line
            .split("color(")
            .skip(1)
            .flat_map(|t| {
                t.split(')')
                    .next()
                    .unwrap()
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().unwrap())
                    .collect::<Vec<_>>()
            })
            .collect();
        assert_eq!(nums.len(), 3 * e.theta.len(), "{name}");
        for (i, chunk) in nums.chunks(3).enumerate() {
            for (c, got) in chunk.iter().enumerate() {
                // serde_json reads decimal text to within an ulp, not always exactly.
                let want = e.channel(name, c)[i];
                assert!(
                    (got - want).abs() <= 4.0 * f64::EPSILON * want.abs(),
                    "{name}[{i}][{c}]: {got} vs {want}"
                );
            }
        }
    }
    assert!(rsl.contains("color ds_lookup(uniform color tab[]; float angle)"));
}
