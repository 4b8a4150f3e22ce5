//! Mie coefficients `a_n`, `b_n` of a homogeneous sphere and the efficiencies derived from them.
//!
//! Bohren & Huffman (1983) Eq. 4.88, rewritten with `ψ_{n−1} = ψ_n (D_n(x) + n/x)` so that the
//! numerators carry no cancellation for small `x`:
//!
//! ```text
//! a_n = ψ_n (D_n(mx)/m − D_n(x)) / ((D_n(mx)/m + n/x) ξ_n − ξ_{n−1})
//! b_n = ψ_n (m D_n(mx) − D_n(x)) / ((m D_n(mx) + n/x) ξ_n − ξ_{n−1})
//! ```
//!
//! Efficiencies (cross-sections over `π r²`):
//! - `Q_sca = (2/x²) Σ (2n+1)(|a_n|² + |b_n|²)`;
//! - `Q_abs = (2/x²) Σ (2n+1)(Re a_n − |a_n|² + Re b_n − |b_n|²)`, each bracket from the exact
//!   identity `Re a_n − |a_n|² = −Im(D_n(mx)/m)/|den_a|²` (and `−Im(m D_n(mx))/|den_b|²`),
//!   which follows from the Wronskian `ψ_{n−1}χ_n − ψ_nχ_{n−1} = 1`. It is exactly 0 for real
//!   `m` and accurate relative to itself for weak absorption;
//! - `Q_ext = Q_sca + Q_abs` (the optical-theorem sum `(2/x²) Σ (2n+1) Re(a_n + b_n)` is kept as
//!   [`Efficiencies::q_ext_series`] for consistency checks);
//! - `Q_back = |Σ (2n+1)(−1)^n (a_n − b_n)|²/x²` (radar convention, `= 4|S_1(180°)|²/x²`;
//!   the per-steradian value of MiePlot is `Q_back/(4π)`, [`Efficiencies::q_back_per_sr`]);
//! - `g = (4/(x² Q_sca)) Σ [n(n+2)/(n+1) Re(a_n a*_{n+1} + b_n b*_{n+1})
//!   + (2n+1)/(n(n+1)) Re(a_n b*_n)]`.

use super::domain::{MieError, check_domain};
use super::riccati::{RiccatiBessel, log_derivative_complex, n_stop_default};
use num_complex::Complex64;

/// Mie coefficients of one sphere.
#[derive(Debug, Clone)]
pub struct MieCoefficients {
    /// Size parameter `x = 2π r / λ` (λ in the outside medium).
    pub size_parameter: f64,
    /// Relative refractive index `m = n + i k`, `k ≥ 0`.
    pub m: Complex64,
    /// `a_n` for `n = 1..=n_stop` (`a[0]` is `a_1`).
    pub a: Vec<Complex64>,
    /// `b_n` for `n = 1..=n_stop` (`b[0]` is `b_1`).
    pub b: Vec<Complex64>,
    /// `(2/x²) Σ (2n+1)(Re a_n − |a_n|² + Re b_n − |b_n|²)`: the absorption efficiency.
    q_abs: f64,
}

/// Efficiencies and asymmetry parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Efficiencies {
    /// Extinction efficiency `Q_sca + Q_abs`.
    pub q_ext: f64,
    /// Scattering efficiency.
    pub q_sca: f64,
    /// Absorption efficiency (exactly 0 for real `m`).
    pub q_abs: f64,
    /// Backscattering efficiency in the radar convention, `4π (dC_sca/dΩ)(180°)/(π r²) =
    /// 4|S_1(180°)|²/x²` (see [`Efficiencies::q_back_per_sr`] for MiePlot's, `4π` smaller).
    pub q_back: f64,
    /// Asymmetry parameter `⟨cos θ⟩`.
    pub g: f64,
    /// Optical-theorem series `(2/x²) Σ (2n+1) Re(a_n + b_n)` (equals `q_ext` analytically).
    pub q_ext_series: f64,
}

