//! The build pipeline: manifests → tasks → checkpoints → tables → catalog.
//!
//! - **Tasks.** Every manifest entry is planned by its stage into independent tasks. All pending
//!   tasks of a build run in one rayon pool (`--jobs`), in a deterministic global order.
//! - **Content keys.** A table's key is SHA-256 of the canonical JSON of
//!   `{stage, algorithm_version, parameters}`; a task's key adds the task's index and parameters.
//!   A table whose file exists, verifies, and carries the same key is skipped (`--force`
//!   recomputes).
//! - **Resume.** Each finished task is written atomically as a checkpoint
//!   `<out>/.work/<table>/<task-key>.chunk` (bincode: key, SHA-256, values). A rerun reuses valid
//!   checkpoints, so killing a build at any moment loses at most the tasks in flight, and the
//!   tables produced are byte-identical to an uninterrupted build (set `SOURCE_DATE_EPOCH` to
//!   make the creation time identical too). When its last task finishes, a table is assembled,
//!   written atomically, and its checkpoints are removed.
//! - **Sharding.** `--shard I/N` (or `SLURM_ARRAY_TASK_ID`/`SLURM_ARRAY_TASK_COUNT`, or
//!   `JOB_COMPLETION_INDEX` with a count) computes only global tasks `k` with `k mod N = I`.
//!   Whichever shard finds all checkpoints of a table present assembles it; `scatterbake
//!   catalog` (or a plain `build`) afterwards assembles anything left and rebuilds the catalog.
//! - **Concurrency.** Two builds on one output directory are safe by per-task atomicity:
//!   checkpoints and tables are written by rename of a complete temporary file, contents are
//!   deterministic, a missing checkpoint at assembly time is recomputed, and the catalog is
//!   rewritten under an exclusive lock on `<out>/.lock`. They may duplicate work, never corrupt.

use crate::manifest::{PlannedTable, load_manifest};
use crate::table::format::write_atomic;
use crate::table::{Provenance, Table, write_table_atomic};
use anyhow::{Context, Result, anyhow, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Which part of the global task list this process computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// 0-based shard index.
    pub index: usize,
    /// Number of shards (≥ 1).
    pub count: usize,
}

impl Shard {
    /// Parse `I/N`.
    pub fn parse(s: &str) -> Result<Shard> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| anyhow!("--shard must be I/N (e.g. 0/4), got `{s}`"))?;
        let index: usize = i
            .trim()
            .parse()
            .map_err(|_| anyhow!("--shard: `{i}` is not a number"))?;
        let count: usize = n
            .trim()
            .parse()
            .map_err(|_| anyhow!("--shard: `{n}` is not a number"))?;
        if count == 0 || index >= count {
            bail!("--shard {index}/{count}: need 0 <= I < N");
        }
        Ok(Shard { index, count })
    }

    /// Shard from the environment: Slurm job arrays (`SLURM_ARRAY_TASK_ID`,
    /// `SLURM_ARRAY_TASK_COUNT`, ids assumed 0-based — use `--array=0-(N-1)`), or a Kubernetes
    /// Indexed Job (`JOB_COMPLETION_INDEX` with `SCATTERBAKE_SHARD_COUNT` giving N).
    pub fn from_env() -> Result<Option<Shard>> {
        let get = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        if let (Some(i), None) = (get("SLURM_ARRAY_TASK_ID"), get("SLURM_ARRAY_TASK_COUNT")) {
            bail!(
                "SLURM_ARRAY_TASK_ID is set ({i}) but SLURM_ARRAY_TASK_COUNT is not: pass --shard I/N"
            );
        }
        if let (Some(i), Some(n)) = (get("SLURM_ARRAY_TASK_ID"), get("SLURM_ARRAY_TASK_COUNT")) {
            return Shard::parse(&format!("{i}/{n}"))
                .map(Some)
                .context("from SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT");
        }
        if let Some(i) = get("JOB_COMPLETION_INDEX") {
            let n = get("SCATTERBAKE_SHARD_COUNT").ok_or_else(|| {
                anyhow!("JOB_COMPLETION_INDEX is set but SCATTERBAKE_SHARD_COUNT (the Job's completions) is not")
            })?;
            return Shard::parse(&format!("{i}/{n}"))
                .map(Some)
                .context("from JOB_COMPLETION_INDEX/SCATTERBAKE_SHARD_COUNT");
        }
        Ok(None)
    }
}

