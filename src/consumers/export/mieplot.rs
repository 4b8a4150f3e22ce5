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

/// What [`read_mieplot_layout`] recognised in a file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MiePlotLayout {
    /// Text lines before and between the data rows (titles, parameters, column headers).
    pub header: Vec<String>,
    /// Column roles of the data rows, from a header line naming them (e.g. `Angle`,
    /// `Intensity (perpendicular)`, `Intensity (parallel)`, `Unpolarised`) or by position.
    pub columns: Vec<ColumnRole>,
    /// Whether the columns were named by a header line (otherwise: by position).
    pub named: bool,
    /// Whether numbers used a decimal comma (fields separated by tabs or semicolons).
    pub decimal_comma: bool,
}

/// The meaning of a column of a MiePlot-style file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnRole {
    /// Scattering angle (deg).
    Angle,
    /// Perpendicular component (|S1|² in MiePlot, `i_perp` in ours).
    Perpendicular,
    /// Parallel component (|S2|² in MiePlot, `i_par` in ours).
    Parallel,
    /// Unpolarised (the mean of the two).
    Unpolarised,
    /// Anything else (ignored).
    Other,
}

impl ColumnRole {
    /// Role of a column from its header text (case-insensitive).
    fn from_label(label: &str) -> ColumnRole {
        let l = label.to_lowercase();
        let has = |w: &[&str]| w.iter().any(|k| l.contains(k));
        if l.contains("s11") {
            ColumnRole::Unpolarised
        } else if has(&["perp", "s1", "i1", "ortho"]) {
            ColumnRole::Perpendicular
        } else if has(&["paral", "_par", "s2", "i2"]) {
            ColumnRole::Parallel
        } else if has(&[
            "unpol", "natural", "phase", "s11", "average", "mean", "total",
        ]) {
            ColumnRole::Unpolarised
        } else if has(&["angle", "theta", "deg"]) {
            ColumnRole::Angle
        } else {
            ColumnRole::Other
        }
    }
}

/// Fields of a line: split at tabs or semicolons when the line has any (then a comma inside a
/// field is a decimal comma), else at commas, else at white space; quotes are removed.
fn split_fields(line: &str) -> (Vec<String>, bool) {
    let clean = |f: &str| f.trim().trim_matches('"').trim().to_string();
    let fields: Vec<String>;
    let mut comma_decimal = false;
    if line.contains('\t') || line.contains(';') {
        fields = line.split(['\t', ';']).map(clean).collect();
        comma_decimal = fields.iter().any(|f| {
            f.contains(',') && !f.contains('.') && f.replace(',', ".").parse::<f64>().is_ok()
        });
    } else if line.contains(',') {
        fields = line.split(',').map(clean).collect();
    } else {
        fields = line.split_whitespace().map(clean).collect();
    }
    (
        fields.into_iter().filter(|f| !f.is_empty()).collect(),
        comma_decimal,
    )
}

/// Parse a MiePlot-style table (see the module doc for what is accepted).
pub fn read_mieplot(text: &str) -> Result<MiePlotData, ConsumerError> {
    read_mieplot_layout(text).map(|(d, _)| d)
}

/// The numbers of a data row (line `line`, 1-based): every field a number, at least three
/// (angle, i_perp, i_par).
fn row_numbers(
    fields: &[String],
    number: impl Fn(&str) -> Result<f64, std::num::ParseFloatError>,
    line: usize,
) -> Result<Vec<f64>, ConsumerError> {
    let nums: Vec<f64> = fields
        .iter()
        .map(|f| number(f))
        .collect::<Result<_, _>>()
        .map_err(|e| ConsumerError::Parse {
            line,
            message: "not all fields are numbers",
            source: Some(e),
        })?;
    if nums.len() < 3 {
        return Err(ConsumerError::Parse {
            line,
            message: "need at least angle, i_perp, i_par",
            source: None,
        });
    }
    Ok(nums)
}

