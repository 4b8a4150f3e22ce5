//! `mixture` stage (schema `mixture-phase/1`): phase functions of drop-size mixtures that use
//! Lorenz–Mie for the small drops and the ray tracer's exact 1-D sphere path (geometric optics
//! plus phase, Airy-uniform caustics; Sadeghi 2012 ch. 3) for the large ones.
//!
//! For each (distribution, wavelength) the distribution's Gauss–Legendre rule in ln r (the one
//! of the `mie` stage, `radius_points` nodes) gives radii r_i and number weights n(r_i) dr_i.
//! Each radius contributes its normalised curve p_i (Mie below `handover_radius_um`, traced at
//! or above it) with weight n(r_i) dr_i · C_sca(r_i), where C_sca = π r² Q_sca for Mie and
//! σ_GO + π r² (traced orders plus the forward Fraunhofer lobe) for traced drops. The mix is
//! formed on the `mie` stage's intermediate grid, convolved with the sun's disc and averaged
//! over the output bins exactly as the `mie` stage does, so a mixture whose radii all lie below
//! the handover is the `mie` stage's table of the same distribution (tested to 1e-3).
//!
//! Output follows the phase-function contract (`docs/consumers.md`): axes distribution ×
//! wavelength × scattering_angle, channels phase, i_perp, i_par, dolp, so every 1-D consumer
//! (read, export, plot, render) works on it.
//!
//! Size distributions: `marshall-palmer` (Marshall & Palmer 1948), `gamma`, `lognormal`,
//! `monodisperse` (the `mie` stage's kinds), or `explicit` radii with number weights.

use crate::mie::distributions::SizeDistribution;
use crate::mie::filters::{
    FINE_CELL_POINTS, PolarisedPhase, SunDiscOperator, fine_intervals, resample_bins,
};
use crate::mie::{MieError, Sphere, size_parameter};
use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::raytrace::sphere1d::{Phase1dOptions, SphereGo, sphere_phase_1d};
use crate::stages::mie::FilterSettings;
use crate::stages::{Job, ParamDoc, PlanError, Stage, TaskSpec, checks, parse_params};
use crate::table::phase_contract::{self, CHANNELS};
use crate::table::{Axis, Schema, TableContent};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Errors of a mixture entry.
#[derive(Debug, thiserror::Error)]
pub enum MixtureError {
    #[error("Mie part: {0}")]
    Mie(#[from] MieError),
    #[error("distribution {entry}: total scattering cross-section {value} is not positive")]
    EmptyMixture { entry: usize, value: f64 },
}

/// The stage.
pub struct MixtureStage;

/// Explicit radii with number weights (any unit; normalised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplicitMixture {
    pub radii_um: Vec<f64>,
    pub number_weights: Vec<f64>,
}

/// One entry of the `distribution` axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MixtureEntry {
    Explicit(ExplicitMixture),
    Distribution(SizeDistribution),
}

impl MixtureEntry {
    /// Radii (µm) and number weights n(r) dr.
    fn nodes(&self, points: usize) -> (Vec<f64>, Vec<f64>) {
        match self {
            MixtureEntry::Explicit(e) => (e.radii_um.clone(), e.number_weights.clone()),
            MixtureEntry::Distribution(d) => d.quadrature(points),
        }
    }
}

fn default_wavelengths() -> Vec<f64> {
    SADEGHI_WAVELENGTHS_NM.to_vec()
}
fn default_model() -> String {
    "iapws1997".into()
}
fn default_temperature() -> f64 {
    20.0
}
fn default_step() -> f64 {
    0.05
}
fn default_sun() -> f64 {
    0.5
}
fn default_radius_points() -> usize {
    24
}
fn default_handover() -> f64 {
    DEFAULT_HANDOVER_UM
}
fn default_max_order() -> usize {
    3
}

/// Default handover radius (µm): above it the size parameter at 700 nm exceeds ~900 and the
/// 1-D traced path is within a few per cent of Mie at the bows (docs/raytrace.md).
pub const DEFAULT_HANDOVER_UM: f64 = 100.0;

/// Smallest radius the traced path accepts (µm), as the `raytrace` stage.
const MIN_TRACED_UM: f64 = 10.0;

