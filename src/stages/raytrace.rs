//! `raytrace` stage: wave-optics ray-traced phase functions of raindrops.
//!
//! Parameters use the vocabulary of the other phase-function stages (`docs/vocabulary.md`):
//! `radii_um`, `wavelengths_nm`, `water_index_model` (default `iapws1997`), `temperature_c`.
//!
//! - `shape = "sphere"`: schema `raytrace-phase/2`, axes radius (µm) × wavelength (nm) ×
//!   scattering_angle (deg), one task per (radius, wavelength), computed by the exact 1-D
//!   geometric-optics-plus-phase path ([`crate::raytrace::sphere1d`]), which the general 2-D
//!   tracer is validated against (tests/raytrace_validation.rs).
//! - `shape = "beard-chuang"` or `"profile"`: schema `raytrace-phase-2d/2`, axes radius (µm, one
//!   value) × wavelength (nm) × sun_elevation (deg) × outgoing_polar (deg) × outgoing_azimuth
//!   (deg), one task per (wavelength, sun elevation), computed by the 2-D patch tracer.
//!
//! The table (entries, axes, channels, renormalisation, header texts, compact form) is
//! [`crate::raytrace::phase_table`]; this module reads and checks the parameters, lays out the
//! tasks and their chunks (`raytrace_job.rs`) and checks each entry's integral.
//!
//! Version 1 of both schemas had the axes wavelength × radius (1-D) and wavelength × sun_elevation
//! (2-D, radius only in the `radius_mm` attribute) and was written from the keys `radius_mm` and
//! `wavelength_nm`; those keys are now refused with a message giving the new ones.

#[path = "raytrace_job.rs"]
mod job;

use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::raytrace::compact::Compression;
use crate::raytrace::domain;
use crate::raytrace::phase_table::{PhaseTable, PhaseTableSpec, steps};
use crate::raytrace::shape::{CosineSeries, DropShape};
use crate::raytrace::sphere1d::{DiffractionModel, SPHERE_MAX_ORDER};
use crate::raytrace::tracer::RayGridLayout;
use crate::stages::{Job, JobError, PlanError, StageSpec, checks, stage_params};

/// The stage.
pub struct RaytraceStage;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct RaytraceParams {
        /// `sphere`, `beard-chuang` or `profile`.
        pub shape: String = required, "string",
            "sphere (1-D table, exact GO+phase path) | beard-chuang | profile (2-D tables, patch tracer)";
        /// Equal-volume radii (µm); spheres accept a list, 2-D shapes exactly one.
        pub radii_um: Vec<f64> = required, "list of float, µm",
            "equal-volume radii, 10–5000 µm, strictly increasing; exactly one for 2-D shapes";
        /// Vacuum wavelengths (nm), strictly increasing; default: the thesis' 33 samples 380–700 nm.
        pub wavelengths_nm: Vec<f64> = default(SADEGHI_WAVELENGTHS_NM.to_vec()),
            "list of float, nm", "vacuum wavelengths, strictly increasing";
        /// `iapws1997` (default) or `sadeghi-table-3.2`.
        pub water_index_model: String = default("iapws1997".into()),
            "string", "iapws1997 | sadeghi-table-3.2 (thesis parity)";
        /// Water temperature for `iapws1997` (°C).
        pub temperature_c: f64 = default(20.0), "float, °C", "water temperature (iapws1997)";
        /// Highest order traced: 6 for spheres (the 1-D path: p = 6 fills Alexander's dark band,
        /// decision RT-30), 3 for 2-D shapes (each order costs the tracer time and memory).
        pub max_order: Option<usize> = optional("6 (sphere) / 3 (2-D)"), "integer",
            "highest order p traced (0 reflection, 1 transmission, 2 primary, 3 secondary, ...), 1–8; default 6 for spheres (Alexander's dark band), 3 for 2-D shapes";
        /// Scattering-angle step (deg) of 1-D sphere tables.
        pub angle_step_deg: f64 = default(0.05), "float, deg",
            "scattering-angle step of 1-D sphere tables (divides 180)";
        pub sun_elevation_deg: Vec<f64> = default(vec![0.0]), "list of float, deg",
            "sun elevations above the horizon (drop axis vertical), 0–90, 2-D shapes";
        pub rays: usize = default(600), "integer",
            "rays per side of the ray grid, rays² rays (2-D shapes; the thesis used 3000)";
        /// Layout of the `rays × rays` grid in the emitting plane (decision RT-31).
        pub ray_grid: RayGridLayout = default(RayGridLayout::Silhouette), "string",
            "silhouette: the rays × rays index square mapped onto the silhouette, refined towards its edge (grazing incidence); square: evenly spaced over the silhouette's bounding box (thesis); 2-D shapes";
        pub polar_step_deg: f64 = default(0.1), "float, deg",
            "outgoing polar step (divides 180), 2-D shapes";
        pub azimuth_step_deg: f64 = default(5.0), "float, deg",
            "outgoing azimuth step (divides 360), 2-D shapes";
        pub diffraction_filter: bool = default(true), "bool",
            "apply the Table 3.3 Gaussian filter to the main channels (the unfiltered channels are written with diagnostic_channels)";
        /// Write the per-order and unfiltered channels after the contract's four.
        pub diagnostic_channels: bool = default(true), "bool",
            "also write the per-order phases phase_p0…phase_pN (filtered, no lobe) and the unfiltered phase, i_perp, i_par after phase, i_perp, i_par, dolp; false writes those four only (the phase-table contract every consumer reads; a 2-D table of max_order 3 holds 4 instead of 11 values per direction)";
        /// 2-D shapes: add the orders `max_order + 1 …` [`SPHERE_MAX_ORDER`] of the equal-volume
        /// sphere (decision RT-37).
        pub sphere_higher_orders: bool = default(true), "bool",
            "2-D shapes: add the orders above max_order up to 6 of the equal-volume sphere (1-D path: Airy rainbows, grazing waves; the same at every azimuth) to phase, i_perp, i_par and their unfiltered channels; they fill Alexander's dark band, which orders ≤ 3 leave ≈ 14 % dark on a sphere. The per-order channels hold the traced orders only";
        /// Average each 2-D table pixel with its mirror image φ ↔ 360° − φ (decision RT-24).
        pub mirror_symmetrise: bool = default(true), "bool",
            "2-D shapes: replace the values at φ and 360° − φ by their mean (the drop and the sun are mirror-symmetric about the vertical plane φ = 0), removing the ray-noise asymmetry";
        /// Compute the azimuths 0°–180° only and copy them to 360° − φ (decision RT-34).
        pub mirror_half: bool = default(false), "bool",
            "2-D shapes: compute only the azimuths 0°–180° and copy each to its mirror image 360° − φ (about half the rasterising, caustic filtering and memory; the table is exactly symmetric, without the averaging of mirror_symmetrise, so its ray noise is that of one half); needs mirror_symmetrise = true";
        /// Diffraction model of the main channels: `airy-uniform` (spheres only, default for
        /// spheres), `airy-local` (2-D shapes only, default for them: the sphere's Airy
        /// correction moved onto each column's caustic within its domain, the Gaussian filter
        /// outside it; decisions RT-28, RT-33) or `gaussian` (thesis Table 3.3 filter, windowed
        /// around the caustics).
        pub diffraction_model: Option<DiffractionModel> =
            optional("airy-uniform (sphere) / airy-local (2-D)"), "string",
            "airy-uniform: uniform caustic (Airy) approximation at each rainbow (spheres); airy-local: the equal-volume sphere's Airy correction moved onto each azimuth column's own caustic where that caustic is the sphere's fold, the Gaussian filter elsewhere (2-D shapes); gaussian: thesis Table 3.3 Gaussian filter windowed around the caustics";
        pub profile_theta_deg: Option<Vec<f64>> = optional("none"), "list of float, deg",
            "shape = profile: polar angles from the downward pole";
        pub profile_r: Option<Vec<f64>> = optional("none"), "list of float",
            "shape = profile: radii at profile_theta_deg (any unit; rescaled to radii_um equal volume)";
        /// 2-D shapes: the dense table, or the compact form seen through the sun's disc and
        /// resampled adaptively within a stated error (decision RT-39). Not written to the
        /// resolved parameters when `none`, so that dense tables keep their content keys.
        #[serde(skip_serializing_if = "Compression::is_none")]
        pub compression: Compression = default(Compression::None), "string or table",
            "none: the dense table on the uniform grid; { kind = \"sun-disc-resampled\", tolerance = 0.01 } (optional sun_diameter_deg, default 0.5): every entry convolved with the sun's disc (Gaussian of the disc's second moment, σ = diameter/4 of arc) and resampled onto adaptive polar and azimuth knots so that phase, i_perp and i_par stay within tolerance × phase of the filtered dense entry at every direction of the dense grid, measured at build time (refused otherwise); 2-D shapes with diagnostic_channels = false (docs/raytrace.md, Compact tables)";
    }
}

