//! Drop-size distributions and their radius quadrature.
//!
//! Every distribution is a number density `n(r)` (per unit radius, arbitrary scale) on a
//! finite support `[r_lo, r_hi]`; [`SizeDistribution::quadrature`] returns radii and weights
//! `w_k ≈ n(r_k) dr` from a Gauss–Legendre rule in `ln r`. The ensemble phase function mixes
//! the normalised single-sphere phase functions with weights `w_k · C_sca(r_k)` (number density
//! × scattering cross-section; decision MIE-2 in `docs/decisions.md`).

use serde::{Deserialize, Serialize};

/// A drop-size distribution (manifest form: a table with `kind = "..."`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum SizeDistribution {
    /// All drops of one radius.
    Monodisperse { radius_um: f64 },
    /// `n(r) ∝ (1/r) exp(−ln²(r/r_g)/(2 ln² σ_g))`, support `r_g σ_g^{±6}`.
    Lognormal {
        median_radius_um: f64,
        geometric_sigma: f64,
    },
    /// Hansen & Travis (1974) gamma: `n(r) ∝ r^{(1−3v)/v} exp(−r/(a v))` with effective radius
    /// `a` and effective variance `0 < v < 0.5`; support from mean − 5 to mean + 10 standard deviations
    /// (clipped at 0.1 % of the mean).
    Gamma {
        effective_radius_um: f64,
        effective_variance: f64,
    },
    /// Marshall & Palmer (1948) rain: `n(D) = N_0 exp(−Λ D)`, `Λ = 4.1 R^{−0.21} mm⁻¹` for rain
    /// rate `R` in mm/h, truncated to `[min_radius_um, max_radius_um]` (defaults 50 µm and
    /// 3000 µm; drops above ~0.5 mm are not spherical in nature, this is the Mie idealisation).
    MarshallPalmer {
        rain_rate_mm_h: f64,
        #[serde(default = "default_mp_min")]
        min_radius_um: f64,
        #[serde(default = "default_mp_max")]
        max_radius_um: f64,
    },
}

fn default_mp_min() -> f64 {
    50.0
}
fn default_mp_max() -> f64 {
    3000.0
}

