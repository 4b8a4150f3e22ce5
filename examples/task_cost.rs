//! Measured cost of a build without running it: for every table of the manifests, the task
//! count and the CPU time of a few sample tasks spread over the task list (first, last and
//! evenly spaced between), each run alone on one thread. Prints per table the mean CPU seconds
//! per sampled task and the extrapolated CPU-hours of the whole table (mean × tasks). Figures
//! for the cost model in `docs/pipeline.md`; a measurement, not a test:
//!
//! `cargo run --release --example task_cost -- [--samples K] [--max-task-s S] MANIFEST...`
//!
//! `--samples` (default 3) tasks per table; sampling of a table stops early once one task
//! exceeded `--max-task-s` CPU seconds (default 120), and the table is marked `partial`.
//! CPU time is this process's user + system time (Linux `/proc/self/stat`, 10 ms ticks), so
//! other processes on a loaded machine do not inflate it.

use anyhow::{Context, bail};
use std::path::PathBuf;

/// CPU seconds (user + system) used by this process so far.
fn cpu_seconds() -> anyhow::Result<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").context("/proc/self/stat")?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')').context("parse /proc/self/stat")?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>()? + f[12].parse::<f64>()?;
    Ok(ticks / 100.0)
}

fn main() -> anyhow::Result<()> {
    let mut samples = 3usize;
    let mut max_task_s = 120.0f64;
    let mut manifests = Vec::<PathBuf>::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--samples" => samples = args.next().context("--samples K")?.parse()?,
            "--max-task-s" => max_task_s = args.next().context("--max-task-s S")?.parse()?,
            _ => manifests.push(a.into()),
        }
    }
    if manifests.is_empty() || samples == 0 {
        bail!("usage: task_cost [--samples K] [--max-task-s S] MANIFEST...");
    }
    // One thread: a task's CPU time is then its cost on one core.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    println!("table\ttasks\tsampled\tmean_cpu_s_per_task\tmin_s\tmax_s\tcpu_hours\tnote");
    for m in &manifests {
        for t in scatterbake::manifest::load_manifest(m)? {
            let n = t.job.tasks().len();
            let picks: Vec<usize> = if n <= samples {
                (0..n).collect()
            } else {
                let mut p: Vec<usize> = (0..samples)
                    .map(|i| i * (n - 1) / (samples - 1).max(1))
                    .collect();
                p.dedup();
                p
            };
            let mut times = Vec::new();
            let mut note = "";
            for &k in &picks {
                let c0 = cpu_seconds()?;
                if let Err(e) = pool.install(|| t.job.run_task(k)) {
                    note = "failed";
                    eprintln!("{} task {k}: {e}", t.name);
                    break;
                }
                let dt = cpu_seconds()? - c0;
                times.push(dt);
                if dt > max_task_s && times.len() < picks.len() {
                    note = "partial";
                    break;
                }
            }
            if times.is_empty() {
                println!("{}\t{n}\t0\t-\t-\t-\t-\t{note}", t.name);
                continue;
            }
            let mean = times.iter().sum::<f64>() / times.len() as f64;
            let min = times.iter().cloned().fold(f64::INFINITY, f64::min);
            let max = times.iter().cloned().fold(0.0, f64::max);
            println!(
                "{}\t{n}\t{}\t{mean:.3}\t{min:.3}\t{max:.3}\t{:.3}\t{note}",
                t.name,
                times.len(),
                mean * n as f64 / 3600.0
            );
        }
    }
    Ok(())
}
