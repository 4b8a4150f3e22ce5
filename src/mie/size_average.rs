//! Size-distribution averages to a requested accuracy: an adaptive, nested radius rule with a
//! checked error estimate (decision MIE-18 in `docs/decisions.md`).
//!
//! A distribution average is `⟨v⟩ = ∫ n(r) v(r) dr` of a vector `v(r)` per drop: the
//! cross-section-weighted curve `C_sca(r) p(θ; r)` (point values, or cell averages on the
//! stage's intermediate grid), the number `1` and the cross-sections `π r²`, `C_ext`, `C_sca`,
//! `C_back`, `C_sca g` (all in µm²). The returned curve is `L(⟨C_sca p⟩)/⟨C_sca⟩`, where `L` is the
//! integrand's linear finishing map (identity for point values; sun disc, blur and output bins
//! for a table entry, [`RadiusIntegrand::finish`]).
//!
//! **Rule.** At a fixed angle the single-drop curve oscillates in the size parameter
//! `x = 2π r/λ` with a roughly constant period (interference of ray paths whose optical path
//! difference grows linearly with `x`), so the rule is uniform in `r` (equivalently in `x`):
//! the support is split into [`PANEL_QUANTILES`] panels at quantiles of `n(r) r²`, and each
//! panel carries a trapezoid rule with Gregory end corrections (weights `3/8, 7/6, 23/24, 1, …,
//! 1, 23/24, 7/6, 3/8` times the step; error `O(h⁴)` at a hard cut-off such as the
//! Marshall–Palmer limits, spectral where `n(r)` fades smoothly). A panel starts with
//! [`FIRST_INTERVALS`] intervals and is refined by halving its step; the coarser rule's nodes
//! are a subset of the finer one's, so a refinement evaluates only the new midpoints.
//!
//! **Error estimate.** For each panel, `Δ = Q_h − Q_{2h}` (the last two levels) propagated to
//! the returned quantity: `e = (L(Δ_curve) − out · Δ_{C_sca})/⟨C_sca⟩`, i.e. after the sun disc
//! and bins where the stage applies them (smoothing in angle averages the ripple in `x` away, so
//! the rule stops earlier than on point values). The entry's estimate is the RMS over the output
//! angles and both channels (`i_perp`, `i_par`) of `Σ_panels f |e|` relative to the returned
//! phase function, where `f = max(1, ρ/(1 − ρ))` extrapolates the panel's observed ratio `ρ` of
//! two successive differences (a geometric tail; `ρ ≤ 0.9`). `Δ` measures the error of the
//! coarser rule, so for fast convergence it over-estimates that of the returned finer one; for
//! slow, noise-like convergence (resonances sampled at random) `f` inflates it. Panels whose
//! step is at least [`UNRESOLVED_STEPS`] absorption-limited resonance widths (every panel for
//! clear water, [`RadiusIntegrand::resonance_width`]) hit the narrow resonances at random, so
//! their errors are independent: they enter the RMS in quadrature, `Σ_resolved f|e| +
//! (Σ_unresolved (f e)²)^{1/2}` per angle (decision MIE-19); the estimate of the maximum keeps the
//! plain sum, with each panel's `|e|` at an angle replaced by `max(|e|, max(ρ, 1/2) |e_prev|)`,
//! `e_prev` its previous halving's difference there (decision MIE-20). It is trusted only once
//! it has been seen to shrink on a rule fine enough not to alias the ripple: a panel is *settled* after at least two halvings, with its
//! last estimate no larger than the one before and a step of at most [`TRUSTED_STEP_X`] in `x`.
//!
//! **Stopping.** Refine the panel with the largest share `f |e|` of the estimate until the total is ≤ the tolerance
//! and every panel is settled (or negligible). A tolerance that cannot be met within the node
//! limit is [`SizeAverageError::NotConverged`], never a silent result.

use super::distributions::{RadiusSampler, SizeDistribution};
use super::filters::{
    FINE_CELL_POINTS, FilterSettings, PolarisedPhase, SunDiscOperator, gaussian_blur, resample_bins,
};
use super::{MieError, MirroredAmplitudes, Sphere, size_parameter};
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Default tolerance: RMS relative error of the returned curve (relative to the phase function).
pub const DEFAULT_TOLERANCE: f64 = 1e-3;
/// Default largest number of radius nodes (spheres) of one average.
pub const DEFAULT_MAX_NODES: usize = 100_000;
/// Panel boundaries: quantiles of the geometric cross-section weight `n(r) r²` (the support's
/// ends are the outer boundaries). Narrow panels where the weight is, wide ones in the tails,
/// each refined as far as its own share of the error asks.
pub const PANEL_QUANTILES: [f64; 9] = [1e-3, 0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.98, 0.999];
/// Intervals of a panel's first rule (7 nodes: the end corrections need six distinct nodes).
pub const FIRST_INTERVALS: usize = 6;
/// A panel whose estimate is below this fraction of the tolerance need not be settled.
pub const NEGLIGIBLE: f64 = 0.01;
/// Largest observed ratio of two successive estimates used by `Panel::extrapolation`.
pub const MAX_RATIO: f64 = 0.9;

/// Smallest ratio of successive halvings credited at a single angle by the maximum estimate.
pub const MIN_ANGLE_RATIO: f64 = 0.5;
/// Largest step in `x` at which a panel's estimate is trusted: a coarser rule can alias the
/// ripple in `x` (period ~1–10) so that two levels agree by coincidence.
pub const TRUSTED_STEP_X: f64 = 1.0;
/// How many times the widest absorption-limited resonance width a panel's step in `x` must be
/// for its errors to count as random hits of unresolved resonances (`Panel::unresolved`).
pub const UNRESOLVED_STEPS: f64 = 10.0;
/// Gregory end weights of the first (and, mirrored, last) three nodes.
const END_WEIGHTS: [f64; 3] = [3.0 / 8.0, 7.0 / 6.0, 23.0 / 24.0];
/// Scalars appended to every node's curve: the number 1, then the cross-sections `π r²`,
/// `C_ext`, `C_sca`, `C_back`, `C_sca g` (µm²).
pub const CROSS_SECTIONS: usize = 6;
const C_SCA: usize = 3;

