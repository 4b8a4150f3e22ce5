//! Airy function Ai and its derivative for moderate real arguments (|z| ≤ 12), by the
//! Maclaurin series `Ai(z) = c1 f(z) − c2 g(z)` (Abramowitz & Stegun 10.4.2). Accuracy: the
//! alternating series loses about `(2/3)|z|^{3/2}/ln 10` digits, i.e. |error| < 1e-7 at |z| = 12.
//! Used by the uniform caustic (Airy) approximation of the 1-D sphere path.

const C1: f64 = 0.355_028_053_887_817_2;
const C2: f64 = 0.258_819_403_792_806_8;

/// `(Ai(z), Ai'(z))` for |z| ≤ 12.
pub fn airy_ai(z: f64) -> (f64, f64) {
    debug_assert!(z.abs() <= 12.5);
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
    (C1 * f - C2 * g, C1 * fp - C2 * gp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn airy_matches_reference_values() {
        // A&S Table 10.11 / DLMF: Ai(0) = 0.355028053887817, Ai'(0) = −0.258819403792807,
        // Ai(1) = 0.135292416312881, Ai(−1) = 0.535560883292352, Ai'(−1) = −0.010160567116645,
        // first zero a1 = −2.338107410459767, Ai(−5) = 0.350761009024114.
        let (a0, d0) = airy_ai(0.0);
        assert!(
            (a0 - 0.355_028_053_887_817).abs() < 1e-14
                && (d0 + 0.258_819_403_792_807).abs() < 1e-14
        );
        assert!((airy_ai(1.0).0 - 0.135_292_416_312_881).abs() < 1e-13);
        assert!((airy_ai(-1.0).0 - 0.535_560_883_292_352).abs() < 1e-13);
        assert!((airy_ai(-1.0).1 + 0.010_160_567_116_645).abs() < 1e-12);
        assert!(airy_ai(-2.338_107_410_459_767).0.abs() < 1e-12);
        assert!((airy_ai(-5.0).0 - 0.350_761_009_024_114).abs() < 1e-11);
        // Asymptotics at z = −12: Ai(−x) ≈ π^{−1/2} x^{−1/4} sin(2/3 x^{3/2} + π/4).
        let x: f64 = 12.0;
        let asym = (std::f64::consts::PI).sqrt().recip()
            * x.powf(-0.25)
            * (2.0 / 3.0 * x.powf(1.5) + std::f64::consts::FRAC_PI_4).sin();
        assert!((airy_ai(-12.0).0 - asym).abs() < 2e-3 * x.powf(-0.25));
    }
}
