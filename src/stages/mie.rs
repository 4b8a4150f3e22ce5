//! The `mie` stage (schema `mie-phase/1`): per-wavelength Lorenz–Mie phase functions of water
//! drops (monodisperse radii or size distributions), smoothed by the sun's disc and integrated
//! over the table's angular bins. Follows the phase-function table contract
//! (`docs/consumers.md`): axes `radius` (µm) or `distribution` (1) × `wavelength` (nm) ×
//! `scattering_angle` (deg); channels `phase`, `i_perp`, `i_par`, `dolp`; per-entry Q_ext, Q_sca,
//! Q_back, g as f64 arrays `[entry][wavelength]` in the header attributes.

use crate::mie::distributions::SizeDistribution;
use crate::mie::filters::{
    FINE_CELL_POINTS, PolarisedPhase, SunDiscOperator, fine_intervals, gaussian_blur, resample_bins,
};
use crate::mie::{Sphere, size_parameter};
use crate::optics::water::{SADEGHI_WAVELENGTHS_NM, WaterIndexModel};
use crate::stages::{
    Job, ParamDoc, PlanError, Stage, TaskSpec, checks, join_f64, parse_params, split_f64,
};
use crate::table::phase_contract::{self, CHANNELS};
use crate::table::{Axis, Schema, TableContent};
use num_complex::Complex64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The stage.
pub struct MieStage;

/// Parameters of `[table.params]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MieParams {
    /// Vacuum wavelengths (nm); default: the thesis' 33 samples 380–700 nm.
    #[serde(default = "default_wavelengths")]
    pub wavelengths_nm: Vec<f64>,
    /// Monodisperse radii (µm), strictly increasing. Exactly one of `radii_um`/`distributions`.
    #[serde(default)]
    pub radii_um: Option<Vec<f64>>,
    /// Size distributions (tables with `kind = "lognormal" | "gamma" | "marshall-palmer" |
    /// "monodisperse"`).
    #[serde(default)]
    pub distributions: Option<Vec<SizeDistribution>>,
    /// `iapws1997` or `sadeghi-table-3.2`.
    #[serde(default = "default_model")]
    pub water_index_model: String,
    /// Water temperature for `iapws1997` (°C).
    #[serde(default = "default_temperature")]
    pub temperature_c: f64,
    /// Output angular step (deg); 180/step must be an integer.
    #[serde(default = "default_step")]
    pub angle_step_deg: f64,
    /// Angular diameter of the sun's disc (deg); 0 disables the convolution.
    #[serde(default = "default_sun")]
    pub sun_diameter_deg: f64,
    /// Optional extra 1-D Gaussian blur (deg, standard deviation); 0 = off.
    #[serde(default)]
    pub gaussian_sigma_deg: f64,
    /// Gauss–Legendre points in ln r for distributions.
    #[serde(default = "default_radius_points")]
    pub radius_points: usize,
    /// Refractive index of the medium around the drops: the drop index and the vacuum
    /// wavelength are divided by it (left out of the content key when 1).
    #[serde(default = "default_n_medium", skip_serializing_if = "is_vacuum")]
    pub n_medium: f64,
}