/// Accuracy asked of an average and the work allowed for it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AverageLimits {
    /// Largest accepted error estimate: RMS over the returned angles and both channels of the
    /// error relative to the phase function.
    pub tolerance: f64,
    /// Largest accepted estimate of the maximum of that error over the angles and channels, if
    /// bounded (`None`: the maximum is estimated and reported, not bounded).
    pub max_tolerance: Option<f64>,
    /// Largest number of radius nodes (each one sphere).
    pub max_nodes: usize,
}

impl Default for AverageLimits {
    fn default() -> Self {
        AverageLimits {
            tolerance: DEFAULT_TOLERANCE,
            max_tolerance: None,
            max_nodes: DEFAULT_MAX_NODES,
        }
    }
}

impl AverageLimits {
    /// Checks the limits (tolerance in `[1e-6, 0.5]`, at least one first rule's nodes).
    pub fn validate(&self) -> Result<(), SizeAverageError> {
        if !(self.tolerance >= 1e-6 && self.tolerance <= 0.5) {
            return Err(SizeAverageError::Limits(format!(
                "tolerance must be in [1e-6, 0.5], got {}",
                self.tolerance
            )));
        }
        if let Some(m) = self.max_tolerance
            && !(m >= self.tolerance && m <= 1.0)
        {
            return Err(SizeAverageError::Limits(format!(
                "the maximum tolerance must be in [tolerance, 1] = [{}, 1], got {m}",
                self.tolerance
            )));
        }
        let least = (PANEL_QUANTILES.len() + 1) * (2 * FIRST_INTERVALS + 1);
        if self.max_nodes < least {
            return Err(SizeAverageError::Limits(format!(
                "the node limit must be at least {least} (two levels of every panel), got {}",
                self.max_nodes
            )));
        }
        Ok(())
    }
}

/// Why an average failed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SizeAverageError {
    #[error("size distribution: {0}")]
    Distribution(String),
    #[error("size average: {0}")]
    Limits(String),
    #[error("radius {radius_um} um: {source}")]
    Sphere { radius_um: f64, source: MieError },
    #[error(transparent)]
    Mie(#[from] MieError),
    #[error("the distribution scatters nothing (its integral of n(r) C_sca(r) dr is {0})")]
    NoScattering(f64),
    #[error(
        "the radius average did not reach the tolerance {tolerance:.1e}{}: estimated RMS relative error {estimate:.2e}, maximum {max_estimate:.2e} after {nodes} radius nodes, and the next refinement would exceed the limit of {max_nodes}; raise the node limit or the tolerance", max_tolerance.map_or(String::new(), |m| format!(" (maximum {m:.1e})"))
    )]
    NotConverged {
        tolerance: f64,
        max_tolerance: Option<f64>,
        estimate: f64,
        max_estimate: f64,
        nodes: usize,
        max_nodes: usize,
    },
}

/// What the rule integrates (see the module doc).
pub trait RadiusIntegrand: Sync {
    /// Length of the curve part of a node (both channels, `i_perp` first).
    fn curve_len(&self) -> usize;
    /// The node at `radius_um`: `curve_len()` curve values `C_sca p` followed by the
    /// [`CROSS_SECTIONS`] cross-sections (µm²).
    fn node(&self, radius_um: f64) -> Result<Vec<f64>, MieError>;
    /// [`Self::node`] at each of `radii_um`, in order (an integrand may share work between the
    /// drops of one batch).
    fn nodes(&self, radii_um: &[f64]) -> Vec<Result<Vec<f64>, MieError>> {
        radii_um.iter().map(|&r| self.node(r)).collect()
    }
    /// The returned curve (both channels, `i_perp` first, equal halves) from an integrated
    /// curve; linear.
    fn finish(&self, curve: &[f64]) -> Vec<f64>;
    /// `2π/λ` in µm⁻¹ (`x` per µm of radius).
    fn wavenumber_per_um(&self) -> f64;
    /// The width in `x`, relative to `x`, below which the absorption of the drops keeps no
    /// resonance (`Δx/x ≥ 2k/n` for `m = n + ik`: an internal mode's quality factor is at most
    /// `n/(2k)`); `None` when unknown. The estimate combines the panels that sample these
    /// resonances at random in quadrature (module doc).
    fn resonance_width(&self) -> Option<f64> {
        None
    }
}

/// A finished average.
#[derive(Debug, Clone, PartialEq)]
pub struct SizeAverage {
    /// Returned `i_perp` (1/sr).
    pub i_perp: Vec<f64>,
    /// Returned `i_par` (1/sr).
    pub i_par: Vec<f64>,
    /// `⟨C_ext⟩/⟨π r²⟩`.
    pub q_ext: f64,
    /// `⟨C_sca⟩/⟨π r²⟩`.
    pub q_sca: f64,
    /// `⟨C_back⟩/⟨π r²⟩` (radar convention).
    pub q_back: f64,
    /// `⟨C_sca g⟩/⟨C_sca⟩`.
    pub g: f64,
    /// `⟨π x² Q_sca⟩/⟨1⟩`: the mean over drops of the divisor turning `|S|²` into the phase
    /// function, so that `i_perp` times it is the mean `|S_1|²` per drop.
    pub phase_normalisation: f64,
    /// Error estimate (module doc); 0 for a monodisperse entry.
    pub error_estimate: f64,
    /// Estimate of the largest error over the angles and channels, relative to the phase
    /// function (the same per-angle estimate whose RMS is `error_estimate`); 0 for a
    /// monodisperse entry.
    pub max_error_estimate: f64,
    /// Radius nodes (spheres) evaluated.
    pub radius_nodes: usize,
    /// The final rule: radii (µm), increasing.
    pub radii_um: Vec<f64>,
    /// The final rule: weights `≈ n(r) dr` (the distribution's scale).
    pub weights: Vec<f64>,
}

