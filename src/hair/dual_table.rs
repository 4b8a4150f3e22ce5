//! The `hair-dual/1` table: Dual Scattering averages of a physical fibre (per roughness and
//! absorption) or of the artist-friendly model (per colour channel), one row per light
//! inclination θ_i, with the header that states its conventions. Layout: `docs/hair.md`.

use super::absorption::AbsorptionAxis;
use super::artist::{ArtistModel, ArtistNormalisation};
use super::diffuse::DIFFUSE_THETA_H_VARIANCE;
use super::dual::{DUAL_CHANNELS, HQuadrature};
use super::elliptic::DEFAULT_ORIENTATION_NODES;
use super::rows::{DUAL_TABLE_CHANNELS, DualSweep, artist_dual_row};
use super::tables::{ThetaRowTable, feature_attributes, theta_inside_blocks};
use crate::table::{Axis, Channel, Schema, TableContent};
use serde_json::{Map, Value, json};

/// A `hair-dual` table of checked parameters.
#[derive(Debug, Clone)]
pub struct DualTable {
    /// The physical fibre swept over roughness and absorption (its `sigma_a` are those of
    /// `absorption`); with `artist`, only `d_b` and `clamp` are used.
    pub sweep: DualSweep,
    /// The absorption axis (the artist model: one colour, `Rgb`).
    pub absorption: AbsorptionAxis,
    /// The artist-friendly model instead of the physical fibre.
    pub artist: Option<ArtistModel>,
    /// Samples of θ_i over [−90°, 90°], endpoints included.
    pub theta_count: usize,
    /// Gauss–Legendre nodes per h panel.
    pub quadrature_order: usize,
}

impl DualTable {
    /// The table of `sweep` (whose σ_a become those of `absorption`), or of `artist` when
    /// given.
    pub fn new(
        sweep: DualSweep,
        absorption: AbsorptionAxis,
        artist: Option<ArtistModel>,
        theta_count: usize,
        quadrature_order: usize,
    ) -> Self {
        DualTable {
            sweep: DualSweep {
                sigma_a: absorption.sigma_values(),
                ..sweep
            },
            absorption,
            artist,
            theta_count,
            quadrature_order,
        }
    }

    fn quadrature(&self) -> HQuadrature {
        HQuadrature {
            order: self.quadrature_order,
            ..HQuadrature::default()
        }
    }

    /// One θ row: `[roughness][absorption][16]` for the given quadrature.
    fn compute_row(&self, theta_rad: f64, quad: &HQuadrature) -> Vec<f64> {
        match &self.artist {
            Some(m) => artist_dual_row(m, theta_rad, self.sweep.d_b, self.sweep.clamp),
            None => self.sweep.row(theta_rad, quad),
        }
    }

    fn n_roughness(&self) -> usize {
        if self.artist.is_some() {
            1
        } else {
            self.sweep.roughness_deg.len()
        }
    }
}

impl ThetaRowTable for DualTable {
    fn theta_deg(&self) -> Vec<f64> {
        let n = self.theta_count;
        (0..n)
            .map(|i| -90.0 + 180.0 * i as f64 / (n - 1) as f64)
            .collect()
    }
    fn row_len(&self) -> usize {
        self.n_roughness() * self.absorption.len() * DUAL_TABLE_CHANNELS
    }
    /// Row: `[roughness][absorption][16 channels]` at this θ; change: the largest change of any
    /// of the 16 channels when the h-panels are halved (quadrature doubling; 0 for the artist
    /// model, which has no h quadrature).
    fn row_with_change(&self, theta: f64) -> (Vec<f64>, f64) {
        let q = self.quadrature();
        let row = self.compute_row(theta, &q);
        let check = if self.artist.is_some() {
            0.0
        } else {
            let fine = self.compute_row(theta, &q.doubled());
            row.iter()
                .zip(&fine)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        (row, check)
    }
    /// Roughness (physical model only) × absorption × θ_i.
    fn axes(&self) -> Vec<Axis> {
        let nt = self.theta_count;
        let mut axes = Vec::new();
        if self.artist.is_none() {
            axes.push(Axis::values(
                "roughness",
                "deg",
                self.sweep.roughness_deg.clone(),
            ));
        }
        axes.push(self.absorption.axis());
        axes.push(Axis::uniform(
            "theta",
            "deg",
            -90.0,
            180.0 / (nt - 1) as f64,
            nt,
        ));
        axes
    }
    fn channel_count(&self) -> usize {
        DUAL_TABLE_CHANNELS
    }
    fn content(&self, rows: &[&[f32]], doubling: f64) -> Result<TableContent, serde_json::Error> {
        let blocks = self.n_roughness() * self.absorption.len();
        let data = theta_inside_blocks(rows, blocks, DUAL_TABLE_CHANNELS);
        let mut attributes = self.common_attributes();
        match &self.artist {
            Some(m) => artist_attributes(m, &mut attributes)?,
            None => self.physical_attributes(doubling, &mut attributes),
        }
        self.absorption.describe(&mut attributes);
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("hair-dual", 1),
            description: "Dual Scattering averages of a hair fibre per light inclination".into(),
            axes: self.axes(),
            channels: dual_channels(),
            attributes,
            data,
        })
    }
}

