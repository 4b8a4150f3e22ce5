//! The windowed Gaussian diffraction filter of 2-D tables, column by column (Sadeghi 2012,
//! §3.4.4, Table 3.3; decision RT-9 for the split, RT-23 for the window and kernels).
//!
//! The thesis filter blurs every azimuth column along the polar angle with σ (primary side of the
//! Alexander-band midpoint) or 2σ (secondary side) and blends the blurred value in with a
//! Gaussian window of half-width `DEFAULT_CAUSTIC_WINDOW_SIGMAS · σ_local` around each caustic
//! (the per-column peaks of the p = 2 and p = 3 intensities). Two observations make it cheap:
//!
//! - the samples are on a uniform grid and σ takes two values, so the Gaussian weights are two
//!   precomputed kernels (truncated at ±(4σ + Δθ), renormalised over the samples available near
//!   0° and 180°, as [`crate::raytrace::post::gaussian_blur`]);
//! - the blend weight is below [`WINDOW_CUTOFF`] (under the f32 resolution of the stored values)
//!   further than [`window_reach_rad`] from every caustic, so only the polar range around the
//!   bows is blurred; elsewhere the filtered value is the unfiltered one.
//!
//! The result differs from blurring the whole column by less than `WINDOW_CUTOFF` times the
//! column's local dynamic range (tested below against the direct evaluation).

use super::post::{DEFAULT_CAUSTIC_WINDOW_SIGMAS, caustic_weight};

/// Blend weights below this are treated as 0 (the filtered value is then the unfiltered one):
/// 1e-9 is 60× below the f32 resolution (6e-8) of the stored tables.
pub const WINDOW_CUTOFF: f64 = 1e-9;

/// Kernel half-width in σ (samples beyond 4σ carry < 3.4e-4 of the peak weight).
const KERNEL_SIGMAS: f64 = 4.0;

/// Polar search ranges (deg) of the primary (p = 2) and secondary (p = 3) caustics.
pub const PRIMARY_SEARCH_DEG: (f64, f64) = (130.0, 150.0);
pub const SECONDARY_SEARCH_DEG: (f64, f64) = (115.0, 135.0);

/// Distance (rad) from a caustic beyond which the blend weight with window half-width `w` is
/// below [`WINDOW_CUTOFF`].
pub fn window_reach_rad(w: f64) -> f64 {
    w * (2.0 * (1.0 / WINDOW_CUTOFF).ln()).sqrt()
}

/// A symmetric Gaussian kernel `exp(−½(mΔθ/σ)²)`, m = 0..=half, on the polar grid.
fn kernel(sigma: f64, step: f64) -> Vec<f64> {
    let half = (KERNEL_SIGMAS * sigma / step).ceil() as usize + 1;
    (0..=half)
        .map(|m| {
            let d = m as f64 * step / sigma;
            (-0.5 * d * d).exp()
        })
        .collect()
}

/// The filter of one table (one radius and wavelength): polar grid, σ on either side of the
/// Alexander-band midpoint, and whether the filter is applied at all.
#[derive(Debug, Clone)]
pub struct ColumnFilter {
    n_polar: usize,
    step: f64,
    split: f64,
    sigma: f64,
    enabled: bool,
    /// Kernels for σ (primary side) and 2σ (secondary side).
    kernels: [Vec<f64>; 2],
}

/// The filtered values of one column over the polar rows `start..start + len`, `nvals` values
/// per row; rows outside keep their unfiltered values.
#[derive(Debug, Clone, Default)]
pub struct CausticWindow {
    pub start: usize,
    pub len: usize,
    nvals: usize,
    values: Vec<f64>,
}

impl CausticWindow {
    /// The filtered values at polar row `j`, if inside the window.
    pub fn get(&self, j: usize) -> Option<&[f64]> {
        (j >= self.start && j < self.start + self.len)
            .then(|| &self.values[(j - self.start) * self.nvals..][..self.nvals])
    }
}

