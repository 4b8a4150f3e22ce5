//! The interface between the pipeline and a computation stage.
//!
//! A stage turns a manifest entry's `[table.params]` into a [`Job`]: a list of independent
//! tasks (each a pure computation returning a [`Chunk`]: f32 table values and f64 scalars) and
//! an `assemble` step that turns the chunks, in task order, into a [`TableContent`]. The
//! pipeline owns I/O, parallelism, resume (per-task checkpoints keyed by stage, algorithm
//! version and task parameters) and progress; stages plan, call the physics and assemble, and
//! stay free of I/O.
//!
//! A stage is written as a [`StageSpec`] (name, version, summary, a parameter struct declared
//! with [`stage_params!`](crate::stages::stage_params) and a planning function); [`Stage`], the
//! object-safe form the registry and the manifest reader use, follows from it.

use crate::error::error_chain;
use crate::table::{Axis, TableContent};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Documentation of one manifest parameter (for `scatterbake stages`).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamDoc {
    pub name: &'static str,
    /// Type as written in TOML, e.g. `float`, `list of float`, `string`.
    pub kind: &'static str,
    /// The default value as text (derived from the value the parameter struct uses), or
    /// `required`, or what leaving an optional parameter out means.
    pub default: String,
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

    /// [`PlanError::Invalid`] whose message is `context` followed by the whole cause chain of
    /// `cause` (the manifest error carries text only).
    pub fn invalid_because(
        key: &str,
        context: &str,
        cause: &(dyn std::error::Error + 'static),
    ) -> Self {
        PlanError::invalid(key, format!("{context}: {}", error_chain(cause)))
    }
}

/// Why a task or the assembly of a planned job failed.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The Lorenz–Mie or Debye computation of a task.
    #[error("Lorenz–Mie computation")]
    Mie(#[from] crate::mie::MieError),
    /// The size-distribution average of a task (including a tolerance not met within the
    /// node limit).
    #[error("size-distribution average")]
    SizeAverage(#[from] crate::mie::size_average::SizeAverageError),
    /// The refractive index of water at a task's wavelength.
    #[error("water refractive index")]
    WaterIndex(#[from] crate::optics::water::WaterIndexError),
    /// A fur computation (e.g. a lookup in medulla tables).
    #[error("fur far field")]
    Fur(#[from] crate::fur::FurError),
    /// `assemble` received a different number of chunks than the job has tasks.
    #[error("expected {expected} chunks (one per task), got {got}")]
    ChunkCount { expected: usize, got: usize },
    /// A chunk of the wrong length (e.g. a checkpoint of another layout).
    #[error("chunk {index} has {got} {part}, expected {expected}")]
    ChunkLength {
        index: usize,
        part: ChunkPart,
        got: usize,
        expected: usize,
    },
    /// A compact table entry whose error, measured against the dense entry seen through the
    /// same sun disc, exceeds the tolerance its manifest states; the table is not written.
    #[error(
        "entry {entry}: the compact table's error {measured:.3e} (in the stated norm, against the dense entry seen through the sun's disc) exceeds the stated tolerance {tolerance:e}; the table is not written (tolerances below the f32 rounding of the stored values, about 1e-7, cannot be met)"
    )]
    CompressionTolerance {
        entry: usize,
        measured: f64,
        tolerance: f64,
    },
    /// A table entry whose phase function cannot be normalised to ∫ p dΩ = 1.
    #[error("entry {entry}: ∫ p dΩ = {integral}, not positive and finite; cannot normalise")]
    NotNormalisable { entry: usize, integral: f64 },
    /// A table entry whose phase function, before renormalisation, integrates far from 1: a
    /// numerical failure, not physics ([`PLAUSIBLE_PHASE_INTEGRAL`]); the table is not written.
    #[error(
        "entry {entry}: ∫ p dΩ = {integral} before renormalisation, outside {:?}: a numerical failure; the table is not written",
        PLAUSIBLE_PHASE_INTEGRAL
    )]
    ImplausibleIntegral { entry: usize, integral: f64 },
    /// The assembled table is not the size the job announced at plan time (a stage bug: the
    /// plan-time size check would have been wrong).
    #[error("the table has {assembled} bytes of values, but the job planned {planned}")]
    PlannedSize { planned: u64, assembled: u64 },
    /// The assembled table's axes or channels differ from those the job planned (a stage bug).
    #[error("the table is {assembled}, but the job planned {planned}")]
    PlannedShape { planned: String, assembled: String },
    /// A header attribute that does not encode as JSON.
    #[error("encoding the table attributes as JSON")]
    Attributes(#[from] serde_json::Error),
}

/// What one task returns: its share of the table's f32 values (in the stage's layout) and f64
/// scalars that the stage records elsewhere (e.g. per-entry cross-sections in the header, or
/// statistics of the computation), kept at full precision.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Chunk {
    /// The task's table values.
    pub values: Vec<f32>,
    /// The task's scalars, in an order the stage defines.
    pub scalars: Vec<f64>,
}