/// Options of `scatterbake build`.
#[derive(Debug, Clone)]
pub struct BuildOptions {
    pub manifests: Vec<PathBuf>,
    pub out_dir: PathBuf,
    pub jobs: Option<usize>,
    pub shard: Option<Shard>,
    pub force: bool,
    pub quiet: bool,
}

/// What a build did.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct BuildReport {
    /// Tables already up to date.
    pub tables_up_to_date: Vec<String>,
    /// Tables written by this build.
    pub tables_written: Vec<String>,
    /// Tables left incomplete (other shards' tasks missing).
    pub tables_pending: Vec<String>,
    /// Tasks computed by this build.
    pub tasks_computed: usize,
    /// Tasks reused from checkpoints.
    pub tasks_reused: usize,
}

fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// Canonical JSON (keys sorted, no whitespace) used for content keys.
pub fn canonical_json(v: &serde_json::Value) -> String {
    // serde_json::Map is a BTreeMap without the `preserve_order` feature: keys are sorted.
    serde_json::to_string(v).expect("JSON values serialise")
}

/// The content key of a planned table.
pub fn table_key(t: &PlannedTable) -> String {
    sha256_hex(
        canonical_json(&serde_json::json!({
            "stage": t.stage.name(),
            "algorithm_version": t.stage.algorithm_version(),
            "parameters": t.job.parameters(),
        }))
        .as_bytes(),
    )
}

fn task_key(table_key: &str, index: usize, params: &serde_json::Value) -> String {
    sha256_hex(
        canonical_json(&serde_json::json!({
            "table_key": table_key,
            "task_index": index,
            "task_parameters": params,
        }))
        .as_bytes(),
    )
}

#[derive(Serialize, Deserialize)]
struct Checkpoint {
    key: String,
    sha256: String,
    values: Vec<f32>,
}

fn bincode_config() -> bincode::config::Configuration {
    bincode::config::standard()
}

fn read_checkpoint(path: &Path, key: &str) -> Option<Vec<f32>> {
    let bytes = std::fs::read(path).ok()?;
    let (c, used): (Checkpoint, usize) =
        bincode::serde::decode_from_slice(&bytes, bincode_config()).ok()?;
    (used == bytes.len()
        && c.key == key
        && crate::workdir::checkpoint_hash(key, &c.values) == c.sha256)
        .then_some(c.values)
}

fn write_checkpoint(path: &Path, key: &str, values: &[f32]) -> Result<()> {
    let c = Checkpoint {
        key: key.to_string(),
        sha256: crate::workdir::checkpoint_hash(key, values),
        values: values.to_vec(),
    };
    let bytes = bincode::serde::encode_to_vec(&c, bincode_config())?;
    write_checkpoint_bytes(path, &bytes)
        .with_context(|| format!("writing checkpoint {}", path.display()))
}

/// Write a checkpoint atomically, retrying when a concurrent build that finished the table
/// removed its work directory in between (the directory is recreated).
fn write_checkpoint_bytes(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut attempt = 0;
    loop {
        if let Some(dir) = path.parent() {
            crate::workdir::refuse_symlink(dir).map_err(std::io::Error::other)?;
        }
        match write_atomic(path, bytes) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && attempt < 8 => attempt += 1,
            r => return r,
        }
    }
}

/// Creation time for provenance: `SOURCE_DATE_EPOCH` when set (reproducible builds), else now.
pub fn creation_time() -> String {
    let t = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .map(|s| std::time::UNIX_EPOCH + std::time::Duration::from_secs(s))
        .unwrap_or_else(std::time::SystemTime::now);
    humantime::format_rfc3339_seconds(t).to_string()
}

/// Git commit of the tool's source tree, when known at build time.
pub fn git_commit() -> Option<String> {
    let c = env!("SCATTERBAKE_GIT_COMMIT");
    (!c.is_empty()).then(|| c.to_string())
}

/// Provenance for a planned table.
pub fn provenance(t: &PlannedTable, key: &str) -> Provenance {
    Provenance {
        tool: "scatterbake".into(),
        tool_version: env!("CARGO_PKG_VERSION").into(),
        git_commit: git_commit(),
        manifest: Some(t.manifest.display().to_string()),
        entry: Some(t.name.clone()),
        stage: Some(format!(
            "{}@{}",
            t.stage.name(),
            t.stage.algorithm_version()
        )),
        parameters: t.job.parameters(),
        parameters_digest: key.to_string(),
        created_utc: creation_time(),
    }
}

