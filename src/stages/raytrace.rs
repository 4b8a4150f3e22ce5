//! `raytrace` stage: wave-optics ray-traced phase functions of raindrops.
//!
//! Parameters use the vocabulary of the other phase-function stages (`docs/vocabulary.md`):
//! `radii_um`, `wavelengths_nm`, `water_index_model` (default `iapws1997`), `temperature_c`.
//!
//! - `shape = "sphere"`: schema `raytrace-phase/2`, axes radius (µm) × wavelength (nm) ×
//!   scattering_angle (deg, uniform over [0, 180]), as `mie-phase` and `debye-phase`; computed by
//!   the exact 1-D geometric-optics-plus-phase path ([`crate::raytrace::sphere1d`]), which the
//!   general 2-D tracer is validated against (tests/raytrace_validation.rs).
//! - `shape = "beard-chuang"` or `"profile"`: schema `raytrace-phase-2d/2`, axes radius (µm, one
//!   value) × wavelength (nm) × sun_elevation (deg) × outgoing_polar (deg from the incident
//!   direction, 0 = forward) × outgoing_azimuth (deg, 0..360, from the vertical plane containing
//!   the incident direction, towards +y; see [`crate::raytrace::tracer`] for the frame); computed
//!   by the 2-D patch tracer.
//!
//! Version 1 of both schemas had the axes wavelength × radius (1-D) and wavelength × sun_elevation
//! (2-D, radius only in the `radius_mm` attribute) and was written from the keys `radius_mm` and
//! `wavelength_nm`; those keys are now refused with a message giving the new ones.
//!
//! Channels (both schemas): phase, i_perp, i_par, dolp, phase_p0..phase_pN (per order,
//! filtered), phase_unfiltered, i_perp_unfiltered, i_par_unfiltered; all in 1/sr normalised
//! against the full scattering cross-section σ = σ_GO (traced orders) + A (forward Fraunhofer
//! lobe of the projected area A): i_perp = (dσ/dΩ)_⊥/σ, i_par = (dσ/dΩ)_∥/σ and
//! phase = (i_perp + i_par)/2, so that ∫_{4π} phase dΩ = 1 up to the flux of triangles discarded
//! at the silhouette (reported in the attributes). For a sphere this is the `mie` normalisation
//! i_perp = |S1|²/(π x² Q_sca).

use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::raytrace::compact::{self, CompactEntry, Components, Compression};
use crate::raytrace::domain;
use crate::raytrace::post::{filter_sigma_deg, integral_1d};
use crate::raytrace::shape::{CosineSeries, DropShape};
use crate::raytrace::sphere1d::{
    DiffractionModel, SPHERE_MAX_ORDER, SphereTableOptions, sphere_table_channels,
};
use crate::raytrace::table2d::{
    Table2dOptions, Trace2d, WavelengthCache, WavelengthFields, divide_intensities,
    entry_integral_2d, trace_table_2d,
};
use crate::raytrace::tracer::{DirectionGrid, RayGridLayout};
use crate::stages::cost::{RAYTRACE_2D_COST, SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH};
use crate::stages::phase_contract;
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunk, check_chunks, checks,
    concat_values, stage_params,
};
use crate::table::{Axis, Channel, Schema, TableContent};

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

