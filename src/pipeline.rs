//! The build pipeline: manifests → tasks → checkpoints → tables → catalog.
//!
//! - **Tasks.** Every manifest entry is planned by its stage into independent tasks. All pending
//!   tasks of a build run in one rayon pool (`--jobs`), in a deterministic global order.
//! - **Content keys.** A table's key is SHA-256 of the canonical JSON of
//!   `{stage, algorithm_version, parameters}`; a task's key adds the task's index and parameters.
//!   A table whose file exists, verifies, and carries the same key is skipped (`--force`
//!   recomputes).
//! - **Resume.** Each finished task is written atomically as a checkpoint
//!   `<out>/.work/<table>/<task-key>.chunk` (bincode: checkpoint format, task key, HMAC-SHA-256
//!   of the task key and chunk under the directory's secret `<out>/.checkpoint-key`, the chunk's
//!   values and scalars). A rerun reuses valid checkpoints; a checkpoint of another format, or
//!   one that is truncated, belongs to another task, fails its keyed hash (edited, forged, or
//!   copied from another directory) or has the wrong number of values or scalars is named in
//!   the report and its task recomputed. So killing a build at any moment loses at most the tasks in flight, and the
//!   tables produced are byte-identical to an uninterrupted build (set `SOURCE_DATE_EPOCH` to
//!   make the creation time identical too). When its last task finishes, a table is assembled,
//!   written atomically, and its checkpoints are removed. The task that completes a table hands
//!   its values to the assembly in memory, and a table of **one task** writes no checkpoint at
//!   all: the table file is its checkpoint (for the 1.1 GB tables of the seed-resolution ray
//!   tracer the round trip through `.work` cost more CPU than the rasteriser). Killing such a
//!   build while it writes the table loses that one task, as for any task in flight.
//! - **Sharding.** `--shard I/N` (or `SLURM_ARRAY_TASK_ID`/`SLURM_ARRAY_TASK_COUNT`, or
//!   `JOB_COMPLETION_INDEX` with a count) computes only global tasks `k` with `k mod N = I`,
//!   `k` counting the tasks of every planned table (also those already up to date, so shards
//!   that start after a table was written agree on the numbering). Every shard, before it
//!   exits, assembles under the lock each table whose checkpoints are all present, so the last
//!   shard leaves every table built and the catalog current; a plain `build` afterwards
//!   computes only what a failed shard left.
//! - **Progress.** A build reports its tasks and each table's steps (up to date, computing,
//!   writing, written, waiting for other shards, failed) to a [`Progress`]; it draws nothing.
//! - **Concurrency.** Two builds on one output directory are safe by per-task atomicity:
//!   checkpoints and tables are written by rename of a complete temporary file, contents are
//!   deterministic, a missing checkpoint at assembly time is recomputed, and the catalog is
//!   rewritten under an exclusive lock on `<out>/.lock`. They may duplicate work, never corrupt.

use crate::catalog::CatalogError;
use crate::error::{IoError, error_chain};
use crate::manifest::{ManifestError, PlannedTable, load_manifest};
use crate::progress::{Progress, TableStep};
use crate::stages::{Chunk, JobError};
use crate::table::format::write_atomic;
use crate::table::{Provenance, Table, TableError, write_table_atomic_sealed};
use crate::workdir::CheckpointKey;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Directory under the output directory that holds the checkpoints, one folder per table.
pub const WORK_DIR: &str = ".work";
/// File extension of a task checkpoint, `<task-key>.chunk`.
pub const CHECKPOINT_EXTENSION: &str = "chunk";
/// Bytes per GiB, for messages.
const GIB: f64 = (1u64 << 30) as f64;
/// Attempts at writing a checkpoint whose work directory a concurrent build removed.
const CHECKPOINT_RETRIES: usize = 8;
/// Thread count that lets rayon choose (one per CPU), used when `--jobs` is not given.
const DEFAULT_THREADS: usize = 0;

/// Why a shard specification is unusable.
#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("--shard must be I/N (e.g. 0/4), got `{0}`")]
    Syntax(String),
    #[error("--shard: `{text}` is not a number")]
    NotANumber {
        text: String,
        #[source]
        source: std::num::ParseIntError,
    },
    #[error("--shard {index}/{count}: need 0 <= I < N")]
    OutOfRange { index: usize, count: usize },
    #[error(
        "JOB_COMPLETION_INDEX is set but SCATTERBAKE_SHARD_COUNT (the Job's completions) is not"
    )]
    MissingCount,
    /// A Slurm array task id without the array size.
    #[error("SLURM_ARRAY_TASK_ID is set ({0}) but SLURM_ARRAY_TASK_COUNT is not: pass --shard I/N")]
    SlurmMissingCount(String),
    /// A shard taken from environment variables (named) that does not parse.
    #[error("from {variables}")]
    Environment {
        variables: &'static str,
        #[source]
        source: Box<ShardError>,
    },
}

