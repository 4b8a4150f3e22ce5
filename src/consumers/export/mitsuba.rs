//! Mitsuba 3 `tabphase` export.
//!
//! What Mitsuba 3 expects (plugin `tabphase`, `src/phase/tabphase.cpp` and its documentation):
//! - one parameter `values`, a string of comma- (or space-) separated numbers: the phase
//!   function at N points **regularly spaced in μ = cos θ from −1 to +1** (first value at
//!   μ = −1 = backscattering, last at μ = +1 = forward), in the *physics* convention
//!   (θ = 0 forward), which is ours;
//! - Mitsuba builds a piecewise-linear distribution in μ and **normalises it itself**:
//!   p_mitsuba(μ) = v(μ) / (2π ∫_{-1}^{1} v dμ), so absolute units do not matter; we write the
//!   table's p in 1/sr anyway, so the list is also meaningful on its own;
//! - the phase function is a scalar: the same for every colour channel or wavelength of a
//!   render. A spectral scene therefore needs one `tabphase` per wavelength band (one medium or
//!   one render per band), an RGB scene one per channel, or the luminance-weighted list as a
//!   monochrome approximation (which loses the rainbow's colours). See `docs/consumers.md`.
//!
//! Our mapping: value_k = cell average of p over [μ_k − h/2, μ_k + h/2] (h = 2/(N − 1),
//! μ_k = −1 + 2k/(N − 1), half cells at ±1), with p the table's lookup formula (linear in θ
//! between stored angles), see [`tabphase_values`]. Point sampling would be wrong for drops:
//! near θ = 0 a μ cell spans Δθ ≈ √(2h) (1.8° for N = 4096) while the diffraction peak of a
//! 0.5 mm drop is ~0.05° wide, so a point sample at μ = 1 times the cell width over-counts the
//! peak's power by orders of magnitude and Mitsuba's renormalisation then darkens the rainbow
//! angles by the same factor (measured: ×1427 for a 0.5 mm Mie table). With cell averages the
//! list's trapezoid integral equals the table's own normalisation. The export reports
//! `normalisation_ratio = 2π ∫ v dμ` (trapezoid in μ, what Mitsuba integrates) and the largest
//! relative difference between Mitsuba's normalised function and the table at the table's own
//! angles in 90°–180° (where rainbows live; it includes the smoothing of supernumeraries by the
//! μ cells, Δθ = h / sin θ ≈ 0.04° at 138° for N = 4096).
//!
//! RGB integration: the linear-sRGB channel c of a spectrum is Σ_k w_ck v_k with
//! w_ck = (M_XYZ→sRGB · W_k)_c and W_k the CIE 1931 XYZ weights of wavelength sample k under D65
//! ([`SpectralWeights`]); since a flat spectrum of 1 gives sRGB (1, 1, 1), p_c(θ) = Σ_k w_ck p_k(θ)
//! is again normalised to 1. Colour-matching lobes make some w_ck negative, so p_c can dip
//! below 0 where the spectrum is very uneven; such values are clamped to 0 and reported, the
//! policy of every export ([`NegativeClamp`]).

use crate::consumers::ConsumerError;
use crate::consumers::export::NegativeClamp;
use crate::consumers::read::phase::PhaseCurves;
use crate::optics::colour::{Illuminant1931, SpectralWeights, xyz_to_linear_srgb};
use std::f64::consts::PI;
use std::fmt::Write as _;

/// The μ grid of a tabphase list of `n` values (ascending from −1 to +1).
pub fn mu_grid(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| -1.0 + 2.0 * k as f64 / (n - 1) as f64)
        .collect()
}

/// ∫_0^θ p(θ') sin θ' dθ' for the piecewise-linear-in-θ function given at `angles_deg`
/// (degrees in, radians in the integral), exact up to 4-point Gauss–Legendre per partial
/// segment (the integrand is a linear function times sin θ on cells of a fraction of a degree).
struct Cumulative<'a> {
    angles_deg: &'a [f64],
    phase: &'a [f64],
    at_nodes: Vec<f64>,
}

impl<'a> Cumulative<'a> {
    fn new(angles_deg: &'a [f64], phase: &'a [f64]) -> Self {
        let mut at_nodes = vec![0.0; angles_deg.len()];
        for j in 1..angles_deg.len() {
            at_nodes[j] = at_nodes[j - 1] + Self::segment(angles_deg, phase, j - 1, angles_deg[j]);
        }
        Cumulative {
            angles_deg,
            phase,
            at_nodes,
        }
    }

