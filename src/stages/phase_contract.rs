//! The phase-function table contract shared by every stage that tabulates a phase function of
//! scattering angle (`mie`, `debye`, `raytrace`) and read by every consumer (see
//! `docs/consumers.md`): a `wavelength` axis, any entry axes (e.g. `radius`), scattering angle
//! last, channels `phase`, `i_perp`,
//! `i_par`, `dolp` first, and the attributes below.
//!
//! One meaning of the channels in every such table (and in every command's output): `i_perp`
//! and `i_par` are the perpendicular and parallel components of the normalised phase function
//! (1/sr), `i_perp = |S1|²/(π x² Q_sca)` and `i_par = |S2|²/(π x² Q_sca)` for a sphere
//! (Bohren & Huffman amplitudes), in general (dσ/dΩ)_⊥,∥ / σ_sca; `phase = (i_perp + i_par)/2`
//! with ∫_{4π} phase dΩ = 1; `dolp = (i_perp − i_par)/(i_perp + i_par)`. Raw |S1|², |S2|²
//! (dimensionless) are never called `i_perp`/`i_par`: commands print them as `s1_sq`, `s2_sq`.

use crate::optics::water::WaterIndexModel;
use crate::table::Channel;
use serde_json::{Map, Value};

/// Names of the four leading channels of every phase-function table.
pub const CHANNELS: [&str; 4] = ["phase", "i_perp", "i_par", "dolp"];

/// The four leading channels; `normalisation` says what |S|² is divided by (e.g.
/// "over pi x^2 Q_sca").
pub fn channels(normalisation: &str) -> Vec<Channel> {
    vec![
        Channel::new(
            "phase",
            "1/sr",
            &format!("unpolarised phase function (i_perp + i_par)/2, {normalisation}"),
        ),
        Channel::new(
            "i_perp",
            "1/sr",
            &format!("|S1|^2 {normalisation}, perpendicular to the scattering plane"),
        ),
        Channel::new(
            "i_par",
            "1/sr",
            &format!("|S2|^2 {normalisation}, parallel to the scattering plane"),
        ),
        Channel::new("dolp", "1", "(i_perp - i_par)/(i_perp + i_par)"),
    ]
}

/// The attributes every phase-function table states: `normalization`, `angle_convention`,
/// `water_index_model` (and `temperature_c` for IAPWS), `medium`, `sun_diameter_deg` (the
/// name of the manifest key) and `interpolable_axes` (wavelength and scattering angle; a
/// stage with other fine axes overwrites it).
pub fn attributes(
    normalization: &str,
    model: &WaterIndexModel,
    sun_diameter_deg: f64,
) -> Map<String, Value> {
    let mut a = Map::new();
    a.insert("normalization".into(), normalization.into());
    a.insert(
        "angle_convention".into(),
        "scattering angle, 0 deg forward".into(),
    );
    a.insert("water_index_model".into(), model.name().into());
    if let WaterIndexModel::Iapws1997 { temperature_c } = model {
        a.insert("temperature_c".into(), (*temperature_c).into());
    }
    a.insert(
        "medium".into(),
        "water drops in air (outside index 1.0)".into(),
    );
    a.insert("sun_diameter_deg".into(), sun_diameter_deg.into());
    a.insert(
        INTERPOLABLE_AXES.into(),
        serde_json::json!(["wavelength", "scattering_angle"]),
    );
    a
}

/// Attribute naming the axes along which linear interpolation between samples is meaningful
/// (finely sampled spectral and angular axes); consumers take stored samples along every
/// other axis (radius, sun elevation, …) and refuse values between them.
pub const INTERPOLABLE_AXES: &str = "interpolable_axes";
