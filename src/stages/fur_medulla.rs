//! Stages `fur-medulla-azimuthal` (C^N) and `fur-medulla-longitudinal` (C^M).
//!
//! Methods (manifest key `method`): `monte-carlo` (both families, [`crate::fur::medulla`]),
//! `adaptive` (azimuthal; `fur_medulla_adaptive.rs`), `characteristics` (azimuthal, the default
//! there; deterministic, `fur_medulla_disc.rs`) and `adding-doubling` (longitudinal, the default
//! there; deterministic, `fur_medulla_slab.rs`). All methods share
//! the row packing, mirroring and assembly below, so the layouts are identical.
//!
//! Monte Carlo: one task per (σ, g) pair: it computes every entry row (h' or θ'_i) of that pair, in
//! parallel over rows (each row has its own random stream derived from the seed and the entry
//! parameters, so results do not depend on thread count or sharding). When the entry grid is
//! mirror-symmetric, rows with a negative entry are the exact mirror of the positive row
//! (C^N(φ'; −h') = C^N(−φ'; h'), C^M(θ'_r; −θ'_i) = C^M(−θ'_r; θ'_i)); the symmetry itself is
//! tested on independent runs in [`crate::fur::medulla`].
//!
//! Table layouts (row-major, channel innermost):
//! - azimuthal `fur-medulla-azimuthal/1`: axes `sigma` × `g` × `h` × `phi` (bins),
//!   channels `energy`, `path_length`, `std_error`;
//! - longitudinal `fur-medulla-longitudinal/1`: axes `sigma` × `g` × `theta_i` × `lobe` (0 back,
//!   1 forward) × `theta_r` (bins/2), channels `pdf`, `cdf`, `energy`, `path_length`,
//!   `std_error`.
//!
//! Per-entry scalars (ballistic and scattered fractions, their standard errors, lobe energies)
//! are stored in the attributes as flat row-major arrays over (sigma, g, entry).

use crate::fur::medulla::{Estimator, Geometry, McSettings, Profile, normalise_lobes, simulate};
use crate::stages::{
    Chunk, Job, JobError, ParamDoc, PlanError, StageParams, StageSpec, TaskSpec, check_chunks,
    concat_values, stage_params,
};
use crate::table::{Axis, Channel, Schema, TableContent};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;

#[path = "fur_medulla_adaptive.rs"]
mod adaptive_job;
#[path = "fur_medulla_disc.rs"]
mod disc_job;
#[path = "fur_medulla_slab.rs"]
mod slab_job;

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

fn check_grid(
    key: &str,
    pts: &[f64],
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
) -> Result<(), PlanError> {
    if pts.is_empty() || pts.len() > 4096 {
        return Err(PlanError::invalid(key, "needs 1 to 4096 points"));
    }
    if pts.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PlanError::invalid(key, "must be strictly increasing"));
    }
    for &p in pts {
        let below = if lo_open { p <= lo } else { p < lo };
        let above = if hi_open { p >= hi } else { p > hi };
        if !p.is_finite() || below || above {
            return Err(PlanError::invalid(
                key,
                format!(
                    "value {p} outside the valid domain {}{lo}, {hi}{}",
                    if lo_open { "(" } else { "[" },
                    if hi_open { ")" } else { "]" }
                ),
            ));
        }
    }
    Ok(())
}