    /// ∫ from angles_deg[j] to `to_deg` (within segment j) of p sin θ dθ.
    fn segment(a: &[f64], p: &[f64], j: usize, to_deg: f64) -> f64 {
        const X: [f64; 4] = [
            -0.861_136_311_594_052_6,
            -0.339_981_043_584_856_3,
            0.339_981_043_584_856_3,
            0.861_136_311_594_052_6,
        ];
        const W: [f64; 4] = [
            0.347_854_845_137_453_9,
            0.652_145_154_862_546_1,
            0.652_145_154_862_546_1,
            0.347_854_845_137_453_9,
        ];
        let (t0, t1) = (a[j], to_deg);
        if t1 <= t0 {
            return 0.0;
        }
        let h = a[j + 1] - a[j];
        let mut acc = 0.0;
        for (x, w) in X.iter().zip(&W) {
            let t = t0 + 0.5 * (x + 1.0) * (t1 - t0);
            let f = (t - a[j]) / h;
            acc += w * (p[j] * (1.0 - f) + p[j + 1] * f) * t.to_radians().sin();
        }
        acc * 0.5 * (t1 - t0).to_radians()
    }

    fn at(&self, theta_deg: f64) -> f64 {
        let a = self.angles_deg;
        let t = theta_deg.clamp(a[0], a[a.len() - 1]);
        let j = a
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(a.len() - 2);
        self.at_nodes[j] + Self::segment(a, self.phase, j, t)
    }
}

/// Resample a phase function (given on `angles_deg`, linear in θ between samples) onto the
/// tabphase μ grid by cell averages: value_k = (1/|C_k|) ∫_{C_k} p dμ over the cell
/// C_k = [μ_k − h/2, μ_k + h/2] ∩ [−1, 1]. The trapezoid rule Mitsuba applies to the list then
/// integrates to exactly the table's own 2π ∫ p dμ, so narrow features (the forward diffraction
/// peak, much narrower than a μ cell near θ = 0) keep their power instead of being point-sampled
/// at their maximum.
pub fn tabphase_values(angles_deg: &[f64], phase: &[f64], n: usize) -> Vec<f64> {
    let c = Cumulative::new(angles_deg, phase);
    let h = 2.0 / (n - 1) as f64;
    // ∫_{μ_lo}^{μ_hi} p dμ = C(θ(μ_lo)) − C(θ(μ_hi)).
    let integral = |lo: f64, hi: f64| {
        c.at(lo.clamp(-1.0, 1.0).acos().to_degrees())
            - c.at(hi.clamp(-1.0, 1.0).acos().to_degrees())
    };
    mu_grid(n)
        .into_iter()
        .map(|mu| {
            let (lo, hi) = ((mu - 0.5 * h).max(-1.0), (mu + 0.5 * h).min(1.0));
            integral(lo, hi) / (hi - lo)
        })
        .collect()
}

/// Point samples of the phase function on the tabphase μ grid (no cell averaging; for
/// comparison and for smooth phase functions).
pub fn tabphase_point_values(angles_deg: &[f64], phase: &[f64], n: usize) -> Vec<f64> {
    mu_grid(n)
        .into_iter()
        .map(|mu| {
            crate::table::interp::interp1(
                angles_deg,
                phase,
                mu.clamp(-1.0, 1.0).acos().to_degrees(),
            )
        })
        .collect()
}

/// Mitsuba's evaluation of a `values` list at `mu` (emulating the documented convention:
/// piecewise-linear in μ on the uniform grid, normalised to unit integral, divided by 2π).
pub fn mitsuba_eval(values: &[f64], mu: f64) -> f64 {
    let n = values.len();
    let h = 2.0 / (n - 1) as f64;
    let integral: f64 = values.windows(2).map(|w| 0.5 * (w[0] + w[1]) * h).sum();
    let v = crate::table::interp::interp1_uniform(values, -1.0, h, mu);
    v / integral / (2.0 * PI)
}

/// Quality figures of one exported list.
#[derive(Debug, Clone, Copy)]
pub struct TabphaseQuality {
    /// 2π ∫ v dμ (trapezoid in μ); 1 for a perfectly resolved normalised table.
    pub normalisation_ratio: f64,
    /// max |p_mitsuba − p| / p over the table's angles in [90°, 180°] (large where a μ cell
    /// averages over Mie ripple finer than the cell).
    pub max_rel_error_back: f64,
    /// ∫ |p_mitsuba − p| dΩ / ∫ p dΩ over 90°–180° (trapezoid on the table's angles): the
    /// fraction of back-hemisphere power that is misplaced.
    pub l1_rel_error_back: f64,
}

