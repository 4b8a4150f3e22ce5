//! `mixture` stage (schema `mixture-phase/1`): phase functions of drop-size mixtures that use
//! Lorenz–Mie for the small drops and the ray tracer's exact 1-D sphere path (geometric optics
//! plus phase, Airy-uniform caustics; Sadeghi 2012 ch. 3) for the large ones.
//!
//! For each (distribution, wavelength) the distribution's Gauss–Legendre rule in ln r (the one
//! of the `mie` stage, `radius_points` nodes) gives radii r_i and number weights n(r_i) dr_i.
//! Each radius contributes its normalised curve p_i (Mie below `handover_radius_um`, traced at
//! or above it) with weight n(r_i) dr_i · C_sca(r_i), where C_sca = π r² Q_sca for Mie and
//! σ_GO + π r² (traced orders plus the forward Fraunhofer lobe) for traced drops. The mix is
//! formed on the `mie` stage's intermediate grid, convolved with the sun's disc and averaged
//! over the output bins exactly as the `mie` stage does, so a mixture whose radii all lie below
//! the handover is the `mie` stage's table of the same distribution with its Gauss–Legendre rule
//! (`radius_tolerance = 0`; tested to 1e-3). The `mie` stage's default, the sampled radius ×
//! angle average (decision MIE-16), is not used here.
//!
//! Output follows the phase-function contract (`docs/consumers.md`): axes distribution ×
//! wavelength × scattering_angle, channels phase, i_perp, i_par, dolp, so every 1-D consumer
//! (read, export, plot, render) works on it.
//!
//! Size distributions: `marshall-palmer` (Marshall & Palmer 1948), `gamma`, `lognormal`,
//! `monodisperse` (the `mie` stage's kinds), or `explicit` radii with number weights.

use crate::mie::distributions::SizeDistribution;
use crate::mie::filters::PolarisedPhase;
use crate::raytrace::mixture::{Handover, mix_sizes};
use crate::stages::common::{
    CONTRACT_CHANNELS, FilteredPhase, filtered_phase_params, phase_chunk, scalar_arrays,
};
use crate::stages::phase_contract;
use crate::stages::{Chunk, Job, JobError, PlanError, StageSpec, TaskSpec, checks};
use crate::table::{Axis, Schema, TableContent};
use serde::{Deserialize, Serialize};

/// The stage.
pub struct MixtureStage;

/// Explicit radii with number weights (any unit; normalised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplicitMixture {
    pub radii_um: Vec<f64>,
    pub number_weights: Vec<f64>,
}

/// One entry of the `distribution` axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MixtureEntry {
    Explicit(ExplicitMixture),
    Distribution(SizeDistribution),
}

impl MixtureEntry {
    /// Radii (µm) and number weights n(r) dr.
    fn nodes(&self, points: usize) -> (Vec<f64>, Vec<f64>) {
        match self {
            MixtureEntry::Explicit(e) => (e.radii_um.clone(), e.number_weights.clone()),
            MixtureEntry::Distribution(d) => d.quadrature(points),
        }
    }

    /// A short name with the parameters, for the labels of the `distribution` axis.
    pub fn label(&self) -> String {
        match self {
            MixtureEntry::Distribution(d) => d.label(),
            MixtureEntry::Explicit(e) => {
                let (lo, hi) = self.support_um();
                match e.radii_um.len() {
                    1 => format!("explicit r={lo} um"),
                    n => format!("explicit {n} radii r={lo}-{hi} um"),
                }
            }
        }
    }

    /// Smallest and largest radius (µm).
    pub(crate) fn support_um(&self) -> (f64, f64) {
        match self {
            MixtureEntry::Explicit(e) => e
                .radii_um
                .iter()
                .fold((f64::INFINITY, 0.0), |(lo, hi), &r| (lo.min(r), hi.max(r))),
            MixtureEntry::Distribution(d) => d.support_um(),
        }
    }
}