/// Why a build failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A symlinked work, lock or catalog path, or a lock that cannot be taken.
    #[error(transparent)]
    Workdir(#[from] crate::workdir::WorkdirError),
    /// A manifest that does not read or plan (the error gives FILE:LINE:COLUMN).
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    #[error("table `{name}` is defined twice: in {} and in {}", first.display(), second.display())]
    DuplicateTable {
        name: String,
        first: PathBuf,
        second: PathBuf,
    },
    /// A file or directory operation of the build.
    #[error(transparent)]
    Io(#[from] IoError),
    #[error("creating the thread pool")]
    ThreadPool(#[source] rayon::ThreadPoolBuildError),
    #[error(transparent)]
    Shard(#[from] ShardError),
    /// A task's computation or a table's assembly.
    #[error(transparent)]
    Job(#[from] JobError),
    #[error("encoding checkpoint {}", path.display())]
    CheckpointEncode {
        path: PathBuf,
        #[source]
        source: bincode::error::EncodeError,
    },
    /// Making or writing a table file (the error names the file when there is one).
    #[error(transparent)]
    Table(#[from] TableError),
    /// One task of a table (its index and label) and why it failed.
    #[error("{table} task {index} ({label})")]
    Task {
        table: String,
        index: usize,
        label: String,
        #[source]
        source: Box<PipelineError>,
    },
    /// Assembling or writing a table whose tasks are all done.
    #[error("{table}")]
    Finish {
        table: String,
        #[source]
        source: Box<PipelineError>,
    },
    #[error(transparent)]
    Catalog(#[from] CatalogError),
    /// A planned table larger than the reader accepts, refused before any task runs.
    #[error(
        "table `{name}` ({}) would hold {bytes} bytes of values ({:.1} GiB), more than the \
         reader's limit of {limit} bytes ({:.1} GiB): reduce its grid or split it into several \
         tables",
        manifest.display(),
        *bytes as f64 / GIB,
        *limit as f64 / GIB
    )]
    TableTooLarge {
        name: String,
        manifest: PathBuf,
        bytes: u64,
        limit: u64,
    },
    /// Every task or table that failed (each with its cause chain); the others were built.
    #[error("{} failure(s):\n  {}", .0.len(), .0.iter().map(|e| error_chain(e)).collect::<Vec<_>>().join("\n  "))]
    Failed(Vec<PipelineError>),
}

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
    pub fn parse(s: &str) -> Result<Shard, ShardError> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| ShardError::Syntax(s.to_string()))?;
        let number = |t: &str| {
            t.trim()
                .parse::<usize>()
                .map_err(|source| ShardError::NotANumber {
                    text: t.to_string(),
                    source,
                })
        };
        let (index, count) = (number(i)?, number(n)?);
        if count == 0 || index >= count {
            return Err(ShardError::OutOfRange { index, count });
        }
        Ok(Shard { index, count })
    }

    /// Shard from the environment: Slurm job arrays (`SLURM_ARRAY_TASK_ID`,
    /// `SLURM_ARRAY_TASK_COUNT`, ids assumed 0-based — use `--array=0-(N-1)`), or a Kubernetes
    /// Indexed Job (`JOB_COMPLETION_INDEX` with `SCATTERBAKE_SHARD_COUNT` giving N).
    pub fn from_env() -> Result<Option<Shard>, ShardError> {
        let get = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
        if let (Some(i), None) = (get("SLURM_ARRAY_TASK_ID"), get("SLURM_ARRAY_TASK_COUNT")) {
            return Err(ShardError::SlurmMissingCount(i));
        }
        let parse = |i: String, n: String, variables: &'static str| {
            Shard::parse(&format!("{i}/{n}"))
                .map(Some)
                .map_err(|e| ShardError::Environment {
                    variables,
                    source: Box::new(e),
                })
        };
        if let (Some(i), Some(n)) = (get("SLURM_ARRAY_TASK_ID"), get("SLURM_ARRAY_TASK_COUNT")) {
            return parse(i, n, "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT");
        }
        if let Some(i) = get("JOB_COMPLETION_INDEX") {
            let n = get("SCATTERBAKE_SHARD_COUNT").ok_or(ShardError::MissingCount)?;
            return parse(i, n, "JOB_COMPLETION_INDEX/SCATTERBAKE_SHARD_COUNT");
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
}

/// What a build did.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct BuildReport {
    /// Tables already up to date, or written meanwhile by another shard or concurrent build.
    pub tables_up_to_date: Vec<String>,
    /// Tables written by this build.
    pub tables_written: Vec<String>,
    /// Tables left incomplete (other shards' tasks missing).
    pub tables_pending: Vec<String>,
    /// Tasks computed by this build.
    pub tasks_computed: usize,
    /// Tasks reused from checkpoints.
    pub tasks_reused: usize,
    /// Checkpoints not used (each `PATH: why`); their tasks were recomputed.
    pub checkpoints_rejected: Vec<String>,
    /// The output directory's catalog as this build left it (`index.json`), for consumers
    /// that present it (the catalog page) without listing the directory again.
    pub catalog: Option<crate::catalog::Catalog>,
}

/// The content key of a planned table ([`crate::provenance::content_key`]).
pub fn table_key(t: &PlannedTable) -> String {
    crate::provenance::content_key(
        t.stage.name(),
        t.stage.algorithm_version(),
        &t.job.parameters(),
    )
}

/// The key of task `index` of the table with content key `table_key`.
fn task_key(table_key: &str, index: usize, params: &serde_json::Value) -> String {
    crate::provenance::json_key(&serde_json::json!({
        "table_key": table_key,
        "task_index": index,
        "task_parameters": params,
    }))
}

/// Version of the checkpoint encoding, the first field of every checkpoint: 2 stores a task's
/// [`Chunk`] (f32 values and f64 scalars). Files of any other version (version 1 had no version
/// field and stored the values only) are refused, never decoded, and their tasks recomputed.
pub const CHECKPOINT_FORMAT: u32 = 2;

/// A checkpoint as decoded, its strings borrowed from the file's bytes (so that a length
/// prefix is checked against the bytes present before anything is allocated).
#[derive(Deserialize)]
struct Checkpoint<'a> {
    /// [`CHECKPOINT_FORMAT`].
    format: u32,
    /// Task key.
    #[serde(borrow)]
    key: &'a str,
    /// HMAC-SHA-256 (hex) of the task key, values and scalars under the directory's secret.
    #[serde(borrow)]
    sha256: &'a str,
    values: Vec<f32>,
    scalars: Vec<f64>,
}

