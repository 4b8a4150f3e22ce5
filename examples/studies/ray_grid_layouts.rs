//! The two ray-grid layouts of the 2-D tracer side by side (figures for docs/raytrace.md, "Ray
//! grid on the silhouette"; a measurement, not a test): for a sphere and Beard–Chuang drops,
//! 600² rays onto 0.1° × 5° directions (the stage defaults), 650 nm, sun 0° and 40°, the trace
//! time and per order the flux carried by the patches over the rays' flux (the square grid
//! discards the triangles that straddle the silhouette).
//!
//! `cargo run --release --example ray_grid_layouts -- [rays]`
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};

fn main() {
    let rays: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(600);
    let grid = DirectionGrid {
        n_polar: 1801,
        n_azimuth: 72,
    };
    println!("shape,sun_elevation_deg,ray_grid,trace_s,patch_over_ray_p0,p1,p2,p3");
    for (name, shape) in [
        ("sphere 0.4 mm", DropShape::Sphere { radius_um: 400.0 }),
        ("beard-chuang 1 mm", DropShape::beard_chuang(1.0)),
        ("beard-chuang 2 mm", DropShape::beard_chuang(2.0)),
        ("beard-chuang 3 mm", DropShape::beard_chuang(3.0)),
    ] {
        for elev in [0.0f64, 40.0] {
            for layout in [RayGridLayout::Square, RayGridLayout::Silhouette] {
                let cfg = TraceConfig {
                    rays,
                    max_order: 3,
                    sun_elevation_rad: elev.to_radians(),
                    wavelength_nm: 650.0,
                    n: 1.331,
                    ray_grid: layout,
                };
                let t = std::time::Instant::now();
                let f = trace_fields(&shape, &cfg, grid);
                let secs = t.elapsed().as_secs_f64();
                let ratios: Vec<String> = f
                    .patch_cross_section_um2
                    .iter()
                    .zip(&f.order_cross_section_um2)
                    .map(|(p, r)| format!("{:.4}", p / r))
                    .collect();
                println!("{name},{elev},{layout:?},{secs:.2},{}", ratios.join(","));
            }
        }
    }
}
