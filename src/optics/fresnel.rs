//! Complex Fresnel amplitude coefficients at a planar interface.
//!
//! Convention (Born & Wolf): light travels from medium 1 (index `eta_1`) into medium 2
//! (index `eta_2`); both indices may be complex (`n + ik`, `k >= 0`, time dependence `e^{-iωt}`).
//!
//! ```text
//! r_s (= r_⊥) = (η₁ cos θ_i − η₂ cos θ_t) / (η₁ cos θ_i + η₂ cos θ_t)
//! r_p (= r_∥) = (η₂ cos θ_i − η₁ cos θ_t) / (η₂ cos θ_i + η₁ cos θ_t)
//! t_s (= t_⊥) = 2 η₁ cos θ_i / (η₁ cos θ_i + η₂ cos θ_t)
//! t_p (= t_∥) = 2 η₁ cos θ_i / (η₂ cos θ_i + η₁ cos θ_t)
//! ```
//!
//! `cos θ_t` is the complex square root of `1 − (η₁/η₂)² sin² θ_i` on the branch with
//! non-negative imaginary part, so the transmitted wave decays into medium 2. Under total internal
//! reflection this gives `|r| = 1` with a complex phase, and an evanescent transmitted field.
//!
//! The power-consistent transmission amplitudes `t̃ = t · sqrt(Re(η₂ cos θ_t) / Re(η₁ cos θ_i))`
//! (for non-absorbing media) satisfy `|r|² + |t̃|² = 1`; use them whenever beam-area change is
//! accounted separately (non-spherical drops, fibre path integrals). For a sphere the raw
//! amplitudes are exact because the factor cancels between entry and exit (Stokes relations).

use num_complex::Complex64;

/// Fresnel amplitude coefficients for one incidence angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FresnelAmplitudes {
    /// Reflection amplitude, perpendicular (s, ⊥) polarisation.
    pub r_s: Complex64,
    /// Reflection amplitude, parallel (p, ∥) polarisation.
    pub r_p: Complex64,
    /// Transmission amplitude, perpendicular (raw, not power-consistent).
    pub t_s: Complex64,
    /// Transmission amplitude, parallel (raw, not power-consistent).
    pub t_p: Complex64,
    /// Complex cosine of the transmission angle (branch with Im >= 0).
    pub cos_theta_t: Complex64,
    /// True when the transmitted wave is evanescent (total internal reflection, lossless media).
    pub total_internal_reflection: bool,
}

impl FresnelAmplitudes {
    /// Power reflectance for perpendicular polarisation, `|r_s|²`.
    pub fn reflectance_s(&self) -> f64 {
        self.r_s.norm_sqr()
    }
    /// Power reflectance for parallel polarisation, `|r_p|²`.
    pub fn reflectance_p(&self) -> f64 {
        self.r_p.norm_sqr()
    }
    /// Unpolarised power reflectance `(|r_s|² + |r_p|²)/2`.
    pub fn reflectance_unpolarized(&self) -> f64 {
        0.5 * (self.reflectance_s() + self.reflectance_p())
    }
}

/// Fresnel amplitudes for light going from `eta_1` into `eta_2` at incidence cosine
/// `cos_theta_i` in `[0, 1]` (values outside are clamped).
pub fn fresnel_amplitudes(
    eta_1: Complex64,
    eta_2: Complex64,
    cos_theta_i: f64,
) -> FresnelAmplitudes {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let ratio = eta_1 / eta_2;
    let cos2_t = Complex64::new(1.0, 0.0) - ratio * ratio * sin2_i;
    let mut cos_t = cos2_t.sqrt();
    if cos_t.im < 0.0 {
        cos_t = -cos_t;
    }
    let ci = Complex64::new(cos_i, 0.0);
    let a = eta_1 * ci;
    let b = eta_2 * cos_t;
    let c = eta_2 * ci;
    let d = eta_1 * cos_t;
    let r_s = (a - b) / (a + b);
    let r_p = (c - d) / (c + d);
    let t_s = 2.0 * a / (a + b);
    let t_p = 2.0 * a / (c + d);
    let total_internal_reflection = eta_1.im == 0.0 && eta_2.im == 0.0 && cos2_t.re < 0.0;
    FresnelAmplitudes {
        r_s,
        r_p,
        t_s,
        t_p,
        cos_theta_t: cos_t,
        total_internal_reflection,
    }
}

