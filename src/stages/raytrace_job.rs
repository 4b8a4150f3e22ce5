//! The `raytrace` stage's job: one task per table entry (a sphere's (radius, wavelength), a
//! drop's (wavelength, sun elevation)), the cost estimates, the chunks (values, and for 2-D
//! entries the airy-local transfer weights and the compact form's scalars) and the checks of
//! each entry's integral before [`PhaseTable`] assembles the table.

use super::RaytraceJob;
use crate::raytrace::compact::{self, CompactEntry, SunDiscResampled};
use crate::raytrace::compact_table::CompactPart;
use crate::raytrace::phase_table::PhaseTable;
use crate::raytrace::shape::DropShape;
use crate::stages::cost::{
    RAYTRACE_2D_COMPACT_CPU_FACTOR, RAYTRACE_2D_COMPACT_POLAR_KNOTS, RAYTRACE_2D_COST,
    RAYTRACE_2D_SPHERE_CPU_S_PER_DIRECTION, SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH,
};
use crate::stages::phase_contract;
use crate::stages::{
    Chunk, ChunkPart, Job, JobError, PlannedShape, TaskSpec, check_chunk, check_chunks,
    check_phase_integral, concat_values,
};
use crate::table::TableContent;
use serde_json::{Map, Value};

impl Job for RaytraceJob {
    /// Known at plan time: tasks × (angles, or polar × azimuth directions) × channels.
    /// Compact tables: the dense grid as the upper bound of the knots chosen while the tasks
    /// run.
    fn shape(&self) -> PlannedShape {
        let channels = self.table.n_channels();
        if self.table.compact_spec().is_some() {
            return PlannedShape::adaptive(self.table.axes(), channels);
        }
        PlannedShape::new(self.table.axes(), channels)
    }
    /// Spheres: per task ∝ radius/λ (the internal grid's step is ≤ λ/(10a)); as a 2-D table
    /// also per direction of the dense grid. 2-D shapes
    /// (`RAYTRACE_2D_COST`): a set-up, then per task a part growing with the drop's size
    /// parameter, one per ray traced and one per direction computed.
    fn estimated_cpu_seconds(&self) -> f64 {
        let pairs = self.table.entries();
        if !self.table.two_d() {
            let size: f64 = pairs.iter().map(|&(a_um, l_nm)| a_um / l_nm).sum();
            return SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH * size;
        }
        let grid = self.table.direction_grid();
        if self.table.sphere_from_1d_path() {
            let directions = (grid.n_polar * grid.n_azimuth) as f64;
            let a_um = self.p.radii_um[0];
            return (pairs.iter())
                .map(|&(l_nm, _)| {
                    SPHERE_CPU_S_PER_RADIUS_OVER_WAVELENGTH * a_um / l_nm
                        + RAYTRACE_2D_SPHERE_CPU_S_PER_DIRECTION * directions
                })
                .sum();
        }
        let computed_azimuths = if self.p.mirror_half {
            grid.n_azimuth / 2 + 1
        } else {
            grid.n_azimuth
        };
        let rays = (self.p.rays * self.p.rays) as f64;
        let directions = (grid.n_polar * computed_azimuths) as f64;
        let [table, per_size, per_ray, per_direction] = RAYTRACE_2D_COST;
        let radius_mm = self.p.radii_um[0] / 1000.0;
        let per_task: f64 = (pairs.iter())
            .map(|&(l_nm, _)| {
                per_size * radius_mm * 550.0 / l_nm + per_ray * rays + per_direction * directions
            })
            .sum();
        let compact = if self.table.compact_spec().is_some() {
            RAYTRACE_2D_COMPACT_CPU_FACTOR
        } else {
            1.0
        };
        compact * (table + per_task)
    }
    /// Compact tables: of the dense grid's payload (the plan's upper bound).
    fn estimated_stored_fraction(&self) -> f64 {
        use crate::stages::cost::*;
        if let Some(spec) = self.table.compact_spec() {
            use compact::{ErrorNorm, StoredValues};
            let sphere = matches!(self.table.spec.shape, Some(DropShape::Sphere { .. }));
            let fewer_bits = compact::TOP16_MANTISSA_BITS.saturating_sub(spec.mantissa_bits);
            let bits = STORED_RATIO_TOP16_PER_MANTISSA_BIT.powi(fewer_bits as i32);
            return bits
                * match (sphere, spec.values, spec.norm) {
                    (true, StoredValues::F32, _) => STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE,
                    (true, StoredValues::Top16, _) => {
                        STORED_FRACTION_RAYTRACE_2D_COMPACT_SPHERE_TOP16
                    }
                    (false, StoredValues::F32, ErrorNorm::Max) => {
                        STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX
                    }
                    (false, StoredValues::F32, ErrorNorm::Rms) => {
                        STORED_FRACTION_RAYTRACE_2D_COMPACT_RMS
                    }
                    (false, StoredValues::Top16, ErrorNorm::Max) => {
                        STORED_FRACTION_RAYTRACE_2D_COMPACT_MAX_TOP16
                    }
                    (false, StoredValues::Top16, ErrorNorm::Rms) => {
                        STORED_FRACTION_RAYTRACE_2D_COMPACT_TOP16
                    }
                };
        }
        match (self.table.two_d(), self.p.diagnostic_channels) {
            (false, _) => STORED_FRACTION_RAYTRACE_SPHERE,
            (true, true) => STORED_FRACTION_RAYTRACE_2D_DIAGNOSTIC,
            (true, false) => STORED_FRACTION_RAYTRACE_2D,
        }
    }
    /// Per task: integrals, and for 2-D shapes the transfer weights of every azimuth column.
    /// Compact tables: the measured size of their attributes, which summarise the transfer
    /// weights instead ([`RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES`]).
    ///
    /// [`RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES`]: crate::stages::cost::RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::{
            ATTRIBUTE_BYTES, ATTRIBUTE_BYTES_PER_SCALAR, RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES,
        };
        if self.table.compact_spec().is_some() {
            return RAYTRACE_2D_COMPACT_ATTRIBUTE_BYTES;
        }
        let tasks = self.table.entries().len() as u64;
        let per_task = 1 + self.table.domain_values() as u64;
        ATTRIBUTE_BYTES + ATTRIBUTE_BYTES_PER_SCALAR * tasks * per_task
    }
    /// Compact tables list their knots: [`RAYTRACE_2D_COMPACT_POLAR_KNOTS`] per entry (at
    /// most the dense grid) spread over the dense polar grid, and the azimuth knots: 0° and
    /// 180° for a sphere, whose entry is the same at every azimuth (the 1-D path, decision
    /// RT-43; a sphere traced under the Gaussian model is flat within the tolerance at 3000²
    /// rays, 2–3 knots, and keeps more with few rays), and the whole stored half circle (or
    /// circle) for a drop (855–897 of 901 in the rainbow database).
    fn estimated_header_axes(&self) -> Option<Vec<crate::table::Axis>> {
        use crate::table::{Axis, Symmetry};
        self.table.compact_spec()?;
        let mut axes = self.table.axes();
        let subset = |axis: &Axis, indices: Vec<usize>| {
            let values = indices.into_iter().map(|i| axis.coord(i)).collect();
            Axis::values(&axis.name, &axis.unit, values)
        };
        let n_polar = axes[3].len();
        let knots = (RAYTRACE_2D_COMPACT_POLAR_KNOTS * self.table.entries().len()).min(n_polar);
        let spread = (0..knots)
            .map(|k| k * (n_polar - 1) / (knots - 1).max(1))
            .collect();
        axes[3] = subset(&axes[3], spread);
        let n_azimuth = axes[4].len();
        let sphere = matches!(self.table.spec.shape, Some(DropShape::Sphere { .. }));
        let mirror = self.table.compact_mirror();
        let stored = if mirror { n_azimuth / 2 + 1 } else { n_azimuth };
        let azimuth = if sphere {
            vec![0, stored - 1]
        } else {
            (0..stored).collect()
        };
        let azimuth = subset(&axes[4], azimuth);
        axes[4] = if mirror {
            azimuth.with_symmetry(Symmetry::EvenPeriodic { period: 360.0 })
        } else {
            azimuth
        };
        Some(axes)
    }
    fn parameters(&self) -> Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        let two_d = self.table.two_d();
        (self.table.entries().into_iter())
            .map(|(l, s)| {
                if two_d {
                    TaskSpec {
                        label: format!("λ={l} nm sun={s}°"),
                        params: serde_json::json!({"wavelength_nm": l, "sun_elevation_deg": s}),
                    }
                } else {
                    TaskSpec {
                        label: format!("a={l} µm λ={s} nm"),
                        params: serde_json::json!({"radius_um": l, "wavelength_nm": s}),
                    }
                }
            })
            .collect()
    }

    /// Spheres: the entry's values. 2-D shapes: the entry's values and, with airy-local, the
    /// transfer weights of its azimuth columns (`[primary, secondary]` per column), which
    /// `assemble` records in the header; compact tables: the compact entry, its dense bin-sum
    /// and its scalars before the weights.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (f, s) = self.table.entries()[index];
        if !self.table.two_d() {
            let values = self.table.sphere_entry(f, s, self.index(s)?);
            return Ok(Chunk::values(values));
        }
        let t = self.table.trace_entry(f, self.index(f)?, s);
        let weights = t.domain_weights.unwrap_or_default().into_iter().flatten();
        if let Some(spec) = self.table.compact_spec() {
            let (integral, entry) = self.compact_task(index, t.values, spec)?;
            let mut scalars = vec![integral];
            scalars.extend(entry.scalars());
            scalars.extend(weights);
            return Ok(Chunk::new(entry.values, scalars));
        }
        Ok(Chunk::new(t.values, weights.collect()))
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        if let Some(spec) = self.table.compact_spec() {
            return self.assemble_compact(chunks, spec);
        }
        let scalars = self.table.domain_values();
        check_chunks(
            &chunks,
            self.table.entries().len(),
            self.table.entry_len(),
            scalars,
        )?;
        let domain = (scalars > 0).then(|| {
            let weights: Vec<&[f64]> = chunks.iter().map(|c| c.scalars.as_slice()).collect();
            self.table.domain_attribute(&weights)
        });
        let mut t = self.assemble_values(chunks)?;
        if let Some(d) = domain {
            t.attributes.insert("airy_local_domain".into(), d);
        }
        Ok(t)
    }
}

