//! Size-distribution averages (`mie::size_average`, decision MIE-18) against brute-force
//! references built independently.
//!
//! - `point_values_match_references` and `bin_averages_match_references` (default `cargo
//!   test`): the adaptive rule against `tests/data/mie_distribution_reference.json`, written by
//!   `tests/data/mie_distribution_reference.py` (miepython coefficients, the distributions
//!   written out from their definitions, dense midpoint rules in x at two steps; fog lognormal
//!   6 µm / 1.35 and cloud gamma 10 µm / 0.1 with m = 1.333 + 0.001i, rain Marshall–Palmer
//!   5 mm/h 50–100 µm with m = 1.333 + 0.0001i, 550 nm; the small absorption damps the narrow
//!   resonances of clear water, which make a clear-water reference itself uncertain at ~2e-3).
//!   The estimate must meet the tolerance and bound the true error (within the reference's own
//!   error, from its two steps).
//! - `clear_water_estimate_bounds_the_true_error` (default): fog and cloud of clear water
//!   (`k = 0`) at 1e-2 and 1e-3 against `tests/data/mie_distribution_clear_water.json`
//!   (`examples/studies/clear_water_reference.rs`: midpoint rules in x of 2·10⁶ spheres over the
//!   support, own error ≈ 1.6e-5 RMS from their two halves), where the estimate combines the
//!   panels that sample the resonances at random in quadrature.
//! - `rain_matches_reference_at_1e-3` (ignored, ≈ 1–2 min): the rain case at 1e-3, points and
//!   1° bins.
//! - `fog_entry_with_sun_disc_matches_dense_gauss_legendre` (default): a stage entry with the
//!   sun disc (0.25° bins, 0.5° disc) against the Gauss–Legendre rule in ln r with 1024 nodes
//!   and exact cell averages per node (independent code; 512 vs 1024 nodes checked).

use num_complex::Complex64;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::mie::ensemble::{compute_entry, relative_difference};
use scatterbake::mie::filters::FilterSettings;
use scatterbake::mie::size_average::{
    AverageLimits, BinnedCurve, SizeAverage, average, average_at_angles,
};
use scatterbake::optics::water::WaterIndexModel;

const REFERENCE: &str = include_str!("data/mie_distribution_reference.json");
const CLEAR_WATER: &str = include_str!("data/mie_distribution_clear_water.json");

struct Case {
    distribution: SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    json: serde_json::Value,
}

fn case(name: &str) -> Case {
    let all: serde_json::Value = serde_json::from_str(REFERENCE).unwrap();
    let json = all["cases"][name].clone();
    Case {
        distribution: serde_json::from_value(json["distribution"].clone()).unwrap(),
        wavelength_nm: json["wavelength_nm"].as_f64().unwrap(),
        m: Complex64::new(
            json["m"][0].as_f64().unwrap(),
            json["m"][1].as_f64().unwrap(),
        ),
        json,
    }
}

