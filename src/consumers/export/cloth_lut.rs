//! Engine LUT of a cloth BRDF table (`cloth-brdf/2`, stage `cloth`): DDS textures a shader
//! samples with hardware filtering to get the table's BRDF, its directional albedo and its
//! average. Layout, shader lookup and measured errors: `docs/cloth.md` §7; decision CLOTH-21 in
//! `docs/decisions.md`.
//!
//! The texels sit at the table's own nodes, so hardware filtering reproduces the table's
//! multilinear interpolation; the non-uniform axes (θ_i, β_x, β_y) map to texel coordinates
//! exactly through a small warp texture of uniform bins. Files, for `--out X.dds`:
//!
//! - `X.dds`: 3-D texture `N_x × N_y × (N_θ·N_φ)`: texel `(a, b, s·N_φ + p)` holds
//!   `K = f cos θ_i` (RGB, 1/sr) at β_x node `a`, β_y node `b`, θ_i node `s`, φ_i node `p`
//!   (alpha 1 in the half and float formats). The θ_i nodes are slabs of `N_φ` layers: a
//!   lookup clamps its φ_i coordinate inside the slab, fetches the two slabs around θ_i
//!   (trilinear in β_x, β_y, φ_i) and blends them.
//! - `X-warp.dds`: RGBA32F, `M × 3`: row 0 θ_i, row 1 β_x, row 2 β_y (degrees), each `M`
//!   uniform bins over `[first node, last node]`, no wider than the narrowest node spacing; bin
//!   `k` holds `(i, x_i, x_{i+1}, x_{i+2})`, `i` the last node at or before the bin's start. A
//!   shader fetches the bin of `x` (no filtering) and gets the continuous node index `j`
//!   (`i + (x − x_i)/(x_{i+1} − x_i)` or the same one node on), exactly.
//! - `X-albedo.dds`: RGBA32F, `N_φ × N_θ`: the directional albedo `E(θ_i, φ_i)` of the stored K
//!   (RGB) and its luminance, at the table's nodes.
//! - `X.json`: sizes, axes, symmetry, constants of the lookup, `E_avg` and the measured errors.
//!
//! Every axis is cell-centred: texel `i` of `n` sits at `(i + 0.5)/n`.

use super::dds::{DdsError, DdsImage, DxgiFormat, RGB9E5_MAX, dds_encode, rgb9e5, rgb9e5_decode};
use crate::cloth::tabulate::{
    CHANNELS, HalfGrid, albedo_summary, check_point, interpolation_error, lookup_f, luminance,
};
use crate::cloth::{ClothModel, ModelOptions, Symmetry, direction, preset};
use crate::table::Table;
use crate::table::interp::locate;
use std::path::{Path, PathBuf};

/// Rows of the warp texture: θ_i, β_x, β_y.
pub const WARP_ROWS: usize = 3;
/// Largest side of a 3-D texture (Direct3D 11 `D3D11_REQ_TEXTURE3D_U_V_OR_W_DIMENSION`).
pub const MAX_VOLUME_SIDE: usize = 2048;
/// Largest value of `DXGI_FORMAT_R16G16B16A16_FLOAT`.
const HALF_MAX: f64 = 65504.0;

/// Errors of the cloth LUT export.
#[derive(Debug, thiserror::Error)]
pub enum ClothLutError {
    #[error(
        "not a cloth BRDF table: schema `{0}` (the cloth LUT is made from `cloth-brdf/2` tables \
         of stage `cloth`)"
    )]
    NotCloth(String),
    #[error("not the cloth-brdf/2 layout: {0}")]
    Layout(String),
    #[error("the 3-D texture would be {0:?} texels; each side must be at most 2048")]
    TooLarge([usize; 3]),
    #[error(
        "axis `{axis}` has nodes {spacing_deg:e}° apart: its warp row would need {bins} bins, \
         more than the {MAX_WARP_BINS} a 2-D texture row may hold"
    )]
    WarpTooFine {
        axis: &'static str,
        spacing_deg: f64,
        bins: f64,
    },
    #[error("K reaches {max} 1/sr, beyond the {format} range ({limit}); use precision float")]
    Overflow {
        max: f64,
        format: &'static str,
        limit: f64,
    },
    #[error("output {path}: {why}")]
    BadOutput { path: String, why: &'static str },
    #[error(transparent)]
    Dds(#[from] DdsError),
    #[error("the table's fabric: {0}")]
    Fabric(String),
    #[error("writing {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
}

/// Storage of the BRDF texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LutPrecision {
    /// `DXGI_FORMAT_R9G9B9E5_SHAREDEXP`, 4 bytes per texel.
    Rgb9e5,
    /// `DXGI_FORMAT_R16G16B16A16_FLOAT`, 8 bytes per texel.
    Half,
    /// `DXGI_FORMAT_R32G32B32A32_FLOAT`, 16 bytes per texel.
    Float,
}

