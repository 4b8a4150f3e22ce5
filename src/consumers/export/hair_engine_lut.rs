//! Engine layouts of `hair-dual` tables: the 3-D Dual Scattering LUTs of Unreal Engine's hair
//! strands shading and of Unity HDRP's hair multiple scattering, plus HDRP's 2-D `N^G` LUT, as
//! DirectDraw Surface files (DX10 header, `DXGI_FORMAT_R32G32B32A32_FLOAT`, one mip, 3-D textures
//! as `TEXTURE3D` resources). Layouts, parameter mappings and the shader lookups: `docs/hair.md`
//! §5.1; decisions DS-29 and DS-30 in `docs/decisions.md`.
//!
//! # Conventions
//! - Every axis is cell-centred: texel `i` of an axis of `n` texels sits at `(i + 0.5)/n`, the
//!   point a linear-clamp sampler returns unblended.
//! - The engines look the LUTs up with `|sin θ_i|`; the tables are not even in θ_i (cuticle tilt),
//!   so a texel holds the mean of the table at `+θ_i` and `−θ_i`.
//! - Both engines parameterise absorption by a colour `c ∈ [0, 1]`; `c` is mapped to `σ_a` (per
//!   unit radius) with Chiang et al. 2016 eq. 9 at azimuthal roughness `β_n = 0.3`
//!   ([`colour_to_sigma_a`]), then to the table's `absorption_u = 1 − exp(−2σ_a)`.
//! - Roughness: the engines' longitudinal variance of R is `r²` (rad²), so `β_R = r` rad with
//!   `r` = Unreal roughness, HDRP perceptual roughness `= 1 − smoothness`. Values outside the
//!   table's `roughness` axis take its edge values.
//! - Values come from multilinear interpolation of the table ([`DualTableView::sample`]).

use super::dds::{DdsImage, DxgiFormat, dds_decode, dds_encode};
use crate::hair::dual::DUAL_CHANNELS;
use crate::stages::hair::DUAL_TABLE_CHANNELS;
use crate::table::TableContent;
use std::path::Path;

/// Errors of the engine exports.
#[derive(Debug, thiserror::Error)]
pub enum EngineLutError {
    #[error("not a hair-dual/1 table ({0})")]
    NotHairDual(String),
    #[error(
        "the engine LUTs need a physical LUT table (axes roughness × absorption_u × theta, \
         `absorption_count = N`); this table has axes {0}"
    )]
    WrongAxes(String),
    #[error("texture size {0:?} must be 2–1024 texels per axis")]
    BadSize([usize; 3]),
    #[error("roughness {0}° is outside the table's roughness axis")]
    RoughnessOutside(f64),
    #[error("not a DDS file this module writes: {0}")]
    BadDds(&'static str),
    #[error("writing {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
}

/// Index of a quantity in the table channels.
fn channel(name: &str) -> usize {
    DUAL_CHANNELS
        .iter()
        .position(|n| *n == name)
        .expect("known channel")
}

/// Linear interpolation weights on a monotone axis: `(i, t)` with value = `(1 − t)·v[i] + t·v[i+1]`,
/// clamped to the axis range.
fn bracket(axis: &[f64], x: f64) -> (usize, f64) {
    let n = axis.len();
    if n == 1 || x <= axis[0] {
        return (0, 0.0);
    }
    if x >= axis[n - 1] {
        return (n - 2, 1.0);
    }
    let i = axis.partition_point(|&a| a <= x).clamp(1, n - 1) - 1;
    (i, (x - axis[i]) / (axis[i + 1] - axis[i]))
}

/// A physical `hair-dual/1` LUT table (roughness × absorption_u × theta) with multilinear lookup.
pub struct DualTableView<'a> {
    table: &'a TableContent,
    roughness_deg: Vec<f64>,
    absorption_u: Vec<f64>,
    theta_deg: Vec<f64>,
}

