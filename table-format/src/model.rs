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
#[serde(try_from = "AxisJson")]
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
    /// Format 3.0: the tabulated function is even and periodic along this axis, which stores
    /// only 0 … period/2; lookups fold their coordinate into it ([`Axis::fold`];
    /// `docs/table-format.md`, "Symmetric axes"). Absent from the header when `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub symmetry: Option<Symmetry>,
}

/// `kind` of an even, periodic axis.
pub const EVEN_PERIODIC: &str = "even-periodic";

/// The symmetry of the function tabulated along an axis (`axes[].symmetry`, format 3.0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Symmetry {
    /// f(x + period) = f(x) and f(−x) = f(x): the axis stores coordinates from exactly 0 to
    /// exactly period/2, e.g. the outgoing azimuth of a drop mirror symmetric about the plane
    /// of the sun and its axis (period 360°).
    EvenPeriodic { period: f64 },
}

impl Symmetry {
    /// The period.
    pub fn period(&self) -> f64 {
        match *self {
            Symmetry::EvenPeriodic { period } => period,
        }
    }

    /// The coordinate in the stored half that `x` stands for: `r = fmod(|x|, P)` (exact in
    /// binary64), then `P − r` when `r > P/2`. Every reader computes these same bits; an
    /// infinite `x` gives NaN.
    pub fn fold(&self, x: f64) -> f64 {
        let period = self.period();
        let r = x.abs() % period;
        if r > 0.5 * period { period - r } else { r }
    }
}

/// `axes[].symmetry` as the header holds it, before its kind is checked.
#[derive(Deserialize)]
struct SymmetryJson {
    kind: String,
    period: f64,
}

/// An axis as the header holds it: the typed [`Axis`] once the symmetry rules hold.
#[derive(Deserialize)]
struct AxisJson {
    name: String,
    unit: String,
    points: AxisPoints,
    #[serde(default)]
    labels: Vec<String>,
    #[serde(default)]
    symmetry: Option<SymmetryJson>,
}

impl TryFrom<AxisJson> for Axis {
    type Error = String;
    fn try_from(a: AxisJson) -> Result<Self, String> {
        let symmetry = match a.symmetry {
            None => None,
            Some(s) if s.kind == EVEN_PERIODIC => Some(Symmetry::EvenPeriodic { period: s.period }),
            Some(s) => {
                return Err(format!(
                    "axis `{}`: symmetry.kind `{}` is not `{EVEN_PERIODIC}`",
                    a.name, s.kind
                ));
            }
        };
        let axis = Axis {
            name: a.name,
            unit: a.unit,
            points: a.points,
            labels: a.labels,
            symmetry,
        };
        crate::validate::check_symmetry(&axis)?;
        Ok(axis)
    }
}

impl Axis {
    /// Axis with explicit values.
    pub fn values(name: &str, unit: &str, values: Vec<f64>) -> Self {
        Axis {
            name: name.into(),
            unit: unit.into(),
            points: AxisPoints::Values(values),
            labels: Vec::new(),
            symmetry: None,
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
            symmetry: None,
        }
    }
    /// The axis with `symmetry` (format 3.0: a table with a symmetric axis is written as 3.0).
    pub fn with_symmetry(self, symmetry: Symmetry) -> Self {
        Axis {
            symmetry: Some(symmetry),
            ..self
        }
    }
    /// The coordinate a lookup uses for `x`: [`Symmetry::fold`] on a symmetric axis, `x`
    /// itself on any other.
    pub fn fold(&self, x: f64) -> f64 {
        self.symmetry.map_or(x, |s| s.fold(x))
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
    /// Format 2.0: the channel is not stored but computed from two stored channels
    /// (`docs/table-format.md`, "Derived channels"). Absent from the header when `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub derived: Option<Derived>,
}

/// How a derived channel is computed: `op` (`mean` or `normalized-difference`) of the stored
/// channels named in `of` (two names).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Derived {
    pub op: String,
    pub of: Vec<String>,
}

impl Channel {
    pub fn new(name: &str, unit: &str, meaning: &str) -> Self {
        Channel {
            name: name.into(),
            unit: unit.into(),
            meaning: meaning.into(),
            derived: None,
        }
    }

    /// A channel computed by `op` (`mean`, `normalized-difference`) from the stored channels
    /// `a` and `b` (format 2.0).
    pub fn derived(name: &str, unit: &str, meaning: &str, op: &str, a: &str, b: &str) -> Self {
        Channel {
            derived: Some(Derived {
                op: op.into(),
                of: vec![a.into(), b.into()],
            }),
            ..Channel::new(name, unit, meaning)
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
    /// Row-major samples, axes in order, channel innermost; length = Π|axis| · |channels|
    /// (derived channels included: the writer recomputes them from the stored ones).
    pub data: Vec<f32>,
    /// How the payload stores the values (format 1.0 for [`ValueEncoding::F32`] without
    /// derived channels, else 2.0; 3.0 whenever an axis has a [`Symmetry`]).
    pub encoding: ValueEncoding,
}

/// How a payload stores the values of the stored channels (`docs/table-format.md`, "16-bit
/// values").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ValueEncoding {
    /// 32-bit floats, `layout.dtype = "f32le"`.
    #[default]
    F32,
    /// 16-bit codes of non-negative finite values (8 exponent and 8 mantissa bits,
    /// `layout.dtype = "f32-top16le"`), optionally each code stored as its difference to the
    /// code `stride` values earlier.
    Top16 { predictor: Option<PreviousRow> },
}

/// The `previous-row` predictor: within each block of `block` stored values, a value from the
/// `stride`-th on is stored as its code minus the code `stride` values earlier (mod 2^16).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PreviousRow {
    pub stride: u64,
    pub block: u64,
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
    /// `f32le`, or in format 2.0 `f32-top16le`.
    pub dtype: String,
    /// Shape: axis lengths, then the number of stored channels (those not derived).
    pub shape: Vec<usize>,
    /// Format 2.0: the predictor of a `f32-top16le` payload. Absent from the header when `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predictor: Option<Predictor>,
}

/// `layout.predictor`: `kind` (`previous-row`), `stride` and `block` in values.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Predictor {
    pub kind: String,
    pub stride: u64,
    pub block: u64,
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
    /// SHA-256 (hex) of the uncompressed payload (the f32le array, or the stored 16-bit codes).
    pub sha256_uncompressed: String,
}
