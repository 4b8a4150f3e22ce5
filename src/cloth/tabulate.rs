//! The fabric BRDF on angle grids, for tables: values, directional albedo and sampling CDFs.
//!
//! Grid ([`AngleGrid`], step `h` degrees, `90/h` an integer):
//! - θ_i and θ_r at the cell centres `(k + ½)h`, `k = 0 … 90/h − 1` (never 0° or 90°: the BRDF
//!   diverges toward θ_i = 90° and is discontinuous at θ_r = 90°);
//! - φ_i at the nodes `lo + k h` of the fabric's fundamental domain `[lo, hi]`
//!   ([`super::Symmetry::phi_i_domain_deg`]), both ends included;
//! - φ_r at the nodes `−180° + k h`, `k = 0 … 360/h`: the last node repeats the first, so
//!   clamped multilinear interpolation is periodic in φ_r.
//!
//! Per (θ_i, φ_i) the hemisphere of ω_r is split into cells `[θ_r ± h/2] × [φ_r,l, φ_r,l+1]`
//! with weight `w = ½(Y_l + Y_{l+1}) sin θ_r cos θ_r Δθ Δφ` (Y = Rec. 709 luminance of f at the
//! cell's θ_r centre and φ_r ends). The directional albedo is the same midpoint/trapezoid sum
//! per channel. The sampling tables are the marginal CDF over θ_r cells (value at the upper edge
//! of cell k, stored at θ_r,k) and the conditional CDF over φ_r (value at node l = weight of the
//! intervals before it), so a sample picks a cell by two binary searches and places ω_r
//! uniformly in (θ_r, φ_r) inside it; its pdf per solid angle is
//! `w_cell / (W Δθ Δφ sin θ_r)` ([`sample_view`], [`view_pdf`]).

use super::brdf::{ClothModel, PreparedDirection, direction};
use super::fabric::Symmetry;

/// Channels of one table entry.
pub const CHANNELS: [&str; 5] = ["r", "g", "b", "cdf_theta_r", "cdf_phi_r"];

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
#[error("the angle step {0}° must divide 90° (between 0.25° and 30°)")]
pub struct GridError(pub f64);

/// The table grid of one fabric.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleGrid {
    /// Step h, degrees.
    pub step_deg: f64,
    /// θ cell centres (shared by θ_i and θ_r), degrees.
    pub theta_deg: Vec<f64>,
    /// φ_i nodes over the fundamental domain, degrees.
    pub phi_i_deg: Vec<f64>,
    /// φ_r nodes over [−180°, 180°], degrees.
    pub phi_r_deg: Vec<f64>,
}

impl AngleGrid {
    /// The grid of step `step_deg` for a fabric with `symmetry`.
    pub fn new(symmetry: Symmetry, step_deg: f64) -> Result<Self, GridError> {
        let n = 90.0 / step_deg;
        if !(0.25..=30.0).contains(&step_deg) || (n - n.round()).abs() > 1e-9 {
            return Err(GridError(step_deg));
        }
        let n = n.round() as usize;
        let (lo, hi) = symmetry.phi_i_domain_deg();
        let n_phi_i = ((hi - lo) / step_deg).round() as usize;
        Ok(AngleGrid {
            step_deg,
            theta_deg: (0..n).map(|k| (k as f64 + 0.5) * step_deg).collect(),
            phi_i_deg: (0..=n_phi_i).map(|k| lo + k as f64 * step_deg).collect(),
            phi_r_deg: (0..=4 * n).map(|k| -180.0 + k as f64 * step_deg).collect(),
        })
    }

    /// Values of one θ_i row: φ_i × θ_r × φ_r × channels.
    pub fn row_len(&self) -> usize {
        self.phi_i_deg.len() * self.theta_deg.len() * self.phi_r_deg.len() * CHANNELS.len()
    }
}

/// One θ_i row of the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// φ_i × θ_r × φ_r × [`CHANNELS`].
    pub values: Vec<f32>,
    /// Directional albedo of the model as printed, per φ_i, RGB.
    pub albedo: Vec<[f64; 3]>,
    /// Factor applied to each φ_i's values (1 unless [`EnergyMode::Clamp`] reduced them).
    pub scale: Vec<f64>,
}

