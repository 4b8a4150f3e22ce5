//! Reading phase-function tables that follow `PHASE_CONTRACT` (see `docs/consumers.md`):
//! one axis `wavelength` (nm, at any position but the last), last axis `scattering_angle` (deg,
//! 0 = forward, covering [0, 180]), every other axis is an "entry" axis (e.g. `radius`) selected
//! by `--entry name=value`; channels
//! `phase`, `i_perp`, `i_par` (1/sr, ∫_{4π} p dΩ = 1) and `dolp`.
//!
//! The axis order does not matter, so `raytrace-phase/1` tables (wavelength × radius ×
//! scattering_angle) are read as well as `raytrace-phase/2` (radius × wavelength ×
//! scattering_angle, the order of `mie-phase` and `debye-phase`); the channels mean the same in
//! both. Other `raytrace-phase` versions are refused with a message naming the version.
//!
//! Everything here goes through the public reader API ([`Table::open`], [`Table::sample`]).

use crate::consumers::ConsumerError;
use crate::table::Table;
use std::path::Path;

/// Refuse a table whose channels `channels` hold NaN or infinite values: no consumer can show,
/// export or compare a phase function that is not a number (`scatterbake verify --strict`
/// lists them). The message names the channel, the count and the first grid index.
pub fn check_finite(table: &Table, channels: &[usize]) -> Result<(), ConsumerError> {
    let nc = table.header.channels.len();
    for &c in channels {
        let mut bad = table
            .data
            .iter()
            .skip(c)
            .step_by(nc)
            .enumerate()
            .filter(|(_, v)| !v.is_finite())
            .map(|(i, _)| i);
        if let Some(first) = bad.next() {
            let count = 1 + bad.count();
            return Err(ConsumerError::invalid(format!(
                "channel `{}` holds {} NaN or infinite value(s) (the first at flat grid index {first}); \
                 a phase function must be finite: run `scatterbake verify --strict` on the table",
                table.header.channels[c].name, count
            )));
        }
    }
    Ok(())
}

/// One `name=value` entry selection (value in the axis unit).
#[derive(Debug, Clone, PartialEq)]
pub struct EntrySelection {
    pub axis: String,
    pub value: f64,
}

impl std::str::FromStr for EntrySelection {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| format!("`{s}`: expected NAME=VALUE, e.g. radius=500"))?;
        let value: f64 = value
            .trim()
            .parse()
            .map_err(|e| format!("`{s}`: value is not a number ({e})"))?;
        if !value.is_finite() {
            return Err(format!("`{s}`: value must be a finite number"));
        }
        Ok(EntrySelection {
            axis: name.trim().to_string(),
            value,
        })
    }
}

/// A table checked against the phase-function contract, with the entry axes identified.
pub struct PhaseTable {
    pub table: Table,
    /// Index of the `scattering_angle` axis (always the last).
    pub angle_axis: usize,
    /// Index of the `wavelength` axis.
    pub wavelength_axis: usize,
    /// Indices of the entry axes (every axis but wavelength and scattering_angle, in order).
    pub entry_axes: Vec<usize>,
    ch_phase: usize,
    ch_perp: usize,
    ch_par: usize,
}

/// The phase function of one entry at every wavelength, on the table's own angle grid.
#[derive(Debug, Clone)]
pub struct PhaseCurves {
    pub wavelengths_nm: Vec<f64>,
    pub angles_deg: Vec<f64>,
    /// `phase[k][j]`: p at wavelength k and angle j (1/sr).
    pub phase: Vec<Vec<f64>>,
    pub i_perp: Vec<Vec<f64>>,
    pub i_par: Vec<Vec<f64>>,
    /// Coordinates of the selected entry, `(axis name, value)` per entry axis.
    pub entry: Vec<(String, f64)>,
    /// Step of the angle grid when it is uniform (to 1e-9 relative).
    pub uniform_step: Option<f64>,
}

impl PhaseTable {
    /// Open a table file and check the contract.
    pub fn open(path: &Path) -> Result<Self, ConsumerError> {
        ConsumerError::check_file(path, Self::new)
    }

    /// Check a table in memory against the contract.
    pub fn new(table: Table) -> Result<Self, ConsumerError> {
        let (wavelength_axis, [ch_phase, ch_perp, ch_par]) = Self::check_header(&table.header)?;
        check_finite(&table, &[ch_phase, ch_perp, ch_par])?;
        let last = table.axes().len() - 1;
        Ok(PhaseTable {
            entry_axes: (0..last).filter(|&i| i != wavelength_axis).collect(),
            angle_axis: last,
            wavelength_axis,
            ch_phase,
            ch_perp,
            ch_par,
            table,
        })
    }

