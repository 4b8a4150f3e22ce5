//! Numerical primitives with no physics in them, each once: quadrature rules, 3-vectors, a
//! seeded pseudo-random generator, bracketed Newton root finding. Interpolation and grid location are defined once, beside the
//! table reader that uses them: [`crate::table::interp`].

pub mod quadrature;
pub mod rng;
pub mod roots;
pub mod vec3;
