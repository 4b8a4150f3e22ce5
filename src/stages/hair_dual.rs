//! The `hair-dual` stage: parameters, their checks, and the [`DualTable`] whose rows (one per
//! light inclination θ_i) are the tasks.

use super::job::{HairJob, check_fibre, fibre_features, hair_params, invalid};
use crate::hair::absorption::AbsorptionAxis;
use crate::hair::artist::{ArtistModel, ArtistParams};
use crate::hair::dual_table::DualTable;
use crate::hair::rows::DualSweep;
use crate::stages::{Job, PlanError, StageSpec, checks};
use serde::{Deserialize, Serialize};

/// Which fibre model feeds the Dual Scattering averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum HairModel {
    #[default]
    Physical,
    Artist,
}

/// The `hair-dual` stage.
pub struct HairDualStage;

hair_params! {
    /// Parameters of `hair-dual`.
    pub struct HairDualParams {
        pub model: HairModel = default(HairModel::Physical), "string",
            "physical (Marschner/Zinke fibre) or artist (Sadeghi 2010, eq. 4.17 scalar normalisation per θ_i; artist.normalisation = \"normal-incidence\" for one constant)";
        /// Cuticle tilt α (deg): α_R = −α, α_TT = α/2, α_TRT = 3α/2.
        pub cuticle_tilt_deg: f64 = default(5.0), "float, deg",
            "cuticle tilt α: α_R = −α, α_TT = α/2, α_TRT = 3α/2 (0–15°)";
        /// Longitudinal R widths β_R (deg): β_TT = β_R/2, β_TRT = 2β_R.
        pub roughness_deg: Vec<f64> = default(vec![7.5]), "list of float, deg",
            "longitudinal widths β_R (β_TT = β_R/2, β_TRT = 2β_R), 0.5–30°, strictly increasing; the roughness axis";
        /// Azimuthal roughness w_φ = ratio × β_R (0 = smooth cylinder).
        pub azimuthal_width_ratio: f64 = default(1.0), "float",
            "azimuthal roughness w_φ = ratio·β_R (0 = smooth cylinder), 0–4";
        pub sigma_a_rgb: Option<[f64; 3]> = optional("—"), "[r, g, b], 1/radius",
            "one hair colour (axis colour_channel)";
        pub melanin: Option<[f64; 2]> = optional("—"), "[eumelanin, pheomelanin]",
            "one hair colour from melanin concentrations (pbrt/Chiang 2016 mapping)";
        pub theta_count: usize = default(64), "int",
            "samples of the light inclination θ_i over [−90°, 90°], endpoints included (2–4096)";
        pub d_b: f64 = default(0.7), "float",
            "backscattering density factor in σ̄_b (ZYWK08)";
        pub clamp: f64 = default(0.99), "float",
            "ā_f, ā_b are clamped to ≤ clamp before Ā_b, Δ̄_b, σ̄_b² (0.5–1)";
        /// Artist-friendly parameters (model = "artist" only).
        pub artist: Option<ArtistParams> = optional("Arnold-sample defaults"), "table",
            "artist-friendly lobe colours/intensities/shifts/widths/glints (model = artist)";
    }
}

impl StageSpec for HairDualStage {
    const NAME: &'static str = "hair-dual";
    /// 2: the artist model's eq. 4.17 normalisation is taken per light inclination.
    /// 3: Fresnel amplitudes in real arithmetic below the critical angle (last bits).
    const VERSION: u32 = 3;
    const SUMMARY: &'static str = "Dual Scattering hair averages (ā, ᾱ, β̄², Ā_b, Δ̄_b, σ̄_b², N^G) over roughness × absorption × light inclination";
    type Params = HairDualParams;
    fn plan_params(&self, p: HairDualParams) -> Result<Box<dyn Job>, PlanError> {
        Ok(Box::new(HairDualJob::new(p)?))
    }
}

/// A planned `hair-dual` table.
pub type HairDualJob = HairJob<HairDualParams, DualTable>;

impl HairDualJob {
    /// Validate and plan.
    pub fn new(p: HairDualParams) -> Result<Self, PlanError> {
        let table = dual_table(&p)?;
        let stored_fraction = if table.artist.is_some() {
            crate::stages::cost::STORED_FRACTION_HAIR_DUAL_ARTIST
        } else {
            crate::stages::cost::STORED_FRACTION_HAIR_DUAL
        };
        Ok(HairJob::planned(p, table, stored_fraction))
    }
}

