//! Thesis-resolution timing of the 2-D tracer (not a test of correctness; prints figures for
//! docs/raytrace.md): `cargo test --release --test raytrace_perf -- --ignored --nocapture`.
//! 3000 × 3000 rays, one wavelength, 0.0125° polar steps (14401 rows) and a subset of the
//! 1800 azimuth columns, on all threads and on one thread.

use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::tracer::{DirectionGrid, TraceConfig, trace_fields};

#[test]
#[ignore]
fn thesis_resolution_timing() {
    for (name, shape) in [
        ("sphere 0.4 mm", DropShape::Sphere { radius_um: 400.0 }),
        ("beard-chuang 1 mm", DropShape::beard_chuang(1.0)),
    ] {
        for &n_azimuth in &[36usize, 180] {
            for threads in [2usize, 1] {
                if threads == 1 && n_azimuth != 36 {
                    continue;
                }
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let cfg = TraceConfig {
                    rays: 3000,
                    max_order: 3,
                    sun_elevation_rad: 0.4,
                    wavelength_nm: 650.0,
                    n: 1.331,
                };
                let grid = DirectionGrid {
                    n_polar: 14401,
                    n_azimuth,
                };
                let t = std::time::Instant::now();
                let f = pool.install(|| trace_fields(&shape, &cfg, grid));
                let el = t.elapsed().as_secs_f64();
                println!(
                    "{name}: 3000² rays, 14401 × {n_azimuth} directions, {threads} thread(s): {el:.1} s ({:.0} rays/s); σ_GO/πa² = {:.4}",
                    9e6 / el,
                    f.order_cross_section_um2.iter().sum::<f64>()
                        / (std::f64::consts::PI * shape.radius_um().powi(2))
                );
            }
        }
    }
}

/// The full configuration of Sadeghi 2012 for one wavelength: 3000² rays onto 14401 × 1800
/// directions (needs ≈ 3.3 GB of accumulators): `cargo test --release --test raytrace_perf full -- --ignored --nocapture`.
#[test]
#[ignore]
fn full_thesis_grid_one_wavelength() {
    let shape = DropShape::Sphere { radius_um: 400.0 };
    let cfg = TraceConfig {
        rays: 3000,
        max_order: 3,
        sun_elevation_rad: 0.4,
        wavelength_nm: 650.0,
        n: 1.331,
    };
    let grid = DirectionGrid {
        n_polar: 14401,
        n_azimuth: 1800,
    };
    for threads in [2usize, 1] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let t = std::time::Instant::now();
        let f = pool.install(|| trace_fields(&shape, &cfg, grid));
        let el = t.elapsed().as_secs_f64();
        println!(
            "sphere 0.4 mm: 3000² rays, 14401 × 1800 directions, {threads} thread(s): {el:.1} s; ×33 wavelengths = {:.1} min; thesis 350 min → ratio {:.1}",
            33.0 * el / 60.0,
            350.0 * 60.0 / (33.0 * el)
        );
        assert_eq!(f.data.len(), 14401 * 1800 * 16);
    }
}
