//! The shading-time half of Dual Scattering (Zinke et al. 2008, revised in Sadeghi 2010 §4.7.2):
//! what a renderer computes per shading point from the precomputed averages of a `hair-dual`
//! table. This is a reference implementation to port (the shader snippet in `docs/hair.md` §6
//! is the same code): plain functions of one colour channel, no state.
//!
//! Inputs per shading point: the averages [`DualScattering`] looked up at the light
//! inclination θ_i (decision DS-1: every table is indexed by θ_i, also where the thesis's shader
//! writes `[θ_h]` or `[θ_d]`), the half angle θ_h = (θ_i + θ_r)/2, Marschner's difference angle
//! θ_d = (θ_r − θ_i)/2, the lobe shifts and widths of the fibre, the renderer's single
//! scattering `f_s^direct`, the fraction of direct light reaching the point and the forward
//! scattering along the shadow path ([`ForwardScattering`]), the last three per light
//! ([`LightAtPoint`]).
//!
//! Conventions (decisions in `docs/decisions.md`, DS-31):
//! - `g` is the unit-area Gaussian [`gaussian`]`(x, variance)` for f_back and the broadened lobes
//!   M^G of the physical model;
//! - f_s^scatter is divided by cos²θ_d like f_s^direct (thesis eq. 4.7);
//! - the F^scatter weight is the thesis's `(T_f − directFraction)·d_f`, clamped at 0: as printed
//!   it is negative at a fully lit point (T_f = d_f = 0.7 < directFraction = 1).

use super::diffuse::DiffuseTerms;
use super::dual::DualScattering;
use super::longitudinal::{cos2_theta_d, gaussian};
use std::f64::consts::PI;

/// Forward scattering density factor d_f of Zinke et al. 2008.
pub const FORWARD_DENSITY: f64 = 0.7;

/// Transmittance and longitudinal variance of the light that reaches a shading point through
/// the hairs in front of it (thesis eqs. 4.20–4.24).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardScattering {
    /// T_f = d_f Π_k ā_f(θ^k).
    pub transmittance: f64,
    /// σ̄_f² = Σ_k β̄_f²(θ^k) (rad²).
    pub variance: f64,
}

impl ForwardScattering {
    /// The production approximation (eqs. 4.23, 4.24): every one of the `hairs_in_front` hairs
    /// (from the deep shadow map's opacity; need not be an integer) has the shading hair's
    /// orientation, so T_f = d_f ā_f^n and σ̄_f² = n β̄_f², with `ds` at the shading hair's θ_i.
    pub fn same_orientation(ds: &DualScattering, hairs_in_front: f64, d_f: f64) -> Self {
        ForwardScattering {
            transmittance: d_f * ds.a_f.powf(hairs_in_front),
            variance: hairs_in_front * ds.beta_f2,
        }
    }

    /// The exact variant (eqs. 4.20, 4.22): the averages of each hair along the shadow path,
    /// each looked up at that hair's own inclination to the light.
    pub fn along_path(hairs: &[DualScattering], d_f: f64) -> Self {
        ForwardScattering {
            transmittance: d_f * hairs.iter().map(|h| h.a_f).product::<f64>(),
            variance: hairs.iter().map(|h| h.beta_f2).sum(),
        }
    }
}

/// Geometry of one shading point (radians): half and difference angles of the light and view
/// inclinations, and the light inclination itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadingAngles {
    pub theta_i: f64,
    pub theta_h: f64,
    pub theta_d: f64,
}

impl ShadingAngles {
    /// From the light and view inclinations θ_i, θ_r (rad, from the normal plane).
    pub fn new(theta_i: f64, theta_r: f64) -> Self {
        ShadingAngles {
            theta_i,
            theta_h: 0.5 * (theta_i + theta_r),
            theta_d: 0.5 * (theta_r - theta_i),
        }
    }

    /// cos²θ_d, kept ≥ 1e-3 like the tables (decision DS-10): θ_d = (θ_o − θ_i)/2 of
    /// [`cos2_theta_d`] with the difference angle itself.
    pub fn cos2_theta_d(&self) -> f64 {
        cos2_theta_d(0.0, 2.0 * self.theta_d)
    }
}

/// Local backscattering f_back = 2 Ā_b g(θ_h − Δ̄_b, σ̄_b² + `extra_variance`)/(π cos²θ_d)
/// (thesis eqs. 4.26, 4.36, 4.37 with the labels as the text uses them): `extra_variance` is 0
/// for f_back^direct and σ̄_f² for f_back^scatter.
pub fn f_back(ds: &DualScattering, a: &ShadingAngles, extra_variance: f64) -> f64 {
    2.0 * ds.big_a_b * gaussian(a.theta_h - ds.delta_b, ds.sigma_b2 + extra_variance)
        / (PI * a.cos2_theta_d())
}