impl LutPrecision {
    /// The DXGI format written.
    pub fn format(self) -> DxgiFormat {
        match self {
            LutPrecision::Rgb9e5 => DxgiFormat::R9G9B9E5SharedExp,
            LutPrecision::Half => DxgiFormat::R16G16B16A16Float,
            LutPrecision::Float => DxgiFormat::R32G32B32A32Float,
        }
    }

    /// `(texels, bytes)` of `rgb` as stored and as the GPU reads it back.
    fn encode(self, rgb: [f64; 3]) -> (Vec<u8>, [f32; 3]) {
        match self {
            LutPrecision::Rgb9e5 => {
                let w = rgb9e5(rgb);
                (w.to_le_bytes().to_vec(), rgb9e5_decode(w).map(|v| v as f32))
            }
            LutPrecision::Half => {
                let h = rgb.map(half::f16::from_f64);
                let mut b: Vec<u8> = h.iter().flat_map(|x| x.to_le_bytes()).collect();
                b.extend_from_slice(&half::f16::ONE.to_le_bytes());
                (b, h.map(f32::from))
            }
            LutPrecision::Float => {
                let f = rgb.map(|v| v as f32);
                let mut b: Vec<u8> = f.iter().flat_map(|x| x.to_le_bytes()).collect();
                b.extend_from_slice(&1f32.to_le_bytes());
                (b, f)
            }
        }
    }

    /// Largest value stored.
    fn limit(self) -> f64 {
        match self {
            LutPrecision::Rgb9e5 => RGB9E5_MAX,
            LutPrecision::Half => HALF_MAX,
            LutPrecision::Float => f64::from(f32::MAX),
        }
    }
}

/// A `cloth-brdf/2` table, checked, with its grid, symmetry and albedo.
pub struct ClothTableView<'a> {
    data: &'a [f32],
    /// The table's axes.
    pub grid: HalfGrid,
    /// The fabric's mirrors (header `symmetry`).
    pub symmetry: Symmetry,
    /// Step of the φ_i nodes, degrees.
    pub phi_i_step_deg: f64,
    /// Directional albedo of the stored K (the model as printed times the energy scale),
    /// `[θ_i][φ_i]`, RGB.
    pub albedo_rgb: Vec<Vec<[f64; 3]>>,
    /// Factor the table applied per (θ_i, φ_i) (header `energy_scale`).
    pub energy_scale: Vec<Vec<f64>>,
    /// Fabric preset (header `fabric`).
    pub fabric: String,
    /// Tangent quadrature step the table was built with (provenance; 1° when absent).
    pub ramp_step_deg: f64,
    /// The header's `interpolation_error_l2_relative` and `_max_over_peak`.
    pub header_error: (f64, f64),
}

fn layout(why: impl Into<String>) -> ClothLutError {
    ClothLutError::Layout(why.into())
}

/// A header attribute parsed as `T`.
fn attribute<T: serde::de::DeserializeOwned>(t: &Table, key: &str) -> Result<T, ClothLutError> {
    let v = t.header.attributes.get(key).cloned();
    v.and_then(|v| serde_json::from_value(v).ok())
        .ok_or_else(|| layout(format!("header attribute `{key}` missing or malformed")))
}

/// An axis of at least two increasing nodes strictly inside `open` (degrees).
fn check_axis(name: &str, nodes: &[f64], open: (f64, f64)) -> Result<(), ClothLutError> {
    let inside = nodes.iter().all(|x| *x > open.0 && *x < open.1);
    if nodes.len() < 2 || !inside || nodes.windows(2).any(|w| w[1] <= w[0]) {
        return Err(layout(format!(
            "axis {name} must have two or more increasing nodes inside ({}, {})°",
            open.0, open.1
        )));
    }
    Ok(())
}

