//! `scatterbake mie`: one sphere, printed as a MiePlot-style table, CSV or JSON.
//!
//! ```text
//! scatterbake mie (--radius-um R --wavelength-nm L | --x X) [--index N+Ki | --n N --k K |
//!     --water-index-model iapws1997 --temperature-c 20] [--n-medium 1.333]
//!     [(--core-radius-um RC | --core-x XC) --core-index N+Ki] [--angle-step-deg 0.1 |
//!     --angles START:STOP:STEP | --angles-deg 0,90,180] [--format table|csv|json] [--csv FILE]
//!     [--debye-orders 2,3 [--debye-per-order]]
//! scatterbake mie --distribution lognormal:R,S | gamma:REFF,VEFF | marshall-palmer:RATE[,MIN,MAX]
//!     --wavelength-nm L [index and angle options as above] [--tolerance 1e-3]
//!     [--max-radius-nodes 100000]
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
//!
//! With `--debye-orders`, the coherent sum of the chosen Debye-series terms of the same sphere
//! is printed in the same columns (`i_perp`, `i_par`, `phase` still divided by the full sphere's
//! `π x² Q_sca`); `--debye-per-order` adds one column `phase_p<k>` per order.
//!
//! With `--distribution`, the same columns are the size-distribution average (weights
//! `n(r) dr · C_sca(r)`, the `mie` stage's) at point angles, by the adaptive radius rule of
//! `mie::size_average` to `--tolerance` (the estimated RMS relative error of `i_perp`, `i_par`
//! over the angles, relative to `phase`; `--max-tolerance` also bounds its estimated largest
//! value over the angles), which the header states with the spheres used; a
//! tolerance not met within `--max-radius-nodes` spheres is an error. The parameters are those
//! of the manifest's `distributions` entries: `lognormal:median_radius_um,geometric_sigma`,
//! `gamma:effective_radius_um,effective_variance`,
//! `marshall-palmer:rain_rate_mm_h[,min_radius_um,max_radius_um]` (defaults 50 and 3000 µm).
//! `s1_sq`, `s2_sq` are then the mean `|S1|²`, `|S2|²` per drop and the normalisation the mean
//! `π x² Q_sca` per drop.

use crate::args::{AngleRange, IndexArgs, parse_complex_index};
use crate::curve::{
    CURVE_CSV_COLUMNS, CURVE_TABLE_COLUMNS, CurveFormat, CurveReport, CurveRow, curve_json,
    q_back_line,
};
use anyhow::{Context, bail};
use num_complex::Complex64;
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use scatterbake::mie::coated::{CoatedSphere, coated_coefficients};
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::mie::size_average::{
    AverageLimits, DEFAULT_MAX_NODES, DEFAULT_TOLERANCE, average_at_angles,
};
use scatterbake::mie::{Q_BACK_CONVENTIONS, Sphere, size_parameter};
use std::fmt::Write as _;
use std::path::PathBuf;

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
    #[arg(long, conflicts_with = "angles_deg", value_parser = AngleRange::parse)]
    pub angles: Option<AngleRange>,
    /// Explicit comma-separated angles in degrees (overrides --angle-step-deg).
    #[arg(long, value_delimiter = ',')]
    pub angles_deg: Option<Vec<f64>>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = CurveFormat::Table)]
    pub format: CurveFormat,
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
        let angles_deg = query_angles(args)?;
        let (s1, s2) = sphere.amplitudes_deg_parallel(&angles_deg);
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

/// The angles of a query (`--angles`, `--angles-deg` or `--angle-step-deg`).
fn query_angles(args: &MieArgs) -> anyhow::Result<Vec<f64>> {
    Ok(match (&args.angles_deg, args.angles) {
        (None, Some(range)) => range.angles(),
        (Some(a), _) => {
            if let Some(bad) = a.iter().find(|t| !(0.0..=180.0).contains(*t)) {
                bail!("angle {bad} is outside 0–180°");
            }
            a.clone()
        }
        (None, None) => AngleRange::full(args.angle_step_deg)
            .context("--angle-step-deg")?
            .angles(),
    })
}

