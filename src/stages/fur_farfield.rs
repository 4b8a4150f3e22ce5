//! Stage `fur-farfield` (schema `fur-farfield/1`): far-field profiles of the practical fur
//! shading model ([`crate::fur::farfield`]) for the fitted samples of Tseng 2015 Table 4.2.
//!
//! Axes (row-major, channel innermost): `sample` (index into the attribute `samples`) ×
//! `theta_i` (deg) × `theta_r` (deg, cell centres over [−90, 90]) × `phi` (deg, cell centres over
//! [−180, 180)). Channels: `energy` (total) and its components `r`, `tt`, `trt`,
//! `medulla_paths`, `scattered`, each the cell-averaged exiting energy per unit θ_r per unit φ
//! (rad⁻²) per unit intercepted incident power. One task per sample.

use crate::fur::farfield::{
    COMPONENTS, FarFieldSettings, FurSample, MedullaShapes, MedullaSource, SigmaScaling, TABLE_4_2,
    far_field_with, isotropic_fraction, medulla_sigma,
};
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunks, checks, concat_values,
    stage_params,
};
use crate::table::Table;
use crate::table::{Axis, Channel, Schema, TableContent};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::sync::Arc;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct FarFieldParams {
        /// Sample names from Table 4.2 (default: all ten, in the thesis's column order).
        samples: Vec<String> = default(TABLE_4_2.iter().map(|s| s.name.to_string()).collect()),
            "list of string",
            "bobcat, cat, deer, dog, mouse, rabbit, raccoon, red_fox, springbok, human";
        /// Incidence inclinations θ_i (deg), |θ_i| < 90.
        theta_i_deg: Vec<f64> = required, "list of float",
            "incidence inclinations from the fibre's normal plane, |θ_i| < 90";
        theta_r_cells: usize = default(90), "integer", "θ_r cells over [−90, 90] deg";
        phi_cells: usize = default(180), "integer", "φ cells over [−180, 180) deg (even)";
        h_samples: usize = default(400), "integer",
            "offsets across the fibre width (midpoint rule in asin h)";
        medulla_rows: usize = default(17), "integer",
            "rows h' ∈ [0, 1] of the on-the-fly azimuthal medulla profiles";
        medulla_bins: usize = default(360), "integer",
            "exit bins of the medulla profiles (multiple of 4)";
        photons: u64 = required, "integer",
            "Monte Carlo photons per medulla profile (expected-value estimator)";
        seed: u64 = default(0), "integer", "random seed of the medulla profiles";
        medulla_sigma_scaling: SigmaScaling = default(SigmaScaling::ThesisOverKappa), "string",
            "σ_ms → table σ per medulla radius: thesis_over_kappa (σ/κ, the lookup Table 4.2 was fitted with; default), kappa_half (σκ/2, optical depth of σ per diameter), kappa (σκ)";
        /// Where the medulla profiles come from when `medulla_tables` is not given.
        #[serde(skip_serializing_if = "Option::is_none")]
        medulla_source: Option<MedullaSourceKind> = optional("assets"),
            "string",
            "assets (default: multilinear lookup in the shipped compressed thesis-grid tables assets/fur-medulla/, embedded in the library) or monte-carlo (expected-value Monte Carlo on the fly, `photons` per profile)";
        /// Take the medulla profiles from other tables instead of the shipped assets.
        #[serde(skip_serializing_if = "Option::is_none")]
        medulla_tables: Option<MedullaTablePaths> = optional("none (the shipped assets)"),
            "table { azimuthal = path, longitudinal = path }",
            "look the medulla profiles up in fur-medulla-azimuthal/1 and fur-medulla-longitudinal/1 tables, dense or tensor-train compressed (fur-medulla-tt/1; their grids must cover every sample's σ, g and θ'_i); the tables' payload digests enter the content key";
    }
}

/// The medulla profile sources selectable by `medulla_source`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MedullaSourceKind {
    /// The shipped compressed thesis-grid tables (`crate::fur::assets`).
    Assets,
    /// The expected-value Monte Carlo on the fly.
    MonteCarlo,
}

/// Paths (relative to the working directory of the build) of the medulla tables a far field
/// looks its profiles up in.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MedullaTablePaths {
    azimuthal: String,
    longitudinal: String,
}