/// Forward-scattered single scattering f_s^scatter = Σ_X M_X^G(θ_h) N_X^G / cos²θ_d with
/// M_X^G = g(θ_h − α_X, β_X² + σ̄_f²) (eq. 4.34; lobe shifts `alpha_rad` and widths
/// `beta_rad` of R, TT, TRT) and the tabulated N^G (eq. 4.35).
pub fn f_s_scatter(
    ds: &DualScattering,
    alpha_rad: [f64; 3],
    beta_rad: [f64; 3],
    a: &ShadingAngles,
    forward_variance: f64,
) -> f64 {
    let n_g = [ds.n_g_r, ds.n_g_tt, ds.n_g_trt];
    (0..3)
        .map(|x| {
            gaussian(
                a.theta_h - alpha_rad[x],
                beta_rad[x].powi(2) + forward_variance,
            ) * n_g[x]
        })
        .sum::<f64>()
        / a.cos2_theta_d()
}

/// The diffuse terms' part of f_s^scatter (decision DS-32): the forward azimuthal average
/// (2/π)∫_{π/2}^{π} f_d dφ of the diffuse BCSDF, constant in θ_h — f_d has no longitudinal lobe
/// and no 1/cos²θ_d, so the longitudinal broadening by σ̄_f² leaves it unchanged. Add it to
/// [`f_s_scatter`] when the fibre has diffuse terms (the table's N^G are the lobes' only; the
/// value is the header attribute `diffuse.forward_average`).
pub fn f_s_scatter_diffuse(diffuse: &DiffuseTerms) -> f64 {
    diffuse.forward_average()
}

/// What the renderer knows of one light at a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightAtPoint {
    /// The renderer's own single scattering f_s^direct.
    pub f_s_direct: f64,
    /// Fraction of the light's direct illumination reaching the point.
    pub direct_fraction: f64,
    /// Forward scattering along the shadow path.
    pub forward: ForwardScattering,
}