/// Arguments of `scatterbake mie`: one sphere, optionally split into Debye-series terms, or a
/// size distribution (`--distribution`).
#[derive(Debug, Clone, clap::Args)]
pub struct MieCommandArgs {
    #[command(flatten)]
    pub mie: MieArgs,
    /// Debye orders p to sum (0 = diffraction + external reflection, 1 = transmission,
    /// 2 = primary bow, 3 = secondary, ...); without it the plain Mie result is printed.
    #[arg(long, value_delimiter = ',')]
    pub debye_orders: Option<Vec<usize>>,
    /// Also print one `phase_p<k>` column per order.
    #[arg(long, requires = "debye_orders")]
    pub debye_per_order: bool,
    /// Average over a size distribution (with --wavelength-nm): `lognormal:R,S` (median radius
    /// µm, geometric sigma), `gamma:REFF,VEFF` (effective radius µm, effective variance) or
    /// `marshall-palmer:RATE[,MIN,MAX]` (rain rate mm/h, radius limits µm, default 50 and 3000).
    #[arg(long, value_parser = parse_distribution, conflicts_with_all = ["radius_um", "x", "debye_orders", "core_x", "core_radius_um"], requires = "wavelength_nm")]
    pub distribution: Option<SizeDistribution>,
    /// Largest estimated RMS relative error of a --distribution average (relative to phase).
    #[arg(long, default_value_t = DEFAULT_TOLERANCE, requires = "distribution")]
    pub tolerance: f64,
    /// Largest estimated maximum relative error of a --distribution average over the angles
    /// (relative to phase; default: estimated and printed, not bounded).
    #[arg(long, requires = "distribution")]
    pub max_tolerance: Option<f64>,
    /// Largest number of spheres of a --distribution average.
    #[arg(long, default_value_t = DEFAULT_MAX_NODES, requires = "distribution")]
    pub max_radius_nodes: usize,
}

/// Parses `KIND:P1,P2[,P3]` into the manifest's size distribution (parameters in the order and
/// units of its keys, see [`MieCommandArgs::distribution`]).
pub fn parse_distribution(text: &str) -> Result<SizeDistribution, String> {
    let (kind, rest) = text
        .split_once(':')
        .ok_or_else(|| format!("{text:?}: expected KIND:PARAMETERS, e.g. lognormal:6,1.35"))?;
    let values = rest
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|e| format!("{text:?}: {v:?}: {e}"))
        })
        .collect::<Result<Vec<f64>, _>>()?;
    let d = match (kind, values.as_slice()) {
        ("lognormal", &[median_radius_um, geometric_sigma]) => SizeDistribution::Lognormal {
            median_radius_um,
            geometric_sigma,
        },
        ("gamma", &[effective_radius_um, effective_variance]) => SizeDistribution::Gamma {
            effective_radius_um,
            effective_variance,
        },
        ("marshall-palmer", &[rain_rate_mm_h]) => SizeDistribution::MarshallPalmer {
            rain_rate_mm_h,
            min_radius_um: 50.0,
            max_radius_um: 3000.0,
        },
        ("marshall-palmer", &[rain_rate_mm_h, min_radius_um, max_radius_um]) => {
            SizeDistribution::MarshallPalmer {
                rain_rate_mm_h,
                min_radius_um,
                max_radius_um,
            }
        }
        _ => {
            return Err(format!(
                "{text:?}: expected lognormal:MEDIAN_RADIUS_UM,GEOMETRIC_SIGMA, gamma:EFFECTIVE_RADIUS_UM,EFFECTIVE_VARIANCE or marshall-palmer:RAIN_RATE_MM_H[,MIN_RADIUS_UM,MAX_RADIUS_UM]"
            ));
        }
    };
    d.validate().map_err(|e| format!("{text:?}: {e}"))?;
    Ok(d)
}