impl<'a> ClothTableView<'a> {
    /// Check `t` and read what the LUT needs.
    pub fn new(t: &'a Table) -> Result<Self, ClothLutError> {
        let h = &t.header;
        if h.schema.name != "cloth-brdf" || h.schema.version != 2 {
            return Err(ClothLutError::NotCloth(h.schema.to_string()));
        }
        let names: Vec<&str> = h.axes.iter().map(|a| a.name.as_str()).collect();
        if names != ["theta_i", "phi_i", "half_x", "half_y"]
            || h.axes.iter().any(|a| a.unit != "deg")
        {
            return Err(layout(format!("axes {} (deg expected)", names.join(" × "))));
        }
        let channels: Vec<&str> = h.channels.iter().map(|c| c.name.as_str()).collect();
        if channels != CHANNELS {
            return Err(layout(format!("channels {}", channels.join(", "))));
        }
        let c = |k: usize| h.axes[k].coords();
        let grid = HalfGrid {
            theta_i_deg: c(0),
            phi_i_deg: c(1),
            half_x_deg: c(2),
            half_y_deg: c(3),
        };
        if t.data.len() != grid.theta_i_deg.len() * grid.row_len() {
            return Err(layout("data length"));
        }
        check_axis("theta_i", &grid.theta_i_deg, (0.0, 90.0))?;
        check_axis("half_x", &grid.half_x_deg, (-90.0, 90.0))?;
        check_axis("half_y", &grid.half_y_deg, (-90.0, 90.0))?;
        let sym: serde_json::Value = attribute(t, "symmetry")?;
        let flag = |k: &str| {
            sym[k]
                .as_bool()
                .ok_or_else(|| layout(format!("symmetry.{k}")))
        };
        let symmetry = Symmetry {
            mirror_x: flag("mirror_x")?,
            mirror_y: flag("mirror_y")?,
            swap_xy: flag("swap_xy")?,
        };
        let phi = &grid.phi_i_deg;
        let (lo, hi) = symmetry.phi_i_domain_deg();
        let step = if phi.len() > 1 { phi[1] - phi[0] } else { 0.0 };
        if phi.len() < 2 || (phi[0] - lo).abs() > 1e-9 || (phi[phi.len() - 1] - hi).abs() > 1e-9 {
            return Err(layout(format!(
                "phi_i nodes must span the domain [{lo}, {hi}]°"
            )));
        }
        let albedo: Vec<Vec<[f64; 3]>> = attribute(t, "albedo_rgb_as_printed")?;
        let energy_scale: Vec<Vec<f64>> = attribute(t, "energy_scale")?;
        let shape_ok = |n: usize| n == grid.theta_i_deg.len();
        if !shape_ok(albedo.len()) || !shape_ok(energy_scale.len()) {
            return Err(layout("albedo_rgb_as_printed / energy_scale per θ_i"));
        }
        let albedo_rgb = (albedo.iter().zip(&energy_scale))
            .map(|(a, s)| (a.iter().zip(s)).map(|(e, s)| e.map(|v| v * s)).collect())
            .collect::<Vec<Vec<_>>>();
        if albedo_rgb
            .iter()
            .any(|r: &Vec<[f64; 3]>| r.len() != phi.len())
        {
            return Err(layout("albedo_rgb_as_printed / energy_scale per φ_i"));
        }
        let ramp = h.provenance.parameters.get("ramp_step_deg");
        Ok(ClothTableView {
            data: &t.data,
            phi_i_step_deg: step,
            symmetry,
            albedo_rgb,
            energy_scale,
            fabric: attribute(t, "fabric")?,
            ramp_step_deg: ramp.and_then(|v| v.as_f64()).unwrap_or(1.0),
            header_error: (
                attribute(t, "interpolation_error_l2_relative")?,
                attribute(t, "interpolation_error_max_over_peak")?,
            ),
            grid,
        })
    }

    /// The table's f (RGB, 1/sr) at cloth-frame angles `q = (θ_i, φ_i, θ_r, φ_r)` (degrees, any
    /// azimuths): the header's mirrors, then [`lookup_f`].
    pub fn brdf_deg(&self, q: [f64; 4]) -> [f64; 3] {
        let (pi, pr) = self.symmetry.reduce_deg(q[1], q[3]);
        lookup_f(&self.grid, self.data, [q[0], pi, q[2], pr])
    }

    /// K (RGB) at node `(s, p, a, b)` of (θ_i, φ_i, β_x, β_y).
    fn k_node(&self, s: usize, p: usize, a: usize, b: usize) -> [f64; 3] {
        let g = &self.grid;
        let (n_p, n_x, n_y) = (g.phi_i_deg.len(), g.half_x_deg.len(), g.half_y_deg.len());
        let o = (((s * n_p + p) * n_x + a) * n_y + b) * CHANNELS.len();
        [0, 1, 2].map(|c| f64::from(self.data[o + c]))
    }
}

