//! Diffuse terms of the fibre BCSDF. Zinke & Weber 2007 use the symbol `k_d` for two different
//! quantities; both are offered under names that say which one is meant (decision FIB-21):
//!
//! - [`DiffuseTerms::lambertian_kd`]: the BRDF value `k_d` of an **opaque fibre with a Lambertian
//!   surface** (Zinke & Weber §9.1.1, eq. 49). Its BCSDF, in closed form (substitute
//!   `h_o = sin u` in eq. 49), is
//!   `f_L(φ) = (k_d/4)(sin|φ| + (π − |φ|) cos φ)`, independent of θ_i and θ_o;
//!   `∫_{−π}^{π} f_L dφ = 2k_d` and its albedo under the energy measure is `π k_d`, so
//!   `0 ≤ k_d ≤ 1/π`. (The paper's eq. 51 is a Taylor approximation, 6.1 % high at φ = 0; not
//!   used.)
//! - [`DiffuseTerms::higher_order_kd`]: the **BFSDF constant** `k_d δ(Δs)` of Zinke & Weber
//!   eq. 52 that approximates higher-order scattering inside the dielectric fibre. Its BCSDF is
//!   the constant `2k_d`, albedo `2π² k_d`, so `0 ≤ k_d ≤ 1/(2π²)`.
//!
//! Both are θ-independent BCSDF terms added to the lobes, `f_s = Σ_p M_p N_p / cos²θ_d + f_d(φ)`
//! (no longitudinal lobe, no `1/cos²θ_d`). Under the energy measure
//! `∫∫ f cos²θ_o dθ_o dφ` (`∫ cos²θ_o dθ_o = π/2`) each contributes `(π/2) ∫ f_d dφ`:
//!
//! | term | ∫ f dφ, backward \|φ\| < π/2 | forward | albedo |
//! |---|---|---|---|
//! | Lambertian cylinder | k_d (1 + π/4) | k_d (1 − π/4) | π k_d |
//! | higher-order constant | 2π k_d | 2π k_d | 2π² k_d |

use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_4, PI};

/// Largest physical Lambertian BRDF value: albedo `π k_d ≤ 1`.
pub const LAMBERTIAN_KD_MAX: f64 = 1.0 / PI;
/// Largest physical higher-order BFSDF constant: albedo `2π² k_d ≤ 1`.
pub const HIGHER_ORDER_KD_MAX: f64 = 1.0 / (2.0 * PI * PI);

/// Variance (rad²) of `θ_h = (θ_i + θ_o)/2` about `θ_i/2` for a term that is constant in θ_o
/// under the energy measure: `θ_o` has the density `(2/π) cos²θ_o` on `[−π/2, π/2]`, variance
/// `π²/12 − 1/2`, so `θ_h` has a quarter of it, `(π² − 6)/48` (decision DS-32).
pub const DIFFUSE_THETA_H_VARIANCE: f64 = (PI * PI - 6.0) / 48.0;

/// BCSDF of an opaque circular fibre with a Lambertian surface BRDF `kd` (per radian of
/// relative azimuth φ, any θ): `(k_d/4)(sin|φ| + (π − |φ|) cos φ)`, φ wrapped to (−π, π].
pub fn lambertian_cylinder_bcsdf(kd: f64, phi_rad: f64) -> f64 {
    let a = super::fiber::wrap_angle(phi_rad).abs();
    0.25 * kd * (a.sin() + (PI - a) * a.cos())
}

/// The two diffuse terms of the fibre BCSDF (both 0 by default: no diffuse term).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct DiffuseTerms {
    /// Lambertian surface BRDF value `k_d` of an opaque fibre (BCSDF `(k_d/4)(sin|φ| + (π−|φ|)
    /// cos φ)`, albedo `π k_d`), `0 ≤ k_d ≤ 1/π`.
    pub lambertian_kd: f64,
    /// Zinke & Weber eq. 52 higher-order BFSDF constant `k_d` (BCSDF `2k_d`, albedo `2π² k_d`),
    /// `0 ≤ k_d ≤ 1/(2π²)`.
    pub higher_order_kd: f64,
}

impl DiffuseTerms {
    /// No diffuse term at all.
    pub fn is_zero(&self) -> bool {
        self.lambertian_kd == 0.0 && self.higher_order_kd == 0.0
    }

