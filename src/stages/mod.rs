//! Computation stages: the adapters between manifests and the physics. A stage turns a
//! manifest entry's `[table.params]` into a [`Job`] (independent pure tasks plus an assemble
//! step); the pipeline runs jobs. Each stage lives in its own module; this file lists them.

pub mod cloth;
mod common;
pub mod cost;
pub mod debye;
pub mod fur_farfield;
pub mod fur_medulla;
pub mod hair;
pub mod mie;
pub mod mixture;
pub mod mixture_2d;
pub mod phase_contract;
pub mod raytrace;
mod stage;
pub mod water_index;

pub use stage::*;
pub(crate) use stage::{param_default_text, param_raw_type, param_value, stage_params};

/// All stages known to this build, in the order `scatterbake stages` lists them.
pub fn registry() -> Vec<Box<dyn Stage>> {
    vec![
        Box::new(water_index::WaterIndexStage),
        Box::new(crate::stages::hair::HairDualStage),
        Box::new(crate::stages::hair::HairAzimuthalStage),
        Box::new(crate::stages::mie::MieStage),
        Box::new(crate::stages::debye::DebyeStage),
        Box::new(crate::stages::fur_medulla::FurMedullaAzimuthalStage),
        Box::new(crate::stages::fur_medulla::FurMedullaLongitudinalStage),
        Box::new(crate::stages::raytrace::RaytraceStage),
        Box::new(crate::stages::mixture::MixtureStage),
        Box::new(crate::stages::mixture_2d::Mixture2dStage),
        Box::new(crate::stages::fur_farfield::FurFarFieldStage),
        Box::new(crate::stages::cloth::ClothStage),
    ]
}

/// Look up a stage by manifest name.
pub fn find(name: &str) -> Option<Box<dyn Stage>> {
    registry().into_iter().find(|s| s.name() == name)
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_registered_stage_documents_distinct_parameters() {
        for s in crate::stages::registry() {
            let docs = s.parameters();
            assert!(!docs.is_empty(), "{}", s.name());
            let mut names: Vec<&str> = docs.iter().map(|d| d.name).collect();
            names.sort_unstable();
            names.dedup();
            assert_eq!(names.len(), docs.len(), "{}: duplicate names", s.name());
        }
    }
}
