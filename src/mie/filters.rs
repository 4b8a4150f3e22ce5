//! Ensemble filters applied to high-resolution phase curves before tabulation: mixing over
//! drop sizes, the sun's disc, an optional Gaussian blur, and resampling to a table grid by
//! integrating over each bin.
//!
//! All curves live on uniform grids `θ_j = j·δ`, `j = 0..=M`, `δ = 180°/M`, and node `j`
//! represents the cell `[θ_j − δ/2, θ_j + δ/2] ∩ [0°, 180°]` whose solid angle is
//! `ΔΩ_j = 2π (cos θ_lo − cos θ_hi)`. The discrete energy of a curve is `Σ_j ΔΩ_j p_j`
//! ([`PolarisedPhase::integral`]); bin resampling preserves it exactly and the sun-disc
//! convolution to the accuracy stated on [`sun_disc`].

use super::Sphere;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Normalised polarised phase function on a uniform grid over `[0°, 180°]`.
#[derive(Debug, Clone, PartialEq)]
pub struct PolarisedPhase {
    /// Grid step δ in degrees (`180/δ` is an integer `M`; there are `M + 1` nodes).
    pub step_deg: f64,
    /// `|S_1|²/(π x² Q_sca)` (1/sr).
    pub i_perp: Vec<f64>,
    /// `|S_2|²/(π x² Q_sca)` (1/sr).
    pub i_par: Vec<f64>,
}

impl PolarisedPhase {
    /// A zero curve with `intervals` cells.
    pub fn zeros(intervals: usize) -> Self {
        PolarisedPhase {
            step_deg: 180.0 / intervals as f64,
            i_perp: vec![0.0; intervals + 1],
            i_par: vec![0.0; intervals + 1],
        }
    }

    /// Number of intervals `M`.
    pub fn intervals(&self) -> usize {
        self.i_perp.len() - 1
    }

    /// Angle of node `j` in degrees.
    pub fn angle_deg(&self, j: usize) -> f64 {
        180.0 * j as f64 / self.intervals() as f64
    }

    /// Unpolarised phase `(i_perp + i_par)/2`.
    pub fn phase(&self) -> Vec<f64> {
        self.i_perp
            .iter()
            .zip(&self.i_par)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }

    /// Degree of linear polarisation `(i_perp − i_par)/(i_perp + i_par)` (0 where both vanish).
    pub fn dolp(&self) -> Vec<f64> {
        self.i_perp
            .iter()
            .zip(&self.i_par)
            .map(|(a, b)| if a + b > 0.0 { (a - b) / (a + b) } else { 0.0 })
            .collect()
    }

    /// `Σ_j ΔΩ_j p_j`: the discrete `∫_{4π} p dΩ` (1 for a normalised curve).
    pub fn integral(&self) -> f64 {
        let cells = cell_solid_angles(self.intervals());
        self.phase().iter().zip(&cells).map(|(p, w)| p * w).sum()
    }

