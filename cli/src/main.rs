//! The `scatterbake` command line. Argument parsing (clap) and error reporting (anyhow) live
//! here only; every command calls library functions of the `scatterbake` crate that take and
//! return plain structs. Every failure prints `error: …` naming the problem and where, and exits
//! non-zero; nothing panics on bad input.

mod args;
mod commands;
#[cfg(test)]
mod consumer_tests;
mod curve;
mod display;
mod progress;

use anyhow::Result;
use clap::{Parser, Subcommand};
use commands::*;

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
    Build(build::BuildArgs),
    /// Show a table's header, axes, channels, provenance and sizes.
    Inspect(inspect::InspectArgs),
    /// Verify tables (checksums, sizes, structure); non-zero exit if any is bad.
    Verify(verify::VerifyArgs),
    /// Export a table: csv|json|exr (any table) or mitsuba|legendre|mieplot|rgb-lut (phase
    /// functions).
    Export(export::ExportArgs),
    /// Plot a table (phase function, rainbow colour strip, Lee diagram, 2-D maps) to PNG/SVG.
    Plot(plot::PlotArgs),
    /// Plot 2-D ray-traced tables (raytrace-phase-2d): bows near the rainbows per outgoing
    /// azimuth with colour strips (several tables = several radii), or a lat-long map.
    PlotRaytrace(plot_raytrace::PlotRaytraceArgs),
    /// Render a picture through the public table reader API.
    #[command(subcommand)]
    Render(RenderCommand),
    /// Lorenz–Mie scattering of one sphere (MiePlot-style columns); `--debye-orders` selects
    /// Debye-series terms.
    Mie(mie::MieCommandArgs),
    /// Patch-based wave-optics ray tracing of one drop (sphere or Beard–Chuang) at one wavelength.
    Raytrace(raytrace::RaytraceArgs),
    /// Airy theory of the primary or secondary rainbow (same columns as `mie`).
    Airy(airy::AiryArgs),
    /// Fur medulla scattering profile for one (σ, g, entry) by Monte Carlo, as CSV or JSON.
    Medulla(medulla::MedullaArgs),
    /// Compress the dense thesis-grid medulla tables into the shipped assets (docs/fur.md).
    MedullaAssets(medulla_assets::MedullaAssetsArgs),
    /// Hair Dual Scattering table → engine EXR LUT (layout and shader lookup in docs/hair.md).
    HairLut(hair_lut::HairLutArgs),
    /// Cloth BRDF table → engine textures (DDS 3-D texture, warp, albedo; layout and shader
    /// lookup in docs/cloth.md).
    ClothLut(cloth_lut::ClothLutArgs),
    /// Dual Scattering averages for one hair parameter set, as JSON or CSV.
    #[command(visible_alias = "hair-json")]
    DualScattering(dual_scattering::DualScatteringArgs),
    /// Cloth BRDF (Sadeghi et al. 2013 microcylinder model) of a fabric preset at one pair of
    /// directions, with its surface and volume lobes.
    Cloth(cloth::ClothArgs),
    /// Compare a phase-function table with a MiePlot-style reference text file.
    Validate(validate::ValidateArgs),
    /// List stages with their parameters and defaults.
    Stages,
    /// Rebuild DIR/index.json from the tables in DIR (after sharded builds).
    Catalog(catalog::CatalogArgs),
}

/// What `render` can draw.
#[derive(Subcommand, Debug)]
enum RenderCommand {
    /// Spectral single-scattering rainbow in a rain volume, sun importance-sampled as a disc.
    Rainbow(render::RenderRainbowArgs),
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
            eprintln!(
                "error: {}",
                display::lines(&scatterbake::error::error_chain(e.as_ref()))
            );
            1
        }
    }
}

fn run(cmd: Command) -> Result<i32> {
    match cmd {
        Command::Build(a) => build::run_build(a),
        Command::Inspect(a) => inspect::run_inspect(&a).map(|_| 0),
        Command::Verify(a) => verify::run_verify(&a),
        Command::Export(a) => export::run_export(a).map(|_| 0),
        Command::Plot(a) => plot::run_plot(&a).map(|_| 0),
        Command::PlotRaytrace(a) => plot_raytrace::run_plot_raytrace(&a).map(|_| 0),
        Command::Render(RenderCommand::Rainbow(a)) => render::run_render_rainbow(&a).map(|_| 0),
        Command::Mie(a) => mie::run_mie(&a).map(|_| 0),
        Command::Raytrace(a) => raytrace::run_raytrace(&a).map(|_| 0),
        Command::Airy(a) => airy::run_airy(&a).map(|_| 0),
        Command::Medulla(a) => medulla::run_medulla(&a).map(|_| 0),
        Command::MedullaAssets(a) => medulla_assets::run_medulla_assets(&a).map(|_| 0),
        Command::HairLut(a) => hair_lut::run_hair_lut(&a).map(|_| 0),
        Command::ClothLut(a) => cloth_lut::run_cloth_lut(&a).map(|_| 0),
        Command::DualScattering(a) => dual_scattering::run_dual_scattering(&a).map(|_| 0),
        Command::Cloth(a) => cloth::run_cloth(&a).map(|_| 0),
        Command::Validate(a) => validate::run_validate(&a).map(|_| 0),
        Command::Stages => stages::run_stages().map(|_| 0),
        Command::Catalog(a) => catalog::run_catalog(&a),
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

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// Each subcommand has its own file (or directory) under `cli/src/commands/`, named after
    /// it, and nothing else lives there.
    #[test]
    fn every_command_has_one_file_named_after_it() {
        let commands: std::collections::BTreeSet<String> = super::Cli::command()
            .get_subcommands()
            .map(|c| c.get_name().replace('-', "_"))
            .filter(|name| name != "help")
            .collect();
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/commands");
        let files: std::collections::BTreeSet<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| !p.ends_with("mod.rs"))
            .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(files, commands);
    }

    /// Every option and argument of every command (and subcommand) says what it is in `--help`.
    #[test]
    fn every_argument_has_help_text() {
        fn walk(cmd: &clap::Command, path: &str, missing: &mut Vec<String>) {
            for a in cmd.get_arguments() {
                let id = a.get_id().as_str();
                if a.is_hide_set() || id == "help" || id == "version" {
                    continue;
                }
                if a.get_help().is_none_or(|h| h.to_string().trim().is_empty()) {
                    missing.push(format!("{path} {id}"));
                }
            }
            for sub in cmd.get_subcommands() {
                walk(sub, &format!("{path} {}", sub.get_name()), missing);
            }
        }
        let mut missing = Vec::new();
        walk(&super::Cli::command(), "scatterbake", &mut missing);
        assert!(missing.is_empty(), "arguments without help: {missing:?}");
    }

    /// The summary of `export` names every format `--format` takes.
    #[test]
    fn export_summary_names_every_format() {
        let cli = super::Cli::command();
        let export = cli.find_subcommand("export").unwrap();
        let summary = export.get_about().unwrap().to_string();
        let format = export
            .get_arguments()
            .find(|a| a.get_id() == "format")
            .unwrap();
        for v in format.get_possible_values() {
            assert!(
                summary.contains(v.get_name()),
                "`{}` missing from: {summary}",
                v.get_name()
            );
        }
    }
}