/// Path of a table in an output directory.
pub fn table_path(out_dir: &Path, name: &str) -> PathBuf {
    out_dir.join(format!("{name}.sbt"))
}

fn up_to_date(path: &Path, key: &str) -> bool {
    match crate::table::read_header_only(path) {
        Ok(h) if h.provenance.parameters_digest == key => Table::open(path).is_ok(),
        _ => false,
    }
}

struct TableState {
    planned: PlannedTable,
    key: String,
    task_keys: Vec<String>,
    task_labels: Vec<String>,
    work_dir: PathBuf,
    remaining: AtomicUsize,
}

/// Optional artificial delay after each task (milliseconds), from
/// `SCATTERBAKE_TEST_TASK_DELAY_MS`. A test hook used by the interrupt/resume test to make
/// builds slow enough to kill mid-way; it never changes results.
fn test_delay() -> Option<std::time::Duration> {
    std::env::var("SCATTERBAKE_TEST_TASK_DELAY_MS")
        .ok()
        .and_then(|s| s.parse::<u64>().ok())
        .map(std::time::Duration::from_millis)
}

/// Under the lock on `<out>/.lock`, assemble every table this build did not write whose
/// checkpoints are now all present (written by other shards or concurrent builds), unless
/// another build already wrote it: whichever shard finishes last assembles every complete table.
fn assemble_completed(
    states: &[TableState],
    finish_table: &(dyn Fn(&TableState) -> Result<()> + Sync),
    written: &Mutex<Vec<String>>,
    errors: &Mutex<Vec<String>>,
    out_dir: &Path,
) -> Result<()> {
    let _lock = crate::workdir::lock_out_dir(out_dir)?;
    for s in states {
        if written.lock().expect("lock").contains(&s.planned.name) {
            continue;
        }
        if up_to_date(&table_path(out_dir, &s.planned.name), &s.key) {
            continue;
        }
        let complete = s
            .task_keys
            .iter()
            .all(|k| read_checkpoint(&s.work_dir.join(format!("{k}.chunk")), k).is_some());
        if complete && let Err(e) = finish_table(s) {
            errors
                .lock()
                .expect("lock")
                .push(format!("{}: {e:#}", s.planned.name));
        }
    }
    Ok(())
}

