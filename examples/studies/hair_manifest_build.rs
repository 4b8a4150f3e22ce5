//! Build every table of a hair manifest in memory and print the time and the quadrature
//! figures of each (figures for docs/hair.md; a measurement, not a test):
//!
//! `cargo run --release --example hair_manifest_build [-- MANIFEST]`
//!
//! MANIFEST defaults to `manifests/hair-dual.toml`; `manifests/full/hair-dual.toml` is the full
//! set.

use anyhow::Context;

fn main() -> anyhow::Result<()> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| root.join("manifests/hair-dual.toml"));
    let text = std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
    let doc: toml::Value = toml::from_str(&text)?;
    let all = std::time::Instant::now();
    for entry in doc["table"].as_array().context("no [[table]]")? {
        let name = entry["name"].as_str().context("table without a name")?;
        let stage_name = entry["stage"].as_str().context("table without a stage")?;
        let stage = scatterbake::stages::find(stage_name)
            .with_context(|| format!("unknown stage {stage_name}"))?;
        let params = toml::to_string(&entry["params"])?;
        let inline = format!("{{ {} }}", params.trim().replace('\n', ", "));
        let job = stage.plan(toml::de::ValueDeserializer::parse(&inline)?)?;
        let t0 = std::time::Instant::now();
        let t = scatterbake::stages::run_in_memory(job.as_ref())?;
        println!(
            "{name}: {} values in {:.2} s; quadrature {}",
            t.data.len(),
            t0.elapsed().as_secs_f64(),
            t.attributes
                .get("quadrature")
                .map(|q| q.to_string())
                .unwrap_or("-".into())
        );
    }
    println!("total {:.2} s", all.elapsed().as_secs_f64());
    Ok(())
}