/// Quality of `values` against the original curve.
pub fn quality(values: &[f64], angles_deg: &[f64], phase: &[f64]) -> TabphaseQuality {
    let h = 2.0 / (values.len() - 1) as f64;
    let normalisation_ratio = 2.0
        * PI
        * values
            .windows(2)
            .map(|w| 0.5 * (w[0] + w[1]) * h)
            .sum::<f64>();
    let mut max_rel_error_back: f64 = 0.0;
    let (mut diff, mut total) = (0.0, 0.0);
    let mut prev: Option<(f64, f64, f64)> = None; // (θ rad, |Δ| sinθ, p sinθ)
    for (&t, &p) in angles_deg.iter().zip(phase) {
        if t >= 90.0 {
            let m = mitsuba_eval(values, t.to_radians().cos());
            if p > 0.0 {
                max_rel_error_back = max_rel_error_back.max((m - p).abs() / p);
            }
            let (th, s) = (t.to_radians(), t.to_radians().sin());
            let cur = (th, (m - p).abs() * s, p * s);
            if let Some(q) = prev {
                diff += 0.5 * (q.1 + cur.1) * (th - q.0);
                total += 0.5 * (q.2 + cur.2) * (th - q.0);
            }
            prev = Some(cur);
        }
    }
    TabphaseQuality {
        normalisation_ratio,
        max_rel_error_back,
        l1_rel_error_back: if total > 0.0 { diff / total } else { 0.0 },
    }
}

/// What to export.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MitsubaMode {
    /// Three lists, one per linear-sRGB channel (D65 sun, CIE 1931 2°).
    Rgb,
    /// One list per table wavelength.
    Spectral,
    /// One list at the table wavelength nearest to `--wavelength-nm`.
    Wavelength,
    /// One list weighted by CIE Ȳ under D65 (a monochrome approximation).
    Luminance,
}

impl MitsubaMode {
    /// Every mode, by the name a user writes.
    pub const NAMES: [&'static str; 4] = ["rgb", "spectral", "wavelength", "luminance"];
}

impl std::str::FromStr for MitsubaMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rgb" => Ok(Self::Rgb),
            "spectral" => Ok(Self::Spectral),
            "wavelength" => Ok(Self::Wavelength),
            "luminance" => Ok(Self::Luminance),
            _ => Err(format!(
                "unknown Mitsuba mode `{s}` (one of {:?})",
                Self::NAMES
            )),
        }
    }
}

/// One named list.
#[derive(Debug, Clone)]
pub struct NamedList {
    pub id: String,
    pub label: String,
    pub values: Vec<f64>,
    pub quality: TabphaseQuality,
    /// Negative values written as 0 (see [`NegativeClamp`]).
    pub negatives: NegativeClamp,
}

/// Weighted sum of the per-wavelength curves (on the table angle grid).
fn weighted_curve(c: &PhaseCurves, w: &[f64]) -> Vec<f64> {
    (0..c.angles_deg.len())
        .map(|j| c.phase.iter().zip(w).map(|(p, wk)| wk * p[j]).sum())
        .collect()
}