fn bincode_config() -> bincode::config::Configuration {
    bincode::config::standard()
}

/// Read the checkpoint of task `task_key` at `path`: `Ok(None)` when there is none, `Err(why)`
/// when the file exists but must not be used (another checkpoint format, truncated, trailing
/// bytes, another task's, or a keyed hash that does not match: edited, forged, or written under
/// another secret).
pub fn read_checkpoint(
    path: &Path,
    task_key: &str,
    secret: &CheckpointKey,
) -> Result<Option<Chunk>, String> {
    let bytes = match crate::table::read_regular(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("unreadable ({e})")),
    };
    // The format first, so that a file of another format is never decoded as this one.
    match bincode::serde::decode_from_slice::<u32, _>(&bytes, bincode_config()) {
        Ok((CHECKPOINT_FORMAT, _)) => {}
        _ => {
            return Err(format!(
                "not of checkpoint format {CHECKPOINT_FORMAT} (written by another version, or \
                 not a checkpoint)"
            ));
        }
    }
    // Strings borrowed from the file, so that a length prefix is checked against the bytes
    // present before anything is allocated (serde caps the preallocation of the vectors).
    let (c, used): (Checkpoint<'_>, usize) =
        bincode::serde::borrow_decode_from_slice(&bytes, bincode_config())
            .map_err(|e| format!("truncated or not a checkpoint ({} bytes: {e})", bytes.len()))?;
    if used != bytes.len() {
        return Err(format!(
            "wrong length: {} bytes, the checkpoint ends at byte {used}",
            bytes.len()
        ));
    }
    debug_assert_eq!(c.format, CHECKPOINT_FORMAT, "checked before decoding");
    if c.key != task_key {
        return Err("belongs to another task".into());
    }
    if crate::workdir::checkpoint_hash(secret, task_key, &c.values, &c.scalars) != c.sha256 {
        return Err(
            "its keyed hash does not match its values (edited, or written under another \
             checkpoint secret)"
                .into(),
        );
    }
    Ok(Some(Chunk::new(c.values, c.scalars)))
}

/// The encoding of a [`Checkpoint`] from a borrowed chunk (the same bytes, without copying the
/// values first).
#[derive(Serialize)]
struct CheckpointRef<'a> {
    format: u32,
    key: &'a str,
    sha256: String,
    values: &'a [f32],
    scalars: &'a [f64],
}

/// Write the checkpoint of task `task_key` (its chunk and their keyed hash) atomically at
/// `path`.
pub fn write_checkpoint(
    path: &Path,
    task_key: &str,
    secret: &CheckpointKey,
    chunk: &Chunk,
) -> Result<(), PipelineError> {
    let c = CheckpointRef {
        format: CHECKPOINT_FORMAT,
        key: task_key,
        sha256: crate::workdir::checkpoint_hash(secret, task_key, &chunk.values, &chunk.scalars),
        values: &chunk.values,
        scalars: &chunk.scalars,
    };
    let bytes = bincode::serde::encode_to_vec(&c, bincode_config()).map_err(|source| {
        PipelineError::CheckpointEncode {
            path: path.to_path_buf(),
            source,
        }
    })?;
    write_checkpoint_bytes(path, &bytes).map_err(IoError::doing("writing checkpoint", path))?;
    Ok(())
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
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && attempt < CHECKPOINT_RETRIES => {
                attempt += 1
            }
            r => return r,
        }
    }
}

/// Provenance for a planned table.
pub fn provenance(t: &PlannedTable, key: &str) -> Provenance {
    Provenance {
        tool: crate::provenance::TOOL.into(),
        tool_version: crate::provenance::TOOL_VERSION.into(),
        git_commit: crate::provenance::git_commit(),
        manifest: Some(t.manifest.display().to_string()),
        entry: Some(t.name.clone()),
        stage: Some(format!(
            "{}@{}",
            t.stage.name(),
            t.stage.algorithm_version()
        )),
        parameters: t.job.parameters(),
        parameters_digest: key.to_string(),
        created_utc: crate::provenance::creation_time(),
    }
}

/// Path of a table in an output directory.
pub fn table_path(out_dir: &Path, name: &str) -> PathBuf {
    out_dir.join(format!("{name}.sbt"))
}

/// The table at `path` has content key `key` in its own checksummed header (never the
/// catalog's word for it: an edited `index.json` cannot make a stale table current) and is sealed
/// as written: either it is the file the catalog `listed` lists at that path, unchanged since
/// (same size, modification and status change times, device and inode; a catalog lists only
/// tables that were sealed when it read or wrote them), or [`crate::table::verify_sealed`]
/// checks it now (checksummed compressed payload, not decompressed).
fn up_to_date(path: &Path, key: &str, listed: &crate::catalog::Listed) -> bool {
    // Only a regular file can be an up-to-date table: a FIFO or device planted under the
    // table's name is not opened by the reader (which would block on a FIFO), and is replaced
    // when the table is written.
    if crate::table::open_regular(path).is_err() {
        return false;
    }
    match crate::table::read_header_only(path) {
        Ok(h) if h.provenance.parameters_digest == key => {
            listed.unchanged(path).is_some() || crate::table::verify_sealed(path).is_ok()
        }
        _ => false,
    }
}

/// A table of the build that is not up to date: its plan, content key and tasks.
struct TableState {
    planned: PlannedTable,
    key: String,
    /// Global index of the table's first task, over every planned table (up to date or not).
    first_global: usize,
    task_keys: Vec<String>,
    task_labels: Vec<String>,
    work_dir: PathBuf,
    /// Tasks without a valid checkpoint yet; the task that brings it to 0 assembles the table.
    remaining: AtomicUsize,
}

