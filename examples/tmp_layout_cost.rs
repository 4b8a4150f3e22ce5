use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};
fn main() {
    let prof = DropShape::Series(
        scatterbake::raytrace::shape::CosineSeries::fit_table(400.0, &[0.0, 90.0, 180.0], &[1.0, 1.0, 1.0]).unwrap().0,
    );
    for (name, shape) in [("sphere", DropShape::Sphere { radius_um: 400.0 }), ("profile", prof), ("bc1", DropShape::beard_chuang(1.0)), ("bc2", DropShape::beard_chuang(2.0))] {
        for np in [14401usize] {
            for layout in [RayGridLayout::Square, RayGridLayout::Silhouette] {
                let cfg = TraceConfig { rays: 600, max_order: 3, sun_elevation_rad: 17f64.to_radians(), wavelength_nm: 650.0, n: 1.331, ray_grid: layout };
                let t = std::time::Instant::now();
                let f = trace_fields(&shape, &cfg, DirectionGrid { n_polar: np, n_azimuth: 72 });
                println!("{name} np={np} {layout:?}: {:.2} s, patch/ray {:?}", t.elapsed().as_secs_f64(),
                    f.patch_cross_section_um2.iter().zip(&f.order_cross_section_um2).map(|(a,b)| format!("{:.4}", a/b)).collect::<Vec<_>>());
            }
        }
    }
}
