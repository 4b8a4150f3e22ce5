//! `raytrace` stage: wave-optics ray-traced phase functions of raindrops.
//!
//! - `shape = "sphere"`: schema `raytrace-phase/1`, axes wavelength (nm) × radius (µm) ×
//!   scattering_angle (deg, uniform over [0, 180]); computed by the exact 1-D
//!   geometric-optics-plus-phase path ([`crate::raytrace::sphere1d`]), which the general 2-D tracer is
//!   validated against (tests/raytrace_validation.rs).
//! - `shape = "beard-chuang"` or `"profile"`: schema `raytrace-phase-2d/1`, axes wavelength (nm)
//!   × sun_elevation (deg) × outgoing_polar (deg from the incident direction, 0 = forward) ×
//!   outgoing_azimuth (deg, 0..360, from the vertical plane containing the incident direction,
//!   towards +y; see [`crate::raytrace::tracer`] for the frame); computed by the 2-D patch tracer.
//!
//! Channels (both schemas): phase, i_perp, i_par, dolp, phase_p0..phase_pN (per order,
//! filtered), phase_unfiltered, i_perp_unfiltered, i_par_unfiltered; all in 1/sr normalised
//! against the full scattering cross-section σ = σ_GO (traced orders) + A (forward Fraunhofer
//! lobe of the projected area A), so that ∫_{4π} p dΩ = 1 up to the flux of triangles discarded
//! at the silhouette (reported in the attributes).

use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::raytrace::post::{
    DEFAULT_CAUSTIC_WINDOW_SIGMAS, bin_edges, caustic_weight, filter_sigma_deg,
    fraunhofer_bin_average, gaussian_blur,
};
use crate::raytrace::shape::{CosineSeries, DropShape};
use crate::raytrace::sphere1d::{DiffractionModel, Phase1dOptions, SphereGo, sphere_phase_1d};
use crate::raytrace::tracer::{DirectionGrid, TraceConfig, trace_fields};
use crate::stages::{Job, JobError, PlanError, StageSpec, TaskSpec, checks, stage_params};
use crate::table::phase_contract;
use crate::table::{Axis, Channel, Schema, TableContent};
use std::f64::consts::PI;

/// The stage.
pub struct RaytraceStage;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct RaytraceParams {
        /// `sphere`, `beard-chuang` or `profile`.
        pub shape: String = required, "string",
            "sphere (1-D table, exact GO+phase path) | beard-chuang | profile (2-D tables, patch tracer)";
        /// Equal-volume radii (mm); spheres accept a list, 2-D shapes exactly one.
        pub radius_mm: Vec<f64> = required, "list of float, mm",
            "equal-volume radii, 0.01–5 mm; exactly one for 2-D shapes";
        pub wavelength_nm: Vec<f64> = default(SADEGHI_WAVELENGTHS_NM.to_vec()),
            "list of float, nm", "vacuum wavelengths, strictly increasing";
        pub water_index_model: String = default("sadeghi-table-3.2".into()),
            "string", "sadeghi-table-3.2 (thesis parity) or iapws1997";
        pub temperature_c: Option<f64> = optional("20"),
            "float, °C", "temperature for iapws1997";
        pub max_order: usize = default(3), "integer",
            "highest order p traced (0 reflection, 1 transmission, 2 primary, 3 secondary, ...), 1–8";
        /// Scattering-angle step (deg) of 1-D sphere tables.
        pub angle_step_deg: f64 = default(0.05), "float, deg",
            "scattering-angle step of 1-D sphere tables (divides 180)";
        pub sun_elevation_deg: Vec<f64> = default(vec![0.0]), "list of float, deg",
            "sun elevations above the horizon (drop axis vertical), 0–90, 2-D shapes";
        pub rays: usize = default(600), "integer",
            "rays per side of the square ray grid (2-D shapes; the thesis used 3000)";
        pub polar_step_deg: f64 = default(0.1), "float, deg",
            "outgoing polar step (divides 180), 2-D shapes";
        pub azimuth_step_deg: f64 = default(5.0), "float, deg",
            "outgoing azimuth step (divides 360), 2-D shapes";
        pub diffraction_filter: bool = default(true), "bool",
            "apply the Table 3.3 Gaussian filter to the main channels (unfiltered channels are always written)";
        /// Diffraction model of the main channels: `airy-uniform` (spheres only, default for
        /// spheres) or `gaussian` (thesis Table 3.3 filter, windowed around the caustics; the only
        /// choice for 2-D shapes).
        pub diffraction_model: Option<DiffractionModel> =
            optional("airy-uniform (sphere) / gaussian (2-D)"), "string",
            "airy-uniform: uniform caustic (Airy) approximation at each rainbow (spheres); gaussian: thesis Table 3.3 Gaussian filter windowed around the caustics";
        pub profile_theta_deg: Option<Vec<f64>> = optional("none"), "list of float, deg",
            "shape = profile: polar angles from the downward pole";
        pub profile_r: Option<Vec<f64>> = optional("none"), "list of float",
            "shape = profile: radii at profile_theta_deg (any unit; rescaled to radius_mm equal volume)";
    }
}

