//! `scatterbake mie ... --debye-orders 2,3` and `scatterbake airy ...`: one sphere, printed in
//! the columns of `scatterbake mie`.
//!
//! ```text
//! scatterbake mie <mie args> --debye-orders 2,3 [--debye-per-order]
//! scatterbake airy --radius-um R --wavelength-nm L [--order 1|2] [--index N | --n N |
//!     --water-index-model M --temperature-c T] [--angle-step-deg S | --angles-deg a,b,c]
//!     [--format table|csv|json] [--csv FILE]
//! ```
//! Columns: those of `mie` (`angle_deg, s1_sq, s2_sq, s11, i_perp, i_par, phase, dolp`: raw
//! Bohren–Huffman |S1|², |S2|², s11, then `i_perp`, `i_par`, `phase` divided by the full
//! sphere's `π x² Q_sca`); with `--debye-per-order`, one more column `phase_p<k>` per order.
//! For `airy` the normalisation uses `Q_sca = 2` (the large-x limit), stated in the header.

use crate::commands::mie::{
    CURVE_CSV_COLUMNS, CURVE_TABLE_COLUMNS, CurveRow, IndexArgs, MieArgs, MieFormat, MieQuery,
    curve_json,
};
use anyhow::{Context, bail};
use scatterbake::debye::airy::{AiryRainbow, airy_rainbow};
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use scatterbake::mie::size_parameter;
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `scatterbake mie ... --debye-orders ...`.
#[derive(Debug, Clone, clap::Args)]
pub struct DebyeArgs {
    #[command(flatten)]
    pub mie: MieArgs,
    /// Debye orders p to sum (0 = diffraction + external reflection, 1 = transmission,
    /// 2 = primary bow, 3 = secondary, ...); without it the plain Mie result is printed.
    #[arg(long, value_delimiter = ',')]
    pub debye_orders: Option<Vec<usize>>,
    /// Also print one `phase_p<k>` column per order.
    #[arg(long, requires = "debye_orders")]
    pub debye_per_order: bool,
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