/// The view directions of the grid, prepared once per row.
fn prepared_views(model: &ClothModel, grid: &AngleGrid) -> Vec<PreparedDirection> {
    let mut out = Vec::with_capacity(grid.theta_deg.len() * grid.phi_r_deg.len());
    for t in &grid.theta_deg {
        for p in &grid.phi_r_deg {
            out.push(model.prepare(direction(t.to_radians(), p.to_radians())));
        }
    }
    out
}

/// The θ_i row `ti` of the table of `model` on `grid`.
pub fn tabulate_row(model: &ClothModel, grid: &AngleGrid, ti: usize, energy: EnergyMode) -> Row {
    let views = prepared_views(model, grid);
    let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
    let theta_i = grid.theta_deg[ti].to_radians();
    let mut row = Row {
        values: Vec::with_capacity(grid.row_len()),
        albedo: Vec::new(),
        scale: Vec::new(),
    };
    for phi_i in &grid.phi_i_deg {
        let wi = model.prepare(direction(theta_i, phi_i.to_radians()));
        let f: Vec<[f64; 3]> = views
            .iter()
            .map(|v| model.eval_prepared(&wi, v).total())
            .collect();
        let albedo = albedo_of(grid, &f);
        let peak = albedo.iter().cloned().fold(0.0, f64::max);
        let scale = match energy {
            EnergyMode::Clamp if peak > 1.0 => 1.0 / peak,
            _ => 1.0,
        };
        let (marginal, conditional) = cdfs(grid, &f);
        for a in 0..n_t {
            for b in 0..n_p {
                let v = f[a * n_p + b];
                row.values.extend(v.map(|x| (x * scale) as f32));
                row.values.push(marginal[a] as f32);
                row.values.push(conditional[a * n_p + b] as f32);
            }
        }
        row.albedo.push(albedo);
        row.scale.push(scale);
    }
    row
}

/// Per-cell weights `½(g_l + g_{l+1}) sin θ cos θ Δθ Δφ` of a quantity `g` on the grid of
/// views (θ_r-major, φ_r nodes).
fn cell_weights(grid: &AngleGrid, g: impl Fn(usize) -> f64) -> Vec<f64> {
    let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
    let h = grid.step_deg.to_radians();
    let mut w = Vec::with_capacity(n_t * (n_p - 1));
    for a in 0..n_t {
        let t = grid.theta_deg[a].to_radians();
        let jac = t.sin() * t.cos() * h * h;
        for b in 0..n_p - 1 {
            w.push(0.5 * (g(a * n_p + b) + g(a * n_p + b + 1)) * jac);
        }
    }
    w
}

/// Directional albedo (RGB) of one incident direction from its grid of BRDF values.
pub fn albedo_of(grid: &AngleGrid, f: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|c| cell_weights(grid, |k| f[k][c]).iter().sum())
}

/// Marginal CDF over θ_r cells (one per θ_r) and conditional CDFs over φ_r (one per view
/// node) of the luminance-weighted cells. A row of zero weight gets uniform CDFs.
pub fn cdfs(grid: &AngleGrid, f: &[[f64; 3]]) -> (Vec<f64>, Vec<f64>) {
    let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
    let w = cell_weights(grid, |k| luminance(f[k]));
    let rows: Vec<f64> = w.chunks(n_p - 1).map(|r| r.iter().sum()).collect();
    let total: f64 = rows.iter().sum();
    let mut marginal = Vec::with_capacity(n_t);
    let mut acc = 0.0;
    for (a, r) in rows.iter().enumerate() {
        acc += r;
        marginal.push(if total > 0.0 {
            acc / total
        } else {
            (a + 1) as f64 / n_t as f64
        });
    }
    let mut conditional = Vec::with_capacity(n_t * n_p);
    for (a, r) in rows.iter().enumerate() {
        let mut acc = 0.0;
        conditional.push(0.0);
        for b in 0..n_p - 1 {
            acc += w[a * (n_p - 1) + b];
            conditional.push(if *r > 0.0 {
                acc / r
            } else {
                (b + 1) as f64 / (n_p - 1) as f64
            });
        }
    }
    (marginal, conditional)
}