/// Parameters of `[table.params]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MixtureParams {
    /// One table entry per distribution.
    pub distributions: Vec<MixtureEntry>,
    #[serde(default = "default_wavelengths")]
    pub wavelengths_nm: Vec<f64>,
    #[serde(default = "default_model")]
    pub water_index_model: String,
    #[serde(default = "default_temperature")]
    pub temperature_c: f64,
    #[serde(default = "default_step")]
    pub angle_step_deg: f64,
    #[serde(default = "default_sun")]
    pub sun_diameter_deg: f64,
    #[serde(default = "default_radius_points")]
    pub radius_points: usize,
    /// Radii below this use Lorenz–Mie, radii at or above it the traced 1-D path (µm).
    #[serde(default = "default_handover")]
    pub handover_radius_um: f64,
    /// Highest order traced for the large drops.
    #[serde(default = "default_max_order")]
    pub max_order: usize,
}

const PARAMS: &[ParamDoc] = &[
    ParamDoc {
        name: "distributions",
        kind: "list of tables",
        default: "required",
        description: "kind = marshall-palmer {rain_rate_mm_h, min_radius_um, max_radius_um} | gamma | lognormal | monodisperse (as the mie stage), or {radii_um, number_weights}",
    },
    ParamDoc {
        name: "wavelengths_nm",
        kind: "list of float, nm",
        default: "33 samples 380–700 nm",
        description: "vacuum wavelengths, strictly increasing",
    },
    ParamDoc {
        name: "water_index_model",
        kind: "string",
        default: "iapws1997",
        description: "iapws1997 | sadeghi-table-3.2",
    },
    ParamDoc {
        name: "temperature_c",
        kind: "float, °C",
        default: "20",
        description: "water temperature (iapws1997)",
    },
    ParamDoc {
        name: "angle_step_deg",
        kind: "float, deg",
        default: "0.05",
        description: "output scattering-angle step (divides 180)",
    },
    ParamDoc {
        name: "sun_diameter_deg",
        kind: "float, deg",
        default: "0.5",
        description: "sun's disc convolved with the mix (0 = off)",
    },
    ParamDoc {
        name: "radius_points",
        kind: "integer",
        default: "24",
        description: "Gauss–Legendre nodes in ln r per distribution",
    },
    ParamDoc {
        name: "handover_radius_um",
        kind: "float, µm",
        default: "100",
        description: "radii below use Lorenz–Mie, radii at or above the traced 1-D sphere path",
    },
    ParamDoc {
        name: "max_order",
        kind: "integer",
        default: "3",
        description: "highest order traced for the large drops, 1–8",
    },
];

impl Stage for MixtureStage {
    fn name(&self) -> &'static str {
        "mixture"
    }
    fn algorithm_version(&self) -> u32 {
        1
    }
    fn summary(&self) -> &'static str {
        "drop-size mixtures: Lorenz–Mie for small drops, traced spheres for large ones, weighted by number × scattering cross-section"
    }
    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMS
    }
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError> {
        let p: MixtureParams = parse_params(params)?;
        Ok(Box::new(MixtureJob::new(p)?))
    }
}

struct MixtureJob {
    p: MixtureParams,
    model: WaterIndexModel,
    indices: Vec<f64>,
    settings: FilterSettings,
    sun: std::sync::OnceLock<SunDiscOperator>,
}

fn validate_entry(i: usize, e: &MixtureEntry) -> Result<(), PlanError> {
    let key = format!("distributions[{i}]");
    match e {
        MixtureEntry::Distribution(d) => d.validate().map_err(|m| PlanError::invalid(&key, m)),
        MixtureEntry::Explicit(x) => {
            let ok = !x.radii_um.is_empty()
                && x.radii_um.len() == x.number_weights.len()
                && x.radii_um.iter().all(|r| *r > 0.0 && r.is_finite())
                && x.number_weights.iter().all(|w| *w >= 0.0 && w.is_finite())
                && x.number_weights.iter().any(|w| *w > 0.0);
            ok.then_some(()).ok_or_else(|| {
                PlanError::invalid(
                    &key,
                    "radii_um and number_weights: same non-zero length, radii > 0, weights ≥ 0, not all 0",
                )
            })
        }
    }
}

