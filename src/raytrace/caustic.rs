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

/// Airy argument z of the maximum of Ai(−z)² (the main bow of the uniform caustic).
const AIRY_PEAK_Z: f64 = 1.018_793;

/// Bright-side range of the caustic-position fit, in Airy units z (see [`fold_position`]).
const FIT_Z: f64 = 0.5;

/// Domain of the airy-local transfer, per column and bow (decision RT-33): the column's caustic
/// strength over the sphere's must lie in this range. Measured on Beard–Chuang drops (400² rays,
/// 5° azimuth, 650 nm): 1.001–1.004 on a sphere, 0.90–1.40 at 0.5 mm (sun 20°); where a 1–2 mm
/// drop's caustic splits, moves out of the search range or fades, 0–0.41 and up to 20.
pub const AIRY_DOMAIN_STRENGTH: (f64, f64) = (0.5, 2.0);

/// Domain of the airy-local transfer: the most negative value the transfer produces before
/// clipping, over the column's largest `i_perp` or `i_par` in the filter's rows, must be above
/// −this. The sphere's Airy intensity is positive, so a column whose caustic is the sphere's
/// fold, moved and scaled, gets no negative values beyond the ray noise (≤ 1e-4 on a sphere,
/// ≤ 2 % at 0.5 mm); where it is not, the transferred correction overshoots (−10 % to −560 %
/// measured at 1 mm).
pub const AIRY_DOMAIN_NEGATIVE: f64 = 0.05;

/// Around a caustic, within `REPLACE_Z.0` Airy units the column's own order intensity is
/// replaced by the sphere's (shifted, scaled) GO intensity before the correction is added, with
/// a cosine taper to the column's own values at `REPLACE_Z.1`.
const REPLACE_Z: (f64, f64) = (0.25, 0.5);

/// The GO intensity of a fold caustic at distance `x` (in Airy units z) on the bright side, up
/// to a factor: the two-branch phasor sum z^(−1/2)·(1 + sin(4/3·z^(3/2))) (the asymptotic form
/// of Ai(−z)², whose branches are π/2 apart at the caustic).
fn fold_shape(z: f64) -> f64 {
    (1.0 + (4.0 / 3.0 * z.powf(1.5)).sin()) / z.sqrt()
}

/// Sub-row position (fractional row index) of a fold caustic in the intensity `v` (rows
/// `row0..row0 + v.len()`), given its peak row `jc`, the side of its bright side (`sign` = +1:
/// bright towards larger rows) and the Airy unit in rows `ell`: the caustic position `p` (within
/// 4.5 rows behind the peak row to half a row in front of it: the peak row may lie a few rows
/// into the bright side where the solid-angle floor of the patches caps the rows nearest the
/// caustic) whose fold shape
/// `C·fold_shape(sign·(j − p)/ell)` best fits the rows 1..=K past the peak (K rows ≈ `FIT_Z`
/// Airy units, at least 3), in relative least squares. The peak row itself is left out (it
/// carries the sampling of the singularity). `None` when fewer than 3 rows are usable.
fn fold_position(v: &[f64], row0: usize, jc: usize, sign: f64, ell: f64) -> Option<f64> {
    let k = ((FIT_Z * ell).round() as isize).max(3);
    let samples: Vec<(f64, f64)> = (1..=k)
        .filter_map(|d| {
            let j = jc as isize + sign as isize * d;
            let i = j - row0 as isize;
            (i >= 0 && (i as usize) < v.len() && v[i as usize] > 0.0)
                .then(|| (d as f64, v[i as usize]))
        })
        .collect();
    if samples.len() < 3 {
        return None;
    }
    // t: distance (rows) of the caustic behind the peak row, towards the dark side.
    let cost = |t: f64| -> f64 {
        let r: Vec<f64> = samples
            .iter()
            .map(|&(d, y)| y / fold_shape((d + t) / ell))
            .collect();
        let m = r.iter().sum::<f64>() / r.len() as f64;
        r.iter().map(|x| (x / m - 1.0).powi(2)).sum::<f64>()
    };
    let (lo, hi, n) = (-0.5, 4.5, 500usize);
    let h = (hi - lo) / n as f64;
    let costs: Vec<f64> = (0..=n).map(|i| cost(lo + h * i as f64)).collect();
    let i = (0..=n).min_by(|&a, &b| costs[a].total_cmp(&costs[b]))?;
    let mut t = lo + h * i as f64;
    if i > 0 && i < n {
        let (a, b, c) = (costs[i - 1], costs[i], costs[i + 1]);
        let den = a - 2.0 * b + c;
        if den > 0.0 {
            t += 0.5 * h * (a - c) / den;
        }
    }
    Some(jc as f64 - sign * t)
}

/// Azimuth half-width (deg) over which [`smooth_over_azimuth`] fits the caustic positions.
pub const POSITION_SMOOTHING_DEG: f64 = 5.0;

