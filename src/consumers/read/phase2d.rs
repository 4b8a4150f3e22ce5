//! Consumers' view of the ray tracer's 2-D tables (schema `raytrace-phase-2d`, stage `raytrace`
//! for non-spherical drops), channel `phase` (1/sr). Both versions are read:
//! - version 2 (written now): radius (µm) × wavelength (nm) × sun_elevation (deg) ×
//!   outgoing_polar (deg) × outgoing_azimuth (deg), the radius × wavelength × … × angle order of
//!   every phase-function table;
//! - version 1: wavelength × [entry axes] × sun_elevation × outgoing_polar × outgoing_azimuth,
//!   the radius (mm) in the `radius_mm` attribute.
//!
//! In general the axes before `sun_elevation` are `wavelength` (at any position) and entry axes
//! (e.g. `radius`); other versions are refused with a message naming the version.
//!
//! Frame (the table's `frame` attribute, `docs/raytrace.md`): drop symmetry axis z up, sun at
//! elevation e in the +x half, incident (propagation) direction d = (−cos e, 0, −sin e);
//! outgoing_polar = angle between d and the outgoing direction w (0 = forward), outgoing_azimuth
//! = azimuth of w about d measured from e1 = (−sin e, 0, cos e) (the vertical plane, upwards)
//! towards e2 = d × e1 = +y. This is also the renderer's world frame (sun at azimuth 0), so a
//! world direction needs no rotation. For an incident direction that is not in the x–z plane
//! (sun-disc samples) the frame is the same construction about that direction (e1 = the
//! component of z perpendicular to d), which is exact because the drops are axisymmetric about
//! z.
//!
//! Values are read only through the public reader API: [`Phase2dTable::slice`] samples the
//! table with `Table::sample` (multilinear) at the requested sun elevation and entry, on the
//! table's own polar × azimuth grid; the bilinear interpolation of that slice in (polar,
//! azimuth) is then identical to the table's multilinear lookup formula, with the azimuth taken
//! as periodic (the axis covers [0, 360) without repeating 360°).

use super::spectrum::SkyPhase;
use crate::consumers::ConsumerError;
use crate::consumers::read::phase::EntrySelection;
use crate::math::vec3::V3;
use crate::math::vec3::{cross, dot};
use crate::table::{Axis, Table};
use rayon::prelude::*;
use std::path::Path;

/// Schema name of the ray tracer's 2-D tables.
pub const SCHEMA_2D: &str = "raytrace-phase-2d";

/// Versions of [`SCHEMA_2D`] this reader understands.
pub const SCHEMA_2D_VERSIONS: [u32; 2] = [1, 2];

/// Is this a 2-D ray-traced table?
pub fn is_2d(table: &Table) -> bool {
    table.header.schema.name == SCHEMA_2D
}

/// A `raytrace-phase-2d` table (version 1 or 2) with its axes identified.
pub struct Phase2dTable {
    pub table: Table,
    ax_wavelength: usize,
    ax_elev: usize,
    ax_polar: usize,
    ax_az: usize,
    /// Entry axes other than wavelength / sun_elevation / polar / azimuth (e.g. radius), in
    /// table order.
    pub entry_axes: Vec<usize>,
}

impl Phase2dTable {
    /// Open a file and check the layout.
    pub fn open(path: &Path) -> Result<Self, ConsumerError> {
        ConsumerError::check_file(path, Self::new)
    }

