//! The deterministic disc solver against the adaptive Monte Carlo at one (σ, g, h'):
//! `cargo run --release --example fur_disc_check -- SIGMA G H [CELLS_PER_MFP MAX_CELL DIRECTIONS TARGET]`.
//! Prints the solver's time, GMRES iterations and energy identity, and per 0.5° bin (bins ≥ 1e-3
//! of the maximum) the relative deviation and z against the Monte Carlo run to TARGET.
use scatterbake::fur::disc::{DiscSettings, solve_disc};
use scatterbake::fur::medulla_fast::{AdaptiveSettings, simulate_adaptive};
use std::time::Instant;

fn main() {
    let a: Vec<f64> = std::env::args()
        .skip(1)
        .map(|s| s.parse().unwrap())
        .collect();
    let (sigma, g, h) = (a[0], a[1], a[2]);
    let mut s = DiscSettings::default();
    if a.len() > 3 {
        s.cells_per_mean_free_path = a[3];
        s.max_cell = a[4];
        s.directions = a[5] as usize;
    }
    let target = a.get(6).copied().unwrap_or(0.01);
    let env = |k: &str| std::env::var(k).ok().map(|v| v.parse::<f64>().unwrap());
    if let Some(v) = env("DISC_GROWTH") {
        s.ring_growth = v;
    }
    if let Some(v) = env("DISC_ARC") {
        s.arc_ratio = v;
    }
    if let Some(v) = env("DISC_RINGS") {
        s.boundary_rings_per_mean_free_path = v;
    }
    if let Some(v) = env("DISC_TRACK") {
        s.track_spacing = v;
    }
    let refine = std::env::var("FINE").unwrap_or_else(|_| "cpm".into());
    let t = Instant::now();
    let d = solve_disc(sigma, g, &[h], &s);
    let ts = t.elapsed().as_secs_f64();
    let e = &d.energy[0];
    let sum: f64 = e.iter().sum();
    println!(
        "disc: {ts:.2} s, cell {:.4}, iterations {:?}, residual {:.1e} {:.1e}, scattered {sum:.6} vs exact {:.6} (rel {:.2e})",
        d.cell,
        d.iterations,
        d.residual.0,
        d.residual.1,
        1.0 - d.ballistic[0],
        sum / (1.0 - d.ballistic[0]) - 1.0
    );
    if target == 0.0 {
        return;
    }
    if target < 0.0 {
        // Against the same solver on a grid twice as fine (no noise): discretisation error.
        let mut fine = s;
        for r in refine.split(',') {
            match r {
                "cpm" => {
                    fine.cells_per_mean_free_path *= 2.0;
                    fine.max_cell *= 0.5;
                }
                "arc" => fine.arc_ratio *= 0.5,
                "track" => fine.track_spacing *= 0.5,
                "growth" => fine.ring_growth = 1.0 + 0.5 * (fine.ring_growth - 1.0),
                "dir" => fine.directions *= 2,
                _ => panic!("FINE: cpm, arc, track, growth, dir"),
            }
        }
        let f = solve_disc(sigma, g, &[h], &fine);
        let f = &f.energy[0];
        let max = f.iter().cloned().fold(0.0, f64::max);
        let mut rel: Vec<(f64, usize)> = (0..e.len())
            .filter(|&k| f[k] >= 1e-3 * max)
            .map(|k| (((e[k] - f[k]) / f[k]).abs(), k))
            .collect();
        rel.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n = rel.len();
        println!(
            "vs 2x finer grid: {n} bins, rel dev median {:.4} p90 {:.4} max {:.4} (at {:.1} deg)",
            rel[n / 2].0,
            rel[n * 9 / 10].0,
            rel[n - 1].0,
            -180.0 + (rel[n - 1].1 as f64 + 0.5) * 0.5
        );
        return;
    }
    let t = Instant::now();
    // Optional cache of the Monte Carlo reference (energy, std_error, path_length per line).
    let cache = std::env::var("MC_CACHE").ok();
    let cached = cache.as_ref().and_then(|c| std::fs::read_to_string(c).ok());
    let m = if let Some(text) = cached {
        let mut m = simulate_adaptive(
            sigma,
            g,
            h,
            &AdaptiveSettings {
                max_photons: 64,
                ..AdaptiveSettings::default()
            },
        );
        for (k, line) in text.lines().enumerate() {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            m.energy[k] = v[0];
            m.std_error[k] = v[1];
            m.path_length[k] = v[2];
        }
        m
    } else {
        let m = simulate_adaptive(
            sigma,
            g,
            h,
            &AdaptiveSettings {
                seed: 5,
                target_rel_error: target,
                max_photons: 4_000_000,
                ..AdaptiveSettings::default()
            },
        );
        if let Some(c) = &cache {
            let text: String = (0..m.energy.len())
                .map(|k| format!("{},{},{}\n", m.energy[k], m.std_error[k], m.path_length[k]))
                .collect();
            std::fs::write(c, text).unwrap();
        }
        m
    };
    let tm = t.elapsed().as_secs_f64();
    let max = m.energy.iter().cloned().fold(0.0, f64::max);
    let (mut rel, mut z2, mut zmax, mut n) = (Vec::new(), 0.0, 0.0f64, 0);
    let mut lrel = Vec::new();
    let mut worst = (0usize, 0.0f64);
    for k in 0..e.len() {
        if m.energy[k] < 1e-3 * max {
            continue;
        }
        let r = (e[k] - m.energy[k]) / m.energy[k];
        if r.abs() > worst.1.abs() {
            worst = (k, r);
        }
        rel.push(r.abs());
        let z = (e[k] - m.energy[k]) / m.std_error[k];
        z2 += z * z;
        zmax = zmax.max(z.abs());
        n += 1;
        lrel.push(((d.path_length[0][k] - m.path_length[k]) / m.path_length[k]).abs());
    }
    rel.sort_by(f64::total_cmp);
    lrel.sort_by(f64::total_cmp);
    println!(
        "mc: {tm:.1} s, {} photons, worst rel se {:.4}; {n} bins: rel dev median {:.4} max {:.4} (bin {} at {:.1} deg: {:+.4}), mean z2 {:.2}, max |z| {:.2}; path rel dev median {:.4} max {:.4}; mc scattered {:.6}",
        m.photons,
        m.worst_rel_error,
        rel[n / 2],
        rel[n - 1],
        worst.0,
        -180.0 + (worst.0 as f64 + 0.5) * 0.5,
        worst.1,
        z2 / n as f64,
        zmax,
        lrel[n / 2],
        lrel[n - 1],
        m.scattered
    );
}
