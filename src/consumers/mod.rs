//! Consumers of tables, by what they do; dependencies point one way, from `read` outward:
//!
//! - [`read`]: phase-function tables through the phase contract (`docs/consumers.md`): 1-D
//!   curves per entry ([`read::phase`]), 2-D ray-traced tables ([`read::phase2d`]) and their
//!   colour under sunlight ([`read::spectrum`]);
//! - [`export`]: files other programs read — CSV/JSON/EXR of any table ([`export::generic`]),
//!   Mitsuba 3 `tabphase`, Legendre moments, MiePlot-style text, RGB lookup textures, hair LUTs;
//! - [`plot`]: figures of tables (phase functions, colour strips, Lee diagrams, heatmaps,
//!   previews per table family);
//! - [`render`]: a reference spectral renderer of rainbows in a rain volume;
//! - [`validate`]: a table against a reference curve, like with like (a point reference is
//!   taken through the table's own angular operators first);
//! - [`image`]: PNG writing shared by `plot` and `render`.
//!
//! Every consumer reports failures as a [`ConsumerError`].
//!
//! Everything reads tables through the public reader API ([`crate::table::Table::open`],
//! [`crate::table::Table::sample`]). The C ABI for other languages is the `capi/` crate and
//! the Python reader `python/scatterbake_table.py`.

mod error;
pub mod export;
pub mod image;
pub mod plot;
pub mod read;
pub mod render;
#[cfg(any(test, feature = "fixtures"))]
pub mod synthetic;
pub mod validate;

pub use error::ConsumerError;

/// Progress of a long consumer (a render, a Lee diagram): `start` with the number of units,
/// then `advance` as units finish, from any thread. The library draws nothing; the command line
/// shows a bar (quiet when stderr is not a terminal). [`Silent`] ignores everything.
pub trait Progress: Sync {
    /// `total` units of work described by `what` begin.
    fn start(&self, _total: u64, _what: &str) {}
    /// `n` more units are done.
    fn advance(&self, _n: u64) {}
}

/// A [`Progress`] that reports nothing.
pub struct Silent;

impl Progress for Silent {}