/// One panel `[a, b]` of the rule and its two finest levels.
struct Panel {
    a: f64,
    b: f64,
    intervals: usize,
    /// Σ over all nodes of `n(r) v(r)`.
    sum: Vec<f64>,
    /// `n(r) v(r)` at nodes 0, 1, 2, N−2, N−1, N.
    ends: [Vec<f64>; 6],
    /// The rule's value at the current and the previous level.
    value: Vec<f64>,
    previous: Option<Vec<f64>>,
    /// `L(Δ_curve)` and `Δ_{C_sca}` of the last halving.
    finished_delta: Option<(Vec<f64>, f64)>,
    /// Its contribution to the entry's per-angle estimate of the maximum (extrapolated,
    /// relative to the phase function, MIE-20; empty before the first halving).
    error_by_angle: Vec<f64>,
    /// The last halving's per-angle difference before extrapolation (relative to the phase
    /// function), and the previous halving's (kept when the panel is refined).
    raw_by_angle: Vec<f64>,
    previous_raw_by_angle: Vec<f64>,
    /// Error estimate of the last and of the previous halving (module doc).
    error: f64,
    previous_error: f64,
    level: usize,
}

impl Panel {
    fn step(&self) -> f64 {
        (self.b - self.a) / self.intervals as f64
    }

    /// The Gregory-corrected trapezoid value from `sum` and `ends`.
    fn rule_value(&self) -> Vec<f64> {
        let h = self.step();
        let mut v = self.sum.clone();
        for (k, end) in self.ends.iter().enumerate() {
            let c = END_WEIGHTS[k.min(5 - k)] - 1.0;
            for (a, b) in v.iter_mut().zip(end) {
                *a += c * b;
            }
        }
        v.iter_mut().for_each(|a| *a *= h);
        v
    }

    /// Factor from the last difference to the remaining error: with the observed ratio
    /// `ρ = error/previous_error` of two halvings (clamped to [`MAX_RATIO`]), a geometric tail
    /// `ρ/(1 − ρ)`, never below 1 (the difference itself). Slow, noise-like convergence (the
    /// narrow resonances of clear water sampled at random) is inflated, fast convergence is not
    /// credited beyond the plain difference.
    fn extrapolation(&self) -> f64 {
        let rho = self.ratio();
        (rho / (1.0 - rho)).max(1.0)
    }

    /// The observed ratio `ρ = error/previous_error` of the last two halvings, clamped to
    /// [`MAX_RATIO`]; 0 before two halvings.
    fn ratio(&self) -> f64 {
        if !self.previous_error.is_finite() || !(self.previous_error > 0.0) {
            return 0.0;
        }
        (self.error / self.previous_error).min(MAX_RATIO)
    }

    /// Whether the panel's step is at least [`UNRESOLVED_STEPS`] times the widest
    /// absorption-limited resonance in it, `resonance_width · x_b` at its largest size
    /// parameter `x_b` (in `r`: `resonance_width · b`; `resonance_width` =
    /// [`RadiusIntegrand::resonance_width`], `None`: never). Such a rule hits the resonances at
    /// random (module doc).
    fn unresolved(&self, resonance_width: Option<f64>) -> bool {
        resonance_width.is_some_and(|w| self.step() >= UNRESOLVED_STEPS * w * self.b)
    }

    /// Whether the panel's estimate can be trusted (module doc): two halvings, the last
    /// estimate no larger than the one before, and a step of at most [`TRUSTED_STEP_X`] in `x`
    /// (`x_per_um` = 2π/λ); or an estimate below [`NEGLIGIBLE`] of the tolerance.
    fn settled(&self, tolerance: f64, x_per_um: f64) -> bool {
        (self.level >= 2
            && self.error <= self.previous_error
            && self.step() * x_per_um <= TRUSTED_STEP_X)
            || (self.level >= 1 && self.error <= NEGLIGIBLE * tolerance)
    }
}

/// Node values kept apart from a sum, with their indices.
type KeptNodes = Vec<(usize, Vec<f64>)>;

/// Largest number of drops whose angular sums [`RadiusIntegrand::nodes`] is given at once.
pub const MAX_BATCH: usize = 16;

/// Drops per batch for `count` new nodes: at most [`MAX_BATCH`], and small enough that every
/// thread of the pool gets about four batches (rayon balances them).
fn batch_size(count: usize) -> usize {
    (count / (4 * rayon::current_num_threads())).clamp(1, MAX_BATCH)
}

/// `n(r) v(r)` at the nodes `indices` of a rule of `intervals` intervals on `[a, b]`, summed,
/// with the values at `keep` indices returned separately (in parallel over batches of adjacent
/// nodes, [`RadiusIntegrand::nodes`]).
fn evaluate_nodes<I: RadiusIntegrand>(
    distribution: &SizeDistribution,
    integrand: &I,
    (a, b, intervals): (f64, f64, usize),
    indices: &[usize],
    keep: &[usize],
) -> Result<(Vec<f64>, KeptNodes), SizeAverageError> {
    let len = integrand.curve_len() + CROSS_SECTIONS;
    let h = (b - a) / intervals as f64;
    let zero = || (vec![0.0; len], Vec::new());
    let radius = |i: usize| if i == intervals { b } else { a + h * i as f64 };
    indices
        .par_chunks(batch_size(indices.len()))
        .flat_map_iter(|batch| {
            let radii: Vec<f64> = batch.iter().map(|&i| radius(i)).collect();
            let values = integrand.nodes(&radii);
            batch.iter().zip(radii).zip(values).map(|((&i, r), v)| {
                let mut v = v.map_err(|source| SizeAverageError::Sphere {
                    radius_um: r,
                    source,
                })?;
                let n = distribution.density(r);
                v.iter_mut().for_each(|x| *x *= n);
                Ok((i, v))
            })
        })
        .try_fold(zero, |mut acc, item: Result<_, SizeAverageError>| {
            let (i, v) = item?;
            acc.0.iter_mut().zip(&v).for_each(|(s, x)| *s += x);
            if keep.contains(&i) {
                acc.1.push((i, v));
            }
            Ok(acc)
        })
        .try_reduce(zero, |mut x, y| {
            x.0.iter_mut().zip(&y.0).for_each(|(s, v)| *s += v);
            x.1.extend(y.1);
            Ok(x)
        })
}

fn take(kept: &mut KeptNodes, index: usize) -> Vec<f64> {
    let at = kept
        .iter()
        .position(|(i, _)| *i == index)
        .expect("kept node");
    kept.swap_remove(at).1
}

