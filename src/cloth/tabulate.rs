//! The fabric BRDF on the tables' grid (layout `cloth-brdf/2`, decision CLOTH-18): values,
//! directional albedo and sampling CDFs.
//!
//! Grid ([`HalfGrid`]):
//! - light: θ_i at the centres of cells that tile [0°, 90°], `light_step_deg` wide up to
//!   `90° − grazing_deg` and `grazing_step_deg` wide above (the BRDF changes fastest with the
//!   light near grazing incidence), and φ_i at the nodes `lo + k·phi_i_step_deg` of the fabric's
//!   fundamental domain `[lo, hi]` ([`super::Symmetry::phi_i_domain_deg`]), both ends included;
//! - view: the projected half angles `β_x`, `β_y` of the half vector ([`super::half`]), each on
//!   a non-uniform axis over `[−β_max, β_max]`: spacing `half_fine · γ_s` over the β range of
//!   the lobes of the family whose highlights lie along that axis (warp: `β_x = −α`, weft:
//!   `β_y = −α`, α over the family's tangent curve), growing away from it up to
//!   `half_coarse_deg`.
//!
//! The stored value is the patch integrand `K = f·cos θ_i` (eq. 5.20, RGB): `f = K / cos θ_i`
//! takes part of the growth of f toward grazing light out of what is interpolated. Where the
//! reflected view `ω_r = 2(ω_i·h)h − ω_i` lies below the horizon, the node holds `K` of the
//! view of the same azimuth just above the horizon ([`onto_horizon`]), so that interpolation
//! next to the horizon does not blend with zeros or with a meaningless continuation; a lookup
//! returns 0 below the horizon.
//!
//! Per (θ_i, φ_i) the half-vector plane is split into cells `[β_x,a, β_x,a+1] × [β_y,b,
//! β_y,b+1]` with weight `w = ∫_cell Y(f) cos θ_r · 4(ω_i·h) · J(β) dβ_x dβ_y` (0 where ω_r is
//! below the horizon; `J` = [`half_jacobian`], `4(ω_i·h)` the Jacobian of reflection), computed
//! by [`cell_integrals`]: `Σ w` is the directional albedo of luminance Y (per channel for the
//! albedo). The
//! sampling tables are the marginal CDF over `β_x` intervals (value at node `a` = weight of the
//! intervals before it) and, per `β_x` interval `a`, the conditional CDF over `β_y` intervals
//! (stored at `β_x` node `a`; the last node repeats the previous one). A sample picks a cell by
//! two binary searches, places `(β_x, β_y)` uniformly inside it and reflects ω_i about `h`;
//! its density per solid angle of ω_r is `w_cell / (W Δβ_x Δβ_y J(β) 4(ω_i·h))`
//! ([`sample_view`], [`view_pdf`]).

use super::brdf::{ClothModel, direction};
use super::fabric::Fabric;
use super::half::{half_angles_deg, half_axis, half_direction, half_jacobian, half_of, reflect};
use crate::math::vec3::dot;

/// Channels of one table entry.
pub const CHANNELS: [&str; 5] = ["k_r", "k_g", "k_b", "cdf_half_x", "cdf_half_y"];

/// θ range (degrees, both θ_i and θ_r) of the interpolation-error check points.
pub const CHECK_THETA_DEG: (f64, f64) = (2.5, 87.5);

/// Rec. 709 luminance of linear RGB.
pub fn luminance(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// What the tables do about the directional albedo above 1 near grazing incidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnergyMode {
    /// The model as printed in the thesis (albedo > 1 near grazing incidence).
    AsPrinted,
    /// Each incident direction's values scaled by `min(1, 1/max_c ρ_c(ω_i))`.
    Clamp,
}

/// Why a grid is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error(
        "theta_i cells: light_step_deg {0}° must divide 90° − grazing_deg and grazing_step_deg \
         {1}° must divide grazing_deg {2}° (steps 0.25°–30°, grazing_deg 0°–45°)"
    )]
    ThetaI(f64, f64, f64),
    #[error("phi_i_step_deg {0}° must divide 45° (between 0.25° and 45°)")]
    PhiI(f64),
    #[error("half_fine {0} must be in [0.05, 5] (a fraction of the thread roughness γ_s)")]
    HalfFine(f64),
    #[error("half_coarse_deg {0} must be in [0.1, 30]")]
    HalfCoarse(f64),
    #[error("half_max_deg {0} must be in [45, 89.9]")]
    HalfMax(f64),
}

/// The parameters of a grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// θ_i cell size below `90° − grazing_deg`, degrees.
    pub light_step_deg: f64,
    /// Width of the grazing band of θ_i, degrees (0: none).
    pub grazing_deg: f64,
    /// θ_i cell size in the grazing band, degrees.
    pub grazing_step_deg: f64,
    /// Step of the φ_i nodes, degrees; divides 45.
    pub phi_i_step_deg: f64,
    /// Half-angle spacing over a family's lobes, as a fraction of its γ_s.
    pub half_fine: f64,
    /// Largest half-angle spacing, degrees.
    pub half_coarse_deg: f64,
    /// End of the half-angle axes, degrees.
    pub half_max_deg: f64,
}