/// One view direction drawn from a node's sampling tables, with its density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewSample {
    /// θ_r, radians.
    pub theta_r_rad: f64,
    /// φ_r in [−π, π], radians.
    pub phi_r_rad: f64,
    /// Density per solid angle, sr⁻¹.
    pub pdf_sr: f64,
}

/// The (θ_r cell, φ_r interval) that holds `(theta_r_rad, phi_r_rad)` (θ_r in [0, π/2],
/// φ_r in [−π, π]; the ends land in the end cells).
pub fn view_cell(grid: &AngleGrid, theta_r_rad: f64, phi_r_rad: f64) -> (usize, usize) {
    let h = grid.step_deg;
    let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
    let k = ((theta_r_rad.to_degrees() / h).floor().max(0.0) as usize).min(n_t - 1);
    let l = (((phi_r_rad.to_degrees() + 180.0) / h).floor().max(0.0) as usize).min(n_p - 2);
    (k, l)
}

/// Draws ω_r from one (θ_i, φ_i) node's sampling tables by the procedure of the module
/// documentation: `marginal` (one value per θ_r cell, channel `cdf_theta_r`) picks the θ_r cell,
/// `conditional` (θ_r × φ_r nodes, channel `cdf_phi_r`) a φ_r interval of it, and ω_r is uniform
/// in (θ_r, φ_r) inside, from the remainders of the two uniforms `u` ∈ [0, 1)².
pub fn sample_view(
    grid: &AngleGrid,
    marginal: &[f64],
    conditional: &[f64],
    u: [f64; 2],
) -> ViewSample {
    let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
    let k = marginal.partition_point(|&m| m <= u[0]).min(n_t - 1);
    let lo = if k > 0 { marginal[k - 1] } else { 0.0 };
    let row = &conditional[k * n_p..(k + 1) * n_p];
    let l = (row.partition_point(|&c| c <= u[1]).max(1) - 1).min(n_p - 2);
    let within = |x: f64, a: f64, b: f64| {
        if b > a {
            ((x - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            0.5
        }
    };
    let h = grid.step_deg.to_radians();
    let theta_r_rad = (k as f64 + within(u[0], lo, marginal[k])) * h;
    let phi_r_rad = -std::f64::consts::PI + (l as f64 + within(u[1], row[l], row[l + 1])) * h;
    ViewSample {
        theta_r_rad,
        phi_r_rad,
        pdf_sr: view_pdf(grid, marginal, conditional, theta_r_rad, phi_r_rad),
    }
}

/// The density per solid angle of [`sample_view`] at `(theta_r_rad, phi_r_rad)`:
/// `w_cell / (W Δθ Δφ sin θ_r)`, the CDF increments being `w_cell / W`.
pub fn view_pdf(
    grid: &AngleGrid,
    marginal: &[f64],
    conditional: &[f64],
    theta_r_rad: f64,
    phi_r_rad: f64,
) -> f64 {
    let n_p = grid.phi_r_deg.len();
    let (k, l) = view_cell(grid, theta_r_rad, phi_r_rad);
    let lo = if k > 0 { marginal[k - 1] } else { 0.0 };
    let cell = (marginal[k] - lo) * (conditional[k * n_p + l + 1] - conditional[k * n_p + l]);
    let h = grid.step_deg.to_radians();
    cell / (h * h * theta_r_rad.sin().max(f64::MIN_POSITIVE))
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

/// Interpolation error of a table against the model evaluated directly, at `count`
/// low-discrepancy points inside the grid: `(relative L2, max |Δ| / max f)` of the luminance.
/// `lookup(θ_i, φ_i, θ_r, φ_r)` (degrees) interpolates the table; `scale(θ_i, φ_i)` is the
/// energy factor the table applied (1 for the model as printed).
pub fn interpolation_error(
    model: &ClothModel,
    grid: &AngleGrid,
    count: usize,
    lookup: impl Fn([f64; 4]) -> [f64; 3],
    scale: impl Fn(f64, f64) -> f64,
) -> (f64, f64) {
    let t = &grid.theta_deg;
    let (t0, t1) = (t[0], t[t.len() - 1]);
    let (p0, p1) = (grid.phi_i_deg[0], grid.phi_i_deg[grid.phi_i_deg.len() - 1]);
    let (mut num, mut den, mut max_d, mut max_f) = (0.0, 0.0, 0.0f64, 0.0f64);
    for k in 0..count {
        let u = halton4(k);
        let q = [
            t0 + u[0] * (t1 - t0),
            p0 + u[1] * (p1 - p0),
            t0 + u[2] * (t1 - t0),
            -180.0 + 360.0 * u[3],
        ];
        let direct = model
            .eval_angles(
                q[0].to_radians(),
                q[1].to_radians(),
                q[2].to_radians(),
                q[3].to_radians(),
            )
            .total();
        let exact = luminance(direct) * scale(q[0], q[1]);
        let approx = luminance(lookup(q));
        num += (approx - exact).powi(2);
        den += exact * exact;
        max_d = max_d.max((approx - exact).abs());
        max_f = max_f.max(exact);
    }
    ((num / den.max(f64::MIN_POSITIVE)).sqrt(), max_d / max_f)
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
pub fn albedo_summary(grid: &AngleGrid, albedo: &[Vec<[f64; 3]>]) -> AlbedoSummary {
    let h = grid.step_deg.to_radians();
    let n_phi = grid.phi_i_deg.len();
    let (mut average, mut norm) = ([0.0; 3], 0.0);
    let mut max_per_theta_i = Vec::with_capacity(albedo.len());
    for (t, row) in grid.theta_deg.iter().zip(albedo) {
        let t = t.to_radians();
        let w = 2.0 * t.sin() * t.cos() * h;
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
        .map(|k| grid.theta_deg[k]);
    AlbedoSummary {
        average: average.map(|a| a / norm),
        max,
        max_per_theta_i,
        above_one_from_theta_i_deg,
    }
}

/// Multilinear interpolation of the RGB channels of a table laid out as
/// θ_i × φ_i × θ_r × φ_r × [`CHANNELS`] on `grid`, at `q` (degrees, φ_i inside the domain).
pub fn lookup_rgb(grid: &AngleGrid, data: &[f32], q: [f64; 4]) -> [f64; 3] {
    use crate::table::interp::{locate, multilinear};
    let axes = [
        &grid.theta_deg,
        &grid.phi_i_deg,
        &grid.theta_deg,
        &grid.phi_r_deg,
    ];
    let pos: Vec<(usize, f64)> = axes.iter().zip(q).map(|(a, x)| locate(a, x)).collect();
    let shape: Vec<usize> = axes.iter().map(|a| a.len()).collect();
    let nc = CHANNELS.len();
    [0, 1, 2].map(|c| multilinear(&pos, &shape, |flat| f64::from(data[flat * nc + c])))
}

#[cfg(test)]
mod tests {
    use super::super::{ModelOptions, preset};
    use super::*;

    #[test]
    fn cdfs_end_at_one_and_increase() {
        let model = ClothModel::new(preset("silk_shot").unwrap(), ModelOptions::default());
        let grid = AngleGrid::new(model.fabric().symmetry(), 15.0).unwrap();
        assert_eq!(
            grid.phi_i_deg,
            vec![0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
        );
        let row = tabulate_row(&model, &grid, 2, EnergyMode::AsPrinted);
        assert_eq!(row.values.len(), grid.row_len());
        let (n_t, n_p) = (grid.theta_deg.len(), grid.phi_r_deg.len());
        for chunk in row.values.chunks(n_t * n_p * 5) {
            let at = |a: usize, b: usize, c: usize| chunk[(a * n_p + b) * 5 + c];
            assert!((at(n_t - 1, 0, 3) - 1.0).abs() < 1e-6);
            for a in 0..n_t {
                assert!((at(a, n_p - 1, 4) - 1.0).abs() < 1e-6);
                assert_eq!(at(a, 0, 4), 0.0);
                for b in 1..n_p {
                    assert!(at(a, b, 4) >= at(a, b - 1, 4));
                }
            }
        }
    }

    #[test]
    fn steps_that_do_not_divide_90_are_refused() {
        let s = preset("linen_plain").unwrap().symmetry();
        assert!(AngleGrid::new(s, 7.0).is_err());
        assert!(AngleGrid::new(s, 0.0).is_err());
        let g = AngleGrid::new(s, 5.0).unwrap();
        assert_eq!(g.phi_i_deg.len(), 10);
        assert_eq!(g.phi_r_deg.len(), 73);
    }
}
