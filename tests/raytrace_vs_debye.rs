//! Order-by-order validation of the ray tracer against the Debye series: the Debye term `p` of
//! the Lorenz–Mie solution is the exact wave-optics field of the rays that cross the sphere `p`
//! times, so each ray-traced order must match it on its own.
//!
//! Conventions shared by both sides (stated once, used everywhere below):
//! - water index from the same model on both sides: `sadeghi-table-3.2` at 650 nm (n = 1.331);
//! - per order, unpolarised `dσ_p/dΩ / (π a²)` (1/sr): Debye `(|S1^(p)|² + |S2^(p)|²)/(2 π x²)`,
//!   ray tracer `½(|E⊥|² + |E∥|²)/(π a²)` (its fields are in sqrt(µm²/sr)). Dividing both by the
//!   same geometric cross-section keeps the comparison free of any σ_GO / Q_sca choice;
//! - the same smoothing applied to both: a Gaussian of σ_s = 0.04° · (0.4 mm / a) (resolves the
//!   supernumeraries; used for the maxima) and the 0.5° sun disc (uniform disc, chord profile);
//! - windows: p = 0 over 30°–179° (Debye p = 0 contains the diffraction term ½, so the forward
//!   lobe is excluded), p = 1 over 30°–80° (GO shadow boundary of p = 1 at 82.6°),
//!   p = 2 over 125°–150° (primary bow), p = 3 over 115°–135° (secondary bow).
//!
//! Three ray-traced variants: the 1-D unfiltered geometric-optics field (`SphereGo::order_field`,
//! no caustic model), the 1-D Airy-uniform channel (`order_field_uniform`, the stage's default
//! for spheres) and the 2-D patch tracer (`trace_fields`, unfiltered GO with patches).
//!
//! Full table: `cargo test --release --test raytrace_vs_debye -- --ignored --nocapture`.

use num_complex::Complex64;
use rayon::prelude::*;
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use scatterbake::optics::water::WaterIndexModel;
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::sphere1d::{Phase1dOptions, SphereGo, sphere_phase_1d};
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};
use std::f64::consts::PI;

const LAMBDA_NM: f64 = 650.0;

fn water_n() -> f64 {
    WaterIndexModel::SadeghiTable32.index(LAMBDA_NM).unwrap()
}

fn grid(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step).round() as usize + 1;
    (0..n).map(|i| lo + step * i as f64).collect()
}

/// Which intensity is compared: unpolarised (the default everywhere), ⊥ (|S1|²) or ∥ (|S2|²).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Pol {
    Unpolarised,
    Perp,
    Par,
}

impl Pol {
    fn of(self, perp: f64, par: f64) -> f64 {
        match self {
            Pol::Unpolarised => 0.5 * (perp + par),
            Pol::Perp => perp,
            Pol::Par => par,
        }
    }
}

