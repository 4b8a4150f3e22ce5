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
}

/// Run a build; returns the exit code.
pub fn run_build(a: BuildArgs) -> Result<i32> {
    let manifests = manifests_to_build(a.manifests)?;
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