stage_params! {
    /// Parameters shared by both stages.
    pub struct MedullaParams {
        /// Scattering coefficient per unit medulla radius (dimensionless).
        sigma: Grid = required, "list of float | {start, stop, count[, centred]}",
            "scattering coefficient per unit MEDULLA radius (dimensionless; azimuthal disc radius 1, slab half-thickness 1), 0–200; ranges include both endpoints";
        /// Planar HG anisotropy.
        g: Grid = required, "list of float | {start, stop, count}",
            "planar Henyey–Greenstein anisotropy, 0 ≤ g ≤ 0.95";
        /// Entry offsets h' ∈ [−1, 1] (azimuthal only).
        #[serde(skip_serializing_if = "Option::is_none")]
        h: Option<Grid> = optional("required"), "list of float | {start, stop, count}",
            "entry offset h' on the unit medulla circle, −1 ≤ h' ≤ 1";
        /// Entry inclinations θ'_i in degrees, in (−90, 90) (longitudinal only).
        #[serde(skip_serializing_if = "Option::is_none")]
        theta_i_deg: Option<Grid> = optional("required"),
            "list of float | {start, stop, count, centred}",
            "entry inclination θ'_i in degrees, strictly inside (−90, 90)";
        bins: usize = default(720), "integer",
            "exit bins, a multiple of 4: over [−π, π) (azimuthal), over both faces with bins/2 per lobe (longitudinal)";
        /// How the table is computed; `None` = the family's default (resolved in `plan`).
        #[serde(skip_serializing_if = "Option::is_none")]
        method: Option<Method> = optional("characteristics (azimuthal), adding-doubling (longitudinal)"), "string",
            "`monte-carlo` (fixed photons, both families), `adaptive` (azimuthal: closed-form single scattering, next-event Monte Carlo of the higher orders until `target_rel_error`, batch error bars), `characteristics` (azimuthal: deterministic, one plane-wave transport solution per (σ, g) gives every h' by reciprocity) or `adding-doubling` (longitudinal: deterministic slab solver, all σ and θ'_i of one g at once)";
        /// Monte Carlo: paths per entry; adaptive: the cap per entry.
        #[serde(skip_serializing_if = "Option::is_none")]
        photons: Option<u64> = optional("required by monte-carlo and adaptive; rejected by the deterministic methods"), "integer",
            "monte-carlo: paths per entry; adaptive: the cap per entry";
        /// Adaptive only: target relative standard error.
        #[serde(skip_serializing_if = "Option::is_none")]
        target_rel_error: Option<f64> = optional("0.01 for adaptive"), "float",
            "adaptive only: stop an entry once every bin above 1e-3 of its maximum has this relative standard error";
        seed: u64 = default(0), "integer", "random seed (streams derived per entry; Monte Carlo methods)";
        estimator: Estimator = default(Estimator::Expected), "string",
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

/// The entry parameter a family does not take (left out of its documentation).
fn foreign_entry_key(family: Family) -> &'static str {
    match family {
        Family::Azimuthal => "theta_i_deg",
        Family::Longitudinal => "h",
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Family {
    Azimuthal,
    Longitudinal,
}

/// Stage for the azimuthal family C^N(φ'; h', σ, g).
pub struct FurMedullaAzimuthalStage;
/// Stage for the longitudinal family C^M(θ'_r; θ'_i, σ, g).
pub struct FurMedullaLongitudinalStage;

/// The method of a plan (explicit, or the family's default) after checking it against the
/// family and its own settings; sets `p.method` and the adaptive method's default target.
fn checked_method(family: Family, p: &mut MedullaParams) -> Result<Method, PlanError> {
    let method = match (family, p.method) {
        (Family::Azimuthal, Some(Method::AddingDoubling)) => {
            return Err(PlanError::invalid(
                "method",
                "adding-doubling is a slab solver: longitudinal stage only",
            ));
        }
        (Family::Longitudinal, Some(Method::Adaptive)) => {
            return Err(PlanError::invalid(
                "method",
                "adaptive is the disc estimator: azimuthal stage only",
            ));
        }
        (Family::Longitudinal, Some(Method::Characteristics)) => {
            return Err(PlanError::invalid(
                "method",
                "characteristics is the disc solver: azimuthal stage only",
            ));
        }
        (Family::Azimuthal, m) => m.unwrap_or(Method::Characteristics),
        (Family::Longitudinal, m) => m.unwrap_or(Method::AddingDoubling),
    };
    p.method = Some(method);
    match (method, p.target_rel_error) {
        (Method::Adaptive, None) => p.target_rel_error = Some(0.01),
        (Method::Adaptive, Some(t)) if !(t > 0.0 && t < 1.0) => {
            return Err(PlanError::invalid("target_rel_error", "must be in (0, 1)"));
        }
        (Method::Adaptive, Some(_)) | (_, None) => {}
        (_, Some(_)) => {
            return Err(PlanError::invalid(
                "target_rel_error",
                "only for method = \"adaptive\"",
            ));
        }
    }
    Ok(method)
}

/// The entry axis of the family: h' (azimuthal) or θ'_i in degrees (longitudinal), checked.
fn entry_points(family: Family, p: &MedullaParams) -> Result<Vec<f64>, PlanError> {
    Ok(match family {
        Family::Azimuthal => {
            if p.theta_i_deg.is_some() {
                return Err(PlanError::invalid(
                    "theta_i_deg",
                    "belongs to the longitudinal stage",
                ));
            }
            let h =
                p.h.as_ref()
                    .ok_or_else(|| PlanError::invalid("h", "required"))?
                    .points();
            check_grid("h", &h, -1.0, 1.0, false, false)?;
            h
        }
        Family::Longitudinal => {
            if p.h.is_some() {
                return Err(PlanError::invalid("h", "belongs to the azimuthal stage"));
            }
            let t = p
                .theta_i_deg
                .as_ref()
                .ok_or_else(|| PlanError::invalid("theta_i_deg", "required"))?
                .points();
            check_grid("theta_i_deg", &t, -90.0, 90.0, true, true)?;
            t
        }
    })
}

fn plan(family: Family, mut p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
    let method = checked_method(family, &mut p)?;
    let sigma = p.sigma.points();
    let g = p.g.points();
    check_grid("sigma", &sigma, 0.0, 200.0, false, false)?;
    check_grid("g", &g, 0.0, 0.95, false, false)?;
    let entries = entry_points(family, &p)?;
    if p.bins < 8 || !p.bins.is_multiple_of(4) || p.bins > 36_000 {
        return Err(PlanError::invalid(
            "bins",
            "must be a multiple of 4 in 8..=36000",
        ));
    }
    if matches!(method, Method::AddingDoubling | Method::Characteristics) {
        if p.photons.is_some() {
            return Err(PlanError::invalid(
                "photons",
                "only for the Monte Carlo methods (monte-carlo, adaptive)",
            ));
        }
        let job = MedullaJob {
            family,
            p,
            sigma,
            g,
            entries,
        };
        return Ok(if method == Method::AddingDoubling {
            Box::new(slab_job::SlabJob::new(job))
        } else {
            Box::new(disc_job::DiscJob::new(job))
        });
    }
    match p.photons {
        None => {
            return Err(PlanError::invalid(
                "photons",
                "required by the Monte Carlo methods (monte-carlo, adaptive)",
            ));
        }
        Some(n) if n == 0 || n > 1_000_000_000 => {
            return Err(PlanError::invalid("photons", "must be in 1..=1e9"));
        }
        Some(_) => {}
    }
    let job = MedullaJob {
        family,
        p,
        sigma,
        g,
        entries,
    };
    if method == Method::Adaptive {
        return Ok(Box::new(adaptive_job::AdaptiveJob::new(job)));
    }
    Ok(Box::new(job))
}

/// The documentation of `MedullaParams` without the other family's entry key (and, for the
/// longitudinal family, without the adaptive method's key).
fn family_docs(family: Family) -> Vec<ParamDoc> {
    MedullaParams::docs()
        .into_iter()
        .filter(|d| d.name != foreign_entry_key(family))
        .filter(|d| !(family == Family::Longitudinal && d.name == "target_rel_error"))
        .collect()
}

impl StageSpec for FurMedullaAzimuthalStage {
    const NAME: &'static str = "fur-medulla-azimuthal";
    const VERSION: u32 = 4;
    const SUMMARY: &'static str = "fur medulla azimuthal scattering C^N(φ'; h', σ, g): 2-D transport in the unit disc (deterministic characteristics solver, adaptive or fixed-photon Monte Carlo)";
    type Params = MedullaParams;
    fn plan_params(&self, p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
        plan(Family::Azimuthal, p)
    }
    fn parameter_docs(&self) -> Vec<ParamDoc> {
        family_docs(Family::Azimuthal)
    }
}

impl StageSpec for FurMedullaLongitudinalStage {
    const NAME: &'static str = "fur-medulla-longitudinal";
    const VERSION: u32 = 2;
    const SUMMARY: &'static str = "fur medulla longitudinal scattering C^M(θ'_r; θ'_i, σ, g): back/forward lobes of a slab of thickness 2 (adding–doubling or Monte Carlo)";
    type Params = MedullaParams;
    fn plan_params(&self, p: MedullaParams) -> Result<Box<dyn Job>, PlanError> {
        plan(Family::Longitudinal, p)
    }
    fn parameter_docs(&self) -> Vec<ParamDoc> {
        family_docs(Family::Longitudinal)
    }
}

/// σ used to compute the σ → 0 limit *shape* of the normalised longitudinal lobes.
const SIGMA_LIMIT: f64 = 1e-9;

struct MedullaJob {
    family: Family,
    p: MedullaParams,
    sigma: Vec<f64>,
    g: Vec<f64>,
    entries: Vec<f64>,
}

impl MedullaJob {
    fn channels(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,
            Family::Longitudinal => 5,
        }
    }
    /// Values and scalars of one (σ, g) chunk: every entry's row and scalars.
    fn pair_chunk_len(&self) -> (usize, usize) {
        let n = self.entries.len();
        (n * self.p.bins * self.channels(), n * self.scalars())
    }

    /// The (σ, g) chunks of a chunk of several (as the deterministic methods compute them),
    /// in order.
    fn split_pairs(&self, chunk: Chunk) -> Vec<Chunk> {
        let (values, scalars) = self.pair_chunk_len();
        chunk
            .values
            .chunks(values)
            .zip(chunk.scalars.chunks(scalars))
            .map(|(v, s)| Chunk::new(v.to_vec(), s.to_vec()))
            .collect()
    }

    /// Several (σ, g) chunks as one, in order.
    fn join_pairs(pairs: Vec<Chunk>) -> Chunk {
        let mut out = Chunk::default();
        for c in pairs {
            out.values.extend(c.values);
            out.scalars.extend(c.scalars);
        }
        out
    }
    /// Remove the header attributes that describe Monte Carlo sampling (for the deterministic
    /// methods, which assemble through the same code).
    fn remove_sampling_attributes(a: &mut serde_json::Map<String, serde_json::Value>) {
        for key in [
            "estimator",
            "estimator_description",
            "photons_per_entry",
            "seed",
            "rng",
            "energy_identity_max_deviation_std_errors",
        ] {
            a.remove(key);
        }
    }
    fn scalars(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,    // ballistic, scattered, scattered_se
            Family::Longitudinal => 5, // ballistic, scattered, scattered_se, back, forward
        }
    }
    fn geometry(&self, x: f64) -> Geometry {
        match self.family {
            Family::Azimuthal => Geometry::Azimuthal { h: x },
            Family::Longitudinal => Geometry::Longitudinal {
                theta_i_rad: x.to_radians(),
            },
        }
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
    /// Index of the mirror entry if it exists and is > 0 (negative rows are mirrored).
    fn mirror_source(&self, i: usize) -> Option<usize> {
        let x = self.entries[i];
        if x >= 0.0 {
            return None;
        }
        self.entries.iter().position(|&y| y == -x)
    }
    fn mirror_bin(&self, k: usize) -> usize {
        let b = self.p.bins;
        match self.family {
            Family::Azimuthal => b - 1 - k,
            Family::Longitudinal => {
                let half = b / 2;
                if k < half {
                    half - 1 - k
                } else {
                    half + (b - 1 - k)
                }
            }
        }
    }
    /// Row values (bins × channels) and scalars for one entry.
    fn row(&self, sigma: f64, g: f64, x: f64) -> (Vec<f32>, Vec<f32>) {
        let geom = self.geometry(x);
        let s = self.settings();
        let prof: Profile = simulate(sigma, g, geom, &s);
        self.pack_row(sigma, &prof, || simulate(SIGMA_LIMIT, g, geom, &s).energy)
    }
    /// Row values and scalars of a computed profile; `limit_shape` gives the σ → 0 lobe shape
    /// (any scale) stored in the longitudinal pdf/cdf at σ = 0.
    fn pack_row(
        &self,
        sigma: f64,
        prof: &Profile,
        limit_shape: impl FnOnce() -> Vec<f64>,
    ) -> (Vec<f32>, Vec<f32>) {
        let b = self.p.bins;
        match self.family {
            Family::Azimuthal => {
                let mut v = Vec::with_capacity(b * 3);
                for k in 0..b {
                    v.extend([
                        prof.energy[k] as f32,
                        prof.path_length[k] as f32,
                        prof.std_error[k] as f32,
                    ]);
                }
                (
                    v,
                    vec![
                        prof.ballistic as f32,
                        prof.scattered as f32,
                        prof.scattered_std_error as f32,
                    ],
                )
            }
            Family::Longitudinal => {
                // Lobe shapes: for σ = 0 the stored pdf/cdf are the σ → 0 limit (energy stays 0).
                let (pdf, cdf) = if sigma > 0.0 {
                    normalise_lobes(&prof.energy)
                } else {
                    normalise_lobes(&limit_shape())
                };
                let mut v = Vec::with_capacity(b * 5);
                for k in 0..b {
                    v.extend([
                        pdf[k] as f32,
                        cdf[k] as f32,
                        prof.energy[k] as f32,
                        prof.path_length[k] as f32,
                        prof.std_error[k] as f32,
                    ]);
                }
                let back: f64 = prof.energy[..b / 2].iter().sum();
                let fwd: f64 = prof.energy[b / 2..].iter().sum();
                (
                    v,
                    vec![
                        prof.ballistic as f32,
                        prof.scattered as f32,
                        prof.scattered_std_error as f32,
                        back as f32,
                        fwd as f32,
                    ],
                )
            }
        }
    }
    /// A task's chunk: every entry row in order (negative rows mirrored from their positive
    /// source, which `rows` holds; mirrored rows are `None`) and the per-entry scalars.
    fn chunk(&self, rows: &[Option<(Vec<f32>, Vec<f32>)>]) -> Chunk {
        let n = self.entries.len();
        let (b, c) = (self.p.bins, self.channels());
        let mut data = Vec::with_capacity(n * b * c);
        let mut scalars = Vec::with_capacity(n * self.scalars());
        for i in 0..n {
            match (&rows[i], self.mirror_source(i)) {
                (Some((v, sc)), _) => {
                    data.extend_from_slice(v);
                    scalars.extend_from_slice(sc);
                }
                (None, Some(src)) => {
                    let (v, sc) = rows[src].as_ref().expect("mirror source computed");
                    for k in 0..b {
                        let m = self.mirror_bin(k);
                        data.extend_from_slice(&v[m * c..(m + 1) * c]);
                    }
                    if self.family == Family::Longitudinal {
                        // cdf must be re-accumulated in the mirrored bin order.
                        let half = b / 2;
                        for lobe in 0..2 {
                            let base = data.len() - b * c + lobe * half * c;
                            let mut acc = 0.0f64;
                            let mut tot = 0.0f64;
                            for j in 0..half {
                                tot += data[base + j * c] as f64;
                            }
                            for j in 0..half {
                                acc += data[base + j * c] as f64;
                                data[base + j * c + 1] =
                                    if tot > 0.0 { (acc / tot) as f32 } else { 0.0 };
                            }
                        }
                        // back and forward energies are unchanged by the mirror.
                    }
                    scalars.extend_from_slice(sc);
                }
                (None, None) => unreachable!(),
            }
        }
        Chunk::new(data, scalars.into_iter().map(f64::from).collect())
    }
}

impl Job for MedullaJob {
    /// Known at plan time: σ × g × entries × bins × channels.
    fn payload_bytes(&self) -> Option<u64> {
        Some(crate::stages::f32_payload_bytes(&[
            self.sigma.len(),
            self.g.len(),
            self.entries.len(),
            self.p.bins,
            self.channels(),
        ]))
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        let mut t = Vec::new();
        for &s in &self.sigma {
            for &g in &self.g {
                t.push(TaskSpec {
                    label: format!("σ={s:.4} g={g:.4}"),
                    params: json!({ "sigma": s, "g": g }),
                });
            }
        }
        t
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let sigma = self.sigma[index / self.g.len()];
        let g = self.g[index % self.g.len()];
        let n = self.entries.len();
        let rows: Vec<Option<(Vec<f32>, Vec<f32>)>> = (0..n)
            .into_par_iter()
            .map(|i| match self.mirror_source(i) {
                Some(_) => None,
                None => Some(self.row(sigma, g, self.entries[i])),
            })
            .collect();
        Ok(self.chunk(&rows))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let (b, ns, n) = (self.p.bins, self.scalars(), self.entries.len());
        let (row_len, scalar_len) = self.pair_chunk_len();
        let mut scal: Vec<Vec<f64>> = vec![Vec::new(); ns];
        check_chunks(
            &chunks,
            self.sigma.len() * self.g.len(),
            row_len,
            scalar_len,
        )?;
        for ch in &chunks {
            for i in 0..n {
                for (j, s) in scal.iter_mut().enumerate() {
                    s.push(ch.scalars[i * ns + j]);
                }
            }
        }
        let data = concat_values(chunks);
        let dw_deg = 360.0 / b as f64;
        let mut a = self.monte_carlo_attributes(&scal, dw_deg)?;
        let sigma_ax = Axis::values("sigma", "1/medulla_radius", self.sigma.clone());
        let g_ax = Axis::values("g", "1", self.g.clone());
        let content = match self.family {
            Family::Azimuthal => {
                a.insert(
                    "geometry".into(),
                    "unit disc entered at (-sqrt(1-h^2), h) moving along +x".into(),
                );
                a.insert("bin_convention".into(), "phi' = atan2(d_y, d_x) of the exit direction relative to the entering propagation direction: 0 = unscattered continuation (forward), +/-180 deg = straight back towards the source, counter-clockwise = towards the side of positive h'; bins cover [-180, 180) deg".into());
                a.insert(
                    "energy_identity".into(),
                    "sum over phi of energy = 1 - exp(-2 sigma sqrt(1 - h^2))".into(),
                );
                TableContent {
                    schema: Schema::new("fur-medulla-azimuthal", 1),
                    description: "fur medulla azimuthal scattering profile C^N(phi'; h', sigma, g) (scattered energy per exit-direction bin)".into(),
                    axes: vec![
                        sigma_ax,
                        g_ax,
                        Axis::values("h", "1", self.entries.clone()),
                        Axis::uniform("phi", "deg", -180.0 + 0.5 * dw_deg, dw_deg, b),
                    ],
                    channels: vec![
                        Channel::new("energy", "1", "scattered exiting energy in the bin per unit incident energy"),
                        Channel::new("path_length", "medulla_radius", "mean in-medulla path length of the energy in the bin"),
                        Channel::new("std_error", "1", "Monte Carlo standard error of energy"),
                    ],
                    attributes: a,
                    data,
                }
            }
            Family::Longitudinal => {
                a.insert("geometry".into(), "slab 0 <= x <= 2 (x along the slab normal = in the fiber's normal plane, y along the fiber axis), entered at x = 0 with propagation direction (cos theta_i, -sin theta_i)".into());
                a.insert("bin_convention".into(), "theta_i is the inclination of the direction towards the source, theta_r of the exit direction (sin theta_r = exit d_y), both from the slab normal, Marschner-style: the unscattered continuation exits at theta_r = -theta_i. lobe 0 = back (exits through the entry face x = 0, the thesis's 'upper' lobe, used at phi = 0), lobe 1 = forward (exits through x = 2, the 'lower' lobe, used at phi = +/-180 deg); theta_r bins cover [-90, 90) deg per lobe".into());
                a.insert("pdf_convention".into(), "channel `pdf` is each lobe normalised to a probability density per radian of theta_r (sum pdf * bin_width_rad = 1 per lobe); `cdf` is its cumulative distribution at the UPPER edge of each bin (last bin = 1). At sigma = 0 energy is 0 and pdf/cdf hold the sigma -> 0 limit shape (single scattering on the chord)".into());
                a.insert(
                    "energy_identity".into(),
                    "sum over both lobes of energy = 1 - exp(-2 sigma / cos theta_i)".into(),
                );
                a.insert("back_lobe_energy".into(), scal[3].clone().into());
                a.insert("forward_lobe_energy".into(), scal[4].clone().into());
                TableContent {
                    schema: Schema::new("fur-medulla-longitudinal", 1),
                    description: "fur medulla longitudinal scattering lobes C^M(theta'_r; theta'_i, sigma, g) of a slab of thickness 2".into(),
                    axes: vec![
                        sigma_ax,
                        g_ax,
                        Axis::values("theta_i", "deg", self.entries.clone()),
                        Axis::values("lobe", "1", vec![0.0, 1.0]),
                        Axis::uniform("theta_r", "deg", -90.0 + 0.5 * dw_deg, dw_deg, b / 2),
                    ],
                    channels: vec![
                        Channel::new("pdf", "1/rad", "lobe-normalised density of theta_r"),
                        Channel::new("cdf", "1", "lobe cumulative distribution at the bin's upper edge"),
                        Channel::new("energy", "1", "scattered exiting energy in the bin per unit incident energy"),
                        Channel::new("path_length", "medulla_radius", "mean in-medulla path length of the energy in the bin"),
                        Channel::new("std_error", "1", "Monte Carlo standard error of energy"),
                    ],
                    attributes: a,
                    data,
                }
            }
        };
        Ok(content)
    }
}

impl MedullaJob {
    /// Attributes of every Monte Carlo medulla table: model, conventions, estimator, the
    /// per-entry scalars `scal` (ballistic, scattered, its standard error, …) and the energy
    /// identity over the whole table, in absolute terms and in standard errors.
    fn monte_carlo_attributes(
        &self,
        scal: &[Vec<f64>],
        dw_deg: f64,
    ) -> Result<serde_json::Map<String, serde_json::Value>, JobError> {
        // Energy-identity check over the whole table, in standard errors.
        let mut max_dev_se: f64 = 0.0;
        let mut max_dev_abs: f64 = 0.0;
        for ((ballistic, scattered), se) in scal[0].iter().zip(&scal[1]).zip(&scal[2]) {
            let dev = (scattered - (1.0 - ballistic)).abs();
            max_dev_abs = max_dev_abs.max(dev);
            if *se > 0.0 {
                max_dev_se = max_dev_se.max(dev / se);
            }
        }
        let mut a = serde_json::Map::new();
        a.insert("model".into(), "2-D volumetric Monte Carlo, Tseng 2015 §5 / App. A: purely scattering medium, planar Henyey–Greenstein phase function rho(theta) = (1-g^2)/(2 pi (1+g^2-2g cos theta)), no absorption, index-matched boundary (no Fresnel, no refraction), unit incident energy".into());
        a.insert("sigma_convention".into(), "sigma is the scattering coefficient per unit MEDULLA radius (dimensionless optical coefficient; azimuthal disc radius 1, slab thickness 2). Renderer mapping (docs/fur.md): sigma = sigma_ms[per fiber radius] * kappa = sigma_ms[per fiber diameter] * kappa / 2; the thesis's sigma_ms/kappa lookup is NOT used".into());
        a.insert("length_unit".into(), "medulla radius".into());
        a.insert("estimator".into(), serde_json::to_value(self.p.estimator)?);
        a.insert("estimator_description".into(), match self.p.estimator {
            Estimator::Expected => "expected value: forced first collision (weight 1 - exp(-sigma chord)), next-event estimate to every bin at every collision (phase density at bin centre x bin width x exp(-sigma s)), analog continuation",
            Estimator::Histogram => "analog histogram of exit directions",
        }.into());
        a.insert("photons_per_entry".into(), self.p.photons.into());
        a.insert("method".into(), "monte-carlo".into());
        a.insert("seed".into(), self.p.seed.into());
        a.insert("rng".into(), "SplitMix64, one stream per entry derived from (seed, family, sigma, g, entry) bit patterns: independent of threads and sharding".into());
        a.insert("grid_endpoints".into(), "axis values are exactly the listed sample points; {start, stop, count} ranges include both endpoints unless centred = true".into());
        a.insert("bin_width_deg".into(), dw_deg.into());
        a.insert("bin_rule".into(), "bins are half-open cells [lower, upper) of equal width 360/bins deg; the axis coordinate is the cell centre; values are averages over the cell (midpoint rule for the expected-value estimator)".into());
        a.insert("energy_convention".into(), "channel `energy` is scattered exiting energy per bin per unit incident energy (NOT a density: divide by the bin width in rad for per-radian density); it sums over bins to the scattered fraction 1 - ballistic".into());
        a.insert("path_length_convention".into(), "channel `path_length` is the energy-weighted mean in-medulla path length (medulla radii) of the light exiting in the bin; 0 where the bin is empty. Medulla absorption at render time: multiply energy by exp(-sigma_a * path_length) (first-order; exact only for a narrow length distribution)".into());
        a.insert("std_error_convention".into(), "channel `std_error` is the Monte Carlo standard error of `energy` in the bin (from per-photon second moments)".into());
        a.insert("symmetry".into(), "rows with a negative entry (h or theta_i) whose positive mirror is on the grid are stored as the exact mirror of that row (bins reversed, within each lobe for the longitudinal family)".into());
        a.insert(
            "scalars_layout".into(),
            "per-entry arrays below are flat row-major over (sigma, g, entry)".into(),
        );
        a.insert("ballistic_fraction".into(), scal[0].clone().into());
        a.insert("scattered_fraction".into(), scal[1].clone().into());
        a.insert(
            "scattered_fraction_std_error".into(),
            scal[2].clone().into(),
        );
        a.insert("energy_identity_max_deviation".into(), max_dev_abs.into());
        a.insert(
            "energy_identity_max_deviation_std_errors".into(),
            max_dev_se.into(),
        );
        Ok(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::stages::Stage;
    use disc_job::SOLVER_ERROR as SOLVER_ERROR_CHARACTERISTICS;
    use std::f64::consts::PI;

    fn plan_str(family: Family, s: &str) -> Result<Box<dyn Job>, PlanError> {
        let v = toml::de::ValueDeserializer::parse(s).unwrap();
        match family {
            Family::Azimuthal => FurMedullaAzimuthalStage.plan(v),
            Family::Longitudinal => FurMedullaLongitudinalStage.plan(v),
        }
    }

    fn run(job: &dyn Job) -> TableContent {
        crate::stages::run_in_memory(job).unwrap()
    }

    #[test]
    fn azimuthal_table_energy_zeros_and_mirror_rows() {
        for method in ["monte-carlo", "adaptive", "characteristics"] {
            let deterministic = method == "characteristics";
            let photons = if deterministic {
                ""
            } else {
                ", photons = 300, seed = 3"
            };
            let job = plan_str(
                Family::Azimuthal,
                &format!("{{ sigma = [0.0, 2.0], g = [0.0, 0.6], h = {{ start = -1.0, stop = 1.0, count = 5 }}, bins = 72, method = \"{method}\"{photons} }}"),
            )
            .unwrap();
            let t = run(job.as_ref());
            assert_eq!(t.data.len(), t.expected_len());
            assert_eq!(t.attributes["method"], method);
            let (nh, b, c) = (5, 72, 3);
            let at = |si: usize, gi: usize, hi: usize, k: usize, ch: usize| {
                t.data[(((si * 2 + gi) * nh + hi) * b + k) * c + ch]
            };
            let se = t.attributes["scattered_fraction_std_error"]
                .as_array()
                .unwrap();
            for gi in 0..2 {
                for hi in 0..nh {
                    for k in 0..b {
                        assert_eq!(at(0, gi, hi, k, 0), 0.0); // σ = 0
                    }
                }
                for k in 0..b {
                    assert_eq!(at(1, gi, 0, k, 0), 0.0); // h = −1
                    assert_eq!(at(1, gi, 4, k, 0), 0.0); // h = +1
                    assert_eq!(at(1, gi, 1, k, 0), at(1, gi, 3, b - 1 - k, 0)); // mirror
                }
                for hi in 0..nh {
                    let h: f64 = -1.0 + 0.5 * hi as f64;
                    let sum: f64 = (0..b).map(|k| at(1, gi, hi, k, 0) as f64).sum();
                    let expect = 1.0 - (-2.0 * 2.0 * (1.0 - h * h).max(0.0).sqrt()).exp();
                    let err = se[(2 + gi) * nh + hi].as_f64().unwrap();
                    // The deterministic solver: within its discretisation error (the energy
                    // identity is not imposed by the method; measured ≤ 2.2e-3 relative).
                    let tol = if deterministic {
                        (3e-3 * expect).max(1e-12)
                    } else {
                        (5.0 * err).max(1e-4)
                    };
                    assert!(
                        (sum - expect).abs() < tol,
                        "{method} h={h}: {sum} vs {expect} ± {err}"
                    );
                }
            }
            if deterministic {
                assert_eq!(t.attributes["solver_error"], SOLVER_ERROR_CHARACTERISTICS);
            } else {
                assert!(
                    t.attributes["energy_identity_max_deviation_std_errors"]
                        .as_f64()
                        .unwrap()
                        < 5.0
                );
            }
        }
    }

    /// Error bars that hold when rebinned, read from the stored table: for groups of bins, the
    /// spread of group sums over replicate tables (independent seeds) against the error the
    /// header documents, Var(Σ_G energy) = Σ_{k,l∈G} se_k se_l exp(−|k−l|/ℓ), with `std_error`
    /// and the entry's `std_error_correlation_length_bins` ℓ. Two entries: a moderate one and a
    /// σ = 12 one read through its mirrored row (h' = −0.5). Groups of 1 to 72 bins must agree
    /// within the noise of 16 replicates; 180-bin groups (where energy conservation makes far
    /// bins anti-correlated) must not be understated; the plain quadrature sum must understate
    /// 10° groups (so the test fails if the correlation were dropped).
    #[test]
    fn rebinned_error_bars_from_the_table_match_replicate_runs() {
        use crate::fur::medulla_fast::correlated_group_error;
        let reps = 16u64;
        for (sigma, g) in [(4.0, 0.6), (12.0, 0.2)] {
            // Rows per table: h' = −0.5 (mirror of +0.5) and +0.5; the test reads row 0.
            let tables: Vec<TableContent> = (0..reps)
                .map(|r| {
                    let job = plan_str(
                        Family::Azimuthal,
                        &format!("{{ sigma = [{sigma}], g = [{g}], h = [-0.5, 0.5], method = \"adaptive\", target_rel_error = 0.001, photons = 1024, seed = {} }}", 100 + r),
                    )
                    .unwrap();
                    run(job.as_ref())
                })
                .collect();
            let c = 3;
            let column = |t: &TableContent, ch: usize| -> Vec<f64> {
                (0..720).map(|k| t.data[k * c + ch] as f64).collect()
            };
            let energy: Vec<Vec<f64>> = tables.iter().map(|t| column(t, 0)).collect();
            let se: Vec<Vec<f64>> = tables.iter().map(|t| column(t, 2)).collect();
            let ell: Vec<f64> = tables
                .iter()
                .map(|t| {
                    t.attributes["std_error_correlation_length_bins"][0]
                        .as_f64()
                        .unwrap()
                })
                .collect();
            let n = reps as f64;
            for (group, lo, hi) in [
                (1usize, 0.7, 1.3),
                (20, 0.7, 1.3),
                (72, 0.7, 1.3),
                (180, 0.0, 1.2),
            ] {
                let (mut ratio, mut ratio_quad) = (0.0, 0.0);
                let groups = 720 / group;
                for gi in 0..groups {
                    let r = gi * group..(gi + 1) * group;
                    let sums: Vec<f64> = energy.iter().map(|e| e[r.clone()].iter().sum()).collect();
                    let mean = sums.iter().sum::<f64>() / n;
                    let sd =
                        (sums.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                    let model = se
                        .iter()
                        .zip(&ell)
                        .map(|(s, &l)| correlated_group_error(s, l, r.clone()))
                        .sum::<f64>()
                        / n;
                    let quad = se
                        .iter()
                        .map(|s| s[r.clone()].iter().map(|x| x * x).sum::<f64>().sqrt())
                        .sum::<f64>()
                        / n;
                    ratio += sd / model / groups as f64;
                    ratio_quad += sd / quad / groups as f64;
                }
                println!(
                    "σ={sigma} g={g} h'=-0.5: {group}-bin groups: replicate sd / stored-model error {ratio:.3}, / quadrature sum {ratio_quad:.3} (mean ℓ {:.1} bins)",
                    ell.iter().sum::<f64>() / n
                );
                assert!((lo..hi).contains(&ratio), "σ={sigma} {group} bins: {ratio}");
                if group == 20 {
                    assert!(ratio_quad > 2.0, "σ={sigma} 10° groups: {ratio_quad}");
                }
            }
        }
    }

    #[test]
    fn longitudinal_lobes_normalised_and_cdf_ends_at_one() {
        let job = plan_str(
            Family::Longitudinal,
            "{ sigma = [0.0, 1.5], g = [0.3], theta_i_deg = { start = -60.0, stop = 60.0, count = 4, centred = true }, bins = 120, method = \"monte-carlo\", photons = 200 }",
        )
        .unwrap();
        let t = run(job.as_ref());
        let (nt, half, c) = (4, 60, 5);
        let dw = 2.0 * PI / 120.0;
        for si in 0..2 {
            for ti in 0..nt {
                for lobe in 0..2 {
                    let base = (((si * nt + ti) * 2 + lobe) * half) * c;
                    let int: f64 = (0..half).map(|j| t.data[base + j * c] as f64 * dw).sum();
                    assert!((int - 1.0).abs() < 1e-5, "σ{si} θ{ti} lobe {lobe}: {int}");
                    assert!((t.data[base + (half - 1) * c + 1] - 1.0).abs() < 1e-6);
                    assert!(
                        (0..half - 1)
                            .all(|j| t.data[base + (j + 1) * c + 1] >= t.data[base + j * c + 1])
                    );
                    if si == 0 {
                        assert!((0..half).all(|j| t.data[base + j * c + 2] == 0.0));
                    }
                }
            }
        }
    }

    #[test]
    fn shipped_manifests_plan_with_the_documented_grids() {
        // (file, tasks of each table in order): Monte Carlo and adaptive one per (σ, g),
        // characteristics one per σ, adding–doubling one per g.
        for (file, tasks) in [
            ("manifests/fur-medulla.toml", [9, 5]),
            ("manifests/full/fur-medulla-full.toml", [1024, 1024]),
            ("manifests/full/fur-medulla-thesis.toml", [64, 16]),
        ] {
            let jobs = crate::stages::plan_manifest_file(file);
            assert_eq!(jobs.len(), 2, "{file}");
            for ((_, job), n) in jobs.into_iter().zip(tasks) {
                assert_eq!(job.tasks().len(), n, "{file}");
                if file.contains("full/") {
                    let p: MedullaParams = serde_json::from_value(job.parameters()).unwrap();
                    let sigma = p.sigma.points();
                    assert_eq!((sigma.len(), sigma[0], sigma[63]), (64, 0.0, 20.0));
                    assert!((sigma[1] - 20.0 / 63.0).abs() < 1e-12);
                    let g = p.g.points();
                    assert!((g[1] - 0.8 / 15.0).abs() < 1e-12 && g[15] == 0.8);
                    let e = p.h.or(p.theta_i_deg).unwrap().points();
                    assert_eq!(e.len(), 64);
                }
            }
        }
    }

    #[test]
    fn methods_resolve_per_family_and_reject_foreign_keys() {
        let az = "sigma = [1.0], g = [0.0], h = [0.5]";
        let lo = "sigma = [1.0], g = [0.0], theta_i_deg = [10.0]";
        crate::stages::assert_planning(
            &FurMedullaAzimuthalStage,
            &[
                &format!("{az}, method = \"adding-doubling\", photons = 10"),
                &format!("{az}, method = \"adaptive\""),
                &format!("{az}, method = \"adaptive\", photons = 10, target_rel_error = 0.0"),
                &format!("{az}, method = \"monte-carlo\", photons = 10, target_rel_error = 0.1"),
                &format!("{az}, method = \"bogus\", photons = 10"),
                &format!("{az}, photons = 10"),
                &format!("{az}, method = \"characteristics\", target_rel_error = 0.01"),
            ],
            &[
                az,
                &format!("{az}, method = \"characteristics\""),
                &format!("{az}, method = \"adaptive\", photons = 10"),
                &format!("{az}, method = \"adaptive\", photons = 10, target_rel_error = 0.05"),
                &format!("{az}, method = \"monte-carlo\", photons = 10"),
            ],
        );
        crate::stages::assert_planning(
            &FurMedullaLongitudinalStage,
            &[
                &format!("{lo}, method = \"adaptive\", photons = 10"),
                &format!("{lo}, method = \"characteristics\""),
                &format!("{lo}, photons = 10"),
                &format!("{lo}, method = \"monte-carlo\""),
                &format!("{lo}, target_rel_error = 0.01"),
            ],
            &[
                lo,
                &format!("{lo}, method = \"adding-doubling\""),
                &format!("{lo}, method = \"monte-carlo\", photons = 10"),
            ],
        );
        // The resolved method is part of the recorded parameters (and so of the content key).
        let job = plan_str(Family::Azimuthal, &format!("{{ {az} }}")).unwrap();
        assert_eq!(job.parameters()["method"], "characteristics");
        assert_eq!(job.tasks().len(), 1);
        let job = plan_str(
            Family::Azimuthal,
            &format!("{{ {az}, method = \"adaptive\", photons = 10 }}"),
        )
        .unwrap();
        assert_eq!(job.parameters()["target_rel_error"], 0.01);
        let job = plan_str(Family::Longitudinal, &format!("{{ {lo} }}")).unwrap();
        assert_eq!(job.parameters()["method"], "adding-doubling");
        assert_eq!(job.tasks().len(), 1);
    }

    #[test]
    fn rejects_bad_params() {
        let common = "sigma = [1.0], g = [0.0], photons = 1";
        crate::stages::assert_planning(
            &FurMedullaAzimuthalStage,
            &[
                &format!("{common}, h = [1.5]"),
                "sigma = [1.0], g = [0.99], h = [0.5]",
                &format!("{common}, h = [0.5], bogus = 2"),
                &format!("{common}, theta_i_deg = [0.5]"),
            ],
            &[&format!("{common}, h = [0.5], method = \"adaptive\"")],
        );
        crate::stages::assert_planning(
            &FurMedullaLongitudinalStage,
            &[&format!("{common}, theta_i_deg = [90.0]")],
            &[&format!(
                "{common}, theta_i_deg = [0.5], method = \"monte-carlo\""
            )],
        );
    }
}