impl Default for GridSpec {
    fn default() -> Self {
        GridSpec {
            light_step_deg: 10.0,
            grazing_deg: 10.0,
            grazing_step_deg: 1.25,
            phi_i_step_deg: 5.0,
            half_fine: 0.5,
            half_coarse_deg: 7.5,
            half_max_deg: 88.0,
        }
    }
}

/// `width / step` when it is a whole number and the step is in [0.25°, 30°].
fn cells(width: f64, step: f64) -> Option<usize> {
    let n = width / step;
    ((0.25..=30.0).contains(&step) && (n - n.round()).abs() < 1e-9).then(|| n.round() as usize)
}

/// θ_i cell centres of `spec`: cells of `light_step_deg` up to `90° − grazing_deg`, then of
/// `grazing_step_deg`.
fn theta_i_centres(spec: &GridSpec) -> Result<Vec<f64>, GridError> {
    let err = GridError::ThetaI(spec.light_step_deg, spec.grazing_step_deg, spec.grazing_deg);
    if !(0.0..=45.0).contains(&spec.grazing_deg) {
        return Err(err);
    }
    let split = 90.0 - spec.grazing_deg;
    let n = cells(split, spec.light_step_deg).ok_or(err.clone())?;
    let m = if spec.grazing_deg > 0.0 {
        cells(spec.grazing_deg, spec.grazing_step_deg).ok_or(err)?
    } else {
        0
    };
    let low = (0..n).map(|k| (k as f64 + 0.5) * spec.light_step_deg);
    let high = (0..m).map(|k| split + (k as f64 + 0.5) * spec.grazing_step_deg);
    Ok(low.chain(high).collect())
}

/// The table grid of one fabric.
#[derive(Debug, Clone, PartialEq)]
pub struct HalfGrid {
    /// θ_i cell centres, degrees.
    pub theta_i_deg: Vec<f64>,
    /// φ_i nodes over the fundamental domain, degrees.
    pub phi_i_deg: Vec<f64>,
    /// β_x nodes, degrees.
    pub half_x_deg: Vec<f64>,
    /// β_y nodes, degrees.
    pub half_y_deg: Vec<f64>,
}

/// The β range (degrees) of family `j`'s specular lines, `−α` over its tangent curve.
fn lobe_range(fabric: &Fabric, j: usize) -> (f64, f64) {
    let nodes = fabric.families[j].curve.nodes(1.0);
    let a = nodes.iter().map(|n| n.alpha_rad.to_degrees());
    let (lo, hi) = a.fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)));
    (-hi, -lo)
}

impl HalfGrid {
    /// The grid of `spec` for `fabric`.
    pub fn new(fabric: &Fabric, spec: GridSpec) -> Result<Self, GridError> {
        let theta_i_deg = theta_i_centres(&spec)?;
        let s = spec.phi_i_step_deg;
        let n45 = 45.0 / s;
        if !(0.25..=45.0).contains(&s) || (n45 - n45.round()).abs() > 1e-9 {
            return Err(GridError::PhiI(s));
        }
        if !(0.05..=5.0).contains(&spec.half_fine) {
            return Err(GridError::HalfFine(spec.half_fine));
        }
        if !(0.1..=30.0).contains(&spec.half_coarse_deg) {
            return Err(GridError::HalfCoarse(spec.half_coarse_deg));
        }
        if !(45.0..=89.9).contains(&spec.half_max_deg) {
            return Err(GridError::HalfMax(spec.half_max_deg));
        }
        let (lo, hi) = fabric.symmetry().phi_i_domain_deg();
        let n_phi_i = ((hi - lo) / s).round() as usize;
        let axis = |j: usize| {
            let gamma = fabric.families[j].optics.gamma_s_rad.to_degrees();
            let fine = (spec.half_fine * gamma).min(spec.half_coarse_deg);
            half_axis(
                lobe_range(fabric, j),
                fine,
                spec.half_coarse_deg,
                spec.half_max_deg,
            )
        };
        Ok(HalfGrid {
            theta_i_deg,
            phi_i_deg: (0..=n_phi_i).map(|k| lo + k as f64 * s).collect(),
            half_x_deg: axis(0),
            half_y_deg: axis(1),
        })
    }

    /// Half-vector nodes per (θ_i, φ_i).
    pub fn views(&self) -> usize {
        self.half_x_deg.len() * self.half_y_deg.len()
    }

    /// Values of one θ_i row: φ_i × β_x × β_y × channels.
    pub fn row_len(&self) -> usize {
        self.phi_i_deg.len() * self.views() * CHANNELS.len()
    }

    /// The (β_x, β_y) cell `(a, b)` holding the half vector of `(wi, wr)`, `None` outside the
    /// axes or when the pair has no half vector above the cloth plane.
    pub fn cell(&self, wi: [f64; 3], wr: [f64; 3]) -> Option<(usize, usize)> {
        let (bx, by) = half_angles_deg(half_of(wi, wr)?);
        let find = |axis: &[f64], x: f64| {
            (x >= axis[0] && x <= axis[axis.len() - 1])
                .then(|| crate::table::interp::locate(axis, x).0)
        };
        Some((find(&self.half_x_deg, bx)?, find(&self.half_y_deg, by)?))
    }
}