/// Keys of `raytrace-phase/1` manifests and the keys that replaced them (same vocabulary as the
/// `mie` and `debye` stages); the old keys are refused rather than translated, so that no
/// manifest silently changes unit.
const RENAMED_KEYS: [(&str, &str); 2] = [
    (
        "radius_mm",
        "`radius_mm` (mm) was replaced by `radii_um` (µm), as in the mie and debye stages: write e.g. radii_um = [400.0] for radius_mm = [0.4]",
    ),
    (
        "wavelength_nm",
        "`wavelength_nm` was replaced by `wavelengths_nm`, as in the mie and debye stages",
    ),
];

/// A clear message for a key of the old vocabulary (serde reports it as an unknown field).
fn renamed_key_error(e: PlanError) -> PlanError {
    let text = e.to_string();
    for (old, message) in RENAMED_KEYS {
        if text.contains(&format!("unknown field `{old}`")) {
            return PlanError::invalid(old, message);
        }
    }
    e
}

impl StageSpec for RaytraceStage {
    const NAME: &'static str = "raytrace";
    /// 2: 2-D tables renormalised to ∫ p dΩ = 1 on their grid. 3: Table 3.2 of Sadeghi (2012)
    /// corrected at 580–650 nm; axes radius × wavelength × …, keys `radii_um`, `wavelengths_nm`.
    /// 4: 2-D tables mirror-symmetrised in azimuth by default (`mirror_symmetrise`).
    /// 5: curved-surface (Debye) coefficients for the orders p ≥ 4 of the 1-D sphere path
    /// (decision RT-29; sphere tables with `max_order ≥ 4` change).
    /// 6: 2-D tables trace the silhouette ray grid by default (`ray_grid`, decision RT-31).
    /// 7: `airy-local` is the default caustic model of 2-D tables, with a domain outside which
    /// columns take the Gaussian filter (decision RT-33).
    /// 8: sphere (1-D) tables trace orders up to 6 by default (decision RT-30 amendment).
    /// 9: 2-D airy-local tables record where the transfer was used (`airy_local_domain`; each
    /// task's chunk carries its columns' transfer weights after the values).
    /// 10: Fresnel amplitudes in real arithmetic below the critical angle (values change in the
    /// last bits); `diagnostic_channels`.
    /// 11: sphere tables with `max_order ≥ 4`: the grazing region of those orders is their
    /// exact partial waves (decision RT-36; Alexander's band), and with `airy-uniform` their rays
    /// carry the axial focal-line phases (RT-38); 2-D tables add the equal-volume sphere's
    /// orders above `max_order` (`sphere_higher_orders`, decision RT-37).
    /// 12: the Debye surface coefficients of the grazing waves and of the added orders are
    /// regular where sin(mx) vanishes (they were wrong by orders of magnitude there, e.g. at
    /// 0.4 and 1 mm, 500 nm, Table 3.2 index); entries integrating far from 1 are refused.
    /// 13: compact tables: the polar knots take what the azimuth knots' measured error leaves
    /// of the tolerance; mirror symmetric entries store 0°–180° of azimuth on an even-periodic
    /// axis (table format 3.0; decision RT-42).
    /// 14: intersections with convex drops bracketed between their spheroids (last bits).
    /// 15: 2-D tables of spherical drops (Beard–Chuang up to 0.4 mm) under airy-local are the
    /// 1-D sphere path's, the same at every azimuth (decision RT-43).
    const VERSION: u32 = 15;
    const SUMMARY: &'static str =
        "wave-optics patch ray tracer: phase functions of spherical and Beard–Chuang raindrops";
    type Params = RaytraceParams;
    fn map_parse_error(e: PlanError) -> PlanError {
        renamed_key_error(e)
    }
    fn plan_params(&self, p: RaytraceParams) -> Result<Box<dyn Job>, PlanError> {
        Ok(Box::new(RaytraceJob::new(p)?))
    }
}

/// A planned ray-tracing job.
pub struct RaytraceJob {
    p: RaytraceParams,
    model: WaterIndexModel,
    /// A fixed real index replacing the water model (single queries; see
    /// [`RaytraceJob::with_refractive_index`]).
    fixed_index: Option<f64>,
    /// The table the tasks compute.
    table: PhaseTable,
}

/// The checks of a 2-D (non-spherical) plan: one radius, direction grid steps that divide the
/// sphere, ray count and sun elevations.
fn check_two_d_grid(p: &RaytraceParams) -> Result<(), PlanError> {
    if p.radii_um.len() != 1 {
        return Err(PlanError::invalid(
            "radii_um",
            "2-D shapes take exactly one radius per table",
        ));
    }
    if steps(180.0, p.polar_step_deg).is_none() {
        return Err(PlanError::invalid(
            "polar_step_deg",
            "must be > 0 and divide 180 into 2 to 1e7 steps",
        ));
    }
    if steps(360.0, p.azimuth_step_deg).is_none() {
        return Err(PlanError::invalid(
            "azimuth_step_deg",
            "must be > 0 and divide 360 into 2 to 1e7 steps",
        ));
    }
    domain::check_rays(p.rays).map_err(|why| PlanError::invalid("rays", why))?;
    if p.sun_elevation_deg.is_empty() || p.sun_elevation_deg.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PlanError::invalid(
            "sun_elevation_deg",
            "must be strictly increasing within 0–90",
        ));
    }
    for &e in &p.sun_elevation_deg {
        domain::check_sun_elevation_deg(e)
            .map_err(|why| PlanError::invalid("sun_elevation_deg", why))?;
    }
    Ok(())
}

/// Compression is for 2-D shapes with the contract's four channels.
fn check_compression(p: &RaytraceParams, two_d_shape: bool) -> Result<(), PlanError> {
    if p.compression.is_none() {
        return Ok(());
    }
    if !two_d_shape {
        return Err(PlanError::invalid(
            "compression",
            "compact tables are 2-D (beard-chuang, profile); sphere tables are 1-D and small: use compression = \"none\"",
        ));
    }
    if p.diagnostic_channels {
        return Err(PlanError::invalid(
            "compression",
            "compact tables hold the contract's four channels (phase, i_perp, i_par, dolp): set diagnostic_channels = false",
        ));
    }
    Ok(())
}

impl RaytraceJob {
    /// Validate parameters and plan.
    pub fn new(p: RaytraceParams) -> Result<Self, PlanError> {
        checks::increasing("wavelengths_nm", &p.wavelengths_nm, true)?;
        let (model, _) = checks::water_indices(
            &p.water_index_model,
            Some(p.temperature_c),
            "wavelengths_nm",
            &p.wavelengths_nm,
        )?;
        checks::increasing("radii_um", &p.radii_um, true)?;
        for &r in &p.radii_um {
            domain::check_radius_um(r).map_err(|why| PlanError::invalid("radii_um", why))?;
        }
        let two_d_shape = p.shape != "sphere";
        let max_order = p
            .max_order
            .unwrap_or(if two_d_shape { 3 } else { SPHERE_MAX_ORDER });
        if !(1..=8).contains(&max_order) {
            return Err(PlanError::invalid("max_order", "must be within 1–8"));
        }
        check_models(&p, two_d_shape)?;
        check_compression(&p, two_d_shape)?;
        let (shape, profile_fit_residual) = match p.shape.as_str() {
            "sphere" => {
                if steps(180.0, p.angle_step_deg).is_none() {
                    return Err(PlanError::invalid(
                        "angle_step_deg",
                        "must be > 0 and divide 180 into 2 to 1e7 steps",
                    ));
                }
                (None, None)
            }
            "beard-chuang" | "profile" => {
                check_two_d_grid(&p)?;
                let (shape, residual) = drop_shape(&p)?;
                (Some(shape), residual)
            }
            other => {
                return Err(PlanError::invalid(
                    "shape",
                    format!("unknown shape `{other}` (sphere, beard-chuang, profile)"),
                ));
            }
        };
        let spec = table_spec(&p, max_order, shape, profile_fit_residual);
        Ok(RaytraceJob {
            p,
            model,
            fixed_index: None,
            table: PhaseTable::new(spec),
        })
    }

