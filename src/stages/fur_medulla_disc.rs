//! The `characteristics` method of the `fur-medulla-azimuthal` stage (its default). One task per
//! σ computes every (g, h') row of that σ with [`crate::fur::disc::DiscSolver`]: one plane-wave
//! transport solution per (σ, g) gives every h' and every exit bin by reciprocity and rotational
//! symmetry; the grid of σ is built once and shared by all g, each g starting from the previous
//! one's solution. Rows are packed, mirrored and assembled by the Monte Carlo job's code, so the
//! table layout and conventions are identical; only the header attributes that describe the
//! method differ.

use super::job::MedullaJob;
use crate::fur::disc::{DiscSettings, DiscSolver};
use crate::fur::medulla::Profile;
use crate::fur::medulla_headers::characteristics_attributes;
use crate::stages::{Chunk, Job, JobError, TaskSpec, check_chunks};
use crate::table::TableContent;
use serde_json::json;

pub(super) struct DiscJob {
    inner: MedullaJob,
    settings: DiscSettings,
}

impl DiscJob {
    pub(super) fn new(inner: MedullaJob) -> Self {
        let settings = DiscSettings {
            bins: inner.layout.bins,
            ..DiscSettings::default()
        };
        DiscJob { inner, settings }
    }
}

impl Job for DiscJob {
    /// The table of the Monte Carlo job it replaces.
    fn shape(&self) -> crate::stages::PlannedShape {
        self.inner.shape()
    }
    fn estimated_cpu_seconds(&self) -> f64 {
        // One plane-wave solve per (σ, g), dearer with σ (more iterations).
        let l = &self.inner.layout;
        let solves: f64 = l.sigma.iter().map(|s| 1.0 + s).sum();
        crate::stages::cost::MEDULLA_DISC_SOLVE_CPU_S * solves * l.g.len() as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_MEDULLA_AZIMUTHAL
    }
    fn parameters(&self) -> serde_json::Value {
        self.inner.parameters()
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        self.inner
            .layout
            .sigma
            .iter()
            .map(|&sigma| TaskSpec {
                label: format!("sigma={sigma:.4} (all g)"),
                params: json!({ "sigma": sigma }),
            })
            .collect()
    }

    /// All g of one σ: the (σ, g) chunks of the Monte Carlo layout, g in grid order.
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let job = &self.inner.layout;
        let sigma = job.sigma[index];
        let bins = job.bins;
        let n = job.entries.len();
        let sources: Vec<usize> = (0..n).filter(|&i| job.mirror_source(i).is_none()).collect();
        let hs: Vec<f64> = sources.iter().map(|&i| job.entries[i]).collect();
        let mut solver = DiscSolver::new(sigma, &self.settings);
        let mut pairs = Vec::with_capacity(job.g.len());
        for &g in &job.g {
            let solved = solver.solve(g, &hs);
            let mut rows = vec![None; n];
            for (b, &i) in sources.iter().enumerate() {
                let scattered = solved.energy[b].iter().sum();
                let prof = Profile {
                    energy: solved.energy[b].clone(),
                    path_length: solved.path_length[b].clone(),
                    std_error: vec![0.0; bins],
                    ballistic: solved.ballistic[b],
                    ballistic_mc: solved.ballistic[b],
                    scattered,
                    scattered_std_error: 0.0,
                };
                rows[i] = Some(job.pack_row(sigma, &prof, Vec::new));
            }
            pairs.push(self.inner.chunk(&rows));
        }
        Ok(MedullaJob::join_pairs(pairs))
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let job = &self.inner;
        let l = &job.layout;
        let (ns, ng, (values, scalars)) = (l.sigma.len(), l.g.len(), l.pair_len());
        check_chunks(&chunks, ns, ng * values, ng * scalars)?;
        // Task order is σ-major with g inside, the (σ, g) order of the Monte Carlo job.
        let mut per_pair = Vec::with_capacity(ns * ng);
        for ch in chunks {
            per_pair.extend(job.split_pairs(ch));
        }
        let mut content = job.assemble(per_pair)?;
        characteristics_attributes(&self.settings, &mut content.attributes);
        Ok(content)
    }
}