/// The role of each of `n` columns: from the header `labels` when they name one column each,
/// including both polarisations (an unnamed first column is the angle), else by position
/// (angle, perpendicular, parallel, unpolarised, others). The flag says whether the labels were
/// used.
fn column_roles(labels: &[String], n: usize) -> (Vec<ColumnRole>, bool) {
    let named: Vec<ColumnRole> = labels.iter().map(|l| ColumnRole::from_label(l)).collect();
    let has = |r| named.contains(&r);
    if named.len() == n && has(ColumnRole::Perpendicular) && has(ColumnRole::Parallel) {
        let angle = has(ColumnRole::Angle);
        let mut named = named;
        if !angle {
            named[0] = ColumnRole::Angle;
        }
        (named, true)
    } else {
        let mut r = vec![
            ColumnRole::Angle,
            ColumnRole::Perpendicular,
            ColumnRole::Parallel,
        ];
        if n >= 4 {
            r.push(ColumnRole::Unpolarised);
        }
        r.resize(n, ColumnRole::Other);
        (r, false)
    }
}

/// Parse a MiePlot-style table and report what was recognised.
///
/// Accepted: our own export (`#` comments, a `# wavelength_nm:` line, `angle i_perp i_par phase`),
/// and text saved by MiePlot or similar programs: any lines whose first field is not a number
/// (titles, parameters, column headers) are kept as header text; fields are separated by tabs,
/// semicolons, commas or white space (with tabs or semicolons a comma may be the decimal
/// separator); quotes around fields are removed. Columns are identified by the last header line
/// before the data with as many fields as a data row whose labels name an angle and both
/// polarisations (`Angle`, `Intensity (perpendicular)`, `Intensity (parallel)`, `Unpolarised`,
/// `S1`, `S2`, `i_perp`, `i_par`, `phase`, … in any order); without such a line, by position:
/// angle, perpendicular, parallel and optionally the unpolarised value (else the mean of the
/// two).
pub fn read_mieplot_layout(text: &str) -> Result<(MiePlotData, MiePlotLayout), ConsumerError> {
    let mut d = MiePlotData::default();
    let mut layout = MiePlotLayout::default();
    let mut labels: Vec<String> = Vec::new();
    let mut roles: Option<Vec<ColumnRole>> = None;
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        if let Some(rest) = line.strip_prefix('#') {
            if let Some(v) = rest.trim().strip_prefix("wavelength_nm:") {
                d.wavelength_nm = Some(v.trim().parse().map_err(|e| ConsumerError::Parse {
                    line: ln + 1,
                    message: "wavelength is not a number",
                    source: Some(e),
                })?);
            }
            layout.header.push(line.to_string());
            let (f, _) = split_fields(rest.trim());
            if f.len() >= 3 {
                labels = f;
            }
            continue;
        }
        let (fields, comma) = split_fields(line);
        let number = |f: &str| {
            if comma {
                f.replace(',', ".").parse::<f64>()
            } else {
                f.parse::<f64>()
            }
        };
        let Some(first) = fields.first() else {
            continue;
        };
        if number(first).is_err() {
            layout.header.push(line.to_string());
            if fields.len() >= 3 {
                labels = fields;
            }
            continue;
        }
        layout.decimal_comma |= comma;
        let nums = row_numbers(&fields, number, ln + 1)?;
        let roles = roles.get_or_insert_with(|| {
            let (r, named) = column_roles(&labels, nums.len());
            layout.named = named;
            r
        });
        if nums.len() < roles.len() {
            return Err(ConsumerError::Parse {
                line: ln + 1,
                message: "row has fewer fields than the columns of the first row",
                source: None,
            });
        }
        let get = |role: ColumnRole| {
            roles
                .iter()
                .position(|r| *r == role)
                .and_then(|i| nums.get(i).copied())
        };
        let (Some(a), Some(p), Some(q)) = (
            get(ColumnRole::Angle),
            get(ColumnRole::Perpendicular),
            get(ColumnRole::Parallel),
        ) else {
            return Err(ConsumerError::Parse {
                line: ln + 1,
                message: "row is shorter than the header's columns",
                source: None,
            });
        };
        d.angle_deg.push(a);
        d.i_perp.push(p);
        d.i_par.push(q);
        d.phase
            .push(get(ColumnRole::Unpolarised).unwrap_or(0.5 * (p + q)));
    }
    if d.angle_deg.is_empty() {
        return Err(ConsumerError::invalid("no data rows found"));
    }
    layout.columns = roles.unwrap_or_default();
    Ok((d, layout))
}

