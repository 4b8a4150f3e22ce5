//! The ray-traced phase tables, `raytrace-phase/2` (spheres) and `raytrace-phase-2d/2`
//! (non-spherical drops): their entries, axes, channels, values and renormalisation, and their
//! header texts ([`super::phase_table_headers`]); the compact form of 2-D tables is
//! [`super::compact_table`].
//!
//! - Spheres: axes radius (µm) × wavelength (nm) × scattering_angle (deg, uniform over
//!   [0, 180]); one entry per (radius, wavelength), computed by the exact 1-D
//!   geometric-optics-plus-phase path ([`super::sphere1d`]).
//! - Non-spherical drops: axes radius (µm, one value) × wavelength (nm) × sun_elevation (deg) ×
//!   outgoing_polar (deg from the incident direction) × outgoing_azimuth (deg); one entry per
//!   (wavelength, sun elevation), traced by the patch tracer ([`super::table2d`]) and
//!   renormalised to ∫ p dΩ = 1 on the grid (decision RT-21).
//!
//! Channels: [`super::channel_names`], in 1/sr against the full scattering cross-section
//! σ = σ_GO (traced orders) + A (forward Fraunhofer lobe of the projected area A).

use super::compact::{Compression, SunDiscResampled};
use super::post::integral_1d;
use super::shape::DropShape;
use super::sphere1d::{DiffractionModel, SphereTableOptions, sphere_table_channels};
use super::table2d::{
    Table2dOptions, Trace2d, divide_intensities, entry_integral_2d, shared_wavelength_fields,
    sphere_table_2d, trace_table_2d,
};
use super::tracer::{DirectionGrid, RayGridLayout};
use crate::table::{Axis, TableContent};
use serde_json::{Map, Value};

/// What a ray-traced phase table holds and how its entries are computed.
#[derive(Debug, Clone)]
pub struct PhaseTableSpec {
    /// The shape's name in the header (`sphere`, `beard-chuang`, `profile`).
    pub shape_name: String,
    /// The drop of a 2-D table; `None` for the 1-D table of spheres.
    pub shape: Option<DropShape>,
    /// RMS relative residual of the cosine-series fit of a tabulated profile.
    pub profile_fit_residual: Option<f64>,
    /// Equal-volume radii (µm); one for 2-D tables.
    pub radii_um: Vec<f64>,
    /// Vacuum wavelengths (nm).
    pub wavelengths_nm: Vec<f64>,
    /// Sun elevations (deg) of 2-D tables.
    pub sun_elevation_deg: Vec<f64>,
    /// Highest order traced.
    pub max_order: usize,
    /// Scattering-angle step (deg) of 1-D tables; divides 180.
    pub angle_step_deg: f64,
    /// Outgoing polar step (deg) of 2-D tables; divides 180.
    pub polar_step_deg: f64,
    /// Outgoing azimuth step (deg) of 2-D tables; divides 360.
    pub azimuth_step_deg: f64,
    /// Rays per side of the ray grid (2-D tables).
    pub rays: usize,
    /// Layout of the ray grid (decision RT-31).
    pub ray_grid: RayGridLayout,
    /// Apply the diffraction model to the main channels.
    pub diffraction_filter: bool,
    /// Diffraction model of the main channels.
    pub model: DiffractionModel,
    /// Write the per-order and unfiltered channels after the contract's four.
    pub diagnostic_channels: bool,
    /// 2-D tables: add the equal-volume sphere's orders above `max_order` (decision RT-37).
    pub sphere_higher_orders: bool,
    /// 2-D tables: average the values at φ and 360° − φ (decision RT-24).
    pub mirror_symmetrise: bool,
    /// 2-D tables: trace the azimuths 0°–180° and copy them to 360° − φ (decision RT-34).
    pub mirror_half: bool,
    /// 2-D tables: dense, or seen through the sun's disc and resampled (decision RT-39).
    pub compression: Compression,
}

/// A ray-traced phase table: its [`PhaseTableSpec`].
pub struct PhaseTable {
    pub spec: PhaseTableSpec,
}

/// The number of steps of `step` in `total` (2 to 1e7 of them), or `None` when `step` does not
/// divide `total`.
pub fn steps(total: f64, step: f64) -> Option<usize> {
    if step.is_nan() || step <= 0.0 {
        return None;
    }
    let n = total / step;
    // At most 1e7 steps: a tiny step would overflow the grid's sample count.
    if (n - n.round()).abs() < 1e-6 && (2.0..=1e7).contains(&n.round()) {
        Some(n.round() as usize)
    } else {
        None
    }
}