impl TableState {
    fn checkpoint(&self, task: usize) -> PathBuf {
        self.work_dir
            .join(format!("{}.{CHECKPOINT_EXTENSION}", self.task_keys[task]))
    }

    /// The values of task `task` from its checkpoint, when there is a usable one; an unusable
    /// checkpoint is noted in `ctx`.
    fn read(&self, task: usize, ctx: &Context) -> Option<Chunk> {
        let path = self.checkpoint(task);
        read_checkpoint(&path, &self.task_keys[task], &ctx.secret).unwrap_or_else(|why| {
            ctx.reject(&path, why);
            None
        })
    }
}

/// What every step of one build shares: the checkpoint secret of the output directory and the
/// checkpoints found unusable (path → why, each reported once).
struct Context {
    secret: CheckpointKey,
    rejected: Mutex<std::collections::BTreeMap<PathBuf, String>>,
    /// Tables this build wrote, listed in the catalog without reading them back.
    fresh: Mutex<Vec<crate::catalog::FreshTable>>,
}

impl Context {
    fn reject(&self, path: &Path, why: String) {
        self.rejected
            .lock()
            .expect("lock")
            .entry(path.to_path_buf())
            .or_insert(why);
    }

    fn rejected(self) -> Vec<String> {
        let map = self.rejected.into_inner().expect("lock");
        map.into_iter()
            .map(|(p, why)| format!("{}: {why}; not used, its task is recomputed", p.display()))
            .collect()
    }
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
    finish: &(dyn Fn(&TableState) + Sync),
    written: &Mutex<Vec<String>>,
    out_dir: &Path,
    ctx: &Context,
) -> Result<(), PipelineError> {
    let _lock = crate::workdir::lock_out_dir(out_dir)?;
    let listed = crate::catalog::Listed::load(out_dir);
    for s in states {
        if written.lock().expect("lock").contains(&s.planned.name) {
            continue;
        }
        if up_to_date(&table_path(out_dir, &s.planned.name), &s.key, &listed) {
            continue;
        }
        let complete = (0..s.task_keys.len()).all(|k| s.read(k, ctx).is_some());
        if complete {
            finish(s);
        }
    }
    Ok(())
}

/// Run a build: plan, load checkpoints, run the pending tasks (assembling each table when its
/// last task is done), rebuild the catalog. Tasks and table steps are reported to `progress`.
pub fn build(opts: &BuildOptions, progress: &dyn Progress) -> Result<BuildReport, PipelineError> {
    let planned = plan_manifests(&opts.manifests)?;
    std::fs::create_dir_all(&opts.out_dir)
        .map_err(IoError::doing("creating output directory", &opts.out_dir))?;
    crate::workdir::check_out_dir(&opts.out_dir)?;
    let ctx = Context {
        secret: crate::workdir::checkpoint_key(&opts.out_dir)?,
        rejected: Mutex::default(),
        fresh: Mutex::default(),
    };
    let mut report = BuildReport::default();
    let states = plan_tables(planned, opts, &mut report, progress)?;
    let pending = load_checkpoints(&states, opts, &mut report, &ctx)?;
    let run = run_tasks(&states, &pending, opts, &ctx, progress)?;
    let fresh = std::mem::take(&mut *ctx.fresh.lock().expect("lock"));
    report.checkpoints_rejected = ctx.rejected();
    report.tasks_computed = run.computed;
    report.tables_written = run.written;
    report.tables_written.sort();
    sort_unwritten(&states, &opts.out_dir, &mut report, progress);
    let catalog = update_catalog(&opts.out_dir, &fresh).map(|c| report.catalog = Some(c));
    build_outcome(run.errors, catalog)?;
    Ok(report)
}

/// A table this build did not write is up to date when another shard or concurrent build wrote
/// it meanwhile (and reported so), else pending.
fn sort_unwritten(
    states: &[TableState],
    out_dir: &Path,
    report: &mut BuildReport,
    progress: &dyn Progress,
) {
    let listed = crate::catalog::Listed::load(out_dir);
    for s in states {
        let name = &s.planned.name;
        if report.tables_written.contains(name) {
            continue;
        }
        if up_to_date(&table_path(out_dir, name), &s.key, &listed) {
            progress.table(name, TableStep::UpToDate);
            report.tables_up_to_date.push(name.clone());
        } else {
            report.tables_pending.push(name.clone());
        }
    }
}

/// The outcome of a build from its task and table errors and the catalog update: a catalog
/// that cannot be written is reported with the task errors, never instead of them.
fn build_outcome(
    mut errors: Vec<PipelineError>,
    catalog: Result<(), PipelineError>,
) -> Result<(), PipelineError> {
    if let Err(e) = catalog {
        if errors.is_empty() {
            return Err(e);
        }
        errors.push(e);
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(PipelineError::Failed(errors))
    }
}

/// Plan every table of the manifests; a table name may appear only once across them, and a
/// table whose size is known at plan time must fit the reader's default limit.
pub(crate) fn plan_manifests(manifests: &[PathBuf]) -> Result<Vec<PlannedTable>, PipelineError> {
    let limit = crate::table::ReadLimits::default().max_payload_bytes;
    let mut planned: Vec<PlannedTable> = Vec::new();
    for m in manifests {
        for t in load_manifest(m)? {
            let bytes = t.job.payload_bytes();
            if bytes > limit {
                return Err(PipelineError::TableTooLarge {
                    name: t.name,
                    manifest: t.manifest,
                    bytes,
                    limit,
                });
            }
            if let Some(prev) = planned.iter().find(|p| p.name == t.name) {
                return Err(PipelineError::DuplicateTable {
                    name: t.name,
                    first: prev.manifest.clone(),
                    second: t.manifest,
                });
            }
            planned.push(t);
        }
    }
    Ok(planned)
}

