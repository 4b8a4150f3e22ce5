//! The validated domain of the Lorenz–Mie code: where its accuracy is established against
//! independent references (see the module documentation of [`crate::mie`] and docs/mie.md), and
//! the errors for what lies outside.

use num_complex::Complex64;

/// A region of (size parameter, relative index) whose accuracy is validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidatedDomain {
    /// Smallest size parameter `x`.
    pub x_min: f64,
    /// Largest size parameter `x`.
    pub x_max: f64,
    /// Smallest `Re m`.
    pub m_re_min: f64,
    /// Largest `Re m`.
    pub m_re_max: f64,
    /// Largest `Im m` (the smallest is 0: no gain media).
    pub m_im_max: f64,
    /// Largest inside size parameter `|m| x`.
    pub mx_max: f64,
    /// Smallest `|m − 1|` (a nearly index-matched sphere hardly scatters: its coefficients are
    /// `∝ m − 1` and the phase function, `s11/(π x² Q_sca)`, is 0/0 at `m = 1`).
    pub m_minus_one_min: f64,
}

impl ValidatedDomain {
    /// Checks `(x, m)` against this region.
    pub fn check(&self, x: f64, m: Complex64) -> Result<(), MieError> {
        if !(self.x_min..=self.x_max).contains(&x) {
            return Err(MieError::SizeParameterOutOfDomain {
                x,
                min: self.x_min,
                max: self.x_max,
            });
        }
        if !(self.m_re_min..=self.m_re_max).contains(&m.re)
            || !(0.0..=self.m_im_max).contains(&m.im)
        {
            return Err(MieError::IndexOutOfDomain {
                re: m.re,
                im: m.im,
                re_min: self.m_re_min,
                re_max: self.m_re_max,
                im_max: self.m_im_max,
            });
        }
        if !((m - 1.0).norm() >= self.m_minus_one_min) {
            return Err(MieError::NearlyMatchedIndex {
                re: m.re,
                im: m.im,
                min: self.m_minus_one_min,
            });
        }
        let mx = m.norm() * x;
        if !(mx <= self.mx_max) {
            return Err(MieError::InsideSizeOutOfDomain {
                x,
                m_abs: m.norm(),
                max: self.mx_max,
            });
        }
        Ok(())
    }
}

/// The validated domain of the homogeneous-sphere solution: `10⁻³ ≤ x ≤ 10⁵`,
/// `0.05 ≤ Re m ≤ 10`, `0 ≤ Im m ≤ 10`, `|m − 1| ≥ 10⁻⁵`, `|m| x ≤ 1.5·10⁵`.
///
/// Upper x: a 5 mm drop at 380 nm has x ≈ 8.3·10⁴. `|m| x ≤ 1.5·10⁵` is the largest inside size
/// parameter of the 40-digit references (m = 10 + 10i at x = 10⁴), so a high-index or metal
/// sphere reaches x = 10⁵ only when `|m| ≤ 1.5` (water, bubbles). Lower x: below 10⁻³ the
/// phase function is Rayleigh to 10⁻⁶. `|m − 1| ≥ 10⁻⁵`: the smallest contrast of the
/// references; at `m = 1` the phase function is 0/0. The algorithm itself (downward `D_n`
/// from `max(n_stop, |mx|) + 10 M^{1/3} + 100`, the `r_n` numerators of
/// [`MieCoefficients`](crate::mie::coefficients::MieCoefficients)) needs no regime switch inside this domain.
pub const VALIDATED_DOMAIN: ValidatedDomain = ValidatedDomain {
    x_min: 1e-3,
    x_max: 1e5,
    m_re_min: 0.05,
    m_re_max: 10.0,
    m_im_max: 10.0,
    mx_max: 1.5e5,
    m_minus_one_min: 1e-5,
};

/// Errors of the Mie module.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MieError {
    #[error(
        "size parameter x = {x} is outside the validated domain [{min:e}, {max:e}] of the Mie module"
    )]
    SizeParameterOutOfDomain { x: f64, min: f64, max: f64 },
    #[error(
        "refractive index m = {re} + {im}i is outside the validated domain ({re_min} <= Re m <= {re_max}, 0 <= Im m <= {im_max})"
    )]
    IndexOutOfDomain {
        re: f64,
        im: f64,
        re_min: f64,
        re_max: f64,
        im_max: f64,
    },
    #[error(
        "inside size parameter |m| x = {} (x = {x}, |m| = {m_abs}) is outside the validated domain |m| x <= {max:e} of the Mie module",
        m_abs * x
    )]
    InsideSizeOutOfDomain { x: f64, m_abs: f64, max: f64 },
    #[error(
        "refractive index m = {re} + {im}i is too close to the outside medium's (|m - 1| < {min:e}): the sphere hardly scatters and the phase function is undefined at m = 1"
    )]
    NearlyMatchedIndex { re: f64, im: f64, min: f64 },
}

/// Checks `(x, m)` against [`VALIDATED_DOMAIN`].
pub fn check_domain(x: f64, m: Complex64) -> Result<(), MieError> {
    VALIDATED_DOMAIN.check(x, m)
}

/// [`VALIDATED_DOMAIN`] in words (for table headers).
pub const VALIDATED_DOMAIN_TEXT: &str = "1e-3 <= x <= 1e5, 0.05 <= Re m <= 10, 0 <= Im m <= 10, |m - 1| >= 1e-5, |m| x <= 1.5e5; vs 40-digit references S1, S2 <= 3e-9 relative where |S|^2 >= 1e-12 of its maximum, Q_ext, Q_sca, g <= 3e-11, Q_back <= 6e-9 (see docs/mie.md)";