fn default_n_medium() -> f64 {
    1.0
}
fn is_vacuum(n: &f64) -> bool {
    *n == 1.0
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

const PARAMS: &[ParamDoc] = &[
    ParamDoc {
        name: "wavelengths_nm",
        kind: "list of float, nm",
        default: "33 samples 380–700 nm",
        description: "vacuum wavelengths",
    },
    ParamDoc {
        name: "radii_um",
        kind: "list of float, µm",
        default: "required unless distributions",
        description: "monodisperse drop radii, strictly increasing",
    },
    ParamDoc {
        name: "distributions",
        kind: "list of tables",
        default: "required unless radii_um",
        description: "size distributions: kind = lognormal {median_radius_um, geometric_sigma} | gamma {effective_radius_um, effective_variance} | marshall-palmer {rain_rate_mm_h, min_radius_um=50, max_radius_um=3000} | monodisperse {radius_um}",
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
        description: "output bin width; 180/step integer; values are bin averages",
    },
    ParamDoc {
        name: "sun_diameter_deg",
        kind: "float, deg",
        default: "0.5",
        description: "uniform solar disc convolution (0 = off)",
    },
    ParamDoc {
        name: "gaussian_sigma_deg",
        kind: "float, deg",
        default: "0",
        description: "optional extra Gaussian blur in angle",
    },
    ParamDoc {
        name: "n_medium",
        kind: "float",
        default: "1",
        description: "real index of the surrounding medium (1–3): relative index n_water/n_medium, size parameter 2π r n_medium/λ",
    },
    ParamDoc {
        name: "radius_points",
        kind: "integer",
        default: "24",
        description: "Gauss–Legendre nodes in ln r per distribution",
    },
];

/// Number of f32 values appended to each task chunk: Q_ext, Q_sca, Q_back, g, each as an f32
/// pair (hi, lo) with hi + lo = the f64 value to ~1e-14 relative (chunks are f32 vectors).
const TAIL: usize = 8;

/// The entries (second axis) of a job.
#[derive(Debug, Clone)]
enum Entries {
    Radii(Vec<f64>),
    Distributions(Vec<SizeDistribution>),
}

impl Entries {
    fn len(&self) -> usize {
        match self {
            Entries::Radii(r) => r.len(),
            Entries::Distributions(d) => d.len(),
        }
    }
    fn distribution(&self, i: usize) -> SizeDistribution {
        match self {
            Entries::Radii(r) => SizeDistribution::Monodisperse { radius_um: r[i] },
            Entries::Distributions(d) => d[i].clone(),
        }
    }
}

/// Ensemble result of one (wavelength, entry): the table curve and averaged scalars.
#[derive(Debug, Clone)]
pub struct EntryResult {
    /// Output curve (bin averages on the table grid).
    pub curve: PolarisedPhase,
    /// `⟨C_ext⟩/⟨π r²⟩`.
    pub q_ext: f64,
    /// `⟨C_sca⟩/⟨π r²⟩`.
    pub q_sca: f64,
    /// `⟨C_back⟩/⟨π r²⟩`.
    pub q_back: f64,
    /// `⟨C_sca g⟩/⟨C_sca⟩`.
    pub g: f64,
}

/// Filter settings of one job.
#[derive(Debug, Clone, Copy)]
pub struct FilterSettings {
    pub output_intervals: usize,
    pub sun_diameter_deg: f64,
    pub gaussian_sigma_deg: f64,
    pub radius_points: usize,
}

impl FilterSettings {
    /// Intervals of the intermediate grid on which the disc/Gaussian act: the output step
    /// divided by the smallest odd `k` giving a step ≤ min(sun diameter/40, σ/4) (so that cells
    /// nest in output bins).
    pub fn intermediate_intervals(&self) -> usize {
        let step = 180.0 / self.output_intervals as f64;
        let mut limit = step;
        if self.sun_diameter_deg > 0.0 {
            limit = limit.min(self.sun_diameter_deg / 40.0);
        }
        if self.gaussian_sigma_deg > 0.0 {
            limit = limit.min(self.gaussian_sigma_deg / 4.0);
        }
        let mut k = (step / limit - 1e-9).ceil().max(1.0) as usize;
        if k.is_multiple_of(2) {
            k += 1;
        }
        self.output_intervals * k
    }

    /// The sun-disc operator on the intermediate grid (build once per job, share across tasks).
    pub fn sun_operator(&self) -> SunDiscOperator {
        SunDiscOperator::new(self.intermediate_intervals(), self.sun_diameter_deg)
    }
}

/// Computes one table entry (pure): every radius of the distribution's quadrature on its own
/// fine grid of cell averages, resampled to the intermediate grid, mixed with weights
/// `n(r) dr · C_sca(r)`, convolved with the sun's disc, optionally blurred, and integrated
/// over the output bins. `sun` must be [`FilterSettings::sun_operator`] of `settings`.
pub fn compute_entry(
    distribution: &SizeDistribution,
    wavelength_nm: f64,
    m: Complex64,
    settings: &FilterSettings,
    sun: &SunDiscOperator,
) -> Result<EntryResult, crate::mie::MieError> {
    let (radii, weights) = distribution.quadrature(settings.radius_points);
    let mid = settings.intermediate_intervals();
    let per_radius: Vec<Result<(PolarisedPhase, [f64; 5]), crate::mie::MieError>> = radii
        .par_iter()
        .zip(&weights)
        .map(|(&r, &w)| {
            let x = size_parameter(r, wavelength_nm);
            let sphere = Sphere::new(x, m)?;
            let n_stop = sphere.coefficients.n_stop();
            // fine cells nest in intermediate cells: an odd multiple of `mid`
            let need = fine_intervals(n_stop, mid);
            let mut k = need.div_ceil(mid);
            if k.is_multiple_of(2) {
                k += 1;
            }
            let fine = PolarisedPhase::from_sphere(&sphere, mid * k, FINE_CELL_POINTS, false);
            let curve = resample_bins(&fine, mid);
            let e = sphere.efficiencies;
            let area = std::f64::consts::PI * r * r;
            Ok((
                curve,
                [
                    w * area,
                    w * area * e.q_ext,
                    w * area * e.q_sca,
                    w * area * e.q_back,
                    w * area * e.q_sca * e.g,
                ],
            ))
        })
        .collect();
    let mut mix = PolarisedPhase::zeros(mid);
    let mut sums = [0.0; 5];
    let mut total_sca = 0.0;
    let mut parts = Vec::with_capacity(per_radius.len());
    for item in per_radius {
        let (curve, s) = item?;
        for (a, b) in sums.iter_mut().zip(s) {
            *a += b;
        }
        total_sca += s[2];
        parts.push((curve, s[2]));
    }
    for (curve, c_sca) in &parts {
        mix.add_scaled(curve, c_sca / total_sca);
    }
    let mix = sun.apply(&mix);
    let mix = gaussian_blur(&mix, settings.gaussian_sigma_deg);
    let curve = resample_bins(&mix, settings.output_intervals);
    Ok(EntryResult {
        curve,
        q_ext: sums[1] / sums[0],
        q_sca: sums[2] / sums[0],
        q_back: sums[3] / sums[0],
        g: sums[4] / sums[2],
    })
}

struct MieJob {
    p: MieParams,
    model: WaterIndexModel,
    entries: Entries,
    indices: Vec<f64>,
    settings: FilterSettings,
    sun: std::sync::OnceLock<SunDiscOperator>,
}

impl Stage for MieStage {
    fn name(&self) -> &'static str {
        "mie"
    }
    /// 3: `q_back_per_sr` and the Q_back conventions in the header, `n_medium`
    /// (2: axes radius × wavelength × angle, Q and g kept in f64).
    fn algorithm_version(&self) -> u32 {
        3
    }
    fn summary(&self) -> &'static str {
        "Lorenz–Mie phase functions of water drops (radii or size distributions), sun-disc smoothed, bin-integrated"
    }
    fn parameters(&self) -> &'static [ParamDoc] {
        PARAMS
    }
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError> {
        let p: MieParams = parse_params(params)?;
        Ok(Box::new(plan_job(p)?))
    }
}