    /// Use the fixed real relative index `n` at every wavelength instead of the water model
    /// (what `scatterbake raytrace --n N` asks for); the table then records
    /// `water_index_model = "none"` and `refractive_index_real = n`.
    pub fn with_refractive_index(mut self, n: f64) -> Result<Self, PlanError> {
        if !(n > 1.0 && n < 2.0) {
            return Err(PlanError::invalid(
                "n",
                format!("{n} is outside (1, 2), where the primary bow exists"),
            ));
        }
        self.fixed_index = Some(n);
        Ok(self)
    }

    /// Refractive index at `wavelength_nm`.
    fn index(&self, wavelength_nm: f64) -> Result<f64, JobError> {
        match self.fixed_index {
            Some(n) => Ok(n),
            None => Ok(self.model.index(wavelength_nm)?),
        }
    }

    /// 2-D shapes: the values `[polar][azimuth][channel]` of one (wavelength, sun elevation) as
    /// a task returns them (divided by σ, before the renormalisation of `assemble`) and the
    /// scattering cross-section σ = σ_GO + A (µm²) they were divided by.
    pub fn trace_2d(&self, lambda: f64, elevation_deg: f64) -> Result<(Vec<f32>, f64), JobError> {
        let t = self
            .table
            .trace_entry(lambda, self.index(lambda)?, elevation_deg);
        Ok((t.values, t.cross_section_um2))
    }
}

/// The table of a checked plan: the parameters with the shape's defaults resolved.
fn table_spec(
    p: &RaytraceParams,
    max_order: usize,
    shape: Option<DropShape>,
    profile_fit_residual: Option<f64>,
) -> PhaseTableSpec {
    let model_default = if shape.is_some() {
        DiffractionModel::AiryLocal
    } else {
        DiffractionModel::AiryUniform
    };
    PhaseTableSpec {
        shape_name: p.shape.clone(),
        shape,
        profile_fit_residual,
        radii_um: p.radii_um.clone(),
        wavelengths_nm: p.wavelengths_nm.clone(),
        sun_elevation_deg: p.sun_elevation_deg.clone(),
        max_order,
        angle_step_deg: p.angle_step_deg,
        polar_step_deg: p.polar_step_deg,
        azimuth_step_deg: p.azimuth_step_deg,
        rays: p.rays,
        ray_grid: p.ray_grid,
        diffraction_filter: p.diffraction_filter,
        model: p.diffraction_model.unwrap_or(model_default),
        diagnostic_channels: p.diagnostic_channels,
        sphere_higher_orders: p.sphere_higher_orders,
        mirror_symmetrise: p.mirror_symmetrise,
        mirror_half: p.mirror_half,
        compression: p.compression,
    }
}

/// The diffraction model named suits the shape, and `mirror_half` goes with
/// `mirror_symmetrise`.
fn check_models(p: &RaytraceParams, two_d_shape: bool) -> Result<(), PlanError> {
    if two_d_shape && p.diffraction_model == Some(DiffractionModel::AiryUniform) {
        return Err(PlanError::invalid(
            "diffraction_model",
            "airy-uniform is available for spheres only; use airy-local or gaussian",
        ));
    }
    if !two_d_shape && p.diffraction_model == Some(DiffractionModel::AiryLocal) {
        return Err(PlanError::invalid(
            "diffraction_model",
            "airy-local is for 2-D shapes (it transfers the sphere's airy-uniform correction); spheres use airy-uniform",
        ));
    }
    if p.mirror_half && !p.mirror_symmetrise {
        return Err(PlanError::invalid(
            "mirror_half",
            "mirror_half = true makes the table exactly mirror-symmetric, which contradicts mirror_symmetrise = false (keep the ray-noise asymmetry); set mirror_symmetrise = true or mirror_half = false",
        ));
    }
    Ok(())
}

