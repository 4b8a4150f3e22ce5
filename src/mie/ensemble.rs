//! Size-distribution averages by joint stratified sampling of radius and angle (decision
//! MIE-16 in `docs/decisions.md`).
//!
//! A table value of a size distribution is a double integral: over radius (weight
//! `n(r) C_sca(r)`) and over the table's angular cell (solid-angle average). For drops of a few
//! hundred µm the single-sphere curve ripples in both `r` and `θ` much faster than the output
//! resolves, so resolving either integral point by point (a fine angular grid of `n_stop` cells
//! per radius, a radius rule that follows the ripple in `x`) is wasted work. Here both are
//! sampled jointly and unbiasedly:
//!
//! - **Radius**: importance sampling with density `q(r) ∝ n(r) r²` (the geometric cross-section
//!   weight, within a few per cent of `n(r) C_sca(r)` for drops with `x ≫ 1`), through its
//!   inverse cumulative distribution ([`RadiusSampler`]); each *round* draws one radius per
//!   stratum of `strata` equal-probability strata (jittered). A node's weight is
//!   `n(r) C_sca(r)/q(r)`, so the estimator of the mix is `Σ w_k p_k / Σ w_k`. The tails of
//!   `n(r) r²` beyond [`TRUNCATION`] of its mass are dropped (stated bound below).
//! - **Angle**: per radius node, cells of the intermediate grid within [`EXACT_DEG`] of 0° and
//!   180° (diffraction peak and glory, where the curve spans decades within a cell) are exact
//!   cell averages (Gauss–Legendre sub-cells of at most one ripple period, as
//!   [`PolarisedPhase::from_sphere`]); elsewhere one cosine is drawn uniformly (in solid angle)
//!   in each block of `block_cells` cells and its value, times `ΔΩ_block/ΔΩ_cell`, is credited
//!   to the cell it falls in: an unbiased estimate of every cell average ([`sample_sphere`]).
//! - **Error**: rounds are independent replicates, so the spread of their outputs (after the
//!   sun disc and bin averaging) estimates the standard error of the pooled mean; rounds are
//!   added (doubling) until the estimate meets the tolerance (the caller's loop,
//!   [`compute_entry`]).
//!
//! Everything is deterministic: the pseudo-random numbers come from [`SplitMix64`] seeded by
//! the entry, the wavelength and the node.

use super::distributions::SizeDistribution;
use super::filters::{
    FINE_CELL_POINTS, FilterSettings, PolarisedPhase, SunDiscOperator, cell_solid_angles,
    gaussian_blur, resample_bins,
};
use super::{MieError, Sphere, size_parameter};
use num_complex::Complex64;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Mass of `n(r) r²` dropped from each tail of the support (so at most `2·TRUNCATION` in all).
/// The mix changes by at most `2·TRUNCATION · (1 + max_θ p_tail(θ)/p(θ)) · max Q_sca/min Q_sca`
/// relative, where `p_tail` is the dropped drops' curve: ≤ 1e-3 for the ratios of rain
/// (Q_sca ≈ 2, p_tail/p ≤ a few after the sun disc).
pub const TRUNCATION: f64 = 5e-5;

/// Cells within this many degrees of 0° and 180° are exact cell averages for every node.
pub const EXACT_DEG: f64 = 1.0;

/// Points of the cumulative-distribution table of [`RadiusSampler`] (uniform in `ln r`).
const CDF_POINTS: usize = 4096;

pub use crate::math::rng::SplitMix64;

/// FNV-1a hash of bytes (seeds).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ *b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Inverse-CDF sampler of radii with density `q(r) ∝ n(r) r²` on the (truncated) support.
///
/// The cumulative distribution is tabulated on [`CDF_POINTS`] nodes uniform in `ln r`
/// (trapezoid rule) and inverted piecewise linearly, so `q` is piecewise constant in `ln r`;
/// [`RadiusSampler::weight`] returns `n(r)/q(r)` of exactly this `q`, which keeps the
/// estimator unbiased whatever the table's resolution.
#[derive(Debug, Clone)]
pub struct RadiusSampler {
    ln_r: Vec<f64>,
    cdf: Vec<f64>,
    /// Dropped mass of `n(r) r²` (both tails, fraction of the support's).
    pub truncated_fraction: f64,
}