impl Panel {
    /// The first rule of `[a, b]` ([`FIRST_INTERVALS`] intervals).
    fn new<I: RadiusIntegrand>(
        distribution: &SizeDistribution,
        integrand: &I,
        a: f64,
        b: f64,
    ) -> Result<Self, SizeAverageError> {
        let n = FIRST_INTERVALS;
        let all: Vec<usize> = (0..=n).collect();
        let keep = [0, 1, 2, n - 2, n - 1, n];
        let (sum, mut kept) = evaluate_nodes(distribution, integrand, (a, b, n), &all, &keep)?;
        let ends = keep.map(|i| take(&mut kept, i));
        let mut p = Panel {
            a,
            b,
            intervals: n,
            sum,
            ends,
            value: Vec::new(),
            previous: None,
            finished_delta: None,
            error_by_angle: Vec::new(),
            raw_by_angle: Vec::new(),
            previous_raw_by_angle: Vec::new(),
            error: f64::INFINITY,
            previous_error: f64::INFINITY,
            level: 0,
        };
        p.value = p.rule_value();
        Ok(p)
    }

    /// Halves the step: evaluates the new midpoints and keeps the last two values.
    fn refine<I: RadiusIntegrand>(
        &mut self,
        distribution: &SizeDistribution,
        integrand: &I,
    ) -> Result<(), SizeAverageError> {
        let n = 2 * self.intervals;
        let new: Vec<usize> = (1..n).step_by(2).collect();
        let (sum, mut kept) = evaluate_nodes(
            distribution,
            integrand,
            (self.a, self.b, n),
            &new,
            &[1, n - 1],
        )?;
        self.sum.iter_mut().zip(&sum).for_each(|(s, v)| *s += v);
        let [e0, e1, _, _, e4, e5] = std::mem::take(&mut self.ends);
        self.ends = [e0, take(&mut kept, 1), e1, e4, take(&mut kept, n - 1), e5];
        self.intervals = n;
        self.level += 1;
        let value = self.rule_value();
        self.previous = Some(std::mem::replace(&mut self.value, value));
        let curve_len = integrand.curve_len();
        let delta: Vec<f64> = self
            .value
            .iter()
            .zip(self.previous.as_deref().unwrap_or_default())
            .map(|(a, b)| a - b)
            .collect();
        self.finished_delta = Some((
            integrand.finish(&delta[..curve_len]),
            delta[curve_len + C_SCA],
        ));
        Ok(())
    }

    /// Nodes of the current rule: radii and weights.
    fn rule(&self, distribution: &SizeDistribution) -> Vec<(f64, f64)> {
        let (n, h) = (self.intervals, self.step());
        (0..=n)
            .map(|i| {
                let r = if i == n {
                    self.b
                } else {
                    self.a + h * i as f64
                };
                let c = if i < 3 {
                    END_WEIGHTS[i]
                } else if n - i < 3 {
                    END_WEIGHTS[n - i]
                } else {
                    1.0
                };
                (r, h * c * distribution.density(r))
            })
            .collect()
    }
}

/// Panel boundaries: the support's ends and the quantiles [`PANEL_QUANTILES`] of `n(r) r²`.
pub fn panel_bounds(distribution: &SizeDistribution) -> Vec<f64> {
    let (lo, hi) = distribution.support_um();
    let sampler = RadiusSampler::new(distribution, 0.0);
    let mut bounds = vec![lo];
    for u in PANEL_QUANTILES {
        let r = sampler.sample(distribution, u).0;
        let last = *bounds.last().expect("non-empty");
        if r > last * (1.0 + 1e-6) && r < hi * (1.0 - 1e-6) {
            bounds.push(r);
        }
    }
    bounds.push(hi);
    bounds
}

/// Radius nodes the rule is expected to use at `tolerance` (planning only; measured on fog,
/// cloud and rain entries with 1° bins and slightly absorbing drops: 1200–1500 nodes at 1e-2,
/// 2200–3200 at 1e-3; clear water needs 5–20× more, see [`EXPECTED_NODES_AT_1E3`]), so
/// `EXPECTED_NODES_AT_1E3 · (1e-3/tolerance)^0.4`, spread uniformly in `r` between the first
/// and last panel quantiles (for the cost of each sphere).
pub fn planned_radii_um(distribution: &SizeDistribution, tolerance: f64) -> Vec<f64> {
    if let SizeDistribution::Monodisperse { radius_um } = *distribution {
        return vec![radius_um];
    }
    let nodes = (EXPECTED_NODES_AT_1E3 * (1e-3 / tolerance.max(1e-6)).powf(0.4)).ceil() as usize;
    let sampler = RadiusSampler::new(distribution, 0.0);
    let lo = sampler.sample(distribution, PANEL_QUANTILES[0]).0;
    let hi = sampler
        .sample(distribution, PANEL_QUANTILES[PANEL_QUANTILES.len() - 1])
        .0;
    (0..nodes)
        .map(|i| lo + (hi - lo) * (i as f64 + 0.5) / nodes as f64)
        .collect()
}

/// Expected nodes of a distribution entry of clear water at tolerance 1e-3
/// ([`planned_radii_um`]): with 2500, `examples/plan_check.rs` measured 0.11 (fog lognormal
/// 6 µm / 1.35) and 0.52 (Marshall–Palmer 50–100 µm) of the actual CPU time (550 nm, 0.5° bins,
/// 0.5° sun disc, 198 s and 257 s); 10 000 splits the difference (≈ 0.45 and 2.1).
pub const EXPECTED_NODES_AT_1E3: f64 = 10_000.0;

/// The returned curve and its phase function from the panels' values.
struct Totals {
    total: Vec<f64>,
    out: Vec<f64>,
    phase: Vec<f64>,
}

