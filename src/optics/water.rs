//! Refractive index of liquid water versus wavelength.
//!
//! Two models, selectable by name in manifests and recorded in every table header:
//!
//! - `iapws1997` (the default of every stage and command: mie, debye, raytrace, airy): the
//!   IAPWS R9-97 formulation (Harvey et al. 1998) of the refractive
//!   index of water and steam as a function of wavelength, temperature and density. Density of
//!   liquid water at 1 atm from temperature uses Kell's (1975) polynomial (0–150 °C, better than
//!   1e-5 relative against IAPWS-95, i.e. < 1e-6 in n). Validated domain of R9-97:
//!   0.2–1.1 µm, −12–500 °C, 0–1060 kg/m³; outside it [`WaterIndexModel::index`] refuses.
//! - `sadeghi-table-3.2`: the 33 tabulated values of Table 3.2 of the rainbow thesis (Sadeghi
//!   2012, derived from Hale & Querry 1973, 380–700 nm every 10 nm), linearly interpolated
//!   between nodes; refuses wavelengths outside 380–700 nm. Use it to reproduce the thesis
//!   exactly (same name in manifests and on the command line).
//!
//! Both give the real index relative to vacuum; the absorption index of water in 380–700 nm is
//! below 3.5e-8 (Pope & Fry 1997) and is ignored (k = 0). The outside medium is taken as 1.0
//! (the Table 3.2 values then act as relative indices; decision MIE-3 in `docs/decisions.md`).

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Error for a wavelength/temperature outside a model's validated domain.
#[derive(Debug, Error, PartialEq)]
pub enum WaterIndexError {
    #[error(
        "wavelength {wavelength_nm} nm is outside the validated domain {min_nm}–{max_nm} nm of water index model `{model}`"
    )]
    WavelengthOutOfDomain {
        model: &'static str,
        wavelength_nm: f64,
        min_nm: f64,
        max_nm: f64,
    },
    #[error(
        "temperature {temperature_c} °C is outside 0–100 °C (liquid water at 1 atm) for model `iapws1997`"
    )]
    TemperatureOutOfDomain { temperature_c: f64 },
    #[error("unknown water index model `{0}` (known: iapws1997, sadeghi-table-3.2)")]
    UnknownModel(String),
}

/// Choice of water refractive index model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "kebab-case")]
pub enum WaterIndexModel {
    /// IAPWS R9-97 at the given temperature (°C), liquid water at 1 atm.
    Iapws1997 { temperature_c: f64 },
    /// Table 3.2 of the rainbow thesis (Hale & Querry 1973 derived), linear interpolation.
    SadeghiTable32,
}

impl Default for WaterIndexModel {
    fn default() -> Self {
        WaterIndexModel::Iapws1997 {
            temperature_c: 20.0,
        }
    }
}

/// Wavelengths (nm) of the rainbow thesis' Table 3.2 and of its default spectral sampling:
/// 380–700 nm in 10 nm steps, 33 samples.
pub const SADEGHI_WAVELENGTHS_NM: [f64; 33] = {
    let mut w = [0.0; 33];
    let mut i = 0;
    while i < 33 {
        w[i] = 380.0 + 10.0 * i as f64;
        i += 1;
    }
    w
};

/// Indices of Table 3.2 at [`SADEGHI_WAVELENGTHS_NM`].
pub const SADEGHI_TABLE_3_2: [f64; 33] = [
    1.3406, 1.3398, 1.339, 1.3386, 1.3382, 1.3378, 1.3374, 1.337, 1.3366, 1.3362, 1.3358, 1.3354,
    1.335, 1.3346, 1.3342, 1.3338, 1.3334, 1.333, 1.333, 1.333, 1.3328, 1.3324, 1.332, 1.332,
    1.332, 1.3318, 1.3314, 1.331, 1.331, 1.331, 1.331, 1.331, 1.331,
];