fn divides(total: f64, step: f64) -> Option<usize> {
    if step.is_nan() || step <= 0.0 {
        return None;
    }
    let n = total / step;
    // At most 1e7 steps: a tiny step would overflow the grid's sample count.
    if (n - n.round()).abs() < 1e-6 && (2.0..=1e7).contains(&n.round()) {
        Some(n.round() as usize)
    } else {
        None
    }
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
    const VERSION: u32 = 12;
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
    /// The highest order traced (`max_order`, or its default for the shape).
    max_order: usize,
    model: WaterIndexModel,
    /// A fixed real index replacing the water model (single queries; see
    /// [`RaytraceJob::with_refractive_index`]).
    fixed_index: Option<f64>,
    two_d: bool,
    shape: Option<DropShape>,
    profile_fit_residual: Option<f64>,
    /// What a 2-D entry computes once per wavelength for all its sun elevations.
    per_wavelength: WavelengthCache,
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
    if divides(180.0, p.polar_step_deg).is_none() {
        return Err(PlanError::invalid(
            "polar_step_deg",
            "must be > 0 and divide 180 into 2 to 1e7 steps",
        ));
    }
    if divides(360.0, p.azimuth_step_deg).is_none() {
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

/// Divide the intensity channels of 2-D entry `e` by its bin-sum over 4π (decision RT-21) and
/// return the bin-sum; an entry that cannot be normalised or integrates implausibly is refused.
fn renormalise_entry(
    e: usize,
    entry: &mut [f32],
    grid: DirectionGrid,
    nch: usize,
) -> Result<f64, JobError> {
    let s = entry_integral_2d(entry, grid, nch);
    if !(s > 0.0 && s.is_finite()) {
        return Err(JobError::NotNormalisable {
            entry: e,
            integral: s,
        });
    }
    crate::stages::check_phase_integral(e, s)?;
    divide_intensities(entry, grid.n_azimuth * nch, nch, s);
    Ok(s)
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
        check_compression(&p, two_d_shape)?;
        let two_d = match p.shape.as_str() {
            "sphere" => false,
            "beard-chuang" | "profile" => true,
            other => {
                return Err(PlanError::invalid(
                    "shape",
                    format!("unknown shape `{other}` (sphere, beard-chuang, profile)"),
                ));
            }
        };
        let mut job = RaytraceJob {
            p,
            max_order,
            model,
            fixed_index: None,
            two_d,
            shape: None,
            profile_fit_residual: None,
            per_wavelength: WavelengthCache::default(),
        };
        if !two_d {
            if divides(180.0, job.p.angle_step_deg).is_none() {
                return Err(PlanError::invalid(
                    "angle_step_deg",
                    "must be > 0 and divide 180 into 2 to 1e7 steps",
                ));
            }
            return Ok(job);
        }
        check_two_d_grid(&job.p)?;
        let p = &job.p;
        let r_um = p.radii_um[0];
        let shape = if p.shape == "beard-chuang" {
            DropShape::beard_chuang(r_um * 1e-3)
        } else {
            let (Some(th), Some(r)) = (&p.profile_theta_deg, &p.profile_r) else {
                return Err(PlanError::invalid(
                    "profile_theta_deg",
                    "shape = profile needs profile_theta_deg and profile_r",
                ));
            };
            let (s, res) = CosineSeries::fit_table(r_um, th, r)
                .map_err(|e| PlanError::invalid("profile_r", e))?;
            if res > 1e-3 {
                return Err(PlanError::invalid(
                    "profile_r",
                    format!("cosine-series fit residual {res:.2e} > 1e-3: profile too rough"),
                ));
            }
            job.profile_fit_residual = Some(res);
            DropShape::Series(s)
        };
        job.shape = Some(shape);
        Ok(job)
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
        self.per_wavelength = WavelengthCache::default();
        Ok(self)
    }

    /// Refractive index at `wavelength_nm`.
    fn index(&self, wavelength_nm: f64) -> Result<f64, JobError> {
        match self.fixed_index {
            Some(n) => Ok(n),
            None => Ok(self.model.index(wavelength_nm)?),
        }
    }

    fn diffraction_model(&self) -> DiffractionModel {
        self.p.diffraction_model.unwrap_or(if self.two_d {
            DiffractionModel::AiryLocal
        } else {
            DiffractionModel::AiryUniform
        })
    }

    fn n_angles(&self) -> usize {
        divides(180.0, self.p.angle_step_deg).unwrap() + 1
    }

    fn direction_grid(&self) -> DirectionGrid {
        DirectionGrid {
            n_polar: divides(180.0, self.p.polar_step_deg).unwrap() + 1,
            n_azimuth: divides(360.0, self.p.azimuth_step_deg).unwrap(),
        }
    }

    /// Tasks in table order: (radius µm, wavelength nm) for spheres; (wavelength nm, sun
    /// elevation deg) of the one radius for 2-D shapes.
    fn task_pairs(&self) -> Vec<(f64, f64)> {
        let (first, second) = if self.two_d {
            (&self.p.wavelengths_nm, &self.p.sun_elevation_deg)
        } else {
            (&self.p.radii_um, &self.p.wavelengths_nm)
        };
        first
            .iter()
            .flat_map(|&f| second.iter().map(move |&s| (f, s)))
            .collect()
    }

    fn channels(&self) -> Vec<Channel> {
        crate::raytrace::channel_names(self.max_order, self.p.diagnostic_channels)
            .into_iter()
            .map(|n| {
                let (unit, meaning) = match n.as_str() {
                    "phase" => ("1/sr", "unpolarised phase function (i_perp + i_par)/2, diffraction-filtered, with forward lobe".to_string()),
                    "i_perp" => ("1/sr", "perpendicular component (dσ/dΩ)_perp/σ, for a sphere |S1|^2/(pi x^2 Q_sca); phase = (i_perp + i_par)/2".to_string()),
                    "i_par" => ("1/sr", "parallel component (dσ/dΩ)_par/σ, for a sphere |S2|^2/(pi x^2 Q_sca); phase = (i_perp + i_par)/2".to_string()),
                    "dolp" => ("1", "(i_perp − i_par)/(i_perp + i_par)".to_string()),
                    "phase_unfiltered" => ("1/sr", "phase without the Gaussian diffraction filter (forward lobe included)".to_string()),
                    "i_perp_unfiltered" => ("1/sr", "i_perp without the Gaussian filter".to_string()),
                    "i_par_unfiltered" => ("1/sr", "i_par without the Gaussian filter".to_string()),
                    other => ("1/sr", format!("unpolarised contribution of order p = {} alone (filtered, no lobe)", &other[7..])),
                };
                Channel::new(&n, unit, &meaning)
            })
            .collect()
    }

    /// The table's axes: radius × wavelength × scattering angle (spheres), or radius ×
    /// wavelength × sun elevation × outgoing polar × outgoing azimuth (2-D shapes).
    fn table_axes(&self) -> Vec<Axis> {
        let mut axes = vec![
            Axis::values("radius", "um", self.p.radii_um.clone()),
            Axis::values("wavelength", "nm", self.p.wavelengths_nm.clone()),
        ];
        if self.two_d {
            let grid = self.direction_grid();
            axes.extend([
                Axis::values("sun_elevation", "deg", self.p.sun_elevation_deg.clone()),
                Axis::uniform(
                    "outgoing_polar",
                    "deg",
                    0.0,
                    self.p.polar_step_deg,
                    grid.n_polar,
                ),
                Axis::uniform(
                    "outgoing_azimuth",
                    "deg",
                    0.0,
                    self.p.azimuth_step_deg,
                    grid.n_azimuth,
                ),
            ]);
        } else {
            axes.push(Axis::uniform(
                "scattering_angle",
                "deg",
                0.0,
                self.p.angle_step_deg,
                self.n_angles(),
            ));
        }
        axes
    }

    /// Values per entry (task): angles, or polar × azimuth directions, times channels.
    fn entry_len(&self) -> usize {
        let channels = self.channels().len();
        if self.two_d {
            let grid = self.direction_grid();
            grid.n_polar * grid.n_azimuth * channels
        } else {
            self.n_angles() * channels
        }
    }

    /// How the 2-D entries of this job are traced.
    fn table2d_options(&self) -> Table2dOptions {
        Table2dOptions {
            rays: self.p.rays,
            ray_grid: self.p.ray_grid,
            max_order: self.max_order,
            grid: self.direction_grid(),
            diffraction_filter: self.p.diffraction_filter,
            model: self.diffraction_model(),
            sphere_higher_orders: self.p.sphere_higher_orders,
            diagnostic_channels: self.p.diagnostic_channels,
            mirror_symmetrise: self.p.mirror_symmetrise,
            mirror_half: self.p.mirror_half,
        }
    }

    /// Scalars per 2-D task: the airy-local transfer weight of each azimuth column (primary,
    /// secondary), 2 × n_azimuth, or none for the other models and for spheres.
    fn domain_values(&self) -> usize {
        if self.two_d && self.table2d_options().airy_local() {
            2 * self.direction_grid().n_azimuth
        } else {
            0
        }
    }

    /// 2-D shapes: the values `[polar][azimuth][channel]` of one (wavelength, sun elevation) as
    /// a task returns them (divided by σ, before the renormalisation of `assemble`) and the
    /// scattering cross-section σ = σ_GO + A (µm²) they were divided by.
    pub fn trace_2d(&self, lambda: f64, elevation_deg: f64) -> Result<(Vec<f32>, f64), JobError> {
        let t = self.trace_entry(lambda, elevation_deg)?;
        Ok((t.values, t.cross_section_um2))
    }

    /// One (wavelength, sun elevation) entry of a 2-D table ([`trace_table_2d`]), with the
    /// wavelength's fields shared by its sun elevations.
    fn trace_entry(&self, lambda: f64, elevation_deg: f64) -> Result<Trace2d, JobError> {
        let shape = self.shape.as_ref().expect("2-D job has a shape");
        let n = self.index(lambda)?;
        let opts = self.table2d_options();
        // Before the trace: their few allocations do not stack on the accumulators' peak.
        let fields = self
            .per_wavelength
            .get(lambda, self.p.sun_elevation_deg.len(), || {
                WavelengthFields::new(shape.radius_um(), lambda, n, &opts)
            });
        Ok(trace_table_2d(
            shape,
            lambda,
            n,
            elevation_deg,
            &opts,
            &fields,
        ))
    }

    /// A sphere's 1-D entry: values `[angle][channel]`.
    fn sphere_entry(&self, radius_um: f64, lambda: f64) -> Result<Vec<f32>, JobError> {
        let na = self.n_angles();
        let ch = sphere_table_channels(
            radius_um,
            lambda,
            self.index(lambda)?,
            &SphereTableOptions {
                max_order: self.max_order,
                step_deg: self.p.angle_step_deg,
                angles: na,
                diffraction_filter: self.p.diffraction_filter,
                model: self.diffraction_model(),
            },
        );
        let nch = self.channels().len();
        let mut out = vec![0f32; na * nch];
        for j in 0..na {
            for c in 0..nch {
                out[j * nch + c] = ch[c][j] as f32;
            }
        }
        Ok(out)
    }
}

impl Job for RaytraceJob {
    /// Known at plan time: tasks × (angles, or polar × azimuth directions) × channels.
    /// Compact tables: the dense grid as the upper bound of the knots chosen while the tasks
    /// run.
    fn shape(&self) -> crate::stages::PlannedShape {
        let channels = self.channels().len();
        if self.compact_spec().is_some() {
            return crate::stages::PlannedShape::adaptive(self.table_axes(), channels);
        }
        crate::stages::PlannedShape::new(self.table_axes(), channels)
    }
    /// Spheres: per task ∝ radius/λ (the internal grid's step is ≤ λ/(10a)). 2-D shapes
    /// (`RAYTRACE_2D_COST`): a set-up, then per task a part growing with the drop's size
    /// parameter, one per ray traced and one per direction computed.
    fn estimated_cpu_seconds(&self) -> f64 {
        let pairs = self.task_pairs();
        if !self.two_d {
            let size: f64 = pairs.iter().map(|&(a_um, l_nm)| a_um / l_nm).sum();
            return SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH * size;
        }
        let grid = self.direction_grid();
        let computed_azimuths = if self.p.mirror_half {
            grid.n_azimuth / 2 + 1
        } else {
            grid.n_azimuth
        };
        let rays = (self.p.rays * self.p.rays) as f64;
        let directions = (grid.n_polar * computed_azimuths) as f64;
        let [table, per_size, per_ray, per_direction] = RAYTRACE_2D_COST;
        let radius_mm = self.p.radii_um[0] / 1000.0;
        let per_task: f64 = (pairs.iter())
            .map(|&(l_nm, _)| {
                per_size * radius_mm * 550.0 / l_nm + per_ray * rays + per_direction * directions
            })
            .sum();
        table + per_task
    }
    /// Compact tables: of the dense grid's payload (the plan's upper bound).
    fn estimated_stored_fraction(&self) -> f64 {
        use crate::stages::cost::*;
        if let Some(spec) = self.compact_spec() {
            if matches!(self.shape, Some(DropShape::Sphere { .. })) {
                return STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE;
            }
            return match spec.norm {
                compact::ErrorNorm::Max => STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX,
                compact::ErrorNorm::Rms => STORED_FRACTION_RAYTRACE_2D_COMPACT_RMS,
            };
        }
        match (self.two_d, self.p.diagnostic_channels) {
            (false, _) => STORED_FRACTION_RAYTRACE_SPHERE,
            (true, true) => STORED_FRACTION_RAYTRACE_2D_DIAGNOSTIC,
            (true, false) => STORED_FRACTION_RAYTRACE_2D,
        }
    }
    /// Per task: integrals, and for 2-D shapes the transfer weights of every azimuth column.
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::{ATTRIBUTE_BYTES, ATTRIBUTE_BYTES_PER_SCALAR};
        let tasks = self.task_pairs().len() as u64;
        ATTRIBUTE_BYTES + ATTRIBUTE_BYTES_PER_SCALAR * tasks * (1 + self.domain_values() as u64)
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        self.task_pairs()
            .into_iter()
            .map(|(l, s)| {
                if self.two_d {
                    TaskSpec {
                        label: format!("λ={l} nm sun={s}°"),
                        params: serde_json::json!({"wavelength_nm": l, "sun_elevation_deg": s}),
                    }
                } else {
                    TaskSpec {
                        label: format!("a={l} µm λ={s} nm"),
                        params: serde_json::json!({"radius_um": l, "wavelength_nm": s}),
                    }
                }
            })
            .collect()
    }

    /// Spheres: the entry's values. 2-D shapes: the entry's values and, with airy-local, the
    /// transfer weights of its azimuth columns (`[primary, secondary]` per column), which
    /// `assemble` records in the header.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (f, s) = self.task_pairs()[index];
        if !self.two_d {
            return Ok(Chunk::values(self.sphere_entry(f, s)?));
        }
        let t = self.trace_entry(f, s)?;
        let weights = t.domain_weights.unwrap_or_default().into_iter().flatten();
        if let Some(spec) = self.compact_spec() {
            let (integral, entry) = self.compact_task(index, t.values, spec)?;
            let mut scalars = vec![integral];
            scalars.extend(entry.scalars());
            scalars.extend(weights);
            return Ok(Chunk::new(entry.values, scalars));
        }
        Ok(Chunk::new(t.values, weights.collect()))
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        if let Some(spec) = self.compact_spec() {
            return self.assemble_compact(chunks, spec);
        }
        let scalars = self.domain_values();
        let tasks = self.task_pairs().len();
        check_chunks(&chunks, tasks, self.entry_len(), scalars)?;
        let domain = (scalars > 0).then(|| {
            let weights: Vec<&[f64]> = chunks.iter().map(|c| c.scalars.as_slice()).collect();
            self.domain_attribute(&weights)
        });
        let mut t = self.assemble_values(chunks)?;
        if let Some(d) = domain {
            t.attributes.insert("airy_local_domain".into(), d);
        }
        Ok(t)
    }
}

