//! Checks `scatterbake build --plan` against real work: for every table of the manifests whose
//! estimated CPU time is below `--max-cpu-s` (default 120), runs the whole job on one thread
//! (tasks, assembly and serialisation to the exact file bytes, nothing written) and prints the
//! plan's estimated size on disk and CPU time next to the measured ones, with their ratios.
//! The figures behind the cost model in `src/stages/cost.rs` and docs/pipeline.md ("Planning a
//! build"); a measurement, not a test:
//!
//! `cargo run --release --example plan_check -- [--max-cpu-s S] MANIFEST...`
//!
//! CPU time is this process's user + system time (Linux `/proc/self/stat`, 10 ms ticks), so
//! other processes on a loaded machine do not inflate it.

use anyhow::{Context, bail};
use scatterbake::manifest::load_manifest;
use scatterbake::pipeline::{provenance, table_key};
use scatterbake::table::Table;
use std::path::PathBuf;

/// CPU seconds (user + system) used by this process so far.
fn cpu_seconds() -> anyhow::Result<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").context("/proc/self/stat")?;
    let rest = stat.rsplit_once(')').context("parse /proc/self/stat")?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>()? + f[12].parse::<f64>()?;
    Ok(ticks / 100.0)
}

fn main() -> anyhow::Result<()> {
    let mut max_cpu_s = 120.0f64;
    let mut manifests = Vec::<PathBuf>::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--max-cpu-s" => max_cpu_s = args.next().context("--max-cpu-s S")?.parse()?,
            _ => manifests.push(a.into()),
        }
    }
    if manifests.is_empty() {
        bail!("usage: plan_check [--max-cpu-s S] MANIFEST...");
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    println!(
        "table\tstage\tpayload_bytes\tplan_bytes\tbytes\tbytes_ratio\tplan_cpu_s\tcpu_s\tcpu_ratio"
    );
    for m in &manifests {
        for t in load_manifest(m)? {
            let plan = scatterbake::plan::plan_table(&t);
            if plan.estimated_cpu_s > max_cpu_s {
                println!(
                    "{}\t{}\t{}\t{}\t-\t-\t{:.2}\t-\t-\tskipped",
                    t.name,
                    plan.stage,
                    plan.payload_bytes,
                    plan.estimated_bytes,
                    plan.estimated_cpu_s
                );
                continue;
            }
            let c0 = cpu_seconds()?;
            let content = pool.install(|| scatterbake::stages::run_in_memory(t.job.as_ref()))?;
            let mut table = Table::from_content(content, provenance(&t, &table_key(&t)))?;
            let bytes = table.to_bytes()?.len() as u64;
            let cpu = cpu_seconds()? - c0;
            println!(
                "{}\t{}\t{}\t{}\t{bytes}\t{:.3}\t{:.2}\t{cpu:.2}\t{:.2}",
                t.name,
                plan.stage,
                plan.payload_bytes,
                plan.estimated_bytes,
                plan.estimated_bytes as f64 / bytes as f64,
                plan.estimated_cpu_s,
                plan.estimated_cpu_s / cpu.max(0.01)
            );
        }
    }
    Ok(())
}
