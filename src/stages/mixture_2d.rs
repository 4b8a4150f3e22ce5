//! `mixture-2d` stage (schema `raytrace-phase-2d/2`, entry axis `distribution`): drop-size
//! mixtures of ray-traced Beard–Chuang drops (Sadeghi 2012, ch. 3; shapes after Beard & Chuang
//! 1987), for rain whose large drops are flattened, such as the twinned rainbow.
//!
//! For each (distribution, wavelength, sun elevation) every radius r_i of the distribution (its
//! Gauss–Legendre nodes in ln r, `radius_points` of them, or explicit radii with number
//! weights) is traced exactly as the `raytrace` stage traces a one-radius 2-D table (same
//! parameters, same diffraction filter, same mirror symmetrisation), giving p_i = (dσ/dΩ)_i/σ_i
//! with σ_i = σ_GO + A the drop's scattering cross-section. The mixture is
//!
//! ```text
//! p = Σ n_i σ_i p_i / Σ n_i σ_i        (n_i = n(r_i) dr_i, the number weight)
//! ```
//!
//! channel by channel (dolp recomputed from the mixed i_perp and i_par), renormalised on the
//! grid as the `raytrace` stage does (decision RT-21). The table has the `raytrace` stage's
//! 2-D schema with `distribution` as its entry axis, so `plot raytrace`, `render rainbow` and
//! the readers take it unchanged.

use crate::mie::distributions::SizeDistribution;
use crate::optics::water::SADEGHI_WAVELENGTHS_NM;
use crate::raytrace::table2d::{SizeMix, n_channels_2d};
use crate::raytrace::tracer::RayGridLayout;
use crate::stages::mixture::{ExplicitMixture, MixtureEntry};
use crate::stages::raytrace::{RaytraceJob, RaytraceParams};
use crate::stages::{Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, checks, stage_params};
use crate::table::{Axis, TableContent};

/// The stage.
pub struct Mixture2dStage;

stage_params! {
    /// Parameters of `[table.params]`.
    pub struct Mixture2dParams {
        /// One table entry per distribution.
        pub distributions: Vec<MixtureEntry> = required, "list of tables",
            "kind = marshall-palmer | gamma | lognormal | monodisperse (as the mie stage), or {radii_um, number_weights}; every radius traced as a Beard–Chuang drop (10–5000 µm)";
        /// Gauss–Legendre nodes in ln r per distribution (each node is one 2-D trace).
        pub radius_points: usize = default(4), "integer",
            "Gauss–Legendre nodes in ln r per distribution (each one a 2-D trace), 1–64";
        pub wavelengths_nm: Vec<f64> = default(SADEGHI_WAVELENGTHS_NM.to_vec()),
            "list of float, nm", "vacuum wavelengths, strictly increasing";
        pub water_index_model: String = default("iapws1997".into()), "string",
            "iapws1997 | sadeghi-table-3.2";
        pub temperature_c: f64 = default(20.0), "float, °C", "water temperature (iapws1997)";
        pub max_order: usize = default(3), "integer", "highest order p traced, 1–8";
        pub sun_elevation_deg: Vec<f64> = default(vec![0.0]), "list of float, deg",
            "sun elevations above the horizon (drop axis vertical), 0–90";
        pub rays: usize = default(600), "integer", "rays per side of the ray grid (rays² rays)";
        pub ray_grid: RayGridLayout = default(RayGridLayout::Silhouette), "string",
            "silhouette | square: layout of the ray grid (as the raytrace stage)";
        pub polar_step_deg: f64 = default(0.1), "float, deg", "outgoing polar step (divides 180)";
        pub azimuth_step_deg: f64 = default(5.0), "float, deg",
            "outgoing azimuth step (divides 360)";
        pub diffraction_filter: bool = default(true), "bool",
            "apply the Table 3.3 Gaussian filter to the main channels";
        pub sphere_higher_orders: bool = default(true), "bool",
            "add the orders above max_order up to 6 of each radius's equal-volume sphere to every channel but the per-order ones (as the raytrace stage)";
        pub mirror_symmetrise: bool = default(true), "bool",
            "average the values at φ and 360° − φ of every radius (as the raytrace stage)";
        pub mirror_half: bool = default(false), "bool",
            "compute the azimuths 0°–180° of every radius and copy them to 360° − φ (as the raytrace stage)";
    }
}

/// Largest number of traced radii per distribution.
const MAX_RADIUS_POINTS: usize = 64;

