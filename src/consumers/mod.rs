//! Consumers of phase-function tables: renderer exports (Mitsuba 3 `tabphase`, Legendre
//! moments, MiePlot-style text, an RGB lookup texture), a reference rainbow renderer and plots
//! (the C ABI for other languages is the `capi/` crate, `libscatterbake_table`; the Python
//! reader is `python/scatterbake_table.py`). Everything reads tables through the public reader API
//! ([`crate::table::Table::open`], [`crate::table::Table::sample`]) and the phase contract
//! (`docs/consumers.md`).
//!
//! CLI entry points (wired by `cli.rs`): [`mitsuba::MitsubaArgs`], [`legendre::LegendreArgs`],
//! [`mieplot::MiePlotArgs`], [`mieplot::ValidateArgs`], [`lut::LutArgs`], [`plot::PlotArgs`],
//! [`render::RenderRainbowArgs`], [`plot_raytrace::PlotRaytraceArgs`]. 2-D ray-traced tables
//! (`raytrace-phase-2d/1`) are read through [`phase2d`].

pub mod figure;
pub mod legendre;
pub mod lut;
pub mod mieplot;
pub mod mitsuba;
pub mod phase;
pub mod phase2d;
pub mod plot;
pub mod plot_raytrace;
pub mod previews;
pub mod render;
pub mod synthetic;
