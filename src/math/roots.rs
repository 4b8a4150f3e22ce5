//! Root finding.

/// The root of `g` in a bracket `[a, b]` with g(a)·g(b) ≤ 0 (`lo = (a, g(a))`,
/// `hi = (b, g(b))`), by Newton's method safeguarded by the bracket: `gd(t)` gives `g` and its
/// derivative; the secant point of the bracket is the first iterate, a step leaving the bracket
/// (or not finite) is replaced by bisection, and every evaluation shrinks the bracket. Stops when
/// a step or the bracket is at most `tol(t)` (at most 100 evaluations).
pub fn newton_bracketed(
    gd: impl Fn(f64) -> (f64, f64),
    (mut a, mut ga): (f64, f64),
    (mut b, gb): (f64, f64),
    tol: impl Fn(f64) -> f64,
) -> f64 {
    if gb == 0.0 {
        return b;
    }
    if ga == 0.0 {
        return a;
    }
    let mut t = (a * gb - b * ga) / (gb - ga);
    if !(t.is_finite() && t > a.min(b) && t < a.max(b)) {
        t = 0.5 * (a + b);
    }
    for _ in 0..100 {
        let (g, slope) = gd(t);
        if g == 0.0 {
            return t;
        }
        if (g > 0.0) == (ga > 0.0) {
            a = t;
            ga = g;
        } else {
            b = t;
        }
        let newton = t - g / slope;
        let next = if newton.is_finite() && newton > a.min(b) && newton < a.max(b) {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - t).abs() <= tol(t) || (b - a).abs() <= tol(t) {
            return next;
        }
        t = next;
    }
    t
}