/// Smooth the caustic positions of the columns `positions[k]` (per bow, fractional rows;
/// columns k·`azimuth_step_deg` around the full circle) over azimuth: each is replaced by the
/// value at its own azimuth of a weighted least-squares quadratic in φ through the columns within
/// ±[`POSITION_SMOOTHING_DEG`] (tricube weights), which leaves a position varying smoothly with
/// azimuth (a deformed drop's) unbiased to second order and averages the ray noise of the
/// per-column fits. Columns without a position keep none; with fewer than 7 positions in the
/// window a column keeps its own.
pub fn smooth_over_azimuth(
    positions: &[[Option<f64>; 2]],
    azimuth_step_deg: f64,
) -> Vec<[Option<f64>; 2]> {
    let na = positions.len();
    let half =
        ((POSITION_SMOOTHING_DEG / azimuth_step_deg).floor() as isize).min((na as isize - 1) / 2);
    (0..na)
        .map(|k| {
            let mut out = positions[k];
            for (b, slot) in out.iter_mut().enumerate() {
                if slot.is_none() || half < 3 {
                    continue;
                }
                // Normal equations of y ≈ c0 + c1 x + c2 x² (x in columns from k).
                let mut m = [[0.0f64; 3]; 3];
                let mut r = [0.0f64; 3];
                let mut n = 0;
                for d in -half..=half {
                    let i = (k as isize + d).rem_euclid(na as isize) as usize;
                    let Some(y) = positions[i][b] else {
                        continue;
                    };
                    let u = d as f64 / (half + 1) as f64;
                    let w = (1.0 - u.abs().powi(3)).powi(3);
                    let x = d as f64;
                    let p = [1.0, x, x * x];
                    for a in 0..3 {
                        r[a] += w * p[a] * y;
                        for c in 0..3 {
                            m[a][c] += w * p[a] * p[c];
                        }
                    }
                    n += 1;
                }
                if n < 7 {
                    continue;
                }
                if let Some(c0) = solve3(m, r) {
                    *slot = Some(c0);
                }
            }
            out
        })
        .collect()
}

/// Weights of the airy-local transfer per column and bow from the columns' domain flags
/// ([`ColumnFilter::airy_domain`]; columns k·`azimuth_step_deg` around the full circle): each
/// column is first given 1 if every column within ±[`POSITION_SMOOTHING_DEG`] is in the domain
/// and 0 otherwise (erosion), and these are averaged over the same window (tricube weights). So
/// a column outside the domain weighs 0 (it never gets the transfer), a column whose every
/// neighbour within twice the window is inside weighs 1, and the blend of the transfer and the
/// Gaussian filter varies smoothly over azimuth in between instead of jumping between adjacent
/// columns.
pub fn domain_weights(flags: &[[bool; 2]], azimuth_step_deg: f64) -> Vec<[f64; 2]> {
    let na = flags.len();
    let half = ((POSITION_SMOOTHING_DEG / azimuth_step_deg).floor() as isize)
        .min((na as isize - 1) / 2)
        .max(0);
    let at = |k: usize, d: isize| (k as isize + d).rem_euclid(na as isize) as usize;
    let eroded: Vec<[f64; 2]> = (0..na)
        .map(|k| [0, 1].map(|b| f64::from((-half..=half).all(|d| flags[at(k, d)][b]))))
        .collect();
    (0..na)
        .map(|k| {
            [0, 1].map(|b| {
                let (mut sw, mut sv) = (0.0, 0.0);
                for d in -half..=half {
                    let u = d as f64 / (half + 1) as f64;
                    let w = (1.0 - u.abs().powi(3)).powi(3);
                    sw += w;
                    sv += w * eroded[at(k, d)][b];
                }
                // Exactly 1 (or 0) where every column in the window is 1 (or 0).
                if sv >= sw { 1.0 } else { sv / sw }
            })
        })
        .collect()
}

/// The first unknown of the 3×3 system `m·c = r` (Cramer's rule), if it is well conditioned.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<f64> {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let d = det(m);
    if !(d.abs() > 1e-12 * m[0][0].powi(3).max(1e-300)) {
        return None;
    }
    let mut a = m;
    for (row, v) in a.iter_mut().zip(r) {
        row[0] = v;
    }
    Some(det(a) / d)
}

/// Linear interpolation of `v` (rows `row0..row0 + v.len()`) at the fractional row `u`; `None`
/// outside. At a constant fractional offset it conserves the sum over rows.
fn interp(v: &[f64], row0: usize, u: f64) -> Option<f64> {
    let x = u - row0 as f64;
    if !(x >= 0.0) {
        return None;
    }
    let i = x.floor() as usize;
    let f = x - i as f64;
    match (v.get(i), v.get(i + 1)) {
        (Some(a), Some(b)) => Some(a + f * (b - a)),
        (Some(a), None) if f == 0.0 => Some(*a),
        _ => None,
    }
}