impl SizeDistribution {
    /// Checks the parameters; returns a message on error.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |v: f64, name: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        match *self {
            SizeDistribution::Monodisperse { radius_um } => positive(radius_um, "radius_um"),
            SizeDistribution::Lognormal {
                median_radius_um,
                geometric_sigma,
            } => {
                positive(median_radius_um, "median_radius_um")?;
                if !(geometric_sigma > 1.0 && geometric_sigma < 5.0) {
                    return Err(format!(
                        "geometric_sigma must be in (1, 5), got {geometric_sigma}"
                    ));
                }
                Ok(())
            }
            SizeDistribution::Gamma {
                effective_radius_um,
                effective_variance,
            } => {
                positive(effective_radius_um, "effective_radius_um")?;
                if !(effective_variance > 0.0 && effective_variance < 0.5) {
                    return Err(format!(
                        "effective_variance must be in (0, 0.5), got {effective_variance}"
                    ));
                }
                Ok(())
            }
            SizeDistribution::MarshallPalmer {
                rain_rate_mm_h,
                min_radius_um,
                max_radius_um,
            } => {
                positive(rain_rate_mm_h, "rain_rate_mm_h")?;
                positive(min_radius_um, "min_radius_um")?;
                if max_radius_um.is_nan() || max_radius_um <= min_radius_um {
                    return Err("max_radius_um must exceed min_radius_um".into());
                }
                Ok(())
            }
        }
    }

    /// A short name with the parameters, for the labels of a `distribution` axis, e.g.
    /// `marshall-palmer R=5 mm/h r=50-3000 um`.
    pub fn label(&self) -> String {
        match *self {
            SizeDistribution::Monodisperse { radius_um } => {
                format!("monodisperse r={radius_um} um")
            }
            SizeDistribution::Lognormal {
                median_radius_um,
                geometric_sigma,
            } => format!("lognormal r_g={median_radius_um} um sigma_g={geometric_sigma}"),
            SizeDistribution::Gamma {
                effective_radius_um,
                effective_variance,
            } => format!("gamma r_eff={effective_radius_um} um v_eff={effective_variance}"),
            SizeDistribution::MarshallPalmer {
                rain_rate_mm_h,
                min_radius_um,
                max_radius_um,
            } => format!(
                "marshall-palmer R={rain_rate_mm_h} mm/h r={min_radius_um}-{max_radius_um} um"
            ),
        }
    }

    /// Support `[r_lo, r_hi]` in µm.
    pub fn support_um(&self) -> (f64, f64) {
        match *self {
            SizeDistribution::Monodisperse { radius_um } => (radius_um, radius_um),
            SizeDistribution::Lognormal {
                median_radius_um,
                geometric_sigma,
            } => (
                median_radius_um / geometric_sigma.powi(6),
                median_radius_um * geometric_sigma.powi(6),
            ),
            SizeDistribution::Gamma {
                effective_radius_um: a,
                effective_variance: v,
            } => {
                let mean = a * (1.0 - 2.0 * v);
                let sd = a * (v * (1.0 - 2.0 * v)).sqrt();
                ((mean - 5.0 * sd).max(1e-3 * mean), mean + 10.0 * sd)
            }
            SizeDistribution::MarshallPalmer {
                min_radius_um,
                max_radius_um,
                ..
            } => (min_radius_um, max_radius_um),
        }
    }

    /// Number density per unit radius at `r_um` (arbitrary scale).
    pub fn density(&self, r_um: f64) -> f64 {
        match *self {
            SizeDistribution::Monodisperse { .. } => 1.0,
            SizeDistribution::Lognormal {
                median_radius_um,
                geometric_sigma,
            } => {
                let s = geometric_sigma.ln();
                let l = (r_um / median_radius_um).ln();
                (-(l * l) / (2.0 * s * s)).exp() / r_um
            }
            SizeDistribution::Gamma {
                effective_radius_um: a,
                effective_variance: v,
            } => {
                // log form to avoid overflow of r^{(1−3v)/v}
                let e = (1.0 - 3.0 * v) / v;
                (e * (r_um / a).ln() - r_um / (a * v)).exp()
            }
            SizeDistribution::MarshallPalmer { rain_rate_mm_h, .. } => {
                let lambda_per_mm = 4.1 * rain_rate_mm_h.powf(-0.21);
                // D = 2r, r in mm = r_um/1000
                (-lambda_per_mm * 2.0 * r_um * 1e-3).exp()
            }
        }
    }

    /// Radii (µm) and weights `≈ n(r) dr` of a `points`-point Gauss–Legendre rule in `ln r`
    /// over the support (one node of weight 1 for a monodisperse distribution).
    pub fn quadrature(&self, points: usize) -> (Vec<f64>, Vec<f64>) {
        if let SizeDistribution::Monodisperse { radius_um } = *self {
            return (vec![radius_um], vec![1.0]);
        }
        let (lo, hi) = self.support_um();
        let (x, w) = crate::math::quadrature::gauss_legendre_interval(points, lo.ln(), hi.ln());
        let radii: Vec<f64> = x.iter().map(|l| l.exp()).collect();
        let weights = radii
            .iter()
            .zip(&w)
            .map(|(r, wl)| wl * r * self.density(*r))
            .collect();
        (radii, weights)
    }
}

/// Points of the cumulative-distribution table of [`RadiusSampler`] (uniform in `ln r`).
const CDF_POINTS: usize = 4096;

/// Inverse-CDF sampler of radii with density `q(r) ∝ n(r) r²` on the (truncated) support.
///
/// The cumulative distribution is tabulated on `CDF_POINTS` nodes uniform in `ln r`
/// (trapezoid rule) and inverted piecewise linearly, so `q` is piecewise constant in `ln r`;
/// [`RadiusSampler::sample`] weighs each radius with `n(r)/q(r)` of exactly this `q`, which keeps the
/// estimator unbiased whatever the table's resolution.
#[derive(Debug, Clone)]
pub struct RadiusSampler {
    ln_r: Vec<f64>,
    cdf: Vec<f64>,
    /// Dropped mass of `n(r) r²` (both tails, fraction of the support's).
    pub truncated_fraction: f64,
}

