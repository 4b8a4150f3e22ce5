//! The adaptive azimuthal estimator against plain analog tracking (the independent reference)
//! at held-out (σ, g, h'): `cargo run --release --example fur_azimuthal_validation [CAP] [PHOTONS_ANALOG]`
//! (defaults 1024, the cap of manifests/full/fur-medulla-azimuthal-capped.toml, and 2e6).
//! For each point the adaptive profile is computed twice, capped at CAP photons (as in the
//! capped thesis-grid table) and run to 1 % (cap 400 000), and compared per 0.5° bin with the
//! analog histogram on the bins ≥ 1e-3 of the profile maximum: max and median relative
//! deviation, the analog's median relative standard error (Poisson), mean z² and max |z|
//! (z with both standard errors), plus the adaptive run's worst relative standard error, photons
//! and seconds. Relative deviations include the analog's own noise; z² ≈ 1 means agreement
//! within the error bars. CSV on stdout, one line per point (any order).
#[path = "common/held_out.rs"]
mod held_out;
use rayon::prelude::*;
use scatterbake::fur::medulla::{Estimator, Geometry, McSettings, simulate};
use scatterbake::fur::medulla_fast::{AdaptiveProfile, AdaptiveSettings, simulate_adaptive};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let cap: u64 = args.get(1).map_or(1024, |s| s.parse().unwrap());
    let nh: u64 = args.get(2).map_or(2_000_000, |s| s.parse().unwrap());
    let points = held_out::AZIMUTHAL_HELD_OUT;
    println!(
        "sigma,g,h,bins,median_rel_se_analog,capped_photons,capped_worst_rel_se,capped_max_rel_dev,capped_median_rel_dev,capped_mean_z2,capped_max_abs_z,capped_s,target_photons,target_worst_rel_se,target_max_rel_dev,target_median_rel_dev,target_mean_z2,target_max_abs_z,target_s,analog_s"
    );
    points.par_iter().for_each(|&(sigma, g, h)| {
        let run = |max_photons, target_rel_error| {
            let t = Instant::now();
            let a = simulate_adaptive(
                sigma,
                g,
                h,
                &AdaptiveSettings {
                    seed: 11,
                    max_photons,
                    target_rel_error,
                    ..AdaptiveSettings::default()
                },
            );
            (a, t.elapsed().as_secs_f64())
        };
        let (capped, capped_s) = run(cap, 0.01);
        let (target, target_s) = run(400_000, 0.01);
        let t = Instant::now();
        // Analog photons in 8 independent streams.
        let hist: Vec<f64> = (0..8u64)
            .into_par_iter()
            .map(|i| {
                simulate(
                    sigma,
                    g,
                    Geometry::Azimuthal { h },
                    &McSettings {
                        photons: nh / 8,
                        seed: 4000 + i,
                        estimator: Estimator::Histogram,
                        bins: 720,
                        max_order: None,
                    },
                )
                .energy
                .iter()
                .map(|v| v / 8.0)
                .collect::<Vec<f64>>()
            })
            .reduce(
                || vec![0.0; 720],
                |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect(),
            );
        let analog_s = t.elapsed().as_secs_f64();
        let n = (nh / 8 * 8) as f64;
        // Bins: ≥ 1e-3 of the maximum of the 1 % profile.
        let max = target.profile.energy.iter().cloned().fold(0.0, f64::max);
        let bins: Vec<usize> = (0..720)
            .filter(|&k| target.profile.energy[k] >= 1e-3 * max)
            .collect();
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let se_h = |k: usize| (hist[k] * (1.0 - hist[k]) / n).max(1.0 / (n * n)).sqrt();
        let compare = |a: &AdaptiveProfile| {
            let (mut rel, mut z2, mut zmax) = (Vec::new(), 0.0, 0.0f64);
            for &k in &bins {
                rel.push((a.profile.energy[k] - hist[k]).abs() / a.profile.energy[k]);
                let z = (a.profile.energy[k] - hist[k]) / (a.profile.std_error[k].powi(2) + se_h(k).powi(2)).sqrt();
                z2 += z * z;
                zmax = zmax.max(z.abs());
            }
            let vmax = rel.iter().cloned().fold(0.0, f64::max);
            (vmax, median(rel), z2 / bins.len() as f64, zmax)
        };
        let se_rel = median(bins.iter().map(|&k| se_h(k) / target.profile.energy[k]).collect());
        let c = compare(&capped);
        let d = compare(&target);
        println!(
            "{sigma},{g},{h},{},{se_rel:.4e},{},{:.4},{:.4e},{:.4e},{:.3},{:.2},{capped_s:.2},{},{:.4},{:.4e},{:.4e},{:.3},{:.2},{target_s:.2},{analog_s:.1}",
            bins.len(),
            capped.photons,
            capped.worst_rel_error,
            c.0,
            c.1,
            c.2,
            c.3,
            target.photons,
            target.worst_rel_error,
            d.0,
            d.1,
            d.2,
            d.3
        );
    });
}
