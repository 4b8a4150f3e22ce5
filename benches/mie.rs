//! Single-thread Lorenz–Mie benchmark: coefficients + S1/S2 at 3601 angles (0..180° step
//! 0.05°) for x = 1e2, 1e3, 1e4, 1e5 at m = 1.333, scatterbake against the `scatrs` crate in
//! the same run (scatrs only up to its validated x = 2e4; at 1e5 it runs with
//! `allow_unvalidated`). Ratios: divide the `scatrs/…` time by the `scatterbake/…` time.
//!
//! ```text
//! cargo bench --bench mie
//! ```
//!
//! Group `mie-batch-901-cosines`: the angular sums alone (coefficients solved beforehand) of 16
//! spheres x = 300, 303, …, 345 at 901 cosines (0..90° step 0.1°, mirrors included), one
//! sphere at a time (`amplitudes_mirrored`) against the batched kernel
//! (`amplitudes_mirrored_batch`) with all 16 in one batch and with batches of one. Ratio:
//! `per-sphere` time over `batch-16`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use num_complex::Complex64;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let m = Complex64::new(1.333, 0.0);
    let angles = 3601;
    let mu: Vec<f64> = (0..angles)
        .map(|k| (0.05 * k as f64).to_radians().cos())
        .collect();
    // half grid for the mirrored kernel: θ ≤ 90° (1801 cosines), mirrors give θ ≥ 90°
    let half: Vec<f64> = mu[..=1800].to_vec();
    let mut group = c.benchmark_group("mie-3601-angles");
    group.sample_size(10);
    group.measurement_time(std::time::Duration::from_secs(3));
    group.warm_up_time(std::time::Duration::from_millis(500));
    for x in [1e2, 1e3, 1e4, 1e5] {
        group.bench_with_input(BenchmarkId::new("scatterbake", x), &x, |b, &x| {
            b.iter(|| {
                let s = scatterbake::mie::Sphere::new(black_box(x), m).unwrap();
                black_box(s.amplitudes_mirrored(&half, false))
            })
        });
        let opts = scatrs::mie::MieOptions::new().with_allow_unvalidated(x > 2e4);
        let mut ws = scatrs::mie::Mie::<f64>::new();
        let (mut s1, mut s2) = (
            vec![Complex64::new(0.0, 0.0); angles],
            vec![Complex64::new(0.0, 0.0); angles],
        );
        group.bench_with_input(BenchmarkId::new("scatrs", x), &x, |b, &x| {
            b.iter(|| {
                let sol = ws.compute(black_box(x), m, &opts).unwrap();
                sol.amplitudes(
                    &mu,
                    scatrs::mie::AmplitudeBuffers {
                        s1: &mut s1,
                        s2: &mut s2,
                    },
                )
                .unwrap();
                black_box((&s1, &s2));
            })
        });
    }
    group.finish();
}

fn bench_batch(c: &mut Criterion) {
    let m = Complex64::new(1.333, 0.0);
    let mu: Vec<f64> = (0..=900)
        .map(|k| (0.1 * k as f64).to_radians().cos())
        .collect();
    let spheres: Vec<scatterbake::mie::Sphere> = (0..16)
        .map(|i| scatterbake::mie::Sphere::new(300.0 + 3.0 * i as f64, m).unwrap())
        .collect();
    let refs: Vec<&scatterbake::mie::Sphere> = spheres.iter().collect();
    let mut group = c.benchmark_group("mie-batch-901-cosines");
    group.sample_size(10);
    group.measurement_time(std::time::Duration::from_secs(3));
    group.warm_up_time(std::time::Duration::from_millis(500));
    group.bench_function("per-sphere", |b| {
        b.iter(|| {
            for s in &spheres {
                black_box(s.amplitudes_mirrored(black_box(&mu), false));
            }
        })
    });
    group.bench_function("batch-16", |b| {
        b.iter(|| {
            black_box(scatterbake::mie::Sphere::amplitudes_mirrored_batch(
                &refs,
                black_box(&mu),
            ))
        })
    });
    group.bench_function("batch-1", |b| {
        b.iter(|| {
            for s in &refs {
                black_box(scatterbake::mie::Sphere::amplitudes_mirrored_batch(
                    std::slice::from_ref(s),
                    black_box(&mu),
                ));
            }
        })
    });
    group.finish();
}

criterion_group!(benches, bench, bench_batch);
criterion_main!(benches);