impl Efficiencies {
    /// Backscattering per steradian (MiePlot's convention): `Q_back/(4π) = |S_1(180°)|²/(π x²)`.
    /// [`Efficiencies::q_back`] is the radar convention, `4π` larger.
    pub fn q_back_per_sr(&self) -> f64 {
        self.q_back / (4.0 * std::f64::consts::PI)
    }
}

impl MieCoefficients {
    /// Computes `a_n`, `b_n` for `n = 1..=n_stop_default(x)` at size parameter `x` and relative
    /// index `m`, refusing inputs outside [`super::VALIDATED_DOMAIN`].
    pub fn new(size_parameter: f64, m: Complex64) -> Result<Self, MieError> {
        check_domain(size_parameter, m)?;
        Ok(Self::with_order(
            size_parameter,
            m,
            n_stop_default(size_parameter),
        ))
    }

    /// As [`MieCoefficients::new`] with an explicit truncation order `n_stop` and no domain check
    /// (for convergence studies; `x > 0` and `m ≠ 0` are still required by the maths).
    ///
    /// The numerators use `D_n(z) = (n+1)/z − r_n(z)`, `r_n = ψ_{n+1}/ψ_n =
    /// 1/(D_{n+1}(z) + (n+1)/z)`:
    /// `D_n(mx)/m − D_n(x) = (n+1)(1 − m²)/(m² x) + r_n(x) − r_n(mx)/m` and
    /// `m D_n(mx) − D_n(x) = r_n(x) − m r_n(mx)`, which removes the cancellation of the
    /// `(n+1)/x` poles when `|m x|` is small (the `b_n` numerator is `O(x)` while each term is
    /// `O(n/x)`: 2.7e-6 relative error in `S_2(90°)` at x = 1e-3, m = 0.982 with the direct
    /// difference, 1e-15 with this one) and evaluates `1 − m²` exactly as `(1 − m)(1 + m)`.
    pub fn with_order(x: f64, m: Complex64, n_stop: usize) -> Self {
        let rb = RiccatiBessel::new(x, n_stop + 1);
        let mut dz = Vec::new();
        log_derivative_complex(m * x, n_stop + 1, &mut dz);
        let inv_x = 1.0 / x;
        let inv_mx = 1.0 / (m * x);
        let one_minus_m2_over_m2x = (1.0 - m) * (1.0 + m) / (m * m) * inv_x;
        let inv_m = 1.0 / m;
        Self::assemble(&rb, m, &dz[1..=n_stop], &dz[1..=n_stop], |n| {
            let n1 = (n + 1) as f64;
            let psi = rb.psi[n];
            let r_mx = 1.0 / (dz[n + 1] + n1 * inv_mx);
            let t_x = rb.log_derivative[n + 1] + n1 * inv_x;
            if (rb.log_derivative[n + 1].abs() + n1 * inv_x) <= 100.0 * t_x.abs() {
                // r_n(x) and r_n(mx) come from the same recurrence, so their difference keeps
                // its accuracy as m → 1.
                let r_x = 1.0 / t_x;
                (
                    psi * (n1 * one_minus_m2_over_m2x + r_x - r_mx * inv_m),
                    psi * (r_x - m * r_mx),
                )
            } else {
                // ψ_n near a zero: r_n(x) = ψ_{n+1}/ψ_n is a large quotient of a small
                // difference; ψ_n r_n(x) = ψ_{n+1} is taken directly.
                (
                    psi * (n1 * one_minus_m2_over_m2x - r_mx * inv_m) + rb.psi[n + 1],
                    rb.psi[n + 1] - m * r_mx * psi,
                )
            }
        })
    }

