//! Alexander's dark band order by order: the Debye-series terms p = 0..6 (and the diffraction
//! and external-reflection parts of p = 0) against the 1-D ray path's per-order fields (GO and
//! the Airy-uniform caustic channel), as mean `dσ/dΩ / (π a²)` (1/sr) over 131°–136°, plus the
//! cross-order interference `⟨|Σ_p E_p|²⟩ − Σ_p ⟨|E_p|²⟩` on both sides.
//!
//! Both sides are divided by the geometric cross-section, so no normalisation choice enters.
//! Writes `docs/data/raytrace/alexander_band_orders.csv`.
//!
//! `cargo run --release --example alexander_band_orders`
use num_complex::Complex64;
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use scatterbake::raytrace::sphere1d::{OrderField, SphereGo};
use std::f64::consts::PI;
use std::fmt::Write as _;

const LAMBDA_NM: f64 = 650.0;
const N: f64 = 1.331;
const MAX_P: usize = 6;
const BAND: (f64, f64) = (131.0, 136.0);

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Unpolarised `dσ/dΩ/(πa²)` of Debye amplitudes.
fn debye_intensity(s1: &[Complex64], s2: &[Complex64], x: f64) -> Vec<f64> {
    s1.iter()
        .zip(s2)
        .map(|(a, b)| 0.5 * (a.norm_sqr() + b.norm_sqr()) / (PI * x * x))
        .collect()
}

/// Unpolarised `dσ/dΩ/(πa²)` of ray fields.
fn ray_intensity(f: &[OrderField], a_um: f64) -> Vec<f64> {
    f.iter()
        .map(|f| 0.5 * (f.perp.norm_sqr() + f.par.norm_sqr()) / (PI * a_um * a_um))
        .collect()
}

fn sum_fields(
    fields: &[Vec<OrderField>],
    orders: std::ops::RangeInclusive<usize>,
) -> Vec<OrderField> {
    let n = fields[0].len();
    (0..n)
        .map(|j| {
            let mut s = OrderField::default();
            for p in orders.clone() {
                s.perp += fields[p][j].perp;
                s.par += fields[p][j].par;
            }
            s
        })
        .collect()
}

/// Ray fields per order on the angles `ang` (deg) of a drop of radius `a` (µm):
/// unfiltered geometric optics, the Airy-uniform caustic channel, and that channel with plane
/// Fresnel coefficients.
fn ray_fields(a: f64, ang: &[f64]) -> [Vec<Vec<OrderField>>; 3] {
    let go = SphereGo::new(a, LAMBDA_NM, N, MAX_P);
    let plane = go.clone().with_surface_coefficients(false);
    let per_order = |f: &dyn Fn(usize, f64) -> OrderField| -> Vec<Vec<OrderField>> {
        (0..=MAX_P)
            .map(|p| ang.iter().map(|t| f(p, t.to_radians())).collect())
            .collect()
    };
    [
        per_order(&|p, t| go.order_field(p, t)),
        per_order(&|p, t| go.order_field_uniform(p, t)),
        per_order(&|p, t| plane.order_field_uniform(p, t)),
    ]
}

/// Debye amplitudes (S1, S2) of one term on the band's angles.
type Amplitudes = (Vec<Complex64>, Vec<Complex64>);

/// The coherent sum of the Debye terms `deb`.
fn coherent_sum(deb: &[Amplitudes]) -> Amplitudes {
    let n = deb[0].0.len();
    let mut s1 = vec![Complex64::new(0.0, 0.0); n];
    let mut s2 = s1.clone();
    for (a, b) in deb {
        for j in 0..n {
            s1[j] += a[j];
            s2[j] += b[j];
        }
    }
    (s1, s2)
}

/// 1° windows of the two caustic tails (where in the band the deficit sits): Airy channel over
/// the Debye term.
fn print_caustic_windows(
    ang: &[f64],
    deb: &[Amplitudes],
    airy_f: &[Vec<OrderField>],
    x: f64,
    a: f64,
) {
    for p in [2usize, 3] {
        let w: Vec<String> = (0..5)
            .map(|k| {
                let (lo, hi) = (BAND.0 + k as f64, BAND.0 + k as f64 + 1.0);
                let sel = |v: &[f64]| -> f64 {
                    let s: Vec<f64> = ang
                        .iter()
                        .zip(v)
                        .filter(|(t, _)| **t >= lo && **t <= hi)
                        .map(|(_, v)| *v)
                        .collect();
                    mean(&s)
                };
                let dv = sel(&debye_intensity(&deb[p].0, &deb[p].1, x));
                let av = sel(&ray_intensity(&airy_f[p], a));
                format!("{av:.2}/{dv:.2e}", av = av / dv)
            })
            .collect();
        println!(
            "  p{p} Airy/Debye in 1° windows from 131°: {}",
            w.join("  ")
        );
    }
}

