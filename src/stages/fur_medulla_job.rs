//! The Monte Carlo job of the fur medulla stages and the parameter types it shares with the
//! other methods' jobs (which pack, mirror and assemble their rows with its code): the stage
//! module plans; this module computes.

use crate::fur::medulla::{Estimator, Geometry, McSettings, Profile, normalise_lobes, simulate};
use crate::stages::{Chunk, Job, JobError, TaskSpec, check_chunks, concat_values, stage_params};
use crate::table::{Axis, Channel, Schema, TableContent};
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

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Family {
    Azimuthal,
    Longitudinal,
}

/// σ used to compute the σ → 0 limit *shape* of the normalised longitudinal lobes.
pub(super) const SIGMA_LIMIT: f64 = 1e-9;

pub(super) struct MedullaJob {
    pub(super) family: Family,
    pub(super) p: MedullaParams,
    pub(super) sigma: Vec<f64>,
    pub(super) g: Vec<f64>,
    pub(super) entries: Vec<f64>,
}

impl MedullaJob {
    /// σ × g × h × φ (azimuthal) or σ × g × θ_i × lobe × θ_r (longitudinal).
    pub(super) fn table_axes(&self) -> Vec<Axis> {
        let b = self.p.bins;
        let dw_deg = 360.0 / b as f64;
        let mut axes = vec![
            Axis::values("sigma", "1/medulla_radius", self.sigma.clone()),
            Axis::values("g", "1", self.g.clone()),
        ];
        match self.family {
            Family::Azimuthal => axes.extend([
                Axis::values("h", "1", self.entries.clone()),
                Axis::uniform("phi", "deg", -180.0 + 0.5 * dw_deg, dw_deg, b),
            ]),
            Family::Longitudinal => axes.extend([
                Axis::values("theta_i", "deg", self.entries.clone()),
                Axis::values("lobe", "1", vec![0.0, 1.0]),
                Axis::uniform("theta_r", "deg", -90.0 + 0.5 * dw_deg, dw_deg, b / 2),
            ]),
        }
        axes
    }

    pub(super) fn channels(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,
            Family::Longitudinal => 5,
        }
    }
    /// Values and scalars of one (σ, g) chunk: every entry's row and scalars.
    pub(super) fn pair_chunk_len(&self) -> (usize, usize) {
        let n = self.entries.len();
        (n * self.p.bins * self.channels(), n * self.scalars())
    }

    /// The (σ, g) chunks of a chunk of several (as the deterministic methods compute them),
    /// in order.
    pub(super) fn split_pairs(&self, chunk: Chunk) -> Vec<Chunk> {
        let (values, scalars) = self.pair_chunk_len();
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
    /// Remove the header attributes that describe Monte Carlo sampling (for the deterministic
    /// methods, which assemble through the same code).
    pub(super) fn remove_sampling_attributes(a: &mut serde_json::Map<String, serde_json::Value>) {
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
    pub(super) fn scalars(&self) -> usize {
        match self.family {
            Family::Azimuthal => 3,    // ballistic, scattered, scattered_se
            Family::Longitudinal => 5, // ballistic, scattered, scattered_se, back, forward
        }
    }
    pub(super) fn geometry(&self, x: f64) -> Geometry {
        match self.family {
            Family::Azimuthal => Geometry::Azimuthal { h: x },
            Family::Longitudinal => Geometry::Longitudinal {
                theta_i_rad: x.to_radians(),
            },
        }
    }
    pub(super) fn settings(&self) -> McSettings {
        McSettings {
            photons: self.p.photons.unwrap_or(0),
            seed: self.p.seed,
            estimator: self.p.estimator,
            bins: self.p.bins,
            max_order: None,
        }
    }
    /// Index of the mirror entry if it exists and is > 0 (negative rows are mirrored).
    pub(super) fn mirror_source(&self, i: usize) -> Option<usize> {
        let x = self.entries[i];
        if x >= 0.0 {
            return None;
        }
        self.entries.iter().position(|&y| y == -x)
    }
    pub(super) fn mirror_bin(&self, k: usize) -> usize {
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
    pub(super) fn row(&self, sigma: f64, g: f64, x: f64) -> (Vec<f32>, Vec<f32>) {
        let geom = self.geometry(x);
        let s = self.settings();
        let prof: Profile = simulate(sigma, g, geom, &s);
        self.pack_row(sigma, &prof, || simulate(SIGMA_LIMIT, g, geom, &s).energy)
    }
    /// Row values and scalars of a computed profile; `limit_shape` gives the σ → 0 lobe shape
    /// (any scale) stored in the longitudinal pdf/cdf at σ = 0.
    pub(super) fn pack_row(
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
    pub(super) fn chunk(&self, rows: &[Option<(Vec<f32>, Vec<f32>)>]) -> Chunk {
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
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.table_axes(), self.channels())
    }
    /// Photon histories: `photons` per entry of every (σ, g), each costing more with σ (more
    /// scattering events), `cost::MEDULLA_PHOTON_CPU_S · (1 + σ)`.
    fn estimated_cpu_seconds(&self) -> f64 {
        let photons = self.p.photons.unwrap_or(0) as f64 * self.entries.len() as f64;
        let per_g: f64 = self.sigma.iter().map(|s| 1.0 + s).sum();
        crate::stages::cost::MEDULLA_PHOTON_CPU_S * photons * per_g * self.g.len() as f64
    }
    fn estimated_stored_fraction(&self) -> f64 {
        match self.family {
            Family::Azimuthal => crate::stages::cost::STORED_FRACTION_MEDULLA_AZIMUTHAL_MC,
            Family::Longitudinal => crate::stages::cost::STORED_FRACTION_MEDULLA_LONGITUDINAL_MC,
        }
    }
    /// Per (σ, g, entry) Monte Carlo statistics in the header.
    fn estimated_attribute_bytes(&self) -> u64 {
        let entries = (self.sigma.len() * self.g.len() * self.entries.len()) as u64;
        crate::stages::cost::ATTRIBUTE_BYTES
            + crate::stages::cost::MEDULLA_ATTRIBUTE_BYTES_PER_ENTRY * entries
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
        let axes = self.table_axes();
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
                    axes,
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
                    axes,
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
    pub(super) fn monte_carlo_attributes(
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
