//! Build the fur medulla tables of a manifest without the pipeline (timing and size study):
//! `cargo run --release --example fur_medulla_build -- manifests/fur-medulla.toml OUT_DIR [TT_TOL]`
//! Runs every task with rayon, assembles, writes `.sbt` files, prints the wall time, the energy
//! identity check and, with TT_TOL, the tensor-train size and reconstruction error.
use rayon::prelude::*;
use scatterbake::fur::tt::compress_table;
use scatterbake::table::{Provenance, Table, write_table_atomic};
use std::time::Instant;

/// Relative standard error over bins above 1e-3 of each row's maximum (energy channel).
fn print_std_error_summary(content: &scatterbake::table::TableContent) {
    let nc = content.channels.len();
    let (ei, si) = (
        content
            .channels
            .iter()
            .position(|c| c.name == "energy")
            .unwrap(),
        content
            .channels
            .iter()
            .position(|c| c.name == "std_error")
            .unwrap(),
    );
    let row = content.axes.last().unwrap().len() * if content.axes.len() == 5 { 2 } else { 1 };
    let (mut worst, mut sum_rel, mut count) = (0.0f64, 0.0f64, 0usize);
    for r in content.data.chunks(row * nc) {
        let max = (0..row).map(|k| r[k * nc + ei]).fold(0.0f32, f32::max);
        for k in 0..row {
            let e = r[k * nc + ei];
            if max > 0.0 && e > 1e-3 * max {
                let rel = (r[k * nc + si] / e) as f64;
                worst = worst.max(rel);
                sum_rel += rel;
                count += 1;
            }
        }
    }
    println!(
        "  relative std error on bins > 1e-3 of row max: mean {:.4}, worst {:.4}",
        sum_rel / count.max(1) as f64,
        worst
    );
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let manifest = std::fs::read_to_string(&args[1])?;
    let out = std::path::PathBuf::from(&args[2]);
    let tt_tol: Option<f64> = args.get(3).map(|s| s.parse()).transpose()?;
    std::fs::create_dir_all(&out)?;
    let doc: toml::Table = toml::from_str(&manifest)?;
    let t_all = Instant::now();
    for entry in doc["table"].as_array().expect("[[table]]") {
        let name = entry["name"].as_str().unwrap();
        let stage = scatterbake::stages::find(entry["stage"].as_str().unwrap()).expect("stage");
        let params = entry["params"].to_string();
        let job = stage.plan(toml::de::ValueDeserializer::parse(&params)?)?;
        let t0 = Instant::now();
        let n = job.tasks().len();
        let chunks: Vec<scatterbake::stages::Chunk> = (0..n)
            .into_par_iter()
            .map(|i| job.run_task(i).unwrap())
            .collect();
        let content = job.assemble(chunks)?;
        let secs = t0.elapsed().as_secs_f64();
        let a = &content.attributes;
        // Deterministic methods have no standard errors (the attribute is absent).
        println!(
            "{name}: {n} tasks, {secs:.1} s, method {}, energy identity max dev {:.3e} ({} std errors)",
            a.get("method")
                .and_then(|m| m.as_str())
                .unwrap_or("monte-carlo"),
            a["energy_identity_max_deviation"]
                .as_f64()
                .unwrap_or(f64::NAN),
            a.get("energy_identity_max_deviation_std_errors")
                .and_then(|v| v.as_f64())
                .map_or("no".to_string(), |v| format!("{v:.2}"))
        );
        print_std_error_summary(&content);
        if let Some(tol) = tt_tol {
            let ch = if content.schema.name == "fur-medulla-longitudinal" {
                "pdf"
            } else {
                "energy"
            };
            let t1 = Instant::now();
            let (tt, rep) = compress_table(&content, ch, tol, 64)?;
            let mut tab = Table::from_content(
                tt,
                Provenance {
                    tool: "scatterbake".into(),
                    ..Default::default()
                },
            )?;
            let bytes = write_table_atomic(&mut tab, &out.join(format!("{name}-{ch}-tt.sbt")))?;
            println!(
                "  TT `{ch}` tol {tol}: ranks {}, {} values, file {bytes} B, rel Frobenius {:.3e}, max abs {:.3e} ({:.3e} of max), {:.1} s",
                tab.header.attributes["ranks"],
                rep.parameters,
                rep.rel_frobenius_error,
                rep.max_abs_error,
                rep.max_abs_error_rel_to_max,
                t1.elapsed().as_secs_f64()
            );
        }
        let mut tab = Table::from_content(
            content,
            Provenance {
                tool: "scatterbake".into(),
                ..Default::default()
            },
        )?;
        let bytes = write_table_atomic(&mut tab, &out.join(format!("{name}.sbt")))?;
        println!("  dense file {bytes} B ({} f32 values)", tab.data.len());
    }
    println!(
        "total {:.1} s on {} threads",
        t_all.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    Ok(())
}
