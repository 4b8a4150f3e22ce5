//! Table entries of size distributions (the `mie` stage) and a brute-force reference for them.
//!
//! [`compute_entry`] computes one (entry, wavelength) of a `mie` table: a monodisperse entry is
//! its one sphere (exact cell averages on its fine grid); a distribution is averaged to
//! `radius_tolerance` by the adaptive radius rule of [`super::size_average`] (decision MIE-18),
//! whose error estimate is taken on the returned bins after the sun disc; with
//! `radius_tolerance = 0` the Gauss–Legendre rule in ln r of `radius_points` nodes is used
//! instead (no error estimate). [`reference_entry`] is a slow midpoint rule in the cumulative
//! distribution of `n(r) r²` ([`RadiusSampler`]) for validation.

pub use super::distributions::RadiusSampler;
use super::distributions::SizeDistribution;
use super::filters::{
    FINE_CELL_POINTS, FilterSettings, PolarisedPhase, SunDiscOperator, gaussian_blur, resample_bins,
};
use super::size_average::{AverageLimits, BinnedCurve, SizeAverageError, average};
use super::{MieError, Sphere, size_parameter};
use num_complex::Complex64;
use rayon::prelude::*;

/// Default of `radius_tolerance`: the estimated RMS relative error of a distribution entry's
/// bins (decision MIE-18).
pub const DEFAULT_RADIUS_TOLERANCE: f64 = super::size_average::DEFAULT_TOLERANCE;

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
    /// Estimated RMS relative error of the curve (adaptive rule, decision MIE-18; 0 for a
    /// single sphere and for the Gauss–Legendre rule, which has no estimate).
    pub error_rms: f64,
    /// Estimated largest relative error over the bins and both channels (same estimate as
    /// `error_rms`, before its RMS; 0 where `error_rms` is 0).
    pub error_max: f64,
}

/// Computes one table entry (pure): every radius of the distribution's quadrature on its own
/// fine grid of cell averages, resampled to the intermediate grid, mixed with weights
/// `n(r) dr · C_sca(r)`, convolved with the sun's disc, optionally blurred, and integrated
/// over the output bins. `sun` must be [`FilterSettings::sun_operator`] of `settings`.
/// `wavelength_nm` is the wavelength in the medium around the drops and `m` the index relative
/// to it (see [`crate::mie::in_medium`]).
///
/// A monodisperse entry is its one sphere (exact cell averages). A distribution is averaged by
/// the adaptive radius rule ([`super::size_average`], decision MIE-18) until the estimated RMS
/// relative error of the returned bins is ≤ `settings.radius_tolerance` (an error if that takes
/// more than [`MAX_ENTRY_NODES`] spheres), or, when that is 0, by the Gauss–Legendre rule in
/// ln r of `settings.radius_points` nodes with exact cell averages per node.
pub fn compute_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<EntryResult, SizeAverageError> {
    match distribution {
        SizeDistribution::Monodisperse { .. } => Ok(gauss_legendre_entry(
            distribution,
            wavelength_nm,
            m,
            settings,
            sun,
        )?),
        _ if settings.radius_tolerance > 0.0 => {
            let integrand = BinnedCurve::new(wavelength_nm, m, settings, sun);
            let limits = AverageLimits {
                tolerance: settings.radius_tolerance,
                max_tolerance: None,
                max_nodes: MAX_ENTRY_NODES,
            };
            let a = average(distribution, &integrand, &limits)?;
            let values: Vec<f64> = a.i_perp.iter().chain(&a.i_par).copied().collect();
            Ok(EntryResult {
                curve: BinnedCurve::to_phase(&values),
                q_ext: a.q_ext,
                q_sca: a.q_sca,
                q_back: a.q_back,
                g: a.g,
                radius_nodes: a.radius_nodes,
                error_rms: a.error_estimate,
                error_max: a.max_error_estimate,
            })
        }
        _ => Ok(gauss_legendre_entry(
            distribution,
            wavelength_nm,
            m,
            settings,
            sun,
        )?),
    }
}

/// Largest number of spheres of one distribution entry of the `mie` stage.
pub const MAX_ENTRY_NODES: usize = super::size_average::DEFAULT_MAX_NODES;

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
        error_max: 0.0,
    })
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

#[cfg(test)]
mod tests {
    use super::*;

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
