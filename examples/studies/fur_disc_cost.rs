//! Cost of the characteristics solver per σ task (all 16 g of the thesis grid, the 32
//! non-negative h' rows of its 64-point h' axis, 720 bins), single-threaded:
//! `cargo run --release --example fur_disc_cost -- SIGMA...` (default 5 10 15 20). Prints the
//! grid size, the GMRES iterations summed over g and the wall time per σ. Settings may be
//! overridden by the environment variables of `common/disc_settings.rs`.
#[path = "common/disc_settings.rs"]
mod disc_settings;
use scatterbake::fur::disc::DiscSolver;
use std::time::Instant;

fn main() {
    let mut sigmas: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().unwrap())
        .collect();
    if sigmas.is_empty() {
        sigmas = vec![5.0, 10.0, 15.0, 20.0];
    }
    let s = disc_settings::disc_settings_from_env();
    let hs: Vec<f64> = (32..64).map(|i| -1.0 + 2.0 * i as f64 / 63.0).collect();
    let gs: Vec<f64> = (0..16).map(|j| 0.8 * j as f64 / 15.0).collect();
    let mut total = 0.0;
    for &sigma in &sigmas {
        let t = Instant::now();
        let mut solver = DiscSolver::new(sigma, &s);
        let (mut it1, mut it2) = (0, 0);
        let mut check = 0.0;
        for &g in &gs {
            let p = solver.solve(g, &hs);
            it1 += p.iterations.0;
            it2 += p.iterations.1;
            check += p.energy.iter().map(|e| e.iter().sum::<f64>()).sum::<f64>();
        }
        let el = t.elapsed().as_secs_f64();
        total += el;
        let (cells, segs) = solver.size();
        println!(
            "sigma {sigma}: {cells} cells, {segs} segments, iterations {it1} + {it2}, {el:.2} s (check {check:.6})"
        );
    }
    println!("total {total:.2} s");
}
