//! scatterbake: precomputed light-scattering tables for renderers.
//!
//! The modules follow the data flow in layers. This table is the rule `tests/architecture`
//! enforces: a module imports only from its own layer and lower-numbered ones, and no file
//! imports itself through others (names not yet in the crate are skipped):
//!
//! | layer | modules | role |
//! |---|---|---|
//! | 0 | `math`, `error`, `progress`, `provenance` | numerical primitives (interpolation, quadrature, 3-vectors); error pieces every layer shares (I/O failures with their path, cause chains); progress reports; canonical JSON and content keys |
//! | 1 | `table` | the `.sbt` table file format (writer, reader, verifier, lookup API) |
//! | 2 | `optics` | optics primitives shared by every stage (Fresnel, water index, colour, Henyey–Greenstein, Airy function) |
//! | 3 | `mie`, `debye`, `raytrace`, `hair`, `fur`, `cloth`, `fixtures` | physics, pure and free of I/O: Lorenz–Mie, Debye series and Airy theory, patch-based wave-optics ray tracing of raindrops, fibre lobes and Dual Scattering, fur medulla transport and far field, cloth; synthetic tables with analytically known properties for tests (feature `fixtures`) |
//! | 4 | `stages`, `manifest`, `workdir`, `pipeline`, `plan`, `catalog` | manifest parameters → jobs of pure tasks → tables: I/O, parallelism, resume, progress |
//! | 5 | `consumers` | reading, exporting, plotting and rendering tables |
//!
//! Each layer has its own error type ([`table::TableError`], [`stages::PlanError`],
//! [`stages::JobError`], [`pipeline::PipelineError`], [`consumers::ConsumerError`], …) built on
//! the shared pieces of [`error`].
//!
//! The command line is a separate crate (`cli/`, binary `scatterbake`); this library never sees
//! its argument parser.

pub mod math;

pub mod error;
pub mod progress;
pub mod provenance;

/// The `.sbt` table file format: the crate `scatterbake-table` (`table-format/`).
pub use scatterbake_table as table;

pub mod optics;

pub mod cloth;
pub mod debye;
pub mod fur;
pub mod hair;
pub mod mie;
pub mod raytrace;

/// Synthetic tables with analytically known properties (tests, demos, other readers).
#[cfg(any(test, feature = "fixtures"))]
pub mod fixtures;

pub mod catalog;
pub mod manifest;
pub mod pipeline;
pub mod plan;
pub mod stages;
pub mod workdir;

pub mod consumers;