/// The sphere's caustic of one bow, as the transfer needs it.
#[derive(Debug, Clone)]
struct SphereBow {
    /// Fractional row of the fold caustic ([`fold_position`] on the sphere's GO intensity).
    position: f64,
    /// Airy unit (rows): distance of the Airy maximum from the caustic / [`AIRY_PEAK_Z`].
    ell: f64,
}

/// The uniform-caustic (Airy) correction of the equal-volume sphere, transferred to the columns
/// of a 2-D table (decision RT-28).
///
/// For a sphere the 1-D path's Airy-uniform channels differ from its geometric-optics (GO)
/// channels only around the primary (p = 2) and secondary (p = 3) caustics: `Δ = Airy − GO`
/// (dσ/dΩ per channel, bin averages on the table's polar rows) is the diffraction correction the
/// GO field lacks there. Each azimuth column of a traced table gets, per bow,
///
/// `value_c(θ) = col_c(θ) + s·Δ_c(θ − δ) − w(θ)·κ_c·(col_o(θ) − s·GO_o(θ − δ))`:
///
/// δ moves the sphere's fold caustic onto the column's own, both located to a fraction of a row
/// by fitting the fold shape of the GO intensity of the order `o` past its peak
/// (`fold_position`); the sphere's channels are interpolated linearly at the fractional shift
/// (which conserves their sum over rows). `s` scales the correction to the column's caustic
/// strength (the ratio of the column's order intensity to the shifted sphere's over 0.1°–1.5° on
/// the bright side). Within `REPLACE_Z` Airy units of the caustic (weight `w`, 1 inside
/// `REPLACE_Z.0`, cosine taper to 0 at `REPLACE_Z.1`), the column's own order intensity is
/// replaced by the shifted, scaled sphere's GO intensity (`κ_c`: the order's share of channel
/// `c`), so the result there is the sphere's Airy intensity rather than a difference of two
/// differently sampled GO singularities (the column's point samples against the sphere's bin
/// averages). Rows above the Alexander-band midpoint take the primary's correction, rows below the
/// secondary's. On a sphere δ = 0 and s = 1 up to ray noise, so the 2-D path reproduces the 1-D
/// Airy path. Domain: fold caustics of drops close to the sphere; the Airy width stays the
/// sphere's (the local curvature of a deformed drop's deviation function is not followed), and
/// columns where a deformed drop's caustic splits or vanishes take a shifted, scaled sphere
/// correction that is only as good as that picture.
#[derive(Debug, Clone)]
pub struct AiryTransfer {
    /// First row of the arrays (the filter's [`ColumnFilter::needed_rows`]`.0`).
    row0: usize,
    /// Airy − GO (µm²/sr) of the columns' channels `[i_perp, i_par, p0, p1, …]`.
    delta: Vec<Vec<f64>>,
    /// GO (µm²/sr) of the same channels.
    go: Vec<Vec<f64>>,
    /// The primary's and the secondary's caustic.
    bows: [Option<SphereBow>; 2],
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
        let argmax = |v: &[f64], (lo, hi): (f64, f64)| -> Option<usize> {
            let (a, b) = (
                filter.row(lo.to_radians()).max(rows.0),
                filter.row(hi.to_radians()).min(rows.1),
            );
            (a..=b).max_by(|&x, &y| v[x - rows.0].total_cmp(&v[y - rows.0]))
        };
        let bow = |b: usize, search: (f64, f64), sign: f64| -> Option<SphereBow> {
            let c = 2 + 2 + b;
            let (g, a) = (go.get(c)?, airy.get(c)?);
            let jc = argmax(g, search)?;
            let ja = argmax(a, search)?;
            if !(g[jc - rows.0] > 0.0) || ja == rows.0 || ja >= rows.1 {
                return None;
            }
            // Airy maximum to a fraction of a row (parabola through three rows).
            let (y0, y1, y2) = (a[ja - 1 - rows.0], a[ja - rows.0], a[ja + 1 - rows.0]);
            let den = y0 - 2.0 * y1 + y2;
            let peak = ja as f64
                + if den < 0.0 {
                    0.5 * (y0 - y2) / den
                } else {
                    0.0
                };
            let rough = sign * (peak - jc as f64) / AIRY_PEAK_Z;
            if !(rough > 0.0) {
                return None;
            }
            let position = fold_position(g, rows.0, jc, sign, rough).unwrap_or(jc as f64);
            let ell = sign * (peak - position) / AIRY_PEAK_Z;
            (ell > 0.0).then_some(SphereBow { position, ell })
        };
        AiryTransfer {
            row0: rows.0,
            delta,
            go: go.to_vec(),
            bows: [
                bow(0, PRIMARY_SEARCH_DEG, 1.0),
                bow(1, SECONDARY_SEARCH_DEG, -1.0),
            ],
        }
    }
}