fn totals<I: RadiusIntegrand>(panels: &[Panel], integrand: &I) -> Result<Totals, SizeAverageError> {
    let len = integrand.curve_len() + CROSS_SECTIONS;
    let mut total = vec![0.0; len];
    for p in panels {
        total.iter_mut().zip(&p.value).for_each(|(s, v)| *s += v);
    }
    let c_sca = total[integrand.curve_len() + C_SCA];
    if !(c_sca > 0.0 && c_sca.is_finite()) {
        return Err(SizeAverageError::NoScattering(c_sca));
    }
    let mut out = integrand.finish(&total[..integrand.curve_len()]);
    out.iter_mut().for_each(|v| *v /= c_sca);
    let k = out.len() / 2;
    let phase = (0..k).map(|j| 0.5 * (out[j] + out[k + j])).collect();
    Ok(Totals { total, out, phase })
}

/// The entry's error estimate: RMS and maximum over the angles and channels (with a positive
/// phase function), and where the maximum is.
struct Estimate {
    rms: f64,
    max: f64,
    at: usize,
}

/// Updates every panel's error from its last halving against the current totals; returns the
/// entry's estimate (module doc): per panel the error vector of the last halving, scaled by
/// [`Panel::extrapolation`]. The maximum over angles and channels is that of their sum in
/// absolute value over panels; the RMS is that of the same sum, except that the panels whose
/// step leaves the resonances unresolved (`unresolved`, [`Panel::unresolved`]) enter it in
/// quadrature (independent random errors, see the module doc).
fn estimate(panels: &mut [Panel], t: &Totals, c_sca: f64, unresolved: &[bool]) -> Estimate {
    let k = t.phase.len();
    let mut combined = vec![0.0; 2 * k];
    let mut resolved_sum = vec![0.0; 2 * k];
    let mut unresolved_sq = vec![0.0; 2 * k];
    for (p, &noise) in panels.iter_mut().zip(unresolved) {
        let Some((fd, dc)) = &p.finished_delta else {
            continue;
        };
        let (mut sq, mut count) = (0.0, 0usize);
        let mut e = vec![0.0; 2 * k];
        for (j, ej) in e.iter_mut().enumerate() {
            let ph = t.phase[j % k];
            *ej = if ph > 0.0 {
                ((fd[j] - t.out[j] * dc) / c_sca).abs() / ph
            } else {
                0.0
            };
            sq += *ej * *ej;
            count += usize::from(ph > 0.0);
        }
        p.error = (sq / count.max(1) as f64).sqrt();
        let factor = p.extrapolation();
        // The maximum: at each angle the larger of the last difference and the previous one
        // times the panel's observed ratio, at least 1/2 (no angle is credited with more than
        // halving its error per halving), so that an angle where the last halving happened to
        // change little keeps the error its previous halving supports (MIE-20).
        let rho = p.ratio().max(MIN_ANGLE_RATIO);
        let contribution: Vec<f64> = (0..2 * k)
            .map(|j| {
                let previous = p.previous_raw_by_angle.get(j).map_or(0.0, |v| rho * v);
                factor * e[j].max(previous)
            })
            .collect();
        combined
            .iter_mut()
            .zip(&contribution)
            .for_each(|(c, v)| *c += v);
        p.raw_by_angle.clone_from(&e);
        e.iter_mut().for_each(|v| *v *= factor);
        if noise {
            unresolved_sq
                .iter_mut()
                .zip(&e)
                .for_each(|(c, v)| *c += v * v);
        } else {
            resolved_sum.iter_mut().zip(&e).for_each(|(c, v)| *c += v);
        }
        p.error_by_angle = contribution;
    }
    let kept = |j: &usize| t.phase[j % k] > 0.0;
    let n = (0..2 * k).filter(kept).count();
    let (at, max) = (0..2 * k)
        .filter(kept)
        .map(|j| (j, combined[j]))
        .fold((0, 0.0), |m, c| if c.1 > m.1 { c } else { m });
    let square = |j: usize| (resolved_sum[j] + unresolved_sq[j].sqrt()).powi(2);
    Estimate {
        rms: ((0..2 * k).map(square).sum::<f64>() / n.max(1) as f64).sqrt(),
        max,
        at,
    }
}

/// The panel to refine next: while the RMS is over the tolerance, the panel of the largest
/// RMS error; while only the maximum is over its bound, the panel contributing most where the
/// maximum is; once both are met, the unsettled panel of the largest error (`None`: done).
fn next_panel(
    panels: &[Panel],
    e: &Estimate,
    limits: &AverageLimits,
    x_per_um: f64,
) -> Option<usize> {
    let tol = limits.tolerance;
    // a panel's share of the estimate is its last difference times its extrapolation
    let share = |p: &Panel| p.error * p.extrapolation();
    let by_error = |a: &(usize, &Panel), b: &(usize, &Panel)| share(a.1).total_cmp(&share(b.1));
    let pick = if e.rms > tol {
        panels.iter().enumerate().max_by(by_error)
    } else if limits.max_tolerance.is_some_and(|m| e.max > m) {
        let at = |p: &Panel| p.error_by_angle.get(e.at).copied().unwrap_or(0.0);
        panels
            .iter()
            .enumerate()
            .max_by(|a, b| at(a.1).total_cmp(&at(b.1)))
    } else {
        panels
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.settled(tol, x_per_um))
            .max_by(by_error)
    };
    pick.map(|(i, _)| i)
}