/// One θ_i row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// φ_i × β_x × β_y × [`CHANNELS`].
    pub values: Vec<f32>,
    /// Directional albedo of the model as printed, per φ_i, RGB.
    pub albedo: Vec<[f64; 3]>,
    /// Factor applied to each φ_i's values (1 unless [`EnergyMode::Clamp`] reduced them).
    pub scale: Vec<f64>,
}

/// The patch integrand `K` (RGB) at every half-vector node (β_x-major) of the light
/// direction `wi` (views below the horizon moved up to it, [`onto_horizon`]).
pub fn light_nodes(model: &ClothModel, grid: &HalfGrid, wi: [f64; 3]) -> Vec<[f64; 3]> {
    let light = model.prepare(wi);
    let mut k = Vec::with_capacity(grid.views());
    for &bx in &grid.half_x_deg {
        for &by in &grid.half_y_deg {
            let wr = reflect(wi, half_direction(bx, by));
            let v = model
                .patch_prepared(&light, &model.prepare(onto_horizon(wr)))
                .total();
            k.push(v);
        }
    }
    k
}

/// Sub-cells per cell and axis of the cell integrals.
const SUB: usize = 4;

/// A cell's centre is evaluated for the sampling weights when its weight times the relative
/// spread of `K` over its corners (a bound on the bilinear rule's error in the cell, up to a
/// factor of order one) exceeds this fraction of the light's total weight.
const CENTRE_ERROR: f64 = 3e-5;

/// `K` (RGB) at the centre of every half-vector cell (β_x-major) of the light `wi` whose
/// bilinear weight `cells` ([`cell_integrals`] without centres) could be wrong by more than
/// `CENTRE_ERROR` of the total, judged from the spread of the luminance of its corner values
/// `k` ([`light_nodes`]); `None` elsewhere.
pub fn cell_centres(
    model: &ClothModel,
    grid: &HalfGrid,
    wi: [f64; 3],
    k: &[[f64; 3]],
    cells: &[[f64; 3]],
) -> Vec<Option<[f64; 3]>> {
    let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
    let n_y = ys.len();
    let total: f64 = cells.iter().map(|c| luminance(*c)).sum();
    let light = model.prepare(wi);
    let mut out = Vec::with_capacity(cells.len());
    for a in 0..xs.len() - 1 {
        for b in 0..n_y - 1 {
            let corners = [
                a * n_y + b,
                a * n_y + b + 1,
                (a + 1) * n_y + b,
                (a + 1) * n_y + b + 1,
            ]
            .map(|j| luminance(k[j]));
            let lo = corners.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = corners.iter().cloned().fold(0.0, f64::max);
            let mean = 0.25 * corners.iter().sum::<f64>();
            let weight = luminance(cells[a * (n_y - 1) + b]);
            if mean <= 0.0 || weight * (hi - lo) / mean <= CENTRE_ERROR * total {
                out.push(None);
                continue;
            }
            let h = half_direction(0.5 * (xs[a] + xs[a + 1]), 0.5 * (ys[b] + ys[b + 1]));
            let wr = onto_horizon(reflect(wi, h));
            out.push(Some(
                model.patch_prepared(&light, &model.prepare(wr)).total(),
            ));
        }
    }
    out
}