    /// Check a table in memory.
    pub fn new(table: Table) -> Result<Self, ConsumerError> {
        if !is_2d(&table) {
            return Err(ConsumerError::layout(format!(
                "schema `{}` is not `{SCHEMA_2D}`",
                table.header.schema.name
            )));
        }
        let version = table.header.schema.version;
        if !SCHEMA_2D_VERSIONS.contains(&version) {
            return Err(ConsumerError::layout(format!(
                "`{SCHEMA_2D}/{version}` is not a version this reader knows (it reads \
                 {SCHEMA_2D}/1 and {SCHEMA_2D}/2)"
            )));
        }
        let axes = table.axes();
        let n = axes.len();
        let ax_wavelength = axes[..n.saturating_sub(3)]
            .iter()
            .position(|a| a.name == "wavelength");
        let (true, Some(ax_wavelength)) = (
            n >= 4
                && axes[n - 3].name == "sun_elevation"
                && axes[n - 2].name == "outgoing_polar"
                && axes[n - 1].name == "outgoing_azimuth",
            ax_wavelength,
        ) else {
            let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
            return Err(ConsumerError::layout(format!(
                "expected axes [radius ×] wavelength × sun_elevation × outgoing_polar × \
                 outgoing_azimuth (version 2) or wavelength × [entry axes] × sun_elevation × \
                 outgoing_polar × outgoing_azimuth (version 1), found {names:?}"
            )));
        };
        let ch_phase = table
            .channel_index("phase")
            .map_err(|_| ConsumerError::layout("table has no channel `phase`"))?;
        crate::consumers::read::phase::check_finite(&table, &[ch_phase])?;
        let p = axes[n - 2].coords();
        if p[0] > 1e-9 || p[p.len() - 1] < 180.0 - 1e-9 {
            return Err(ConsumerError::layout(
                "outgoing_polar must cover [0, 180] deg",
            ));
        }
        let a = axes[n - 1].coords();
        if a[0].abs() > 1e-9 || a[a.len() - 1] >= 360.0 {
            return Err(ConsumerError::layout(
                "outgoing_azimuth must start at 0 and stay below 360 deg",
            ));
        }
        if let Some(sym) = axes[n - 1].symmetry
            && sym.period() != 360.0
        {
            return Err(ConsumerError::layout(format!(
                "outgoing_azimuth is even-periodic with period {} deg; a phase function's \
                 azimuth has period 360 deg",
                sym.period()
            )));
        }
        Ok(Phase2dTable {
            ax_wavelength,
            ax_elev: n - 3,
            ax_polar: n - 2,
            ax_az: n - 1,
            entry_axes: (0..n - 3).filter(|&i| i != ax_wavelength).collect(),
            table,
        })
    }

    /// The table's sun elevations (deg).
    pub fn elevations_deg(&self) -> Vec<f64> {
        self.table.axes()[self.ax_elev].coords()
    }

    /// The sun elevation to use: the table's lowest elevation when none is requested, else the
    /// requested one, which must lie within the table's range and, unless the table declares
    /// `sun_elevation` interpolable, be one of its elevations (errors name the range or the
    /// nearest elevation).
    pub fn resolve_elevation(&self, requested: Option<f64>) -> Result<f64, ConsumerError> {
        let e = self.elevations_deg();
        match requested {
            None => Ok(e[0]),
            Some(x) => {
                super::operators::resolve_axis_value(&self.table, self.ax_elev, x).map_err(|e| {
                    ConsumerError::invalid(format!(
                        "{e}; ray-traced tables are only valid at the sun elevations they were \
                         traced for (--sun-elevation-deg)"
                    ))
                })
            }
        }
    }

    /// Entry values (name, value) for the extra entry axes: requested or the first sample.
    pub fn resolve_entry(
        &self,
        sel: &[EntrySelection],
    ) -> Result<Vec<(String, f64)>, ConsumerError> {
        crate::consumers::read::phase::resolve_entry_axes(
            &self.table,
            &self.entry_axes,
            sel,
            "; the sun elevation is chosen with --sun-elevation-deg",
        )
    }

    /// Drop radius for labels: the entry's `radius` (in its axis unit) or, for version 1
    /// tables without a radius axis, the `radius_mm` attribute; for a drop-size mixture (entry
    /// axis `distribution`, no single radius) the entry's label when the axis has labels (e.g.
    /// `marshall-palmer R=5 mm/h r=50-3000 um`), else the entry itself, e.g. `distribution 1`.
    pub fn radius_label(&self, entry: &[(String, f64)]) -> String {
        if let Some((_, v)) = entry.iter().find(|e| e.0 == "radius") {
            let unit = self
                .table
                .axes()
                .iter()
                .find(|a| a.name == "radius")
                .map(|a| a.unit.as_str())
                .unwrap_or("");
            return format!("{v} {unit}");
        }
        match self.table.header.attributes.get("radius_mm") {
            Some(v) => format!("{v} mm"),
            None if !entry.is_empty() => entry
                .iter()
                .map(|(name, v)| {
                    // a labelled axis (e.g. `distribution`) names its entries
                    let axis = self.table.axes().iter().find(|a| &a.name == name);
                    let label = axis.and_then(|a| {
                        (0..a.len())
                            .find(|i| a.coord(*i) == *v)
                            .and_then(|i| a.label(i))
                    });
                    label.map_or_else(|| format!("{name} {v}"), str::to_string)
                })
                .collect::<Vec<_>>()
                .join(", "),
            None => "?".into(),
        }
    }