/// Default handover radius (µm): where Beard–Chuang drops depart from the sphere (a ≤ 0.4 mm is
/// a sphere, as in Sadeghi 2012), so below it Lorenz–Mie is exact for the drops the traced
/// tables assume. Ray optics misses 12–16 % of Alexander's dark band at 0.1–0.2 mm and is within
/// 10 % of it from 0.4 mm up with orders to 6 (docs/raytrace.md, decision RT-15).
pub const DEFAULT_HANDOVER_UM: f64 = 400.0;

/// Smallest radius the traced path accepts (µm), as the `raytrace` stage.
const MIN_TRACED_UM: f64 = 10.0;

/// The scalar of each task's chunk: the traced share of the scattering cross-section.
const SCALARS: [&str; 1] = ["traced_fraction"];

filtered_phase_params! {
    /// Parameters of `[table.params]`.
    pub struct MixtureParams {
        /// One table entry per distribution.
        pub distributions: Vec<MixtureEntry> = required, "list of tables",
            "kind = marshall-palmer {rain_rate_mm_h, min_radius_um, max_radius_um} | gamma | lognormal | monodisperse (as the mie stage), or {radii_um, number_weights}";
        /// Gauss–Legendre points in ln r for distributions.
        pub radius_points: usize = default(24),
            "integer", "Gauss–Legendre nodes in ln r per distribution";
        /// Radii below this use Lorenz–Mie, radii at or above it the traced 1-D path (µm).
        pub handover_radius_um: f64 = default(DEFAULT_HANDOVER_UM),
            "float, µm", "radii below use Lorenz–Mie, radii at or above the traced 1-D sphere path";
        /// Highest order traced for the large drops (6: the p = 6 rays fill Alexander's dark
        /// band, decision RT-30).
        pub max_order: usize = default(6),
            "integer", "highest order traced for the large drops, 1–8";
    }
}

impl StageSpec for MixtureStage {
    const NAME: &'static str = "mixture";
    /// 2: curved-surface coefficients in the traced path (RT-29), `max_order` default 6 (RT-30).
    /// 3: `handover_radius_um` default 400 µm (RT-15).
    /// 4: Fresnel amplitudes in real arithmetic below the critical angle (last bits).
    /// 5: the traced radii's orders p ≥ 4 take their grazing waves (decision RT-36), and their
    /// rays carry the axial focal-line phases (RT-38).
    /// 6: the traced radii's Debye surface coefficients are regular where sin(mx) vanishes.
    const VERSION: u32 = 6;
    const SUMMARY: &'static str = "drop-size mixtures: Lorenz–Mie for small drops, traced spheres for large ones, weighted by number × scattering cross-section";
    type Params = MixtureParams;
    fn plan_params(&self, p: MixtureParams) -> Result<Box<dyn Job>, PlanError> {
        let filter = FilteredPhase::plan(p.filter_keys(0.0, p.radius_points))?;
        if p.distributions.is_empty() {
            return Err(PlanError::invalid("distributions", "must not be empty"));
        }
        for (i, e) in p.distributions.iter().enumerate() {
            validate_entry(i, e)?;
        }
        if !(p.handover_radius_um >= MIN_TRACED_UM) {
            return Err(PlanError::invalid(
                "handover_radius_um",
                format!("must be ≥ {MIN_TRACED_UM} µm (geometric optics needs x ≫ 1)"),
            ));
        }
        checks::within("max_order", p.max_order, 1, 8, "")?;
        // The Mie part of every entry must lie in the validated Mie domain.
        for e in &p.distributions {
            let (lo, hi) = e.support_um();
            let mie: Vec<f64> = [lo, hi.min(p.handover_radius_um)]
                .into_iter()
                .filter(|r| *r < p.handover_radius_um)
                .collect();
            filter.check_domain("distributions", &mie, 1.0)?;
        }
        Ok(Box::new(MixtureJob { p, filter }))
    }
}