impl RaytraceJob {
    /// The table from the tasks' chunks in task order (their scalars unused): what
    /// `mixture-2d` assembles per radius.
    pub fn assemble_values(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let entry_len = self.entry_len();
        for (index, c) in chunks.iter().enumerate() {
            check_chunk(index, c, entry_len, c.scalars.len())?;
        }
        let channels = self.channels();
        let at = self.common_attributes();
        let data = concat_values(chunks);
        if self.two_d {
            self.assemble_2d(data, channels, at)
        } else {
            self.assemble_1d(data, channels, at)
        }
    }
}

impl RaytraceJob {
    /// Attributes of 1-D and 2-D tables: the phase contract, index, orders, normalisation,
    /// focal-line rule, diffraction model and Fresnel conventions.
    fn common_attributes(&self) -> serde_json::Map<String, serde_json::Value> {
        let mut at = serde_json::Map::new();
        at.extend(phase_contract::attributes(
            "integral over 4pi sr equals 1",
            &self.model,
            0.0,
        ));
        if let Some(n) = self.fixed_index {
            at.insert("water_index_model".into(), "none".into());
            at.remove("temperature_c");
            at.insert("refractive_index_real".into(), n.into());
        }
        at.insert("max_order".into(), self.max_order.into());
        at.insert("cross_section_normalization".into(), "p = (dσ/dΩ)/σ with σ = σ_GO (flux of the traced orders) + A (Fraunhofer forward lobe of the projected area A, added to i_perp and i_par as the exact bin average of a²J1(x sinθ)²/sin²θ)".into());
        at.insert("focal_line_rule".into(), "longer-path branch π/2 behind (docs/decisions.md RT-1): phase exp(i(k l − (π/2) f)), f = [dl/db > 0], b = u² + v²".into());
        let model = self.diffraction_model();
        let filter_text = match model {
            DiffractionModel::AiryUniform => "airy-uniform: uniform caustic (Airy) approximation of each order's rainbow (two-branch CUA on the bright side, Airy continuation on the dark side); GO elsewhere".to_string(),
            DiffractionModel::AiryLocal => "airy-local: the equal-volume sphere's uniform-caustic correction (1-D Airy-uniform minus GO channels, bin averages) added to each azimuth column, moved onto the column's own primary/secondary caustic (fold fit of the p = 2 / p = 3 GO intensity, smoothed over ±5° of azimuth) and scaled to its caustic strength (bright side 0.1–1.5°); primary correction above the Alexander-band midpoint, secondary below; GO elsewhere. Domain per column and bow: caustic inside the search range, strength 0.5–2 times the sphere's, no value below −5 % of the column's largest before clipping; columns with a column outside the domain within ±5° take the Gaussian filter instead, blended over ±5° of azimuth (docs/decisions.md RT-28, RT-33)".to_string(),
            DiffractionModel::Gaussian => format!("gaussian: thesis Table 3.3 Gaussian in polar angle (σ linear in radius, Airy a^(-2/3) outside 0.1–1 mm; σ = {:.4}° at the first radius) for θ above the Alexander-band midpoint, 2σ below, blended in only within a Gaussian window of half-width 2σ_local around each caustic (peaks of the p = 2 and p = 3 intensities)", filter_sigma_deg(self.p.radii_um[0] * 1e-3)),
        };
        at.insert(
            "diffraction_filter".into(),
            format!("{filter_text}; applied = {}", self.p.diffraction_filter).into(),
        );
        at.insert("fresnel".into(), "complex Fresnel amplitudes, Born–Wolf signs, power-consistent transmission (src/optics/fresnel.rs)".into());
        at.insert("cross_order_phase".into(), "orders summed coherently without per-order constant (axial focal line) phases, as in the thesis: the fine cross-order ripple of the unfiltered channels is not Mie-exact".into());
        at
    }