impl RaytraceJob {
    /// The table from the tasks' chunks in task order (their scalars unused): what
    /// `mixture-2d` assembles per radius. Every entry's bin-sum over 4π is checked first.
    pub fn assemble_values(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let entry_len = self.table.entry_len();
        for (index, c) in chunks.iter().enumerate() {
            check_chunk(index, c, entry_len, c.scalars.len())?;
        }
        let data = concat_values(chunks);
        let integrals = self.table.entry_integrals(&data);
        for (e, &s) in integrals.iter().enumerate() {
            self.check_integral(e, s)?;
        }
        Ok(self
            .table
            .content(data, &integrals, self.contract_attributes()))
    }

    /// The phase-table contract's attributes, with the index this job used and the axes a
    /// consumer may interpolate along.
    fn contract_attributes(&self) -> Map<String, Value> {
        let normalisation = "integral over 4pi sr equals 1";
        let mut at = phase_contract::attributes(normalisation, &self.model, 0.0);
        if let Some(n) = self.fixed_index {
            at.insert("water_index_model".into(), "none".into());
            at.remove("temperature_c");
            at.insert("refractive_index_real".into(), n.into());
        }
        let interpolable = self.table.interpolable_axes();
        at.insert(
            phase_contract::INTERPOLABLE_AXES.into(),
            interpolable.into(),
        );
        at
    }

