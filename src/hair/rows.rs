//! Rows of the hair tables, one per light inclination θ: the Dual Scattering averages of a
//! physical fibre per (roughness, absorption) or of the artist model, and the azimuthal
//! scattering functions `N_p(θ, φ)` per (absorption, φ).

use super::artist::ArtistModel;
use super::diffuse::DiffuseTerms;
use super::dual::{
    HQuadrature, LobeShape, PhysicalFiber, combine_with_diffuse, elliptic_slices,
    orientation_averaged_energies,
};
use super::elliptic::orientation_indices;
use super::fiber::{FresnelModel, LOBES, OffsetQuadrature};

/// Channels of a Dual Scattering row entry: the twelve DS quantities, then the lobe energies.
pub const DUAL_TABLE_CHANNELS: usize = 16;

/// A physical fibre swept over roughness and absorption for Dual Scattering rows.
#[derive(Debug, Clone)]
pub struct DualSweep {
    pub eta: f64,
    pub fresnel: FresnelModel,
    /// Cuticle tilt α (deg).
    pub cuticle_tilt_deg: f64,
    /// Longitudinal R widths β_R (deg), the roughness axis.
    pub roughness_deg: Vec<f64>,
    /// Azimuthal roughness w_φ = ratio × β_R.
    pub azimuthal_width_ratio: f64,
    pub diffuse: DiffuseTerms,
    pub axis_ratio: f64,
    /// σ_a per unit radius, the absorption axis.
    pub sigma_a: Vec<f64>,
    /// Backscattering density factor of σ̄_b.
    pub d_b: f64,
    /// ā_f, ā_b are clamped to ≤ this before Ā_b, Δ̄_b, σ̄_b².
    pub clamp: f64,
}

impl DualSweep {
    /// The fibre of R width `beta_r_deg`.
    pub fn fiber(&self, beta_r_deg: f64) -> PhysicalFiber {
        PhysicalFiber {
            eta: self.eta,
            fresnel: self.fresnel,
            lobes: LobeShape::marschner(
                self.cuticle_tilt_deg.to_radians(),
                beta_r_deg.to_radians(),
            ),
            azimuthal_width_rad: self.azimuthal_width_ratio * beta_r_deg.to_radians(),
            diffuse: self.diffuse,
            axis_ratio: self.axis_ratio,
        }
    }

    /// One θ row: `[roughness][absorption][DUAL_TABLE_CHANNELS]` for the given quadrature.
    pub fn row(&self, theta_rad: f64, quad: &HQuadrature) -> Vec<f64> {
        let sigmas = &self.sigma_a;
        let w_min = self.azimuthal_width_ratio * self.roughness_deg[0].to_radians();
        let idx = orientation_indices(self.eta, self.axis_ratio, quad.orientation_nodes);
        let offs = quad.offsets_for(self.eta, &idx, theta_rad, w_min);
        let na = sigmas.len();
        let fibers: Vec<PhysicalFiber> =
            self.roughness_deg.iter().map(|&b| self.fiber(b)).collect();
        let (slice, variants) = elliptic_slices(&fibers[0], theta_rad, &idx, &offs);
        // Per roughness: the backward fractions of the slice, then of each orientation variant.
        let wbs: Vec<Vec<Vec<[f64; 3]>>> = fibers
            .iter()
            .map(|f| {
                std::iter::once(&slice)
                    .chain(&variants)
                    .map(|s| s.backward_fractions(f.azimuthal_width_rad))
                    .collect()
            })
            .collect();
        let mut out = vec![0.0; fibers.len() * na * DUAL_TABLE_CHANNELS];
        for (ia, &s) in sigmas.iter().enumerate() {
            let wa = slice.weighted_attenuations(s);
            for (ir, (fiber, wb)) in fibers.iter().zip(&wbs).enumerate() {
                let (eb, ef) = orientation_averaged_energies(&slice, &variants, &wa, wb);
                let ds = combine_with_diffuse(
                    &eb,
                    &ef,
                    &fiber.lobes,
                    &fiber.diffuse,
                    theta_rad,
                    self.d_b,
                    self.clamp,
                );
                let o = (ir * na + ia) * DUAL_TABLE_CHANNELS;
                out[o..o + 12].copy_from_slice(&ds.to_array());
                for p in 0..LOBES {
                    out[o + 12 + p] = eb[p] + ef[p];
                }
            }
        }
        out
    }
}