/// The `fur-farfield` stage.
pub struct FurFarFieldStage;

impl StageSpec for FurFarFieldStage {
    const NAME: &'static str = "fur-farfield";
    const VERSION: u32 = 1;
    const SUMMARY: &'static str = "far-field fur profiles S(θ_r, φ; θ_i) of the practical coaxial-cylinder model for Tseng 2015 Table 4.2";
    type Params = FarFieldParams;
    fn plan_params(&self, p: FarFieldParams) -> Result<Box<dyn Job>, PlanError> {
        let mut samples = Vec::new();
        for n in &p.samples {
            let s = TABLE_4_2
                .iter()
                .find(|s| s.name == n)
                .ok_or_else(|| PlanError::invalid("samples", format!("unknown sample `{n}`")))?;
            samples.push(*s);
        }
        if samples.is_empty() {
            return Err(PlanError::invalid("samples", "empty"));
        }
        if p.theta_i_deg.is_empty()
            || p.theta_i_deg
                .iter()
                .any(|t| !(t.abs() < 89.0) || !t.is_finite())
        {
            return Err(PlanError::invalid(
                "theta_i_deg",
                "need a non-empty list with |θ_i| < 89",
            ));
        }
        if p.theta_i_deg.windows(2).any(|w| w[1] <= w[0]) {
            return Err(PlanError::invalid("theta_i_deg", "must be increasing"));
        }
        checks::within("theta_r_cells", p.theta_r_cells, 6, 1800, "")?;
        if !(8..=3600).contains(&p.phi_cells) || !p.phi_cells.is_multiple_of(2) {
            return Err(PlanError::invalid("phi_cells", "must be even, 8..=3600"));
        }
        checks::within("h_samples", p.h_samples, 16, 100_000, "")?;
        checks::within("medulla_rows", p.medulla_rows, 2, 1000, "")?;
        if !(8..=36_000).contains(&p.medulla_bins) || !p.medulla_bins.is_multiple_of(4) {
            return Err(PlanError::invalid(
                "medulla_bins",
                "must be a multiple of 4 in 8..=36000",
            ));
        }
        if p.photons == 0 || p.photons > 100_000_000 {
            return Err(PlanError::invalid("photons", "must be in 1..=1e8"));
        }
        let tables = match (&p.medulla_tables, p.medulla_source) {
            (Some(_), Some(_)) => {
                return Err(PlanError::invalid(
                    "medulla_source",
                    "give either medulla_source or medulla_tables, not both",
                ));
            }
            (None, Some(MedullaSourceKind::MonteCarlo)) => None,
            (Some(paths), None) => Some(open_medulla_tables(
                MedullaInputs::Files(paths),
                &p,
                &samples,
            )?),
            (None, None | Some(MedullaSourceKind::Assets)) => {
                Some(open_medulla_tables(MedullaInputs::Assets, &p, &samples)?)
            }
        };
        Ok(Box::new(FarFieldJob { p, samples, tables }))
    }
}

/// Where a plan's medulla tables come from.
#[derive(Clone, Copy)]
enum MedullaInputs<'a> {
    /// The shipped assets embedded in the library.
    Assets,
    /// Files named by `medulla_tables`.
    Files(&'a MedullaTablePaths),
}

/// The medulla tables a far field reads: (azimuthal, longitudinal) dense tables, restricted
/// to the σ and g grid points the plan's lookups touch when the source is a tensor train
/// (reconstructed at those points only, bit-identical to the full reconstruction there), and
/// the payload SHA-256 of each source file (the content key's input).
pub struct MedullaTables {
    pub azimuthal: Table,
    pub longitudinal: Table,
    pub payload_sha256: [String; 2],
}

/// Indices of the grid points of `coords` that bracket every value of `xs` (multilinear
/// lookup touches exactly these); values outside the axis are left to the range check.
fn bracket_indices(coords: &[f64], xs: &[f64]) -> Vec<usize> {
    let mut set = std::collections::BTreeSet::new();
    let n = coords.len();
    for &x in xs {
        let k = coords.partition_point(|&c| c <= x).saturating_sub(1);
        let k = k.min(n.saturating_sub(2));
        set.insert(k);
        if k + 1 < n {
            set.insert(k + 1);
        }
    }
    set.into_iter().collect()
}

