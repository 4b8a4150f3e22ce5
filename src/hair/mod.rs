//! Hair fibre scattering tables: single-scattering lobes of a dielectric fibre and the Dual
//! Scattering averages (Zinke et al. 2008) for the physically based and the artist-friendly
//! (Sadeghi et al. 2010) fibre models. Conventions, validated domain and accuracy:
//! `docs/hair.md`; decisions on points the sources leave open (labels FIB-n, DS-n):
//! `docs/decisions.md`.
//!
//! - [`fiber`]: smooth/rough dielectric cylinder, Bravais indices, Fresnel, absorption, `N_p`;
//! - [`longitudinal`]: longitudinal lobes `M_p` and their energy normalisation;
//! - [`diffuse`]: the two diffuse `k_d` terms (Lambertian cylinder, higher-order constant);
//! - [`elliptic`]: elliptic cross-sections (axis ratio, Marschner's effective TRT index η*);
//! - [`dual`]: Dual Scattering averages and closed forms;
//! - [`artist`]: the artist-friendly model with the scalar normalisation of thesis eq. 4.17;
//! - [`melanin`]: eumelanin/pheomelanin concentration → `σ_a`;
//! - [`absorption`]: the absorption axis of the tables (LUT sweep, `σ_a` list, one colour);
//! - [`rows`]: the rows of the hair tables per light inclination;
//! - [`tables`], [`dual_table`], [`azimuthal_table`]: the `hair-dual` and `hair-azimuthal`
//!   tables as a whole (rows with their quadrature-doubling check, layout, header), computed
//!   row by row by the stages or at once ([`tables::ThetaRowTable::compute`]);
//! - [`shading`]: the shading-time half of Dual Scattering (T_f, σ̄_f², f_back, f_s^scatter, F)
//!   as a reference to port;
//!
//! The `hair-azimuthal` and `hair-dual` stages ([`crate::stages::hair`]) check manifest
//! parameters and run the rows as tasks; the EXR LUT and JSON exports are
//! [`crate::consumers::export::hair_lut`].

pub mod absorption;
pub mod artist;
pub mod azimuthal_table;
pub mod diffuse;
pub mod dual;
pub mod dual_table;
pub mod elliptic;
pub mod fiber;
pub mod longitudinal;
pub mod melanin;
pub mod rows;
pub mod shading;
pub mod tables;
