//! `scatterbake` glue for [`scatterbake::consumers::plot::tables`].

use anyhow::{Context, anyhow};
use scatterbake::consumers::plot::previews::previews;
#[allow(unused_imports)]
use scatterbake::consumers::plot::tables::*;
use scatterbake::consumers::read::phase::{EntrySelection, PhaseTable};
#[allow(unused_imports)]
use scatterbake::table::Table;
use std::path::PathBuf;

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected LO,HI"))?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|e| format!("{e}"))?,
        b.trim().parse().map_err(|e| format!("{e}"))?,
    );
    if !(0.0..=180.0).contains(&a) || !(0.0..=180.0).contains(&b) || a >= b {
        return Err(format!("`{s}`: need 0 <= LO < HI <= 180"));
    }
    Ok((a, b))
}

/// `scatterbake plot`.
#[derive(Debug, Clone, clap::Args)]
pub struct PlotArgs {
    /// Table (.sbt).
    pub table: PathBuf,
    /// What to draw: auto (every preview of the table's kind), phase (phase function vs
    /// angle), strip (rainbow colour strip), lee (Lee diagram), heatmap (2-D map), line (1-D
    /// curves), orders (Debye or ray orders).
    #[arg(long, value_enum, default_value = "auto")]
    pub kind: PlotKind,
    /// Entry selection, NAME=VALUE per entry axis, repeatable (e.g. radius=400; default: the
    /// first sample of each entry axis).
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    pub entry: Vec<EntrySelection>,
    /// Channel for heatmaps (default: the first).
    #[arg(long)]
    pub channel: Option<String>,
    /// Wavelengths to draw in phase plots (default: up to 8 spread over the table).
    #[arg(long = "wavelength-nm")]
    pub wavelength_nm: Vec<f64>,
    /// Also draw i_perp (dashed) and i_par (dotted) in phase plots.
    #[arg(long)]
    pub polarised: bool,
    /// Scattering-angle range of strips and Lee diagrams, LO,HI in deg.
    #[arg(long, default_value = "120,145", value_parser = parse_range)]
    pub angle_range: (f64, f64),
    /// Sun disc of strips and Lee diagrams (deg). Default: the disc the table already averaged
    /// over (attribute `sun_diameter_deg`; nothing more is applied), 0.5 for a point-sun table.
    /// A value smaller than the table's is refused.
    #[arg(long)]
    pub sun_diameter_deg: Option<f64>,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1000)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 600)]
    pub height: u32,
    /// Output .png or .svg (a directory for --kind auto).
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `scatterbake plot`.
pub fn run_plot(args: &PlotArgs) -> anyhow::Result<()> {
    let size = (args.width, args.height);
    let phase = || PhaseTable::open(&args.table);
    match args.kind {
        PlotKind::Auto => {
            for p in previews(&args.table, &args.out)? {
                eprintln!("wrote {}", crate::display::path(&p));
            }
            return Ok(());
        }
        PlotKind::Phase => plot_phase(
            &phase()?,
            &args.entry,
            &args.wavelength_nm,
            args.polarised,
            &args.out,
            size,
        )?,
        PlotKind::Strip => {
            let disc = plot_strip(
                &phase()?,
                &args.entry,
                args.sun_diameter_deg,
                args.angle_range,
                &args.out,
                size,
            )?;
            eprintln!("{}", disc.describe());
        }
        PlotKind::Lee => {
            let disc = plot_lee(
                &phase()?,
                &args.entry,
                args.sun_diameter_deg,
                args.angle_range,
                &args.out,
                size,
                &crate::progress::TerminalProgress::new("lee", false),
            )?;
            eprintln!("{}", disc.describe());
        }
        PlotKind::Orders => plot_debye_components(
            &phase()?,
            &args.entry,
            args.wavelength_nm.first().copied().unwrap_or(650.0),
            &args.out,
            size,
        )?,
        PlotKind::Heatmap | PlotKind::Line => {
            let t = Table::open(&args.table)
                .map_err(|e| anyhow!(e))
                .with_context(|| crate::display::path(&args.table))?;
            if args.kind == PlotKind::Heatmap {
                plot_heatmap(&t, &args.entry, args.channel.as_deref(), &args.out, size)?
            } else {
                plot_line(&t, &args.entry, &args.out, size)?
            }
        }
    }
    eprintln!("wrote {}", crate::display::path(&args.out));
    Ok(())
}
/// Plot kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlotKind {
    /// Every default preview of the table into the directory `--out`.
    Auto,
    Phase,
    Strip,
    Lee,
    Heatmap,
    Line,
    /// Per-order channels `phase_p<k>` (Debye series, ray orders) with their coherent sum, at
    /// the first `--wavelength-nm` (default 650 nm).
    Orders,
}
