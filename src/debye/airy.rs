//! Airy theory of the rainbow (primary and secondary), with Fresnel factors per polarisation:
//! a fast approximate curve near a bow, in the Bohren–Huffman normalisation of [`crate::mie`]
//! (`i_perp = |S_1|²`, `i_par = |S_2|²`, dimensionless; `dσ/dΩ = |S|²/k²`).
//!
//! # Formulas (cubic wavefront; van de Hulst 1957 §13.2, Wang & van de Hulst 1991)
//! A ray of order `p` (`p` chords inside; `p = 2` primary, `p = 3` secondary, `order = p − 1`)
//! entering at incidence `i` (`u = sin i = b/a`), refraction `r` (`sin r = u/n`), is deviated by
//! `D(u) = (p−1)π + 2i − 2p r`. At the rainbow ray `dD/du = 0`:
//!
//! ```text
//! cos² i_R = (n² − 1)/(p² − 1),   u_R = sin i_R,   D'' = d²D/du² = 2 u_R (p² − 1)/(p² cos³ i_R)
//! ```
//!
//! and the rainbow angle `θ_R` is `D(u_R)` folded into `[0°, 180°]`. Expanding the exit phase to
//! third order in `b − b_R` and integrating over the wavefront (2-D stationary-phase normalisation,
//! times the axial focusing `b/sin θ`) gives
//!
//! ```text
//! |S_j(θ)|² = 2π u_R x^{7/3} (2/D'')^{2/3} |ε_j|² Ai(−z)² / sin θ,
//! z = (2x²/D'')^{1/3} s (θ − θ_R)            (θ in rad),
//! |ε_j|² = (1 − R_j)² R_j^{p−1}              (R_j: Fresnel reflectance at i_R, j = ⊥, ∥)
//! ```
//!
//! with `s = +1` when the fold keeps `θ = D` (primary: lit side at `θ > θ_R`) and `s = −1`
//! when it maps `θ = 2π − D` (secondary: lit side at `θ < θ_R`). Far on the lit side the
//! average reproduces the two geometric-optics branches (`|S|² = x² u |du/dθ| |ε|²/sin θ`
//! each), which fixes the normalisation; the first maximum is at `z = 1.0188`
//! (`Ai'(−z) = 0`), i.e. `θ_R + 1.0188 (D''/2x²)^{1/3}` rad for the primary.
//!
//! # Domain and accuracy (`docs/debye.md`)
//! Asymptotic in `x`; the Fresnel factors are frozen at the rainbow ray. Near the bow of a
//! 0.4 mm drop at 650 nm the ⊥ maxima agree with the Debye `p = 2` term to ~0.01° and the peak
//! height to ~1 %; the ∥ component is poor (its Fresnel factor passes near Brewster's angle
//! across the wavefront), and the agreement degrades for smaller drops and farther from the
//! bow (figures in `docs/debye.md`). No surface-wave, complex-angular-momentum or
//! refraction-order interference: use the Debye series for exact per-order curves.

use crate::optics::airy_function::airy_ai;
use crate::optics::fresnel::fresnel_amplitudes_real;
use std::f64::consts::PI;

/// Prepared Airy-theory parameters of one bow.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AiryRainbow {
    /// Size parameter `x = 2πa/λ`.
    pub size_parameter: f64,
    /// Relative refractive index (real).
    pub n: f64,
    /// Debye order `p` (2 primary, 3 secondary).
    pub p: usize,
    /// Rainbow scattering angle θ_R (deg).
    pub rainbow_angle_deg: f64,
    /// Incidence angle of the rainbow ray (deg).
    pub incidence_deg: f64,
    /// `D'' = d²D/du²` at the rainbow ray.
    pub curvature: f64,
    /// `+1`: lit side at θ > θ_R; `−1`: lit side at θ < θ_R.
    pub side: f64,
    /// `|ε_⊥|²`.
    pub eps2_perp: f64,
    /// `|ε_∥|²`.
    pub eps2_par: f64,
}

impl AiryRainbow {
    /// The bow of `order` (1 = primary, 2 = secondary, …; Debye `p = order + 1`) of a sphere of
    /// size parameter `x` and real index `n` (`1 < n < p`, so that the bow exists).
    pub fn new(x: f64, n: f64, order: usize) -> Self {
        let p = order + 1;
        let pf = p as f64;
        assert!(
            order >= 1 && n > 1.0 && n < pf,
            "no rainbow of order {order} for n = {n}"
        );
        let cos_i = ((n * n - 1.0) / (pf * pf - 1.0)).sqrt();
        let u = (1.0 - cos_i * cos_i).sqrt();
        let i = u.asin();
        let r = (u / n).asin();
        let d = (pf - 1.0) * PI + 2.0 * i - 2.0 * pf * r;
        let folded = d.rem_euclid(2.0 * PI);
        let (theta, side) = if folded <= PI {
            (folded, 1.0)
        } else {
            (2.0 * PI - folded, -1.0)
        };
        let curvature = 2.0 * u * (pf * pf - 1.0) / (pf * pf * cos_i.powi(3));
        let f = fresnel_amplitudes_real(1.0, n, cos_i);
        let (rs, rp) = (f.reflectance_s(), f.reflectance_p());
        let eps = |r: f64| (1.0 - r).powi(2) * r.powi(p as i32 - 1);
        AiryRainbow {
            size_parameter: x,
            n,
            p,
            rainbow_angle_deg: theta.to_degrees(),
            incidence_deg: i.to_degrees(),
            curvature,
            side,
            eps2_perp: eps(rs),
            eps2_par: eps(rp),
        }
    }

