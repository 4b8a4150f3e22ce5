//! Time the preview pictures `build` draws for one table (CPU seconds of this process for the
//! table read and for each picture). Use with `perf record` to see where the time goes.
//!
//! `cargo run --release --example preview_cost -- TABLE.sbt [OUT_DIR]`

use std::path::PathBuf;
use std::time::Instant;

fn cpu_seconds() -> f64 {
    // user + system time of this process from /proc/self/stat (clock ticks of 10 ms)
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map(|(_, r)| r.split_whitespace().collect())
        .unwrap_or_default();
    let tick = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (tick(11) + tick(12)) / 100.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let table = PathBuf::from(
        args.next()
            .ok_or("usage: preview_cost TABLE.sbt [OUT_DIR]")?,
    );
    let out = PathBuf::from(args.next().unwrap_or_else(|| "/tmp/preview-cost".into()));
    let (w0, c0) = (Instant::now(), cpu_seconds());
    let t = scatterbake::table::Table::open(&table)?;
    let (w1, c1) = (Instant::now(), cpu_seconds());
    println!(
        "read {}: {:.2} s wall, {:.2} s CPU ({} values)",
        table.display(),
        (w1 - w0).as_secs_f64(),
        c1 - c0,
        t.data.len()
    );
    drop(t);
    let files = scatterbake::consumers::plot::previews::previews(&table, &out)?;
    println!(
        "previews (including a second read): {:.2} s wall, {:.2} s CPU: {files:?}",
        w1.elapsed().as_secs_f64(),
        cpu_seconds() - c1
    );
    Ok(())
}