    /// The single-sphere curve as cell averages on a uniform grid of `intervals` cells,
    /// normalised by `π x² Q_sca`: each cell's `∫ p dΩ` is integrated with a
    /// `points`-point Gauss–Legendre rule in θ (the rule's nodes are symmetric about 90°, so
    /// the mirror symmetry of the series halves the work), then divided by the cell's solid
    /// angle. Use [`fine_intervals`] for `intervals`.
    pub fn from_sphere(sphere: &Sphere, intervals: usize, points: usize, parallel: bool) -> Self {
        let m = intervals.max(2) + intervals % 2;
        let d = PI / m as f64;
        let (gx, gw) = crate::math::quadrature::gauss_legendre(points);
        let half_cells = m / 2;
        let mut mu = Vec::with_capacity((half_cells + 1) * points);
        let mut wsin = Vec::with_capacity((half_cells + 1) * points);
        for j in 0..=half_cells {
            let lo = ((j as f64 - 0.5) * d).max(0.0);
            let hi = (j as f64 + 0.5) * d;
            let (h, c) = (0.5 * (hi - lo), 0.5 * (hi + lo));
            for (x, w) in gx.iter().zip(&gw) {
                let t = c + h * x;
                mu.push(t.cos());
                wsin.push(w * h * t.sin());
            }
        }
        let amp = sphere.amplitudes_mirrored(&mu, parallel);
        let norm = 2.0 * PI / sphere.phase_normalisation();
        let cells = cell_solid_angles(m);
        let mut out = PolarisedPhase::zeros(m);
        for j in 0..=half_cells {
            let (mut a, mut b, mut am, mut bm) = (0.0, 0.0, 0.0, 0.0);
            for k in 0..points {
                let i = j * points + k;
                // the mirror of node k in cell j is node points−1−k in cell m−j
                let im = j * points + (points - 1 - k);
                a += wsin[i] * amp.s1[i].norm_sqr();
                b += wsin[i] * amp.s2[i].norm_sqr();
                am += wsin[im] * amp.s1_mirror[im].norm_sqr();
                bm += wsin[im] * amp.s2_mirror[im].norm_sqr();
            }
            out.i_perp[j] = a * norm / cells[j];
            out.i_par[j] = b * norm / cells[j];
            if m - j != j {
                out.i_perp[m - j] = am * norm / cells[m - j];
                out.i_par[m - j] = bm * norm / cells[m - j];
            }
        }
        out
    }

    /// Adds `weight · other` (same grid).
    pub fn add_scaled(&mut self, other: &PolarisedPhase, weight: f64) {
        assert_eq!(self.i_perp.len(), other.i_perp.len(), "grids differ");
        for (a, b) in self.i_perp.iter_mut().zip(&other.i_perp) {
            *a += weight * b;
        }
        for (a, b) in self.i_par.iter_mut().zip(&other.i_par) {
            *a += weight * b;
        }
    }

    fn map_channels(&self, intervals: usize, f: impl Fn(&[f64]) -> Vec<f64>) -> Self {
        PolarisedPhase {
            step_deg: 180.0 / intervals as f64,
            i_perp: f(&self.i_perp),
            i_par: f(&self.i_par),
        }
    }
}

/// Fine-grid intervals for a sphere of `n_stop` terms: `s11` is a polynomial of degree
/// `2 n_stop` in `cos θ`, so its shortest angular period is `180°/n_stop`; cells of at most
/// `FINE_CELL_PERIODS` such periods are integrated with [`FINE_CELL_POINTS`] Gauss points,
/// and there are never fewer than `min_intervals` cells. Even.
pub fn fine_intervals(n_stop: usize, min_intervals: usize) -> usize {
    let m = ((n_stop as f64 / FINE_CELL_PERIODS).ceil() as usize)
        .max(min_intervals)
        .max(360);
    m + (m % 2)
}

/// Gauss–Legendre points per cell and dimension in [`sun_disc`].
pub const SUN_POINTS: usize = 4;
/// 2-point Gauss–Legendre nodes (unit weights) for smooth source cells in [`sun_disc`].
const PLAIN_NODES: [f64; 2] = [-0.577_350_269_189_625_8, 0.577_350_269_189_625_8];

/// Gauss–Legendre points per target cell in [`sun_disc`].
pub const ROW_POINTS: usize = 2;

/// Width of a fine cell in shortest ripple periods (`180°/n_stop`).
pub const FINE_CELL_PERIODS: f64 = 1.0;
/// Gauss–Legendre points per fine cell.
pub const FINE_CELL_POINTS: usize = 6;

/// Cell solid angles `ΔΩ_j` of a uniform grid with `intervals` cells (sum = 4π).
pub fn cell_solid_angles(intervals: usize) -> Vec<f64> {
    let d = PI / intervals as f64;
    (0..=intervals)
        .map(|j| {
            let lo = ((j as f64 - 0.5) * d).max(0.0);
            let hi = ((j as f64 + 0.5) * d).min(PI);
            2.0 * PI * (lo.cos() - hi.cos())
        })
        .collect()
}