/// `(cos θ_i, cos θ_t)` for real indices, `cos_theta_i` clamped to [0, 1]; `None` under total
/// internal reflection.
fn real_cosines(eta_1: f64, eta_2: f64, cos_theta_i: f64) -> Option<(f64, f64)> {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let ratio = eta_1 / eta_2;
    let cos2_t = 1.0 - ratio * ratio * sin2_i;
    (cos2_t >= 0.0).then(|| (cos_i, cos2_t.sqrt()))
}

/// Fresnel amplitudes for real (non-absorbing) indices. Below the critical angle every
/// quantity is real and is computed in real arithmetic (imaginary parts exactly zero; the
/// complex path divides through `(a·c̄)/|c|²`, so the two agree to a few ulp); under total
/// internal reflection it is [`fresnel_amplitudes`].
pub fn fresnel_amplitudes_real(eta_1: f64, eta_2: f64, cos_theta_i: f64) -> FresnelAmplitudes {
    let Some((cos_i, cos_t)) = real_cosines(eta_1, eta_2, cos_theta_i) else {
        return fresnel_amplitudes(
            Complex64::new(eta_1, 0.0),
            Complex64::new(eta_2, 0.0),
            cos_theta_i,
        );
    };
    let a = eta_1 * cos_i;
    let b = eta_2 * cos_t;
    let c = eta_2 * cos_i;
    let d = eta_1 * cos_t;
    let real = |x: f64| Complex64::new(x, 0.0);
    FresnelAmplitudes {
        r_s: real((a - b) / (a + b)),
        r_p: real((c - d) / (c + d)),
        t_s: real(2.0 * a / (a + b)),
        t_p: real(2.0 * a / (c + d)),
        cos_theta_t: real(cos_t),
        total_internal_reflection: false,
    }
}

/// Real Fresnel amplitudes below the critical angle, with power-consistent transmission
/// ([`fresnel_power_consistent_real`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RealFresnel {
    /// Reflection amplitudes r_s (⊥), r_p (∥).
    pub r_s: f64,
    pub r_p: f64,
    /// Power-consistent transmission amplitudes t̃_s, t̃_p (`|r|² + |t̃|² = 1`).
    pub t_s: f64,
    pub t_p: f64,
    /// Cosine of the transmission angle.
    pub cos_theta_t: f64,
}

/// Reflection and power-consistent transmission amplitudes for real indices, light going from
/// `eta_1` into `eta_2` at incidence cosine `cos_theta_i` (clamped to [0, 1]); `None` under
/// total internal reflection. With `a = η₁ cos θ_i`, `b = η₂ cos θ_t`, `c = η₂ cos θ_i`,
/// `d = η₁ cos θ_t`: `r_s = (a − b)/(a + b)`, `r_p = (c − d)/(c + d)` and
/// `t̃ = t·sqrt(b/a)`, i.e. `t̃_s = 2√(ab)/(a + b)`, `t̃_p = 2√(ab)/(c + d)`: three divisions
/// and two square roots in all (the ray tracer calls it at every interface). Agrees with
/// [`fresnel_amplitudes`] and [`power_consistent_transmission`] to a few ulp.
pub fn fresnel_power_consistent_real(
    eta_1: f64,
    eta_2: f64,
    cos_theta_i: f64,
) -> Option<RealFresnel> {
    let (cos_i, cos_t) = real_cosines(eta_1, eta_2, cos_theta_i)?;
    let (a, b) = (eta_1 * cos_i, eta_2 * cos_t);
    let (c, d) = (eta_2 * cos_i, eta_1 * cos_t);
    let (s, p) = (1.0 / (a + b), 1.0 / (c + d));
    let two_root_ab = 2.0 * (a * b).sqrt();
    Some(RealFresnel {
        r_s: (a - b) * s,
        r_p: (c - d) * p,
        t_s: two_root_ab * s,
        t_p: two_root_ab * p,
        cos_theta_t: cos_t,
    })
}

