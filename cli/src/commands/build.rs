//! `scatterbake build`: manifests into tables, then preview pictures.

use anyhow::{Context, Result, bail};
use scatterbake::pipeline::{BuildOptions, Shard, build};
use std::path::{Path, PathBuf};

/// Arguments of `scatterbake build`.
#[derive(clap::Args, Debug)]
pub struct BuildArgs {
    /// Manifest files; default: every *.toml directly in manifests/.
    pub manifests: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "tables")]
    pub out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Compute only shard I of N (I/N, 0-based); default from SLURM_ARRAY_TASK_ID/COUNT or
    /// JOB_COMPLETION_INDEX + SCATTERBAKE_SHARD_COUNT.
    #[arg(long)]
    pub shard: Option<String>,
    /// Recompute even if up-to-date tables or checkpoints exist.
    #[arg(long)]
    pub force: bool,
    /// No progress (a bar on a terminal, one line per table or step on stderr otherwise).
    #[arg(long, short)]
    pub quiet: bool,
    /// Do not draw preview pictures into OUT/previews/.
    #[arg(long)]
    pub no_previews: bool,
    /// Do not write the browsable catalog page OUT/index.html (`scatterbake catalog --html`).
    #[arg(long)]
    pub no_html: bool,
    /// Compute nothing: print each table's tasks, axes, size (uncompressed and estimated on
    /// disk) and estimated CPU time, and the totals.
    #[arg(long)]
    pub plan: bool,
    /// With --plan: print the plan as JSON (keys `tables`, `total_bytes`, …).
    #[arg(long, requires = "plan")]
    pub json: bool,
}

/// Run a build; returns the exit code.
pub fn run_build(a: BuildArgs) -> Result<i32> {
    let manifests = manifests_to_build(a.manifests)?;
    if a.plan {
        return print_plan(&manifests, a.json);
    }
    if a.jobs == Some(0) {
        bail!("--jobs must be at least 1");
    }
    let shard = match a.shard {
        Some(s) => Some(Shard::parse(&s)?),
        None => Shard::from_env()?,
    };
    let t0 = std::time::Instant::now();
    let progress = crate::progress::TerminalProgress::new("build", a.quiet);
    let report = build(
        &BuildOptions {
            manifests,
            out_dir: a.out.clone(),
            jobs: a.jobs,
            shard,
            force: a.force,
        },
        &progress,
    )?;
    for c in &report.checkpoints_rejected {
        eprintln!("warning: checkpoint {c}");
    }
    if !a.no_previews {
        draw_previews(&a.out, &report.tables_written);
    }
    if let (false, Some(catalog)) = (a.no_html, &report.catalog) {
        // The catalog the build just wrote: the directory is not listed a second time.
        let opts = scatterbake::consumers::catalog_page::PageOptions::default();
        super::catalog::write_page(&a.out, catalog, &opts)?;
    }
    println!(
        "built {} table(s), {} up to date, {} pending other shards; tasks: {} computed, {} reused from checkpoints; {:.1} s; catalog {}",
        report.tables_written.len(),
        report.tables_up_to_date.len(),
        report.tables_pending.len(),
        report.tasks_computed,
        report.tasks_reused,
        t0.elapsed().as_secs_f64(),
        crate::display::path(&a.out.join("index.json"))
    );
    Ok(0)
}

/// The manifests named on the command line, or every `*.toml` directly in `manifests/`.
fn manifests_to_build(named: Vec<PathBuf>) -> Result<Vec<PathBuf>> {
    let manifests = if named.is_empty() {
        scatterbake::manifest::default_manifests(Path::new("manifests"))
            .context("listing manifests/ (run from the repository root or name manifests)")?
    } else {
        named
    };
    if manifests.is_empty() {
        bail!("no manifests to build");
    }
    Ok(manifests)
}

/// Preview pictures of freshly written tables into `OUT/previews/`. Pictures are a
/// convenience: a failure is reported and the table stays valid.
fn draw_previews(out: &Path, tables: &[String]) {
    for name in tables {
        let path = scatterbake::pipeline::table_path(out, name);
        if let Err(e) =
            scatterbake::consumers::plot::previews::previews(&path, &out.join("previews"))
        {
            eprintln!("warning: previews of {name}: {:#}", anyhow::Error::from(e));
        }
    }
}

/// `build --plan`: the plan as a table on stdout, or as JSON.
fn print_plan(manifests: &[PathBuf], json: bool) -> Result<i32> {
    let plan = scatterbake::plan::plan_build(manifests)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&plan)?);
        return Ok(0);
    }
    println!(
        "{:<36} {:>6} {:>11} {:>11} {:>10}  axes × channels",
        "table", "tasks", "values", "on disk", "CPU"
    );
    for t in &plan.tables {
        let axes: Vec<String> = t
            .axes
            .iter()
            .map(|a| format!("{} {}", a.name, a.len))
            .collect();
        println!(
            "{:<36} {:>6} {:>11} {:>11} {:>10}  {} × {} ch",
            t.name,
            t.tasks,
            t.values,
            human_bytes(t.estimated_bytes),
            human_seconds(t.estimated_cpu_s),
            axes.join(" × "),
            t.channels
        );
    }
    println!(
        "total: {} table(s), {} tasks, {} uncompressed, ≈ {} on disk, ≈ {} CPU (≈ {} wall on {} core(s))",
        plan.tables.len(),
        plan.total_tasks,
        human_bytes(plan.total_payload_bytes),
        human_bytes(plan.total_bytes),
        human_seconds(plan.total_cpu_s),
        human_seconds(plan.total_cpu_s / cores() as f64),
        cores()
    );
    Ok(0)
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// Bytes with a binary unit (KiB, MiB, GiB, TiB).
fn human_bytes(b: u64) -> String {
    let mut v = b as f64;
    for unit in ["B", "KiB", "MiB", "GiB"] {
        if v < 1024.0 {
            return if unit == "B" {
                format!("{b} B")
            } else {
                format!("{v:.1} {unit}")
            };
        }
        v /= 1024.0;
    }
    format!("{v:.1} TiB")
}

/// Seconds as s, min or h.
fn human_seconds(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.1} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}
