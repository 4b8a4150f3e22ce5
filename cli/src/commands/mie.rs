//! `scatterbake mie`: one sphere, printed as a MiePlot-style table, CSV or JSON.
//!
//! ```text
//! scatterbake mie (--radius-um R --wavelength-nm L | --x X) [--index N+Ki | --n N --k K |
//!     --water-index-model iapws1997 --temperature-c 20] [--n-medium 1.333]
//!     [(--core-radius-um RC | --core-x XC) --core-index N+Ki] [--angle-step-deg 0.1 |
//!     --angles START:STOP:STEP | --angles-deg 0,90,180] [--format table|csv|json] [--csv FILE]
//! ```
//! The index options give the sphere's own (absolute) index; `--n-medium` (default 1) is the
//! real index of the non-absorbing medium around it: the relative index is `index/n_medium` and,
//! from `--radius-um/--wavelength-nm` (vacuum wavelength), `x = 2π r n_medium/λ`; a given `--x`
//! is the size parameter in the medium. A core (`--core-radius-um` with `--radius-um`, or
//! `--core-x`, and `--core-index`) makes a coated sphere whose shell is the material of the index
//! options. Every output states both backscattering conventions: `Q_back` (radar, `4|S1(180°)|²/x²`)
//! and `Q_back_per_sr` (MiePlot's, per steradian, `Q_back/4π`).
//! Columns (the vocabulary of every phase-function table, `docs/vocabulary.md`): `i_perp`,
//! `i_par` = |S1|², |S2|² over π x² Q_sca (1/sr), `phase = (i_perp + i_par)/2` with
//! `∫_{4π} phase dΩ = 1`, `dolp = (i_perp − i_par)/(i_perp + i_par)`; the raw Bohren–Huffman
//! intensities are `s1_sq` = |S1|², `s2_sq` = |S2|² and `s11` = (|S1|² + |S2|²)/2
//! (dimensionless, CSV and JSON only).

use anyhow::{Context, bail};
use num_complex::Complex64;
use scatterbake::mie::coated::{CoatedSphere, coated_coefficients};
use scatterbake::mie::{Q_BACK_CONVENTIONS, Sphere, size_parameter};
use scatterbake::optics::water::WaterIndexModel;
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Output format of `scatterbake mie`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MieFormat {
    /// Aligned columns with a `#` header block (MiePlot style).
    Table,
    /// Comma-separated values with a header row.
    Csv,
    /// One JSON object.
    Json,
}

/// Largest number of angles a single query may ask for.
const MAX_ANGLES: usize = 10_000_000;

/// Parse `N+Ki`, `N-Ki` (refused: k must be ≥ 0) or `N`.
fn parse_complex_index(s: &str) -> Result<(f64, f64), String> {
    let t = s.trim().replace(' ', "");
    let bad = || format!("`{s}` is not a refractive index of the form N+Ki (e.g. 1.55+0.002i)");
    let (n, k) = match t.strip_suffix(['i', 'j']) {
        Some(body) => {
            // Split at the last sign that is not an exponent sign.
            let bytes = body.as_bytes();
            let pos = (1..bytes.len())
                .rev()
                .find(|&i| matches!(bytes[i], b'+' | b'-') && !matches!(bytes[i - 1], b'e' | b'E'))
                .ok_or_else(bad)?;
            let n: f64 = body[..pos].parse().map_err(|_| bad())?;
            let k: f64 = body[pos..]
                .trim_start_matches('+')
                .parse()
                .map_err(|_| bad())?;
            (n, k)
        }
        None => (t.parse().map_err(|_| bad())?, 0.0),
    };
    if !(n > 0.0) || !n.is_finite() {
        return Err(format!("real part {n} of `{s}` must be positive"));
    }
    if !(k >= 0.0) || !k.is_finite() {
        return Err(format!(
            "imaginary part {k} of `{s}` must be ≥ 0 (absorbing convention m = n + ik, e^(-iωt))"
        ));
    }
    Ok((n, k))
}

