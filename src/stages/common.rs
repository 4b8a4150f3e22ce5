//! What the stages of bin-averaged, sun-smoothed phase functions of water drops (`mie`,
//! `debye`) share: [`FilteredPhase`] (water index per wavelength, angular filters, the
//! (entry, wavelength) task grid, the chunk layout of a task, the table axes and the header
//! attributes that describe the filters) and the Mie-domain check at plan time.

use crate::mie::filters::FilterSettings;
use crate::mie::filters::{PolarisedPhase, SunDiscOperator};
use crate::mie::{check_domain, in_medium};
use crate::optics::water::WaterIndexModel;
use crate::stages::cost::MIE_CPU_S_PER_TERM_ANGLE;
use crate::stages::phase_contract;
use crate::stages::{Chunk, JobError, PlanError, TaskSpec, check_chunks, checks};
use crate::table::Axis;
use num_complex::Complex64;
use serde_json::{Map, Value};
use std::sync::OnceLock;

/// Channels every phase-function chunk starts with, per angle: phase, i_perp, i_par, dolp.
pub const CONTRACT_CHANNELS: usize = 4;

/// The f64 scalars of every task, `[entry][wavelength][scalar]`.
pub type EntryScalars = Vec<Vec<Vec<f64>>>;

/// Declares the parameter struct of a filtered phase-function stage with
/// [`stage_params!`](crate::stages::stage_params): the keys every such stage reads
/// (`wavelengths_nm`, `water_index_model`, `temperature_c`, `angle_step_deg`,
/// `sun_diameter_deg`) followed by the stage's own fields, and a method `filter_keys` that
/// hands the shared keys to [`FilteredPhase::plan`].
macro_rules! filtered_phase_params {
    (
        $(#[$sattr:meta])*
        pub struct $name:ident { $($fields:tt)* }
    ) => {
        $crate::stages::stage_params! {
            $(#[$sattr])*
            pub struct $name {
                /// Vacuum wavelengths (nm), strictly increasing; default: the thesis' 33 samples
                /// 380–700 nm.
                pub wavelengths_nm: Vec<f64> =
                    default($crate::optics::water::SADEGHI_WAVELENGTHS_NM.to_vec()),
                    "list of float, nm", "vacuum wavelengths";
                /// `iapws1997` or `sadeghi-table-3.2`.
                pub water_index_model: String = default("iapws1997".into()),
                    "string", "iapws1997 | sadeghi-table-3.2";
                /// Water temperature for `iapws1997` (°C).
                pub temperature_c: f64 = default(20.0),
                    "float, °C", "water temperature (iapws1997)";
                /// Output angular step (deg); 180/step must be an integer.
                pub angle_step_deg: f64 = default(0.05),
                    "float, deg", "output bin width; 180/step integer; values are bin averages";
                /// Angular diameter of the sun's disc (deg); 0 disables the convolution.
                pub sun_diameter_deg: f64 = default(0.5),
                    "float, deg", "uniform solar disc convolution (0 = off)";
                $($fields)*
            }
        }

        impl $name {
            /// The shared keys, with the stage's Gaussian blur and size-distribution nodes.
            fn filter_keys(
                &self,
                gaussian_sigma_deg: f64,
                radius_points: usize,
            ) -> $crate::stages::common::FilterKeys<'_> {
                $crate::stages::common::FilterKeys {
                    water_index_model: &self.water_index_model,
                    temperature_c: self.temperature_c,
                    wavelengths_nm: &self.wavelengths_nm,
                    angle_step_deg: self.angle_step_deg,
                    sun_diameter_deg: self.sun_diameter_deg,
                    gaussian_sigma_deg,
                    radius_points,
                }
            }
        }
    };
}
pub(crate) use filtered_phase_params;

/// The manifest keys [`FilteredPhase::plan`] reads (names as in the manifest).
pub struct FilterKeys<'a> {
    pub water_index_model: &'a str,
    pub temperature_c: f64,
    pub wavelengths_nm: &'a [f64],
    pub angle_step_deg: f64,
    pub sun_diameter_deg: f64,
    pub gaussian_sigma_deg: f64,
    pub radius_points: usize,
}

