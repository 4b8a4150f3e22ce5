//! Legendre moments of a tabulated phase function, the form radiative-transfer codes (DISORT,
//! libRadtran) and spherical-harmonics renderers use.
//!
//! Convention: with μ = cos θ and p normalised so that ∫_{4π} p dΩ = 1,
//!
//! ```text
//! χ_l = 2π ∫_{-1}^{1} p(μ) P_l(μ) dμ,          χ_0 = 1, χ_1 = g (asymmetry parameter),
//! p_L(μ) = Σ_{l=0}^{L} (2l + 1)/(4π) · χ_l · P_l(μ).
//! ```
//!
//! For Henyey–Greenstein, χ_l = g^l exactly. The table is interpreted with its lookup formula
//! (linear in θ between stored angles), and each angle cell is integrated with Gauss–Legendre
//! quadrature of enough nodes for the highest order, so the moments are those of the
//! piecewise-linear function the table defines (no extra discretisation beyond the table's).
//!
//! Truncation error (what the reported numbers mean), evaluated at the stored angles θ_j:
//! - `max_rel_error = max_j |p_L(θ_j) − p(θ_j)| / p(θ_j)`;
//! - `l1_error = 2π ∫ |p_L − p| sin θ dθ` (trapezoid rule on the stored grid): the fraction of
//!   scattered power the truncated series misplaces.
//!
//! **Delta-M** (Wiscombe 1977, `--delta-m`), the truncation radiative-transfer codes use for
//! strongly forward-peaked functions such as raindrops: with `f = χ_{L+1}` the forward-peak
//! fraction, `p ≈ f·δ(1 − μ)/(2π) + (1 − f)·p*_L` with `χ*_l = (χ_l − f)/(1 − f)`. The errors
//! of `(1 − f)·p*_L` are reported over θ ≥ `--error-from-deg` (default 5° with delta-M: the δ
//! replaces the peak, so the error inside it is not meaningful), and `f` is printed (the
//! power the δ carries: scale the scattering coefficient by 1 − f, as DISORT does).

use crate::consumers::ConsumerError;
use crate::math::quadrature::gauss_legendre;
use std::f64::consts::PI;

/// P_0..P_L at `x` by the three-term recurrence.
pub fn legendre_polynomials(order: usize, x: f64, out: &mut Vec<f64>) {
    out.clear();
    out.push(1.0);
    if order == 0 {
        return;
    }
    out.push(x);
    for l in 1..order {
        let lf = l as f64;
        let next = ((2.0 * lf + 1.0) * x * out[l] - lf * out[l - 1]) / (lf + 1.0);
        out.push(next);
    }
}

/// Legendre moments χ_0..χ_L of the piecewise-linear-in-θ phase function given at
/// `angles_deg` (strictly increasing, covering [0, 180]).
pub fn moments(angles_deg: &[f64], phase: &[f64], order: usize) -> Vec<f64> {
    assert_eq!(angles_deg.len(), phase.len());
    let mut chi = vec![0.0; order + 1];
    let mut pl = Vec::with_capacity(order + 1);
    for j in 1..angles_deg.len() {
        let (a, b) = (angles_deg[j - 1].to_radians(), angles_deg[j].to_radians());
        let h = b - a;
        // P_l(cos θ) oscillates with ~ l·h/π half-periods per cell; polynomial degree of the
        // integrand grows accordingly.
        let nq = 6 + ((order as f64 * h) * 1.5).ceil() as usize;
        let (x, w) = gauss_legendre(nq);
        for (xi, wi) in x.iter().zip(&w) {
            let t = 0.5 * (xi + 1.0);
            let theta = a + t * h;
            let p = phase[j - 1] * (1.0 - t) + phase[j] * t;
            let weight = 2.0 * PI * p * theta.sin() * 0.5 * h * wi;
            legendre_polynomials(order, theta.cos(), &mut pl);
            for l in 0..=order {
                chi[l] += weight * pl[l];
            }
        }
    }
    chi
}

/// Evaluate the truncated expansion p_L at `cos_theta`.
pub fn reconstruct(chi: &[f64], cos_theta: f64) -> f64 {
    let mut pl = Vec::with_capacity(chi.len());
    legendre_polynomials(chi.len() - 1, cos_theta, &mut pl);
    chi.iter()
        .zip(&pl)
        .enumerate()
        .map(|(l, (c, p))| (2.0 * l as f64 + 1.0) / (4.0 * PI) * c * p)
        .sum()
}

/// Truncation error of a moment set against the tabulated function (see module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruncationError {
    pub max_rel_error: f64,
    /// Angle (deg) where the relative error is largest.
    pub max_rel_error_at_deg: f64,
    pub l1_error: f64,
}

/// Truncation error of `chi` against the stored samples.
pub fn truncation_error(angles_deg: &[f64], phase: &[f64], chi: &[f64]) -> TruncationError {
    truncation_error_from(angles_deg, phase, chi, 1.0, 0.0)
}

/// Delta-M truncation of a moment set (see module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaM {
    /// Forward-peak fraction f = χ_{L+1}.
    pub f: f64,
    /// χ*_0..χ*_L = (χ_l − f)/(1 − f).
    pub chi_star: Vec<f64>,
}

/// Delta-M moments of order L from the full moments `chi` = χ_0..χ_{L+1}.
pub fn delta_m(chi: &[f64]) -> Result<DeltaM, ConsumerError> {
    if chi.len() < 2 {
        return Err(ConsumerError::invalid("delta-M needs moments up to L + 1"));
    }
    let l = chi.len() - 2;
    let f = chi[l + 1];
    if !(f < 1.0 - 1e-12) {
        return Err(ConsumerError::invalid(format!(
            "delta-M: f = chi_{} = {f} is not below 1",
            l + 1
        )));
    }
    Ok(DeltaM {
        f,
        chi_star: chi[..=l].iter().map(|c| (c - f) / (1.0 - f)).collect(),
    })
}