impl MixtureJob {
    fn new(p: MixtureParams) -> Result<Self, PlanError> {
        checks::increasing("wavelengths_nm", &p.wavelengths_nm, true)?;
        let (model, indices) = checks::water_indices(
            &p.water_index_model,
            Some(p.temperature_c),
            "wavelengths_nm",
            &p.wavelengths_nm,
        )?;
        if p.distributions.is_empty() {
            return Err(PlanError::invalid("distributions", "must not be empty"));
        }
        for (i, e) in p.distributions.iter().enumerate() {
            validate_entry(i, e)?;
        }
        let output_intervals = checks::angle_step_intervals("angle_step_deg", p.angle_step_deg)?;
        if !(0.0..=5.0).contains(&p.sun_diameter_deg) {
            return Err(PlanError::invalid(
                "sun_diameter_deg",
                "must be within 0–5 deg",
            ));
        }
        if !(4..=512).contains(&p.radius_points) {
            return Err(PlanError::invalid("radius_points", "must be within 4–512"));
        }
        if !(p.handover_radius_um >= MIN_TRACED_UM) {
            return Err(PlanError::invalid(
                "handover_radius_um",
                format!("must be ≥ {MIN_TRACED_UM} µm (geometric optics needs x ≫ 1)"),
            ));
        }
        if !(1..=8).contains(&p.max_order) {
            return Err(PlanError::invalid("max_order", "must be within 1–8"));
        }
        let settings = FilterSettings {
            output_intervals,
            sun_diameter_deg: p.sun_diameter_deg,
            gaussian_sigma_deg: 0.0,
            radius_points: p.radius_points,
        };
        Ok(MixtureJob {
            p,
            model,
            indices,
            settings,
            sun: std::sync::OnceLock::new(),
        })
    }
}

/// One radius' normalised curve on the intermediate grid (`mid` intervals) and its scattering
/// cross-section (µm²): Lorenz–Mie below `handover_um`, the traced 1-D path at or above.
fn radius_curve(
    r: f64,
    wavelength_nm: f64,
    n: f64,
    mid: usize,
    handover_um: f64,
    max_order: usize,
) -> Result<(PolarisedPhase, f64, bool), MixtureError> {
    if r < handover_um {
        let sphere = Sphere::new(size_parameter(r, wavelength_nm), Complex64::new(n, 0.0))?;
        // Fine cells nest in intermediate cells: an odd multiple of `mid` (as the mie stage).
        let need = fine_intervals(sphere.coefficients.n_stop(), mid);
        let mut k = need.div_ceil(mid);
        if k.is_multiple_of(2) {
            k += 1;
        }
        let fine = PolarisedPhase::from_sphere(&sphere, mid * k, FINE_CELL_POINTS, false);
        let c_sca = PI * r * r * sphere.efficiencies.q_sca;
        return Ok((resample_bins(&fine, mid), c_sca, false));
    }
    let go = SphereGo::new(r, wavelength_nm, n, max_order);
    let angles: Vec<f64> = (0..=mid).map(|j| 180.0 * j as f64 / mid as f64).collect();
    let (ch, _) = sphere_phase_1d(&go, &angles, Phase1dOptions::default());
    let sigma_go: f64 = (0..=max_order).map(|p| go.energy_fraction(p)).sum::<f64>() * PI * r * r;
    let curve = PolarisedPhase {
        step_deg: 180.0 / mid as f64,
        i_perp: ch[1].clone(),
        i_par: ch[2].clone(),
    };
    Ok((curve, sigma_go + PI * r * r, true))
}