    /// Coefficients from the log-derivatives `H^a_n`, `H^b_n` (`n = 1..=n_stop`, index 0 is
    /// `n = 1`) of the inside field at the surface, in the inside argument `m x`:
    /// `a_n = ψ_n (H^a_n/m − D_n(x)) / ((H^a_n/m + n/x) ξ_n − ξ_{n−1})`,
    /// `b_n = ψ_n (m H^b_n − D_n(x)) / ((m H^b_n + n/x) ξ_n − ξ_{n−1})`.
    /// A homogeneous sphere has `H^a_n = H^b_n = D_n(m x)`; a coated one the values carried
    /// through its shell ([`super::coated`]). `outside` holds `ψ_n`, `χ_n`, `D_n` at `x` for
    /// `n = 0..=n_stop` (or more). The `Q_abs` identity of the module doc holds for any `H`.
    pub fn from_log_derivatives(
        outside: &RiccatiBessel,
        m: Complex64,
        ha: &[Complex64],
        hb: &[Complex64],
    ) -> Self {
        let inv_m = 1.0 / m;
        let inv_x = 1.0 / outside.x;
        Self::assemble(outside, m, ha, hb, |n| {
            // ψ_n D_n(x) = ψ_n' = ψ_{n−1} − (n/x) ψ_n (no D_n(x), large near zeros of ψ_n).
            let psi = outside.psi[n];
            let dpsi = outside.psi_prev(n) - n as f64 * inv_x * psi;
            (ha[n - 1] * inv_m * psi - dpsi, hb[n - 1] * m * psi - dpsi)
        })
    }

    /// Shared assembly; `numerators(n)` returns `ψ_n (H^a_n/m − D_n(x))` and
    /// `ψ_n (m H^b_n − D_n(x))`.
    fn assemble(
        rb: &RiccatiBessel,
        m: Complex64,
        ha: &[Complex64],
        hb: &[Complex64],
        numerators: impl Fn(usize) -> (Complex64, Complex64),
    ) -> Self {
        let x = rb.x;
        let n_stop = ha.len();
        debug_assert_eq!(hb.len(), n_stop);
        debug_assert!(rb.psi.len() > n_stop);
        let mut a = Vec::with_capacity(n_stop);
        let mut b = Vec::with_capacity(n_stop);
        let mut q_abs = 0.0;
        let inv_x = 1.0 / x;
        let inv_m = 1.0 / m;
        #[allow(clippy::needless_range_loop)] // n indexes several arrays and is the order
        for n in 1..=n_stop {
            let nx = n as f64 * inv_x;
            let xi = rb.xi(n);
            let xi_prev = Complex64::new(rb.psi_prev(n), -rb.chi_prev(n));
            let d_over_m = ha[n - 1] * inv_m;
            let m_d = hb[n - 1] * m;
            let den_a = (d_over_m + nx) * xi - xi_prev;
            let den_b = (m_d + nx) * xi - xi_prev;
            let (num_a, num_b) = numerators(n);
            let an = num_a / den_a;
            let bn = num_b / den_b;
            a.push(an);
            b.push(bn);
            q_abs -=
                (2 * n + 1) as f64 * (d_over_m.im / den_a.norm_sqr() + m_d.im / den_b.norm_sqr());
        }
        q_abs *= 2.0 * inv_x * inv_x;
        MieCoefficients {
            size_parameter: x,
            m,
            a,
            b,
            q_abs,
        }
    }

    /// Truncation order (number of terms).
    pub fn n_stop(&self) -> usize {
        self.a.len()
    }

