//! Reading phase-function tables: the phase contract for 1-D tables, 2-D ray-traced tables,
//! the colour a phase function gives under sunlight, and what a table already applied
//! (sun disc, interpolable axes) so that consumers do not apply it again.

pub mod operators;
pub mod phase;
pub mod phase2d;
pub mod spectrum;
