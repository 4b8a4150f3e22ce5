//! Coated spheres (`scatterbake::mie::coated`) against committed references: an independent
//! arbitrary-precision evaluation of Bohren & Huffman's coated-sphere formulas and scattnlay
//! (Peña & Pal 2009), both from `tests/data/mie_coated_reference.py`; and the homogeneous
//! limits (equal indices, vanishing core). A missing reference file fails.
//!
//! `cargo test --release --test mie_coated -- --nocapture` prints the accuracy table.

use num_complex::Complex64;
use scatterbake::mie::coated::{CoatedError, CoatedSphere, coated_coefficients};
use scatterbake::mie::{AngularSeries, MieCoefficients, amplitudes};
use serde_json::Value;

fn load(name: &str) -> Value {
    let path = format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!("reference {path} is missing ({e}); regenerate it with tests/data/mie_coated_reference.py")
    });
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("reference {path}: {e}"))
}

fn c(v: &Value) -> Complex64 {
    Complex64::new(v[0].as_f64().unwrap(), v[1].as_f64().unwrap())
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// `[S1, S2, Q_ext, Q_sca, Q_back, g]` relative errors (S: max over angles).
fn errors(coef: &MieCoefficients, mu: &[f64], reference: &Value) -> [f64; 6] {
    let (s1, s2) = amplitudes(&AngularSeries::new(coef), mu);
    let e = coef.efficiencies();
    let s_err = |mine: &[Complex64], theirs: &Value| -> f64 {
        mine.iter()
            .zip(theirs.as_array().unwrap())
            .map(|(a, r)| (a - c(r)).norm() / c(r).norm())
            .fold(0.0, f64::max)
    };
    let rel = |a: f64, b: f64| ((a - b) / b).abs();
    [
        s_err(&s1, &reference["s1"]),
        s_err(&s2, &reference["s2"]),
        rel(e.q_ext, f(&reference["qext"])),
        rel(e.q_sca, f(&reference["qsca"])),
        rel(e.q_back, f(&reference["qback"])),
        rel(e.g, f(&reference["g"])),
    ]
}

fn sphere(case: &Value) -> CoatedSphere {
    CoatedSphere {
        core_size_parameter: f(&case["core_x"]),
        size_parameter: f(&case["x"]),
        core_index: c(&case["core_m"]),
        shell_index: c(&case["shell_m"]),
    }
}

/// Every case against the arbitrary-precision values (≤ 1e-9 relative everywhere) and
/// scattnlay (printed).
#[test]
fn coated_against_references() {
    let r = load("mie_coated_reference.json");
    let cases = r["cases"].as_array().unwrap();
    assert!(cases.len() >= 12, "reference set is incomplete");
    println!("| case | x_c | x | S1 | S2 | Q_ext | Q_sca | Q_back | g | (mpmath) S1 (scattnlay) |");
    let mut worst = [0.0f64; 6];
    for case in cases {
        assert!(
            f(&case["mp_self_check"]) < 1e-20,
            "reference not converged: {case}"
        );
        let coef = coated_coefficients(&sphere(case)).unwrap();
        let mu: Vec<f64> = case["mu"].as_array().unwrap().iter().map(f).collect();
        let e = errors(&coef, &mu, &case["mpmath"]);
        let sn = if case["scattnlay"].get("error").is_some() {
            f64::NAN
        } else {
            errors(&coef, &mu, &case["scattnlay"])[0]
        };
        println!(
            "| {} | {} | {} | {} | {sn:.1e} |",
            case["label"].as_str().unwrap(),
            f(&case["core_x"]),
            f(&case["x"]),
            e.iter()
                .map(|v| format!("{v:.1e}"))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        for (w, v) in worst.iter_mut().zip(e) {
            *w = w.max(v);
        }
    }
    println!("worst vs mpmath [S1, S2, Q_ext, Q_sca, Q_back, g]: {worst:?}");
    assert!(worst.iter().all(|e| *e < 1e-9), "{worst:?}");
}

/// Equal core and shell indices reproduce the homogeneous sphere, and a vanishing core the
/// homogeneous shell-material sphere.
#[test]
fn homogeneous_limits() {
    let mu: Vec<f64> = (0..=36)
        .map(|k| (5.0 * k as f64).to_radians().cos())
        .collect();
    let compare = |coated: &MieCoefficients, plain: &MieCoefficients| -> f64 {
        let (a1, a2) = amplitudes(&AngularSeries::new(coated), &mu);
        let (b1, b2) = amplitudes(&AngularSeries::new(plain), &mu);
        let mut worst: f64 = 0.0;
        for i in 0..mu.len() {
            worst = worst.max((a1[i] - b1[i]).norm() / b1[i].norm());
            worst = worst.max((a2[i] - b2[i]).norm() / b2[i].norm());
        }
        let (e, p) = (coated.efficiencies(), plain.efficiencies());
        for (u, v) in [
            (e.q_ext, p.q_ext),
            (e.q_sca, p.q_sca),
            (e.q_back, p.q_back),
            (e.g, p.g),
        ] {
            worst = worst.max(((u - v) / v).abs());
        }
        worst
    };
    for (x, m) in [
        (10.0, Complex64::new(1.5, 0.01)),
        (300.0, Complex64::new(1.333, 0.0)),
        (20.0, Complex64::new(0.1425812, 3.6813284)),
        (50.0, Complex64::new(0.75, 0.0)),
    ] {
        let plain = MieCoefficients::new(x, m).unwrap();
        let same = coated_coefficients(&CoatedSphere {
            core_size_parameter: 0.6 * x,
            size_parameter: x,
            core_index: m,
            shell_index: m,
        })
        .unwrap();
        let e = compare(&same, &plain);
        println!("x = {x}, m = {m}: equal indices {e:.1e}");
        assert!(e < 1e-10, "equal indices x={x} m={m}: {e}");
        let tiny = coated_coefficients(&CoatedSphere {
            core_size_parameter: 1e-7,
            size_parameter: x,
            core_index: Complex64::new(3.0, 1.0),
            shell_index: m,
        })
        .unwrap();
        let e = compare(&tiny, &plain);
        println!("x = {x}, m = {m}: vanishing core {e:.1e}");
        assert!(e < 1e-10, "vanishing core x={x} m={m}: {e}");
    }
}

#[test]
fn coated_domain_is_enforced() {
    let base = CoatedSphere {
        core_size_parameter: 5.0,
        size_parameter: 10.0,
        core_index: Complex64::new(1.5, 0.0),
        shell_index: Complex64::new(1.33, 0.0),
    };
    assert!(coated_coefficients(&base).is_ok());
    let bigger_core = CoatedSphere {
        core_size_parameter: 11.0,
        ..base
    };
    assert!(matches!(
        coated_coefficients(&bigger_core),
        Err(CoatedError::CoreLargerThanShell { .. })
    ));
    let gain = CoatedSphere {
        core_index: Complex64::new(1.5, -0.1),
        ..base
    };
    assert!(matches!(
        coated_coefficients(&gain),
        Err(CoatedError::Core(_))
    ));
    let huge = CoatedSphere {
        size_parameter: 2e4,
        ..base
    };
    assert!(matches!(
        coated_coefficients(&huge),
        Err(CoatedError::Shell(_))
    ));
}