impl DualTable {
    /// Attributes of both models: conventions of θ, the tangent, the azimuth and the measures.
    fn common_attributes(&self) -> Map<String, Value> {
        let mut attributes = Map::new();
        attributes.insert(
            "model".into(),
            json!(match self.artist {
                None => "physical",
                Some(_) => "artist",
            }),
        );
        attributes.insert("theta".into(), "light inclination θ_i from the normal plane (docs/decisions.md DS-1); +90° = along the tangent toward the tip; look the tables up with θ_i".into());
        attributes.insert("tangent".into(), "fibre tangent points root → tip; α > 0 shifts toward the tip; R is shifted toward the root (α_R < 0) (docs/decisions.md DS-23)".into());
        attributes.insert("azimuth".into(), "relative azimuth φ = φ_o − φ_i; φ = 0 back toward the light; forward half-space |φ| ≥ π/2, backward |φ| < π/2 (docs/decisions.md DS-21)".into());
        attributes.insert("energy_measure".into(), "a_H(θ_i) = ∫_{−π/2}^{π/2} ∫_{H} f_s(θ_i, θ_o, φ) cos²θ_o dφ dθ_o (power per unit curve irradiance, Zinke & Weber eq. 33/36), relative azimuth, no extra incident-azimuth average (docs/decisions.md DS-3)".into());
        attributes.insert("averages".into(), "ᾱ, β̄² are energy-weighted means of the lobe α_p and β_p² (variances, docs/decisions.md DS-7); ā is clamped before the closed forms".into());
        attributes.insert("a_clamp".into(), json!(self.sweep.clamp));
        attributes.insert("d_b".into(), json!(self.sweep.d_b));
        attributes.insert("closed_forms".into(), "ZYWK08 originals: (1 − ā_f²)³ in Ā_b, sqrt(2β̄_f² + 3β̄_b²) in σ̄_b, widths in its denominator kept verbatim, σ̄_b stored squared (docs/decisions.md DS-5, DS-6)".into());
        attributes.insert(
            "angles".into(),
            "radians inside the data; axis coordinates in degrees".into(),
        );
        attributes
    }

    /// Attributes of the physical model: fibre, lobes, quadrature and its doubling check, and
    /// the fibre features when used.
    fn physical_attributes(&self, doubling: f64, attributes: &mut Map<String, Value>) {
        let s = &self.sweep;
        attributes.insert("eta".into(), json!(s.eta));
        attributes.insert("fresnel".into(), json!(s.fresnel.name()));
        attributes.insert("cuticle_tilt_deg".into(), json!(s.cuticle_tilt_deg));
        attributes.insert("lobes".into(), "α_R = −α, α_TT = α/2, α_TRT = 3α/2, residual 0; β_TT = β_R/2, β_TRT = β_residual = 2β_R (Marschner 2003 Table 1)".into());
        attributes.insert(
            "azimuthal_width_ratio".into(),
            json!(s.azimuthal_width_ratio),
        );
        attributes.insert("fiber_model".into(), "smooth dielectric cylinder integrated over h (Zinke & Weber 2007 far field), Bravais geometry, internal chord 2cosγ_t/cosθ_t, orders p ≥ 3 lumped in a residual lobe uniform in φ, wrapped-normal azimuthal roughness w_φ = ratio·β_R; N_p evaluated at the incident inclination and longitudinal lobes normalised per lobe under the energy measure, so a lossless fibre conserves energy exactly".into());
        attributes.insert("quadrature".into(), json!({
                "rule": "composite Gauss–Legendre in γ_i = asin h, panels ≤ min(0.05 rad, w_φ/2), split where any exit azimuth crosses |φ| = π/2; closed-form (erf) azimuthal windows",
                "order": self.quadrature_order,
                "doubling_max_abs_change": doubling,
            }));
        feature_attributes(
            &s.diffuse,
            s.axis_ratio,
            DEFAULT_ORIENTATION_NODES,
            attributes,
        );
        if !s.diffuse.is_zero() {
            attributes.insert("diffuse_in_averages".into(), json!(format!(
                "ā_f, ā_b include the diffuse albedos (the E_p channels do not); ᾱ, β̄² include the diffuse term with its θ_h moments θ_i/2 and (π² − 6)/48 = {DIFFUSE_THETA_H_VARIANCE:.6} rad²; N^G are the lobes' only, add diffuse.forward_average in f_s^scatter (docs/decisions.md DS-32)"
            )));
        }
    }
}

