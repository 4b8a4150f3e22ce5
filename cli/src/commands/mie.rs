//! `scatterbake mie`: one sphere, printed as a MiePlot-style table, CSV or JSON (the lead
//! wires [`MieArgs`] and [`run_mie`] into the command line).
//!
//! ```text
//! scatterbake mie (--radius-um R --wavelength-nm L | --x X) [--n 1.333 --k 0 |
//!     --water-index-model iapws1997 --temperature-c 20] [--n-medium 1]
//!     [--core-radius-um RC | --core-x XC] [--core-index N+Ki]
//!     [--angles-step-deg 0.1 | --angles-deg 0,90,180] [--format table|csv|json] [--csv FILE]
//! ```
//! Intensities are raw Bohren–Huffman `|S|²` (dimensionless); `phase` is normalised to
//! `∫_{4π} p dΩ = 1` (1/sr). Indices are absolute and divided by `--n-medium`; a radius and
//! vacuum wavelength give `x = 2π r n_medium/λ`, while `--x` is taken as the size parameter in
//! the medium. With a core, the sphere index is the shell's. Q_back is printed in both
//! conventions, each labelled: radar `4|S1(180°)|²/x²` and per steradian (MiePlot) `/4π`.

use anyhow::{Context, bail};
use num_complex::Complex64;
use scatterbake::mie::coated::{CoatedSphere, coated_coefficients};
use scatterbake::mie::{Sphere, size_parameter};
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

/// Arguments of `scatterbake mie`.
#[derive(Debug, Clone, clap::Args)]
pub struct MieArgs {
    /// Drop radius in µm (with --wavelength-nm).
    #[arg(long)]
    pub radius_um: Option<f64>,
    /// Vacuum wavelength in nm (with --radius-um; also selects the water index).
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Size parameter 2πr/λ (instead of radius and wavelength; then --n is required).
    #[arg(long, conflicts_with = "radius_um")]
    pub x: Option<f64>,
    /// Relative complex refractive index as `N+Ki` (e.g. `1.55+0.002i`, or `1.333`); the same
    /// as `--n N --k K`.
    #[arg(long, conflicts_with_all = ["n", "water"], value_parser = parse_complex_index)]
    pub index: Option<(f64, f64)>,
    /// Use the index of water at the wavelength (the default when no index is given).
    #[arg(long)]
    pub water: bool,
    /// Real part of the relative refractive index (default: water at the wavelength).
    #[arg(long, conflicts_with = "water")]
    pub n: Option<f64>,
    /// Imaginary part (absorption), k ≥ 0.
    #[arg(long, default_value_t = 0.0)]
    pub k: f64,
    /// Water index model when --n is not given: iapws1997 | sadeghi-table-3.2.
    #[arg(long, default_value = "iapws1997")]
    pub water_index_model: String,
    /// Water temperature (°C) for iapws1997.
    #[arg(long, default_value_t = 20.0)]
    pub temperature_c: f64,
    /// Real refractive index of the surrounding medium; the sphere's (and core's) index and
    /// the vacuum wavelength are divided by it.
    #[arg(long, default_value_t = 1.0)]
    pub n_medium: f64,
    /// Coated sphere: core radius in µm (with --radius-um, the outer radius).
    #[arg(long, requires = "radius_um", conflicts_with = "core_x")]
    pub core_radius_um: Option<f64>,
    /// Coated sphere: core size parameter (with --x, the outer one).
    #[arg(long, requires = "x")]
    pub core_x: Option<f64>,
    /// Coated sphere: absolute core index `N+Ki` (the sphere index is then the shell's).
    #[arg(long, value_parser = parse_complex_index)]
    pub core_index: Option<(f64, f64)>,
    /// Uniform angle step from 0 to 180° (degrees).
    #[arg(long, default_value_t = 0.1)]
    pub angles_step_deg: f64,
    /// Angle range `START:STOP:STEP` in degrees, within 0–180 (overrides --angles-step-deg).
    #[arg(long, conflicts_with = "angles_deg", value_parser = parse_angle_range)]
    pub angles: Option<(f64, f64, f64)>,
    /// Explicit comma-separated angles in degrees (overrides --angles-step-deg).
    #[arg(long, value_delimiter = ',')]
    pub angles_deg: Option<Vec<f64>>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = MieFormat::Table)]
    pub format: MieFormat,
    /// Also write CSV to this file.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

/// Result of one query (for printing and tests).
#[derive(Debug, Clone)]
pub struct MieQuery {
    pub x: f64,
    /// Index relative to the medium (the shell's for a coated sphere).
    pub m: Complex64,
    /// Medium index.
    pub n_medium: f64,
    /// Coated sphere: core size parameter and relative core index.
    pub core: Option<(f64, Complex64)>,
    pub sphere: Sphere,
    pub angles_deg: Vec<f64>,
    pub i_perp: Vec<f64>,
    pub i_par: Vec<f64>,
}

