//! The `hair-azimuthal/1` table: the azimuthal scattering functions `N_p(θ, φ)` of a rough
//! dielectric fibre per absorption, one row per inclination θ, with the header that states
//! its conventions. Layout: `docs/hair.md`.

use super::absorption::AbsorptionAxis;
use super::diffuse::DiffuseTerms;
use super::elliptic::orientation_nodes_for_width;
use super::fiber::{FresnelModel, LOBE_NAMES};
use super::rows::AzimuthalSweep;
use super::tables::{ThetaRowTable, feature_attributes, theta_inside_blocks};
use crate::table::{Axis, Channel, Schema, TableContent};
use serde_json::{Map, json};

/// Channels of every `hair-azimuthal` table: the lobes and their sum (a `diffuse` channel
/// follows when a diffuse term is set).
const LOBE_CHANNELS: usize = 5;

/// A `hair-azimuthal` table of checked parameters.
#[derive(Debug, Clone)]
pub struct AzimuthalTable {
    /// Fibre index of refraction.
    pub eta: f64,
    pub fresnel: FresnelModel,
    /// Azimuthal roughness w_φ (wrapped normal std), deg.
    pub azimuthal_width_deg: f64,
    /// Gauss–Legendre nodes per h panel.
    pub quadrature_order: usize,
    pub diffuse: DiffuseTerms,
    /// Minor/major semi-axis ratio (1: circular).
    pub axis_ratio: f64,
    pub absorption: AbsorptionAxis,
    /// Samples of θ over [0°, 90°].
    pub theta_count: usize,
    /// Samples of φ over [0°, 180°].
    pub phi_count: usize,
}

impl AzimuthalTable {
    /// Orientation nodes of the elliptic TRT average for this table's azimuthal width.
    fn orientation_nodes(&self) -> usize {
        orientation_nodes_for_width(
            self.eta,
            self.axis_ratio,
            self.azimuthal_width_deg.to_radians(),
        )
    }

    /// One θ row; `panel_scale` 2 is the quadrature-doubling check.
    fn row(&self, theta_rad: f64, panel_scale: f64) -> Vec<f64> {
        AzimuthalSweep {
            eta: self.eta,
            fresnel: self.fresnel,
            width_rad: self.azimuthal_width_deg.to_radians(),
            quadrature_order: self.quadrature_order,
            diffuse: self.diffuse,
            axis_ratio: self.axis_ratio,
            orientation_nodes: self.orientation_nodes(),
            sigma_a: self.absorption.sigma_values(),
            phi_count: self.phi_count,
        }
        .row(theta_rad, panel_scale)
    }

    /// Channel descriptions: R, TT, TRT, residual, sum, and `diffuse` when a diffuse term is
    /// set.
    fn channels(&self) -> Vec<Channel> {
        let mut channels: Vec<Channel> = LOBE_NAMES
            .iter()
            .map(|n| Channel::new(n, "1/rad", "azimuthal scattering function N_p(θ, φ); ∫_{−π}^{π} N_p dφ = ½∫ a_p dh (lobe energy)"))
            .collect();
        channels[3].meaning = "orders p ≥ 3 lumped, uniform in φ (energy / 2π)".into();
        channels.push(Channel::new(
            "sum",
            "1/rad",
            "N_R + N_TT + N_TRT + residual; ∫_{−π}^{π} sum dφ = 1 for σ_a = 0",
        ));
        if !self.diffuse.is_zero() {
            channels.push(Channel::new(
                "diffuse",
                "1/rad",
                "diffuse BCSDF f_d(φ) (lambertian_kd and higher_order_kd terms), added to Σ_p M_p N_p / cos²θ_d without a longitudinal lobe; not in sum; ∫_{−π}^{π} diffuse dφ = 2 lambertian_kd + 4π higher_order_kd (docs/decisions.md FIB-21)",
            ));
        }
        channels
    }
}

impl ThetaRowTable for AzimuthalTable {
    fn theta_deg(&self) -> Vec<f64> {
        (0..self.theta_count)
            .map(|i| 90.0 * i as f64 / (self.theta_count - 1) as f64)
            .collect()
    }
    fn row_len(&self) -> usize {
        self.absorption.len() * self.phi_count * self.channel_count()
    }
    /// Row: `[absorption][φ][channel]` at this θ; change: the largest relative change (to the
    /// peak of the row) under quadrature doubling.
    fn row_with_change(&self, theta: f64) -> (Vec<f64>, f64) {
        let row = self.row(theta, 1.0);
        let fine = self.row(theta, 2.0);
        let peak = row.iter().cloned().fold(0.0, f64::max).max(1e-30);
        let change = row
            .iter()
            .zip(&fine)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / peak;
        (row, change)
    }
    /// Absorption × θ × φ.
    fn axes(&self) -> Vec<Axis> {
        let (nt, np) = (self.theta_count, self.phi_count);
        vec![
            self.absorption.axis(),
            Axis::uniform("theta", "deg", 0.0, 90.0 / (nt - 1) as f64, nt),
            Axis::uniform("phi", "deg", 0.0, 180.0 / (np - 1) as f64, np),
        ]
    }
    fn channel_count(&self) -> usize {
        if self.diffuse.is_zero() {
            LOBE_CHANNELS
        } else {
            LOBE_CHANNELS + 1
        }
    }
    fn content(&self, rows: &[&[f32]], change: f64) -> Result<TableContent, serde_json::Error> {
        let block = self.phi_count * self.channel_count();
        let data = theta_inside_blocks(rows, self.absorption.len(), block);
        let mut attributes = Map::new();
        attributes.insert("eta".into(), json!(self.eta));
        attributes.insert("fresnel".into(), json!(self.fresnel.name()));
        attributes.insert(
            "azimuthal_width_deg".into(),
            json!(self.azimuthal_width_deg),
        );
        attributes.insert("theta".into(), "inclination used for the Bravais indices, Fresnel and path length; N_p is even in θ. Marschner/Zinke look it up with θ_d = (θ_o − θ_i)/2; the energy-conserving DS model of scatterbake with θ_i (identical at the specular cone)".into());
        attributes.insert("azimuth".into(), "relative azimuth φ = φ_o − φ_i in [0°, 180°]; N_p(−φ) = N_p(φ); φ = 0 back toward the light".into());
        attributes.insert(
            "exit_azimuth".into(),
            "Φ_p(h) = 2γ_i − 2pγ_t + pπ, γ_i = asin h, sin γ_t = h/n' (Zinke & Weber eq. 17–19)"
                .into(),
        );
        attributes.insert("roughness".into(), "each lobe convolved with a wrapped normal of std azimuthal_width_deg (exactly normalised on the circle)".into());
        feature_attributes(
            &self.diffuse,
            self.axis_ratio,
            self.orientation_nodes(),
            &mut attributes,
        );
        attributes.insert(
            "quadrature".into(),
            json!({
                "rule": "composite Gauss–Legendre in γ_i = asin h, panels ≤ min(0.05 rad, w_φ/2)",
                "order": self.quadrature_order,
                "doubling_max_rel_change": change,
            }),
        );
        self.absorption.describe(&mut attributes);
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("hair-azimuthal", 1),
            description: "azimuthal scattering functions of a rough dielectric hair fibre".into(),
            axes: self.axes(),
            channels: self.channels(),
            attributes,
            data,
        })
    }
}