/// Resamples `curve` to a grid of `intervals` cells by solid-angle-weighted averaging over
/// each target cell (the overlaps of source and target cells partition the sphere, so
/// `Σ ΔΩ p` is preserved exactly and no fine ripple is point-sampled).
pub fn resample_bins(curve: &PolarisedPhase, intervals: usize) -> PolarisedPhase {
    let src_m = curve.intervals();
    let ds = PI / src_m as f64;
    let dt = PI / intervals as f64;
    let f = |v: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; intervals + 1];
        for (i, o) in out.iter_mut().enumerate() {
            let lo = ((i as f64 - 0.5) * dt).max(0.0);
            let hi = ((i as f64 + 0.5) * dt).min(PI);
            let j0 = ((lo / ds - 0.5).floor().max(0.0)) as usize;
            let j1 = (((hi / ds + 0.5).ceil()) as usize).min(src_m);
            let (mut num, mut den) = (0.0, 0.0);
            for (j, value) in v.iter().enumerate().take(j1 + 1).skip(j0) {
                let a = ((j as f64 - 0.5) * ds).max(lo);
                let b = ((j as f64 + 0.5) * ds).min(hi);
                if b > a {
                    let w = a.cos() - b.cos();
                    num += w * value;
                    den += w;
                }
            }
            *o = if den > 0.0 { num / den } else { 0.0 };
        }
        out
    };
    curve.map_channels(intervals, f)
}

/// Half-angle `φ_0` of the arc of the circle of angular radius `t` around the outgoing
/// direction that lies inside a cap of angular radius `rho` whose centre is at angular
/// distance `s` from it (`cos φ_0 = (cos ρ − cos s cos t)/(sin s sin t)`).
fn arc_half_angle(cos_rho: f64, (sin_s, cos_s): (f64, f64), t: f64) -> f64 {
    let (sin_t, cos_t) = t.sin_cos();
    let num = cos_rho - cos_s * cos_t;
    let den = sin_s * sin_t;
    if den <= 1e-300 {
        return if num < 0.0 { PI } else { 0.0 };
    }
    let c = num / den;
    if c <= -1.0 {
        PI
    } else if c >= 1.0 {
        0.0
    } else {
        c.acos()
    }
}

/// Convolution with the sun's disc: a uniform (non-limb-darkened) disc of angular diameter
/// `diameter_deg`, averaged exactly in 2-D on the sphere. The result at scattering angle `θ`
/// is the mean of `p(θ')` over all incident directions inside the disc,
/// `p̃(θ) = (1/Ω_⊙) ∫ 2 φ_0(θ, θ') p(θ') sin θ' dθ'` with `Ω_⊙ = 2π(1 − cos ρ)` and the arc
/// half-angle `φ_0` from the spherical law of cosines (so poles, where the disc covers the
/// forward or backward direction, are exact too).
///
/// Discretisation: `p` is piecewise constant on its cells (cell averages); the result is the
/// cell average of `p̃` ([`ROW_POINTS`] Gauss points per target cell), and the kernel is integrated over each source cell, split at the kinks of
/// `φ_0` (where the circle touches the disc's rim) with a substitution that removes their
/// square-root behaviour, then a [`SUN_POINTS`]-point Gauss–Legendre rule per half-piece. The
/// continuous operator conserves `∫ p dΩ` exactly (`∫ 2φ_0(θ, θ') sin θ dθ = Ω_⊙`); the
/// discrete one conserves a constant to ~1e-12 and `Σ ΔΩ p` to the figures measured in the
/// tests. Use it on a grid with step ≤ ρ/20 (e.g. after [`resample_bins`] to 0.01°).
pub fn sun_disc(curve: &PolarisedPhase, diameter_deg: f64) -> PolarisedPhase {
    SunDiscOperator::new(curve.intervals(), diameter_deg).apply(curve)
}

/// The linear operator of [`sun_disc`] on a grid of `intervals` cells, built once and
/// applied to many curves (it depends only on the grid and the disc diameter).
#[derive(Debug, Clone)]
pub struct SunDiscOperator {
    intervals: usize,
    diameter_deg: f64,
    /// Per target cell: first source index and weights.
    rows: Vec<(usize, Vec<f64>)>,
}

