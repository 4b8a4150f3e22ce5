//! The `fur-farfield/1` table: far-field profiles of the practical fur shading model
//! ([`super::farfield`]) for samples of Tseng 2015 Table 4.2, one block of values per sample,
//! with the header that states the conventions and the energy per (sample, θ_i, channel).
//! Also the medulla tables its profiles are looked up in: which grid points the lookups touch,
//! a tensor-train table reconstructed at those points, and the check at plan time that every
//! lookup lies inside the tables' grids.
//!
//! Axes (row-major, channel innermost): `sample` (index into the attribute `samples`) ×
//! `theta_i` (deg) × `theta_r` (deg, cell centres over [−90, 90]) × `phi` (deg, cell centres
//! over [−180, 180)). Channels: `energy` (total) and its components `r`, `tt`, `trt`,
//! `medulla_paths`, `scattered`, each the cell-averaged exiting energy per unit θ_r per unit φ
//! (rad⁻²) per unit intercepted incident power.

use super::FurError;
use super::farfield::{
    COMPONENTS, FarFieldSettings, FurSample, MedullaShapes, MedullaSource, far_field_with,
    isotropic_fraction, longitudinal_lobe_pdf, medulla_sigma,
};
use crate::table::tt::{TT_SCHEMA, decode_tensor_train};
use crate::table::{Axis, Channel, Schema, Table, TableContent};
use serde_json::{Map, Value, json};

/// Channels of the table: the total, then [`COMPONENTS`].
pub const CHANNELS: usize = 1 + COMPONENTS.len();

/// The medulla tables a far field reads: (azimuthal, longitudinal) dense tables, restricted
/// to the σ and g grid points the lookups touch when the source is a tensor train
/// (reconstructed at those points only, bit-identical to the full reconstruction there), and
/// the payload SHA-256 of each source table (the content key's input).
#[derive(Debug)]
pub struct MedullaTables {
    pub azimuthal: Table,
    pub longitudinal: Table,
    pub payload_sha256: [String; 2],
}

/// Where a far-field table's medulla profiles come from.
#[derive(Debug)]
pub enum MedullaProfiles {
    /// The expected-value Monte Carlo on the fly.
    MonteCarlo,
    /// The shipped compressed thesis-grid tables ([`super::assets`]).
    Assets(MedullaTables),
    /// Tables given by the user, named by their paths.
    Files {
        azimuthal: String,
        longitudinal: String,
        tables: MedullaTables,
    },
}

impl MedullaProfiles {
    /// The looked-up tables (none for the Monte Carlo).
    pub fn tables(&self) -> Option<&MedullaTables> {
        match self {
            MedullaProfiles::MonteCarlo => None,
            MedullaProfiles::Assets(t) | MedullaProfiles::Files { tables: t, .. } => Some(t),
        }
    }
}

/// The σ and g values a far field looks its medulla profiles up at: azimuthal at (σ, g) of
/// each sample, longitudinal at (σ/cos θ_t, g) for each θ_i (the expressions of the lookups
/// themselves). Returns (azimuthal σ, longitudinal σ, g).
pub fn lookup_points(
    samples: &[FurSample],
    theta_i_deg: &[f64],
    set: &FarFieldSettings,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut az_sigma = Vec::new();
    let mut lo_sigma = Vec::new();
    let mut gs = Vec::new();
    for s in samples {
        let sigma = medulla_sigma(s, set.sigma_scaling);
        az_sigma.push(sigma);
        gs.push(s.g);
        for &ti in theta_i_deg {
            let sin_ti = ti.to_radians().sin();
            let cos_tm = (1.0 - (sin_ti / s.eta_m).powi(2)).sqrt();
            lo_sigma.push(sigma / cos_tm);
        }
    }
    (az_sigma, lo_sigma, gs)
}

/// Indices of the grid points of `coords` that bracket every value of `xs` (multilinear
/// lookup touches exactly these); values outside the axis are left to the range check.
fn bracket_indices(coords: &[f64], xs: &[f64]) -> Vec<usize> {
    let mut set = std::collections::BTreeSet::new();
    let n = coords.len();
    for &x in xs {
        let k = coords.partition_point(|&c| c <= x).saturating_sub(1);
        let k = k.min(n.saturating_sub(2));
        set.insert(k);
        if k + 1 < n {
            set.insert(k + 1);
        }
    }
    set.into_iter().collect()
}

