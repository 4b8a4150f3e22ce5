//! Patch-based wave-optics ray tracer for raindrops (Sadeghi 2012, PhD thesis, ch. 3; Sadeghi et
//! al. 2012). See `docs/raytrace.md` for the algorithm, conventions and measured accuracy, and
//! `docs/decisions.md` (RT-1 … RT-22) for the decisions on points the thesis leaves open.
//!
//! - [`shape`]: spheres, Beard–Chuang cosine-series drops, tabulated axisymmetric profiles;
//! - [`tracer`]: the general 2-D patch tracer (any shape, any sun elevation), with the radial
//!   ray densities of its silhouette grids in [`ray_density`];
//! - [`sphere1d`]: the fast exact 1-D geometric-optics-plus-phase path for spheres;
//! - [`post`]: the Gaussian diffraction filter and the forward Fraunhofer lobe;
//! - [`caustic`]: the caustic windows of 2-D table columns and their filters;
//! - [`compact`]: compact 2-D entries, seen through the sun's disc and resampled adaptively;
//! - [`table2d`]: one entry of a 2-D table from a trace (filters, lobe, added sphere orders,
//!   mirror symmetry);
//! - [`phase_table`]: the tables `raytrace-phase/2` and `raytrace-phase-2d/2` (entries, axes,
//!   channels, renormalisation), their header texts ([`phase_table_headers`]) and the compact
//!   form of 2-D tables ([`compact_table`]);
//! - [`mixture`]: drop-size mixtures of Lorenz–Mie and traced spheres.
//!
//! The `raytrace` and `mixture` stages (schemas `raytrace-phase/2`, `raytrace-phase-2d/2`,
//! `mixture-phase/1`) are [`crate::stages::raytrace`] and [`crate::stages::mixture`]: they check
//! the parameters, lay out the tasks and call these modules.

pub mod caustic;
pub mod compact;
pub mod compact_table;
pub mod domain;
pub mod mixture;
pub mod phase_table;
pub mod phase_table_headers;
pub mod post;
pub mod ray_density;
pub mod shape;
pub mod sphere1d;
pub mod table2d;
pub mod tracer;

/// A phase function of scattering angle in the phase-table normalisation (1/sr):
/// `i_perp = (dσ/dΩ)_⊥/σ`, `i_par = (dσ/dΩ)_∥/σ`, `phase = (i_perp + i_par)/2`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhaseCurves {
    /// Scattering angles (deg).
    pub angle_deg: Vec<f64>,
    pub phase: Vec<f64>,
    pub i_perp: Vec<f64>,
    pub i_par: Vec<f64>,
}

/// Channel names of a ray-traced phase table, in order: the phase-table contract's four (phase,
/// i_perp, i_par, dolp), then, with `diagnostic`, the per-order (filtered) phase functions
/// p = 0..=max_order and the unfiltered phase, i_perp and i_par.
pub fn channel_names(max_order: usize, diagnostic: bool) -> Vec<String> {
    let mut v: Vec<String> = ["phase", "i_perp", "i_par", "dolp"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    if !diagnostic {
        return v;
    }
    for p in 0..=max_order {
        v.push(format!("phase_p{p}"));
    }
    v.extend(
        ["phase_unfiltered", "i_perp_unfiltered", "i_par_unfiltered"]
            .iter()
            .map(|s| s.to_string()),
    );
    v
}
