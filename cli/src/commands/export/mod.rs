//! `scatterbake export`: a table as CSV, JSON or EXR (any table), or a phase-function table as a
//! Mitsuba `tabphase` snippet, Legendre moments, a MiePlot-style text table or an sRGB lookup
//! table (one file per format below).

pub mod legendre;
pub mod mieplot;
pub mod mitsuba;
pub mod rgb_lut;

use anyhow::{Context as _, Result, bail};
use scatterbake::table::Table;
use std::path::PathBuf;

/// Every export format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
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
    /// Sun-disc-averaged linear-sRGB lookup texture vs angle, `.exr`, `.png` or `.csv`
    /// (phase-function tables).
    RgbLut,
}

/// Arguments of `scatterbake export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// Table file (.sbt).
    file: PathBuf,
    /// Output format: csv, json, exr for any table; mitsuba, legendre, mieplot, rgb-lut for
    /// 1-D phase-function tables.
    #[arg(long, value_enum)]
    format: ExportFormat,
    /// Output file: required for csv, json, exr and rgb-lut (.exr, .png or .csv); mitsuba,
    /// legendre and mieplot write to stdout when it is omitted.
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
    #[arg(long, default_value = "rgb", value_parser = crate::args::named::<scatterbake::consumers::export::mitsuba::MitsubaMode>(&scatterbake::consumers::export::mitsuba::MitsubaMode::NAMES))]
    mode: scatterbake::consumers::export::mitsuba::MitsubaMode,
    /// Number of samples: tabphase values uniform in cos θ (mitsuba; default 4096), or rows
    /// uniform in angle over [0, 180]° (rgb-lut; default 7201, 0.025° apart).
    #[arg(long)]
    samples: Option<usize>,
    /// Also write the plain tabphase value lists here (mitsuba).
    #[arg(long)]
    values_out: Option<PathBuf>,
    /// Sun disc angular diameter in degrees (rgb-lut). Default: the disc the table already
    /// averaged over (attribute `sun_diameter_deg`), 0.5 for a point-sun table.
    #[arg(long)]
    sun_diameter_deg: Option<f64>,
}

/// The name of `format` on the command line.
fn format_name(format: ExportFormat) -> String {
    use clap::ValueEnum as _;
    format
        .to_possible_value()
        .map(|v| v.get_name().to_string())
        .unwrap_or_default()
}

/// Refuse a phase-function format for a table that does not follow the phase contract, before
/// any work, saying what the table is and which formats apply to it (reads the header only).
fn check_phase_format(file: &std::path::Path, format: ExportFormat) -> Result<()> {
    let header = scatterbake::table::read_header_only(file)?;
    if let Err(why) = scatterbake::consumers::read::phase::PhaseTable::check_header(&header) {
        bail!(
            "--format {} applies to 1-D phase-function tables (axes … × wavelength × \
             scattering_angle, channels phase, i_perp, i_par: schemas mie-phase, debye-phase, \
             raytrace-phase, mixture-phase); {} is a `{}/{}` table ({why}). Formats for any \
             table: csv, json, exr",
            format_name(format),
            crate::display::path(file),
            header.schema.name,
            header.schema.version
        );
    }
    Ok(())
}

pub fn run_export(a: ExportArgs) -> Result<()> {
    use scatterbake::consumers::export::generic::GenericFormat;
    if a.samples.is_some() && !matches!(a.format, ExportFormat::Mitsuba | ExportFormat::RgbLut) {
        bail!("--samples applies to --format mitsuba and rgb-lut only");
    }
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
        scatterbake::consumers::export::generic::export(&t, format, &out).with_context(|| {
            format!(
                "exporting {} as {}",
                crate::display::path(&a.file),
                format_name(a.format)
            )
        })?;
        println!("wrote {}", crate::display::path(&out));
        return Ok(());
    }
    check_phase_format(&a.file, a.format)?;
    match a.format {
        ExportFormat::Mitsuba => mitsuba::run_mitsuba(&mitsuba::MitsubaArgs {
            table: a.file,
            entry: a.entry,
            mode: a.mode,
            wavelength_nm: a.wavelength_nm,
            samples: a.samples.unwrap_or(mitsuba::DEFAULT_SAMPLES),
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
        ExportFormat::RgbLut => rgb_lut::run_lut(&rgb_lut::LutArgs {
            table: a.file,
            entry: a.entry,
            samples: a.samples.unwrap_or(rgb_lut::DEFAULT_SAMPLES),
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: ExportArgs,
    }

    /// `--samples` is the number asked for, whatever the format's default; formats without
    /// samples refuse it.
    #[test]
    fn samples_are_honoured_or_refused() {
        let dir = tempfile::tempdir().unwrap();
        let table = dir.path().join("hg.sbt");
        let mut t = scatterbake::fixtures::henyey_greenstein_table(
            &[450.0, 550.0, 650.0],
            &[1.0],
            |_, _| 0.7,
            1801,
            0.0,
        );
        scatterbake::table::write_table_atomic(&mut t, &table).unwrap();
        let out = dir.path().join("lut.csv");
        let export = |extra: &[&str]| {
            let mut argv = vec!["t", table.to_str().unwrap(), "--out", out.to_str().unwrap()];
            argv.extend(extra);
            run_export(Cli::parse_from(argv).args)
        };
        let rows = || {
            let text = std::fs::read_to_string(&out).unwrap();
            text.lines().filter(|l| !l.starts_with('#')).count() - 1
        };
        for (extra, want) in [
            (&["--samples", "4096"][..], 4096),
            (&[], rgb_lut::DEFAULT_SAMPLES),
        ] {
            let mut argv = vec!["--format", "rgb-lut"];
            argv.extend(extra);
            export(&argv).unwrap();
            assert_eq!(rows(), want, "{extra:?}");
        }
        let err = export(&["--format", "csv", "--samples", "10"]).unwrap_err();
        assert!(err.to_string().contains("--samples applies to"), "{err}");
    }
}