impl StageSpec for Mixture2dStage {
    const NAME: &'static str = "mixture-2d";
    /// 2: the traced radii use the silhouette ray grid by default (`ray_grid`, decision RT-31).
    /// 3: the traced radii use the `airy-local` caustic model by default (decision RT-33).
    /// 4: Fresnel amplitudes in real arithmetic below the critical angle (last bits).
    /// 5: `sphere_higher_orders` (decision RT-37): each radius adds its equal-volume sphere's
    /// orders above `max_order`.
    /// 6: those orders' Debye surface coefficients are regular where sin(mx) vanishes.
    /// 7: the traced radii's intersections bracketed between their spheroids (last bits).
    /// 8: spherical radii (up to 0.4 mm) from the 1-D sphere path (decision RT-43).
    const VERSION: u32 = 8;
    const SUMMARY: &'static str = "drop-size mixtures of ray-traced Beard–Chuang drops (2-D tables over outgoing directions), weighted by number × scattering cross-section";
    type Params = Mixture2dParams;
    fn plan_params(&self, p: Mixture2dParams) -> Result<Box<dyn Job>, PlanError> {
        if p.distributions.is_empty() {
            return Err(PlanError::invalid("distributions", "must not be empty"));
        }
        checks::within("radius_points", p.radius_points, 1, MAX_RADIUS_POINTS, "")?;
        let mut nodes = Vec::with_capacity(p.distributions.len());
        for (i, e) in p.distributions.iter().enumerate() {
            let key = format!("distributions[{i}]");
            let (radii, weights) =
                entry_nodes(e, p.radius_points).map_err(|m| PlanError::invalid(&key, m))?;
            for &r in &radii {
                crate::raytrace::domain::check_radius_um(r)
                    .map_err(|why| PlanError::invalid(&key, format!("radius {why}")))?;
            }
            nodes.push((radii, weights));
        }
        let jobs = nodes
            .iter()
            .map(|(radii, _)| {
                radii
                    .iter()
                    .map(|&r| RaytraceJob::new(p.raytrace_params(r)))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Box::new(Mixture2dJob { p, nodes, jobs }))
    }
}

/// Radii (µm) and number weights of an entry; explicit entries are checked here.
fn entry_nodes(e: &MixtureEntry, points: usize) -> Result<(Vec<f64>, Vec<f64>), String> {
    match e {
        MixtureEntry::Explicit(ExplicitMixture {
            radii_um,
            number_weights,
        }) => {
            let ok = !radii_um.is_empty()
                && radii_um.len() == number_weights.len()
                && number_weights.iter().all(|w| *w >= 0.0 && w.is_finite())
                && number_weights.iter().any(|w| *w > 0.0);
            if !ok {
                return Err(
                    "radii_um and number_weights: same non-zero length, weights ≥ 0, not all 0"
                        .into(),
                );
            }
            Ok((radii_um.clone(), number_weights.clone()))
        }
        MixtureEntry::Distribution(d) => {
            d.validate()?;
            if let SizeDistribution::Monodisperse { radius_um } = d {
                return Ok((vec![*radius_um], vec![1.0]));
            }
            Ok(d.quadrature(points))
        }
    }
}

impl Mixture2dParams {
    /// The `raytrace` stage's parameters of one traced radius.
    fn raytrace_params(&self, radius_um: f64) -> RaytraceParams {
        RaytraceParams {
            shape: "beard-chuang".into(),
            radii_um: vec![radius_um],
            wavelengths_nm: self.wavelengths_nm.clone(),
            water_index_model: self.water_index_model.clone(),
            temperature_c: self.temperature_c,
            max_order: Some(self.max_order),
            angle_step_deg: 0.05,
            sun_elevation_deg: self.sun_elevation_deg.clone(),
            rays: self.rays,
            ray_grid: self.ray_grid,
            polar_step_deg: self.polar_step_deg,
            azimuth_step_deg: self.azimuth_step_deg,
            diffraction_filter: self.diffraction_filter,
            diagnostic_channels: true,
            sphere_higher_orders: self.sphere_higher_orders,
            mirror_symmetrise: self.mirror_symmetrise,
            mirror_half: self.mirror_half,
            diffraction_model: None,
            profile_theta_deg: None,
            profile_r: None,
            compression: Default::default(),
        }
    }
}

struct Mixture2dJob {
    p: Mixture2dParams,
    /// Per distribution: radii (µm) and number weights.
    nodes: Vec<(Vec<f64>, Vec<f64>)>,
    /// Per distribution, per radius: the one-radius `raytrace` job.
    jobs: Vec<Vec<RaytraceJob>>,
}

impl Mixture2dJob {
    /// (wavelength, elevation) pairs of one entry, in table order.
    fn pairs(&self) -> Vec<(f64, f64)> {
        self.p
            .wavelengths_nm
            .iter()
            .flat_map(|&l| self.p.sun_elevation_deg.iter().map(move |&e| (l, e)))
            .collect()
    }
}

impl Mixture2dJob {
    /// The `distribution` axis that replaces the `raytrace` table's radius axis.
    fn distribution_axis(&self) -> Axis {
        Axis::labelled(
            "distribution",
            "1",
            (0..self.nodes.len()).map(|i| i as f64).collect(),
            self.p
                .distributions
                .iter()
                .map(MixtureEntry::label)
                .collect(),
        )
    }
}

impl Job for Mixture2dJob {
    /// One entry per distribution, each with the grid of its first radius's `raytrace` table.
    fn shape(&self) -> crate::stages::PlannedShape {
        let mut shape = self.jobs[0][0].shape();
        shape.axes[0] = self.distribution_axis();
        shape
    }
    /// Every radius of every distribution traced as one `raytrace` table.
    fn estimated_cpu_seconds(&self) -> f64 {
        self.jobs
            .iter()
            .flatten()
            .map(Job::estimated_cpu_seconds)
            .sum()
    }
    fn estimated_stored_fraction(&self) -> f64 {
        self.jobs[0][0].estimated_stored_fraction()
    }
    fn estimated_attribute_bytes(&self) -> u64 {
        self.jobs
            .iter()
            .map(|j| j[0].estimated_attribute_bytes())
            .sum()
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }

