//! The parameter types of the fur medulla stages and the fixed-photon Monte Carlo job, whose
//! task grid (one task per (σ, g)) and chunks the other methods' jobs share. Rows are packed,
//! mirrored and laid out by [`crate::fur::medulla_table`]; the stage module plans.

use crate::fur::medulla::{Estimator, McSettings};
use crate::fur::medulla_headers::{MonteCarloRun, monte_carlo_attributes};
use crate::fur::medulla_table::{MedullaLayout, PackedRow};
use crate::stages::{Chunk, Job, JobError, TaskSpec, check_chunks, concat_values, stage_params};
use crate::table::TableContent;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;

/// A 1-D grid: an explicit increasing list, or `{ start, stop, count }` with both endpoints
/// included (`centred = true`: `count` cell centres of [start, stop] instead).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Grid {
    List(Vec<f64>),
    Range {
        start: f64,
        stop: f64,
        count: usize,
        #[serde(default)]
        centred: bool,
    },
}

impl Grid {
    pub fn points(&self) -> Vec<f64> {
        match self {
            Grid::List(v) => v.clone(),
            &Grid::Range {
                start,
                stop,
                count,
                centred,
            } => {
                if centred {
                    let step = (stop - start) / count as f64;
                    (0..count)
                        .map(|i| start + (i as f64 + 0.5) * step)
                        .collect()
                } else if count == 1 {
                    vec![start]
                } else {
                    let step = (stop - start) / (count - 1) as f64;
                    (0..count)
                        .map(|i| {
                            if i + 1 == count {
                                stop
                            } else {
                                start + i as f64 * step
                            }
                        })
                        .collect()
                }
            }
        }
    }
}

stage_params! {
    /// Parameters shared by both stages.
    pub struct MedullaParams {
        /// Scattering coefficient per unit medulla radius (dimensionless).
        pub sigma: Grid = required, "list of float | {start, stop, count[, centred]}",
            "scattering coefficient per unit MEDULLA radius (dimensionless; azimuthal disc radius 1, slab half-thickness 1), 0–200; ranges include both endpoints";
        /// Planar HG anisotropy.
        pub g: Grid = required, "list of float | {start, stop, count}",
            "planar Henyey–Greenstein anisotropy, 0 ≤ g ≤ 0.95";
        /// Entry offsets h' ∈ [−1, 1] (azimuthal only).
        #[serde(skip_serializing_if = "Option::is_none")]
        pub h: Option<Grid> = optional("required"), "list of float | {start, stop, count}",
            "entry offset h' on the unit medulla circle, −1 ≤ h' ≤ 1";
        /// Entry inclinations θ'_i in degrees, in (−90, 90) (longitudinal only).
        #[serde(skip_serializing_if = "Option::is_none")]
        pub theta_i_deg: Option<Grid> = optional("required"),
            "list of float | {start, stop, count, centred}",
            "entry inclination θ'_i in degrees, strictly inside (−90, 90)";
        pub bins: usize = default(720), "integer",
            "exit bins, a multiple of 4: over [−π, π) (azimuthal), over both faces with bins/2 per lobe (longitudinal)";
        /// How the table is computed; `None` = the family's default (resolved in `plan`).
        #[serde(skip_serializing_if = "Option::is_none")]
        pub method: Option<Method> = optional("characteristics (azimuthal), adding-doubling (longitudinal)"), "string",
            "`monte-carlo` (fixed photons, both families), `adaptive` (azimuthal: closed-form single scattering, next-event Monte Carlo of the higher orders until `target_rel_error`, batch error bars), `characteristics` (azimuthal: deterministic, one plane-wave transport solution per (σ, g) gives every h' by reciprocity) or `adding-doubling` (longitudinal: deterministic slab solver, all σ and θ'_i of one g at once)";
        /// Monte Carlo: paths per entry; adaptive: the cap per entry.
        #[serde(skip_serializing_if = "Option::is_none")]
        pub photons: Option<u64> = optional("required by monte-carlo and adaptive; rejected by the deterministic methods"), "integer",
            "monte-carlo: paths per entry; adaptive: the cap per entry";
        /// Adaptive only: target relative standard error.
        #[serde(skip_serializing_if = "Option::is_none")]
        pub target_rel_error: Option<f64> = optional("0.01 for adaptive"), "float",
            "adaptive only: stop an entry once every bin above 1e-3 of its maximum has this relative standard error";
        pub seed: u64 = default(0), "integer", "random seed (streams derived per entry; Monte Carlo methods)";
        pub estimator: Estimator = default(Estimator::Expected), "string",
            "monte-carlo only: `expected` (next-event, default) or `histogram`";
    }
}