    /// The header record of where airy-local used the sphere's transfer (decision RT-33), per
    /// (wavelength, sun elevation) entry and bow, from the weights of each task's chunk
    /// (`[primary, secondary]` per azimuth column), classified at f32 precision.
    fn domain_attribute(&self, weights: &[&[f64]]) -> serde_json::Value {
        let step = self.p.azimuth_step_deg;
        let bow = |w: &[f64], b: usize| {
            let col: Vec<f32> = w.chunks_exact(2).map(|p| p[b] as f32).collect();
            let transfer = col.iter().filter(|&&x| x >= 1.0).count();
            let gaussian = col.iter().filter(|&&x| x <= 0.0).count();
            // Azimuth ranges (deg, inclusive) of the columns that did not take the transfer
            // alone (blended or Gaussian).
            let mut ranges: Vec<[f64; 2]> = Vec::new();
            let mut start = None;
            for (k, &x) in col.iter().chain([&1.0f32]).enumerate() {
                match (x < 1.0, start) {
                    (true, None) => start = Some(k),
                    (false, Some(k0)) => {
                        ranges.push([k0 as f64 * step, (k - 1) as f64 * step]);
                        start = None;
                    }
                    _ => {}
                }
            }
            serde_json::json!({
                "transfer_columns": transfer,
                "blended_columns": col.len() - transfer - gaussian,
                "gaussian_columns": gaussian,
                "not_transfer_azimuth_ranges_deg": ranges,
            })
        };
        let entries: Vec<serde_json::Value> = self
            .task_pairs()
            .iter()
            .zip(weights)
            .map(|(&(l, e), w)| {
                serde_json::json!({
                    "wavelength_nm": l,
                    "sun_elevation_deg": e,
                    "primary": bow(w, 0),
                    "secondary": bow(w, 1),
                })
            })
            .collect();
        serde_json::json!({
            "what": "where the airy-local caustic model used the equal-volume sphere's transfer (the model validated against Lorenz–Mie on spheres) and where the Gaussian filter, per (wavelength, sun elevation) entry and bow (primary: rows above the Alexander-band midpoint, secondary: below): counts of azimuth columns with transfer weight 1 (transfer), 0 (Gaussian filter) or between (blended over ±5° of azimuth), and the azimuth ranges (deg, inclusive) of the columns with weight below 1 (docs/decisions.md RT-33)",
            "entries": entries,
        })
    }