/// The planned part shared by the filtered phase-function jobs: one task per (entry,
/// wavelength), entry-major.
pub struct FilteredPhase {
    pub model: WaterIndexModel,
    pub wavelengths_nm: Vec<f64>,
    /// Real refractive index of water at every wavelength.
    pub indices: Vec<f64>,
    pub settings: FilterSettings,
    /// Output step as given (the table's axis step).
    pub angle_step_deg: f64,
    /// Sun-disc operator on the intermediate grid, built once per job.
    sun: OnceLock<SunDiscOperator>,
}

impl FilteredPhase {
    /// Check the shared keys (errors name them) and resolve the water index.
    pub fn plan(k: FilterKeys<'_>) -> Result<Self, PlanError> {
        let (model, indices) = checks::water_indices(
            k.water_index_model,
            Some(k.temperature_c),
            "wavelengths_nm",
            k.wavelengths_nm,
        )?;
        let output_intervals = checks::angle_step_intervals("angle_step_deg", k.angle_step_deg)?;
        checks::within("sun_diameter_deg", k.sun_diameter_deg, 0.0, 5.0, " deg")?;
        checks::within(
            "gaussian_sigma_deg",
            k.gaussian_sigma_deg,
            0.0,
            10.0,
            " deg",
        )?;
        checks::within("radius_points", k.radius_points, 4, 512, "")?;
        Ok(FilteredPhase {
            model,
            wavelengths_nm: k.wavelengths_nm.to_vec(),
            indices,
            settings: FilterSettings {
                output_intervals,
                sun_diameter_deg: k.sun_diameter_deg,
                gaussian_sigma_deg: k.gaussian_sigma_deg,
                radius_points: k.radius_points,
                radius_tolerance: 0.0,
            },
            angle_step_deg: k.angle_step_deg,
            sun: OnceLock::new(),
        })
    }

    /// Every radius at every wavelength must lie in the validated Mie domain, with the drops in
    /// a medium of index `n_medium` (1 = vacuum, [`crate::mie::in_medium`]); the error names
    /// `key`.
    pub fn check_domain(
        &self,
        key: &str,
        radii_um: &[f64],
        n_medium: f64,
    ) -> Result<(), PlanError> {
        for &r in radii_um {
            for (l, n) in self.wavelengths_nm.iter().zip(&self.indices) {
                let (x, m) = in_medium(r, *l, Complex64::new(*n, 0.0), n_medium);
                check_domain(x, m).map_err(|err| {
                    PlanError::invalid(key, format!("radius {r} µm at {l} nm: {err}"))
                })?;
            }
        }
        Ok(())
    }

    /// Output angles (bin centres over [0°, 180°]).
    pub fn angles(&self) -> usize {
        self.settings.output_intervals + 1
    }

    /// Estimated CPU seconds of one Lorenz–Mie or Debye sphere of radius `radius_um` at
    /// `wavelength_nm` (vacuum) in a medium of index `n_medium`: the series has about x terms,
    /// each evaluated on the intermediate angular grid (`MIE_CPU_S_PER_TERM_ANGLE`).
    pub fn estimated_sphere_cpu_s(&self, radius_um: f64, wavelength_nm: f64, n_medium: f64) -> f64 {
        let x = 2.0 * std::f64::consts::PI * radius_um * 1000.0 * n_medium / wavelength_nm;
        let terms = x + 4.0 * x.cbrt() + 2.0;
        let angles = self.settings.intermediate_intervals() as f64 + 1.0;
        MIE_CPU_S_PER_TERM_ANGLE * terms * angles
    }

    /// [`Self::estimated_sphere_cpu_s`] summed over every wavelength of the table.
    pub fn estimated_entry_cpu_s(&self, radius_um: f64, n_medium: f64) -> f64 {
        self.wavelengths_nm
            .iter()
            .map(|&l| self.estimated_sphere_cpu_s(radius_um, l, n_medium))
            .sum()
    }

    /// The sun-disc operator (built on first use).
    pub fn sun(&self) -> &SunDiscOperator {
        self.sun.get_or_init(|| self.settings.sun_operator())
    }

    /// Tasks of `entries` × wavelengths: `task(entry, wavelength_nm, n)`.
    pub fn tasks(
        &self,
        entries: usize,
        task: impl Fn(usize, f64, f64) -> TaskSpec,
    ) -> Vec<TaskSpec> {
        (0..entries)
            .flat_map(|e| {
                self.wavelengths_nm
                    .iter()
                    .zip(&self.indices)
                    .map(move |(&l, &n)| (e, l, n))
            })
            .map(|(e, l, n)| task(e, l, n))
            .collect()
    }

