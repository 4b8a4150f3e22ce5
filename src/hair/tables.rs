//! What the two hair tables share: one row per inclination θ with its largest change under
//! quadrature doubling ([`ThetaRowTable`]), the layout that moves θ inside each block of a row,
//! and the header attributes of the fibre features (diffuse terms, elliptic cross-section).
//! The tables themselves: [`super::dual_table`] (`hair-dual/1`) and
//! [`super::azimuthal_table`] (`hair-azimuthal/1`).

use super::diffuse::DiffuseTerms;
use crate::table::{Axis, TableContent};
use rayon::prelude::*;
use serde_json::{Map, Value, json};

/// A hair table computed one row per inclination θ. The stages run one row per task;
/// [`ThetaRowTable::compute`] computes the whole table at once with the same values.
pub trait ThetaRowTable: Sync {
    /// The inclinations θ of the rows (deg), in table order.
    fn theta_deg(&self) -> Vec<f64>;
    /// Values per row.
    fn row_len(&self) -> usize;
    /// The row at `theta_rad` and its largest change under quadrature doubling.
    fn row_with_change(&self, theta_rad: f64) -> (Vec<f64>, f64);
    /// The table's axes.
    fn axes(&self) -> Vec<Axis>;
    /// Channels per table entry.
    fn channel_count(&self) -> usize;
    /// The table from its stored rows (f32, in θ order, each [`Self::row_len`] long) and the
    /// largest doubling change of any row.
    fn content(&self, rows: &[&[f32]], change: f64) -> Result<TableContent, serde_json::Error>;

    /// The whole table: every row (in parallel over θ), then [`Self::content`].
    fn compute(&self) -> Result<TableContent, serde_json::Error> {
        let rows: Vec<(Vec<f32>, f64)> = self
            .theta_deg()
            .par_iter()
            .map(|t| {
                let (row, change) = self.row_with_change(t.to_radians());
                (row.iter().map(|&v| v as f32).collect(), change)
            })
            .collect();
        let change = rows.iter().fold(0.0, |m: f64, r| m.max(r.1));
        let stored: Vec<&[f32]> = rows.iter().map(|r| r.0.as_slice()).collect();
        self.content(&stored, change)
    }
}

/// Rows of a [`ThetaRowTable`] (each `blocks` blocks of `block` values) with θ moved inside
/// each block: the table data, block-major, then θ.
pub fn theta_inside_blocks(rows: &[&[f32]], blocks: usize, block: usize) -> Vec<f32> {
    let nt = rows.len();
    let mut data = vec![0f32; blocks * nt * block];
    for (it, row) in rows.iter().enumerate() {
        for b in 0..blocks {
            let dst = (b * nt + it) * block;
            data[dst..dst + block].copy_from_slice(&row[b * block..(b + 1) * block]);
        }
    }
    data
}

/// Header attributes of the diffuse terms and the elliptic cross-section (only when used, so
/// that the headers of circular fibres without diffuse terms are unchanged).
pub fn feature_attributes(
    diffuse: &DiffuseTerms,
    axis_ratio: f64,
    orientation_nodes: usize,
    attributes: &mut Map<String, Value>,
) {
    if !diffuse.is_zero() {
        let (ab, af) = diffuse.hemisphere_albedos();
        attributes.insert(
            "diffuse".into(),
            json!({
                "lambertian_kd": diffuse.lambertian_kd,
                "higher_order_kd": diffuse.higher_order_kd,
                "bcsdf": "f_d(φ) = (lambertian_kd/4)(sin|φ| + (π−|φ|) cos φ) + 2·higher_order_kd, per radian, independent of θ_i and θ_o; f_s = Σ_p M_p N_p / cos²θ_d + f_d (docs/decisions.md FIB-21)",
                "albedo": diffuse.albedo(),
                "albedo_backward": ab,
                "albedo_forward": af,
                "forward_average": diffuse.forward_average(),
            }),
        );
    }
    if axis_ratio != 1.0 {
        attributes.insert(
            "elliptic".into(),
            json!({
                "axis_ratio": axis_ratio,
                "model": "Marschner et al. 2003 first order: TRT exit azimuth with η*(ψ) = ½(η*₁+η*₂) − ½cos(2ψ)(η*₁−η*₂), η*₁ = 2(η−1)a² − η + 2, η*₂ = 2(η−1)/a² − η + 2, ψ = φ_h − φ_major; η* replaces η before the Bravais index; Fresnel and chords use η; R, TT, residual circular (docs/decisions.md FIB-22, FIB-23)",
                "orientation": "TRT averaged over the orientation of the major axis (uniform), so the table stays a function of (θ, φ) (docs/decisions.md FIB-24)",
                "orientation_nodes": orientation_nodes,
            }),
        );
    }
}