struct MixtureJob {
    p: MixtureParams,
    filter: FilteredPhase,
}

fn validate_entry(i: usize, e: &MixtureEntry) -> Result<(), PlanError> {
    let key = format!("distributions[{i}]");
    match e {
        MixtureEntry::Distribution(d) => d.validate().map_err(|m| PlanError::invalid(&key, m)),
        MixtureEntry::Explicit(x) => {
            let ok = !x.radii_um.is_empty()
                && x.radii_um.len() == x.number_weights.len()
                && x.radii_um.iter().all(|r| *r > 0.0 && r.is_finite())
                && x.number_weights.iter().all(|w| *w >= 0.0 && w.is_finite())
                && x.number_weights.iter().any(|w| *w > 0.0);
            ok.then_some(()).ok_or_else(|| {
                PlanError::invalid(
                    &key,
                    "radii_um and number_weights: same non-zero length, radii > 0, weights ≥ 0, not all 0",
                )
            })
        }
    }
}

/// One (distribution, wavelength): the mixed curve on the output grid and the fraction of the
/// scattering cross-section carried by traced drops; refuses traced curves that do not
/// integrate to about 1 and mixtures without a positive finite cross-section.
fn mix_entry(job: &MixtureJob, index: usize) -> Result<(PolarisedPhase, f64), JobError> {
    let (entry, l, m) = job.filter.task(index);
    let (radii, weights) = job.p.distributions[entry].nodes(job.p.radius_points);
    let handover = Handover {
        radius_um: job.p.handover_radius_um,
        max_order: job.p.max_order,
    };
    let mixed = mix_sizes(
        &radii,
        &weights,
        l,
        m.re,
        &job.filter.settings,
        job.filter.sun(),
        handover,
    )?;
    for &integral in &mixed.traced_integrals {
        crate::stages::check_phase_integral(entry, integral)?;
    }
    let total = mixed.cross_section_um2;
    if !(total > 0.0 && total.is_finite()) {
        return Err(JobError::NotNormalisable {
            entry,
            integral: total,
        });
    }
    Ok((mixed.curve, mixed.traced_fraction))
}

impl MixtureJob {
    /// The `distribution` axis: entry numbers labelled with each mixture.
    fn distribution_axis(&self) -> Axis {
        Axis::labelled(
            "distribution",
            "1",
            (0..self.p.distributions.len()).map(|i| i as f64).collect(),
            self.p
                .distributions
                .iter()
                .map(MixtureEntry::label)
                .collect(),
        )
    }
}