/// The drop of a 2-D plan (Beard–Chuang, or the cosine series fitted to `profile_r`, with its
/// fit residual).
fn drop_shape(p: &RaytraceParams) -> Result<(DropShape, Option<f64>), PlanError> {
    let r_um = p.radii_um[0];
    if p.shape == "beard-chuang" {
        return Ok((DropShape::beard_chuang(r_um * 1e-3), None));
    }
    let (Some(th), Some(r)) = (&p.profile_theta_deg, &p.profile_r) else {
        return Err(PlanError::invalid(
            "profile_theta_deg",
            "shape = profile needs profile_theta_deg and profile_r",
        ));
    };
    let (s, res) =
        CosineSeries::fit_table(r_um, th, r).map_err(|e| PlanError::invalid("profile_r", e))?;
    if res > 1e-3 {
        return Err(PlanError::invalid(
            "profile_r",
            format!("cosine-series fit residual {res:.2e} > 1e-3: profile too rough"),
        ));
    }
    Ok((DropShape::Series(s), Some(res)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raytrace::post::bin_edges;
    use crate::raytrace::table2d::{DOLP_CHANNEL, n_channels_2d};
    use crate::stages::Chunk;
    use crate::table::{Schema, TableContent};
    use rayon::prelude::*;

    fn plan(toml_lines: &str) -> Result<Box<dyn Job>, PlanError> {
        crate::stages::plan_from_lines(&RaytraceStage, toml_lines)
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(plan("shape = \"cube\"\nradii_um = [1000.0]").is_err());
        assert!(plan("shape = \"sphere\"\nradii_um = [400.0]\nangle_step_deg = 0.07").is_err());
        assert!(plan("shape = \"beard-chuang\"\nradii_um = [1000.0, 2000.0]").is_err());
        assert!(plan("shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [150.0]").is_err());
        assert!(plan("shape = \"sphere\"\nradii_um = [400.0]\nunknown = 1").is_err());
        assert!(plan("shape = \"profile\"\nradii_um = [1000.0]").is_err());
        assert!(plan("shape = \"sphere\"\nradii_um = [0.4]").is_err());
        assert!(plan("shape = \"sphere\"\nradii_um = [400.0]").is_ok());
    }

    /// At 0.4 mm and 500 nm with the Table 3.2 index (m = 1.335) sin(mx) vanishes (mx = 2136π);
    /// the sphere's orders p ≥ 4 (grazing waves in 1-D tables, the added orders of 2-D tables)
    /// were wrong there by orders of magnitude. Both tables now integrate to 1 before
    /// renormalisation like their neighbours, and an entry far from 1 is refused.
    #[test]
    fn tables_are_regular_where_sin_mx_vanishes() {
        let integrals = |t: &TableContent| -> Vec<f64> {
            t.attributes["integral_check"]["values"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let two_d = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"beard-chuang\"\nradii_um = [400.0]\nwavelengths_nm = [500.0]\nwater_index_model = \"sadeghi-table-3.2\"\nsun_elevation_deg = [0.0]\nrays = 60\npolar_step_deg = 0.5\nazimuth_step_deg = 30.0",
        );
        let one_d = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [500.0]\nwater_index_model = \"sadeghi-table-3.2\"\nangle_step_deg = 0.5",
        );
        for (name, t, tol) in [("2-D", &two_d, 0.05), ("1-D", &one_d, 0.02)] {
            for s in integrals(t) {
                assert!((s - 1.0).abs() < tol, "{name}: ∫ p dΩ = {s}");
            }
        }
        assert!(crate::stages::check_phase_integral(0, 1.039).is_ok());
        let e = crate::stages::check_phase_integral(3, 5.2e14).unwrap_err();
        assert!(e.to_string().contains("entry 3"), "{e}");
    }

    /// The sun elevations of a wavelength share its filter and sphere orders: the tasks of a
    /// two-elevation, two-wavelength entry, run concurrently, give the values of single-task
    /// entries, and each wavelength's fields are computed once.
    #[test]
    fn sun_elevations_share_their_wavelength_fields() {
        let lines = |l: &str, e: &str| {
            format!(
                "shape = \"beard-chuang\"\nradii_um = [1500.0]\nwavelengths_nm = [{l}]\nsun_elevation_deg = [{e}]\nrays = 60\npolar_step_deg = 1.0\nazimuth_step_deg = 20.0"
            )
        };
        let both = plan(&lines("550.0, 650.0", "0.0, 20.0")).unwrap();
        let values: Vec<Chunk> = (0..4)
            .into_par_iter()
            .map(|i| both.run_task(i).unwrap())
            .collect();
        for (i, (l, e)) in [
            ("550.0", "0.0"),
            ("550.0", "20.0"),
            ("650.0", "0.0"),
            ("650.0", "20.0"),
        ]
        .into_iter()
        .enumerate()
        {
            let single = plan(&lines(l, e)).unwrap().run_task(0).unwrap();
            assert_eq!(values[i], single, "λ = {l} nm, sun {e}°");
        }
        assert_ne!(values[0], values[1]);
    }

    /// The keys of `raytrace-phase/1` manifests are refused with a message naming the new key
    /// (never silently read in another unit).
    #[test]
    fn old_keys_are_refused_with_the_new_names() {
        let e = plan("shape = \"sphere\"\nradius_mm = [0.4]").err().unwrap();
        let t = e.to_string();
        assert!(
            t.contains("radius_mm") && t.contains("radii_um = [400.0]"),
            "{t}"
        );
        let e = plan("shape = \"sphere\"\nradii_um = [400.0]\nwavelength_nm = [650.0]")
            .err()
            .unwrap();
        assert!(e.to_string().contains("wavelengths_nm"), "{e}");
    }

    /// Default water index: IAPWS R9-97 at 20 °C, as in the mie and debye stages; axes radius ×
    /// wavelength × scattering_angle, schema version 2.
    #[test]
    fn defaults_and_axis_order_match_the_mie_stage() {
        let job = plan(
            "shape = \"sphere\"\nradii_um = [300.0, 400.0]\nwavelengths_nm = [450.0, 650.0]\nangle_step_deg = 1.0",
        )
        .unwrap();
        assert_eq!(job.parameters()["water_index_model"], "iapws1997");
        assert_eq!(job.parameters()["temperature_c"], 20.0);
        let tasks = job.tasks();
        assert_eq!(tasks[1].params["radius_um"], 300.0);
        assert_eq!(tasks[1].params["wavelength_nm"], 650.0);
        let chunks: Vec<Chunk> = (0..tasks.len()).map(|i| job.run_task(i).unwrap()).collect();
        let t = job.assemble(chunks).unwrap();
        assert_eq!(t.schema, Schema::new("raytrace-phase", 2));
        let names: Vec<&str> = t.axes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["radius", "wavelength", "scattering_angle"]);
        assert_eq!(t.axes[0].coords(), vec![300.0, 400.0]);
        assert_eq!(t.attributes["water_index_model"], "iapws1997");
        assert_eq!(t.data.len(), t.expected_len());
    }

    /// A fixed index replaces the water model: the table is the water table of that index
    /// (Table 3.2 gives 1.331 at 650 nm) and its header says so.
    #[test]
    fn a_fixed_index_is_recorded_instead_of_the_water_model() {
        let p = |model: &str| -> RaytraceParams {
            toml::from_str(&format!(
                "shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [650.0]\nwater_index_model = \"{model}\"\nangle_step_deg = 0.5"
            ))
            .unwrap()
        };
        let water = RaytraceJob::new(p("sadeghi-table-3.2")).unwrap();
        let fixed = (RaytraceJob::new(p("iapws1997")).unwrap())
            .with_refractive_index(1.331)
            .unwrap();
        let (w, f) = (
            crate::stages::run_in_memory(&water).unwrap(),
            crate::stages::run_in_memory(&fixed).unwrap(),
        );
        assert_eq!(w.data, f.data);
        assert_eq!(f.attributes["water_index_model"], "none");
        assert_eq!(f.attributes["refractive_index_real"], 1.331);
        assert!(!f.attributes.contains_key("temperature_c"));
        assert_eq!(w.attributes["water_index_model"], "sadeghi-table-3.2");
        let err = RaytraceJob::new(p("iapws1997"))
            .unwrap()
            .with_refractive_index(2.5);
        assert!(err.is_err());
    }

    #[test]
    fn sphere_table_is_normalised_and_peaks_near_mie() {
        let job = plan(
            "shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [650.0]\nwater_index_model = \"sadeghi-table-3.2\"\nangle_step_deg = 0.05",
        )
        .unwrap();
        let t = crate::stages::run_in_memory(job.as_ref()).unwrap();
        assert_eq!(t.data.len(), t.expected_len());
        let integral = t.attributes["integral_check"]["values"][0]
            .as_f64()
            .unwrap();
        // Traced orders (99.7 %) + lobe; bin-summed on the table grid.
        assert!((integral - 1.0).abs() < 0.01, "∫p = {integral}");
        // Filtered primary maximum: Lorenz–Mie 138.03° (0.4 mm, 650 nm, n = 1.331); the
        // Gaussian filter of Table 3.3 places it within 0.15°.
        let nch = t.channels.len();
        let (mut best, mut at) = (0.0, 0.0);
        for j in 0..3601 {
            let th = 0.05 * j as f64;
            if (135.0..142.0).contains(&th) && t.data[j * nch + 1] > best {
                best = t.data[j * nch + 1];
                at = th;
            }
        }
        assert!((at - 138.03).abs() < 0.15, "primary max at {at}");
        // Mie p_unpol at the main max ≈ 0.087 sr⁻¹ (miepython); GO + filter within 25 %.
        let phase_at = t.data[((at / 0.05).round() as usize) * nch] as f64;
        assert!((phase_at / 0.087 - 1.0).abs() < 0.25, "p(max) = {phase_at}");
    }

    /// A coarse 2-D Beard–Chuang table: stored bin-sum of `phase` over 4π is 1 (renormalised),
    /// the raw bin-sum is recorded, and phase = (i_perp + i_par)/2 survives the scaling.
    #[test]
    fn two_d_table_integrates_to_one() {
        let job = plan(
            "shape = \"beard-chuang\"\nradii_um = [2000.0]\nwavelengths_nm = [550.0]\nsun_elevation_deg = [0.0]\nrays = 80\npolar_step_deg = 0.5\nazimuth_step_deg = 30.0",
        )
        .unwrap();
        let t = crate::stages::run_in_memory(job.as_ref()).unwrap();
        let raw = t.attributes["integral_check"]["values"][0]
            .as_f64()
            .unwrap();
        assert!((raw - 1.0).abs() < 0.1, "raw ∫p = {raw}");
        assert_eq!(t.schema, Schema::new("raytrace-phase-2d", 2));
        let names: Vec<&str> = t.axes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "radius",
                "wavelength",
                "sun_elevation",
                "outgoing_polar",
                "outgoing_azimuth"
            ]
        );
        let (np, na, nch) = (t.axes[3].len(), t.axes[4].len(), t.channels.len());
        let dth = 0.5f64.to_radians();
        let mut s = 0.0;
        for j in 0..np {
            let (lo, hi) = bin_edges(dth * j as f64, dth);
            let om = (lo.cos() - hi.cos()) * 30f64.to_radians();
            for k in 0..na {
                let v = &t.data[(j * na + k) * nch..][..nch];
                s += v[0] as f64 * om;
                assert!((v[0] - 0.5 * (v[1] + v[2])).abs() <= 1e-5 * v[0].abs() + 1e-30);
            }
        }
        assert!((s - 1.0).abs() < 1e-5, "stored ∫p = {s}");
    }

    /// The channels of pixel (polar row j, azimuth column k) of a one-entry 2-D table.
    fn at(t: &TableContent, na: usize, nch: usize, j: usize, k: usize) -> &[f32] {
        &t.data[(j * na + k) * nch..][..nch]
    }

    /// Mirror symmetrisation (RT-24): without it a Beard–Chuang table breaks φ ↔ 360° − φ by ray
    /// noise; with it every channel is symmetric (dolp recomputed), the unsymmetrised table's
    /// pair means are kept and the header says so.
    #[test]
    fn two_d_tables_are_mirror_symmetric_in_azimuth() {
        let lines = |on: bool| {
            format!(
                "shape = \"beard-chuang\"\nradii_um = [1500.0]\nwavelengths_nm = [550.0]\nsun_elevation_deg = [10.0]\nrays = 60\npolar_step_deg = 1.0\nazimuth_step_deg = 20.0\nmirror_symmetrise = {on}"
            )
        };
        let raw = crate::stages::table_from_lines(&RaytraceStage, &lines(false));
        let sym = crate::stages::table_from_lines(&RaytraceStage, &lines(true));
        let (np, na, nch) = (raw.axes[3].len(), raw.axes[4].len(), raw.channels.len());
        assert_eq!(na, 18);
        let (mut asym_raw, mut asym_sym, mut norm) = (0.0f64, 0.0f64, 0.0f64);
        for j in 0..np {
            for k in 1..na / 2 {
                let (a, b) = (at(&raw, na, nch, j, k), at(&raw, na, nch, j, na - k));
                let (c, d) = (at(&sym, na, nch, j, k), at(&sym, na, nch, j, na - k));
                asym_raw += ((a[0] - b[0]) as f64).powi(2);
                asym_sym += ((c[0] - d[0]) as f64).powi(2);
                norm += ((a[0] + b[0]) as f64 / 2.0).powi(2);
                assert_eq!(c, d, "row {j}, column {k}");
                // Same renormalisation factor up to f32 rounding of the sums: pair means agree.
                let mean = 0.5 * (a[1] as f64 + b[1] as f64);
                assert!(
                    (c[1] as f64 - mean).abs() <= 1e-4 * mean + 1e-12,
                    "{} vs {mean}",
                    c[1]
                );
            }
        }
        let rel = (asym_raw / norm).sqrt();
        assert!(rel > 1e-5, "unsymmetrised table already symmetric: {rel}");
        assert_eq!(asym_sym, 0.0);
        assert!(
            sym.attributes["mirror_symmetrisation"]
                .as_str()
                .unwrap()
                .starts_with("applied")
        );
    }

    /// `diagnostic_channels = false` keeps the contract's four channels, with the values of the
    /// full table's first four (the renormalisation uses the phase channel only), for a 2-D
    /// drop and for a sphere (1-D path).
    #[test]
    fn contract_channels_only_equal_the_full_tables_first_four() {
        let two_d = "shape = \"beard-chuang\"\nradii_um = [1500.0]\nwavelengths_nm = [550.0]\nsun_elevation_deg = [10.0]\nrays = 60\npolar_step_deg = 1.0\nazimuth_step_deg = 20.0\n";
        let sphere = "shape = \"sphere\"\nradii_um = [300.0]\nwavelengths_nm = [450.0, 650.0]\nangle_step_deg = 0.5\n";
        for base in [two_d, sphere] {
            let full = crate::stages::table_from_lines(&RaytraceStage, base);
            let four = crate::stages::table_from_lines(
                &RaytraceStage,
                &format!("{base}diagnostic_channels = false"),
            );
            let names: Vec<&str> = four.channels.iter().map(|c| c.name.as_str()).collect();
            assert_eq!(names, ["phase", "i_perp", "i_par", "dolp"]);
            assert!(full.channels.len() > 4);
            assert_eq!(four.channels[..], full.channels[..4]);
            let nch = full.channels.len();
            assert_eq!(four.data.len() * nch, full.data.len() * 4);
            for (a, b) in four.data.chunks(4).zip(full.data.chunks(nch)) {
                assert_eq!(a, &b[..4]);
            }
        }
    }

    /// `sphere_higher_orders` (RT-37): a sphere through the 2-D path (shape `profile`, constant
    /// radius, 0.4 mm) with orders ≤ 3 traced has Alexander's band (mean phase over 131°–136°
    /// and over azimuth) within 10 % of the project's Lorenz–Mie with the equal-volume sphere's
    /// orders 4–6 added (measured 0.967), and more than 10 % below it without them (0.852); the
    /// header names the added orders only when they are added.
    #[test]
    fn two_d_sphere_tables_fill_alexanders_band() {
        let (a_um, lambda, n) = (400.0, 650.0, 1.331);
        let base = format!(
            "shape = \"profile\"\nradii_um = [{a_um}]\nwavelengths_nm = [{lambda}]\nwater_index_model = \"sadeghi-table-3.2\"\nsun_elevation_deg = [17.0]\nrays = 200\npolar_step_deg = 0.05\nazimuth_step_deg = 30.0\nprofile_theta_deg = [0.0, 90.0, 180.0]\nprofile_r = [1.0, 1.0, 1.0]\n"
        );
        let x = crate::mie::size_parameter(a_um, lambda);
        let sphere = crate::mie::Sphere::new(x, num_complex::Complex64::new(n, 0.0)).unwrap();
        let band: Vec<f64> = (0..=100).map(|j| 131.0 + 0.05 * j as f64).collect();
        let (s1, s2) = sphere.amplitudes_deg(&band);
        let norm = sphere.phase_normalisation();
        let mie = s1
            .iter()
            .zip(&s2)
            .map(|(a, b)| 0.5 * (a.norm_sqr() + b.norm_sqr()) / norm)
            .sum::<f64>()
            / band.len() as f64;
        let ratio = |extra: &str| {
            let t = crate::stages::table_from_lines(&RaytraceStage, &format!("{base}{extra}"));
            let (na, nch) = (t.axes[4].len(), t.channels.len());
            let rows = (131.0f64 / 0.05).round() as usize..=(136.0f64 / 0.05).round() as usize;
            let (mut s, mut count) = (0.0, 0);
            for j in rows {
                for k in 0..na {
                    s += at(&t, na, nch, j, k)[0] as f64;
                    count += 1;
                }
            }
            (
                s / count as f64 / mie,
                t.attributes.contains_key("sphere_higher_orders"),
            )
        };
        let (with, recorded) = ratio("");
        assert!((0.9..=1.1).contains(&with), "band {with} of Mie");
        assert!(recorded);
        let (without, recorded) = ratio("sphere_higher_orders = false\n");
        assert!(without < 0.9, "orders ≤ 3 alone: band {without} of Mie");
        assert!(!recorded);
    }

    /// `mirror_half` (RT-34): with the Gaussian filter (no smoothing over azimuth) the held
    /// columns 0°–180° equal the unsymmetrised table's, the others are their mirror images, and
    /// the header says so; with airy-local (caustic positions smoothed across φ = 0°, 180°) the
    /// table stays within ray noise of the averaged one; contradicting `mirror_symmetrise =
    /// false` is refused.
    #[test]
    fn mirror_half_tables_copy_the_held_half() {
        let lines = |extra: &str| {
            format!(
                "shape = \"beard-chuang\"\nradii_um = [1500.0]\nwavelengths_nm = [550.0]\nsun_elevation_deg = [10.0]\nrays = 60\npolar_step_deg = 1.0\nazimuth_step_deg = 20.0\n{extra}"
            )
        };
        let gauss = "diffraction_model = \"gaussian\"\n";
        let raw = crate::stages::table_from_lines(
            &RaytraceStage,
            &lines(&format!("{gauss}mirror_symmetrise = false")),
        );
        let half = crate::stages::table_from_lines(
            &RaytraceStage,
            &lines(&format!("{gauss}mirror_half = true")),
        );
        let (np, na, nch) = (raw.axes[3].len(), raw.axes[4].len(), raw.channels.len());
        assert_eq!(na, 18);
        // The renormalisation divides by the bin sum over 4π, which differs between the two
        // tables by the asymmetry of the other half: equal up to one factor per table.
        let scale = at(&raw, na, nch, 100, 3)[1] as f64 / at(&half, na, nch, 100, 3)[1] as f64;
        assert!(
            (scale - 1.0).abs() < 0.05,
            "renormalisations differ by {scale}"
        );
        for j in 0..np {
            for k in 0..na {
                let h = at(&half, na, nch, j, k);
                if k > na / 2 {
                    assert_eq!(h, at(&half, na, nch, j, na - k), "row {j}, column {k}");
                    continue;
                }
                for (c, (x, y)) in h.iter().zip(at(&raw, na, nch, j, k)).enumerate() {
                    let (x, y) = (*x as f64, *y as f64);
                    let want = if c == DOLP_CHANNEL { y } else { y / scale };
                    assert!(
                        (x - want).abs() <= 1e-5 * want.abs() + 1e-12,
                        "row {j}, column {k}, channel {c}: {x} vs {want}"
                    );
                }
            }
        }
        assert!(
            half.attributes["mirror_symmetrisation"]
                .as_str()
                .unwrap()
                .starts_with("by construction")
        );
        let avg = crate::stages::table_from_lines(&RaytraceStage, &lines(""));
        let half_local =
            crate::stages::table_from_lines(&RaytraceStage, &lines("mirror_half = true"));
        let (mut d2, mut n2) = (0.0f64, 0.0f64);
        for (a, b) in avg.data.chunks(nch).zip(half_local.data.chunks(nch)) {
            d2 += (a[0] as f64 - b[0] as f64).powi(2);
            n2 += (a[0] as f64).powi(2);
        }
        let rel = (d2 / n2).sqrt();
        assert!(
            rel > 0.0 && rel < 0.1,
            "mirror-half vs averaged table: {rel}"
        );
        let err = crate::stages::plan_from_lines(
            &RaytraceStage,
            &lines("mirror_half = true\nmirror_symmetrise = false"),
        )
        .err()
        .expect("contradiction refused")
        .to_string();
        assert!(err.contains("mirror_half"), "{err}");
    }

    /// The header records, per entry and bow, where airy-local used the sphere's transfer: every
    /// column of a 0.4 mm drop (a sphere), few of a 2 mm drop at sun 0° (its primary caustic is
    /// no longer the sphere's fold); counts partition the columns and the listed ranges hold
    /// exactly the columns without the transfer; no record for the Gaussian model.
    #[test]
    fn airy_local_tables_record_their_domain() {
        let lines = |radius: f64, extra: &str| {
            format!(
                "shape = \"beard-chuang\"\nradii_um = [{radius}]\nwavelengths_nm = [550.0, 650.0]\nsun_elevation_deg = [0.0]\nrays = 400\npolar_step_deg = 0.0125\nazimuth_step_deg = 10.0\n{extra}"
            )
        };
        let entries = |t: &TableContent| t.attributes["airy_local_domain"]["entries"].clone();
        let count = |v: &serde_json::Value, key: &str| v[key].as_u64().unwrap() as usize;
        let sphere = crate::stages::table_from_lines(&RaytraceStage, &lines(400.0, ""));
        let e = entries(&sphere);
        assert_eq!(e.as_array().unwrap().len(), 2);
        assert_eq!(e[1]["wavelength_nm"], 650.0);
        for entry in e.as_array().unwrap() {
            for bow in ["primary", "secondary"] {
                assert_eq!(count(&entry[bow], "transfer_columns"), 36, "{entry}");
                assert!(
                    entry[bow]["not_transfer_azimuth_ranges_deg"]
                        .as_array()
                        .unwrap()
                        .is_empty()
                );
            }
        }
        let drop = crate::stages::table_from_lines(&RaytraceStage, &lines(2000.0, ""));
        let mut outside = 0;
        for entry in entries(&drop).as_array().unwrap() {
            for bow in ["primary", "secondary"] {
                let b = &entry[bow];
                let (t, m, g) = (
                    count(b, "transfer_columns"),
                    count(b, "blended_columns"),
                    count(b, "gaussian_columns"),
                );
                assert_eq!(t + m + g, 36, "{b}");
                let listed: f64 = b["not_transfer_azimuth_ranges_deg"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|r| (r[1].as_f64().unwrap() - r[0].as_f64().unwrap()) / 10.0 + 1.0)
                    .sum();
                assert_eq!(listed as usize, m + g, "{b}");
                outside += g;
            }
        }
        assert!(
            outside > 0,
            "a 2 mm drop at sun 0° keeps the sphere's transfer everywhere"
        );
        let gauss = crate::stages::table_from_lines(
            &RaytraceStage,
            &lines(400.0, "diffraction_model = \"gaussian\""),
        );
        assert!(!gauss.attributes.contains_key("airy_local_domain"));
    }

    /// On a 2 mm drop with the sun on the horizon most columns leave the airy-local domain:
    /// there the default table is the Gaussian filter's, value for value, and it keeps the
    /// values the Gaussian filter keeps positive.
    #[test]
    fn airy_local_takes_the_gaussian_filter_outside_its_domain() {
        let lines = |model: &str| {
            format!(
                "shape = \"beard-chuang\"\nradii_um = [2000.0]\nwavelengths_nm = [650.0]\nsun_elevation_deg = [0.0]\nrays = 200\npolar_step_deg = 0.05\nazimuth_step_deg = 10.0\nmirror_symmetrise = false{model}"
            )
        };
        let default = crate::stages::table_from_lines(&RaytraceStage, &lines(""));
        let gaussian = crate::stages::table_from_lines(
            &RaytraceStage,
            &lines("\ndiffraction_model = \"gaussian\""),
        );
        assert!(
            default.attributes["diffraction_filter"]
                .as_str()
                .unwrap()
                .starts_with("airy-local")
        );
        let (np, na, nch) = (
            default.axes[3].len(),
            default.axes[4].len(),
            default.channels.len(),
        );
        // Primary rows (130–150°): columns equal to the Gaussian's over the whole range.
        let (j0, j1) = ((130.0 / 0.05) as usize, (150.0 / 0.05) as usize);
        // Renormalisation factors differ by the flux the two models move: compare shapes.
        let col = |t: &TableContent, k: usize| -> Vec<f64> {
            (j0..=j1)
                .map(|j| t.data[(j * na + k) * nch] as f64)
                .collect()
        };
        let mut same = 0;
        for k in 0..na {
            let (a, b) = (col(&default, k), col(&gaussian, k));
            let r = a[0] / b[0];
            if a.iter()
                .zip(&b)
                .all(|(x, y)| (x - r * y).abs() <= 1e-5 * y.abs() + 1e-12)
            {
                same += 1;
            }
            for (x, y) in a.iter().zip(&b) {
                assert!(*y <= 0.0 || *x > 0.0, "column {k}: {x} where gaussian {y}");
            }
        }
        assert!(
            same >= na / 2,
            "{same} of {na} columns are the Gaussian filter's"
        );
        assert!(same < na, "every column left the domain");
        assert_eq!(default.data.len(), np * na * nch);
    }

    /// Sphere tables trace orders up to 6 by default, which puts Alexander's dark band
    /// (131–136°) within 10 % of the project's Lorenz–Mie at 0.4 mm (p ≤ 3: 14 % low); 2-D
    /// shapes keep 3.
    #[test]
    fn sphere_tables_fill_alexanders_band_by_default() {
        let t = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"sphere\"\nradii_um = [400.0]\nwavelengths_nm = [650.0]\nwater_index_model = \"sadeghi-table-3.2\"\nangle_step_deg = 0.05",
        );
        assert_eq!(t.attributes["max_order"], 6);
        let nch = t.channels.len();
        let band = |v: &dyn Fn(f64) -> f64| -> f64 {
            let ang: Vec<f64> = (0..=100).map(|i| 131.0 + 0.05 * i as f64).collect();
            ang.iter().map(|&a| v(a)).sum::<f64>() / ang.len() as f64
        };
        let table = band(&|a| t.data[(a / 0.05).round() as usize * nch] as f64);
        let x = crate::mie::size_parameter(400.0, 650.0);
        let sphere = crate::mie::Sphere::new(x, num_complex::Complex64::new(1.331, 0.0)).unwrap();
        let norm = sphere.phase_normalisation();
        let mie = band(&|a| {
            let (s1, s2) = sphere.amplitudes_deg(&[a]);
            0.5 * (s1[0].norm_sqr() + s2[0].norm_sqr()) / norm
        });
        let r = table / mie;
        assert!((0.9..=1.1).contains(&r), "band over Mie: {r}");
        eprintln!("Alexander band of the default 0.4 mm sphere table over Mie: {r:.4}");
        let bc = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"beard-chuang\"\nradii_um = [1000.0]\nwavelengths_nm = [650.0]\nrays = 20\npolar_step_deg = 1.0\nazimuth_step_deg = 30.0",
        );
        assert_eq!(bc.attributes["max_order"], 3);
        assert_eq!(bc.channels.len(), n_channels_2d(4, true));
    }
}