/// How a table is computed (manifest key `method`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// 2-D Monte Carlo ([`crate::fur::medulla`]); both families; needs `photons`.
    MonteCarlo,
    /// Closed-form single scattering plus next-event Monte Carlo of the higher orders, run
    /// until `target_rel_error` or `photons` ([`crate::fur::medulla_fast`]); azimuthal only
    /// (the default there).
    Adaptive,
    /// Adding–doubling on the circle of directions ([`crate::fur::slab`]); longitudinal only,
    /// deterministic (the default there).
    AddingDoubling,
    /// Method of characteristics for one plane-wave problem per (σ, g), every h' by
    /// reciprocity ([`crate::fur::disc`]); azimuthal only, deterministic (the default there).
    Characteristics,
}

pub(super) use crate::fur::medulla_table::Family;

/// A planned medulla table: its parameters and its grid.
pub(super) struct MedullaJob {
    pub(super) p: MedullaParams,
    pub(super) layout: MedullaLayout,
}

impl MedullaJob {
    /// One (σ, g) pair's chunk from its entry rows (see [`MedullaLayout::pair`]).
    pub(super) fn chunk(&self, rows: &[Option<PackedRow>]) -> Chunk {
        let (values, scalars) = self.layout.pair(rows);
        Chunk::new(values, scalars)
    }

    /// The (σ, g) chunks of a chunk of several (as the deterministic methods compute them),
    /// in order.
    pub(super) fn split_pairs(&self, chunk: Chunk) -> Vec<Chunk> {
        let (values, scalars) = self.layout.pair_len();
        chunk
            .values
            .chunks(values)
            .zip(chunk.scalars.chunks(scalars))
            .map(|(v, s)| Chunk::new(v.to_vec(), s.to_vec()))
            .collect()
    }

    /// Several (σ, g) chunks as one, in order.
    pub(super) fn join_pairs(pairs: Vec<Chunk>) -> Chunk {
        let mut out = Chunk::default();
        for c in pairs {
            out.values.extend(c.values);
            out.scalars.extend(c.scalars);
        }
        out
    }

    fn settings(&self) -> McSettings {
        McSettings {
            photons: self.p.photons.unwrap_or(0),
            seed: self.p.seed,
            estimator: self.p.estimator,
            bins: self.p.bins,
            max_order: None,
        }
    }
}

impl Job for MedullaJob {
    /// Known at plan time: σ × g × entries × bins × channels.
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.layout.axes(), self.layout.channels())
    }
    /// Photon histories: `photons` per entry of every (σ, g), each costing more with σ (more
    /// scattering events), `cost::MEDULLA_PHOTON_CPU_S · (1 + σ)`.
    fn estimated_cpu_seconds(&self) -> f64 {
        let l = &self.layout;
        let photons = self.p.photons.unwrap_or(0) as f64 * l.entries.len() as f64;
        let per_g: f64 = l.sigma.iter().map(|s| 1.0 + s).sum();
        crate::stages::cost::MEDULLA_PHOTON_CPU_S * photons * per_g * l.g.len() as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        match self.layout.family {
            Family::Azimuthal => crate::stages::cost::STORED_FRACTION_MEDULLA_AZIMUTHAL_MC,
            Family::Longitudinal => crate::stages::cost::STORED_FRACTION_MEDULLA_LONGITUDINAL_MC,
        }
    }
    /// Per (σ, g, entry) Monte Carlo statistics in the header.
    fn estimated_attribute_bytes(&self) -> u64 {
        let l = &self.layout;
        let entries = (l.sigma.len() * l.g.len() * l.entries.len()) as u64;
        crate::stages::cost::ATTRIBUTE_BYTES
            + crate::stages::cost::MEDULLA_ATTRIBUTE_BYTES_PER_ENTRY * entries
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        let mut t = Vec::new();
        for &s in &self.layout.sigma {
            for &g in &self.layout.g {
                t.push(TaskSpec {
                    label: format!("σ={s:.4} g={g:.4}"),
                    params: json!({ "sigma": s, "g": g }),
                });
            }
        }
        t
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let l = &self.layout;
        let sigma = l.sigma[index / l.g.len()];
        let g = l.g[index % l.g.len()];
        let s = self.settings();
        let rows: Vec<Option<PackedRow>> = (0..l.entries.len())
            .into_par_iter()
            .map(|i| match l.mirror_source(i) {
                Some(_) => None,
                None => Some(l.monte_carlo_row(sigma, g, l.entries[i], &s)),
            })
            .collect();
        Ok(self.chunk(&rows))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let l = &self.layout;
        let (ns, n) = (l.scalars(), l.entries.len());
        let (row_len, scalar_len) = l.pair_len();
        check_chunks(&chunks, l.sigma.len() * l.g.len(), row_len, scalar_len)?;
        let mut scal: Vec<Vec<f64>> = vec![Vec::new(); ns];
        for ch in &chunks {
            for i in 0..n {
                for (j, s) in scal.iter_mut().enumerate() {
                    s.push(ch.scalars[i * ns + j]);
                }
            }
        }
        let run = MonteCarloRun {
            photons: self.p.photons,
            seed: self.p.seed,
            estimator: self.p.estimator,
        };
        let attributes = monte_carlo_attributes(&run, &scal, 360.0 / l.bins as f64)?;
        Ok(l.content(concat_values(chunks), &scal, attributes))
    }
}
