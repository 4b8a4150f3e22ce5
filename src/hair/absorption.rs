//! The absorption axis of the hair tables: a LUT sweep uniform in `u = 1 − exp(−2σ_a)`,
//! explicit `σ_a` values, or one RGB colour (given as `σ_a` or as melanin concentrations,
//! [`super::melanin`]), with its axis and the header text that states its convention.

use super::melanin::{sigma_a_from_absorption_u, sigma_a_from_melanin};
use crate::table::Axis;
use serde_json::{Map, Value, json};

/// The absorption axis of a table.
#[derive(Debug, Clone, PartialEq)]
pub enum AbsorptionAxis {
    /// `absorption_u = 1 − exp(−2σ_a)` uniform on `[0, 1]` with `count` samples (LUT mode).
    Sweep(usize),
    /// Explicit `σ_a` values (per unit radius), strictly increasing.
    SigmaA(Vec<f64>),
    /// One colour: `σ_a` for R, G, B (axis `colour_channel` = 0, 1, 2).
    Rgb([f64; 3]),
}

impl AbsorptionAxis {
    /// The axis from exactly one of its four descriptions: `count` samples of `u`, explicit
    /// `sigma_a`, one colour `rgb` or `melanin` concentrations `[eumelanin, pheomelanin]`. An
    /// error names the key (the manifest's) and says why.
    pub fn from_keys(
        count: Option<usize>,
        sigma_a: Option<Vec<f64>>,
        rgb: Option<[f64; 3]>,
        melanin: Option<[f64; 2]>,
    ) -> Result<Self, (&'static str, String)> {
        let given = [
            count.is_some(),
            sigma_a.is_some(),
            rgb.is_some(),
            melanin.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        let invalid = |key, why: &str| Err((key, why.to_string()));
        if given != 1 {
            return invalid(
                "absorption_count",
                "give exactly one of absorption_count, sigma_a, sigma_a_rgb, melanin",
            );
        }
        if let Some(n) = count {
            if !(2..=1024).contains(&n) {
                return invalid("absorption_count", "must be within 2–1024");
            }
            return Ok(AbsorptionAxis::Sweep(n));
        }
        if let Some(v) = sigma_a {
            if v.is_empty() || v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return invalid("sigma_a", "needs finite values ≥ 0");
            }
            if v.windows(2).any(|w| w[1] <= w[0]) {
                return invalid("sigma_a", "must be strictly increasing");
            }
            return Ok(AbsorptionAxis::SigmaA(v));
        }
        if let Some(c) = rgb {
            if c.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return invalid("sigma_a_rgb", "needs finite values ≥ 0");
            }
            return Ok(AbsorptionAxis::Rgb(c));
        }
        let [ce, cp] = melanin.expect("one key is given");
        if !(ce.is_finite() && cp.is_finite() && ce >= 0.0 && cp >= 0.0) {
            return invalid("melanin", "concentrations must be finite and ≥ 0");
        }
        Ok(AbsorptionAxis::Rgb(sigma_a_from_melanin(ce, cp)))
    }

    /// The σ_a values along the axis.
    pub fn sigma_values(&self) -> Vec<f64> {
        match self {
            AbsorptionAxis::Sweep(n) => (0..*n)
                .map(|i| sigma_a_from_absorption_u(i as f64 / (*n - 1) as f64))
                .collect(),
            AbsorptionAxis::SigmaA(v) => v.clone(),
            AbsorptionAxis::Rgb(c) => c.to_vec(),
        }
    }

    /// Samples along the axis.
    pub fn len(&self) -> usize {
        match self {
            AbsorptionAxis::Sweep(n) => *n,
            AbsorptionAxis::SigmaA(v) => v.len(),
            AbsorptionAxis::Rgb(_) => 3,
        }
    }

    /// Whether the axis has no sample (never, for an axis from [`Self::from_keys`]).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The table axis: `absorption_u`, `sigma_a` or `colour_channel`.
    pub fn axis(&self) -> Axis {
        match self {
            AbsorptionAxis::Sweep(n) => {
                Axis::uniform("absorption_u", "1", 0.0, 1.0 / (*n - 1) as f64, *n)
            }
            AbsorptionAxis::SigmaA(v) => Axis::values("sigma_a", "1/radius", v.clone()),
            AbsorptionAxis::Rgb(_) => Axis::values("colour_channel", "1", vec![0.0, 1.0, 2.0]),
        }
    }

    /// The header attributes of the absorption convention and of the axis.
    pub fn describe(&self, attributes: &mut Map<String, Value>) {
        attributes.insert(
            "absorption_convention".into(),
            "sigma_a per unit fibre radius (internal chord 2 cos γ_t / cos θ_t at r = 1, as pbrt's HairBxDF)".into(),
        );
        match self {
            AbsorptionAxis::Sweep(_) => {
                attributes.insert(
                    "absorption_u".into(),
                    "u = 1 − exp(−2 sigma_a); sigma_a = −ln(1 − u)/2; u = 1 is an opaque interior (sigma_a = ∞). Look up each RGB channel with its own u.".into(),
                );
            }
            AbsorptionAxis::SigmaA(_) => {}
            AbsorptionAxis::Rgb(c) => {
                attributes.insert(
                    "colour_channel".into(),
                    "0 = R, 1 = G, 2 = B (linear sRGB)".into(),
                );
                attributes.insert("sigma_a_rgb".into(), json!(c));
            }
        }
    }
}
