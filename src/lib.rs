//! scatterbake: precomputed light-scattering tables for renderers.
//!
//! The modules follow the data flow; each depends only on those listed before it:
//! 0. [`math`]: numerical primitives (interpolation, quadrature, 3-vectors);
//!    [`error`]: error pieces every layer shares (I/O failures with their path, cause chains);
//!    each layer has its own error type ([`table::TableError`], [`stages::PlanError`],
//!    [`stages::JobError`], [`pipeline::PipelineError`], [`consumers::ConsumerError`], …);
//! 1. [`table`]: the `.sbt` table file format (writer, reader, verifier, lookup API);
//! 2. [`optics`]: optics primitives shared by every stage (Fresnel, water index, colour,
//!    Henyey–Greenstein, Airy function);
//! 3. physics, pure and free of I/O: [`mie`] (Lorenz–Mie), [`debye`] (Debye series, Airy
//!    theory), [`raytrace`] (patch-based wave-optics ray tracing of raindrops), [`hair`]
//!    (fibre lobes, Dual Scattering), [`fur`] (medulla transport, far field), [`cloth`]
//!    (microcylinder cloth model);
//! 4. [`stages`] (manifest parameters → jobs), [`manifest`], [`pipeline`] and [`catalog`]
//!    (manifests → tasks → tables: I/O, parallelism, resume, progress);
//! 5. [`consumers`]: reading, exporting, plotting and rendering tables.
//!
//! The command line is a separate crate (`cli/`, binary `scatterbake`); this library never sees
//! its argument parser.

pub mod math;

pub mod error;

pub mod table;

pub mod optics;

pub mod cloth;
pub mod debye;
pub mod fur;
pub mod hair;
pub mod mie;
pub mod raytrace;

pub mod catalog;
pub mod manifest;
pub mod pipeline;
pub mod stages;
pub mod workdir;

pub mod consumers;