/// The textures of one table, encoded, and the values the GPU reads from them.
#[derive(Debug, Clone, PartialEq)]
pub struct ClothLut {
    pub precision: LutPrecision,
    /// Warp bins per row, `M`.
    pub warp_bins: usize,
    /// BRDF texture size `[N_x, N_y, N_θ·N_φ]`.
    pub size: [usize; 3],
    pub n_theta_i: usize,
    pub n_phi_i: usize,
    /// First φ_i node and the step, degrees.
    pub phi_i_lo_deg: f64,
    pub phi_i_step_deg: f64,
    pub symmetry: Symmetry,
    /// `[first node, last node]` (degrees) of the warp rows θ_i, β_x, β_y.
    pub warp_range_deg: [[f64; 2]; WARP_ROWS],
    /// Decoded BRDF texels (K RGB), x fastest, then y, then z.
    pub k: Vec<[f32; 3]>,
    /// Warp rows, `M` bins `(i, x_i, x_{i+1}, x_{i+2})` each.
    pub warp: Vec<[f32; 4]>,
    /// `E` RGB and its luminance, φ_i fastest, then θ_i.
    pub albedo: Vec<[f32; 4]>,
    /// Cosine-weighted hemispherical average of `E`, RGB.
    pub albedo_average_rgb: [f64; 3],
    /// The files: BRDF, warp, albedo.
    pub images: [DdsImage; 3],
}

/// Warp bins per row for node spacings down to `min_spacing` over `width`: a power of two, at
/// least 64, with bins no wider than the narrowest node spacing (so that a bin holds at most one
/// node).
fn warp_bins(width: f64, min_spacing: f64) -> usize {
    ((width / min_spacing).ceil() as usize)
        .max(64)
        .next_power_of_two()
}

/// Largest warp row: the width limit of a 2-D texture in Direct3D 11 and most GL drivers.
const MAX_WARP_BINS: usize = 16384;

/// The warp texture: per row (θ_i, β_x, β_y), `m` uniform bins over the axis's end nodes; bin
/// `k` holds `(i, x_i, x_{i+1}, x_{i+2})` with `i` the last node at or before the bin's start
/// (`x_{i+2} = x_{i+1} + 1` past the end).
type WarpRows = (usize, [[f64; 2]; WARP_ROWS], Vec<[f32; 4]>);

fn warp_rows(grid: &HalfGrid) -> Result<WarpRows, ClothLutError> {
    let axes = [&grid.theta_i_deg, &grid.half_x_deg, &grid.half_y_deg];
    let range = axes.map(|a| [a[0], a[a.len() - 1]]);
    let min_spacing = |a: &[f64]| a.windows(2).map(|w| w[1] - w[0]).fold(f64::MAX, f64::min);
    for (r, axis) in ["theta_i", "half_x", "half_y"].into_iter().enumerate() {
        let spacing_deg = min_spacing(axes[r]);
        let bins = (range[r][1] - range[r][0]) / spacing_deg;
        if bins.is_nan() || bins > MAX_WARP_BINS as f64 {
            return Err(ClothLutError::WarpTooFine {
                axis,
                spacing_deg,
                bins,
            });
        }
    }
    let m = (0..WARP_ROWS)
        .map(|r| warp_bins(range[r][1] - range[r][0], min_spacing(axes[r])))
        .max()
        .unwrap_or(64);
    let mut warp = Vec::with_capacity(WARP_ROWS * m);
    for (axis, [lo, hi]) in axes.iter().zip(range) {
        let n = axis.len();
        for k in 0..m {
            let start = lo + k as f64 * (hi - lo) / m as f64;
            let i = (axis.partition_point(|&x| x <= start).max(1) - 1).min(n - 2);
            let after = if i + 2 < n {
                axis[i + 2]
            } else {
                axis[n - 1] + 1.0
            };
            warp.push([i as f64, axis[i], axis[i + 1], after].map(|v| v as f32));
        }
    }
    Ok((m, range, warp))
}

/// The BRDF texels of `view` in `precision`: file bytes and the decoded values.
fn brdf_texels(
    view: &ClothTableView,
    size: [usize; 3],
    precision: LutPrecision,
) -> Result<(Vec<u8>, Vec<[f32; 3]>), ClothLutError> {
    let n_phi = view.grid.phi_i_deg.len();
    let mut bytes = Vec::with_capacity(size.iter().product::<usize>() * 16);
    let mut k = Vec::with_capacity(size.iter().product());
    let mut max = 0.0f64;
    for z in 0..size[2] {
        for b in 0..size[1] {
            for a in 0..size[0] {
                let v = view.k_node(z / n_phi, z % n_phi, a, b);
                if v.iter().any(|k| !k.is_finite() || *k < 0.0) {
                    return Err(layout(format!("K = {v:?} (negative or not finite)")));
                }
                max = v.iter().cloned().fold(max, f64::max);
                let (raw, back) = precision.encode(v);
                bytes.extend_from_slice(&raw);
                k.push(back);
            }
        }
    }
    if max > precision.limit() {
        return Err(ClothLutError::Overflow {
            max,
            format: precision.format().name(),
            limit: precision.limit(),
        });
    }
    Ok((bytes, k))
}