/// `∫ f cos θ_r dω_r` (RGB) over every half-vector cell (β_x-major, `(n_x − 1) × (n_y − 1)`)
/// for the light `wi`, from the nodes' `K`: the midpoint rule on `SUB × SUB` sub-cells of
/// `K` interpolated bilinearly from the cell's corners, divided by `cos θ_i`, times
/// `cos θ_r · 4(ω_i·h) · J(β)` evaluated exactly at each sub-cell (0 where ω_r is below the
/// horizon), so that cells cut by the horizon and the Jacobians are integrated accurately.
///
/// With `centres` ([`cell_centres`]), a cell whose centre value `K_c` is known adds
/// `(K_c − K̃_c) · s · 16u(1−u)v(1−v)` to the bilinear `K̃`, with `s` such that the bump carries
/// 2/3 of the cell's weight: for constant geometry the cell's integral is then the product
/// rule `(K₀₀ + K₀₁ + K₁₀ + K₁₁)/12 + 2K_c/3`, exact for cubics (Simpson's order), where the
/// bilinear rule is exact only for bilinear `K`. The sum is clamped at 0 per sub-cell, so every
/// weight is ≥ 0.
pub fn cell_integrals(
    grid: &HalfGrid,
    wi: [f64; 3],
    k: &[[f64; 3]],
    centres: Option<&[Option<[f64; 3]>]>,
) -> Vec<[f64; 3]> {
    let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
    let n_y = ys.len();
    let bump = |t: f64| t * (1.0 - t);
    let mean_bump: f64 = (0..SUB)
        .map(|i| bump((i as f64 + 0.5) / SUB as f64))
        .sum::<f64>()
        / SUB as f64;
    let bump_scale = (2.0 / 3.0) / (mean_bump * mean_bump);
    let mut out = Vec::with_capacity((xs.len() - 1) * (n_y - 1));
    for a in 0..xs.len() - 1 {
        for b in 0..n_y - 1 {
            let corners = [
                k[a * n_y + b],
                k[a * n_y + b + 1],
                k[(a + 1) * n_y + b],
                k[(a + 1) * n_y + b + 1],
            ];
            let excess = centres.and_then(|c| c[a * (n_y - 1) + b]).map(|kc| {
                [0, 1, 2].map(|c| kc[c] - 0.25 * corners.iter().map(|q| q[c]).sum::<f64>())
            });
            let (dx, dy) = (xs[a + 1] - xs[a], ys[b + 1] - ys[b]);
            let area = (dx / SUB as f64).to_radians() * (dy / SUB as f64).to_radians();
            let mut sum = [0.0; 3];
            for i in 0..SUB {
                let u = (i as f64 + 0.5) / SUB as f64;
                for j in 0..SUB {
                    let v = (j as f64 + 0.5) / SUB as f64;
                    let (bx, by) = (xs[a] + u * dx, ys[b] + v * dy);
                    let h = half_direction(bx, by);
                    let wr = reflect(wi, h);
                    if wi[2] <= 0.0 || wr[2] <= 0.0 {
                        continue;
                    }
                    let geom = wr[2] * 4.0 * dot(wi, h) * half_jacobian(bx, by) * area / wi[2];
                    let w = [(1.0 - u) * (1.0 - v), (1.0 - u) * v, u * (1.0 - v), u * v];
                    let phi = bump_scale * bump(u) * bump(v);
                    for (c, s) in sum.iter_mut().enumerate() {
                        let bilinear: f64 = (0..4).map(|q| w[q] * corners[q][c]).sum();
                        // K ≥ 0: a dark centre between bright corners must not make the
                        // bump negative (a negative weight would break the CDFs).
                        let kc = (bilinear + excess.map_or(0.0, |e| e[c] * phi)).max(0.0);
                        *s += kc * geom;
                    }
                }
            }
            out.push(sum);
        }
    }
    out
}

/// Lowest `cos θ_r` (θ_r = 87.5°) of the view directions the tables evaluate: a view below it
/// is moved up to it along its azimuth, and that value holds beyond it. Nearer the horizon the
/// model's value rises steeply (masking and 1/ΣP), and holding it would spread that rise over
/// whole cells next to the horizon.
pub const HORIZON_COS: f64 = 0.043_619_387_365_336;

/// `w` unchanged when `w_z ≥` [`HORIZON_COS`], else the direction of the same azimuth at
/// `w_z =` [`HORIZON_COS`] (straight up when `w` has no azimuth).
pub fn onto_horizon(w: [f64; 3]) -> [f64; 3] {
    if w[2] >= HORIZON_COS {
        return w;
    }
    let r = w[0].hypot(w[1]);
    if r == 0.0 {
        return [0.0, 0.0, 1.0];
    }
    let s = (1.0 - HORIZON_COS * HORIZON_COS).sqrt() / r;
    [w[0] * s, w[1] * s, HORIZON_COS]
}

/// The θ_i row `ti` of the table of `model` on `grid`.
pub fn tabulate_row(model: &ClothModel, grid: &HalfGrid, ti: usize, energy: EnergyMode) -> Row {
    let theta_i = grid.theta_i_deg[ti].to_radians();
    let mut row = Row {
        values: Vec::with_capacity(grid.row_len()),
        albedo: Vec::new(),
        scale: Vec::new(),
    };
    let n_y = grid.half_y_deg.len();
    for phi_i in &grid.phi_i_deg {
        let wi = direction(theta_i, phi_i.to_radians());
        let k = light_nodes(model, grid, wi);
        let cells = cell_integrals(grid, wi, &k, None);
        let albedo = [0, 1, 2].map(|c| cells.iter().map(|x| x[c]).sum());
        let centres = cell_centres(model, grid, wi, &k, &cells);
        let weights = cell_integrals(grid, wi, &k, Some(&centres));
        let peak = albedo.iter().cloned().fold(0.0, f64::max);
        let scale = match energy {
            EnergyMode::Clamp if peak > 1.0 => 1.0 / peak,
            _ => 1.0,
        };
        let (marginal, conditional) = cdfs(grid, &weights);
        for (j, v) in k.iter().enumerate() {
            row.values.extend(v.map(|x| (x * scale) as f32));
            row.values.push(marginal[j / n_y] as f32);
            row.values.push(conditional[j] as f32);
        }
        row.albedo.push(albedo);
        row.scale.push(scale);
    }
    row
}