/// One medulla table of `schema` from `bytes` or a file, reconstructed at the σ values
/// `sigmas` and g values `gs` if it is a tensor train.
fn load_medulla_table(
    input: MedullaInputs<'_>,
    which: usize,
    schema: &str,
    sigmas: &[f64],
    gs: &[f64],
) -> Result<(Table, String), PlanError> {
    use crate::fur::assets::{ASSET_FILES, AZIMUTHAL_BYTES, LONGITUDINAL_BYTES};
    use crate::table::tt::{TT_SCHEMA, decode_tensor_train};
    let bad = |m: String| PlanError::invalid("medulla_tables", m);
    let (t, name) = match input {
        MedullaInputs::Assets => {
            let name = format!("assets/fur-medulla/{}", ASSET_FILES[which]);
            let bytes = [AZIMUTHAL_BYTES, LONGITUDINAL_BYTES][which];
            let t = Table::from_bytes(bytes, std::path::Path::new(&name))
                .map_err(|e| PlanError::invalid("medulla_source", e.to_string()))?;
            (t, name)
        }
        MedullaInputs::Files(paths) => {
            let path = [&paths.azimuthal, &paths.longitudinal][which].clone();
            // The table error names the file.
            (Table::open(&path).map_err(|e| bad(e.to_string()))?, path)
        }
    };
    let sha = t.header.payload.sha256_uncompressed.clone();
    if t.header.schema.name != TT_SCHEMA {
        if t.header.schema.name != schema {
            return Err(bad(format!(
                "{name}: schema {} (expected {schema})",
                t.header.schema.name
            )));
        }
        return Ok((t, sha));
    }
    let path = std::path::Path::new(&name);
    let d = decode_tensor_train(&t, path, &Default::default()).map_err(|e| bad(e.to_string()))?;
    if d.schema.name != schema || d.axes.len() < 2 {
        return Err(bad(format!(
            "{name}: holds a {} table (expected {schema})",
            d.schema.name
        )));
    }
    let mut sel = vec![None; d.axes.len()];
    sel[0] = Some(bracket_indices(&d.axes[0].coords(), sigmas));
    sel[1] = Some(bracket_indices(&d.axes[1].coords(), gs));
    let sub = d.sub_table(&sel).map_err(|e| bad(e.to_string()))?;
    Ok((sub, sha))
}

/// Open the medulla tables a far-field plan uses, check their schemas, and check that every
/// lookup the plan will make (each sample's σ and g, each θ_i) lies inside their grids.
fn open_medulla_tables(
    input: MedullaInputs<'_>,
    p: &FarFieldParams,
    samples: &[FurSample],
) -> Result<Arc<MedullaTables>, PlanError> {
    // The lookups: azimuthal at (σ, g) of each sample, longitudinal at (σ/cos θ_t, g) for
    // each θ_i (the same expressions as the lookups themselves, below and in run_task).
    let mut az_sigma = Vec::new();
    let mut lo_sigma = Vec::new();
    let mut gs = Vec::new();
    for s in samples {
        let sigma = medulla_sigma(s, p.medulla_sigma_scaling);
        az_sigma.push(sigma);
        gs.push(s.g);
        for &ti in &p.theta_i_deg {
            let sin_ti = ti.to_radians().sin();
            let cos_tm = (1.0 - (sin_ti / s.eta_m).powi(2)).sqrt();
            lo_sigma.push(sigma / cos_tm);
        }
    }
    let (az, az_sha) = load_medulla_table(input, 0, "fur-medulla-azimuthal", &az_sigma, &gs)?;
    let (lo, lo_sha) = load_medulla_table(input, 1, "fur-medulla-longitudinal", &lo_sigma, &gs)?;
    let tables = Arc::new(MedullaTables {
        azimuthal: az,
        longitudinal: lo,
        payload_sha256: [az_sha, lo_sha],
    });
    // Every lookup must be inside the tables' grids: check them at plan time.
    let set = FarFieldJob {
        p: p.clone(),
        samples: samples.to_vec(),
        tables: Some(tables.clone()),
    }
    .settings();
    for s in samples {
        let source = MedullaSource::Tables {
            azimuthal: &tables.azimuthal,
            longitudinal: &tables.longitudinal,
        };
        let sigma = medulla_sigma(s, p.medulla_sigma_scaling);
        MedullaShapes::from_table(&tables.azimuthal, sigma, s.g, &set).map_err(|e| {
            PlanError::invalid_because("medulla_tables", &format!("sample {}", s.name), &e)
        })?;
        for &ti in &p.theta_i_deg {
            let sin_ti = ti.to_radians().sin();
            let cos_tm = (1.0 - (sin_ti / s.eta_m).powi(2)).sqrt();
            crate::fur::farfield::longitudinal_lobe_pdf(
                source,
                sigma / cos_tm,
                s.g,
                (sin_ti / s.eta_m).asin(),
                &set,
            )
            .map_err(|e| {
                PlanError::invalid_because(
                    "medulla_tables",
                    &format!("sample {} at theta_i {ti}", s.name),
                    &e,
                )
            })?;
        }
    }
    Ok(tables)
}

