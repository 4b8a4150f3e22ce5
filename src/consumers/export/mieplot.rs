//! MiePlot-style text tables: `angle_deg  i_perp  i_par  phase`, one row per scattering
//! angle, and the `validate` comparison that reads such a file back against a table. The
//! columns have the meaning they have in every table and command (`docs/vocabulary.md`):
//! `i_perp`, `i_par` are the normalised perpendicular and parallel components (1/sr, for a
//! sphere |S1|², |S2|² over π x² Q_sca) and `phase = (i_perp + i_par)/2` (∫_{4π} phase dΩ = 1),
//! the columns `scatterbake mie --format table` prints.
//!
//! Written format (what [`write_mieplot`] produces and [`read_mieplot`] reads):
//! ```text
//! # scatterbake mieplot export
//! # table: tables/rainbow-mie.sbt
//! # entry: radius=500 um
//! # wavelength_nm: 650
//! # units: angle in deg (0 = forward); i_perp, i_par, phase in 1/sr, phase = (i_perp + i_par)/2, integral over 4pi of phase = 1
//! # angle_deg<TAB>i_perp<TAB>i_par<TAB>phase
//! 0<TAB>1.2e3<TAB>1.2e3<TAB>1.2e3
//! ```
//! Numbers are written as the shortest decimal that round-trips the f64 value, so reading the
//! file back reproduces the table's values exactly.
//!
//! The reader also accepts files saved by MiePlot itself (or any similar tool): lines that do
//! not start with a number are skipped (headers, titles), fields may be separated by tabs,
//! spaces, commas or semicolons, and rows need 3 columns (angle, perpendicular, parallel; the
//! phase is then their mean) or 4+ (the 4th is the phase, i.e. the unpolarised value). MiePlot's
//! intensities are raw |S1|², |S2|², not normalised like ours: `validate --rescale` fits one
//! scale factor (least squares on the phase column) before comparing.

use crate::consumers::ConsumerError;
use crate::consumers::read::phase::{EntrySelection, PhaseTable};
use crate::error::IoError;
use std::fmt::Write as _;
use std::path::Path;

/// A MiePlot-style table in memory.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MiePlotData {
    /// From a `# wavelength_nm:` comment, when present.
    pub wavelength_nm: Option<f64>,
    pub angle_deg: Vec<f64>,
    pub i_perp: Vec<f64>,
    pub i_par: Vec<f64>,
    /// (i_perp + i_par)/2, the unpolarised phase function.
    pub phase: Vec<f64>,
}

/// Format a MiePlot-style table (comment lines first, then rows).
pub fn write_mieplot(d: &MiePlotData, comments: &[String]) -> String {
    let mut s = String::new();
    s.push_str("# scatterbake mieplot export\n");
    for c in comments {
        let _ = writeln!(s, "# {c}");
    }
    if let Some(w) = d.wavelength_nm {
        let _ = writeln!(s, "# wavelength_nm: {w}");
    }
    s.push_str("# units: angle in deg (0 = forward); i_perp, i_par, phase in 1/sr, phase = (i_perp + i_par)/2, integral over 4pi of phase = 1\n");
    s.push_str("# angle_deg\ti_perp\ti_par\tphase\n");
    for j in 0..d.angle_deg.len() {
        let _ = writeln!(
            s,
            "{:e}\t{:e}\t{:e}\t{:e}",
            d.angle_deg[j], d.i_perp[j], d.i_par[j], d.phase[j]
        );
    }
    s
}

/// Parse a MiePlot-style table (see the module doc for what is accepted).
pub fn read_mieplot(text: &str) -> Result<MiePlotData, ConsumerError> {
    let mut d = MiePlotData::default();
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix('#') {
            if let Some(v) = rest.trim().strip_prefix("wavelength_nm:") {
                d.wavelength_nm = Some(v.trim().parse().map_err(|e| ConsumerError::Parse {
                    line: ln + 1,
                    message: "wavelength is not a number",
                    source: Some(e),
                })?);
            }
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ',' || c == ';')
            .filter(|f| !f.is_empty())
            .collect();
        let Some(first) = fields.first() else {
            continue;
        };
        if first.parse::<f64>().is_err() {
            continue; // header or title line
        }
        let nums: Vec<f64> = fields
            .iter()
            .map(|f| f.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| ConsumerError::Parse {
                line: ln + 1,
                message: "not all fields are numbers",
                source: Some(e),
            })?;
        if nums.len() < 3 {
            return Err(ConsumerError::Parse {
                line: ln + 1,
                message: "need at least angle, i_perp, i_par",
                source: None,
            });
        }
        d.angle_deg.push(nums[0]);
        d.i_perp.push(nums[1]);
        d.i_par.push(nums[2]);
        d.phase.push(if nums.len() >= 4 {
            nums[3]
        } else {
            0.5 * (nums[1] + nums[2])
        });
    }
    if d.angle_deg.is_empty() {
        return Err(ConsumerError::invalid("no data rows found"));
    }
    Ok(d)
}

