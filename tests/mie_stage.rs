//! The `mie` stage through the registry with the shipped manifests: they plan, and (ignored,
//! `cargo test --release --test mie_stage -- --ignored --nocapture`) the default manifest's
//! full job runs with every row normalised, reporting its wall time.

use scatterbake::stages::Job;

fn plan_manifest(path: &str) -> Vec<Box<dyn Job>> {
    let text = std::fs::read_to_string(format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let doc: toml::Value = toml::from_str(&text).unwrap();
    doc["table"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let stage =
                scatterbake::stages::find(t["stage"].as_str().unwrap()).expect("stage registered");
            let inline = t["params"].to_string();
            stage
                .plan(toml::de::ValueDeserializer::parse(&inline).unwrap())
                .unwrap()
        })
        .collect()
}

#[test]
fn shipped_manifests_plan() {
    let jobs = plan_manifest("manifests/rainbow-mie.toml");
    assert_eq!(jobs[0].tasks().len(), 33 * 11);
    let full = plan_manifest("manifests/full/rainbow-mie-full.toml");
    assert_eq!(full.len(), 2);
    assert_eq!(full[1].tasks().len(), 33 * 3);
}

#[test]
#[ignore = "long validation: builds the whole default table (≈3 min on 2 cores); run with cargo test --release -- --ignored"]
fn default_manifest_builds_normalised() {
    use rayon::prelude::*;
    let jobs = plan_manifest("manifests/rainbow-mie.toml");
    let job = &jobs[0];
    let t0 = std::time::Instant::now();
    let chunks: Vec<scatterbake::stages::Chunk> = (0..job.tasks().len())
        .into_par_iter()
        .map(|i| job.run_task(i).unwrap())
        .collect();
    let elapsed = t0.elapsed();
    let table = job.assemble(chunks).unwrap();
    let n_a = table.axes[2].len();
    let cells = scatterbake::mie::filters::cell_solid_angles(n_a - 1);
    let mut worst: f64 = 0.0;
    for row in table.data.chunks(n_a * 4) {
        let e: f64 = row
            .chunks(4)
            .zip(&cells)
            .map(|(c, w)| c[0] as f64 * w)
            .sum();
        worst = worst.max((e - 1.0).abs());
    }
    println!(
        "default rainbow-mie: {} tasks in {:.1} s on {} threads; worst |∫p dΩ − 1| = {worst:.1e}",
        job.tasks().len(),
        elapsed.as_secs_f64(),
        rayon::current_num_threads()
    );
    assert!(worst < 1e-5);
}