    /// Range checks; returns `(key, message)` naming the offending key. Each term alone and the
    /// two together must have an albedo within [0, 1].
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (key, v, max, albedo) in [
            (
                "lambertian_kd",
                self.lambertian_kd,
                LAMBERTIAN_KD_MAX,
                "π k_d",
            ),
            (
                "higher_order_kd",
                self.higher_order_kd,
                HIGHER_ORDER_KD_MAX,
                "2π² k_d",
            ),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return Err((
                    key,
                    format!(
                        "must be within 0–{max:.6} (its albedo {albedo} must not exceed 1; got {v})"
                    ),
                ));
            }
        }
        let total = self.albedo();
        if total > 1.0 + 1e-12 {
            return Err((
                "higher_order_kd",
                format!(
                    "with lambertian_kd the diffuse albedo π·lambertian_kd + 2π²·higher_order_kd = {total:.6} exceeds 1"
                ),
            ));
        }
        Ok(())
    }

    /// The diffuse BCSDF `f_d(φ)` (per radian, independent of θ_i, θ_o).
    pub fn bcsdf(&self, phi_rad: f64) -> f64 {
        lambertian_cylinder_bcsdf(self.lambertian_kd, phi_rad) + 2.0 * self.higher_order_kd
    }

    /// `(∫_{|φ|<π/2} f_d dφ, ∫_{|φ|≥π/2} f_d dφ)` in closed form.
    pub fn hemisphere_integrals(&self) -> (f64, f64) {
        let (l, h) = (self.lambertian_kd, self.higher_order_kd);
        (
            l * (1.0 + FRAC_PI_4) + 2.0 * PI * h,
            l * (1.0 - FRAC_PI_4) + 2.0 * PI * h,
        )
    }

    /// `(backward, forward)` albedos under the energy measure, `(π/2)` times
    /// [`Self::hemisphere_integrals`].
    pub fn hemisphere_albedos(&self) -> (f64, f64) {
        let (b, f) = self.hemisphere_integrals();
        (0.5 * PI * b, 0.5 * PI * f)
    }

    /// Total albedo `π k_d(Lambertian) + 2π² k_d(higher order)`.
    pub fn albedo(&self) -> f64 {
        PI * self.lambertian_kd + 2.0 * PI * PI * self.higher_order_kd
    }

    /// Forward-averaged azimuthal value `(2/π) ∫_{π/2}^{π} f_d dφ` (per radian), the diffuse
    /// counterpart of `N^G_p` for the shading-time `f_s^scatter` (docs/hair.md §10).
    pub fn forward_average(&self) -> f64 {
        self.hemisphere_integrals().1 / PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::quadrature::gauss_legendre_interval;

    /// Zinke & Weber eq. 49, `(k_d/2) ∫_{−1}^{cos φ} cos(φ + asin h_o) dh_o` (φ ≥ 0), integrated
    /// numerically in `h_o` (not through the substitution that gives the closed form). The
    /// integrand has square-root end-point behaviour (`asin` at `h_o = ±1`), so the rule is
    /// Gauss–Legendre in `s ∈ [0, 1]` with `h_o = −1 + (cos φ + 1)(3s² − 2s³)`, whose Jacobian
    /// vanishes at both ends and makes the integrand smooth.
    fn eq49_numerical(kd: f64, phi: f64) -> f64 {
        let phi = phi.abs();
        let span = phi.cos() + 1.0;
        let (x, w) = gauss_legendre_interval(200, 0.0, 1.0);
        let mut sum = 0.0;
        for (s, ws) in x.iter().zip(&w) {
            let h = -1.0 + span * (3.0 * s * s - 2.0 * s * s * s);
            let dh = span * 6.0 * s * (1.0 - s);
            sum += ws * (phi + h.clamp(-1.0, 1.0).asin()).cos() * dh;
        }
        0.5 * kd * sum
    }

    #[test]
    fn lambertian_closed_form_matches_numerical_eq49() {
        let kd = 0.27;
        let mut worst: f64 = 0.0;
        for k in 0..=360 {
            let phi = PI * k as f64 / 360.0;
            let exact = eq49_numerical(kd, phi);
            let closed = lambertian_cylinder_bcsdf(kd, phi);
            worst = worst.max((exact - closed).abs());
            // Even in φ (to the rounding of the angle wrap).
            assert!((closed - lambertian_cylinder_bcsdf(kd, -phi)).abs() < 1e-15);
        }
        println!(
            "Lambertian cylinder: max |eq. 49 numerical − closed form| over 361 φ = {worst:.2e}"
        );
        assert!(worst < 1e-10, "{worst:e}");
        // Reference values (units of k_d): π/4 at 0, 1/4 at 90°, 0 at 180°, and the table of
        // Zinke & Weber §7 recomputed at 30° and 120°: 0.69181, 0.08561.
        for (deg, want) in [
            (0.0, FRAC_PI_4),
            (30.0, 0.69181),
            (90.0, 0.25),
            (120.0, 0.08561),
            (180.0, 0.0),
        ] {
            let v = lambertian_cylinder_bcsdf(1.0, f64::to_radians(deg));
            assert!((v - want).abs() < 6e-6, "{deg}: {v} vs {want}");
        }
    }

    #[test]
    fn lambertian_energy_and_hemispheres() {
        let kd = 0.3;
        let d = DiffuseTerms {
            lambertian_kd: kd,
            higher_order_kd: 0.0,
        };
        let (x, w) = gauss_legendre_interval(64, 0.0, PI / 2.0);
        let (xf, wf) = gauss_legendre_interval(64, PI / 2.0, PI);
        let back: f64 = 2.0 * x.iter().zip(&w).map(|(p, w)| w * d.bcsdf(*p)).sum::<f64>();
        let fwd: f64 = 2.0
            * xf.iter()
                .zip(&wf)
                .map(|(p, w)| w * d.bcsdf(*p))
                .sum::<f64>();
        let (cb, cf) = d.hemisphere_integrals();
        assert!((back - cb).abs() < 1e-14 && (fwd - cf).abs() < 1e-14);
        assert!(
            (back + fwd - 2.0 * kd).abs() < 1e-14,
            "∫f dφ = {}",
            back + fwd
        );
        // Albedo: (π/2)∫f dφ = π k_d, checked with an explicit θ_o quadrature of cos²θ_o.
        let (t, wt) = gauss_legendre_interval(32, -PI / 2.0, PI / 2.0);
        let c2: f64 = t.iter().zip(&wt).map(|(t, w)| w * t.cos().powi(2)).sum();
        assert!((c2 * (back + fwd) - PI * kd).abs() < 1e-14);
        assert!((d.albedo() - PI * kd).abs() < 1e-15);
        let (ab, af) = d.hemisphere_albedos();
        assert!((ab + af - PI * kd).abs() < 1e-14);
    }

    #[test]
    fn higher_order_constant_energy() {
        let kd = 0.02;
        let d = DiffuseTerms {
            lambertian_kd: 0.0,
            higher_order_kd: kd,
        };
        assert_eq!(d.bcsdf(0.3), 2.0 * kd);
        assert_eq!(d.bcsdf(3.0), 2.0 * kd);
        let (b, f) = d.hemisphere_albedos();
        assert!((b - PI * PI * kd).abs() < 1e-15 * PI * PI * kd * 4.0);
        assert!((f - PI * PI * kd).abs() < 1e-15 * PI * PI * kd * 4.0);
        assert!((d.albedo() - 2.0 * PI * PI * kd).abs() < 1e-15);
        assert!((d.forward_average() - 2.0 * kd).abs() < 1e-15);
        // Plain quadrature of the constant over each half-circle.
        let (x, w) = gauss_legendre_interval(8, 0.0, PI / 2.0);
        let back: f64 = 2.0 * x.iter().zip(&w).map(|(p, w)| w * d.bcsdf(*p)).sum::<f64>();
        assert!((back - d.hemisphere_integrals().0).abs() < 1e-15);
    }

    #[test]
    fn invalid_values_are_refused_with_the_key() {
        let bad = [
            (-0.1, 0.0, "lambertian_kd"),
            (0.4, 0.0, "lambertian_kd"),
            (f64::NAN, 0.0, "lambertian_kd"),
            (0.0, 0.06, "higher_order_kd"),
            (0.0, -1e-9, "higher_order_kd"),
            (0.0, f64::INFINITY, "higher_order_kd"),
            (0.2, 0.03, "higher_order_kd"),
        ];
        for (l, h, key) in bad {
            let d = DiffuseTerms {
                lambertian_kd: l,
                higher_order_kd: h,
            };
            assert_eq!(d.validate().unwrap_err().0, key, "{l} {h}");
        }
        for (l, h) in [
            (0.0, 0.0),
            (LAMBERTIAN_KD_MAX, 0.0),
            (0.0, HIGHER_ORDER_KD_MAX),
        ] {
            assert!(
                DiffuseTerms {
                    lambertian_kd: l,
                    higher_order_kd: h,
                }
                .validate()
                .is_ok()
            );
        }
    }
}
