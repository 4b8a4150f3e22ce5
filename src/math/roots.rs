//! Root finding.

/// The root of `g` in a bracket `[a, b]` with g(a)·g(b) ≤ 0 (`lo = (a, g(a))`,
/// `hi = (b, g(b))`), by Newton's method safeguarded by the bracket: `gd(t)` gives `g` and its
/// derivative; the secant point of the bracket is the first iterate, a step leaving the bracket
/// (or not finite) is replaced by bisection, and every evaluation shrinks the bracket. Stops when
/// a step or the bracket is at most `tol(t)` (at most 100 evaluations).
pub fn newton_bracketed(
    gd: impl Fn(f64) -> (f64, f64),
    (a, ga): (f64, f64),
    (b, gb): (f64, f64),
    tol: impl Fn(f64) -> f64,
) -> f64 {
    if gb == 0.0 {
        return b;
    }
    if ga == 0.0 {
        return a;
    }
    let t = (a * gb - b * ga) / (gb - ga);
    let t = if t.is_finite() && t > a.min(b) && t < a.max(b) {
        t
    } else {
        0.5 * (a + b)
    };
    newton_in_bracket(gd, (a, ga > 0.0), b, t, tol)
}

/// [`newton_bracketed`] from the first iterate `t` inside the bracket `[a, b]`, where `g` is
/// known to be positive at `a` if `a_positive` and of the other sign at `b`: for brackets whose
/// signs are known without evaluating `g` at their ends.
pub fn newton_in_bracket(
    gd: impl Fn(f64) -> (f64, f64),
    bracket_end: (f64, bool),
    b: f64,
    t: f64,
    tol: impl Fn(f64) -> f64,
) -> f64 {
    let mut state = BracketedNewton::new(bracket_end, b, t);
    loop {
        let (g, slope) = gd(state.t);
        if let Some(root) = state.step(g, slope, &tol) {
            return root;
        }
    }
}

/// The iteration of [`newton_in_bracket`] one evaluation at a time, for callers that advance
/// several independent roots in turn (their evaluations overlap in the processor instead of
/// waiting on each other): evaluate `g` and its derivative at [`Self::t`], pass them to
/// [`Self::step`], until it returns the root. The iterates and the root are those of
/// [`newton_in_bracket`], bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct BracketedNewton {
    a: f64,
    a_positive: bool,
    b: f64,
    /// The next point at which to evaluate `g`.
    pub t: f64,
    evaluations: u32,
}

impl BracketedNewton {
    /// From the first iterate `t` in the bracket `[a, b]`, `g` positive at `a` if `a_positive`
    /// and of the other sign at `b`.
    pub fn new((a, a_positive): (f64, bool), b: f64, t: f64) -> Self {
        BracketedNewton {
            a,
            a_positive,
            b,
            t,
            evaluations: 0,
        }
    }

    /// Takes `g` and its derivative at [`Self::t`]: the root when the iteration ends, else
    /// `None` with the next point in [`Self::t`] (at most 100 evaluations).
    #[inline]
    pub fn step(&mut self, g: f64, slope: f64, tol: impl Fn(f64) -> f64) -> Option<f64> {
        let t = self.t;
        if g == 0.0 {
            return Some(t);
        }
        if (g > 0.0) == self.a_positive {
            self.a = t;
        } else {
            self.b = t;
        }
        let (a, b) = (self.a, self.b);
        let newton = t - g / slope;
        // A converged step returns even when it rounds onto a bracket end (the root within
        // rounding of an end that `t` already moved there): bisecting further would spend up
        // to ~40 evaluations shrinking the bracket around a root already found.
        if newton.is_finite() && (newton - t).abs() <= tol(t) {
            return Some(newton.clamp(a.min(b), a.max(b)));
        }
        let next = if newton.is_finite() && newton > a.min(b) && newton < a.max(b) {
            newton
        } else {
            0.5 * (a + b)
        };
        if (next - t).abs() <= tol(t) || (b - a).abs() <= tol(t) {
            return Some(next);
        }
        self.evaluations += 1;
        if self.evaluations >= 100 {
            return Some(next);
        }
        self.t = next;
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// A root that no f64 reaches (g changes sign between two neighbouring floats): the
    /// iteration stops once its step is within the tolerance, also when that step rounds onto
    /// the bracket end the iterate already moved to, instead of bisecting the bracket down to
    /// the tolerance (≈ 40 evaluations from a bracket of 20).
    #[test]
    fn a_converged_step_onto_a_bracket_end_stops() {
        let evaluations = Cell::new(0);
        // g < 0 at `root` and > 0 at the next float up; from afar, every Newton step lands on
        // `root` exactly (the offset is lost in rounding).
        let root = 3000.0;
        let gd = |t: f64| {
            evaluations.set(evaluations.get() + 1);
            (t - root - 1e-13, 1.0)
        };
        let tol = |t: f64| 1e-13 * (1.0 + t.abs());
        let (a, b) = (2990.0, 3010.0);
        let t = newton_bracketed(gd, (a, gd(a).0), (b, gd(b).0), tol);
        assert!((t - root).abs() < 1e-12, "{t}");
        assert!(evaluations.get() <= 6, "{} evaluations", evaluations.get());
        // The same root from a start and the ends' signs alone.
        evaluations.set(0);
        let t = newton_in_bracket(gd, (b, true), a, 2995.0, tol);
        assert!((t - root).abs() < 1e-12, "{t}");
        assert!(evaluations.get() <= 4, "{} evaluations", evaluations.get());
    }
}