/// `t` (called `name` in messages) as a dense medulla table of `schema` and its payload
/// SHA-256: a dense table as it is; a tensor train reconstructed at the σ grid points that
/// bracket `sigmas` and the g grid points that bracket `gs`. The error is a message naming
/// the table.
pub fn dense_medulla_table(
    t: Table,
    name: &str,
    schema: &str,
    sigmas: &[f64],
    gs: &[f64],
) -> Result<(Table, String), String> {
    let sha = t.header.payload.sha256_uncompressed.clone();
    if t.header.schema.name != TT_SCHEMA {
        if t.header.schema.name != schema {
            return Err(format!(
                "{name}: schema {} (expected {schema})",
                t.header.schema.name
            ));
        }
        return Ok((t, sha));
    }
    let path = std::path::Path::new(name);
    let d = decode_tensor_train(&t, path, &Default::default()).map_err(|e| e.to_string())?;
    if d.schema.name != schema || d.axes.len() < 2 {
        return Err(format!(
            "{name}: holds a {} table (expected {schema})",
            d.schema.name
        ));
    }
    let mut sel = vec![None; d.axes.len()];
    sel[0] = Some(bracket_indices(&d.axes[0].coords(), sigmas));
    sel[1] = Some(bracket_indices(&d.axes[1].coords(), gs));
    let sub = d.sub_table(&sel).map_err(|e| e.to_string())?;
    Ok((sub, sha))
}

/// A `fur-farfield` table of checked parameters.
#[derive(Debug)]
pub struct FarFieldTable {
    pub samples: Vec<FurSample>,
    /// Incidence inclinations θ_i (deg), |θ_i| < 89.
    pub theta_i_deg: Vec<f64>,
    pub settings: FarFieldSettings,
    pub medulla: MedullaProfiles,
}

impl FarFieldTable {
    /// Sample × θ_i × θ_r × φ.
    pub fn axes(&self) -> Vec<Axis> {
        let (nt, np) = (self.settings.theta_r_cells, self.settings.phi_cells);
        let dt = 180.0 / nt as f64;
        let dp = 360.0 / np as f64;
        vec![
            Axis::values(
                "sample",
                "index",
                (0..self.samples.len()).map(|i| i as f64).collect(),
            ),
            Axis::values("theta_i", "deg", self.theta_i_deg.clone()),
            Axis::uniform("theta_r", "deg", -90.0 + 0.5 * dt, dt, nt),
            Axis::uniform("phi", "deg", -180.0 + 0.5 * dp, dp, np),
        ]
    }

    /// Values per sample: θ_i × θ_r × φ × channels.
    pub fn sample_len(&self) -> usize {
        let set = &self.settings;
        self.theta_i_deg.len() * set.theta_r_cells * set.phi_cells * CHANNELS
    }

    /// The medulla source of the far field and the azimuthal shapes of `s`.
    fn medulla_of(&self, s: &FurSample) -> Result<(MedullaShapes, MedullaSource<'_>), FurError> {
        let set = &self.settings;
        let sigma = medulla_sigma(s, set.sigma_scaling);
        Ok(match self.medulla.tables() {
            None => (
                MedullaShapes::compute(sigma, s.g, set),
                MedullaSource::Simulate,
            ),
            Some(t) => (
                MedullaShapes::from_table(&t.azimuthal, sigma, s.g, set)?,
                MedullaSource::Tables {
                    azimuthal: &t.azimuthal,
                    longitudinal: &t.longitudinal,
                },
            ),
        })
    }

    /// The values of sample `index`: per θ_i the profile's cells, each the total then the
    /// components.
    pub fn sample_values(&self, index: usize) -> Result<Vec<f32>, FurError> {
        let s = &self.samples[index];
        let set = &self.settings;
        let (shapes, source) = self.medulla_of(s)?;
        let mut out = Vec::with_capacity(self.sample_len());
        for &ti in &self.theta_i_deg {
            let ff = far_field_with(s, ti.to_radians(), &shapes, set, source)?;
            for i in 0..set.theta_r_cells {
                for j in 0..set.phi_cells {
                    let k = i * set.phi_cells + j;
                    out.push(ff.total(i, j) as f32);
                    for c in &ff.components {
                        out.push(c[k] as f32);
                    }
                }
            }
        }
        Ok(out)
    }