/// Content and task keys of every planned table; tables whose file is up to date are only
/// reported (unless `--force`).
fn plan_tables(
    planned: Vec<PlannedTable>,
    opts: &BuildOptions,
    report: &mut BuildReport,
    progress: &dyn Progress,
) -> Result<Vec<TableState>, PipelineError> {
    let mut states = Vec::new();
    // Global task indices count the tasks of every planned table, up to date or not, so that
    // every shard divides the same list even when another shard has written a table meanwhile.
    let mut next_global = 0usize;
    let listed = crate::catalog::Listed::load(&opts.out_dir);
    for t in planned {
        let key = table_key(&t);
        let path = table_path(&opts.out_dir, &t.name);
        let tasks = t.job.tasks();
        let first_global = next_global;
        next_global += tasks.len();
        let work_dir = opts.out_dir.join(WORK_DIR).join(&t.name);
        if !opts.force && up_to_date(&path, &key, &listed) {
            // Checkpoints of a sealed table are of no use: a build killed between sealing the
            // table and removing them left them behind.
            crate::workdir::remove_table_work_dir(&work_dir)?;
            progress.table(&t.name, TableStep::UpToDate);
            report.tables_up_to_date.push(t.name.clone());
            continue;
        }
        let task_keys = tasks
            .iter()
            .enumerate()
            .map(|(i, s)| task_key(&key, i, &s.params))
            .collect::<Vec<_>>();
        let task_labels = tasks.into_iter().map(|s| s.label).collect();
        crate::workdir::refuse_symlink(&work_dir)?;
        states.push(TableState {
            first_global,
            remaining: AtomicUsize::new(task_keys.len()),
            planned: t,
            key,
            task_keys,
            task_labels,
            work_dir,
        });
    }
    Ok(states)
}

/// Count the tasks with a valid checkpoint as done (none with `--force`, which also removes
/// the old checkpoints) and return the other tasks of this shard, as (table, task) in the
/// deterministic global order the shards divide by index. A task whose checkpoint exists but
/// is unusable is recomputed by whichever shard finds it (results are deterministic).
fn load_checkpoints(
    states: &[TableState],
    opts: &BuildOptions,
    report: &mut BuildReport,
    ctx: &Context,
) -> Result<Vec<(usize, usize)>, PipelineError> {
    let mut pending = Vec::new();
    for (ti, s) in states.iter().enumerate() {
        for (k, key) in s.task_keys.iter().enumerate() {
            let global = s.first_global + k;
            let mine = opts.shard.is_none_or(|sh| global % sh.count == sh.index);
            let found = if opts.force {
                Ok(None)
            } else {
                read_checkpoint(&s.checkpoint(k), key, &ctx.secret)
            };
            match found {
                Ok(Some(_)) => {
                    report.tasks_reused += 1;
                    s.remaining.fetch_sub(1, Ordering::SeqCst);
                }
                Ok(None) if !mine => {}
                Ok(None) => pending.push((ti, k)),
                Err(why) => {
                    ctx.reject(&s.checkpoint(k), why);
                    pending.push((ti, k));
                }
            }
        }
    }
    if opts.force {
        for s in states {
            crate::workdir::remove_table_work_dir(&s.work_dir)?;
        }
    }
    Ok(pending)
}

/// What [`run_tasks`] did.
struct TaskRun {
    computed: usize,
    written: Vec<String>,
    errors: Vec<PipelineError>,
}

/// Run the pending tasks in one pool, writing a checkpoint per task; a table is assembled as
/// soon as its last task is done (right away when every task was reused). Failures are
/// collected, not fatal: the other tables still build.
fn run_tasks(
    states: &[TableState],
    pending: &[(usize, usize)],
    opts: &BuildOptions,
    ctx: &Context,
    progress: &dyn Progress,
) -> Result<TaskRun, PipelineError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs.unwrap_or(DEFAULT_THREADS))
        .build()
        .map_err(PipelineError::ThreadPool)?;
    let runner = TaskRunner::new(states, pending, &opts.out_dir, ctx, progress);
    progress.start(pending.len() as u64, "tasks");
    pool.install(|| {
        states
            .par_iter()
            .filter(|s| s.remaining.load(Ordering::SeqCst) == 0)
            .for_each(|s| runner.finish(s, None));
        pending
            .par_iter()
            .for_each(|&(ti, k)| runner.run_task(ti, k));
    });
    let finish = |s: &TableState| runner.finish(s, None);
    let assembled = assemble_completed(states, &finish, &runner.written, &opts.out_dir, ctx);
    progress.finish();
    assembled?;
    Ok(TaskRun {
        computed: runner.computed.load(Ordering::SeqCst),
        written: runner.written.into_inner().expect("lock"),
        errors: runner.errors.into_inner().expect("lock"),
    })
}

/// The tasks one process computes for one table, for the progress report.
struct TableTasks {
    /// Tasks of the table this process computes.
    here: usize,
    /// Of those, the ones not finished yet.
    left: AtomicUsize,
    /// The first has begun.
    started: AtomicBool,
    /// One failed.
    failed: AtomicBool,
}

