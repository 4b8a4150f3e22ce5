//! One checked evaluation of a fabric preset's BRDF at a direction pair given in degrees, and its
//! record: what `scatterbake cloth --format json` prints and `scatterbake.cloth_brdf` returns
//! (one code path, so the two cannot drift apart).
//!
//! The record's keys: `fabric`, `model`, `frame`, the four angles (`theta_i_deg`, `phi_i_deg`,
//! `theta_r_deg`, `phi_r_deg`), `unit` (1/sr), `channels`, `brdf` (RGB), `surface` (the white
//! surface lobe, repeated per channel), `volume` (RGB; `brdf = surface + volume`) and
//! `ramp_step_deg`.

use super::brdf::{ClothModel, ClothValue, ModelOptions};
use super::fabric::{FabricError, preset};
use serde_json::json;

/// A direction pair in the cloth frame, degrees: θ from the normal, φ from the warp (`+x`)
/// toward the weft (`+y`); `i` toward the light, `r` toward the viewer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionPairDeg {
    /// Light direction, angle from the cloth normal.
    pub theta_i_deg: f64,
    /// Light direction, azimuth from the warp.
    pub phi_i_deg: f64,
    /// View direction, angle from the cloth normal.
    pub theta_r_deg: f64,
    /// View direction, azimuth from the warp.
    pub phi_r_deg: f64,
}

/// Why a query is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum QueryError {
    #[error(transparent)]
    Fabric(#[from] FabricError),
    #[error("{name} = {value} must be in [0, 90) degrees (the BRDF is defined above the cloth)")]
    Theta { name: &'static str, value: f64 },
    #[error("{name} = {value} must be finite")]
    Phi { name: &'static str, value: f64 },
    #[error("ramp_step_deg = {0} must be in (0, 10]")]
    RampStep(f64),
}

/// The BRDF of preset `fabric` at `q` with the tangent quadrature step `ramp_step_deg`, after
/// checking every input.
pub fn brdf_at_deg(
    fabric: &str,
    q: DirectionPairDeg,
    ramp_step_deg: f64,
) -> Result<ClothValue, QueryError> {
    for (name, value) in [("theta_i", q.theta_i_deg), ("theta_r", q.theta_r_deg)] {
        if !(0.0..90.0).contains(&value) {
            return Err(QueryError::Theta { name, value });
        }
    }
    for (name, value) in [("phi_i", q.phi_i_deg), ("phi_r", q.phi_r_deg)] {
        if !value.is_finite() {
            return Err(QueryError::Phi { name, value });
        }
    }
    if !(ramp_step_deg > 0.0 && ramp_step_deg <= 10.0) {
        return Err(QueryError::RampStep(ramp_step_deg));
    }
    let options = ModelOptions {
        ramp_step_deg,
        ..ModelOptions::default()
    };
    let model = ClothModel::new(preset(fabric)?, options);
    Ok(model.eval_angles(
        q.theta_i_deg.to_radians(),
        q.phi_i_deg.to_radians(),
        q.theta_r_deg.to_radians(),
        q.phi_r_deg.to_radians(),
    ))
}

/// The record of one evaluation (keys in the module documentation).
pub fn brdf_record(
    fabric: &str,
    q: DirectionPairDeg,
    ramp_step_deg: f64,
) -> Result<serde_json::Value, QueryError> {
    let v = brdf_at_deg(fabric, q, ramp_step_deg)?;
    Ok(json!({
        "fabric": fabric,
        "model": "Sadeghi et al. 2013 microcylinder cloth model (thesis ch. 5), as printed",
        "frame": "cloth normal +z, warp +x, weft +y; theta from the normal, phi from +x toward +y; omega_i toward the light",
        "theta_i_deg": q.theta_i_deg,
        "phi_i_deg": q.phi_i_deg,
        "theta_r_deg": q.theta_r_deg,
        "phi_r_deg": q.phi_r_deg,
        "unit": "1/sr",
        "channels": "linear RGB (Rec. 709)",
        "brdf": v.total(),
        "surface": vec![v.surface; 3],
        "volume": v.volume,
        "ramp_step_deg": ramp_step_deg,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(theta_r_deg: f64) -> DirectionPairDeg {
        DirectionPairDeg {
            theta_i_deg: 30.0,
            phi_i_deg: 10.0,
            theta_r_deg,
            phi_r_deg: -170.0,
        }
    }

    #[test]
    fn record_is_the_model() {
        let r = brdf_record("silk_shot", pair(40.0), 1.0).unwrap();
        let m = ClothModel::new(preset("silk_shot").unwrap(), ModelOptions::default());
        let v = m.eval_angles(
            30f64.to_radians(),
            10f64.to_radians(),
            40f64.to_radians(),
            (-170f64).to_radians(),
        );
        for c in 0..3 {
            assert_eq!(r["brdf"][c].as_f64().unwrap(), v.total()[c]);
            assert_eq!(r["volume"][c].as_f64().unwrap(), v.volume[c]);
        }
    }

    #[test]
    fn bad_queries_are_refused_with_their_reason() {
        let e = brdf_record("denim", pair(40.0), 1.0).unwrap_err();
        assert!(e.to_string().contains("unknown fabric `denim`"), "{e}");
        let e = brdf_at_deg("velvet", pair(90.0), 1.0).unwrap_err();
        assert!(e.to_string().contains("theta_r = 90"), "{e}");
        let mut q = pair(10.0);
        q.phi_i_deg = f64::NAN;
        assert!(brdf_at_deg("velvet", q, 1.0).is_err());
        assert!(brdf_at_deg("velvet", pair(10.0), 0.0).is_err());
    }
}