    fn tasks(&self) -> Vec<TaskSpec> {
        let pairs = self.pairs();
        let mut out = Vec::with_capacity(self.nodes.len() * pairs.len());
        for (e, d) in self.p.distributions.iter().enumerate() {
            for &(l, el) in &pairs {
                out.push(TaskSpec {
                    label: format!("distribution {e} λ={l} nm sun {el}°"),
                    params: serde_json::json!({ "wavelength_nm": l, "sun_elevation_deg": el, "entry": d }),
                });
            }
        }
        out
    }

    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let pairs = self.pairs();
        let (entry, (l, el)) = (index / pairs.len(), pairs[index % pairs.len()]);
        let nch = n_channels_2d(self.p.max_order + 1, true);
        let weights = &self.nodes[entry].1;
        let mut mix = SizeMix::default();
        for (job, &n_i) in self.jobs[entry].iter().zip(weights) {
            if n_i != 0.0 {
                let (values, sigma) = job.trace_2d(l, el)?;
                mix.add(n_i, &values, sigma);
            }
        }
        mix.finish(nch)
            .map(Chunk::values)
            .map_err(|total| JobError::NotNormalisable {
                entry,
                integral: total,
            })
    }

    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let per_entry = self.pairs().len();
        crate::stages::check_chunks(
            &chunks,
            self.nodes.len() * per_entry,
            chunks.first().map_or(0, |c| c.values.len()),
            0,
        )?;
        // Each entry is renormalised and described by the `raytrace` stage's assembly of its
        // first radius; the entry axis then replaces the radius axis.
        let mut chunks = chunks.into_iter();
        let mut content: Option<TableContent> = None;
        let mut integrals = Vec::new();
        for jobs in &self.jobs {
            let part: Vec<Chunk> = chunks.by_ref().take(per_entry).collect();
            let t = jobs[0].assemble_values(part)?;
            integrals.push(t.attributes["integral_check"]["values"].clone());
            match &mut content {
                None => content = Some(t),
                Some(c) => c.data.extend_from_slice(&t.data),
            }
        }
        let mut t = content.expect("at least one distribution");
        t.axes[0] = self.distribution_axis();
        let a = &mut t.attributes;
        a.remove("radius_um");
        a.insert("shape".into(), "beard-chuang mixture".into());
        a.insert(
            "distributions".into(),
            serde_json::to_value(&self.p.distributions)?,
        );
        a.insert(
            "mixture_radii_um".into(),
            serde_json::to_value(self.nodes.iter().map(|n| &n.0).collect::<Vec<_>>())?,
        );
        a.insert(
            "mixture_number_weights".into(),
            serde_json::to_value(self.nodes.iter().map(|n| &n.1).collect::<Vec<_>>())?,
        );
        a.insert("mixture_weighting".into(), "p = Σ n_i σ_i p_i / Σ n_i σ_i over the traced radii r_i (mixture_radii_um[entry]) with number weights n_i = n(r_i) dr_i (mixture_number_weights[entry]; Gauss–Legendre in ln r or explicit) and σ_i = σ_GO + A of each traced drop at that wavelength and sun elevation; every channel mixed linearly, dolp recomputed; then renormalised on the grid (integral_check)".into());
        a.insert(
            "integral_check".into(),
            serde_json::json!({"what": "bin-sum of phase over 4π per distribution and (wavelength, sun elevation) before renormalisation", "values": integrals}),
        );
        t.description = format!(
            "ray-traced phase function of {} drop-size mixture(s) of Beard–Chuang drops over outgoing directions",
            self.nodes.len()
        );
        Ok(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raytrace::table2d::DOLP_CHANNEL;
    use crate::stages::{plan_from_lines, run_in_memory};

    const SMALL: &str = "wavelengths_nm = [650.0]\nsun_elevation_deg = [0.0]\nrays = 60\npolar_step_deg = 0.5\nazimuth_step_deg = 30.0\n";

    #[test]
    fn rejects_bad_mixtures() {
        crate::stages::assert_planning(
            &Mixture2dStage,
            &[
                "distributions = []",
                "distributions = [{ radii_um = [400.0], number_weights = [1.0, 2.0] }]",
                "distributions = [{ radii_um = [400.0], number_weights = [0.0] }]",
                "distributions = [{ radii_um = [5.0], number_weights = [1.0] }]",
                "distributions = [{ radii_um = [400.0], number_weights = [1.0] }]\nradius_points = 0",
            ],
            &[
                "distributions = [{ radii_um = [400.0, 1000.0], number_weights = [1.0, 1.0] }]",
                "distributions = [{ kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = 500.0, max_radius_um = 1250.0 }]",
            ],
        );
    }

    /// A one-radius mixture is the `raytrace` stage's table of that radius; a two-radius
    /// mixture lies between its components, pixel by pixel, with the cross-section weights.
    #[test]
    fn mixture_of_one_radius_is_the_raytrace_table() {
        let one = run_in_memory(
            &*plan_from_lines(
                &Mixture2dStage,
                &format!(
                    "{SMALL}distributions = [{{ radii_um = [1000.0], number_weights = [3.0] }}]"
                ),
            )
            .unwrap(),
        )
        .unwrap();
        let rt = run_in_memory(
            &*plan_from_lines(
                &crate::stages::raytrace::RaytraceStage,
                &format!("{SMALL}shape = \"beard-chuang\"\nradii_um = [1000.0]"),
            )
            .unwrap(),
        )
        .unwrap();
        // Equal up to the f32 rounding of dolp (recomputed from the stored i_perp, i_par).
        assert_eq!(one.data.len(), rt.data.len());
        let nch = one.channels.len();
        for (x, y) in one.data.chunks(nch).zip(rt.data.chunks(nch)) {
            for c in 0..nch {
                let tol = if c == DOLP_CHANNEL { 1e-6 } else { 0.0 };
                assert!(
                    (x[c] - y[c]).abs() <= tol,
                    "channel {c}: {} vs {}",
                    x[c],
                    y[c]
                );
            }
        }
        assert_eq!(one.axes[0].name, "distribution");
        assert_eq!(one.schema, rt.schema);
        let small = run_in_memory(
            &*plan_from_lines(
                &Mixture2dStage,
                &format!("{SMALL}distributions = [{{ radii_um = [400.0], number_weights = [1.0] }}, {{ radii_um = [400.0, 1000.0], number_weights = [1.0, 1.0] }}]"),
            )
            .unwrap(),
        )
        .unwrap();
        let n = one.data.len();
        assert_eq!(small.data.len(), 2 * n);
        let (a, mix) = small.data.split_at(n);
        let mut between = 0usize;
        let mut total = 0usize;
        for ((x, y), m) in a.chunks(nch).zip(one.data.chunks(nch)).zip(mix.chunks(nch)) {
            // phase channel: within the components' range up to the renormalisation (< 1 %).
            let (lo, hi) = (x[0].min(y[0]), x[0].max(y[0]));
            total += 1;
            if m[0] >= lo * 0.99 - 1e-9 && m[0] <= hi * 1.01 + 1e-9 {
                between += 1;
            }
        }
        assert_eq!(between, total);
    }

    /// The `phase` values of azimuth column `k` of entry `e` (one wavelength, one elevation).
    fn column(t: &TableContent, e: usize, k: usize) -> Vec<f64> {
        let (np, na, nch) = (t.axes[3].len(), t.axes[4].len(), t.channels.len());
        let base = e * np * na * nch;
        (0..np)
            .map(|j| t.data[base + (j * na + k) * nch] as f64)
            .collect()
    }

    /// `c` (polar step `step` deg) seen through the sun's disc (0.5°) along θ: each value the
    /// mean over ±0.25° weighted by the disc's chord length √(1 − (Δ/0.25°)²), as an image of
    /// the bow sees it. The main channels keep the traced cross-order ripple (≈ 0.1° period),
    /// which the disc averages out.
    fn through_sun_disc(c: &[f64], step: f64) -> Vec<f64> {
        let half = (0.25 / step).round() as isize;
        let w: Vec<f64> = (-half..=half)
            .map(|d| (1.0 - (d as f64 * step / 0.25).powi(2)).max(0.0).sqrt())
            .collect();
        (0..c.len() as isize)
            .map(|j| {
                let (mut s, mut sw) = (0.0, 0.0);
                for (d, wd) in (-half..=half).zip(&w) {
                    if let Some(v) = c.get((j + d) as usize).filter(|_| j + d >= 0) {
                        s += wd * v;
                        sw += wd;
                    }
                }
                s / sw
            })
            .collect()
    }

    /// Polar angle (deg) of the largest value of `c` within `lo..=hi` deg.
    fn argmax_deg(c: &[f64], step: f64, lo: f64, hi: f64) -> f64 {
        let (a, b) = ((lo / step).round() as usize, (hi / step).round() as usize);
        (a..=b).max_by(|&x, &y| c[x].total_cmp(&c[y])).unwrap() as f64 * step
    }

    /// Whether `c` has a local maximum (largest within ±0.25°) within 0.1° of `at_deg`.
    fn local_max_near(c: &[f64], step: f64, at_deg: f64) -> bool {
        let half = (0.25 / step).round() as usize;
        let near = (0.1 / step).round() as usize;
        let j0 = (at_deg / step).round() as usize;
        (j0 - near..=j0 + near).any(|j| (j - half..=j + half).all(|i| c[i] <= c[j]))
    }

    /// The twinned rainbow (Sadeghi 2012, §3.5, Fig. 3.20: spherical and flattened drops mixed,
    /// the primary twinned, the secondary not): 0.4 mm drops (spheres) mixed with 0.7 mm
    /// Beard–Chuang drops, sun on the horizon, 650 nm. At the bow's top (φ = 180°) the two sizes
    /// put their primary maxima ≥ 1° apart and the mixture keeps both as separate maxima; at the
    /// bow's feet (φ = 90°, horizontal plane, where a drop with a vertical axis is circular) the
    /// maxima coincide within 0.3°, so the bow splits near its top only. Columns are compared
    /// as seen through the sun's disc.
    #[test]
    fn twinned_primary_splits_at_the_top_of_the_bow_only() {
        let t = run_in_memory(
            &*plan_from_lines(
                &Mixture2dStage,
                "wavelengths_nm = [650.0]\nsun_elevation_deg = [0.0]\nrays = 400\npolar_step_deg = 0.05\nazimuth_step_deg = 10.0\nwater_index_model = \"sadeghi-table-3.2\"\ndistributions = [{ radii_um = [400.0, 700.0], number_weights = [1.0, 0.33] }, { radii_um = [400.0], number_weights = [1.0] }, { radii_um = [700.0], number_weights = [1.0] }]",
            )
            .unwrap(),
        )
        .unwrap();
        let step = 0.05;
        let (top, side) = (18, 9); // φ = 180°, 90°
        let seen = |e: usize, k: usize| through_sun_disc(&column(&t, e, k), step);
        let (mix, sph, flat) = (seen(0, top), seen(1, top), seen(2, top));
        let (a, b) = (
            argmax_deg(&sph, step, 134.0, 148.0),
            argmax_deg(&flat, step, 134.0, 148.0),
        );
        assert!(b - a >= 1.0, "top: sphere {a}°, flattened {b}°: no twin");
        assert!(
            local_max_near(&mix, step, a),
            "mixture lost the sphere maximum at {a}°"
        );
        assert!(
            local_max_near(&mix, step, b),
            "mixture lost the flattened maximum at {b}°"
        );
        let (sa, sb) = (
            argmax_deg(&seen(1, side), step, 134.0, 148.0),
            argmax_deg(&seen(2, side), step, 134.0, 148.0),
        );
        assert!((sa - sb).abs() <= 0.3, "feet: {sa}° vs {sb}°");
        eprintln!(
            "primary maxima at the top: {a}° (0.4 mm), {b}° (0.7 mm); at the feet {sa}°, {sb}°"
        );
    }
}