/// Solves a `--distribution` query (no I/O). `None` when no distribution was given.
pub fn solve_distribution(args: &MieCommandArgs) -> anyhow::Result<Option<CurveReport>> {
    let Some(d) = &args.distribution else {
        return Ok(None);
    };
    let a = &args.mie;
    let Some(wavelength_nm) = a.wavelength_nm else {
        bail!("--distribution needs --wavelength-nm");
    };
    if !(a.n_medium > 0.0 && a.n_medium.is_finite()) {
        bail!("--n-medium {} must be a positive real index", a.n_medium);
    }
    let (n, k) = a.refractive.resolve(Some(wavelength_nm))?;
    let m = Complex64::new(n, k) / a.n_medium;
    let angles_deg = query_angles(a)?;
    let limits = AverageLimits {
        tolerance: args.tolerance,
        max_tolerance: args.max_tolerance,
        max_nodes: args.max_radius_nodes,
    };
    let r = average_at_angles(d, wavelength_nm / a.n_medium, m, &angles_deg, &limits)
        .context("size-distribution average")?;
    let norm = r.phase_normalisation;
    Ok(Some(CurveReport {
        header: vec![
            format!(
                "size distribution {} (weights n(r) dr C_sca(r)), wavelength_nm: {wavelength_nm}, m = {} + {}i (relative to the medium), n_medium = {}",
                d.label(),
                m.re,
                m.im,
                a.n_medium
            ),
            format!(
                "error_estimate = {:.3e} (RMS relative error of i_perp, i_par over the angles, relative to phase; tolerance {:.1e})  max_error_estimate = {:.3e} (largest over the angles{})  radius_nodes = {}",
                r.error_estimate,
                args.tolerance,
                r.max_error_estimate,
                args.max_tolerance
                    .map_or(String::new(), |m| format!("; tolerance {m:.1e}")),
                r.radius_nodes
            ),
            format!(
                "Q_ext = {:.10}  Q_sca = {:.10}  g = {:.10} (<C>/<pi r^2>, g weighted by C_sca)",
                r.q_ext, r.q_sca, r.g
            ),
            q_back_line(r.q_back),
            format!(
                "i_perp, i_par, phase = averages of the normalised curves (1/sr, integral over 4pi of phase = 1); s1_sq, s2_sq = mean |S1|^2, |S2|^2 per drop; mean pi x^2 Q_sca per drop = {norm:.10e}"
            ),
        ],
        s1_sq: r.i_perp.iter().map(|v| v * norm).collect(),
        s2_sq: r.i_par.iter().map(|v| v * norm).collect(),
        angles_deg,
        normalisation: norm,
        extra: Vec::new(),
    }))
}

/// Solves a `--debye-orders` query (no I/O). `None` when no orders were requested.
pub fn solve_debye(args: &MieCommandArgs) -> anyhow::Result<Option<CurveReport>> {
    let Some(orders) = &args.debye_orders else {
        return Ok(None);
    };
    if orders.is_empty()
        || orders
            .iter()
            .any(|&p| p > scatterbake::stages::debye::MAX_ORDER)
    {
        bail!(
            "--debye-orders needs orders in 0..={}",
            scatterbake::stages::debye::MAX_ORDER
        );
    }
    let q = MieQuery::solve(&args.mie)?;
    if q.core.is_some() {
        bail!("--debye-orders treats homogeneous spheres only (no --core-x/--core-radius-um)");
    }
    let d = DebyeCoefficients::from_mie(q.sphere.coefficients.clone());
    let (s1, s2) = d.amplitudes_deg(&OrderSet::Orders(orders.clone()), &q.angles_deg);
    let norm = d.mie_normalisation();
    let mut extra = Vec::new();
    if args.debye_per_order {
        for &p in orders {
            let (a, b) = d.amplitudes_deg(&OrderSet::Orders(vec![p]), &q.angles_deg);
            let v = a
                .iter()
                .zip(&b)
                .map(|(u, w)| 0.5 * (u.norm_sqr() + w.norm_sqr()) / norm)
                .collect();
            extra.push((format!("phase_p{p}"), v));
        }
    }
    let e = q.sphere.efficiencies;
    Ok(Some(CurveReport {
        header: vec![
            format!(
                "Debye series orders {orders:?} (Bohren & Huffman conventions), x = {}, m = {} + {}i",
                q.x, q.m.re, q.m.im
            ),
            format!(
                "full sphere: Q_ext = {:.10}  Q_sca = {:.10}  n_stop = {}; phase = s11/(pi x^2 Q_sca) of the full sphere",
                e.q_ext,
                e.q_sca,
                d.n_stop()
            ),
            q_back_line(e.q_back) + " (full sphere)",
            "i_perp = |S1|^2/(pi x^2 Q_sca), i_par = |S2|^2/(pi x^2 Q_sca) of the coherent sum of the orders (1/sr); s1_sq = |S1|^2, s2_sq = |S2|^2 (dimensionless) in --format csv|json"
                .into(),
        ],
        angles_deg: q.angles_deg,
        s1_sq: s1.iter().map(|v| v.norm_sqr()).collect(),
        s2_sq: s2.iter().map(|v| v.norm_sqr()).collect(),
        normalisation: norm,
        extra,
    }))
}