impl ColumnFilter {
    /// Filter on the polar grid θ_j = j·`step` (j < `n_polar`), σ (rad) on the primary side of
    /// `split` (rad) and 2σ below it.
    pub fn new(n_polar: usize, step: f64, sigma: f64, split: f64, enabled: bool) -> Self {
        ColumnFilter {
            n_polar,
            step,
            split,
            sigma,
            enabled,
            kernels: [kernel(sigma, step), kernel(2.0 * sigma, step)],
        }
    }

    /// σ (rad) at polar angle `th`; 0 when the filter is off.
    pub fn sigma_at(&self, th: f64) -> f64 {
        if !self.enabled {
            0.0
        } else if th > self.split {
            self.sigma
        } else {
            2.0 * self.sigma
        }
    }

    fn row(&self, rad: f64) -> usize {
        ((rad / self.step).round().max(0.0) as usize).min(self.n_polar - 1)
    }

    /// The polar rows a column must supply: the caustic search ranges widened by the window
    /// reach and the kernel.
    pub fn needed_rows(&self) -> (usize, usize) {
        let reach = window_reach_rad(2.0 * self.sigma * DEFAULT_CAUSTIC_WINDOW_SIGMAS)
            + self.kernels[1].len() as f64 * self.step;
        let lo = SECONDARY_SEARCH_DEG.0.to_radians() - reach;
        let hi = PRIMARY_SEARCH_DEG.1.to_radians() + reach;
        (self.row(lo), self.row(hi))
    }