/// Averages `integrand` over `distribution` to `limits` (module doc). A monodisperse
/// distribution is its one sphere (estimate 0).
pub fn average<I: RadiusIntegrand>(
    distribution: &SizeDistribution,
    integrand: &I,
    limits: &AverageLimits,
) -> Result<SizeAverage, SizeAverageError> {
    distribution
        .validate()
        .map_err(SizeAverageError::Distribution)?;
    if let SizeDistribution::Monodisperse { radius_um } = *distribution {
        return monodisperse(integrand, radius_um);
    }
    limits.validate()?;
    let bounds = panel_bounds(distribution);
    let mut panels = bounds
        .windows(2)
        .map(|w| Panel::new(distribution, integrand, w[0], w[1]))
        .collect::<Result<Vec<_>, _>>()?;
    let mut nodes: usize = panels.iter().map(|p| p.intervals + 1).sum();
    for p in panels.iter_mut() {
        p.refine(distribution, integrand)?;
        nodes += p.intervals / 2;
    }
    loop {
        let t = totals(&panels, integrand)?;
        let c_sca = t.total[integrand.curve_len() + C_SCA];
        let unresolved: Vec<bool> = panels
            .iter()
            .map(|p| p.unresolved(integrand.resonance_width()))
            .collect();
        let error = estimate(&mut panels, &t, c_sca, &unresolved);
        let Some(i) = next_panel(&panels, &error, limits, integrand.wavenumber_per_um()) else {
            return Ok(finish_average(
                distribution,
                &panels,
                &t,
                &error,
                nodes,
                integrand,
            ));
        };
        let more = panels[i].intervals;
        if nodes + more > limits.max_nodes {
            return Err(SizeAverageError::NotConverged {
                tolerance: limits.tolerance,
                max_tolerance: limits.max_tolerance,
                estimate: error.rms,
                max_estimate: error.max,
                nodes,
                max_nodes: limits.max_nodes,
            });
        }
        let prior = panels[i].error;
        panels[i].previous_raw_by_angle = std::mem::take(&mut panels[i].raw_by_angle);
        panels[i].refine(distribution, integrand)?;
        panels[i].previous_error = prior;
        nodes += more;
    }
}

fn finish_average<I: RadiusIntegrand>(
    distribution: &SizeDistribution,
    panels: &[Panel],
    t: &Totals,
    error: &Estimate,
    radius_nodes: usize,
    integrand: &I,
) -> SizeAverage {
    let mut rule: Vec<(f64, f64)> = Vec::new();
    for p in panels {
        for (r, w) in p.rule(distribution) {
            match rule.last_mut() {
                Some(last) if last.0 == r => last.1 += w,
                _ => rule.push((r, w)),
            }
        }
    }
    scalars(
        &t.out,
        &t.total[integrand.curve_len()..],
        integrand.wavenumber_per_um(),
        (error.rms, error.max),
        radius_nodes,
        rule,
    )
}

/// A [`SizeAverage`] from the returned curve `out` (both channels), the integrated scalars
/// (node layout) and the rule.
fn scalars(
    out: &[f64],
    cs: &[f64],
    wavenumber_per_um: f64,
    (error_estimate, max_error_estimate): (f64, f64),
    radius_nodes: usize,
    rule: Vec<(f64, f64)>,
) -> SizeAverage {
    let k = out.len() / 2;
    SizeAverage {
        i_perp: out[..k].to_vec(),
        i_par: out[k..].to_vec(),
        q_ext: cs[2] / cs[1],
        q_sca: cs[3] / cs[1],
        q_back: cs[4] / cs[1],
        g: cs[5] / cs[3],
        phase_normalisation: wavenumber_per_um * wavenumber_per_um * cs[3] / cs[0],
        error_estimate,
        max_error_estimate,
        radius_nodes,
        radii_um: rule.iter().map(|p| p.0).collect(),
        weights: rule.iter().map(|p| p.1).collect(),
    }
}

fn monodisperse<I: RadiusIntegrand>(
    integrand: &I,
    radius_um: f64,
) -> Result<SizeAverage, SizeAverageError> {
    let v = integrand
        .node(radius_um)
        .map_err(|source| SizeAverageError::Sphere { radius_um, source })?;
    let len = integrand.curve_len();
    let cs = &v[len..];
    if !(cs[C_SCA] > 0.0) {
        return Err(SizeAverageError::NoScattering(cs[C_SCA]));
    }
    let out: Vec<f64> = integrand
        .finish(&v[..len])
        .iter()
        .map(|x| x / cs[C_SCA])
        .collect();
    Ok(scalars(
        &out,
        cs,
        integrand.wavenumber_per_um(),
        (0.0, 0.0),
        1,
        vec![(radius_um, 1.0)],
    ))
}

/// The number 1 and the cross-sections of a sphere of radius `radius_um` (µm²), in the node
/// layout.
fn cross_sections(sphere: &Sphere, radius_um: f64) -> [f64; CROSS_SECTIONS] {
    let e = sphere.efficiencies;
    let area = PI * radius_um * radius_um;
    [
        1.0,
        area,
        area * e.q_ext,
        area * e.q_sca,
        area * e.q_back,
        area * e.q_sca * e.g,
    ]
}

/// Point values of the curve at arbitrary angles (no smoothing): `C_sca p = r² |S|²/x²`.
/// Angles `θ` and `180° − θ` share one evaluation of the series.
pub struct PointAngles {
    wavelength_nm: f64,
    m: Complex64,
    /// Cosines of the distinct angles folded into `[0°, 90°]`.
    mu: Vec<f64>,
    /// Per requested angle: index into `mu` and whether it is the mirror `180° − θ`.
    map: Vec<(usize, bool)>,
}

impl PointAngles {
    /// Drops of index `m` relative to the medium, wavelength `wavelength_nm` in the medium.
    pub fn new(wavelength_nm: f64, m: Complex64, angles_deg: &[f64]) -> Self {
        let mut folded: Vec<f64> = angles_deg.iter().map(|&a| a.min(180.0 - a)).collect();
        folded.sort_by(f64::total_cmp);
        folded.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let map = angles_deg
            .iter()
            .map(|&a| {
                let f = a.min(180.0 - a);
                let i = folded.partition_point(|v| *v < f - 1e-12);
                (i.min(folded.len().saturating_sub(1)), a > 90.0)
            })
            .collect();
        PointAngles {
            wavelength_nm,
            m,
            mu: folded.iter().map(|a| a.to_radians().cos()).collect(),
            map,
        }
    }
}

impl PointAngles {
    /// The node vector of a solved sphere from its amplitudes at `self.mu` and their mirrors.
    fn node_values(&self, sphere: &Sphere, radius_um: f64, amp: &MirroredAmplitudes) -> Vec<f64> {
        let x = sphere.size_parameter();
        let scale = radius_um * radius_um / (x * x);
        let k = self.map.len();
        let mut v = vec![0.0; 2 * k + CROSS_SECTIONS];
        for (j, &(i, mirrored)) in self.map.iter().enumerate() {
            let (s1, s2) = if mirrored {
                (amp.s1_mirror[i], amp.s2_mirror[i])
            } else {
                (amp.s1[i], amp.s2[i])
            };
            v[j] = scale * s1.norm_sqr();
            v[k + j] = scale * s2.norm_sqr();
        }
        v[2 * k..].copy_from_slice(&cross_sections(sphere, radius_um));
        v
    }
}

