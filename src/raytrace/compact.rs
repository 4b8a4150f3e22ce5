//! Compact 2-D phase tables: one entry seen through the sun's disc, then resampled onto
//! adaptive polar and azimuth knots where linear interpolation meets a stated tolerance
//! (docs/raytrace.md, "Compact tables"; docs/decisions.md RT-39).
//!
//! A dense entry carries pixel-scale ray and fringe structure (8–9 % at the thesis
//! resolution) that the sun's 0.5° disc removes, so the error a compact entry states is defined
//! as a renderer sees it: against the dense entry convolved with the same disc.
//!
//! - The disc: the Gaussian with the second moment of a uniform disc of diameter `d`
//!   (σ = d/4 of arc per axis; 0.125° for the 0.5° sun), applied separably: along the polar
//!   (scattering) angle with σ, along the azimuth about the incident direction with σ/sin θ
//!   (wrapped around the circle; the whole row's mean at the poles), reflecting across the
//!   poles onto the opposite azimuth.
//! - Knots: azimuth first (every polar row checked), then polar (every kept azimuth column
//!   checked), each the greedy furthest knot whose linear interpolation keeps i_perp and i_par
//!   within a share of the tolerance of the filtered values, relative to the filtered phase at
//!   each direction: the azimuth knots a first share, the polar knots what the azimuth knots'
//!   measured error leaves ([`compact_entry`]); the bilinear interpolant is then re-measured on
//!   every dense direction, with the values as stored (decision RT-42).
//! - A mirror symmetric entry (its value at φ that at 360° − φ) keeps knots over 0°–180° only;
//!   its table's azimuth axis is even-periodic (table format 3.0) and every lookup folds onto it.
//! - Values (`values`): the four channels as f32, or (`top16`) i_perp and i_par as 16-bit codes
//!   (table format 2.0, `f32-top16le`: relative rounding ≤ 2^−9, or 2^−(m+1) with
//!   `mantissa_bits` m) with phase and dolp derived from them by every reader; the knots then
//!   keep a margin for the rounding (decision RT-41).

use crate::raytrace::tracer::DirectionGrid;
use crate::table::codec::{DerivedOp, round_mantissa, top16_round};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The sun's apparent diameter compact tables assume by default (deg).
pub const SUN_DIAMETER_DEG: f64 = 0.5;

/// The `compression` key of the `raytrace` stage.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Compression {
    /// The dense table on the uniform direction grid.
    #[default]
    None,
    /// Seen through the sun's disc, resampled onto adaptive knots.
    SunDiscResampled(SunDiscResampled),
}

/// Parameters of [`Compression::SunDiscResampled`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SunDiscResampled {
    /// Largest error of the compact entry against the disc-filtered dense entry, relative to
    /// the filtered phase at each direction, of phase, i_perp and i_par.
    pub tolerance: f64,
    /// Apparent diameter of the sun (deg).
    #[serde(default = "default_sun_diameter_deg")]
    pub sun_diameter_deg: f64,
    /// What the tolerance bounds.
    #[serde(default)]
    pub norm: ErrorNorm,
    /// How the table stores its values.
    #[serde(default)]
    pub values: StoredValues,
    /// With `values = "top16"`: the mantissa bits kept of i_perp and i_par (1–8; default 8, all
    /// a 16-bit code holds). Fewer bits round each value to a code whose low bits are zero,
    /// which the table's compression stores in fewer bytes; readers decode it unchanged.
    #[serde(default = "default_mantissa_bits")]
    pub mantissa_bits: u32,
}

/// How a compact table stores its values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StoredValues {
    /// phase, i_perp, i_par and dolp as f32 (table format 1.0).
    #[default]
    F32,
    /// i_perp and i_par as 16-bit codes, one polar row predicting the next; phase and dolp
    /// derived from them by every reader (table format 2.0, `f32-top16le`).
    Top16,
}

/// What the tolerance of a compact table bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorNorm {
    /// The error at every direction of the dense grid, relative to the phase there.
    #[default]
    Max,
    /// The root mean square of the relative error (solid-angle weighted) over each of
    /// [`ERROR_WINDOWS`]; the knots meet it over every interval between knots.
    Rms,
}

fn default_sun_diameter_deg() -> f64 {
    SUN_DIAMETER_DEG
}

/// All the mantissa bits a `f32-top16le` code holds.
pub const TOP16_MANTISSA_BITS: u32 = 8;

fn default_mantissa_bits() -> u32 {
    TOP16_MANTISSA_BITS
}

/// The `kind` naming [`Compression::SunDiscResampled`] in manifests and headers.
pub const SUN_DISC_RESAMPLED: &str = "sun-disc-resampled";

impl Compression {
    /// True for the dense table.
    pub fn is_none(&self) -> bool {
        *self == Compression::None
    }

    /// The value from its manifest form: `"none"` or `{ kind = "sun-disc-resampled", tolerance
    /// = …, sun_diameter_deg = … }`.
    pub fn from_value(v: serde_json::Value) -> Result<Self, String> {
        const FORMS: &str = "\"none\" or { kind = \"sun-disc-resampled\", tolerance = 0.01 } (optional sun_diameter_deg, default 0.5; norm = \"max\" | \"rms\"; values = \"f32\" | \"top16\")";
        match v {
            serde_json::Value::String(s) if s == "none" => Ok(Compression::None),
            serde_json::Value::Object(mut m) => {
                match m.remove("kind") {
                    Some(serde_json::Value::String(k)) if k == SUN_DISC_RESAMPLED => {}
                    Some(k) => return Err(format!("unknown kind {k}; expected {FORMS}")),
                    None => return Err(format!("a table needs `kind`; expected {FORMS}")),
                }
                let spec: SunDiscResampled = serde_json::from_value(m.into())
                    .map_err(|e| format!("{e}; expected {FORMS}"))?;
                spec.check()?;
                Ok(Compression::SunDiscResampled(spec))
            }
            other => Err(format!("unknown compression {other}; expected {FORMS}")),
        }
    }
}

