//! The interface between the pipeline and a computation stage.
//!
//! A stage turns a manifest entry's `[table.params]` into a [`Job`]: a list of independent
//! tasks (each a pure computation returning a chunk of f32 values) and an `assemble` step that
//! turns the chunks, in task order, into a [`TableContent`]. The pipeline owns I/O, parallelism,
//! resume (per-task checkpoints keyed by stage, algorithm version and task parameters) and
//! progress; stages own the physics and must stay free of I/O.

use crate::table::TableContent;
use serde::de::DeserializeOwned;

/// Documentation of one manifest parameter (for `scatterbake stages`).
#[derive(Debug, Clone, Copy)]
pub struct ParamDoc {
    pub name: &'static str,
    /// Type as written in TOML, e.g. `float`, `list of float`, `string`.
    pub kind: &'static str,
    /// Default, or `required`.
    pub default: &'static str,
    pub description: &'static str,
}

/// Why a manifest entry's parameters are unusable.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Unknown key, wrong type, missing key (carries the TOML span).
    #[error("{0}")]
    Deserialize(#[from] toml::de::Error),
    /// A value that parses but is out of range or inconsistent; `key` is the dotted key path
    /// inside `params` (e.g. `radius_um` or `distribution.sigma`).
    #[error("parameter `{key}`: {message}")]
    Invalid { key: String, message: String },
}

impl PlanError {
    /// Shorthand for [`PlanError::Invalid`].
    pub fn invalid(key: &str, message: impl Into<String>) -> Self {
        PlanError::Invalid {
            key: key.to_string(),
            message: message.into(),
        }
    }
}

/// Deserialise a stage's parameter struct from the manifest value (use
/// `#[serde(deny_unknown_fields)]` on the struct so unknown keys are errors).
pub fn parse_params<T: DeserializeOwned>(
    params: toml::de::ValueDeserializer<'_>,
) -> Result<T, PlanError> {
    Ok(T::deserialize(params)?)
}

/// One independent unit of work.
#[derive(Debug, Clone)]
pub struct TaskSpec {
    /// Human label for progress and errors, e.g. `λ=550 nm r=100 µm`.
    pub label: String,
    /// Canonical parameters of this task (part of its content key, with the job's parameters).
    pub params: serde_json::Value,
}

/// A planned computation for one output table.
pub trait Job: Send + Sync {
    /// Fully resolved parameters (defaults filled in), recorded in the table's provenance and
    /// hashed into the content key.
    fn parameters(&self) -> serde_json::Value;
    /// The independent tasks, in a deterministic order.
    fn tasks(&self) -> Vec<TaskSpec>;
    /// Run task `index` (pure; may use rayon internally). Returns its chunk of values.
    fn run_task(&self, index: usize) -> anyhow::Result<Vec<f32>>;
    /// Assemble the chunks (in task order) into the table.
    fn assemble(&self, chunks: Vec<Vec<f32>>) -> anyhow::Result<TableContent>;
}

/// Run a planned job in memory, tasks in parallel (rayon), without checkpoints or files: the
/// runner for tests, examples and library users who want a table's content directly. The
/// pipeline's resumable runner gives identical content.
pub fn run_in_memory(job: &dyn Job) -> anyhow::Result<TableContent> {
    use rayon::prelude::*;
    let chunks = (0..job.tasks().len())
        .into_par_iter()
        .map(|i| job.run_task(i))
        .collect::<anyhow::Result<Vec<_>>>()?;
    job.assemble(chunks)
}

/// A computation stage, registered in [`crate::stages::registry`].
pub trait Stage: Send + Sync {
    /// Stage name used in manifests (`stage = "..."`).
    fn name(&self) -> &'static str;
    /// Algorithm version: bump when results change, so that stale tables are rebuilt.
    fn algorithm_version(&self) -> u32;
    /// One-line summary.
    fn summary(&self) -> &'static str;
    /// Parameters accepted in `[table.params]`.
    fn parameters(&self) -> &'static [ParamDoc];
    /// Validate parameters and plan the job.
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError>;
}

/// Shared parameter checks, so every stage words and enforces them the same way.
/// Split an f64 into an f32 pair `[hi, lo]` with `hi + lo` = v to about 2^-48 relative, so a
/// task (whose result is an f32 vector) can carry an f64 scalar for the header without
/// rounding it to f32. Finite values of f32 range only.
pub fn split_f64(v: f64) -> [f32; 2] {
    let hi = v as f32;
    [hi, (v - hi as f64) as f32]
}

/// Inverse of [`split_f64`].
pub fn join_f64(hi: f32, lo: f32) -> f64 {
    hi as f64 + lo as f64
}

pub mod checks {
    use super::PlanError;
    use crate::optics::water::WaterIndexModel;

    /// `values` must be non-empty, finite and strictly increasing (and positive when
    /// `positive`).
    pub fn increasing(key: &str, values: &[f64], positive: bool) -> Result<(), PlanError> {
        let bad = values.is_empty()
            || values
                .iter()
                .any(|v| !v.is_finite() || (positive && *v <= 0.0))
            || values.windows(2).any(|w| w[1] <= w[0]);
        if bad {
            let what = if positive { "positive, " } else { "" };
            return Err(PlanError::invalid(
                key,
                format!("must be {what}non-empty and strictly increasing"),
            ));
        }
        Ok(())
    }

    /// Number of intervals `180/step` of a uniform scattering-angle grid; the step must divide
    /// 180° into at most 1e6 intervals.
    pub fn angle_step_intervals(key: &str, step_deg: f64) -> Result<usize, PlanError> {
        let ratio = 180.0 / step_deg;
        if !(step_deg > 0.0) || (ratio - ratio.round()).abs() > 1e-6 || ratio.round() > 1e6 {
            return Err(PlanError::invalid(
                key,
                "must be > 0 with 180/step an integer ≤ 1e6",
            ));
        }
        Ok(ratio.round() as usize)
    }

    /// Resolve a water index model by name and evaluate it at every wavelength; errors name
    /// `water_index_model` or the wavelength key.
    pub fn water_indices(
        model_name: &str,
        temperature_c: Option<f64>,
        wavelengths_key: &str,
        wavelengths_nm: &[f64],
    ) -> Result<(WaterIndexModel, Vec<f64>), PlanError> {
        let model = WaterIndexModel::from_name(model_name, temperature_c)
            .map_err(|e| PlanError::invalid("water_index_model", e.to_string()))?;
        let indices = wavelengths_nm
            .iter()
            .map(|&l| model.index(l))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| PlanError::invalid(wavelengths_key, e.to_string()))?;
        Ok((model, indices))
    }
}

/// Test helper: plan `stage` from parameter lines written as TOML (`key = value` per line).
#[cfg(test)]
pub fn plan_from_lines(stage: &dyn Stage, toml_lines: &str) -> Result<Box<dyn Job>, PlanError> {
    let inline = format!(
        "{{ {} }}",
        toml_lines
            .lines()
            .filter(|l| !l.trim().is_empty())
            .collect::<Vec<_>>()
            .join(", ")
    );
    stage.plan(toml::de::ValueDeserializer::parse(&inline).expect("test TOML parses"))
}