/// Per channel [i_perp, i_par, order], the (row, deviation) at either edge of a replacement
/// window.
type WindowEdges = [[(f64, f64); 2]; 3];

/// Rows averaged on either side of the replacement window for its edge values.
const EDGE_ROWS: isize = 3;

/// One bow of one column: what [`ColumnFilter::transfer_column`] applies.
#[derive(Debug, Clone, Copy)]
struct ColumnBow {
    /// Column row of the caustic (fractional) and the shift δ (rows) from the sphere's.
    position: f64,
    shift: f64,
    strength: f64,
    /// Channel of the bow's order in the column.
    channel: usize,
    /// Replacement window half-widths (rows).
    window: (f64, f64),
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

    /// Whether [`ColumnFilter::filter_column_at`] uses caustic positions (the airy-local
    /// transfer, filter enabled).
    pub fn uses_fold_positions(&self) -> bool {
        self.enabled && self.airy.is_some()
    }

    /// The sub-row caustic positions (fractional rows) of one column's primary and secondary
    /// (`fold_position` past the column's peak row of the order; the peak row when the fit
    /// fails), with the airy-local transfer; `None` per bow without one. Arguments as
    /// [`ColumnFilter::filter_column`].
    pub fn fold_positions(
        &self,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        primary: Option<usize>,
        secondary: Option<usize>,
    ) -> [Option<f64>; 2] {
        let mut out = [None, None];
        let (Some(t), true) = (&self.airy, self.enabled) else {
            return out;
        };
        let (j0, j1) = rows;
        for (b, ((search, sign), order)) in
            [(PRIMARY_SEARCH_DEG, 1.0), (SECONDARY_SEARCH_DEG, -1.0)]
                .into_iter()
                .zip([primary, secondary])
                .enumerate()
        {
            let (Some(c), Some(sb)) = (order, &t.bows[b]) else {
                continue;
            };
            let (a, z) = (
                self.row(search.0.to_radians()).max(j0),
                self.row(search.1.to_radians()).min(j1),
            );
            let Some(jc) = (a..=z).max_by(|&x, &y| cols[c][x - j0].total_cmp(&cols[c][y - j0]))
            else {
                continue;
            };
            out[b] = Some(fold_position(&cols[c], j0, jc, sign, sb.ell).unwrap_or(jc as f64));
        }
        out
    }

    /// The bows of one column for the airy-local transfer `t`: per bow with an order, a sphere
    /// bow and a caustic position, the shift from the sphere's caustic and the strength (the
    /// column's intensity over the shifted sphere GO's, summed over [`STRENGTH_RANGE_DEG`] on
    /// the bright side). Arguments as [`ColumnFilter::transfer_column`].
    fn column_bows(
        &self,
        t: &AiryTransfer,
        (j0, j1): (usize, usize),
        cols: &[Vec<f64>],
        orders: [Option<usize>; 2],
        positions: [Option<f64>; 2],
    ) -> [Option<ColumnBow>; 2] {
        let mut bows: [Option<ColumnBow>; 2] = [None, None];
        for (b, (sign, order)) in [1.0, -1.0].into_iter().zip(orders).enumerate() {
            let (Some(c), Some(sb), Some(position)) = (order, &t.bows[b], positions[b]) else {
                continue;
            };
            let Some(go) = t.go.get(c) else {
                continue;
            };
            let shift = position - sb.position;
            let (d0, d1) = (
                (STRENGTH_RANGE_DEG.0.to_radians() / self.step).round() as isize,
                (STRENGTH_RANGE_DEG.1.to_radians() / self.step).round() as isize,
            );
            let (mut num, mut den) = (0.0, 0.0);
            for d in d0..=d1 {
                let j = position.round() as isize + sign as isize * d;
                if j < j0 as isize || j > j1 as isize {
                    continue;
                }
                let Some(g) = interp(go, t.row0, j as f64 - shift) else {
                    continue;
                };
                num += cols[c][j as usize - j0];
                den += g;
            }
            if den > 0.0 {
                bows[b] = Some(ColumnBow {
                    position,
                    shift,
                    strength: num / den,
                    channel: c,
                    window: (REPLACE_Z.0 * sb.ell, REPLACE_Z.1 * sb.ell),
                });
            }
        }
        bows
    }

    /// Whether the caustic at row `p` of bow `b` (0: primary) lies inside the bow's search
    /// range less one row at either end (a caustic found on its edge lies outside it).
    fn inside_search_range(&self, (j0, j1): (usize, usize), b: usize, p: f64) -> bool {
        let range = if b == 0 {
            PRIMARY_SEARCH_DEG
        } else {
            SECONDARY_SEARCH_DEG
        };
        let (a, z) = (
            self.row(range.0.to_radians()).max(j0),
            self.row(range.1.to_radians()).min(j1),
        );
        p > a as f64 + 1.0 && p < z as f64 - 1.0
    }