impl RadiusSampler {
    /// Sampler for `distribution` (not monodisperse), dropping at most `truncation` of the mass
    /// of `n(r) r²` at each end.
    pub fn new(distribution: &SizeDistribution, truncation: f64) -> Self {
        let (lo, hi) = distribution.support_um();
        let (a, b) = (lo.ln(), hi.ln());
        let h = (b - a) / (CDF_POINTS - 1) as f64;
        // density in ln r: n(r) r² · r
        let f: Vec<f64> = (0..CDF_POINTS)
            .map(|i| {
                let r = (a + h * i as f64).exp();
                distribution.density(r) * r * r * r
            })
            .collect();
        let mut cdf = vec![0.0; CDF_POINTS];
        for i in 1..CDF_POINTS {
            cdf[i] = cdf[i - 1] + 0.5 * h * (f[i - 1] + f[i]);
        }
        let total = cdf[CDF_POINTS - 1];
        // truncate: first node with cdf ≥ truncation·total, last with cdf ≤ (1 − truncation)·total
        let i0 = cdf
            .iter()
            .position(|c| *c >= truncation * total)
            .unwrap_or(0)
            .saturating_sub(1);
        let i1 = cdf
            .iter()
            .rposition(|c| *c <= (1.0 - truncation) * total)
            .map_or(CDF_POINTS - 1, |i| (i + 1).min(CDF_POINTS - 1));
        let kept = cdf[i1] - cdf[i0];
        let ln_r: Vec<f64> = (i0..=i1).map(|i| a + h * i as f64).collect();
        let cdf: Vec<f64> = (i0..=i1).map(|i| (cdf[i] - cdf[i0]) / kept).collect();
        RadiusSampler {
            ln_r,
            cdf,
            truncated_fraction: 1.0 - kept / total,
        }
    }

    /// Radius (µm) at cumulative probability `u ∈ [0, 1)` and its importance weight
    /// `n(r)·r/q_ln(ln r)` (`q_ln` the sampling density in `ln r`), i.e. `n(r) dr` per unit
    /// probability: `Σ weight · g(r)/N` estimates `∫ n(r) g(r) dr` over the kept support.
    pub fn sample(&self, distribution: &SizeDistribution, u: f64) -> (f64, f64) {
        let k = self
            .cdf
            .partition_point(|c| *c <= u)
            .clamp(1, self.cdf.len() - 1);
        let (c0, c1) = (self.cdf[k - 1], self.cdf[k]);
        let (l0, l1) = (self.ln_r[k - 1], self.ln_r[k]);
        // q_ln constant on the segment; empty segments are never selected (c1 > u ≥ c0)
        let q_ln = (c1 - c0) / (l1 - l0);
        let t = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.5 };
        let r = (l0 + t * (l1 - l0)).exp();
        (r, distribution.density(r) * r / q_ln)
    }

    /// Kept support `[r_lo, r_hi]` (µm).
    pub fn support_um(&self) -> (f64, f64) {
        (self.ln_r[0].exp(), self.ln_r[self.ln_r.len() - 1].exp())
    }
}