impl SunDiscResampled {
    /// Tolerance within (0, 1), sun diameter within (0, 10]°.
    pub fn check(&self) -> Result<(), String> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!(
                "tolerance {} must lie within (0, 1) (a relative error)",
                self.tolerance
            ));
        }
        if self.values == StoredValues::Top16 {
            if !(1..=TOP16_MANTISSA_BITS).contains(&self.mantissa_bits) {
                return Err(format!(
                    "mantissa_bits {} must lie within 1..={TOP16_MANTISSA_BITS} (the bits a 16-bit \
                     code holds)",
                    self.mantissa_bits
                ));
            }
            let margin = self.rounding_margin();
            if !(self.tolerance > margin) {
                return Err(format!(
                    "tolerance {} must exceed {margin} with values = \"top16\" and {} mantissa \
                     bits (the rounding alone may reach it)",
                    self.tolerance, self.mantissa_bits
                ));
            }
        } else if self.mantissa_bits != TOP16_MANTISSA_BITS {
            return Err(format!(
                "mantissa_bits {} needs values = \"top16\" (f32 values keep all their bits)",
                self.mantissa_bits
            ));
        }
        if !(self.sun_diameter_deg > 0.0 && self.sun_diameter_deg <= 10.0) {
            return Err(format!(
                "sun_diameter_deg {} must lie within (0, 10]",
                self.sun_diameter_deg
            ));
        }
        Ok(())
    }

    /// The largest error the rounding of the stored i_perp and i_par adds, relative to the
    /// phase: 0 for f32 (below 1e-7), 2 × 2^−(m+1) = 2^−m with m mantissa bits of a 16-bit code
    /// (a value is at most 2 × phase).
    pub fn rounding_margin(&self) -> f64 {
        match self.values {
            StoredValues::F32 => 0.0,
            StoredValues::Top16 => 0.5f64.powi(self.mantissa_bits as i32),
        }
    }

    /// Gaussian σ (deg of arc) with the second moment of the uniform disc: radius/2.
    pub fn sigma_deg(&self) -> f64 {
        self.sun_diameter_deg / 4.0
    }
}

impl Serialize for Compression {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Compression::None => s.serialize_str("none"),
            Compression::SunDiscResampled(c) => {
                let mut v = serde_json::json!({
                    "kind": SUN_DISC_RESAMPLED,
                    "tolerance": c.tolerance,
                    "sun_diameter_deg": c.sun_diameter_deg,
                    "norm": c.norm,
                });
                // Absent when f32, so the content keys of f32 tables stay as they were.
                if c.values != StoredValues::F32 {
                    v["values"] = serde_json::json!(c.values);
                }
                // Absent at the default, so the content keys of 8-bit tables stay as they were.
                if c.mantissa_bits != TOP16_MANTISSA_BITS {
                    v["mantissa_bits"] = serde_json::json!(c.mantissa_bits);
                }
                v.serialize(s)
            }
        }
    }
}

impl<'de> Deserialize<'de> for Compression {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = serde_json::Value::deserialize(d)?;
        Compression::from_value(v).map_err(serde::de::Error::custom)
    }
}

/// Scattering-angle windows over which compact entries report their error (deg, inclusive).
pub const ERROR_WINDOWS: [(&str, f64, f64); 4] = [
    ("primary", 134.0, 150.0),
    ("secondary", 115.0, 134.0),
    ("bows", 125.0, 145.0),
    ("all", 0.0, 180.0),
];

/// The polarised components of one entry on its uniform direction grid, `[polar][azimuth]`.
pub struct Components<'a> {
    pub grid: DirectionGrid,
    pub i_perp: &'a [f64],
    pub i_par: &'a [f64],
    /// The entry is mirror symmetric in azimuth (its value at φ is its value at 360° − φ; the
    /// azimuth count is even, so 180° is a sample): its knots cover 0°–180° only, the samples
    /// beyond are their mirror images ([`stored_azimuths`]).
    pub mirror: bool,
}

/// The azimuth columns a compact entry's knots cover on a grid of `n_azimuth` columns: all, or
/// for a mirror symmetric entry (`n_azimuth` even) the columns 0°–180°, `0..=n_azimuth / 2`.
pub fn stored_azimuths(n_azimuth: usize, mirror: bool) -> usize {
    if mirror { n_azimuth / 2 + 1 } else { n_azimuth }
}

impl Components<'_> {
    /// The azimuth columns the knots cover ([`stored_azimuths`]).
    fn stored_azimuths(&self) -> usize {
        stored_azimuths(self.grid.n_azimuth, self.mirror)
    }

    /// The stored column that stands for dense column `k`: `k`, or its mirror image `n − k`
    /// beyond 180° of a mirror symmetric entry.
    fn folded(&self, k: usize) -> usize {
        let na = self.grid.n_azimuth;
        if self.mirror && k > na / 2 { na - k } else { k }
    }
}

/// Weights of a normalised Gaussian of `sigma` samples at offsets `−r..=r`, r = ⌈4σ⌉.
fn gaussian_weights(sigma: f64) -> Vec<f64> {
    let r = (4.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-r..=r)
        .map(|d| (-0.5 * (d as f64 / sigma).powi(2)).exp())
        .collect();
    let total: f64 = k.iter().sum();
    k.iter().map(|x| x / total).collect()
}

/// `(offset, weight)` pairs of a normalised Gaussian of `sigma` samples on a circle of `n`
/// samples (wrapped; uniform when σ is infinite or NaN).
fn circular_kernel(sigma: f64, n: usize) -> Vec<(isize, f64)> {
    let g = |d: f64| (-0.5 * (d / sigma).powi(2)).exp();
    let mut w: Vec<(isize, f64)> = if !(sigma.is_finite()) || sigma > n as f64 {
        (0..n as isize).map(|d| (d, 1.0)).collect()
    } else {
        let r = (4.0 * sigma).ceil() as isize;
        if 2 * r < n as isize {
            return (-r..=r).zip(gaussian_weights(sigma)).collect();
        } else {
            // Wrapped: every offset once, with the weights of all its images.
            let n_f = n as f64;
            let images = (4.0 * sigma / n_f).ceil() as i64 + 1;
            (0..n as isize)
                .map(|d| {
                    let s: f64 = (-images..=images)
                        .map(|m| g(d as f64 + m as f64 * n_f))
                        .sum();
                    (d, s)
                })
                .collect()
        }
    };
    let total: f64 = w.iter().map(|p| p.1).sum();
    w.iter_mut().for_each(|p| p.1 /= total);
    w
}

/// `values` (`[polar][azimuth]` on `grid`) convolved with the Gaussian of `sigma_deg` of arc:
/// along the polar angle (reflected across both poles onto the opposite azimuth when the
/// azimuth count is even, onto the same azimuth otherwise), then along the azimuth with
/// σ/sin θ, wrapped.
pub fn disc_filter(values: &[f64], grid: DirectionGrid, sigma_deg: f64) -> Vec<f64> {
    disc_filter_symmetric(values, grid, sigma_deg, false)
}

