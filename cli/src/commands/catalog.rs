//! `scatterbake catalog`: rebuild a directory's `index.json` from its tables.

use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `scatterbake catalog`.
#[derive(clap::Args, Debug)]
pub struct CatalogArgs {
    /// Directory of tables whose index.json is rebuilt.
    #[arg(default_value = "tables")]
    pub dir: PathBuf,
}

/// Rebuild a directory's catalog; returns the exit code (1 if any table is invalid).
pub fn run_catalog(a: &CatalogArgs) -> Result<i32> {
    let c = scatterbake::catalog::rebuild(&a.dir)?;
    println!(
        "{}: {} table(s), {} invalid",
        crate::display::path(&a.dir.join("index.json")),
        c.tables.len(),
        c.invalid.len()
    );
    for (f, why) in &c.invalid {
        eprintln!(
            "invalid: {}: {}",
            crate::display::text(f),
            crate::display::text(why)
        );
    }
    Ok(if c.invalid.is_empty() { 0 } else { 1 })
}