#[cfg(test)]
mod compact_tests {
    use super::*;
    use crate::raytrace::compact;
    use crate::raytrace::tracer::DirectionGrid;
    use crate::table::{Provenance, Table, TableContent};

    /// A sphere (Beard–Chuang at 0.4 mm) at two sun elevations, small enough for a unit test.
    const BASE: &str = "shape = \"beard-chuang\"\nradii_um = [400.0]\nwavelengths_nm = [650.0]\nsun_elevation_deg = [10.0, 30.0]\nrays = 300\npolar_step_deg = 0.05\nazimuth_step_deg = 5.0\ndiagnostic_channels = false\n";

    fn compact_lines(tolerance: f64) -> String {
        format!("{BASE}compression = {{ kind = \"sun-disc-resampled\", tolerance = {tolerance} }}")
    }

    /// The dense table's entry `e` seen through the sun's disc: (i_perp, i_par) on its grid.
    fn filtered_dense(t: &TableContent, e: usize) -> (Vec<f64>, Vec<f64>) {
        let (np, na) = (t.axes[3].len(), t.axes[4].len());
        let grid = DirectionGrid {
            n_polar: np,
            n_azimuth: na,
        };
        let entry = &t.data[e * np * na * 4..][..np * na * 4];
        let comp = |c: usize| {
            let v: Vec<f64> = entry.iter().skip(c).step_by(4).map(|&x| x as f64).collect();
            compact::disc_filter(&v, grid, 0.125)
        };
        (comp(1), comp(2))
    }

