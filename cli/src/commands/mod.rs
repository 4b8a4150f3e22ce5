//! One module per subcommand, named after it; each holds the clap argument struct and the glue
//! that calls the library. Options shared by several commands are in `crate::args`, the printed
//! curves of `mie` and `airy` in `crate::curve`.

pub mod airy;
pub mod build;
pub mod catalog;
pub mod cloth;
pub mod cloth_lut;
pub mod dual_scattering;
pub mod export;
pub mod hair_lut;
pub mod inspect;
pub mod medulla;
pub mod medulla_assets;
pub mod mie;
pub mod plot;
pub mod plot_raytrace;
pub mod raytrace;
pub mod render;
pub mod stages;
pub mod validate;
pub mod verify;