/// MiePlot-style data of one entry and wavelength of a phase table, on the table's angles.
pub fn from_table(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    wavelength_nm: f64,
) -> Result<MiePlotData, ConsumerError> {
    let e = pt.resolve_entry(entry)?;
    let angles = pt.angles_deg();
    let mut d = MiePlotData {
        wavelength_nm: Some(wavelength_nm),
        ..Default::default()
    };
    for &a in &angles {
        let [p, s, q] = pt.sample_at(wavelength_nm, &e, a)?;
        d.angle_deg.push(a);
        d.i_perp.push(s);
        d.i_par.push(q);
        d.phase.push(p);
    }
    Ok(d)
}

/// Result of comparing a reference file against a table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValidationReport {
    pub rows: usize,
    /// Scale applied to the reference (1 unless rescaled).
    pub scale: f64,
    /// max |table − ref| / |ref| per column (i_perp, i_par, phase).
    pub max_rel_error: [f64; 3],
    /// Angle (deg) of the largest phase relative error.
    pub worst_angle_deg: f64,
    /// RMS relative error per column (i_perp, i_par, phase).
    pub rms_rel_error: [f64; 3],
    /// Pearson correlation of the phase curves (table vs reference).
    pub correlation: f64,
    /// Primary-bow maximum of the phase curve (deg): (table, reference). The primary is
    /// searched in (132°, 160°], the secondary in [115°, 132°] (132° ≈ middle of Alexander's
    /// band for water); `None` when the reference has no angles there.
    pub primary_max_deg: Option<(f64, f64)>,
    /// Secondary-bow maximum (deg): (table, reference).
    pub secondary_max_deg: Option<(f64, f64)>,
}

/// Angle of the largest value of `v` among angles in `[lo, hi]` (`lo_open` excludes `lo`).
fn argmax_in(angles: &[f64], v: &[f64], lo: f64, hi: f64, lo_open: bool) -> Option<f64> {
    angles
        .iter()
        .zip(v)
        .filter(|(a, _)| (if lo_open { **a > lo } else { **a >= lo }) && **a <= hi)
        .max_by(|x, y| x.1.total_cmp(y.1))
        .map(|(a, _)| *a)
}