    /// The 1-D table of spheres: radius × wavelength × scattering angle.
    fn assemble_1d(
        &self,
        data: Vec<f32>,
        channels: Vec<Channel>,
        mut at: serde_json::Map<String, serde_json::Value>,
    ) -> Result<TableContent, JobError> {
        let nch = channels.len();
        let na = self.n_angles();
        let step = self.p.angle_step_deg.to_radians();
        let mut ints = vec![];
        for e in 0..self.task_pairs().len() {
            let base = e * na * nch;
            let s = integral_1d((0..na).map(|j| data[base + j * nch] as f64), step);
            crate::stages::check_phase_integral(e, s)?;
            ints.push(s);
        }
        at.insert(
            "integral_check".into(),
            serde_json::json!({"what": "bin-sum of phase over 4π per entry", "values": ints}),
        );
        at.insert("angular_resampling".into(), format!("point samples of the GO+phase field on an internal grid of step ≤ λ/(10a); filtered channels are Gaussian averages of it; the forward lobe is the exact average over each {}° bin", self.p.angle_step_deg).into());
        at.insert("method".into(), "exact 1-D geometric optics plus phase for spheres (two-branch phasor sum of Airy theory), validated against the 2-D patch tracer and Lorenz–Mie (docs/raytrace.md)".into());
        at.insert("validated_domain".into(), "spheres of radius 0.1–1 mm in 380–700 nm (x ≳ 1000): supernumerary positions within 0.02° (primary) and 0.05° (secondary) of Lorenz–Mie; not valid within ~1° of 0° (forward lobe only approximate) and near 180° (glory, axial caustic clamped at a quarter bin)".into());
        let axes = self.table_axes();
        Ok(TableContent {
            schema: Schema::new("raytrace-phase", 2),
            description: "ray-traced (geometric optics + phase) phase function of water spheres"
                .into(),
            axes,
            channels,
            attributes: at,
            data,
        })
    }