impl<'a> DualTableView<'a> {
    pub fn new(t: &'a TableContent) -> Result<Self, EngineLutError> {
        if t.schema.name != "hair-dual" || t.schema.version != 1 {
            return Err(EngineLutError::NotHairDual(t.schema.to_string()));
        }
        let names: Vec<&str> = t.axes.iter().map(|a| a.name.as_str()).collect();
        if names != ["roughness", "absorption_u", "theta"]
            || t.channels.len() != DUAL_TABLE_CHANNELS
        {
            return Err(EngineLutError::WrongAxes(names.join(" × ")));
        }
        Ok(DualTableView {
            table: t,
            roughness_deg: t.axes[0].coords(),
            absorption_u: t.axes[1].coords(),
            theta_deg: t.axes[2].coords(),
        })
    }

    /// The roughness axis (deg).
    pub fn roughness_deg(&self) -> &[f64] {
        &self.roughness_deg
    }

    /// All 16 channels at (β_R deg, absorption_u, θ_i deg), multilinear, clamped to the axes.
    pub fn sample(&self, beta_deg: f64, u: f64, theta_deg: f64) -> [f64; DUAL_TABLE_CHANNELS] {
        let (ir, tr) = bracket(&self.roughness_deg, beta_deg);
        let (ia, ta) = bracket(&self.absorption_u, u);
        let (it, tt) = bracket(&self.theta_deg, theta_deg);
        let (na, nt) = (self.absorption_u.len(), self.theta_deg.len());
        let nr = self.roughness_deg.len();
        let mut out = [0.0; DUAL_TABLE_CHANNELS];
        for (dr, wr) in [(0, 1.0 - tr), (1, tr)] {
            for (da, wa) in [(0, 1.0 - ta), (1, ta)] {
                for (dt, wt) in [(0, 1.0 - tt), (1, tt)] {
                    let w = wr * wa * wt;
                    if w == 0.0 {
                        continue;
                    }
                    let (r, a, th) = ((ir + dr).min(nr - 1), (ia + da).min(na - 1), it + dt);
                    let o = ((r * na + a) * nt + th.min(nt - 1)) * DUAL_TABLE_CHANNELS;
                    for (k, v) in out.iter_mut().enumerate() {
                        *v += w * self.table.data[o + k] as f64;
                    }
                }
            }
        }
        out
    }

    /// Mean of [`Self::sample`] at `+θ` and `−θ` (the engines fold the sign of θ_i).
    pub fn sample_folded(
        &self,
        beta_deg: f64,
        u: f64,
        abs_sin_theta: f64,
    ) -> [f64; DUAL_TABLE_CHANNELS] {
        let th = abs_sin_theta.clamp(0.0, 1.0).asin().to_degrees();
        let a = self.sample(beta_deg, u, th);
        let b = self.sample(beta_deg, u, -th);
        std::array::from_fn(|k| 0.5 * (a[k] + b[k]))
    }
}

/// Absorption per unit radius of a hair colour `c` (one channel, clamped to [1e-4, 1]): Chiang
/// et al. 2016 eq. 9 at azimuthal roughness `β_n = 0.3`.
pub fn colour_to_sigma_a(c: f64) -> f64 {
    let b = 0.3f64;
    let d = 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * b.powi(3)
        + 5.574 * b.powi(4)
        + 0.245 * b.powi(5);
    (c.clamp(1e-4, 1.0).ln() / d).powi(2)
}

/// The table's absorption coordinate `u = 1 − exp(−2σ_a)` of a colour `c`.
pub fn colour_to_absorption_u(c: f64) -> f64 {
    1.0 - (-2.0 * colour_to_sigma_a(c)).exp()
}

/// An RGBA32F texture, `width × height × depth` (depth 1 for 2-D), texels x fastest, then y
/// (row 0 = v = 0, the first row in memory), then z.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    pub size: [usize; 3],
    pub texels: Vec<[f32; 4]>,
}

