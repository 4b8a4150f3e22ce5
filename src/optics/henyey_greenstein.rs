//! Henyey–Greenstein phase functions (Henyey & Greenstein 1941), the one definition every
//! module uses.
//!
//! - [`planar_hg_density`] / [`sample_planar_hg`]: the **planar (2-D)** Henyey–Greenstein
//!   function used by 2-D transport (Davis 2006; Tseng 2015 Eq. A.1), a density over the signed
//!   deflection angle θ ∈ (−π, π] (per radian):
//!   ρ(θ; g) = (1/2π) · (1 − g²) / (1 + g² − 2g cos θ).
//!   It is the wrapped Cauchy distribution: ∫ρ dθ = 1 and E[cos θ] = g exactly; g = 0 is uniform
//!   (1/2π). Valid for |g| < 1.
//! - [`hg_density_sr`]: the usual 3-D Henyey–Greenstein function per steradian (Henyey &
//!   Greenstein 1941), p(θ; g) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}), normalised over 4π;
//!   its Legendre moments are exactly g^l.
//!
//! Every function takes the angle (or its cosine) first and the asymmetry `g` second.

use std::f64::consts::PI;

/// Planar HG density per radian at deflection `theta_rad` (any real angle; 2π-periodic).
pub fn planar_hg_density(theta_rad: f64, g: f64) -> f64 {
    planar_hg_density_cos(theta_rad.cos(), g)
}

/// Planar HG density per radian from the cosine of the deflection.
#[inline]
pub fn planar_hg_density_cos(cos_theta: f64, g: f64) -> f64 {
    (1.0 - g * g) / (2.0 * PI * (1.0 + g * g - 2.0 * g * cos_theta))
}

/// Exact inverse-CDF sample of the planar HG deflection, θ ∈ (−π, π), from a uniform
/// `xi ∈ [0, 1)`: θ = 2·atan( (1−g)/(1+g) · tan(π(ξ − ½)) ).
#[inline]
pub fn sample_planar_hg(xi: f64, g: f64) -> f64 {
    let t = (PI * (xi - 0.5)).tan();
    2.0 * ((1.0 - g) / (1.0 + g) * t).atan()
}

/// Planar HG cumulative distribution on (−π, π]: P(Θ ≤ θ), the inverse of [`sample_planar_hg`].
pub fn planar_hg_cdf(theta_rad: f64, g: f64) -> f64 {
    let t = (0.5 * theta_rad).tan();
    0.5 + ((1.0 + g) / (1.0 - g) * t).atan() / PI
}

/// 3-D HG phase function per steradian.
pub fn hg_density_sr(cos_theta: f64, g: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos_theta).powf(1.5))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::quadrature::integrate;

    #[test]
    fn planar_hg_is_normalised_with_mean_cosine_g() {
        for &g in &[0.0, 0.3, 0.6, 0.8] {
            // Split the integral so the forward peak is resolved.
            let norm = integrate(|t| planar_hg_density(t, g), -PI, 0.0, 200)
                + integrate(|t| planar_hg_density(t, g), 0.0, PI, 200);
            let mean_cos = integrate(|t| t.cos() * planar_hg_density(t, g), -PI, 0.0, 200)
                + integrate(|t| t.cos() * planar_hg_density(t, g), 0.0, PI, 200);
            assert!((norm - 1.0).abs() < 1e-10, "g={g} norm={norm}");
            assert!((mean_cos - g).abs() < 1e-10, "g={g} <cos>={mean_cos}");
        }
    }

    #[test]
    fn planar_hg_sampling_inverts_cdf_and_has_mean_cosine_g() {
        for &g in &[0.0, 0.5, 0.8] {
            let n = 200_000;
            let mut sum_cos = 0.0;
            for i in 0..n {
                let xi = (i as f64 + 0.5) / n as f64;
                let th = sample_planar_hg(xi, g);
                assert!((planar_hg_cdf(th, g) - xi).abs() < 1e-9);
                sum_cos += th.cos();
            }
            // Stratified midpoints: error O(1/n²)-ish, far below 1e-4.
            assert!((sum_cos / n as f64 - g).abs() < 1e-4, "g={g}");
        }
    }

    #[test]
    fn hg_3d_is_normalised() {
        let g = 0.7;
        let norm = 2.0 * PI * integrate(|mu| hg_density_sr(mu, g), -1.0, 1.0, 400);
        assert!((norm - 1.0).abs() < 1e-8, "{norm}");
    }
}
