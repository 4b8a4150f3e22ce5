//! Debye series vs plain Lorenz–Mie, single thread, 3601 angles (0..180° step 0.05°, computed
//! as 1801 mirrored cosines like the Mie bench) at m = 1.333, x = 1e3 and 1e4:
//! - `mie`: `Sphere::new` + S1/S2 (the peer, same run);
//! - `debye-coefficients`: the surface coefficients R22/R11/T21T12 (includes the Mie solve it
//!   wraps);
//! - `debye-one-order`: coefficients + S1/S2 of one order (p = 2);
//! - `debye-orders-0-3`: coefficients + S1/S2 of each of p = 0, 1, 2, 3 separately.
//!
//! Ratios: divide each time by the `mie` time of the same x.
//!
//! ```text
//! cargo bench --bench debye
//! ```

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use num_complex::Complex64;
use scatterbake::debye::{DebyeCoefficients, OrderSet};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let m = Complex64::new(1.333, 0.0);
    let half: Vec<f64> = (0..=1800)
        .map(|k| (0.05 * k as f64).to_radians().cos())
        .collect();
    let mut group = c.benchmark_group("debye-3601-angles");
    group.sample_size(10);
    group.measurement_time(std::time::Duration::from_secs(3));
    group.warm_up_time(std::time::Duration::from_millis(500));
    for x in [1e3, 1e4] {
        group.bench_with_input(BenchmarkId::new("mie", x), &x, |b, &x| {
            b.iter(|| {
                let s = scatterbake::mie::Sphere::new(black_box(x), m).unwrap();
                black_box(s.amplitudes_mirrored(&half, false))
            })
        });
        group.bench_with_input(BenchmarkId::new("debye-coefficients", x), &x, |b, &x| {
            b.iter(|| black_box(DebyeCoefficients::new(black_box(x), m).unwrap()))
        });
        group.bench_with_input(BenchmarkId::new("debye-one-order", x), &x, |b, &x| {
            b.iter(|| {
                let d = DebyeCoefficients::new(black_box(x), m).unwrap();
                let (a, bb) = d.coefficients(&OrderSet::Orders(vec![2]));
                black_box(d.term_sphere(a, bb).amplitudes_mirrored(&half, false))
            })
        });
        group.bench_with_input(BenchmarkId::new("debye-orders-0-3", x), &x, |b, &x| {
            b.iter(|| {
                let d = DebyeCoefficients::new(black_box(x), m).unwrap();
                for p in 0..=3 {
                    let (a, bb) = d.coefficients(&OrderSet::Orders(vec![p]));
                    black_box(d.term_sphere(a, bb).amplitudes_mirrored(&half, false));
                }
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