/// Run a build.
pub fn build(opts: &BuildOptions) -> Result<BuildReport> {
    let mut planned = Vec::new();
    for m in &opts.manifests {
        for t in load_manifest(m)? {
            if let Some(prev) = planned.iter().find(|p: &&PlannedTable| p.name == t.name) {
                bail!(
                    "table `{}` is defined twice: in {} and in {}",
                    t.name,
                    prev.manifest.display(),
                    t.manifest.display()
                );
            }
            planned.push(t);
        }
    }
    std::fs::create_dir_all(&opts.out_dir)
        .with_context(|| format!("creating output directory {}", opts.out_dir.display()))?;
    crate::workdir::check_out_dir(&opts.out_dir)?;

    let mut report = BuildReport::default();
    let mut states = Vec::new();
    for t in planned {
        let key = table_key(&t);
        let path = table_path(&opts.out_dir, &t.name);
        if !opts.force && up_to_date(&path, &key) {
            report.tables_up_to_date.push(t.name.clone());
            continue;
        }
        let tasks = t.job.tasks();
        let task_keys = tasks
            .iter()
            .enumerate()
            .map(|(i, s)| task_key(&key, i, &s.params))
            .collect::<Vec<_>>();
        let task_labels = tasks.into_iter().map(|s| s.label).collect();
        let work_dir = opts.out_dir.join(".work").join(&t.name);
        crate::workdir::refuse_symlink(&work_dir)?;
        states.push(TableState {
            remaining: AtomicUsize::new(task_keys.len()),
            planned: t,
            key,
            task_keys,
            task_labels,
            work_dir,
        });
    }

    // Global task list: (table, task) in deterministic order; shard by global index.
    let mut pending = Vec::new();
    let mut global = 0usize;
    for (ti, s) in states.iter().enumerate() {
        for (k, key) in s.task_keys.iter().enumerate() {
            let mine = opts.shard.is_none_or(|sh| global % sh.count == sh.index);
            global += 1;
            let ck = s.work_dir.join(format!("{key}.chunk"));
            let done = !opts.force && read_checkpoint(&ck, key).is_some();
            if done {
                report.tasks_reused += 1;
                s.remaining.fetch_sub(1, Ordering::SeqCst);
            } else if mine {
                pending.push((ti, k));
            }
        }
    }
    if opts.force {
        for s in &states {
            crate::workdir::remove_table_work_dir(&s.work_dir)?;
        }
    }

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs.unwrap_or(0))
        .build()
        .context("creating the thread pool")?;
    let bar = ProgressBar::new(pending.len() as u64);
    if opts.quiet || !std::io::stdout().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(
            "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} tasks, eta {eta} {msg}",
        )
        .expect("valid template"),
    );
    bar.set_prefix("build");
    let errors = Mutex::new(Vec::<String>::new());
    let written = Mutex::new(Vec::<String>::new());
    let computed = AtomicUsize::new(0);
    let delay = test_delay();

    // Tables whose tasks were all reused can be assembled right away.
    let finish_table = |s: &TableState| -> Result<()> {
        let chunks = s
            .task_keys
            .iter()
            .enumerate()
            .map(|(i, key)| {
                let ck = s.work_dir.join(format!("{key}.chunk"));
                match read_checkpoint(&ck, key) {
                    Some(v) => Ok(v),
                    // Removed by a concurrent build that finished this table, or corrupt.
                    None => s.planned.job.run_task(i),
                }
            })
            .collect::<Result<Vec<_>>>()?;
        let mut content = s.planned.job.assemble(chunks)?;
        if let Some(d) = &s.planned.description {
            content
                .attributes
                .insert("manifest_description".into(), d.clone().into());
        }
        let mut table = Table::from_content(content, provenance(&s.planned, &s.key))?;
        let path = table_path(&opts.out_dir, &s.planned.name);
        write_table_atomic(&mut table, &path)?;
        crate::workdir::remove_table_work_dir(&s.work_dir)?;
        written.lock().expect("lock").push(s.planned.name.clone());
        Ok(())
    };

    pool.install(|| {
        states
            .par_iter()
            .filter(|s| s.remaining.load(Ordering::SeqCst) == 0)
            .for_each(|s| {
                if let Err(e) = finish_table(s) {
                    errors
                        .lock()
                        .expect("lock")
                        .push(format!("{}: {e:#}", s.planned.name));
                }
            });
        pending.par_iter().for_each(|&(ti, k)| {
            let s = &states[ti];
            let label = &s.task_labels[k];
            let result = s.planned.job.run_task(k).and_then(|values| {
                write_checkpoint(
                    &s.work_dir.join(format!("{}.chunk", s.task_keys[k])),
                    &s.task_keys[k],
                    &values,
                )
            });
            if let Some(d) = delay {
                std::thread::sleep(d);
            }
            computed.fetch_add(1, Ordering::SeqCst);
            bar.inc(1);
            match result {
                Err(e) => errors
                    .lock()
                    .expect("lock")
                    .push(format!("{} task {k} ({label}): {e:#}", s.planned.name)),
                Ok(()) => {
                    if s.remaining.fetch_sub(1, Ordering::SeqCst) == 1 {
                        bar.set_message(format!("writing {}", s.planned.name));
                        if let Err(e) = finish_table(s) {
                            errors
                                .lock()
                                .expect("lock")
                                .push(format!("{}: {e:#}", s.planned.name));
                        }
                    }
                }
            }
        });
    });
    bar.finish_and_clear();
    assemble_completed(&states, &finish_table, &written, &errors, &opts.out_dir)?;

    report.tasks_computed = computed.load(Ordering::SeqCst);
    report.tables_written = written.into_inner().expect("lock");
    report.tables_written.sort();
    for s in &states {
        if !report.tables_written.contains(&s.planned.name) {
            report.tables_pending.push(s.planned.name.clone());
        }
    }
    // Leave no empty work directory behind (ignore failure: another build may be using it).
    let _ = std::fs::remove_dir(opts.out_dir.join(".work"));
    crate::catalog::rebuild(&opts.out_dir)?;
    let errors = errors.into_inner().expect("lock");
    if !errors.is_empty() {
        bail!(
            "{} task(s) failed:\n  {}",
            errors.len(),
            errors.join("\n  ")
        );
    }
    Ok(report)
}
