//! Estimator efficiency and full-grid cost extrapolation for the medulla Monte Carlo:
//! `cargo run --release --example fur_efficiency`
//! For each (σ, g, h'): variance ratio histogram/expected at equal photon count, efficiency
//! ratio at equal CPU time, and the photons/time the expected estimator needs for ≤ 1 % relative
//! standard error on every bin above 1e-3 of the profile maximum (single thread).
use scatterbake::fur::medulla::*;
use std::time::Instant;

fn run(sigma: f64, g: f64, h: f64, n: u64, est: Estimator) -> (Profile, f64) {
    let s = McSettings {
        photons: n,
        seed: 5,
        estimator: est,
        bins: 720,
        max_order: None,
    };
    let t = Instant::now();
    let p = simulate(sigma, g, Geometry::Azimuthal { h }, &s);
    (p, t.elapsed().as_secs_f64())
}

fn main() {
    println!(
        "sigma,g,h,var_ratio_equal_photons,efficiency_ratio_equal_time,ms_per_photon_expected,ms_per_photon_histogram,worst_rel_se_1e3,photons_for_1pct,seconds_for_1pct"
    );
    let mut total_secs = 0.0;
    let mut count = 0;
    for &sigma in &[0.3, 1.0, 2.5, 5.0, 10.0, 20.0] {
        for &g in &[0.0, 0.4, 0.8] {
            for &h in &[0.0, 0.5, 0.9] {
                let ne = 400;
                let nh = 200_000;
                let (a, ta) = run(sigma, g, h, ne, Estimator::Expected);
                let (_b, tb) = run(sigma, g, h, nh, Estimator::Histogram);
                let max = a.energy.iter().cloned().fold(0.0, f64::max);
                let sel: Vec<usize> = (0..720).filter(|&k| a.energy[k] > 1e-3 * max).collect();
                // Per-photon variances (mean over the selected bins).
                let va: f64 = sel
                    .iter()
                    .map(|&k| a.std_error[k].powi(2) * ne as f64)
                    .sum::<f64>()
                    / sel.len() as f64;
                let vb: f64 = sel
                    .iter()
                    .map(|&k| a.energy[k] * (1.0 - a.energy[k]))
                    .sum::<f64>()
                    / sel.len() as f64;
                let (ca, cb) = (ta / ne as f64, tb / nh as f64);
                let worst = sel
                    .iter()
                    .map(|&k| a.std_error[k] / a.energy[k])
                    .fold(0.0, f64::max);
                let need = ne as f64 * (worst / 0.01).powi(2);
                total_secs += need * ca;
                count += 1;
                println!(
                    "{sigma},{g},{h},{:.1},{:.1},{:.4},{:.5},{:.3},{:.0},{:.1}",
                    vb / va,
                    (vb * cb) / (va * ca),
                    ca * 1e3,
                    cb * 1e3,
                    worst,
                    need,
                    need * ca
                );
            }
        }
    }
    let mean = total_secs / count as f64;
    // Thesis grid: 64 σ × 16 g × 64 h' (32 computed thanks to the mirror) per family.
    let entries = 64.0 * 16.0 * 32.0;
    println!("# mean single-thread seconds per entry for 1% worst-bin error: {mean:.1}");
    println!(
        "# extrapolated azimuthal thesis grid on 2 cores: {:.0} core-hours, {:.1} days wall",
        mean * entries / 3600.0,
        mean * entries / 2.0 / 86400.0
    );
}
