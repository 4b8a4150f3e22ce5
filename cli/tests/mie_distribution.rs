//! `scatterbake mie --distribution`: the size-distribution average at point angles against the
//! independent reference of `tests/data/mie_distribution_reference.json` (miepython, dense
//! midpoint rule in x; written by `tests/data/mie_distribution_reference.py`), the stated error
//! estimate, and clean failures.

mod common;
use common::text;

use std::process::{Command, Output};

const REFERENCE: &str = include_str!("../../tests/data/mie_distribution_reference.json");

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_scatterbake"))
        .args(args)
        .output()
        .expect("run scatterbake")
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn lognormal_fog_matches_the_reference_and_states_its_error() {
    let o = run(&[
        "mie",
        "--distribution",
        "lognormal:6,1.35",
        "--wavelength-nm",
        "550",
        "--n",
        "1.333",
        "--k",
        "0.001",
        "--angles",
        "0:180:0.5",
        "--tolerance",
        "1e-3",
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let out: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let header = out["header"].to_string();
    assert!(
        header.contains("error_estimate") && header.contains("radius_nodes"),
        "{header}"
    );
    let reference: serde_json::Value = serde_json::from_str(REFERENCE).unwrap();
    let fog = &reference["cases"]["fog"];
    assert_eq!(fog["m"][1].as_f64(), Some(0.001));
    let (perp, par) = (numbers(&out["i_perp"]), numbers(&out["i_par"]));
    let (rp, ra) = (
        numbers(&fog["points_i_perp"]),
        numbers(&fog["points_i_par"]),
    );
    assert_eq!(perp.len(), rp.len());
    let mut sq = 0.0;
    for j in 0..rp.len() {
        let phase = 0.5 * (rp[j] + ra[j]);
        sq += ((perp[j] - rp[j]) / phase).powi(2) + ((par[j] - ra[j]) / phase).powi(2);
    }
    let rms = (sq / (2 * rp.len()) as f64).sqrt();
    assert!(rms < 1e-3, "rms relative difference {rms:.2e}");
}

#[test]
fn unmet_tolerance_and_bad_distributions_fail_cleanly() {
    let base = [
        "mie",
        "--wavelength-nm",
        "550",
        "--n",
        "1.333",
        "--angles-deg",
        "30,140",
    ];
    for (extra, expect) in [
        (
            vec![
                "--distribution",
                "lognormal:6,1.35",
                "--tolerance",
                "1e-5",
                "--max-radius-nodes",
                "500",
            ],
            "tolerance",
        ),
        (vec!["--distribution", "lognormal:6"], "lognormal"),
        (vec!["--distribution", "gamma:10,0.7"], "effective_variance"),
        (
            vec!["--distribution", "marshall-palmer:5,100,50"],
            "max_radius_um",
        ),
        (vec!["--distribution", "weibull:1,2"], "expected"),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        let o = run(&args);
        let t = text(&o);
        assert!(!o.status.success(), "{args:?}: {t}");
        assert!(
            !t.contains("panicked") && t.contains(expect),
            "{args:?}: {t}"
        );
    }
}
