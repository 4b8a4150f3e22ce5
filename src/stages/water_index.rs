//! `water-index` stage: the refractive index of liquid water over wavelength × temperature,
//! from the IAPWS R9-97 formulation (see [`crate::optics::water`]). Small and exact; it also
//! serves as the reference table for the index used by the scattering stages.

use crate::optics::water::{WaterIndexModel, water_density_kell_kg_m3};
use crate::stages::{
    Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, check_chunks, concat_values, stage_params,
};
use crate::table::{Axis, Channel, Schema, TableContent};

/// The stage.
pub struct WaterIndexStage;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct WaterIndexParams {
        /// Wavelength range in nm: [start, stop, step].
        wavelength_nm: [f64; 3] = required, "[start, stop, step] float, nm",
            "wavelength grid, within 200–1100 nm (IAPWS R9-97 domain)";
        /// Temperatures in °C.
        temperature_c: Vec<f64> = required, "list of float, °C",
            "temperatures, strictly increasing, within 0–100 °C (liquid water at 1 atm)";
    }
}

impl StageSpec for WaterIndexStage {
    const NAME: &'static str = "water-index";
    const VERSION: u32 = 1;
    const SUMMARY: &'static str =
        "refractive index of liquid water (IAPWS R9-97) over wavelength × temperature";
    type Params = WaterIndexParams;
    fn plan_params(&self, p: WaterIndexParams) -> Result<Box<dyn Job>, PlanError> {
        let [start, stop, step] = p.wavelength_nm;
        if !(step > 0.0) || !(stop >= start) {
            return Err(PlanError::invalid(
                "wavelength_nm",
                "needs [start, stop, step] with step > 0 and stop >= start",
            ));
        }
        if start < 200.0 || stop > 1100.0 {
            return Err(PlanError::invalid(
                "wavelength_nm",
                format!("range {start}–{stop} nm leaves the IAPWS R9-97 domain 200–1100 nm"),
            ));
        }
        // Counted in f64 first: a tiny step must not overflow the integer count.
        let intervals = ((stop - start) / step + 1e-9).floor();
        if !(intervals < 1e6) {
            return Err(PlanError::invalid(
                "wavelength_nm",
                format!("step {step:?} nm gives more than 1e6 samples"),
            ));
        }
        let count = intervals as usize + 1;
        if p.temperature_c.is_empty() {
            return Err(PlanError::invalid("temperature_c", "must not be empty"));
        }
        if p.temperature_c.windows(2).any(|w| w[1] <= w[0]) {
            return Err(PlanError::invalid(
                "temperature_c",
                "must be strictly increasing",
            ));
        }
        if let Some(t) = p.temperature_c.iter().find(|t| !(0.0..=100.0).contains(*t)) {
            return Err(PlanError::invalid(
                "temperature_c",
                format!("{t} °C is outside 0–100 °C"),
            ));
        }
        Ok(Box::new(WaterIndexJob { p, count }))
    }
}

struct WaterIndexJob {
    p: WaterIndexParams,
    count: usize,
}

impl WaterIndexJob {
    fn wavelengths(&self) -> Vec<f64> {
        (0..self.count)
            .map(|i| self.p.wavelength_nm[0] + self.p.wavelength_nm[2] * i as f64)
            .collect()
    }
}

impl WaterIndexJob {
    /// Axes: temperature (°C) × vacuum wavelength (nm).
    fn table_axes(&self) -> Vec<Axis> {
        vec![
            Axis::values("temperature", "degC", self.p.temperature_c.clone()),
            Axis::uniform(
                "wavelength",
                "nm",
                self.p.wavelength_nm[0],
                self.p.wavelength_nm[2],
                self.count,
            ),
        ]
    }
}

impl Job for WaterIndexJob {
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.p
            .temperature_c
            .iter()
            .map(|t| TaskSpec {
                label: format!("T={t} °C"),
                params: serde_json::json!({ "temperature_c": t }),
            })
            .collect()
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let model = WaterIndexModel::Iapws1997 {
            temperature_c: self.p.temperature_c[index],
        };
        let values = self
            .wavelengths()
            .iter()
            .map(|&l| Ok(model.index(l)? as f32))
            .collect::<Result<_, JobError>>()?;
        Ok(Chunk::values(values))
    }
    /// Temperatures × wavelengths × one channel of f32.
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table_axes(), 1)
    }
    /// One IAPWS R9-97 evaluation per value (`cost::WATER_INDEX_VALUE_CPU_S`).
    fn estimated_cpu_seconds(&self) -> f64 {
        let values = (self.p.temperature_c.len() * self.count) as f64;
        crate::stages::cost::WATER_INDEX_VALUE_CPU_S * values
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_WATER_INDEX
    }
    /// The model's name and the density of water at each temperature.
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::ATTRIBUTE_BYTES_PER_SCALAR;
        400 + ATTRIBUTE_BYTES_PER_SCALAR * self.p.temperature_c.len() as u64
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        // chunks are per temperature; the table is temperature × wavelength.
        check_chunks(&chunks, self.p.temperature_c.len(), self.count, 0)?;
        let data = concat_values(chunks);
        let mut attributes = serde_json::Map::new();
        attributes.insert(
            "model".into(),
            "iapws1997 (IAPWS R9-97), liquid water at 1 atm".into(),
        );
        attributes.insert(
            "density".into(),
            "Kell (1975) polynomial of temperature".into(),
        );
        attributes.insert(
            "density_kg_m3".into(),
            self.p
                .temperature_c
                .iter()
                .map(|&t| water_density_kell_kg_m3(t))
                .collect::<Vec<_>>()
                .into(),
        );
        attributes.insert("outside_medium_index".into(), 1.0.into());
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("water-index", 1),
            description: "real refractive index of liquid water relative to vacuum".into(),
            axes: self.table_axes(),
            channels: vec![Channel::new(
                "n",
                "1",
                "real refractive index of water (vacuum wavelength axis)",
            )],
            attributes,
            data,
        })
    }
}