    /// Every medulla lookup the table makes (each sample's azimuthal shapes, its longitudinal
    /// lobes at each θ_i) lies inside the medulla tables' grids; the error names the sample
    /// (and θ_i) it concerns.
    pub fn check_lookups(&self) -> Result<(), (String, FurError)> {
        let Some(tables) = self.medulla.tables() else {
            return Ok(());
        };
        let set = &self.settings;
        let source = MedullaSource::Tables {
            azimuthal: &tables.azimuthal,
            longitudinal: &tables.longitudinal,
        };
        for s in &self.samples {
            let sigma = medulla_sigma(s, set.sigma_scaling);
            MedullaShapes::from_table(&tables.azimuthal, sigma, s.g, set)
                .map_err(|e| (format!("sample {}", s.name), e))?;
            for &ti in &self.theta_i_deg {
                let sin_ti = ti.to_radians().sin();
                let cos_tm = (1.0 - (sin_ti / s.eta_m).powi(2)).sqrt();
                let theta_i_med = (sin_ti / s.eta_m).asin();
                longitudinal_lobe_pdf(source, sigma / cos_tm, s.g, theta_i_med, set)
                    .map_err(|e| (format!("sample {} at theta_i {ti}", s.name), e))?;
            }
        }
        Ok(())
    }

    /// The table from the values of every sample, in sample order.
    pub fn content(&self, per_sample: &[&[f32]]) -> TableContent {
        let energies = self.energies(per_sample);
        let mut channels = vec![Channel::new(
            "energy",
            "1/rad^2",
            "total exiting energy density per unit theta_r per unit phi",
        )];
        for c in COMPONENTS {
            channels.push(Channel::new(c, "1/rad^2", "component of energy"));
        }
        TableContent {
            encoding: Default::default(),
            schema: Schema::new("fur-farfield", 1),
            description: "far-field fur scattering profiles of Tseng 2015 Table 4.2 samples (practical coaxial-cylinder model)".into(),
            axes: self.axes(),
            channels,
            attributes: self.attributes(energies),
            data: per_sample.concat(),
        }
    }

    /// Energy per (sample, θ_i) and channel, Σ value × cell area, from the stored (f32) values,
    /// flat row-major over (sample, θ_i, channel).
    fn energies(&self, per_sample: &[&[f32]]) -> Vec<f64> {
        let (nt, np) = (self.settings.theta_r_cells, self.settings.phi_cells);
        let area = (180.0 / nt as f64).to_radians() * (360.0 / np as f64).to_radians();
        let mut energies = Vec::new();
        for values in per_sample {
            for ti in 0..self.theta_i_deg.len() {
                let block = &values[ti * nt * np * CHANNELS..(ti + 1) * nt * np * CHANNELS];
                energies.extend((0..CHANNELS).map(|c| {
                    block
                        .iter()
                        .skip(c)
                        .step_by(CHANNELS)
                        .map(|&v| v as f64)
                        .sum::<f64>()
                        * area
                }));
            }
        }
        energies
    }

    /// Where the medulla profiles come from, as the header states it.
    fn medulla_source_text(&self) -> String {
        let set = &self.settings;
        match &self.medulla {
            MedullaProfiles::Assets(t) => format!(
                "multilinear lookup (sigma, g, h' or theta'_i, exit angle) in the shipped tensor-train compressed thesis-grid tables assets/fur-medulla/{} and {} (payload SHA-256 {} and {}) at {} bins",
                super::assets::ASSET_FILES[0],
                super::assets::ASSET_FILES[1],
                t.payload_sha256[0],
                t.payload_sha256[1],
                set.medulla_bins
            ),
            MedullaProfiles::MonteCarlo => format!(
                "expected-value Monte Carlo on the fly, {} photons, {} bins, seed {}",
                set.photons, set.medulla_bins, set.seed
            ),
            MedullaProfiles::Files {
                azimuthal,
                longitudinal,
                ..
            } => format!(
                "multilinear lookup (sigma, g, h' or theta'_i, exit angle) in the tables {} and {} at {} bins",
                azimuthal, longitudinal, set.medulla_bins
            ),
        }
    }

