//! Independent check of the 2-D tracer on a non-spherical drop: an oblate spheroid with the sun
//! on the horizon. Rays in the vertical plane through the drop's axis stay in that plane, so the
//! geometric primary-bow angle there is the Descartes angle of the 2-D ellipse cross-section,
//! computed here by a separate 2-D ray trace (no code shared with the tracer). The wave-optics
//! maximum lies a little beyond the geometric angle (Airy), so the tracer's p = 2 maximum must
//! fall in [geometric, geometric + 1°].

use scatterbake::raytrace::shape::{CosineSeries, DropShape};
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};

/// Primary-bow (one internal reflection) scattering angle of a 2-D ellipse
/// `x² + (y/q)² = 1` lit along +x, in degrees: the minimum scattering angle over impact heights.
fn ellipse_primary_bow_deg(q: f64, n: f64) -> f64 {
    let hit = |p: [f64; 2], d: [f64; 2]| -> [f64; 2] {
        let a = d[0] * d[0] + d[1] * d[1] / (q * q);
        let b = 2.0 * (p[0] * d[0] + p[1] * d[1] / (q * q));
        let c = p[0] * p[0] + p[1] * p[1] / (q * q) - 1.0;
        let t = (-b + (b * b - 4.0 * a * c).max(0.0).sqrt()) / (2.0 * a);
        [p[0] + t * d[0], p[1] + t * d[1]]
    };
    let normal = |x: [f64; 2]| {
        let g = [x[0], x[1] / (q * q)];
        let l = g[0].hypot(g[1]);
        [g[0] / l, g[1] / l]
    };
    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
    let refract = |d: [f64; 2], mut nr: [f64; 2], eta: f64| -> Option<[f64; 2]> {
        let mut c = -dot(d, nr);
        if c < 0.0 {
            nr = [-nr[0], -nr[1]];
            c = -c;
        }
        let k = 1.0 - eta * eta * (1.0 - c * c);
        (k >= 0.0).then(|| {
            let f = eta * c - k.sqrt();
            [eta * d[0] + f * nr[0], eta * d[1] + f * nr[1]]
        })
    };
    let mut best = f64::MAX;
    let m = 20_000;
    for i in 1..m {
        let y0 = q * (-1.0 + 2.0 * i as f64 / m as f64);
        let x0 = -(1.0 - (y0 / q).powi(2)).sqrt();
        let x1 = [x0, y0];
        let Some(d1) = refract([1.0, 0.0], normal(x1), 1.0 / n) else {
            continue;
        };
        let x2 = hit(x1, d1);
        let n2 = normal(x2);
        let r = 2.0 * dot(d1, n2);
        let d2 = [d1[0] - r * n2[0], d1[1] - r * n2[1]];
        let x3 = hit(x2, d2);
        if let Some(d3) = refract(d2, normal(x3), n) {
            best = best.min(d3[1].atan2(d3[0]).abs().to_degrees());
        }
    }
    best
}

/// Oblate spheroid of equal-volume radius `a_um` and axis ratio `q` as a fitted profile.
fn spheroid(a_um: f64, q: f64) -> DropShape {
    let theta: Vec<f64> = (0..=180).map(f64::from).collect();
    let r: Vec<f64> = theta
        .iter()
        .map(|t| {
            let t = t.to_radians();
            1.0 / (t.sin().powi(2) + (t.cos() / q).powi(2)).sqrt()
        })
        .collect();
    let (s, residual) = CosineSeries::fit_table(a_um, &theta, &r).unwrap();
    assert!(residual < 1e-3, "fit residual {residual}");
    DropShape::Series(s)
}

/// p = 2 maximum (deg) in the vertical plane (azimuth 0° and 180°), Gaussian-smoothed by σ = 0.1°
/// to remove the fine interference ripple.
fn traced_primary_max_deg(shape: &DropShape, n: f64) -> (f64, f64) {
    let cfg = TraceConfig {
        rays: 500,
        max_order: 3,
        sun_elevation_rad: 0.0,
        wavelength_nm: 650.0,
        n,
        ray_grid: RayGridLayout::Square,
    };
    let grid = DirectionGrid {
        n_polar: 3601,
        n_azimuth: 36,
    };
    let f = trace_fields(shape, &cfg, grid);
    let peak = |k: usize| {
        let v: Vec<f64> = (0..3601).map(|j| f.intensities(j, k).2[2]).collect();
        let sm = scatterbake::mie::filters::gaussian_blur_1d(&v, 0.05, 0.1);
        (2600..3500)
            .max_by(|&a, &b| sm[a].total_cmp(&sm[b]))
            .map(|j| 0.05 * j as f64)
            .unwrap()
    };
    (peak(0), peak(18))
}

#[test]
fn oblate_spheroid_bow_in_the_vertical_plane_matches_the_ellipse_descartes_angle() {
    let n = 1.331;
    let q = 0.927; // axis ratio of a 1 mm Beard–Chuang drop (Beard & Chuang 1987)
    let geo_sphere = ellipse_primary_bow_deg(1.0, n);
    assert!(
        (geo_sphere - 137.63).abs() < 0.01,
        "sphere Descartes {geo_sphere}"
    );
    let geo = ellipse_primary_bow_deg(q, n);
    let (up, down) = traced_primary_max_deg(&spheroid(1000.0, q), n);
    println!(
        "q = {q}: ellipse Descartes angle {geo:.3}°, traced p = 2 maxima {up:.2}° / {down:.2}°"
    );
    for m in [up, down] {
        assert!(
            m >= geo - 0.1 && m <= geo + 1.0,
            "traced {m}° vs geometric {geo}°"
        );
    }
    // The shift is large (≈ 8°): a plain sphere-like result would fail the check above.
    assert!(geo - geo_sphere > 5.0);
}