/// One (distribution, wavelength): the mixed curve on the output grid and the fraction of the
/// scattering cross-section carried by traced drops.
fn mix_entry(
    job: &MixtureJob,
    entry: usize,
    w: usize,
) -> Result<(PolarisedPhase, f64), MixtureError> {
    let (radii, weights) = job.p.distributions[entry].nodes(job.p.radius_points);
    let mid = job.settings.intermediate_intervals();
    let (l, n) = (job.p.wavelengths_nm[w], job.indices[w]);
    let parts: Vec<(PolarisedPhase, f64, bool)> = radii
        .par_iter()
        .zip(&weights)
        .map(|(&r, &nw)| {
            let (c, c_sca, traced) =
                radius_curve(r, l, n, mid, job.p.handover_radius_um, job.p.max_order)?;
            Ok((c, nw * c_sca, traced))
        })
        .collect::<Result<_, MixtureError>>()?;
    let total: f64 = parts.iter().map(|p| p.1).sum();
    if !(total > 0.0 && total.is_finite()) {
        return Err(MixtureError::EmptyMixture {
            entry,
            value: total,
        });
    }
    let traced: f64 = parts.iter().filter(|p| p.2).map(|p| p.1).sum();
    let mut mix = PolarisedPhase::zeros(mid);
    for (curve, weight, _) in &parts {
        mix.add_scaled(curve, weight / total);
    }
    let sun = job.sun.get_or_init(|| job.settings.sun_operator());
    let mix = sun.apply(&mix);
    Ok((
        resample_bins(&mix, job.settings.output_intervals),
        traced / total,
    ))
}

