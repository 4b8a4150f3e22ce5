//! Prints the planned size of every table of the given manifests (bytes of f32 values, as the
//! pipeline checks it against the reader's limit before running anything).
//!
//! `cargo run --release --example plan_sizes -- manifests/*.toml manifests/full/*.toml`

use scatterbake::manifest::load_manifest;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let limit = scatterbake::table::ReadLimits::default().max_payload_bytes;
    for m in std::env::args().skip(1) {
        for t in load_manifest(Path::new(&m))? {
            let size = match t.job.payload_bytes() {
                Some(b) => format!("{:.3} GiB", b as f64 / (1u64 << 30) as f64),
                None => "not stated".into(),
            };
            let over = t.job.payload_bytes().is_some_and(|b| b > limit);
            println!(
                "{m}\t{}\t{size}{}",
                t.name,
                if over {
                    "\tOVER THE READER'S LIMIT"
                } else {
                    ""
                }
            );
        }
    }
    Ok(())
}