/// [`disc_filter`]; with `mirror`, `values` must be mirror symmetric (the value at azimuth
/// column `k` equal to the one at `n_azimuth − k`, an even azimuth count), and both passes
/// compute the columns 0°–180° only, with the same sums in the same order as
/// [`disc_filter`] (bit for bit its values there), and copy their mirror images beyond, in
/// half the work. The result is exactly mirror symmetric; [`disc_filter`]'s own columns
/// beyond 180° can differ from their mirror images in the last bits (≈ 1e-9 near the poles).
pub fn disc_filter_symmetric(
    values: &[f64],
    grid: DirectionGrid,
    sigma_deg: f64,
    mirror: bool,
) -> Vec<f64> {
    let (np, na) = (grid.n_polar, grid.n_azimuth);
    let (dth, dph) = (
        grid.polar_step().to_degrees(),
        grid.azimuth_step().to_degrees(),
    );
    let s = sigma_deg / dth;
    let r = (4.0 * s).ceil() as isize;
    let kernel = gaussian_weights(s);
    let half = if na % 2 == 0 { na / 2 } else { 0 };
    let cols = if mirror && na % 2 == 0 {
        na / 2 + 1
    } else {
        na
    };
    let last = np as isize - 1;
    let mut polar = vec![0.0; np * na];
    polar.par_chunks_mut(na).enumerate().for_each(|(j, row)| {
        let out = &mut row[..cols];
        for (i, w) in kernel.iter().enumerate() {
            let jj = j as isize + i as isize - r;
            // Across a pole: the row mirrored about it, on the opposite azimuth.
            let (row, shift) = if jj < 0 {
                ((-jj).min(last), half)
            } else if jj > last {
                ((2 * last - jj).max(0), half)
            } else {
                (jj, 0)
            };
            // src[(k + shift) mod na] as two contiguous runs (one when shift = 0).
            let src = &values[row as usize * na..][..na];
            let split = (na - shift).min(cols);
            let (head, tail) = out.split_at_mut(split);
            for (o, s) in head.iter_mut().zip(&src[shift..]) {
                *o += w * s;
            }
            for (o, s) in tail.iter_mut().zip(src) {
                *o += w * s;
            }
        }
        for k in cols..na {
            row[k] = row[na - k];
        }
    });
    let mut out = vec![0.0; np * na];
    out.par_chunks_mut(na).enumerate().for_each(|(j, row)| {
        let sin = (dth * j as f64).to_radians().sin();
        let sigma = if sin > 1e-12 {
            sigma_deg / (sin * dph)
        } else {
            f64::INFINITY
        };
        // With `mirror`, the columns beyond 180° are the mirror images of the held ones.
        convolve_circular(
            &polar[j * na..][..na],
            &circular_kernel(sigma, na),
            &mut row[..cols],
        );
        for k in cols..na {
            row[k] = row[na - k];
        }
    });
    out
}

/// `out[k] = Σ w · src[(k + d) mod n]` over the kernel's `(d, w)` in its order (the same sum,
/// term by term, as indexing the circle per tap), through a copy of `src` padded by the
/// kernel's reach on both sides so that every tap is one contiguous, vectorisable pass; for
/// the first `out.len()` (at most `n`) positions `k`.
fn convolve_circular(src: &[f64], kernel: &[(isize, f64)], out: &mut [f64]) {
    let n = src.len() as isize;
    let lo = kernel.iter().map(|p| p.0).min().unwrap_or(0);
    let hi = kernel.iter().map(|p| p.0).max().unwrap_or(0);
    let padded: Vec<f64> = (lo..n + hi)
        .map(|i| src[i.rem_euclid(n) as usize])
        .collect();
    out.fill(0.0);
    for &(d, w) in kernel {
        let from = (d - lo) as usize;
        for (o, s) in out.iter_mut().zip(&padded[from..from + src.len()]) {
            *o += w * s;
        }
    }
}

/// Knots `0 = k_0 < … < k_m = n − 1` of `n` samples, each the furthest from its predecessor
/// (exponential, then binary search) for which `fits(a, b)` holds; adjacent samples always fit.
pub fn greedy_knots(n: usize, fits: impl Fn(usize, usize) -> bool) -> Vec<usize> {
    let mut knots = vec![0];
    let mut a = 0;
    while a + 1 < n {
        let (mut good, mut bad) = (a + 1, None);
        let mut step = 2;
        while bad.is_none() && good < n - 1 {
            let b = (a + step).min(n - 1);
            if fits(a, b) {
                good = b;
            } else {
                bad = Some(b);
            }
            step *= 2;
        }
        if let Some(mut hi) = bad {
            while hi - good > 1 {
                let mid = (good + hi) / 2;
                if fits(a, mid) {
                    good = mid;
                } else {
                    hi = mid;
                }
            }
        }
        knots.push(good);
        a = good;
    }
    knots
}

/// Over the samples between `a` and `b` of the series `at(i)` (i_perp, i_par), the error of
/// linear interpolation relative to the phase (the larger of i_perp's and i_par's): its
/// largest value, the sum of its squares and the number of samples.
fn segment_error(a: usize, b: usize, at: impl Fn(usize) -> (f64, f64)) -> [f64; 3] {
    let (pa, qa) = at(a);
    let (pb, qb) = at(b);
    let mut sums = [0.0f64; 3];
    for i in a + 1..b {
        let t = (i - a) as f64 / (b - a) as f64;
        let (p, q) = at(i);
        let phase = (0.5 * (p + q)).max(f64::MIN_POSITIVE);
        let d = ((1.0 - t) * pa + t * pb - p)
            .abs()
            .max(((1.0 - t) * qa + t * qb - q).abs());
        let rel = d / phase;
        sums = [sums[0].max(rel), sums[1] + rel * rel, sums[2] + 1.0];
    }
    sums
}

/// Whether the errors of a segment's lines meet `tol` in `norm`; for [`ErrorNorm::Rms`] within
/// each group of lines (`group(line)`: the indices of the windows a line belongs to).
fn fits<I>(lines: I, tol: f64, norm: ErrorNorm, group: impl Fn(usize) -> u8 + Sync) -> bool
where
    I: IndexedParallelIterator<Item = [f64; 3]>,
{
    const GROUPS: usize = ERROR_WINDOWS.len();
    match norm {
        ErrorNorm::Max => lines.all(|e| e[0] <= tol),
        ErrorNorm::Rms => {
            let sums = lines.enumerate().fold(
                || [[0.0; 2]; GROUPS],
                |mut acc, (i, e)| {
                    let g = group(i);
                    for (w, a) in acc.iter_mut().enumerate() {
                        if g & (1 << w) != 0 {
                            *a = [a[0] + e[1], a[1] + e[2]];
                        }
                    }
                    acc
                },
            );
            let total = sums.reduce(
                || [[0.0; 2]; GROUPS],
                |mut x, y| {
                    for (a, b) in x.iter_mut().zip(y) {
                        *a = [a[0] + b[0], a[1] + b[1]];
                    }
                    x
                },
            );
            total.iter().all(|[e2, n]| *e2 <= tol * tol * n)
        }
    }
}

/// The windows (bit w for [`ERROR_WINDOWS`]`[w]`) holding the polar angle `theta_deg`.
fn windows_of(theta_deg: f64) -> u8 {
    (ERROR_WINDOWS.iter().enumerate())
        .filter(|(_, w)| (w.1..=w.2).contains(&theta_deg))
        .fold(0, |g, (i, _)| g | (1 << i))
}

