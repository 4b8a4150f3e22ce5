//! Exports: files other programs read.

pub mod generic;
pub mod hair_engine_lut;
pub mod hair_lut;
pub mod legendre;
pub mod lut;
pub mod mieplot;
pub mod mitsuba;