    /// Check a table header against the layout part of the contract (axes, units, channels;
    /// the values are checked by [`PhaseTable::new`]): the index of the wavelength axis and of
    /// the channels `phase`, `i_perp`, `i_par`.
    pub fn check_header(
        header: &crate::table::Header,
    ) -> Result<(usize, [usize; 3]), ConsumerError> {
        let schema = &header.schema;
        if schema.name == "raytrace-phase" && !(1..=2).contains(&schema.version) {
            return Err(ConsumerError::layout(format!(
                "`raytrace-phase/{}` is not a version this reader knows (it reads \
                 raytrace-phase/1 and raytrace-phase/2)",
                schema.version
            )));
        }
        let axes = &header.axes;
        if axes.len() < 2 {
            return Err(ConsumerError::layout(
                "a phase-function table needs at least the axes wavelength and scattering_angle",
            ));
        }
        let last = axes.len() - 1;
        let Some(wavelength_axis) = axes[..last].iter().position(|a| a.name == "wavelength") else {
            let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
            return Err(ConsumerError::layout(format!(
                "a phase-function table needs a `wavelength` axis before `scattering_angle` (axes: {names:?})"
            )));
        };
        if axes[wavelength_axis].unit != "nm" {
            return Err(ConsumerError::layout(format!(
                "axis `wavelength` must be in nm (found `{}`)",
                axes[wavelength_axis].unit
            )));
        }
        let a = &axes[last];
        if a.name != "scattering_angle" || a.unit != "deg" {
            return Err(ConsumerError::layout(format!(
                "last axis must be `scattering_angle` in deg (found `{}` in `{}`); 2-D tables \
                 (outgoing_polar/outgoing_azimuth) are not 1-D phase functions",
                a.name, a.unit
            )));
        }
        let c = a.coords();
        if c[0] > 1e-9 || c[c.len() - 1] < 180.0 - 1e-9 {
            return Err(ConsumerError::layout(format!(
                "scattering_angle must cover [0, 180] deg (covers [{}, {}])",
                c[0],
                c[c.len() - 1]
            )));
        }
        let ch = |n: &str| {
            header
                .channels
                .iter()
                .position(|c| c.name == n)
                .ok_or_else(|| {
                    ConsumerError::layout(format!(
                        "table has no channel `{n}` required by the phase contract"
                    ))
                })
        };
        Ok((wavelength_axis, [ch("phase")?, ch("i_perp")?, ch("i_par")?]))
    }

    /// Wavelengths of the table (nm).
    pub fn wavelengths_nm(&self) -> Vec<f64> {
        self.table.axes()[self.wavelength_axis].coords()
    }

    /// Scattering angles of the table (deg).
    pub fn angles_deg(&self) -> Vec<f64> {
        self.table.axes()[self.angle_axis].coords()
    }

    /// Resolve an entry selection: for every entry axis the requested value, or its first
    /// sample when not selected. Unknown axis names are an error.
    pub fn resolve_entry(
        &self,
        sel: &[EntrySelection],
    ) -> Result<Vec<(String, f64)>, ConsumerError> {
        resolve_entry_axes(&self.table, &self.entry_axes, sel, "")
    }

    /// Interpolated (phase, i_perp, i_par) at wavelength, entry values and angle (table lookup
    /// formula: multilinear in the stored coordinates, clamped at the axis ends).
    pub fn sample_at(
        &self,
        wavelength_nm: f64,
        entry: &[(String, f64)],
        angle_deg: f64,
    ) -> Result<[f64; 3], ConsumerError> {
        let mut coords = vec![0.0; entry.len() + 2];
        coords[self.wavelength_axis] = wavelength_nm;
        for (&i, e) in self.entry_axes.iter().zip(entry) {
            coords[i] = e.1;
        }
        coords[self.angle_axis] = angle_deg;
        let v = self.table.sample(&coords)?;
        Ok([v[self.ch_phase], v[self.ch_perp], v[self.ch_par]])
    }

    /// Curves of one entry at every table wavelength on the table's angle grid (grid values are
    /// reproduced exactly when the entry value lies on a grid sample).
    pub fn curves(&self, sel: &[EntrySelection]) -> Result<PhaseCurves, ConsumerError> {
        let entry = self.resolve_entry(sel)?;
        let wavelengths_nm = self.wavelengths_nm();
        let angles_deg = self.angles_deg();
        let mut out = PhaseCurves {
            wavelengths_nm: wavelengths_nm.clone(),
            angles_deg: angles_deg.clone(),
            phase: vec![],
            i_perp: vec![],
            i_par: vec![],
            entry: entry.clone(),
            uniform_step: {
                let n = angles_deg.len();
                let step = (angles_deg[n - 1] - angles_deg[0]) / (n - 1) as f64;
                angles_deg
                    .windows(2)
                    .all(|w| (w[1] - w[0] - step).abs() <= 1e-9 * step)
                    .then_some(step)
            },
        };
        for &wl in &wavelengths_nm {
            let (mut p, mut s, mut q) = (vec![], vec![], vec![]);
            for &a in &angles_deg {
                let v = self.sample_at(wl, &entry, a)?;
                p.push(v[0]);
                s.push(v[1]);
                q.push(v[2]);
            }
            out.phase.push(p);
            out.i_perp.push(s);
            out.i_par.push(q);
        }
        Ok(out)
    }
}