impl Chunk {
    /// A chunk of values and scalars.
    pub fn new(values: Vec<f32>, scalars: Vec<f64>) -> Self {
        Chunk { values, scalars }
    }

    /// A chunk of values without scalars.
    pub fn values(values: Vec<f32>) -> Self {
        Chunk {
            values,
            scalars: Vec::new(),
        }
    }
}

/// Checks that `chunks` holds `count` chunks of `values` values and `scalars` scalars each.
pub fn check_chunks(
    chunks: &[Chunk],
    count: usize,
    values: usize,
    scalars: usize,
) -> Result<(), JobError> {
    if chunks.len() != count {
        return Err(JobError::ChunkCount {
            expected: count,
            got: chunks.len(),
        });
    }
    for (index, c) in chunks.iter().enumerate() {
        check_chunk(index, c, values, scalars)?;
    }
    Ok(())
}

/// Checks that chunk `index` holds `values` values and `scalars` scalars.
pub fn check_chunk(index: usize, c: &Chunk, values: usize, scalars: usize) -> Result<(), JobError> {
    for (part, got, expected) in [
        (ChunkPart::Values, c.values.len(), values),
        (ChunkPart::Scalars, c.scalars.len(), scalars),
    ] {
        if got != expected {
            return Err(JobError::ChunkLength {
                index,
                part,
                got,
                expected,
            });
        }
    }
    Ok(())
}

/// The values of `chunks` in order as one vector: the first chunk's values become the table
/// (grown in place) and each further chunk is dropped once copied, so a one-task table is never
/// copied and larger ones hold one spare chunk at most.
pub fn concat_values(chunks: Vec<Chunk>) -> Vec<f32> {
    let total: usize = chunks.iter().map(|c| c.values.len()).sum();
    let mut chunks = chunks.into_iter();
    let mut data = chunks.next().map(|c| c.values).unwrap_or_default();
    data.reserve_exact(total - data.len());
    for c in chunks {
        data.extend_from_slice(&c.values);
    }
    data
}

/// The part of a [`Chunk`] that [`JobError::ChunkLength`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChunkPart {
    Values,
    Scalars,
}

impl std::fmt::Display for ChunkPart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ChunkPart::Values => "values",
            ChunkPart::Scalars => "scalars",
        })
    }
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
    /// Run task `index` (pure; may use rayon internally). Returns its chunk.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError>;
    /// Assemble the chunks (in task order) into the table.
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError>;
    /// The table's grid, known before any task runs: the axes `assemble` will produce and the
    /// number of channels ([`assemble_checked`] holds every run to it).
    fn shape(&self) -> PlannedShape;
    /// Uncompressed size of the table's values in bytes, known before any task runs
    /// (`u64::MAX` when the count overflows). The pipeline refuses at plan time a table the
    /// reader would refuse (`ReadLimits::max_payload_bytes`).
    fn payload_bytes(&self) -> u64 {
        self.shape().payload_bytes()
    }
    /// Estimated CPU seconds of the whole job (every task and the assembly) on one core of the
    /// reference machine, from a cost model of the stage calibrated on measured builds
    /// (docs/pipeline.md, "Planning a build"). An estimate for sizing jobs, not a promise.
    fn estimated_cpu_seconds(&self) -> f64;
    /// Estimated stored fraction of the payload: zstd-compressed bytes over uncompressed, as
    /// measured on tables of the stage (`crate::stages::cost`).
    fn estimated_stored_fraction(&self) -> f64;
    /// Estimated bytes of the header's `attributes` object (compact JSON): stage-specific
    /// conventions plus per-task records such as integrals and cross-sections.
    fn estimated_attribute_bytes(&self) -> u64 {
        crate::stages::cost::ATTRIBUTE_BYTES
    }
    /// Estimated axes as the written header will list them, when they differ from the planned
    /// grid's: a job that chooses samples while it runs (an adaptive [`PlannedShape`]) lists
    /// those samples, not the grid that bounds them. `None`: the planned axes.
    fn estimated_header_axes(&self) -> Option<Vec<Axis>> {
        None
    }
}

