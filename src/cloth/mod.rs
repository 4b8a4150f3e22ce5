//! The microcylinder cloth model of Sadeghi, Bisker, De Deken & Jensen 2013 ("A Practical
//! Microcylinder Appearance Model for Cloth Rendering", ACM TOG 32(2)), as in chapter 5 and
//! Appendix E of Sadeghi's thesis (2011): pure physics, no I/O.
//!
//! - [`thread`]: the thread scattering function `f_s` (eqs. 5.6–5.11) in a thread's frame;
//! - [`curve`]: tangent curves (Table E.1), their arc-length quadrature and sampling;
//! - [`fabric`]: thread families, the six measured fabrics (Tables 5.2, E.1) and their
//!   symmetries;
//! - [`brdf`]: shadowing/masking, reweighting and the fabric BRDF (eqs. 5.12–5.20);
//! - [`half`]: the half-vector coordinates of the tables (projected half angles β_x, β_y);
//! - [`tabulate`]: the BRDF on the tables' grid, directional albedo and sampling CDFs;
//! - [`query`]: one checked evaluation at a direction pair in degrees and its record (the
//!   command line's JSON, the Python package's `cloth_brdf`).
//!
//! Conventions: cloth frame `n = +z`, warp (family 1) `+x`, weft `+y`; θ from the normal, φ from
//! `+x` toward `+y`; angles in radians in code (names end in `_rad`; `_deg` on table and command
//! line inputs); `ω_i` toward the light, `ω_r` toward the viewer; BRDF and `f_s` in sr⁻¹;
//! colours are linear RGB. Validated domain: θ_i, θ_r < 90° (the BRDF is finite on every
//! cell-centred grid); the model as printed is not energy conserving above θ_i ≈ 84° (see
//! `docs/cloth.md`). Decisions on the text's ambiguous points: CLOTH-1 … CLOTH-12 in
//! `docs/decisions.md`.

pub mod brdf;
pub mod curve;
pub mod fabric;
pub mod half;
pub mod query;
pub mod tabulate;
pub mod thread;

pub use brdf::{ClothModel, ClothValue, ModelOptions, direction};
pub use fabric::{Fabric, PRESET_NAMES, Symmetry, preset};