/// The azimuth knots of a filtered entry, from the first to the last column of the dense grid
/// (as in the dense table, the azimuth axis stops one step short of 360°; at 180° for a mirror
/// symmetric entry): every polar row checked, within `tol` in `norm` (for [`ErrorNorm::Rms`]
/// within each window of rows).
fn azimuth_knots(c: &Components, tol: f64, norm: ErrorNorm) -> Vec<usize> {
    let (np, na) = (c.grid.n_polar, c.grid.n_azimuth);
    let at = |j: usize, k: usize| (c.i_perp[j * na + k], c.i_par[j * na + k]);
    let dth = c.grid.polar_step().to_degrees();
    greedy_knots(c.stored_azimuths(), |a, b| {
        let lines = (0..np)
            .into_par_iter()
            .map(|j| segment_error(a, b, |k| at(j, k)));
        fits(lines, tol, norm, |j| windows_of(dth * j as f64))
    })
}

/// The polar knots of a filtered entry, first to last row, every column of `azimuth` checked.
fn polar_knots(c: &Components, azimuth: &[usize], tol: f64, norm: ErrorNorm) -> Vec<usize> {
    let na = c.grid.n_azimuth;
    let at = |j: usize, k: usize| (c.i_perp[j * na + k], c.i_par[j * na + k]);
    greedy_knots(c.grid.n_polar, |a, b| {
        let lines = (azimuth.par_iter()).map(|&k| segment_error(a, b, |j| at(j, k)));
        fits(lines, tol, norm, |_| 1)
    })
}

/// The error of interpolating linearly in azimuth only, between the `azimuth` knots on every
/// polar row of the dense grid, in `norm` ([`entry_error`] of its windows, every stored
/// direction counted).
fn azimuth_error(c: &Components, azimuth: &[usize], norm: ErrorNorm) -> f64 {
    let (na, n_stored) = (c.grid.n_azimuth, c.stored_azimuths());
    let errors = window_errors(c, |j| {
        let row = |k: usize| (c.i_perp[j * na + k], c.i_par[j * na + k]);
        let [max, sq] = (azimuth.windows(2)).fold([0.0f64; 2], |e, s| {
            let [max, sq, _] = segment_error(s[0], s[1], row);
            [e[0].max(max), e[1] + sq]
        });
        [max, sq, n_stored as f64]
    });
    entry_error(&errors, norm)
}

/// Per [`ERROR_WINDOWS`], from each polar row's relative errors `row(j)` = [largest, sum of
/// squares, count]: the largest, and the root mean square weighted by solid angle (sin θ of
/// the row).
fn window_errors(c: &Components, row: impl Fn(usize) -> [f64; 3] + Sync) -> Vec<WindowError> {
    let dth = c.grid.polar_step().to_degrees();
    let zero = || vec![[0.0; 3]; ERROR_WINDOWS.len()];
    let sums = (0..c.grid.n_polar)
        .into_par_iter()
        .fold(zero, |mut acc: Vec<Sums>, j| {
            let theta = dth * j as f64;
            let w = theta.to_radians().sin();
            let [max, sq, n] = row(j);
            for (a, &(_, lo, hi)) in acc.iter_mut().zip(&ERROR_WINDOWS) {
                if (lo..=hi).contains(&theta) {
                    *a = [a[0] + w * sq, a[1] + w * n, a[2].max(max)];
                }
            }
            acc
        })
        .reduce(zero, |mut a, b| {
            for (x, y) in a.iter_mut().zip(b) {
                *x = [x[0] + y[0], x[1] + y[1], x[2].max(y[2])];
            }
            a
        });
    sums.iter()
        .map(|s| WindowError {
            rms_relative: if s[1] > 0.0 {
                (s[0] / s[1]).sqrt()
            } else {
                0.0
            },
            max_relative: s[2],
        })
        .collect()
}

/// The error of phase, i_perp and i_par relative to the phase over one window: root mean
/// square (solid-angle weighted) and largest.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WindowError {
    pub rms_relative: f64,
    pub max_relative: f64,
}

/// One compact entry: knots (polar rows, azimuth positions of the dense grid), its values
/// `[polar knot][azimuth knot][phase, i_perp, i_par, dolp]` and its measured errors per
/// [`ERROR_WINDOWS`].
#[derive(Debug, Clone, PartialEq)]
pub struct CompactEntry {
    pub polar_rows: Vec<usize>,
    pub azimuth_positions: Vec<usize>,
    pub values: Vec<f32>,
    pub errors: Vec<WindowError>,
}

/// The channels at one knot from the filtered components, as the table stores them: i_perp
/// and i_par rounded to f32 (or, with 16-bit codes, to `mantissa_bits` and then to their codes:
/// NaN for a value no code holds, which the measured error then refuses), phase and dolp
/// derived from them as every reader derives them.
fn knot_values(p: f64, q: f64, spec: &SunDiscResampled) -> [f32; 4] {
    let (mut p32, mut q32) = (p as f32, q as f32);
    if spec.values == StoredValues::Top16 {
        let code = |v: f32| top16_round(round_mantissa(v, spec.mantissa_bits)).unwrap_or(f32::NAN);
        (p32, q32) = (code(p32), code(q32));
    }
    [
        DerivedOp::Mean.apply(p32, q32),
        p32,
        q32,
        DerivedOp::NormalizedDifference.apply(p32, q32),
    ]
}

/// `(segment, t)` of every dense sample of `samples` between consecutive `knots`.
fn segments(knots: &[usize], samples: impl Iterator<Item = usize>) -> Vec<(usize, f64)> {
    samples
        .map(|i| {
            let s = knots.partition_point(|&k| k <= i).clamp(1, knots.len() - 1) - 1;
            let t = (i - knots[s]) as f64 / (knots[s + 1] - knots[s]) as f64;
            (s, t)
        })
        .collect()
}

/// Sums of one window: weighted squared relative error, weights, largest relative error.
type Sums = [f64; 3];