/// Unbiased estimate of one sphere's normalised cell averages on a uniform grid of `intervals`
/// cells (see the module doc): exact cell averages within [`EXACT_DEG`] of both poles, and
/// elsewhere one uniform-in-solid-angle sample per block of `block_cells` cells (and its mirror
/// `180° − θ`, which the angular kernel gives for free), credited to the cell it falls in with
/// weight `ΔΩ_block/ΔΩ_cell`. Cells that receive no sample in this call hold 0.
pub fn sample_sphere(
    sphere: &Sphere,
    intervals: usize,
    block_cells: usize,
    rng: &mut SplitMix64,
) -> PolarisedPhase {
    let m = intervals;
    let d = PI / m as f64;
    let block = block_cells.max(1);
    let half = m / 2;
    let n_stop = sphere.coefficients.n_stop();
    // exact cells 0..=ce (θ ≤ (ce + ½)δ) and their mirrors
    let ce = ((EXACT_DEG.to_radians() / d).ceil() as usize).min(half.saturating_sub(1));
    let theta_e = (ce as f64 + 0.5) * d;
    let sub = n_stop.div_ceil(m).max(1);
    let (gx, gw) = crate::math::quadrature::gauss_legendre(FINE_CELL_POINTS);
    let cells = cell_solid_angles(m);
    // (μ, cell, weight): contribution weight · |S|² · norm to `cell`, and the mirror's to m − cell
    let mut mu = Vec::new();
    let mut target = Vec::new();
    let mut weight = Vec::new();
    for (c, cell) in cells.iter().enumerate().take(ce + 1) {
        let lo = ((c as f64 - 0.5) * d).max(0.0);
        let hi = (c as f64 + 0.5) * d;
        let w_sub = (hi - lo) / sub as f64;
        for s in 0..sub {
            let a = lo + s as f64 * w_sub;
            let (h, mid) = (0.5 * w_sub, a + 0.5 * w_sub);
            for (x, w) in gx.iter().zip(&gw) {
                let t = mid + h * x;
                mu.push(t.cos());
                target.push(c);
                weight.push(2.0 * PI * w * h * t.sin() / cell);
            }
        }
    }
    let mut lo = theta_e;
    while lo < 0.5 * PI - 1e-15 {
        let hi = (lo + block as f64 * d).min(0.5 * PI);
        let (mu_lo, mu_hi) = (lo.cos(), hi.cos());
        let u = mu_hi + rng.next_f64() * (mu_lo - mu_hi);
        let c = ((u.acos() / d).round() as usize).clamp(ce + 1, half);
        mu.push(u);
        target.push(c);
        weight.push(2.0 * PI * (mu_lo - mu_hi) / cells[c]);
        lo = hi;
    }
    let amp = sphere.amplitudes_mirrored(&mu, false);
    let norm = 1.0 / sphere.phase_normalisation();
    let mut out = PolarisedPhase::zeros(m);
    for (i, (&c, &w)) in target.iter().zip(&weight).enumerate() {
        let wn = w * norm;
        out.i_perp[c] += wn * amp.s1[i].norm_sqr();
        out.i_par[c] += wn * amp.s2[i].norm_sqr();
        out.i_perp[m - c] += wn * amp.s1_mirror[i].norm_sqr();
        out.i_par[m - c] += wn * amp.s2_mirror[i].norm_sqr();
    }
    out
}

/// Default of `radius_tolerance` (decision MIE-16).
pub const DEFAULT_RADIUS_TOLERANCE: f64 = 0.02;

/// Strata (radius nodes) per round of the sampled average.
pub const STRATA: usize = 16;
/// Rounds before the first error estimate.
pub const MIN_ROUNDS: usize = 4;
/// Largest number of radius nodes of one sampled entry (the estimate is then reported as is).
pub const MAX_NODES: usize = 4096;
/// Intermediate cells per angular sample of a radius node (outside the exact polar caps).
pub const ANGLE_BLOCK_CELLS: usize = 8;

/// Ensemble result of one (wavelength, entry): the table curve and averaged scalars.
#[derive(Debug, Clone)]
pub struct EntryResult {
    /// Output curve (bin averages on the table grid).
    pub curve: PolarisedPhase,
    /// `⟨C_ext⟩/⟨π r²⟩`.
    pub q_ext: f64,
    /// `⟨C_sca⟩/⟨π r²⟩`.
    pub q_sca: f64,
    /// `⟨C_back⟩/⟨π r²⟩`.
    pub q_back: f64,
    /// `⟨C_sca g⟩/⟨C_sca⟩`.
    pub g: f64,
    /// Radius nodes used (1 for a single sphere).
    pub radius_nodes: usize,
    /// Estimated RMS relative standard error of the curve (sampled distributions; 0 for a
    /// single sphere and for the Gauss–Legendre rule, which has no estimate).
    pub error_rms: f64,
}