    /// (entry, wavelength in nm, refractive index of water) of task `index`.
    pub fn task(&self, index: usize) -> (usize, f64, Complex64) {
        let (e, w) = (
            index / self.wavelengths_nm.len(),
            index % self.wavelengths_nm.len(),
        );
        (
            e,
            self.wavelengths_nm[w],
            Complex64::new(self.indices[w], 0.0),
        )
    }

    /// Chunks of [`phase_chunk`] with `channels` values per angle and `scalars` scalars, split
    /// into the table data and the scalars `[entry][wavelength][scalar]`.
    pub fn split_chunks(
        &self,
        chunks: Vec<Chunk>,
        entries: usize,
        channels: usize,
        scalars: usize,
    ) -> Result<(Vec<f32>, EntryScalars), JobError> {
        let wavelengths = self.wavelengths_nm.len();
        let values = self.angles() * channels;
        check_chunks(&chunks, entries * wavelengths, values, scalars)?;
        let mut data = Vec::with_capacity(chunks.len() * values);
        let mut tails = vec![Vec::with_capacity(wavelengths); entries];
        for (i, c) in chunks.into_iter().enumerate() {
            data.extend_from_slice(&c.values);
            tails[i / wavelengths].push(c.scalars);
        }
        Ok((data, tails))
    }

    /// Axes of the table: `entry` × wavelength (nm) × scattering angle (deg).
    pub fn axes(&self, entry: Axis) -> Vec<Axis> {
        vec![
            entry,
            Axis::values("wavelength", "nm", self.wavelengths_nm.clone()),
            Axis::uniform(
                "scattering_angle",
                "deg",
                0.0,
                self.angle_step_deg,
                self.angles(),
            ),
        ]
    }

    /// Header attributes: the phase contract's (with `normalisation`), the water index per
    /// wavelength, the sun-disc model and the angular resampling rule.
    pub fn attributes(&self, normalisation: &str) -> Map<String, Value> {
        let mut a = Map::new();
        a.extend(phase_contract::attributes(
            normalisation,
            &self.model,
            self.settings.sun_diameter_deg,
        ));
        a.insert("refractive_index_real".into(), self.indices.clone().into());
        a.insert(
            "sun_disc_model".into(),
            "uniform disc (no limb darkening), exact 2-D average on the sphere".into(),
        );
        a.insert("angular_resampling".into(), "each value is the solid-angle average over its bin [theta - step/2, theta + step/2] (clipped at 0 and 180 deg) of the single-sphere curve, computed as cell averages with 6 Gauss points per cell of at most 180/n_stop deg; no point sampling".into());
        a
    }
}

/// A task chunk: per angle the contract channels of `curve` and then the `extra` curves (one
/// value each); `scalars` as they are.
pub fn phase_chunk(curve: &PolarisedPhase, extra: &[Vec<f64>], scalars: &[f64]) -> Chunk {
    let (phase, dolp) = (curve.phase(), curve.dolp());
    let mut out = Vec::with_capacity(phase.len() * (CONTRACT_CHANNELS + extra.len()));
    for j in 0..phase.len() {
        out.extend([
            phase[j] as f32,
            curve.i_perp[j] as f32,
            curve.i_par[j] as f32,
            dolp[j] as f32,
        ]);
        out.extend(extra.iter().map(|c| c[j] as f32));
    }
    Chunk::new(out, scalars.to_vec())
}

/// `[entry][wavelength]` arrays of scalar `k` of every task.
pub fn scalar_arrays(tails: &EntryScalars, k: usize) -> Vec<Vec<f64>> {
    tails
        .iter()
        .map(|row| row.iter().map(|t| t[k]).collect())
        .collect()
}

/// Test helper: ∫ c dΩ of channel `channel` of every `stride`-channel row over the cells of
/// `cell_solid_angles`, per block of `cells.len()` angles.
#[cfg(test)]
pub fn bin_integrals(data: &[f32], stride: usize, channel: usize, cells: &[f64]) -> Vec<f64> {
    data.chunks(cells.len() * stride)
        .map(|row| {
            row.chunks(stride)
                .zip(cells)
                .map(|(c, w)| c[channel] as f64 * w)
                .sum()
        })
        .collect()
}