    /// The transferred Airy correction of one column (see [`AiryTransfer`]), at the caustic
    /// positions `positions` (fractional rows, per bow; see [`ColumnFilter::fold_positions`]).
    fn transfer_column(
        &self,
        t: &AiryTransfer,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        orders: [Option<usize>; 2],
        positions: [Option<f64>; 2],
    ) -> (CausticWindow, [bool; 2]) {
        let (j0, j1) = rows;
        let bows = self.column_bows(t, rows, cols, orders, positions);
        let nvals = cols.len();
        // The column's deviation from the shifted, scaled sphere GO in channel c at row j.
        let deviation = |bw: &ColumnBow, c: usize, j: usize| -> Option<f64> {
            let g = interp(t.go.get(c)?, t.row0, j as f64 - bw.shift)?;
            Some(cols[c][j - j0] - bw.strength * g)
        };
        // Per bow and channel [i_perp, i_par, order]: the deviation on either edge of the
        // replacement window (mean over EDGE_ROWS rows just outside it) as (row, value) pairs.
        let edges: [Option<WindowEdges>; 2] = bows.map(|bw| {
            let bw = bw?;
            let lo = (bw.position - bw.window.1).floor() as isize;
            let hi = (bw.position + bw.window.1).ceil() as isize;
            let mut out = [[(0.0, 0.0); 2]; 3];
            for (ci, c) in [0, 1, bw.channel].into_iter().enumerate() {
                for (side, rows) in [(lo - EDGE_ROWS + 1..=lo), (hi..=hi + EDGE_ROWS - 1)]
                    .into_iter()
                    .enumerate()
                {
                    let (mut n, mut sj, mut sd) = (0.0, 0.0, 0.0);
                    for j in rows {
                        if j < j0 as isize || j > j1 as isize {
                            return None;
                        }
                        sd += deviation(&bw, c, j as usize)?;
                        sj += j as f64;
                        n += 1.0;
                    }
                    out[ci][side] = (sj / n, sd / n);
                }
            }
            Some(out)
        });
        let mut values = Vec::with_capacity((j1 + 1 - j0) * nvals);
        // Per bow: the most negative value before clipping and the largest i_perp, i_par.
        let mut lowest = [0.0f64; 2];
        let mut largest = [0.0f64; 2];
        for j in j0..=j1 {
            let th = self.step * j as f64;
            let b = usize::from(th <= self.split);
            let start = values.len();
            values.extend(cols.iter().map(|col| col[j - j0]));
            let Some(bw) = bows[b] else {
                continue;
            };
            let u = j as f64 - bw.shift;
            let dist = (j as f64 - bw.position).abs();
            let w = match edges[b] {
                None => 0.0,
                Some(_) if dist <= bw.window.0 => 1.0,
                Some(_) if dist >= bw.window.1 => 0.0,
                Some(_) => {
                    let x = (dist - bw.window.0) / (bw.window.1 - bw.window.0);
                    0.5 * (1.0 + (std::f64::consts::PI * x).cos())
                }
            };
            // i_perp, i_par and the bow's own order; other orders have no caustic here.
            for (ci, c) in [0, 1, bw.channel].into_iter().enumerate() {
                let Some(d) = t.delta.get(c).and_then(|d| interp(d, t.row0, u)) else {
                    continue;
                };
                // Within the window the column's deviation from the sphere's GO (the sampling
                // of the singularity and the cross-order ripple it drives) is replaced by its
                // straight line between the window's edges.
                let replace = match (w > 0.0, edges[b], deviation(&bw, c, j)) {
                    (true, Some(e), Some(dev)) => {
                        let [(ja, da), (jb, db)] = e[ci];
                        let line = da + (db - da) * (j as f64 - ja) / (jb - ja);
                        w * (dev - line)
                    }
                    _ => 0.0,
                };
                let v = &mut values[start + c];
                let unclipped = *v + bw.strength * d - replace;
                if ci < 2 {
                    lowest[b] = lowest[b].min(unclipped);
                    largest[b] = largest[b].max(cols[c][j - j0]);
                }
                *v = unclipped.max(0.0);
            }
        }
        let in_domain = [0, 1].map(|b| {
            bows[b].is_some_and(|bw| {
                (AIRY_DOMAIN_STRENGTH.0..=AIRY_DOMAIN_STRENGTH.1).contains(&bw.strength)
                    && self.inside_search_range(rows, b, bw.position)
                    && lowest[b] >= -AIRY_DOMAIN_NEGATIVE * largest[b]
            })
        });
        (
            CausticWindow {
                start: j0,
                len: j1 + 1 - j0,
                nvals,
                values,
            },
            in_domain,
        )
    }