/// The marginal CDF over β_x intervals (one value per β_x node) and the conditional CDFs over
/// β_y intervals (one per half-vector node) of the luminance of the cell integrals `cells`
/// ([`cell_integrals`]). An interval row of zero weight gets a uniform CDF.
pub fn cdfs(grid: &HalfGrid, cells: &[[f64; 3]]) -> (Vec<f64>, Vec<f64>) {
    let (n_x, n_y) = (grid.half_x_deg.len(), grid.half_y_deg.len());
    let w: Vec<f64> = cells.iter().map(|c| luminance(*c)).collect();
    let rows: Vec<f64> = w.chunks(n_y - 1).map(|r| r.iter().sum()).collect();
    let total: f64 = rows.iter().sum();
    let mut marginal = vec![0.0];
    let mut acc = 0.0;
    for (a, r) in rows.iter().enumerate() {
        acc += r;
        marginal.push(if total > 0.0 {
            acc / total
        } else {
            (a + 1) as f64 / (n_x - 1) as f64
        });
    }
    let mut conditional = Vec::with_capacity(n_x * n_y);
    for a in 0..n_x {
        let a = a.min(n_x - 2);
        let (mut acc, r) = (0.0, rows[a]);
        conditional.push(0.0);
        for b in 0..n_y - 1 {
            acc += w[a * (n_y - 1) + b];
            conditional.push(if r > 0.0 {
                acc / r
            } else {
                (b + 1) as f64 / (n_y - 1) as f64
            });
        }
    }
    (marginal, conditional)
}

/// One view direction drawn from a node's sampling tables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSample {
    /// The drawn projected half angles (β_x, β_y), degrees.
    pub half_deg: (f64, f64),
    /// The drawn cell `(a, b)` of the half-vector axes.
    pub cell: (usize, usize),
    /// ω_r, the light reflected about the drawn half vector (may lie below the horizon: the
    /// sample is then lost).
    pub wr: [f64; 3],
    /// Density per solid angle of ω_r, sr⁻¹ (0 for a lost sample).
    pub pdf_sr: f64,
}

/// The interval `k` of a CDF `cdf` (first value 0, last 1) holding `u`, and where `u` lies in
/// it (0–1).
fn interval(cdf: &[f64], u: f64) -> (usize, f64) {
    let k = (cdf.partition_point(|&c| c <= u).max(1) - 1).min(cdf.len() - 2);
    let (lo, hi) = (cdf[k], cdf[k + 1]);
    let t = if hi > lo {
        ((u - lo) / (hi - lo)).clamp(0.0, 1.0)
    } else {
        0.5
    };
    (k, t)
}

/// Draws ω_r for the light `wi` from one (θ_i, φ_i) node's sampling tables by the procedure of
/// the module documentation: `marginal` (one value per β_x node, channel `cdf_half_x`) picks a
/// β_x interval, `conditional` (β_x × β_y nodes, channel `cdf_half_y`) a β_y interval, and
/// (β_x, β_y) is uniform inside, from the remainders of the two uniforms `u` ∈ [0, 1)².
pub fn sample_view(
    grid: &HalfGrid,
    wi: [f64; 3],
    marginal: &[f64],
    conditional: &[f64],
    u: [f64; 2],
) -> ViewSample {
    let n_y = grid.half_y_deg.len();
    let (a, tx) = interval(marginal, u[0]);
    let (b, ty) = interval(&conditional[a * n_y..(a + 1) * n_y], u[1]);
    let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
    let bx = xs[a] + tx * (xs[a + 1] - xs[a]);
    let by = ys[b] + ty * (ys[b + 1] - ys[b]);
    let wr = reflect(wi, half_direction(bx, by));
    let pdf_sr = if wr[2] > 0.0 {
        view_pdf(grid, wi, marginal, conditional, wr)
    } else {
        0.0
    };
    ViewSample {
        half_deg: (bx, by),
        cell: (a, b),
        wr,
        pdf_sr,
    }
}

/// The density per solid angle of [`sample_view`] at `wr`:
/// `w_cell / (W Δβ_x Δβ_y J(β) 4(ω_i·h))` (the CDF increments being `w_cell / W`); 0 below
/// the horizon and outside the axes.
pub fn view_pdf(
    grid: &HalfGrid,
    wi: [f64; 3],
    marginal: &[f64],
    conditional: &[f64],
    wr: [f64; 3],
) -> f64 {
    if wr[2] <= 0.0 || wi[2] <= 0.0 {
        return 0.0;
    }
    let Some((a, b)) = grid.cell(wi, wr) else {
        return 0.0;
    };
    let h = half_of(wi, wr).expect("a cell has a half vector");
    let (bx, by) = half_angles_deg(h);
    let n_y = grid.half_y_deg.len();
    let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
    let row = &conditional[a * n_y..(a + 1) * n_y];
    let cell = (marginal[a + 1] - marginal[a]) * (row[b + 1] - row[b]);
    let area = (xs[a + 1] - xs[a]).to_radians() * (ys[b + 1] - ys[b]).to_radians();
    cell / (area * half_jacobian(bx, by) * 4.0 * dot(wi, h))
}

