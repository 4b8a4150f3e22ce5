//! The `mie` stage (schema `mie-phase/1`): per-wavelength Lorenz–Mie phase functions of water
//! drops (monodisperse radii or size distributions), smoothed by the sun's disc and integrated
//! over the table's angular bins. Follows the phase-function table contract
//! (`docs/consumers.md`): axes `radius` (µm) or `distribution` (1) × `wavelength` (nm) ×
//! `scattering_angle` (deg); channels `phase`, `i_perp`, `i_par`, `dolp`; per-entry Q_ext, Q_sca,
//! Q_back, g as f64 arrays `[entry][wavelength]` in the header attributes.

use crate::mie::distributions::SizeDistribution;
use crate::mie::ensemble::{DEFAULT_RADIUS_TOLERANCE, compute_entry};
use crate::stages::common::{
    CONTRACT_CHANNELS, FilteredPhase, filtered_phase_params, phase_chunk, scalar_arrays,
};
use crate::stages::phase_contract;
use crate::stages::{Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, checks};
use crate::table::{Axis, Schema, TableContent};

/// The stage.
pub struct MieStage;

filtered_phase_params! {
    /// Parameters of `[table.params]`.
    pub struct MieParams {
        /// Monodisperse radii (µm), strictly increasing. Exactly one of `radii_um`/`distributions`.
        pub radii_um: Option<Vec<f64>> = optional("required unless distributions"),
            "list of float, µm", "monodisperse drop radii, strictly increasing";
        /// Size distributions (tables with `kind = "lognormal" | "gamma" | "marshall-palmer" |
        /// "monodisperse"`).
        pub distributions: Option<Vec<SizeDistribution>> = optional("required unless radii_um"),
            "list of tables",
            "size distributions: kind = lognormal {median_radius_um, geometric_sigma} | gamma {effective_radius_um, effective_variance} | marshall-palmer {rain_rate_mm_h, min_radius_um=50, max_radius_um=3000} | monodisperse {radius_um}";
        /// Optional extra 1-D Gaussian blur (deg, standard deviation); 0 = off.
        pub gaussian_sigma_deg: f64 = default(0.0),
            "float, deg", "optional extra Gaussian blur in angle";
        /// Gauss–Legendre points in ln r for distributions when `radius_tolerance = 0`.
        pub radius_points: usize = default(DEFAULT_RADIUS_POINTS),
            "integer", "Gauss–Legendre nodes in ln r per distribution (only with radius_tolerance = 0)";
        /// Largest accepted estimated error of a size-distribution entry: RMS over the output
        /// bins and `i_perp`, `i_par` of the error relative to the bin's phase function, from
        /// the nested adaptive radius rule (decision MIE-18); an entry that cannot meet it
        /// within the node limit fails. 0 selects the Gauss–Legendre rule of `radius_points`
        /// nodes (no estimate).
        pub radius_tolerance: f64 = default(DEFAULT_RADIUS_TOLERANCE),
            "float", "distributions: largest estimated output error, RMS over bins and i_perp, i_par relative to the phase function (adaptive radius rule, fails if not met within the node limit); 0 = Gauss–Legendre rule of radius_points nodes";
        /// Real refractive index of the (non-absorbing) medium around the drops; the water
        /// index and the vacuum wavelength are divided by it. Left out of the content key when 1.
        #[serde(skip_serializing_if = "is_vacuum")]
        pub n_medium: f64 = default(1.0),
            "float", "index of the medium around the drops (1–3); m = n_water/n_medium, x = 2 pi r n_medium/lambda";
    }
}

/// `n_medium == 1` (the default, left out of the parameters and so of the content key).
fn is_vacuum(n_medium: &f64) -> bool {
    *n_medium == 1.0
}

/// The scalars of each task's chunk ([`phase_chunk`]), stored in the header as
/// `[entry][wavelength]` arrays (the last three only for adaptively averaged distributions).
const SCALARS: [&str; 7] = [
    "q_ext",
    "q_sca",
    "q_back",
    "g",
    "radius_nodes",
    "radius_error_rms",
    "radius_error_max",
];

/// Default of `radius_points`.
pub const DEFAULT_RADIUS_POINTS: usize = 24;

/// The entries (second axis) of a job.
#[derive(Debug, Clone)]
enum Entries {
    Radii(Vec<f64>),
    Distributions(Vec<SizeDistribution>),
}