    /// Divide every intensity channel (all but `dolp`) of each entry of a 2-D table by its
    /// bin-sum over 4π, so ∫ p dΩ = 1 exactly on the table grid (decision RT-21); returns the
    /// bin-sums before renormalisation. The bin-sum deviates from 1 by the flux of discarded
    /// silhouette triangles (−0.1…−0.5 %) and, for strongly flattened drops, by point-sampled
    /// cusp caustics (+3.9 % at 3 mm, sun 0°).
    fn renormalise_2d(&self, data: &mut [f32], nch: usize) -> Result<Vec<f64>, JobError> {
        let grid = self.direction_grid();
        let len = grid.n_polar * grid.n_azimuth * nch;
        (data.chunks_mut(len).enumerate())
            .map(|(e, entry)| renormalise_entry(e, entry, grid, nch))
            .collect()
    }

    /// The 2-D table of one drop: radius × wavelength × sun elevation × outgoing polar ×
    /// outgoing azimuth, renormalised ([`Self::renormalise_2d`]).
    fn assemble_2d(
        &self,
        mut data: Vec<f32>,
        channels: Vec<Channel>,
        at: serde_json::Map<String, serde_json::Value>,
    ) -> Result<TableContent, JobError> {
        let ints = self.renormalise_2d(&mut data, channels.len())?;
        self.content_2d(data, channels, at, &ints, self.table_axes())
    }

    /// The 2-D table's content from its renormalised values, on `axes`, with the attributes of
    /// every 2-D table (`ints`: the entries' bin-sums before renormalisation).
    fn content_2d(
        &self,
        data: Vec<f32>,
        channels: Vec<Channel>,
        mut at: serde_json::Map<String, serde_json::Value>,
        ints: &[f64],
        axes: Vec<Axis>,
    ) -> Result<TableContent, JobError> {
        at.insert("integral_check".into(), serde_json::json!({"what": "bin-sum of phase over 4π per entry before renormalisation (below 1 by the flux of triangles discarded at the silhouette, above 1 where cusp caustics are point-sampled); every channel but dolp was divided by it, so the stored table integrates to 1 on its grid", "values": ints}));
        at.insert("angular_resampling".into(), "point samples of the coherent patch sum at the grid directions; filtered channels are Gaussian averages along the polar angle per azimuth column; the forward lobe is the exact average over each polar bin".into());
        if self.p.sphere_higher_orders && self.max_order < SPHERE_MAX_ORDER {
            at.insert(
                "sphere_higher_orders".into(),
                serde_json::json!({
                    "orders": [self.max_order + 1, SPHERE_MAX_ORDER],
                    "what": "phase, i_perp, i_par and their unfiltered channels include these orders of the equal-volume sphere (1-D path: Airy rainbows, grazing waves), bin averages along the polar angle, the same at every azimuth; the per-order channels hold the traced orders only"
                }),
            );
        }
        at.insert(
            phase_contract::INTERPOLABLE_AXES.into(),
            serde_json::json!(["wavelength", "outgoing_polar", "outgoing_azimuth"]),
        );
        at.insert(
            "mirror_symmetrisation".into(),
            if self.p.mirror_half {
                "by construction: only the outgoing_azimuth range 0°–180° was computed and each value copied to 360° − φ (mirror_half); the drop (a surface of revolution about the vertical axis) and the sun (in the vertical plane φ = 0) are symmetric under y → −y, so the exact table has this symmetry; the ray noise is that of the half traced, not averaged with its mirror image (docs/decisions.md RT-34)"
            } else if self.p.mirror_symmetrise {
                "applied: the values at outgoing_azimuth φ and 360° − φ were replaced by their mean (every channel but dolp, which was recomputed from the mean i_perp and i_par); the drop (a surface of revolution about the vertical axis) and the sun (in the vertical plane φ = 0) are symmetric under y → −y, so the exact table has this symmetry and the averaging removes ray noise only (docs/decisions.md RT-24)"
            } else {
                "not applied: values at φ and 360° − φ differ by ray noise"
            }
            .into(),
        );
        at.insert("frame".into(), "drop axis vertical (z up); sun at elevation e in the +x half-space, incident direction d = (−cos e, 0, −sin e); outgoing_polar = angle from d; outgoing_azimuth about d from e1 = (−sin e, 0, cos e) (vertical plane, upwards) towards e2 = +y".into());
        at.insert("shape".into(), self.p.shape.clone().into());
        at.insert("radius_um".into(), self.p.radii_um[0].into());
        at.insert("rays_per_side".into(), self.p.rays.into());
        at.insert(
            "ray_grid".into(),
            match self.p.ray_grid {
                RayGridLayout::Square => "square: rays_per_side² rays evenly spaced over the silhouette's bounding box",
                RayGridLayout::Silhouette => "silhouette: rays_per_side² rays, the index square mapped onto the silhouette (Shirley–Chiu concentric map, ρ = R(ψ) sin(π s / 2)), refined towards the edge; docs/decisions.md RT-31",
            }
            .into(),
        );
        at.insert("beard_chuang".into(), "r(θ) = a[1 + Σ c_n cos nθ], θ from the downward pole, thesis Table 3.1 linear in a; sphere for a ≤ 0.4 mm; clamped to the 3 mm row above 3 mm".into());
        if let Some(res) = self.profile_fit_residual {
            at.insert("profile_fit_rms_relative".into(), res.into());
        }
        at.insert("forward_lobe".into(), "Fraunhofer lobe of the equal-projected-area disc (azimuthally symmetric approximation for non-circular silhouettes)".into());
        at.insert("method".into(), "patch-based wave-optics ray tracer (Sadeghi 2012, ch. 3) with 3-D complex field vectors, spherical-triangle patches, coherent sums; see docs/raytrace.md".into());
        at.insert("validated_domain".into(), "validated on spheres (0.4 mm, 650 nm) against the exact 1-D path and Lorenz–Mie; Beard–Chuang results checked for volume, axis ratios, symmetry and energy; accuracy depends on rays_per_side (docs/raytrace.md)".into());
        Ok(TableContent {
            schema: Schema::new("raytrace-phase-2d", 2),
            description: format!(
                "ray-traced phase function of a {} drop, a = {} µm, over outgoing directions",
                self.p.shape, self.p.radii_um[0]
            ),
            axes,
            channels,
            attributes: at,
            data,
        })
    }
}