    /// Whether each bow of one column lies in the airy-local transfer's domain
    /// ([`AIRY_DOMAIN_STRENGTH`], [`AIRY_DOMAIN_NEGATIVE`], a caustic inside the search range),
    /// at the caustic positions `positions`; `[false, false]` without a transfer. Arguments as
    /// [`ColumnFilter::filter_column_at`].
    pub fn airy_domain(
        &self,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        primary: Option<usize>,
        secondary: Option<usize>,
        positions: [Option<f64>; 2],
    ) -> [bool; 2] {
        self.transfer_columns(rows, &[cols], primary, secondary, &[positions])
            .and_then(|mut t| t.pop())
            .map_or([false, false], |(_, flags)| flags)
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
        let positions = self.fold_positions(rows, cols, primary, secondary);
        match self.transfer_columns(rows, &[cols], primary, secondary, &[positions]) {
            None => self.gaussian_windows(rows, &[cols], primary, secondary),
            // One transfer: its window and its domain flags as the column's weights.
            Some(t) => {
                let (windows, flags): (Vec<_>, Vec<_>) = t.into_iter().unzip();
                let weights = [flags[0].map(f64::from)];
                self.blend_with_gaussian(rows, &[cols], primary, secondary, windows, &weights)
            }
        }
        .pop()
        .unwrap_or_default()
    }

    /// [`ColumnFilter::filter_column`] with the caustic positions of the airy-local transfer
    /// given (e.g. [`ColumnFilter::fold_positions`] smoothed over azimuth with
    /// [`smooth_over_azimuth`]) and the transfer's weight per bow (1: the transfer, 0: the
    /// Gaussian filter, between: their blend; e.g. [`ColumnFilter::airy_domain`] smoothed over
    /// azimuth with [`domain_weights`]). Without a transfer the Gaussian filter ignores both.
    pub fn filter_column_at(
        &self,
        rows: (usize, usize),
        cols: &[Vec<f64>],
        primary: Option<usize>,
        secondary: Option<usize>,
        positions: [Option<f64>; 2],
        airy_weight: [f64; 2],
    ) -> CausticWindow {
        let mut w = self.filter_columns_at(
            rows,
            &[cols],
            primary,
            secondary,
            &[positions],
            &[airy_weight],
        );
        w.pop().unwrap_or_default()
    }

    /// [`ColumnFilter::filter_column_at`] of several columns (`blocks[c]` is column `c`'s
    /// values, `positions[c]` its caustic positions, `airy_weights[c]` its transfer weights).
    /// The Gaussian filter convolves the values of all columns in one pass over the rows (each
    /// value's sum in row order, as one column at a time would: the windows are identical),
    /// which vectorises. With a transfer, a column whose weights are both 1 gets the transfer
    /// alone, one whose weights are both 0 the Gaussian filter alone; each row takes the weight
    /// of its bow (primary above the Alexander-band midpoint, secondary below).
    pub fn filter_columns_at(
        &self,
        rows: (usize, usize),
        blocks: &[&[Vec<f64>]],
        primary: Option<usize>,
        secondary: Option<usize>,
        positions: &[[Option<f64>; 2]],
        airy_weights: &[[f64; 2]],
    ) -> Vec<CausticWindow> {
        if !self.enabled {
            return vec![CausticWindow::default(); blocks.len()];
        }
        match self.transfer_columns(rows, blocks, primary, secondary, positions) {
            None => self.gaussian_windows(rows, blocks, primary, secondary),
            Some(t) => {
                let windows = t.into_iter().map(|(w, _)| w).collect();
                self.blend_with_gaussian(rows, blocks, primary, secondary, windows, airy_weights)
            }
        }
    }

    /// The airy-local transfer of several columns (`blocks[c]` is column `c`'s values,
    /// `positions[c]` its caustic positions), each with its bows' domain flags (see
    /// [`ColumnFilter::airy_domain`]); `None` without a transfer or with the filter off.
    pub fn transfer_columns(
        &self,
        rows: (usize, usize),
        blocks: &[&[Vec<f64>]],
        primary: Option<usize>,
        secondary: Option<usize>,
        positions: &[[Option<f64>; 2]],
    ) -> Option<Vec<(CausticWindow, [bool; 2])>> {
        let t = self.airy.as_ref().filter(|_| self.enabled)?;
        Some(
            blocks
                .iter()
                .zip(positions)
                .map(|(cols, pos)| self.transfer_column(t, rows, cols, [primary, secondary], *pos))
                .collect(),
        )
    }

