//! `scatterbake export --format mieplot`: glue for [`scatterbake::consumers::export::mieplot`].

use scatterbake::consumers::export::mieplot::{from_table, write_mieplot};
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
use std::path::PathBuf;

/// `scatterbake export --format mieplot`.
#[derive(Debug, Clone, clap::Args)]
pub struct MiePlotArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: PathBuf,
    /// Entry selection, NAME=VALUE per entry axis (default: first sample of each).
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
            format!("table: {}", crate::display::path(&args.table)),
            format!("entry: {}", describe_entry(&pt.table, &e)),
        ],
    );
    match &args.out {
        Some(p) => std::fs::write(p, text)?,
        None => print!("{text}"),
    }
    Ok(())
}