/// Deterministic low-discrepancy point `k` in [0, 1)^4 (Halton bases 2, 3, 5, 7).
pub fn halton4(k: usize) -> [f64; 4] {
    [2, 3, 5, 7].map(|base| {
        let (mut f, mut r, mut i) = (1.0, 0.0, k + 1);
        while i > 0 {
            f /= base as f64;
            r += f * (i % base) as f64;
            i /= base;
        }
        r
    })
}

/// Check point `k` (θ_i, φ_i, θ_r, φ_r in degrees) of [`interpolation_error`]: Halton point `k`
/// mapped uniformly in angle onto θ_i, θ_r in [`CHECK_THETA_DEG`], φ_i over
/// `phi_i_domain_deg` and φ_r over [−180°, 180°].
pub fn check_point(k: usize, phi_i_domain_deg: (f64, f64)) -> [f64; 4] {
    let (t0, t1) = CHECK_THETA_DEG;
    let (p0, p1) = phi_i_domain_deg;
    let u = halton4(k);
    [
        t0 + u[0] * (t1 - t0),
        p0 + u[1] * (p1 - p0),
        t0 + u[2] * (t1 - t0),
        -180.0 + 360.0 * u[3],
    ]
}

/// `(relative L2, max |Δ| / max reference)` of the luminance of `approx(q)` (RGB) against
/// `reference(q)` (a luminance) over the first `count` [`check_point`]s.
pub fn luminance_error(
    phi_i_domain_deg: (f64, f64),
    count: usize,
    reference: impl Fn([f64; 4]) -> f64,
    approx: impl Fn([f64; 4]) -> [f64; 3],
) -> (f64, f64) {
    let (mut num, mut den, mut max_d, mut max_f) = (0.0, 0.0, 0.0f64, 0.0f64);
    for k in 0..count {
        let q = check_point(k, phi_i_domain_deg);
        let exact = reference(q);
        let d = luminance(approx(q)) - exact;
        num += d * d;
        den += exact * exact;
        max_d = max_d.max(d.abs());
        max_f = max_f.max(exact);
    }
    (
        (num / den.max(f64::MIN_POSITIVE)).sqrt(),
        max_d / max_f.max(f64::MIN_POSITIVE),
    )
}

/// Interpolation error of a table against the model evaluated directly, at `count`
/// low-discrepancy points (θ_i, φ_i, θ_r, φ_r) uniform in angle over θ_i, θ_r in
/// [`CHECK_THETA_DEG`], φ_i over `phi_i_domain_deg` and φ_r over [−180°, 180°]
/// ([`check_point`]): `(relative L2, max |Δ| / max f)` of the luminance of f.
/// `lookup(θ_i, φ_i, θ_r, φ_r)` (degrees) is the table's f; `scale(θ_i, φ_i)` is the energy
/// factor the table applied (1 for the model as printed).
pub fn interpolation_error(
    model: &ClothModel,
    phi_i_domain_deg: (f64, f64),
    count: usize,
    lookup: impl Fn([f64; 4]) -> [f64; 3],
    scale: impl Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let reference = |q: [f64; 4]| {
        let r = q.map(f64::to_radians);
        luminance(model.eval_angles(r[0], r[1], r[2], r[3]).total()) * scale(q[0], q[1])
    };
    luminance_error(phi_i_domain_deg, count, reference, lookup)
}

/// Edges (degrees) of the cells whose centres are `centres`, the first at 0°.
pub fn theta_cell_edges_deg(centres: &[f64]) -> Vec<f64> {
    let mut edges = vec![0.0];
    for c in centres {
        let last = edges[edges.len() - 1];
        edges.push(2.0 * c - last);
    }
    edges
}

/// Energy figures of a table from the directional albedo at its (θ_i, φ_i) nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct AlbedoSummary {
    /// Hemispherical average `(1/π) ∫ ρ(ω_i) cos θ_i dω_i`, RGB.
    pub average: [f64; 3],
    /// Largest ρ over nodes and channels.
    pub max: f64,
    /// Per θ_i node, the largest ρ over φ_i and channels.
    pub max_per_theta_i: Vec<f64>,
    /// The first θ_i node (degrees) whose largest ρ exceeds 1.
    pub above_one_from_theta_i_deg: Option<f64>,
}

/// The energy figures of `albedo[θ_i][φ_i]` on `grid`.
pub fn albedo_summary(grid: &HalfGrid, albedo: &[Vec<[f64; 3]>]) -> AlbedoSummary {
    let edges = theta_cell_edges_deg(&grid.theta_i_deg);
    let n_phi = grid.phi_i_deg.len();
    let (mut average, mut norm) = ([0.0; 3], 0.0);
    let mut max_per_theta_i = Vec::with_capacity(albedo.len());
    for (k, (t, row)) in grid.theta_i_deg.iter().zip(albedo).enumerate() {
        let t = t.to_radians();
        let w = 2.0 * t.sin() * t.cos() * (edges[k + 1] - edges[k]).to_radians();
        norm += w;
        for c in 0..3 {
            // Trapezoid over the φ_i nodes of the fundamental domain.
            let sum: f64 = (0..n_phi - 1)
                .map(|k| 0.5 * (row[k][c] + row[k + 1][c]))
                .sum();
            average[c] += w * sum / (n_phi - 1) as f64;
        }
        max_per_theta_i.push(row.iter().flatten().cloned().fold(0.0, f64::max));
    }
    let max = max_per_theta_i.iter().cloned().fold(0.0, f64::max);
    let above_one_from_theta_i_deg = max_per_theta_i
        .iter()
        .position(|m| *m > 1.0)
        .map(|k| grid.theta_i_deg[k]);
    AlbedoSummary {
        average: average.map(|a| a / norm),
        max,
        max_per_theta_i,
        above_one_from_theta_i_deg,
    }
}

