//! Far field from the shipped full-grid medulla assets (the default) against the on-the-fly
//! Monte Carlo (`medulla_source = "monte-carlo"`), per Table 4.2 sample, with the parameters of
//! `manifests/fur-farfield.toml` at the given θ_i (default −40°, the thesis's geometry):
//! `cargo run --release --example fur_farfield_assets -- [THETA_I_DEG ...]`
//!
//! Prints per sample and θ_i: the relative L2 difference of the `energy` and `scattered`
//! channels over the (θ_r, φ) cells, the energy of each component in both (the unscattered
//! lobes do not depend on the source; the scattered energy comes from the analytic extinction),
//! the scattered energy in the back (|φ| < 90°) and forward half, and the wall time of each.
use scatterbake::fur::farfield::COMPONENTS;
use scatterbake::stages::{find, run_in_memory};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let thetas: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse())
        .collect::<Result<_, _>>()?;
    let thetas = if thetas.is_empty() {
        vec![-40.0]
    } else {
        thetas
    };
    let stage = find("fur-farfield").unwrap();
    let list = thetas
        .iter()
        .map(|t| format!("{t:?}"))
        .collect::<Vec<_>>()
        .join(", ");
    let common = format!(
        "theta_i_deg = [{list}], theta_r_cells = 90, phi_cells = 180, h_samples = 400, medulla_rows = 17, medulla_bins = 360, photons = 2000, seed = 1"
    );
    let run = |extra: &str| -> anyhow::Result<(scatterbake::table::TableContent, f64)> {
        let t0 = Instant::now();
        let job = stage.plan(toml::de::ValueDeserializer::parse(&format!(
            "{{ {common}{extra} }}"
        ))?)?;
        let c = run_in_memory(job.as_ref())?;
        Ok((c, t0.elapsed().as_secs_f64()))
    };
    let (assets, t_assets) = run("")?;
    let (fly, t_fly) = run(", medulla_source = \"monte-carlo\"")?;
    println!("wall: assets {t_assets:.1} s, on the fly {t_fly:.1} s");
    let nc = 1 + COMPONENTS.len();
    let (nt, np) = (90usize, 180usize);
    let area = (2.0f64).to_radians() * (2.0f64).to_radians();
    let samples = assets.attributes["samples"].as_array().unwrap().clone();
    println!(
        "sample theta_i relL2_energy relL2_scattered scattered_energy(assets,fly) back_scattered(assets,fly) forward_scattered(assets,fly) component_energies(r,tt,trt,medulla_paths) max_abs_component_diff"
    );
    let block = thetas.len() * nt * np * nc;
    for (si, s) in samples.iter().enumerate() {
        for (ti, theta) in thetas.iter().enumerate() {
            let off = si * block + ti * nt * np * nc;
            let a = &assets.data[off..off + nt * np * nc];
            let b = &fly.data[off..off + nt * np * nc];
            let l2 = |c: usize| {
                let (mut e2, mut n2) = (0.0f64, 0.0f64);
                for (x, y) in a.chunks(nc).zip(b.chunks(nc)) {
                    let (x, y) = (x[c] as f64, y[c] as f64);
                    e2 += (x - y) * (x - y);
                    n2 += y * y;
                }
                (e2 / n2.max(1e-300)).sqrt()
            };
            let energy = |v: &[f32], c: usize, sel: &dyn Fn(usize) -> bool| -> f64 {
                v.chunks(nc)
                    .enumerate()
                    .filter(|(k, _)| sel(*k % np))
                    .map(|(_, r)| r[c] as f64)
                    .sum::<f64>()
                    * area
            };
            let all = |_: usize| true;
            let back = |j: usize| {
                let phi = -180.0 + (j as f64 + 0.5) * 2.0;
                phi.abs() < 90.0
            };
            let fwd = |j: usize| !back(j);
            let sc = nc - 1;
            let mut comp = Vec::new();
            let mut max_diff = 0.0f64;
            for c in 1..sc {
                let (ea, eb) = (energy(a, c, &all), energy(b, c, &all));
                comp.push(format!("{ea:.5}"));
                max_diff = max_diff.max((ea - eb).abs());
            }
            println!(
                "{} {theta} {:.4} {:.4} {:.5},{:.5} {:.5},{:.5} {:.5},{:.5} {} {:.1e}",
                s["name"].as_str().unwrap(),
                l2(0),
                l2(sc),
                energy(a, sc, &all),
                energy(b, sc, &all),
                energy(a, sc, &back),
                energy(b, sc, &back),
                energy(a, sc, &fwd),
                energy(b, sc, &fwd),
                comp.join(","),
                max_diff
            );
        }
    }
    Ok(())
}