fn main() -> anyhow::Result<()> {
    let step = 0.005;
    let nang = ((BAND.1 - BAND.0) / step).round() as usize + 1;
    let ang: Vec<f64> = (0..nang).map(|i| BAND.0 + step * i as f64).collect();
    let mut csv = String::from(
        "# Alexander's dark band (131-136 deg) order by order, n = 1.331, 650 nm: mean dsigma/dOmega/(pi a^2) (1/sr)\n\
         # term: p0..p6 single orders; p0_diffraction, p0_reflection (Debye split of p = 0); coherent_0_3/_0_6, incoherent_0_3/_0_6; mie\n\
         # ray_go = unfiltered geometric optics, ray_airy = Airy-uniform caustic channel (order_field_uniform), both with the curved-surface coefficients; ray_airy_plane = Airy channel with plane Fresnel coefficients\n\
         radius_um,term,debye,ray_go,ray_airy,ray_airy_plane\n",
    );
    for a_mm in [0.1, 0.2, 0.4, 1.0] {
        let a = a_mm * 1e3;
        let x = scatterbake::mie::size_parameter(a, LAMBDA_NM);
        let d = DebyeCoefficients::new(x, Complex64::new(N, 0.0))?;
        let amp = |set: &OrderSet| d.amplitudes_deg(set, &ang);
        // Debye amplitudes per order
        let deb: Vec<Amplitudes> = (0..=MAX_P)
            .map(|p| amp(&OrderSet::Orders(vec![p])))
            .collect();
        let mie = amp(&OrderSet::From(0));
        let rest = amp(&OrderSet::From(MAX_P + 1));
        let (da, db) = d.diffraction();
        let diff = d.term_sphere(da, db).amplitudes_deg(&ang);
        let (ra, rb) = d.external_reflection();
        let refl = d.term_sphere(ra, rb).amplitudes_deg(&ang);
        let [go_f, airy_f, plane_f] = ray_fields(a, &ang);

        let mie_b = mean(&debye_intensity(&mie.0, &mie.1, x));
        println!(
            "a = {a_mm} mm (x = {x:.1}): Mie band ⟨dσ/dΩ⟩/(πa²) = {mie_b:.4e} sr⁻¹ \
             (p ≥ {} alone {:.2e})",
            MAX_P + 1,
            mean(&debye_intensity(&rest.0, &rest.1, x))
        );
        println!(
            "  {:<18} {:>11} {:>11} {:>11} {:>9} {:>9} {:>10} {:>9}",
            "term", "Debye", "ray GO", "ray Airy", "GO/Deb", "Airy/Deb", "plane/Deb", "Deb/Mie"
        );
        let mut row = |name: &str, dv: f64, gv: f64, av: f64, pv: f64| {
            println!(
                "  {:<18} {:>11.4e} {:>11.4e} {:>11.4e} {:>9.3} {:>9.3} {:>10.3} {:>9.3}",
                name,
                dv,
                gv,
                av,
                gv / dv,
                av / dv,
                pv / dv,
                dv / mie_b
            );
            let _ = writeln!(csv, "{a},{name},{dv:.6e},{gv:.6e},{av:.6e},{pv:.6e}");
        };
        for p in 0..=MAX_P {
            let dv = mean(&debye_intensity(&deb[p].0, &deb[p].1, x));
            let gv = mean(&ray_intensity(&go_f[p], a));
            let av = mean(&ray_intensity(&airy_f[p], a));
            let pv = mean(&ray_intensity(&plane_f[p], a));
            row(&format!("p{p}"), dv, gv, av, pv);
        }
        let dd = mean(&debye_intensity(&diff.0, &diff.1, x));
        let dr = mean(&debye_intensity(&refl.0, &refl.1, x));
        let g0 = mean(&ray_intensity(&go_f[0], a));
        row("p0_diffraction", dd, 0.0, 0.0, 0.0);
        row("p0_reflection", dr, g0, g0, g0);
        for hi in [3usize, MAX_P] {
            let (s1, s2) = coherent_sum(&deb[..=hi]);
            let dc = mean(&debye_intensity(&s1, &s2, x));
            let di: f64 = (0..=hi)
                .map(|p| mean(&debye_intensity(&deb[p].0, &deb[p].1, x)))
                .sum();
            let gc = mean(&ray_intensity(&sum_fields(&go_f, 0..=hi), a));
            let gi: f64 = (0..=hi).map(|p| mean(&ray_intensity(&go_f[p], a))).sum();
            let ac = mean(&ray_intensity(&sum_fields(&airy_f, 0..=hi), a));
            let ai: f64 = (0..=hi).map(|p| mean(&ray_intensity(&airy_f[p], a))).sum();
            let pc = mean(&ray_intensity(&sum_fields(&plane_f, 0..=hi), a));
            let pi: f64 = (0..=hi).map(|p| mean(&ray_intensity(&plane_f[p], a))).sum();
            row(&format!("coherent_0_{hi}"), dc, gc, ac, pc);
            row(&format!("incoherent_0_{hi}"), di, gi, ai, pi);
            row(
                &format!("interference_0_{hi}"),
                dc - di,
                gc - gi,
                ac - ai,
                pc - pi,
            );
        }
        row("mie", mie_b, f64::NAN, f64::NAN, f64::NAN);
        print_caustic_windows(&ang, &deb, &airy_f, x, a);
    }
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/data/raytrace");
    std::fs::create_dir_all(dir)?;
    let path = format!("{dir}/alexander_band_orders.csv");
    std::fs::write(&path, csv)?;
    println!("wrote {path}");
    Ok(())
}