impl Texture {
    fn build(size: [usize; 3], f: impl Fn([f64; 3]) -> [f64; 4]) -> Result<Self, EngineLutError> {
        let is_2d = size[2] == 1;
        for (k, &n) in size.iter().enumerate() {
            if !((2..=1024).contains(&n) || k == 2 && is_2d) {
                return Err(EngineLutError::BadSize(size));
            }
        }
        let centre = |i: usize, n: usize| (i as f64 + 0.5) / n as f64;
        let mut texels = Vec::with_capacity(size.iter().product());
        for z in 0..size[2] {
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let v = f([centre(x, size[0]), centre(y, size[1]), centre(z, size[2])]);
                    texels.push(v.map(|c| c as f32));
                }
            }
        }
        Ok(Texture { size, texels })
    }

    /// Linear-clamp sampling at normalised coordinates (what `SampleLevel(s_linear_clamp, uvw, 0)`
    /// returns): texel centres at `(i + 0.5)/n`, clamped to the edge texels.
    pub fn sample_linear(&self, uvw: [f64; 3]) -> [f64; 4] {
        let mut idx = [[0usize; 2]; 3];
        let mut wts = [[0.0f64; 2]; 3];
        for k in 0..3 {
            let n = self.size[k];
            let x = (uvw[k] * n as f64 - 0.5).clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n.saturating_sub(2));
            let t = if n == 1 { 0.0 } else { x - i as f64 };
            idx[k] = [i, (i + 1).min(n - 1)];
            wts[k] = [1.0 - t, t];
        }
        let mut out = [0.0; 4];
        for a in 0..2 {
            for b in 0..2 {
                for c in 0..2 {
                    let w = wts[0][a] * wts[1][b] * wts[2][c];
                    let t = self.texels
                        [(idx[2][c] * self.size[1] + idx[1][b]) * self.size[0] + idx[0][a]];
                    for (o, v) in out.iter_mut().zip(t) {
                        *o += w * v as f64;
                    }
                }
            }
        }
        out
    }
}

/// Unreal Engine hair strands Dual Scattering LUT: `x = |sin θ_i|`, `y = roughness r` (β_R = r
/// rad), `z = sqrt(c)` (c = hair colour, one channel) → `(ā_f, ā_b, β̄_f², β̄_b²)`. Engine default
/// size 64 × 64 × 16.
pub fn unreal_dual_scattering(
    view: &DualTableView,
    size: [usize; 3],
) -> Result<Texture, EngineLutError> {
    let q = quantities();
    Texture::build(size, |[s, r, z]| {
        let v = view.sample_folded(r.to_degrees(), colour_to_absorption_u(z * z), s);
        q.map(|k| v[k])
    })
}

/// HDRP `_PreIntegratedHairFiberScattering`: `x = smoothness` (β_R = 1 − x rad), `y = |sin θ_i|`,
/// `z = c` → `(ā_f, ā_b, β̄_f², β̄_b²)`. Engine size 64³.
pub fn hdrp_fiber_scattering(
    view: &DualTableView,
    size: [usize; 3],
) -> Result<Texture, EngineLutError> {
    let q = quantities();
    Texture::build(size, |[x, s, c]| {
        let v = view.sample_folded((1.0 - x).to_degrees(), colour_to_absorption_u(c), s);
        q.map(|k| v[k])
    })
}

/// HDRP `_PreIntegratedAverageHairFiberScattering` (2-D): `x = |sin θ_i|`, `y = c` →
/// `(N^G_R, N^G_TT, N^G_TRT, 0)` at roughness `beta_deg` (a value of the table's roughness
/// axis range).
pub fn hdrp_average_azimuthal(
    view: &DualTableView,
    size: [usize; 2],
    beta_deg: f64,
) -> Result<Texture, EngineLutError> {
    let r = view.roughness_deg();
    if beta_deg < r[0] - 1e-9 || beta_deg > r[r.len() - 1] + 1e-9 {
        return Err(EngineLutError::RoughnessOutside(beta_deg));
    }
    let ng = [channel("N_G_R"), channel("N_G_TT"), channel("N_G_TRT")];
    Texture::build([size[0], size[1], 1], |[s, c, _]| {
        let v = view.sample_folded(beta_deg, colour_to_absorption_u(c), s);
        [v[ng[0]], v[ng[1]], v[ng[2]], 0.0]
    })
}