impl SunDiscOperator {
    /// Builds the operator (rows in parallel with rayon).
    pub fn new(intervals: usize, diameter_deg: f64) -> Self {
        if diameter_deg <= 0.0 {
            return SunDiscOperator {
                intervals,
                diameter_deg,
                rows: Vec::new(),
            };
        }
        let rows = sun_disc_rows(intervals, diameter_deg);
        SunDiscOperator {
            intervals,
            diameter_deg,
            rows,
        }
    }

    /// Applies the operator to both polarisation channels.
    pub fn apply(&self, curve: &PolarisedPhase) -> PolarisedPhase {
        if self.diameter_deg <= 0.0 {
            return curve.clone();
        }
        assert_eq!(curve.intervals(), self.intervals, "grid mismatch");
        let f = |v: &[f64]| -> Vec<f64> {
            self.rows
                .iter()
                .map(|(j0, w)| w.iter().zip(&v[*j0..]).map(|(a, b)| a * b).sum())
                .collect()
        };
        curve.map_channels(self.intervals, f)
    }
}

fn sun_disc_rows(m: usize, diameter_deg: f64) -> Vec<(usize, Vec<f64>)> {
    let d = PI / m as f64;
    let rho = 0.5 * diameter_deg.to_radians();
    let cos_rho = rho.cos();
    let reach = (rho / d).ceil() as usize + 1;
    let (gx, gw) = crate::math::quadrature::gauss_legendre(SUN_POINTS);
    let inv_disc = 1.0 / (2.0 * PI * (1.0 - cos_rho));
    // ∫_a^b 2 φ_0(s, t) sin t dt on a piece whose ends may carry a square-root singularity of
    // φ_0: split at the middle and use t = e ± h v² from each end (smooth integrand in v).
    let piece = |s: (f64, f64), a: f64, b: f64| -> f64 {
        let mid = 0.5 * (a + b);
        let mut acc = 0.0;
        for (end, other) in [(a, mid), (b, mid)] {
            let h = other - end;
            for (x, w) in gx.iter().zip(&gw) {
                let v = 0.5 * (x + 1.0);
                let t = end + h * v * v;
                let jac = h.abs() * v;
                acc += w * jac * 2.0 * arc_half_angle(cos_rho, s, t) * t.sin();
            }
        }
        acc
    };
    // Cells more than two cells away from every kink have a smooth integrand: 2 points.
    let plain = |s: (f64, f64), a: f64, b: f64| -> f64 {
        let (h, c) = (0.5 * (b - a), 0.5 * (b + a));
        PLAIN_NODES
            .iter()
            .map(|x| {
                let t = c + h * x;
                h * 2.0 * arc_half_angle(cos_rho, s, t) * t.sin()
            })
            .sum()
    };
    // rows[i] = (first source index, weights): cell average of p̃ over cell i,
    // p̃_i = Σ_j w_ij p_j with w_ij = (2π/ΔΩ_i) ∫_{cell i} sin θ (1/Ω_⊙) ∫_{cell j}
    // 2 φ_0(θ, θ') sin θ' dθ' dθ; the outer integral uses ROW_POINTS Gauss points, the inner
    // one is split at the kinks of φ_0.
    let (rx, rw) = crate::math::quadrature::gauss_legendre(ROW_POINTS);
    let cells = cell_solid_angles(m);
    (0..=m)
        .into_par_iter()
        .map(|i| {
            let j0 = i.saturating_sub(reach);
            let j1 = (i + reach).min(m);
            let lo_i = ((i as f64 - 0.5) * d).max(0.0);
            let hi_i = ((i as f64 + 0.5) * d).min(PI);
            let (hh, mm) = (0.5 * (hi_i - lo_i), 0.5 * (hi_i + lo_i));
            let mut w = vec![0.0; j1 - j0 + 1];
            for (x, wr) in rx.iter().zip(&rw) {
                let s = mm + hh * x;
                let ws = 2.0 * PI * wr * hh * s.sin() / cells[i];
                let sc = s.sin_cos();
                // kinks of φ_0 in θ', sorted (|θ − θ'| = ρ, θ + θ' = ρ, θ + θ' = 2π − ρ)
                let mut kinks = [s - rho, s + rho, rho - s, 2.0 * PI - rho - s];
                kinks.sort_by(f64::total_cmp);
                for (j, wj) in (j0..=j1).zip(w.iter_mut()) {
                    let lo = ((j as f64 - 0.5) * d).max(0.0);
                    let hi = ((j as f64 + 0.5) * d).min(PI);
                    let mut total = 0.0;
                    let mut start = lo;
                    let mut kinked = false;
                    for &c in kinks.iter().filter(|k| **k > lo && **k < hi) {
                        total += piece(sc, start, c);
                        start = c;
                        kinked = true;
                    }
                    let near = kinks.iter().any(|k| *k > lo - 2.0 * d && *k < hi + 2.0 * d);
                    total += if kinked || near {
                        piece(sc, start, hi)
                    } else {
                        plain(sc, lo, hi)
                    };
                    *wj += ws * total * inv_disc;
                }
            }
            (j0, w)
        })
        .collect()
}