impl RadiusIntegrand for PointAngles {
    fn curve_len(&self) -> usize {
        2 * self.map.len()
    }
    fn node(&self, radius_um: f64) -> Result<Vec<f64>, MieError> {
        let sphere = Sphere::new(size_parameter(radius_um, self.wavelength_nm), self.m)?;
        let amp = sphere.amplitudes_mirrored(&self.mu, false);
        Ok(self.node_values(&sphere, radius_um, &amp))
    }
    /// The batch's spheres share the angular functions ([`Sphere::amplitudes_mirrored_batch`]).
    fn nodes(&self, radii_um: &[f64]) -> Vec<Result<Vec<f64>, MieError>> {
        let solved: Vec<Result<Sphere, MieError>> = radii_um
            .iter()
            .map(|&r| Sphere::new(size_parameter(r, self.wavelength_nm), self.m))
            .collect();
        let (spheres, radii): (Vec<&Sphere>, Vec<f64>) = solved
            .iter()
            .zip(radii_um)
            .filter_map(|(s, &r)| s.as_ref().ok().map(|s| (s, r)))
            .unzip();
        let amps = Sphere::amplitudes_mirrored_batch(&spheres, &self.mu);
        let mut values: Vec<Vec<f64>> = spheres
            .iter()
            .zip(radii)
            .zip(&amps)
            .map(|((s, r), amp)| self.node_values(s, r, amp))
            .collect();
        values.reverse();
        solved
            .into_iter()
            .map(|s| s.map(|_| values.pop().expect("one value per solved sphere")))
            .collect()
    }
    fn finish(&self, curve: &[f64]) -> Vec<f64> {
        curve.to_vec()
    }
    fn wavenumber_per_um(&self) -> f64 {
        size_parameter(1.0, self.wavelength_nm)
    }
    fn resonance_width(&self) -> Option<f64> {
        Some(absorption_width(self.m))
    }
}

/// A table entry of the `mie` stage: every node's exact cell averages on its fine grid,
/// resampled to the intermediate grid; finished by the sun disc, the optional blur and the
/// output bins.
pub struct BinnedCurve<'a> {
    wavelength_nm: f64,
    m: Complex64,
    settings: &'a FilterSettings,
    sun: &'a SunDiscOperator,
    mid: usize,
}

impl<'a> BinnedCurve<'a> {
    /// `sun` must be [`FilterSettings::sun_operator`] of `settings`; wavelength and index in
    /// the medium.
    pub fn new(
        wavelength_nm: f64,
        m: Complex64,
        settings: &'a FilterSettings,
        sun: &'a SunDiscOperator,
    ) -> Self {
        BinnedCurve {
            wavelength_nm,
            m,
            settings,
            sun,
            mid: settings.intermediate_intervals(),
        }
    }

    /// The output curve of a finished vector (`i_perp` then `i_par`).
    pub fn to_phase(values: &[f64]) -> PolarisedPhase {
        let k = values.len() / 2;
        PolarisedPhase {
            step_deg: 180.0 / (k - 1) as f64,
            i_perp: values[..k].to_vec(),
            i_par: values[k..].to_vec(),
        }
    }
}

impl RadiusIntegrand for BinnedCurve<'_> {
    fn curve_len(&self) -> usize {
        2 * (self.mid + 1)
    }
    fn node(&self, radius_um: f64) -> Result<Vec<f64>, MieError> {
        let sphere = Sphere::new(size_parameter(radius_um, self.wavelength_nm), self.m)?;
        let fine_cells =
            FilterSettings::fine_grid_intervals(self.mid, sphere.coefficients.n_stop());
        let fine = PolarisedPhase::from_sphere(&sphere, fine_cells, FINE_CELL_POINTS, false);
        let curve = resample_bins(&fine, self.mid);
        let cs = cross_sections(&sphere, radius_um);
        let mut v: Vec<f64> = curve
            .i_perp
            .iter()
            .chain(&curve.i_par)
            .map(|p| p * cs[C_SCA])
            .collect();
        v.extend_from_slice(&cs);
        Ok(v)
    }
    fn finish(&self, curve: &[f64]) -> Vec<f64> {
        let c = Self::to_phase(curve);
        let c = gaussian_blur(&self.sun.apply(&c), self.settings.gaussian_sigma_deg);
        let c = resample_bins(&c, self.settings.output_intervals);
        c.i_perp.into_iter().chain(c.i_par).collect()
    }
    fn wavenumber_per_um(&self) -> f64 {
        size_parameter(1.0, self.wavelength_nm)
    }
    fn resonance_width(&self) -> Option<f64> {
        Some(absorption_width(self.m))
    }
}

/// `2k/n` for `m = n + ik`: the smallest relative width `Δx/x` of a resonance of drops of that
/// index ([`RadiusIntegrand::resonance_width`]).
fn absorption_width(m: Complex64) -> f64 {
    2.0 * m.im.max(0.0) / m.re
}