impl PhaseTable {
    /// The table of `spec`; its steps must divide the sphere ([`steps`]).
    pub fn new(spec: PhaseTableSpec) -> Self {
        PhaseTable { spec }
    }

    /// A 2-D table (a non-spherical drop over outgoing directions).
    pub fn two_d(&self) -> bool {
        self.spec.shape.is_some()
    }

    /// Scattering angles of a 1-D entry.
    pub fn n_angles(&self) -> usize {
        steps(180.0, self.spec.angle_step_deg).expect("angle step divides 180") + 1
    }

    /// Outgoing directions of a 2-D entry.
    pub fn direction_grid(&self) -> DirectionGrid {
        DirectionGrid {
            n_polar: steps(180.0, self.spec.polar_step_deg).expect("polar step divides 180") + 1,
            n_azimuth: steps(360.0, self.spec.azimuth_step_deg).expect("azimuth step divides 360"),
        }
    }

    /// Entries in table order: (radius µm, wavelength nm) for spheres; (wavelength nm, sun
    /// elevation deg) of the one radius for 2-D shapes.
    pub fn entries(&self) -> Vec<(f64, f64)> {
        let s = &self.spec;
        let (first, second) = if self.two_d() {
            (&s.wavelengths_nm, &s.sun_elevation_deg)
        } else {
            (&s.radii_um, &s.wavelengths_nm)
        };
        first
            .iter()
            .flat_map(|&f| second.iter().map(move |&s| (f, s)))
            .collect()
    }

    /// The table's axes: radius × wavelength × scattering angle (spheres), or radius ×
    /// wavelength × sun elevation × outgoing polar × outgoing azimuth (2-D shapes).
    pub fn axes(&self) -> Vec<Axis> {
        let s = &self.spec;
        let mut axes = vec![
            Axis::values("radius", "um", s.radii_um.clone()),
            Axis::values("wavelength", "nm", s.wavelengths_nm.clone()),
        ];
        if self.two_d() {
            let grid = self.direction_grid();
            axes.extend([
                Axis::values("sun_elevation", "deg", s.sun_elevation_deg.clone()),
                Axis::uniform("outgoing_polar", "deg", 0.0, s.polar_step_deg, grid.n_polar),
                Axis::uniform(
                    "outgoing_azimuth",
                    "deg",
                    0.0,
                    s.azimuth_step_deg,
                    grid.n_azimuth,
                ),
            ]);
        } else {
            axes.push(Axis::uniform(
                "scattering_angle",
                "deg",
                0.0,
                s.angle_step_deg,
                self.n_angles(),
            ));
        }
        axes
    }

