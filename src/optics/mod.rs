//! Optics primitives shared by every stage. Each primitive lives here exactly once (numerical
//! primitives without physics are in [`crate::math`]).
//!
//! Conventions (shared by all of scatterbake, see `docs/vocabulary.md`):
//! - complex refractive index `m = n + i k`, `k >= 0` absorbing, time dependence `e^{-iωt}`
//!   (Bohren & Huffman);
//! - angles in radians in code, with `_rad`/`_deg` in names where confusion is possible;
//! - wavelengths in nanometres (`_nm`) at interfaces.

pub mod airy_function;
pub mod atmosphere;
pub mod colour;
pub mod fresnel;
pub mod henyey_greenstein;
pub mod water;