/// The errors of the bilinear interpolant of `values` on the knots against the filtered
/// components, per [`ERROR_WINDOWS`] (solid-angle weights sin θ for the mean square). Every
/// dense direction counts; those beyond 180° of a mirror symmetric entry are looked up at
/// their mirror image, as every reader folds them, and equal it (the components are mirror
/// symmetric), so their errors are computed once.
fn measure(c: &Components, polar: &[usize], azimuth: &[usize], values: &[f32]) -> Vec<WindowError> {
    let (np, na) = (c.grid.n_polar, c.grid.n_azimuth);
    let nk = azimuth.len();
    let cols = segments(azimuth, 0..c.stored_azimuths());
    let rows = segments(polar, 0..np);
    window_errors(c, |j| {
        let (s, u) = rows[j];
        let v = |jk: usize, kk: usize, ch: usize| values[(jk * nk + kk) * 4 + ch] as f64;
        let relative: Vec<f64> = (cols.iter().enumerate())
            .map(|(k, &(m, t))| {
                let interp = |ch: usize| {
                    let lo = (1.0 - t) * v(s, m, ch) + t * v(s, m + 1, ch);
                    let hi = (1.0 - t) * v(s + 1, m, ch) + t * v(s + 1, m + 1, ch);
                    (1.0 - u) * lo + u * hi
                };
                let (p, q) = (c.i_perp[j * na + k], c.i_par[j * na + k]);
                let phase = 0.5 * (p + q);
                [interp(0) - phase, interp(1) - p, interp(2) - q]
                    .iter()
                    .map(|d| d.abs() / phase.max(f64::MIN_POSITIVE))
                    .fold(0.0, f64::max)
            })
            .collect();
        (0..na).fold([0.0, 0.0, na as f64], |e, k| {
            let rel = relative[c.folded(k)];
            [e[0].max(rel), e[1] + rel * rel, e[2]]
        })
    })
}

/// The compact form of one entry from its dense, disc-filtered components: azimuth knots
/// within a first share of the tolerance, polar knots within what the azimuth knots' measured
/// error leaves of it, the stored values and the measured errors.
///
/// The tolerance the knots share is the entry's less the rounding of the stored values
/// ([`SunDiscResampled::rounding_margin`] δ, 0 for f32; each share is then taken at 99 %):
/// for `max`, (T − δ)/(1 + δ), since (1 + fit)(1 + δ) − 1 ≤ T; for `rms`, √(T² − δ²/3), the
/// root mean square of a rounding spread evenly up to δ added in quadrature (it is uncorrelated
/// with the interpolation error). The azimuth knots take the first share: `max` √(1 + t) − 1, `rms`
/// t/2. Their error is then measured on the dense grid (a), and the polar knots take the rest:
/// `max` (1 + t)/(1 + a) − 1, `rms` √(t² − a²) (the two interpolation errors add in quadrature
/// where they are independent). Where every azimuth column stays a knot (a = 0, the Beard–Chuang
/// drops) the polar knots get the whole tolerance. The windows are measured with the stored values;
/// an entry over its tolerance is retried with both shares × 0.7.
pub fn compact_entry(c: &Components, spec: &SunDiscResampled) -> CompactEntry {
    let (norm, margin) = (spec.norm, spec.rounding_margin());
    let tol = match (spec.values, norm) {
        (StoredValues::F32, _) => spec.tolerance,
        (StoredValues::Top16, ErrorNorm::Max) => (spec.tolerance - margin) / (1.0 + margin),
        (StoredValues::Top16, ErrorNorm::Rms) => {
            (spec.tolerance.powi(2) - margin.powi(2) / 3.0).sqrt()
        }
    };
    let mut scale = 0.99;
    let mut tries = 0;
    loop {
        let first = match norm {
            ErrorNorm::Max => (1.0 + tol).sqrt() - 1.0,
            ErrorNorm::Rms => 0.5 * tol,
        };
        let azimuth = azimuth_knots(c, scale * first, norm);
        // Measured; kept below the whole so that the polar knots have a share (the windows
        // are measured below in any case).
        let a = azimuth_error(c, &azimuth, norm).min(0.9 * tol);
        let rest = match norm {
            ErrorNorm::Max => (1.0 + tol) / (1.0 + a) - 1.0,
            ErrorNorm::Rms => (tol * tol - a * a).sqrt(),
        };
        let polar = polar_knots(c, &azimuth, scale * rest, norm);
        let entry = entry_on_knots(c, (polar, azimuth), spec);
        tries += 1;
        if entry_error(&entry.errors, norm) <= spec.tolerance || tries == KNOT_TRIES {
            return entry;
        }
        scale *= 0.7;
    }
}

/// Knot choices [`compact_entry`] tries before it returns an entry over its tolerance.
const KNOT_TRIES: usize = 5;

/// The entry's values on the knots `(polar, azimuth)` and its errors.
fn entry_on_knots(
    c: &Components,
    (polar, azimuth): (Vec<usize>, Vec<usize>),
    spec: &SunDiscResampled,
) -> CompactEntry {
    let na = c.grid.n_azimuth;
    let mut values = Vec::with_capacity(polar.len() * azimuth.len() * 4);
    for &j in &polar {
        for &k in &azimuth {
            let i = j * na + k;
            values.extend(knot_values(c.i_perp[i], c.i_par[i], spec));
        }
    }
    let errors = measure(c, &polar, &azimuth, &values);
    CompactEntry {
        polar_rows: polar,
        azimuth_positions: azimuth,
        values,
        errors,
    }
}

/// The error of an entry in `norm`: the largest relative error over all directions (the
/// [`ERROR_WINDOWS`] entry `all`), or the largest root mean square of the windows.
pub fn entry_error(errors: &[WindowError], norm: ErrorNorm) -> f64 {
    match norm {
        ErrorNorm::Max => errors.last().map_or(f64::INFINITY, |e| e.max_relative),
        ErrorNorm::Rms => errors.iter().map(|e| e.rms_relative).fold(0.0, f64::max),
    }
}

/// Linear interpolation of the channels of one entry (values `[polar][azimuth][4]` on its
/// knots) at the dense sample `(j, k)`: phase, i_perp, i_par interpolated, dolp recomputed.
fn sample_entry(e: &CompactEntry, j: usize, k: usize) -> [f32; 4] {
    let locate = |knots: &[usize], i: usize| -> (usize, f64) {
        let s = knots.partition_point(|&x| x <= i).clamp(1, knots.len() - 1) - 1;
        (s, (i - knots[s]) as f64 / (knots[s + 1] - knots[s]) as f64)
    };
    let (s, u) = locate(&e.polar_rows, j);
    let (m, t) = locate(&e.azimuth_positions, k);
    let nk = e.azimuth_positions.len();
    let v = |jk: usize, kk: usize, ch: usize| e.values[(jk * nk + kk) * 4 + ch] as f64;
    let interp = |ch: usize| {
        let lo = (1.0 - t) * v(s, m, ch) + t * v(s, m + 1, ch);
        let hi = (1.0 - t) * v(s + 1, m, ch) + t * v(s + 1, m + 1, ch);
        (1.0 - u) * lo + u * hi
    };
    // At one of the entry's own knots the stored values, exactly.
    if e.polar_rows[s] == j && e.azimuth_positions[m] == k {
        let i = (s * nk + m) * 4;
        return [
            e.values[i],
            e.values[i + 1],
            e.values[i + 2],
            e.values[i + 3],
        ];
    }
    let (p, q) = (interp(1), interp(2));
    let dolp = if p + q > 0.0 { (p - q) / (p + q) } else { 0.0 };
    [interp(0) as f32, p as f32, q as f32, dolp as f32]
}