fn divides(total: f64, step: f64) -> Option<usize> {
    if step.is_nan() || step <= 0.0 {
        return None;
    }
    let n = total / step;
    if (n - n.round()).abs() < 1e-6 && n.round() >= 2.0 {
        Some(n.round() as usize)
    } else {
        None
    }
}

impl StageSpec for RaytraceStage {
    const NAME: &'static str = "raytrace";
    /// 2: 2-D tables renormalised to ∫ p dΩ = 1 on their grid.
    const VERSION: u32 = 2;
    const SUMMARY: &'static str =
        "wave-optics patch ray tracer: phase functions of spherical and Beard–Chuang raindrops";
    type Params = RaytraceParams;
    fn plan_params(&self, p: RaytraceParams) -> Result<Box<dyn Job>, PlanError> {
        Ok(Box::new(RaytraceJob::new(p)?))
    }
}

/// A planned ray-tracing job.
pub struct RaytraceJob {
    p: RaytraceParams,
    model: WaterIndexModel,
    two_d: bool,
    shape: Option<DropShape>,
    profile_fit_residual: Option<f64>,
}

impl RaytraceJob {
    /// Validate parameters and plan.
    pub fn new(p: RaytraceParams) -> Result<Self, PlanError> {
        checks::increasing("wavelength_nm", &p.wavelength_nm, true)?;
        let (model, _) = checks::water_indices(
            &p.water_index_model,
            p.temperature_c,
            "wavelength_nm",
            &p.wavelength_nm,
        )?;
        checks::increasing("radius_mm", &p.radius_mm, true)?;
        if let Some(r) = p.radius_mm.iter().find(|r| !(0.01..=5.0).contains(*r)) {
            return Err(PlanError::invalid(
                "radius_mm",
                format!("{r} mm is outside 0.01–5 mm (geometric optics needs x ≫ 1)"),
            ));
        }
        if !(1..=8).contains(&p.max_order) {
            return Err(PlanError::invalid("max_order", "must be within 1–8"));
        }
        let two_d_shape = p.shape != "sphere";
        if two_d_shape && p.diffraction_model == Some(DiffractionModel::AiryUniform) {
            return Err(PlanError::invalid(
                "diffraction_model",
                "airy-uniform is available for spheres only; use gaussian",
            ));
        }
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
            model,
            two_d,
            shape: None,
            profile_fit_residual: None,
        };
        if !two_d {
            if divides(180.0, job.p.angle_step_deg).is_none() {
                return Err(PlanError::invalid(
                    "angle_step_deg",
                    "must be > 0 and divide 180",
                ));
            }
            return Ok(job);
        }
        let p = &job.p;
        if p.radius_mm.len() != 1 {
            return Err(PlanError::invalid(
                "radius_mm",
                "2-D shapes take exactly one radius per table",
            ));
        }
        if divides(180.0, p.polar_step_deg).is_none() {
            return Err(PlanError::invalid(
                "polar_step_deg",
                "must be > 0 and divide 180",
            ));
        }
        if divides(360.0, p.azimuth_step_deg).is_none() {
            return Err(PlanError::invalid(
                "azimuth_step_deg",
                "must be > 0 and divide 360",
            ));
        }
        if !(8..=20_000).contains(&p.rays) {
            return Err(PlanError::invalid("rays", "must be within 8–20000"));
        }
        if p.sun_elevation_deg.is_empty()
            || p.sun_elevation_deg.windows(2).any(|w| w[1] <= w[0])
            || p.sun_elevation_deg
                .iter()
                .any(|e| !(0.0..=90.0).contains(e))
        {
            return Err(PlanError::invalid(
                "sun_elevation_deg",
                "must be strictly increasing within 0–90",
            ));
        }
        let r_mm = p.radius_mm[0];
        let shape = if p.shape == "beard-chuang" {
            DropShape::beard_chuang(r_mm)
        } else {
            let (Some(th), Some(r)) = (&p.profile_theta_deg, &p.profile_r) else {
                return Err(PlanError::invalid(
                    "profile_theta_deg",
                    "shape = profile needs profile_theta_deg and profile_r",
                ));
            };
            let (s, res) = CosineSeries::fit_table(r_mm * 1e3, th, r)
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

    fn diffraction_model(&self) -> DiffractionModel {
        self.p.diffraction_model.unwrap_or(if self.two_d {
            DiffractionModel::Gaussian
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

    fn task_pairs(&self) -> Vec<(f64, f64)> {
        let second = if self.two_d {
            &self.p.sun_elevation_deg
        } else {
            &self.p.radius_mm
        };
        self.p
            .wavelength_nm
            .iter()
            .flat_map(|&l| second.iter().map(move |&s| (l, s)))
            .collect()
    }

    fn channels(&self) -> Vec<Channel> {
        crate::raytrace::channel_names(self.p.max_order)
            .into_iter()
            .map(|n| {
                let (unit, meaning) = match n.as_str() {
                    "phase" => ("1/sr", "unpolarised phase function (i_perp + i_par)/2, diffraction-filtered, with forward lobe".to_string()),
                    "i_perp" => ("1/sr", "perpendicular part |S1|²-like, same normalisation".to_string()),
                    "i_par" => ("1/sr", "parallel part |S2|²-like, same normalisation".to_string()),
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

    /// Run the 2-D tracer for one (wavelength, elevation): values [polar][azimuth][channel].
    #[allow(clippy::needless_range_loop)]
    fn run_2d(&self, lambda: f64, elevation_deg: f64) -> Result<Vec<f32>, JobError> {
        let shape = self.shape.as_ref().expect("2-D job has a shape");
        let n = self.model.index(lambda)?;
        let grid = self.direction_grid();
        let cfg = TraceConfig {
            rays: self.p.rays,
            max_order: self.p.max_order,
            sun_elevation_rad: elevation_deg.to_radians(),
            wavelength_nm: lambda,
            n,
        };
        let f = trace_fields(shape, &cfg, grid);
        let a_um = shape.radius_um();
        let area = f.projected_area_um2;
        let a_eff = (area / PI).sqrt();
        let sigma_total: f64 = f.order_cross_section_um2.iter().sum::<f64>() + area;
        let (np, na) = (grid.n_polar, grid.n_azimuth);
        let orders = self.p.max_order + 1;
        let dth = grid.polar_step();
        let theta: Vec<f64> = (0..np).map(|j| dth * j as f64).collect();
        let go = SphereGo::new(a_um, lambda, n, 3);
        let split = 0.5
            * (go.rainbow_angle_rad(2).unwrap_or(2.4) + go.rainbow_angle_rad(3).unwrap_or(2.26));
        let sigma = filter_sigma_deg(a_um * 1e-3).to_radians();
        let filt = self.p.diffraction_filter;
        let sigma_at = |th: f64| {
            if !filt {
                0.0
            } else if th > split {
                sigma
            } else {
                2.0 * sigma
            }
        };
        let lobe: Vec<f64> = theta
            .iter()
            .map(|&th| {
                let (lo, hi) = bin_edges(th, dth);
                fraunhofer_bin_average(a_eff, lambda, lo, hi)
            })
            .collect();
        let nch = 4 + orders + 3;
        let mut out = vec![0f32; np * na * nch];
        for k in 0..na {
            // Columns of dσ/dΩ: i_perp, i_par, per order.
            let mut cols = vec![vec![0.0; np]; 2 + orders];
            for j in 0..np {
                let (ip, ipar, per) = f.intensities(j, k);
                cols[0][j] = ip;
                cols[1][j] = ipar;
                for o in 0..orders {
                    cols[2 + o][j] = per[o];
                }
            }
            // Caustics of this column: the peaks of the unfiltered primary and secondary orders
            // ("very sharp transitions"), searched in 130–150° and 115–135°.
            let peak = |o: usize, lo: f64, hi: f64| -> Option<f64> {
                if o >= orders {
                    return None;
                }
                let (j0, j1) = (
                    (lo.to_radians() / dth) as usize,
                    ((hi.to_radians() / dth) as usize).min(np - 1),
                );
                (j0..=j1)
                    .max_by(|&x, &y| cols[2 + o][x].total_cmp(&cols[2 + o][y]))
                    .map(|j| theta[j])
            };
            let bows: Vec<f64> = [peak(2, 130.0, 150.0), peak(3, 115.0, 135.0)]
                .into_iter()
                .flatten()
                .collect();
            let filtered: Vec<Vec<f64>> = cols
                .iter()
                .map(|c| {
                    let b = gaussian_blur(c, 0.0, dth, &theta, sigma_at);
                    (0..np)
                        .map(|j| {
                            let w = caustic_weight(
                                theta[j],
                                &bows,
                                sigma_at(theta[j]) * DEFAULT_CAUSTIC_WINDOW_SIGMAS,
                            );
                            if filt {
                                w * b[j] + (1.0 - w) * c[j]
                            } else {
                                c[j]
                            }
                        })
                        .collect()
                })
                .collect();
            for j in 0..np {
                let ip = (filtered[0][j] + lobe[j]) / sigma_total;
                let ipar = (filtered[1][j] + lobe[j]) / sigma_total;
                let ipu = (cols[0][j] + lobe[j]) / sigma_total;
                let iparu = (cols[1][j] + lobe[j]) / sigma_total;
                let base = (j * na + k) * nch;
                let mut row = vec![
                    0.5 * (ip + ipar),
                    ip,
                    ipar,
                    if ip + ipar > 0.0 {
                        (ip - ipar) / (ip + ipar)
                    } else {
                        0.0
                    },
                ];
                for o in 0..orders {
                    row.push(filtered[2 + o][j] / sigma_total);
                }
                row.extend([0.5 * (ipu + iparu), ipu, iparu]);
                for (c, v) in row.iter().enumerate() {
                    out[base + c] = *v as f32;
                }
            }
        }
        Ok(out)
    }
}

/// ∫ p dΩ of a 1-D phase function on a uniform [0, π] grid (bin-sum with exact bin solid angles).
fn integral_1d(values: impl Iterator<Item = f64>, step: f64) -> f64 {
    values
        .enumerate()
        .map(|(j, v)| {
            let (lo, hi) = bin_edges(step * j as f64, step);
            v * 2.0 * PI * (lo.cos() - hi.cos())
        })
        .sum()
}

impl Job for RaytraceJob {
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
                        label: format!("λ={l} nm a={s} mm"),
                        params: serde_json::json!({"wavelength_nm": l, "radius_mm": s}),
                    }
                }
            })
            .collect()
    }

    fn run_task(&self, index: usize) -> Result<Vec<f32>, JobError> {
        let (l, s) = self.task_pairs()[index];
        if self.two_d {
            return self.run_2d(l, s);
        }
        let n = self.model.index(l)?;
        let go = SphereGo::new(s * 1e3, l, n, self.p.max_order);
        let na = self.n_angles();
        let angles: Vec<f64> = (0..na).map(|j| self.p.angle_step_deg * j as f64).collect();
        let (ch, _) = sphere_phase_1d(
            &go,
            &angles,
            Phase1dOptions {
                diffraction_filter: self.p.diffraction_filter,
                model: self.diffraction_model(),
                ..Default::default()
            },
        );
        let nch = ch.len();
        let mut out = vec![0f32; na * nch];
        for j in 0..na {
            for c in 0..nch {
                out[j * nch + c] = ch[c][j] as f32;
            }
        }
        Ok(out)
    }

    fn assemble(&self, chunks: Vec<Vec<f32>>) -> Result<TableContent, JobError> {
        let data: Vec<f32> = chunks.into_iter().flatten().collect();
        let channels = self.channels();
        let nch = channels.len();
        let mut at = serde_json::Map::new();
        at.extend(phase_contract::attributes(
            "integral over 4pi sr equals 1",
            &self.model,
            0.0,
        ));
        at.insert("max_order".into(), self.p.max_order.into());
        at.insert("cross_section_normalization".into(), "p = (dσ/dΩ)/σ with σ = σ_GO (flux of the traced orders) + A (Fraunhofer forward lobe of the projected area A, added to i_perp and i_par as the exact bin average of a²J1(x sinθ)²/sin²θ)".into());
        at.insert("focal_line_rule".into(), "longer-path branch π/2 behind (docs/decisions.md RT-1): phase exp(i(k l − (π/2) f)), f = [dl/db > 0], b = u² + v²".into());
        let model = self.diffraction_model();
        let filter_text = match model {
            DiffractionModel::AiryUniform => "airy-uniform: uniform caustic (Airy) approximation of each order's rainbow (two-branch CUA on the bright side, Airy continuation on the dark side); GO elsewhere".to_string(),
            DiffractionModel::Gaussian => format!("gaussian: thesis Table 3.3 Gaussian in polar angle (σ linear in radius, Airy a^(-2/3) outside 0.1–1 mm; σ = {:.4}° at the first radius) for θ above the Alexander-band midpoint, 2σ below, blended in only within a Gaussian window of half-width 2σ_local around each caustic (peaks of the p = 2 and p = 3 intensities)", filter_sigma_deg(self.p.radius_mm[0])),
        };
        at.insert(
            "diffraction_filter".into(),
            format!("{filter_text}; applied = {}", self.p.diffraction_filter).into(),
        );
        at.insert("fresnel".into(), "complex Fresnel amplitudes, Born–Wolf signs, power-consistent transmission (src/optics/fresnel.rs)".into());
        at.insert("cross_order_phase".into(), "orders summed coherently without per-order constant (axial focal line) phases, as in the thesis: the fine cross-order ripple of the unfiltered channels is not Mie-exact".into());
        if !self.two_d {
            let na = self.n_angles();
            let step = self.p.angle_step_deg.to_radians();
            let mut ints = vec![];
            for e in 0..self.task_pairs().len() {
                let base = e * na * nch;
                ints.push(integral_1d(
                    (0..na).map(|j| data[base + j * nch] as f64),
                    step,
                ));
            }
            at.insert(
                "integral_check".into(),
                serde_json::json!({"what": "bin-sum of phase over 4π per entry", "values": ints}),
            );
            at.insert("angular_resampling".into(), format!("point samples of the GO+phase field on an internal grid of step ≤ λ/(10a); filtered channels are Gaussian averages of it; the forward lobe is the exact average over each {}° bin", self.p.angle_step_deg).into());
            at.insert("method".into(), "exact 1-D geometric optics plus phase for spheres (two-branch phasor sum of Airy theory), validated against the 2-D patch tracer and Lorenz–Mie (docs/raytrace.md)".into());
            at.insert("validated_domain".into(), "spheres of radius 0.1–1 mm in 380–700 nm (x ≳ 1000): supernumerary positions within 0.02° (primary) and 0.05° (secondary) of Lorenz–Mie; not valid within ~1° of 0° (forward lobe only approximate) and near 180° (glory, axial caustic clamped at a quarter bin)".into());
            let axes = vec![
                Axis::values("wavelength", "nm", self.p.wavelength_nm.clone()),
                Axis::values(
                    "radius",
                    "um",
                    self.p.radius_mm.iter().map(|r| r * 1e3).collect(),
                ),
                Axis::uniform("scattering_angle", "deg", 0.0, self.p.angle_step_deg, na),
            ];
            return Ok(TableContent {
                schema: Schema::new("raytrace-phase", 1),
                description:
                    "ray-traced (geometric optics + phase) phase function of water spheres".into(),
                axes,
                channels,
                attributes: at,
                data,
            });
        }
        let grid = self.direction_grid();
        let (np, na) = (grid.n_polar, grid.n_azimuth);
        let dth = grid.polar_step();
        let mut data = data;
        let mut ints = vec![];
        for e in 0..self.task_pairs().len() {
            let base = e * np * na * nch;
            let mut s = 0.0;
            for j in 0..np {
                let (lo, hi) = bin_edges(dth * j as f64, dth);
                let om = (lo.cos() - hi.cos()) * grid.azimuth_step();
                for k in 0..na {
                    s += data[base + (j * na + k) * nch] as f64 * om;
                }
            }
            ints.push(s);
            // Renormalisation of 2-D tables (decision RT-21 in docs/decisions.md): the bin-sum
            // deviates from 1 by the flux of discarded silhouette triangles (−0.1…−0.5 %) and,
            // for strongly flattened drops, by point-sampled cusp caustics (+3.9 % at 3 mm,
            // sun 0°); every intensity channel (all but `dolp`) is divided by it, so ∫ p dΩ = 1
            // exactly on the table grid, as the phase-function contract requires, and the
            // factor is kept in `integral_check`.
            if !(s > 0.0 && s.is_finite()) {
                return Err(JobError::NotNormalisable {
                    entry: e,
                    integral: s,
                });
            }
            for v in data[base..base + np * na * nch].chunks_mut(nch) {
                for (c, x) in v.iter_mut().enumerate() {
                    if c != 3 {
                        *x = (*x as f64 / s) as f32;
                    }
                }
            }
        }
        at.insert("integral_check".into(), serde_json::json!({"what": "bin-sum of phase over 4π per entry before renormalisation (below 1 by the flux of triangles discarded at the silhouette, above 1 where cusp caustics are point-sampled); every channel but dolp was divided by it, so the stored table integrates to 1 on its grid", "values": ints}));
        at.insert("angular_resampling".into(), "point samples of the coherent patch sum at the grid directions; filtered channels are Gaussian averages along the polar angle per azimuth column; the forward lobe is the exact average over each polar bin".into());
        at.insert("frame".into(), "drop axis vertical (z up); sun at elevation e in the +x half-space, incident direction d = (−cos e, 0, −sin e); outgoing_polar = angle from d; outgoing_azimuth about d from e1 = (−sin e, 0, cos e) (vertical plane, upwards) towards e2 = +y".into());
        at.insert("shape".into(), self.p.shape.clone().into());
        at.insert("radius_mm".into(), self.p.radius_mm[0].into());
        at.insert("rays_per_side".into(), self.p.rays.into());
        at.insert("beard_chuang".into(), "r(θ) = a[1 + Σ c_n cos nθ], θ from the downward pole, thesis Table 3.1 linear in a; sphere for a ≤ 0.4 mm; clamped to the 3 mm row above 3 mm".into());
        if let Some(res) = self.profile_fit_residual {
            at.insert("profile_fit_rms_relative".into(), res.into());
        }
        at.insert("forward_lobe".into(), "Fraunhofer lobe of the equal-projected-area disc (azimuthally symmetric approximation for non-circular silhouettes)".into());
        at.insert("method".into(), "patch-based wave-optics ray tracer (Sadeghi 2012, ch. 3) with 3-D complex field vectors, spherical-triangle patches, coherent sums; see docs/raytrace.md".into());
        at.insert("validated_domain".into(), "validated on spheres (0.4 mm, 650 nm) against the exact 1-D path and Lorenz–Mie; Beard–Chuang results checked for volume, axis ratios, symmetry and energy; accuracy depends on rays_per_side (docs/raytrace.md)".into());
        let axes = vec![
            Axis::values("wavelength", "nm", self.p.wavelength_nm.clone()),
            Axis::values("sun_elevation", "deg", self.p.sun_elevation_deg.clone()),
            Axis::uniform("outgoing_polar", "deg", 0.0, self.p.polar_step_deg, np),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, self.p.azimuth_step_deg, na),
        ];
        Ok(TableContent {
            schema: Schema::new("raytrace-phase-2d", 1),
            description: format!(
                "ray-traced phase function of a {} drop, a = {} mm, over outgoing directions",
                self.p.shape, self.p.radius_mm[0]
            ),
            axes,
            channels,
            attributes: at,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_parameters() {
        crate::stages::assert_planning(
            &RaytraceStage,
            &[
                "shape = \"cube\"\nradius_mm = [1.0]",
                "shape = \"sphere\"\nradius_mm = [0.4]\nangle_step_deg = 0.07",
                "shape = \"beard-chuang\"\nradius_mm = [1.0, 2.0]",
                "shape = \"sphere\"\nradius_mm = [0.4]\nwavelength_nm = [300.0]",
                "shape = \"sphere\"\nradius_mm = [0.4]\nunknown = 1",
                "shape = \"profile\"\nradius_mm = [1.0]",
            ],
            &[],
        );
    }

    #[test]
    fn sphere_table_is_normalised_and_peaks_near_mie() {
        let t = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"sphere\"\nradius_mm = [0.4]\nwavelength_nm = [650.0]\nangle_step_deg = 0.05",
        );
        assert_eq!(t.data.len(), t.expected_len());
        let integral = t.attributes["integral_check"]["values"][0]
            .as_f64()
            .unwrap();
        // Traced orders (99.7 %) + lobe; bin-summed on the table grid.
        assert!((integral - 1.0).abs() < 0.01, "∫p = {integral}");
        // Filtered primary maximum: Lorenz–Mie 138.03° (0.4 mm, 650 nm); the Gaussian filter
        // of Table 3.3 places it within 0.15°.
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
        let t = crate::stages::table_from_lines(
            &RaytraceStage,
            "shape = \"beard-chuang\"\nradius_mm = [2.0]\nwavelength_nm = [550.0]\nsun_elevation_deg = [0.0]\nrays = 80\npolar_step_deg = 0.5\nazimuth_step_deg = 30.0",
        );
        let raw = t.attributes["integral_check"]["values"][0]
            .as_f64()
            .unwrap();
        assert!((raw - 1.0).abs() < 0.1, "raw ∫p = {raw}");
        let (np, na, nch) = (t.axes[2].len(), t.axes[3].len(), t.channels.len());
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
}