/// Build the lists for a mode.
pub fn build_lists(
    c: &PhaseCurves,
    mode: MitsubaMode,
    wavelength_nm: Option<f64>,
    n: usize,
) -> Result<Vec<NamedList>, ConsumerError> {
    let mk = |id: String, label: String, curve: Vec<f64>| {
        let mut values = tabphase_values(&c.angles_deg, &curve, n);
        let negatives = NegativeClamp::apply(values.iter_mut());
        let quality = quality(&values, &c.angles_deg, &curve);
        NamedList {
            id,
            label,
            values,
            quality,
            negatives,
        }
    };
    let sw = SpectralWeights::new(&c.wavelengths_nm, Illuminant1931::D65);
    Ok(match mode {
        MitsubaMode::Spectral => c
            .wavelengths_nm
            .iter()
            .enumerate()
            .map(|(k, wl)| {
                mk(
                    format!("sbt_{wl}nm"),
                    format!("wavelength {wl} nm"),
                    c.phase[k].clone(),
                )
            })
            .collect(),
        MitsubaMode::Wavelength => {
            let wl = wavelength_nm
                .ok_or_else(|| ConsumerError::invalid("--mode wavelength needs --wavelength-nm"))?;
            let k = c.nearest_wavelength(wl);
            let w = c.wavelengths_nm[k];
            vec![mk(
                format!("sbt_{w}nm"),
                format!("wavelength {w} nm (nearest to {wl} nm)"),
                c.phase[k].clone(),
            )]
        }
        MitsubaMode::Luminance => {
            let w: Vec<f64> = sw.weights.iter().map(|x| x[1]).collect();
            vec![mk(
                "sbt_luminance".into(),
                "CIE Y weighted under D65".into(),
                weighted_curve(c, &w),
            )]
        }
        MitsubaMode::Rgb => {
            let rgb_w: Vec<[f64; 3]> = sw.weights.iter().map(|x| xyz_to_linear_srgb(*x)).collect();
            ["r", "g", "b"]
                .iter()
                .enumerate()
                .map(|(ci, name)| {
                    let w: Vec<f64> = rgb_w.iter().map(|x| x[ci]).collect();
                    mk(
                        format!("sbt_{name}"),
                        format!("linear sRGB channel {name} (D65 sun)"),
                        weighted_curve(c, &w),
                    )
                })
                .collect()
        }
    })
}

/// Format a list as Mitsuba expects (comma-separated, shortest round-trip decimal).
pub fn values_string(values: &[f64]) -> String {
    let mut s = String::with_capacity(values.len() * 12);
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        let _ = write!(s, "{:e}", *v as f32);
    }
    s
}

