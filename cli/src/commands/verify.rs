//! `scatterbake verify`: checksums, sizes and structure of table files, and the sample values of
//! phase-function tables.

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
    match scatterbake::table::verify_file(f, limits) {
        Ok(v) => {
            let problems = value_problems(&v);
            let n: usize = v.header.layout.shape.iter().product();
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
