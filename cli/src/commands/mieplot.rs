//! `scatterbake` glue for [`scatterbake::consumers::export::mieplot`].

use anyhow::bail;
#[allow(unused_imports)]
use scatterbake::consumers::export::mieplot::*;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::path::PathBuf;

/// `scatterbake export --format mieplot`.
#[derive(Debug, Clone, clap::Args)]
pub struct MiePlotArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Wavelength (nm); default: the table's first wavelength. Interpolated linearly between
    /// table wavelengths (the table's lookup formula).
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Output text file (default: stdout).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run the MiePlot-style export.
pub fn run_mieplot(args: &MiePlotArgs) -> anyhow::Result<()> {
    let pt = PhaseTable::open(&args.table)?;
    let wl = args.wavelength_nm.unwrap_or_else(|| pt.wavelengths_nm()[0]);
    let d = from_table(&pt, &args.entry, wl)?;
    let e = pt.resolve_entry(&args.entry)?;
    let text = write_mieplot(
        &d,
        &[
            format!("table: {}", args.table.display()),
            format!("entry: {}", describe_entry(&pt.table, &e)),
        ],
    );
    match &args.out {
        Some(p) => std::fs::write(p, text)?,
        None => print!("{text}"),
    }
    Ok(())
}

/// `scatterbake validate`: compare a table against a MiePlot-style reference file.
#[derive(Debug, Clone, clap::Args)]
pub struct ValidateArgs {
    /// Phase-function table (.sbt).
    pub table: PathBuf,
    /// MiePlot-style reference text file (angle, i_perp, i_par[, phase]).
    #[arg(long)]
    pub reference: PathBuf,
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Wavelength (nm); default: the reference's `# wavelength_nm:` line.
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Fit one scale factor to the reference first (for references in other units).
    #[arg(long)]
    pub rescale: bool,
    /// Fail (non-zero exit) when any column's max relative error exceeds this.
    #[arg(long)]
    pub tolerance: Option<f64>,
}

/// Run the validation; prints the figures, errors out when over `--tolerance`.
pub fn run_validate(args: &ValidateArgs) -> anyhow::Result<()> {
    let pt = PhaseTable::open(&args.table)?;
    let r = read_mieplot_file(&args.reference)?;
    let wl = args.wavelength_nm.or(r.wavelength_nm).ok_or_else(|| {
        anyhow::anyhow!("reference has no `# wavelength_nm:` line: pass --wavelength-nm")
    })?;
    let rep = compare(&pt, &args.entry, wl, &r, args.rescale)?;
    println!(
        "{} vs {} at {wl} nm: {} rows, scale {:.6e}, max rel. error i_perp {:.3e}, i_par {:.3e}, phase {:.3e} (worst at {} deg)",
        args.table.display(),
        args.reference.display(),
        rep.rows,
        rep.scale,
        rep.max_rel_error[0],
        rep.max_rel_error[1],
        rep.max_rel_error[2],
        rep.worst_angle_deg
    );
    println!(
        "  rms rel. error i_perp {:.3e}, i_par {:.3e}, phase {:.3e}; correlation {:.9}",
        rep.rms_rel_error[0], rep.rms_rel_error[1], rep.rms_rel_error[2], rep.correlation
    );
    let show = |name: &str, m: Option<(f64, f64)>| match m {
        Some((t, r)) => println!("  {name} bow maximum: table {t:.4} deg, reference {r:.4} deg"),
        None => println!("  {name} bow maximum: no reference angles in its range"),
    };
    show("primary", rep.primary_max_deg);
    show("secondary", rep.secondary_max_deg);
    if let Some(t) = args.tolerance {
        let worst = rep.max_rel_error.iter().cloned().fold(0.0, f64::max);
        if worst > t {
            bail!("max relative error {worst:.3e} exceeds tolerance {t:.3e}");
        }
    }
    Ok(())
}