/// Parse `START:STOP:STEP` (degrees).
fn parse_angle_range(s: &str) -> Result<(f64, f64, f64), String> {
    let parts: Vec<&str> = s.split(':').collect();
    let bad = || format!("`{s}` is not START:STOP:STEP in degrees (e.g. 0:180:0.05)");
    if parts.len() != 3 {
        return Err(bad());
    }
    let v: Vec<f64> = parts
        .iter()
        .map(|p| p.trim().parse::<f64>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    let (start, stop, step) = (v[0], v[1], v[2]);
    if !(0.0..=180.0).contains(&start) || !(0.0..=180.0).contains(&stop) || !(stop >= start) {
        return Err(format!("`{s}`: need 0 ≤ START ≤ STOP ≤ 180"));
    }
    if !(step > 0.0) || (stop - start) / step > MAX_ANGLES as f64 {
        return Err(format!(
            "`{s}`: STEP must be > 0 and give at most {MAX_ANGLES} angles"
        ));
    }
    Ok((start, stop, step))
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn complex_index_forms() {
        assert_eq!(parse_complex_index("1.55+0.002i").unwrap(), (1.55, 0.002));
        assert_eq!(parse_complex_index("1.333").unwrap(), (1.333, 0.0));
        assert_eq!(parse_complex_index("1.5+1e-3i").unwrap(), (1.5, 1e-3));
        assert!(parse_complex_index("1.5-0.1i").is_err());
        assert!(parse_complex_index("abc").is_err());
        assert_eq!(parse_angle_range("0:180:0.5").unwrap(), (0.0, 180.0, 0.5));
        assert!(parse_angle_range("0:190:1").is_err());
        assert!(parse_angle_range("0:180:0").is_err());
    }
}

/// Refractive-index options of every command that takes an index (`mie`, `airy`, `raytrace`):
/// an explicit relative index, or water at the wavelength from a named model (IAPWS R9-97 by
/// default, or Table 3.2 of Sadeghi 2012 as `sadeghi-table-3.2`), the names and defaults of the
/// manifest keys `water_index_model` and `temperature_c`.
#[derive(Debug, Clone, clap::Args)]
pub struct IndexArgs {
    /// Relative complex refractive index as `N+Ki` (e.g. `1.55+0.002i`, or `1.333`); the same
    /// as `--n N --k K`.
    #[arg(long, conflicts_with_all = ["n", "k", "water"], value_parser = parse_complex_index)]
    pub index: Option<(f64, f64)>,
    /// Use the index of water at the wavelength (the default when no index is given).
    #[arg(long)]
    pub water: bool,
    /// Real part of the relative refractive index (default: water at the wavelength).
    #[arg(long, conflicts_with = "water")]
    pub n: Option<f64>,
    /// Imaginary part (absorption), k ≥ 0 (default 0).
    #[arg(long)]
    pub k: Option<f64>,
    /// Water index model when no --index/--n is given.
    #[arg(long, default_value = "iapws1997", value_parser = ["iapws1997", "sadeghi-table-3.2"])]
    pub water_index_model: String,
    /// Water temperature (°C) for iapws1997.
    #[arg(long, default_value_t = 20.0)]
    pub temperature_c: f64,
}

impl IndexArgs {
    /// The explicit index (n, k), if one was given (`--index`, or `--n` with optional `--k`).
    pub fn explicit(&self) -> anyhow::Result<Option<(f64, f64)>> {
        let (n, k) = match self.index {
            Some((n, k)) => (Some(n), k),
            None => (self.n, self.k.unwrap_or(0.0)),
        };
        if !(k >= 0.0) || !k.is_finite() {
            bail!("--k {k} must be ≥ 0 (absorbing convention m = n + ik, e^(-iωt))");
        }
        match n {
            Some(n) if !(n > 0.0) || !n.is_finite() => bail!("--n {n} must be positive"),
            Some(n) => Ok(Some((n, k))),
            None => Ok(None),
        }
    }

    /// The water model named by `--water-index-model` and `--temperature-c`.
    pub fn water_model(&self) -> anyhow::Result<WaterIndexModel> {
        Ok(WaterIndexModel::from_name(
            &self.water_index_model,
            Some(self.temperature_c),
        )?)
    }

    /// (n, k) at `wavelength_nm`: the explicit index, or water (with `--k` if given); without
    /// a wavelength only an explicit `--n`/`--index` works.
    pub fn resolve(&self, wavelength_nm: Option<f64>) -> anyhow::Result<(f64, f64)> {
        if let Some(nk) = self.explicit()? {
            return Ok(nk);
        }
        let Some(l) = wavelength_nm else {
            bail!("--x needs --n or --index (no wavelength to evaluate the water index)");
        };
        Ok((self.water_model()?.index(l)?, self.k.unwrap_or(0.0)))
    }

    /// Real index n at `wavelength_nm` for methods without absorption (`what`, e.g. "ray
    /// tracing"): k must be 0.
    pub fn resolve_real(&self, wavelength_nm: f64, what: &str) -> anyhow::Result<f64> {
        let (n, k) = self.resolve(Some(wavelength_nm))?;
        if k != 0.0 {
            bail!("{what} treats non-absorbing drops only: k must be 0 (use `mie` for k > 0)");
        }
        Ok(n)
    }
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

/// Arguments of `scatterbake mie`.
#[derive(Debug, Clone, clap::Args)]
pub struct MieArgs {
    /// Drop radius in µm (with --wavelength-nm).
    #[arg(long)]
    pub radius_um: Option<f64>,
    /// Vacuum wavelength in nm (with --radius-um; also selects the water index).
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Size parameter 2πr/λ (instead of radius and wavelength; then --n or --index is required).
    #[arg(long, conflicts_with = "radius_um")]
    pub x: Option<f64>,
    #[command(flatten)]
    pub refractive: IndexArgs,
    /// Real refractive index of the non-absorbing medium around the sphere (1 = vacuum): the
    /// relative index is index/n_medium and --wavelength-nm is divided by it (same as the
    /// manifest key `n_medium`).
    #[arg(long, default_value_t = 1.0)]
    pub n_medium: f64,
    /// Core radius in µm of a coated sphere (with --radius-um, --wavelength-nm, --core-index);
    /// the shell is the material of --index/--n/--k/water.
    #[arg(long, conflicts_with = "core_x", requires = "core_index")]
    pub core_radius_um: Option<f64>,
    /// Core size parameter of a coated sphere (≤ the outer size parameter; with --core-index).
    #[arg(long, requires = "core_index")]
    pub core_x: Option<f64>,
    /// Absolute complex index `N+Ki` of the core of a coated sphere.
    #[arg(long, value_parser = parse_complex_index)]
    pub core_index: Option<(f64, f64)>,
    /// Uniform angle step from 0 to 180° (degrees).
    #[arg(long, default_value_t = 0.1)]
    pub angle_step_deg: f64,
    /// Angle range `START:STOP:STEP` in degrees, within 0–180 (overrides --angle-step-deg).
    #[arg(long, conflicts_with = "angles_deg", value_parser = parse_angle_range)]
    pub angles: Option<(f64, f64, f64)>,
    /// Explicit comma-separated angles in degrees (overrides --angle-step-deg).
    #[arg(long, value_delimiter = ',')]
    pub angles_deg: Option<Vec<f64>>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = MieFormat::Table)]
    pub format: MieFormat,
    /// Also write CSV to this file.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// The core of a coated sphere in a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoreQuery {
    /// Core size parameter (in the medium).
    pub x: f64,
    /// Core index relative to the medium.
    pub m: Complex64,
}