/// Computes one table entry (pure): every radius of the distribution's quadrature on its own
/// fine grid of cell averages, resampled to the intermediate grid, mixed with weights
/// `n(r) dr · C_sca(r)`, convolved with the sun's disc, optionally blurred, and integrated
/// over the output bins. `sun` must be [`FilterSettings::sun_operator`] of `settings`.
/// `wavelength_nm` is the wavelength in the medium around the drops and `m` the index relative
/// to it (see [`crate::mie::in_medium`]).
///
/// A monodisperse entry is its one sphere (exact cell averages). A distribution is averaged by
/// joint sampling of radius and angle to `settings.radius_tolerance`
/// (this module's sampling, decision MIE-16), or, when that is 0, by the Gauss–Legendre rule
/// in ln r of `settings.radius_points` nodes with exact cell averages per node.
pub fn compute_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<EntryResult, MieError> {
    match distribution {
        SizeDistribution::Monodisperse { .. } => {
            gauss_legendre_entry(distribution, wavelength_nm, m, settings, sun)
        }
        _ if settings.radius_tolerance > 0.0 => {
            sampled_entry(distribution, wavelength_nm, m, settings, sun)
        }
        _ => gauss_legendre_entry(distribution, wavelength_nm, m, settings, sun),
    }
}

/// The Gauss–Legendre rule in ln r (one node for a monodisperse entry), every node's curve as
/// exact cell averages on its fine grid.
fn gauss_legendre_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<EntryResult, MieError> {
    let (radii, weights) = distribution.quadrature(settings.radius_points);
    let mid = settings.intermediate_intervals();
    let per_radius: Vec<Result<(PolarisedPhase, [f64; 5]), MieError>> = radii
        .par_iter()
        .zip(&weights)
        .map(|(&r, &w)| {
            let x = size_parameter(r, wavelength_nm);
            let sphere = Sphere::new(x, m)?;
            let fine_cells = FilterSettings::fine_grid_intervals(mid, sphere.coefficients.n_stop());
            let fine = PolarisedPhase::from_sphere(&sphere, fine_cells, FINE_CELL_POINTS, false);
            let curve = resample_bins(&fine, mid);
            let e = sphere.efficiencies;
            let area = std::f64::consts::PI * r * r;
            Ok((
                curve,
                [
                    w * area,
                    w * area * e.q_ext,
                    w * area * e.q_sca,
                    w * area * e.q_back,
                    w * area * e.q_sca * e.g,
                ],
            ))
        })
        .collect();
    let mut mix = PolarisedPhase::zeros(mid);
    let mut sums = [0.0; 5];
    let mut total_sca = 0.0;
    let mut parts = Vec::with_capacity(per_radius.len());
    for item in per_radius {
        let (curve, s) = item?;
        for (a, b) in sums.iter_mut().zip(s) {
            *a += b;
        }
        total_sca += s[2];
        parts.push((curve, s[2]));
    }
    for (curve, c_sca) in &parts {
        mix.add_scaled(curve, c_sca / total_sca);
    }
    let mix = sun.apply(&mix);
    let mix = gaussian_blur(&mix, settings.gaussian_sigma_deg);
    let curve = resample_bins(&mix, settings.output_intervals);
    Ok(EntryResult {
        curve,
        q_ext: sums[1] / sums[0],
        q_sca: sums[2] / sums[0],
        q_back: sums[3] / sums[0],
        g: sums[4] / sums[2],
        radius_nodes: radii.len(),
        error_rms: 0.0,
    })
}