impl Job for MixtureJob {
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        let mut out = Vec::new();
        for (e, d) in self.p.distributions.iter().enumerate() {
            for l in &self.p.wavelengths_nm {
                out.push(TaskSpec {
                    label: format!("distribution {e} λ={l} nm"),
                    params: serde_json::json!({ "wavelength_nm": l, "entry": d }),
                });
            }
        }
        out
    }
    fn run_task(&self, index: usize) -> anyhow::Result<Vec<f32>> {
        let n_w = self.p.wavelengths_nm.len();
        let (curve, traced) = mix_entry(self, index / n_w, index % n_w)?;
        let (phase, dolp) = (curve.phase(), curve.dolp());
        let mut out = Vec::with_capacity(phase.len() * CHANNELS.len() + 1);
        for j in 0..phase.len() {
            out.extend([
                phase[j] as f32,
                curve.i_perp[j] as f32,
                curve.i_par[j] as f32,
                dolp[j] as f32,
            ]);
        }
        out.push(traced as f32);
        Ok(out)
    }
    fn assemble(&self, chunks: Vec<Vec<f32>>) -> anyhow::Result<TableContent> {
        let n_w = self.p.wavelengths_nm.len();
        let n_a = self.settings.output_intervals + 1;
        let per = n_a * CHANNELS.len();
        anyhow::ensure!(
            chunks.len() == n_w * self.p.distributions.len(),
            "wrong number of chunks"
        );
        let mut data = Vec::with_capacity(chunks.len() * per);
        let mut traced: Vec<Vec<f64>> = vec![];
        for (i, c) in chunks.iter().enumerate() {
            anyhow::ensure!(c.len() == per + 1, "chunk {i} has {} values", c.len());
            data.extend_from_slice(&c[..per]);
            if i % n_w == 0 {
                traced.push(vec![]);
            }
            traced.last_mut().expect("row").push(c[per] as f64);
        }
        let mut a = serde_json::Map::new();
        a.extend(phase_contract::attributes(
            "integral over 4pi sr equals 1",
            &self.model,
            self.p.sun_diameter_deg,
        ));
        a.insert("refractive_index_real".into(), self.indices.clone().into());
        a.insert(
            "distributions".into(),
            serde_json::to_value(&self.p.distributions)?,
        );
        a.insert(
            "handover_radius_um".into(),
            self.p.handover_radius_um.into(),
        );
        a.insert("traced_fraction".into(), serde_json::to_value(traced)?);
        a.insert("mixture_weighting".into(), "normalised phase functions mixed with weights n(r) dr · C_sca(r) (Gauss–Legendre in ln r, or explicit weights); C_sca = π r² Q_sca (Lorenz–Mie, r < handover) or σ_GO + π r² (traced sphere, 1-D exact path with Airy-uniform caustics, r ≥ handover); mixed on the mie stage's intermediate grid, then sun disc and bin averages; traced_fraction[entry][wavelength] = traced share of the mixture's scattering cross-section".into());
        Ok(TableContent {
            schema: Schema::new("mixture-phase", 1),
            description:
                "phase functions of drop-size mixtures (Lorenz–Mie small drops, traced large drops)"
                    .into(),
            axes: vec![
                Axis::values(
                    "distribution",
                    "1",
                    (0..self.p.distributions.len()).map(|i| i as f64).collect(),
                ),
                Axis::values("wavelength", "nm", self.p.wavelengths_nm.clone()),
                Axis::uniform("scattering_angle", "deg", 0.0, self.p.angle_step_deg, n_a),
            ],
            channels: phase_contract::channels("over the mixture's scattering cross-section"),
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::{plan_from_lines, run_in_memory};

    const MP: &str = "{ kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = 20.0, max_radius_um = 80.0 }";

    /// Identity: a Marshall–Palmer mixture whose radii all lie below the handover equals the
    /// `mie` stage's own Marshall–Palmer table (same quadrature radii, same weights) to 1e-3.
    #[test]
    fn mie_only_marshall_palmer_mixture_equals_the_mie_stage() {
        let common = "wavelengths_nm = [550.0]\nangle_step_deg = 0.5\nradius_points = 8\n";
        let mix = plan_from_lines(
            &MixtureStage,
            &format!("{common}distributions = [{MP}]\nhandover_radius_um = 1000.0"),
        )
        .unwrap();
        let mie = plan_from_lines(
            &crate::stages::mie::MieStage,
            &format!("{common}distributions = [{MP}]"),
        )
        .unwrap();
        let (a, b) = (run_in_memory(&*mix).unwrap(), run_in_memory(&*mie).unwrap());
        assert_eq!(a.data.len(), b.data.len());
        assert_eq!(a.attributes["traced_fraction"][0][0], 0.0);
        let mut worst = 0.0f64;
        for (x, y) in a.data.iter().zip(&b.data).step_by(4) {
            worst = worst.max(((x - y) / y).abs() as f64);
        }
        assert!(worst < 1e-3, "max relative difference {worst}");
    }

    /// Moving the handover below the largest radii traces them: the traced share is positive,
    /// the table still integrates to 1 and changes near the primary bow.
    #[test]
    fn handover_switches_large_drops_to_the_traced_path() {
        let lines = |h: f64| {
            format!(
                "wavelengths_nm = [650.0]\nangle_step_deg = 0.5\nradius_points = 6\ndistributions = [{MP}]\nhandover_radius_um = {h}"
            )
        };
        let t = run_in_memory(&*plan_from_lines(&MixtureStage, &lines(50.0)).unwrap()).unwrap();
        let f = t.attributes["traced_fraction"][0][0].as_f64().unwrap();
        assert!(f > 0.0 && f < 1.0, "traced fraction {f}");
        let step = 0.5f64.to_radians();
        let integral: f64 = (0..361)
            .map(|j| {
                let (lo, hi) = crate::raytrace::post::bin_edges(step * j as f64, step);
                t.data[j * 4] as f64 * 2.0 * PI * (lo.cos() - hi.cos())
            })
            .sum();
        assert!((integral - 1.0).abs() < 0.02, "∫p = {integral}");
        let m = run_in_memory(&*plan_from_lines(&MixtureStage, &lines(1000.0)).unwrap()).unwrap();
        let j = (138.0f64 / 0.5) as usize;
        assert!((t.data[j * 4] - m.data[j * 4]).abs() > 1e-4 * m.data[j * 4]);
    }

    #[test]
    fn rejects_bad_mixtures() {
        let bad = [
            "distributions = []",
            "distributions = [{ radii_um = [100.0], number_weights = [1.0, 2.0] }]",
            "distributions = [{ radii_um = [100.0], number_weights = [0.0] }]",
            "distributions = [{ radii_um = [100.0], number_weights = [1.0] }]\nhandover_radius_um = 1.0",
        ];
        for b in bad {
            assert!(plan_from_lines(&MixtureStage, b).is_err(), "{b}");
        }
        assert!(
            plan_from_lines(
                &MixtureStage,
                "distributions = [{ radii_um = [100.0, 500.0], number_weights = [10.0, 1.0] }]"
            )
            .is_ok()
        );
    }
}