impl MieQuery {
    /// Solves the query described by `args` (no I/O).
    pub fn solve(args: &MieArgs) -> anyhow::Result<Self> {
        let n_medium = args.n_medium;
        if !(n_medium.is_finite() && (0.05..=10.0).contains(&n_medium)) {
            bail!("--n-medium {n_medium} must be within 0.05–10");
        }
        let (x, wavelength) = match (args.x, args.radius_um, args.wavelength_nm) {
            (Some(x), None, _) => (x, args.wavelength_nm),
            (None, Some(r), Some(l)) => (size_parameter(r, l / n_medium), Some(l)),
            _ => bail!("give either --x, or --radius-um with --wavelength-nm"),
        };
        let (n_arg, k) = match args.index {
            Some((n, k)) => (Some(n), k),
            None => (args.n, args.k),
        };
        let n = match (n_arg, wavelength) {
            (Some(n), _) => n,
            (None, Some(l)) => {
                WaterIndexModel::from_name(&args.water_index_model, Some(args.temperature_c))?
                    .index(l)?
            }
            (None, None) => bail!("--x needs --n (no wavelength to evaluate the water index)"),
        };
        let m = Complex64::new(n, k) / n_medium;
        let core_x = match (args.core_x, args.core_radius_um, args.radius_um) {
            (Some(xc), _, _) => Some(xc),
            (None, Some(rc), Some(r)) => Some(x * rc / r),
            _ => None,
        };
        let core = match (core_x, args.core_index) {
            (Some(xc), Some((cn, ck))) => Some((xc, Complex64::new(cn, ck) / n_medium)),
            (None, None) => None,
            _ => bail!("a coated sphere needs --core-index and one of --core-radius-um, --core-x"),
        };
        let sphere = match core {
            None => Sphere::new(x, m).context("Mie query")?,
            Some((xc, mc)) => Sphere::from_coefficients(
                coated_coefficients(&CoatedSphere {
                    core_size_parameter: xc,
                    size_parameter: x,
                    core_index: mc,
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
                let step = args.angles_step_deg;
                let count = 180.0 / step;
                if step.is_nan() || step <= 0.0 || (count - count.round()).abs() > 1e-6 {
                    bail!("--angles-step-deg must divide 180");
                }
                if count > MAX_ANGLES as f64 {
                    bail!("--angles-step-deg {step} gives more than {MAX_ANGLES} angles");
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
            core,
            angles_deg,
            i_perp: s1.iter().map(|v| v.norm_sqr()).collect(),
            i_par: s2.iter().map(|v| v.norm_sqr()).collect(),
            sphere,
        })
    }

    fn rows(&self) -> impl Iterator<Item = (f64, f64, f64, f64, f64, f64)> + '_ {
        let norm = 1.0 / self.sphere.phase_normalisation();
        (0..self.angles_deg.len()).map(move |i| {
            let (a, b) = (self.i_perp[i], self.i_par[i]);
            let s11 = 0.5 * (a + b);
            let pol = if a + b > 0.0 { (a - b) / (a + b) } else { 0.0 };
            (self.angles_deg[i], a, b, s11, s11 * norm, pol)
        })
    }

    /// CSV with a header row.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("angle_deg,i_perp,i_par,s11,phase,polarization\n");
        for (t, a, b, u, p, d) in self.rows() {
            let _ = writeln!(s, "{t},{a:e},{b:e},{u:e},{p:e},{d}");
        }
        s
    }

    /// MiePlot-style table with the efficiencies in a `#` header.
    pub fn to_table(&self) -> String {
        let e = self.sphere.efficiencies;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# Lorenz-Mie (Bohren & Huffman conventions), x = {}, m = {} + {}i (relative to n_medium = {})",
            self.x, self.m.re, self.m.im, self.n_medium
        );
        if let Some((xc, mc)) = self.core {
            let _ = writeln!(
                s,
                "# coated sphere: core x_c = {xc}, m_core = {} + {}i; shell m = {} + {}i",
                mc.re, mc.im, self.m.re, self.m.im
            );
        }
        let _ = writeln!(
            s,
            "# Q_ext = {:.10}  Q_sca = {:.10}  g = {:.10}  n_stop = {}",
            e.q_ext,
            e.q_sca,
            e.g,
            self.sphere.coefficients.n_stop()
        );
        let _ = writeln!(
            s,
            "# Q_back (radar, 4|S1(180)|^2/x^2) = {:.10}  Q_back (per sr, MiePlot, |S1(180)|^2/(pi x^2)) = {:.10}",
            e.q_back,
            e.q_back_per_sr()
        );
        let _ = writeln!(
            s,
            "# i_perp = |S1|^2, i_par = |S2|^2, unpolarised = (i_perp + i_par)/2 (dimensionless)"
        );
        let _ = writeln!(
            s,
            "# {:>10} {:>20} {:>20} {:>20}",
            "angle", "i_perp", "i_par", "unpolarised"
        );
        for (t, a, b, u, _, _) in self.rows() {
            let _ = writeln!(s, "{t:>12.4} {a:>20.10e} {b:>20.10e} {u:>20.10e}");
        }
        s
    }