/// One round of the sampled average: `Σ w_k p_k` on the intermediate grid and the sums
/// `Σ w_k π r² · [1, Q_ext, Q_sca, Q_back, Q_sca g]` (`w_k = n(r_k)/q(r_k)`).
struct Round {
    mix: PolarisedPhase,
    sums: [f64; 5],
}

/// The sampled size-distribution average (module doc): rounds of
/// [`STRATA`] jittered radius strata, each node's curve sampled on the intermediate grid, until
/// the spread of the rounds' outputs (after sun disc, blur, bins) gives an RMS relative standard
/// error ≤ `settings.radius_tolerance` (relative to the phase function of the bin, over every
/// bin and both `i_perp` and `i_par`), or [`MAX_NODES`] nodes. [`MIN_ROUNDS`] rounds first, then
/// the number of rounds the estimate predicts (it falls like `1/√rounds`), plus 10 %.
fn sampled_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<EntryResult, MieError> {
    let mid = settings.intermediate_intervals();
    let sampler = RadiusSampler::new(distribution, TRUNCATION);
    let seed = fnv1a(
        format!(
            "{distribution:?} {} {} {}",
            wavelength_nm.to_bits(),
            m.re.to_bits(),
            m.im.to_bits()
        )
        .as_bytes(),
    );
    let finish = |mix: &PolarisedPhase, scale: f64| {
        let mut c = PolarisedPhase::zeros(mid);
        c.add_scaled(mix, scale);
        let c = gaussian_blur(&sun.apply(&c), settings.gaussian_sigma_deg);
        resample_bins(&c, settings.output_intervals)
    };
    let round = |k: usize| -> Result<Round, MieError> {
        let mut mix = PolarisedPhase::zeros(mid);
        let mut sums = [0.0; 5];
        for s in 0..STRATA {
            let mut rng = SplitMix64::new(seed ^ fnv1a(&((k * STRATA + s) as u64).to_le_bytes()));
            let u = (s as f64 + rng.next_f64()) / STRATA as f64;
            let (r, w) = sampler.sample(distribution, u);
            let sphere = Sphere::new(size_parameter(r, wavelength_nm), m)?;
            let curve = sample_sphere(&sphere, mid, ANGLE_BLOCK_CELLS, &mut rng);
            let e = sphere.efficiencies;
            let wa = w * std::f64::consts::PI * r * r;
            mix.add_scaled(&curve, wa * e.q_sca);
            for (a, b) in sums
                .iter_mut()
                .zip([1.0, e.q_ext, e.q_sca, e.q_back, e.q_sca * e.g])
            {
                *a += wa * b;
            }
        }
        Ok(Round { mix, sums })
    };
    let mut outputs: Vec<PolarisedPhase> = Vec::new();
    let mut pooled = PolarisedPhase::zeros(mid);
    let mut sums = [0.0; 5];
    let mut add = MIN_ROUNDS;
    loop {
        let start = outputs.len();
        let batch = (start..start + add)
            .into_par_iter()
            .map(round)
            .collect::<Result<Vec<Round>, _>>()?;
        for r in batch {
            outputs.push(finish(&r.mix, 1.0 / r.sums[2]));
            pooled.add_scaled(&r.mix, 1.0);
            for (a, b) in sums.iter_mut().zip(r.sums) {
                *a += b;
            }
        }
        let curve = finish(&pooled, 1.0 / sums[2]);
        let error_rms = rounds_error_rms(&outputs, &curve);
        let nodes = outputs.len() * STRATA;
        if error_rms <= settings.radius_tolerance || nodes + STRATA > MAX_NODES {
            return Ok(EntryResult {
                curve,
                q_ext: sums[1] / sums[0],
                q_sca: sums[2] / sums[0],
                q_back: sums[3] / sums[0],
                g: sums[4] / sums[2],
                radius_nodes: nodes,
                error_rms,
            });
        }
        // the standard error falls like 1/√rounds: add the rounds the estimate asks for (+10 %),
        // at least one, at most four times those done, within MAX_NODES
        let rounds = outputs.len();
        let wanted = (rounds as f64 * 1.1 * (error_rms / settings.radius_tolerance).powi(2)).ceil();
        add = (wanted as usize)
            .saturating_sub(rounds)
            .clamp(1, 4 * rounds)
            .min(MAX_NODES / STRATA - rounds);
    }
}

