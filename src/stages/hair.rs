//! Stages `hair-dual` (Dual Scattering averages, schema `hair-dual/1`) and `hair-azimuthal`
//! (azimuthal functions `N_p(θ, φ)`, schema `hair-azimuthal/1`). See `docs/hair.md`.

use crate::hair::artist::{ArtistModel, ArtistNormalisation, ArtistParams};
use crate::hair::diffuse::{DIFFUSE_THETA_H_VARIANCE, DiffuseTerms};
use crate::hair::dual::{DUAL_CHANNELS, HQuadrature};
use crate::hair::elliptic::{
    DEFAULT_ORIENTATION_NODES, orientation_nodes_for_width, validate_axis_ratio,
};
use crate::hair::fiber::{FresnelModel, LOBE_NAMES};
use crate::hair::melanin::{sigma_a_from_absorption_u, sigma_a_from_melanin};
pub use crate::hair::rows::DUAL_TABLE_CHANNELS;
use crate::hair::rows::{AzimuthalSweep, DualSweep, artist_dual_row};
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunks, checks, stage_params,
};
use crate::table::{Axis, Channel, Schema, TableContent};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value, json};

/// Which fibre model feeds the Dual Scattering averages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum HairModel {
    #[default]
    Physical,
    Artist,
}

/// The absorption axis of a table, resolved from the flat manifest keys.
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
    fn from_keys(
        count: Option<usize>,
        sigma_a: Option<Vec<f64>>,
        rgb: Option<[f64; 3]>,
        melanin: Option<[f64; 2]>,
    ) -> Result<Self, PlanError> {
        let given = [
            count.is_some(),
            sigma_a.is_some(),
            rgb.is_some(),
            melanin.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if given != 1 {
            return Err(PlanError::invalid(
                "absorption_count",
                "give exactly one of absorption_count, sigma_a, sigma_a_rgb, melanin",
            ));
        }
        if let Some(n) = count {
            if !(2..=1024).contains(&n) {
                return Err(PlanError::invalid(
                    "absorption_count",
                    "must be within 2–1024",
                ));
            }
            return Ok(AbsorptionAxis::Sweep(n));
        }
        if let Some(v) = sigma_a {
            if v.is_empty() || v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(PlanError::invalid("sigma_a", "needs finite values ≥ 0"));
            }
            if v.windows(2).any(|w| w[1] <= w[0]) {
                return Err(PlanError::invalid("sigma_a", "must be strictly increasing"));
            }
            return Ok(AbsorptionAxis::SigmaA(v));
        }
        if let Some(c) = rgb {
            if c.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(PlanError::invalid("sigma_a_rgb", "needs finite values ≥ 0"));
            }
            return Ok(AbsorptionAxis::Rgb(c));
        }
        let [ce, cp] = melanin.expect("one key is given");
        if !(ce.is_finite() && cp.is_finite() && ce >= 0.0 && cp >= 0.0) {
            return Err(PlanError::invalid(
                "melanin",
                "concentrations must be finite and ≥ 0",
            ));
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

    fn axis(&self) -> Axis {
        match self {
            AbsorptionAxis::Sweep(n) => {
                Axis::uniform("absorption_u", "1", 0.0, 1.0 / (*n - 1) as f64, *n)
            }
            AbsorptionAxis::SigmaA(v) => Axis::values("sigma_a", "1/radius", v.clone()),
            AbsorptionAxis::Rgb(_) => Axis::values("colour_channel", "1", vec![0.0, 1.0, 2.0]),
        }
    }

    fn describe(&self, attributes: &mut Map<String, Value>) {
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

/// Fibre index of refraction, shared by both stages.
const DEFAULT_ETA: f64 = 1.55;
/// Gauss–Legendre nodes per h panel, shared by both stages.
const DEFAULT_QUADRATURE_ORDER: usize = 8;

/// Declares the parameter struct of a hair stage with [`stage_params!`]: the fibre keys both
/// stages read (`eta`, `fresnel`, `quadrature_order`, `absorption_count`, `sigma_a`) followed
/// by the stage's own fields.
macro_rules! hair_params {
    (
        $(#[$sattr:meta])*
        pub struct $name:ident { $($fields:tt)* }
    ) => {
        stage_params! {
            $(#[$sattr])*
            pub struct $name {
                pub eta: f64 = default(DEFAULT_ETA), "float",
                    "fibre index of refraction, 1.1–2.5 (physical fibre)";
                pub fresnel: FresnelModel = default(FresnelModel::ThreeD), "string",
                    "three-d (exact unpolarised at the 3-D incidence angle) or bravais (Marschner two-index)";
                /// Gauss–Legendre nodes per panel of the h integral.
                pub quadrature_order: usize = default(DEFAULT_QUADRATURE_ORDER), "int",
                    "Gauss–Legendre nodes per h panel (2–32)";
                pub absorption_count: Option<usize> = optional("—"), "int",
                    "absorption_u = 1 − exp(−2σ_a) uniform on [0, 1] (LUT mode; give exactly one absorption key)";
                pub sigma_a: Option<Vec<f64>> = optional("—"), "list of float, 1/radius",
                    "explicit absorption values, strictly increasing";
                /// Lambertian surface BRDF k_d of an opaque fibre (FIB-21).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub lambertian_kd: Option<f64> = optional("0 (none)"), "float",
                    "Lambertian-cylinder term: BRDF value k_d of an opaque Lambertian fibre surface, BCSDF (k_d/4)(sin|φ| + (π−|φ|) cos φ), albedo π k_d; 0–1/π (physical fibre)";
                /// Zinke & Weber eq. 52 higher-order diffuse constant (FIB-21).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub higher_order_kd: Option<f64> = optional("0 (none)"), "float",
                    "higher-order diffuse constant k_d of Zinke & Weber eq. 52: BCSDF 2k_d, albedo 2π² k_d; 0–1/(2π²) (physical fibre)";
                /// Minor/major axis ratio of an elliptic fibre (FIB-22).
                #[serde(skip_serializing_if = "Option::is_none")]
                pub axis_ratio: Option<f64> = optional("1 (circular)"), "float",
                    "elliptic cross-section: minor/major semi-axis ratio a (Marschner's \"eccentricity\"), 0.85–1; TRT uses η* = ½(η*₁+η*₂) − ½cos 2ψ (η*₁−η*₂), averaged over the major-axis orientation (physical fibre)";
                $($fields)*
            }
        }
    };
}

/// Checks shared by both stages: the fibre index and the quadrature order.
fn check_fibre(eta: f64, quadrature_order: usize) -> Result<(), PlanError> {
    checks::within("eta", eta, 1.1, 2.5, "")?;
    checks::within("quadrature_order", quadrature_order, 2, 32, "")
}

/// The diffuse terms and the axis ratio from the optional keys, validated (both stages).
fn fibre_features(
    lambertian_kd: Option<f64>,
    higher_order_kd: Option<f64>,
    axis_ratio: Option<f64>,
) -> Result<(DiffuseTerms, f64), PlanError> {
    let diffuse = DiffuseTerms {
        lambertian_kd: lambertian_kd.unwrap_or(0.0),
        higher_order_kd: higher_order_kd.unwrap_or(0.0),
    };
    diffuse
        .validate()
        .map_err(|(k, m)| PlanError::invalid(k, m))?;
    let a = axis_ratio.unwrap_or(1.0);
    validate_axis_ratio(a).map_err(|m| PlanError::invalid("axis_ratio", m))?;
    Ok((diffuse, a))
}

/// Header attributes of the diffuse terms and the elliptic cross-section (only when used, so
/// that the headers of circular fibres without diffuse terms are unchanged).
fn feature_attributes(
    diffuse: &DiffuseTerms,
    axis_ratio: f64,
    orientation_nodes: usize,
    attributes: &mut Map<String, Value>,
) {
    if !diffuse.is_zero() {
        let (ab, af) = diffuse.hemisphere_albedos();
        attributes.insert(
            "diffuse".into(),
            json!({
                "lambertian_kd": diffuse.lambertian_kd,
                "higher_order_kd": diffuse.higher_order_kd,
                "bcsdf": "f_d(φ) = (lambertian_kd/4)(sin|φ| + (π−|φ|) cos φ) + 2·higher_order_kd, per radian, independent of θ_i and θ_o; f_s = Σ_p M_p N_p / cos²θ_d + f_d (docs/decisions.md FIB-21)",
                "albedo": diffuse.albedo(),
                "albedo_backward": ab,
                "albedo_forward": af,
                "forward_average": diffuse.forward_average(),
            }),
        );
    }
    if axis_ratio != 1.0 {
        attributes.insert(
            "elliptic".into(),
            json!({
                "axis_ratio": axis_ratio,
                "model": "Marschner et al. 2003 first order: TRT exit azimuth with η*(ψ) = ½(η*₁+η*₂) − ½cos(2ψ)(η*₁−η*₂), η*₁ = 2(η−1)a² − η + 2, η*₂ = 2(η−1)/a² − η + 2, ψ = φ_h − φ_major; η* replaces η before the Bravais index; Fresnel and chords use η; R, TT, residual circular (docs/decisions.md FIB-22, FIB-23)",
                "orientation": "TRT averaged over the orientation of the major axis (uniform), so the table stays a function of (θ, φ) (docs/decisions.md FIB-24)",
                "orientation_nodes": orientation_nodes,
            }),
        );
    }
}

fn theta_axis_deg(count: usize) -> Vec<f64> {
    (0..count)
        .map(|i| -90.0 + 180.0 * i as f64 / (count - 1) as f64)
        .collect()
}

/// A hair job with one task per inclination θ, each computing one row of values and the
/// row's largest change under quadrature doubling; [`Job`] follows from it.
trait ThetaRows: Send + Sync {
    /// The job's resolved parameters (see [`Job::parameters`]).
    fn params_json(&self) -> Value;
    /// The inclinations θ of the tasks (deg).
    fn theta_deg(&self) -> Vec<f64>;
    /// The row at `theta_rad` and its quadrature-doubling change.
    fn row_with_change(&self, theta_rad: f64) -> (Vec<f64>, f64);
    /// See [`Job::assemble`]; each chunk is a row with its change as its one scalar.
    fn assemble_rows(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError>;
    /// Values per row (per θ) of the table.
    fn row_len(&self) -> usize;
    /// The table's axes and channel count (see [`Job::shape`]).
    fn planned_shape(&self) -> crate::stages::PlannedShape;
    /// See [`Job::estimated_stored_fraction`].
    fn stored_fraction(&self) -> f64;
}

impl<T: ThetaRows> Job for T {
    fn parameters(&self) -> Value {
        self.params_json()
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.theta_deg()
            .iter()
            .map(|t| TaskSpec {
                label: format!("θ={t:.3}°"),
                params: json!({ "theta_deg": t }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (row, change) = self.row_with_change(self.theta_deg()[index].to_radians());
        Ok(Chunk::new(
            row.iter().map(|&v| v as f32).collect(),
            vec![change],
        ))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        self.assemble_rows(chunks)
    }
    fn shape(&self) -> crate::stages::PlannedShape {
        self.planned_shape()
    }
    /// A set-up, then every value of every row computed twice (the quadrature-doubling
    /// check), `cost::HAIR_CPU_S`.
    fn estimated_cpu_seconds(&self) -> f64 {
        let [table, per_value] = crate::stages::cost::HAIR_CPU_S;
        table + per_value * (self.theta_deg().len() * self.row_len()) as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        self.stored_fraction()
    }
}

/// Chunks of [`ThetaRows`] jobs (each `blocks` blocks of `block` values, the doubling change as
/// the scalar) with θ moved inside each block: the table data (block-major, then θ) and the
/// largest change.
fn theta_inside_blocks(
    chunks: &[Chunk],
    nt: usize,
    blocks: usize,
    block: usize,
) -> Result<(Vec<f32>, f64), JobError> {
    check_chunks(chunks, nt, blocks * block, 1)?;
    let mut data = vec![0f32; blocks * nt * block];
    let mut change: f64 = 0.0;
    for (it, chunk) in chunks.iter().enumerate() {
        change = change.max(chunk.scalars[0]);
        for b in 0..blocks {
            let dst = (b * nt + it) * block;
            data[dst..dst + block].copy_from_slice(&chunk.values[b * block..(b + 1) * block]);
        }
    }
    Ok((data, change))
}

// ---------------------------------------------------------------------------------------------
// hair-dual

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
pub struct HairDualJob {
    pub params: HairDualParams,
    absorption: AbsorptionAxis,
    artist: Option<ArtistModel>,
    diffuse: DiffuseTerms,
    axis_ratio: f64,
}

impl HairDualJob {
    /// Validate and plan.
    pub fn new(p: HairDualParams) -> Result<Self, PlanError> {
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
        let (diffuse, axis_ratio) =
            fibre_features(p.lambertian_kd, p.higher_order_kd, p.axis_ratio)?;
        let (absorption, artist) = match p.model {
            HairModel::Physical => {
                if p.artist.is_some() {
                    return Err(PlanError::invalid(
                        "artist",
                        "only used with model = \"artist\"",
                    ));
                }
                (
                    AbsorptionAxis::from_keys(
                        p.absorption_count,
                        p.sigma_a.clone(),
                        p.sigma_a_rgb,
                        p.melanin,
                    )?,
                    None,
                )
            }
            HairModel::Artist => {
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
                (AbsorptionAxis::Rgb([0.0; 3]), Some(ArtistModel::new(a)))
            }
        };
        Ok(HairDualJob {
            params: p,
            absorption,
            artist,
            diffuse,
            axis_ratio,
        })
    }

    fn quadrature(&self) -> HQuadrature {
        HQuadrature {
            order: self.params.quadrature_order,
            ..HQuadrature::default()
        }
    }

    /// The physical fibre swept over this table's roughness and absorption.
    fn sweep(&self) -> DualSweep {
        let p = &self.params;
        DualSweep {
            eta: p.eta,
            fresnel: p.fresnel,
            cuticle_tilt_deg: p.cuticle_tilt_deg,
            roughness_deg: p.roughness_deg.clone(),
            azimuthal_width_ratio: p.azimuthal_width_ratio,
            diffuse: self.diffuse,
            axis_ratio: self.axis_ratio,
            sigma_a: self.absorption.sigma_values(),
            d_b: p.d_b,
            clamp: p.clamp,
        }
    }

    /// One θ row: `[roughness][absorption][16]` for the given quadrature.
    fn compute_row(&self, theta_rad: f64, quad: &HQuadrature) -> Vec<f64> {
        match &self.artist {
            Some(m) => artist_dual_row(m, theta_rad, self.params.d_b, self.params.clamp),
            None => self.sweep().row(theta_rad, quad),
        }
    }
    fn n_roughness(&self) -> usize {
        if self.artist.is_some() {
            1
        } else {
            self.params.roughness_deg.len()
        }
    }
    fn n_absorption(&self) -> usize {
        match &self.absorption {
            AbsorptionAxis::Sweep(n) => *n,
            AbsorptionAxis::SigmaA(v) => v.len(),
            AbsorptionAxis::Rgb(_) => 3,
        }
    }
}

impl ThetaRows for HairDualJob {
    fn row_len(&self) -> usize {
        self.n_roughness() * self.n_absorption() * DUAL_TABLE_CHANNELS
    }
    fn planned_shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.dual_axes(), dual_channels().len())
    }
    fn stored_fraction(&self) -> f64 {
        if self.artist.is_some() {
            crate::stages::cost::STORED_FRACTION_HAIR_DUAL_ARTIST
        } else {
            crate::stages::cost::STORED_FRACTION_HAIR_DUAL
        }
    }
    fn params_json(&self) -> Value {
        serde_json::to_value(&self.params).expect("params serialise")
    }
    fn theta_deg(&self) -> Vec<f64> {
        theta_axis_deg(self.params.theta_count)
    }
    /// Row: `[roughness][absorption][16 channels]` at this θ; change: the largest change of any
    /// of the 16 channels when the h-panels are halved (quadrature doubling).
    fn row_with_change(&self, theta: f64) -> (Vec<f64>, f64) {
        let q = self.quadrature();
        let row = self.compute_row(theta, &q);
        let check = if self.artist.is_some() {
            0.0
        } else {
            let fine = self.compute_row(theta, &q.doubled());
            row.iter()
                .zip(&fine)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        };
        (row, check)
    }
    fn assemble_rows(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let nt = self.params.theta_count;
        let (data, doubling) = theta_inside_blocks(
            &chunks,
            nt,
            self.n_roughness() * self.n_absorption(),
            DUAL_TABLE_CHANNELS,
        )?;
        let mut attributes = self.common_attributes();
        match &self.artist {
            Some(m) => artist_attributes(m, &mut attributes)?,
            None => {
                self.physical_attributes(doubling, &mut attributes);
                feature_attributes(
                    &self.diffuse,
                    self.axis_ratio,
                    DEFAULT_ORIENTATION_NODES,
                    &mut attributes,
                );
                if !self.diffuse.is_zero() {
                    attributes.insert("diffuse_in_averages".into(), json!(format!(
                        "ā_f, ā_b include the diffuse albedos (the E_p channels do not); ᾱ, β̄² include the diffuse term with its θ_h moments θ_i/2 and (π² − 6)/48 = {DIFFUSE_THETA_H_VARIANCE:.6} rad²; N^G are the lobes' only, add diffuse.forward_average in f_s^scatter (docs/decisions.md DS-32)"
                    )));
                }
            }
        }
        self.absorption.describe(&mut attributes);
        Ok(TableContent {
            schema: Schema::new("hair-dual", 1),
            description: "Dual Scattering averages of a hair fibre per light inclination".into(),
            axes: self.dual_axes(),
            channels: dual_channels(),
            attributes,
            data,
        })
    }
}

impl HairDualJob {
    /// Axes: roughness (physical model only) × absorption × θ_i.
    fn dual_axes(&self) -> Vec<Axis> {
        let nt = self.params.theta_count;
        let mut axes = Vec::new();
        if self.artist.is_none() {
            axes.push(Axis::values(
                "roughness",
                "deg",
                self.params.roughness_deg.clone(),
            ));
        }
        axes.push(self.absorption.axis());
        axes.push(Axis::uniform(
            "theta",
            "deg",
            -90.0,
            180.0 / (nt - 1) as f64,
            nt,
        ));
        axes
    }

    /// Attributes of both models: conventions of θ, the tangent, the azimuth and the measures.
    fn common_attributes(&self) -> Map<String, Value> {
        let mut attributes = Map::new();
        attributes.insert(
            "model".into(),
            json!(match self.params.model {
                HairModel::Physical => "physical",
                HairModel::Artist => "artist",
            }),
        );
        attributes.insert("theta".into(), "light inclination θ_i from the normal plane (docs/decisions.md DS-1); +90° = along the tangent toward the tip; look the tables up with θ_i".into());
        attributes.insert("tangent".into(), "fibre tangent points root → tip; α > 0 shifts toward the tip; R is shifted toward the root (α_R < 0) (docs/decisions.md DS-23)".into());
        attributes.insert("azimuth".into(), "relative azimuth φ = φ_o − φ_i; φ = 0 back toward the light; forward half-space |φ| ≥ π/2, backward |φ| < π/2 (docs/decisions.md DS-21)".into());
        attributes.insert("energy_measure".into(), "a_H(θ_i) = ∫_{−π/2}^{π/2} ∫_{H} f_s(θ_i, θ_o, φ) cos²θ_o dφ dθ_o (power per unit curve irradiance, Zinke & Weber eq. 33/36), relative azimuth, no extra incident-azimuth average (docs/decisions.md DS-3)".into());
        attributes.insert("averages".into(), "ᾱ, β̄² are energy-weighted means of the lobe α_p and β_p² (variances, docs/decisions.md DS-7); ā is clamped before the closed forms".into());
        attributes.insert("a_clamp".into(), json!(self.params.clamp));
        attributes.insert("d_b".into(), json!(self.params.d_b));
        attributes.insert("closed_forms".into(), "ZYWK08 originals: (1 − ā_f²)³ in Ā_b, sqrt(2β̄_f² + 3β̄_b²) in σ̄_b, widths in its denominator kept verbatim, σ̄_b stored squared (docs/decisions.md DS-5, DS-6)".into());
        attributes.insert(
            "angles".into(),
            "radians inside the data; axis coordinates in degrees".into(),
        );
        attributes
    }

    /// Attributes of the physical model: fibre, lobes, quadrature and its doubling check.
    fn physical_attributes(&self, doubling: f64, attributes: &mut Map<String, Value>) {
        attributes.insert("eta".into(), json!(self.params.eta));
        attributes.insert("fresnel".into(), json!(self.params.fresnel.name()));
        attributes.insert(
            "cuticle_tilt_deg".into(),
            json!(self.params.cuticle_tilt_deg),
        );
        attributes.insert("lobes".into(), "α_R = −α, α_TT = α/2, α_TRT = 3α/2, residual 0; β_TT = β_R/2, β_TRT = β_residual = 2β_R (Marschner 2003 Table 1)".into());
        attributes.insert(
            "azimuthal_width_ratio".into(),
            json!(self.params.azimuthal_width_ratio),
        );
        attributes.insert("fiber_model".into(), "smooth dielectric cylinder integrated over h (Zinke & Weber 2007 far field), Bravais geometry, internal chord 2cosγ_t/cosθ_t, orders p ≥ 3 lumped in a residual lobe uniform in φ, wrapped-normal azimuthal roughness w_φ = ratio·β_R; N_p evaluated at the incident inclination and longitudinal lobes normalised per lobe under the energy measure, so a lossless fibre conserves energy exactly".into());
        attributes.insert("quadrature".into(), json!({
                "rule": "composite Gauss–Legendre in γ_i = asin h, panels ≤ min(0.05 rad, w_φ/2), split where any exit azimuth crosses |φ| = π/2; closed-form (erf) azimuthal windows",
                "order": self.params.quadrature_order,
                "doubling_max_abs_change": doubling,
            }));
    }
}

/// Attributes of the artist-friendly model: its parameters and normalisation.
fn artist_attributes(m: &ArtistModel, attributes: &mut Map<String, Value>) -> Result<(), JobError> {
    attributes.insert("artist_params".into(), serde_json::to_value(&m.params)?);
    attributes.insert("normalization_k".into(), json!(m.k));
    attributes.insert("normalization".into(), match m.params.normalisation {
            ArtistNormalisation::PerInclination => "per-inclination: eq. 4.17 with one scalar per θ_i, K(θ_i) = max over RGB of the energy of f'_s at θ_i under the energy measure, glints included (G_angle averaged uniformly over its range), so ā_f + ā_b ≤ 1 for every θ_i and channel, = 1 for the brightest; normalization_k is K(0) (docs/decisions.md DS-4, DS-14)",
            ArtistNormalisation::NormalIncidence => "normal-incidence: eq. 4.17 with one scalar K = normalization_k = max over RGB of the energy of f'_s at θ_i = 0 under the energy measure, glints included (G_angle averaged uniformly over its range); ā_f + ā_b exceeds 1 toward grazing light (docs/decisions.md DS-4, DS-14)",
        }.into());
    attributes.insert(
        "longitudinal".into(),
        "unit-height g'(θ_h − α_X, β_X²)/cos²θ_d, cos²θ_d ≥ 1e-3 (docs/decisions.md DS-9, DS-18)"
            .into(),
    );
    Ok(())
}

/// The 16 channels of a `hair-dual` table: the twelve Dual Scattering averages, then the
/// energy of each lobe.
fn dual_channels() -> Vec<Channel> {
    let meanings = [
        (
            "1",
            "ā_f: fraction of the light arriving at inclination θ scattered into |φ| ≥ π/2 (forward), clamped to ≤ clamp",
        ),
        (
            "1",
            "ā_b: fraction scattered into |φ| < π/2 (backward), clamped to ≤ clamp",
        ),
        (
            "rad",
            "ᾱ_f: energy-weighted mean longitudinal shift of the forward lobes (θ_h convention)",
        ),
        (
            "rad",
            "ᾱ_b: energy-weighted mean longitudinal shift of the backward lobes",
        ),
        (
            "rad^2",
            "β̄_f²: energy-weighted mean longitudinal variance β_p² of the forward lobes",
        ),
        (
            "rad^2",
            "β̄_b²: energy-weighted mean longitudinal variance of the backward lobes",
        ),
        (
            "1",
            "Ā_b = ā_b ā_f²/(1−ā_f²) + ā_b³ ā_f²/(1−ā_f²)³ (ZYWK08 eq. 14)",
        ),
        ("rad", "Δ̄_b (ZYWK08 eq. 16 / thesis 4.28)"),
        (
            "rad^2",
            "σ̄_b²: square of ZYWK08 eq. 17 with sqrt(2β̄_f² + 3β̄_b²) and d_b",
        ),
        (
            "1/rad",
            "N^G_R = (2/π)∫_{π/2}^{π} N_R dφ (artist: × C_R I_R / K)",
        ),
        (
            "1/rad",
            "N^G_TT = (2/π)∫_{π/2}^{π} N_TT dφ (artist: × C_TT I_TT / K)",
        ),
        (
            "1/rad",
            "N^G_TRT = (2/π)∫_{π/2}^{π} N_TRT dφ (artist: × C_TRT I_TRT / K)",
        ),
        ("1", "energy of lobe R, ∫∫ f_R cos²θ_o dθ_o dφ (unclamped)"),
        ("1", "energy of lobe TT"),
        ("1", "energy of lobe TRT"),
        (
            "1",
            "energy of the residual p ≥ 3 lobe (physical; 0 for the artist model)",
        ),
    ];
    let names = DUAL_CHANNELS
        .iter()
        .copied()
        .chain(["E_R", "E_TT", "E_TRT", "E_residual"]);
    names
        .zip(meanings)
        .map(|(name, (unit, meaning))| Channel::new(name, unit, meaning))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// hair-azimuthal

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

/// Channels stored by `hair-azimuthal`: the lobes and their sum.
const AZ_CHANNELS: usize = 5;

/// A planned `hair-azimuthal` table.
pub struct HairAzimuthalJob {
    pub params: HairAzimuthalParams,
    absorption: AbsorptionAxis,
    diffuse: DiffuseTerms,
    axis_ratio: f64,
}

impl HairAzimuthalJob {
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
            AbsorptionAxis::from_keys(p.absorption_count, p.sigma_a.clone(), None, None)?;
        let (diffuse, axis_ratio) =
            fibre_features(p.lambertian_kd, p.higher_order_kd, p.axis_ratio)?;
        Ok(HairAzimuthalJob {
            params: p,
            absorption,
            diffuse,
            axis_ratio,
        })
    }

    /// Orientation nodes of the elliptic TRT average for this table's azimuthal width.
    fn orientation_nodes(&self) -> usize {
        orientation_nodes_for_width(
            self.params.eta,
            self.axis_ratio,
            self.params.azimuthal_width_deg.to_radians(),
        )
    }

    /// Channels per (absorption, φ): R, TT, TRT, residual, sum, and `diffuse` when a diffuse term
    /// is set.
    /// Axes: absorption × θ × φ.
    fn azimuthal_axes(&self) -> Vec<Axis> {
        let (nt, np) = (self.params.theta_count, self.params.phi_count);
        vec![
            self.absorption.axis(),
            Axis::uniform("theta", "deg", 0.0, 90.0 / (nt - 1) as f64, nt),
            Axis::uniform("phi", "deg", 0.0, 180.0 / (np - 1) as f64, np),
        ]
    }

    fn channel_count(&self) -> usize {
        if self.diffuse.is_zero() {
            AZ_CHANNELS
        } else {
            AZ_CHANNELS + 1
        }
    }
    fn row(&self, theta_rad: f64, panel_scale: f64) -> Vec<f64> {
        AzimuthalSweep {
            eta: self.params.eta,
            fresnel: self.params.fresnel,
            width_rad: self.params.azimuthal_width_deg.to_radians(),
            quadrature_order: self.params.quadrature_order,
            diffuse: self.diffuse,
            axis_ratio: self.axis_ratio,
            orientation_nodes: self.orientation_nodes(),
            sigma_a: self.absorption.sigma_values(),
            phi_count: self.params.phi_count,
        }
        .row(theta_rad, panel_scale)
    }
}

impl ThetaRows for HairAzimuthalJob {
    fn row_len(&self) -> usize {
        self.absorption.sigma_values().len() * self.params.phi_count * self.channel_count()
    }
    fn planned_shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.azimuthal_axes(), self.channel_count())
    }
    fn stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_HAIR_AZIMUTHAL
    }
    fn params_json(&self) -> Value {
        serde_json::to_value(&self.params).expect("params serialise")
    }
    fn theta_deg(&self) -> Vec<f64> {
        (0..self.params.theta_count)
            .map(|i| 90.0 * i as f64 / (self.params.theta_count - 1) as f64)
            .collect()
    }
    /// Row: `[absorption][φ][5]` at this θ; change: the largest relative change (to the peak of
    /// each lobe) under quadrature doubling.
    fn row_with_change(&self, theta: f64) -> (Vec<f64>, f64) {
        let row = self.row(theta, 1.0);
        let fine = self.row(theta, 2.0);
        let peak = row.iter().cloned().fold(0.0, f64::max).max(1e-30);
        let change = row
            .iter()
            .zip(&fine)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / peak;
        (row, change)
    }
    fn assemble_rows(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let nt = self.params.theta_count;
        let np = self.params.phi_count;
        let na = self.absorption.sigma_values().len();
        let (data, change) = theta_inside_blocks(&chunks, nt, na, np * self.channel_count())?;
        let mut channels: Vec<Channel> = LOBE_NAMES
            .iter()
            .map(|n| Channel::new(n, "1/rad", "azimuthal scattering function N_p(θ, φ); ∫_{−π}^{π} N_p dφ = ½∫ a_p dh (lobe energy)"))
            .collect();
        channels[3].meaning = "orders p ≥ 3 lumped, uniform in φ (energy / 2π)".into();
        channels.push(Channel::new(
            "sum",
            "1/rad",
            "N_R + N_TT + N_TRT + residual; ∫_{−π}^{π} sum dφ = 1 for σ_a = 0",
        ));
        if !self.diffuse.is_zero() {
            channels.push(Channel::new(
                "diffuse",
                "1/rad",
                "diffuse BCSDF f_d(φ) (lambertian_kd and higher_order_kd terms), added to Σ_p M_p N_p / cos²θ_d without a longitudinal lobe; not in sum; ∫_{−π}^{π} diffuse dφ = 2 lambertian_kd + 4π higher_order_kd (docs/decisions.md FIB-21)",
            ));
        }
        let mut attributes = Map::new();
        attributes.insert("eta".into(), json!(self.params.eta));
        attributes.insert("fresnel".into(), json!(self.params.fresnel.name()));
        attributes.insert(
            "azimuthal_width_deg".into(),
            json!(self.params.azimuthal_width_deg),
        );
        attributes.insert("theta".into(), "inclination used for the Bravais indices, Fresnel and path length; N_p is even in θ. Marschner/Zinke look it up with θ_d = (θ_o − θ_i)/2; the energy-conserving DS model of scatterbake with θ_i (identical at the specular cone)".into());
        attributes.insert("azimuth".into(), "relative azimuth φ = φ_o − φ_i in [0°, 180°]; N_p(−φ) = N_p(φ); φ = 0 back toward the light".into());
        attributes.insert(
            "exit_azimuth".into(),
            "Φ_p(h) = 2γ_i − 2pγ_t + pπ, γ_i = asin h, sin γ_t = h/n' (Zinke & Weber eq. 17–19)"
                .into(),
        );
        attributes.insert("roughness".into(), "each lobe convolved with a wrapped normal of std azimuthal_width_deg (exactly normalised on the circle)".into());
        feature_attributes(
            &self.diffuse,
            self.axis_ratio,
            self.orientation_nodes(),
            &mut attributes,
        );
        attributes.insert(
            "quadrature".into(),
            json!({
                "rule": "composite Gauss–Legendre in γ_i = asin h, panels ≤ min(0.05 rad, w_φ/2)",
                "order": self.params.quadrature_order,
                "doubling_max_rel_change": change,
            }),
        );
        self.absorption.describe(&mut attributes);
        Ok(TableContent {
            schema: Schema::new("hair-azimuthal", 1),
            description: "azimuthal scattering functions of a rough dielectric hair fibre".into(),
            axes: self.azimuthal_axes(),
            channels,
            attributes,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::table_from_lines as build;

    #[test]
    fn dual_sweep_is_consistent_and_lossless_column_conserves_energy() {
        let t = build(
            &HairDualStage,
            "roughness_deg = [3.0, 10.0]\nabsorption_count = 5\ntheta_count = 9",
        );
        assert_eq!(t.axes.len(), 3);
        // absorption_u = 0 (lossless): a_f + a_b = Σ E = 1 for every θ and roughness.
        for ir in 0..2 {
            for it in 0..9 {
                let base = ((ir * 5) * 9 + it) * DUAL_TABLE_CHANNELS;
                let v = &t.data[base..base + DUAL_TABLE_CHANNELS];
                let e: f32 = v[12..16].iter().sum();
                assert!(
                    (v[0] + v[1] - 1.0).abs() < 1e-5 && (e - 1.0).abs() < 1e-5,
                    "{v:?}"
                );
            }
        }
        // u = 1 (opaque): only R remains.
        let base = ((4) * 9 + 4) * DUAL_TABLE_CHANNELS;
        assert_eq!(t.data[base + 13], 0.0);
        let dbl = t.attributes["quadrature"]["doubling_max_abs_change"]
            .as_f64()
            .unwrap();
        assert!(dbl < 1e-5, "{dbl}");
    }

    #[test]
    fn dual_rejects_bad_parameters() {
        crate::stages::assert_planning(
            &HairDualStage,
            &[
                "absorption_count = 5\nsigma_a = [0.1]",
                "absorption_count = 5\nroughness_deg = [10.0, 5.0]",
                "absorption_count = 5\neta = 0.9",
                "absorption_count = 5\nbogus = 1",
                "model = \"artist\"\nmelanin = [1.0, 0.0]",
            ],
            &["absorption_count = 5"],
        );
    }

    #[test]
    fn dual_artist_and_melanin_tables_build() {
        let t = build(&HairDualStage, "model = \"artist\"\ntheta_count = 5");
        assert_eq!(t.axes[0].name, "colour_channel");
        let t = build(&HairDualStage, "melanin = [0.3, 0.0]\ntheta_count = 5");
        assert_eq!(t.axes[1].name, "colour_channel");
        assert_eq!(t.attributes["sigma_a_rgb"][2].as_f64().unwrap(), 0.3 * 1.37);
    }

    /// Physically invalid diffuse terms and axis ratios are refused at plan time with an error
    /// naming the key; the artist model refuses the physical-fibre keys.
    #[test]
    fn fibre_feature_keys_are_checked_at_plan_time() {
        use crate::stages::plan_from_lines;
        for (stage, base) in [
            (
                &HairDualStage as &dyn crate::stages::Stage,
                "absorption_count = 3\ntheta_count = 3",
            ),
            (
                &HairAzimuthalStage,
                "sigma_a = [0.1]\ntheta_count = 2\nphi_count = 5",
            ),
        ] {
            for (extra, key) in [
                ("lambertian_kd = 0.4", "lambertian_kd"),
                ("lambertian_kd = -0.01", "lambertian_kd"),
                ("higher_order_kd = 0.06", "higher_order_kd"),
                ("higher_order_kd = nan", "higher_order_kd"),
                (
                    "lambertian_kd = 0.2\nhigher_order_kd = 0.03",
                    "higher_order_kd",
                ),
                ("axis_ratio = 0.8", "axis_ratio"),
                ("axis_ratio = 1.2", "axis_ratio"),
            ] {
                let err = match plan_from_lines(stage, &format!("{base}\n{extra}")) {
                    Ok(_) => panic!("{extra} accepted"),
                    Err(e) => e.to_string(),
                };
                assert!(err.contains(&format!("`{key}`")), "{extra}: {err}");
            }
            for ok in [
                "lambertian_kd = 0.3",
                "higher_order_kd = 0.05",
                "axis_ratio = 0.85",
                "axis_ratio = 1.0",
            ] {
                assert!(
                    plan_from_lines(stage, &format!("{base}\n{ok}")).is_ok(),
                    "{ok}"
                );
            }
        }
        for key in [
            "lambertian_kd = 0.1",
            "higher_order_kd = 0.01",
            "axis_ratio = 0.9",
        ] {
            let err = plan_from_lines(&HairDualStage, &format!("model = \"artist\"\n{key}"))
                .err()
                .expect("refused")
                .to_string();
            assert!(err.contains(key.split(' ').next().unwrap()), "{err}");
        }
    }

    /// Without the new keys the parameters recorded in the header are those of earlier
    /// versions (no new entries), and a = 1 written explicitly gives the same data.
    #[test]
    fn defaults_leave_tables_unchanged() {
        let job =
            HairDualJob::new(toml::from_str("absorption_count = 3\ntheta_count = 5").unwrap())
                .unwrap();
        let p = crate::stages::Job::parameters(&job);
        for key in ["lambertian_kd", "higher_order_kd", "axis_ratio"] {
            assert!(p.get(key).is_none(), "{key} in {p}");
        }
        let a = build(&HairDualStage, "absorption_count = 3\ntheta_count = 5");
        let b = build(
            &HairDualStage,
            "absorption_count = 3\ntheta_count = 5\naxis_ratio = 1.0\nlambertian_kd = 0.0",
        );
        assert_eq!(a.data, b.data);
        assert!(b.attributes.get("diffuse").is_none() && b.attributes.get("elliptic").is_none());
    }

    /// hair-azimuthal with an elliptic fibre and diffuse terms: the lossless lobes still
    /// integrate to 1, TRT moves, the `diffuse` channel holds f_d with ∫ f_d dφ =
    /// 2 lambertian_kd + 4π higher_order_kd.
    #[test]
    fn azimuthal_table_with_fibre_features() {
        let np = 721;
        let t = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0]\ntheta_count = 2\nphi_count = 721\nazimuthal_width_deg = 3.0\naxis_ratio = 0.9\nlambertian_kd = 0.2\nhigher_order_kd = 0.01",
        );
        let c0 = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0]\ntheta_count = 2\nphi_count = 721\nazimuthal_width_deg = 3.0",
        );
        assert_eq!(t.channels.len(), 6);
        assert_eq!(t.channels[5].name, "diffuse");
        let step = std::f64::consts::PI / 720.0;
        let integral = |data: &[f32], nc: usize, c: usize| {
            (0..np)
                .map(|j| {
                    let w = if j == 0 || j == np - 1 { 0.5 } else { 1.0 };
                    2.0 * w * step * data[j * nc + c] as f64
                })
                .sum::<f64>()
        };
        let sum = integral(&t.data, 6, 4);
        assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        let d = integral(&t.data, 6, 5);
        let want = 2.0 * 0.2 + 4.0 * std::f64::consts::PI * 0.01;
        assert!((d - want).abs() < 1e-5, "{d} vs {want}");
        let moved = (0..np)
            .map(|j| (t.data[j * 6 + 2] - c0.data[j * 5 + 2]).abs())
            .fold(0.0f32, f32::max);
        assert!(moved > 1e-3, "{moved}");
        for j in 0..np {
            assert_eq!(t.data[j * 6], c0.data[j * 5]);
            assert_eq!(t.data[j * 6 + 1], c0.data[j * 5 + 1]);
        }
        assert!(t.attributes["elliptic"]["axis_ratio"].as_f64() == Some(0.9));
        // Quadrature doubling (h panels halved and 16 instead of 8 orientation nodes).
        let dbl = t.attributes["quadrature"]["doubling_max_rel_change"]
            .as_f64()
            .unwrap();
        println!("hair-azimuthal, axis_ratio 0.9, w_φ = 3°: doubling_max_rel_change {dbl:.2e}");
        assert!(dbl < 1e-6, "{dbl}");
        // hair-dual with the smallest axis ratio, smooth and rough fibre.
        for ratio in ["0.0", "1.0"] {
            let t = build(
                &HairDualStage,
                &format!(
                    "sigma_a = [0.0, 0.3]\ntheta_count = 13\naxis_ratio = 0.85\nazimuthal_width_ratio = {ratio}\nroughness_deg = [5.0]"
                ),
            );
            let dbl = t.attributes["quadrature"]["doubling_max_abs_change"]
                .as_f64()
                .unwrap();
            println!(
                "hair-dual, axis_ratio 0.85, w_φ/β_R = {ratio}: doubling_max_abs_change {dbl:.2e}"
            );
            assert!(dbl < 1e-6, "{dbl}");
            // Lossless column: ā_f + ā_b = 1 (no clamp reached at β_R = 5°? checked via E_p).
            for it in 0..13 {
                let v = &t.data[it * DUAL_TABLE_CHANNELS..(it + 1) * DUAL_TABLE_CHANNELS];
                let e: f32 = v[12..16].iter().sum();
                assert!((e - 1.0).abs() < 1e-5, "{v:?}");
            }
        }
    }

    #[test]
    fn azimuthal_table_is_normalised() {
        let t = build(
            &HairAzimuthalStage,
            "sigma_a = [0.0, 0.5]\ntheta_count = 4\nphi_count = 721\nazimuthal_width_deg = 3.0",
        );
        // σ_a = 0: ∫_{−π}^{π} sum dφ = 1 (trapezoid over [0, π], doubled).
        let np = 721;
        let step = std::f64::consts::PI / 720.0;
        for it in 0..4 {
            let mut s = 0.0;
            for j in 0..np {
                let w = if j == 0 || j == np - 1 { 0.5 } else { 1.0 };
                s += 2.0 * w * step * t.data[(it * np + j) * 5 + 4] as f64;
            }
            assert!((s - 1.0).abs() < 1e-5, "θ index {it}: {s}");
        }
    }
}