    /// One channel at `elevation_deg` and the entry, on the table's polar × azimuth grid, every
    /// wavelength (sampled through `Table::sample`).
    pub fn slice(
        &self,
        elevation_deg: f64,
        sel: &[EntrySelection],
        channel: &str,
    ) -> Result<PhaseSlice, ConsumerError> {
        let entry = self.resolve_entry(sel)?;
        let elevation_deg = self.resolve_elevation(Some(elevation_deg))?;
        let ch = self.table.channel_index(channel)?;
        let axes = self.table.axes();
        let wavelengths_nm = axes[self.ax_wavelength].coords();
        let polar_deg = axes[self.ax_polar].coords();
        // The full circle: a symmetric azimuth axis (0°–180° stored) unfolded onto 0°–360°.
        let (azimuth_deg, stored_az) = unfolded_azimuths(&axes[self.ax_az]);
        let (np, na) = (polar_deg.len(), azimuth_deg.len());
        // Entry and elevation are stored samples whenever their axes are not interpolable
        // (`resolve_entry`/`resolve_elevation` refuse anything else): then the slice is read
        // straight from the grid; otherwise each value is interpolated.
        let stored = |axis: usize, v: f64| {
            let c = axes[axis].coords();
            c.iter()
                .position(|&x| (x - v).abs() <= 1e-9 * v.abs().max(1.0))
        };
        let mut fixed: Vec<Option<usize>> = vec![None; axes.len()];
        for (&i, e) in self.entry_axes.iter().zip(&entry) {
            fixed[i] = stored(i, e.1);
        }
        fixed[self.ax_elev] = stored(self.ax_elev, elevation_deg);
        let on_grid = self
            .entry_axes
            .iter()
            .chain([&self.ax_elev])
            .all(|&i| fixed[i].is_some());
        let rows: Vec<(usize, usize)> = (0..wavelengths_nm.len())
            .flat_map(|k| (0..np).map(move |j| (k, j)))
            .collect();
        let values: Vec<f32> = rows
            .par_iter()
            .map(|&(k, j)| {
                if on_grid {
                    let mut idx: Vec<usize> = fixed.iter().map(|f| f.unwrap_or(0)).collect();
                    idx[self.ax_wavelength] = k;
                    idx[self.ax_polar] = j;
                    return Ok((stored_az.iter())
                        .map(|&i| {
                            idx[self.ax_az] = i;
                            self.table.at(&idx, ch)
                        })
                        .collect());
                }
                let mut c = vec![0.0; axes.len()];
                c[self.ax_wavelength] = wavelengths_nm[k];
                for (&i, e) in self.entry_axes.iter().zip(&entry) {
                    c[i] = e.1;
                }
                c[self.ax_elev] = elevation_deg;
                c[self.ax_polar] = polar_deg[j];
                (0..na)
                    .map(|i| {
                        c[self.ax_az] = azimuth_deg[i];
                        self.table.sample(&c).map(|v| v[ch] as f32)
                    })
                    .collect::<Result<Vec<f32>, _>>()
            })
            .collect::<Result<Vec<Vec<f32>>, _>>()?
            .into_iter()
            .flatten()
            .collect();
        Ok(PhaseSlice {
            wavelengths_nm,
            sun_elevation_deg: elevation_deg,
            polar_step: uniform_step(&polar_deg),
            polar_deg,
            azimuth_deg,
            values,
            entry,
        })
    }
}

