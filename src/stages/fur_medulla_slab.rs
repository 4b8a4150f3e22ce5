//! The `adding-doubling` method of the `fur-medulla-longitudinal` stage. One task per g computes
//! every (σ, θ'_i) row of that g at once with [`crate::fur::slab::solve_slab`] (a uniform σ grid
//! costs one adding step per σ); the rows are packed, mirrored and assembled by the same code as
//! the Monte Carlo rows, so the table layout and conventions are identical. Only the header
//! attributes that describe the method differ.

use super::job::MedullaJob;
use crate::fur::medulla::Profile;
use crate::fur::medulla_headers::adding_doubling_attributes;
use crate::fur::slab::{SlabSettings, limit_shape, solve_slab};
use crate::stages::{Chunk, Job, JobError, TaskSpec, check_chunks};
use crate::table::TableContent;
use serde_json::json;

pub(super) struct SlabJob {
    inner: MedullaJob,
    settings: SlabSettings,
}

impl SlabJob {
    pub(super) fn new(inner: MedullaJob) -> Self {
        let settings = SlabSettings {
            bins: inner.layout.bins,
            ..SlabSettings::default()
        };
        SlabJob { inner, settings }
    }
}

impl Job for SlabJob {
    /// The table of the Monte Carlo job it replaces.
    fn shape(&self) -> crate::stages::PlannedShape {
        self.inner.shape()
    }
    fn estimated_cpu_seconds(&self) -> f64 {
        // One adding–doubling solve per g for every σ and θ'_i.
        let l = &self.inner.layout;
        let cells = l.g.len() * l.sigma.len() * l.entries.len();
        crate::stages::cost::MEDULLA_SLAB_SOLVE_CPU_S * cells as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_MEDULLA_LONGITUDINAL
    }
    fn parameters(&self) -> serde_json::Value {
        self.inner.parameters()
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        self.inner
            .layout
            .g
            .iter()
            .map(|&g| TaskSpec {
                label: format!("g={g:.4} (all σ)"),
                params: json!({ "g": g }),
            })
            .collect()
    }

    /// All σ of one g: the (σ, g) chunks of the Monte Carlo layout, σ ascending in grid order.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let job = &self.inner.layout;
        let g = job.g[index];
        let bins = job.bins;
        let n = job.entries.len();
        let sources: Vec<usize> = (0..n).filter(|&i| job.mirror_source(i).is_none()).collect();
        let theta: Vec<f64> = sources
            .iter()
            .map(|&i| job.entries[i].to_radians())
            .collect();
        let solved = solve_slab(g, &job.sigma, &theta, &self.settings);
        let mut pairs = Vec::with_capacity(job.sigma.len());
        for (si, &sigma) in job.sigma.iter().enumerate() {
            let mut rows = vec![None; n];
            for (b, &i) in sources.iter().enumerate() {
                let s = &solved[si][b];
                let prof = Profile {
                    energy: s.energy.clone(),
                    path_length: s.path_length.clone(),
                    std_error: vec![0.0; bins],
                    ballistic: s.ballistic,
                    ballistic_mc: s.ballistic,
                    scattered: s.scattered,
                    scattered_std_error: 0.0,
                };
                rows[i] = Some(job.pack_row(sigma, &prof, || limit_shape(g, theta[b], bins)));
            }
            pairs.push(self.inner.chunk(&rows));
        }
        Ok(MedullaJob::join_pairs(pairs))
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let job = &self.inner;
        let l = &job.layout;
        let (ns, ng, (values, scalars)) = (l.sigma.len(), l.g.len(), l.pair_len());
        check_chunks(&chunks, ng, ns * values, ns * scalars)?;
        // Reorder into the (σ, g) task order of the Monte Carlo job, freeing each task's chunk
        // once split.
        let mut pieces: Vec<Vec<Chunk>> = Vec::with_capacity(ng);
        for ch in chunks {
            pieces.push(job.split_pairs(ch));
        }
        let mut per_pair = Vec::with_capacity(ns * ng);
        for si in 0..ns {
            for p in pieces.iter_mut() {
                per_pair.push(std::mem::take(&mut p[si]));
            }
        }
        drop(pieces);
        let mut content = job.assemble(per_pair)?;
        adding_doubling_attributes(&self.settings, &mut content.attributes);
        Ok(content)
    }
}
