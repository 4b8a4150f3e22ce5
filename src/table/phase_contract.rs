//! The phase-function table contract shared by every stage that tabulates a phase function of
//! scattering angle (`mie`, `debye`, `raytrace`) and read by every consumer (see
//! `docs/consumers.md`): a `wavelength` axis, any entry axes (e.g. `radius`), scattering angle
//! last, channels `phase`, `i_perp`,
//! `i_par`, `dolp` first, and the attributes below.

use super::Channel;
use crate::optics::water::WaterIndexModel;
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
/// `water_index_model` (and `temperature_c` for IAPWS), `medium`, `sun_disc_diameter_deg`.
pub fn attributes(
    normalization: &str,
    model: &WaterIndexModel,
    sun_disc_diameter_deg: f64,
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
    a.insert("sun_disc_diameter_deg".into(), sun_disc_diameter_deg.into());
    a
}