/// Power-consistent transmission amplitudes `(t̃_s, t̃_p)` such that `|r|² + |t̃|² = 1` for
/// non-absorbing media: `t̃ = t · sqrt(Re(η₂ cos θ_t) / Re(η₁ cos θ_i))`. Zero under TIR.
pub fn power_consistent_transmission(
    eta_1: Complex64,
    eta_2: Complex64,
    cos_theta_i: f64,
    amps: &FresnelAmplitudes,
) -> (Complex64, Complex64) {
    if amps.total_internal_reflection {
        return (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
    }
    let num = (eta_2 * amps.cos_theta_t).re;
    let den = (eta_1 * cos_theta_i.clamp(0.0, 1.0)).re;
    if den <= 0.0 || num <= 0.0 {
        return (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
    }
    let f = (num / den).sqrt();
    (amps.t_s * f, amps.t_p * f)
}

/// Unpolarised Fresnel power reflectance for a real relative index `eta = η₂/η₁` at
/// incidence cosine `cos_theta_i` (1.0 under total internal reflection). This is the scalar
/// used by fibre models (hair, fur).
pub fn fresnel_reflectance_unpolarized(eta: f64, cos_theta_i: f64) -> f64 {
    let amps = fresnel_amplitudes_real(1.0, eta, cos_theta_i);
    if amps.total_internal_reflection {
        1.0
    } else {
        amps.reflectance_unpolarized()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form() {
        let n = 1.333;
        let a = fresnel_amplitudes_real(1.0, n, 1.0);
        let r = (1.0 - n) / (1.0 + n);
        assert!((a.r_s.re - r).abs() < 1e-14);
        // Born & Wolf sign: r_p = -r_s at normal incidence.
        assert!((a.r_p.re + r).abs() < 1e-14);
        assert!((a.t_s.re - 2.0 / (1.0 + n)).abs() < 1e-14);
    }

    #[test]
    fn real_path_agrees_with_the_complex_formulas() {
        // Both directions of the water interface, every incidence up to grazing, through the
        // critical angle (≈ 48.6° from inside), plus the critical angle itself.
        for (e1, e2) in [(1.0f64, 1.333), (1.333, 1.0), (1.0, 1.55), (1.55, 1.0)] {
            let critical_cos = (1.0 - (e2 / e1).powi(2)).max(0.0).sqrt();
            let cosines = (0..=2000).map(|i| i as f64 / 2000.0).chain([critical_cos]);
            for ci in cosines {
                let r = fresnel_amplitudes_real(e1, e2, ci);
                let c = fresnel_amplitudes(Complex64::new(e1, 0.0), Complex64::new(e2, 0.0), ci);
                assert_eq!(
                    r.total_internal_reflection, c.total_internal_reflection,
                    "{ci}"
                );
                for (x, y) in [
                    (r.r_s, c.r_s),
                    (r.r_p, c.r_p),
                    (r.t_s, c.t_s),
                    (r.t_p, c.t_p),
                    (r.cos_theta_t, c.cos_theta_t),
                ] {
                    assert!(
                        (x - y).norm() <= 1e-15 * (1.0 + y.norm()),
                        "{e1}->{e2} {ci}: {x} {y}"
                    );
                }
            }
        }
    }

    #[test]
    fn power_consistent_real_path_agrees_with_the_complex_formulas() {
        for (e1, e2) in [(1.0, 1.333), (1.333, 1.0), (1.0, 1.55), (1.55, 1.0)] {
            for i in 0..=2000 {
                let ci = i as f64 / 2000.0;
                let c = fresnel_amplitudes_real(e1, e2, ci);
                let r = fresnel_power_consistent_real(e1, e2, ci);
                assert_eq!(r.is_none(), c.total_internal_reflection, "{e1}->{e2} {ci}");
                let Some(r) = r else { continue };
                let (ts, tp) = power_consistent_transmission(
                    Complex64::new(e1, 0.0),
                    Complex64::new(e2, 0.0),
                    ci,
                    &c,
                );
                for (x, y) in [
                    (r.r_s, c.r_s),
                    (r.r_p, c.r_p),
                    (r.t_s, ts),
                    (r.t_p, tp),
                    (r.cos_theta_t, c.cos_theta_t),
                ] {
                    assert!(
                        (Complex64::new(x, 0.0) - y).norm() <= 1e-15 * (1.0 + y.norm()),
                        "{e1}->{e2} {ci}: {x} {y}"
                    );
                }
                // |r|² + |t̃|² = 1 for each polarisation.
                assert!((r.r_s * r.r_s + r.t_s * r.t_s - 1.0).abs() < 1e-14);
                assert!((r.r_p * r.r_p + r.t_p * r.t_p - 1.0).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn brewster_angle_zeroes_parallel_reflection() {
        let n: f64 = 1.5;
        let theta_b = n.atan();
        let a = fresnel_amplitudes_real(1.0, n, theta_b.cos());
        assert!(a.r_p.norm() < 1e-14);
    }

    #[test]
    fn energy_is_conserved_with_power_consistent_transmission() {
        for &(e1, e2) in &[(1.0, 1.333), (1.333, 1.0), (1.0, 1.55)] {
            for k in 0..=50 {
                let cos_i = k as f64 / 50.0;
                let c1 = Complex64::new(e1, 0.0);
                let c2 = Complex64::new(e2, 0.0);
                let a = fresnel_amplitudes(c1, c2, cos_i);
                let (ts, tp) = power_consistent_transmission(c1, c2, cos_i, &a);
                if cos_i > 0.0 {
                    assert!((a.r_s.norm_sqr() + ts.norm_sqr() - 1.0).abs() < 1e-12);
                    assert!((a.r_p.norm_sqr() + tp.norm_sqr() - 1.0).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn total_internal_reflection_has_unit_modulus_and_phase() {
        let n: f64 = 1.333;
        let critical = (1.0 / n).asin();
        let theta = critical + 0.2;
        let a = fresnel_amplitudes_real(n, 1.0, theta.cos());
        assert!(a.total_internal_reflection);
        assert!((a.r_s.norm() - 1.0).abs() < 1e-13);
        assert!((a.r_p.norm() - 1.0).abs() < 1e-13);
        assert!(a.r_s.im.abs() > 1e-3, "TIR must carry a phase");
        assert_eq!(fresnel_reflectance_unpolarized(1.0 / n, theta.cos()), 1.0);
    }

    #[test]
    fn stokes_relation_t12_t21_equals_one_minus_r_squared() {
        let n = 1.333;
        let theta_i: f64 = 0.7;
        let a12 = fresnel_amplitudes_real(1.0, n, theta_i.cos());
        let theta_t = a12.cos_theta_t.re.acos();
        let a21 = fresnel_amplitudes_real(n, 1.0, theta_t.cos());
        let lhs = a12.t_s * a21.t_s;
        assert!((lhs.re - (1.0 - a12.r_s.norm_sqr())).abs() < 1e-12);
        let lhs_p = a12.t_p * a21.t_p;
        assert!((lhs_p.re - (1.0 - a12.r_p.norm_sqr())).abs() < 1e-12);
    }

    #[test]
    fn absorbing_metal_reflectance_is_below_one() {
        let m = Complex64::new(0.2, 3.0);
        let a = fresnel_amplitudes(Complex64::new(1.0, 0.0), m, 0.8);
        assert!(a.reflectance_s() < 1.0 && a.reflectance_s() > 0.8);
        assert!(!a.total_internal_reflection);
    }
}
