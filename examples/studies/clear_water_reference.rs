//! A dense reference for size-distribution averages of clear water (`k = 0`), whose narrow
//! resonances no affordable rule resolves (docs/mie.md, "Clear water"): a midpoint rule in `x`
//! of `N` nodes over the distribution's whole support, written as two interleaved halves (even
//! and odd nodes, each a midpoint rule of twice the step). Sampled at random by both halves,
//! the resonances make their errors nearly independent, so half their difference estimates the
//! error of the full rule; the output states it (`half_difference`).
//!
//! ```text
//! cargo run --release --example clear_water_reference -- CASE K NODES OUT.json
//! ```
//! `CASE` is `fog` (lognormal 6 µm / 1.35) or `cloud` (gamma 10 µm / 0.1), 550 nm,
//! `m = 1.333 + K i`, point values at 0, 0.5, …, 180°. The written JSON has the columns
//! `points_i_perp`, `points_i_par` and the RMS and largest half difference relative to the phase
//! function, as `tests/data/mie_distribution_reference.json` has them.
use num_complex::Complex64;
use rayon::prelude::*;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::mie::size_average::{CROSS_SECTIONS, PointAngles, RadiusIntegrand};
use std::time::Instant;

/// The distributions of the accuracy study (`tests/data/mie_distribution_reference.json`).
fn distribution(case: &str) -> anyhow::Result<SizeDistribution> {
    Ok(match case {
        "fog" => SizeDistribution::Lognormal {
            median_radius_um: 6.0,
            geometric_sigma: 1.35,
        },
        "cloud" => SizeDistribution::Gamma {
            effective_radius_um: 10.0,
            effective_variance: 0.1,
        },
        other => anyhow::bail!("unknown case {other} (fog or cloud)"),
    })
}

/// Sums of `n(r) v(r)` over the even and the odd nodes of the midpoint rule.
fn half_sums(
    d: &SizeDistribution,
    integrand: &PointAngles,
    nodes: usize,
) -> anyhow::Result<[Vec<f64>; 2]> {
    let (lo, hi) = d.support_um();
    let h = (hi - lo) / nodes as f64;
    let len = integrand.curve_len() + CROSS_SECTIONS;
    let chunks: Vec<usize> = (0..nodes.div_ceil(4096)).collect();
    let parts = chunks
        .par_iter()
        .map(|&c| {
            let mut s = [vec![0.0; len], vec![0.0; len]];
            for i in c * 4096..((c + 1) * 4096).min(nodes) {
                let r = lo + (i as f64 + 0.5) * h;
                let v = integrand.node(r)?;
                let w = d.density(r);
                s[i % 2].iter_mut().zip(&v).for_each(|(a, b)| *a += w * b);
            }
            Ok(s)
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let mut total = [vec![0.0; len], vec![0.0; len]];
    for p in parts {
        for k in 0..2 {
            total[k].iter_mut().zip(&p[k]).for_each(|(a, b)| *a += b);
        }
    }
    Ok(total)
}

/// The normalised curve (`i_perp` then `i_par`) of a sum of node vectors.
fn curve(sum: &[f64], curve_len: usize) -> Vec<f64> {
    let c_sca = sum[curve_len + 3];
    sum[..curve_len].iter().map(|v| v / c_sca).collect()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [case, k, nodes, out] = args.as_slice() else {
        anyhow::bail!("usage: clear_water_reference CASE K NODES OUT.json");
    };
    let d = distribution(case)?;
    let k: f64 = k.parse()?;
    let nodes: usize = nodes.parse()?;
    let angles: Vec<f64> = (0..=360).map(|j| j as f64 * 0.5).collect();
    let integrand = PointAngles::new(550.0, Complex64::new(1.333, k), &angles);
    let t0 = Instant::now();
    let [even, odd] = half_sums(&d, &integrand, nodes)?;
    let len = integrand.curve_len();
    let full: Vec<f64> = even.iter().zip(&odd).map(|(a, b)| a + b).collect();
    let (f, e, o) = (curve(&full, len), curve(&even, len), curve(&odd, len));
    let a = angles.len();
    let (mut sq, mut max) = (0.0, 0.0f64);
    for j in 0..len {
        let phase = 0.5 * (f[j % a] + f[a + j % a]);
        let r = 0.5 * (e[j] - o[j]).abs() / phase;
        sq += r * r;
        max = max.max(r);
    }
    let rms = (sq / len as f64).sqrt();
    let seconds = t0.elapsed().as_secs_f64();
    println!(
        "{case} k={k} nodes={nodes}: half difference rms {rms:.3e} max {max:.3e}, {seconds:.1} s"
    );
    let json = serde_json::json!({
        "distribution": d,
        "wavelength_nm": 550.0,
        "m": [1.333, k],
        "rule": format!("midpoint in x over the support, {nodes} nodes; check: its even and odd halves"),
        "half_difference": {"rms": rms, "max": max},
        "seconds": seconds,
        "points_deg": angles,
        "points_i_perp": &f[..a],
        "points_i_par": &f[a..],
    });
    std::fs::write(out, serde_json::to_string(&json)?)?;
    Ok(())
}