/// What the tasks of one [`run_tasks`] share: the tables, where they go, the results so far and
/// where progress is reported.
struct TaskRunner<'a> {
    states: &'a [TableState],
    /// Per table of `states`.
    tables: Vec<TableTasks>,
    out_dir: &'a Path,
    ctx: &'a Context,
    progress: &'a dyn Progress,
    errors: Mutex<Vec<PipelineError>>,
    written: Mutex<Vec<String>>,
    computed: AtomicUsize,
    delay: Option<std::time::Duration>,
}

impl<'a> TaskRunner<'a> {
    fn new(
        states: &'a [TableState],
        pending: &[(usize, usize)],
        out_dir: &'a Path,
        ctx: &'a Context,
        progress: &'a dyn Progress,
    ) -> Self {
        let mut here = vec![0; states.len()];
        for &(ti, _) in pending {
            here[ti] += 1;
        }
        let tables = here
            .into_iter()
            .map(|n| TableTasks {
                here: n,
                left: AtomicUsize::new(n),
                started: AtomicBool::new(false),
                failed: AtomicBool::new(false),
            })
            .collect();
        TaskRunner {
            states,
            tables,
            out_dir,
            ctx,
            progress,
            errors: Mutex::default(),
            written: Mutex::default(),
            computed: AtomicUsize::new(0),
            delay: test_delay(),
        }
    }

    /// Compute task `k` of table `ti` and write its checkpoint; the task that completes the
    /// table assembles and writes it.
    fn run_task(&self, ti: usize, k: usize) {
        let (s, ctx) = (&self.states[ti], self.ctx);
        let tasks = &self.tables[ti];
        if !tasks.started.swap(true, Ordering::SeqCst) {
            let step = TableStep::Computing { tasks: tasks.here };
            self.progress.table(&s.planned.name, step);
        }
        // A one-task table is assembled from the values in memory, without a checkpoint.
        let one_task = s.task_keys.len() == 1;
        let result = s
            .planned
            .job
            .run_task(k)
            .map_err(PipelineError::from)
            .and_then(|values| {
                if !one_task {
                    write_checkpoint(&s.checkpoint(k), &s.task_keys[k], &ctx.secret, &values)?;
                }
                Ok(values)
            });
        if let Some(d) = self.delay {
            std::thread::sleep(d);
        }
        self.computed.fetch_add(1, Ordering::SeqCst);
        self.progress.advance(1);
        match result {
            Err(e) => {
                tasks.failed.store(true, Ordering::SeqCst);
                self.errors.lock().expect("lock").push(PipelineError::Task {
                    table: s.planned.name.clone(),
                    index: k,
                    label: s.task_labels[k].clone(),
                    source: Box::new(e),
                });
            }
            Ok(values) => {
                if s.remaining.fetch_sub(1, Ordering::SeqCst) == 1 {
                    self.finish(s, Some((k, values)));
                }
            }
        }
        self.task_done(ti);
    }

    /// After this process's last task of table `ti`: a table that is not complete (tasks of
    /// other shards missing, or one failed) is reported waiting or failed. The task that
    /// completes a table brings `remaining` to 0 before its own `left` count, so a table being
    /// written is never reported waiting.
    fn task_done(&self, ti: usize) {
        let (s, tasks) = (&self.states[ti], &self.tables[ti]);
        if tasks.left.fetch_sub(1, Ordering::SeqCst) == 1 && s.remaining.load(Ordering::SeqCst) != 0
        {
            let step = if tasks.failed.load(Ordering::SeqCst) {
                TableStep::Failed
            } else {
                TableStep::Waiting
            };
            self.progress.table(&s.planned.name, step);
        }
    }

    /// Assemble and write table `s` ([`finish_table`]), noting the result.
    fn finish(&self, s: &TableState, in_memory: Option<(usize, Chunk)>) {
        let name = &s.planned.name;
        self.progress.table(name, TableStep::Writing);
        match finish_table(s, in_memory, self.out_dir, self.ctx) {
            Ok(()) => {
                self.written.lock().expect("lock").push(name.clone());
                self.progress.table(name, TableStep::Written);
            }
            Err(e) => {
                self.errors
                    .lock()
                    .expect("lock")
                    .push(PipelineError::Finish {
                        table: name.clone(),
                        source: Box::new(e),
                    });
                self.progress.table(name, TableStep::Failed);
            }
        }
    }
}