    /// Blend the transferred windows `transferred` of several columns (from
    /// [`ColumnFilter::transfer_columns`]; `blocks` as there) with the Gaussian filter by the
    /// transfer's weights per bow: a column whose weights are both 1 keeps its transfer, one
    /// whose weights are both 0 gets the Gaussian filter alone, and in between each row takes
    /// `w·transfer + (1 − w)·gaussian` with the weight of its bow (primary above the
    /// Alexander-band midpoint, secondary below).
    pub fn blend_with_gaussian(
        &self,
        rows: (usize, usize),
        blocks: &[&[Vec<f64>]],
        primary: Option<usize>,
        secondary: Option<usize>,
        transferred: Vec<CausticWindow>,
        airy_weights: &[[f64; 2]],
    ) -> Vec<CausticWindow> {
        if airy_weights.iter().all(|w| w[0] >= 1.0 && w[1] >= 1.0) {
            return transferred;
        }
        let gaussian = self.gaussian_windows(rows, blocks, primary, secondary);
        transferred
            .into_iter()
            .zip(gaussian)
            .zip(airy_weights)
            .zip(blocks)
            .map(|(((mut a, g), w), cols)| {
                if w[0] <= 0.0 && w[1] <= 0.0 {
                    return g;
                }
                let nvals = a.nvals;
                for j in a.start..a.start + a.len {
                    let wb = w[usize::from(self.step * j as f64 <= self.split)];
                    if wb >= 1.0 {
                        continue;
                    }
                    let base = (j - a.start) * nvals;
                    for v in 0..nvals {
                        let gv = g.get(j).map_or(cols[v][j - rows.0], |g| g[v]);
                        let x = &mut a.values[base + v];
                        *x = wb * *x + (1.0 - wb) * gv;
                    }
                }
                a
            })
            .collect()
    }

    /// The bows of one column (the peaks of its primary and secondary intensity within their
    /// search ranges) and the window rows around them; `None` without a bow. Arguments as
    /// [`ColumnFilter::filter_column`].
    fn bow_window(
        &self,
        (j0, j1): (usize, usize),
        cols: &[Vec<f64>],
        primary: Option<usize>,
        secondary: Option<usize>,
    ) -> Option<BowWindow> {
        let reach = window_reach_rad(2.0 * self.sigma * DEFAULT_CAUSTIC_WINDOW_SIGMAS);
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
            return None;
        }
        let lo = self
            .row(bows.iter().cloned().fold(f64::MAX, f64::min) - reach)
            .max(j0);
        let hi = self
            .row(bows.iter().cloned().fold(f64::MIN, f64::max) + reach)
            .min(j1);
        Some((bows, lo, hi))
    }

    /// The thesis's windowed Gaussian filter of several columns (see
    /// [`ColumnFilter::filter_columns_at`]).
    fn gaussian_windows(
        &self,
        rows: (usize, usize),
        blocks: &[&[Vec<f64>]],
        primary: Option<usize>,
        secondary: Option<usize>,
    ) -> Vec<CausticWindow> {
        let (j0, j1) = rows;
        let windows: Vec<Option<BowWindow>> = blocks
            .iter()
            .map(|cols| self.bow_window(rows, cols, primary, secondary))
            .collect();
        let lo = windows.iter().flatten().map(|w| w.1).min();
        let hi = windows.iter().flatten().map(|w| w.2).max();
        let (Some(lo), Some(hi)) = (lo, hi) else {
            return vec![CausticWindow::default(); blocks.len()];
        };
        let nvals = blocks[0].len();
        let lanes = blocks.len() * nvals;
        let m = interleave_rows(blocks, j1 + 1 - j0);
        let mut values: Vec<Vec<f64>> = windows
            .iter()
            .map(|w| {
                w.as_ref()
                    .map_or(vec![], |w| Vec::with_capacity((w.2 + 1 - w.1) * nvals))
            })
            .collect();
        let mut acc = vec![0.0; lanes];
        for j in lo..=hi {
            let th = self.step * j as f64;
            let s = self.sigma_at(th);
            let k = &self.kernels[usize::from(th <= self.split)];
            let half = k.len() - 1;
            // Kernel support clipped to the table (renormalised) and to the supplied rows.
            let (a, b) = (j.saturating_sub(half), (j + half).min(self.n_polar - 1));
            let (a, b) = (a.max(j0), b.min(j1));
            acc.fill(0.0);
            let mut wsum = 0.0;
            for (i, row) in (a..=b).zip(m[(a - j0) * lanes..].chunks_exact(lanes)) {
                let kw = k[i.abs_diff(j)];
                for (acc, x) in acc.iter_mut().zip(row) {
                    *acc += kw * x;
                }
                wsum += kw;
            }
            for (c, (win, out)) in windows.iter().zip(values.iter_mut()).enumerate() {
                let Some((bows, lo, hi)) = win else {
                    continue;
                };
                if j < *lo || j > *hi {
                    continue;
                }
                let w = caustic_weight(th, bows, s * DEFAULT_CAUSTIC_WINDOW_SIGMAS);
                for (acc, col) in acc[c * nvals..(c + 1) * nvals].iter().zip(blocks[c].iter()) {
                    let blurred = if wsum > 0.0 { acc / wsum } else { 0.0 };
                    out.push(w * blurred + (1.0 - w) * col[j - j0]);
                }
            }
        }
        windows
            .into_iter()
            .zip(values)
            .map(|(win, values)| match win {
                Some((_, lo, hi)) => CausticWindow {
                    start: lo,
                    len: hi + 1 - lo,
                    nvals,
                    values,
                },
                None => CausticWindow::default(),
            })
            .collect()
    }
}

