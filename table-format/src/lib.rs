//! The scatterbake table file format (`.sbt`), versions 1.0, 2.0 and 3.0. Specification:
//! `docs/table-format.md`.
//!
//! A table is an N-D grid of f32 samples (row-major, axes in header order, channel index
//! innermost), described by a JSON header and stored as a zstd-compressed payload with SHA-256
//! checksums of the header and of the payload (compressed and uncompressed).
//!
//! Modules, each importing only those listed before it: [`interp`] (interpolation and grid
//! location), `model` (the header and table types), [`codec`] (how a payload stores its
//! values: f32, 16-bit codes, derived channels), `validate` (the axis rules both the writer
//! and the reader apply), `entry` (the samples and header of one entry), [`format`](mod@format) (bytes,
//! writing, errors), `frame` (the streaming check of a payload's zstd frame), [`read`] (reading
//! and verification, of a whole table or one entry), `sample` (lookups), [`tt`] (tensor-train
//! tables).

pub mod codec;
mod entry;
pub mod format;
mod frame;
pub mod interp;
mod model;
pub mod read;
mod sample;
pub mod tt;
mod validate;

pub use format::{
    FORMAT_MAJOR, FORMAT_MINOR, FileStamp, MAGIC, TableError, WrittenTable, open_regular,
    read_regular, write_table_atomic, write_table_atomic_sealed,
};
pub use model::{
    Axis, AxisPoints, Channel, Derived, EVEN_PERIODIC, Header, Layout, PayloadInfo, Predictor,
    PreviousRow, Provenance, Schema, Symmetry, Table, TableContent, ValueEncoding,
};
pub use read::{
    DEFAULT_MAX_PAYLOAD_BYTES, MAX_AXES, MAX_HEADER_BYTES, MAX_JSON_DEPTH, ReadLimits, ValueStats,
    Verified, read_header_only, verify_file, verify_sealed, verify_sealed_bytes,
    verify_sealed_stream,
};
pub use sample::SampleError;