/// Compare reference data against a table at the reference's angles and wavelength.
pub fn compare(
    pt: &PhaseTable,
    entry: &[EntrySelection],
    wavelength_nm: f64,
    r: &MiePlotData,
    rescale: bool,
) -> Result<ValidationReport, ConsumerError> {
    let e = pt.resolve_entry(entry)?;
    let vals: Vec<[f64; 3]> = r
        .angle_deg
        .iter()
        .map(|&a| pt.sample_at(wavelength_nm, &e, a))
        .collect::<Result<_, _>>()?;
    let scale = if rescale {
        let num: f64 = vals.iter().zip(&r.phase).map(|(v, u)| v[0] * u).sum();
        let den: f64 = r.phase.iter().map(|u| u * u).sum();
        if !(den > 0.0) {
            return Err(ConsumerError::invalid(
                "cannot rescale: the reference is all zero",
            ));
        }
        num / den
    } else {
        1.0
    };
    let mut max = [0.0f64; 3];
    let mut worst = r.angle_deg[0];
    for (j, v) in vals.iter().enumerate() {
        let refs = [r.i_perp[j], r.i_par[j], r.phase[j]];
        let tab = [v[1], v[2], v[0]];
        for c in 0..3 {
            let rf = refs[c] * scale;
            let err = if rf == tab[c] {
                0.0
            } else {
                (tab[c] - rf).abs() / rf.abs().max(f64::MIN_POSITIVE)
            };
            if err > max[c] {
                max[c] = err;
                if c == 2 {
                    worst = r.angle_deg[j];
                }
            }
        }
    }
    let mut sq = [0.0f64; 3];
    for (j, v) in vals.iter().enumerate() {
        let refs = [r.i_perp[j], r.i_par[j], r.phase[j]];
        let tab = [v[1], v[2], v[0]];
        for c in 0..3 {
            let rf = refs[c] * scale;
            if rf != tab[c] {
                sq[c] += ((tab[c] - rf) / rf.abs().max(f64::MIN_POSITIVE)).powi(2);
            }
        }
    }
    let nrows = vals.len().max(1) as f64;
    let rms = sq.map(|s| (s / nrows).sqrt());
    let tab_u: Vec<f64> = vals.iter().map(|v| v[0]).collect();
    let ref_u: Vec<f64> = r.phase.iter().map(|u| u * scale).collect();
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
    let (mt, mr) = (mean(&tab_u), mean(&ref_u));
    let cov: f64 = tab_u
        .iter()
        .zip(&ref_u)
        .map(|(a, b)| (a - mt) * (b - mr))
        .sum();
    let vt: f64 = tab_u.iter().map(|a| (a - mt).powi(2)).sum();
    let vr: f64 = ref_u.iter().map(|b| (b - mr).powi(2)).sum();
    let correlation = if vt > 0.0 && vr > 0.0 {
        cov / (vt * vr).sqrt()
    } else {
        f64::NAN
    };
    let both = |lo: f64, hi: f64, open: bool| {
        Some((
            argmax_in(&r.angle_deg, &tab_u, lo, hi, open)?,
            argmax_in(&r.angle_deg, &ref_u, lo, hi, open)?,
        ))
    };
    Ok(ValidationReport {
        rows: r.angle_deg.len(),
        scale,
        max_rel_error: max,
        worst_angle_deg: worst,
        rms_rel_error: rms,
        correlation,
        primary_max_deg: both(132.0, 160.0, true),
        secondary_max_deg: both(115.0, 132.0, false),
    })
}

/// Read a MiePlot-style file from disk.
pub fn read_mieplot_file(path: &Path) -> Result<MiePlotData, ConsumerError> {
    let text = std::fs::read_to_string(path).map_err(IoError::doing("reading", path))?;
    read_mieplot(&text).map_err(|e| e.in_file(path))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::consumers::synthetic::henyey_greenstein_table;

    fn table() -> PhaseTable {
        let t = henyey_greenstein_table(
            &[450.0, 650.0],
            &[100.0, 500.0],
            |k, r| 0.5 + 0.1 * k as f64 + 0.05 * r as f64,
            721,
            0.4,
        );
        PhaseTable::new(t).unwrap()
    }

    #[test]
    fn round_trip_is_exact() {
        let pt = table();
        let sel = vec!["radius=500".parse().unwrap()];
        let d = from_table(&pt, &sel, 650.0).unwrap();
        let back = read_mieplot(&write_mieplot(&d, &["table: x".into()])).unwrap();
        assert_eq!(back, d);
        let rep = compare(&pt, &sel, 650.0, &back, false).unwrap();
        assert_eq!(rep.max_rel_error, [0.0; 3]);
        // The other entry differs, so the comparison can fail.
        let other = compare(&pt, &[], 650.0, &back, false).unwrap();
        assert!(other.max_rel_error[2] > 0.05, "{other:?}");
    }

    #[test]
    fn reader_accepts_foreign_layouts_and_rescale_recovers_units() {
        let pt = table();
        let d = from_table(&pt, &[], 450.0).unwrap();
        // MiePlot-like: title lines, comma separated, 3 columns, arbitrary units (×1000).
        let mut s = String::from("MiePlot v4.6\nAngle, Perpendicular, Parallel\n");
        for j in 0..d.angle_deg.len() {
            s.push_str(&format!(
                "{}, {}, {}\n",
                d.angle_deg[j],
                1000.0 * d.i_perp[j],
                1000.0 * d.i_par[j]
            ));
        }
        let r = read_mieplot(&s).unwrap();
        assert_eq!(r.angle_deg.len(), 721);
        let raw = compare(&pt, &[], 450.0, &r, false).unwrap();
        assert!(raw.max_rel_error[2] > 0.99);
        let fit = compare(&pt, &[], 450.0, &r, true).unwrap();
        assert!((fit.scale - 1e-3).abs() < 1e-10, "{fit:?}");
        // Unpolarised = mean of the f32-rounded i_perp, i_par: agreement to f32 precision.
        assert!(fit.max_rel_error.iter().all(|e| *e < 1e-6), "{fit:?}");
    }
}