/// Result of one query (for printing and tests).
#[derive(Debug, Clone)]
pub struct MieQuery {
    /// Size parameter in the medium (outer size parameter of a coated sphere).
    pub x: f64,
    /// Index relative to the medium (of the shell, for a coated sphere).
    pub m: Complex64,
    /// Index of the medium.
    pub n_medium: f64,
    /// The sphere's own index (`m · n_medium`).
    pub index: Complex64,
    /// The core of a coated sphere.
    pub core: Option<CoreQuery>,
    /// Radius (µm) and vacuum wavelength (nm) when the query gave them.
    pub radius_um: Option<f64>,
    pub wavelength_nm: Option<f64>,
    pub sphere: Sphere,
    pub angles_deg: Vec<f64>,
    /// |S1|² (dimensionless).
    pub s1_sq: Vec<f64>,
    /// |S2|² (dimensionless).
    pub s2_sq: Vec<f64>,
}

impl MieQuery {
    /// Solves the query described by `args` (no I/O).
    pub fn solve(args: &MieArgs) -> anyhow::Result<Self> {
        let n_medium = args.n_medium;
        if !(n_medium > 0.0 && n_medium.is_finite()) {
            bail!("--n-medium {n_medium} must be a positive real index");
        }
        let (x, wavelength) = match (args.x, args.radius_um, args.wavelength_nm) {
            (Some(x), None, _) => (x, args.wavelength_nm),
            (None, Some(r), Some(l)) => (size_parameter(r, l / n_medium), Some(l)),
            _ => bail!("give either --x, or --radius-um with --wavelength-nm"),
        };
        let (n, k) = args.refractive.resolve(wavelength)?;
        let index = Complex64::new(n, k);
        let m = index / n_medium;
        let core = match (args.core_radius_um, args.core_x, args.core_index) {
            (None, None, None) => None,
            (None, None, Some(_)) => bail!("--core-index needs --core-radius-um or --core-x"),
            (_, _, None) => bail!("--core-radius-um and --core-x need --core-index"),
            (Some(rc), _, Some((cn, ck))) => {
                let (Some(_), Some(l)) = (args.radius_um, args.wavelength_nm) else {
                    bail!(
                        "--core-radius-um needs --radius-um and --wavelength-nm (with --x use --core-x)"
                    );
                };
                Some(CoreQuery {
                    x: size_parameter(rc, l / n_medium),
                    m: Complex64::new(cn, ck) / n_medium,
                })
            }
            (None, Some(xc), Some((cn, ck))) => Some(CoreQuery {
                x: xc,
                m: Complex64::new(cn, ck) / n_medium,
            }),
        };
        let sphere = match core {
            None => Sphere::new(x, m).context("Mie query")?,
            Some(c) => Sphere::from_coefficients(
                coated_coefficients(&CoatedSphere {
                    core_size_parameter: c.x,
                    size_parameter: x,
                    core_index: c.m,
                    shell_index: m,
                })
                .context("coated-sphere query")?,
            ),
        };
        let angles_deg = match (&args.angles_deg, args.angles) {
            (None, Some((start, stop, step))) => {
                let count = ((stop - start) / step + 1e-9).floor() as usize + 1;
                (0..count).map(|i| start + step * i as f64).collect()
            }
            (Some(a), _) => {
                if let Some(bad) = a.iter().find(|t| !(0.0..=180.0).contains(*t)) {
                    bail!("angle {bad} is outside 0–180°");
                }
                a.clone()
            }
            (None, None) => {
                let step = args.angle_step_deg;
                let count = 180.0 / step;
                if step.is_nan() || step <= 0.0 || (count - count.round()).abs() > 1e-6 {
                    bail!("--angle-step-deg must divide 180");
                }
                if count > MAX_ANGLES as f64 {
                    bail!("--angle-step-deg {step} gives more than {MAX_ANGLES} angles");
                }
                (0..=count.round() as usize)
                    .map(|i| i as f64 * step)
                    .collect()
            }
        };
        let (s1, s2) = sphere.amplitudes_deg(&angles_deg);
        Ok(MieQuery {
            x,
            m,
            n_medium,
            index,
            core,
            radius_um: args.radius_um,
            wavelength_nm: wavelength,
            angles_deg,
            s1_sq: s1.iter().map(|v| v.norm_sqr()).collect(),
            s2_sq: s2.iter().map(|v| v.norm_sqr()).collect(),
            sphere,
        })
    }

