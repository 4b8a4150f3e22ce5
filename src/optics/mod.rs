//! Optics primitives shared by every stage. Each primitive lives here exactly once.
//!
//! Conventions (shared by all of scatterbake, see `docs/conventions.md`):
//! - complex refractive index `m = n + i k`, `k >= 0` absorbing, time dependence `e^{-iωt}`
//!   (Bohren & Huffman);
//! - angles in radians in code, with `_rad`/`_deg` in names where confusion is possible;
//! - wavelengths in nanometres (`_nm`) at interfaces.

pub mod airy_function;
pub mod colour;
pub mod fresnel;
pub mod henyey_greenstein;
pub mod interp;
pub mod quadrature;
pub mod vec3;
pub mod water;