    /// `(2x²/D'')^{1/3}`: the Airy argument per radian of scattering angle.
    pub fn angular_scale(&self) -> f64 {
        (2.0 * self.size_parameter.powi(2) / self.curvature).cbrt()
    }

    /// Airy argument `z` at scattering angle θ (deg): `|S|² ∝ Ai(−z)²`.
    pub fn airy_argument(&self, theta_deg: f64) -> f64 {
        self.angular_scale() * self.side * (theta_deg - self.rainbow_angle_deg).to_radians()
    }

    /// Angle (deg) at which the Airy argument equals `z`.
    pub fn angle_at(&self, z: f64) -> f64 {
        self.rainbow_angle_deg + (z / (self.angular_scale() * self.side)).to_degrees()
    }
}

/// `(|S_1|², |S_2|²)` of the Airy approximation at scattering angle `theta_deg`.
pub fn airy_rainbow(bow: &AiryRainbow, theta_deg: f64) -> (f64, f64) {
    let x = bow.size_parameter;
    let ai = airy_ai(-bow.airy_argument(theta_deg));
    let u = bow.incidence_deg.to_radians().sin();
    let base = 2.0 * PI * u * x.powf(7.0 / 3.0) * (2.0 / bow.curvature).powf(2.0 / 3.0) * ai * ai
        / theta_deg.to_radians().sin();
    (base * bow.eps2_perp, base * bow.eps2_par)
}

/// First maxima of `Ai(−z)²` (the zeros of `Ai'`, DLMF Table 9.9.1): the main bow and the first
/// supernumeraries in Airy theory.
pub const AIRY_MAXIMA_Z: [f64; 5] = [
    1.018_792_97,
    3.248_197_58,
    4.820_099_21,
    6.163_307_36,
    7.372_177_26,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// Rainbow angles for the two indices quoted by Sadeghi 2012 (η = 1.3314 and 1.3445; the
    /// thesis gives 137.7°/139.6° primary, 129.5°/126.1° secondary), against two-decimal values
    /// computed independently (137.69°, 139.57°; 129.53°, 126.14°) and Descartes' formula.
    #[test]
    fn geometric_rainbow_angles() {
        let cases = [
            (1.3314, 1, 137.69),
            (1.3445, 1, 139.57),
            (1.3314, 2, 129.53),
            (1.3445, 2, 126.14),
        ];
        for (n, order, theta) in cases {
            let b = AiryRainbow::new(1000.0, n, order);
            assert!(
                (b.rainbow_angle_deg - theta).abs() < 0.01,
                "n={n} order={order}: {}",
                b.rainbow_angle_deg
            );
        }
        assert_eq!(AiryRainbow::new(1000.0, 1.33, 1).side, 1.0);
        assert_eq!(AiryRainbow::new(1000.0, 1.33, 2).side, -1.0);
    }

    /// D'' against a finite difference of D(u).
    #[test]
    fn curvature_matches_finite_difference() {
        for (n, order) in [(1.333, 1usize), (1.333, 2), (1.5, 1)] {
            let b = AiryRainbow::new(100.0, n, order);
            let p = (order + 1) as f64;
            let d = |u: f64| (p - 1.0) * PI + 2.0 * u.asin() - 2.0 * p * (u / n).asin();
            let u0 = b.incidence_deg.to_radians().sin();
            let h = 1e-4;
            let fd = (d(u0 + h) - 2.0 * d(u0) + d(u0 - h)) / (h * h);
            assert!(
                ((fd - b.curvature) / b.curvature).abs() < 1e-5,
                "{fd} vs {}",
                b.curvature
            );
        }
    }

    /// Far on the lit side the Airy curve averages to geometric optics (two branches).
    #[test]
    fn lit_side_average_is_geometric_optics() {
        let n = 1.333;
        let x = 5000.0;
        let b = AiryRainbow::new(x, n, 1);
        // average over many fringes around z ≈ 40
        let (z0, z1) = (38.0, 42.0);
        let steps = 20000;
        let (t0, t1) = (b.angle_at(z0), b.angle_at(z1));
        let mut sum = 0.0;
        for k in 0..steps {
            let t = t0 + (t1 - t0) * (k as f64 + 0.5) / steps as f64;
            sum += airy_rainbow(&b, t).0;
        }
        let airy_avg = sum / steps as f64;
        // geometric optics at the middle angle: Σ branches x² u |du/dθ| |ε|²/sin θ
        let t = b.angle_at(40.0).to_radians();
        let dth = t - b.rainbow_angle_deg.to_radians();
        let u0 = b.incidence_deg.to_radians().sin();
        let go = 2.0 * x * x * u0 * b.eps2_perp / (t.sin() * (2.0 * b.curvature * dth).sqrt());
        assert!((airy_avg / go - 1.0).abs() < 0.02, "{airy_avg} vs {go}");
    }
}
