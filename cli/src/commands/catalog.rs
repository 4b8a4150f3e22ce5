//! `scatterbake catalog`: rebuild a directory's `index.json` from its tables, and with `--html`
//! its browsable page `index.html`.

use anyhow::Result;
use scatterbake::consumers::catalog_page::{PageOptions, write_catalog_page};
use std::path::{Path, PathBuf};

/// Arguments of `scatterbake catalog`.
#[derive(clap::Args, Debug)]
pub struct CatalogArgs {
    /// Directory of tables whose index.json is rebuilt.
    #[arg(default_value = "tables")]
    pub dir: PathBuf,
    /// Also write DIR/index.html: every table with its header, checksum, previews, exports and
    /// an interactive plot (a static page; open it in a browser, no server needed).
    #[arg(long)]
    pub html: bool,
    /// Read and verify every table, trusting nothing the previous catalog recorded (by default
    /// a table whose size, times, device and inode are those listed is not read again).
    #[arg(long)]
    pub full: bool,
    /// With --html: tables whose uncompressed payload exceeds this many bytes are listed
    /// without a plot.
    #[arg(long, requires = "html", default_value_t = scatterbake::consumers::catalog_page::DEFAULT_MAX_PLOT_PAYLOAD_BYTES)]
    pub max_plot_payload_bytes: u64,
}

/// Rebuild a directory's catalog; returns the exit code (1 if any table is invalid).
pub fn run_catalog(a: &CatalogArgs) -> Result<i32> {
    let c = match a.full {
        true => scatterbake::catalog::rebuild_reading_all(&a.dir)?,
        false => scatterbake::catalog::rebuild(&a.dir)?,
    };
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
    if a.html {
        let opts = PageOptions {
            max_plot_payload_bytes: a.max_plot_payload_bytes,
        };
        write_page(&a.dir, &c, &opts)?;
    }
    Ok(if c.invalid.is_empty() { 0 } else { 1 })
}

/// Write `dir/index.html` and say what it holds.
pub fn write_page(dir: &Path, c: &scatterbake::catalog::Catalog, opts: &PageOptions) -> Result<()> {
    let r = write_catalog_page(dir, c, opts)?;
    println!(
        "{}: {} table(s), {} plotted",
        crate::display::path(&r.path),
        r.tables,
        r.plotted
    );
    for (name, why) in &r.not_plotted {
        println!(
            "  {}: {}",
            crate::display::text(name),
            crate::display::text(why)
        );
    }
    Ok(())
}
