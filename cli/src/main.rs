//! The `scatterbake` command line. Argument parsing (clap) and error reporting (anyhow) live
//! here only; every command calls library functions of the `scatterbake` crate that take and
//! return plain structs. Every failure prints `error: …` naming the problem and where, and exits
//! non-zero; nothing panics on bad input.

mod commands;
mod progress;

use anyhow::Result;
use clap::{Parser, Subcommand};
use scatterbake::table::Table;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "scatterbake",
    version,
    about = "Bakes light-scattering tables (Mie, ray-traced raindrops, hair, fur) for renderers"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Build tables from manifests (default: every manifests/*.toml into tables/).
    Build(crate::commands::build::BuildArgs),
    /// Show a table's header, axes, channels, provenance and sizes.
    Inspect(crate::commands::table::InspectArgs),
    /// Verify tables (checksums, sizes, structure); non-zero exit if any is bad.
    Verify(crate::commands::table::VerifyArgs),
    /// Export a table: csv|json|exr (any table) or mitsuba|legendre|mieplot (phase functions).
    Export(ExportArgs),
    /// Plot a table (phase function, rainbow colour strip, Lee diagram, 2-D maps) to PNG/SVG.
    Plot(crate::commands::plot::PlotArgs),
    /// Plot 2-D ray-traced tables (raytrace-phase-2d): bows near the rainbows per outgoing
    /// azimuth with colour strips (several tables = several radii), or a lat-long map.
    PlotRaytrace(crate::commands::plot_raytrace::PlotRaytraceArgs),
    /// Render a picture through the public table reader API.
    #[command(subcommand)]
    Render(RenderCommand),
    /// Lorenz–Mie scattering of one sphere (MiePlot-style columns); `--debye-orders` selects
    /// Debye-series terms.
    Mie(crate::commands::debye::DebyeArgs),
    /// Patch-based wave-optics ray tracing of one drop (sphere or Beard–Chuang) at one wavelength.
    Raytrace(crate::commands::raytrace::RaytraceArgs),
    /// Airy theory of the primary or secondary rainbow (same columns as `mie`).
    Airy(crate::commands::debye::AiryArgs),
    /// Fur medulla scattering profile for one (σ, g, entry) by Monte Carlo, as CSV or JSON.
    Medulla(crate::commands::medulla::MedullaArgs),
    /// Compress the dense thesis-grid medulla tables into the shipped assets (docs/fur.md).
    MedullaAssets(crate::commands::medulla::MedullaAssetsArgs),
    /// Hair Dual Scattering table → engine EXR LUT (layout and shader lookup in docs/hair.md).
    HairLut(crate::commands::hair::HairLutArgs),
    /// Dual Scattering averages for one hair parameter set, as JSON or CSV.
    #[command(name = "dual-scattering", visible_alias = "hair-json")]
    HairJson(crate::commands::hair::DualScatteringArgs),
    /// Cloth BRDF (Sadeghi et al. 2013 microcylinder model) of a fabric preset at one pair of
    /// directions, with its surface and volume lobes.
    Cloth(crate::commands::cloth::ClothArgs),
    /// Compare a phase-function table with a MiePlot-style reference text file.
    Validate(crate::commands::mieplot::ValidateArgs),
    /// List stages with their parameters and defaults.
    Stages,
    /// Rebuild DIR/index.json from the tables in DIR (after sharded builds).
    Catalog(crate::commands::table::CatalogArgs),
}

/// What `render` can draw.
#[derive(Subcommand, Debug)]
enum RenderCommand {
    /// Spectral single-scattering rainbow in a rain volume, sun importance-sampled as a disc.
    Rainbow(crate::commands::render::RenderRainbowArgs),
}

/// Every export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ExportFormat {
    /// One row per grid point (any table).
    Csv,
    /// Header plus one object per grid point (any table).
    Json,
    /// f32 texture, last axis along x, other axes flattened along y (any table).
    Exr,
    /// Mitsuba 3 `tabphase` XML snippet (phase-function tables).
    Mitsuba,
    /// Legendre moments with truncation error (phase-function tables).
    Legendre,
    /// MiePlot-style text table: angle, i_perp, i_par, phase (phase-function tables).
    Mieplot,
    /// Sun-disc-convolved linear-sRGB lookup vs angle, `.csv` or `.png` (phase-function tables).
    RgbLut,
}

#[derive(clap::Args, Debug)]
struct ExportArgs {
    /// Table file (.sbt).
    file: PathBuf,
    #[arg(long, value_enum)]
    format: ExportFormat,
    /// Output file (required for csv/json/exr; stdout otherwise when omitted).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Entry selection NAME=VALUE per entry axis (phase formats; default: first sample of each).
    #[arg(long = "entry", value_name = "NAME=VALUE")]
    entry: Vec<scatterbake::consumers::read::phase::EntrySelection>,
    /// Wavelength in nm (phase formats).
    #[arg(long)]
    wavelength_nm: Option<f64>,
    /// Highest Legendre order (legendre).
    #[arg(long, default_value_t = 64)]
    order: usize,
    /// Delta-M truncation of the Legendre moments (legendre).
    #[arg(long)]
    delta_m: bool,
    /// Report the Legendre truncation error over θ ≥ this angle in deg (legendre; default 0,
    /// or 5 with --delta-m).
    #[arg(long)]
    error_from_deg: Option<f64>,
    /// What to export for Mitsuba (mitsuba).
    #[arg(long, default_value = "rgb", value_parser = crate::commands::named::<scatterbake::consumers::export::mitsuba::MitsubaMode>(&scatterbake::consumers::export::mitsuba::MitsubaMode::NAMES))]
    mode: scatterbake::consumers::export::mitsuba::MitsubaMode,
    /// Number of tabphase values, uniform in cos θ (mitsuba).
    #[arg(long, default_value_t = 4096)]
    samples: usize,
    /// Also write the plain tabphase value lists here (mitsuba).
    #[arg(long)]
    values_out: Option<PathBuf>,
    /// Sun disc angular diameter in degrees (rgb-lut). Default: the disc the table already
    /// averaged over (attribute `sun_diameter_deg`), 0.5 for a point-sun table.
    #[arg(long)]
    sun_diameter_deg: Option<f64>,
}

fn run_export(a: ExportArgs) -> Result<()> {
    use crate::commands::{legendre, mieplot, mitsuba};
    use scatterbake::consumers::export::generic::GenericFormat;
    let generic = match a.format {
        ExportFormat::Csv => Some(GenericFormat::Csv),
        ExportFormat::Json => Some(GenericFormat::Json),
        ExportFormat::Exr => Some(GenericFormat::Exr),
        _ => None,
    };
    if let Some(format) = generic {
        let out = a
            .out
            .ok_or_else(|| anyhow::anyhow!("--out is required for --format csv|json|exr"))?;
        let t = Table::open(&a.file)?;
        scatterbake::consumers::export::generic::export(&t, format, &out)?;
        println!("wrote {}", out.display());
        return Ok(());
    }
    match a.format {
        ExportFormat::Mitsuba => mitsuba::run_mitsuba(&mitsuba::MitsubaArgs {
            table: a.file,
            entry: a.entry,
            mode: a.mode,
            wavelength_nm: a.wavelength_nm,
            samples: a.samples,
            out: a.out,
            values_out: a.values_out,
        }),
        ExportFormat::Legendre => legendre::run_legendre(&legendre::LegendreArgs {
            table: a.file,
            entry: a.entry,
            order: a.order,
            delta_m: a.delta_m,
            error_from_deg: a.error_from_deg,
            wavelength_nm: a.wavelength_nm,
            out: a.out,
        }),
        ExportFormat::RgbLut => crate::commands::lut::run_lut(&crate::commands::lut::LutArgs {
            table: a.file,
            entry: a.entry,
            samples: if a.samples == 4096 { 7201 } else { a.samples },
            sun_diameter_deg: a.sun_diameter_deg,
            out: a.out.ok_or_else(|| {
                anyhow::anyhow!("--out (.exr, .png or .csv) is required for rgb-lut")
            })?,
        }),
        ExportFormat::Mieplot => mieplot::run_mieplot(&mieplot::MiePlotArgs {
            table: a.file,
            entry: a.entry,
            wavelength_nm: a.wavelength_nm,
            out: a.out,
        }),
        _ => unreachable!("generic formats handled above"),
    }
}

/// Entry point; returns the process exit code.
fn run_cli() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { 2 } else { 0 };
        }
    };
    match run(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            1
        }
    }
}

fn run(cmd: Command) -> Result<i32> {
    match cmd {
        Command::Build(a) => crate::commands::build::run_build(a),
        Command::Inspect(a) => crate::commands::table::run_inspect(&a).map(|_| 0),
        Command::Verify(a) => crate::commands::table::run_verify(&a),
        Command::Export(a) => run_export(a).map(|_| 0),
        Command::Plot(a) => crate::commands::plot::run_plot(&a).map(|_| 0),
        Command::PlotRaytrace(a) => {
            crate::commands::plot_raytrace::run_plot_raytrace(&a).map(|_| 0)
        }
        Command::Render(RenderCommand::Rainbow(a)) => {
            crate::commands::render::run_render_rainbow(&a).map(|_| 0)
        }
        Command::Mie(a) => crate::commands::debye::run_debye(&a).map(|_| 0),
        Command::Raytrace(a) => crate::commands::raytrace::run_raytrace(&a).map(|_| 0),
        Command::Airy(a) => crate::commands::debye::run_airy(&a).map(|_| 0),
        Command::Medulla(a) => crate::commands::medulla::run_medulla(&a).map(|_| 0),
        Command::MedullaAssets(a) => crate::commands::medulla::run_medulla_assets(&a).map(|_| 0),
        Command::HairLut(a) => crate::commands::hair::run_hair_lut(&a).map(|_| 0),
        Command::HairJson(a) => crate::commands::hair::run_dual_scattering(&a).map(|_| 0),
        Command::Cloth(a) => crate::commands::cloth::run_cloth(&a).map(|_| 0),
        Command::Validate(a) => crate::commands::mieplot::run_validate(&a).map(|_| 0),
        Command::Stages => crate::commands::table::run_stages().map(|_| 0),
        Command::Catalog(a) => crate::commands::table::run_catalog(&a),
    }
}

fn main() {
    // A reader that stops early (`scatterbake stages | head -1`) closes our stdout; `println!`
    // then panics with "failed printing to stdout: Broken pipe". That is not an error of ours:
    // exit 0 without a message, as `head`'s other producers do.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !is_broken_pipe(info.payload()) {
            default_hook(info);
        }
    }));
    let code = match std::panic::catch_unwind(run_cli) {
        Ok(code) => code,
        Err(payload) if is_broken_pipe(payload.as_ref()) => 0,
        Err(_) => 101,
    };
    std::process::exit(code);
}

/// Whether a panic payload is the standard library's "stdout closed by the reader" panic.
fn is_broken_pipe(payload: &(dyn std::any::Any + Send)) -> bool {
    let message = payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
        .unwrap_or("");
    message.starts_with("failed printing to stdout") && message.contains("Broken pipe")
}
