//! Lorenz–Mie coefficients of a coated sphere (a core inside one concentric shell).
//!
//! Conventions as in [`crate::mie`] (Bohren & Huffman 1983): time dependence `e^{−iωt}`,
//! indices relative to the outside medium with `Im m ≥ 0` absorbing, size parameters
//! `x_c = 2π r_core/λ ≤ x = 2π r_shell/λ` (λ in the outside medium). The outside functions
//! `ψ_n(x)`, `ξ_n(x)` are those of the homogeneous sphere, so [`MieCoefficients`] (and with it
//! the efficiencies, [`crate::mie::Sphere`] and the angular kernel) is shared.
//!
//! # Algorithm (Toon & Ackerman 1981; in the recursive form of Yang 2003, as in Peña & Pal 2009)
//!
//! In the shell the radial function is `f = ψ_n(ρ) + c_n ζ_n(ρ)`, `ρ = m_s k r`, with
//! `ζ_n = ψ_n − iχ_n` (outgoing, `z h⁽¹⁾_n`). Matching log-derivatives at the core surface
//! (`H^a = D_n(m_c x_c)`, TM; `H^b` the same function, TE) and carrying them to the outer surface:
//!
//! ```text
//! z1 = m_s x_c, z2 = m_s x
//! G1 = m_s H^a − m_c D_n(z1),   G2 = m_s H^a − m_c D³_n(z1)
//! Ĝ1 = m_c H^b − m_s D_n(z1),   Ĝ2 = m_c H^b − m_s D³_n(z1)
//! Q_n = [ψ_n(z1)/ζ_n(z1)] / [ψ_n(z2)/ζ_n(z2)]
//! H^a(z2) = (G2 D_n(z2) − Q G1 D³_n(z2)) / (G2 − Q G1)     (and Ĝ for H^b)
//! a_n = ψ_n (H^a/m_s − D_n(x)) / ((H^a/m_s + n/x) ξ_n − ξ_{n−1}),   b_n with m_s H^b
//! ```
//! with `D_n = ψ_n'/ψ_n` (downward recurrence, [`super::riccati::log_derivative_complex`]),
//! `D³_n = ζ_n'/ζ_n = D_n + i/(ψ_n ζ_n)` (Wronskian `ψζ' − ψ'ζ = i`), the product
//! `ψ_n ζ_n = ψ_{n−1}ζ_{n−1} (n/z − D³_{n−1})/(D_n + n/z)` upward from
//! `ψ_0 ζ_0 = (1 − e^{2iz})/2`, and `Q_n = Q_{n−1} [(D³_n(z1) + n/z1)/(D_n(z1) + n/z1)]
//! / [(D³_n(z2) + n/z2)/(D_n(z2) + n/z2)]` upward from
//! `Q_0 = e^{2i(z2 − z1)} (1 − e^{2iz1})/(1 − e^{2iz2})`. Every exponential has a non-positive
//! real exponent for `Im m_s ≥ 0`, so nothing overflows for thick absorbing shells (`Q → 0`,
//! the core disappears from view, as it must).
//!
//! Limits: equal indices give `G1 = Ĝ1 = 0` and the homogeneous sphere exactly; a vanishing
//! core gives `Q → 0` and the homogeneous shell-material sphere.
//!
//! Validated domain ([`COATED_VALIDATED_DOMAIN`], checked by [`coated_coefficients`]): both
//! indices and the outer size parameter inside [`super::VALIDATED_DOMAIN`]'s index and size
//! bounds with `x ≤ 10⁴` and `|m| x ≤ 10⁵` for both materials, `0 ≤ x_c ≤ x`. Evidence in
//! `docs/mie.md` (scattnlay and an independent 40-digit implementation, `tests/mie_coated.rs`).

use super::coefficients::MieCoefficients;
use super::riccati::{RiccatiBessel, log_derivative_complex, n_stop_default};
use super::{MieError, ValidatedDomain};
use num_complex::Complex64;

/// Inputs for which the coated-sphere solution is validated (applied to the outer size
/// parameter with each of the two indices).
pub const COATED_VALIDATED_DOMAIN: ValidatedDomain = ValidatedDomain {
    x_min: 1e-3,
    x_max: 1e4,
    m_re_min: 0.05,
    m_re_max: 10.0,
    m_im_max: 10.0,
    mx_max: 1e5,
    m_minus_one_min: 0.0,
};

/// Errors specific to a coated sphere.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CoatedError {
    #[error("core size parameter x_c = {core} must satisfy 0 <= x_c <= x = {shell}")]
    CoreLargerThanShell { core: f64, shell: f64 },
    #[error("core index: {0}")]
    Core(MieError),
    #[error("shell index: {0}")]
    Shell(MieError),
}

/// A coated sphere: core and shell size parameters and relative indices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoatedSphere {
    /// Core size parameter `2π r_core/λ`.
    pub core_size_parameter: f64,
    /// Outer (shell) size parameter `2π r_shell/λ`.
    pub size_parameter: f64,
    /// Core index relative to the outside medium.
    pub core_index: Complex64,
    /// Shell index relative to the outside medium.
    pub shell_index: Complex64,
}

