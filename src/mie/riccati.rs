//! Riccati–Bessel machinery for Lorenz–Mie (and Debye-series) computations.
//!
//! Conventions (Bohren & Huffman 1983, §4.4): the Riccati–Bessel functions of real argument
//! `x` are `ψ_n(x) = x j_n(x)`, `χ_n(x) = −x y_n(x)` and `ξ_n(x) = ψ_n(x) − i χ_n(x)`
//! (an outgoing wave for the time dependence `e^{−iωt}`), with `ψ_{−1} = cos x`,
//! `ψ_0 = sin x`, `χ_{−1} = −sin x`, `χ_0 = cos x`. The logarithmic derivative is
//! `D_n(z) = ψ_n'(z)/ψ_n(z)`.
//!
//! Algorithms (chosen for stability over the whole validated domain of [`crate::mie`]):
//! - `D_n(z)` (complex `z = m x`) and `D_n(x)` (real) by the downward recurrence
//!   `D_{n−1} = n/z − 1/(D_n + n/z)`, started from `D = 0` at
//!   [`downward_start_order`] `= M + 10 M^{1/3} + 100` with `M = max(n_max, |z|)`. Starting at
//!   `|z| + 40` is not enough: it leaves relative errors ~1e-4 in s11 at x = 1000 (measured by the
//!   reference-data authors; see `docs/mie.md`).
//! - `ψ_n(x)` by the ratio `ψ_n = ψ_{n−1}/(D_n(x) + n/x)` from `ψ_0 = sin x` (stable in both the
//!   oscillating `n < x` and the decaying `n > x` regime, and free of the cancellation that
//!   upward recurrence suffers for `x ≪ 1`), except at a step where `D_n + n/x = ψ_{n−1}/ψ_n`
//!   is a small difference (`ψ_{n−1}` near a zero, e.g. `ψ_0 = sin x` at `x = kπ`): there the
//!   upward recurrence `ψ_n = (2n−1)/x ψ_{n−1} − ψ_{n−2}` is taken when its condition number is
//!   the smaller one. Without this, x = 5π (to the last bit) gave Q_ext 10.18 for
//!   m = 1.2 + 0.008i instead of 2.2956, and x = π, 2π were wrong in the second digit.
//! - `χ_n(x)` by the upward recurrence `χ_n = (2n−1)/x χ_{n−1} − χ_{n−2}` (χ is the dominant
//!   solution upward, so this is stable). The Wronskian `ψ_{n−1}χ_n − ψ_nχ_{n−1} = 1` holds
//!   and is used by [`crate::mie::coefficients`] for an exact `Q_abs`.
//!
//! Everything here is reusable by a Debye-series module: it needs `D_n`, `ψ_n`, `χ_n`/`ξ_n`
//! at the inside and outside arguments.

use num_complex::Complex64;

/// Default truncation order `n_stop = ⌈x + 6 x^{1/3} + 3⌉` (at least 3).
///
/// Wiscombe's rule ([`n_stop_wiscombe`]) leaves truncation errors that s11 reveals: at
/// x = 2000, m = 1.55 + 0.002i, 8.5e-9 relative at 180° and 8.2e-9 at 10° against the
/// 40-digit reference (Q_ext 4.4e-11); twenty more terms bring them to ≤ 1e-11. This rule
/// (the one `scatrs` adopted from Arb measurements) adds ~2x^{1/3} terms, i.e. < 1 % cost at
/// large x.
pub fn n_stop_default(x: f64) -> usize {
    ((x + 6.0 * x.cbrt() + 3.0).ceil() as usize).max(3)
}

/// Wiscombe's (1980) truncation order `n_stop = ⌈x + 4.05 x^{1/3} + 2⌉` (at least 3).
///
/// Wiscombe gives `x + 4 x^{1/3} + 1` below x = 8, `x + 4.05 x^{1/3} + 2` for 8–4200 and
/// `x + 4 x^{1/3} + 2` above; using `4.05 x^{1/3} + 2` everywhere is never smaller.
pub fn n_stop_wiscombe(x: f64) -> usize {
    ((x + 4.05 * x.cbrt() + 2.0).ceil() as usize).max(3)
}