/// The entries on the union of their knots (polar rows, azimuth positions), each entry's
/// bilinear interpolant evaluated there (the same piecewise-bilinear function: its own knots
/// are among the union's), entries in order.
pub fn merge_entries(entries: &[CompactEntry]) -> (Vec<usize>, Vec<usize>, Vec<f32>) {
    let union = |f: fn(&CompactEntry) -> &Vec<usize>| {
        let mut all: Vec<usize> = entries.iter().flat_map(|e| f(e).iter().copied()).collect();
        all.sort_unstable();
        all.dedup();
        all
    };
    let polar = union(|e| &e.polar_rows);
    let azimuth = union(|e| &e.azimuth_positions);
    let mut data = Vec::with_capacity(entries.len() * polar.len() * azimuth.len() * 4);
    for e in entries {
        for &j in &polar {
            for &k in &azimuth {
                data.extend(sample_entry(e, j, k));
            }
        }
    }
    (polar, azimuth, data)
}

impl CompactEntry {
    /// The entry as scalars: counts, knots, values' count, errors (window by window: rms,
    /// max); the values travel as the chunk's values.
    pub fn scalars(&self) -> Vec<f64> {
        let mut s = vec![
            self.polar_rows.len() as f64,
            self.azimuth_positions.len() as f64,
        ];
        s.extend(self.polar_rows.iter().map(|&x| x as f64));
        s.extend(self.azimuth_positions.iter().map(|&x| x as f64));
        for e in &self.errors {
            s.extend([e.rms_relative, e.max_relative]);
        }
        s
    }

    /// The entry from [`Self::scalars`] and its values, and the scalars after it; `None` when
    /// they do not describe an entry on `grid` (its azimuth knots up to 180° when `mirror`).
    pub fn from_parts(
        scalars: &[f64],
        values: Vec<f32>,
        grid: DirectionGrid,
        mirror: bool,
    ) -> Option<(Self, &[f64])> {
        let count = |x: f64| (x >= 2.0 && x.fract() == 0.0 && x < 1e9).then_some(x as usize);
        let (np, na) = (count(*scalars.first()?)?, count(*scalars.get(1)?)?);
        let windows = ERROR_WINDOWS.len();
        let rest = scalars.get(2..)?;
        if rest.len() < np + na + 2 * windows || values.len() != np * na * 4 {
            return None;
        }
        let knots = |xs: &[f64], last: usize| -> Option<Vec<usize>> {
            let v: Vec<usize> = xs.iter().map(|&x| x as usize).collect();
            let ok = xs.iter().zip(&v).all(|(x, i)| *x == *i as f64)
                && v.first() == Some(&0)
                && v.last() == Some(&last)
                && v.windows(2).all(|w| w[0] < w[1]);
            ok.then_some(v)
        };
        let polar_rows = knots(&rest[..np], grid.n_polar - 1)?;
        let last_azimuth = stored_azimuths(grid.n_azimuth, mirror) - 1;
        let azimuth_positions = knots(&rest[np..np + na], last_azimuth)?;
        let errs = &rest[np + na..np + na + 2 * windows];
        let errors = errs
            .chunks(2)
            .map(|e| WindowError {
                rms_relative: e[0],
                max_relative: e[1],
            })
            .collect();
        let entry = CompactEntry {
            polar_rows,
            azimuth_positions,
            values,
            errors,
        };
        Some((entry, &rest[np + na + 2 * windows..]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(np: usize, na: usize) -> DirectionGrid {
        DirectionGrid {
            n_polar: np,
            n_azimuth: na,
        }
    }

    /// i_perp = `f(θ°, φ°)` at every direction of `g`, and i_par = `ratio` × i_perp.
    fn polarised(g: DirectionGrid, ratio: f64, f: impl Fn(f64, f64) -> f64) -> [Vec<f64>; 2] {
        let (dth, dph) = (180.0 / (g.n_polar - 1) as f64, 360.0 / g.n_azimuth as f64);
        let p: Vec<f64> = (0..g.n_polar * g.n_azimuth)
            .map(|i| {
                f(
                    dth * (i / g.n_azimuth) as f64,
                    dph * (i % g.n_azimuth) as f64,
                )
            })
            .collect();
        let q = p.iter().map(|x| ratio * x).collect();
        [p, q]
    }

    /// The compression with `tolerance` in `norm`, 0.5° sun, f32 values.
    fn spec(tolerance: f64, norm: ErrorNorm) -> SunDiscResampled {
        SunDiscResampled {
            tolerance,
            sun_diameter_deg: 0.5,
            norm,
            values: StoredValues::F32,
            mantissa_bits: TOP16_MANTISSA_BITS,
        }
    }

    /// The filter keeps a constant, keeps the mean of each row's azimuth profile (wrapped), and
    /// at the poles averages the whole row.
    #[test]
    fn disc_filter_keeps_constants_and_row_means() {
        let g = grid(181, 36);
        let c = vec![2.5; 181 * 36];
        for v in disc_filter(&c, g, 3.0) {
            assert!((v - 2.5).abs() < 1e-12);
        }
        let f: Vec<f64> = (0..181 * 36)
            .map(|i| 1.0 + 0.5 * ((i % 36) as f64 * 10f64.to_radians()).cos())
            .collect();
        let out = disc_filter(&f, g, 3.0);
        for j in [0, 90, 180] {
            let row = &out[j * 36..][..36];
            let mean: f64 = row.iter().sum::<f64>() / 36.0;
            assert!((mean - 1.0).abs() < 1e-12, "row {j}: {mean}");
        }
        // At the poles the row is flat (the disc covers every azimuth); at 90° barely damped.
        assert!(out[..36].iter().all(|v| (v - 1.0).abs() < 1e-9));
        assert!((out[90 * 36] - 1.5).abs() < 0.01, "{}", out[90 * 36]);
    }

    /// The padded convolution is the per-tap modular sum, bit for bit, for a narrow kernel,
    /// one wrapped around the circle and the uniform one.
    #[test]
    fn padded_circular_convolution_is_the_modular_sum() {
        let n = 37;
        let src: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 / 7.0).collect();
        for sigma in [0.7, 3.0, 12.0, f64::INFINITY] {
            let kernel = circular_kernel(sigma, n);
            let mut out = vec![f64::NAN; n];
            convolve_circular(&src, &kernel, &mut out);
            for (k, o) in out.iter().enumerate() {
                let direct: f64 = (kernel.iter())
                    .map(|&(d, w)| w * src[(k as isize + d).rem_euclid(n as isize) as usize])
                    .fold(0.0, |a, b| a + b);
                assert_eq!(o.to_bits(), direct.to_bits(), "sigma {sigma}, k {k}");
            }
        }
    }

    /// The filter as first written (a modulo per term in both passes), kept as the reference
    /// the contiguous passes must reproduce bit for bit.
    fn disc_filter_by_modulo(values: &[f64], grid: DirectionGrid, sigma_deg: f64) -> Vec<f64> {
        let (np, na) = (grid.n_polar, grid.n_azimuth);
        let (dth, dph) = (
            grid.polar_step().to_degrees(),
            grid.azimuth_step().to_degrees(),
        );
        let (s, half, last) = (
            sigma_deg / dth,
            if na % 2 == 0 { na / 2 } else { 0 },
            np as isize - 1,
        );
        let r = (4.0 * s).ceil() as isize;
        let mut polar = vec![0.0; np * na];
        for j in 0..np {
            for (i, w) in gaussian_weights(s).iter().enumerate() {
                let jj = j as isize + i as isize - r;
                let (row, shift) = match jj {
                    jj if jj < 0 => ((-jj).min(last), half),
                    jj if jj > last => ((2 * last - jj).max(0), half),
                    jj => (jj, 0),
                };
                for k in 0..na {
                    polar[j * na + k] += w * values[row as usize * na + (k + shift) % na];
                }
            }
        }
        (0..np * na)
            .map(|i| {
                let (j, k) = (i / na, i % na);
                let sin = (dth * j as f64).to_radians().sin();
                let sigma = if sin > 1e-12 {
                    sigma_deg / (sin * dph)
                } else {
                    f64::INFINITY
                };
                (circular_kernel(sigma, na).iter())
                    .map(|&(d, w)| {
                        w * polar[j * na + (k as isize + d).rem_euclid(na as isize) as usize]
                    })
                    .fold(0.0, |a, b| a + b)
            })
            .collect()
    }

    /// The passes over 0°–180° of a mirror-symmetric entry give the whole filter's result bit
    /// for bit on those columns, and the other columns are their exact mirror images (the
    /// whole filter sums a mirrored column's taps in another order and, near the poles, with
    /// another truncation of the wrapped kernel, so it differs slightly from its mirror image).
    #[test]
    fn mirror_symmetric_disc_filter_is_the_whole_filter_bit_for_bit() {
        let (np, na) = (91, 36);
        let g = grid(np, na);
        let mut rng = crate::math::rng::SplitMix64::new(7);
        let mut v = vec![0.0; np * na];
        for j in 0..np {
            for k in 0..=na / 2 {
                let x = rng.next_f64();
                v[j * na + k] = x;
                v[j * na + (na - k) % na] = x;
            }
        }
        for sigma in [3.0, 9.0] {
            let whole = disc_filter(&v, g, sigma);
            let half = disc_filter_symmetric(&v, g, sigma, true);
            for j in 0..np {
                for k in 0..na {
                    let held = if k <= na / 2 { k } else { na - k };
                    assert_eq!(
                        half[j * na + k].to_bits(),
                        whole[j * na + held].to_bits(),
                        "row {j}, column {k}, sigma {sigma}"
                    );
                }
            }
            let largest = (whole.iter().zip(&half))
                .map(|(a, b)| ((a - b) / a).abs())
                .fold(0.0, f64::max);
            // The whole filter's wrapped kernel near the poles keeps a different set of the
            // Gaussian's images for offsets d and n − d, so its mirrored columns differ from
            // the held ones by up to ≈ 1e-9 (relative) there.
            assert!(largest < 1e-8, "{largest}");
        }
    }

    #[test]
    fn contiguous_disc_filter_is_the_modulo_filter_bit_for_bit() {
        for (np, na) in [(61, 36), (61, 35)] {
            let g = grid(np, na);
            let v: Vec<f64> = (0..np * na)
                .map(|i| ((i * 7919) % 1013) as f64 / 17.0)
                .collect();
            let (fast, slow) = (disc_filter(&v, g, 9.0), disc_filter_by_modulo(&v, g, 9.0));
            for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "{np} x {na}, sample {i}");
            }
        }
    }