/// Channel indices stored in the 3-D LUTs.
fn quantities() -> [usize; 4] {
    [
        channel("a_f"),
        channel("a_b"),
        channel("beta_f2"),
        channel("beta_b2"),
    ]
}

/// The texture as a DDS file: DX10 extended header, `DXGI_FORMAT_R32G32B32A32_FLOAT`, one mip,
/// resource dimension `TEXTURE3D` (depth > 1) or `TEXTURE2D`, little-endian texels in
/// [`Texture`] order ([`super::dds`]).
pub fn dds_bytes(t: &Texture) -> Vec<u8> {
    let data = t
        .texels
        .iter()
        .flat_map(|texel| texel.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    dds_encode(&DdsImage {
        size: t.size,
        format: DxgiFormat::R32G32B32A32Float,
        data,
    })
}

/// Read back a DDS written by [`dds_bytes`].
pub fn parse_dds(b: &[u8]) -> Result<Texture, EngineLutError> {
    let img = dds_decode(b).map_err(|e| EngineLutError::BadDds(e.0))?;
    if img.format != DxgiFormat::R32G32B32A32Float {
        return Err(EngineLutError::BadDds("not DX10 R32G32B32A32_FLOAT"));
    }
    let texels = img
        .data
        .chunks_exact(16)
        .map(|t| {
            std::array::from_fn(|c| {
                f32::from_le_bytes([t[4 * c], t[4 * c + 1], t[4 * c + 2], t[4 * c + 3]])
            })
        })
        .collect();
    Ok(Texture {
        size: img.size,
        texels,
    })
}

/// Write [`dds_bytes`] to `path`.
pub fn write_dds(t: &Texture, path: &Path) -> Result<(), EngineLutError> {
    std::fs::write(path, dds_bytes(t)).map_err(|source| EngineLutError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::SplitMix64;
    use crate::stages::hair::{HairDualJob, HairDualParams};

    fn lut_table() -> TableContent {
        let p: HairDualParams = toml::from_str(
            "roughness_deg = [2.0, 5.0, 10.0, 20.0, 30.0]\nabsorption_count = 17\ntheta_count = 37",
        )
        .unwrap();
        crate::stages::run_in_memory(&HairDualJob::new(p).unwrap()).unwrap()
    }

    fn round_trip(t: &Texture) -> Texture {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lut.dds");
        write_dds(t, &path).unwrap();
        parse_dds(&std::fs::read(&path).unwrap()).unwrap()
    }

    /// Sample each exported texture with a linear-clamp sampler at random points and compare
    /// with the table interpolated at the engine coordinates mapped as documented: exact (f32) at
    /// texel centres, and within the resampling error between them.
    #[test]
    fn engine_textures_match_the_table_at_random_points() {
        let table = lut_table();
        let view = DualTableView::new(&table).unwrap();
        let q = quantities();
        type Reference<'r> = Box<dyn Fn([f64; 3]) -> [f64; 4] + 'r>;
        let cases: Vec<(&str, Texture, Reference)> = vec![
            (
                "unreal",
                unreal_dual_scattering(&view, [32, 32, 16]).unwrap(),
                Box::new(|[s, r, z]: [f64; 3]| {
                    let v = view.sample_folded(r.to_degrees(), colour_to_absorption_u(z * z), s);
                    q.map(|k| v[k])
                }),
            ),
            (
                "hdrp-fiber",
                hdrp_fiber_scattering(&view, [32, 32, 32]).unwrap(),
                Box::new(|[x, s, c]: [f64; 3]| {
                    let v =
                        view.sample_folded((1.0 - x).to_degrees(), colour_to_absorption_u(c), s);
                    q.map(|k| v[k])
                }),
            ),
            (
                "hdrp-azimuthal",
                hdrp_average_azimuthal(&view, [32, 32], 10.0).unwrap(),
                Box::new(|[s, c, _]: [f64; 3]| {
                    let v = view.sample_folded(10.0, colour_to_absorption_u(c), s);
                    [v[9], v[10], v[11], 0.0]
                }),
            ),
        ];
        let mut rng = SplitMix64::new(0xe261_2e5c);
        for (name, tex, reference) in &cases {
            let tex = round_trip(tex);
            let dims = if tex.size[2] == 1 { 2 } else { 3 };
            let (mut worst_centre, mut worst, mut sum, mut n) = (0.0f64, 0.0f64, 0.0, 0);
            for _ in 0..400 {
                let mut p = [0.5; 3];
                let mut c = [0.5; 3];
                for k in 0..dims {
                    p[k] = rng.next_f64();
                    let i = (rng.next_f64() * tex.size[k] as f64) as usize;
                    c[k] = (i.min(tex.size[k] - 1) as f64 + 0.5) / tex.size[k] as f64;
                }
                let (got, want) = (tex.sample_linear(c), reference(c));
                for k in 0..4 {
                    let e = (got[k] - want[k]).abs() / want[k].abs().max(1.0);
                    worst_centre = worst_centre.max(e);
                }
                let (got, want) = (tex.sample_linear(p), reference(p));
                for k in 0..4 {
                    let e = (got[k] - want[k]).abs();
                    worst = worst.max(e);
                    sum += e;
                    n += 1;
                }
            }
            println!(
                "{name} {:?}: texel centres max |Δ| {worst_centre:.2e}; 400 random points max |Δ| {worst:.2e}, mean {:.2e}",
                tex.size,
                sum / n as f64
            );
            assert!(
                worst_centre < 1e-6,
                "{name}: texel centres {worst_centre:e}"
            );
            // Between texel centres the texture and the table are two different piecewise-linear
            // interpolants; they differ most where ā_b changes fast (grazing light, on a 32-texel
            // axis): measured max 0.18 (Unreal), mean 1.2e-3. Layout errors (a swapped axis or
            // mapping) give O(0.1) mean errors and fail the mean and texel-centre checks.
            assert!(worst < 0.25, "{name}: random points {worst:e}");
            assert!(sum / (n as f64) < 2e-3, "{name}: mean {}", sum / n as f64);
        }
    }

    #[test]
    fn dds_header_is_a_dx10_volume_and_axes_are_in_engine_order() {
        let table = lut_table();
        let view = DualTableView::new(&table).unwrap();
        let t = unreal_dual_scattering(&view, [8, 4, 2]).unwrap();
        let b = dds_bytes(&t);
        assert_eq!(b.len(), 148 + 16 * 64);
        assert_eq!(&b[84..88], b"DX10");
        // Depth, width and height in their header fields.
        assert_eq!(u32::from_le_bytes(b[24..28].try_into().unwrap()), 2);
        assert_eq!(u32::from_le_bytes(b[16..20].try_into().unwrap()), 8);
        assert_eq!(u32::from_le_bytes(b[12..16].try_into().unwrap()), 4);
        // x is |sin θ|: the last texel along x is near grazing where ā_b of the Fresnel-dominated
        // fibre rises; z is sqrt(colour): a light colour (z = 1) forward-scatters more.
        let at = |x: usize, y: usize, z: usize| t.texels[(z * 4 + y) * 8 + x];
        assert!(
            at(0, 1, 1)[0] > at(0, 1, 0)[0],
            "ā_f must grow with colour (z)"
        );
        assert!(
            at(7, 1, 1)[1] > at(0, 1, 1)[1],
            "ā_b must grow toward grazing (x)"
        );
    }

    #[test]
    fn colour_mapping_is_monotone_and_white_is_lossless() {
        assert_eq!(colour_to_sigma_a(1.0), 0.0);
        let mut prev = -1.0;
        for k in 1..=100 {
            let u = colour_to_absorption_u(1.0 - k as f64 / 100.0);
            assert!(u > prev && u <= 1.0);
            prev = u;
        }
    }
}