/// Compact 2-D tables (`compression`, decision RT-39).
impl RaytraceJob {
    /// The compact form's parameters, for 2-D tables that ask for it.
    fn compact_spec(&self) -> Option<compact::SunDiscResampled> {
        match self.p.compression {
            Compression::SunDiscResampled(c) if self.two_d => Some(c),
            _ => None,
        }
    }

    /// Task `index`'s entry renormalised, seen through the sun's disc and compacted; its
    /// bin-sum before renormalisation. Refused when the measured error exceeds the tolerance.
    fn compact_task(
        &self,
        index: usize,
        mut values: Vec<f32>,
        spec: compact::SunDiscResampled,
    ) -> Result<(f64, CompactEntry), JobError> {
        let grid = self.direction_grid();
        let nch = self.channels().len();
        let integral = renormalise_entry(index, &mut values, grid, nch)?;
        let filtered = |c: usize| {
            let v: Vec<f64> = values
                .iter()
                .skip(c)
                .step_by(nch)
                .map(|&x| x as f64)
                .collect();
            compact::disc_filter(&v, grid, spec.sigma_deg())
        };
        let (i_perp, i_par) = (filtered(1), filtered(2));
        drop(values);
        let c = Components {
            grid,
            i_perp: &i_perp,
            i_par: &i_par,
        };
        let entry = compact::compact_entry(&c, &spec);
        let measured = compact::entry_error(&entry.errors, spec.norm);
        if !(measured <= spec.tolerance) {
            return Err(JobError::CompressionTolerance {
                entry: index,
                measured,
                tolerance: spec.tolerance,
            });
        }
        Ok((integral, entry))
    }

    /// The compact table from the tasks' chunks: entries on the union of their knots.
    fn assemble_compact(
        &self,
        chunks: Vec<Chunk>,
        spec: compact::SunDiscResampled,
    ) -> Result<TableContent, JobError> {
        let tasks = self.task_pairs().len();
        if chunks.len() != tasks {
            return Err(JobError::ChunkCount {
                expected: tasks,
                got: chunks.len(),
            });
        }
        let (grid, domain) = (self.direction_grid(), self.domain_values());
        let (mut ints, mut entries, mut weights) = (vec![], vec![], vec![]);
        for (index, c) in chunks.into_iter().enumerate() {
            let bad = |got: usize| JobError::ChunkLength {
                index,
                part: crate::stages::ChunkPart::Scalars,
                got,
                expected: 1 + 2 + 2 * compact::ERROR_WINDOWS.len() + domain,
            };
            let n = c.scalars.len();
            let (Some(&integral), Some(rest)) = (c.scalars.first(), c.scalars.get(1..)) else {
                return Err(bad(n));
            };
            let Some((entry, rest)) = CompactEntry::from_parts(rest, c.values, grid) else {
                return Err(bad(n));
            };
            if rest.len() != domain {
                return Err(bad(n));
            }
            ints.push(integral);
            weights.push(rest.to_vec());
            entries.push(entry);
        }
        let (polar, azimuth, data) = compact::merge_entries(&entries);
        let mut at = self.common_attributes();
        if domain > 0 {
            let w: Vec<&[f64]> = weights.iter().map(Vec::as_slice).collect();
            at.insert("airy_local_domain".into(), self.domain_attribute(&w));
        }
        let mut axes = self.table_axes();
        let step = |axis: &Axis| match axis.points {
            crate::table::AxisPoints::Uniform { step, .. } => step,
            crate::table::AxisPoints::Values(_) => unreachable!("the dense grid is uniform"),
        };
        let (dp, da) = (step(&axes[3]), step(&axes[4]));
        axes[3] = Axis::values(
            "outgoing_polar",
            "deg",
            polar.iter().map(|&j| j as f64 * dp).collect(),
        );
        let az = azimuth.iter().map(|&k| k as f64 * da).collect();
        axes[4] = Axis::values("outgoing_azimuth", "deg", az);
        let mut t = self.content_2d(data, self.channels(), at, &ints, axes)?;
        t.attributes.insert("integral_check".into(), serde_json::json!({"what": "bin-sum of phase over 4π per entry of the dense table before renormalisation; every channel but dolp of the dense entry was divided by it, then seen through the sun's disc and resampled (compression)", "values": ints}));
        t.attributes.insert("angular_resampling".into(), "compact: the dense entries (point samples of the coherent patch sum on the uniform grid of the compression's dense_grid, renormalised) seen through the sun's disc, then sampled at the outgoing_polar and outgoing_azimuth knots (compression); bilinear interpolation between knots is the table's value".into());
        t.attributes.insert(
            "compression".into(),
            self.compression_attribute(spec, &entries, &polar, &azimuth),
        );
        // The disc consumers find already applied (docs/consumers.md): they convolve only the
        // difference to the disc they show.
        t.attributes
            .insert("sun_diameter_deg".into(), spec.sun_diameter_deg.into());
        Ok(t)
    }