/// 1-D Gaussian blur in θ with standard deviation `sigma_deg` (truncated at 5σ, rows
/// normalised, edges not reflected). This is the "diffraction" post-filter of Sadeghi 2012
/// (§3.4.4), also used to smooth the miepython reference maxima (σ = 0.04°); it is not
/// energy-conserving on the sphere (no `sin θ` weight) and is off unless requested
/// (decision MIE-7 in `docs/decisions.md`).
pub fn gaussian_blur(curve: &PolarisedPhase, sigma_deg: f64) -> PolarisedPhase {
    if sigma_deg <= 0.0 {
        return curve.clone();
    }
    let m = curve.intervals();
    let f = |v: &[f64]| gaussian_blur_1d(v, curve.step_deg, sigma_deg);
    curve.map_channels(m, f)
}

/// 1-D Gaussian blur of uniformly spaced samples (`step` and `sigma` in the same unit),
/// truncated at 5σ with per-sample renormalised weights.
pub fn gaussian_blur_1d(values: &[f64], step: f64, sigma: f64) -> Vec<f64> {
    let reach = (5.0 * sigma / step).ceil() as isize;
    let kernel: Vec<f64> = (-reach..=reach)
        .map(|k| (-0.5 * (k as f64 * step / sigma).powi(2)).exp())
        .collect();
    let n = values.len() as isize;
    (0..n)
        .map(|i| {
            let (mut num, mut den) = (0.0, 0.0);
            for (k, w) in (-reach..=reach).zip(&kernel) {
                let j = i + k;
                if (0..n).contains(&j) {
                    num += w * values[j as usize];
                    den += w;
                }
            }
            num / den
        })
        .collect()
}

/// Filter settings of one job.
#[derive(Debug, Clone, Copy)]
pub struct FilterSettings {
    pub output_intervals: usize,
    pub sun_diameter_deg: f64,
    pub gaussian_sigma_deg: f64,
    pub radius_points: usize,
    /// Target RMS relative standard error of sampled distribution entries; 0 = Gauss–Legendre
    /// rule of `radius_points` nodes (decision MIE-16).
    pub radius_tolerance: f64,
}

/// The smallest odd integer ≥ `k` (odd refinements keep every output bin centre on a cell
/// centre of the finer grid, so that cells nest in bins).
fn odd_at_least(k: usize) -> usize {
    if k.is_multiple_of(2) { k + 1 } else { k }
}

impl FilterSettings {
    /// Intervals of the intermediate grid on which the disc/Gaussian act: the output step
    /// divided by the smallest odd `k` giving a step ≤ min(sun diameter/40, σ/4) (so that cells
    /// nest in output bins).
    pub fn intermediate_intervals(&self) -> usize {
        let step = 180.0 / self.output_intervals as f64;
        let mut limit = step;
        if self.sun_diameter_deg > 0.0 {
            limit = limit.min(self.sun_diameter_deg / 40.0);
        }
        if self.gaussian_sigma_deg > 0.0 {
            limit = limit.min(self.gaussian_sigma_deg / 4.0);
        }
        self.output_intervals * odd_at_least((step / limit - 1e-9).ceil().max(1.0) as usize)
    }