    /// Efficiencies and asymmetry parameter from the coefficient sums.
    pub fn efficiencies(&self) -> Efficiencies {
        let x2 = self.size_parameter * self.size_parameter;
        let (mut sca, mut ext, mut g) = (0.0, 0.0, 0.0);
        let mut back = Complex64::new(0.0, 0.0);
        let n_stop = self.n_stop();
        for i in 0..n_stop {
            let n = (i + 1) as f64;
            let (an, bn) = (self.a[i], self.b[i]);
            let w = 2.0 * n + 1.0;
            sca += w * (an.norm_sqr() + bn.norm_sqr());
            ext += w * (an.re + bn.re);
            let sign = if (i + 1) % 2 == 0 { 1.0 } else { -1.0 };
            back += (an - bn) * (w * sign);
            g += w / (n * (n + 1.0)) * (an * bn.conj()).re;
            if i + 1 < n_stop {
                let (an1, bn1) = (self.a[i + 1], self.b[i + 1]);
                g += n * (n + 2.0) / (n + 1.0) * ((an * an1.conj()).re + (bn * bn1.conj()).re);
            }
        }
        let q_sca = 2.0 * sca / x2;
        let g = if q_sca > 0.0 {
            4.0 * g / (x2 * q_sca)
        } else {
            0.0
        };
        Efficiencies {
            q_ext: q_sca + self.q_abs,
            q_sca,
            q_abs: self.q_abs,
            q_back: back.norm_sqr() / x2,
            g,
            q_ext_series: 2.0 * ext / x2,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bohren & Huffman (1983) Appendix A test case, x = 5.2128, m = 1.55: Q_sca = 3.10543 and
    /// Q_back = 2.92534 (also reproduced by miepython 3.3.0). BH printed these from a
    /// single-precision program; we agree to 1.4e-5 and 4.3e-5 relative (and with scatrs to 1e-12).
    #[test]
    fn bohren_huffman_test_case() {
        let c = MieCoefficients::new(5.2128, Complex64::new(1.55, 0.0)).unwrap();
        let e = c.efficiencies();
        assert!(
            ((e.q_sca - 3.10543) / 3.10543).abs() < 5e-5,
            "Q_sca = {}",
            e.q_sca
        );
        assert!(
            ((e.q_back - 2.92534) / 2.92534).abs() < 5e-5,
            "Q_back = {}",
            e.q_back
        );
        assert_eq!(e.q_abs, 0.0);
        assert!((e.q_ext - e.q_ext_series).abs() < 1e-13);
    }

    /// Rayleigh limit x = 1e-3: Q_sca = 8/3 x⁴ |(m²−1)/(m²+2)|² (1 + O(x²)),
    /// Q_abs = 4x Im((m²−1)/(m²+2)) (1 + O(x²)).
    #[test]
    fn rayleigh_limit() {
        let x = 1e-3;
        for m in [
            Complex64::new(1.333, 0.0),
            Complex64::new(1.5, 0.1),
            Complex64::new(2.0, 1.0),
        ] {
            let e = MieCoefficients::new(x, m).unwrap().efficiencies();
            let pol = (m * m - 1.0) / (m * m + 2.0);
            let q_sca = 8.0 / 3.0 * x.powi(4) * pol.norm_sqr();
            assert!(
                ((e.q_sca - q_sca) / q_sca).abs() < 1e-5,
                "m={m} {} vs {q_sca}",
                e.q_sca
            );
            let q_abs = 4.0 * x * pol.im;
            if q_abs > 0.0 {
                assert!(((e.q_abs - q_abs) / q_abs).abs() < 1e-5);
            } else {
                assert_eq!(e.q_abs, 0.0);
            }
            // Rayleigh: g → 0 (it is O(x²)).
            assert!(e.g.abs() < 1e-5);
        }
    }

    /// Size parameters at multiples of π (ψ_0 = sin x ≈ 0 there) against the 40-digit
    /// evaluation of `tests/data/mie_wide_reference.py` (`mie_mpmath`, x the f64 value of kπ):
    /// before the ψ_n fix x = 5π gave Q_ext = 10.18.
    #[test]
    fn multiples_of_pi() {
        let pi = std::f64::consts::PI;
        let m = Complex64::new(1.2, 0.008);
        for (x, reference) in [
            (
                pi,
                [
                    0.7746512788767365,
                    0.6914075063661926,
                    0.019177973646263908,
                    0.8079309680205506,
                ],
            ),
            (
                2.0 * pi,
                [
                    2.4836957160209194,
                    2.3142072386891646,
                    0.061978493512926745,
                    0.9175921171734479,
                ],
            ),
            (
                5.0 * pi,
                [
                    2.295614942870707,
                    1.9114029146989053,
                    0.021897429767055828,
                    0.8835029292017205,
                ],
            ),
        ] {
            let e = MieCoefficients::new(x, m).unwrap().efficiencies();
            for (got, want) in [e.q_ext, e.q_sca, e.q_back, e.g].iter().zip(reference) {
                assert!(
                    ((got - want) / want).abs() < 1e-12,
                    "x = {x}: {got} vs {want}"
                );
            }
            let near = MieCoefficients::new(x * (1.0 + 1e-12), m)
                .unwrap()
                .efficiencies();
            assert!(((near.q_ext - e.q_ext) / e.q_ext).abs() < 1e-10, "x = {x}");
        }
    }
}
