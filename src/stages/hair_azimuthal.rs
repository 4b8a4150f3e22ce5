//! The `hair-azimuthal` stage: parameters, their checks, and the [`AzimuthalTable`] whose
//! rows (one per inclination θ) are the tasks.

use super::job::{HairJob, check_fibre, fibre_features, hair_params, invalid};
use crate::hair::absorption::AbsorptionAxis;
use crate::hair::azimuthal_table::AzimuthalTable;
use crate::stages::{Job, PlanError, StageSpec, checks};

/// The `hair-azimuthal` stage.
pub struct HairAzimuthalStage;

hair_params! {
    /// Parameters of `hair-azimuthal`.
    pub struct HairAzimuthalParams {
        /// Azimuthal roughness (standard deviation of the wrapped normal), deg, 0.25–60.
        pub azimuthal_width_deg: f64 = default(5.0), "float, deg",
            "azimuthal roughness w_φ (wrapped normal std), 0.25–60°";
        /// Samples of θ over [0°, 90°] (N_p is even in θ).
        pub theta_count: usize = default(46), "int", "samples of θ over [0°, 90°] (2–2048)";
        /// Samples of φ over [0°, 180°] (N_p is even in φ).
        pub phi_count: usize = default(181), "int", "samples of φ over [0°, 180°] (2–8192)";
    }
}

impl StageSpec for HairAzimuthalStage {
    const NAME: &'static str = "hair-azimuthal";
    /// 2: Fresnel amplitudes in real arithmetic below the critical angle (last bits).
    const VERSION: u32 = 2;
    const SUMMARY: &'static str = "azimuthal scattering functions N_R, N_TT, N_TRT of a rough dielectric fibre over absorption × θ × φ";
    type Params = HairAzimuthalParams;
    fn plan_params(&self, p: HairAzimuthalParams) -> Result<Box<dyn Job>, PlanError> {
        Ok(Box::new(HairAzimuthalJob::new(p)?))
    }
}

/// A planned `hair-azimuthal` table.
pub type HairAzimuthalJob = HairJob<HairAzimuthalParams, AzimuthalTable>;

impl HairAzimuthalJob {
    /// Validate and plan.
    pub fn new(p: HairAzimuthalParams) -> Result<Self, PlanError> {
        check_fibre(p.eta, p.quadrature_order)?;
        checks::within(
            "azimuthal_width_deg",
            p.azimuthal_width_deg,
            0.25,
            60.0,
            "°",
        )?;
        checks::within("theta_count", p.theta_count, 2, 2048, "")?;
        checks::within("phi_count", p.phi_count, 2, 8192, "")?;
        let absorption =
            AbsorptionAxis::from_keys(p.absorption_count, p.sigma_a.clone(), None, None)
                .map_err(invalid)?;
        let (diffuse, axis_ratio) =
            fibre_features(p.lambertian_kd, p.higher_order_kd, p.axis_ratio)?;
        let table = AzimuthalTable {
            eta: p.eta,
            fresnel: p.fresnel,
            azimuthal_width_deg: p.azimuthal_width_deg,
            quadrature_order: p.quadrature_order,
            diffuse,
            axis_ratio,
            absorption,
            theta_count: p.theta_count,
            phi_count: p.phi_count,
        };
        let stored_fraction = crate::stages::cost::STORED_FRACTION_HAIR_AZIMUTHAL;
        Ok(HairJob::planned(p, table, stored_fraction))
    }
}