impl RadiusSampler {
    /// Sampler for `distribution` (not monodisperse), dropping at most `truncation` of the mass
    /// of `n(r) r²` at each end.
    pub fn new(distribution: &SizeDistribution, truncation: f64) -> Self {
        let (lo, hi) = distribution.support_um();
        let (a, b) = (lo.ln(), hi.ln());
        let h = (b - a) / (CDF_POINTS - 1) as f64;
        // density in ln r: n(r) r² · r
        let f: Vec<f64> = (0..CDF_POINTS)
            .map(|i| {
                let r = (a + h * i as f64).exp();
                distribution.density(r) * r * r * r
            })
            .collect();
        let mut cdf = vec![0.0; CDF_POINTS];
        for i in 1..CDF_POINTS {
            cdf[i] = cdf[i - 1] + 0.5 * h * (f[i - 1] + f[i]);
        }
        let total = cdf[CDF_POINTS - 1];
        // truncate: first node with cdf ≥ truncation·total, last with cdf ≤ (1 − truncation)·total
        let i0 = cdf
            .iter()
            .position(|c| *c >= truncation * total)
            .unwrap_or(0)
            .saturating_sub(1);
        let i1 = cdf
            .iter()
            .rposition(|c| *c <= (1.0 - truncation) * total)
            .map_or(CDF_POINTS - 1, |i| (i + 1).min(CDF_POINTS - 1));
        let kept = cdf[i1] - cdf[i0];
        let ln_r: Vec<f64> = (i0..=i1).map(|i| a + h * i as f64).collect();
        let cdf: Vec<f64> = (i0..=i1).map(|i| (cdf[i] - cdf[i0]) / kept).collect();
        RadiusSampler {
            ln_r,
            cdf,
            truncated_fraction: 1.0 - kept / total,
        }
    }

    /// Radius (µm) at cumulative probability `u ∈ [0, 1)` and its importance weight
    /// `n(r)·r/q_ln(ln r)` (`q_ln` the sampling density in `ln r`), i.e. `n(r) dr` per unit
    /// probability: `Σ weight · g(r)/N` estimates `∫ n(r) g(r) dr` over the kept support.
    pub fn sample(&self, distribution: &SizeDistribution, u: f64) -> (f64, f64) {
        let k = self
            .cdf
            .partition_point(|c| *c <= u)
            .clamp(1, self.cdf.len() - 1);
        let (c0, c1) = (self.cdf[k - 1], self.cdf[k]);
        let (l0, l1) = (self.ln_r[k - 1], self.ln_r[k]);
        // q_ln constant on the segment; empty segments are never selected (c1 > u ≥ c0)
        let q_ln = (c1 - c0) / (l1 - l0);
        let t = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let r = (l0 + t * (l1 - l0)).exp();
        (r, distribution.density(r) * r / q_ln)
    }

    /// Kept support `[r_lo, r_hi]` (µm).
    pub fn support_um(&self) -> (f64, f64) {
        (self.ln_r[0].exp(), self.ln_r[self.ln_r.len() - 1].exp())
    }
}

/// The ensemble of a size distribution at point angles (unfiltered): the normalised phase
/// function and its polarised components on an arbitrary angle grid, with the averaged
/// efficiencies. The weights are those of the `mie` stage (decision MIE-2): single-sphere
/// phase functions mixed with `n(r) dr · C_sca(r)`; Q values are `⟨C⟩/⟨π r²⟩`, g is weighted by
/// `C_sca`. Point values are not bin averages: at large size parameters each radius node
/// contributes its own fine ripple, which the table's cell averages remove.
#[derive(Debug, Clone, PartialEq)]
pub struct EnsemblePhase {
    /// Scattering angles (deg).
    pub angles_deg: Vec<f64>,
    /// `⟨|S_1|²⟩ / ⟨π x² Q_sca⟩` (1/sr).
    pub i_perp: Vec<f64>,
    /// `⟨|S_2|²⟩ / ⟨π x² Q_sca⟩` (1/sr).
    pub i_par: Vec<f64>,
    /// `(i_perp + i_par)/2` (1/sr), `∫_{4π} phase dΩ = 1`.
    pub phase: Vec<f64>,
    /// `⟨C_ext⟩/⟨π r²⟩`.
    pub q_ext: f64,
    /// `⟨C_sca⟩/⟨π r²⟩`.
    pub q_sca: f64,
    /// `⟨C_back⟩/⟨π r²⟩` (radar convention, as [`super::Efficiencies::q_back`]).
    pub q_back: f64,
    /// `⟨C_sca g⟩/⟨C_sca⟩`.
    pub g: f64,
    /// Quadrature radii (µm).
    pub radii_um: Vec<f64>,
    /// Quadrature weights `≈ n(r) dr` (arbitrary scale).
    pub weights: Vec<f64>,
}

