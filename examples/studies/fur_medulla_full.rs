//! Build one fur medulla table of a manifest in memory and report what a full-grid build
//! costs and achieves, without writing the dense table:
//! `cargo run --release --example fur_medulla_full -- MANIFEST TABLE [TT_TOL ...]`
//! (run it under `/usr/bin/time -v` for CPU time and peak memory).
//!
//! Prints the wall time of the tasks and of the assembly; the energy identity recomputed from
//! the stored `energy` channel against the analytic scattered fraction 1 − exp(−σ·chord) for
//! every entry (absolute, and in units of the entry's `scattered_fraction_std_error` where that
//! is positive); for the adaptive method the distribution over computed entries of the achieved
//! worst relative standard error and of the photons used; for the deterministic method the
//! header's `solver_error`. For each TT_TOL: the tensor-train size of the channel the far field
//! reads (`energy` azimuthal, `pdf` longitudinal) as an `.sbt` file without the per-entry header
//! arrays, and its reconstruction error (relative Frobenius, per-bin relative on bins ≥ 1e-3 of
//! the profile maximum: median, 99th percentile, maximum). `log:TOL` compresses the logarithm
//! of the channel instead (`fur::tt::compress_table_log`; all figures are of the values).
use rayon::prelude::*;
use scatterbake::fur::tt::{compress_table, compress_table_log, reconstruct_table};
use scatterbake::table::{Provenance, Table, TableContent};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(args.len() >= 3, "usage: MANIFEST TABLE [TT_TOL ...]");
    let doc: toml::Table = toml::from_str(&std::fs::read_to_string(&args[1])?)?;
    let entry = doc["table"]
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("no [[table]]"))?
        .iter()
        .find(|e| e["name"].as_str() == Some(&args[2]))
        .ok_or_else(|| anyhow::anyhow!("no table {} in {}", args[2], args[1]))?;
    let stage = scatterbake::stages::find(entry["stage"].as_str().unwrap_or_default())
        .ok_or_else(|| anyhow::anyhow!("unknown stage"))?;
    let job = stage.plan(toml::de::ValueDeserializer::parse(
        &entry["params"].to_string(),
    )?)?;
    let n = job.tasks().len();
    println!(
        "{}: {n} tasks on {} threads",
        args[2],
        rayon::current_num_threads()
    );
    let t0 = Instant::now();
    let chunks = (0..n)
        .into_par_iter()
        .map(|i| job.run_task(i))
        .collect::<Result<Vec<_>, _>>()?;
    let tasks_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let content = job.assemble(chunks)?;
    println!(
        "tasks {tasks_s:.1} s wall, assembly {:.1} s wall, {} f32 values ({:.0} MB dense)",
        t1.elapsed().as_secs_f64(),
        content.data.len(),
        content.data.len() as f64 * 4e-6
    );
    energy_identity(&content);
    method_report(&content);
    for tol in &args[3..] {
        match tol.strip_prefix("log:") {
            Some(t) => compress(&content, t.parse()?, true)?,
            None => compress(&content, tol.parse()?, false)?,
        }
    }
    Ok(())
}

fn channel(content: &TableContent, name: &str) -> Vec<f32> {
    let nc = content.channels.len();
    let ci = content
        .channels
        .iter()
        .position(|c| c.name == name)
        .expect("channel");
    content.data.iter().skip(ci).step_by(nc).copied().collect()
}

fn attr_array(content: &TableContent, key: &str) -> Vec<f64> {
    content
        .attributes
        .get(key)
        .and_then(|v| v.as_array())
        .map(|a| a.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect())
        .unwrap_or_default()
}

/// Values per entry (profile length) and the chord of every entry, row-major (σ, g, entry).
fn entries(content: &TableContent) -> (usize, Vec<(f64, f64)>) {
    let longitudinal = content.schema.name == "fur-medulla-longitudinal";
    let profile = content.axes.last().unwrap().len() * if longitudinal { 2 } else { 1 };
    let mut out = Vec::new();
    for &s in &content.axes[0].coords() {
        for _ in 0..content.axes[1].len() {
            for &x in &content.axes[2].coords() {
                let chord = if longitudinal {
                    2.0 / x.to_radians().cos()
                } else {
                    2.0 * (1.0 - x * x).max(0.0).sqrt()
                };
                out.push((s, chord));
            }
        }
    }
    (profile, out)
}

