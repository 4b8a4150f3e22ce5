//! Cost of one Marshall–Palmer table entry (rain 0.05–3 mm) against one 1 mm drop, at one
//! wavelength, with the `mie` stage's current radius quadrature (Gauss–Legendre in ln r) and
//! filters (0.05° bins, 0.5° sun disc). Prints wall times and their ratio (same run, same
//! machine); run single-threaded for a per-core figure:
//!
//! ```text
//! RAYON_NUM_THREADS=1 cargo run --release --example mie_distribution_cost -- [WAVELENGTH_NM] [RADIUS_POINTS]
//! ```
use num_complex::Complex64;
use scatterbake::mie::distributions::SizeDistribution;
use scatterbake::optics::water::WaterIndexModel;
use scatterbake::stages::mie::{FilterSettings, compute_entry};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let wavelength_nm: f64 = args.get(1).map_or(Ok(650.0), |s| s.parse())?;
    let radius_points: usize = args.get(2).map_or(Ok(24), |s| s.parse())?;
    let settings = FilterSettings {
        output_intervals: 3600,
        sun_diameter_deg: 0.5,
        gaussian_sigma_deg: 0.0,
        radius_points,
    };
    let sun = settings.sun_operator();
    let m = Complex64::new(WaterIndexModel::default().index(wavelength_nm)?, 0.0);
    let time = |d: &SizeDistribution| -> anyhow::Result<f64> {
        let t = Instant::now();
        let r = compute_entry(d, wavelength_nm, m, &settings, &sun)?;
        let s = t.elapsed().as_secs_f64();
        println!("  {d:?}: {s:.3} s (Q_sca {:.6}, g {:.6})", r.q_sca, r.g);
        Ok(s)
    };
    println!(
        "wavelength {wavelength_nm} nm, {radius_points} radius nodes, 0.05 deg bins, sun 0.5 deg"
    );
    let one = time(&SizeDistribution::Monodisperse { radius_um: 1000.0 })?;
    let rain = time(&SizeDistribution::MarshallPalmer {
        rain_rate_mm_h: 5.0,
        min_radius_um: 50.0,
        max_radius_um: 3000.0,
    })?;
    println!("Marshall-Palmer entry / one 1 mm drop = {:.1}", rain / one);
    Ok(())
}