/// A table's grid as a job plans it: its axes (outermost first) and channel count.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedShape {
    pub axes: Vec<Axis>,
    pub channels: usize,
    /// The axis lengths are upper bounds: the job chooses the samples of some axes while it
    /// runs (e.g. compact 2-D raytrace tables); names, order and channels are still exact.
    pub adaptive: bool,
}

impl PlannedShape {
    /// The shape of a table with these axes and `channels` channels.
    pub fn new(axes: Vec<Axis>, channels: usize) -> Self {
        PlannedShape {
            axes,
            channels,
            adaptive: false,
        }
    }
    /// A shape whose axis lengths are upper bounds of the table's.
    pub fn adaptive(axes: Vec<Axis>, channels: usize) -> Self {
        PlannedShape {
            adaptive: true,
            ..PlannedShape::new(axes, channels)
        }
    }
    /// Axis lengths, then the channel count (the table's `layout.shape`).
    pub fn dims(&self) -> Vec<usize> {
        let mut d: Vec<usize> = self.axes.iter().map(Axis::len).collect();
        d.push(self.channels);
        d
    }
    /// `4 · Π dims` bytes of f32 values (`u64::MAX` on overflow).
    pub fn payload_bytes(&self) -> u64 {
        f32_payload_bytes(&self.dims())
    }
    /// Number of values (`u64::MAX` on overflow).
    pub fn values(&self) -> u64 {
        self.payload_bytes() / 4
    }
}

/// `4 · Π dims`: the bytes of a table of f32 values with these dimensions (axes, then
/// channels), `u64::MAX` when the count overflows; for [`Job::payload_bytes`].
pub fn f32_payload_bytes(dims: &[usize]) -> u64 {
    dims.iter()
        .try_fold(4u64, |acc, &d| acc.checked_mul(d as u64))
        .unwrap_or(u64::MAX)
}

/// Range of ∫ p dΩ, before renormalisation, of a phase function divided by its own scattering
/// cross-section. Tables differ from 1 by their discretisation: the flux of triangles dropped
/// at a drop's silhouette (a few per mille) and point-sampled cusp caustics (up to 1.039 on the
/// coarse grids of the default manifests). An entry outside this range is a numerical failure.
pub const PLAUSIBLE_PHASE_INTEGRAL: (f64, f64) = (0.5, 2.0);

/// [`JobError::ImplausibleIntegral`] unless `integral` lies in [`PLAUSIBLE_PHASE_INTEGRAL`].
pub fn check_phase_integral(entry: usize, integral: f64) -> Result<(), JobError> {
    let (lo, hi) = PLAUSIBLE_PHASE_INTEGRAL;
    if (lo..=hi).contains(&integral) {
        Ok(())
    } else {
        Err(JobError::ImplausibleIntegral { entry, integral })
    }
}

/// Run a planned job in memory, tasks in parallel (rayon), without checkpoints or files: the
/// runner for tests, examples and library users who want a table's content directly. The
/// pipeline's resumable runner gives identical content.
pub fn run_in_memory(job: &dyn Job) -> Result<TableContent, JobError> {
    use rayon::prelude::*;
    let chunks = (0..job.tasks().len())
        .into_par_iter()
        .map(|i| job.run_task(i))
        .collect::<Result<Vec<_>, _>>()?;
    assemble_checked(job, chunks)
}

/// [`Job::assemble`], then check that the table has the axes (names and lengths), channel
/// count and size [`Job::shape`] announced (every run checks the plan the pipeline and
/// `build --plan` rely on).
pub fn assemble_checked(job: &dyn Job, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
    let planned = job.shape();
    let content = job.assemble(chunks)?;
    if planned.adaptive {
        return check_adaptive_shape(&planned, content);
    }
    let assembled = 4 * content.data.len() as u64;
    if planned.payload_bytes() != assembled {
        return Err(JobError::PlannedSize {
            planned: planned.payload_bytes(),
            assembled,
        });
    }
    let (want, got) = (
        describe_shape(&planned.axes, planned.channels),
        describe_shape(&content.axes, content.channels.len()),
    );
    if want != got {
        return Err(JobError::PlannedShape {
            planned: want,
            assembled: got,
        });
    }
    Ok(content)
}

