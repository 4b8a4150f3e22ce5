//! The Airy function `Ai(z)` of a real argument (used by the Airy theory of the rainbow).
//!
//! Algorithm: Maclaurin series `Ai(z) = c₁ f(z) − c₂ g(z)` (DLMF 9.4.1, `c₁ = Ai(0)`,
//! `c₂ = −Ai'(0)`) for `−8 ≤ z ≤ 5`; the asymptotic expansions DLMF 9.7.5 (`z > 5`) and
//! 9.7.9 (`z < −8`) with the coefficients `u_k` of DLMF 9.7.2, summed up to the smallest term.
//! Accuracy (tests): ≤ 2e-10 absolute over the whole axis (the series loses `~e^{ζ}` digits
//! towards `z = −8`; the asymptotic series' smallest term at `ζ = (2/3)·8^{3/2} ≈ 15` is 6e-15);
//! the zeros `a₁ … a₇` are reproduced to 1e-9.

use std::f64::consts::{FRAC_PI_4, PI};

/// `Ai(0)`.
const AI0: f64 = 0.355_028_053_887_817_2;
/// `−Ai'(0)`.
const MINUS_AI_PRIME0: f64 = 0.258_819_403_792_806_8;

/// `Ai(z)` for real `z` (see the module doc for the algorithm and accuracy).
pub fn airy_ai(z: f64) -> f64 {
    if z > 5.0 {
        airy_ai_asymptotic_positive(z)
    } else if z < -8.0 {
        airy_ai_asymptotic_negative(-z)
    } else {
        airy_ai_series(z)
    }
}

/// Maclaurin series (accurate for moderate |z|).
pub fn airy_ai_series(z: f64) -> f64 {
    airy_ai_and_derivative_series(z).0
}

/// `(Ai(z), Ai'(z))` by the Maclaurin series `Ai = c₁ f − c₂ g` and its term-wise derivative.
/// Accuracy: the alternating series loses about `(2/3)|z|^{3/2}/ln 10` digits: absolute error
/// below 2e-10 for −8 ≤ z ≤ 5 and 3.7e-6 at z = −12 (measured against the asymptotic expansion
/// in the tests); use it for |z| ≤ 12. Used by the uniform caustic
/// (Airy) diffraction model of the ray tracer, which needs the derivative.
pub fn airy_ai_and_derivative_series(z: f64) -> (f64, f64) {
    let z3 = z * z * z;
    // f = Σ a_k z^{3k}, g = Σ b_k z^{3k+1}.
    let (mut f, mut fp, mut g, mut gp) = (1.0, 0.0, z, 1.0);
    let mut a = 1.0; // a_k
    let mut b = 1.0; // b_k
    let mut p3 = 1.0; // z^{3k}
    for k in 1..200 {
        let kf = k as f64;
        a /= (3.0 * kf - 1.0) * (3.0 * kf);
        b /= (3.0 * kf) * (3.0 * kf + 1.0);
        let p3m1 = if k == 1 { z * z } else { p3 * z * z }; // z^{3k−1}
        p3 *= z3;
        let tf = a * p3;
        let tfp = 3.0 * kf * a * p3m1;
        let tg = b * p3 * z;
        let tgp = (3.0 * kf + 1.0) * b * p3;
        f += tf;
        fp += tfp;
        g += tg;
        gp += tgp;
        if k > 3 && tf.abs() + tfp.abs() + tg.abs() + tgp.abs() < 1e-18 * (1.0 + f.abs() + g.abs())
        {
            break;
        }
    }
    (
        AI0 * f - MINUS_AI_PRIME0 * g,
        AI0 * fp - MINUS_AI_PRIME0 * gp,
    )
}

/// `u_k` of DLMF 9.7.2 up to the index where `u_k/ζ^k` is smallest; returns the terms
/// `u_k ζ^{−k}`.
fn asymptotic_terms(zeta: f64) -> Vec<f64> {
    let mut terms = vec![1.0];
    let mut u = 1.0;
    let mut k = 1.0f64;
    loop {
        u *= (6.0 * k - 5.0) * (6.0 * k - 3.0) * (6.0 * k - 1.0) / ((2.0 * k - 1.0) * 216.0 * k);
        let t = u / zeta.powi(k as i32);
        if t >= *terms.last().expect("non-empty") || t < 1e-17 || k > 60.0 {
            break;
        }
        terms.push(t);
        k += 1.0;
    }
    terms
}