/// Comparison of reference columns with model values at the reference's angles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveComparison {
    pub rows: usize,
    /// Scale applied to the reference (1 unless rescaled).
    pub scale: f64,
    /// max |model − ref| / |ref| per column (perpendicular, parallel, unpolarised).
    pub max_rel_difference: [f64; 3],
    /// Angle (deg) of the largest difference over the three columns.
    pub worst_angle_deg: f64,
    /// RMS relative difference per column.
    pub rms_rel_difference: [f64; 3],
}

/// Compares `reference` with model values `[perpendicular, parallel, unpolarised]` at its
/// angles (pure). With `rescale`, one least-squares factor on the unpolarised column is applied
/// to the reference first (for references in other units).
pub fn compare_curves(
    reference: &MiePlotData,
    model: [&[f64]; 3],
    rescale: bool,
) -> Result<CurveComparison, ConsumerError> {
    let n = reference.angle_deg.len();
    if model.iter().any(|c| c.len() != n) || n == 0 {
        return Err(ConsumerError::invalid(format!(
            "model has {}/{}/{} values for {n} reference angles",
            model[0].len(),
            model[1].len(),
            model[2].len()
        )));
    }
    let refs = [&reference.i_perp, &reference.i_par, &reference.phase];
    let scale = if rescale {
        let num: f64 = model[2].iter().zip(refs[2]).map(|(v, u)| v * u).sum();
        let den: f64 = refs[2].iter().map(|u| u * u).sum();
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
    let mut sq = [0.0f64; 3];
    let mut worst = (0.0, reference.angle_deg[0]);
    for j in 0..n {
        for c in 0..3 {
            let rf = refs[c][j] * scale;
            let e = if rf == model[c][j] {
                0.0
            } else {
                (model[c][j] - rf).abs() / rf.abs().max(f64::MIN_POSITIVE)
            };
            max[c] = max[c].max(e);
            sq[c] += e * e;
            if e > worst.0 {
                worst = (e, reference.angle_deg[j]);
            }
        }
    }
    Ok(CurveComparison {
        rows: n,
        scale,
        max_rel_difference: max,
        worst_angle_deg: worst.1,
        rms_rel_difference: sq.map(|s| (s / n as f64).sqrt()),
    })
}

/// Largest relative difference in |S1|², |S2|² to expect from a double-precision BHMIE
/// (Bohren & Huffman 1983, Appendix A; the algorithm behind MiePlot) at size parameter `x`:
/// `3·10⁻⁹ · max(1, x/10)^{1.5}`. Measured envelope: a transcription of BHMIE against 40-digit
/// references for 15 indices × x = 1 … 10⁴ (`docs/mie.md`) stays below it except near `m = 1`
/// (`|m − 1| ≤ 10⁻³`, where |S|² is ill-conditioned) and for real `m > 1` at x ≥ 10 with
/// BHMIE's original start order of the `D_n` recurrence (`max(x_stop, |mx|) + 15`, too small
/// there: up to O(1), Du 2004).
pub fn bhmie_drift_envelope(x: f64) -> f64 {
    3e-9 * (x / 10.0).max(1.0).powf(1.5)
}

/// A "large absorbing" sphere for [`bhmie_drift_envelope`]: `Im(m) x ≥ 10` and `x ≥ 10`, where
/// the measured BHMIE differences reach 1e-9 … 1.5e-6 (x = 10 … 10⁴).
pub fn is_large_absorbing(x: f64, m_im: f64) -> bool {
    x >= 10.0 && m_im * x >= 10.0
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
    /// Least-squares scale of the reference onto the table (phase column), whether applied or
    /// not: far from 1, the two are in different units or normalisations.
    pub fitted_scale: f64,
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
    let num: f64 = vals.iter().zip(&r.phase).map(|(v, u)| v[0] * u).sum();
    let den: f64 = r.phase.iter().map(|u| u * u).sum();
    let fitted_scale = num / den;
    let scale = if rescale {
        if !(den > 0.0) {
            return Err(ConsumerError::invalid(
                "cannot rescale: the reference is all zero",
            ));
        }
        fitted_scale
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
        fitted_scale,
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
    use crate::fixtures::henyey_greenstein_table;

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

    /// Columns named by a header line are used in any order; tabs or semicolons with decimal
    /// commas and quoted labels are read; without names, columns go by position.
    #[test]
    fn named_columns_decimal_commas_and_positions() {
        let text = "Title line, with commas, and more\n\"Angle\";\"Parallel\";\"Unpolarised\";\"Perpendicular\"\n0;2,5;3,0;3,5\n90;1,0;1,5;2,0\n";
        let (d, layout) = read_mieplot_layout(text).unwrap();
        assert!(layout.named && layout.decimal_comma, "{layout:?}");
        assert_eq!(
            layout.columns,
            vec![
                ColumnRole::Angle,
                ColumnRole::Parallel,
                ColumnRole::Unpolarised,
                ColumnRole::Perpendicular
            ]
        );
        assert_eq!(d.angle_deg, vec![0.0, 90.0]);
        assert_eq!(d.i_perp, vec![3.5, 2.0]);
        assert_eq!(d.i_par, vec![2.5, 1.0]);
        assert_eq!(d.phase, vec![3.0, 1.5]);
        assert_eq!(layout.header.len(), 2);
        // Positional: angle, perpendicular, parallel (phase = mean).
        let (d, layout) = read_mieplot_layout("1 4 2\n2 6 4\n").unwrap();
        assert!(!layout.named);
        assert_eq!((d.i_perp[1], d.i_par[1], d.phase[1]), (6.0, 4.0, 5.0));
        // A short row under a 4-column header is an error naming the line.
        let err = read_mieplot("Angle\tS1\tS2\tS11\n0\t1\t2\t1.5\n1\t1\t2\n").unwrap_err();
        assert!(err.to_string().contains('3'), "{err}");
    }

    #[test]
    fn curve_comparison_and_drift_envelope() {
        let r = MiePlotData {
            wavelength_nm: None,
            angle_deg: vec![0.0, 90.0],
            i_perp: vec![2.0, 4.0],
            i_par: vec![2.0, 2.0],
            phase: vec![2.0, 3.0],
        };
        let c = compare_curves(&r, [&[2.0, 4.4], &[2.0, 2.0], &[2.0, 3.0]], false).unwrap();
        assert!((c.max_rel_difference[0] - 0.1).abs() < 1e-12);
        assert_eq!(c.max_rel_difference[1], 0.0);
        assert_eq!(c.worst_angle_deg, 90.0);
        let doubled = compare_curves(&r, [&[4.0, 8.0], &[4.0, 4.0], &[4.0, 6.0]], true).unwrap();
        assert!((doubled.scale - 2.0).abs() < 1e-12 && doubled.max_rel_difference[2] < 1e-12);
        assert!(compare_curves(&r, [&[1.0], &[1.0], &[1.0]], false).is_err());
        assert_eq!(bhmie_drift_envelope(1.0), 3e-9);
        assert!((bhmie_drift_envelope(1000.0) - 3e-6).abs() < 1e-15);
        assert!(is_large_absorbing(10.0, 3.68) && !is_large_absorbing(1000.0, 0.0));
    }
}