/// A table's grid in words: `name length` per axis, then the channel count.
fn describe_shape(axes: &[Axis], channels: usize) -> String {
    let mut s: Vec<String> = axes
        .iter()
        .map(|a| format!("{} {}", a.name, a.len()))
        .collect();
    s.push(format!("{channels} channels"));
    s.join(" × ")
}

/// [`assemble_checked`] of an adaptive plan: the same axis names and channel count, no axis
/// longer than planned, and values for exactly the table's grid.
fn check_adaptive_shape(
    planned: &PlannedShape,
    content: TableContent,
) -> Result<TableContent, JobError> {
    let fits = planned.axes.len() == content.axes.len()
        && planned.channels == content.channels.len()
        && (planned.axes.iter().zip(&content.axes))
            .all(|(p, a)| p.name == a.name && a.len() <= p.len());
    if !fits {
        return Err(JobError::PlannedShape {
            planned: format!(
                "at most {}",
                describe_shape(&planned.axes, planned.channels)
            ),
            assembled: describe_shape(&content.axes, content.channels.len()),
        });
    }
    if content.data.len() != content.expected_len() {
        return Err(JobError::PlannedSize {
            planned: 4 * content.expected_len() as u64,
            assembled: 4 * content.data.len() as u64,
        });
    }
    Ok(content)
}

/// A computation stage, registered in [`crate::stages::registry`]. Implemented for every
/// [`StageSpec`].
pub trait Stage: Send + Sync {
    /// Stage name used in manifests (`stage = "..."`).
    fn name(&self) -> &'static str;
    /// Algorithm version: bump when results change, so that stale tables are rebuilt.
    fn algorithm_version(&self) -> u32;
    /// One-line summary.
    fn summary(&self) -> &'static str;
    /// Parameters accepted in `[table.params]`.
    fn parameters(&self) -> Vec<ParamDoc>;
    /// Validate parameters and plan the job.
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError>;
}

/// A parameter struct declared with the `stage_params!` macro: it reads
/// itself from `[table.params]` (unknown keys are errors, missing keys take their declared
/// defaults) and documents every field.
pub trait StageParams: DeserializeOwned + Serialize {
    /// One entry per field, in declaration order.
    fn docs() -> Vec<ParamDoc>;
}

/// The typed description of a stage; [`Stage`] follows from it.
pub trait StageSpec: Send + Sync {
    /// Stage name used in manifests (`stage = "..."`).
    const NAME: &'static str;
    /// Algorithm version: bump when results change, so that stale tables are rebuilt.
    const VERSION: u32;
    /// One-line summary.
    const SUMMARY: &'static str;
    /// The `[table.params]` struct.
    type Params: StageParams;
    /// Validate parsed parameters and plan the job.
    fn plan_params(&self, params: Self::Params) -> Result<Box<dyn Job>, PlanError>;
    /// Rewrite an error of parsing the parameters (e.g. name the key that replaced an old one);
    /// the default keeps it.
    fn map_parse_error(e: PlanError) -> PlanError {
        e
    }
    /// Parameters listed by `scatterbake stages` (every field of [`Self::Params`] unless a
    /// stage shares its struct with another).
    fn parameter_docs(&self) -> Vec<ParamDoc> {
        Self::Params::docs()
    }
}

impl<S: StageSpec> Stage for S {
    fn name(&self) -> &'static str {
        S::NAME
    }
    fn algorithm_version(&self) -> u32 {
        S::VERSION
    }
    fn summary(&self) -> &'static str {
        S::SUMMARY
    }
    fn parameters(&self) -> Vec<ParamDoc> {
        self.parameter_docs()
    }
    fn plan(&self, params: toml::de::ValueDeserializer<'_>) -> Result<Box<dyn Job>, PlanError> {
        let parsed =
            serde::Deserialize::deserialize(params).map_err(|e| S::map_parse_error(e.into()))?;
        self.plan_params(parsed)
    }
}

