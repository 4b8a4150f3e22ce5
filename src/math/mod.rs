//! Numerical primitives with no physics in them, each once: interpolation and grid location,
//! quadrature rules, 3-vectors, a seeded pseudo-random generator. The table reader and every
//! layer above use them.

pub mod interp;
pub mod quadrature;
pub mod rng;
pub mod vec3;
