//! Reading phase-function tables: the phase contract for 1-D tables, 2-D ray-traced tables,
//! and the colour a phase function gives under sunlight.

pub mod phase;
pub mod phase2d;
pub mod spectrum;