/// The azimuths of a slice on the full circle and, for each, the index of its stored sample:
/// the axis as stored, or for an even-periodic axis (table format 3.0: 0°–180° stored, the
/// value at 360° − φ that at φ) the stored samples followed by the mirror images 360° − φ of
/// those strictly between 0° and 180°, in increasing order.
fn unfolded_azimuths(axis: &Axis) -> (Vec<f64>, Vec<usize>) {
    let c = axis.coords();
    let n = c.len();
    let Some(symmetry) = axis.symmetry else {
        return (c, (0..n).collect());
    };
    let period = symmetry.period();
    let mirrored = (1..n - 1).rev().map(|i| (period - c[i], i));
    (0..n).map(|i| (c[i], i)).chain(mirrored).unzip()
}

fn uniform_step(c: &[f64]) -> Option<f64> {
    let n = c.len();
    let step = (c[n - 1] - c[0]) / (n - 1) as f64;
    c.windows(2)
        .all(|w| (w[1] - w[0] - step).abs() <= 1e-9 * step)
        .then_some(step)
}

/// One channel of a 2-D table at one sun elevation and entry: `values[(k·n_polar + j)·n_az + i]`.
#[derive(Debug, Clone)]
pub struct PhaseSlice {
    pub wavelengths_nm: Vec<f64>,
    pub sun_elevation_deg: f64,
    pub polar_deg: Vec<f64>,
    pub azimuth_deg: Vec<f64>,
    polar_step: Option<f64>,
    values: Vec<f32>,
    pub entry: Vec<(String, f64)>,
}

/// Bracketing index and weight on a sorted grid (clamped at the ends).
fn locate(c: &[f64], step: Option<f64>, x: f64) -> (usize, f64) {
    let n = c.len();
    if x <= c[0] {
        return (0, 0.0);
    }
    if x >= c[n - 1] {
        return (n - 2, 1.0);
    }
    let j = match step {
        Some(s) => (((x - c[0]) / s) as usize).min(n - 2),
        None => c.partition_point(|&v| v <= x).clamp(1, n - 1) - 1,
    };
    (j, ((x - c[j]) / (c[j + 1] - c[j])).clamp(0.0, 1.0))
}

impl PhaseSlice {
    /// Value at wavelength index k, polar and azimuth (deg): bilinear, azimuth periodic.
    pub fn value(&self, k: usize, polar_deg: f64, azimuth_deg: f64) -> f64 {
        let w = self.weights(polar_deg, azimuth_deg);
        self.apply(k, &w)
    }

    /// Bilinear corner indices (within one wavelength's block) and weights.
    fn weights(&self, polar_deg: f64, azimuth_deg: f64) -> [(usize, f64); 4] {
        let (j, tj) = locate(&self.polar_deg, self.polar_step, polar_deg);
        let na = self.azimuth_deg.len();
        let a = azimuth_deg.rem_euclid(360.0);
        let (i0, i1, ti) = if a >= self.azimuth_deg[na - 1] {
            // Between the last sample and 360° ≡ the first sample.
            let last = self.azimuth_deg[na - 1];
            (na - 1, 0, (a - last) / (360.0 - last))
        } else {
            let (i, t) = locate(&self.azimuth_deg, None, a);
            (i, i + 1, t)
        };
        [
            (j * na + i0, (1.0 - tj) * (1.0 - ti)),
            (j * na + i1, (1.0 - tj) * ti),
            ((j + 1) * na + i0, tj * (1.0 - ti)),
            ((j + 1) * na + i1, tj * ti),
        ]
    }

    fn apply(&self, k: usize, w: &[(usize, f64); 4]) -> f64 {
        let base = k * self.polar_deg.len() * self.azimuth_deg.len();
        w.iter()
            .map(|&(i, t)| t * f64::from(self.values[base + i]))
            .sum()
    }
}

