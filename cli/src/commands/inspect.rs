//! `scatterbake inspect`: a table's header, axes, channels, provenance and sizes; with
//! `--entry`, one entry of it (its fixed coordinates and the range of its samples).

use crate::display::text as esc;
use anyhow::Result;
use scatterbake::table::{AxisPoints, ReadLimits, Table, verify_file};
use std::path::PathBuf;

/// Arguments of `scatterbake inspect`.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    /// Table file (.sbt).
    pub file: PathBuf,
    /// Print the raw JSON header.
    #[arg(long)]
    pub json: bool,
    /// Also show one entry: indices of the first axes, e.g. `0,2,1` (radius, wavelength and
    /// sun elevation of a ray-traced table). Only that entry is kept in memory while the whole
    /// file is verified (`docs/table-format.md`, "Reading one entry").
    #[arg(long, value_delimiter = ',')]
    pub entry: Option<Vec<usize>>,
}

/// Print a table's header (summary or raw JSON), and with `--entry` that entry's summary. The
/// whole file is verified without keeping its samples.
pub fn run_inspect(a: &InspectArgs) -> Result<()> {
    let limits = ReadLimits::default();
    let t = match &a.entry {
        Some(entry) => Table::open_slice(&a.file, entry, &limits)?,
        None => Table {
            header: verify_file(&a.file, &limits)?.header,
            data: Vec::new(),
        },
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&t.header)?);
    } else {
        print_summary(&a.file, &t)?;
    }
    if let Some(entry) = &a.entry {
        print_entry(entry, &t);
    }
    Ok(())
}

/// The fixed coordinates of an entry and, per channel, its samples' range and count of
/// non-finite values.
fn print_entry(entry: &[usize], t: &Table) {
    println!("entry:");
    for a in &t.header.axes[..entry.len()] {
        let label = a
            .label(0)
            .map(|l| format!(" ({})", esc(l)))
            .unwrap_or_default();
        println!(
            "  {:<20} {} {}{label}",
            esc(&a.name),
            a.coord(0),
            esc(&a.unit)
        );
    }
    let nc = t.header.channels.len();
    println!("  {} samples per channel", t.data.len() / nc);
    for (c, ch) in t.header.channels.iter().enumerate() {
        let values = t.data.iter().skip(c).step_by(nc);
        let (mut lo, mut hi, mut bad) = (f32::INFINITY, f32::NEG_INFINITY, 0usize);
        for &v in values {
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            } else {
                bad += 1;
            }
        }
        println!(
            "  {:<20} min {lo:e} max {hi:e}, {bad} not finite",
            esc(&ch.name)
        );
    }
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
        // A symmetric axis stores half its period; lookups fold onto it (table format 3.0).
        let symmetry = a.symmetry.map_or(String::new(), |s| {
            format!(
                "; even-periodic, period {}: the value at x is the value at −x and x + period",
                s.period()
            )
        });
        println!(
            "  {:<20} [{}] {}{}",
            esc(&a.name),
            esc(&a.unit),
            desc,
            symmetry
        );
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
