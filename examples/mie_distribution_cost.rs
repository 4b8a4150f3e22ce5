//! Cost of one Marshall–Palmer table entry (rain 0.05–3 mm) against one 1 mm drop, at one
//! wavelength, with the `mie` stage's current radius quadrature (Gauss–Legendre in ln r) and
//! filters (0.05° bins, 0.5° sun disc). Prints wall times and their ratio (same run, same
//! machine); run single-threaded for a per-core figure:
//!
//! ```text
//! RAYON_NUM_THREADS=1 cargo run --release --example mie_distribution_cost -- [WAVELENGTH_NM] [RADIUS_POINTS] [REFERENCE_POINTS]
//! ```
//! With `REFERENCE_POINTS`, the Marshall–Palmer entry is computed again with that many nodes and
//! the differences (max and rms relative over the 0.05° bins of the phase function, Q_sca, g)
//! are printed: the quadrature error of `RADIUS_POINTS` nodes against a denser rule.
use num_complex::Complex64;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::optics::water::WaterIndexModel;
use scatterbake::stages::mie::{FilterSettings, compute_entry};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let wavelength_nm: f64 = args.get(1).map_or(Ok(650.0), |s| s.parse())?;
    let radius_points: usize = args.get(2).map_or(Ok(24), |s| s.parse())?;
    let reference_points: Option<usize> = args.get(3).map(|s| s.parse()).transpose()?;
    let settings = FilterSettings {
        output_intervals: 3600,
        sun_diameter_deg: 0.5,
        gaussian_sigma_deg: 0.0,
        radius_points,
    };
    let sun = settings.sun_operator();
    let m = Complex64::new(WaterIndexModel::default().index(wavelength_nm)?, 0.0);
    let time = |d: &SizeDistribution, settings: &FilterSettings| {
        let t = Instant::now();
        let r = compute_entry(d, wavelength_nm, m, settings, &sun)?;
        let s = t.elapsed().as_secs_f64();
        println!(
            "  {d:?}, {} nodes: {s:.3} s (Q_sca {:.9}, g {:.9})",
            settings.radius_points, r.q_sca, r.g
        );
        anyhow::Ok((s, r))
    };
    println!(
        "wavelength {wavelength_nm} nm, {radius_points} radius nodes, 0.05 deg bins, sun 0.5 deg"
    );
    let (one, _) = time(
        &SizeDistribution::Monodisperse { radius_um: 1000.0 },
        &settings,
    )?;
    let rain_distribution = SizeDistribution::MarshallPalmer {
        rain_rate_mm_h: 5.0,
        min_radius_um: 50.0,
        max_radius_um: 3000.0,
    };
    let (rain, r) = time(&rain_distribution, &settings)?;
    println!("Marshall-Palmer entry / one 1 mm drop = {:.1}", rain / one);
    if let Some(points) = reference_points {
        let dense = FilterSettings {
            radius_points: points,
            ..settings
        };
        let (_, reference) = time(&rain_distribution, &dense)?;
        let (p, q) = (r.curve.phase(), reference.curve.phase());
        let rel: Vec<f64> = p.iter().zip(&q).map(|(a, b)| (a - b).abs() / b).collect();
        let max = rel.iter().cloned().fold(0.0, f64::max);
        let worst = rel.iter().position(|e| *e == max).unwrap_or(0) as f64 * 0.05;
        let rms = (rel.iter().map(|e| e * e).sum::<f64>() / rel.len() as f64).sqrt();
        println!(
            "{radius_points} vs {points} nodes: phase max rel. {max:.2e} (at {worst:.2} deg), rms {rms:.2e}; Q_sca {:.2e}, g {:.2e}",
            (r.q_sca - reference.q_sca).abs() / reference.q_sca,
            (r.g - reference.g).abs() / reference.g
        );
    }
    Ok(())
}