/// Multilinear interpolation of the stored `K` (RGB) of a table laid out as
/// θ_i × φ_i × β_x × β_y × [`CHANNELS`] on `grid`, at `q = (θ_i, φ_i, β_x, β_y)` (degrees, φ_i
/// inside the domain; clamped to the axes).
pub fn lookup_k(grid: &HalfGrid, data: &[f32], q: [f64; 4]) -> [f64; 3] {
    use crate::table::interp::{locate, multilinear};
    let axes = [
        &grid.theta_i_deg,
        &grid.phi_i_deg,
        &grid.half_x_deg,
        &grid.half_y_deg,
    ];
    let pos: Vec<(usize, f64)> = axes.iter().zip(q).map(|(a, x)| locate(a, x)).collect();
    let shape: Vec<usize> = axes.iter().map(|a| a.len()).collect();
    let nc = CHANNELS.len();
    [0, 1, 2].map(|c| multilinear(&pos, &shape, |flat| f64::from(data[flat * nc + c])))
}

/// The table's BRDF `f = K / cos θ_i` (RGB, 1/sr) at cloth-frame angles `q = (θ_i, φ_i, θ_r,
/// φ_r)` (degrees, φ_i inside the domain): the half angles of the pair, [`lookup_k`], 0 when
/// either direction is at or below the horizon.
pub fn lookup_f(grid: &HalfGrid, data: &[f32], q: [f64; 4]) -> [f64; 3] {
    let r = q.map(f64::to_radians);
    let (wi, wr) = (direction(r[0], r[1]), direction(r[2], r[3]));
    if wi[2] <= 0.0 || wr[2] <= 0.0 {
        return [0.0; 3];
    }
    let Some(h) = half_of(wi, wr) else {
        return [0.0; 3];
    };
    let (bx, by) = half_angles_deg(h);
    lookup_k(grid, data, [q[0], q[1], bx, by]).map(|k| k / wi[2])
}

#[cfg(test)]
mod tests {
    use super::super::{ModelOptions, preset};
    use super::*;

    fn coarse(name: &str) -> (ClothModel, HalfGrid) {
        let model = ClothModel::new(preset(name).unwrap(), ModelOptions::default());
        let spec = GridSpec {
            light_step_deg: 15.0,
            grazing_deg: 0.0,
            phi_i_step_deg: 15.0,
            half_fine: 1.0,
            half_coarse_deg: 10.0,
            ..GridSpec::default()
        };
        let grid = HalfGrid::new(model.fabric(), spec).unwrap();
        (model, grid)
    }