fn energy_identity(content: &TableContent) {
    let energy = channel(content, "energy");
    let (profile, ent) = entries(content);
    let se = attr_array(content, "scattered_fraction_std_error");
    let (mut max_abs, mut max_z, mut n_z_gt3) = (0.0f64, 0.0f64, 0usize);
    let mut with_se = 0usize;
    for (i, (row, &(sigma, chord))) in energy.chunks(profile).zip(&ent).enumerate() {
        let sum: f64 = row.iter().map(|&v| v as f64).sum();
        let dev = sum - (1.0 - (-sigma * chord).exp());
        max_abs = max_abs.max(dev.abs());
        if let Some(&s) = se.get(i)
            && s > 0.0
        {
            with_se += 1;
            let z = (dev / s).abs();
            max_z = max_z.max(z);
            n_z_gt3 += usize::from(z > 3.0);
        }
    }
    println!(
        "energy identity over {} entries (sum of stored f32 energy vs 1 - exp(-sigma chord)): max |dev| {max_abs:.3e}; over the {with_se} entries with a standard error: max {max_z:.2} std errors, {n_z_gt3} beyond 3",
        ent.len()
    );
}

fn method_report(content: &TableContent) {
    let a = &content.attributes;
    println!(
        "method {}",
        a.get("method").unwrap_or(&"monte-carlo".into())
    );
    if let Some(e) = a.get("solver_error") {
        println!("solver_error (header) {e}");
    }
    let worst = attr_array(content, "worst_rel_std_error");
    if worst.is_empty() {
        return;
    }
    let photons = attr_array(content, "photons_used");
    let scattered = attr_array(content, "scattered_fraction");
    // Computed entries: a non-empty profile (σ > 0, |h'| < 1); mirrored rows repeat their source.
    let mut w: Vec<f64> = Vec::new();
    let mut total_photons = 0.0;
    for ((&wv, &p), &s) in worst.iter().zip(&photons).zip(&scattered) {
        if s > 0.0 {
            w.push(wv);
            total_photons += p;
        }
    }
    w.sort_by(f64::total_cmp);
    let q = |f: f64| w[((w.len() - 1) as f64 * f).round() as usize];
    let target = a["target_rel_error"].as_f64().unwrap_or(f64::NAN);
    let reached = w.iter().filter(|&&v| v <= target * 1.0001).count();
    println!(
        "adaptive: {} non-empty entries (mirrors counted), worst relative std error per entry: median {:.4}, p90 {:.4}, max {:.4}; {reached} at target {target}; photons per entry mean {:.0}",
        w.len(),
        q(0.5),
        q(0.9),
        q(1.0),
        total_photons / w.len() as f64
    );
}

/// `log`: compress ln(max(value, 1e-12 × the table maximum)) (`compress_table_log`; the
/// reconstruction applies exp), so that relative errors spread evenly over the profile.
fn compress(content: &TableContent, tol: f64, log: bool) -> anyhow::Result<()> {
    let longitudinal = content.schema.name == "fur-medulla-longitudinal";
    let name = if longitudinal { "pdf" } else { "energy" };
    let dense = channel(content, name);
    let (profile, _) = entries(content);
    let t = Instant::now();
    let (mut tt, rep) = if log {
        compress_table_log(content, name, tol, 256, 1e-12)?
    } else {
        compress_table(content, name, tol, 256)?
    };
    let secs = t.elapsed().as_secs_f64();
    let back = reconstruct_table(&tt)?;
    let mut rel: Vec<f64> = Vec::new();
    for (a, b) in dense.chunks(profile).zip(back.data.chunks(profile)) {
        let max = a.iter().cloned().fold(0.0f32, f32::max);
        for (x, y) in a.iter().zip(b) {
            if max > 0.0 && *x >= 1e-3 * max {
                rel.push(((x - y) / x).abs() as f64);
            }
        }
    }
    rel.sort_by(f64::total_cmp);
    // The per-entry arrays of the source header are not part of the shipped compressed table.
    if let Some(serde_json::Value::Object(src)) = tt.attributes.get_mut("source_attributes") {
        src.retain(|_, v| !v.is_array());
    }
    let ranks = tt.attributes["ranks"].clone();
    let bytes = Table::from_content(tt, Provenance::default())?
        .to_bytes()?
        .len();
    println!(
        "TT `{name}`{} tol {tol}: ranks {ranks}, {} values, {bytes} B, rel Frobenius {:.3e}, max abs/max {:.3e}, per-bin rel (bins >= 1e-3 of profile max): median {:.3e}, p99 {:.3e}, max {:.3e}; {secs:.1} s",
        if log { " (log)" } else { "" },
        rep.parameters,
        rep.rel_frobenius_error,
        rep.max_abs_error_rel_to_max,
        rel[rel.len() / 2],
        rel[rel.len() * 99 / 100],
        rel[rel.len() - 1]
    );
    Ok(())
}