/// Debye term `p` alone: `dσ_p/dΩ / (π a²)` at `angles` (deg).
fn debye_order(d: &DebyeCoefficients, p: usize, angles: &[f64], pol: Pol) -> Vec<f64> {
    let x = d.size_parameter;
    let set = OrderSet::Orders(vec![p]);
    let (a, b) = d.coefficients(&set);
    let sphere = d.term_sphere(a, b);
    angles
        .par_chunks(256)
        .flat_map_iter(|c| {
            let (s1, s2) = sphere.amplitudes_deg(c);
            s1.iter()
                .zip(&s2)
                .map(|(s1, s2)| pol.of(s1.norm_sqr(), s2.norm_sqr()) / (PI * x * x))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Ray-traced order `p` (1-D path): unpolarised `dσ_p/dΩ / (π a²)`; `uniform` selects the
/// Airy-uniform caustic channel, otherwise the plain GO-plus-phase branch sum.
fn go_order(go: &SphereGo, p: usize, angles: &[f64], uniform: bool, pol: Pol) -> Vec<f64> {
    let area = PI * go.radius_um * go.radius_um;
    angles
        .par_iter()
        .map(|&t| {
            let th = t.to_radians();
            let f = if uniform {
                go.order_field_uniform(p, th)
            } else {
                go.order_field(p, th)
            };
            pol.of(f.perp.norm_sqr(), f.par.norm_sqr()) / area
        })
        .collect()
}

/// Gaussian smoothing (σ in samples), renormalised at the ends.
fn gauss(v: &[f64], sigma: f64) -> Vec<f64> {
    let h = (4.0 * sigma).ceil() as i64;
    let w: Vec<f64> = (-h..=h)
        .map(|d| (-0.5 * (d as f64 / sigma).powi(2)).exp())
        .collect();
    convolve(v, &w)
}

/// Uniform sun disc of angular diameter `diam_deg` (chord-length profile).
fn sun_disc(v: &[f64], step_deg: f64, diam_deg: f64) -> Vec<f64> {
    let r = 0.5 * diam_deg / step_deg;
    let h = r.ceil() as i64;
    let w: Vec<f64> = (-h..=h)
        .map(|d| (r * r - (d as f64).powi(2)).max(0.0).sqrt())
        .collect();
    convolve(v, &w)
}

fn convolve(v: &[f64], w: &[f64]) -> Vec<f64> {
    let h = (w.len() / 2) as i64;
    (0..v.len() as i64)
        .map(|i| {
            let (mut s, mut ws) = (0.0, 0.0);
            for (k, d) in (-h..=h).enumerate() {
                let j = i + d;
                if j >= 0 && (j as usize) < v.len() {
                    s += w[k] * v[j as usize];
                    ws += w[k];
                }
            }
            s / ws
        })
        .collect()
}

/// Local maxima (deg, parabolic refinement) inside [lo, hi].
fn maxima(angles: &[f64], v: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    (1..v.len() - 1)
        .filter(|&i| angles[i] >= lo && angles[i] <= hi && v[i] > v[i - 1] && v[i] >= v[i + 1])
        .map(|i| {
            let (a, b, c) = (v[i - 1], v[i], v[i + 1]);
            let den = a - 2.0 * b + c;
            let off = if den != 0.0 { 0.5 * (a - c) / den } else { 0.0 };
            angles[i] + off * (angles[1] - angles[0])
        })
        .collect()
}

/// Relative L2 of `a` against the reference `b` over angles in [lo, hi].
fn rel_l2(angles: &[f64], a: &[f64], b: &[f64], lo: f64, hi: f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((t, x), y) in angles.iter().zip(a).zip(b) {
        if *t >= lo && *t <= hi {
            num += (x - y).powi(2);
            den += y * y;
        }
    }
    (num / den).sqrt()
}

/// Comparison window of order `p` (deg).
fn window(p: usize) -> (f64, f64) {
    match p {
        0 => (30.0, 179.0),
        1 => (30.0, 80.0),
        2 => (125.0, 150.0),
        _ => (115.0, 135.0),
    }
}

/// Per-order figures of one variant against Debye.
#[derive(Debug, Clone)]
struct OrderFigures {
    /// Relative L2 after the Gaussian σ_s.
    l2_gauss: f64,
    /// Relative L2 after the 0.5° sun disc.
    l2_disc: f64,
    /// Relative L2 (Gaussian σ_s) away from the caustic: p = 2 over 140°–150°, p = 3 over
    /// 121°–127° (clear of both its caustic at 129.6° and its grazing-incidence edge at
    /// 112.2°, where GO also departs from Debye); = `l2_gauss` for p = 0, 1.
    l2_far: f64,
    /// Main maximum and the first supernumeraries (p = 2, 3), Debye then ray-traced; outwards
    /// from the bow (increasing θ for p = 2, decreasing for p = 3).
    maxima_debye: Vec<f64>,
    maxima_ray: Vec<f64>,
}

/// Ordered bow maxima of a smoothed p = 2 / p = 3 curve: main maximum then supernumeraries.
fn bow_maxima(angles: &[f64], v: &[f64], p: usize, bow_deg: f64, count: usize) -> Vec<f64> {
    let mut m = if p == 2 {
        maxima(angles, v, bow_deg - 1.0, 150.0)
    } else {
        let mut m = maxima(angles, v, 115.0, bow_deg + 1.0);
        m.reverse();
        m
    };
    m.truncate(count);
    m
}

/// Supernumerary maxima only: those more than `gap_deg` from the geometric bow on its bright
/// side (the unfiltered GO field has its spurious caustic peak, and for the 2-D tracer caustic
/// noise, inside that gap).
fn supernumeraries(m: &[f64], p: usize, bow_deg: f64, gap_deg: f64, count: usize) -> Vec<f64> {
    m.iter()
        .copied()
        .filter(|t| {
            if p == 2 {
                *t > bow_deg + gap_deg
            } else {
                *t < bow_deg - gap_deg
            }
        })
        .take(count)
        .collect()
}

fn compare(
    angles: &[f64],
    step: f64,
    a_mm: f64,
    p: usize,
    ray: &[f64],
    deb: &[f64],
    bow: f64,
) -> OrderFigures {
    let sig = 0.016 / a_mm / step;
    let (rg, dg) = (gauss(ray, sig), gauss(deb, sig));
    let (rd, dd) = (sun_disc(ray, step, 0.5), sun_disc(deb, step, 0.5));
    let (lo, hi) = window(p);
    let (maxima_debye, maxima_ray) = if p >= 2 {
        (
            bow_maxima(angles, &dg, p, bow, 5),
            // More than Debye's: noise maxima of the 2-D curve (see nearest_supernumerary_dev).
            bow_maxima(angles, &rg, p, bow, 12),
        )
    } else {
        (vec![], vec![])
    };
    OrderFigures {
        l2_gauss: rel_l2(angles, &rg, &dg, lo, hi),
        l2_disc: rel_l2(angles, &rd, &dd, lo, hi),
        l2_far: match p {
            2 => rel_l2(angles, &rg, &dg, 140.0, 150.0),
            3 => rel_l2(angles, &rg, &dg, 121.0, 127.0),
            _ => rel_l2(angles, &rg, &dg, lo, hi),
        },
        maxima_debye,
        maxima_ray,
    }
}

/// Sampling step (deg) resolving the two-branch fringes of one order (period ≥ λ/a rad).
fn step_for(a_mm: f64) -> f64 {
    (0.004 / a_mm).min(0.02)
}

/// 1-D comparison of order `p` at radius `a_mm`: (GO unfiltered, Airy-uniform) figures.
fn compare_1d(a_mm: f64, p: usize) -> (OrderFigures, OrderFigures) {
    compare_1d_pol(a_mm, p, Pol::Unpolarised)
}

fn compare_1d_pol(a_mm: f64, p: usize, pol: Pol) -> (OrderFigures, OrderFigures) {
    let n = water_n();
    let a_um = a_mm * 1e3;
    let x = 2.0 * PI * a_um / (LAMBDA_NM * 1e-3);
    let d = DebyeCoefficients::new(x, Complex64::new(n, 0.0)).unwrap();
    let go = SphereGo::new(a_um, LAMBDA_NM, n, 3);
    let step = step_for(a_mm);
    let (lo, hi) = window(p);
    let margin = 0.5 + 5.0 * 0.016 / a_mm;
    let angles = grid(lo - margin, (hi + margin).min(179.9), step);
    let deb = debye_order(&d, p, &angles, pol);
    let bow = go.rainbow_angle_rad(p).map_or(0.0, f64::to_degrees);
    let g = compare(
        &angles,
        step,
        a_mm,
        p,
        &go_order(&go, p, &angles, false, pol),
        &deb,
        bow,
    );
    let u = compare(
        &angles,
        step,
        a_mm,
        p,
        &go_order(&go, p, &angles, true, pol),
        &deb,
        bow,
    );
    (g, u)
}

/// 2-D patch tracer (0.4 mm, sun elevation 17°, azimuth-averaged over `n_azimuth` columns) vs
/// Debye, per order, on a 0.02° polar grid.
fn compare_2d(rays: usize, n_azimuth: usize) -> Vec<OrderFigures> {
    let (a_mm, n) = (0.4, water_n());
    let a_um = a_mm * 1e3;
    let cfg = TraceConfig {
        rays,
        max_order: 3,
        sun_elevation_rad: 17f64.to_radians(),
        wavelength_nm: LAMBDA_NM,
        n,
        ray_grid: RayGridLayout::Square,
    };
    let n_polar = 9001;
    let f = trace_fields(
        &DropShape::Sphere { radius_um: a_um },
        &cfg,
        DirectionGrid { n_polar, n_azimuth },
    );
    let step = 180.0 / (n_polar - 1) as f64;
    let x = 2.0 * PI * a_um / (LAMBDA_NM * 1e-3);
    let d = DebyeCoefficients::new(x, Complex64::new(n, 0.0)).unwrap();
    let go = SphereGo::new(a_um, LAMBDA_NM, n, 3);
    let area = PI * a_um * a_um;
    (0..4)
        .map(|p| {
            let (lo, hi) = window(p);
            let j0 = ((lo - 1.0) / step).round() as usize;
            let j1 = (((hi + 1.0) / step).round() as usize).min(n_polar - 2);
            let angles: Vec<f64> = (j0..=j1).map(|j| step * j as f64).collect();
            let ray: Vec<f64> = (j0..=j1)
                .map(|j| {
                    (0..n_azimuth)
                        .map(|k| f.intensities(j, k).2[p])
                        .sum::<f64>()
                        / (n_azimuth as f64 * area)
                })
                .collect();
            let deb = debye_order(&d, p, &angles, Pol::Unpolarised);
            let bow = go.rainbow_angle_rad(p).map_or(0.0, f64::to_degrees);
            compare(&angles, step, a_mm, p, &ray, &deb, bow)
        })
        .collect()
}

fn max_dev(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Width of the zone next to the geometric bow that contains the main maximum (deg).
fn gap_deg(a_mm: f64) -> f64 {
    (0.4 / a_mm).powf(2.0 / 3.0)
}

/// Geometric bow angle of order `p` (deg) for n of the shared water model.
fn bow_deg(p: usize) -> f64 {
    SphereGo::new(400.0, LAMBDA_NM, water_n(), 3)
        .rainbow_angle_rad(p)
        .unwrap()
        .to_degrees()
}

/// (main-maximum deviation, supernumerary deviations of the first four) of one comparison.
fn maxima_devs(f: &OrderFigures, p: usize, a_mm: f64) -> (f64, f64) {
    let (bow, gap) = (bow_deg(p), gap_deg(a_mm));
    let sd = supernumeraries(&f.maxima_debye, p, bow, gap, 4);
    let sr = supernumeraries(&f.maxima_ray, p, bow, gap, 4);
    (
        (f.maxima_ray[0] - f.maxima_debye[0]).abs(),
        max_dev(&sd, &sr),
    )
}

/// Largest distance from each of the first four Debye supernumeraries of order `p` to the
/// nearest ray-traced maximum: the 2-D tracer's curve at 400² rays carries noise maxima between
/// the supernumeraries (e.g. two maxima 0.12° apart near 127.4° for p = 3), which would shift a
/// pairing by rank.
fn nearest_supernumerary_dev(f: &OrderFigures, p: usize, a_mm: f64) -> f64 {
    let (bow, gap) = (bow_deg(p), gap_deg(a_mm));
    supernumeraries(&f.maxima_debye, p, bow, gap, 4)
        .iter()
        .map(|d| {
            f.maxima_ray
                .iter()
                .map(|r| (r - d).abs())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// Fast subset: 0.1 and 0.4 mm, all four orders, 1-D path (unfiltered GO and Airy-uniform)
/// against Debye; the 2-D patch tracer at 0.4 mm with 400² rays. Tolerances are the measured
/// figures (docs/raytrace.md) with a margin of ≥ 2×.
#[test]
fn ray_orders_match_debye_terms() {
    // (a_mm, p, max L2 (disc) of p = 0, 1 and of the Airy channel for p = 2, 3,
    //  max |Δ| main maximum (Airy), max |Δ| supernumeraries (Airy and GO))
    let cases = [
        (0.1, 0, 0.01, 0.0, 0.0),
        (0.1, 1, 0.015, 0.0, 0.0),
        (0.1, 2, 0.025, 0.02, 0.02),
        (0.1, 3, 0.16, 0.05, 0.15),
        (0.4, 0, 0.001, 0.0, 0.0),
        (0.4, 1, 0.004, 0.0, 0.0),
        (0.4, 2, 0.004, 0.005, 0.01),
        (0.4, 3, 0.05, 0.01, 0.02),
    ];
    for (a_mm, p, l2_max, main_max, super_max) in cases {
        let (g, u) = compare_1d(a_mm, p);
        assert!(u.l2_disc < l2_max, "a={a_mm} p={p} Airy L2 {}", u.l2_disc);
        if p < 2 {
            // No caustic: the two channels are the same GO field.
            assert_eq!(g.l2_disc, u.l2_disc);
            continue;
        }
        // Unfiltered GO fails at the caustic (L2 ≥ 19 % in every measured case) but matches
        // Debye away from it.
        assert!(g.l2_gauss > 0.15, "a={a_mm} p={p} GO L2 {}", g.l2_gauss);
        assert!(
            g.l2_far < 2.0 * l2_max,
            "a={a_mm} p={p} GO far L2 {}",
            g.l2_far
        );
        let (main_u, sup_u) = maxima_devs(&u, p, a_mm);
        let (main_g, sup_g) = maxima_devs(&g, p, a_mm);
        assert!(
            main_u <= main_max,
            "a={a_mm} p={p} Airy main max Δ {main_u}"
        );
        assert!(main_g > 0.15, "a={a_mm} p={p} GO main max Δ {main_g}");
        assert!(
            sup_u <= super_max,
            "a={a_mm} p={p} Airy supernumeraries Δ {sup_u}"
        );
        assert!(
            sup_g <= super_max,
            "a={a_mm} p={p} GO supernumeraries Δ {sup_g}"
        );
    }
    // Each polarisation on its own (guards the ∥ sign conventions): p = 1 and p = 2 at 0.4 mm,
    // measured ⊥ 0.09 % / 0.16 %, ∥ 0.17 % / 0.30 % (Airy channel, Gauss σ_s).
    for (p, pol, tol) in [
        (1, Pol::Perp, 0.003),
        (1, Pol::Par, 0.005),
        (2, Pol::Perp, 0.005),
        (2, Pol::Par, 0.01),
    ] {
        let (_, u) = compare_1d_pol(0.4, p, pol);
        assert!(u.l2_gauss < tol, "p={p} {pol:?} L2 {}", u.l2_gauss);
    }
    let f2 = compare_2d(400, 4);
    assert!(f2[0].l2_disc < 0.04, "2-D p=0 L2 {}", f2[0].l2_disc);
    assert!(f2[1].l2_disc < 0.02, "2-D p=1 L2 {}", f2[1].l2_disc);
    // p = 3 converges more slowly with the ray count (0.129° at 400², 0.049° at 800²).
    for (p, tol) in [(2, 0.03), (3, 0.25)] {
        let sup = nearest_supernumerary_dev(&f2[p], p, 0.4);
        assert!(sup <= tol, "2-D p={p} supernumeraries Δ {sup}");
    }
}

/// The stage's per-order channels (`phase_p2`, `phase_p3`: Airy channel, `dσ_p/dΩ / σ_total`
/// with `σ_total = σ_GO + πa²`) against the Debye module's own normalised curves
/// (`DebyeCoefficients::curve`: cell averages of `s11^(p) / (π x² Q_sca)`), 0.4 mm on a 0.01°
/// grid. The two normalisations differ by the constant `σ_total / (π a² Q_sca)` (GO truncated
/// at p = 3 and the forward lobe counted as πa², vs the exact Mie cross-section); with that
/// factor the curves agree like the 1-D comparison above.
#[test]
fn stage_order_channels_match_debye_curves() {
    let (a_mm, n) = (0.4, water_n());
    let a_um = a_mm * 1e3;
    let x = 2.0 * PI * a_um / (LAMBDA_NM * 1e-3);
    let d = DebyeCoefficients::new(x, Complex64::new(n, 0.0)).unwrap();
    let go = SphereGo::new(a_um, LAMBDA_NM, n, 3);
    let intervals = 18000;
    let angles: Vec<f64> = (0..=intervals)
        .map(|j| 180.0 * j as f64 / intervals as f64)
        .collect();
    let (ch, sigma_total) = sphere_phase_1d(&go, &angles, Phase1dOptions::default());
    let q_sca = d.mie_normalisation() / (PI * x * x);
    let scale = sigma_total / (PI * a_um * a_um * q_sca);
    // Measured 0.9938: the stage's σ_total is 0.6 % below the Mie cross-section.
    assert!((scale - 0.9938).abs() < 1e-3, "scale {scale}");
    let sig = 0.016 / a_mm / 0.01;
    for (p, lo, hi, tol) in [(2, 125.0, 150.0, 0.004), (3, 115.0, 135.0, 0.05)] {
        let c = d.curve(&OrderSet::Orders(vec![p]), intervals, 4, true);
        let deb: Vec<f64> = c
            .i_perp
            .iter()
            .zip(&c.i_par)
            .map(|(a, b)| 0.5 * (a + b))
            .collect();
        let stage: Vec<f64> = ch[4 + p].iter().map(|v| v * scale).collect();
        let l2 = rel_l2(&angles, &gauss(&stage, sig), &gauss(&deb, sig), lo, hi);
        let raw = rel_l2(&angles, &gauss(&ch[4 + p], sig), &gauss(&deb, sig), lo, hi);
        eprintln!("p={p}: L2 {l2:.4} with the factor, {raw:.4} without (scale {scale:.4})");
        assert!(l2 < tol, "p={p} L2 {l2}");
    }
}

/// Where the Airy channel's p = 3 error sits: relative L2 (Gauss σ_s, ⊥ and ∥, normalised by
/// the Debye norm over the whole 115°–135° window) in sub-windows, 0.4 mm. At the caustic
/// (127.5° to the bow, and the dark side) the Airy model removes the GO failure (docs/raytrace.md:
/// Airy ≤ 0.8 %, GO 12–54 %); away from it (115°–127.5°) the two channels are the same GO field.
#[test]
fn p3_airy_error_by_region() {
    let (a_mm, p) = (0.4, 3);
    let n = water_n();
    let a_um = a_mm * 1e3;
    let x = 2.0 * PI * a_um / (LAMBDA_NM * 1e-3);
    let d = DebyeCoefficients::new(x, Complex64::new(n, 0.0)).unwrap();
    let go = SphereGo::new(a_um, LAMBDA_NM, n, 3);
    let step = step_for(a_mm);
    let angles = grid(114.0, 136.0, step);
    let bow = bow_deg(p);
    let sig = 0.016 / a_mm / step;
    for pol in [Pol::Perp, Pol::Par] {
        let deb = gauss(&debye_order(&d, p, &angles, pol), sig);
        let den: f64 = angles
            .iter()
            .zip(&deb)
            .filter(|(t, _)| (115.0..=135.0).contains(*t))
            .map(|(_, y)| y * y)
            .sum();
        let parts = |uniform: bool| -> [f64; 4] {
            let ray = gauss(&go_order(&go, p, &angles, uniform, pol), sig);
            let part = |lo: f64, hi: f64| -> f64 {
                let num: f64 = angles
                    .iter()
                    .zip(&ray)
                    .zip(&deb)
                    .filter(|((t, _), _)| **t >= lo && **t < hi)
                    .map(|((_, r), y)| (r - y).powi(2))
                    .sum();
                (num / den).sqrt()
            };
            [
                part(115.0, 121.0),
                part(121.0, bow - 2.0),
                part(bow - 2.0, bow),
                part(bow, 135.0),
            ]
        };
        let (g, u) = (parts(false), parts(true));
        for (name, v) in [("GO", g), ("Airy", u)] {
            println!(
                "{pol:?} {name}: 115–121 {:.4} | 121–{:.2} {:.4} | {:.2}–bow {:.4} | bow–135 (dark) {:.4}",
                v[0],
                bow - 2.0,
                v[1],
                bow - 2.0,
                v[2],
                v[3]
            );
        }
        for k in [2, 3] {
            assert!(u[k] < 0.01, "{pol:?} region {k}: Airy {}", u[k]);
            assert!(g[k] > 0.1, "{pol:?} region {k}: GO {}", g[k]);
        }
        for k in [0, 1] {
            assert!(
                (u[k] - g[k]).abs() < 0.005,
                "{pol:?} region {k}: Airy {} vs GO {}",
                u[k],
                g[k]
            );
        }
    }
}

/// The full order-by-order table of docs/raytrace.md: 0.1, 0.2, 0.4 and 1 mm, p = 0–3, 1-D path
/// (unfiltered GO and the Airy channel) unpolarised and per polarisation, and the 2-D patch
/// tracer at 0.4 mm with 400² and 800² rays, against the Debye terms. Each error of the Airy
/// channel falls as the drop grows (the ray picture is the large-size limit of the Debye
/// term) and stays within 1.5× the documented figure; unfiltered GO fails at every caustic
/// and matches away from it; the 2-D tracer converges with the ray count.
#[test]
#[ignore = "long validation (≈15 s); run with cargo test --release -- --ignored"]
fn ray_orders_match_debye_terms_full_table() {
    full_table_1d();
    full_table_2d();
}

/// The 1-D rows of the full table: every order and radius against its documented figure.
fn full_table_1d() {
    // docs/raytrace.md, per radius: Airy L2 (disc) for p = 0, 1; Airy L2 (Gauss) for p = 2, 3;
    // GO far L2 for p = 2, 3.
    let documented: [(f64, [f64; 4], [f64; 2]); 4] = [
        (0.1, [0.0035, 0.0055, 0.0083, 0.080], [0.015, 0.077]),
        (0.2, [0.0010, 0.0027, 0.0034, 0.046], [0.0073, 0.039]),
        (0.4, [0.0002, 0.0013, 0.0015, 0.025], [0.0032, 0.020]),
        (1.0, [0.0001, 0.0005, 0.0009, 0.011], [0.0012, 0.0067]),
    ];
    let mut prev = [f64::INFINITY; 4];
    for (a_mm, airy_doc, far_doc) in documented {
        for p in 0..4 {
            let (g, u) = compare_1d(a_mm, p);
            println!(
                "a={a_mm} mm p={p}: L2 gauss GO {:.4} Airy {:.4} | disc GO {:.4} Airy {:.4} | far GO {:.4} Airy {:.4}",
                g.l2_gauss, u.l2_gauss, g.l2_disc, u.l2_disc, g.l2_far, u.l2_far
            );
            let (gp, up) = compare_1d_pol(a_mm, p, Pol::Perp);
            let (gq, uq) = compare_1d_pol(a_mm, p, Pol::Par);
            println!(
                "   polarised L2 gauss: ⊥ GO {:.4} Airy {:.4} far GO {:.4} | ∥ GO {:.4} Airy {:.4} far GO {:.4}",
                gp.l2_gauss, up.l2_gauss, gp.l2_far, gq.l2_gauss, uq.l2_gauss, gq.l2_far
            );
            let airy = if p < 2 { u.l2_disc } else { u.l2_gauss };
            assert!(
                airy < 1.5 * airy_doc[p].max(1e-4),
                "a={a_mm} p={p}: Airy L2 {airy} vs documented {}",
                airy_doc[p]
            );
            assert!(
                airy < prev[p],
                "a={a_mm} p={p}: Airy L2 {airy} not below {} at the smaller drop",
                prev[p]
            );
            prev[p] = airy;
            // Each polarisation on its own (docs/raytrace.md: at most 6.1 % for ⊥ and 20 % for ∥,
            // both p = 3 at 0.1 mm; p = 3 ∥ is limited by the grazing-incidence edge of the
            // window, see p3_airy_error_by_region).
            assert!(up.l2_gauss < 0.1 && uq.l2_gauss < 0.25, "a={a_mm} p={p}");
            if p >= 2 {
                check_bow_orders(a_mm, p, [&g, &u, &gq, &uq], far_doc[p - 2]);
            }
        }
    }
}

/// The bow orders (p ≥ 2) of one radius: maxima of GO and of the Airy channel against the
/// Debye term (`[go, airy, go_par, airy_par]`), GO away from the caustic against `far_doc`.
fn check_bow_orders(a_mm: f64, p: usize, figures: [&OrderFigures; 4], far_doc: f64) {
    let [g, u, gq, uq] = figures;
    println!(
        "   ∥ maxima Debye {:?}\n     Airy {:?}",
        round(&gq.maxima_debye),
        round(&uq.maxima_ray[..5.min(uq.maxima_ray.len())])
    );
    let (mg, sg) = maxima_devs(g, p, a_mm);
    let (mu, su) = maxima_devs(u, p, a_mm);
    println!(
        "   maxima Debye {:?}\n   GO    {:?} (main Δ {mg:.3}, supernumeraries max Δ {sg:.3})\n   Airy  {:?} (main Δ {mu:.3}, supernumeraries max Δ {su:.3})",
        round(&g.maxima_debye),
        round(&g.maxima_ray[..5.min(g.maxima_ray.len())]),
        round(&u.maxima_ray[..5.min(u.maxima_ray.len())]),
    );
    // GO fails at the caustic, matches away from it.
    assert!(g.l2_gauss > 0.15, "a={a_mm} p={p}: GO L2 {}", g.l2_gauss);
    assert!(
        g.l2_far < 1.5 * far_doc,
        "a={a_mm} p={p}: GO far L2 {} vs documented {}",
        g.l2_far,
        far_doc
    );
    // docs/raytrace.md: Airy main maximum within 0.012°, supernumeraries within
    // 0.067° (p = 3 at 0.1 mm), 0.006° for p = 2; GO's main maximum is off by ≥ 0.2°.
    let sup_tol = if p == 2 { 0.01 } else { 0.08 };
    assert!(mu <= 0.015, "a={a_mm} p={p}: Airy main Δ {mu}");
    assert!(su <= sup_tol, "a={a_mm} p={p}: Airy supernumeraries Δ {su}");
    assert!(mg > 0.15, "a={a_mm} p={p}: GO main Δ {mg}");
}

/// The 2-D tracer at 0.4 mm converges with the ray count.
fn full_table_2d() {
    let mut prev2: Option<Vec<OrderFigures>> = None;
    for rays in [400, 800] {
        let t = std::time::Instant::now();
        let f2 = compare_2d(rays, 4);
        println!(
            "2-D tracer 0.4 mm, {rays}² rays ({:.2} s):",
            t.elapsed().as_secs_f64()
        );
        for (p, g) in f2.iter().enumerate() {
            print!(
                "   p={p}: L2 gauss {:.4} disc {:.4} far {:.4}",
                g.l2_gauss, g.l2_disc, g.l2_far
            );
            if p >= 2 {
                let (m, s) = maxima_devs(g, p, 0.4);
                let (bow, gap) = (bow_deg(p), gap_deg(0.4));
                print!(
                    " supernumeraries {:?} vs Debye {:?} (max Δ {s:.3}; main Δ {m:.3})",
                    round(&supernumeraries(&g.maxima_ray, p, bow, gap, 4)),
                    round(&supernumeraries(&g.maxima_debye, p, bow, gap, 4)),
                );
            }
            println!();
        }
        if let Some(before) = &prev2 {
            for p in 0..4 {
                assert!(
                    f2[p].l2_far < before[p].l2_far,
                    "p={p}: 2-D far L2 {} at {rays}² not below {}",
                    f2[p].l2_far,
                    before[p].l2_far
                );
            }
            // docs/raytrace.md at 800²: p = 2 0.003°, p = 3 0.049°.
            let (_, s2) = maxima_devs(&f2[2], 2, 0.4);
            let (_, s3) = maxima_devs(&f2[3], 3, 0.4);
            assert!(
                s2 <= 0.01 && s3 <= 0.07,
                "800²: supernumeraries Δ {s2} / {s3}"
            );
        }
        prev2 = Some(f2);
    }
}

fn round(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| (x * 1000.0).round() / 1000.0).collect()
}
