//! `scatterbake airy`: Airy theory of the primary or secondary rainbow of one drop, printed in
//! the columns of `scatterbake mie`.
//!
//! ```text
//! scatterbake airy --radius-um R --wavelength-nm L [--order 1|2] [--index N | --n N |
//!     --water-index-model M --temperature-c T] [--angle-step-deg S | --angles START:STOP:STEP]
//!     [--format table|csv|json] [--csv FILE]
//! ```
//! Columns: those of `mie` (`angle_deg, s1_sq, s2_sq, s11, i_perp, i_par, phase, dolp`: raw
//! Bohren–Huffman |S1|², |S2|², s11, then `i_perp`, `i_par`, `phase` divided by `π x² Q_sca`
//! with `Q_sca = 2`, the large-x limit, stated in the header).

use crate::args::{AngleRange, IndexArgs};
use crate::curve::{CurveFormat, CurveReport};
use anyhow::bail;
use scatterbake::debye::airy::{AiryRainbow, airy_rainbow};
use scatterbake::mie::size_parameter;
use std::path::PathBuf;

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
    /// Angle step (degrees) of the default window: 3 Airy units on the dark side of the bow to
    /// past the 4th supernumerary, within 0–180°.
    #[arg(long, default_value_t = 0.01, conflicts_with = "angles")]
    pub angle_step_deg: f64,
    /// Angle range `START:STOP:STEP` in degrees instead of the default window (as in `mie` and
    /// `raytrace`); Airy theory needs 0 < START and STOP < 180.
    #[arg(long, value_parser = AngleRange::parse)]
    pub angles: Option<AngleRange>,
    /// Output format on stdout.
    #[arg(long, value_enum, default_value_t = CurveFormat::Table)]
    pub format: CurveFormat,
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
    let angles_deg = match args.angles {
        Some(range) => {
            if !(range.start > 0.0 && range.stop < 180.0) {
                bail!(
                    "--angles {}:{}:{}: Airy theory needs angles strictly between 0 and 180°",
                    range.start,
                    range.stop,
                    range.step
                );
            }
            range.angles()
        }
        None => {
            // The window is the bow's own; where it would reach 0° or 180° (a bow of a high
            // order or an index near its limit) it stops just inside, where Airy theory holds.
            let (z0, z1) = (bow.angle_at(-3.0), bow.angle_at(8.0));
            let lo = z0.min(z1).max(0.001);
            let hi = z0.max(z1).min(179.999);
            let step = args.angle_step_deg;
            if !(step > 0.0) || (hi - lo) / step > crate::args::MAX_ANGLES as f64 {
                bail!(
                    "--angle-step-deg {step} must be > 0 and give at most {} angles over the \
                     window {lo:.3}–{hi:.3}°",
                    crate::args::MAX_ANGLES
                );
            }
            AngleRange {
                start: lo,
                stop: hi,
                step,
            }
            .angles()
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
    struct Cli {
        #[command(flatten)]
        args: AiryArgs,
    }

    /// clap's own consistency checks of the arguments.
    #[test]
    fn clap_definitions_are_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }

    #[test]
    fn airy_query() {
        let cli = Cli::parse_from([
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
        let bad = Cli::parse_from([
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