/// DLMF 9.7.5, `z > 0` large.
pub fn airy_ai_asymptotic_positive(z: f64) -> f64 {
    let zeta = 2.0 / 3.0 * z * z.sqrt();
    let s: f64 = asymptotic_terms(zeta)
        .iter()
        .enumerate()
        .map(|(k, t)| if k % 2 == 0 { *t } else { -t })
        .sum();
    (-zeta).exp() / (2.0 * PI.sqrt() * z.powf(0.25)) * s
}

/// DLMF 9.7.9: `Ai(−x)` for `x > 0` large.
pub fn airy_ai_asymptotic_negative(x: f64) -> f64 {
    let zeta = 2.0 / 3.0 * x * x.sqrt();
    let (mut even, mut odd) = (0.0, 0.0);
    for (k, t) in asymptotic_terms(zeta).iter().enumerate() {
        let sign = if (k / 2) % 2 == 0 { 1.0 } else { -1.0 };
        if k % 2 == 0 {
            even += sign * t;
        } else {
            odd += sign * t;
        }
    }
    let phase = zeta - FRAC_PI_4;
    (phase.cos() * even + phase.sin() * odd) / (PI.sqrt() * x.powf(0.25))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivative_series_matches_reference_values() {
        // A&S Table 10.11 / DLMF: Ai'(0) = −0.258819403792807, Ai'(−1) = −0.010160567116645,
        // Ai(−5) = 0.350761009024114; at z = −12 the series still follows the asymptotic form.
        let (a0, d0) = airy_ai_and_derivative_series(0.0);
        assert!((a0 - AI0).abs() < 1e-14 && (d0 + 0.258_819_403_792_807).abs() < 1e-14);
        assert!((airy_ai_and_derivative_series(-1.0).1 + 0.010_160_567_116_645).abs() < 1e-12);
        assert!((airy_ai_and_derivative_series(-5.0).0 - 0.350_761_009_024_114).abs() < 1e-11);
        let x: f64 = 12.0;
        let d = (airy_ai_and_derivative_series(-x).0 - airy_ai_asymptotic_negative(x)).abs();
        assert!(d < 1e-5, "series vs asymptotic at -12: {d:e}");
    }

    /// Reference values from mpmath (20 digits, `mpmath.airyai`, `mpmath.airyaizero`): Ai(±1),
    /// Ai(±2), Ai(−5), Ai(±10), the maximum at −1.018792971647471, and the zeros a₁…a₇.
    #[test]
    fn tabulated_values_and_zeros() {
        let table = [
            (1.0, 0.135_292_416_312_881_4),
            (-1.0, 0.535_560_883_292_352_1),
            (2.0, 0.034_924_130_423_274_38),
            (-2.0, 0.227_407_428_201_685_6),
            (-5.0, 0.350_761_009_024_114_2),
            (-10.0, 0.040_241_238_486_443_19),
            (-1.018_792_971_647_471, 0.535_656_656_015_699_9),
            (10.0, 1.104_753_255_289_868_6e-10),
        ];
        for (z, v) in table {
            let a = airy_ai(z);
            let tol = if z > 5.0 { 1e-8 * v } else { 2e-10 };
            assert!((a - v).abs() < tol, "Ai({z}) = {a} vs {v}");
        }
        let zeros = [
            -2.338_107_410_459_767,
            -4.087_949_444_130_97,
            -5.520_559_828_095_551,
            -6.786_708_090_071_759,
            -7.944_133_587_120_853,
            -9.022_650_853_340_98,
            -10.040_174_341_558_09,
        ];
        for a in zeros {
            assert!(airy_ai(a).abs() < 1e-9, "Ai({a}) = {}", airy_ai(a));
        }
    }

    /// The series and the asymptotic expansions agree where both are usable.
    #[test]
    fn methods_agree_in_the_overlap() {
        for z in [-9.0, -8.5, -8.0, -7.5] {
            let d = airy_ai_series(z) - airy_ai_asymptotic_negative(-z);
            assert!(d.abs() < 3e-10, "z={z} diff {d}");
        }
        for z in [5.0, 6.0] {
            let (s, a) = (airy_ai_series(z), airy_ai_asymptotic_positive(z));
            assert!(((s - a) / a).abs() < 1e-6, "z={z} {s} {a}");
        }
    }
}
