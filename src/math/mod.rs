//! Numerical primitives with no physics in them, each once: interpolation and grid location,
//! quadrature rules, 3-vectors, a seeded pseudo-random generator. The table reader and every
//! layer above use them.

/// Interpolation and grid location, defined beside the table reader that uses them.
pub use scatterbake_table::interp;
pub mod quadrature;
pub mod rng;
pub mod vec3;
