//! What a table is: schema, axes, channels, provenance, the JSON header, and the table in
//! memory (header plus samples).

use serde::{Deserialize, Serialize};

/// Schema of a table: what its axes and channels mean, e.g. `mie-phase/1`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schema {
    /// Schema name, e.g. `mie-phase`.
    pub name: String,
    /// Schema version; bumped whenever the meaning of axes/channels/attributes changes.
    pub version: u32,
}

impl Schema {
    pub fn new(name: &str, version: u32) -> Self {
        Schema {
            name: name.to_string(),
            version,
        }
    }
}

impl std::fmt::Display for Schema {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.name, self.version)
    }
}

/// Sample positions of an axis: explicit values, or a uniform range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AxisPoints {
    /// Explicit, strictly increasing coordinates.
    Values(Vec<f64>),
    /// `start + i·step` for `i = 0..count`.
    Uniform { start: f64, step: f64, count: usize },
}

/// One axis of a table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// Axis name in the field's words, e.g. `wavelength`, `scattering_angle`.
    pub name: String,
    /// Unit, e.g. `nm`, `deg`, `um`, `1` for dimensionless.
    pub unit: String,
    /// Sample coordinates.
    pub points: AxisPoints,
    /// Optional names of the samples (one per sample), for axes whose coordinates are only
    /// entry numbers, e.g. `distribution`: `"marshall-palmer R=5 mm/h, r 50–3000 um"`. Absent
    /// from the header when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub labels: Vec<String>,
}

impl Axis {
    /// Axis with explicit values.
    pub fn values(name: &str, unit: &str, values: Vec<f64>) -> Self {
        Axis {
            name: name.into(),
            unit: unit.into(),
            points: AxisPoints::Values(values),
            labels: Vec::new(),
        }
    }
    /// Axis with explicit values and one label per value.
    pub fn labelled(name: &str, unit: &str, values: Vec<f64>, labels: Vec<String>) -> Self {
        Axis {
            labels,
            ..Axis::values(name, unit, values)
        }
    }
    /// Label of sample `i` when the axis has labels.
    pub fn label(&self, i: usize) -> Option<&str> {
        self.labels.get(i).map(String::as_str)
    }
    /// Axis with a uniform range.
    pub fn uniform(name: &str, unit: &str, start: f64, step: f64, count: usize) -> Self {
        Axis {
            name: name.into(),
            unit: unit.into(),
            points: AxisPoints::Uniform { start, step, count },
            labels: Vec::new(),
        }
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        match &self.points {
            AxisPoints::Values(v) => v.len(),
            AxisPoints::Uniform { count, .. } => *count,
        }
    }
    /// True for an axis without samples (invalid in a table).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Coordinate of sample `i`.
    pub fn coord(&self, i: usize) -> f64 {
        match &self.points {
            AxisPoints::Values(v) => v[i],
            AxisPoints::Uniform { start, step, .. } => start + step * i as f64,
        }
    }
    /// All coordinates.
    pub fn coords(&self) -> Vec<f64> {
        (0..self.len()).map(|i| self.coord(i)).collect()
    }
}

/// One channel (stored quantity) of a table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// Channel name, e.g. `phase`, `i_perp`.
    pub name: String,
    /// Unit, e.g. `1/sr`.
    pub unit: String,
    /// What the channel means, with its convention.
    pub meaning: String,
}

impl Channel {
    pub fn new(name: &str, unit: &str, meaning: &str) -> Self {
        Channel {
            name: name.into(),
            unit: unit.into(),
            meaning: meaning.into(),
        }
    }
}

/// Where a table came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Provenance {
    /// Always `scatterbake`.
    pub tool: String,
    /// Crate version of the writer.
    pub tool_version: String,
    /// Git commit of the writer's source tree, when known at build time.
    pub git_commit: Option<String>,
    /// Manifest file (as given on the command line), if built from a manifest.
    pub manifest: Option<String>,
    /// Manifest entry (output table name).
    pub entry: Option<String>,
    /// Stage name and algorithm version, e.g. `mie@1`.
    pub stage: Option<String>,
    /// Fully resolved stage parameters (defaults filled in).
    pub parameters: serde_json::Value,
    /// SHA-256 (hex) of the canonical JSON of `{stage, algorithm_version, parameters}`: the
    /// content key that decides whether a rebuild is needed.
    pub parameters_digest: String,
    /// Creation time, RFC 3339 UTC (from `SOURCE_DATE_EPOCH` when set, for reproducible builds).
    pub created_utc: String,
}

/// Everything a stage produces for one table: meaning, grid and data (provenance is added by
/// the pipeline).
#[derive(Debug, Clone, PartialEq)]
pub struct TableContent {
    pub schema: Schema,
    /// Short human description.
    pub description: String,
    pub axes: Vec<Axis>,
    pub channels: Vec<Channel>,
    /// Stage-specific self-description: conventions, normalisation, models used, accuracy.
    pub attributes: serde_json::Map<String, serde_json::Value>,
    /// Row-major samples, axes in order, channel innermost; length = Π|axis| · |channels|.
    pub data: Vec<f32>,
}

impl TableContent {
    /// Number of f32 values the axes and channels imply.
    pub fn expected_len(&self) -> usize {
        self.axes.iter().map(Axis::len).product::<usize>() * self.channels.len()
    }
}

/// A table in memory: header (as read or to be written) plus data.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub header: Header,
    pub data: Vec<f32>,
}

/// The JSON header of a `.sbt` file (see the spec for every field). Fields this version does
/// not know are ignored when deserialising; the reader rejects unknown top-level fields only in
/// files of a minor version it implements (`docs/table-format.md`, "Versioning rules").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub schema: Schema,
    pub description: String,
    pub axes: Vec<Axis>,
    pub channels: Vec<Channel>,
    pub layout: Layout,
    pub attributes: serde_json::Map<String, serde_json::Value>,
    pub provenance: Provenance,
    pub payload: PayloadInfo,
}

/// Memory layout of the payload.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layout {
    /// Always `row-major`.
    pub order: String,
    /// Axis names outermost first, then `channel`.
    pub axis_order: Vec<String>,
    /// Always `f32le`.
    pub dtype: String,
    /// Shape: axis lengths, then the number of channels.
    pub shape: Vec<usize>,
}

/// Payload description and checksums.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PayloadInfo {
    /// Always `zstd`.
    pub compression: String,
    pub compressed_bytes: u64,
    pub uncompressed_bytes: u64,
    /// SHA-256 (hex) of the compressed payload bytes as stored in the file.
    pub sha256_compressed: String,
    /// SHA-256 (hex) of the uncompressed payload (the f32le array).
    pub sha256_uncompressed: String,
}