/// The LUT of `view` with the BRDF texture in `precision`.
pub fn build_lut(
    view: &ClothTableView,
    precision: LutPrecision,
) -> Result<ClothLut, ClothLutError> {
    let g = &view.grid;
    let (n_theta_i, n_phi_i) = (g.theta_i_deg.len(), g.phi_i_deg.len());
    let size = [g.half_x_deg.len(), g.half_y_deg.len(), n_theta_i * n_phi_i];
    if size.iter().any(|&n| n > MAX_VOLUME_SIDE) {
        return Err(ClothLutError::TooLarge(size));
    }
    let (bytes, k) = brdf_texels(view, size, precision)?;
    let (warp_bins, warp_range_deg, warp) = warp_rows(g)?;
    let albedo: Vec<[f32; 4]> = (view.albedo_rgb.iter().flatten())
        .map(|e| [e[0], e[1], e[2], luminance(*e)].map(|v| v as f32))
        .collect();
    let image = |size, format, data| DdsImage { size, format, data };
    let f32_bytes = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let images = [
        image(size, precision.format(), bytes),
        image(
            [warp_bins, WARP_ROWS, 1],
            DxgiFormat::R32G32B32A32Float,
            f32_bytes(&warp.concat()),
        ),
        image(
            [n_phi_i, n_theta_i, 1],
            DxgiFormat::R32G32B32A32Float,
            f32_bytes(&albedo.concat()),
        ),
    ];
    Ok(ClothLut {
        precision,
        warp_bins,
        size,
        n_theta_i,
        n_phi_i,
        phi_i_lo_deg: g.phi_i_deg[0],
        phi_i_step_deg: view.phi_i_step_deg,
        symmetry: view.symmetry,
        warp_range_deg,
        k,
        warp,
        albedo,
        albedo_average_rgb: albedo_summary(g, &view.albedo_rgb).average,
        images,
    })
}

/// `(i, t)` of a clamped linear filter at continuous texel index `x` on `n` texels, the weight
/// rounded to `bits` fractional bits when given (hardware filtering).
fn filter(x: f64, n: usize, bits: Option<u32>) -> (usize, f64) {
    let x = x.clamp(0.0, (n - 1) as f64);
    let i = (x.floor() as usize).min(n.saturating_sub(2));
    let t = x - i as f64;
    let t = bits.map_or(t, |b| {
        (t * f64::from(1u32 << b)).round() / f64::from(1u32 << b)
    });
    (i, t)
}

/// Directions mapped by the fabric's mirrors so that the light's azimuth lies in the stored
/// φ_i domain (the vector form of [`Symmetry::reduce_deg`]).
pub fn reduce_directions(s: Symmetry, wi: [f64; 3], wo: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let (mut wi, mut wo) = (wi, wo);
    if s.mirror_y && wi[1] < 0.0 {
        (wi[1], wo[1]) = (-wi[1], -wo[1]);
    }
    if s.mirror_x && wi[0] < 0.0 {
        (wi[0], wo[0]) = (-wi[0], -wo[0]);
    }
    if s.swap_xy && s.mirror_y && wi[1] > wi[0] {
        wi.swap(0, 1);
        wo.swap(0, 1);
    }
    (wi, wo)
}

impl ClothLut {
    /// Warp row `r` at `x` (degrees): the continuous node index (clamped to the end nodes).
    fn warp_at(&self, r: usize, x: f64) -> f64 {
        let [lo, hi] = self.warp_range_deg[r];
        let m = self.warp_bins;
        let x = x.clamp(lo, hi);
        let bin = (((x - lo) / (hi - lo) * m as f64) as usize).min(m - 1);
        let w = self.warp[r * m + bin].map(f64::from);
        if x < w[2] {
            w[0] + (x - w[1]) / (w[2] - w[1])
        } else {
            w[0] + 1.0 + (x - w[2]) / (w[3] - w[2])
        }
    }