    /// A compact table samples (Table::sample, the readers' bilinear lookup) within its stated
    /// tolerance of the dense table seen through the same disc, at random directions of both
    /// entries (the reference interpolated bilinearly on the dense grid); the largest error
    /// found stays within the header's measured maximum; the header is consistent with the
    /// axes; the polar axis is shorter than the dense one; the `rms` norm meets its tolerance
    /// in every window.
    #[test]
    fn compact_tables_sample_within_their_stated_error() {
        let dense = crate::stages::table_from_lines(&RaytraceStage, BASE);
        let compact = crate::stages::table_from_lines(&RaytraceStage, &compact_lines(0.01));
        let c = &compact.attributes["compression"];
        assert_eq!(c["kind"], "sun-disc-resampled");
        assert_eq!(c["tolerance"], 0.01);
        assert!(c["sun_disc"].as_str().unwrap().starts_with("applied"));
        assert_eq!(compact.attributes["sun_diameter_deg"], 0.5);
        assert_eq!(dense.attributes["sun_diameter_deg"], 0.0);
        let stated = c["max_relative_error"].as_f64().unwrap();
        assert!(stated > 0.0 && stated <= 0.01, "{stated}");
        assert_eq!(c["entries"].as_array().unwrap().len(), 2);
        assert_eq!(c["knots"]["outgoing_polar"], compact.axes[3].len());
        assert_eq!(c["knots"]["outgoing_azimuth"], compact.axes[4].len());
        // Mirror symmetric entries (the default `mirror_symmetrise`) store 0°–180° of azimuth
        // on an even-periodic axis (table format 3.0); lookups beyond 180° fold onto it, which
        // `sampled_worst_error` checks against the dense table's own values there.
        assert_eq!(compact.axes[4].coords().last(), Some(&180.0));
        assert_eq!(
            compact.axes[4].symmetry,
            Some(crate::table::Symmetry::EvenPeriodic { period: 360.0 })
        );
        // At 300² rays the ray noise of this coarse grid keeps every 5° azimuth column; the
        // polar axis still drops a third of its rows.
        assert!(
            compact.axes[3].len() * 3 < dense.axes[3].len() * 2,
            "knots {}",
            c["knots"]
        );
        let table = Table::from_content(compact, Provenance::default()).unwrap();
        let worst = sampled_worst_error(&dense, &table);
        assert!(
            worst > 0.0 && worst <= stated * (1.0 + 1e-6) + 1e-7,
            "{worst} vs {stated}"
        );
        let rms = crate::stages::table_from_lines(
            &RaytraceStage,
            &compact_lines(0.01).replace(" }", ", norm = \"rms\" }"),
        );
        let c = &rms.attributes["compression"];
        assert_eq!(c["norm"], "rms");
        let window_rms = c["max_window_rms_relative"].as_f64().unwrap();
        assert!(window_rms > 0.0 && window_rms <= 0.01, "{window_rms}");
    }