    /// Greedy knots of a piecewise-linear series are exactly its corners.
    #[test]
    fn greedy_knots_find_the_corners_of_a_polyline() {
        let f = |i: usize| {
            if i <= 40 {
                i as f64
            } else {
                40.0 + 3.0 * (i - 40) as f64
            }
        };
        let fits = |a: usize, b: usize| {
            (a + 1..b).all(|i| {
                let t = (i - a) as f64 / (b - a) as f64;
                ((1.0 - t) * f(a) + t * f(b) - f(i)).abs() < 1e-9
            })
        };
        assert_eq!(greedy_knots(101, fits), vec![0, 40, 100]);
        assert_eq!(greedy_knots(2, |_, _| false), vec![0, 1]);
    }

    /// A smooth entry compacts to few knots within its tolerance; the merged grid reproduces
    /// every entry at its own knots; the scalars round-trip.
    #[test]
    fn compact_entries_meet_their_tolerance_and_merge() {
        let g = grid(1801, 72);
        let (np, na) = (g.n_polar, g.n_azimuth);
        let mut entries = vec![];
        for shift in [0.0, 1.5] {
            let [p, q] = polarised(g, 0.3, |th, ph| {
                1.0 + (-((th - 138.0 - shift - 0.1 * ph.to_radians().cos()) / 0.5).powi(2)).exp()
            });
            let c = Components {
                grid: g,
                i_perp: &p,
                i_par: &q,
                mirror: false,
            };
            let spec = spec(0.01, ErrorNorm::Max);
            let e = compact_entry(&c, &spec);
            assert!(
                entry_error(&e.errors, ErrorNorm::Max) <= 0.01,
                "{:?}",
                e.errors
            );
            assert!(entry_error(&e.errors, ErrorNorm::Max) > 0.0);
            let rms = compact_entry(
                &c,
                &SunDiscResampled {
                    norm: ErrorNorm::Rms,
                    ..spec
                },
            );
            assert!(
                entry_error(&rms.errors, ErrorNorm::Rms) <= 0.01,
                "{:?}",
                rms.errors
            );
            assert!(rms.polar_rows.len() <= e.polar_rows.len());
            assert!(e.polar_rows.len() < np / 4, "{} rows", e.polar_rows.len());
            assert!(
                e.azimuth_positions.len() < na,
                "{}",
                e.azimuth_positions.len()
            );
            let s = e.scalars();
            let (back, rest) = CompactEntry::from_parts(&s, e.values.clone(), g, false).unwrap();
            assert_eq!(back, e);
            assert!(rest.is_empty());
            entries.push(e);
        }
        let (polar, azimuth, data) = merge_entries(&entries);
        let nk = azimuth.len();
        for (n, e) in entries.iter().enumerate() {
            for (s, &j) in e.polar_rows.iter().enumerate() {
                let a = polar.binary_search(&j).unwrap();
                for (m, &k) in e.azimuth_positions.iter().enumerate() {
                    let b = azimuth.binary_search(&k).unwrap();
                    let at = ((n * polar.len() + a) * nk + b) * 4;
                    let own = (s * e.azimuth_positions.len() + m) * 4;
                    assert_eq!(data[at..at + 4], e.values[own..own + 4]);
                }
            }
        }
    }