    /// Trilinear fetch of K at continuous texel indices (x, y, z).
    fn fetch(&self, at: [f64; 3], bits: Option<u32>) -> [f64; 3] {
        let [nx, ny, nz] = self.size;
        let ((ix, tx), (iy, ty)) = (filter(at[0], nx, bits), filter(at[1], ny, bits));
        let (iz, tz) = filter(at[2], nz, bits);
        let mut out = [0.0; 3];
        for (dz, wz) in [(0, 1.0 - tz), (1, tz)] {
            for (dy, wy) in [(0, 1.0 - ty), (1, ty)] {
                for (dx, wx) in [(0, 1.0 - tx), (1, tx)] {
                    let k = self.k[((iz + dz) * ny + iy + dy) * nx + ix + dx];
                    for c in 0..3 {
                        out[c] += wx * wy * wz * f64::from(k[c]);
                    }
                }
            }
        }
        out
    }

    /// f (RGB, 1/sr) for the light direction `wi` and the view `wo` (cloth frame, unit
    /// vectors) by the documented lookup; `bits` rounds the hardware-filtered weights (β_x,
    /// β_y, φ_i) to that many fractional bits (8 on current GPUs), `None` keeps them exact.
    pub fn brdf(&self, wi: [f64; 3], wo: [f64; 3], bits: Option<u32>) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let (wi, wo) = reduce_directions(self.symmetry, wi, wo);
        let theta_i = wi[2].min(1.0).acos().to_degrees();
        let phi_i = wi[1].atan2(wi[0]).to_degrees();
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let (bx, by) = (s[0].atan2(s[2]).to_degrees(), s[1].atan2(s[2]).to_degrees());
        let jt = self.warp_at(0, theta_i);
        let (jx, jy) = (self.warp_at(1, bx), self.warp_at(2, by));
        let last = (self.n_phi_i - 1) as f64;
        let jp = ((phi_i - self.phi_i_lo_deg) / self.phi_i_step_deg).clamp(0.0, last);
        let s0 = (jt.floor() as usize).min(self.n_theta_i - 1);
        let s1 = (s0 + 1).min(self.n_theta_i - 1);
        let wt = jt - s0 as f64;
        let slab = |s: usize| self.fetch([jx, jy, (s * self.n_phi_i) as f64 + jp], bits);
        let (k0, k1) = (slab(s0), slab(s1));
        [0, 1, 2].map(|c| ((1.0 - wt) * k0[c] + wt * k1[c]) / wi[2])
    }

    /// [`Self::brdf`] at cloth-frame angles `q = (θ_i, φ_i, θ_r, φ_r)` (degrees).
    pub fn brdf_deg(&self, q: [f64; 4], bits: Option<u32>) -> [f64; 3] {
        let r = q.map(f64::to_radians);
        self.brdf(direction(r[0], r[1]), direction(r[2], r[3]), bits)
    }

    /// Bytes of the three textures.
    pub fn bytes(&self) -> usize {
        self.images.iter().map(|i| 148 + i.data.len()).sum()
    }
}

/// The errors a LUT adds, each `(relative L2, max |Δ| / peak)` of the luminance of f at the
/// table header's check points (`cloth::tabulate::check_point`, φ_i over the stored domain).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LutErrors {
    pub points: usize,
    /// LUT (exact filter weights) against the table's own lookup.
    pub lut_vs_table: (f64, f64),
    /// LUT with 8-bit filter weights against the table's own lookup.
    pub lut_8bit_vs_table: (f64, f64),
    /// LUT (exact weights) against the model evaluated directly.
    pub lut_vs_model: (f64, f64),
    /// LUT with 8-bit weights against the model.
    pub lut_8bit_vs_model: (f64, f64),
    /// The table's lookup against the model, at the same points.
    pub table_vs_model: (f64, f64),
}

/// Hardware filter-weight precision assumed in [`LutErrors`].
pub const GPU_WEIGHT_BITS: u32 = 8;