    /// The largest error of `table`'s lookups (phase, i_perp, i_par) relative to the phase of
    /// the `dense` table seen through the sun's disc, at random directions of both entries (the
    /// reference interpolated bilinearly on the dense grid).
    fn sampled_worst_error(dense: &TableContent, table: &Table) -> f64 {
        let (np, na) = (dense.axes[3].len(), dense.axes[4].len());
        let (dp, da) = (0.05, 5.0);
        let mut rng = 0x2545f4914f6cdd1du64;
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut worst = 0.0f64;
        for (e, elevation) in [10.0, 30.0].into_iter().enumerate() {
            let (p, q) = filtered_dense(dense, e);
            for _ in 0..4000 {
                // Within the dense grid's azimuth range, which stops one step short of 360°.
                let (theta, phi) = (180.0 * uniform(), da * (na - 1) as f64 * uniform());
                let (j, u) = ((theta / dp).floor() as usize, (theta / dp).fract());
                let (k, t) = ((phi / da).floor() as usize, (phi / da).fract());
                let (j1, k1) = ((j + 1).min(np - 1), (k + 1).min(na - 1));
                let bil = |f: &[f64]| {
                    let lo = (1.0 - t) * f[j * na + k] + t * f[j * na + k1];
                    let hi = (1.0 - t) * f[j1 * na + k] + t * f[j1 * na + k1];
                    (1.0 - u) * lo + u * hi
                };
                let (ip, ia) = (bil(&p), bil(&q));
                let phase = 0.5 * (ip + ia);
                let got = table
                    .sample(&[400.0, 650.0, elevation, theta, phi])
                    .unwrap();
                for (g, want) in got[..3].iter().zip([phase, ip, ia]) {
                    worst = worst.max((g - want).abs() / phase);
                }
            }
        }
        worst
    }

