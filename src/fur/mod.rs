//! Fur: medulla scattering tables of the coaxial-cylinder fur model (Tseng 2015; Yan et al.
//! 2015) and their compact low-rank form. Conventions: `docs/fur.md`;
//! decisions (FUR-n): `docs/decisions.md`.
//!
//! - [`medulla`]: 2-D volumetric Monte Carlo (planar Henyey–Greenstein, no absorption,
//!   index-matched boundary) for the azimuthal C^N and longitudinal C^M families, with a
//!   next-event (expected-value) estimator and a plain histogram estimator.
//! - [`farfield`]: far-field profiles of the practical shading model for the Table 4.2 samples.
//!
//! Their stages (`fur-medulla-azimuthal`, `fur-medulla-longitudinal`, `fur-farfield`) are
//! [`crate::stages::fur_medulla`] and [`crate::stages::fur_farfield`].
//! - [`tt`]: tensor-train (TT-SVD) compression and reconstruction of a table channel.

pub mod chief_ray;
pub mod farfield;
pub mod medulla;
pub mod rng;
pub mod tt;
