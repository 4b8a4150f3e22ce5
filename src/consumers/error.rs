//! The error type of every consumer.

use crate::error::IoError;
use crate::table::{SampleError, TableError};
use std::path::{Path, PathBuf};

/// Why reading, exporting, plotting or rendering a table failed.
#[derive(Debug, thiserror::Error)]
pub enum ConsumerError {
    /// An operator (sun disc) or axis selection the table cannot honour.
    #[error(transparent)]
    Operator(Box<crate::consumers::read::operators::OperatorError>),
    /// A table file that does not open or verify (the error names the file).
    #[error(transparent)]
    Table(#[from] TableError),
    /// A lookup in a table: unknown axis or channel, NaN coordinate, wrong arity.
    #[error(transparent)]
    Sample(#[from] SampleError),
    /// A table whose layout the consumer cannot use (schema, axes, channels or values).
    #[error("{0}")]
    Layout(String),
    /// An entry selection (`--entry NAME=VALUE`) naming an axis that is not an entry axis;
    /// `entry_axes` lists the entry axes with their ranges.
    #[error("`{axis}` is not an entry axis of this table (entry axes: {entry_axes}){hint}")]
    UnknownEntryAxis {
        axis: String,
        entry_axes: String,
        hint: String,
    },
    /// A requested coordinate outside the range a table covers.
    #[error("{what} {value} {unit} is outside the table's {axis} range [{lo}, {hi}] {unit}{note}")]
    OutOfRange {
        what: &'static str,
        axis: String,
        value: f64,
        lo: f64,
        hi: f64,
        unit: String,
        /// Appended explanation (may be empty).
        note: String,
    },
    /// Arguments or data a consumer cannot work with.
    #[error("{0}")]
    Invalid(String),
    /// A line of a text input (e.g. a MiePlot-style file) that does not parse.
    #[error("line {line}: {message}")]
    Parse {
        line: usize,
        message: &'static str,
        #[source]
        source: Option<std::num::ParseFloatError>,
    },
    /// A file or directory operation.
    #[error(transparent)]
    Io(#[from] IoError),
    /// Encoding a PNG image.
    #[error("encoding the PNG image {}", path.display())]
    Png {
        path: PathBuf,
        #[source]
        source: png::EncodingError,
    },
    /// Encoding or writing an OpenEXR image (`what` says which and where).
    #[error("{what}")]
    Exr {
        what: String,
        #[source]
        source: exr::error::Error,
    },
    /// Encoding JSON.
    #[error("encoding JSON")]
    Json(#[from] serde_json::Error),
    /// Drawing a figure (a `plotters` backend error).
    #[error("plotting failed")]
    Plot(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// An error about the table or output file `path`.
    #[error("{}", path.display())]
    InFile {
        path: PathBuf,
        #[source]
        source: Box<ConsumerError>,
    },
}

impl ConsumerError {
    /// [`ConsumerError::Layout`] with `message`.
    pub fn layout(message: impl Into<String>) -> Self {
        ConsumerError::Layout(message.into())
    }

    /// [`ConsumerError::Invalid`] with `message`.
    pub fn invalid(message: impl Into<String>) -> Self {
        ConsumerError::Invalid(message.into())
    }

    /// Open the table file `path` and check it with `check`; a failed check names the file.
    pub fn check_file<T>(
        path: &Path,
        check: impl FnOnce(crate::table::Table) -> Result<T, ConsumerError>,
    ) -> Result<T, ConsumerError> {
        check(crate::table::Table::open(path)?).map_err(|e| e.in_file(path))
    }

    /// This error, about the file `path`.
    pub fn in_file(self, path: &Path) -> Self {
        ConsumerError::InFile {
            path: path.to_path_buf(),
            source: Box::new(self),
        }
    }
}

impl From<crate::consumers::read::operators::OperatorError> for ConsumerError {
    fn from(e: crate::consumers::read::operators::OperatorError) -> Self {
        ConsumerError::Operator(Box::new(e))
    }
}