    /// The axes along which linear interpolation between samples is meaningful.
    pub fn interpolable_axes(&self) -> Vec<&'static str> {
        if self.two_d() {
            vec!["wavelength", "outgoing_polar", "outgoing_azimuth"]
        } else {
            vec!["wavelength", "scattering_angle"]
        }
    }

    /// Channels per direction.
    pub fn n_channels(&self) -> usize {
        super::channel_names(self.spec.max_order, self.spec.diagnostic_channels).len()
    }

    /// Values per entry: angles, or polar × azimuth directions, times channels.
    pub fn entry_len(&self) -> usize {
        if self.two_d() {
            let grid = self.direction_grid();
            grid.n_polar * grid.n_azimuth * self.n_channels()
        } else {
            self.n_angles() * self.n_channels()
        }
    }

    /// How the 2-D entries are traced.
    pub fn table2d_options(&self) -> Table2dOptions {
        let s = &self.spec;
        Table2dOptions {
            rays: s.rays,
            ray_grid: s.ray_grid,
            max_order: s.max_order,
            grid: self.direction_grid(),
            diffraction_filter: s.diffraction_filter,
            model: s.model,
            sphere_higher_orders: s.sphere_higher_orders,
            diagnostic_channels: s.diagnostic_channels,
            mirror_symmetrise: s.mirror_symmetrise,
            mirror_half: s.mirror_half,
        }
    }

    /// Airy-local transfer weights per 2-D entry (primary, secondary per azimuth column),
    /// 2 × n_azimuth, or none for the other models and for spheres.
    pub fn domain_values(&self) -> usize {
        if self.two_d() && self.table2d_options().airy_local() {
            2 * self.direction_grid().n_azimuth
        } else {
            0
        }
    }

    /// Whether the 2-D entries come from the 1-D sphere path ([`sphere_table_2d`]): a
    /// spherical drop under the airy-local model.
    pub(crate) fn sphere_from_1d_path(&self) -> bool {
        matches!(self.spec.shape, Some(DropShape::Sphere { .. }))
            && self.table2d_options().airy_local()
    }

    /// The compact form's parameters, for 2-D tables that ask for it.
    pub fn compact_spec(&self) -> Option<SunDiscResampled> {
        match self.spec.compression {
            Compression::SunDiscResampled(c) if self.two_d() => Some(c),
            _ => None,
        }
    }

    /// One (wavelength, sun elevation) entry of a 2-D table with real index `n`
    /// ([`trace_table_2d`]), the fields of its radius and wavelength shared with the other sun
    /// elevations ([`shared_wavelength_fields`]); under the airy-local model a sphere's entry
    /// comes from the 1-D path ([`sphere_table_2d`]).
    pub fn trace_entry(&self, wavelength_nm: f64, n: f64, elevation_deg: f64) -> Trace2d {
        let shape = self.spec.shape.as_ref().expect("2-D table has a shape");
        let opts = self.table2d_options();
        if self.sphere_from_1d_path() {
            return sphere_table_2d(shape.radius_um(), wavelength_nm, n, &opts);
        }
        // Before the trace: their few allocations do not stack on the accumulators' peak.
        let fields = shared_wavelength_fields(shape.radius_um(), wavelength_nm, n, &opts);
        trace_table_2d(shape, wavelength_nm, n, elevation_deg, &opts, &fields)
    }

    /// A sphere's 1-D entry with real index `n`: values `[angle][channel]`.
    pub fn sphere_entry(&self, radius_um: f64, wavelength_nm: f64, n: f64) -> Vec<f32> {
        let na = self.n_angles();
        let ch = sphere_table_channels(
            radius_um,
            wavelength_nm,
            n,
            &SphereTableOptions {
                max_order: self.spec.max_order,
                step_deg: self.spec.angle_step_deg,
                angles: na,
                diffraction_filter: self.spec.diffraction_filter,
                model: self.spec.model,
            },
        );
        let nch = self.n_channels();
        let mut out = vec![0f32; na * nch];
        for j in 0..na {
            for c in 0..nch {
                out[j * nch + c] = ch[c][j] as f32;
            }
        }
        out
    }

    /// ∫ phase dΩ of one entry's values (bin-sum over 4π): over the scattering angle (1-D) or
    /// the direction grid (2-D).
    pub fn entry_integral(&self, entry: &[f32]) -> f64 {
        let nch = self.n_channels();
        if self.two_d() {
            return entry_integral_2d(entry, self.direction_grid(), nch);
        }
        let step = self.spec.angle_step_deg.to_radians();
        integral_1d((0..self.n_angles()).map(|j| entry[j * nch] as f64), step)
    }

    /// The bin-sums of the entries of a table's values ([`Self::entry_integral`]).
    pub fn entry_integrals(&self, data: &[f32]) -> Vec<f64> {
        data.chunks(self.entry_len())
            .map(|e| self.entry_integral(e))
            .collect()
    }

    /// Divide every intensity channel (all but `dolp`) of a 2-D entry by its bin-sum
    /// `integral`, so ∫ p dΩ = 1 exactly on the table grid (decision RT-21). The bin-sum
    /// deviates from 1 by the flux of discarded silhouette triangles (−0.1…−0.5 %) and, for
    /// strongly flattened drops, by point-sampled cusp caustics (+3.9 % at 3 mm, sun 0°).
    pub fn renormalise_entry(&self, entry: &mut [f32], integral: f64) {
        let nch = self.n_channels();
        divide_intensities(entry, self.direction_grid().n_azimuth * nch, nch, integral);
    }

    /// The table from its entries' values in table order and their bin-sums `integrals`
    /// ([`Self::entry_integrals`], checked by the caller), on top of the phase-table contract's
    /// `attributes`; 2-D entries are renormalised here.
    pub fn content(
        &self,
        mut data: Vec<f32>,
        integrals: &[f64],
        attributes: Map<String, Value>,
    ) -> TableContent {
        let mut at = attributes;
        self.insert_common_attributes(&mut at);
        if !self.two_d() {
            return self.content_1d(data, integrals, at);
        }
        for (entry, &s) in data.chunks_mut(self.entry_len()).zip(integrals) {
            self.renormalise_entry(entry, s);
        }
        self.content_2d(data, integrals, at, self.axes())
    }
}
