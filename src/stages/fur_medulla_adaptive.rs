//! The `adaptive` method of the `fur-medulla-azimuthal` stage: one task per (σ, g) as for the
//! fixed-photon Monte Carlo, each row by [`crate::fur::medulla_fast::simulate_adaptive`] (closed-
//! form single scattering, next-event Monte Carlo of the higher orders until `target_rel_error`
//! or the `photons` cap, batch error bars). Rows are packed and assembled by the Monte Carlo
//! job's code; each task's chunk carries three more numbers per entry (the fitted correlation
//! length of the bin errors, the photons used and the achieved worst relative error), stored as
//! header arrays.

use super::job::MedullaJob;
use crate::fur::medulla_fast::{AdaptiveSettings, simulate_adaptive};
use crate::fur::medulla_headers::adaptive_attributes;
use crate::stages::{Chunk, Job, JobError, TaskSpec, check_chunks};
use crate::table::TableContent;
use rayon::prelude::*;

/// Extra per-entry scalars of a task's chunk, after the Monte Carlo job's.
const EXTRA: usize = 3;

pub(super) struct AdaptiveJob {
    inner: MedullaJob,
}

impl AdaptiveJob {
    pub(super) fn new(inner: MedullaJob) -> Self {
        AdaptiveJob { inner }
    }

    fn settings(&self) -> AdaptiveSettings {
        AdaptiveSettings {
            bins: self.inner.p.bins,
            seed: self.inner.p.seed,
            max_photons: self.inner.p.photons.unwrap_or(0),
            target_rel_error: self.inner.p.target_rel_error.unwrap_or(0.01),
            ..AdaptiveSettings::default()
        }
    }
}

impl Job for AdaptiveJob {
    /// The table of the Monte Carlo job it replaces.
    fn shape(&self) -> crate::stages::PlannedShape {
        self.inner.shape()
    }
    fn estimated_cpu_seconds(&self) -> f64 {
        // At most `photons` next-event histories per entry; cheaper than analog ones.
        crate::stages::cost::MEDULLA_ADAPTIVE_COST_FACTOR * self.inner.estimated_cpu_seconds()
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_MEDULLA_ADAPTIVE
    }
    fn parameters(&self) -> serde_json::Value {
        self.inner.parameters()
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        self.inner.tasks()
    }

    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let job = &self.inner.layout;
        let sigma = job.sigma[index / job.g.len()];
        let g = job.g[index % job.g.len()];
        let n = job.entries.len();
        let s = self.settings();
        type Row = ((Vec<f32>, Vec<f32>), [f32; EXTRA]);
        let rows: Vec<Option<Row>> = (0..n)
            .into_par_iter()
            .map(|i| {
                job.mirror_source(i).is_none().then(|| {
                    let a = simulate_adaptive(sigma, g, job.entries[i], &s);
                    let extra = [
                        a.correlation_length as f32,
                        a.photons as f32,
                        a.worst_rel_error as f32,
                    ];
                    (job.pack_row(sigma, &a.profile, Vec::new), extra)
                })
            })
            .collect();
        let packed: Vec<Option<(Vec<f32>, Vec<f32>)>> = rows
            .iter()
            .map(|r| r.as_ref().map(|r| r.0.clone()))
            .collect();
        let mut out = self.inner.chunk(&packed);
        for i in 0..n {
            let src = job.mirror_source(i).unwrap_or(i);
            let extra = rows[src].as_ref().expect("source row computed").1;
            out.scalars.extend(extra.map(f64::from));
        }
        Ok(out)
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let layout = &self.inner.layout;
        let n = layout.entries.len();
        let mut extras: Vec<Vec<f64>> = vec![Vec::new(); EXTRA];
        let mut inner_chunks = Vec::with_capacity(chunks.len());
        let (values, scalars) = layout.pair_len();
        let tasks = layout.sigma.len() * layout.g.len();
        check_chunks(&chunks, tasks, values, scalars + n * EXTRA)?;
        for mut ch in chunks {
            let tail = ch.scalars.split_off(scalars);
            for e in tail.chunks(EXTRA) {
                for (j, v) in e.iter().enumerate() {
                    extras[j].push(*v);
                }
            }
            inner_chunks.push(ch);
        }
        let mut content = self.inner.assemble(inner_chunks)?;
        adaptive_attributes(&self.settings(), &extras, &mut content.attributes);
        Ok(content)
    }
}