struct FarFieldJob {
    p: FarFieldParams,
    samples: Vec<FurSample>,
    /// The medulla tables (shipped assets or `medulla_tables`); `None`: Monte Carlo.
    tables: Option<Arc<MedullaTables>>,
}

impl FarFieldJob {
    fn settings(&self) -> FarFieldSettings {
        FarFieldSettings {
            theta_r_cells: self.p.theta_r_cells,
            phi_cells: self.p.phi_cells,
            h_samples: self.p.h_samples,
            medulla_rows: self.p.medulla_rows,
            medulla_bins: self.p.medulla_bins,
            photons: self.p.photons,
            seed: self.p.seed,
            sigma_scaling: self.p.medulla_sigma_scaling,
        }
    }
    /// Axes: sample × θ_i × θ_r × φ.
    fn table_axes(&self) -> Vec<Axis> {
        let (nt, np) = (self.p.theta_r_cells, self.p.phi_cells);
        let dt = 180.0 / nt as f64;
        let dp = 360.0 / np as f64;
        vec![
            Axis::values(
                "sample",
                "index",
                (0..self.samples.len()).map(|i| i as f64).collect(),
            ),
            Axis::values("theta_i", "deg", self.p.theta_i_deg.clone()),
            Axis::uniform("theta_r", "deg", -90.0 + 0.5 * dt, dt, nt),
            Axis::uniform("phi", "deg", -180.0 + 0.5 * dp, dp, np),
        ]
    }
    fn chunk_len(&self) -> usize {
        self.p.theta_i_deg.len() * self.p.theta_r_cells * self.p.phi_cells * CHANNELS
    }
}

const CHANNELS: usize = 1 + COMPONENTS.len();