/// The `hair-dual` table of `p`, every parameter checked (errors name the manifest key); the
/// stage runs its rows as tasks, `scatterbake dual-scattering` computes it at once.
pub fn dual_table(p: &HairDualParams) -> Result<DualTable, PlanError> {
    check_ranges(p)?;
    let (diffuse, axis_ratio) = fibre_features(p.lambertian_kd, p.higher_order_kd, p.axis_ratio)?;
    let (absorption, artist) = match p.model {
        HairModel::Physical => {
            if p.artist.is_some() {
                return Err(PlanError::invalid(
                    "artist",
                    "only used with model = \"artist\"",
                ));
            }
            let absorption = AbsorptionAxis::from_keys(
                p.absorption_count,
                p.sigma_a.clone(),
                p.sigma_a_rgb,
                p.melanin,
            )
            .map_err(invalid)?;
            (absorption, None)
        }
        HairModel::Artist => (AbsorptionAxis::Rgb([0.0; 3]), Some(artist_model(p)?)),
    };
    let sweep = DualSweep {
        eta: p.eta,
        fresnel: p.fresnel,
        cuticle_tilt_deg: p.cuticle_tilt_deg,
        roughness_deg: p.roughness_deg.clone(),
        azimuthal_width_ratio: p.azimuthal_width_ratio,
        diffuse,
        axis_ratio,
        sigma_a: Vec::new(),
        d_b: p.d_b,
        clamp: p.clamp,
    };
    Ok(DualTable::new(
        sweep,
        absorption,
        artist,
        p.theta_count,
        p.quadrature_order,
    ))
}

/// The ranges of the fibre, lobe and grid keys.
fn check_ranges(p: &HairDualParams) -> Result<(), PlanError> {
    check_fibre(p.eta, p.quadrature_order)?;
    checks::within("cuticle_tilt_deg", p.cuticle_tilt_deg, 0.0, 15.0, "°")?;
    if p.roughness_deg.is_empty() || p.roughness_deg.iter().any(|b| !(0.5..=30.0).contains(b)) {
        return Err(PlanError::invalid(
            "roughness_deg",
            "needs values within 0.5–30°",
        ));
    }
    if p.roughness_deg.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PlanError::invalid(
            "roughness_deg",
            "must be strictly increasing",
        ));
    }
    checks::within(
        "azimuthal_width_ratio",
        p.azimuthal_width_ratio,
        0.0,
        4.0,
        "",
    )?;
    checks::within("theta_count", p.theta_count, 2, 4096, "")?;
    checks::within("d_b", p.d_b, 0.0, 1.0, "")?;
    checks::within("clamp", p.clamp, 0.5, 1.0, "")?;
    Ok(())
}

/// The artist model of `p` (`model = "artist"`), refusing the keys of the physical fibre.
fn artist_model(p: &HairDualParams) -> Result<ArtistModel, PlanError> {
    if p.absorption_count.is_some()
        || p.sigma_a.is_some()
        || p.sigma_a_rgb.is_some()
        || p.melanin.is_some()
    {
        return Err(PlanError::invalid(
            "absorption_count",
            "the artist model takes colours, not absorption",
        ));
    }
    if p.roughness_deg.len() != 1 {
        return Err(PlanError::invalid(
            "roughness_deg",
            "the artist model has its own widths; leave the default",
        ));
    }
    for (key, given) in [
        ("lambertian_kd", p.lambertian_kd.is_some()),
        ("higher_order_kd", p.higher_order_kd.is_some()),
        ("axis_ratio", p.axis_ratio.is_some()),
    ] {
        if given {
            return Err(PlanError::invalid(
                key,
                "a physical-fibre parameter: not used by the artist model (its glints play the role of the elliptic TRT caustics)",
            ));
        }
    }
    let a = p.artist.clone().unwrap_or_default();
    a.validate()
        .map_err(|(k, m)| PlanError::invalid(&format!("artist.{k}"), m))?;
    Ok(ArtistModel::new(a))
}
