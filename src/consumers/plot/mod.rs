//! Figures of tables (`scatterbake plot`, `plot-raytrace`, and the previews of a build).

pub mod cloth;
pub mod figure;
pub mod previews;
pub mod raytrace;
pub mod style;
pub mod tables;
pub mod view;