    /// Intervals of the fine grid of cell averages for a sphere of `n_stop` terms: an odd
    /// multiple of the intermediate grid (`mid` intervals) with at least
    /// [`fine_intervals`]`(n_stop, mid)` cells.
    pub fn fine_grid_intervals(mid: usize, n_stop: usize) -> usize {
        mid * odd_at_least(fine_intervals(n_stop, mid).div_ceil(mid))
    }

    /// The sun-disc operator on the intermediate grid (build once per job, share across tasks).
    pub fn sun_operator(&self) -> SunDiscOperator {
        SunDiscOperator::new(self.intermediate_intervals(), self.sun_diameter_deg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_complex::Complex64;

    fn test_curve(m: usize) -> PolarisedPhase {
        let s = Sphere::new(300.0, Complex64::new(1.333, 0.0)).unwrap();
        PolarisedPhase::from_sphere(&s, m, FINE_CELL_POINTS, false)
    }

    #[test]
    fn cells_cover_the_sphere() {
        let total: f64 = cell_solid_angles(1801).iter().sum();
        assert!((total - 4.0 * PI).abs() < 1e-12);
    }

    /// The fine curve integrates to 1 (Q_sca from the coefficient sum vs the angular integral).
    #[test]
    fn fine_curve_is_normalised() {
        let c = test_curve(fine_intervals(n_stop_of(300.0), 0));
        let e = (c.integral() - 1.0).abs();
        assert!(e < 2e-4, "fine integral error {e}");
    }

    fn n_stop_of(x: f64) -> usize {
        super::super::riccati::n_stop_default(x)
    }

    /// Bin resampling preserves Σ ΔΩ p exactly (to rounding), on aligned and misaligned grids.
    #[test]
    fn resampling_preserves_energy() {
        let c = test_curve(7200);
        let e0 = c.integral();
        for target in [3600, 1801, 720, 333] {
            let r = resample_bins(&c, target);
            assert!((r.integral() - e0).abs() < 1e-12, "target {target}");
        }
    }

    /// The sun-disc convolution preserves energy and a constant.
    #[test]
    fn sun_disc_preserves_energy_and_constants() {
        let c = resample_bins(&test_curve(7200), 18000);
        let e0 = c.integral();
        let s = sun_disc(&c, 0.5);
        let e1 = s.integral();
        assert!(
            ((e1 - e0) / e0).abs() < 2e-6,
            "sun disc energy {e0} -> {e1}"
        );
        let mut k = PolarisedPhase::zeros(18000);
        k.i_perp.iter_mut().for_each(|v| *v = 1.0);
        let ks = sun_disc(&k, 0.5);
        let worst = ks
            .i_perp
            .iter()
            .map(|v| (v - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "constant not preserved: {worst}");
    }

    /// At θ = 0 the disc average is the cap average: for p ∝ (1 + cos θ) it is exactly
    /// (1 + (1 + cos ρ)/2) on the cap; checks the pole handling.
    #[test]
    fn sun_disc_pole_is_cap_average() {
        let m = 18000;
        let mut k = PolarisedPhase::zeros(m);
        for j in 0..=m {
            k.i_perp[j] = 1.0 + (j as f64 * PI / m as f64).cos();
        }
        let rho = 0.25f64.to_radians();
        let s = sun_disc(&k, 0.5);
        let expected = 1.0 + 0.5 * (1.0 + rho.cos());
        assert!(
            (s.i_perp[0] - expected).abs() < 1e-7,
            "{} vs {expected}",
            s.i_perp[0]
        );
        // Away from the pole, a linear function of cos θ is mapped to cos ρ-scaled copy:
        // the disc mean of cos θ' is cos θ · (1 + cos ρ)/2.
        let j = 6000;
        let th = j as f64 * PI / m as f64;
        let e = 1.0 + th.cos() * 0.5 * (1.0 + rho.cos());
        assert!((s.i_perp[j] - e).abs() < 1e-6, "{} vs {e}", s.i_perp[j]);
    }
}
