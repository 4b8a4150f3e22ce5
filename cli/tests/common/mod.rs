//! Helpers shared by the command-line test binaries (each uses its own subset).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

/// A command's standard output followed by its standard error, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `dir/w.toml`: a water-index manifest of 6 tasks (one per temperature), table `w`, over
/// 300–1000 nm every `step_nm`.
pub fn water_index_manifest(dir: &Path, step_nm: f64) -> PathBuf {
    let p = dir.join("w.toml");
    std::fs::write(
        &p,
        format!(
            "[[table]]\nname = \"w\"\nstage = \"water-index\"\n[table.params]\n\
             wavelength_nm = [300.0, 1000.0, {step_nm:?}]\n\
             temperature_c = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0]\n"
        ),
    )
    .unwrap();
    p
}