    /// The printed rows (normalised by π x² Q_sca).
    pub fn rows(&self) -> Vec<CurveRow> {
        let norm = self.sphere.phase_normalisation();
        (0..self.angles_deg.len())
            .map(|i| CurveRow::new(self.angles_deg[i], self.s1_sq[i], self.s2_sq[i], norm))
            .collect()
    }

    /// The `#` header lines (without `# `) of the table and CSV outputs: the sphere, the
    /// efficiencies with both backscattering conventions, and the normalisation.
    pub fn header_lines(&self) -> Vec<String> {
        let e = self.sphere.efficiencies;
        let mut h = vec![format!(
            "Lorenz-Mie (Bohren & Huffman conventions), x = {}, m = {} + {}i (relative to the medium)",
            self.x, self.m.re, self.m.im
        )];
        if self.n_medium != 1.0 {
            h.push(format!(
                "medium index n_medium = {}; sphere index {} + {}i; x = 2 pi r n_medium / lambda_vacuum",
                self.n_medium, self.index.re, self.index.im
            ));
        }
        // machine-readable lines (read back by `validate` to find the table entry)
        if let Some(r) = self.radius_um {
            h.push(format!("radius_um: {r}"));
        }
        if let Some(l) = self.wavelength_nm {
            h.push(format!("wavelength_nm: {l}"));
        }
        if let Some(c) = self.core {
            h.push(format!(
                "coated sphere: core x_c = {}, m_core = {} + {}i; shell m = {} + {}i (relative indices)",
                c.x, c.m.re, c.m.im, self.m.re, self.m.im
            ));
        }
        h.push(format!(
            "Q_ext = {:.10}  Q_sca = {:.10}  g = {:.10}  n_stop = {}",
            e.q_ext,
            e.q_sca,
            e.g,
            self.sphere.coefficients.n_stop()
        ));
        h.push(q_back_line(e.q_back));
        h.push(format!(
            "i_perp = |S1|^2/(pi x^2 Q_sca), i_par = |S2|^2/(pi x^2 Q_sca), phase = (i_perp + i_par)/2 (1/sr, integral over 4pi of phase = 1); pi x^2 Q_sca = {:.10e}",
            self.sphere.phase_normalisation()
        ));
        h
    }