/// (outgoing_polar, outgoing_azimuth) in deg of the outgoing direction `out` for light
/// propagating along `inc` (both unit vectors, world frame = drop frame, z up).
pub fn table_angles(inc: V3, out: V3) -> (f64, f64) {
    let c = dot(inc, out).clamp(-1.0, 1.0);
    // e1 = normalize(z − (z·d) d): the vertical direction perpendicular to d, upwards.
    let mut e1 = [-inc[2] * inc[0], -inc[2] * inc[1], 1.0 - inc[2] * inc[2]];
    let l = dot(e1, e1).sqrt();
    if l < 1e-12 {
        // Sun at the zenith/nadir: the table's e1 = (−sin e, 0, cos e) limit.
        e1 = [-inc[2].signum(), 0.0, 0.0];
    } else {
        e1 = [e1[0] / l, e1[1] / l, e1[2] / l];
    }
    let e2 = cross(inc, e1);
    let az = dot(out, e2)
        .atan2(dot(out, e1))
        .to_degrees()
        .rem_euclid(360.0);
    (c.acos().to_degrees(), az)
}

/// Outgoing direction (world frame) at table angles for the sun at `elevation_deg` (azimuth 0).
pub fn outgoing_direction(elevation_deg: f64, polar_deg: f64, azimuth_deg: f64) -> V3 {
    let (se, ce) = elevation_deg.to_radians().sin_cos();
    let d = [-ce, 0.0, -se];
    let e1 = [-se, 0.0, ce];
    let e2 = [0.0, 1.0, 0.0];
    let (st, ct) = polar_deg.to_radians().sin_cos();
    let (sp, cp) = azimuth_deg.to_radians().sin_cos();
    [0, 1, 2].map(|c| ct * d[c] + st * (cp * e1[c] + sp * e2[c]))
}

