//! Tensor-train size and error of a medulla table channel built in memory from a manifest:
//! `cargo run --release --example fur_medulla_compress -- MANIFEST TABLE CHANNEL TOL...`
//! For each tolerance: TT ranks, stored values, file size (zstd, without the copied source
//! attributes), relative Frobenius error, max abs error / max, and the per-bin relative error
//! on bins above 1e-3 of their profile's maximum (profile = last axis, both lobes for the
//! longitudinal family): 99th percentile and maximum. `CHANNEL` prefixed with `log:` compresses
//! ln(max(value, 1e-12)) instead and reports the errors of exp of the reconstruction.
use rayon::prelude::*;
use scatterbake::fur::tt::{compress_table, reconstruct_table};
use scatterbake::table::{Provenance, Table};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let doc: toml::Table = toml::from_str(&std::fs::read_to_string(&args[1])?)?;
    let entry = doc["table"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"].as_str() == Some(&args[2]))
        .expect("table in manifest");
    let stage = scatterbake::stages::find(entry["stage"].as_str().unwrap()).unwrap();
    let job = stage.plan(toml::de::ValueDeserializer::parse(
        &entry["params"].to_string(),
    )?)?;
    let t0 = Instant::now();
    let chunks: Vec<scatterbake::stages::Chunk> = (0..job.tasks().len())
        .into_par_iter()
        .map(|i| job.run_task(i).unwrap())
        .collect();
    let content = job.assemble(chunks)?;
    println!("built in {:.1} s", t0.elapsed().as_secs_f64());
    let (log, name) = match args[3].strip_prefix("log:") {
        Some(n) => (true, n.to_string()),
        None => (false, args[3].clone()),
    };
    let nc = content.channels.len();
    let ci = content
        .channels
        .iter()
        .position(|c| c.name == name)
        .unwrap();
    let dense: Vec<f32> = content.data.iter().skip(ci).step_by(nc).copied().collect();
    let mut content = content;
    if log {
        content.data = dense.iter().map(|v| v.max(1e-12).ln()).collect();
        content.channels = vec![content.channels[ci].clone()];
    }
    // Profile length: last axis, times the lobe axis when present.
    let profile = content.axes.last().unwrap().len()
        * if content.axes.len() == 5 {
            content.axes[3].len()
        } else {
            1
        };
    for tol in &args[4..] {
        let t1 = Instant::now();
        let (mut tt, rep) = compress_table(&content, &name, tol.parse()?, 256)?;
        let secs = t1.elapsed().as_secs_f64();
        let mut back = reconstruct_table(&tt)?;
        if log {
            back.data.iter_mut().for_each(|v| *v = v.exp());
        }
        let mut rel: Vec<f64> = Vec::new();
        for (a, b) in dense.chunks(profile).zip(back.data.chunks(profile)) {
            let max = a.iter().cloned().fold(0.0f32, f32::max);
            for (x, y) in a.iter().zip(b) {
                if max > 0.0 && *x > 1e-3 * max {
                    rel.push(((x - y) / x).abs() as f64);
                }
            }
        }
        rel.sort_by(f64::total_cmp);
        let ranks = tt.attributes["ranks"].clone();
        tt.attributes.remove("source_attributes");
        let bytes = Table::from_content(tt, Provenance::default())?
            .to_bytes()?
            .len();
        println!(
            "tol {tol}: ranks {ranks}, {} values, {bytes} B, rel Frobenius {:.3e}, max abs/max {:.3e}, per-bin rel (bins > 1e-3 of profile max): median {:.3e}, p99 {:.3e}, max {:.3e}; {secs:.1} s",
            rep.parameters,
            rep.rel_frobenius_error,
            rep.max_abs_error_rel_to_max,
            rel[rel.len() / 2],
            rel[rel.len() * 99 / 100],
            rel[rel.len() - 1]
        );
    }
    Ok(())
}
