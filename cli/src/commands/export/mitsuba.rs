//! `scatterbake export --format mitsuba`: glue for [`scatterbake::consumers::export::mitsuba`].

#[allow(unused_imports)]
use scatterbake::consumers::export::mitsuba::*;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable, describe_entry};
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Number of tabphase values unless `--samples` says otherwise.
pub const DEFAULT_SAMPLES: usize = 4096;

/// `scatterbake export --format mitsuba`.
#[derive(Debug, Clone, clap::Args)]
pub struct MitsubaArgs {
    /// Phase-function table (.sbt) following the phase contract.
    pub table: PathBuf,
    /// Entry selection, NAME=VALUE per entry axis (default: first sample of each).
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// rgb: three lists (linear sRGB, D65); spectral: one per wavelength; wavelength: one at
    /// --wavelength-nm; luminance: CIE Y weighted.
    #[arg(long, default_value = "rgb", value_parser = crate::args::named::<MitsubaMode>(&MitsubaMode::NAMES))]
    pub mode: MitsubaMode,
    /// Wavelength for --mode wavelength (nearest table wavelength is used).
    #[arg(long)]
    pub wavelength_nm: Option<f64>,
    /// Number of values (uniform in cos θ over [-1, 1]).
    #[arg(long, default_value_t = DEFAULT_SAMPLES)]
    pub samples: usize,
    /// XML snippet output (default: stdout).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write the plain value lists, one list per line after a `# label` line.
    #[arg(long)]
    pub values_out: Option<PathBuf>,
}

/// Run the Mitsuba export.
pub fn run_mitsuba(args: &MitsubaArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.samples >= 2, "--samples must be at least 2");
    let pt = PhaseTable::open(&args.table)?;
    let c = pt.curves(&args.entry)?;
    if let (MitsubaMode::Wavelength, Some(w)) = (args.mode, args.wavelength_nm) {
        crate::args::nearest_wavelength(&c.wavelengths_nm, w);
    }
    let lists = build_lists(&c, args.mode, args.wavelength_nm, args.samples)?;
    let source = format!(
        "{} [{}]",
        crate::display::path(&args.table),
        describe_entry(&pt.table, &c.entry)
    );
    let xml = xml_snippet(&lists, &source);
    match &args.out {
        Some(p) => std::fs::write(p, &xml)?,
        None => print!("{xml}"),
    }
    if let Some(p) = &args.values_out {
        let mut s = String::new();
        for l in &lists {
            let _ = writeln!(s, "# {} ({})", l.id, l.label);
            let _ = writeln!(s, "{}", values_string(&l.values));
        }
        std::fs::write(p, s)?;
    }
    for l in &lists {
        if (l.quality.normalisation_ratio - 1.0).abs() > 0.01 {
            eprintln!(
                "warning: {}: the table's phase function (linear in angle between samples) integrates to {:.4} over 4pi, not 1: \
                 its angular sampling does not resolve a narrow feature (usually the forward diffraction peak); Mitsuba renormalises",
                l.id, l.quality.normalisation_ratio
            );
        }
        eprintln!(
            "{}: {} values, normalisation ratio {:.6}, 90-180 deg: max rel. error {:.3e}, relative L1 error {:.3e}; {}",
            l.id,
            l.values.len(),
            l.quality.normalisation_ratio,
            l.quality.max_rel_error_back,
            l.quality.l1_rel_error_back,
            l.negatives.describe()
        );
    }
    Ok(())
}