impl SkyPhase for PhaseSlice {
    fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }
    /// The slice is taken at the disc centre's elevation; each disc sample uses its own
    /// incident direction and frame (exact for a shift of the sun in azimuth; for a shift in
    /// elevation of at most the disc radius the table's elevation dependence is neglected).
    fn add_phase(&self, inc: V3, out: V3, spec: &mut [f64]) {
        let (p, a) = table_angles(inc, out);
        let w = self.weights(p, a);
        for (k, s) in spec.iter_mut().enumerate() {
            *s += self.apply(k, &w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_round_trip_and_documented_axes() {
        for &e in &[0.0, 17.0, 30.0, 60.0] {
            let (se, ce) = f64::to_radians(e).sin_cos();
            let d = [-ce, 0.0, -se];
            // Forward is polar 0; "up" (e1) is azimuth 0; +y is azimuth 90.
            assert!(table_angles(d, d).0 < 1e-6);
            let (p, a) = table_angles(d, [-se, 0.0, ce]);
            assert!((p - 90.0).abs() < 1e-9 && a.abs() < 1e-9, "{p} {a}");
            let (p, a) = table_angles(d, [0.0, 1.0, 0.0]);
            assert!(
                (p - 90.0).abs() < 1e-9 && (a - 90.0).abs() < 1e-9,
                "{p} {a}"
            );
            for &(pp, aa) in &[(138.0, 0.0), (138.0, 95.0), (42.0, 271.0), (179.0, 180.0)] {
                let w = outgoing_direction(e, pp, aa);
                let (p, a) = table_angles(d, w);
                assert!(
                    (p - pp).abs() < 1e-9 && (a - aa).abs() < 1e-9,
                    "{e}: {p} {a}"
                );
            }
        }
    }

    /// A version 1 layout (wavelength × radius × sun_elevation × …) is still read; radius and
    /// sun elevation are interpolated only when the table declares them interpolable.
    #[test]
    fn radius_entry_axis_is_selected_and_interpolated() {
        use crate::table::{Axis, Channel, Provenance, Schema, TableContent};
        // wavelength (1) × radius (2) × sun_elevation (2) × polar (3) × azimuth (4):
        // phase = radius_um + 10·elevation + polar/1000 + azimuth/1e5.
        let (radii, elev, polar, az) = ([500.0, 1000.0], [0.0, 20.0], [0.0, 90.0, 180.0], 4);
        let mut data = vec![];
        for &r in &radii {
            for &e in &elev {
                for &p in &polar {
                    for i in 0..az {
                        data.push((r + 10.0 * e + p / 1000.0 + 90.0 * i as f64 / 1e5) as f32);
                    }
                }
            }
        }
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new(SCHEMA_2D, 1),
            description: "test".into(),
            axes: vec![
                Axis::values("wavelength", "nm", vec![550.0]),
                Axis::values("radius", "um", radii.to_vec()),
                Axis::values("sun_elevation", "deg", elev.to_vec()),
                Axis::values("outgoing_polar", "deg", polar.to_vec()),
                Axis::uniform("outgoing_azimuth", "deg", 0.0, 90.0, az),
            ],
            channels: vec![Channel::new("phase", "1/sr", "test")],
            attributes: Default::default(),
            data,
        };
        let coarse =
            Phase2dTable::new(Table::from_content(content.clone(), Provenance::default()).unwrap())
                .unwrap();
        let sel: EntrySelection = "radius=750".parse().unwrap();
        let e = coarse
            .slice(0.0, std::slice::from_ref(&sel), "phase")
            .err()
            .unwrap();
        assert!(e.to_string().contains("nearest is 500 um"), "{e}");
        let e = coarse.slice(5.0, &[], "phase").err().unwrap();
        assert!(e.to_string().contains("nearest is 0 deg"), "{e}");
        let mut content = content;
        content.attributes.insert(
            "interpolable_axes".into(),
            serde_json::json!([
                "wavelength",
                "radius",
                "sun_elevation",
                "outgoing_polar",
                "outgoing_azimuth"
            ]),
        );
        let t = Phase2dTable::new(Table::from_content(content, Provenance::default()).unwrap())
            .unwrap();
        let s = t.slice(5.0, &[sel], "phase").unwrap();
        assert_eq!(t.radius_label(&s.entry), "750 um");
        // Linear in every axis: exact at an off-grid point; azimuth 315° interpolates between
        // 270° and 360° ≡ 0° (periodic), not clamped at 270°.
        let v = s.value(0, 45.0, 45.0);
        assert!(
            (v - (750.0 + 50.0 + 0.045 + 45.0 / 1e5)).abs() < 1e-3,
            "{v}"
        );
        let v = s.value(0, 90.0, 315.0);
        assert!((v - (800.0 + 0.09 + 0.5 * 270.0 / 1e5)).abs() < 1e-3, "{v}");
        let bad: EntrySelection = "size=1".parse().unwrap();
        assert!(t.slice(5.0, &[bad], "phase").is_err());
        // On stored samples the slice is read from the grid: every value as stored.
        let at: EntrySelection = "radius=1000".parse().unwrap();
        let s = t.slice(20.0, &[at], "phase").unwrap();
        assert_eq!(s.values.len(), 3 * 4);
        for (j, p) in polar.iter().enumerate() {
            for i in 0..az {
                let expected = (1000.0 + 200.0 + p / 1000.0 + 90.0 * i as f64 / 1e5) as f32;
                assert_eq!(s.values[j * az + i], expected, "polar {p}, azimuth {i}");
            }
        }
    }

    /// A table storing 0°–180° of azimuth on an even-periodic axis (table format 3.0) is read
    /// as the full circle: the slice holds the mirror images 360° − φ, equal to the slice of
    /// the same table stored whole, and so are its lookups between them; a period other than
    /// 360° is refused.
    #[test]
    fn symmetric_azimuth_axes_unfold_onto_the_full_circle() {
        use crate::table::{Axis, Symmetry};
        let (elev, polar) = (vec![0.0, 20.0], vec![0.0, 90.0, 180.0]);
        let value = |e: f64, p: f64, a: f64| {
            (1.0 + 0.01 * e + p / 1000.0 + (a.to_radians().cos() + 2.0) / 10.0) as f32
        };
        let grid = |az: &[f64]| -> Vec<f32> {
            let mut v = vec![];
            for &e in &elev {
                for &p in &polar {
                    v.extend(az.iter().map(|&a| value(e, p, a)));
                }
            }
            v
        };
        let half_az = vec![0.0, 45.0, 90.0, 135.0, 180.0];
        let full_az: Vec<f64> = (0..8).map(|i| 45.0 * i as f64).collect();
        let axes = |az: Vec<f64>, symmetric: bool| {
            let a = Axis::values("outgoing_azimuth", "deg", az);
            vec![
                Axis::values("wavelength", "nm", vec![550.0]),
                Axis::values("sun_elevation", "deg", elev.clone()),
                Axis::values("outgoing_polar", "deg", polar.clone()),
                if symmetric {
                    a.with_symmetry(Symmetry::EvenPeriodic { period: 360.0 })
                } else {
                    a
                },
            ]
        };
        let half =
            Phase2dTable::new(table_2d(2, axes(half_az.clone(), true), grid(&half_az))).unwrap();
        let full =
            Phase2dTable::new(table_2d(2, axes(full_az.clone(), false), grid(&full_az))).unwrap();
        for elevation in [20.0, 0.0] {
            let (h, f) = (
                half.slice(elevation, &[], "phase").unwrap(),
                full.slice(elevation, &[], "phase").unwrap(),
            );
            assert_eq!(h.azimuth_deg, full_az);
            assert_eq!(h.values, f.values, "elevation {elevation}");
            for (p, a) in [(30.0, 200.0), (90.0, 337.5), (179.0, 359.0)] {
                assert_eq!(h.value(0, p, a), f.value(0, p, a), "{p} {a}");
            }
        }
        let odd = axes(half_az.clone(), false);
        let mut odd = odd;
        odd[3] = Axis::values("outgoing_azimuth", "deg", vec![0.0, 45.0, 90.0])
            .with_symmetry(Symmetry::EvenPeriodic { period: 180.0 });
        let bad = Phase2dTable::new(table_2d(2, odd, grid(&[0.0, 45.0, 90.0])));
        assert!(bad.err().unwrap().to_string().contains("period 180"));
    }

    fn table_2d(version: u32, axes: Vec<crate::table::Axis>, data: Vec<f32>) -> Table {
        use crate::table::{Channel, Provenance, Schema, TableContent};
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new(SCHEMA_2D, version),
            description: "test".into(),
            axes,
            channels: vec![Channel::new("phase", "1/sr", "test")],
            attributes: Default::default(),
            data,
        };
        Table::from_content(content, Provenance::default()).unwrap()
    }

    /// Version 2 layout (radius × wavelength × sun_elevation × polar × azimuth): the radius is an
    /// entry axis and the wavelength axis is found in second place; an unknown version is
    /// refused with its number.
    #[test]
    fn version_2_layout_is_read_and_unknown_versions_refused() {
        use crate::table::Axis;
        // phase = radius_um + wavelength_nm/1000 + 10·elevation + polar/1000 + azimuth/1e5.
        let (radii, wl, elev, polar, az) = (
            [400.0, 800.0],
            [450.0, 650.0],
            [0.0, 20.0],
            [0.0, 90.0, 180.0],
            4,
        );
        let mut data = vec![];
        for &r in &radii {
            for &w in &wl {
                for &e in &elev {
                    for &p in &polar {
                        for i in 0..az {
                            let v = r + w / 1000.0 + 10.0 * e + p / 1000.0;
                            data.push((v + 90.0 * i as f64 / 1e5) as f32);
                        }
                    }
                }
            }
        }
        let axes = vec![
            Axis::values("radius", "um", radii.to_vec()),
            Axis::values("wavelength", "nm", wl.to_vec()),
            Axis::values("sun_elevation", "deg", elev.to_vec()),
            Axis::values("outgoing_polar", "deg", polar.to_vec()),
            Axis::uniform("outgoing_azimuth", "deg", 0.0, 90.0, az),
        ];
        let t = Phase2dTable::new(table_2d(2, axes.clone(), data.clone())).unwrap();
        let sel: EntrySelection = "radius=800".parse().unwrap();
        let s = t.slice(20.0, &[sel], "phase").unwrap();
        assert_eq!(s.wavelengths_nm, wl.to_vec());
        assert_eq!(t.radius_label(&s.entry), "800 um");
        assert_eq!(
            t.radius_label(&[("distribution".to_string(), 1.0)]),
            "distribution 1",
            "a mixture entry is named, not shown as `?`"
        );
        for (k, w) in wl.iter().enumerate() {
            let v = s.value(k, 90.0, 90.0);
            let want = 800.0 + w / 1000.0 + 200.0 + 0.09 + 90.0 / 1e5;
            assert!((v - want).abs() < 1e-3, "{v} vs {want}");
        }
        let e = Phase2dTable::new(table_2d(3, axes, data))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("raytrace-phase-2d/3"), "{e}");
    }
}
