//! Registry of computation stages. Each stage lives in its own module; this file only lists
//! them.

pub mod water_index;

use crate::stage::Stage;

/// All stages known to this build, in the order `scatterbake stages` lists them.
pub fn registry() -> Vec<Box<dyn Stage>> {
    vec![
        Box::new(water_index::WaterIndexStage),
        Box::new(crate::hair::stage::HairDualStage),
        Box::new(crate::hair::stage::HairAzimuthalStage),
        Box::new(crate::mie::stage::MieStage),
        Box::new(crate::debye::stage::DebyeStage),
        Box::new(crate::fur::stage::FurMedullaAzimuthalStage),
        Box::new(crate::fur::stage::FurMedullaLongitudinalStage),
        Box::new(crate::raytrace::stage::RaytraceStage),
        Box::new(crate::fur::farfield_stage::FurFarFieldStage),
    ]
}

/// Look up a stage by manifest name.
pub fn find(name: &str) -> Option<Box<dyn Stage>> {
    registry().into_iter().find(|s| s.name() == name)
}