/// Measure [`LutErrors`] at `points` check points.
pub fn lut_errors(
    view: &ClothTableView,
    lut: &ClothLut,
    points: usize,
) -> Result<LutErrors, ClothLutError> {
    let fabric = preset(&view.fabric).map_err(|e| ClothLutError::Fabric(e.to_string()))?;
    let options = ModelOptions {
        ramp_step_deg: view.ramp_step_deg,
        ..ModelOptions::default()
    };
    let model = ClothModel::new(fabric, options);
    let g = &view.grid;
    let scale = |t: f64, p: f64| {
        use crate::table::interp::multilinear;
        let pos = [locate(&g.theta_i_deg, t), locate(&g.phi_i_deg, p)];
        let n_p = g.phi_i_deg.len();
        multilinear(&pos, &[g.theta_i_deg.len(), n_p], |k| {
            view.energy_scale[k / n_p][k % n_p]
        })
    };
    let domain = (g.phi_i_deg[0], g.phi_i_deg[g.phi_i_deg.len() - 1]);
    let bits = Some(GPU_WEIGHT_BITS);
    let against_model =
        |f: &dyn Fn([f64; 4]) -> [f64; 3]| interpolation_error(&model, domain, points, f, scale);
    let table: Vec<f64> = (0..points)
        .map(|k| luminance(view.brdf_deg(check_point(k, domain))))
        .collect();
    let against_table = |bits: Option<u32>| {
        let (mut num, mut den, mut max_d, mut peak) = (0.0, 0.0, 0.0f64, 0.0f64);
        for (k, t) in table.iter().enumerate() {
            let d = luminance(lut.brdf_deg(check_point(k, domain), bits)) - t;
            (num, den) = (num + d * d, den + t * t);
            (max_d, peak) = (max_d.max(d.abs()), peak.max(*t));
        }
        (
            (num / den.max(f64::MIN_POSITIVE)).sqrt(),
            max_d / peak.max(f64::MIN_POSITIVE),
        )
    };
    Ok(LutErrors {
        points,
        lut_vs_table: against_table(None),
        lut_8bit_vs_table: against_table(bits),
        lut_vs_model: against_model(&|q| lut.brdf_deg(q, None)),
        lut_8bit_vs_model: against_model(&|q| lut.brdf_deg(q, bits)),
        table_vs_model: against_model(&|q| view.brdf_deg(q)),
    })
}

/// The four files of a LUT written to `out` (`X.dds`): `X.dds`, `X-warp.dds`, `X-albedo.dds`,
/// `X.json`.
#[derive(Debug, Clone, PartialEq)]
pub struct LutPaths {
    pub brdf: PathBuf,
    pub warp: PathBuf,
    pub albedo: PathBuf,
    pub metadata: PathBuf,
}

/// The paths of a LUT written to `out`, checked before any work: `out` ends in `.dds` and its
/// directory exists.
pub fn lut_paths(out: &Path) -> Result<LutPaths, ClothLutError> {
    let bad = |why| ClothLutError::BadOutput {
        path: out.display().to_string(),
        why,
    };
    let ext = out.extension().and_then(|e| e.to_str());
    if !ext.is_some_and(|e| e.eq_ignore_ascii_case("dds")) {
        return Err(bad(
            "the cloth LUT is DDS textures; the output must end in .dds",
        ));
    }
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    if stem.is_empty() {
        return Err(bad("no file name before .dds"));
    }
    let dir = out.parent().filter(|d| !d.as_os_str().is_empty());
    if dir.is_some_and(|d| !d.is_dir()) {
        return Err(bad("its directory does not exist"));
    }
    let sibling = |suffix: &str| out.with_file_name(format!("{stem}{suffix}"));
    Ok(LutPaths {
        brdf: out.to_path_buf(),
        warp: sibling("-warp.dds"),
        albedo: sibling("-albedo.dds"),
        metadata: sibling(".json"),
    })
}

