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
//! - [`image`]: PNG writing shared by `plot` and `render`;
//! - [`catalog_page`]: the browsable catalog `index.html` of a directory of tables.
//!
//! Every consumer reports failures as a [`ConsumerError`], and the long ones (a render, a Lee
//! diagram) their progress to a [`crate::progress::Progress`].
//!
//! Everything reads tables through the public reader API ([`crate::table::Table::open`],
//! [`crate::table::Table::sample`]). The C ABI for other languages is the `capi/` crate and
//! the Python reader `python/scatterbake_table.py`.

pub mod catalog_page;
mod error;
pub mod export;
pub mod image;
pub mod plot;
pub mod read;
pub mod render;
pub mod validate;

pub use error::ConsumerError;