    /// The header attributes: model, conventions, medulla source, samples and `energies`.
    fn attributes(&self, energies: Vec<f64>) -> Map<String, Value> {
        let set = &self.settings;
        let mut a = Map::new();
        a.insert("model".into(), "practical shading model of Tseng 2015 ch. 5 / App. A (coaxial cylinder): unscattered Gaussian lobes of R, TT, TRT, TrT, TttT, TtrtT, TrRrT, TttRttT (chief-ray exit azimuths, Stokes-pile cuticle Fresnel, medulla-interface Fresnel, cortex absorption, medulla extinction) plus medulla-scattered lobes of the TttT, TtrtT and TttRttT chords shaped by 2-D medulla Monte Carlo profiles (C^N, C^M; on the fly or from medulla tables, see medulla_profiles), averaged over the fibre width (h uniform on (-1, 1)). Decisions: docs/decisions.md, fur far field (FUR-1f, FUR-11 … FUR-19)".into());
        a.insert("value_convention".into(), "every channel is the exiting energy per unit theta_r per unit phi (1/rad^2) per unit incident power intercepted by the fibre, AVERAGED over the cell (lobes integrated analytically over the cell, medulla bins split linearly between phi cells): sum over cells of value * dtheta_r * dphi = energy carried. Longitudinal lobes are normalised with int M dtheta_r = 1 (no cos weight). The thesis BCSDF S of Eq. 5.1 is sum_p M_p N_p / cos^2 theta_i with N_p the per-h azimuthal energy density; this table holds the h-average of sum_p M_p N_p, i.e. cos^2 theta_i * S averaged over h".into());
        a.insert("angle_convention".into(), "theta from the fibre's normal plane, root at +90 deg (thesis convention, theta flipped w.r.t. Marschner 2003; the specular cone is theta_r = -theta_i); phi = phi_r - phi_i, 0 = back towards the light, +/-180 = forward; theta_r cells over [-90, 90], phi cells over [-180, 180), axis coordinates are cell centres".into());
        a.insert("units_convention".into(), format!("Table 4.2 sigma_ca is per fibre DIAMETER; internally fibre radius 1: cortex coefficient sigma_ca/2 per radius. Medulla table coefficient per unit medulla radius: medulla_sigma_scaling = {:?} (ThesisOverKappa, the default: sigma_ms/kappa as printed in Eq. 5.10, the lookup Table 4.2 was fitted with; KappaHalf: sigma_ms*kappa/2, sigma_ms per diameter, optical depth preserved; Kappa: sigma_ms*kappa). Both coefficients divided by cos theta_t (longitudinal refraction into cortex / medulla) for the azimuthal projection", set.sigma_scaling).into());
        a.insert("components".into(), "energy = r + tt + trt + medulla_paths + scattered; r, tt, trt: classic unscattered lobes (tt and trt only where the chief ray misses the medulla, |h| >= kappa*eta_c'); medulla_paths: unscattered TrT, TttT, TtrtT, TrRrT, TttRttT; scattered: medulla-scattered light (App. A mix with the isotropic fraction lambda)".into());
        let source = self.medulla_source_text();
        a.insert("medulla_profiles".into(), format!("azimuthal C^N rows h' = j/{} (j = 0..{}), mirrored for h' < 0, linear in |h'|, normalised to unit sum (energy from the analytic 1 - exp(-sigma chord)); longitudinal C^M per theta_i at theta'_i = asin(sin theta_i / eta_m); source: {source}", set.medulla_rows - 1, set.medulla_rows - 1).into());
        a.insert("omitted".into(), "paths beyond the eight listed (e.g. TRRT) are omitted as in the thesis; for a lossless fibre without medulla they carry 1/2 int F^2 (1 - F) dh of the energy (tested)".into());
        let samples: Vec<Value> = self
            .samples
            .iter()
            .map(|s| {
                json!({
                    "name": s.name, "kappa": s.kappa, "eta_c": s.eta_c, "eta_m": s.eta_m,
                    "alpha_deg": s.alpha_deg, "beta_deg": s.beta_deg,
                    "sigma_ca_per_diameter": s.sigma_ca, "sigma_ms_per_diameter": s.sigma_ms,
                    "g": s.g, "layers": s.layers,
                    "medulla_sigma_per_medulla_radius": medulla_sigma(s, set.sigma_scaling),
                    "isotropic_fraction_lambda": isotropic_fraction(s),
                })
            })
            .collect();
        a.insert("samples".into(), samples.into());
        a.insert(
            "samples_source".into(),
            "Tseng 2015, Table 4.2 (fitted parameters)".into(),
        );
        a.insert(
            "energy_layout".into(),
            "flat row-major over (sample, theta_i, channel) of sum value * cell area".into(),
        );
        a.insert("energy".into(), energies.into());
        a
    }
}
