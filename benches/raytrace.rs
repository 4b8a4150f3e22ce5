//! Ray-tracer benchmarks: `cargo bench --bench raytrace`.
//!
//! - `sphere_1d/*`: one 1-D sphere phase function (0.4 mm, 650 nm, 3601 angles over 0–180°,
//!   orders 0–3, Airy caustics) with the exact 1-D path, against the scatrs Lorenz–Mie code
//!   (independent peer) computing S1, S2 at the same 3601 angles in the same run; and the
//!   default sphere model (orders 0–6, the grazing waves of p ≥ 4) at 0.4 and 2.5 mm, with the
//!   same orders as rays alone (`with_surface_coefficients(false)`) as the in-run reference;
//! - `tracer_2d/*`: the 2-D patch tracer (rays/s) for a 0.4 mm sphere and a 1 mm Beard–Chuang
//!   drop at 650 nm onto a 1801 × 36 direction grid.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use num_complex::Complex;
use scatrs::mie::{AmplitudeBuffers, Mie, MieOptions};
use scatterbake::raytrace::shape::DropShape;
use scatterbake::raytrace::sphere1d::{Phase1dOptions, SphereGo, sphere_phase_1d};
use scatterbake::raytrace::tracer::{DirectionGrid, RayGridLayout, TraceConfig, trace_fields};
use std::f64::consts::PI;
use std::hint::black_box;

fn sphere_1d(c: &mut Criterion) {
    let (a, lambda, n) = (400.0, 650.0, 1.331);
    let angles: Vec<f64> = (0..3601).map(|j| 0.05 * j as f64).collect();
    let mut g = c.benchmark_group("sphere_1d");
    g.sample_size(10);
    g.bench_function("raytrace_1d_go_airy_0.4mm_650nm_3601_angles", |b| {
        b.iter(|| {
            let go = SphereGo::new(a, lambda, n, 3);
            black_box(sphere_phase_1d(&go, &angles, Phase1dOptions::default()))
        })
    });
    for (a_um, lambda_nm) in [(400.0, 650.0), (2500.0, 380.0)] {
        for grazing in [true, false] {
            let name = if grazing {
                "grazing_waves"
            } else {
                "rays_only"
            };
            g.bench_function(
                format!("raytrace_1d_p6_{name}_{a_um}um_{lambda_nm}nm_3601_angles"),
                |b| {
                    b.iter(|| {
                        let go =
                            SphereGo::new(a_um, lambda_nm, n, 6).with_surface_coefficients(grazing);
                        black_box(sphere_phase_1d(&go, &angles, Phase1dOptions::default()))
                    })
                },
            );
        }
    }
    g.bench_function("scatrs_mie_0.4mm_650nm_3601_angles", |b| {
        let mu: Vec<f64> = angles.iter().map(|d| d.to_radians().cos()).collect();
        let x = 2.0 * PI * a / (lambda * 1e-3);
        b.iter(|| {
            let mut m = Mie::<f64>::new();
            let sol = m
                .compute(x, Complex::new(n, 0.0), &MieOptions::new())
                .unwrap();
            let mut s1 = vec![Complex::new(0.0, 0.0); mu.len()];
            let mut s2 = vec![Complex::new(0.0, 0.0); mu.len()];
            sol.amplitudes(
                &mu,
                AmplitudeBuffers {
                    s1: &mut s1,
                    s2: &mut s2,
                },
            )
            .unwrap();
            black_box((s1, s2))
        })
    });
    g.finish();
}

fn tracer_2d(c: &mut Criterion) {
    let mut g = c.benchmark_group("tracer_2d");
    g.sample_size(10);
    let grid = DirectionGrid {
        n_polar: 1801,
        n_azimuth: 36,
    };
    for (name, shape, rays) in [
        (
            "sphere_0.4mm",
            DropShape::Sphere { radius_um: 400.0 },
            600usize,
        ),
        ("beard_chuang_1mm", DropShape::beard_chuang(1.0), 400),
    ] {
        let cfg = TraceConfig {
            rays,
            max_order: 3,
            sun_elevation_rad: 0.4,
            wavelength_nm: 650.0,
            n: 1.331,
            ray_grid: RayGridLayout::Square,
        };
        g.throughput(Throughput::Elements((rays * rays) as u64));
        g.bench_function(format!("{name}_{rays}x{rays}_rays"), |b| {
            b.iter(|| black_box(trace_fields(&shape, &cfg, grid)))
        });
    }
    g.finish();
}

criterion_group!(benches, sphere_1d, tracer_2d);
criterion_main!(benches);
