//! `scatterbake inspect`: a table's header, axes, channels, provenance and sizes.

use crate::display::text as esc;
use anyhow::Result;
use scatterbake::table::{AxisPoints, Table};
use std::path::PathBuf;

/// Arguments of `scatterbake inspect`.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// Table file (.sbt).
    pub file: PathBuf,
    /// Print the raw JSON header.
    #[arg(long)]
    pub json: bool,
}

/// Print a table's header (summary or raw JSON).
pub fn run_inspect(a: &InspectArgs) -> Result<()> {
    let t = Table::open(&a.file)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&t.header)?);
    } else {
        print_summary(&a.file, &t)?;
    }
    Ok(())
}

fn print_summary(file: &std::path::Path, t: &Table) -> Result<()> {
    let h = &t.header;
    let size = std::fs::metadata(file)?.len();
    println!("file:        {}", crate::display::path(file));
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