impl Job for MixtureJob {
    /// Known at plan time (checked against the reader's limit before any task runs).
    fn shape(&self) -> crate::stages::PlannedShape {
        crate::stages::PlannedShape::new(
            self.filter.axes(self.distribution_axis()),
            CONTRACT_CHANNELS,
        )
    }
    /// Lorenz–Mie spheres below the handover radius as in the `mie` stage; traced spheres
    /// above it at `cost::TRACED_SPHERE_CPU_S` each per wavelength.
    fn estimated_cpu_seconds(&self) -> f64 {
        let waves = self.filter.wavelengths_nm.len() as f64;
        let mut total = 0.0;
        for e in 0..self.p.distributions.len() {
            for &r in &self.p.distributions[e].nodes(self.p.radius_points).0 {
                total += if r < self.p.handover_radius_um {
                    self.filter.estimated_entry_cpu_s(r, 1.0)
                } else {
                    waves * crate::stages::cost::TRACED_SPHERE_CPU_S
                };
            }
        }
        total
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
        self.filter.tasks(self.p.distributions.len(), |e, l, n| TaskSpec {
            label: format!("{} λ={l} nm", self.p.distributions[e].label()),
            params: serde_json::json!({ "wavelength_nm": l, "n": n, "entry": self.p.distributions[e] }),
        })
    }
    fn run_task(&self, index: usize) -> Result<Chunk, JobError> {
        let (curve, traced) = mix_entry(self, index)?;
        Ok(phase_chunk(&curve, &[], &[traced]))
    }
    fn assemble(&self, chunks: Vec<Chunk>) -> Result<TableContent, JobError> {
        let entries = self.p.distributions.len();
        let (data, tails) =
            self.filter
                .split_chunks(chunks, entries, CONTRACT_CHANNELS, SCALARS.len())?;
        let mut a = self.filter.attributes("integral over 4pi sr equals 1");
        a.insert(
            "distributions".into(),
            serde_json::to_value(&self.p.distributions)?,
        );
        a.insert(
            "handover_radius_um".into(),
            self.p.handover_radius_um.into(),
        );
        a.insert("max_order".into(), self.p.max_order.into());
        a.insert(
            SCALARS[0].into(),
            serde_json::to_value(scalar_arrays(&tails, 0))?,
        );
        a.insert("mixture_weighting".into(), "normalised phase functions mixed with weights n(r) dr · C_sca(r) (Gauss–Legendre in ln r, or explicit weights); C_sca = π r² Q_sca (Lorenz–Mie, r < handover) or σ_GO + π r² (traced sphere, 1-D exact path with Airy-uniform caustics, r ≥ handover); mixed on the mie stage's intermediate grid, then sun disc and bin averages; traced_fraction[entry][wavelength] = traced share of the mixture's scattering cross-section".into());
        Ok(TableContent {
            encoding: Default::default(),
            schema: Schema::new("mixture-phase", 1),
            description:
                "phase functions of drop-size mixtures (Lorenz–Mie small drops, traced large drops)"
                    .into(),
            axes: self.filter.axes(self.distribution_axis()),
            channels: phase_contract::channels("over the mixture's scattering cross-section"),
            attributes: a,
            data,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::{plan_from_lines, run_in_memory};
    use std::f64::consts::PI;

    const MP: &str = "{ kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = 20.0, max_radius_um = 80.0 }";

    /// Identity: a Marshall–Palmer mixture whose radii all lie below the handover equals the
    /// `mie` stage's own Marshall–Palmer table with its Gauss–Legendre rule (`radius_tolerance =
    /// 0`: same quadrature radii, same weights) to 1e-3.
    #[test]
    fn mie_only_marshall_palmer_mixture_equals_the_mie_stage() {
        let common = "wavelengths_nm = [550.0]\nangle_step_deg = 0.5\nradius_points = 8\n";
        let mix = plan_from_lines(
            &MixtureStage,
            &format!("{common}distributions = [{MP}]\nhandover_radius_um = 1000.0"),
        )
        .unwrap();
        let mie = plan_from_lines(
            &crate::stages::mie::MieStage,
            &format!("{common}distributions = [{MP}]\nradius_tolerance = 0.0"),
        )
        .unwrap();
        let (a, b) = (run_in_memory(&*mix).unwrap(), run_in_memory(&*mie).unwrap());
        assert_eq!(a.data.len(), b.data.len());
        assert_eq!(a.attributes["traced_fraction"][0][0], 0.0);
        // both name the entry on the distribution axis
        for t in [&a, &b] {
            assert_eq!(t.axes[0].labels, ["marshall-palmer R=5 mm/h r=20-80 um"]);
        }
        let mut worst = 0.0f64;
        for (x, y) in a.data.iter().zip(&b.data).step_by(4) {
            worst = worst.max(((x - y) / y).abs() as f64);
        }
        assert!(worst < 1e-3, "max relative difference {worst}");
    }

    /// Moving the handover below the largest radii traces them: the traced share is positive,
    /// the table still integrates to 1 and changes near the primary bow.
    #[test]
    fn handover_switches_large_drops_to_the_traced_path() {
        let lines = |h: f64| {
            format!(
                "wavelengths_nm = [650.0]\nangle_step_deg = 0.5\nradius_points = 6\ndistributions = [{MP}]\nhandover_radius_um = {h}"
            )
        };
        let t = run_in_memory(&*plan_from_lines(&MixtureStage, &lines(50.0)).unwrap()).unwrap();
        let f = t.attributes["traced_fraction"][0][0].as_f64().unwrap();
        assert!(f > 0.0 && f < 1.0, "traced fraction {f}");
        let step = 0.5f64.to_radians();
        let integral: f64 = (0..361)
            .map(|j| {
                let (lo, hi) = crate::raytrace::post::bin_edges(step * j as f64, step);
                t.data[j * 4] as f64 * 2.0 * PI * (lo.cos() - hi.cos())
            })
            .sum();
        assert!((integral - 1.0).abs() < 0.02, "∫p = {integral}");
        let m = run_in_memory(&*plan_from_lines(&MixtureStage, &lines(1000.0)).unwrap()).unwrap();
        let j = (138.0f64 / 0.5) as usize;
        assert!((t.data[j * 4] - m.data[j * 4]).abs() > 1e-4 * m.data[j * 4]);
    }

    /// With the default handover, a Marshall–Palmer mixture reaching past it (50–600 µm: traced
    /// above 400 µm, orders to 6) keeps Alexander's dark band (mean phase over 131–136°) within
    /// 5 % of the `mie` stage's table of the same radii and weights; a handover at 100 µm, which
    /// traces the 0.1–0.4 mm drops, is further from it.
    #[test]
    fn default_handover_keeps_alexanders_band_close_to_mie() {
        let mp = "{ kind = \"marshall-palmer\", rain_rate_mm_h = 5.0, min_radius_um = 50.0, max_radius_um = 600.0 }";
        let common = format!(
            "wavelengths_nm = [650.0]\nangle_step_deg = 0.5\nradius_points = 8\ndistributions = [{mp}]\n"
        );
        let run = |stage: &dyn crate::stages::Stage, extra: &str| {
            run_in_memory(&*plan_from_lines(stage, &format!("{common}{extra}")).unwrap()).unwrap()
        };
        let band = |t: &crate::table::TableContent| -> f64 {
            let (lo, hi) = ((131.0f64 / 0.5) as usize, (136.0f64 / 0.5) as usize);
            (lo..=hi).map(|j| t.data[j * 4] as f64).sum::<f64>() / (hi - lo + 1) as f64
        };
        let mie = run(&crate::stages::mie::MieStage, "radius_tolerance = 0.0");
        let mixed = run(&MixtureStage, "");
        let early = run(&MixtureStage, "handover_radius_um = 100.0");
        let f = mixed.attributes["traced_fraction"][0][0].as_f64().unwrap();
        assert!(f > 0.0, "nothing traced (traced fraction {f})");
        let (r, r_early) = (band(&mixed) / band(&mie), band(&early) / band(&mie));
        println!("band over Mie: {r} (handover 100 µm: {r_early})");
        assert!((r - 1.0).abs() < 0.05, "band over Mie {r}");
        assert!((r - 1.0).abs() < (r_early - 1.0).abs(), "{r} vs {r_early}");
    }

    #[test]
    fn rejects_bad_mixtures() {
        let bad = [
            "distributions = []",
            "distributions = [{ radii_um = [100.0], number_weights = [1.0, 2.0] }]",
            "distributions = [{ radii_um = [100.0], number_weights = [0.0] }]",
            "distributions = [{ radii_um = [100.0], number_weights = [1.0] }]\nhandover_radius_um = 1.0",
        ];
        for b in bad {
            assert!(plan_from_lines(&MixtureStage, b).is_err(), "{b}");
        }
        assert!(
            plan_from_lines(
                &MixtureStage,
                "distributions = [{ radii_um = [100.0, 500.0], number_weights = [10.0, 1.0] }]"
            )
            .is_ok()
        );
    }
}