impl WaterIndexModel {
    /// Parse a model name as used in manifests: `iapws1997` (20 °C) or `sadeghi-table-3.2`.
    pub fn from_name(name: &str, temperature_c: Option<f64>) -> Result<Self, WaterIndexError> {
        match name {
            "iapws1997" => Ok(WaterIndexModel::Iapws1997 {
                temperature_c: temperature_c.unwrap_or(20.0),
            }),
            "sadeghi-table-3.2" => Ok(WaterIndexModel::SadeghiTable32),
            other => Err(WaterIndexError::UnknownModel(other.to_string())),
        }
    }

    /// Stable name recorded in table headers.
    pub fn name(&self) -> &'static str {
        match self {
            WaterIndexModel::Iapws1997 { .. } => "iapws1997",
            WaterIndexModel::SadeghiTable32 => "sadeghi-table-3.2",
        }
    }

    /// Real refractive index of water at `wavelength_nm` (vacuum wavelength).
    pub fn index(&self, wavelength_nm: f64) -> Result<f64, WaterIndexError> {
        match *self {
            WaterIndexModel::Iapws1997 { temperature_c } => {
                wavelength_within("iapws1997", wavelength_nm, 200.0, 1100.0)?;
                if !(0.0..=100.0).contains(&temperature_c) {
                    return Err(WaterIndexError::TemperatureOutOfDomain { temperature_c });
                }
                let density = water_density_kell_kg_m3(temperature_c);
                Ok(iapws1997_index(
                    wavelength_nm * 1e-3,
                    temperature_c + 273.15,
                    density,
                ))
            }
            WaterIndexModel::SadeghiTable32 => {
                wavelength_within("sadeghi-table-3.2", wavelength_nm, 380.0, 700.0)?;
                Ok(crate::table::interp::interp1_uniform(
                    &SADEGHI_TABLE_3_2,
                    380.0,
                    10.0,
                    wavelength_nm,
                ))
            }
        }
    }
}

/// `Ok` when `wavelength_nm` lies in `[min_nm, max_nm]`, the domain of `model`.
fn wavelength_within(
    model: &'static str,
    wavelength_nm: f64,
    min_nm: f64,
    max_nm: f64,
) -> Result<(), WaterIndexError> {
    if (min_nm..=max_nm).contains(&wavelength_nm) {
        Ok(())
    } else {
        Err(WaterIndexError::WavelengthOutOfDomain {
            model,
            wavelength_nm,
            min_nm,
            max_nm,
        })
    }
}

/// IAPWS R9-97 refractive index of water for wavelength `lambda_um` (µm), absolute temperature
/// `temperature_k` (K) and density `density_kg_m3`. No domain check (see [`WaterIndexModel`]).
pub fn iapws1997_index(lambda_um: f64, temperature_k: f64, density_kg_m3: f64) -> f64 {
    const A: [f64; 8] = [
        0.244_257_733,
        9.746_344_76e-3,
        -3.732_349_96e-3,
        2.686_784_72e-4,
        1.589_205_70e-3,
        2.459_342_59e-3,
        0.900_704_920,
        -1.666_262_19e-2,
    ];
    const LAMBDA_UV: f64 = 0.229_202_0;
    const LAMBDA_IR: f64 = 5.432_937;
    let rho = density_kg_m3 / 1000.0;
    let t = temperature_k / 273.15;
    let l = lambda_um / 0.589;
    let l2 = l * l;
    let a_over_rho = A[0]
        + A[1] * rho
        + A[2] * t
        + A[3] * l2 * t
        + A[4] / l2
        + A[5] / (l2 - LAMBDA_UV * LAMBDA_UV)
        + A[6] / (l2 - LAMBDA_IR * LAMBDA_IR)
        + A[7] * rho * rho;
    let a = a_over_rho * rho;
    ((1.0 + 2.0 * a) / (1.0 - a)).sqrt()
}