impl PhaseCurves {
    /// Index of the table wavelength nearest to `wavelength_nm`.
    pub fn nearest_wavelength(&self, wavelength_nm: f64) -> usize {
        let mut best = 0;
        for (k, &w) in self.wavelengths_nm.iter().enumerate() {
            if (w - wavelength_nm).abs() < (self.wavelengths_nm[best] - wavelength_nm).abs() {
                best = k;
            }
        }
        best
    }

    /// Cell `(j, t)` of `angle_deg` on the angle grid (clamped), for interpolating several
    /// wavelengths at one angle: value = `v[j] (1 − t) + v[j + 1] t`. Needs ≥ 2 angles.
    pub fn locate_angle(&self, angle_deg: f64) -> (usize, f64) {
        match self.uniform_step {
            Some(step) => crate::table::interp::locate_uniform(
                self.angles_deg[0],
                step,
                self.angles_deg.len(),
                angle_deg,
            ),
            None => crate::table::interp::locate(&self.angles_deg, angle_deg),
        }
    }

    /// Phase function of wavelength index `k` at `angle_deg`, linear in angle (the table's
    /// lookup formula), clamped to [0, 180].
    pub fn phase_at(&self, k: usize, angle_deg: f64) -> f64 {
        // Fast path for uniform grids (the contract's preferred layout); same formula.
        if let Some(step) = self.uniform_step {
            return crate::table::interp::interp1_uniform(
                &self.phase[k],
                self.angles_deg[0],
                step,
                angle_deg,
            );
        }
        crate::table::interp::interp1(&self.angles_deg, &self.phase[k], angle_deg)
    }
}

/// Entry values `(axis name, value)` of `entry_axes` of `table`: the selected value, or the
/// axis' first sample when not selected; an unknown axis name is an error listing the entry
/// axes (`hint` is appended to the message). A selected value must lie within its axis, and on
/// an axis the table does not declare interpolable it must be a stored sample
/// ([`super::operators::resolve_axis_value`]).
pub fn resolve_entry_axes(
    table: &Table,
    entry_axes: &[usize],
    sel: &[EntrySelection],
    hint: &str,
) -> Result<Vec<(String, f64)>, ConsumerError> {
    let axes = table.axes();
    for s in sel {
        if !entry_axes.iter().any(|&i| axes[i].name == s.axis) {
            let listed: Vec<String> = entry_axes
                .iter()
                .map(|&i| {
                    let a = &axes[i];
                    format!(
                        "{} [{}, {}] {}",
                        a.name,
                        a.coord(0),
                        a.coord(a.len() - 1),
                        a.unit
                    )
                })
                .collect();
            return Err(ConsumerError::UnknownEntryAxis {
                axis: s.axis.clone(),
                entry_axes: if listed.is_empty() {
                    "none".into()
                } else {
                    listed.join(", ")
                },
                hint: hint.to_string(),
            });
        }
    }
    entry_axes
        .iter()
        .map(|&i| {
            let a = &axes[i];
            let v = match sel.iter().rev().find(|s| s.axis == a.name) {
                Some(s) => super::operators::resolve_axis_value(table, i, s.value)?,
                None => a.coord(0),
            };
            Ok((a.name.clone(), v))
        })
        .collect()
}