/// One θ row of the artist model: `[colour channel][DUAL_TABLE_CHANNELS]` (the lobe energies,
/// then 0).
pub fn artist_dual_row(model: &ArtistModel, theta_rad: f64, d_b: f64, clamp: f64) -> Vec<f64> {
    let mut out = Vec::new();
    for (ds, e) in model.dual_scattering(theta_rad, d_b, clamp) {
        out.extend(ds.to_array());
        out.extend(e);
        out.push(0.0);
    }
    out
}

/// A rough fibre swept over absorption and φ for azimuthal rows.
#[derive(Debug, Clone)]
pub struct AzimuthalSweep {
    pub eta: f64,
    pub fresnel: FresnelModel,
    /// Azimuthal roughness w_φ (rad).
    pub width_rad: f64,
    /// Gauss–Legendre nodes per h panel.
    pub quadrature_order: usize,
    pub diffuse: DiffuseTerms,
    pub axis_ratio: f64,
    /// Orientation nodes of the elliptic TRT average.
    pub orientation_nodes: usize,
    /// σ_a per unit radius, the absorption axis.
    pub sigma_a: Vec<f64>,
    /// Samples of φ over [0, π].
    pub phi_count: usize,
}

impl AzimuthalSweep {
    /// One θ row `[absorption][φ][channel]` with channels R, TT, TRT, residual, their sum and,
    /// when a diffuse term is set, the diffuse BCSDF; `panel_scale` divides the h panels and
    /// multiplies the orientation nodes (2: the quadrature-doubling check).
    pub fn row(&self, theta_rad: f64, panel_scale: f64) -> Vec<f64> {
        let w = self.width_rad;
        let quad = OffsetQuadrature::new(
            (0.05f64).min(0.5 * w) / panel_scale,
            self.quadrature_order,
            &[],
        );
        let nodes = (self.orientation_nodes as f64 * panel_scale) as usize;
        let idx = orientation_indices(self.eta, self.axis_ratio, nodes);
        // Only the index, Fresnel model and axis ratio matter for the slices (lobes unused).
        let fibre = PhysicalFiber {
            diffuse: self.diffuse,
            axis_ratio: self.axis_ratio,
            ..PhysicalFiber::new(self.eta, self.fresnel, LobeShape::marschner(0.0, 0.1), w)
        };
        let (slice, variants) = elliptic_slices(&fibre, theta_rad, &idx, &quad);
        let n = self.phi_count;
        let step = std::f64::consts::PI / (n - 1) as f64;
        let diffuse: Vec<f64> = (0..n)
            .map(|j| self.diffuse.bcsdf(step * j as f64))
            .collect();
        let mut out = Vec::new();
        for &s in &self.sigma_a {
            let mut grid = slice.azimuthal_on_grid(s, w, 0.0, step, n);
            if !variants.is_empty() {
                // TRT averaged over the orientation nodes (FIB-24); R, TT, residual unchanged.
                let mut trt = vec![0.0; n];
                for v in &variants {
                    let g = v.azimuthal_on_grid_lobes(s, w, 0.0, step, n, &[2]);
                    for (t, g) in trt.iter_mut().zip(g) {
                        *t += g[2];
                    }
                }
                for (g, t) in grid.iter_mut().zip(&trt) {
                    g[2] = t / variants.len() as f64;
                }
            }
            for (j, v) in grid.iter().enumerate() {
                out.extend([v[0], v[1], v[2], v[3], v.iter().sum()]);
                if !self.diffuse.is_zero() {
                    out.push(diffuse[j]);
                }
            }
        }
        out
    }
}