    /// A lobe narrower than the cells: with centre values the cell weights match a fine
    /// midpoint rule of the same `K` far better than the bilinear rule does; a dark centre
    /// between bright corners gives weights ≥ 0.
    #[test]
    fn centre_values_sharpen_the_cell_weights() {
        let (_, grid) = coarse("polyester_satin_front");
        let wi = direction(30f64.to_radians(), 10f64.to_radians());
        let (xs, ys) = (&grid.half_x_deg, &grid.half_y_deg);
        let lobe = |bx: f64, by: f64| {
            let v = (-0.5 * (((bx + 12.0) / 2.5).powi(2) + ((by - 3.0) / 4.0).powi(2))).exp();
            [v, 0.5 * v, 0.25 * v]
        };
        let nodes: Vec<[f64; 3]> = xs
            .iter()
            .flat_map(|&bx| ys.iter().map(move |&by| lobe(bx, by)))
            .collect();
        let centre =
            |a: usize, b: usize| lobe(0.5 * (xs[a] + xs[a + 1]), 0.5 * (ys[b] + ys[b + 1]));
        let centres: Vec<Option<[f64; 3]>> = (0..xs.len() - 1)
            .flat_map(|a| (0..ys.len() - 1).map(move |b| Some(centre(a, b))))
            .collect();
        let bilinear = cell_integrals(&grid, wi, &nodes, None);
        let sharp = cell_integrals(&grid, wi, &nodes, Some(&centres));
        // Reference: 40 × 40 midpoints per cell of the lobe itself.
        let n = 40;
        let mut reference = Vec::new();
        for a in 0..xs.len() - 1 {
            for b in 0..ys.len() - 1 {
                let (dx, dy) = (xs[a + 1] - xs[a], ys[b + 1] - ys[b]);
                let mut sum = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        let bx = xs[a] + (i as f64 + 0.5) / n as f64 * dx;
                        let by = ys[b] + (j as f64 + 0.5) / n as f64 * dy;
                        let h = half_direction(bx, by);
                        let wr = reflect(wi, h);
                        if wr[2] > 0.0 {
                            sum +=
                                lobe(bx, by)[0] * wr[2] * 4.0 * dot(wi, h) * half_jacobian(bx, by)
                                    / wi[2];
                        }
                    }
                }
                let area = (dx / n as f64).to_radians() * (dy / n as f64).to_radians();
                reference.push(sum * area);
            }
        }
        let total: f64 = reference.iter().sum();
        let err = |w: &[[f64; 3]]| {
            w.iter()
                .zip(&reference)
                .map(|(c, r)| (c[0] - r).abs())
                .sum::<f64>()
                / total
        };
        let (e_bilinear, e_sharp) = (err(&bilinear), err(&sharp));
        assert!(e_bilinear > 0.02, "{e_bilinear}");
        assert!(e_sharp < 0.2 * e_bilinear, "{e_sharp} vs {e_bilinear}");
        // Bright corners, dark centres.
        let dark = vec![Some([0.0; 3]); centres.len()];
        let ones = vec![[1.0; 3]; nodes.len()];
        let weights = cell_integrals(&grid, wi, &ones, Some(&dark));
        assert!(weights.iter().all(|w| w.iter().all(|&v| v >= 0.0)));
    }

    #[test]
    fn cdfs_end_at_one_and_increase() {
        let (model, grid) = coarse("silk_shot");
        assert_eq!(
            grid.phi_i_deg,
            vec![0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
        );
        let row = tabulate_row(&model, &grid, 2, EnergyMode::AsPrinted);
        assert_eq!(row.values.len(), grid.row_len());
        let (n_x, n_y) = (grid.half_x_deg.len(), grid.half_y_deg.len());
        for chunk in row.values.chunks(n_x * n_y * 5) {
            let at = |a: usize, b: usize, c: usize| chunk[(a * n_y + b) * 5 + c];
            assert_eq!(at(0, 0, 3), 0.0);
            assert!((at(n_x - 1, 0, 3) - 1.0).abs() < 1e-6);
            for a in 0..n_x {
                assert!((at(a, n_y - 1, 4) - 1.0).abs() < 1e-6);
                assert_eq!(at(a, 0, 4), 0.0);
                for b in 1..n_y {
                    assert!(at(a, b, 4) >= at(a, b - 1, 4));
                }
                if a > 0 {
                    assert!(at(a, 0, 3) >= at(a - 1, 0, 3));
                }
            }
        }
    }

    #[test]
    fn the_lookup_is_the_model_on_the_nodes() {
        let (model, grid) = coarse("polyester_satin_front");
        let row = tabulate_row(&model, &grid, 3, EnergyMode::AsPrinted);
        let mut data = vec![0.0f32; grid.row_len() * grid.theta_i_deg.len()];
        data[3 * grid.row_len()..4 * grid.row_len()].copy_from_slice(&row.values);
        let (ti, pi) = (grid.theta_i_deg[3], grid.phi_i_deg[2]);
        let wi = direction(ti.to_radians(), pi.to_radians());
        let h = half_direction(grid.half_x_deg[20], 0.0);
        let wr = reflect(wi, h);
        assert!(wr[2] > 0.0);
        let (tr, pr) = (wr[2].acos().to_degrees(), wr[1].atan2(wr[0]).to_degrees());
        let table = lookup_f(&grid, &data, [ti, pi, tr, pr]);
        let model_f = model.eval(wi, wr).total();
        for c in 0..3 {
            assert!(
                (table[c] - model_f[c]).abs() <= 1e-5 * model_f[c],
                "{table:?} {model_f:?}"
            );
        }
    }

    #[test]
    fn bad_grids_are_refused() {
        let f = preset("linen_plain").unwrap();
        let spec = |s, fine, max| GridSpec {
            phi_i_step_deg: s,
            half_fine: fine,
            half_max_deg: max,
            ..GridSpec::default()
        };
        assert!(HalfGrid::new(&f, spec(7.0, 0.35, 88.0)).is_err());
        assert!(HalfGrid::new(&f, spec(0.0, 0.35, 88.0)).is_err());
        let bad_band = GridSpec {
            grazing_step_deg: 3.0,
            ..GridSpec::default()
        };
        assert!(HalfGrid::new(&f, bad_band).is_err());
        assert!(HalfGrid::new(&f, spec(5.0, 0.0, 88.0)).is_err());
        assert!(HalfGrid::new(&f, spec(5.0, 0.35, 90.0)).is_err());
        let g = HalfGrid::new(&f, GridSpec::default()).unwrap();
        assert_eq!(g.phi_i_deg.len(), 10);
        assert_eq!(g.theta_i_deg.len(), 16);
        assert_eq!((g.theta_i_deg[7], g.theta_i_deg[8]), (75.0, 80.625));
        assert_eq!(g.half_x_deg, g.half_y_deg);
    }
}
