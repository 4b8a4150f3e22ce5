//! Tangent curves (thesis §5.6 and Appendix E, Table E.1): the distribution of a thread's
//! tangent elevation α over the smallest patch of the weave.
//!
//! A curve is given by tangent offsets (degrees) at control points and the lengths of the
//! segments between consecutive points. α(s) is piecewise linear in arc length s; a segment of
//! length 0 is a jump; a segment whose two offsets are equal is a flat stretch, and each flat
//! stretch makes one highlight (decision CLOTH-8). Only the ratios of lengths matter.
//!
//! The patch integral (eq. 5.13) averages over `T` equidistant tangent samples of each curve.
//! Tables use the limit `T → ∞`, the arc-length mean, computed by [`TangentCurve::nodes`]: a
//! flat stretch is one node weighted by its length; a ramp is split into `ceil(|Δα|/step)`
//! equal pieces, each a node at its midpoint. [`TangentCurve::equidistant`] gives the thesis's
//! `T` samples and [`TangentCurve::sample`] draws α for a uniform arc-length position.

/// One tangent sample: elevation α (radians, positive toward the cloth normal) and weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TangentNode {
    /// Elevation α of the tangent out of the cloth plane, radians.
    pub alpha_rad: f64,
    /// Weight (the nodes of one curve sum to 1).
    pub weight: f64,
}

/// A piecewise-linear tangent curve.
#[derive(Debug, Clone, PartialEq)]
pub struct TangentCurve {
    /// Tangent offsets at the control points, degrees.
    pub offsets_deg: Vec<f64>,
    /// Lengths of the segments between consecutive control points (one fewer than offsets).
    pub lengths: Vec<f64>,
}

/// Why a tangent curve is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurveError {
    #[error("a tangent curve needs n ≥ 2 offsets and n − 1 lengths, got {offsets} and {lengths}")]
    Shape { offsets: usize, lengths: usize },
    #[error("tangent lengths must be finite and ≥ 0 with a positive sum")]
    Lengths,
    #[error("tangent offsets must lie within [−90°, 90°]")]
    Offsets,
}

impl TangentCurve {
    /// A curve from offsets (degrees) and segment lengths, checked.
    pub fn new(offsets_deg: &[f64], lengths: &[f64]) -> Result<Self, CurveError> {
        if offsets_deg.len() < 2 || lengths.len() + 1 != offsets_deg.len() {
            return Err(CurveError::Shape {
                offsets: offsets_deg.len(),
                lengths: lengths.len(),
            });
        }
        let total: f64 = lengths.iter().sum();
        if lengths.iter().any(|l| !(l.is_finite() && *l >= 0.0)) || !(total > 0.0) {
            return Err(CurveError::Lengths);
        }
        if offsets_deg.iter().any(|a| !(-90.0..=90.0).contains(a)) {
            return Err(CurveError::Offsets);
        }
        Ok(TangentCurve {
            offsets_deg: offsets_deg.to_vec(),
            lengths: lengths.to_vec(),
        })
    }

    fn total_length(&self) -> f64 {
        self.lengths.iter().sum()
    }

    /// The arc-length quadrature of the curve (`T → ∞`): flat stretches as one node, ramps at
    /// steps of at most `max_step_deg` in α (midpoints). Weights sum to 1.
    pub fn nodes(&self, max_step_deg: f64) -> Vec<TangentNode> {
        assert!(max_step_deg > 0.0, "the ramp step must be positive");
        let total = self.total_length();
        let mut out = Vec::new();
        for (k, &len) in self.lengths.iter().enumerate() {
            if len == 0.0 {
                continue;
            }
            let (a0, a1) = (self.offsets_deg[k], self.offsets_deg[k + 1]);
            let pieces = ((a1 - a0).abs() / max_step_deg - 1e-9).ceil().max(1.0) as usize;
            for p in 0..pieces {
                let x = (p as f64 + 0.5) / pieces as f64;
                out.push(TangentNode {
                    alpha_rad: (a0 + (a1 - a0) * x).to_radians(),
                    weight: len / total / pieces as f64,
                });
            }
        }
        out
    }

