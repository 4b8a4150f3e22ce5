//! Fur: medulla scattering tables of the coaxial-cylinder fur model (Tseng 2015; Yan et al.
//! 2015) and their compact low-rank form. Conventions: `docs/fur.md`;
//! decisions (FUR-n): `docs/decisions.md`.
//!
//! - [`medulla`]: 2-D volumetric Monte Carlo (planar Henyey–Greenstein, no absorption,
//!   index-matched boundary) for the azimuthal C^N and longitudinal C^M families, with a
//!   next-event (expected-value) estimator and a plain histogram estimator.
//! - [`medulla_fast`]: adaptive C^N: closed-form single scattering, vectorised next-event
//!   Monte Carlo of the higher orders until a target error, batch-based error bars.
//! - [`slab`]: deterministic C^M by adding–doubling on the circle of directions (all θ'_i and
//!   all σ of one g at once, no noise).
//! - [`stage`]: the `fur-medulla-azimuthal` and `fur-medulla-longitudinal` stages.
//! - [`farfield`], [`farfield_stage`]: far-field profiles of the practical shading model for the
//!   Table 4.2 samples (stage `fur-farfield`).
//! - [`tt`]: tensor-train (TT-SVD) compression and reconstruction of a table channel.

pub mod chief_ray;
pub mod farfield;
pub mod medulla;
pub mod medulla_fast;
pub mod rng;
pub mod slab;
pub mod tt;