/// The average of `distribution` at point angles `angles_deg` (degrees in `[0, 180]`) for drops
/// of index `m` relative to the medium at the wavelength `wavelength_nm` in the medium (see
/// [`super::in_medium`]), to `limits`: the engine of `mie_distribution` (Python) and
/// `scatterbake mie --distribution`.
pub fn average_at_angles(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    angles_deg: &[f64],
    limits: &AverageLimits,
) -> Result<SizeAverage, SizeAverageError> {
    if angles_deg.is_empty() || angles_deg.iter().any(|a| !(0.0..=180.0).contains(a)) {
        return Err(SizeAverageError::Limits(
            "angles must be a non-empty list of degrees in [0, 180]".into(),
        ));
    }
    average(
        distribution,
        &PointAngles::new(wavelength_nm, m, angles_deg),
        limits,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar integrand `C_sca p = r^k` with cross-sections `1, r², …` (exercises the rule).
    struct Power(i32);
    impl RadiusIntegrand for Power {
        fn curve_len(&self) -> usize {
            2
        }
        fn node(&self, r: f64) -> Result<Vec<f64>, MieError> {
            let v = r.powi(self.0);
            Ok(vec![v, v, 1.0, r * r, r * r, r * r, r * r, r * r])
        }
        fn finish(&self, curve: &[f64]) -> Vec<f64> {
            curve.to_vec()
        }
        fn wavenumber_per_um(&self) -> f64 {
            1.0
        }
    }

    /// The Gregory-corrected panels reproduce a closed-form ratio at a hard cut-off:
    /// Marshall–Palmer `∫ r⁴ e^{−c r} dr / ∫ r² e^{−c r} dr` over `[50, 100]` µm.
    #[test]
    fn rule_matches_closed_form_with_hard_cut_offs() {
        let d = SizeDistribution::MarshallPalmer {
            rain_rate_mm_h: 5.0,
            min_radius_um: 50.0,
            max_radius_um: 100.0,
        };
        let a = average(&d, &Power(4), &AverageLimits::default()).unwrap();
        let c = 4.1 * 5f64.powf(-0.21) * 2e-3;
        // ∫ r^k e^{-c r} dr by a dense Gauss–Legendre rule (independent of the panels)
        let moment = |k: i32| {
            crate::math::quadrature::integrate(|r| r.powi(k) * (-c * r).exp(), 50.0, 100.0, 64)
        };
        let exact = moment(4) / moment(2);
        // the estimate (of the coarser rule) bounds the error of the returned one
        let error = (a.i_perp[0] / exact - 1.0).abs();
        assert!(
            error <= a.error_estimate && a.error_estimate < 1e-6,
            "{error} {}",
            a.error_estimate
        );
        // a smooth integrand settles after the first halvings of every panel
        let panels = panel_bounds(&d).len() - 1;
        assert!(
            a.radius_nodes <= panels * (4 * FIRST_INTERVALS + 1),
            "{}",
            a.radius_nodes
        );
        let w: f64 = a.weights.iter().sum();
        assert!((w / moment(0) - 1.0).abs() < 1e-6);
    }

    /// A tolerance that the node limit cannot reach is an error naming both, not a result.
    #[test]
    fn unmet_tolerance_is_an_error() {
        let d = SizeDistribution::Lognormal {
            median_radius_um: 6.0,
            geometric_sigma: 1.35,
        };
        let limits = AverageLimits {
            tolerance: 1e-4,
            max_tolerance: None,
            max_nodes: 300,
        };
        let e = average_at_angles(
            &d,
            550.0,
            Complex64::new(1.333, 0.0),
            &[30.0, 140.0],
            &limits,
        )
        .unwrap_err();
        let SizeAverageError::NotConverged {
            estimate, nodes, ..
        } = e
        else {
            panic!("{e}");
        };
        assert!(estimate > 1e-4 && nodes <= 300, "{estimate} {nodes}");
        assert!(e.to_string().contains("1.0e-4"), "{e}");
        for bad in [0.0, f64::NAN, 0.7] {
            let l = AverageLimits {
                tolerance: bad,
                max_tolerance: None,
                max_nodes: 1000,
            };
            assert!(average_at_angles(&d, 550.0, Complex64::new(1.333, 0.0), &[30.0], &l).is_err());
        }
        for bad_max in [1e-5, f64::NAN, 2.0] {
            let l = AverageLimits {
                tolerance: 1e-3,
                max_tolerance: Some(bad_max),
                max_nodes: 1000,
            };
            let e = average_at_angles(&d, 550.0, Complex64::new(1.333, 0.0), &[30.0], &l);
            assert!(e.unwrap_err().to_string().contains("maximum tolerance"));
        }
        let l = AverageLimits::default();
        assert!(average_at_angles(&d, 550.0, Complex64::new(1.333, 0.0), &[181.0], &l).is_err());
    }

    /// A batch of drops gives each drop's own node, in order, with a drop outside the
    /// validated domain as its error in its place.
    #[test]
    fn batched_nodes_are_the_single_nodes() {
        let angles: Vec<f64> = (0..=60).map(|j| j as f64 * 3.0).collect();
        let p = PointAngles::new(550.0, Complex64::new(1.333, 0.0), &angles);
        let radii = [3.0, 20.0, 1e4, 7.5, 0.01];
        let batch = p.nodes(&radii);
        assert_eq!(batch.len(), radii.len());
        for (&r, b) in radii.iter().zip(&batch) {
            match (p.node(r), b) {
                (Ok(one), Ok(b)) => {
                    for (u, w) in one.iter().zip(b) {
                        assert!((u - w).abs() <= 1e-12 * u.abs(), "r = {r}: {u} {w}");
                    }
                }
                (Err(e), Err(f)) => assert_eq!(&e, f),
                (one, b) => panic!("r = {r}: {one:?} against {b:?}"),
            }
        }
        assert!(batch[2].is_err() && batch[3].is_ok());
    }

    /// A monodisperse entry is its sphere; mirrored angles share the series correctly.
    #[test]
    fn monodisperse_is_the_sphere() {
        let d = SizeDistribution::Monodisperse { radius_um: 3.0 };
        let m = Complex64::new(1.333, 0.001);
        let angles = [0.0, 10.0, 89.5, 90.0, 90.5, 170.0, 180.0];
        let a = average_at_angles(&d, 550.0, m, &angles, &AverageLimits::default()).unwrap();
        let s = Sphere::new(size_parameter(3.0, 550.0), m).unwrap();
        let (s1, s2) = s.amplitudes_deg(&angles);
        let norm = s.phase_normalisation();
        for j in 0..angles.len() {
            assert!(
                (a.i_perp[j] / (s1[j].norm_sqr() / norm) - 1.0).abs() < 1e-12,
                "{j}"
            );
            assert!(
                (a.i_par[j] / (s2[j].norm_sqr() / norm) - 1.0).abs() < 1e-12,
                "{j}"
            );
        }
        assert!((a.q_ext / s.efficiencies.q_ext - 1.0).abs() < 1e-12);
        assert!((a.phase_normalisation / norm - 1.0).abs() < 1e-12);
        assert_eq!((a.radius_nodes, a.error_estimate), (1, 0.0));
    }
}