impl Entries {
    fn len(&self) -> usize {
        match self {
            Entries::Radii(r) => r.len(),
            Entries::Distributions(d) => d.len(),
        }
    }
    fn distribution(&self, i: usize) -> SizeDistribution {
        match self {
            Entries::Radii(r) => SizeDistribution::Monodisperse { radius_um: r[i] },
            Entries::Distributions(d) => d[i].clone(),
        }
    }
}

struct MieJob {
    p: MieParams,
    entries: Entries,
    filter: FilteredPhase,
}

impl StageSpec for MieStage {
    const NAME: &'static str = "mie";
    /// 2: axes radius × wavelength × angle, Q and g kept in f64. 3: `sadeghi-table-3.2`
    /// corrected at 580–650 nm; attribute `sun_diameter_deg`. 4: key and attribute `n_medium`.
    /// 5: distributions averaged by joint radius × angle sampling to `radius_tolerance`
    /// (MIE-16), attributes `radius_nodes`, `radius_error_rms`, labelled `distribution` axis.
    /// 6: distributions averaged by the adaptive radius rule to an estimated output error
    /// `radius_tolerance` (MIE-18, default 1e-3).
    /// 7: attribute `radius_error_max` (the estimate of the largest error over the bins).
    /// 8: `radius_error_max` also from the previous halving (MIE-20).
    const VERSION: u32 = 8;
    const SUMMARY: &'static str = "Lorenz–Mie phase functions of water drops (radii or size distributions), sun-disc smoothed, bin-integrated";
    type Params = MieParams;
    fn plan_params(&self, p: MieParams) -> Result<Box<dyn Job>, PlanError> {
        let filter = FilteredPhase::plan(p.filter_keys(p.gaussian_sigma_deg, p.radius_points))?;
        let mut filter = filter;
        checks::within("n_medium", p.n_medium, 1.0, 3.0, "")?;
        if p.radius_tolerance != 0.0 {
            checks::within("radius_tolerance", p.radius_tolerance, 1e-4, 0.5, " (or 0)")?;
            // a node count the adaptive rule would ignore is a mistake, not a setting
            if p.radius_points != DEFAULT_RADIUS_POINTS {
                return Err(PlanError::invalid(
                    "radius_points",
                    format!(
                        "{} has no effect while radius_tolerance = {} (distributions are averaged \
                         adaptively to that tolerance); set radius_tolerance = 0 to use a Gauss–Legendre rule of \
                         radius_points nodes, or leave radius_points out",
                        p.radius_points, p.radius_tolerance
                    ),
                ));
            }
        }
        filter.settings.radius_tolerance = p.radius_tolerance;
        let (entries, entries_key) = match (&p.radii_um, &p.distributions) {
            (Some(r), None) => {
                checks::increasing("radii_um", r, true)?;
                (Entries::Radii(r.clone()), "radii_um")
            }
            (None, Some(d)) => {
                if d.is_empty() {
                    return Err(PlanError::invalid("distributions", "must not be empty"));
                }
                for (i, dist) in d.iter().enumerate() {
                    dist.validate()
                        .map_err(|m| PlanError::invalid(&format!("distributions[{i}]"), m))?;
                }
                (Entries::Distributions(d.clone()), "distributions")
            }
            _ => {
                return Err(PlanError::invalid(
                    "radii_um",
                    "give exactly one of `radii_um` and `distributions`",
                ));
            }
        };
        // every wavelength with the radii at the ends of each entry's support must be inside the
        // validated Mie domain
        for e in 0..entries.len() {
            let (lo, hi) = entries.distribution(e).support_um();
            filter.check_domain(entries_key, &[lo, hi], p.n_medium)?;
        }
        Ok(Box::new(MieJob { p, entries, filter }))
    }
}

impl MieJob {
    fn entry_axis(&self) -> Axis {
        match &self.entries {
            Entries::Radii(r) => Axis::values("radius", "um", r.clone()),
            Entries::Distributions(d) => Axis::labelled(
                "distribution",
                "1",
                (0..d.len()).map(|i| i as f64).collect(),
                d.iter().map(SizeDistribution::label).collect(),
            ),
        }
    }
}