/// Everything a light contributes at a shading point, per channel:
/// `(F^direct + F^scatter) cos θ_i` with
/// F^direct = directFraction (f_s^direct + d_b f_back^direct) and
/// F^scatter = max(T_f − directFraction, 0) d_f (f_s^scatter + π d_b f_back^scatter)
/// (thesis §4.7.2).
pub fn dual_scattering(
    ds: &DualScattering,
    alpha_rad: [f64; 3],
    beta_rad: [f64; 3],
    a: &ShadingAngles,
    light: &LightAtPoint,
    d_b: f64,
    d_f: f64,
) -> f64 {
    let LightAtPoint {
        f_s_direct,
        direct_fraction,
        forward,
    } = *light;
    let f_direct = direct_fraction * (f_s_direct + d_b * f_back(ds, a, 0.0));
    let weight = (forward.transmittance - direct_fraction).max(0.0) * d_f;
    let f_scatter = weight
        * (f_s_scatter(ds, alpha_rad, beta_rad, a, forward.variance)
            + PI * d_b * f_back(ds, a, forward.variance));
    (f_direct + f_scatter) * a.theta_i.cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hair::dual::{LobeShape, combine};

    /// Averages of a plausible brown fibre at one θ_i from per-lobe energies.
    fn averages() -> (DualScattering, LobeShape) {
        let lobes = LobeShape::marschner(3f64.to_radians(), 7.5f64.to_radians());
        let eb = [0.04, 0.01, 0.03, 0.005];
        let ef = [0.02, 0.35, 0.05, 0.01];
        (combine(&eb, &ef, &lobes, 0.7, 0.99), lobes)
    }

    fn alpha_beta(l: &LobeShape) -> ([f64; 3], [f64; 3]) {
        (
            [l.alpha_rad[0], l.alpha_rad[1], l.alpha_rad[2]],
            [l.beta_rad[0], l.beta_rad[1], l.beta_rad[2]],
        )
    }

    /// ∫ h(θ_h) dθ_h over [−4, 4] rad by 80 panels of 64-point Gauss–Legendre.
    fn integrate(h: impl Fn(f64) -> f64) -> f64 {
        let width = 8.0 / 80.0;
        (0..80)
            .map(|p| {
                let a = -4.0 + p as f64 * width;
                crate::math::quadrature::integrate(&h, a, a + width, 64)
            })
            .sum()
    }

    /// f_back is a unit-area Gaussian in θ_h times 2Ā_b/(π cos²θ_d), centred on Δ̄_b.
    #[test]
    fn f_back_integrates_to_its_attenuation() {
        let (ds, _) = averages();
        let theta_d: f64 = 0.1;
        let c2 = theta_d.cos().powi(2);
        for extra in [0.0, 0.01] {
            let total = integrate(|th| {
                f_back(
                    &ds,
                    &ShadingAngles {
                        theta_i: 0.0,
                        theta_h: th,
                        theta_d,
                    },
                    extra,
                )
            });
            let want = 2.0 * ds.big_a_b / (PI * c2);
            assert!((total / want - 1.0).abs() < 1e-9, "{total} vs {want}");
        }
        let at = |th: f64| {
            f_back(
                &ds,
                &ShadingAngles {
                    theta_i: 0.0,
                    theta_h: th,
                    theta_d,
                },
                0.0,
            )
        };
        assert!(at(ds.delta_b) > at(ds.delta_b + 0.01) && at(ds.delta_b) > at(ds.delta_b - 0.01));
    }

    /// Each broadened lobe has unit area, so ∫ f_s^scatter cos²θ_d dθ_h = Σ N^G, whatever the
    /// forward variance.
    #[test]
    fn scatter_lobes_keep_the_averaged_azimuthal_energy() {
        let (ds, lobes) = averages();
        let (alpha, beta) = alpha_beta(&lobes);
        for sigma_f2 in [0.0, 0.05] {
            let theta_d = 0.2;
            let total = integrate(|th| {
                let a = ShadingAngles {
                    theta_i: 0.0,
                    theta_h: th,
                    theta_d,
                };
                f_s_scatter(&ds, alpha, beta, &a, sigma_f2) * a.cos2_theta_d()
            });
            let want = ds.n_g_r + ds.n_g_tt + ds.n_g_trt;
            assert!((total / want - 1.0).abs() < 1e-9, "{total} vs {want}");
        }
    }

    /// n identical hairs along the path give the production approximation; no hair in front
    /// gives T_f = d_f and no broadening.
    #[test]
    fn exact_and_approximate_forward_scattering_agree_for_aligned_hair() {
        let (ds, _) = averages();
        let exact = ForwardScattering::along_path(&[ds; 5], FORWARD_DENSITY);
        let approx = ForwardScattering::same_orientation(&ds, 5.0, FORWARD_DENSITY);
        assert!((exact.transmittance - approx.transmittance).abs() < 1e-15);
        assert!((exact.variance - approx.variance).abs() < 1e-15);
        let none = ForwardScattering::same_orientation(&ds, 0.0, FORWARD_DENSITY);
        assert_eq!(none.transmittance, FORWARD_DENSITY);
        assert_eq!(none.variance, 0.0);
    }

    /// A fully lit point with nothing in front: only F^direct, i.e. f_s^direct plus d_b times
    /// the local backscattering (the printed weight would make F^scatter negative there); a
    /// shadowed point: only F^scatter, weighted T_f d_f.
    #[test]
    fn lit_and_shadowed_limits() {
        let (ds, lobes) = averages();
        let (alpha, beta) = alpha_beta(&lobes);
        let a = ShadingAngles::new(0.3, -0.1);
        let f_s = 0.8;
        let lit = ForwardScattering::same_orientation(&ds, 0.0, FORWARD_DENSITY);
        let light = |direct_fraction, forward| LightAtPoint {
            f_s_direct: f_s,
            direct_fraction,
            forward,
        };
        let l = dual_scattering(&ds, alpha, beta, &a, &light(1.0, lit), 0.7, FORWARD_DENSITY);
        let want = (f_s + 0.7 * f_back(&ds, &a, 0.0)) * 0.3f64.cos();
        assert!((l - want).abs() < 1e-14 * want, "{l} vs {want}");
        let shadowed = ForwardScattering::same_orientation(&ds, 10.0, FORWARD_DENSITY);
        let s = dual_scattering(
            &ds,
            alpha,
            beta,
            &a,
            &light(0.0, shadowed),
            0.7,
            FORWARD_DENSITY,
        );
        let want = shadowed.transmittance
            * FORWARD_DENSITY
            * (f_s_scatter(&ds, alpha, beta, &a, shadowed.variance)
                + PI * 0.7 * f_back(&ds, &a, shadowed.variance))
            * 0.3f64.cos();
        assert!((s - want).abs() < 1e-14 * want, "{s} vs {want}");
        assert!(s > 0.0 && s < l);
    }

    /// The diffuse part of f_s^scatter is the forward azimuthal average of f_d (plain
    /// quadrature of the BCSDF over [π/2, π]).
    #[test]
    fn diffuse_scatter_is_the_forward_average_of_f_d() {
        use crate::math::quadrature::gauss_legendre_interval;
        let d = DiffuseTerms {
            lambertian_kd: 0.15,
            higher_order_kd: 0.01,
        };
        let (x, w) = gauss_legendre_interval(32, PI / 2.0, PI);
        let avg: f64 = 2.0 / PI * x.iter().zip(&w).map(|(p, w)| w * d.bcsdf(*p)).sum::<f64>();
        assert!((f_s_scatter_diffuse(&d) - avg).abs() < 1e-14, "{avg}");
        let want = 2.0 * 0.01 + 0.15 * (1.0 - PI / 4.0) / PI;
        assert!((avg - want).abs() < 1e-14);
    }
}