/// Errors of [`ensemble_at_angles`].
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum EnsembleError {
    #[error("size distribution: {0}")]
    Distribution(String),
    #[error("radius {radius_um} um: {source}")]
    Sphere {
        radius_um: f64,
        source: super::MieError,
    },
    #[error("the distribution scatters nothing (sum of n(r) dr C_sca(r) is {0})")]
    NoScattering(f64),
}

/// [`EnsemblePhase`] of `distribution` for drops of relative index `m` at the wavelength
/// `wavelength_nm` in the medium around them (see [`super::in_medium`]), from a
/// `radius_points`-point quadrature ([`SizeDistribution::quadrature`]), at `angles_deg`.
pub fn ensemble_at_angles(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: num_complex::Complex64,
    radius_points: usize,
    angles_deg: &[f64],
) -> Result<EnsemblePhase, EnsembleError> {
    distribution
        .validate()
        .map_err(EnsembleError::Distribution)?;
    if radius_points == 0 {
        return Err(EnsembleError::Distribution(
            "radius_points must be at least 1".into(),
        ));
    }
    let (radii_um, weights) = distribution.quadrature(radius_points);
    let n = angles_deg.len();
    let (mut i_perp, mut i_par) = (vec![0.0; n], vec![0.0; n]);
    // sums of w·π r² times 1, Q_ext, Q_sca, Q_back, Q_sca g
    let mut sums = [0.0; 5];
    for (&r, &w) in radii_um.iter().zip(&weights) {
        let x = super::size_parameter(r, wavelength_nm);
        let sphere = super::Sphere::new(x, m).map_err(|source| EnsembleError::Sphere {
            radius_um: r,
            source,
        })?;
        let e = sphere.efficiencies;
        let area = w * std::f64::consts::PI * r * r;
        for (s, v) in sums
            .iter_mut()
            .zip([1.0, e.q_ext, e.q_sca, e.q_back, e.q_sca * e.g])
        {
            *s += area * v;
        }
        // |S|²/(π x² Q_sca) · C_sca = |S|² r²/x²: the cross-section-weighted phase function
        let scale = area / (std::f64::consts::PI * x * x);
        let (s1, s2) = sphere.amplitudes_deg(angles_deg);
        for j in 0..n {
            i_perp[j] += scale * s1[j].norm_sqr();
            i_par[j] += scale * s2[j].norm_sqr();
        }
    }
    let c_sca = sums[2];
    if !(c_sca > 0.0) {
        return Err(EnsembleError::NoScattering(c_sca));
    }
    for v in i_perp.iter_mut().chain(i_par.iter_mut()) {
        *v /= c_sca;
    }
    let phase = i_perp
        .iter()
        .zip(&i_par)
        .map(|(a, b)| 0.5 * (a + b))
        .collect();
    Ok(EnsemblePhase {
        angles_deg: angles_deg.to_vec(),
        i_perp,
        i_par,
        phase,
        q_ext: sums[1] / sums[0],
        q_sca: c_sca / sums[0],
        q_back: sums[3] / sums[0],
        g: sums[4] / c_sca,
        radii_um,
        weights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_name_kind_and_parameters() {
        let mp = SizeDistribution::MarshallPalmer {
            rain_rate_mm_h: 5.0,
            min_radius_um: 50.0,
            max_radius_um: 3000.0,
        };
        assert_eq!(mp.label(), "marshall-palmer R=5 mm/h r=50-3000 um");
        let ln = SizeDistribution::Lognormal {
            median_radius_um: 10.0,
            geometric_sigma: 1.3,
        };
        assert_eq!(ln.label(), "lognormal r_g=10 um sigma_g=1.3");
    }

    /// The ln-r quadrature reproduces analytic moments: lognormal ⟨r²⟩/⟨1⟩ = r_g² e^{2 ln²σ},
    /// gamma ⟨r³⟩/⟨r²⟩ = a (definition of the effective radius), Marshall–Palmer ⟨1⟩ over the
    /// support in closed form.
    #[test]
    fn quadrature_matches_analytic_moments() {
        let moment = |d: &SizeDistribution, k: i32| -> f64 {
            let (r, w) = d.quadrature(64);
            r.iter().zip(&w).map(|(r, w)| w * r.powi(k)).sum()
        };
        let ln = SizeDistribution::Lognormal {
            median_radius_um: 10.0,
            geometric_sigma: 1.5,
        };
        let s = 1.5f64.ln();
        let expect = 100.0 * (2.0 * s * s).exp();
        assert!((moment(&ln, 2) / moment(&ln, 0) / expect - 1.0).abs() < 1e-6);
        let g = SizeDistribution::Gamma {
            effective_radius_um: 10.0,
            effective_variance: 0.1,
        };
        assert!((moment(&g, 3) / moment(&g, 2) / 10.0 - 1.0).abs() < 1e-5);
        let mp = SizeDistribution::MarshallPalmer {
            rain_rate_mm_h: 5.0,
            min_radius_um: 50.0,
            max_radius_um: 3000.0,
        };
        let c = 4.1 * 5f64.powf(-0.21) * 2.0 * 1e-3; // per µm
        let exact = ((-c * 50.0).exp() - (-c * 3000.0).exp()) / c;
        assert!((moment(&mp, 0) / exact - 1.0).abs() < 1e-10);
    }
    /// A monodisperse ensemble is the single sphere: Q values and the normalised phase function
    /// `(|S_1|² + |S_2|²)/(2π x² Q_sca)`; a lognormal ensemble integrates to 1 over 4π.
    #[test]
    fn ensemble_at_angles_matches_single_sphere_and_normalises() {
        let m = num_complex::Complex64::new(1.33, 0.001);
        let angles: Vec<f64> = (0..=3600).map(|j| j as f64 * 0.05).collect();
        let d = SizeDistribution::Monodisperse { radius_um: 2.0 };
        let e = ensemble_at_angles(&d, 550.0, m, 24, &angles).unwrap();
        let s = crate::mie::Sphere::new(crate::mie::size_parameter(2.0, 550.0), m).unwrap();
        assert!((e.q_ext / s.efficiencies.q_ext - 1.0).abs() < 1e-12);
        assert!((e.g / s.efficiencies.g - 1.0).abs() < 1e-12);
        let (s1, s2) = s.amplitudes_deg(&angles);
        for j in [0, 1000, 3600] {
            let p = 0.5 * (s1[j].norm_sqr() + s2[j].norm_sqr()) / s.phase_normalisation();
            assert!((e.phase[j] / p - 1.0).abs() < 1e-12, "{j}");
        }
        let ln = SizeDistribution::Lognormal {
            median_radius_um: 1.0,
            geometric_sigma: 1.4,
        };
        let e = ensemble_at_angles(&ln, 550.0, m, 24, &angles).unwrap();
        // trapezoid in θ of 2π p sin θ
        let h = 0.05f64.to_radians();
        let integral: f64 = (0..3600)
            .map(|j| {
                let f = |k: usize| e.phase[k] * (angles[k].to_radians()).sin();
                std::f64::consts::PI * h * (f(j) + f(j + 1))
            })
            .sum();
        assert!((integral - 1.0).abs() < 2e-3, "{integral}");
        assert!(ensemble_at_angles(&ln, 550.0, m, 0, &angles).is_err());
        let bad = SizeDistribution::Gamma {
            effective_radius_um: 1.0,
            effective_variance: 0.7,
        };
        assert!(ensemble_at_angles(&bad, 550.0, m, 24, &angles).is_err());
    }
}