/// Order at which the downward recurrence of `D_n` starts (from `D = 0`):
/// `M + 10 M^{1/3} + 100`, `M = max(n_max, |z|)`.
///
/// The error of the start decays like the ratio of the minimal to the dominant solution,
/// which for `n > |z|` falls faster than `exp(−(n − |z|)^{3/2}/|z|^{1/2})`; the margin
/// `10 M^{1/3} + 100` makes it negligible for every `|z|` (the reference README measures that
/// `|z| + 40` is not enough at `|z| ≈ 1333`).
pub fn downward_start_order(n_max: usize, z_abs: f64) -> usize {
    let big = (n_max as f64).max(z_abs);
    (big + 10.0 * big.cbrt() + 100.0).ceil() as usize
}

/// Fills `out[0..=n_max]` with `D_n(z)` for complex `z` (`z ≠ 0`), by downward recurrence
/// from [`downward_start_order`]. Reuses `out`'s allocation.
pub fn log_derivative_complex(z: Complex64, n_max: usize, out: &mut Vec<Complex64>) {
    let start = downward_start_order(n_max, z.norm());
    out.clear();
    out.resize(n_max + 1, Complex64::new(0.0, 0.0));
    let inv_z = 1.0 / z;
    let mut d = Complex64::new(0.0, 0.0);
    for n in (1..=start).rev() {
        let nz = inv_z * n as f64;
        d = nz - 1.0 / (d + nz);
        // d is now D_{n−1}
        if n - 1 <= n_max {
            out[n - 1] = d;
        }
    }
}

/// Fills `out[0..=n_max]` with `D_n(x)` for real `x > 0`, by downward recurrence from
/// [`downward_start_order`]. Reuses `out`'s allocation.
pub fn log_derivative_real(x: f64, n_max: usize, out: &mut Vec<f64>) {
    let start = downward_start_order(n_max, x);
    out.clear();
    out.resize(n_max + 1, 0.0);
    let inv_x = 1.0 / x;
    let mut d = 0.0f64;
    for n in (1..=start).rev() {
        let nx = n as f64 * inv_x;
        let mut den = d + nx;
        if den == 0.0 {
            // D_n + n/x = ψ_{n−1}/ψ_n vanishes only at an exact zero of ψ_{n−1}; nudge it.
            den = f64::MIN_POSITIVE;
        }
        d = nx - 1.0 / den;
        if n - 1 <= n_max {
            out[n - 1] = d;
        }
    }
}

/// Fills `out[0..=n_max]` with the log-derivative of the outgoing Riccati–Hankel function,
/// `G_n(z) = ξ_n'(z)/ξ_n(z)`, `ξ_n = ψ_n − iχ_n = z h_n^{(1)}(z)`, for complex `z` with
/// `Im z ≥ 0`, by the upward recurrence `G_n = −n/z + 1/(n/z − G_{n−1})` from `G_0 = i`
/// (`ξ_0 = −i e^{iz}`). Upward is the stable direction for `ξ` (dominant for `n > |z|`). For
/// Debye-series work (reflection/transmission coefficients need `D_n` and `G_n` at `x` and
/// `mx`).
pub fn log_derivative_xi_complex(z: Complex64, n_max: usize, out: &mut Vec<Complex64>) {
    out.clear();
    out.reserve(n_max + 1);
    let inv_z = 1.0 / z;
    let mut g = Complex64::new(0.0, 1.0);
    out.push(g);
    for n in 1..=n_max {
        let nz = inv_z * n as f64;
        g = -nz + 1.0 / (nz - g);
        out.push(g);
    }
}

/// Largest condition number `(|D_n| + n/x)/|D_n + n/x|` of the ratio step `ψ_n = ψ_{n−1}/(D_n + n/x)`
/// that [`RiccatiBessel`] accepts before comparing it with the upward recurrence (100: at most
/// two digits lost in that one step).
const RATIO_CONDITION_LIMIT: f64 = 100.0;

