//! Longitudinal lobes `M_p` and the energy-conserving normalisation of the physical fibre.
//!
//! Gaussian signature (decision DS-17 in `docs/decisions.md`): `gaussian(x, variance)`
//! everywhere, unit area (`exp(−x²/2v)/sqrt(2πv)`, the RSL `g` of thesis App. C); `gaussian_unit_height` is the
//! artist-friendly `g'` (thesis eq. 4.9).
//!
//! Marschner's lobe `M_p = g(θ_h − α_p, β_p²)` (θ_h = (θ_i + θ_o)/2) has area 2 in θ_o and, with
//! the `1/cos²θ_d` factor of eq. 4.7 and the truncation of θ_o to `[−π/2, π/2]`, does not
//! conserve energy (0.63–1.06 for shifted or wide lobes; decision FIB-5). The physical
//! model of scatterbake therefore divides each lobe by its energy under the measure
//! `cos²θ_o dθ_o` ([`lobe_energy`]), per lobe and per incident inclination:
//!
//! ```text
//! f_s(θ_i, θ_o, φ) = Σ_p g(θ_h − α_p, β_p²) N_p(θ_i, φ) / (Z_p(θ_i) cos²θ_d),
//! Z_p(θ_i) = ∫_{−π/2}^{π/2} g(θ_h − α_p, β_p²) cos²θ_o / cos²θ_d dθ_o,
//! ```
//!
//! which keeps Marschner's shape and makes `∫∫ f_s cos²θ_o dθ_o dφ = Σ_p E_p(θ_i)` exactly.

use crate::math::quadrature::gauss_legendre;
use std::f64::consts::{FRAC_PI_2, PI};

/// Unit-area Gaussian `exp(−x²/(2 v))/sqrt(2π v)` (`v` = variance).
pub fn gaussian(x: f64, variance: f64) -> f64 {
    (-x * x / (2.0 * variance)).exp() / (2.0 * PI * variance).sqrt()
}

/// Unit-height Gaussian `exp(−x²/(2 v))` (thesis `g'`).
pub fn gaussian_unit_height(x: f64, variance: f64) -> f64 {
    (-x * x / (2.0 * variance)).exp()
}

/// `cos²θ_d` with the clamp `≥ 1e-3` (decision DS-18).
pub fn cos2_theta_d(theta_i: f64, theta_o: f64) -> f64 {
    (0.5 * (theta_o - theta_i)).cos().powi(2).max(1e-3)
}

/// `∫_{−π/2}^{π/2} lobe(θ_h) cos²θ_o / cos²θ_d dθ_o` for a lobe of width `beta` (rad) by
/// composite Gauss–Legendre with panels no wider than `beta/2` in θ_o (8 nodes each).
pub fn lobe_energy(theta_i: f64, beta: f64, lobe: impl Fn(f64) -> f64) -> f64 {
    let (x, w) = gauss_legendre(8);
    let n = ((PI / (0.5 * beta.max(1e-4))).ceil() as usize).max(8);
    let step = PI / n as f64;
    let mut s = 0.0;
    for k in 0..n {
        let lo = -FRAC_PI_2 + step * k as f64;
        for (xi, wi) in x.iter().zip(&w) {
            let t_o = lo + 0.5 * step * (xi + 1.0);
            let t_h = 0.5 * (theta_i + t_o);
            s += 0.5 * step * wi * lobe(t_h) * t_o.cos().powi(2) / cos2_theta_d(theta_i, t_o);
        }
    }
    s
}

/// `Z_p(θ_i)` of the physical model for shift `alpha` and width `beta` (rad).
pub fn marschner_lobe_normalisation(theta_i: f64, alpha: f64, beta: f64) -> f64 {
    lobe_energy(theta_i, beta, |t_h| gaussian(t_h - alpha, beta * beta))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Energy table for Zinke's `g(π/2, θ_o+θ_i−Δθ, w)` lobe (truncated Gaussian
    /// normalisation constant of `[−π/2, π/2]`; the reference numbers do not cut the argument)
    /// with the `cos²θ_o/cos²θ_d` factor, computed independently by Simpson's rule:
    /// an independent reference for `lobe_energy`.
    #[test]
    fn reproduces_longitudinal_energy_reference_table() {
        let cases = [
            (5.0, 0.0, 0.0, 0.9943),
            (5.0, 0.0, 60.0, 0.9888),
            (10.0, -5.0, 30.0, 0.9196),
            (20.0, -10.0, 60.0, 0.6536),
            (40.0, 0.0, 80.0, 1.0602),
        ];
        for (w_deg, shift_deg, ti_deg, want) in cases {
            let w = f64::to_radians(w_deg);
            let d = f64::to_radians(shift_deg);
            let ti = f64::to_radians(ti_deg);
            // Truncated normalisation N(π/2, w) = 1/(w sqrt(2π) erf(π/(2 w sqrt 2))).
            let norm = 1.0 / (w * (2.0 * PI).sqrt() * libm::erf(FRAC_PI_2 / (w * 2f64.sqrt())));
            let e = lobe_energy(ti, 0.5 * w, |t_h| {
                let x = 2.0 * t_h - d; // θ_o + θ_i − Δθ
                norm * (-x * x / (2.0 * w * w)).exp()
            });
            assert!(
                (e - want).abs() < 6e-4,
                "w={w_deg} Δ={shift_deg} θ={ti_deg}: {e} vs {want}"
            );
        }
    }

    #[test]
    fn gaussian_has_unit_area_and_marschner_lobe_has_area_two_in_theta_o() {
        let v: f64 = 0.01;
        let a = crate::math::quadrature::integrate(|x| gaussian(x, v), -1.0, 1.0, 200);
        assert!((a - 1.0).abs() < 1e-12);
        // Narrow centred lobe at θ_i = 0: Z ≈ 2 (area 2 in θ_o, cos ratio ≈ 1).
        let z = marschner_lobe_normalisation(0.0, 0.0, 0.02);
        assert!((z - 2.0).abs() < 3e-3, "{z}");
    }
}