    /// CSV: the header lines as `#` comments, then a header row and the rows.
    pub fn to_csv(&self) -> String {
        let mut s = String::new();
        for h in self.header_lines() {
            let _ = writeln!(s, "# {h}");
        }
        let _ = writeln!(s, "{CURVE_CSV_COLUMNS}");
        for r in self.rows() {
            let _ = writeln!(s, "{}", r.csv());
        }
        s
    }

    /// MiePlot-style table with the efficiencies in a `#` header.
    pub fn to_table(&self) -> String {
        let mut s = String::new();
        for h in self.header_lines() {
            let _ = writeln!(s, "# {h}");
        }
        let _ = writeln!(s, "{CURVE_TABLE_COLUMNS}");
        for r in self.rows() {
            let _ = writeln!(s, "{}", r.table());
        }
        s
    }

    /// JSON object: `x`, `m` = [n, k] (relative), `n_medium`, `index` = [n, k] (the sphere's
    /// own), `core` = {x, m} of a coated sphere, the efficiencies (`qback` radar,
    /// `qback_per_sr` MiePlot's, `qback_convention` in words), then the columns of
    /// [`curve_json`].
    pub fn to_json(&self) -> serde_json::Value {
        let e = self.sphere.efficiencies;
        let mut o = serde_json::Map::new();
        o.insert("x".into(), self.x.into());
        o.insert("m".into(), serde_json::json!([self.m.re, self.m.im]));
        o.insert("n_medium".into(), self.n_medium.into());
        o.insert(
            "index".into(),
            serde_json::json!([self.index.re, self.index.im]),
        );
        if let Some(c) = self.core {
            o.insert(
                "core".into(),
                serde_json::json!({ "x": c.x, "m": [c.m.re, c.m.im] }),
            );
        }
        o.insert("qext".into(), e.q_ext.into());
        o.insert("qsca".into(), e.q_sca.into());
        o.insert("qback".into(), e.q_back.into());
        o.insert("qback_per_sr".into(), e.q_back_per_sr().into());
        o.insert("qback_convention".into(), Q_BACK_CONVENTIONS.into());
        o.insert("g".into(), e.g.into());
        o.extend(curve_json(&self.rows()));
        serde_json::Value::Object(o)
    }
}

/// The header line stating both backscattering efficiencies with their conventions.
pub fn q_back_line(q_back: f64) -> String {
    format!(
        "Q_back = {:.10} (radar convention: 4 pi (dC_sca/dOmega at 180 deg)/(pi r^2) = 4 |S1(180)|^2/x^2)  Q_back_per_sr = {:.10e} (MiePlot, per steradian: Q_back/(4 pi) = |S1(180)|^2/(pi x^2))",
        q_back,
        q_back / (4.0 * std::f64::consts::PI)
    )
}