/// Riccati–Bessel functions of a real argument for orders `0..=n_max`.
#[derive(Debug, Clone, Default)]
pub struct RiccatiBessel {
    /// The argument `x`.
    pub x: f64,
    /// `ψ_n(x)`, `n = 0..=n_max`.
    pub psi: Vec<f64>,
    /// `χ_n(x)`, `n = 0..=n_max`.
    pub chi: Vec<f64>,
    /// `D_n(x) = ψ_n'/ψ_n`, `n = 0..=n_max`.
    pub log_derivative: Vec<f64>,
}

impl RiccatiBessel {
    /// Computes `ψ_n`, `χ_n` and `D_n` at real `x > 0` for `n = 0..=n_max` (see module doc).
    pub fn new(x: f64, n_max: usize) -> Self {
        let mut rb = RiccatiBessel::default();
        rb.compute(x, n_max);
        rb
    }

    /// As [`RiccatiBessel::new`], reusing the allocations of `self`.
    pub fn compute(&mut self, x: f64, n_max: usize) {
        self.x = x;
        log_derivative_real(x, n_max, &mut self.log_derivative);
        self.psi.clear();
        self.chi.clear();
        self.psi.reserve(n_max + 1);
        self.chi.reserve(n_max + 1);
        let (s, c) = x.sin_cos();
        self.psi.push(s);
        self.chi.push(c);
        let mut chi_prev = -s; // χ_{−1}
        let mut psi_prev = c; // ψ_{−1}
        let inv_x = 1.0 / x;
        for n in 1..=n_max {
            let nx = n as f64 * inv_x;
            let d = self.log_derivative[n];
            // ψ_n = ψ_{n−1}/t with t = D_n + n/x = ψ_{n−1}/ψ_n; near a zero of ψ_{n−1} (e.g.
            // ψ_0 = sin x at x = kπ) t is a small difference and loses its relative accuracy,
            // so the upward recurrence (well conditioned there, ψ_n ≈ −ψ_{n−2}) takes over.
            let t = d + nx;
            let mut psi_n = self.psi[n - 1] / t;
            let cond_ratio = (d.abs() + nx) / t.abs();
            if !(cond_ratio <= RATIO_CONDITION_LIMIT) {
                let a = (2 * n - 1) as f64 * inv_x * self.psi[n - 1];
                let up = a - psi_prev;
                let cond_up = (a.abs() + psi_prev.abs()) / up.abs();
                if cond_up < cond_ratio {
                    psi_n = up;
                }
            }
            psi_prev = self.psi[n - 1];
            let chi_n = (2 * n - 1) as f64 * inv_x * self.chi[n - 1] - chi_prev;
            chi_prev = self.chi[n - 1];
            self.psi.push(psi_n);
            self.chi.push(chi_n);
        }
    }

    /// `ξ_n(x) = ψ_n(x) − i χ_n(x)`.
    pub fn xi(&self, n: usize) -> Complex64 {
        Complex64::new(self.psi[n], -self.chi[n])
    }

    /// `ψ_{n−1}` for `n ≥ 0` (`ψ_{−1} = cos x`).
    pub fn psi_prev(&self, n: usize) -> f64 {
        if n == 0 {
            self.x.cos()
        } else {
            self.psi[n - 1]
        }
    }