    /// JSON object (issue 3 §5 layout).
    pub fn to_json(&self) -> serde_json::Value {
        let e = self.sphere.efficiencies;
        let rows: Vec<_> = self.rows().collect();
        serde_json::json!({
            "x": self.x,
            "m": [self.m.re, self.m.im],
            "n_medium": self.n_medium,
            "core": self.core.map(|(xc, mc)| serde_json::json!({ "x": xc, "m": [mc.re, mc.im] })),
            "qext": e.q_ext, "qsca": e.q_sca, "g": e.g,
            "qback": e.q_back, "qback_per_sr": e.q_back_per_sr(),
            "qback_convention": scatterbake::mie::Q_BACK_CONVENTIONS.replace("q_back_per_sr", "qback_per_sr").replace("q_back", "qback"),
            "angles_deg": self.angles_deg,
            "s11": rows.iter().map(|r| r.3).collect::<Vec<_>>(),
            "i_perp": self.i_perp,
            "i_par": self.i_par,
            "phase": rows.iter().map(|r| r.4).collect::<Vec<_>>(),
            "polarization": rows.iter().map(|r| r.5).collect::<Vec<_>>(),
        })
    }
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
        assert_eq!(j["angles_deg"].as_array().unwrap().len(), 2);
        let cli = Cli::parse_from([
            "t",
            "--radius-um",
            "10",
            "--wavelength-nm",
            "550",
            "--angles-step-deg",
            "45",
        ]);
        let q = MieQuery::solve(&cli.args).unwrap();
        assert_eq!(q.angles_deg, vec![0.0, 45.0, 90.0, 135.0, 180.0]);
        assert!((q.m.re - 1.3352).abs() < 2e-3);
        assert!(q.to_table().contains("Q_sca"));
        assert_eq!(q.to_csv().lines().count(), 6);
        let bad = Cli::parse_from(["t", "--x", "5", "--angles-step-deg", "0.1"]);
        assert!(MieQuery::solve(&bad.args).is_err());
    }

    /// `--n-medium` divides index and wavelength; both Q_back conventions are printed and
    /// labelled; a core makes a coated sphere (equal indices: the homogeneous one).
    #[test]
    fn medium_coated_and_q_back_conventions() {
        let solve = |argv: &[&str]| MieQuery::solve(&Cli::parse_from(argv).args).unwrap();
        let q = solve(&[
            "t",
            "--radius-um",
            "1",
            "--wavelength-nm",
            "500",
            "--n",
            "1.0",
            "--n-medium",
            "1.333",
            "--angles-deg",
            "0,180",
        ]);
        let (x, m) = scatterbake::mie::in_medium(1.0, 500.0, Complex64::new(1.0, 0.0), 1.333);
        assert!((q.x - x).abs() < 1e-12 && (q.m - m).norm() < 1e-15);
        assert!(q.m.re < 1.0, "an air bubble in water has m < 1");
        let j = q.to_json();
        let (qb, qb_sr) = (
            j["qback"].as_f64().unwrap(),
            j["qback_per_sr"].as_f64().unwrap(),
        );
        assert!((qb / qb_sr - 4.0 * std::f64::consts::PI).abs() < 1e-12);
        assert!(j["qback_convention"].as_str().unwrap().contains("radar"));
        let t = q.to_table();
        assert!(t.contains("Q_back (radar") && t.contains("Q_back (per sr, MiePlot"));
        let plain = solve(&[
            "t",
            "--x",
            "10",
            "--index",
            "1.5+0.01i",
            "--angles-deg",
            "0,90",
        ]);
        let coated = solve(&[
            "t",
            "--x",
            "10",
            "--index",
            "1.5+0.01i",
            "--core-x",
            "4",
            "--core-index",
            "1.5+0.01i",
            "--angles-deg",
            "0,90",
        ]);
        assert!(coated.core.is_some());
        let (a, b) = (plain.to_json(), coated.to_json());
        for k in ["qext", "qsca", "qback", "g"] {
            let (u, v) = (a[k].as_f64().unwrap(), b[k].as_f64().unwrap());
            assert!((u - v).abs() <= 1e-12 * u.abs(), "{k}: {u} vs {v}");
        }
        let soot = solve(&[
            "t",
            "--radius-um",
            "1",
            "--wavelength-nm",
            "550",
            "--core-radius-um",
            "0.5",
            "--core-index",
            "1.75+0.43i",
            "--angles-deg",
            "0",
        ]);
        assert!((soot.core.unwrap().0 - soot.x / 2.0).abs() < 1e-12);
        let incomplete = Cli::parse_from(["t", "--x", "10", "--n", "1.5", "--core-x", "4"]);
        assert!(MieQuery::solve(&incomplete.args).is_err());
    }
}