/// Runs `scatterbake mie` (prints to stdout; writes `--csv` if given).
pub fn run_mie(args: &MieArgs) -> anyhow::Result<()> {
    let q = MieQuery::solve(args)?;
    if let Some(path) = &args.csv {
        std::fs::write(path, q.to_csv()).with_context(|| format!("writing {}", path.display()))?;
    }
    let out = match args.format {
        MieFormat::Table => q.to_table(),
        MieFormat::Csv => q.to_csv(),
        MieFormat::Json => serde_json::to_string_pretty(&q.to_json())? + "\n",
    };
    print!("{out}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: MieArgs,
    }

    #[test]
    fn query_by_radius_uses_water_index_and_reports_bh_values() {
        let cli = Cli::parse_from(["t", "--x", "5.2128", "--n", "1.55", "--angles-deg", "0,180"]);
        let q = MieQuery::solve(&cli.args).unwrap();
        let j = q.to_json();
        assert!((j["qsca"].as_f64().unwrap() - 3.10547).abs() < 1e-5);
        assert_eq!(j["angle_deg"].as_array().unwrap().len(), 2);
        let cli = Cli::parse_from([
            "t",
            "--radius-um",
            "10",
            "--wavelength-nm",
            "550",
            "--angle-step-deg",
            "45",
        ]);
        let q = MieQuery::solve(&cli.args).unwrap();
        assert_eq!(q.angles_deg, vec![0.0, 45.0, 90.0, 135.0, 180.0]);
        assert!((q.m.re - 1.3352).abs() < 2e-3);
        assert!(q.to_table().contains("Q_sca"));
        assert_eq!(
            q.to_csv().lines().filter(|l| !l.starts_with('#')).count(),
            6
        );
        let bad = Cli::parse_from(["t", "--x", "5", "--angle-step-deg", "0.1"]);
        assert!(MieQuery::solve(&bad.args).is_err());
    }

    /// `i_perp`/`i_par` are |S1|², |S2|² over π x² Q_sca (1/sr), `phase` their mean; the raw
    /// intensities are `s1_sq`/`s2_sq`. The normalised phase integrates to 1 over 4π.
    #[test]
    fn i_perp_is_the_normalised_component_and_s1_sq_the_raw_one() {
        let cli = Cli::parse_from([
            "t",
            "--x",
            "20",
            "--index",
            "1.33+0.001i",
            "--angle-step-deg",
            "0.05",
            "--format",
            "json",
        ]);
        let q = MieQuery::solve(&cli.args).unwrap();
        assert_eq!((q.m.re, q.m.im), (1.33, 0.001));
        let j = q.to_json();
        let col = |k: &str| -> Vec<f64> {
            j[k].as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        };
        let (s1, ip, ipar, ph) = (col("s1_sq"), col("i_perp"), col("i_par"), col("phase"));
        let norm = std::f64::consts::PI * 400.0 * j["qsca"].as_f64().unwrap();
        let mut integral = 0.0;
        for i in 0..ip.len() {
            assert!((ip[i] * norm / s1[i] - 1.0).abs() < 1e-12, "{i}");
            assert!((ph[i] - 0.5 * (ip[i] + ipar[i])).abs() <= 1e-12 * ph[i]);
            if i > 0 {
                let (a, b) = (
                    (0.05 * (i - 1) as f64).to_radians(),
                    (0.05 * i as f64).to_radians(),
                );
                integral +=
                    std::f64::consts::PI * (ph[i - 1] * a.sin() + ph[i] * b.sin()) * (b - a);
            }
        }
        assert!((integral - 1.0).abs() < 1e-3, "∫ phase dΩ = {integral}");
        assert!(
            q.to_csv()
                .contains("\nangle_deg,s1_sq,s2_sq,s11,i_perp,i_par,phase,dolp\n")
        );
        // The water index is the default, a --k alone adds absorption to it.
        let cli = Cli::parse_from([
            "t",
            "--radius-um",
            "10",
            "--wavelength-nm",
            "650",
            "--k",
            "0.01",
        ]);
        let q = MieQuery::solve(&cli.args).unwrap();
        let iapws = WaterIndexModel::default().index(650.0).unwrap();
        assert_eq!((q.m.re, q.m.im), (iapws, 0.01));
    }

    /// `--n-medium`: a sphere of index N in a medium n_medium is the sphere of relative index
    /// N/n_medium at the wavelength in the medium; both Q_back conventions are in every output.
    #[test]
    fn medium_index_and_both_backscatter_conventions() {
        let q = |extra: &[&str]| {
            let mut a = vec!["t", "--radius-um", "1", "--wavelength-nm", "500"];
            a.extend(extra);
            MieQuery::solve(&Cli::parse_from(a).args).unwrap()
        };
        let medium = q(&[
            "--index",
            "1.5+0.01i",
            "--n-medium",
            "1.25",
            "--angles-deg",
            "0,180",
        ]);
        let x = size_parameter(1.0, 500.0 / 1.25);
        let direct = Sphere::new(x, Complex64::new(1.2, 0.008)).unwrap();
        assert!((medium.x - x).abs() < 1e-12 * x);
        assert!((medium.m - Complex64::new(1.2, 0.008)).norm() < 1e-15);
        assert_eq!(medium.sphere.efficiencies, direct.efficiencies);
        let vacuum = q(&["--index", "1.5+0.01i", "--angles-deg", "0,180"]);
        assert!((vacuum.sphere.efficiencies.q_sca - direct.efficiencies.q_sca).abs() > 1e-3);
        let j = medium.to_json();
        assert_eq!(j["n_medium"].as_f64(), Some(1.25));
        assert_eq!(j["index"][0].as_f64(), Some(1.5));
        let qb = j["qback"].as_f64().unwrap();
        let per_sr = j["qback_per_sr"].as_f64().unwrap();
        assert!((qb / per_sr - 4.0 * std::f64::consts::PI).abs() < 1e-12);
        // Q_back_per_sr = |S1(180°)|²/(π x²): MiePlot's per-steradian value.
        assert!((per_sr - medium.s1_sq[1] / (std::f64::consts::PI * x * x)).abs() < 1e-12 * per_sr);
        assert!(j["qback_convention"].as_str().unwrap().contains("MiePlot"));
        for text in [medium.to_table(), medium.to_csv()] {
            assert!(
                text.contains("Q_back = ") && text.contains("radar"),
                "{text}"
            );
            assert!(
                text.contains("Q_back_per_sr = ") && text.contains("MiePlot"),
                "{text}"
            );
            assert!(text.contains("n_medium = 1.25"), "{text}");
        }
        let bad = Cli::parse_from(["t", "--x", "5", "--n", "1.5", "--n-medium", "0"]);
        assert!(MieQuery::solve(&bad.args).is_err());
    }

    /// A coated sphere from the command line is the library's coated solution; a core of the
    /// shell's own index is the homogeneous sphere.
    #[test]
    fn coated_sphere_options() {
        let solve = |a: &[&str]| MieQuery::solve(&Cli::parse_from(a).args);
        let q = solve(&[
            "t",
            "--x",
            "50",
            "--core-x",
            "10",
            "--index",
            "1.33",
            "--core-index",
            "1.95+0.79i",
            "--angles-deg",
            "0,90,180",
        ])
        .unwrap();
        let c = scatterbake::mie::coated::coated_coefficients(&CoatedSphere {
            core_size_parameter: 10.0,
            size_parameter: 50.0,
            core_index: Complex64::new(1.95, 0.79),
            shell_index: Complex64::new(1.33, 0.0),
        })
        .unwrap();
        assert_eq!(q.sphere.efficiencies, c.efficiencies());
        assert!(q.to_table().contains("coated sphere: core x_c = 10"));
        assert_eq!(q.to_json()["core"]["x"].as_f64(), Some(10.0));
        let same = solve(&[
            "t",
            "--x",
            "50",
            "--core-x",
            "10",
            "--index",
            "1.5",
            "--core-index",
            "1.5",
            "--angles-deg",
            "0,90,180",
        ])
        .unwrap();
        let homogeneous = solve(&[
            "t",
            "--x",
            "50",
            "--index",
            "1.5",
            "--angles-deg",
            "0,90,180",
        ])
        .unwrap();
        for (a, b) in same.s1_sq.iter().zip(&homogeneous.s1_sq) {
            assert!((a - b).abs() < 1e-11 * b, "{a} vs {b}");
        }
        // With radii: core radius and the medium's wavelength.
        let r = solve(&[
            "t",
            "--radius-um",
            "2",
            "--wavelength-nm",
            "600",
            "--core-radius-um",
            "1",
            "--core-index",
            "1.0",
            "--n",
            "1.31",
            "--n-medium",
            "1.333",
            "--angles-deg",
            "0",
        ])
        .unwrap();
        let core = r.core.unwrap();
        assert!((core.x - size_parameter(1.0, 600.0 / 1.333)).abs() < 1e-12);
        assert!((core.m.re - 1.0 / 1.333).abs() < 1e-15);
        // Errors: a core larger than the sphere, a core radius without radii, no core index.
        assert!(
            solve(&[
                "t",
                "--x",
                "5",
                "--core-x",
                "6",
                "--n",
                "1.5",
                "--core-index",
                "2"
            ])
            .is_err()
        );
        assert!(
            solve(&[
                "t",
                "--x",
                "5",
                "--core-radius-um",
                "1",
                "--n",
                "1.5",
                "--core-index",
                "2"
            ])
            .is_err()
        );
        assert!(Cli::try_parse_from(["t", "--x", "5", "--core-x", "1", "--n", "1.5"]).is_err());
    }
}
