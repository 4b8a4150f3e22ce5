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
}