fn plan_job(p: MieParams) -> Result<MieJob, PlanError> {
    checks::increasing("wavelengths_nm", &p.wavelengths_nm, true)?;
    let (model, indices) = checks::water_indices(
        &p.water_index_model,
        Some(p.temperature_c),
        "wavelengths_nm",
        &p.wavelengths_nm,
    )?;
    let entries = match (&p.radii_um, &p.distributions) {
        (Some(r), None) => {
            checks::increasing("radii_um", r, true)?;
            Entries::Radii(r.clone())
        }
        (None, Some(d)) => {
            if d.is_empty() {
                return Err(PlanError::invalid("distributions", "must not be empty"));
            }
            for (i, dist) in d.iter().enumerate() {
                dist.validate()
                    .map_err(|m| PlanError::invalid(&format!("distributions[{i}]"), m))?;
            }
            Entries::Distributions(d.clone())
        }
        _ => {
            return Err(PlanError::invalid(
                "radii_um",
                "give exactly one of `radii_um` and `distributions`",
            ));
        }
    };
    let output_intervals = checks::angle_step_intervals("angle_step_deg", p.angle_step_deg)?;
    if !(0.0..=5.0).contains(&p.sun_diameter_deg) {
        return Err(PlanError::invalid(
            "sun_diameter_deg",
            "must be within 0–5 deg",
        ));
    }
    if !(0.0..=10.0).contains(&p.gaussian_sigma_deg) {
        return Err(PlanError::invalid(
            "gaussian_sigma_deg",
            "must be within 0–10 deg",
        ));
    }
    if !(4..=512).contains(&p.radius_points) {
        return Err(PlanError::invalid("radius_points", "must be within 4–512"));
    }
    if !(1.0..=3.0).contains(&p.n_medium) {
        return Err(PlanError::invalid("n_medium", "must be within 1–3"));
    }
    // every (wavelength, radius) must be inside the validated Mie domain
    for e in 0..entries.len() {
        let (lo, hi) = entries.distribution(e).support_um();
        for (l, n) in p.wavelengths_nm.iter().zip(&indices) {
            for r in [lo, hi] {
                let x = size_parameter(r, *l / p.n_medium);
                let m = Complex64::new(*n / p.n_medium, 0.0);
                crate::mie::check_domain(x, m).map_err(|err| {
                    PlanError::invalid(
                        if p.radii_um.is_some() {
                            "radii_um"
                        } else {
                            "distributions"
                        },
                        format!("radius {r} µm at {l} nm: {err}"),
                    )
                })?;
            }
        }
    }
    let settings = FilterSettings {
        output_intervals,
        sun_diameter_deg: p.sun_diameter_deg,
        gaussian_sigma_deg: p.gaussian_sigma_deg,
        radius_points: p.radius_points,
    };
    Ok(MieJob {
        p,
        model,
        entries,
        indices,
        settings,
        sun: std::sync::OnceLock::new(),
    })
}