/// Runs `scatterbake mie`: the Debye-series terms with `--debye-orders`, else the plain Mie
/// result (prints to stdout; writes `--csv` if given).
pub fn run_mie(args: &MieCommandArgs) -> anyhow::Result<()> {
    if let Some(r) = solve_distribution(args)? {
        return r.print(args.mie.format, args.mie.csv.as_ref());
    }
    if let Some(r) = solve_debye(args)? {
        return r.print(args.mie.format, args.mie.csv.as_ref());
    }
    let q = MieQuery::solve(&args.mie)?;
    if let Some(path) = &args.mie.csv {
        std::fs::write(path, q.to_csv())
            .with_context(|| format!("writing {}", crate::display::path(path)))?;
    }
    let out = match args.mie.format {
        CurveFormat::Table => q.to_table(),
        CurveFormat::Csv => q.to_csv(),
        CurveFormat::Json => serde_json::to_string_pretty(&q.to_json())? + "\n",
    };
    print!("{out}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use scatterbake::optics::water::WaterIndexModel;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: MieCommandArgs,
    }

    /// clap's own consistency checks of the arguments.
    #[test]
    fn clap_definitions_are_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }

    #[test]
    fn query_by_radius_uses_water_index_and_reports_bh_values() {
        let cli = Cli::parse_from(["t", "--x", "5.2128", "--n", "1.55", "--angles-deg", "0,180"]);
        let q = MieQuery::solve(&cli.args.mie).unwrap();
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
        let q = MieQuery::solve(&cli.args.mie).unwrap();
        assert_eq!(q.angles_deg, vec![0.0, 45.0, 90.0, 135.0, 180.0]);
        assert!((q.m.re - 1.3352).abs() < 2e-3);
        assert!(q.to_table().contains("Q_sca"));
        assert_eq!(
            q.to_csv().lines().filter(|l| !l.starts_with('#')).count(),
            6
        );
        let bad = Cli::parse_from(["t", "--x", "5", "--angle-step-deg", "0.1"]);
        assert!(MieQuery::solve(&bad.args.mie).is_err());
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
        let q = MieQuery::solve(&cli.args.mie).unwrap();
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
        let q = MieQuery::solve(&cli.args.mie).unwrap();
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
            MieQuery::solve(&Cli::parse_from(a).args.mie).unwrap()
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
        assert!(MieQuery::solve(&bad.args.mie).is_err());
    }

    /// A coated sphere from the command line is the library's coated solution; a core of the
    /// shell's own index is the homogeneous sphere.
    #[test]
    fn coated_sphere_options() {
        let solve = |a: &[&str]| MieQuery::solve(&Cli::parse_from(a).args.mie);
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
    }

    /// Core options with radii (core radius and the medium's wavelength), and the refusals.
    #[test]
    fn coated_sphere_options_with_radii_and_errors() {
        let solve = |a: &[&str]| MieQuery::solve(&Cli::parse_from(a).args.mie);
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

    /// `--debye-orders` with all of 0..=400 reproduces the Mie columns at x = 50 (the rest is
    /// the tail of grazing waves), and per-order columns appear.
    #[test]
    fn debye_orders_query() {
        let all: Vec<String> = (0..=400).map(|p| p.to_string()).collect();
        let orders = all.join(",");
        let cli = Cli::parse_from([
            "t",
            "--x",
            "50",
            "--n",
            "1.333",
            "--k",
            "0.001",
            "--angle-step-deg",
            "10",
            "--debye-orders",
            &orders,
        ]);
        let r = solve_debye(&cli.args).unwrap().unwrap();
        let q = MieQuery::solve(&cli.args.mie).unwrap();
        for i in 0..r.angles_deg.len() {
            assert!(
                (r.s1_sq[i] / q.s1_sq[i] - 1.0).abs() < 1e-6,
                "angle {}",
                r.angles_deg[i]
            );
        }
        let cli = Cli::parse_from([
            "t",
            "--x",
            "50",
            "--n",
            "1.333",
            "--angles-deg",
            "0,138",
            "--debye-orders",
            "2,3",
            "--debye-per-order",
        ]);
        let r = solve_debye(&cli.args).unwrap().unwrap();
        assert_eq!(r.extra.len(), 2);
        assert!(
            r.to_csv().contains(
                "\nangle_deg,s1_sq,s2_sq,s11,i_perp,i_par,phase,dolp,phase_p2,phase_p3\n"
            )
        );
        assert!(r.to_json()["phase_p3"].as_array().unwrap().len() == 2);
        let plain = Cli::parse_from(["t", "--x", "5", "--n", "1.5"]);
        assert!(solve_debye(&plain.args).unwrap().is_none());
    }
}
