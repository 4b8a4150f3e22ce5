//! The `scatterbake` command line. Argument parsing (clap) and error reporting (anyhow) live
//! here only; every command calls library functions of the `scatterbake` crate that take and
//! return plain structs. Every failure prints `error: …` naming the problem and where, and exits
//! non-zero; nothing panics on bad input.

mod commands;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use scatterbake::pipeline::{BuildOptions, Shard, build};
use scatterbake::table::{AxisPoints, Table};
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
    Build {
        /// Manifest files; default: every *.toml directly in manifests/.
        manifests: Vec<PathBuf>,
        /// Output directory.
        #[arg(long, default_value = "tables")]
        out: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Compute only shard I of N (I/N, 0-based); default from SLURM_ARRAY_TASK_ID/COUNT or
        /// JOB_COMPLETION_INDEX + SCATTERBAKE_SHARD_COUNT.
        #[arg(long)]
        shard: Option<String>,
        /// Recompute even if up-to-date tables or checkpoints exist.
        #[arg(long)]
        force: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
        /// Do not draw preview pictures into OUT/previews/.
        #[arg(long)]
        no_previews: bool,
    },
    /// Show a table's header, axes, channels, provenance and sizes.
    Inspect {
        file: PathBuf,
        /// Print the raw JSON header.
        #[arg(long)]
        json: bool,
    },
    /// Verify tables (checksums, sizes, structure); non-zero exit if any is bad.
    Verify {
        #[arg(required = true)]
        files: Vec<PathBuf>,
        /// Treat NaN, infinite or negative samples of a phase-function table as errors
        /// (default: warnings).
        #[arg(long)]
        strict: bool,
        /// Largest uncompressed payload to accept, in bytes (default 4 GiB).
        #[arg(long, value_name = "BYTES")]
        max_payload_bytes: Option<u64>,
    },
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
    /// Hair Dual Scattering table → engine EXR LUT (layout and shader lookup in docs/hair.md).
    HairLut(crate::commands::hair::HairLutArgs),
    /// Dual Scattering averages for one hair parameter set, as JSON or CSV.
    #[command(name = "dual-scattering", visible_alias = "hair-json")]
    HairJson(crate::commands::hair::DualScatteringArgs),
    /// Compare a phase-function table with a MiePlot-style reference text file.
    Validate(crate::commands::mieplot::ValidateArgs),
    /// List stages with their parameters and defaults.
    Stages,
    /// Rebuild DIR/index.json from the tables in DIR (after sharded builds).
    Catalog {
        #[arg(default_value = "tables")]
        dir: PathBuf,
    },
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
        Command::Build {
            manifests,
            out,
            jobs,
            shard,
            force,
            quiet,
            no_previews,
        } => {
            let manifests = if manifests.is_empty() {
                scatterbake::manifest::default_manifests(std::path::Path::new("manifests"))
                    .context(
                        "listing manifests/ (run from the repository root or name manifests)",
                    )?
            } else {
                manifests
            };
            if manifests.is_empty() {
                bail!("no manifests to build");
            }
            if jobs == Some(0) {
                bail!("--jobs must be at least 1");
            }
            let shard = match shard {
                Some(s) => Some(Shard::parse(&s)?),
                None => Shard::from_env()?,
            };
            let t0 = std::time::Instant::now();
            let report = build(&BuildOptions {
                manifests,
                out_dir: out.clone(),
                jobs,
                shard,
                force,
                quiet,
            })?;
            if !no_previews {
                draw_previews(&out, &report.tables_written);
            }
            println!(
                "built {} table(s), {} up to date, {} pending other shards; tasks: {} computed, {} reused from checkpoints; {:.1} s; catalog {}",
                report.tables_written.len(),
                report.tables_up_to_date.len(),
                report.tables_pending.len(),
                report.tasks_computed,
                report.tasks_reused,
                t0.elapsed().as_secs_f64(),
                out.join("index.json").display()
            );
            Ok(0)
        }
        Command::Inspect { file, json } => {
            let t = Table::open(&file)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&t.header)?);
            } else {
                print_summary(&file, &t)?;
            }
            Ok(0)
        }
        Command::Verify {
            files,
            strict,
            max_payload_bytes,
        } => {
            let mut limits = scatterbake::table::ReadLimits::default();
            if let Some(m) = max_payload_bytes {
                limits.max_payload_bytes = m;
            }
            let mut bad = 0;
            for f in &files {
                match scatterbake::table::verify_file(f, &limits) {
                    Ok(v) => {
                        let problems = value_problems(&v);
                        let n: usize = v.header.layout.shape.iter().product();
                        if problems.is_empty() {
                            println!("ok   {} ({}, {n} values)", f.display(), v.header.schema);
                        } else if strict {
                            bad += 1;
                            eprintln!("BAD  {}: {}", f.display(), problems.join("; "));
                        } else {
                            println!("ok   {} ({}, {n} values)", f.display(), v.header.schema);
                            eprintln!("warning: {}: {}", f.display(), problems.join("; "));
                        }
                    }
                    Err(e) => {
                        bad += 1;
                        eprintln!("BAD  {e}");
                    }
                }
            }
            if bad > 0 {
                eprintln!(
                    "error: {bad} of {} file(s) failed verification",
                    files.len()
                );
                Ok(1)
            } else {
                Ok(0)
            }
        }
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
        Command::HairLut(a) => crate::commands::hair::run_hair_lut(&a).map(|_| 0),
        Command::HairJson(a) => crate::commands::hair::run_dual_scattering(&a).map(|_| 0),
        Command::Validate(a) => crate::commands::mieplot::run_validate(&a).map(|_| 0),
        Command::Stages => {
            for s in scatterbake::stages::registry() {
                println!(
                    "{} (algorithm v{}): {}",
                    s.name(),
                    s.algorithm_version(),
                    s.summary()
                );
                for p in s.parameters() {
                    println!("    {:<24} {:<28} default: {}", p.name, p.kind, p.default);
                    println!("    {:<24} {}", "", p.description);
                }
                println!();
            }
            Ok(0)
        }
        Command::Catalog { dir } => {
            let c = scatterbake::catalog::rebuild(&dir)?;
            println!(
                "{}: {} table(s), {} invalid",
                dir.join("index.json").display(),
                c.tables.len(),
                c.invalid.len()
            );
            for (f, why) in &c.invalid {
                eprintln!("invalid: {f}: {why}");
            }
            Ok(if c.invalid.is_empty() { 0 } else { 1 })
        }
    }
}