    /// Entry `e`'s bin-sum `s` of phase over 4π is plausible (a 2-D entry, which is divided
    /// by it, also positive and finite, decision RT-21).
    fn check_integral(&self, e: usize, s: f64) -> Result<(), JobError> {
        if self.table.two_d() && !(s > 0.0 && s.is_finite()) {
            return Err(JobError::NotNormalisable {
                entry: e,
                integral: s,
            });
        }
        check_phase_integral(e, s)
    }

    /// Task `index`'s entry renormalised, seen through the sun's disc and compacted; its
    /// bin-sum before renormalisation. Refused when the measured error exceeds the tolerance.
    fn compact_task(
        &self,
        index: usize,
        values: Vec<f32>,
        spec: SunDiscResampled,
    ) -> Result<(f64, CompactEntry), JobError> {
        let integral = self.table.entry_integral(&values);
        self.check_integral(index, integral)?;
        let entry = self.table.compact_entry(values, integral, &spec);
        let measured = compact::entry_error(&entry.errors, spec.norm);
        if !(measured <= spec.tolerance) {
            return Err(JobError::CompressionTolerance {
                entry: index,
                measured,
                tolerance: spec.tolerance,
            });
        }
        Ok((integral, entry))
    }

    /// The compact table from the tasks' chunks: each chunk's dense bin-sum, compact entry
    /// and transfer weights, checked and handed to [`PhaseTable::compact_content`].
    fn assemble_compact(
        &self,
        chunks: Vec<Chunk>,
        spec: SunDiscResampled,
    ) -> Result<TableContent, JobError> {
        let tasks = self.table.entries().len();
        if chunks.len() != tasks {
            return Err(JobError::ChunkCount {
                expected: tasks,
                got: chunks.len(),
            });
        }
        let table: &PhaseTable = &self.table;
        let (grid, domain) = (table.direction_grid(), table.domain_values());
        let mut parts = Vec::with_capacity(tasks);
        for (index, c) in chunks.into_iter().enumerate() {
            let bad = |got: usize| JobError::ChunkLength {
                index,
                part: ChunkPart::Scalars,
                got,
                expected: 1 + 2 + 2 * compact::ERROR_WINDOWS.len() + domain,
            };
            let n = c.scalars.len();
            let (Some(&integral), Some(rest)) = (c.scalars.first(), c.scalars.get(1..)) else {
                return Err(bad(n));
            };
            let Some((entry, rest)) =
                CompactEntry::from_parts(rest, c.values, grid, table.compact_mirror())
            else {
                return Err(bad(n));
            };
            if rest.len() != domain {
                return Err(bad(n));
            }
            parts.push(CompactPart {
                integral,
                entry,
                domain_weights: rest.to_vec(),
            });
        }
        Ok(table.compact_content(parts, spec, self.contract_attributes()))
    }
}
