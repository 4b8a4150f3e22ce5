//! Cost of the adaptive azimuthal estimator on the thesis grid, measured on a random sample of
//! its entries: `cargo run --release --example fur_adaptive_cost [SAMPLES] [CAP] [TARGET]`
//! (defaults 48, 400 000 photons, 0.01). Single thread, entries one after another. For each
//! sampled (σ, g, h') of the grid (σ: 64 points on [0, 20], g: 16 on [0, 0.8], h': the 32
//! non-negative of 64 on [−1, 1]; σ = 0 and |h'| = 1 rows are zero and excluded) prints the
//! photons, seconds and worst relative error reached; entries stopped by the cap get the
//! seconds extrapolated to the target (∝ error²). The mean over the sample times the number
//! of computed entries is the grid's cost (with its sampling standard error).
use scatterbake::fur::medulla_fast::{AdaptiveSettings, simulate_adaptive};
use scatterbake::math::rng::SplitMix64;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let samples: usize = args.get(1).map_or(48, |s| s.parse().unwrap());
    let cap: u64 = args.get(2).map_or(400_000, |s| s.parse().unwrap());
    let target: f64 = args.get(3).map_or(0.01, |s| s.parse().unwrap());
    let sigma = |i: usize| 20.0 * i as f64 / 63.0;
    let g = |j: usize| 0.8 * j as f64 / 15.0;
    let h = |k: usize| -1.0 + 2.0 * k as f64 / 63.0;
    // Computed entries: σ index 1..=63, all 16 g, h index 32..=62 (h ≥ 0, |h| < 1) — the
    // negative rows are mirrors and h = ±1, σ = 0 are zero.
    let entries = 63 * 16 * 31;
    let mut rng = SplitMix64::new(20_240_601);
    let mut pts: Vec<(usize, usize, usize)> = vec![(63, 15, 32), (63, 15, 47)];
    while pts.len() < samples {
        let i = 1 + (rng.next_u64() % 63) as usize;
        let j = (rng.next_u64() % 16) as usize;
        let k = 32 + (rng.next_u64() % 31) as usize;
        pts.push((i, j, k));
    }
    println!("sigma,g,h,photons,seconds,worst_rel_error,seconds_to_target");
    let mut costs = Vec::new();
    for &(i, j, k) in &pts {
        let s = AdaptiveSettings {
            seed: 1,
            max_photons: cap,
            target_rel_error: target,
            ..AdaptiveSettings::default()
        };
        let t = Instant::now();
        let p = simulate_adaptive(sigma(i), g(j), h(k), &s);
        let secs = t.elapsed().as_secs_f64();
        let to_target = secs * (p.worst_rel_error / target).max(1.0).powi(2);
        costs.push(to_target);
        println!(
            "{:.4},{:.4},{:.4},{},{secs:.3},{:.4},{to_target:.3}",
            sigma(i),
            g(j),
            h(k),
            p.photons,
            p.worst_rel_error
        );
    }
    let n = costs.len() as f64;
    let mean = costs.iter().sum::<f64>() / n;
    let sd = (costs.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    println!(
        "# mean seconds per entry to the target {mean:.2} ± {:.2}; grid ({entries} computed entries) {:.1} ± {:.1} core-hours",
        sd / n.sqrt(),
        mean * entries as f64 / 3600.0,
        sd / n.sqrt() * entries as f64 / 3600.0
    );
}