impl Job for MieJob {
    /// Known at plan time (checked against the reader's limit before any task runs).
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(self.filter.axes(self.entry_axis()), CONTRACT_CHANNELS)
    }
    /// Every sphere of every task: a radius entry is one sphere per wavelength; a
    /// distribution is counted as its `radius_points` Gauss–Legendre nodes, or, with the
    /// adaptive rule, as the node count expected at `radius_tolerance`
    /// (`mie::size_average::planned_radii_um`; the rule chooses its own count, so this estimate
    /// is rougher).
    fn estimated_cpu_seconds(&self) -> f64 {
        let n = self.p.n_medium;
        (0..self.entries.len())
            .map(|e| match &self.entries {
                Entries::Radii(r) => self.filter.estimated_entry_cpu_s(r[e], n),
                Entries::Distributions(d) => {
                    let nodes = if self.p.radius_tolerance > 0.0 {
                        crate::mie::size_average::planned_radii_um(&d[e], self.p.radius_tolerance)
                    } else {
                        d[e].quadrature(self.p.radius_points).0
                    };
                    nodes
                        .iter()
                        .map(|&r| self.filter.estimated_entry_cpu_s(r, n))
                        .sum()
                }
            })
            .sum()
    }
    fn estimated_stored_fraction(&self) -> f64 {
        crate::stages::cost::STORED_FRACTION_MIE
    }
    /// Per task: cross-sections, asymmetry and the water index in the header.
    fn estimated_attribute_bytes(&self) -> u64 {
        use crate::stages::cost::{ATTRIBUTE_BYTES, ATTRIBUTE_BYTES_PER_SCALAR};
        ATTRIBUTE_BYTES + ATTRIBUTE_BYTES_PER_SCALAR * 5 * self.tasks().len() as u64
    }
    fn parameters(&self) -> serde_json::Value {
        serde_json::to_value(&self.p).expect("params serialise")
    }
    fn tasks(&self) -> Vec<TaskSpec> {
        self.filter.tasks(self.entries.len(), |e, l, n| {
            let d = self.entries.distribution(e);
            TaskSpec {
                label: format!("λ={l} nm {}", serde_json::to_string(&d).unwrap_or_default()),
                params: serde_json::json!({ "wavelength_nm": l, "n": n, "entry": d }),
            }
        })
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (e, wavelength_nm, m) = self.filter.task(index);
        let n_medium = self.p.n_medium;
        let r = compute_entry(
            &self.entries.distribution(e),
            wavelength_nm / n_medium,
            m / n_medium,
            &self.filter.settings,
            self.filter.sun(),
        )?;
        Ok(phase_chunk(
            &r.curve,
            &[],
            &[
                r.q_ext,
                r.q_sca,
                r.q_back,
                r.g,
                r.radius_nodes as f64,
                r.error_rms,
                r.error_max,
            ],
        ))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let (data, tails) = self.filter.split_chunks(
            chunks,
            self.entries.len(),
            CONTRACT_CHANNELS,
            SCALARS.len(),
        )?;
        let mut a = self.filter.attributes("integral over 4pi sr equals 1");
        let s = |v: &str| serde_json::Value::from(v);
        a.insert(
            "gaussian_sigma_deg".into(),
            self.p.gaussian_sigma_deg.into(),
        );
        a.insert("n_medium".into(), self.p.n_medium.into());
        if self.p.n_medium != 1.0 {
            a.insert("medium".into(), s(&format!("water drops in a non-absorbing medium of index n_medium = {}: relative index refractive_index_real/n_medium, wavelength in the medium wavelength_nm/n_medium; Q, g and the phase function are those in the medium", self.p.n_medium)));
        }
        a.insert(
            "validated_domain".into(),
            s(crate::mie::VALIDATED_DOMAIN_TEXT),
        );
        a.insert("conventions".into(), s("Bohren & Huffman: exp(-i omega t), m = n + ik; i_perp = |S1|^2, i_par = |S2|^2 over (pi x^2 Q_sca); phase = (i_perp + i_par)/2; dolp = (i_perp - i_par)/(i_perp + i_par)"));
        let sampled =
            matches!(self.entries, Entries::Distributions(_)) && self.p.radius_tolerance > 0.0;
        a.insert("size_distribution_weighting".into(), s(if sampled {
            "normalised phase functions mixed with weights n(r) dr * C_sca(r); radius rule uniform in r on panels between quantiles of n(r) r^2 (trapezoid with Gregory end corrections, steps halved), each node exact cell averages; error estimate = difference of the last two nested rules after sun disc and bins, RMS over bins and i_perp, i_par relative to phase, <= radius_tolerance; the same estimate's largest value over bins and channels radius_error_max (estimated, not bounded); radius_nodes, radius_error_rms and radius_error_max per [entry][wavelength]"
        } else {
            "normalised phase functions mixed with weights n(r) dr * C_sca(r); Gauss-Legendre in ln r"
        }));
        if let Entries::Distributions(d) = &self.entries {
            a.insert("distributions".into(), serde_json::to_value(d)?);
            a.insert("radius_tolerance".into(), self.p.radius_tolerance.into());
        }
        for (k, name) in SCALARS.iter().enumerate() {
            if k >= 4 && !sampled {
                continue;
            }
            a.insert(
                (*name).into(),
                serde_json::to_value(scalar_arrays(&tails, k))?,
            );
        }
        // MiePlot's per-steradian Q_back is the radar-convention one over 4π.
        let per_sr: Vec<Vec<f64>> = scalar_arrays(&tails, 2)
            .iter()
            .map(|row| {
                row.iter()
                    .map(|q| q / (4.0 * std::f64::consts::PI))
                    .collect()
            })
            .collect();
        a.insert("q_back_per_sr".into(), serde_json::to_value(per_sr)?);
        a.insert(
            "q_back_convention".into(),
            s(crate::mie::Q_BACK_CONVENTIONS),
        );
        a.insert("scalar_layout".into(), s("q_ext, q_sca, q_back, q_back_per_sr, g: [entry][wavelength] (f64); ensemble averages <C>/<pi r^2>, g weighted by C_sca"));
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("mie-phase", 1),
            description: "Lorenz-Mie phase functions of water drops per wavelength".into(),
            axes: self.filter.axes(self.entry_axis()),
            channels: phase_contract::channels("over pi x^2 Q_sca"),
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mie::{Sphere, size_parameter};
    use crate::optics::water::WaterIndexModel;
    use crate::stages::common::bin_integrals;
    use crate::stages::plan_from_lines;
    use num_complex::Complex64;

    #[test]
    fn rejects_bad_params() {
        crate::stages::assert_planning(
            &MieStage,
            &[
                "radii_um = [10.0]\nangle_step_deg = 0.07",
                "radii_um = [10.0, 5.0]",
                "radii_um = [1e5]\nwavelengths_nm = [380.0]",
                "wavelengths_nm = [550.0]",
                "radii_um = [10.0]\nunknown = 1",
                "radii_um = [10.0]\nwater_index_model = \"sadeghi-table-3.2\"\nwavelengths_nm = [750.0]",
                "radii_um = [10.0]\nn_medium = 0.5",
                "radii_um = [10.0]\nn_medium = 3.5",
                // a node count the adaptive rule would ignore
                "radii_um = [10.0]\nradius_points = 12",
            ],
            &[
                "radii_um = [10.0]",
                "radii_um = [10.0]\nradius_points = 12\nradius_tolerance = 0.0",
            ],
        );
    }

    /// A small job end to end: table shape, contract attributes, and ∫ p dΩ = 1 over the
    /// output bins after sun disc and bin integration.
    #[test]
    fn small_job_is_normalised() {
        let t = crate::stages::table_from_lines(
            &MieStage,
            "radii_um = [2.0, 20.0]\nwavelengths_nm = [450.0, 650.0]\nangle_step_deg = 0.5",
        );
        assert_eq!(t.data.len(), t.expected_len());
        assert_eq!(t.axes[0].name, "radius");
        assert_eq!(t.axes[1].name, "wavelength");
        assert_eq!(t.axes[2].name, "scattering_angle");
        // Header Q_sca [entry][wavelength] keeps f64 precision: the 20 µm drop at 650 nm
        // against a direct evaluation.
        let q = t.attributes["q_sca"][1][1].as_f64().unwrap();
        let n = WaterIndexModel::Iapws1997 {
            temperature_c: 20.0,
        }
        .index(650.0)
        .unwrap();
        let direct =
            crate::mie::MieCoefficients::new(size_parameter(20.0, 650.0), Complex64::new(n, 0.0))
                .unwrap()
                .efficiencies()
                .q_sca;
        assert!((q - direct).abs() <= 1e-12 * direct, "{q} vs {direct}");
        assert!((q - q as f32 as f64).abs() > 0.0, "stored as f64, not f32");
        let cells = crate::mie::filters::cell_solid_angles(360);
        for e in bin_integrals(&t.data, 4, 0, &cells) {
            assert!((e - 1.0).abs() < 1e-5, "integral {e}");
        }
        // phase = (i_perp + i_par)/2
        assert!(
            t.data
                .chunks(4)
                .all(|c| (c[0] - 0.5 * (c[1] + c[2])).abs() <= 1e-6 * c[0].abs())
        );
    }

    /// A size distribution entry: normalised, and its ensemble Q_sca lies between the
    /// single-sphere values at the ends of the support (weights n(r) dr · π r²).
    #[test]
    fn distribution_entry_is_normalised() {
        let job = plan_from_lines(
            &MieStage,
            "distributions = [{ kind = \"gamma\", effective_radius_um = 3.0, effective_variance = 0.1 }]\nwavelengths_nm = [550.0]\nangle_step_deg = 0.5",
        )
        .unwrap();
        let chunk = job.run_task(0).unwrap();
        assert_eq!(chunk.values.len(), 361 * 4);
        let cells = crate::mie::filters::cell_solid_angles(360);
        let e = bin_integrals(&chunk.values, 4, 0, &cells)[0];
        assert!((e - 1.0).abs() < 1e-5, "integral {e}");
        let q_sca = chunk.scalars[1];
        assert!(q_sca > 1.8 && q_sca < 2.6, "Q_sca {q_sca}");
        let g = chunk.scalars[3];
        assert!(g > 0.7 && g < 0.9, "g {g}");
    }

    /// Adaptive distributions (`radius_tolerance` > 0): the `distribution` axis names its
    /// entries, and the header gives each entry's node count and error estimate, which meets
    /// the tolerance.
    #[test]
    fn distribution_axis_is_labelled_and_error_stated() {
        let t = crate::stages::table_from_lines(
            &MieStage,
            "distributions = [{ kind = \"gamma\", effective_radius_um = 3.0, effective_variance = 0.1 }, { kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = 50.0, max_radius_um = 60.0 }]\nwavelengths_nm = [550.0]\nangle_step_deg = 1.0\nradius_tolerance = 0.05",
        );
        assert_eq!(t.axes[0].name, "distribution");
        assert_eq!(
            t.axes[0].labels,
            [
                "gamma r_eff=3 um v_eff=0.1",
                "marshall-palmer R=5 mm/h r=50-60 um"
            ]
        );
        for e in 0..2 {
            let nodes = t.attributes["radius_nodes"][e][0].as_f64().unwrap();
            let err = t.attributes["radius_error_rms"][e][0].as_f64().unwrap();
            let max = t.attributes["radius_error_max"][e][0].as_f64().unwrap();
            assert!(nodes >= 20.0, "{nodes}");
            assert!(err > 0.0 && err <= 0.05, "{err}");
            // the largest error over the bins is at least their RMS
            assert!(max >= err && max.is_finite(), "{max} {err}");
        }
        assert_eq!(t.attributes["radius_tolerance"].as_f64(), Some(0.05));
    }

    /// Drops in a medium (`n_medium`): the header Q_sca is the sphere of relative index
    /// n_water/n_medium and size parameter 2π r n_medium/λ; the key is recorded in the header
    /// and kept out of the parameters (and so of the content key) when 1.
    #[test]
    fn medium_index_divides_index_and_wavelength() {
        let lines = "radii_um = [2.0]\nwavelengths_nm = [650.0]\nangle_step_deg = 1.0";
        let t = crate::stages::table_from_lines(&MieStage, &format!("{lines}\nn_medium = 1.2"));
        assert_eq!(t.attributes["n_medium"].as_f64(), Some(1.2));
        assert!(t.attributes["medium"].as_str().unwrap().contains("1.2"));
        let n = WaterIndexModel::default().index(650.0).unwrap();
        let (x, m) = crate::mie::in_medium(2.0, 650.0, Complex64::new(n, 0.0), 1.2);
        assert!((x - size_parameter(2.0, 650.0) * 1.2).abs() < 1e-12 * x);
        let direct = Sphere::new(x, m).unwrap().efficiencies.q_sca;
        let q = t.attributes["q_sca"][0][0].as_f64().unwrap();
        assert!((q - direct).abs() <= 1e-12 * direct, "{q} vs {direct}");
        let vacuum = crate::stages::table_from_lines(&MieStage, lines);
        let q1 = vacuum.attributes["q_sca"][0][0].as_f64().unwrap();
        assert!(
            (q1 - q).abs() > 1e-3,
            "the medium changes Q_sca: {q1} vs {q}"
        );
        assert_eq!(vacuum.attributes["n_medium"].as_f64(), Some(1.0));
        // n_medium = 1 is not in the parameters (tables built before the key keep their key).
        let job = plan_from_lines(&MieStage, lines).unwrap();
        assert!(job.parameters().get("n_medium").is_none());
        let job = plan_from_lines(&MieStage, &format!("{lines}\nn_medium = 1.2")).unwrap();
        assert_eq!(job.parameters()["n_medium"].as_f64(), Some(1.2));
        // A drop matched to its medium is refused at plan time, naming the key.
        let err = plan_from_lines(&MieStage, &format!("{lines}\nn_medium = {n}"))
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("radii_um"), "{err}");
    }
}