/// Text of a parameter's default value for [`ParamDoc::default`]: strings without quotes,
/// lists of up to [`SHOWN_LIST_LEN`] items in full, longer ones as their length and end values.
pub fn show_default<T: Serialize>(value: &T) -> String {
    fn show(v: &serde_json::Value, nested: bool) -> String {
        use serde_json::Value;
        match v {
            Value::String(s) if !nested => s.clone(),
            Value::Array(a) if a.len() > SHOWN_LIST_LEN => format!(
                "{} values {} … {}",
                a.len(),
                show(&a[0], true),
                show(&a[a.len() - 1], true)
            ),
            Value::Array(a) => format!(
                "[{}]",
                a.iter()
                    .map(|x| show(x, true))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Value::Null => "none".into(),
            other => other.to_string(),
        }
    }
    serde_json::to_value(value).map_or_else(|e| format!("({e})"), |v| show(&v, false))
}

/// Lists longer than this are shown by [`show_default`] as `N values first … last`.
pub const SHOWN_LIST_LEN: usize = 10;

/// Declares a stage's parameter struct together with its documentation, so that each default
/// is written once. Every field is
///
/// `[attributes] [vis] name: Type = HOW, "kind", "description";`
///
/// where `HOW` is `default(EXPR)` (a missing key takes the value of `EXPR`, which
/// `scatterbake stages` shows), `required` (a missing key is an error), or
/// `optional("meaning of leaving it out")` for `Option` fields that stay `None`. The struct
/// derives `Debug`, `Clone` and `Serialize` (field attributes such as
/// `#[serde(skip_serializing_if = ...)]` apply to serialisation); it reads itself from the
/// manifest with unknown keys rejected, and implements [`StageParams`].
///
/// ```ignore
/// stage_params! {
///     /// Parameters of `[table.params]`.
///     pub struct ExampleParams {
///         /// Output angular step (deg).
///         pub angle_step_deg: f64 = default(0.05), "float, deg", "output bin width";
///         pub radii_um: Vec<f64> = required, "list of float, µm", "drop radii";
///         pub profile: Option<Vec<f64>> = optional("none"), "list of float", "drop profile";
///     }
/// }
/// ```
macro_rules! stage_params {
    (
        $(#[$sattr:meta])*
        $svis:vis struct $name:ident {
            $(
                $(#[$fattr:meta])*
                $fvis:vis $field:ident : $ty:ty = $how:ident $(($($arg:tt)*))?, $kind:literal, $desc:literal;
            )*
        }
    ) => {
        $(#[$sattr])*
        #[derive(Debug, Clone, ::serde::Serialize)]
        $svis struct $name {
            $( $(#[$fattr])* $fvis $field: $ty, )*
        }

        impl<'de> ::serde::Deserialize<'de> for $name {
            fn deserialize<D: ::serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                // The manifest form: keys with a default are `Option` here (a missing `Option`
                // is `None`). It carries the public name so that serde's messages use it.
                #[derive(::serde::Deserialize)]
                #[serde(deny_unknown_fields)]
                struct $name {
                    $( $field: $crate::stages::param_raw_type!($how; $ty), )*
                }
                let raw = <$name as ::serde::Deserialize>::deserialize(deserializer)?;
                Ok(Self {
                    $( $field: $crate::stages::param_value!(raw.$field; $ty; $how $(($($arg)*))?), )*
                })
            }
        }

        impl $crate::stages::StageParams for $name {
            fn docs() -> Vec<$crate::stages::ParamDoc> {
                vec![$(
                    $crate::stages::ParamDoc {
                        name: stringify!($field),
                        kind: $kind,
                        default: $crate::stages::param_default_text!($ty; $how $(($($arg)*))?),
                        description: $desc,
                    },
                )*]
            }
        }
    };
}
pub(crate) use stage_params;

/// Type of a field in the manifest form of a [`stage_params!`] struct.
macro_rules! param_raw_type {
    (default; $ty:ty) => { Option<$ty> };
    (required; $ty:ty) => { $ty };
    (optional; $ty:ty) => { $ty };
}
pub(crate) use param_raw_type;

/// Value of a [`stage_params!`] field from its manifest form.
macro_rules! param_value {
    ($raw:expr; $ty:ty; default($default:expr)) => {
        $raw.unwrap_or_else(|| -> $ty { $default })
    };
    ($raw:expr; $ty:ty; required) => {
        $raw
    };
    ($raw:expr; $ty:ty; optional($meaning:literal)) => {
        $raw
    };
}
pub(crate) use param_value;

/// [`ParamDoc::default`] of a [`stage_params!`] field.
macro_rules! param_default_text {
    ($ty:ty; default($default:expr)) => {{
        let value: $ty = $default;
        $crate::stages::show_default(&value)
    }};
    ($ty:ty; required) => {
        String::from("required")
    };
    ($ty:ty; optional($meaning:literal)) => {
        String::from($meaning)
    };
}
pub(crate) use param_default_text;

/// Shared parameter checks, so every stage words and enforces them the same way.
pub mod checks {
    use super::PlanError;
    use crate::optics::water::WaterIndexModel;
    use std::fmt::Display;

    /// `value` must lie within `[lo, hi]` (NaN never does); `unit` is appended to the numbers
    /// in the message (e.g. `" deg"`, `"°"` or `""`).
    pub fn within<T: PartialOrd + Display>(
        key: &str,
        value: T,
        lo: T,
        hi: T,
        unit: &str,
    ) -> Result<(), PlanError> {
        if value >= lo && value <= hi {
            return Ok(());
        }
        Err(PlanError::invalid(
            key,
            format!("must be within {lo}–{hi}{unit} (got {value})"),
        ))
    }

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

    /// Number of intervals `180/step` of a uniform scattering-angle grid; the step must be
    /// finite and divide 180° into 1 to 1e6 intervals (an infinite or huge step would give
    /// none).
    pub fn angle_step_intervals(key: &str, step_deg: f64) -> Result<usize, PlanError> {
        let ratio = 180.0 / step_deg;
        let usable = step_deg.is_finite()
            && step_deg > 0.0
            && (ratio - ratio.round()).abs() <= 1e-6
            && (1.0..=1e6).contains(&ratio.round());
        if !usable {
            return Err(PlanError::invalid(
                key,
                format!(
                    "{step_deg:?} is not usable: must be finite, in (0, 180], with 180/step an integer ≤ 1e6"
                ),
            ));
        }
        Ok(ratio.round() as usize)
    }

    /// Check the wavelengths (positive, strictly increasing), resolve a water index model by
    /// name and evaluate it at every wavelength; errors name `water_index_model` or the
    /// wavelength key.
    pub fn water_indices(
        model_name: &str,
        temperature_c: Option<f64>,
        wavelengths_key: &str,
        wavelengths_nm: &[f64],
    ) -> Result<(WaterIndexModel, Vec<f64>), PlanError> {
        increasing(wavelengths_key, wavelengths_nm, true)?;
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

/// Test helper: plan `stage` from parameter lines (see [`plan_from_lines`]) and run the job in
/// memory; checks that the table has as many values as its axes and channels call for.
#[cfg(test)]
pub fn table_from_lines(stage: &dyn Stage, toml_lines: &str) -> TableContent {
    let job = plan_from_lines(stage, toml_lines)
        .unwrap_or_else(|e| panic!("{} rejected {toml_lines:?}: {e}", stage.name()));
    let t = run_in_memory(job.as_ref()).unwrap_or_else(|e| panic!("{}", error_chain(&e)));
    assert_eq!(t.data.len(), t.expected_len(), "{}", stage.name());
    t
}

/// Test helper: every parameter set of `rejected` fails to plan on `stage` and every one of
/// `accepted` plans (each in the form of [`plan_from_lines`]).
#[cfg(test)]
pub fn assert_planning(stage: &dyn Stage, rejected: &[&str], accepted: &[&str]) {
    for lines in rejected {
        assert!(
            plan_from_lines(stage, lines).is_err(),
            "{} accepted {lines:?}",
            stage.name()
        );
    }
    for lines in accepted {
        if let Err(e) = plan_from_lines(stage, lines) {
            panic!("{} rejected {lines:?}: {e}", stage.name());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    stage_params! {
        /// A parameter struct of every kind of field.
        struct Example {
            step_deg: f64 = default(0.05), "float, deg", "a step";
            radii_um: Vec<f64> = required, "list of float, µm", "radii";
            profile: Option<Vec<f64>> = optional("none"), "list of float", "a profile";
            grid: Vec<f64> = default((0..12).map(f64::from).collect()), "list of float", "a grid";
        }
    }

    fn parse(inline: &str) -> Result<Example, toml::de::Error> {
        serde::Deserialize::deserialize(toml::de::ValueDeserializer::parse(inline).unwrap())
    }

    #[test]
    fn declared_defaults_fill_missing_keys_and_are_documented() {
        let p = parse("{ radii_um = [1.0] }").unwrap();
        assert_eq!(
            (p.step_deg, p.profile.as_deref(), p.grid.len()),
            (0.05, None, 12)
        );
        let docs = Example::docs();
        let shown: Vec<(&str, &str)> = docs.iter().map(|d| (d.name, d.default.as_str())).collect();
        assert_eq!(
            shown,
            [
                ("step_deg", "0.05"),
                ("radii_um", "required"),
                ("profile", "none"),
                ("grid", "12 values 0.0 … 11.0"),
            ]
        );
        // Serialised parameters hold the filled-in defaults (they enter the content key).
        let json = serde_json::to_value(&p).unwrap();
        assert_eq!(json["step_deg"], 0.05);
        assert!(json["profile"].is_null());
    }

    #[test]
    fn unknown_and_missing_keys_are_errors_naming_the_key() {
        let e = parse("{ radii_um = [1.0], bogus = 1 }").unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
        let e = parse("{ step_deg = 0.1 }").unwrap_err();
        assert!(e.to_string().contains("radii_um"), "{e}");
    }

    #[test]
    fn chunk_checks_name_the_chunk() {
        let chunks = vec![
            Chunk::new(vec![0.0; 3], vec![1.0]),
            Chunk::new(vec![0.0; 2], vec![1.0]),
        ];
        assert!(
            check_chunks(&chunks, 2, 3, 1)
                .unwrap_err()
                .to_string()
                .contains("chunk 1 has 2 values, expected 3")
        );
        let chunks = vec![
            Chunk::new(vec![0.0; 3], vec![1.0]),
            Chunk::values(vec![0.0; 3]),
        ];
        assert!(
            check_chunks(&chunks, 2, 3, 1)
                .unwrap_err()
                .to_string()
                .contains("chunk 1 has 0 scalars, expected 1")
        );
        assert!(matches!(
            check_chunks(&chunks, 3, 3, 1),
            Err(JobError::ChunkCount {
                expected: 3,
                got: 2
            })
        ));
    }

    /// A job that plans one shape and assembles another.
    struct Mismatched {
        planned: Vec<Axis>,
        assembled: Vec<Axis>,
    }

    impl Job for Mismatched {
        fn parameters(&self) -> serde_json::Value {
            serde_json::Value::Null
        }
        fn tasks(&self) -> Vec<TaskSpec> {
            Vec::new()
        }
        fn run_task(&self, _: usize) -> Result<Chunk, JobError> {
            Ok(Chunk::default())
        }
        fn assemble(&self, _: Vec<Chunk>) -> Result<TableContent, JobError> {
            let n: usize = self.assembled.iter().map(Axis::len).product();
            Ok(TableContent {
                encoding: Default::default(),
                schema: crate::table::Schema::new("test", 1),
                description: String::new(),
                axes: self.assembled.clone(),
                channels: vec![crate::table::Channel::new("v", "1", "value")],
                attributes: serde_json::Map::new(),
                data: vec![0.0; n],
            })
        }
        fn shape(&self) -> PlannedShape {
            PlannedShape::new(self.planned.clone(), 1)
        }
        fn estimated_cpu_seconds(&self) -> f64 {
            0.0
        }
        fn estimated_stored_fraction(&self) -> f64 {
            1.0
        }
    }

    #[test]
    fn an_assembly_unlike_the_plan_is_refused() {
        let ab = vec![
            Axis::uniform("a", "1", 0.0, 1.0, 2),
            Axis::uniform("b", "1", 0.0, 1.0, 3),
        ];
        let ba = vec![
            Axis::uniform("b", "1", 0.0, 1.0, 3),
            Axis::uniform("a", "1", 0.0, 1.0, 2),
        ];
        let same = Mismatched {
            planned: ab.clone(),
            assembled: ab.clone(),
        };
        assert!(assemble_checked(&same, Vec::new()).is_ok());
        // Same size, axes swapped: the plan's axes would be wrong.
        let swapped = Mismatched {
            planned: ab.clone(),
            assembled: ba,
        };
        let e = assemble_checked(&swapped, Vec::new())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(
                "the table is b 3 × a 2 × 1 channels, but the job planned a 2 × b 3 × 1 channels"
            ),
            "{e}"
        );
        let larger = Mismatched {
            planned: ab,
            assembled: vec![Axis::uniform("a", "1", 0.0, 1.0, 7)],
        };
        assert!(matches!(
            assemble_checked(&larger, Vec::new()),
            Err(JobError::PlannedSize {
                planned: 24,
                assembled: 28
            })
        ));
    }
}