/// Attributes of the artist-friendly model: its parameters and normalisation.
fn artist_attributes(
    m: &ArtistModel,
    attributes: &mut Map<String, Value>,
) -> Result<(), serde_json::Error> {
    attributes.insert("artist_params".into(), serde_json::to_value(&m.params)?);
    attributes.insert("normalization_k".into(), json!(m.k));
    attributes.insert("normalization".into(), match m.params.normalisation {
            ArtistNormalisation::PerInclination => "per-inclination: eq. 4.17 with one scalar per θ_i, K(θ_i) = max over RGB of the energy of f'_s at θ_i under the energy measure, glints included (G_angle averaged uniformly over its range), so ā_f + ā_b ≤ 1 for every θ_i and channel, = 1 for the brightest; normalization_k is K(0) (docs/decisions.md DS-4, DS-14)",
            ArtistNormalisation::NormalIncidence => "normal-incidence: eq. 4.17 with one scalar K = normalization_k = max over RGB of the energy of f'_s at θ_i = 0 under the energy measure, glints included (G_angle averaged uniformly over its range); ā_f + ā_b exceeds 1 toward grazing light (docs/decisions.md DS-4, DS-14)",
        }.into());
    attributes.insert(
        "longitudinal".into(),
        "unit-height g'(θ_h − α_X, β_X²)/cos²θ_d, cos²θ_d ≥ 1e-3 (docs/decisions.md DS-9, DS-18)"
            .into(),
    );
    Ok(())
}

/// Units and meanings of the 16 channels of a `hair-dual` table, in order.
const DUAL_CHANNEL_DOCS: [(&str, &str); DUAL_TABLE_CHANNELS] = [
    (
        "1",
        "ā_f: fraction of the light arriving at inclination θ scattered into |φ| ≥ π/2 (forward), clamped to ≤ clamp",
    ),
    (
        "1",
        "ā_b: fraction scattered into |φ| < π/2 (backward), clamped to ≤ clamp",
    ),
    (
        "rad",
        "ᾱ_f: energy-weighted mean longitudinal shift of the forward lobes (θ_h convention)",
    ),
    (
        "rad",
        "ᾱ_b: energy-weighted mean longitudinal shift of the backward lobes",
    ),
    (
        "rad^2",
        "β̄_f²: energy-weighted mean longitudinal variance β_p² of the forward lobes",
    ),
    (
        "rad^2",
        "β̄_b²: energy-weighted mean longitudinal variance of the backward lobes",
    ),
    (
        "1",
        "Ā_b = ā_b ā_f²/(1−ā_f²) + ā_b³ ā_f²/(1−ā_f²)³ (ZYWK08 eq. 14)",
    ),
    ("rad", "Δ̄_b (ZYWK08 eq. 16 / thesis 4.28)"),
    (
        "rad^2",
        "σ̄_b²: square of ZYWK08 eq. 17 with sqrt(2β̄_f² + 3β̄_b²) and d_b",
    ),
    (
        "1/rad",
        "N^G_R = (2/π)∫_{π/2}^{π} N_R dφ (artist: × C_R I_R / K)",
    ),
    (
        "1/rad",
        "N^G_TT = (2/π)∫_{π/2}^{π} N_TT dφ (artist: × C_TT I_TT / K)",
    ),
    (
        "1/rad",
        "N^G_TRT = (2/π)∫_{π/2}^{π} N_TRT dφ (artist: × C_TRT I_TRT / K)",
    ),
    ("1", "energy of lobe R, ∫∫ f_R cos²θ_o dθ_o dφ (unclamped)"),
    ("1", "energy of lobe TT"),
    ("1", "energy of lobe TRT"),
    (
        "1",
        "energy of the residual p ≥ 3 lobe (physical; 0 for the artist model)",
    ),
];

/// The 16 channels of a `hair-dual` table: the twelve Dual Scattering averages, then the
/// energy of each lobe.
pub fn dual_channels() -> Vec<Channel> {
    let names = DUAL_CHANNELS
        .iter()
        .copied()
        .chain(["E_R", "E_TT", "E_TRT", "E_residual"]);
    names
        .zip(DUAL_CHANNEL_DOCS)
        .map(|(name, (unit, meaning))| Channel::new(name, unit, meaning))
        .collect()
}