/// Truncation error of `scale · p_L` (p_L from `chi`) against the stored samples at angles
/// ≥ `from_deg` (`scale` = 1 − f for delta-M).
pub fn truncation_error_from(
    angles_deg: &[f64],
    phase: &[f64],
    chi: &[f64],
    scale: f64,
    from_deg: f64,
) -> TruncationError {
    let mut max_rel = 0.0;
    let mut at = 0.0;
    let diff: Vec<f64> = angles_deg
        .iter()
        .zip(phase)
        .map(|(&t, &p)| {
            if t < from_deg {
                return 0.0;
            }
            let r = scale * reconstruct(chi, t.to_radians().cos());
            let d = (r - p).abs();
            let rel = if p > 0.0 { d / p } else { f64::INFINITY };
            if rel > max_rel {
                max_rel = rel;
                at = t;
            }
            d
        })
        .collect();
    let mut l1 = 0.0;
    for j in 1..angles_deg.len() {
        let (a, b) = (angles_deg[j - 1].to_radians(), angles_deg[j].to_radians());
        l1 += 0.5 * (diff[j - 1] * a.sin() + diff[j] * b.sin()) * (b - a);
    }
    TruncationError {
        max_rel_error: max_rel,
        max_rel_error_at_deg: at,
        l1_error: 2.0 * PI * l1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::henyey_greenstein::hg_density_sr;

    fn hg_grid(g: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
        let step = 180.0 / (n - 1) as f64;
        let a: Vec<f64> = (0..n).map(|j| j as f64 * step).collect();
        let p = a
            .iter()
            .map(|t: &f64| hg_density_sr(t.to_radians().cos(), g))
            .collect();
        (a, p)
    }

    #[test]
    fn henyey_greenstein_moments_are_powers_of_g() {
        // 0.02° grid: linear interpolation error of HG(0.7) is ~ h²p''/8 ≲ 1e-5 relative.
        for &g in &[0.0, 0.3, 0.7, -0.4] {
            let (a, p) = hg_grid(g, 9001);
            let chi = moments(&a, &p, 60);
            for (l, c) in chi.iter().enumerate() {
                let exact = g.powi(l as i32);
                assert!((c - exact).abs() < 2e-5, "g={g} l={l}: {c} vs {exact}");
            }
        }
    }

    #[test]
    fn truncated_series_error_shrinks_with_order_and_matches_reconstruction() {
        let (a, p) = hg_grid(0.5, 1801);
        let e8 = truncation_error(&a, &p, &moments(&a, &p, 8));
        let e32 = truncation_error(&a, &p, &moments(&a, &p, 32));
        // The error of the truncated HG series is known analytically: p − p_L =
        // Σ_{l>L} (2l+1)/(4π) g^l P_l(μ); at μ = −1 (where p is smallest) P_l = (−1)^l.
        let tail: f64 = (9..400)
            .map(|l| (2 * l + 1) as f64 / (4.0 * PI) * 0.5f64.powi(l) * (-1f64).powi(l))
            .sum();
        let expected_rel = tail.abs() / hg_density_sr(-1.0, 0.5);
        assert_eq!(e8.max_rel_error_at_deg, 180.0, "{e8:?}");
        assert!(
            (e8.max_rel_error - expected_rel).abs() < 1e-4,
            "{e8:?} vs analytic {expected_rel}"
        );
        assert!(e32.max_rel_error < 1e-5, "{e32:?}");
        assert!(e8.l1_error > e32.l1_error * 100.0);
    }

    /// Delta-M of HG: χ*_l = (g^l − g^(L+1))/(1 − g^(L+1)) (from the exact χ_l = g^l), and
    /// away from the forward peak (θ ≥ 20°) the delta-M series of order 16 is closer to HG(0.9)
    /// than the plain truncation of the same order.
    #[test]
    fn delta_m_of_henyey_greenstein() {
        let g: f64 = 0.9;
        let (a, p) = hg_grid(g, 18001);
        let full = moments(&a, &p, 17);
        let d = delta_m(&full).unwrap();
        let f = g.powi(17);
        assert!((d.f - f).abs() < 1e-4, "f {} vs {f}", d.f);
        for (l, c) in d.chi_star.iter().enumerate() {
            let exact = (g.powi(l as i32) - f) / (1.0 - f);
            assert!((c - exact).abs() < 2e-4, "l={l}: {c} vs {exact}");
        }
        let plain = truncation_error_from(&a, &p, &full[..=16], 1.0, 20.0);
        let dm = truncation_error_from(&a, &p, &d.chi_star, 1.0 - d.f, 20.0);
        assert!(
            dm.max_rel_error < 0.5 * plain.max_rel_error,
            "delta-M {dm:?} vs plain {plain:?}"
        );
        assert!(delta_m(&[1.0, 1.0]).is_err());
    }

    #[test]
    fn legendre_recurrence_known_values() {
        let mut p = vec![];
        legendre_polynomials(4, 0.5, &mut p);
        // P2(0.5) = -0.125, P3(0.5) = -0.4375, P4(0.5) = -0.2890625.
        assert!((p[2] + 0.125).abs() < 1e-15);
        assert!((p[3] + 0.4375).abs() < 1e-15);
        assert!((p[4] + 0.2890625).abs() < 1e-15);
    }
}
