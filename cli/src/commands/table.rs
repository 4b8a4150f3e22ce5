//! Commands that look at table files: `inspect`, `verify`, `catalog`, and the stage list.

use anyhow::Result;
use scatterbake::table::{AxisPoints, Table};
use std::path::PathBuf;

/// Arguments of `scatterbake inspect`.
#[derive(clap::Args, Debug)]
pub struct InspectArgs {
    pub file: PathBuf,
    /// Print the raw JSON header.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `scatterbake verify`.
#[derive(clap::Args, Debug)]
pub struct VerifyArgs {
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Treat NaN, infinite or negative samples of a phase-function table as errors
    /// (default: warnings).
    #[arg(long)]
    pub strict: bool,
    /// Largest uncompressed payload to accept, in bytes (default 4 GiB).
    #[arg(long, value_name = "BYTES")]
    pub max_payload_bytes: Option<u64>,
}

/// Arguments of `scatterbake catalog`.
#[derive(clap::Args, Debug)]
pub struct CatalogArgs {
    #[arg(default_value = "tables")]
    pub dir: PathBuf,
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

/// Verify every file; returns the exit code (1 if any failed).
pub fn run_verify(a: &VerifyArgs) -> Result<i32> {
    let mut limits = scatterbake::table::ReadLimits::default();
    if let Some(m) = a.max_payload_bytes {
        limits.max_payload_bytes = m;
    }
    let bad = a
        .files
        .iter()
        .filter(|f| !verify_one(f, &limits, a.strict))
        .count();
    if bad > 0 {
        eprintln!(
            "error: {bad} of {} file(s) failed verification",
            a.files.len()
        );
        Ok(1)
    } else {
        Ok(0)
    }
}

/// Verify one file and print its line; false when it fails.
fn verify_one(f: &std::path::Path, limits: &scatterbake::table::ReadLimits, strict: bool) -> bool {
    match scatterbake::table::verify_file(f, limits) {
        Ok(v) => {
            let problems = value_problems(&v);
            let n: usize = v.header.layout.shape.iter().product();
            if problems.is_empty() {
                println!("ok   {} ({}, {n} values)", f.display(), v.header.schema);
                true
            } else if strict {
                eprintln!("BAD  {}: {}", f.display(), problems.join("; "));
                false
            } else {
                println!("ok   {} ({}, {n} values)", f.display(), v.header.schema);
                eprintln!("warning: {}: {}", f.display(), problems.join("; "));
                true
            }
        }
        Err(e) => {
            eprintln!("BAD  {e}");
            false
        }
    }
}

/// List the registered stages with their parameters and defaults.
pub fn run_stages() -> Result<()> {
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
    Ok(())
}

/// Rebuild a directory's catalog; returns the exit code (1 if any table is invalid).
pub fn run_catalog(a: &CatalogArgs) -> Result<i32> {
    let c = scatterbake::catalog::rebuild(&a.dir)?;
    println!(
        "{}: {} table(s), {} invalid",
        a.dir.join("index.json").display(),
        c.tables.len(),
        c.invalid.len()
    );
    for (f, why) in &c.invalid {
        eprintln!("invalid: {f}: {why}");
    }
    Ok(if c.invalid.is_empty() { 0 } else { 1 })
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
