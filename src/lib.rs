//! scatterbake: precomputed light-scattering tables for renderers.
//!
//! Architecture (one module per concept):
//! - [`table`]: the `.sbt` table file format (writer, reader, verifier, lookup API);
//! - [`optics`]: primitives shared by every stage (Fresnel, water index, colour, quadrature,
//!   interpolation);
//! - [`stage`]: the stage/job interface; [`stages`]: the registry of stages;
//! - [`manifest`], [`pipeline`], [`catalog`]: manifests → tasks → tables (I/O, rayon, resume);
//! - [`export`]: CSV/JSON/EXR exporters; [`cli`]: the command-line interface.

pub mod catalog;

pub mod consumers;
pub mod debye;
pub mod export;
pub mod fur;
pub mod hair;
pub mod manifest;
pub mod mie;
pub mod optics;
pub mod pipeline;
pub mod raytrace;
pub mod stage;
pub mod stages;
pub mod table;