    /// `values = "top16"`: the table is written as format 2.0 with i_perp and i_par as 16-bit
    /// codes and phase and dolp derived, smaller than the f32 table; read back from its bytes,
    /// its lookups stay within the stated maximum error (measured with the decoded values, the
    /// two entries' knots merged), which stays within the tolerance; the `rms` norm meets its
    /// tolerance in every window. Its stated errors are not those of the f32 table.
    #[test]
    fn top16_compact_tables_read_back_within_their_stated_error() {
        let top16 = |norm: &str| {
            compact_lines(0.01)
                .replace(" }", &format!(", norm = \"{norm}\", values = \"top16\" }}"))
        };
        let dense = crate::stages::table_from_lines(&RaytraceStage, BASE);
        let content = crate::stages::table_from_lines(&RaytraceStage, &top16("max"));
        let c = content.attributes["compression"].clone();
        assert_eq!(c["values"], "top16");
        // Within the tolerance, plus the bound of the second rounding at the knots the two
        // entries do not share (docs/raytrace.md, "Compact tables", step 4).
        let stated = c["max_relative_error"].as_f64().unwrap();
        let merged_rounding = crate::table::codec::TOP16_MAX_RELATIVE_ERROR * (2.0 + 0.01);
        assert!(stated > 0.0 && stated <= 0.01 + merged_rounding, "{stated}");
        let mut f32_table = Table::from_content(
            crate::stages::table_from_lines(&RaytraceStage, &compact_lines(0.01)),
            Provenance::default(),
        )
        .unwrap();
        let f32_stated = &f32_table.header.attributes["compression"]["max_relative_error"];
        assert_ne!(c["max_relative_error"], *f32_stated);
        let mut written = Table::from_content(content, Provenance::default()).unwrap();
        let bytes = written.to_bytes().unwrap();
        // 16-bit codes (2.0) on a symmetric azimuth axis (3.0).
        assert_eq!(&bytes[8..12], &[3, 0, 0, 0]);
        assert!(bytes.len() < f32_table.to_bytes().unwrap().len());
        let table = Table::from_bytes(&bytes, std::path::Path::new("top16.sbt")).unwrap();
        assert_eq!(table.data, written.data);
        let derived: Vec<_> = table
            .header
            .channels
            .iter()
            .map(|c| c.derived.is_some())
            .collect();
        assert_eq!(derived, [true, false, false, true]);
        let worst = sampled_worst_error(&dense, &table);
        assert!(
            worst > 0.0 && worst <= stated * (1.0 + 1e-6) + 1e-7,
            "{worst} vs {stated}"
        );
        let rms = crate::stages::table_from_lines(&RaytraceStage, &top16("rms"));
        let window_rms = rms.attributes["compression"]["max_window_rms_relative"].as_f64();
        assert!(
            window_rms.is_some_and(|r| r > 0.0 && r <= 0.01),
            "{window_rms:?}"
        );
    }

    /// A compact plan bounds its table by the dense grid and estimates
    /// the stored size from the fraction measured for its shape and norm.
    #[test]
    fn compact_plans_bound_the_table_by_its_dense_grid() {
        use crate::stages::cost::*;
        let plan = |lines: &str| crate::stages::plan_from_lines(&RaytraceStage, lines).unwrap();
        let sphere = plan(&compact_lines(0.01));
        let shape = sphere.shape();
        assert!(shape.adaptive);
        assert_eq!(shape.axes[3].len(), 3601);
        assert_eq!(shape.axes[4].len(), 72);
        assert_eq!(
            sphere.estimated_stored_fraction(),
            STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE
        );
        let drop = compact_lines(0.01).replace("[400.0]", "[1500.0]");
        assert_eq!(
            plan(&drop).estimated_stored_fraction(),
            STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX
        );
        let rms = drop.replace(" }", ", norm = \"rms\" }");
        assert_eq!(
            plan(&rms).estimated_stored_fraction(),
            STORED_FRACTION_RAYTRACE_2D_COMPACT_RMS
        );
        let top16 = |lines: &str| lines.replace(" }", ", values = \"top16\" }");
        for (lines, fraction) in [
            (top16(&rms), STORED_FRACTION_RAYTRACE_2D_COMPACT_TOP16),
            (top16(&drop), STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX_TOP16),
            (
                top16(&compact_lines(0.01)),
                STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE_TOP16,
            ),
        ] {
            assert_eq!(
                plan(&lines).estimated_stored_fraction(),
                fraction,
                "{lines}"
            );
        }
        assert!(!plan(BASE).shape().adaptive);
    }

    /// A compact plan's header estimate lists the knots the table is expected to hold: polar
    /// knots spread over the dense grid (at most it), the azimuths 0° and 180° of a sphere or
    /// a drop's whole stored half circle, on an even-periodic axis.
    #[test]
    fn compact_plans_list_the_knots_the_header_will_hold() {
        use crate::stages::cost::RAYTRACE_2D_COMPACT_POLAR_KNOTS;
        use crate::table::Symmetry;
        let plan = |lines: &str| crate::stages::plan_from_lines(&RaytraceStage, lines).unwrap();
        assert!(plan(BASE).estimated_header_axes().is_none());
        let sphere = plan(&compact_lines(0.01)).estimated_header_axes().unwrap();
        let polar = sphere[3].coords();
        assert_eq!(polar.len(), 2 * RAYTRACE_2D_COMPACT_POLAR_KNOTS);
        assert_eq!((polar[0], *polar.last().unwrap()), (0.0, 180.0));
        assert!(polar.windows(2).all(|w| w[0] < w[1]));
        assert!(
            polar
                .iter()
                .all(|p| (p / 0.05 - (p / 0.05).round()).abs() < 1e-9)
        );
        let half = Some(Symmetry::EvenPeriodic { period: 360.0 });
        assert_eq!(sphere[4].coords(), [0.0, 180.0]);
        assert_eq!(sphere[4].symmetry, half);
        let drop = compact_lines(0.01).replace("[400.0]", "[1500.0]");
        let drop = plan(&drop).estimated_header_axes().unwrap();
        let azimuth: Vec<f64> = (0..=36).map(|i| 5.0 * i as f64).collect();
        assert_eq!(drop[4].coords(), azimuth);
        assert_eq!(drop[4].symmetry, half);
        let one_entry = compact_lines(0.01).replace("[10.0, 30.0]", "[10.0]");
        let one_entry = plan(&one_entry).estimated_header_axes().unwrap();
        assert_eq!(one_entry[3].len(), RAYTRACE_2D_COMPACT_POLAR_KNOTS);
        let coarse = compact_lines(0.01).replace("polar_step_deg = 0.05", "polar_step_deg = 0.5");
        assert_eq!(plan(&coarse).estimated_header_axes().unwrap()[3].len(), 361);
    }

    /// `compression = "none"` is the default table, with the same resolved parameters (content
    /// key); a tolerance below the f32 rounding of the stored values is refused at build time;
    /// compression on spheres or with the diagnostic channels is refused at plan time.
    #[test]
    fn compression_none_is_the_dense_table_and_unmeetable_tolerances_are_refused() {
        let one = BASE.replace("[10.0, 30.0]", "[30.0]");
        let default = crate::stages::plan_from_lines(&RaytraceStage, &one).unwrap();
        let none =
            crate::stages::plan_from_lines(&RaytraceStage, &format!("{one}compression = \"none\""))
                .unwrap();
        assert_eq!(default.parameters(), none.parameters());
        assert!(default.parameters().get("compression").is_none());
        let a = crate::stages::run_in_memory(default.as_ref()).unwrap();
        let b = crate::stages::run_in_memory(none.as_ref()).unwrap();
        assert_eq!(a, b);
        assert!(!a.attributes.contains_key("compression"));
        let tight = crate::stages::plan_from_lines(
            &RaytraceStage,
            &compact_lines(1e-9).replace("[10.0, 30.0]", "[30.0]"),
        )
        .unwrap();
        assert!(tight.parameters()["compression"]["tolerance"] == 1e-9);
        let e = crate::stages::run_in_memory(tight.as_ref()).unwrap_err();
        assert!(
            matches!(e, JobError::CompressionTolerance { entry: 0, .. }),
            "{e}"
        );
        assert!(
            e.to_string().contains("exceeds the stated tolerance"),
            "{e}"
        );
        let spec = "compression = { kind = \"sun-disc-resampled\", tolerance = 0.01 }";
        for (lines, says) in [
            (
                format!("shape = \"sphere\"\nradii_um = [400.0]\n{spec}"),
                "2-D",
            ),
            (
                BASE.replace("diagnostic_channels = false\n", &format!("{spec}\n")),
                "diagnostic_channels",
            ),
            (
                format!("{BASE}compression = \"zstd\""),
                "sun-disc-resampled",
            ),
            (
                format!("{BASE}compression = {{ kind = \"sun-disc-resampled\", tolerance = 2.0 }}"),
                "tolerance",
            ),
        ] {
            let e = crate::stages::plan_from_lines(&RaytraceStage, &lines)
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains(says), "{lines}: {e}");
        }
    }
}
