//! Timing of the 2-D ray tracer at thesis resolution (figures for docs/raytrace.md; a
//! measurement, not a test):
//!
//! - `cargo run --release --example raytrace_perf` — 3000² rays, one wavelength (650 nm),
//!   0.0125° polar steps (14401 rows) and 36 or 180 of the 1800 azimuth columns, for a 0.4 mm
//!   sphere and a 1 mm Beard–Chuang drop, on 2 threads and on 1;
//! - `cargo run --release --example raytrace_perf -- full` — the full 14401 × 1800 direction
//!   grid for the sphere (≈ 3.3 GB of accumulators), on 2 threads and on 1, with the time
//!   extrapolated to 33 wavelengths;
//! - `cargo run --release --example raytrace_perf -- seed THREADS` — the full grid for the
//!   sphere once, with a fingerprint of the accumulated fields (sums of |field|² per order),
//!   to compare two versions of the tracer;
//! - `cargo run --release --example raytrace_perf -- profile` — a 600² sphere onto
//!   3601 × 1800 directions, a target for `perf record`.
//!
//! `RAY_GRID=silhouette` traces the silhouette ray grid instead of the square one.

use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};

fn config(rays: usize) -> TraceConfig {
    let ray_grid = match std::env::var("RAY_GRID").as_deref() {
        Ok("silhouette") => RayGridLayout::Silhouette,
        Ok("square") | Err(_) => RayGridLayout::Square,
        Ok(other) => {
            eprintln!("unknown RAY_GRID `{other}`: expected `square` or `silhouette`");
            std::process::exit(2);
        }
    };
    TraceConfig {
        rays,
        max_order: 3,
        sun_elevation_rad: 0.4,
        wavelength_nm: 650.0,
        n: 1.331,
        ray_grid,
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

fn thesis_resolution() {
    for (name, shape) in [
        ("sphere 0.4 mm", DropShape::Sphere { radius_um: 400.0 }),
        ("beard-chuang 1 mm", DropShape::beard_chuang(1.0)),
    ] {
        for (n_azimuth, threads) in [(36usize, 2usize), (36, 1), (180, 2)] {
            let grid = DirectionGrid {
                n_polar: 14401,
                n_azimuth,
            };
            let t = std::time::Instant::now();
            let f = pool(threads).install(|| trace_fields(&shape, &config(3000), grid));
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

fn full_grid() {
    let shape = DropShape::Sphere { radius_um: 400.0 };
    let grid = DirectionGrid {
        n_polar: 14401,
        n_azimuth: 1800,
    };
    for threads in [2usize, 1] {
        let t = std::time::Instant::now();
        let f = pool(threads).install(|| trace_fields(&shape, &config(3000), grid));
        let el = t.elapsed().as_secs_f64();
        println!(
            "sphere 0.4 mm: 3000² rays, 14401 × 1800 directions, {threads} thread(s): {el:.1} s ({} values); ×33 wavelengths = {:.1} min",
            f.len(),
            33.0 * el / 60.0
        );
    }
}

fn seed_once(threads: usize) {
    let shape = DropShape::Sphere { radius_um: 400.0 };
    let grid = DirectionGrid {
        n_polar: 14401,
        n_azimuth: 1800,
    };
    let t = std::time::Instant::now();
    let f = pool(threads).install(|| trace_fields(&shape, &config(3000), grid));
    let el = t.elapsed().as_secs_f64();
    let mut power = vec![0.0f64; f.orders];
    for j in 0..grid.n_polar {
        for k in 0..grid.n_azimuth {
            for (o, p) in power.iter_mut().enumerate() {
                *p += f
                    .order_pixel(o, j, k)
                    .iter()
                    .map(|z| z.norm_sqr() as f64)
                    .sum::<f64>();
            }
        }
    }
    println!(
        "sphere 0.4 mm, seed grid, {threads} thread(s): {el:.2} s; Σ|field|² per order {:?}",
        power.iter().map(|p| format!("{p:.9e}")).collect::<Vec<_>>()
    );
}

fn profile() {
    let t = std::time::Instant::now();
    let f = trace_fields(
        &DropShape::Sphere { radius_um: 400.0 },
        &config(600),
        DirectionGrid {
            n_polar: 3601,
            n_azimuth: 1800,
        },
    );
    println!(
        "sphere 600² rays onto 3601 × 1800 directions: {:.2} s, {} rays traced",
        t.elapsed().as_secs_f64(),
        f.rays_traced
    );
}

fn main() {
    match std::env::args().nth(1).as_deref() {
        None => thesis_resolution(),
        Some("full") => full_grid(),
        Some("profile") => profile(),
        Some("seed") => seed_once(
            std::env::args()
                .nth(2)
                .and_then(|s| s.parse().ok())
                .unwrap_or(2),
        ),
        Some(other) => {
            eprintln!("unknown mode `{other}`: expected no argument, `full` or `profile`");
            std::process::exit(2);
        }
    }
}
