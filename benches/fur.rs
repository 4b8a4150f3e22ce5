//! Medulla Monte Carlo estimators, timed in the same run: `cargo bench --bench fur`.
//! Time per photon of the expected-value (next-event + survival biasing) estimator against the
//! plain histogram peer, azimuthal σ = 2.5, g = 0.4, h' = 0.5, 720 bins. Combine the time ratio
//! with the variance ratio (examples/studies/fur_efficiency.rs, docs/fur.md) for the equal-time gain.
use criterion::{Criterion, criterion_group, criterion_main};
use scatterbake::fur::medulla::{Estimator, Geometry, McSettings, simulate};
use std::hint::black_box;

fn estimators(c: &mut Criterion) {
    let mut g = c.benchmark_group("fur_medulla_azimuthal_s2.5_g0.4_h0.5");
    g.sample_size(10);
    for (name, est, photons) in [
        ("expected_100_photons", Estimator::Expected, 100u64),
        ("histogram_100_photons", Estimator::Histogram, 100u64),
    ] {
        let s = McSettings {
            photons,
            seed: 1,
            estimator: est,
            bins: 720,
            max_order: None,
        };
        g.bench_function(name, |b| {
            b.iter(|| simulate(black_box(2.5), 0.4, Geometry::Azimuthal { h: 0.5 }, &s))
        });
    }
    g.finish();
}

criterion_group!(benches, estimators);
criterion_main!(benches);