/// Assemble a table whose tasks are all done from its checkpoints (recomputing any that a
/// concurrent build removed or that is unusable), write it atomically into `out_dir` and remove
/// its checkpoints. A checkpoint whose number of values the stage refuses (e.g. written by a
/// build with another layout) is named in the report and its task recomputed. `in_memory` is
/// the task just computed by this build (index, values): it is used as it is, not read back.
fn finish_table(
    s: &TableState,
    mut in_memory: Option<(usize, Chunk)>,
    out_dir: &Path,
    ctx: &Context,
) -> Result<(), PipelineError> {
    // Each pass reads every checkpoint; a task without a usable one is computed and its
    // checkpoint written. A pass ends with another pass only when the stage refused a chunk
    // read from a checkpoint, which is then replaced: at most one extra pass per task.
    let mut replaced = vec![false; s.task_keys.len()];
    let mut content = loop {
        let mut from_checkpoint = vec![false; s.task_keys.len()];
        let chunks = (0..s.task_keys.len())
            .map(|i| {
                if let Some((_, v)) = in_memory.take_if(|(k, _)| *k == i) {
                    return Ok(v);
                }
                match s.read(i, ctx) {
                    Some(v) => {
                        from_checkpoint[i] = true;
                        Ok(v)
                    }
                    None => recompute(s, i, ctx),
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        match crate::stages::assemble_checked(s.planned.job.as_ref(), chunks) {
            Err(JobError::ChunkLength {
                index,
                part,
                got,
                expected,
            }) if from_checkpoint.get(index) == Some(&true) && !replaced[index] => {
                ctx.reject(
                    &s.checkpoint(index),
                    format!("wrong length: {got} {part}, the table needs {expected}"),
                );
                replaced[index] = true;
                recompute(s, index, ctx)?;
            }
            r => break r?,
        }
    };
    if let Some(d) = &s.planned.description {
        content
            .attributes
            .insert("manifest_description".into(), d.clone().into());
    }
    let mut table = Table::from_content(content, provenance(&s.planned, &s.key))?;
    let path = table_path(out_dir, &s.planned.name);
    let written = write_table_atomic_sealed(&mut table, &path)?;
    ctx.fresh
        .lock()
        .expect("lock")
        .push(crate::catalog::FreshTable::new(
            &path,
            &table.header,
            written,
        ));
    crate::workdir::remove_table_work_dir(&s.work_dir)?;
    Ok(())
}

/// Compute task `task` of a table and write its checkpoint.
fn recompute(s: &TableState, task: usize, ctx: &Context) -> Result<Chunk, PipelineError> {
    let chunk = s.planned.job.run_task(task)?;
    write_checkpoint(&s.checkpoint(task), &s.task_keys[task], &ctx.secret, &chunk)?;
    Ok(chunk)
}

/// Remove the work directory if no table uses it any more (ignoring failure: another build
/// may be using it) and the temporary files killed builds left in `out_dir`
/// ([`crate::workdir::remove_orphan_temp_files`]), and rebuild the catalog of `out_dir`.
fn update_catalog(
    out_dir: &Path,
    fresh: &[crate::catalog::FreshTable],
) -> Result<crate::catalog::Catalog, PipelineError> {
    let _ = std::fs::remove_dir(out_dir.join(WORK_DIR));
    crate::workdir::remove_orphan_temp_files(out_dir);
    Ok(crate::catalog::rebuild_with(out_dir, fresh)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::error_chain;

    /// A chunk's values and scalars come back from its checkpoint bit for bit; a checkpoint of
    /// the first format (task key, keyed hash, values; no format field) is refused before it is
    /// decoded, and so is a file of a later format.
    #[test]
    fn checkpoints_round_trip_and_other_formats_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.chunk");
        let secret = CheckpointKey::from_bytes([7; 32]);
        let key = "k".repeat(64);
        let chunk = Chunk::new(vec![1.5, -0.0, f32::MIN_POSITIVE], vec![0.1, 1e300]);
        write_checkpoint(&path, &key, &secret, &chunk).unwrap();
        assert_eq!(read_checkpoint(&path, &key, &secret).unwrap(), Some(chunk));

        #[derive(Serialize)]
        struct FirstFormat<'a> {
            key: &'a str,
            sha256: String,
            values: Vec<f32>,
        }
        let old = FirstFormat {
            key: &key,
            sha256: "0".repeat(64),
            values: vec![1.0, 2.0],
        };
        std::fs::write(
            &path,
            bincode::serde::encode_to_vec(&old, bincode_config()).unwrap(),
        )
        .unwrap();
        let why = read_checkpoint(&path, &key, &secret).unwrap_err();
        assert!(why.contains("checkpoint format 2"), "{why}");

        let mut later =
            bincode::serde::encode_to_vec(CHECKPOINT_FORMAT + 1, bincode_config()).unwrap();
        later.extend(&std::fs::read(&path).unwrap());
        std::fs::write(&path, later).unwrap();
        assert!(read_checkpoint(&path, &key, &secret).is_err());
    }

    /// A checkpoint whose length prefixes declare more than any file holds (2^62 values, or a
    /// 2^62-byte task key) is refused as truncated, without allocating what it declares.
    #[test]
    fn checkpoints_declaring_huge_lengths_are_refused_without_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.chunk");
        let secret = CheckpointKey::from_bytes([7; 32]);
        let key = "k".repeat(64);
        let huge = {
            // bincode's standard varint: 0xFD then the u64 little-endian.
            let mut b = vec![0xFD];
            b.extend((1u64 << 62).to_le_bytes());
            b
        };
        let mut values_huge =
            bincode::serde::encode_to_vec(CHECKPOINT_FORMAT, bincode_config()).unwrap();
        values_huge.extend(bincode::serde::encode_to_vec(&key, bincode_config()).unwrap());
        values_huge
            .extend(bincode::serde::encode_to_vec("0".repeat(64), bincode_config()).unwrap());
        values_huge.extend(&huge);
        let mut key_huge =
            bincode::serde::encode_to_vec(CHECKPOINT_FORMAT, bincode_config()).unwrap();
        key_huge.extend(&huge);
        for bytes in [values_huge, key_huge] {
            std::fs::write(&path, &bytes).unwrap();
            let why = read_checkpoint(&path, &key, &secret).unwrap_err();
            assert!(why.contains("truncated"), "{why}");
        }
    }

    #[test]
    fn shard_errors_name_the_problem_and_the_source() {
        assert_eq!(
            Shard::parse(" 1 / 4").unwrap(),
            Shard { index: 1, count: 4 }
        );
        let e = Shard::parse("x/4").unwrap_err();
        assert_eq!(
            error_chain(&e),
            "--shard: `x` is not a number: invalid digit found in string"
        );
        assert!(matches!(
            Shard::parse("4/4"),
            Err(ShardError::OutOfRange { index: 4, count: 4 })
        ));
        assert!(matches!(Shard::parse("4"), Err(ShardError::Syntax(_))));
    }

    #[test]
    fn failed_build_lists_each_task_with_its_cause_chain() {
        let task = PipelineError::Task {
            table: "w".into(),
            index: 3,
            label: "T=20 °C".into(),
            source: Box::new(PipelineError::Job(JobError::ChunkCount {
                expected: 2,
                got: 1,
            })),
        };
        let finish = PipelineError::Finish {
            table: "m".into(),
            source: Box::new(
                IoError::doing("writing checkpoint", Path::new("out/.work/m/k.chunk"))(
                    std::io::Error::other("disk full"),
                )
                .into(),
            ),
        };
        let e = PipelineError::Failed(vec![task, finish]);
        assert_eq!(
            e.to_string(),
            "2 failure(s):\n  w task 3 (T=20 °C): expected 2 chunks (one per task), got 1\n  \
             m: writing checkpoint out/.work/m/k.chunk: disk full"
        );
    }

    /// A catalog that cannot be written does not hide the task errors, and alone it is the
    /// build's error.
    #[test]
    fn catalog_failure_keeps_the_task_errors() {
        let task = || PipelineError::Task {
            table: "w".into(),
            index: 0,
            label: "T=0 °C".into(),
            source: Box::new(PipelineError::Job(JobError::ChunkCount {
                expected: 2,
                got: 1,
            })),
        };
        let catalog = || {
            Err(PipelineError::Io(IoError::doing(
                "writing catalog",
                Path::new("out/index.json"),
            )(std::io::Error::other(
                "read-only",
            ))))
        };
        let e = build_outcome(vec![task()], catalog())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("2 failure(s):"), "{e}");
        assert!(
            e.contains("w task 0") && e.contains("out/index.json"),
            "{e}"
        );
        let alone = build_outcome(Vec::new(), catalog())
            .unwrap_err()
            .to_string();
        assert!(alone.contains("out/index.json"), "{alone}");
        assert!(build_outcome(Vec::new(), Ok(())).is_ok());
        assert!(build_outcome(vec![task()], Ok(())).is_err());
    }

    /// Records what a build reports.
    #[derive(Default)]
    struct Recorder {
        steps: Mutex<Vec<(String, TableStep)>>,
        started: Mutex<Vec<(u64, String)>>,
        advanced: AtomicUsize,
        finished: AtomicUsize,
    }

    impl Progress for Recorder {
        fn start(&self, total: u64, what: &str) {
            self.started.lock().unwrap().push((total, what.to_string()));
        }
        fn advance(&self, n: u64) {
            self.advanced.fetch_add(n as usize, Ordering::SeqCst);
        }
        fn table(&self, name: &str, step: TableStep) {
            self.steps.lock().unwrap().push((name.to_string(), step));
        }
        fn finish(&self) {
            self.finished.fetch_add(1, Ordering::SeqCst);
        }
    }

    impl Recorder {
        /// The steps of table `name`, in the order reported.
        fn of(&self, name: &str) -> Vec<TableStep> {
            let steps = self.steps.lock().unwrap();
            steps
                .iter()
                .filter(|(n, _)| n == name)
                .map(|&(_, s)| s)
                .collect()
        }
    }

    /// Every table's steps in order, every task once, for a whole build, a build with nothing
    /// to do, and two shards (the first leaves `b` waiting for the second's tasks).
    #[test]
    fn a_build_reports_each_table_step_and_every_task() {
        use TableStep::*;
        let d = tempfile::tempdir().unwrap();
        let m = d.path().join("m.toml");
        std::fs::write(
            &m,
            "[[table]]\nname = \"a\"\nstage = \"water-index\"\n[table.params]\n\
             wavelength_nm = [300.0, 1000.0, 1.0]\ntemperature_c = [20.0]\n\n\
             [[table]]\nname = \"b\"\nstage = \"water-index\"\n[table.params]\n\
             wavelength_nm = [300.0, 1000.0, 1.0]\ntemperature_c = [0.0, 10.0, 20.0]\n",
        )
        .unwrap();
        let opts = |out: &str, shard: Option<Shard>| BuildOptions {
            manifests: vec![m.clone()],
            out_dir: d.path().join(out),
            jobs: Some(2),
            shard,
            force: false,
        };
        let r = Recorder::default();
        build(&opts("all", None), &r).unwrap();
        assert_eq!(r.of("a"), [Computing { tasks: 1 }, Writing, Written]);
        assert_eq!(r.of("b"), [Computing { tasks: 3 }, Writing, Written]);
        assert_eq!(*r.started.lock().unwrap(), [(4, "tasks".to_string())]);
        assert_eq!(r.advanced.load(Ordering::SeqCst), 4);
        assert_eq!(r.finished.load(Ordering::SeqCst), 1);

        let r = Recorder::default();
        build(&opts("all", None), &r).unwrap();
        assert_eq!(r.of("a"), [UpToDate]);
        assert_eq!(r.of("b"), [UpToDate]);
        assert_eq!(r.advanced.load(Ordering::SeqCst), 0);

        // Global tasks a0 = 0, b0..b2 = 1..3: shard 0/2 computes a0 and b1.
        let r = Recorder::default();
        let report = build(&opts("sh", Some(Shard { index: 0, count: 2 })), &r).unwrap();
        assert_eq!(r.of("a"), [Computing { tasks: 1 }, Writing, Written]);
        assert_eq!(r.of("b"), [Computing { tasks: 1 }, Waiting]);
        assert_eq!(report.tables_pending, ["b"]);
        let r = Recorder::default();
        build(&opts("sh", Some(Shard { index: 1, count: 2 })), &r).unwrap();
        assert_eq!(r.of("a"), [UpToDate]);
        assert_eq!(r.of("b"), [Computing { tasks: 2 }, Writing, Written]);
    }
}
