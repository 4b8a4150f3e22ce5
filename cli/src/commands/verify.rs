//! `scatterbake verify`: checksums, sizes and structure of table files, the sample values of
//! phase-function tables, and the rules of tensor-train tables (checked by reconstructing them,
//! which costs the dense table's size for the time of the check).

use crate::display;
use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `scatterbake verify`.
#[derive(clap::Args, Debug)]
pub struct VerifyArgs {
    /// Table files (.sbt) to verify.
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
    match scatterbake::table::verify_file(f, limits).and_then(|v| tensor_train_rules(f, v, limits))
    {
        Ok(v) => {
            let problems = value_problems(&v);
            // Decoded values: every channel, derived ones included (format 2.0).
            let h = &v.header;
            let n: usize = h.axes.iter().map(|a| a.len()).product::<usize>() * h.channels.len();
            if problems.is_empty() {
                println!(
                    "ok   {} ({}, {n} values)",
                    display::path(f),
                    display::text(&v.header.schema.to_string())
                );
                true
            } else if strict {
                eprintln!("BAD  {}: {}", display::path(f), problems.join("; "));
                false
            } else {
                println!(
                    "ok   {} ({}, {n} values)",
                    display::path(f),
                    display::text(&v.header.schema.to_string())
                );
                eprintln!("warning: {}: {}", display::path(f), problems.join("; "));
                true
            }
        }
        Err(e) => {
            eprintln!(
                "BAD  {}",
                display::text(&scatterbake::error::error_chain(&e))
            );
            false
        }
    }
}

/// A tensor-train table also passes the rules of its layout and reconstructs to finite values
/// (`docs/table-format.md`, "Tensor-train tables"); any other table is returned as verified.
fn tensor_train_rules(
    f: &std::path::Path,
    v: scatterbake::table::Verified,
    limits: &scatterbake::table::ReadLimits,
) -> Result<scatterbake::table::Verified, scatterbake::table::TableError> {
    if v.header.schema.name == scatterbake::table::tt::TT_SCHEMA {
        scatterbake::table::Table::open_reconstructed(f, limits)?;
    }
    Ok(v)
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
                display::text(&c.name),
                s.nan[i]
            ));
        }
        if s.infinite[i] > 0 {
            out.push(format!(
                "channel `{}` has {} infinite value(s)",
                display::text(&c.name),
                s.infinite[i]
            ));
        }
        if ["phase", "i_perp", "i_par"].contains(&c.name.as_str()) && s.negative[i] > 0 {
            out.push(format!(
                "channel `{}` has {} negative value(s)",
                display::text(&c.name),
                s.negative[i]
            ));
        }
    }
    out
}