/// The XML snippet for a set of lists.
pub fn xml_snippet(lists: &[NamedList], source: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "<!-- scatterbake tabphase export: {source} -->");
    let _ = writeln!(
        s,
        "<!-- values: p(mu) at mu = -1 .. +1 uniformly (first = backscatter), physics convention; Mitsuba renormalises. -->"
    );
    for l in lists {
        let _ = writeln!(
            s,
            "<!-- {}: {} values, 2pi*int v dmu = {:.6}, 90-180 deg: max rel. error {:.3e}, relative L1 error {:.3e}; {} -->",
            l.label,
            l.values.len(),
            l.quality.normalisation_ratio,
            l.quality.max_rel_error_back,
            l.quality.l1_rel_error_back,
            l.negatives.describe()
        );
        let _ = writeln!(s, "<phase type=\"tabphase\" id=\"{}\">", l.id);
        let _ = writeln!(
            s,
            "    <string name=\"values\" value=\"{}\"/>",
            values_string(&l.values)
        );
        let _ = writeln!(s, "</phase>");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consumers::read::phase::PhaseTable;
    use crate::fixtures::henyey_greenstein_table;
    use crate::optics::henyey_greenstein::hg_density_sr;

    #[test]
    fn grid_order_and_values_follow_mitsuba_convention() {
        let t = henyey_greenstein_table(&[550.0], &[1.0], |_, _| 0.6, 3601, 0.0);
        let c = PhaseTable::new(t).unwrap().curves(&[]).unwrap();
        let v = tabphase_values(&c.angles_deg, &c.phase[0], 1001);
        // First value backward (μ = −1), last forward (μ = +1); half-cell averages at the ends
        // differ from the point values by ≈ (h/4)·p'/p (≈ 0.5 % forward for g = 0.6).
        assert!((v[0] - hg_density_sr(-1.0, 0.6)).abs() < 1e-2 * v[0]);
        assert!((v[1000] - hg_density_sr(1.0, 0.6)).abs() < 1e-2 * v[1000]);
        for k in (50..1000).step_by(50) {
            let mu = -1.0 + 2.0 * k as f64 / 1000.0;
            let exact = hg_density_sr(mu, 0.6);
            assert!(
                (v[k] - exact).abs() < 1e-3 * exact,
                "k={k}: {} vs {exact}",
                v[k]
            );
        }
        // Mitsuba's normalised evaluation reproduces the analytic function (HG is smooth in μ).
        let q = quality(&v, &c.angles_deg, &c.phase[0]);
        assert!((q.normalisation_ratio - 1.0).abs() < 1e-4, "{q:?}");
        assert!(q.max_rel_error_back < 1e-3, "{q:?}");
        assert!(
            q.l1_rel_error_back < q.max_rel_error_back && q.l1_rel_error_back > 0.0,
            "{q:?}"
        );
        for &mu in &[-0.9, -0.3, 0.2, 0.8] {
            let m = mitsuba_eval(&v, mu);
            assert!((m - hg_density_sr(mu, 0.6)).abs() < 1e-3 * m);
        }
    }

    #[test]
    fn cell_averages_keep_the_power_of_a_narrow_forward_peak() {
        // 99 % of the power in a 0.03° wide forward peak (like a large drop's diffraction
        // lobe), 1 % spread isotropically.
        let t = crate::fixtures::peak_table(&[550.0], |_| 0.0, 0.03, 1e-7, 36001);
        let c = PhaseTable::new(t).unwrap().curves(&[]).unwrap();
        let avg = tabphase_values(&c.angles_deg, &c.phase[0], 4096);
        let pts = tabphase_point_values(&c.angles_deg, &c.phase[0], 4096);
        let q_avg = quality(&avg, &c.angles_deg, &c.phase[0]);
        let q_pts = quality(&pts, &c.angles_deg, &c.phase[0]);
        // The cell averages keep the table's own integral (χ_0 of the piecewise-linear
        // function, computed independently by Gauss–Legendre in legendre.rs; ≈ 1.003 here as
        // peak_table normalises with the trapezoid rule); point samples over-count the peak by
        // orders of magnitude.
        let chi0 = crate::consumers::export::legendre::moments(&c.angles_deg, &c.phase[0], 0)[0];
        assert!(
            (q_avg.normalisation_ratio / chi0 - 1.0).abs() < 1e-6,
            "{q_avg:?} vs {chi0}"
        );
        assert!(q_pts.normalisation_ratio > 10.0, "{q_pts:?}");
        // Back hemisphere: only the renormalisation by χ_0 remains.
        assert!(
            q_avg.max_rel_error_back < (chi0 - 1.0).abs() + 1e-4,
            "{q_avg:?}"
        );
    }

    #[test]
    fn rgb_lists_of_wavelength_independent_table_equal_the_table() {
        // A grey (wavelength-independent) phase function must give three identical lists equal
        // to the per-wavelength one, since each sRGB channel of a flat D65 spectrum is 1.
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let t = henyey_greenstein_table(&wl, &[1.0], |_, _| 0.3, 721, 0.0);
        let c = PhaseTable::new(t).unwrap().curves(&[]).unwrap();
        let lists = build_lists(&c, MitsubaMode::Rgb, None, 257).unwrap();
        let single = build_lists(&c, MitsubaMode::Wavelength, Some(550.0), 257).unwrap();
        for l in &lists {
            for (a, b) in l.values.iter().zip(&single[0].values) {
                assert!((a - b).abs() < 5e-3 * b, "{}: {a} vs {b}", l.id);
            }
        }
        // And the snippet parses back to the same numbers.
        let xml = xml_snippet(&lists, "test");
        assert_eq!(xml.matches("<phase type=\"tabphase\"").count(), 3);
        let first = xml
            .split("value=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        let parsed: Vec<f64> = first
            .split(',')
            .map(|s| s.trim().parse().unwrap())
            .collect();
        assert_eq!(parsed.len(), 257);
        assert!((parsed[0] - lists[0].values[0]).abs() < 1e-6 * parsed[0]);
    }

    #[test]
    fn rgb_lists_separate_colours_of_a_dispersive_table() {
        // Peak at 138° for red light, 140° for blue: the red channel must peak at the smaller
        // angle.
        let wl: Vec<f64> = (0..33).map(|i| 380.0 + 10.0 * i as f64).collect();
        let t = crate::fixtures::peak_table(
            &wl,
            |l| 140.0 - 2.0 * (l - 450.0) / 200.0,
            0.3,
            1e-3,
            3601,
        );
        let c = PhaseTable::new(t).unwrap().curves(&[]).unwrap();
        let lists = build_lists(&c, MitsubaMode::Rgb, None, 20001).unwrap();
        let argmax = |v: &[f64]| {
            let k = v
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .unwrap()
                .0;
            (-1.0 + 2.0 * k as f64 / 20000.0_f64).acos().to_degrees()
        };
        let (r, b) = (argmax(&lists[0].values), argmax(&lists[2].values));
        assert!(r < b - 0.8, "red peak {r}, blue peak {b}");
        assert!(
            (r - 138.3).abs() < 0.6 && (b - 139.7).abs() < 0.6,
            "red {r} blue {b}"
        );
    }
}