/// The `X.json` record of a LUT: files, layout, the lookup's constants, albedo and errors.
pub fn metadata(
    view: &ClothTableView,
    lut: &ClothLut,
    paths: &LutPaths,
    errors: Option<&LutErrors>,
) -> serde_json::Value {
    let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let pair = |e: (f64, f64)| serde_json::json!({"l2_relative": e.0, "max_over_peak": e.1});
    let errors = errors.map(|e| {
        serde_json::json!({
            "check_points": e.points,
            "check": "luminance of f at the table header's check points (Halton, theta_i and theta_r in [2.5, 87.5] deg, phi_i over the stored domain, phi_r over the circle); l2 = sqrt(sum d^2 / sum ref^2), max = max |d| / max ref",
            "gpu_weight_bits": GPU_WEIGHT_BITS,
            "lut_vs_table": pair(e.lut_vs_table),
            "lut_8bit_weights_vs_table": pair(e.lut_8bit_vs_table),
            "lut_vs_model": pair(e.lut_vs_model),
            "lut_8bit_weights_vs_model": pair(e.lut_8bit_vs_model),
            "table_vs_model": pair(e.table_vs_model),
        })
    });
    let s = lut.symmetry;
    serde_json::json!({
        "kind": "scatterbake cloth LUT",
        "layout_version": 1,
        "fabric": view.fabric,
        "source_schema": "cloth-brdf/2",
        "documentation": "docs/cloth.md section 7",
        "frame": "cloth normal +z, warp +x, weft +y (tangent frame T, B = N x T, N); omega_i toward the light, omega_o toward the viewer; f in 1/sr, linear Rec. 709 RGB; K = f cos theta_i",
        "files": {
            "brdf": name(&paths.brdf), "warp": name(&paths.warp),
            "albedo": name(&paths.albedo),
        },
        "brdf_texture": {
            "size": lut.size, "dxgi_format": lut.precision.format().name(),
            "x": "half_x node", "y": "half_y node", "z": "theta_i node * n_phi_i + phi_i node",
            "value": "K = f cos theta_i (RGB, 1/sr)",
        },
        "n_theta_i": lut.n_theta_i, "n_phi_i": lut.n_phi_i,
        "phi_i_lo_deg": lut.phi_i_lo_deg, "phi_i_step_deg": lut.phi_i_step_deg,
        "symmetry": {"mirror_x": s.mirror_x, "mirror_y": s.mirror_y, "swap_xy": s.swap_xy},
        "warp_texture": {
            "size": [lut.warp_bins, WARP_ROWS], "dxgi_format": "DXGI_FORMAT_R32G32B32A32_FLOAT",
            "rows": ["theta_i", "half_x", "half_y"], "range_deg": lut.warp_range_deg,
            "value": "bin k of [lo, hi] (width (hi - lo) / M): (i, x_i, x_i+1, x_i+2), i the last node at or before the bin's start; x_i+2 = x_i+1 + 1 past the end",
        },
        "albedo_texture": {
            "size": [lut.n_phi_i, lut.n_theta_i], "dxgi_format": "DXGI_FORMAT_R32G32B32A32_FLOAT",
            "x": "phi_i node", "y": "theta_i node",
            "value": "directional albedo E of the stored K (RGB), luminance of E",
        },
        "albedo_average_rgb": lut.albedo_average_rgb,
        "axes_deg": {
            "theta_i": view.grid.theta_i_deg, "phi_i": view.grid.phi_i_deg,
            "half_x": view.grid.half_x_deg, "half_y": view.grid.half_y_deg,
        },
        "table_interpolation_error": pair(view.header_error),
        "errors": errors,
        "bytes": lut.bytes(),
    })
}

/// Write the LUT's files; returns the bytes written.
pub fn write_lut(
    lut: &ClothLut,
    metadata: &serde_json::Value,
    paths: &LutPaths,
) -> Result<usize, ClothLutError> {
    let write = |path: &Path, bytes: &[u8]| {
        std::fs::write(path, bytes).map_err(|source| ClothLutError::Io {
            path: path.display().to_string(),
            source,
        })
    };
    let files = [&paths.brdf, &paths.warp, &paths.albedo];
    let mut total = 0;
    for (path, image) in files.into_iter().zip(&lut.images) {
        let bytes = dds_encode(image);
        write(path, &bytes)?;
        total += bytes.len();
    }
    let text = serde_json::to_string_pretty(metadata).expect("JSON values serialise");
    write(&paths.metadata, text.as_bytes())?;
    Ok(total + text.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector form of the reduction maps the light into the stored domain and agrees with
    /// the angle form of `Symmetry::reduce_deg` on both azimuths.
    #[test]
    fn vector_reduction_is_the_angle_reduction() {
        for name in ["linen_plain", "polyester_satin_front", "velvet"] {
            let s = preset(name).unwrap().symmetry();
            let (lo, hi) = s.phi_i_domain_deg();
            for k in 0..72 {
                let (pi, pr) = (-177.5 + 5.0 * k as f64, 31.0 - 7.0 * k as f64);
                let r = |t: f64, p: f64| direction(t.to_radians(), p.to_radians());
                let (wi, wo) = reduce_directions(s, r(40.0, pi), r(60.0, pr));
                let (ri, rr) = s.reduce_deg(pi, pr);
                let phi = |w: [f64; 3]| w[1].atan2(w[0]).to_degrees();
                assert!(phi(wi) >= lo - 1e-9 && phi(wi) <= hi + 1e-9, "{name} {pi}");
                let wrap = |d: f64| (d + 540.0).rem_euclid(360.0) - 180.0;
                assert!(wrap(phi(wi) - ri).abs() < 1e-9, "{name} {pi}");
                assert!(wrap(phi(wo) - rr).abs() < 1e-9, "{name} {pi} {pr}");
            }
        }
    }
}