/// Density of air-free liquid water at 1 atm (kg/m³), Kell (1975), 0–150 °C.
pub fn water_density_kell_kg_m3(temperature_c: f64) -> f64 {
    let t = temperature_c;
    (999.839_52 + 16.945_176 * t - 7.987_040_1e-3 * t * t - 46.170_461e-6 * t.powi(3)
        + 105.563_02e-9 * t.powi(4)
        - 280.542_53e-12 * t.powi(5))
        / (1.0 + 16.879_850e-3 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iapws_check_value() {
        // R9-97 check value: T = 298.15 K, ρ = 997.047435 kg/m³, λ = 0.5893 µm → n = 1.33285819.
        let n = iapws1997_index(0.5893, 298.15, 997.047_435);
        assert!((n - 1.332_858_19).abs() < 5e-9, "n = {n}");
    }

    #[test]
    fn sodium_d_line_at_twenty_celsius_matches_handbook() {
        // Refractometry zero point (CRC handbook, Brix 0): n_D(20 °C) = 1.33299 relative to
        // air; IAPWS is relative to vacuum, so multiply by n_air(589 nm, 20 °C) = 1.000271.
        let n = WaterIndexModel::default().index(589.29).unwrap();
        assert!((n - 1.33299 * 1.000_271).abs() < 2e-5, "n = {n}");
    }

    #[test]
    fn kell_density_matches_standard_values() {
        assert!((water_density_kell_kg_m3(20.0) - 998.2041).abs() < 5e-3);
        assert!((water_density_kell_kg_m3(4.0) - 999.9720).abs() < 5e-3);
        assert!((water_density_kell_kg_m3(25.0) - 997.0479).abs() < 5e-3);
    }

    #[test]
    fn iapws_twenty_celsius_matches_reference_values() {
        // IAPWS R9-97 at 20 °C (independent evaluation of the release's formula): 1.34356 at
        // 400 nm and 1.33468 at 550 nm.
        let m = WaterIndexModel::default();
        assert!((m.index(400.0).unwrap() - 1.34356).abs() < 2e-5);
        assert!((m.index(550.0).unwrap() - 1.33468).abs() < 2e-5);
    }

    /// Every row of Table 3.2 of Sadeghi (2012) as published: (wavelength nm, η). The table
    /// holds 1.333 at 550–570 nm only and 1.331 from 650 nm on.
    const PUBLISHED_TABLE_3_2: [(f64, f64); 33] = [
        (380.0, 1.3406),
        (390.0, 1.3398),
        (400.0, 1.339),
        (410.0, 1.3386),
        (420.0, 1.3382),
        (430.0, 1.3378),
        (440.0, 1.3374),
        (450.0, 1.337),
        (460.0, 1.3366),
        (470.0, 1.3362),
        (480.0, 1.3358),
        (490.0, 1.3354),
        (500.0, 1.335),
        (510.0, 1.3346),
        (520.0, 1.3342),
        (530.0, 1.3338),
        (540.0, 1.3334),
        (550.0, 1.333),
        (560.0, 1.333),
        (570.0, 1.333),
        (580.0, 1.3328),
        (590.0, 1.3324),
        (600.0, 1.332),
        (610.0, 1.332),
        (620.0, 1.332),
        (630.0, 1.3318),
        (640.0, 1.3314),
        (650.0, 1.331),
        (660.0, 1.331),
        (670.0, 1.331),
        (680.0, 1.331),
        (690.0, 1.331),
        (700.0, 1.331),
    ];

    #[test]
    fn sadeghi_table_matches_every_published_row() {
        let m = WaterIndexModel::SadeghiTable32;
        for (k, &(wavelength_nm, eta)) in PUBLISHED_TABLE_3_2.iter().enumerate() {
            assert_eq!(SADEGHI_WAVELENGTHS_NM[k], wavelength_nm);
            assert_eq!(SADEGHI_TABLE_3_2[k], eta, "row {k}: {wavelength_nm} nm");
            assert_eq!(m.index(wavelength_nm).unwrap(), eta, "{wavelength_nm} nm");
        }
    }

    #[test]
    fn sadeghi_table_nodes_and_interpolation() {
        let m = WaterIndexModel::SadeghiTable32;
        assert_eq!(m.index(380.0).unwrap(), 1.3406);
        assert_eq!(m.index(700.0).unwrap(), 1.331);
        assert!((m.index(385.0).unwrap() - 1.3402).abs() < 1e-12);
        assert!(m.index(379.0).is_err());
        assert!(WaterIndexModel::default().index(150.0).is_err());
    }
}
