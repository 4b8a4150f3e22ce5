//! Stage `fur-farfield` (schema `fur-farfield/1`): far-field profiles of the practical fur
//! shading model for the fitted samples of Tseng 2015 Table 4.2, one task per sample. The
//! table (values, layout, header) is [`crate::fur::farfield_table`]; this module checks the
//! parameters and opens the medulla tables the profiles are looked up in (the shipped assets or
//! files named in the manifest).

use crate::fur::farfield::{FarFieldSettings, SigmaScaling, TABLE_4_2};
#[cfg(test)]
use crate::fur::farfield_table::CHANNELS;
use crate::fur::farfield_table::{
    FarFieldTable, MedullaProfiles, MedullaTables, dense_medulla_table, lookup_points,
};
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunks, checks, stage_params,
};
use crate::table::{Table, TableContent};
use serde::{Deserialize, Serialize};
use serde_json::json;

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
        let samples = check_params(&p)?;
        let settings = FarFieldSettings {
            theta_r_cells: p.theta_r_cells,
            phi_cells: p.phi_cells,
            h_samples: p.h_samples,
            medulla_rows: p.medulla_rows,
            medulla_bins: p.medulla_bins,
            photons: p.photons,
            seed: p.seed,
            sigma_scaling: p.medulla_sigma_scaling,
        };
        let mut table = FarFieldTable {
            samples,
            theta_i_deg: p.theta_i_deg.clone(),
            settings,
            medulla: MedullaProfiles::MonteCarlo,
        };
        table.medulla = match (&p.medulla_tables, p.medulla_source) {
            (Some(_), Some(_)) => {
                return Err(PlanError::invalid(
                    "medulla_source",
                    "give either medulla_source or medulla_tables, not both",
                ));
            }
            (None, Some(MedullaSourceKind::MonteCarlo)) => MedullaProfiles::MonteCarlo,
            (Some(paths), None) => MedullaProfiles::Files {
                azimuthal: paths.azimuthal.clone(),
                longitudinal: paths.longitudinal.clone(),
                tables: open_medulla_tables(MedullaInputs::Files(paths), &table)?,
            },
            (None, None | Some(MedullaSourceKind::Assets)) => {
                MedullaProfiles::Assets(open_medulla_tables(MedullaInputs::Assets, &table)?)
            }
        };
        // Every lookup must be inside the tables' grids: check them at plan time.
        table
            .check_lookups()
            .map_err(|(context, e)| PlanError::invalid_because("medulla_tables", &context, &e))?;
        Ok(Box::new(FarFieldJob { p, table }))
    }
}

/// The samples of `p`, every other key checked.
fn check_params(p: &FarFieldParams) -> Result<Vec<crate::fur::farfield::FurSample>, PlanError> {
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
    Ok(samples)
}

/// Where a plan's medulla tables come from.
#[derive(Clone, Copy)]
enum MedullaInputs<'a> {
    /// The shipped assets embedded in the library.
    Assets,
    /// Files named by `medulla_tables`.
    Files(&'a MedullaTablePaths),
}

/// Medulla table `which` (0 azimuthal, 1 longitudinal) of `input`, as a dense table of
/// `schema` at the σ values `sigmas` and g values `gs` (see [`dense_medulla_table`]).
fn load_medulla_table(
    input: MedullaInputs<'_>,
    which: usize,
    schema: &str,
    sigmas: &[f64],
    gs: &[f64],
) -> Result<(Table, String), PlanError> {
    use crate::fur::assets::{ASSET_FILES, AZIMUTHAL_BYTES, LONGITUDINAL_BYTES};
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
    dense_medulla_table(t, &name, schema, sigmas, gs).map_err(bad)
}

/// The medulla tables of `input` at the lookups `table` makes (their schemas checked).
fn open_medulla_tables(
    input: MedullaInputs<'_>,
    table: &FarFieldTable,
) -> Result<MedullaTables, PlanError> {
    let (az_sigma, lo_sigma, gs) =
        lookup_points(&table.samples, &table.theta_i_deg, &table.settings);
    let (az, az_sha) = load_medulla_table(input, 0, "fur-medulla-azimuthal", &az_sigma, &gs)?;
    let (lo, lo_sha) = load_medulla_table(input, 1, "fur-medulla-longitudinal", &lo_sigma, &gs)?;
    Ok(MedullaTables {
        azimuthal: az,
        longitudinal: lo,
        payload_sha256: [az_sha, lo_sha],
    })
}

struct FarFieldJob {
    p: FarFieldParams,
    table: FarFieldTable,
}

impl Job for FarFieldJob {
    /// Known at plan time: samples × θ_i × θ_r cells × φ cells × channels.
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table.axes(), crate::fur::farfield_table::CHANNELS)
    }
    /// Per sample and θ_i, `h_samples` paths through the fibre binned into θ_r × φ cells
    /// (`cost::FARFIELD_PATH_CELL_CPU_S`); the Monte Carlo medulla (no tables) adds
    /// `photons` histories per medulla row.
    fn estimated_cpu_seconds(&self) -> f64 {
        use crate::stages::cost::{FARFIELD_PATH_CELL_CPU_S, MEDULLA_PHOTON_CPU_S};
        let samples = self.table.samples.len() as f64;
        let per = samples * self.p.theta_i_deg.len() as f64;
        let cells = (self.p.theta_r_cells * self.p.phi_cells) as f64;
        let mut t = per * FARFIELD_PATH_CELL_CPU_S * self.p.h_samples as f64 * cells.sqrt();
        if self.table.medulla.tables().is_none() {
            let photons = (self.p.photons * self.p.medulla_rows as u64) as f64;
            t += samples * MEDULLA_PHOTON_CPU_S * photons;
        }
        t
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_FARFIELD
    }
    fn parameters(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(&self.p).expect("params serialise");
        if let Some(t) = self.table.medulla.tables() {
            // The content of the looked-up tables is part of the result.
            v["medulla_table_sha256"] = json!(t.payload_sha256);
        }
        v
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.table
            .samples
            .iter()
            .map(|s| TaskSpec {
                label: s.name.to_string(),
                params: json!({ "sample": s.name }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        Ok(Chunk::values(self.table.sample_values(index)?))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        check_chunks(
            &chunks,
            self.table.samples.len(),
            self.table.sample_len(),
            0,
        )?;
        let per_sample: Vec<&[f32]> = chunks.iter().map(|c| c.values.as_slice()).collect();
        Ok(self.table.content(&per_sample))
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