impl MieJob {
    fn entry_axis(&self) -> Axis {
        match &self.entries {
            Entries::Radii(r) => Axis::values("radius", "um", r.clone()),
            Entries::Distributions(d) => Axis::values(
                "distribution",
                "1",
                (0..d.len()).map(|i| i as f64).collect(),
            ),
        }
    }
}

impl Job for MieJob {
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        let mut out = Vec::new();
        for e in 0..self.entries.len() {
            let d = self.entries.distribution(e);
            for (l, n) in self.p.wavelengths_nm.iter().zip(&self.indices) {
                out.push(TaskSpec {
                    label: format!("λ={l} nm {}", serde_json::to_string(&d).unwrap_or_default()),
                    params: serde_json::json!({ "wavelength_nm": l, "n": n, "entry": d }),
                });
            }
        }
        out
    }
    fn run_task(&self, index: usize) -> anyhow::Result<Vec<f32>> {
        let n_w = self.p.wavelengths_nm.len();
        let (e, w) = (index / n_w, index % n_w);
        let m = Complex64::new(self.indices[w] / self.p.n_medium, 0.0);
        let sun = self.sun.get_or_init(|| self.settings.sun_operator());
        let r = compute_entry(
            &self.entries.distribution(e),
            self.p.wavelengths_nm[w] / self.p.n_medium,
            m,
            &self.settings,
            sun,
        )?;
        let (phase, dolp) = (r.curve.phase(), r.curve.dolp());
        let mut out = Vec::with_capacity(phase.len() * 4 + TAIL);
        for j in 0..phase.len() {
            out.extend([
                phase[j] as f32,
                r.curve.i_perp[j] as f32,
                r.curve.i_par[j] as f32,
                dolp[j] as f32,
            ]);
        }
        for q in [r.q_ext, r.q_sca, r.q_back, r.g] {
            out.extend(split_f64(q));
        }
        Ok(out)
    }
    fn assemble(&self, chunks: Vec<Vec<f32>>) -> anyhow::Result<TableContent> {
        let n_w = self.p.wavelengths_nm.len();
        let n_a = self.settings.output_intervals + 1;
        let per = n_a * CHANNELS.len();
        anyhow::ensure!(
            chunks.len() == n_w * self.entries.len(),
            "wrong number of chunks"
        );
        let mut data = Vec::with_capacity(chunks.len() * per);
        let mut scalars: [Vec<Vec<f64>>; 4] = Default::default();
        for (i, c) in chunks.iter().enumerate() {
            anyhow::ensure!(
                c.len() == per + TAIL,
                "chunk {i} has {} values, expected {}",
                c.len(),
                per + TAIL
            );
            data.extend_from_slice(&c[..per]);
            if i % n_w == 0 {
                scalars.iter_mut().for_each(|s| s.push(Vec::new()));
            }
            for (k, s) in scalars.iter_mut().enumerate() {
                let v = join_f64(c[per + 2 * k], c[per + 2 * k + 1]);
                s.last_mut().expect("row").push(v);
            }
        }
        let mut a = serde_json::Map::new();
        let s = |v: &str| serde_json::Value::from(v);
        a.extend(phase_contract::attributes(
            "integral over 4pi sr equals 1",
            &self.model,
            self.p.sun_diameter_deg,
        ));
        a.insert("refractive_index_real".into(), self.indices.clone().into());
        a.insert(
            "sun_disc_model".into(),
            s("uniform disc (no limb darkening), exact 2-D average on the sphere"),
        );
        a.insert(
            "gaussian_sigma_deg".into(),
            self.p.gaussian_sigma_deg.into(),
        );
        a.insert("angular_resampling".into(), s("each value is the solid-angle average over its bin [theta - step/2, theta + step/2] (clipped at 0 and 180 deg) of the single-sphere curve, computed as cell averages with 6 Gauss points per cell of at most 180/n_stop deg; no point sampling"));
        a.insert(
            "validated_domain".into(),
            s(crate::mie::VALIDATED_DOMAIN_TEXT),
        );
        a.insert("n_medium".into(), self.p.n_medium.into());
        a.insert("medium".into(), s("relative index m = n_water / n_medium; size parameter x = 2 pi r n_medium / wavelength (wavelength axis in vacuum)"));
        a.insert("conventions".into(), s("Bohren & Huffman: exp(-i omega t), m = n + ik; i_perp = |S1|^2, i_par = |S2|^2 over (pi x^2 Q_sca); phase = (i_perp + i_par)/2; dolp = (i_perp - i_par)/(i_perp + i_par)"));
        a.insert("size_distribution_weighting".into(), s("normalised phase functions mixed with weights n(r) dr * C_sca(r); Gauss-Legendre in ln r"));
        if let Entries::Distributions(d) = &self.entries {
            a.insert("distributions".into(), serde_json::to_value(d)?);
        }
        let per_sr: Vec<Vec<f64>> = scalars[2]
            .iter()
            .map(|row| {
                row.iter()
                    .map(|q| q / (4.0 * std::f64::consts::PI))
                    .collect()
            })
            .collect();
        let names = ["q_ext", "q_sca", "q_back", "g"];
        for (k, v) in scalars.into_iter().enumerate() {
            a.insert(names[k].into(), serde_json::to_value(v)?);
        }
        a.insert("q_back_per_sr".into(), serde_json::to_value(per_sr)?);
        a.insert(
            "q_back_convention".into(),
            s(crate::mie::Q_BACK_CONVENTIONS),
        );
        a.insert("scalar_layout".into(), s("q_ext, q_sca, q_back, q_back_per_sr, g: [entry][wavelength] (f64); ensemble averages <C>/<pi r^2>, g weighted by C_sca"));
        Ok(TableContent {
            schema: Schema::new("mie-phase", 1),
            description: "Lorenz-Mie phase functions of water drops per wavelength".into(),
            axes: vec![
                self.entry_axis(),
                Axis::values("wavelength", "nm", self.p.wavelengths_nm.clone()),
                Axis::uniform("scattering_angle", "deg", 0.0, self.p.angle_step_deg, n_a),
            ],
            channels: phase_contract::channels("over pi x^2 Q_sca"),
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(toml_lines: &str) -> Result<Box<dyn Job>, PlanError> {
        crate::stages::plan_from_lines(&MieStage, toml_lines)
    }

    #[test]
    fn rejects_bad_params() {
        assert!(plan("radii_um = [10.0]\nangle_step_deg = 0.07").is_err());
        assert!(plan("radii_um = [10.0, 5.0]").is_err());
        assert!(plan("radii_um = [1e5]\nwavelengths_nm = [380.0]").is_err());
        assert!(plan("wavelengths_nm = [550.0]").is_err());
        assert!(plan("radii_um = [10.0]\nunknown = 1").is_err());
        assert!(plan("radii_um = [10.0]\nwater_index_model = \"sadeghi-table-3.2\"\nwavelengths_nm = [750.0]").is_err());
    }

    /// A small job end to end: table shape, contract attributes, and ∫ p dΩ = 1 over the
    /// output bins after sun disc and bin integration.
    #[test]
    fn small_job_is_normalised() {
        let job =
            plan("radii_um = [2.0, 20.0]\nwavelengths_nm = [450.0, 650.0]\nangle_step_deg = 0.5")
                .unwrap();
        let chunks: Vec<Vec<f32>> = (0..job.tasks().len())
            .map(|i| job.run_task(i).unwrap())
            .collect();
        let t = job.assemble(chunks).unwrap();
        assert_eq!(t.data.len(), t.expected_len());
        assert_eq!(t.axes[0].name, "radius");
        assert_eq!(t.axes[1].name, "wavelength");
        assert_eq!(t.axes[2].name, "scattering_angle");
        // Header Q_sca [entry][wavelength] keeps f64 precision: the 20 µm drop at 650 nm
        // against a direct evaluation.
        let q = t.attributes["q_sca"][1][1].as_f64().unwrap();
        let n = WaterIndexModel::Iapws1997 {
            temperature_c: 20.0,
        }
        .index(650.0)
        .unwrap();
        let direct =
            crate::mie::MieCoefficients::new(size_parameter(20.0, 650.0), Complex64::new(n, 0.0))
                .unwrap()
                .efficiencies()
                .q_sca;
        assert!((q - direct).abs() <= 1e-12 * direct, "{q} vs {direct}");
        assert!((q - q as f32 as f64).abs() > 0.0, "stored as f64, not f32");
        let cells = crate::mie::filters::cell_solid_angles(360);
        for row in t.data.chunks(361 * 4) {
            let e: f64 = row
                .chunks(4)
                .zip(&cells)
                .map(|(c, w)| c[0] as f64 * w)
                .sum();
            assert!((e - 1.0).abs() < 1e-5, "integral {e}");
            // phase = (i_perp + i_par)/2
            assert!(
                row.chunks(4)
                    .all(|c| (c[0] - 0.5 * (c[1] + c[2])).abs() <= 1e-6 * c[0].abs())
            );
        }
    }

    /// `n_medium`: the entry equals the sphere of relative index n/n_medium at the wavelength
    /// in the medium; the header carries both Q_back conventions.
    #[test]
    fn medium_index_and_q_back_conventions() {
        let job = plan(
            "radii_um = [3.0]\nwavelengths_nm = [550.0]\nangle_step_deg = 1.0\nn_medium = 1.333\nsun_diameter_deg = 0",
        )
        .unwrap();
        assert!(job.parameters()["n_medium"].as_f64() == Some(1.333));
        let t = job.assemble(vec![job.run_task(0).unwrap()]).unwrap();
        let n = WaterIndexModel::Iapws1997 {
            temperature_c: 20.0,
        }
        .index(550.0)
        .unwrap();
        let (x, m) = crate::mie::in_medium(3.0, 550.0, Complex64::new(n, 0.0), 1.333);
        let e = crate::mie::MieCoefficients::new(x, m)
            .unwrap()
            .efficiencies();
        let q = t.attributes["q_sca"][0][0].as_f64().unwrap();
        assert!((q - e.q_sca).abs() <= 1e-12 * e.q_sca, "{q} vs {}", e.q_sca);
        let qb = t.attributes["q_back"][0][0].as_f64().unwrap();
        let qb_sr = t.attributes["q_back_per_sr"][0][0].as_f64().unwrap();
        assert!((qb - e.q_back).abs() <= 1e-12 * e.q_back);
        assert!((qb_sr - e.q_back_per_sr()).abs() <= 1e-12 * qb_sr);
        assert!(
            t.attributes["q_back_convention"]
                .as_str()
                .unwrap()
                .contains("radar")
        );
        // vacuum (the default) leaves the content key's parameters unchanged
        let plain = plan("radii_um = [3.0]").unwrap();
        assert!(plain.parameters().get("n_medium").is_none());
        assert!(plan("radii_um = [3.0]\nn_medium = 0.5").is_err());
    }

    /// A size distribution entry: normalised, and its ensemble Q_sca lies between the
    /// single-sphere values at the ends of the support (weights n(r) dr · π r²).
    #[test]
    fn distribution_entry_is_normalised() {
        let job = plan(
            "distributions = [{ kind = \"gamma\", effective_radius_um = 3.0, effective_variance = 0.1 }]\nwavelengths_nm = [550.0]\nangle_step_deg = 0.5\nradius_points = 8",
        )
        .unwrap();
        let chunk = job.run_task(0).unwrap();
        let cells = crate::mie::filters::cell_solid_angles(360);
        let e: f64 = chunk[..361 * 4]
            .chunks(4)
            .zip(&cells)
            .map(|(c, w)| c[0] as f64 * w)
            .sum();
        assert!((e - 1.0).abs() < 1e-5, "integral {e}");
        let q_sca = join_f64(chunk[361 * 4 + 2], chunk[361 * 4 + 3]);
        assert!(q_sca > 1.8 && q_sca < 2.6, "Q_sca {q_sca}");
        let g = join_f64(chunk[361 * 4 + 6], chunk[361 * 4 + 7]);
        assert!(g > 0.7 && g < 0.9, "g {g}");
    }
}