/// A brute-force reference for a distribution entry (validation only; slow): `nodes` radii at
/// the midpoints `u = (i + ½)/nodes` of the cumulative distribution of `n(r) r²` (no
/// truncation), every node's curve as exact cell averages on its fine grid (the single-sphere
/// path), mixed with weights `n(r) dr · C_sca(r)`, then sun disc, blur and bins. Returns the
/// whole rule and its even and odd halves (two interleaved rules of `nodes/2`; their difference
/// bounds the reference's own error).
pub fn reference_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
    nodes: usize,
) -> Result<[PolarisedPhase; 3], MieError> {
    let mid = settings.intermediate_intervals();
    let sampler = RadiusSampler::new(distribution, 0.0);
    let zero = || {
        (
            [PolarisedPhase::zeros(mid), PolarisedPhase::zeros(mid)],
            [0.0; 2],
        )
    };
    let (mixes, totals) = (0..nodes)
        .into_par_iter()
        .map(|i| {
            let (r, w) = sampler.sample(distribution, (i as f64 + 0.5) / nodes as f64);
            let sphere = Sphere::new(size_parameter(r, wavelength_nm), m)?;
            let fine_cells = FilterSettings::fine_grid_intervals(mid, sphere.coefficients.n_stop());
            let fine = PolarisedPhase::from_sphere(&sphere, fine_cells, FINE_CELL_POINTS, false);
            let c = w * std::f64::consts::PI * r * r * sphere.efficiencies.q_sca;
            Ok((i % 2, resample_bins(&fine, mid), c))
        })
        .try_fold(zero, |mut acc, item: Result<_, MieError>| {
            let (half, curve, c) = item?;
            acc.0[half].add_scaled(&curve, c);
            acc.1[half] += c;
            Ok(acc)
        })
        .try_reduce(zero, |mut a, b| {
            for h in 0..2 {
                a.0[h].add_scaled(&b.0[h], 1.0);
                a.1[h] += b.1[h];
            }
            Ok(a)
        })?;
    let finish = |mix: &PolarisedPhase, scale: f64| {
        let mut c = PolarisedPhase::zeros(mid);
        c.add_scaled(mix, scale);
        let c = gaussian_blur(&sun.apply(&c), settings.gaussian_sigma_deg);
        resample_bins(&c, settings.output_intervals)
    };
    let mut all = mixes[0].clone();
    all.add_scaled(&mixes[1], 1.0);
    Ok([
        finish(&all, 1.0 / (totals[0] + totals[1])),
        finish(&mixes[0], 1.0 / totals[0]),
        finish(&mixes[1], 1.0 / totals[1]),
    ])
}

/// Relative differences of `a` against `reference` over the bins, for `i_perp` and `i_par`:
/// `(max, angle of the max in degrees, channel name of the max, rms)`.
pub fn relative_difference(
    a: &PolarisedPhase,
    reference: &PolarisedPhase,
) -> (f64, f64, &'static str, f64) {
    let (mut max, mut at, mut ch, mut sq, mut n) = (0.0, 0.0, "i_perp", 0.0, 0usize);
    for (name, x, y) in [
        ("i_perp", &a.i_perp, &reference.i_perp),
        ("i_par", &a.i_par, &reference.i_par),
    ] {
        for (j, (p, q)) in x.iter().zip(y.iter()).enumerate() {
            if !(q.abs() > 0.0) {
                continue;
            }
            let e = ((p - q) / q).abs();
            sq += e * e;
            n += 1;
            if e > max {
                (max, at, ch) = (e, reference.angle_deg(j), name);
            }
        }
    }
    (max, at, ch, (sq / n.max(1) as f64).sqrt())
}

