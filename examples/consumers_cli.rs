//! Stand-alone front end for the consumer commands, wired the way `scatterbake`'s CLI should
//! wire them (until the lead's `cli.rs` does):
//!
//! ```text
//! cargo run --profile test --example consumers_cli -- export-mitsuba  TABLE [--mode rgb] ...
//! cargo run --profile test --example consumers_cli -- export-legendre TABLE --order 64 ...
//! cargo run --profile test --example consumers_cli -- export-mieplot  TABLE --wavelength-nm 650 ...
//! cargo run --profile test --example consumers_cli -- export-rgb-lut  TABLE --out lut.csv
//! cargo run --profile test --example consumers_cli -- validate        TABLE --reference F.txt
//! cargo run --profile test --example consumers_cli -- plot            TABLE --kind phase --out F.png
//! cargo run --profile test --example consumers_cli -- render-rainbow  --table T --out sky.png
//! ```

use clap::{Parser, Subcommand};
use scatterbake::consumers::{legendre, lut, mieplot, mitsuba, plot, render};

#[derive(Parser)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    ExportMitsuba(mitsuba::MitsubaArgs),
    ExportLegendre(legendre::LegendreArgs),
    ExportMieplot(mieplot::MiePlotArgs),
    ExportRgbLut(lut::LutArgs),
    Validate(mieplot::ValidateArgs),
    Plot(plot::PlotArgs),
    RenderRainbow(render::RenderRainbowArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().cmd {
        Cmd::ExportMitsuba(a) => mitsuba::run_mitsuba(&a),
        Cmd::ExportLegendre(a) => legendre::run_legendre(&a),
        Cmd::ExportMieplot(a) => mieplot::run_mieplot(&a),
        Cmd::ExportRgbLut(a) => lut::run_lut(&a),
        Cmd::Validate(a) => mieplot::run_validate(&a),
        Cmd::Plot(a) => plot::run_plot(&a),
        Cmd::RenderRainbow(a) => render::run_render_rainbow(&a),
    }
}
