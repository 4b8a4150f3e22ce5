//! The printed curves of `mie` (with or without `--debye-orders`) and `airy`: the columns of
//! every phase-function table (`docs/vocabulary.md`) as a MiePlot-style table, CSV or JSON.

use anyhow::Context;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Output format of `mie` and `airy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CurveFormat {
    /// Aligned columns with a `#` header block (MiePlot style).
    Table,
    /// Comma-separated values with a header row.
    Csv,
    /// One JSON object.
    Json,
}

/// Header of the CSV output of `mie`, `mie --debye-orders` and `airy` (extra columns follow).
pub const CURVE_CSV_COLUMNS: &str = "angle_deg,s1_sq,s2_sq,s11,i_perp,i_par,phase,dolp";

/// One printed row: angle (deg), raw |S1|², |S2|², s11 = (|S1|² + |S2|²)/2 (dimensionless), the
/// normalised i_perp, i_par, phase (1/sr, divided by `norm` = π x² Q_sca) and dolp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveRow {
    pub angle_deg: f64,
    pub s1_sq: f64,
    pub s2_sq: f64,
    pub s11: f64,
    pub i_perp: f64,
    pub i_par: f64,
    pub phase: f64,
    pub dolp: f64,
}

impl CurveRow {
    /// Row from the raw intensities and the normalisation π x² Q_sca.
    pub fn new(angle_deg: f64, s1_sq: f64, s2_sq: f64, norm: f64) -> Self {
        let s11 = 0.5 * (s1_sq + s2_sq);
        CurveRow {
            angle_deg,
            s1_sq,
            s2_sq,
            s11,
            i_perp: s1_sq / norm,
            i_par: s2_sq / norm,
            phase: s11 / norm,
            dolp: if s11 > 0.0 {
                (s1_sq - s2_sq) / (s1_sq + s2_sq)
            } else {
                0.0
            },
        }
    }

    /// The CSV fields of [`CURVE_CSV_COLUMNS`].
    pub fn csv(&self) -> String {
        format!(
            "{},{:e},{:e},{:e},{:e},{:e},{:e},{}",
            self.angle_deg,
            self.s1_sq,
            self.s2_sq,
            self.s11,
            self.i_perp,
            self.i_par,
            self.phase,
            self.dolp
        )
    }

    /// The MiePlot-style table line (angle, i_perp, i_par, phase), as `export --format mieplot`.
    pub fn table(&self) -> String {
        format!(
            "{:>12.4} {:>20.10e} {:>20.10e} {:>20.10e}",
            self.angle_deg, self.i_perp, self.i_par, self.phase
        )
    }
}

/// Column header of the MiePlot-style table (after the `#` comment lines).
pub const CURVE_TABLE_COLUMNS: &str =
    "#  angle_deg               i_perp                i_par                phase";

/// JSON arrays of the rows: `angle_deg`, `s1_sq`, `s2_sq`, `s11`, `i_perp`, `i_par`, `phase`,
/// `dolp`.
pub fn curve_json(rows: &[CurveRow]) -> serde_json::Map<String, serde_json::Value> {
    let col = |f: fn(&CurveRow) -> f64| serde_json::json!(rows.iter().map(f).collect::<Vec<_>>());
    let mut o = serde_json::Map::new();
    o.insert("angle_deg".into(), col(|r| r.angle_deg));
    o.insert("s1_sq".into(), col(|r| r.s1_sq));
    o.insert("s2_sq".into(), col(|r| r.s2_sq));
    o.insert("s11".into(), col(|r| r.s11));
    o.insert("i_perp".into(), col(|r| r.i_perp));
    o.insert("i_par".into(), col(|r| r.i_par));
    o.insert("phase".into(), col(|r| r.phase));
    o.insert("dolp".into(), col(|r| r.dolp));
    o
}

/// The header line stating both backscattering efficiencies with their conventions.
pub fn q_back_line(q_back: f64) -> String {
    format!(
        "Q_back = {:.10} (radar convention: 4 pi (dC_sca/dOmega at 180 deg)/(pi r^2) = 4 |S1(180)|^2/x^2)  Q_back_per_sr = {:.10e} (MiePlot, per steradian: Q_back/(4 pi) = |S1(180)|^2/(pi x^2))",
        q_back,
        q_back / (4.0 * std::f64::consts::PI)
    )
}

/// Printed rows of a query.
#[derive(Debug, Clone)]
pub struct CurveReport {
    /// Header lines (without the leading `# `).
    pub header: Vec<String>,
    pub angles_deg: Vec<f64>,
    /// |S1|² (dimensionless).
    pub s1_sq: Vec<f64>,
    /// |S2|² (dimensionless).
    pub s2_sq: Vec<f64>,
    /// `π x² Q_sca` dividing |S1|², |S2|², s11 into i_perp, i_par, phase.
    pub normalisation: f64,
    /// Extra `(name, phase values)` columns.
    pub extra: Vec<(String, Vec<f64>)>,
}

impl CurveReport {
    /// The printed rows.
    pub fn rows(&self) -> Vec<CurveRow> {
        (0..self.angles_deg.len())
            .map(|i| {
                CurveRow::new(
                    self.angles_deg[i],
                    self.s1_sq[i],
                    self.s2_sq[i],
                    self.normalisation,
                )
            })
            .collect()
    }

    /// CSV: the header lines as `#` comments, then a header row (the `mie` columns, then the
    /// extra columns) and the rows.
    pub fn to_csv(&self) -> String {
        let mut s = String::new();
        for h in &self.header {
            let _ = writeln!(s, "# {h}");
        }
        s.push_str(CURVE_CSV_COLUMNS);
        for (name, _) in &self.extra {
            s.push(',');
            s.push_str(name);
        }
        s.push('\n');
        for (i, r) in self.rows().iter().enumerate() {
            s.push_str(&r.csv());
            for (_, v) in &self.extra {
                let _ = write!(s, ",{:e}", v[i]);
            }
            s.push('\n');
        }
        s
    }

    /// Aligned columns with a `#` header block.
    pub fn to_table(&self) -> String {
        let mut s = String::new();
        for h in &self.header {
            let _ = writeln!(s, "# {h}");
        }
        s.push_str(CURVE_TABLE_COLUMNS);
        for (name, _) in &self.extra {
            let _ = write!(s, " {name:>20}");
        }
        s.push('\n');
        for (i, r) in self.rows().iter().enumerate() {
            s.push_str(&r.table());
            for (_, v) in &self.extra {
                let _ = write!(s, " {:>20.10e}", v[i]);
            }
            s.push('\n');
        }
        s
    }

    /// One JSON object with the `mie` keys plus the extra columns.
    pub fn to_json(&self) -> serde_json::Value {
        let mut o = serde_json::Map::new();
        o.insert("header".into(), serde_json::json!(self.header));
        o.extend(curve_json(&self.rows()));
        let mut o = serde_json::Value::Object(o);
        for (name, v) in &self.extra {
            o[name.as_str()] = serde_json::to_value(v).expect("finite values");
        }
        o
    }

    pub fn print(&self, format: CurveFormat, csv: Option<&PathBuf>) -> anyhow::Result<()> {
        if let Some(path) = csv {
            std::fs::write(path, self.to_csv())
                .with_context(|| format!("writing {}", crate::display::path(path)))?;
        }
        let out = match format {
            CurveFormat::Table => self.to_table(),
            CurveFormat::Csv => self.to_csv(),
            CurveFormat::Json => serde_json::to_string_pretty(&self.to_json())? + "\n",
        };
        print!("{out}");
        Ok(())
    }
}