/// The bows of one column (polar angles, rad) and its window rows `lo..=hi`.
type BowWindow = (Vec<f64>, usize, usize);

/// The first `rows` values of every column of `blocks` (`blocks[c][v]`: value `v` of column
/// `c`), row-major: row i holds value v of column c at `c · nvals + v`.
fn interleave_rows(blocks: &[&[Vec<f64>]], rows: usize) -> Vec<f64> {
    let nvals = blocks[0].len();
    let lanes = blocks.len() * nvals;
    let mut m = vec![0.0; rows * lanes];
    for (c, cols) in blocks.iter().enumerate() {
        for (v, col) in cols.iter().enumerate() {
            for (i, x) in col.iter().enumerate().take(rows) {
                m[i * lanes + c * nvals + v] = *x;
            }
        }
    }
    m
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

    /// The fold fit recovers the sub-row caustic position of point-sampled fold intensities on
    /// either side, wherever the caustic falls between two rows (the integer peak row alone is
    /// up to a row off).
    #[test]
    fn fold_position_finds_the_caustic_between_rows() {
        let (row0, n, ell) = (100usize, 200usize, 30.0);
        for sign in [1.0, -1.0] {
            for k in 0..10 {
                let p = 200.0 + 0.1 * k as f64 + 0.05;
                let v: Vec<f64> = (0..n)
                    .map(|i| {
                        let x = sign * ((row0 + i) as f64 - p);
                        if x > 0.0 {
                            3.0 * fold_shape(x / ell)
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let jc = (0..n).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap() + row0;
                let got = fold_position(&v, row0, jc, sign, ell).unwrap();
                assert!((got - p).abs() < 0.01, "sign {sign}: {got} vs {p}");
            }
        }
        // Too few rows past the peak: no fit.
        let v = vec![0.0, 0.0, 5.0, 2.0, 1.0];
        assert!(fold_position(&v, 0, 2, 1.0, 30.0).is_none());
    }

    #[test]
    fn interp_conserves_sums_at_a_fractional_offset() {
        let v: Vec<f64> = (0..50).map(|i| ((i as f64) * 0.3).sin().powi(2)).collect();
        let f = 0.37;
        // Rows fully inside: the shifted samples sum to the original sum (up to the ends).
        let shifted: f64 = (1..49)
            .map(|j| interp(&v, 10, (10 + j) as f64 - f).unwrap())
            .sum();
        let direct: f64 = v[1..49].iter().sum::<f64>() - f * (v[48] - v[0]);
        assert!((shifted - direct).abs() < 1e-12, "{shifted} vs {direct}");
        assert!(interp(&v, 10, 9.5).is_none() && interp(&v, 10, 59.5).is_none());
        assert_eq!(interp(&v, 10, 59.0), Some(v[49]));
    }

    #[test]
    fn disabled_filter_keeps_columns() {
        let f = ColumnFilter::new(1801, 0.1f64.to_radians(), 0.004, 2.3, false);
        let win = f.filter_column(f.needed_rows(), &[vec![1.0; 1801]], Some(0), None);
        assert_eq!(win.len, 0);
        assert!(win.get(1380).is_none());
    }

    /// The transfer weights of [`domain_weights`]: 0 at a column outside the domain, rising
    /// strictly and symmetrically over the 10 columns (±2 × 5°) on either side, 1 beyond; each
    /// bow on its own; a window of one column (coarse azimuth grids) keeps the flags.
    #[test]
    fn domain_weights_erode_and_blend_over_azimuth() {
        let mut flags = vec![[true, true]; 360];
        flags[100][0] = false;
        let w = domain_weights(&flags, 1.0);
        assert!(w.iter().all(|x| x[1] == 1.0));
        assert_eq!(w[100][0], 0.0);
        for d in 1..=10 {
            let (a, b) = (w[100 + d][0], w[100 - d][0]);
            assert!(a > 0.0 && a < 1.0, "+{d}: {a}");
            assert!((a - b).abs() < 1e-12, "±{d}: {a} vs {b}");
            assert!(a > w[100 + d - 1][0]);
        }
        assert!(
            w.iter()
                .enumerate()
                .all(|(k, x)| k.abs_diff(100) <= 10 || x[0] == 1.0)
        );
        let coarse = domain_weights(&[[true, false], [false, true], [true, true]], 10.0);
        assert_eq!(coarse, vec![[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]);
    }
}