/// RMS over bins and the channels `i_perp`, `i_par` of the standard error of the mean of
/// independent `rounds`, relative to the phase function of `pooled` in the bin.
pub fn rounds_error_rms(rounds: &[PolarisedPhase], pooled: &PolarisedPhase) -> f64 {
    let n = rounds.len() as f64;
    if rounds.len() < 2 {
        return f64::INFINITY;
    }
    let phase = pooled.phase();
    let (mut acc, mut count) = (0.0, 0usize);
    for (b, p) in phase.iter().enumerate() {
        if !(*p > 0.0) {
            continue;
        }
        for ch in 0..2 {
            let get = |r: &PolarisedPhase| if ch == 0 { r.i_perp[b] } else { r.i_par[b] };
            let mean = rounds.iter().map(get).sum::<f64>() / n;
            let var = rounds.iter().map(|r| (get(r) - mean).powi(2)).sum::<f64>() / (n - 1.0);
            acc += var / n / (p * p);
            count += 1;
        }
    }
    (acc / count.max(1) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mie::filters::{FINE_CELL_POINTS, fine_intervals, resample_bins};
    use num_complex::Complex64;

    /// The sampled cell averages of one sphere average (over many draws) to the exact ones,
    /// and a single draw keeps the exact cells near the poles exact.
    #[test]
    fn sampled_cells_are_unbiased() {
        let s = Sphere::new(60.0, Complex64::new(1.333, 0.0)).unwrap();
        let m = 720;
        let fine = PolarisedPhase::from_sphere(
            &s,
            m * fine_intervals(s.coefficients.n_stop(), m).div_ceil(m),
            FINE_CELL_POINTS,
            false,
        );
        let exact = resample_bins(&fine, m);
        let mut rng = SplitMix64::new(7);
        let draws = 400;
        let mut mean = PolarisedPhase::zeros(m);
        for _ in 0..draws {
            mean.add_scaled(&sample_sphere(&s, m, 3, &mut rng), 1.0 / draws as f64);
        }
        let one = sample_sphere(&s, m, 3, &mut rng);
        for j in [0, 1, 4, m - 4, m] {
            let e = (one.i_perp[j] - exact.i_perp[j]).abs() / exact.i_perp[j];
            assert!(e < 1e-9, "exact cell {j}: {e}");
        }
        // 400 draws of 1 sample per 3 cells: the cell mean has ≈ 1/√(400/3) ≈ 9 % noise; compare
        // averages over 30-cell windows (~1.6 %).
        for w in (10..m - 40).step_by(30) {
            let a: f64 = mean.i_par[w..w + 30].iter().sum();
            let b: f64 = exact.i_par[w..w + 30].iter().sum();
            assert!((a / b - 1.0).abs() < 0.08, "window {w}: {a} vs {b}");
        }
        assert!((mean.integral() - exact.integral()).abs() < 5e-3);
    }

    /// The sampler reproduces the moment ratio ⟨r³⟩/⟨r²⟩ of a gamma distribution (the effective
    /// radius, by definition) by plain Monte Carlo on its weights.
    #[test]
    fn sampler_weights_are_n_dr() {
        let g = SizeDistribution::Gamma {
            effective_radius_um: 10.0,
            effective_variance: 0.1,
        };
        let s = RadiusSampler::new(&g, 0.0);
        let n = 20000;
        let (mut m3, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let (r, w) = s.sample(&g, (i as f64 + 0.5) / n as f64);
            m3 += w * r.powi(3);
            m2 += w * r * r;
        }
        assert!((m3 / m2 / 10.0 - 1.0).abs() < 1e-3, "{}", m3 / m2);
        let t = RadiusSampler::new(&g, 1e-3);
        assert!(t.truncated_fraction <= 2e-3 + 1e-9 && t.truncated_fraction > 0.0);
        let (lo, hi) = t.support_um();
        assert!(lo > g.support_um().0 && hi < g.support_um().1);
    }
}