/// Preview pictures of freshly written tables into `OUT/previews/`. Pictures are a
/// convenience: a failure is reported and the table stays valid.
fn draw_previews(out: &std::path::Path, tables: &[String]) {
    for name in tables {
        let path = scatterbake::pipeline::table_path(out, name);
        if let Err(e) =
            scatterbake::consumers::plot::previews::previews(&path, &out.join("previews"))
        {
            eprintln!("warning: previews of {name}: {:#}", anyhow::Error::from(e));
        }
    }
}

/// Samples a phase-function table (one with a `phase` channel) must not hold: NaN or infinite
/// values in any channel, negative values in `phase`, `i_perp`, `i_par`.
fn value_problems(v: &scatterbake::table::Verified) -> Vec<String> {
    let h = &v.header;
    if !h.channels.iter().any(|c| c.name == "phase") {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (i, c) in h.channels.iter().enumerate() {
        let s = &v.values;
        if s.nan[i] > 0 {
            out.push(format!(
                "channel `{}` has {} NaN value(s)",
                c.name, s.nan[i]
            ));
        }
        if s.infinite[i] > 0 {
            out.push(format!(
                "channel `{}` has {} infinite value(s)",
                c.name, s.infinite[i]
            ));
        }
        if ["phase", "i_perp", "i_par"].contains(&c.name.as_str()) && s.negative[i] > 0 {
            out.push(format!(
                "channel `{}` has {} negative value(s)",
                c.name, s.negative[i]
            ));
        }
    }
    out
}

/// A header string made safe for a terminal: control characters (escape sequences, carriage
/// returns, newlines, bidirectional overrides) are shown escaped, e.g. `\u{1b}`.
fn esc(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_control()
                || ('\u{202a}'..='\u{202e}').contains(&c)
                || ('\u{2066}'..='\u{2069}').contains(&c)
            {
                c.escape_unicode().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

fn print_summary(file: &std::path::Path, t: &Table) -> Result<()> {
    let h = &t.header;
    let size = std::fs::metadata(file)?.len();
    println!("file:        {}", esc(&file.display().to_string()));
    println!("schema:      {}", esc(&h.schema.to_string()));
    println!("description: {}", esc(&h.description));
    println!(
        "layout:      {} {} shape {:?} ({})",
        h.layout.order,
        h.layout.dtype,
        h.layout.shape,
        esc(&h.layout.axis_order.join(" × "))
    );
    println!(
        "size:        {} bytes on disk, payload {} → {} bytes zstd ({:.1}×)",
        size,
        h.payload.uncompressed_bytes,
        h.payload.compressed_bytes,
        h.payload.uncompressed_bytes as f64 / h.payload.compressed_bytes.max(1) as f64
    );
    println!("axes:");
    for a in &h.axes {
        let desc = match &a.points {
            AxisPoints::Uniform { start, step, count } => {
                format!("uniform {start} + k·{step}, k < {count}")
            }
            AxisPoints::Values(v) if v.len() <= 8 => format!("{v:?}"),
            AxisPoints::Values(v) => format!("{} values {} … {}", v.len(), v[0], v[v.len() - 1]),
        };
        println!("  {:<20} [{}] {}", esc(&a.name), esc(&a.unit), desc);
    }
    println!("channels:");
    for c in &h.channels {
        println!(
            "  {:<20} [{}] {}",
            esc(&c.name),
            esc(&c.unit),
            esc(&c.meaning)
        );
    }
    println!("attributes:");
    for (k, v) in &h.attributes {
        let s = v.to_string();
        let s = if s.len() > 100 {
            format!("{}…", &s[..s.floor_char_boundary(100)])
        } else {
            s
        };
        println!("  {}: {}", esc(k), esc(&s));
    }
    let p = &h.provenance;
    println!("provenance:");
    println!(
        "  tool:        {} {} (commit {})",
        esc(&p.tool),
        esc(&p.tool_version),
        esc(p.git_commit.as_deref().unwrap_or("unknown"))
    );
    println!(
        "  manifest:    {} entry {}",
        esc(p.manifest.as_deref().unwrap_or("-")),
        esc(p.entry.as_deref().unwrap_or("-"))
    );
    println!("  stage:       {}", esc(p.stage.as_deref().unwrap_or("-")));
    println!("  parameters:  {}", p.parameters);
    println!("  digest:      {}", esc(&p.parameters_digest));
    println!("  created:     {}", esc(&p.created_utc));
    Ok(())
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
