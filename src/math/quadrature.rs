//! Gauss–Legendre quadrature.
//!
//! Nodes and weights by Newton iteration on the Legendre recurrence (Golub–Welsch accuracy:
//! nodes to ~1e-15 absolute for n up to several thousand), exact for polynomials of degree
//! `2n − 1`.

/// Gauss–Legendre nodes and weights on `[-1, 1]`, nodes in increasing order.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n > 0, "Gauss–Legendre needs at least one node");
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    let m = n.div_ceil(2);
    for i in 0..m {
        // Tricomi initial guess.
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (p, d) = legendre_and_derivative(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let (_, d) = legendre_and_derivative(n, x);
        dp = if d != 0.0 { d } else { dp };
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = -x;
        nodes[n - 1 - i] = x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

/// Gauss–Legendre nodes and weights mapped to `[a, b]`.
pub fn gauss_legendre_interval(n: usize, a: f64, b: f64) -> (Vec<f64>, Vec<f64>) {
    let (x, w) = gauss_legendre(n);
    let half = 0.5 * (b - a);
    let mid = 0.5 * (b + a);
    (
        x.iter().map(|&xi| mid + half * xi).collect(),
        w.iter().map(|&wi| half * wi).collect(),
    )
}

/// Integrate `f` over `[a, b]` with an `n`-point Gauss–Legendre rule.
pub fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let (x, w) = gauss_legendre_interval(n, a, b);
    x.iter().zip(&w).map(|(&xi, &wi)| wi * f(xi)).sum()
}

/// Legendre polynomial `P_n(x)` and its derivative.
fn legendre_and_derivative(n: usize, x: f64) -> (f64, f64) {
    let mut p0 = 1.0;
    let mut p1 = x;
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_two_and_polynomials_are_exact() {
        for n in [1, 2, 5, 16, 64, 301] {
            let (x, w) = gauss_legendre(n);
            let s: f64 = w.iter().sum();
            assert!((s - 2.0).abs() < 1e-12, "n={n} sum={s}");
            // ∫ x^(2n-2) over [-1,1] = 2/(2n-1)
            let deg = 2 * n - 2;
            let v: f64 = x.iter().zip(&w).map(|(a, b)| b * a.powi(deg as i32)).sum();
            assert!((v - 2.0 / (deg as f64 + 1.0)).abs() < 1e-12, "n={n}");
        }
    }

    #[test]
    fn integrates_cosine() {
        let v = integrate(f64::cos, 0.0, std::f64::consts::FRAC_PI_2, 20);
        assert!((v - 1.0).abs() < 1e-14);
    }
}