fn column(c: &Case, key: &str) -> Vec<f64> {
    c.json[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect()
}

/// RMS and largest error of `a` against the reference `part` (`points` or `bins`), relative to
/// the reference phase function, over both channels.
fn errors(c: &Case, a: &SizeAverage, part: &str) -> (f64, f64) {
    let rp = column(c, &format!("{part}_i_perp"));
    let ra = column(c, &format!("{part}_i_par"));
    assert_eq!(a.i_perp.len(), rp.len());
    let (mut sq, mut max) = (0.0, 0.0f64);
    for j in 0..rp.len() {
        let phase = 0.5 * (rp[j] + ra[j]);
        for e in [(a.i_perp[j] - rp[j]).abs(), (a.i_par[j] - ra[j]).abs()] {
            sq += (e / phase).powi(2);
            max = max.max(e / phase);
        }
    }
    ((sq / (2 * rp.len()) as f64).sqrt(), max)
}

/// The reference's own error bound (its two steps' difference) for `part`: `rms` or `max`.
fn reference_error(c: &Case, part: &str, which: &str) -> f64 {
    c.json["coarse_vs_fine"][part][which].as_f64().unwrap()
}

fn check(name: &str, part: &str, tolerance: f64, a: &SizeAverage) {
    let c = case(name);
    let (rms, max) = errors(&c, a, part);
    let own = reference_error(&c, part, "rms");
    let own_max = reference_error(&c, part, "max");
    println!(
        "{name} {part} tol {tolerance:.0e}: estimate {:.2e}, true rms {rms:.2e}; max estimate {:.2e}, true max {max:.2e}; {} spheres (reference's own: {own:.1e}, max {own_max:.1e})",
        a.error_estimate, a.max_error_estimate, a.radius_nodes
    );
    assert!(
        own < 0.2 * tolerance,
        "{name}: reference not converged ({own:.1e})"
    );
    assert!(a.error_estimate <= tolerance, "{}", a.error_estimate);
    assert!(
        rms <= a.error_estimate + own,
        "{name} {part}: true rms {rms:.2e} above the estimate {:.2e}",
        a.error_estimate
    );
    assert!(
        max <= a.max_error_estimate + own_max,
        "{name} {part}: true max {max:.2e} above the estimate {:.2e}",
        a.max_error_estimate
    );
    for (q, key) in [(a.q_ext, "q_ext"), (a.q_sca, "q_sca"), (a.g, "g")] {
        let r = c.json[key].as_f64().unwrap();
        assert!((q / r - 1.0).abs() < tolerance, "{name} {key}: {q} vs {r}");
    }
}

fn points(name: &str, tolerance: f64, max_tolerance: Option<f64>) -> SizeAverage {
    let c = case(name);
    let limits = AverageLimits {
        tolerance,
        max_tolerance,
        max_nodes: 100_000,
    };
    let angles = column(&c, "points_deg");
    average_at_angles(&c.distribution, c.wavelength_nm, c.m, &angles, &limits).unwrap()
}

fn bins(name: &str, tolerance: f64) -> SizeAverage {
    let c = case(name);
    let settings = FilterSettings {
        output_intervals: 180,
        sun_diameter_deg: 0.0,
        gaussian_sigma_deg: 0.0,
        radius_points: 24,
        radius_tolerance: tolerance,
    };
    let sun = settings.sun_operator();
    let limits = AverageLimits {
        tolerance,
        max_tolerance: None,
        max_nodes: 100_000,
    };
    let integrand = BinnedCurve::new(c.wavelength_nm, c.m, &settings, &sun);
    average(&c.distribution, &integrand, &limits).unwrap()
}

#[test]
fn point_values_match_references() {
    for name in ["fog", "cloud"] {
        for tolerance in [1e-2, 1e-3] {
            check(name, "points", tolerance, &points(name, tolerance, None));
        }
    }
    check("rain", "points", 1e-2, &points("rain", 1e-2, None));
}

/// With a bound on the maximum, the rule refines until the estimated largest error meets it,
/// and the true largest error stays within the estimate.
#[test]
fn maximum_error_is_bounded_when_asked() {
    for name in ["fog", "cloud"] {
        // At an RMS tolerance of 1e-2 the free estimate of the maximum is 1.5-2.2e-2.
        let free = points(name, 1e-2, None);
        let bound = 1e-2;
        assert!(
            free.max_error_estimate > bound,
            "{name}: {:.2e}",
            free.max_error_estimate
        );
        let a = points(name, 1e-2, Some(bound));
        check(name, "points", 1e-2, &a);
        assert!(
            a.max_error_estimate <= bound,
            "{name}: {:.2e}",
            a.max_error_estimate
        );
        assert!(a.radius_nodes > free.radius_nodes);
    }
}

/// Clear water: the narrow resonances are hit at random by the rule; the estimate (panels
/// combined in quadrature where their step leaves the resonances unresolved) still bounds the
/// true RMS and largest error, to the reference's own error.
#[test]
fn clear_water_estimate_bounds_the_true_error() {
    let all: serde_json::Value = serde_json::from_str(CLEAR_WATER).unwrap();
    for name in ["fog", "cloud"] {
        let json = all["cases"][name].clone();
        assert_eq!(json["m"][1].as_f64(), Some(0.0));
        let c = Case {
            distribution: serde_json::from_value(json["distribution"].clone()).unwrap(),
            wavelength_nm: json["wavelength_nm"].as_f64().unwrap(),
            m: Complex64::new(json["m"][0].as_f64().unwrap(), 0.0),
            json,
        };
        let own = c.json["half_difference"]["rms"].as_f64().unwrap();
        let own_max = c.json["half_difference"]["max"].as_f64().unwrap();
        for tolerance in [1e-2, 1e-3] {
            assert!(
                own < 0.05 * tolerance,
                "{name}: reference not converged ({own:.1e})"
            );
            let limits = AverageLimits {
                tolerance,
                max_tolerance: None,
                max_nodes: 100_000,
            };
            let angles = column(&c, "points_deg");
            let a =
                average_at_angles(&c.distribution, c.wavelength_nm, c.m, &angles, &limits).unwrap();
            let (rms, max) = errors(&c, &a, "points");
            println!(
                "clear-water {name} tol {tolerance:.0e}: estimate {:.2e}, true rms {rms:.2e}; max estimate {:.2e}, true max {max:.2e}; {} spheres (reference's own: {own:.1e})",
                a.error_estimate, a.max_error_estimate, a.radius_nodes
            );
            assert!(a.error_estimate <= tolerance, "{}", a.error_estimate);
            assert!(rms <= a.error_estimate + own, "{name}: true rms {rms:.2e}");
            assert!(
                max <= a.max_error_estimate + own_max,
                "{name}: true max {max:.2e}"
            );
        }
    }
}

#[test]
fn bin_averages_match_references() {
    check("fog", "bins", 1e-2, &bins("fog", 1e-2));
}

#[test]
#[ignore = "rain at 1e-3 (points and 1-degree bins) takes 1-2 min on the shared 2-core machine; cargo test --release --test mie_distribution -- --ignored --nocapture"]
fn rain_matches_reference_at_1e_3() {
    check("rain", "points", 1e-3, &points("rain", 1e-3, None));
    check("rain", "bins", 1e-3, &bins("rain", 1e-3));
    check("fog", "bins", 1e-3, &bins("fog", 1e-3));
}

fn settings(output_intervals: usize, tolerance: f64, points: usize) -> FilterSettings {
    FilterSettings {
        output_intervals,
        sun_diameter_deg: 0.5,
        gaussian_sigma_deg: 0.0,
        radius_points: points,
        radius_tolerance: tolerance,
    }
}

#[test]
fn fog_entry_with_sun_disc_matches_dense_gauss_legendre() {
    let fog = SizeDistribution::Lognormal {
        median_radius_um: 3.0,
        geometric_sigma: 1.2,
    };
    // a slightly absorbing drop (k = 0.01) damps the narrow resonances of clear water, so that
    // the Gauss–Legendre reference converges (clear water: 512 vs 1024 nodes differ by 1.9 %)
    let n = WaterIndexModel::default().index(550.0).unwrap();
    let (l, m) = (550.0, Complex64::new(n, 0.01));
    let run = |s: FilterSettings| compute_entry(&fog, l, m, &s, &s.sun_operator()).unwrap();
    let dense = run(settings(720, 0.0, 1024));
    let half = run(settings(720, 0.0, 512));
    let (ref_max, _, _, ref_rms) = relative_difference(&half.curve, &dense.curve);
    let tol = 1e-3;
    assert!(
        ref_rms < 0.2 * tol && ref_max < 2.0 * tol,
        "reference not converged: 512 vs 1024 nodes max {ref_max:.2e} rms {ref_rms:.2e}"
    );
    let adaptive = run(settings(720, tol, 24));
    let (max, at, ch, rms) = relative_difference(&adaptive.curve, &dense.curve);
    println!(
        "fog with sun disc: {} nodes, estimated rms {:.2e}; vs 1024 Gauss-Legendre nodes max {max:.2e} ({ch} at {at} deg), rms {rms:.2e}; reference 512 vs 1024: max {ref_max:.2e} rms {ref_rms:.2e}",
        adaptive.radius_nodes, adaptive.error_rms
    );
    assert!(adaptive.error_rms <= tol, "estimate {}", adaptive.error_rms);
    assert!(
        rms <= adaptive.error_rms + ref_rms,
        "rms {rms:.2e} above the estimate {:.2e}",
        adaptive.error_rms
    );
    for (a, b, what) in [
        (adaptive.q_sca, dense.q_sca, "Q_sca"),
        (adaptive.q_ext, dense.q_ext, "Q_ext"),
        (adaptive.g, dense.g, "g"),
    ] {
        assert!((a / b - 1.0).abs() < 1e-4, "{what}: {a} vs {b}");
    }
    // a looser tolerance takes fewer nodes
    let loose = run(settings(720, 10.0 * tol, 24));
    assert!(loose.radius_nodes < adaptive.radius_nodes);
    assert!(loose.error_rms <= 10.0 * tol && loose.error_rms > adaptive.error_rms);
}