    /// The manifest forms: "none", a table with kind and tolerance; others are refused with
    /// the forms named.
    #[test]
    fn compression_values_parse_or_say_what_is_expected() {
        let none = Compression::from_value(serde_json::json!("none")).unwrap();
        assert!(none.is_none());
        let c = Compression::from_value(
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02}),
        )
        .unwrap();
        assert_eq!(
            c,
            Compression::SunDiscResampled(SunDiscResampled {
                tolerance: 0.02,
                sun_diameter_deg: 0.5,
                norm: ErrorNorm::Max,
                values: StoredValues::F32,
                mantissa_bits: TOP16_MANTISSA_BITS,
            })
        );
        // f32 is the default and is left out of the serialised form (the content key).
        assert!(serde_json::to_value(c).unwrap().get("values").is_none());
        let top16 =
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "values": "top16"});
        let c = Compression::from_value(top16).unwrap();
        assert_eq!(serde_json::to_value(c).unwrap()["values"], "top16");
        assert!(
            serde_json::to_value(c)
                .unwrap()
                .get("mantissa_bits")
                .is_none()
        );
        let seven = serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "values": "top16", "mantissa_bits": 7});
        let c = Compression::from_value(seven).unwrap();
        assert_eq!(serde_json::to_value(c).unwrap()["mantissa_bits"], 7);
        for bad in [
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.003, "values": "top16"}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "values": "f16"}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "values": "top16", "mantissa_bits": 9}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "values": "top16", "mantissa_bits": 0}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.02, "mantissa_bits": 7}),
            serde_json::json!("zip"),
            serde_json::json!({"kind": "zip", "tolerance": 0.02}),
            serde_json::json!({"tolerance": 0.02}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.0}),
            serde_json::json!({"kind": "sun-disc-resampled", "tolerance": 0.01, "x": 1}),
        ] {
            let e = Compression::from_value(bad.clone()).unwrap_err();
            assert!(
                e.contains("sun-disc-resampled")
                    || e.contains("tolerance")
                    || e.contains("mantissa_bits"),
                "{bad}: {e}"
            );
        }
    }

    /// An entry smooth in azimuth keeps few azimuth knots with (almost) no error, so its polar
    /// knots get (almost) the whole tolerance: the measured window error exceeds the half a
    /// fixed split between the dimensions would allow, and stays within the tolerance.
    #[test]
    fn polar_knots_take_what_the_azimuth_knots_leave() {
        let g = grid(3601, 36);
        let [p, q] = polarised(g, 0.4, |th, _| {
            1.0 + 0.5 * (th / 3.0).sin() + (-((th - 138.0) / 0.7).powi(2)).exp()
        });
        let c = Components {
            grid: g,
            i_perp: &p,
            i_par: &q,
            mirror: false,
        };
        let na = g.n_azimuth;
        for values in [StoredValues::F32, StoredValues::Top16] {
            let spec = SunDiscResampled {
                values,
                ..spec(0.01, ErrorNorm::Rms)
            };
            let e = compact_entry(&c, &spec);
            let err = entry_error(&e.errors, ErrorNorm::Rms);
            assert_eq!(e.azimuth_positions, vec![0, na - 1], "{values:?}");
            assert!(err <= 0.01 && err > 0.006, "{values:?}: {:?}", e.errors);
        }
    }

    /// With fewer mantissa bits the stored codes have their low bits zero, the values are the
    /// rounded ones, and the entry still meets its tolerance (with a larger rounding margin).
    #[test]
    fn fewer_mantissa_bits_store_coarser_codes_within_the_tolerance() {
        use crate::table::codec::top16_code;
        let g = grid(1801, 8);
        let [p, q] = polarised(g, 0.7, |th, _| 2.0 + (th / 7.0).cos());
        let c = Components {
            grid: g,
            i_perp: &p,
            i_par: &q,
            mirror: false,
        };
        let spec = SunDiscResampled {
            values: StoredValues::Top16,
            mantissa_bits: 6,
            ..spec(0.015, ErrorNorm::Rms)
        };
        assert_eq!(spec.rounding_margin(), 1.0 / 64.0);
        assert!(spec.check().is_err(), "2^-6 exceeds the tolerance 0.015");
        let spec = SunDiscResampled {
            tolerance: 0.03,
            ..spec
        };
        spec.check().unwrap();
        let e = compact_entry(&c, &spec);
        assert!(
            entry_error(&e.errors, ErrorNorm::Rms) <= 0.03,
            "{:?}",
            e.errors
        );
        for v in e.values.chunks(4) {
            for x in [v[1], v[2]] {
                assert_eq!(top16_code(x).unwrap() % 4, 0, "{x}: 6 of 8 mantissa bits");
            }
        }
    }

    /// A mirror symmetric entry keeps knots up to 180° only; its errors are measured at every
    /// dense direction, those beyond 180° looked up at their mirror image (recomputed here
    /// through the lookup of merged tables); its scalars round-trip with `mirror` only.
    #[test]
    fn mirror_symmetric_entries_store_half_the_circle() {
        let g = grid(1801, 72);
        let (np, na) = (g.n_polar, g.n_azimuth);
        let [p, q] = polarised(g, 0.3, |th, ph| {
            let ph = ph.to_radians();
            1.5 + ph.cos() + 0.3 * (2.0 * ph).cos() + (-((th - 138.0) / 0.5).powi(2)).exp()
        });
        let spec = spec(0.01, ErrorNorm::Max);
        let half = Components {
            grid: g,
            i_perp: &p,
            i_par: &q,
            mirror: true,
        };
        let e = compact_entry(&half, &spec);
        assert_eq!(e.azimuth_positions.last(), Some(&(na / 2)));
        let err = entry_error(&e.errors, ErrorNorm::Max);
        assert!(err > 0.0 && err <= 0.01, "{:?}", e.errors);
        // Recomputed through the lookup of merged tables at every dense direction, folded.
        let mut worst = 0.0f64;
        for j in 0..np {
            for k in 0..na {
                let v = sample_entry(&e, j, half.folded(k));
                let (pp, qq) = (p[j * na + k], q[j * na + k]);
                let phase = 0.5 * (pp + qq);
                for (got, want) in v[..3].iter().zip([phase, pp, qq]) {
                    worst = worst.max((*got as f64 - want).abs() / phase);
                }
            }
        }
        let stated = e.errors.last().unwrap().max_relative;
        assert!((worst - stated).abs() <= 1e-6, "{worst} {stated}");
        let (back, _) = CompactEntry::from_parts(&e.scalars(), e.values.clone(), g, true).unwrap();
        assert_eq!(back, e);
        assert!(CompactEntry::from_parts(&e.scalars(), e.values.clone(), g, false).is_none());
    }
}