impl Job for FarFieldJob {
    /// Known at plan time: samples × θ_i × θ_r cells × φ cells × channels.
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table_axes(), CHANNELS)
    }
    /// Per sample and θ_i, `h_samples` paths through the fibre binned into θ_r × φ cells
    /// (`cost::FARFIELD_PATH_CELL_CPU_S`); the Monte Carlo medulla (no tables) adds
    /// `photons` histories per medulla row.
    fn estimated_cpu_seconds(&self) -> f64 {
        use crate::stages::cost::{FARFIELD_PATH_CELL_CPU_S, MEDULLA_PHOTON_CPU_S};
        let per = (self.samples.len() * self.p.theta_i_deg.len()) as f64;
        let cells = (self.p.theta_r_cells * self.p.phi_cells) as f64;
        let mut t = per * FARFIELD_PATH_CELL_CPU_S * self.p.h_samples as f64 * cells.sqrt();
        if self.tables.is_none() {
            let photons = (self.p.photons * self.p.medulla_rows as u64) as f64;
            t += self.samples.len() as f64 * MEDULLA_PHOTON_CPU_S * photons;
        }
        t
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_FARFIELD
    }
    fn parameters(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(&self.p).expect("params serialise");
        if let Some(t) = &self.tables {
            // The content of the looked-up tables is part of the result.
            v["medulla_table_sha256"] = json!(t.payload_sha256);
        }
        v
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.samples
            .iter()
            .map(|s| TaskSpec {
                label: s.name.to_string(),
                params: json!({ "sample": s.name }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let s = &self.samples[index];
        let set = self.settings();
        let sigma = medulla_sigma(s, self.p.medulla_sigma_scaling);
        let (shapes, source) = match &self.tables {
            None => (
                MedullaShapes::compute(sigma, s.g, &set),
                MedullaSource::Simulate,
            ),
            Some(t) => (
                MedullaShapes::from_table(&t.azimuthal, sigma, s.g, &set)?,
                MedullaSource::Tables {
                    azimuthal: &t.azimuthal,
                    longitudinal: &t.longitudinal,
                },
            ),
        };
        let mut out = Vec::with_capacity(self.chunk_len());
        for &ti in &self.p.theta_i_deg {
            let ff = far_field_with(s, ti.to_radians(), &shapes, &set, source)?;
            for i in 0..set.theta_r_cells {
                for j in 0..set.phi_cells {
                    let k = i * set.phi_cells + j;
                    out.push(ff.total(i, j) as f32);
                    for c in &ff.components {
                        out.push(c[k] as f32);
                    }
                }
            }
        }
        Ok(Chunk::values(out))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        check_chunks(&chunks, self.samples.len(), self.chunk_len(), 0)?;
        let energies = self.energies(&chunks);
        let attributes = self.attributes(energies);
        let mut channels = vec![Channel::new(
            "energy",
            "1/rad^2",
            "total exiting energy density per unit theta_r per unit phi",
        )];
        for c in COMPONENTS {
            channels.push(Channel::new(c, "1/rad^2", "component of energy"));
        }
        Ok(TableContent {
            schema: Schema::new("fur-farfield", 1),
            description: "far-field fur scattering profiles of Tseng 2015 Table 4.2 samples (practical coaxial-cylinder model)".into(),
            axes: self.table_axes(),
            channels,
            attributes,
            data: concat_values(chunks),
        })
    }
}

impl FarFieldJob {
    /// Energy per (sample, θ_i) and channel, Σ value × cell area, from the stored (f32) values,
    /// flat row-major over (sample, θ_i, channel).
    fn energies(&self, chunks: &[Chunk]) -> Vec<f64> {
        let (nt, np) = (self.p.theta_r_cells, self.p.phi_cells);
        let area = (180.0 / nt as f64).to_radians() * (360.0 / np as f64).to_radians();
        let mut energies = Vec::new();
        for ch in chunks {
            for ti in 0..self.p.theta_i_deg.len() {
                let block = &ch.values[ti * nt * np * CHANNELS..(ti + 1) * nt * np * CHANNELS];
                energies.extend((0..CHANNELS).map(|c| {
                    block
                        .iter()
                        .skip(c)
                        .step_by(CHANNELS)
                        .map(|&v| v as f64)
                        .sum::<f64>()
                        * area
                }));
            }
        }
        energies
    }

    /// The header attributes: model, conventions, medulla source, samples and `energies`.
    fn attributes(&self, energies: Vec<f64>) -> serde_json::Map<String, serde_json::Value> {
        let mut a = serde_json::Map::new();
        a.insert("model".into(), "practical shading model of Tseng 2015 ch. 5 / App. A (coaxial cylinder): unscattered Gaussian lobes of R, TT, TRT, TrT, TttT, TtrtT, TrRrT, TttRttT (chief-ray exit azimuths, Stokes-pile cuticle Fresnel, medulla-interface Fresnel, cortex absorption, medulla extinction) plus medulla-scattered lobes of the TttT, TtrtT and TttRttT chords shaped by 2-D medulla Monte Carlo profiles (C^N, C^M; on the fly or from medulla tables, see medulla_profiles), averaged over the fibre width (h uniform on (-1, 1)). Decisions: docs/decisions.md, fur far field (FUR-1f, FUR-11 … FUR-19)".into());
        a.insert("value_convention".into(), "every channel is the exiting energy per unit theta_r per unit phi (1/rad^2) per unit incident power intercepted by the fibre, AVERAGED over the cell (lobes integrated analytically over the cell, medulla bins split linearly between phi cells): sum over cells of value * dtheta_r * dphi = energy carried. Longitudinal lobes are normalised with int M dtheta_r = 1 (no cos weight). The thesis BCSDF S of Eq. 5.1 is sum_p M_p N_p / cos^2 theta_i with N_p the per-h azimuthal energy density; this table holds the h-average of sum_p M_p N_p, i.e. cos^2 theta_i * S averaged over h".into());
        a.insert("angle_convention".into(), "theta from the fibre's normal plane, root at +90 deg (thesis convention, theta flipped w.r.t. Marschner 2003; the specular cone is theta_r = -theta_i); phi = phi_r - phi_i, 0 = back towards the light, +/-180 = forward; theta_r cells over [-90, 90], phi cells over [-180, 180), axis coordinates are cell centres".into());
        a.insert("units_convention".into(), format!("Table 4.2 sigma_ca is per fibre DIAMETER; internally fibre radius 1: cortex coefficient sigma_ca/2 per radius. Medulla table coefficient per unit medulla radius: medulla_sigma_scaling = {:?} (ThesisOverKappa, the default: sigma_ms/kappa as printed in Eq. 5.10, the lookup Table 4.2 was fitted with; KappaHalf: sigma_ms*kappa/2, sigma_ms per diameter, optical depth preserved; Kappa: sigma_ms*kappa). Both coefficients divided by cos theta_t (longitudinal refraction into cortex / medulla) for the azimuthal projection", self.p.medulla_sigma_scaling).into());
        a.insert("components".into(), "energy = r + tt + trt + medulla_paths + scattered; r, tt, trt: classic unscattered lobes (tt and trt only where the chief ray misses the medulla, |h| >= kappa*eta_c'); medulla_paths: unscattered TrT, TttT, TtrtT, TrRrT, TttRttT; scattered: medulla-scattered light (App. A mix with the isotropic fraction lambda)".into());
        let source = match (&self.p.medulla_tables, &self.tables) {
            (None, Some(_)) => format!(
                "multilinear lookup (sigma, g, h' or theta'_i, exit angle) in the shipped tensor-train compressed thesis-grid tables assets/fur-medulla/{} and {} (payload SHA-256 {} and {}) at {} bins",
                crate::fur::assets::ASSET_FILES[0],
                crate::fur::assets::ASSET_FILES[1],
                self.tables
                    .as_ref()
                    .map_or("", |t| t.payload_sha256[0].as_str()),
                self.tables
                    .as_ref()
                    .map_or("", |t| t.payload_sha256[1].as_str()),
                self.p.medulla_bins
            ),
            (None, None) => format!(
                "expected-value Monte Carlo on the fly, {} photons, {} bins, seed {}",
                self.p.photons, self.p.medulla_bins, self.p.seed
            ),
            (Some(t), _) => format!(
                "multilinear lookup (sigma, g, h' or theta'_i, exit angle) in the tables {} and {} at {} bins",
                t.azimuthal, t.longitudinal, self.p.medulla_bins
            ),
        };
        a.insert("medulla_profiles".into(), format!("azimuthal C^N rows h' = j/{} (j = 0..{}), mirrored for h' < 0, linear in |h'|, normalised to unit sum (energy from the analytic 1 - exp(-sigma chord)); longitudinal C^M per theta_i at theta'_i = asin(sin theta_i / eta_m); source: {source}", self.p.medulla_rows - 1, self.p.medulla_rows - 1).into());
        a.insert("omitted".into(), "paths beyond the eight listed (e.g. TRRT) are omitted as in the thesis; for a lossless fibre without medulla they carry 1/2 int F^2 (1 - F) dh of the energy (tested)".into());
        let samples: Vec<serde_json::Value> = self
            .samples
            .iter()
            .map(|s| {
                json!({
                    "name": s.name, "kappa": s.kappa, "eta_c": s.eta_c, "eta_m": s.eta_m,
                    "alpha_deg": s.alpha_deg, "beta_deg": s.beta_deg,
                    "sigma_ca_per_diameter": s.sigma_ca, "sigma_ms_per_diameter": s.sigma_ms,
                    "g": s.g, "layers": s.layers,
                    "medulla_sigma_per_medulla_radius": medulla_sigma(s, self.p.medulla_sigma_scaling),
                    "isotropic_fraction_lambda": isotropic_fraction(s),
                })
            })
            .collect();
        a.insert("samples".into(), samples.into());
        a.insert(
            "samples_source".into(),
            "Tseng 2015, Table 4.2 (fitted parameters)".into(),
        );
        a.insert(
            "energy_layout".into(),
            "flat row-major over (sample, theta_i, channel) of sum value * cell area".into(),
        );
        a.insert("energy".into(), energies.into());
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::stages::Stage;

    fn plan_str(s: &str) -> Result<Box<dyn Job>, PlanError> {
        FurFarFieldStage.plan(toml::de::ValueDeserializer::parse(s).unwrap())
    }

    #[test]
    fn small_table_is_consistent() {
        let job = plan_str(
            "{ samples = [\"cat\", \"raccoon\"], theta_i_deg = [-40.0, 0.0], theta_r_cells = 30, phi_cells = 60, h_samples = 100, medulla_rows = 5, medulla_bins = 120, photons = 60, seed = 3 }",
        )
        .unwrap();
        assert_eq!(job.tasks().len(), 2);
        let t = crate::stages::run_in_memory(job.as_ref()).unwrap();
        assert_eq!(t.data.len(), t.expected_len());
        // energy channel = sum of components, everything non-negative.
        for row in t.data.chunks(CHANNELS) {
            let s: f32 = row[1..].iter().sum();
            assert!((row[0] - s).abs() <= 1e-5 * row[0].abs().max(1e-3));
            assert!(row.iter().all(|v| *v >= 0.0));
        }
        // Cat (κη_m ≥ 1): the tt and trt channels are identically zero.
        let e = t.attributes["energy"].as_array().unwrap();
        let e: Vec<f64> = e.iter().map(|v| v.as_f64().unwrap()).collect();
        for ti in 0..2 {
            let cat = &e[ti * CHANNELS..(ti + 1) * CHANNELS];
            assert_eq!(cat[2], 0.0);
            assert_eq!(cat[3], 0.0);
            let rac = &e[(2 + ti) * CHANNELS..(3 + ti) * CHANNELS];
            assert!(rac[2] > 1e-3, "raccoon tt {}", rac[2]);
            // Absorbing fibre: less than the incident energy, but a sizeable part of it.
            assert!(cat[0] < 1.0 && cat[0] > 0.2, "{}", cat[0]);
        }
    }

    /// The default source is the shipped assets, and their payload digests are in the content
    /// key (a changed asset changes the key, so the far field is rebuilt); the Monte Carlo
    /// source has no table digest; giving both `medulla_source` and `medulla_tables` is refused.
    #[test]
    fn default_source_is_the_shipped_assets_and_enters_the_content_key() {
        use crate::fur::assets::{AZIMUTHAL_BYTES, LONGITUDINAL_BYTES};
        let base = "samples = [\"cat\", \"human\"], theta_i_deg = [-40.0, 20.0], photons = 10";
        let job = plan_str(&format!("{{ {base} }}")).unwrap();
        let want: Vec<String> = [AZIMUTHAL_BYTES, LONGITUDINAL_BYTES]
            .iter()
            .map(|b| {
                Table::from_bytes(b, std::path::Path::new("asset"))
                    .unwrap()
                    .header
                    .payload
                    .sha256_uncompressed
            })
            .collect();
        assert_eq!(job.parameters()["medulla_table_sha256"], json!(want));
        let mc = plan_str(&format!("{{ {base}, medulla_source = \"monte-carlo\" }}")).unwrap();
        assert!(mc.parameters().get("medulla_table_sha256").is_none());
        let e = match plan_str(&format!(
            "{{ {base}, medulla_source = \"assets\", medulla_tables = {{ azimuthal = \"a.sbt\", longitudinal = \"b.sbt\" }} }}"
        )) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("both keys must be refused"),
        };
        assert!(e.contains("medulla_source"), "{e}");
    }

    #[test]
    fn rejects_bad_params() {
        crate::stages::assert_planning(
            &FurFarFieldStage,
            &[
                "theta_i_deg = [0.0], photons = 10, samples = [\"yeti\"]",
                "theta_i_deg = [90.0], photons = 10",
                "theta_i_deg = [0.0], photons = 0",
                "theta_i_deg = [0.0], photons = 10, phi_cells = 7",
                "theta_i_deg = [0.0], photons = 10, bogus = 1",
            ],
            &["theta_i_deg = [0.0], photons = 10"],
        );
    }

    /// Build a small medulla table of `stage` into `dir` and return its path.
    fn medulla_table(stage: &dyn Stage, lines: &str, dir: &std::path::Path, name: &str) -> String {
        let job = crate::stages::plan_from_lines(stage, lines).unwrap();
        let content = crate::stages::run_in_memory(job.as_ref()).unwrap();
        let mut t = Table::from_content(content, Default::default()).unwrap();
        let path = dir.join(name);
        crate::table::write_table_atomic(&mut t, &path).unwrap();
        path.display().to_string()
    }

    /// `medulla_tables`: the far field of the raccoon (σ = 1.02, g = 0.35 per medulla radius)
    /// from medulla tables covering σ ∈ [0.5, 1.5], g ∈ [0.2, 0.4] agrees with the on-the-fly
    /// Monte Carlo: the same component energies (the energy comes from the analytic extinction,
    /// the tables only shape it) and a scattered distribution within the interpolation + noise
    /// error; samples outside the tables' grid are refused at plan time, naming the key.
    #[test]
    fn far_field_from_medulla_tables_matches_on_the_fly() {
        use crate::stages::fur_medulla::{FurMedullaAzimuthalStage, FurMedullaLongitudinalStage};
        let d = tempfile::tempdir().unwrap();
        let az = medulla_table(
            &FurMedullaAzimuthalStage,
            "sigma = [0.5, 1.0, 1.5]\ng = [0.2, 0.4]\nh = { start = -1.0, stop = 1.0, count = 9 }\nbins = 120\nmethod = \"characteristics\"",
            d.path(),
            "az.sbt",
        );
        let lo = medulla_table(
            &FurMedullaLongitudinalStage,
            "sigma = [0.5, 1.0, 1.5]\ng = [0.2, 0.4]\ntheta_i_deg = [-40.0, -30.0, -20.0]\nbins = 120\nmethod = \"adding-doubling\"",
            d.path(),
            "lo.sbt",
        );
        let common = "samples = [\"raccoon\"], theta_i_deg = [-40.0], theta_r_cells = 30, phi_cells = 60, h_samples = 100, medulla_rows = 5, medulla_bins = 120, photons = 4000, seed = 3, medulla_sigma_scaling = \"kappa_half\"";
        let run = |extra: &str| {
            let job = plan_str(&format!("{{ {common}{extra} }}")).unwrap();
            let chunk = job.run_task(0).unwrap().values;
            (job.parameters(), chunk)
        };
        let (p_fly, fly) = run(", medulla_source = \"monte-carlo\"");
        let (p_tab, tab) = run(&format!(
            ", medulla_tables = {{ azimuthal = \"{az}\", longitudinal = \"{lo}\" }}"
        ));
        assert!(
            p_tab["medulla_table_sha256"].is_array() && p_fly.get("medulla_table_sha256").is_none()
        );
        // Channel 5 = scattered; 1..=4 are the unscattered lobes (identical by construction).
        let comp =
            |v: &[f32], c: usize| -> Vec<f64> { v.chunks(CHANNELS).map(|r| r[c] as f64).collect() };
        for c in 1..=4 {
            assert_eq!(
                comp(&fly, c),
                comp(&tab, c),
                "channel {c} must not depend on the source"
            );
        }
        let (a, b) = (comp(&fly, 5), comp(&tab, 5));
        let (ea, eb): (f64, f64) = (a.iter().sum(), b.iter().sum());
        assert!(
            (ea / eb - 1.0).abs() < 1e-3,
            "scattered energy {ea} vs {eb}"
        );
        let l1: f64 = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f64>() / ea;
        println!("raccoon scattered lobe, tables vs on the fly: relative L1 {l1:.4}");
        assert!(l1 < 0.03, "relative L1 {l1}");
        // Cat at σ = 2.58·0.85/2 = 1.10 is inside, but g = 0.62 is not: refused at plan time.
        let e = match plan_str(&format!(
            "{{ samples = [\"cat\"], theta_i_deg = [-40.0], photons = 10, medulla_sigma_scaling = \"kappa_half\", medulla_tables = {{ azimuthal = \"{az}\", longitudinal = \"{lo}\" }} }}"
        )) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("cat's g = 0.62 is outside the tables' g range"),
        };
        assert!(
            e.contains("medulla_tables") && e.contains("g = 0.62"),
            "{e}"
        );
    }
}