    /// Filter one column. `rows = (j0, j1)` is [`ColumnFilter::needed_rows`]; `cols[c]` holds
    /// value `c` at rows `j0..=j1`; `peak_of(o)` is the index in `cols` of order `o`'s intensity
    /// (`None` if not traced). Returns the filtered values around the caustics.
    pub fn filter_column(
        &self,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        primary: Option<usize>,
        secondary: Option<usize>,
    ) -> CausticWindow {
        if !self.enabled {
            return CausticWindow::default();
        }
        let (j0, j1) = rows;
        let peak = |c: Option<usize>, (lo, hi): (f64, f64)| -> Option<f64> {
            let c = c?;
            let (a, b) = (
                self.row(lo.to_radians()).max(j0),
                self.row(hi.to_radians()).min(j1),
            );
            (a..=b)
                .max_by(|&x, &y| cols[c][x - j0].total_cmp(&cols[c][y - j0]))
                .map(|j| self.step * j as f64)
        };
        let bows: Vec<f64> = [
            peak(primary, PRIMARY_SEARCH_DEG),
            peak(secondary, SECONDARY_SEARCH_DEG),
        ]
        .into_iter()
        .flatten()
        .collect();
        if bows.is_empty() {
            return CausticWindow::default();
        }
        let reach = window_reach_rad(2.0 * self.sigma * DEFAULT_CAUSTIC_WINDOW_SIGMAS);
        let lo = self
            .row(bows.iter().cloned().fold(f64::MAX, f64::min) - reach)
            .max(j0);
        let hi = self
            .row(bows.iter().cloned().fold(f64::MIN, f64::max) + reach)
            .min(j1);
        let nvals = cols.len();
        let mut values = Vec::with_capacity((hi + 1 - lo) * nvals);
        for j in lo..=hi {
            let th = self.step * j as f64;
            let s = self.sigma_at(th);
            let w = caustic_weight(th, &bows, s * DEFAULT_CAUSTIC_WINDOW_SIGMAS);
            let k = &self.kernels[usize::from(th <= self.split)];
            let half = k.len() - 1;
            // Kernel support clipped to the table (renormalised) and to the supplied rows.
            let (a, b) = (j.saturating_sub(half), (j + half).min(self.n_polar - 1));
            for col in cols {
                let (mut acc, mut wsum) = (0.0, 0.0);
                for i in a.max(j0)..=b.min(j1) {
                    let kw = k[i.abs_diff(j)];
                    acc += kw * col[i - j0];
                    wsum += kw;
                }
                let blurred = if wsum > 0.0 { acc / wsum } else { 0.0 };
                values.push(w * blurred + (1.0 - w) * col[j - j0]);
            }
        }
        CausticWindow {
            start: lo,
            len: hi + 1 - lo,
            nvals,
            values,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raytrace::post::gaussian_blur;

    /// The windowed, precomputed-kernel filter equals the direct evaluation (blur of the whole
    /// column with `gaussian_blur`, blended with the caustic weight everywhere) to 1e-6 of the
    /// column's maximum, on a column with two sharp caustics and supernumerary-like ripple.
    #[test]
    fn windowed_filter_matches_direct_blur_everywhere() {
        let n = 14401;
        let step = (180.0f64 / (n - 1) as f64).to_radians();
        let theta: Vec<f64> = (0..n).map(|j| step * j as f64).collect();
        let bow = |th: f64, c: f64| {
            let d = (c.to_radians() - th) / 0.3f64.to_radians();
            if d > 0.0 {
                1.0 / d.sqrt().max(0.05) * (40.0 * d).cos().powi(2)
            } else {
                0.0
            }
        };
        let p2: Vec<f64> = theta.iter().map(|&t| bow(t, 138.0) + 0.01).collect();
        let p3: Vec<f64> = theta
            .iter()
            .map(|&t| bow(-t + 2.0 * 129f64.to_radians(), 129.0) * 0.3)
            .collect();
        let total: Vec<f64> = p2.iter().zip(&p3).map(|(a, b)| a + b + 0.05).collect();
        let (sigma, split) = (0.25f64.to_radians(), 133.5f64.to_radians());
        let f = ColumnFilter::new(n, step, sigma, split, true);
        let rows = f.needed_rows();
        let slice = |v: &Vec<f64>| v[rows.0..=rows.1].to_vec();
        let cols = vec![slice(&total), slice(&p2), slice(&p3)];
        let win = f.filter_column(rows, &cols, Some(1), Some(2));
        // Direct evaluation.
        let bows = [138.0f64.to_radians(), 129.0f64.to_radians()];
        let peak = |v: &Vec<f64>, lo: f64, hi: f64| {
            let (a, b) = (
                (lo.to_radians() / step).round() as usize,
                (hi.to_radians() / step).round() as usize,
            );
            (a..=b).max_by(|&x, &y| v[x].total_cmp(&v[y])).unwrap() as f64 * step
        };
        let found = [peak(&p2, 130.0, 150.0), peak(&p3, 115.0, 135.0)];
        assert!((found[0] - bows[0]).abs() < 0.2f64.to_radians());
        let max = total.iter().cloned().fold(0.0, f64::max);
        for (c, v) in [&total, &p2, &p3].into_iter().enumerate() {
            let b = gaussian_blur(v, 0.0, step, &theta, |t| f.sigma_at(t));
            for j in (0..n).step_by(7) {
                let w = caustic_weight(
                    theta[j],
                    &found,
                    f.sigma_at(theta[j]) * DEFAULT_CAUSTIC_WINDOW_SIGMAS,
                );
                let direct = w * b[j] + (1.0 - w) * v[j];
                let got = win.get(j).map_or(v[j], |x| x[c]);
                assert!(
                    (got - direct).abs() <= 1e-6 * max,
                    "c={c} j={j}: {got} vs {direct}"
                );
            }
        }
        assert!(win.len > 0 && win.len < n / 4, "window of {} rows", win.len);
    }

    #[test]
    fn disabled_filter_keeps_columns() {
        let f = ColumnFilter::new(1801, 0.1f64.to_radians(), 0.004, 2.3, false);
        let win = f.filter_column(f.needed_rows(), &[vec![1.0; 1801]], Some(0), None);
        assert_eq!(win.len, 0);
        assert!(win.get(1380).is_none());
    }
}