/// Human-readable description of a selected entry, e.g. `radius=500 um`.
pub fn describe_entry(table: &Table, entry: &[(String, f64)]) -> String {
    if entry.is_empty() {
        return "(single entry)".into();
    }
    entry
        .iter()
        .map(|(n, v)| {
            let unit = table
                .axis_index(n)
                .map(|i| table.axes()[i].unit.clone())
                .unwrap_or_default();
            format!("{n}={v} {unit}")
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Axis, Channel, Provenance, Schema, TableContent};

    /// A raytrace-phase table with phase = radius_um + wavelength_nm/1000 + angle/1e4 (and
    /// i_perp = 2 phase, i_par = 0), axes in version 1 or version 2 order.
    fn raytrace_table(version: u32) -> Table {
        let (radii, wl) = ([400.0, 800.0], [450.0, 650.0]);
        let angles = Axis::uniform("scattering_angle", "deg", 0.0, 90.0, 3);
        let value = |r: f64, w: f64, j: usize| r + w / 1000.0 + 90.0 * j as f64 / 1e4;
        let mut data = vec![];
        let mut push = |r: f64, w: f64| {
            for j in 0..3 {
                let p = value(r, w, j) as f32;
                data.extend([p, 2.0 * p, 0.0, 1.0]);
            }
        };
        let axes = if version == 1 {
            for &w in &wl {
                for &r in &radii {
                    push(r, w);
                }
            }
            vec![
                Axis::values("wavelength", "nm", wl.to_vec()),
                Axis::values("radius", "um", radii.to_vec()),
                angles,
            ]
        } else {
            for &r in &radii {
                for &w in &wl {
                    push(r, w);
                }
            }
            vec![
                Axis::values("radius", "um", radii.to_vec()),
                Axis::values("wavelength", "nm", wl.to_vec()),
                angles,
            ]
        };
        let content = TableContent {
            encoding: Default::default(),
            schema: Schema::new("raytrace-phase", version),
            description: "test".into(),
            axes,
            channels: ["phase", "i_perp", "i_par", "dolp"]
                .iter()
                .map(|n| Channel::new(n, "1", "test"))
                .collect(),
            attributes: Default::default(),
            data,
        };
        Table::from_content(content, Provenance::default()).unwrap()
    }

    /// NaN or inf in a contract channel: every phase consumer refuses the table with the
    /// channel named (not a panic, not a NaN picture); the dolp channel may hold anything.
    #[test]
    fn non_finite_phase_values_are_refused_naming_the_channel() {
        assert!(PhaseTable::new(raytrace_table(2)).is_ok());
        for (k, bad) in [
            (0usize, f32::NAN),
            (1, f32::INFINITY),
            (2, f32::NEG_INFINITY),
        ] {
            let mut t = raytrace_table(2);
            t.data[4 * 5 + k] = bad;
            let e = PhaseTable::new(t).err().expect("refused").to_string();
            let name = ["phase", "i_perp", "i_par"][k];
            assert!(
                e.contains(&format!("channel `{name}`")) && e.contains("1 NaN or infinite"),
                "{e}"
            );
        }
        let mut t = raytrace_table(2);
        t.data[3] = f32::NAN; // dolp
        assert!(PhaseTable::new(t).is_ok());
    }

    #[test]
    fn both_raytrace_versions_read_alike_and_others_are_refused() {
        let sel: Vec<EntrySelection> = vec!["radius=800".parse().unwrap()];
        let v1 = PhaseTable::new(raytrace_table(1))
            .unwrap()
            .curves(&sel)
            .unwrap();
        let v2 = PhaseTable::new(raytrace_table(2))
            .unwrap()
            .curves(&sel)
            .unwrap();
        assert_eq!(v1.wavelengths_nm, vec![450.0, 650.0]);
        assert_eq!(v1.phase, v2.phase);
        assert_eq!(v1.i_perp, v2.i_perp);
        assert_eq!(v2.phase[1][2], (800.0 + 0.65 + 0.018) as f32 as f64);
        let e = PhaseTable::new(raytrace_table(3))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("raytrace-phase/3"), "{e}");
    }

    use crate::fixtures::henyey_greenstein_table;

    #[test]
    fn unknown_entry_axis_lists_the_entry_axes_with_their_ranges() {
        let pt = PhaseTable::new(henyey_greenstein_table(
            &[550.0],
            &[100.0, 500.0],
            |_, _| 0.5,
            181,
            0.0,
        ))
        .unwrap();
        let e = pt
            .resolve_entry(&["diameter=3".parse().unwrap()])
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "`diameter` is not an entry axis of this table (entry axes: radius [100, 500] um)"
        );
    }

    #[test]
    fn layout_errors_of_a_file_name_the_file() {
        use crate::fixtures::{lat_long_from_1d, peak_table};
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("latlong.sbt");
        let one_d = peak_table(&[550.0], |_| 138.0, 0.3, 1e-3, 181);
        let mut t = lat_long_from_1d(&one_d, &[0.0], 90.0, |_, _| 1.0);
        crate::table::write_table_atomic(&mut t, &path).unwrap();
        let e = PhaseTable::open(&path)
            .err()
            .expect("a 2-D table is not a 1-D phase table");
        let chain = crate::error::error_chain(&e);
        assert!(
            chain.starts_with(&format!("{}: ", path.display())),
            "{chain}"
        );
        assert!(chain.contains("2-D tables"), "{chain}");
    }
}