    /// CSV with a header row (the `mie` columns, then the extra columns).
    pub fn to_csv(&self) -> String {
        let mut s = String::from(CURVE_CSV_COLUMNS);
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

    fn print(&self, format: MieFormat, csv: Option<&PathBuf>) -> anyhow::Result<()> {
        if let Some(path) = csv {
            std::fs::write(path, self.to_csv())
                .with_context(|| format!("writing {}", path.display()))?;
        }
        let out = match format {
            MieFormat::Table => self.to_table(),
            MieFormat::Csv => self.to_csv(),
            MieFormat::Json => serde_json::to_string_pretty(&self.to_json())? + "\n",
        };
        print!("{out}");
        Ok(())
    }
}

/// Solves a `--debye-orders` query (no I/O). `None` when no orders were requested.
pub fn solve_debye(args: &DebyeArgs) -> anyhow::Result<Option<CurveReport>> {
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

/// Runs `scatterbake mie` with optional `--debye-orders` (plain Mie output without them).
pub fn run_debye(args: &DebyeArgs) -> anyhow::Result<()> {
    match solve_debye(args)? {
        Some(r) => r.print(args.mie.format, args.mie.csv.as_ref()),
        None => crate::commands::mie::run_mie(&args.mie),
    }
}

/// Arguments of `scatterbake airy`.
#[derive(Debug, Clone, clap::Args)]
pub struct AiryArgs {
    /// Drop radius in µm.
    #[arg(long)]
    pub radius_um: f64,
    /// Vacuum wavelength in nm.
    #[arg(long)]
    pub wavelength_nm: f64,
    /// Rainbow order: 1 = primary (Debye p = 2), 2 = secondary (p = 3).
    #[arg(long, default_value_t = 1)]
    pub order: usize,
    /// Refractive index (real: Airy theory of a non-absorbing drop; k must be 0).
    #[command(flatten)]
    pub refractive: IndexArgs,
    /// Uniform angle step (degrees) over the window --from-deg..--to-deg.
    #[arg(long, default_value_t = 0.01)]
    pub angle_step_deg: f64,
    /// Window start (deg); default: 3 Airy units on the dark side of the bow.
    #[arg(long)]
    pub from_deg: Option<f64>,
    /// Window end (deg); default: past the 4th supernumerary.
    #[arg(long)]
    pub to_deg: Option<f64>,
    /// Explicit comma-separated angles in degrees (overrides the window).
    #[arg(long, value_delimiter = ',')]
    pub angles_deg: Option<Vec<f64>>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = MieFormat::Table)]
    pub format: MieFormat,
    /// Also write CSV to this file.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// Solves an `airy` query (no I/O).
pub fn solve_airy(args: &AiryArgs) -> anyhow::Result<CurveReport> {
    if !(args.radius_um > 0.0 && args.wavelength_nm > 0.0) {
        bail!("--radius-um and --wavelength-nm must be positive");
    }
    if !(1..=5).contains(&args.order) {
        bail!("--order must be 1 (primary) .. 5");
    }
    let n = args
        .refractive
        .resolve_real(args.wavelength_nm, "Airy theory")?;
    if !(n > 1.0 && n < (args.order + 1) as f64) {
        bail!("no rainbow of order {} for n = {n}", args.order);
    }
    let x = size_parameter(args.radius_um, args.wavelength_nm);
    let bow = AiryRainbow::new(x, n, args.order);
    let angles_deg = match &args.angles_deg {
        Some(a) => {
            if let Some(bad) = a.iter().find(|t| !(0.0 < **t && **t < 180.0)) {
                bail!("angle {bad} is outside (0, 180)°");
            }
            a.clone()
        }
        None => {
            let (z0, z1) = (bow.angle_at(-3.0), bow.angle_at(8.0));
            let lo = args.from_deg.unwrap_or(z0.min(z1)).max(0.001);
            let hi = args.to_deg.unwrap_or(z0.max(z1)).min(179.999);
            let step = args.angle_step_deg;
            if step.is_nan() || step <= 0.0 || hi <= lo {
                bail!("need --angle-step-deg > 0 and a non-empty window");
            }
            let count = ((hi - lo) / step).floor() as usize;
            (0..=count).map(|k| lo + k as f64 * step).collect()
        }
    };
    let (s1_sq, s2_sq): (Vec<f64>, Vec<f64>) =
        angles_deg.iter().map(|&t| airy_rainbow(&bow, t)).unzip();
    Ok(CurveReport {
        header: vec![
            format!("Airy theory, {} bow (Debye p = {}), x = {x}, n = {n}", if args.order == 1 { "primary" } else { "higher-order" }, bow.p),
            format!("rainbow angle {:.5} deg, incidence {:.5} deg, D'' = {:.6}, |eps_perp|^2 = {:.6e}, |eps_par|^2 = {:.6e}", bow.rainbow_angle_deg, bow.incidence_deg, bow.curvature, bow.eps2_perp, bow.eps2_par),
            "i_perp = |S1|^2/(pi x^2 * 2), i_par = |S2|^2/(pi x^2 * 2), phase = (i_perp + i_par)/2 (1/sr; Q_sca = 2, the large-x limit); s1_sq = |S1|^2, s2_sq = |S2|^2 (Bohren-Huffman, dimensionless) in --format csv|json".into(),
        ],
        angles_deg,
        s1_sq,
        s2_sq,
        normalisation: std::f64::consts::PI * x * x * 2.0,
        extra: Vec::new(),
    })
}

/// Runs `scatterbake airy`.
pub fn run_airy(args: &AiryArgs) -> anyhow::Result<()> {
    solve_airy(args)?.print(args.format, args.csv.as_ref())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct DCli {
        #[command(flatten)]
        args: DebyeArgs,
    }

    #[derive(Parser)]
    struct ACli {
        #[command(flatten)]
        args: AiryArgs,
    }

    /// clap's own consistency checks of both argument sets.
    #[test]
    fn clap_definitions_are_consistent() {
        use clap::CommandFactory;
        DCli::command().debug_assert();
        ACli::command().debug_assert();
    }

    /// `--debye-orders` with all of 0..=400 reproduces the Mie columns at x = 50 (the rest is
    /// the tail of grazing waves), and per-order columns appear.
    #[test]
    fn debye_orders_query() {
        let all: Vec<String> = (0..=400).map(|p| p.to_string()).collect();
        let orders = all.join(",");
        let cli = DCli::parse_from([
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
        let cli = DCli::parse_from([
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
            r.to_csv().starts_with(
                "angle_deg,s1_sq,s2_sq,s11,i_perp,i_par,phase,dolp,phase_p2,phase_p3\n"
            )
        );
        assert!(r.to_json()["phase_p3"].as_array().unwrap().len() == 2);
        let plain = DCli::parse_from(["t", "--x", "5", "--n", "1.5"]);
        assert!(solve_debye(&plain.args).unwrap().is_none());
    }

    #[test]
    fn airy_query() {
        let cli = ACli::parse_from([
            "t",
            "--radius-um",
            "400",
            "--wavelength-nm",
            "650",
            "--n",
            "1.331",
            "--format",
            "csv",
        ]);
        let r = solve_airy(&cli.args).unwrap();
        // the maximum of s1_sq sits at the first Airy maximum z = 1.0188: 138.036° here
        let (k, _) = r
            .s1_sq
            .iter()
            .enumerate()
            .fold((0, 0.0), |b, (i, v)| if *v > b.1 { (i, *v) } else { b });
        assert!(
            (r.angles_deg[k] - 138.036).abs() < 0.01,
            "{}",
            r.angles_deg[k]
        );
        assert!(r.to_table().contains("rainbow angle"));
        let bad = ACli::parse_from([
            "t",
            "--radius-um",
            "400",
            "--wavelength-nm",
            "650",
            "--n",
            "3.5",
            "--order",
            "1",
        ]);
        assert!(solve_airy(&bad.args).is_err());
    }
}