    /// α (radians) at arc-length fraction `u` ∈ [0, 1) of the curve.
    pub fn sample(&self, u: f64) -> f64 {
        let mut s = u.clamp(0.0, 1.0) * self.total_length();
        for (k, &len) in self.lengths.iter().enumerate() {
            if s < len || k + 1 == self.lengths.len() {
                let x = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
                let (a0, a1) = (self.offsets_deg[k], self.offsets_deg[k + 1]);
                return (a0 + (a1 - a0) * x).to_radians();
            }
            s -= len;
        }
        unreachable!("a checked curve has at least one segment")
    }

    /// The thesis's `T` equidistant samples (eq. 5.13), at arc-length fractions `(k + ½)/T`,
    /// each of weight `1/T`.
    pub fn equidistant(&self, count: usize) -> Vec<TangentNode> {
        (0..count)
            .map(|k| TangentNode {
                alpha_rad: self.sample((k as f64 + 0.5) / count as f64),
                weight: 1.0 / count as f64,
            })
            .collect()
    }

    /// True when the distribution of α is symmetric under α → −α (the cloth then has the mirror
    /// symmetry across the plane normal to this thread).
    pub fn is_symmetric(&self) -> bool {
        let mut a: Vec<(i64, i64)> = self
            .nodes(0.5)
            .iter()
            .map(|n| key(n.alpha_rad, n.weight))
            .collect();
        let mut b: Vec<(i64, i64)> = self
            .nodes(0.5)
            .iter()
            .map(|n| key(-n.alpha_rad, n.weight))
            .collect();
        a.sort_unstable();
        b.sort_unstable();
        a == b
    }
}

/// Rounded (α, weight) for comparing node sets.
fn key(alpha_rad: f64, weight: f64) -> (i64, i64) {
    (
        (alpha_rad.to_degrees() * 1e6).round() as i64,
        (weight * 1e9).round() as i64,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn node_counts_and_weights() {
        let satin = TangentCurve::new(
            &[-32.0, -32.0, -18.0, 0.0, 0.0, 18.0, 32.0, 32.0],
            &[1.33, 0.66, 2.0, 2.0, 2.0, 0.66, 1.33],
        )
        .unwrap();
        let n = satin.nodes(1.0);
        assert_eq!(n.len(), 67);
        let sum: f64 = n.iter().map(|n| n.weight).sum();
        assert!((sum - 1.0).abs() < 1e-12);
        assert!(satin.is_symmetric());
        let velvet = TangentCurve::new(&[-90.0, -50.0], &[1.0]).unwrap();
        assert_eq!(velvet.nodes(1.0).len(), 40);
        assert!(!velvet.is_symmetric());
        let jump = TangentCurve::new(&[-90.0, -55.0, 55.0, 90.0], &[0.5, 0.0, 0.5]).unwrap();
        assert_eq!(jump.nodes(1.0).len(), 70);
        assert!(jump.is_symmetric());
    }

    #[test]
    fn sampling_matches_the_piecewise_linear_curve() {
        let c = TangentCurve::new(&[-35.0, -35.0, 35.0, 35.0], &[1.0, 1.0, 1.0]).unwrap();
        assert!((c.sample(0.1).to_degrees() + 35.0).abs() < 1e-12);
        assert!((c.sample(0.5).to_degrees()).abs() < 1e-12);
        assert!((c.sample(0.9).to_degrees() - 35.0).abs() < 1e-12);
        // Equidistant samples converge to the node quadrature: mean |α|.
        let mean = |n: &[TangentNode]| n.iter().map(|n| n.weight * n.alpha_rad.abs()).sum::<f64>();
        let exact = mean(&c.nodes(0.01));
        assert!((mean(&c.equidistant(4096)) - exact).abs() < 1e-4);
        assert!((exact.to_degrees() - 35.0 * 2.0 / 3.0 - 35.0 / 6.0).abs() < 1e-6);
    }

    #[test]
    fn bad_curves_are_refused() {
        assert!(TangentCurve::new(&[0.0], &[]).is_err());
        assert!(TangentCurve::new(&[0.0, 1.0], &[0.0]).is_err());
        assert!(TangentCurve::new(&[0.0, 91.0], &[1.0]).is_err());
    }
}
