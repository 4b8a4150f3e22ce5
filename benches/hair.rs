//! Hair Dual Scattering timings. Run: `cargo bench --bench hair`.
//!
//! - `full_sweep_lut_64x64x16`: the whole default LUT (64 θ × 64 absorption × 16 roughness,
//!   with its quadrature-doubling check), all tasks over rayon, as the pipeline runs it;
//! - `one_cell/*`: the twelve quantities for one (θ, σ_a, β) cell by scatterbake's factored
//!   h-integral with erf hemisphere windows, against the peer a straightforward port uses:
//!   evaluate N_p(φ) pointwise (h-integral per φ) on a 256-node Gauss–Legendre φ grid and sum
//!   the hemispheres.
use criterion::{Criterion, criterion_group, criterion_main};
use scatterbake::hair::dual::{
    HQuadrature, LobeShape, PhysicalFiber, combine, dual_scattering_physical,
};
use scatterbake::hair::fiber::{FresnelModel, LOBES, azimuthal_pointwise};
use scatterbake::math::quadrature::gauss_legendre_interval;
use scatterbake::stages::hair::{HairDualJob, HairDualParams};
use scatterbake::stages::run_in_memory;
use std::hint::black_box;

fn full_sweep(c: &mut Criterion) {
    let roughness: Vec<String> = (0..16)
        .map(|i| format!("{:.3}", 2.0 + 1.2 * i as f64))
        .collect();
    let src = format!(
        "roughness_deg = [{}]\nabsorption_count = 64\ntheta_count = 64",
        roughness.join(", ")
    );
    let params: HairDualParams = toml::from_str(&src).unwrap();
    let job = HairDualJob::new(params).unwrap();
    let mut g = c.benchmark_group("hair_dual");
    g.sample_size(10);
    g.bench_function("full_sweep_lut_64x64x16", |b| {
        b.iter(|| black_box(run_in_memory(&job).unwrap()))
    });
    g.finish();
}

fn one_cell(c: &mut Criterion) {
    let fiber = PhysicalFiber {
        eta: 1.55,
        fresnel: FresnelModel::ThreeD,
        lobes: LobeShape::marschner(5f64.to_radians(), 7.5f64.to_radians()),
        azimuthal_width_rad: 7.5f64.to_radians(),
        diffuse: Default::default(),
        axis_ratio: 1.0,
    };
    let theta = 0.4;
    let sigma = 0.3;
    let mut g = c.benchmark_group("hair_dual_one_cell");
    g.sample_size(20);
    g.bench_function("scatterbake_factored", |b| {
        b.iter(|| {
            black_box(dual_scattering_physical(
                &fiber,
                theta,
                sigma,
                0.7,
                0.99,
                &HQuadrature::default(),
            ))
        })
    });
    g.bench_function("peer_pointwise_phi_grid_256", |b| {
        b.iter(|| {
            let (x, w) = gauss_legendre_interval(256, 0.0, std::f64::consts::PI);
            let mut eb = [0.0; LOBES];
            let mut ef = [0.0; LOBES];
            for (phi, wt) in x.iter().zip(&w) {
                let n = azimuthal_pointwise(&fiber.pointwise(sigma, 90), theta, *phi);
                let e = if *phi < std::f64::consts::FRAC_PI_2 {
                    &mut eb
                } else {
                    &mut ef
                };
                for p in 0..LOBES {
                    e[p] += 2.0 * wt * n[p];
                }
            }
            black_box(combine(&eb, &ef, &fiber.lobes, 0.7, 0.99))
        })
    });
    g.finish();
}

criterion_group!(benches, full_sweep, one_cell);
criterion_main!(benches);