    /// The header's `compression` record: the operator applied, the error's definition and
    /// the errors measured per entry and window.
    fn compression_attribute(
        &self,
        spec: compact::SunDiscResampled,
        entries: &[CompactEntry],
        polar: &[usize],
        azimuth: &[usize],
    ) -> serde_json::Value {
        let grid = self.direction_grid();
        let windows: serde_json::Map<String, serde_json::Value> = (compact::ERROR_WINDOWS.iter())
            .map(|&(name, lo, hi)| (name.to_string(), serde_json::json!([lo, hi])))
            .collect();
        let per_entry: Vec<serde_json::Value> = (self.task_pairs().iter().zip(entries))
            .map(|(&(l, e), entry)| {
                let errors: serde_json::Map<String, serde_json::Value> = (compact::ERROR_WINDOWS.iter())
                    .zip(&entry.errors)
                    .map(|(w, x)| (w.0.to_string(), serde_json::json!({"rms_relative": x.rms_relative, "max_relative": x.max_relative})))
                    .collect();
                serde_json::json!({
                    "wavelength_nm": l,
                    "sun_elevation_deg": e,
                    "polar_knots": entry.polar_rows.len(),
                    "azimuth_knots": entry.azimuth_positions.len(),
                    "errors": errors,
                })
            })
            .collect();
        let max = (entries.iter())
            .map(|e| compact::entry_error(&e.errors, compact::ErrorNorm::Max))
            .fold(0.0, f64::max);
        let rms = (entries.iter())
            .map(|e| compact::entry_error(&e.errors, compact::ErrorNorm::Rms))
            .fold(0.0, f64::max);
        serde_json::json!({
            "kind": compact::SUN_DISC_RESAMPLED,
            "tolerance": spec.tolerance,
            "norm": spec.norm,
            "max_relative_error": max,
            "max_window_rms_relative": rms,
            "sun_diameter_deg": spec.sun_diameter_deg,
            "sun_disc": format!("applied: every entry is the dense entry convolved with the sun's disc, a uniform disc of diameter {d}° taken as the Gaussian of its second moment, σ = {s}° of arc per axis, separably: along outgoing_polar with σ, reflected across the poles onto the opposite azimuth; along outgoing_azimuth with σ/sin(outgoing_polar), wrapped around the circle (the row's mean at the poles). A renderer must not convolve this table with the sun's disc again", d = spec.sun_diameter_deg, s = spec.sigma_deg()),
            "error_definition": "the table's bilinear interpolation between knots (what Table::sample returns) against the dense entry seen through the same disc, at every direction of the dense grid: max_relative is the largest |compact − dense| of phase, i_perp and i_par divided by the dense phase at that direction; rms_relative is the root mean square of that relative error, weighted by solid angle (sin θ), over a window of outgoing_polar (= scattering angle); norm says which the tolerance bounds (max: max_relative over all directions; rms: rms_relative in every window). The entry errors are measured at build time on the stored f32 values; entries of a table share the union of their knots, each evaluated there from its own bilinear interpolant, which adds one f32 rounding (< 1e-7 relative). dolp follows from i_perp and i_par (error up to about 2 × tolerance, absolute)",
            "windows_deg": windows,
            "dense_grid": {
                "outgoing_polar_step_deg": self.p.polar_step_deg,
                "outgoing_azimuth_step_deg": self.p.azimuth_step_deg,
                "directions": grid.n_polar * grid.n_azimuth,
            },
            "knots": {"outgoing_polar": polar.len(), "outgoing_azimuth": azimuth.len()},
            "entries": per_entry,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raytrace::post::bin_edges;
    use crate::raytrace::table2d::{DOLP_CHANNEL, n_channels_2d};
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
    use crate::table::{Provenance, Table};

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
        assert_eq!(compact.axes[4].coords().last(), Some(&355.0));
        // At 300² rays the ray noise of this coarse grid keeps every 5° azimuth column; the
        // polar axis still drops a third of its rows.
        assert!(
            compact.axes[3].len() * 3 < dense.axes[3].len() * 2,
            "knots {}",
            c["knots"]
        );
        let table = Table::from_content(compact, Provenance::default()).unwrap();
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
            let (p, q) = filtered_dense(&dense, e);
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
        assert!(!plan(BASE).shape().adaptive);
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