    /// `χ_{n−1}` for `n ≥ 0` (`χ_{−1} = −sin x`).
    pub fn chi_prev(&self, n: usize) -> f64 {
        if n == 0 {
            -self.x.sin()
        } else {
            self.chi[n - 1]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: ψ_1 = sin x/x − cos x, χ_1 = cos x/x + sin x, ψ_2 = (3/x² − 1) sin x − 3 cos x/x.
    #[test]
    fn low_orders_match_closed_forms() {
        for &x in &[0.7, 3.0, 25.0] {
            let rb = RiccatiBessel::new(x, 5);
            let (s, c) = f64::sin_cos(x);
            assert!((rb.psi[1] - (s / x - c)).abs() < 1e-14);
            assert!((rb.chi[1] - (c / x + s)).abs() < 1e-14);
            assert!((rb.psi[2] - ((3.0 / (x * x) - 1.0) * s - 3.0 * c / x)).abs() < 1e-13);
        }
    }

    /// Small argument: ψ_n(x) ≈ x^{n+1}/(2n+1)!! to relative 1e-12 (no upward cancellation).
    #[test]
    fn small_argument_psi_is_accurate() {
        let x = 1e-3;
        let rb = RiccatiBessel::new(x, 3);
        let mut dfact = 1.0;
        for n in 1..=3usize {
            dfact *= (2 * n + 1) as f64;
            let series = x.powi(n as i32 + 1) / dfact * (1.0 - x * x / (2.0 * (2 * n + 3) as f64));
            assert!(((rb.psi[n] - series) / series).abs() < 1e-12, "n={n}");
        }
    }

    /// The Wronskian ψ_{n−1}χ_n − ψ_nχ_{n−1} = 1 at large x and n beyond x.
    #[test]
    fn wronskian_holds() {
        let x = 5000.0;
        let n_max = n_stop_wiscombe(x);
        let rb = RiccatiBessel::new(x, n_max);
        for n in [1, 100, 2500, 4999, 5000, n_max] {
            let w = rb.psi_prev(n) * rb.chi[n] - rb.psi[n] * rb.chi_prev(n);
            assert!((w - 1.0).abs() < 1e-9, "n={n} w={w}");
        }
    }

    /// G_n(x) = ξ_n'/ξ_n from the complex upward recurrence equals ξ_{n−1}/ξ_n − n/x from the
    /// real-argument ψ/χ at real x, including n well beyond x.
    #[test]
    fn xi_log_derivative_matches_real_functions() {
        let x = 250.0;
        let n_max = 320;
        let rb = RiccatiBessel::new(x, n_max);
        let mut g = Vec::new();
        log_derivative_xi_complex(Complex64::new(x, 0.0), n_max, &mut g);
        for n in [1, 10, 200, 249, 260, 320] {
            let xi = rb.xi(n);
            let xi_prev = Complex64::new(rb.psi_prev(n), -rb.chi_prev(n));
            let expect = xi_prev / xi - n as f64 / x;
            assert!(
                (g[n] - expect).norm() < 1e-10 * expect.norm().max(1.0),
                "n={n}"
            );
        }
    }

    /// The complex log-derivative satisfies D_n = −n/z + 1/(D_{n−1}... via the upward identity
    /// D_{n−1}(z) = n/z − 1/(D_n + n/z); and D_0(z) = cot z.
    #[test]
    fn complex_log_derivative_d0_is_cot() {
        let z = Complex64::new(1333.0, 2.0);
        let mut d = Vec::new();
        log_derivative_complex(z, 1500, &mut d);
        let cot = z.cos() / z.sin();
        assert!((d[0] - cot).norm() / cot.norm() < 1e-12);
    }

    /// At multiples of π (ψ_0 = sin x ≈ 0) ψ_1, ψ_2 match the closed forms to 1e-13 (absolute;
    /// the amplitude is ~1), and the Wronskian holds.
    #[test]
    fn psi_at_multiples_of_pi() {
        for k in [1.0, 2.0, 5.0, 40.0] {
            let x = k * std::f64::consts::PI;
            let rb = RiccatiBessel::new(x, n_stop_default(x));
            let (s, c) = f64::sin_cos(x);
            let psi1 = s / x - c;
            let psi2 = (3.0 / (x * x) - 1.0) * s - 3.0 * c / x;
            assert!(
                (rb.psi[1] - psi1).abs() < 1e-13,
                "x={x}: {} vs {psi1}",
                rb.psi[1]
            );
            assert!(
                (rb.psi[2] - psi2).abs() < 1e-13,
                "x={x}: {} vs {psi2}",
                rb.psi[2]
            );
            for n in 1..rb.psi.len() {
                let w = rb.psi_prev(n) * rb.chi[n] - rb.psi[n] * rb.chi_prev(n);
                assert!((w - 1.0).abs() < 1e-10, "x={x} n={n} w={w}");
            }
        }
    }
}
