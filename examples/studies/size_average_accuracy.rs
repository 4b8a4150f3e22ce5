//! Accuracy and cost of the adaptive size-distribution average (`mie::size_average`, decision
//! MIE-18) against the brute-force references of `tests/data/mie_distribution_reference.json`
//! (miepython, dense midpoint rules in x; fog, cloud and a reduced rain case at 550 nm, m = 1.333).
//!
//! ```text
//! cargo run --release --example size_average_accuracy -- [TOLERANCE...]
//! ```
//! For each case and tolerance (default 1e-2, 1e-3, 1e-4): the point values at 0, 0.5, …, 180°
//! (`average_at_angles`) and the 1° bin averages (the stage's entry, no sun disc), each with the
//! error estimate, the true RMS and largest relative error of `i_perp`, `i_par` (relative to the
//! phase function, as the estimate), the spheres evaluated and the wall time. A tolerance not
//! met within the node limit prints the error instead.
use num_complex::Complex64;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::mie::filters::FilterSettings;
use scatterbake::mie::size_average::{
    AverageLimits, BinnedCurve, SizeAverage, SizeAverageError, average, average_at_angles,
};
use std::time::Instant;

fn column(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
        .unwrap_or_default()
}

/// RMS and largest relative error of (perp, par) against the reference, relative to its phase.
fn errors(perp: &[f64], par: &[f64], rp: &[f64], ra: &[f64]) -> (f64, f64) {
    let (mut sq, mut max, mut n, mut at) = (0.0, 0.0f64, 0, 0);
    for j in 0..rp.len() {
        let phase = 0.5 * (rp[j] + ra[j]);
        for e in [(perp[j] - rp[j]).abs(), (par[j] - ra[j]).abs()] {
            let r = e / phase;
            sq += r * r;
            if r > max {
                (max, at) = (r, j);
            }
            n += 1;
        }
    }
    if std::env::var_os("SHOW_MAX").is_some() {
        eprintln!("largest error at index {at} of {}", rp.len());
    }
    ((sq / n as f64).sqrt(), max)
}

fn main() -> anyhow::Result<()> {
    let tolerances: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let tolerances = if tolerances.is_empty() {
        vec![1e-2, 1e-3, 1e-4]
    } else {
        tolerances
    };
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/mie_distribution_reference.json"
    );
    let reference: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average at start: {}", load.trim());
    println!("| case | quantity | tolerance | estimate | true rms | true max | spheres | wall s |");
    println!("|---|---|---|---|---|---|---|---|");
    for (name, case) in reference["cases"].as_object().into_iter().flatten() {
        let d: SizeDistribution = serde_json::from_value(case["distribution"].clone())?;
        let wavelength_nm = case["wavelength_nm"].as_f64().unwrap_or(550.0);
        let m = Complex64::new(
            case["m"][0].as_f64().unwrap_or(1.333),
            case["m"][1].as_f64().unwrap_or(0.0),
        );
        for &tolerance in &tolerances {
            let limits = AverageLimits {
                tolerance,
                max_tolerance: None,
                max_nodes: 200_000,
            };
            let t0 = Instant::now();
            let points = column(case, "points_deg");
            let at_points = average_at_angles(&d, wavelength_nm, m, &points, &limits);
            let row = table_row(at_points, case, "points", t0);
            println!("| {name} | points | {tolerance:.0e} | {row} |");
            let settings = FilterSettings {
                output_intervals: 180,
                sun_diameter_deg: 0.0,
                gaussian_sigma_deg: 0.0,
                radius_points: 24,
                radius_tolerance: tolerance,
            };
            let sun = settings.sun_operator();
            let t0 = Instant::now();
            let binned = BinnedCurve::new(wavelength_nm, m, &settings, &sun);
            let row = table_row(average(&d, &binned, &limits), case, "bins", t0);
            println!("| {name} | 1° bins | {tolerance:.0e} | {row} |");
        }
    }
    Ok(())
}

/// The printed columns of one average against the reference columns `<kind>_i_perp`,
/// `<kind>_i_par` of `case`: estimate, true RMS and max error, spheres, wall seconds since `t0`.
fn table_row(
    average: Result<SizeAverage, SizeAverageError>,
    case: &serde_json::Value,
    kind: &str,
    t0: Instant,
) -> String {
    match average {
        Ok(a) => {
            let (rms, max) = errors(
                &a.i_perp,
                &a.i_par,
                &column(case, &format!("{kind}_i_perp")),
                &column(case, &format!("{kind}_i_par")),
            );
            format!(
                "{:.2e} | {rms:.2e} | {max:.2e} | {} | {:.2}",
                a.error_estimate,
                a.radius_nodes,
                t0.elapsed().as_secs_f64()
            )
        }
        Err(e) => format!("{e} | | | | {:.2}", t0.elapsed().as_secs_f64()),
    }
}