impl CoatedSphere {
    /// Checks the sphere against [`COATED_VALIDATED_DOMAIN`] and `0 ≤ x_c ≤ x`.
    pub fn check(&self) -> Result<(), CoatedError> {
        let (xc, x) = (self.core_size_parameter, self.size_parameter);
        if !(0.0..=x).contains(&xc) {
            return Err(CoatedError::CoreLargerThanShell { core: xc, shell: x });
        }
        COATED_VALIDATED_DOMAIN
            .check(x, self.shell_index)
            .map_err(CoatedError::Shell)?;
        COATED_VALIDATED_DOMAIN
            .check(x, self.core_index)
            .map_err(CoatedError::Core)?;
        Ok(())
    }
}

/// `a_n`, `b_n` (`n = 1..=n_stop_default(x)`) of a coated sphere, domain-checked.
///
/// The returned [`MieCoefficients`] carries the shell index in `m` and the outer size
/// parameter; its `efficiencies()` (including `Q_abs` of core and shell together) and the
/// angular series apply unchanged.
pub fn coated_coefficients(sphere: &CoatedSphere) -> Result<MieCoefficients, CoatedError> {
    sphere.check()?;
    Ok(coated_with_order(
        sphere,
        n_stop_default(sphere.size_parameter),
    ))
}

/// `e^w − 1` without cancellation for small `|w|`.
fn exp_m1(w: Complex64) -> Complex64 {
    let (s, c) = w.im.sin_cos();
    let half = (0.5 * w.im).sin();
    let em1 = w.re.exp_m1();
    // e^{a+ib} − 1 = (e^a − 1) e^{ib} + (cos b − 1) + i sin b, cos b − 1 = −2 sin²(b/2)
    Complex64::new(em1 * c - 2.0 * half * half, em1 * s + s)
}

/// `D³_n(z) = ζ_n'/ζ_n` for `n = 0..=n_max` from the downward `D_n(z)` (`d1`), through the
/// product `P_n = ψ_n ζ_n` (module doc), carried upward as
/// `P_n = P_{n−1} (n/z − D³_{n−1}) / (D_n + n/z)`: both factors are free of cancellation
/// (`ψ_n/ψ_{n−1} = 1/(D_n + n/z)`; `ζ` is the dominant solution upward), also for small `|z|`.
fn xi_log_derivative(z: Complex64, d1: &[Complex64], out: &mut Vec<Complex64>) {
    let i = Complex64::new(0.0, 1.0);
    out.clear();
    out.reserve(d1.len());
    // ψ_0 ζ_0 = (1 − e^{2iz})/2
    let mut p = -0.5 * exp_m1(2.0 * i * z);
    out.push(d1[0] + i / p);
    let inv_z = 1.0 / z;
    #[allow(clippy::needless_range_loop)] // n is the order and indexes two arrays
    for n in 1..d1.len() {
        let nz = inv_z * n as f64;
        p *= (nz - out[n - 1]) / (d1[n] + nz);
        out.push(d1[n] + i / p);
    }
}

/// As [`coated_coefficients`] with an explicit truncation order and no domain check (for
/// convergence studies). `x_c = 0` gives the homogeneous shell-material sphere.
pub fn coated_with_order(sphere: &CoatedSphere, n_stop: usize) -> MieCoefficients {
    let (xc, x) = (sphere.core_size_parameter, sphere.size_parameter);
    let (mc, ms) = (sphere.core_index, sphere.shell_index);
    if xc <= 0.0 {
        return MieCoefficients::with_order(x, ms, n_stop);
    }
    let i = Complex64::new(0.0, 1.0);
    let (z1, z2) = (ms * xc, ms * x);
    let (mut d_core, mut d1_z1, mut d1_z2) = (Vec::new(), Vec::new(), Vec::new());
    log_derivative_complex(mc * xc, n_stop, &mut d_core);
    log_derivative_complex(z1, n_stop, &mut d1_z1);
    log_derivative_complex(z2, n_stop, &mut d1_z2);
    let (mut d3_z1, mut d3_z2) = (Vec::new(), Vec::new());
    xi_log_derivative(z1, &d1_z1, &mut d3_z1);
    xi_log_derivative(z2, &d1_z2, &mut d3_z2);
    // Q_0 = e^{2i(z2 − z1)} (1 − e^{2i z1})/(1 − e^{2i z2})
    let mut q = (2.0 * i * (z2 - z1)).exp() * exp_m1(2.0 * i * z1) / exp_m1(2.0 * i * z2);
    let rb = RiccatiBessel::new(x, n_stop);
    let mut ha = Vec::with_capacity(n_stop);
    let mut hb = Vec::with_capacity(n_stop);
    let (inv_z1, inv_z2) = (1.0 / z1, 1.0 / z2);
    #[allow(clippy::needless_range_loop)] // n is the order and indexes five arrays
    for n in 1..=n_stop {
        let nf = n as f64;
        let r1 = (d3_z1[n] + nf * inv_z1) / (d1_z1[n] + nf * inv_z1);
        let r2 = (d3_z2[n] + nf * inv_z2) / (d1_z2[n] + nf * inv_z2);
        q *= r1 / r2;
        let h = d_core[n];
        let g1 = ms * h - mc * d1_z1[n];
        let g2 = ms * h - mc * d3_z1[n];
        let gh1 = mc * h - ms * d1_z1[n];
        let gh2 = mc * h - ms * d3_z1[n];
        ha.push((g2 * d1_z2[n] - q * g1 * d3_z2[n]) / (g2 - q * g1));
        hb.push((gh2 * d1_z2[n] - q * gh1 * d3_z2[n]) / (gh2 - q * gh1));
    }
    MieCoefficients::from_log_derivatives(&rb, ms, &ha, &hb)
}
