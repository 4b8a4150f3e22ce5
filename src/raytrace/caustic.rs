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
    /// With a transfer, columns get the sphere's Airy correction instead of the Gaussian blend.
    airy: Option<AiryTransfer>,
}

/// Bright-side range (deg from the caustic) over which a column's caustic strength is compared
/// with the sphere's.
const STRENGTH_RANGE_DEG: (f64, f64) = (0.1, 1.5);

/// The uniform-caustic (Airy) correction of the equal-volume sphere, transferred to the columns
/// of a 2-D table (decision RT-28).
///
/// For a sphere the 1-D path's Airy-uniform channels differ from its geometric-optics (GO)
/// channels only around the primary (p = 2) and secondary (p = 3) caustics: `Δ = Airy − GO`
/// (dσ/dΩ per channel, bin averages on the table's polar rows) is the diffraction correction the
/// GO field lacks there. Each azimuth column of a traced table gets `value + s·Δ(θ − δ)` per bow:
/// δ moves the sphere's caustic (the GO peak of the order) onto the column's own, and `s` scales
/// it to the column's caustic strength (the ratio of the column's order intensity to the
/// sphere's over 0.1°–1.5° on the bright side). Rows above the Alexander-band midpoint take the
/// primary's correction, rows below the secondary's. On a sphere δ = 0 and s = 1 up to ray noise,
/// so the 2-D path reproduces the 1-D Airy path. Domain: fold caustics of drops close to the
/// sphere; the Airy width stays the sphere's (the local curvature of a deformed drop's
/// deviation function is not followed), and columns where a deformed drop's caustic splits or
/// vanishes take a shifted, scaled sphere correction that is only as good as that picture.
#[derive(Debug, Clone)]
pub struct AiryTransfer {
    /// First row of the arrays (the filter's [`ColumnFilter::needed_rows`]`.0`).
    row0: usize,
    /// Airy − GO (µm²/sr) of the columns' channels `[i_perp, i_par, p0, p1, …]`.
    delta: Vec<Vec<f64>>,
    /// Sphere's GO intensity of orders 2 and 3 (µm²/sr) and the row of its maximum.
    go_bow: [Option<(Vec<f64>, usize)>; 2],
}

impl AiryTransfer {
    /// From the sphere's Airy and GO channels on the rows `rows` of the filter: `airy[c]`,
    /// `go[c]` for the columns' channels `[i_perp, i_par, p0, p1, …]` (µm²/sr); orders the
    /// sphere does not have are zero.
    pub fn new(
        filter: &ColumnFilter,
        rows: (usize, usize),
        airy: &[Vec<f64>],
        go: &[Vec<f64>],
    ) -> Self {
        let delta: Vec<Vec<f64>> = airy
            .iter()
            .zip(go)
            .map(|(a, g)| a.iter().zip(g).map(|(x, y)| x - y).collect())
            .collect();
        let bow = |o: usize, (lo, hi): (f64, f64)| -> Option<(Vec<f64>, usize)> {
            let v = go.get(2 + o)?.clone();
            let (a, b) = (
                filter.row(lo.to_radians()).max(rows.0),
                filter.row(hi.to_radians()).min(rows.1),
            );
            let peak = (a..=b).max_by(|&x, &y| v[x - rows.0].total_cmp(&v[y - rows.0]))?;
            (v[peak - rows.0] > 0.0).then_some((v, peak))
        };
        AiryTransfer {
            row0: rows.0,
            delta,
            go_bow: [bow(2, PRIMARY_SEARCH_DEG), bow(3, SECONDARY_SEARCH_DEG)],
        }
    }
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
            airy: None,
        }
    }

    /// Use the sphere's transferred Airy correction instead of the Gaussian blend.
    pub fn with_airy_transfer(mut self, transfer: AiryTransfer) -> Self {
        self.airy = Some(transfer);
        self
    }

    /// The transferred Airy correction of one column (see [`AiryTransfer`]).
    fn transfer_column(
        &self,
        t: &AiryTransfer,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        orders: [Option<usize>; 2],
    ) -> CausticWindow {
        let (j0, j1) = rows;
        let range = |lo: f64, hi: f64| {
            (
                self.row(lo.to_radians()).max(j0),
                self.row(hi.to_radians()).min(j1),
            )
        };
        // Per bow: (shift in rows, strength, channel of the order).
        let mut bows: [Option<(isize, f64, usize)>; 2] = [None, None];
        for (b, ((search, sign), order)) in
            [(PRIMARY_SEARCH_DEG, 1.0), (SECONDARY_SEARCH_DEG, -1.0)]
                .into_iter()
                .zip(orders)
                .enumerate()
        {
            let (Some(c), Some((go, j_sphere))) = (order, &t.go_bow[b]) else {
                continue;
            };
            let (a, z) = range(search.0, search.1);
            let Some(jc) = (a..=z).max_by(|&x, &y| cols[c][x - j0].total_cmp(&cols[c][y - j0]))
            else {
                continue;
            };
            let shift = jc as isize - *j_sphere as isize;
            let (d0, d1) = (
                (STRENGTH_RANGE_DEG.0.to_radians() / self.step).round() as isize,
                (STRENGTH_RANGE_DEG.1.to_radians() / self.step).round() as isize,
            );
            let (mut num, mut den) = (0.0, 0.0);
            for d in d0..=d1 {
                let j = jc as isize + (sign * d as f64) as isize;
                let js = j - shift;
                if j < j0 as isize
                    || j > j1 as isize
                    || js < t.row0 as isize
                    || js as usize >= t.row0 + go.len()
                {
                    continue;
                }
                num += cols[c][j as usize - j0];
                den += go[js as usize - t.row0];
            }
            if den > 0.0 {
                bows[b] = Some((shift, num / den, c));
            }
        }
        let nvals = cols.len();
        let mut values = Vec::with_capacity((j1 + 1 - j0) * nvals);
        for j in j0..=j1 {
            let th = self.step * j as f64;
            let bow = bows[usize::from(th <= self.split)];
            for (c, col) in cols.iter().enumerate() {
                let mut v = col[j - j0];
                if let Some((shift, strength, order_channel)) = bow {
                    // i_perp, i_par and the bow's own order; other orders have no caustic here.
                    if c < 2 || c == order_channel {
                        let js = j as isize - shift;
                        if let Some(d) = t.delta.get(c).and_then(|d| {
                            (js >= t.row0 as isize)
                                .then(|| d.get(js as usize - t.row0))
                                .flatten()
                        }) {
                            v = (v + strength * d).max(0.0);
                        }
                    }
                }
                values.push(v);
            }
        }
        CausticWindow {
            start: j0,
            len: j1 + 1 - j0,
            nvals,
            values,
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

    pub(crate) fn row(&self, rad: f64) -> usize {
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
        if let Some(t) = &self.airy {
            return self.transfer_column(t, rows, cols, [primary, secondary]);
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
