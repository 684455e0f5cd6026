//! Integrator step cost in ns per body-step, for batches of 1, 100 and 10 000 bodies.
//!
//! `cargo bench --bench step`; criterion reports the time of one batch step: divide by the
//! batch size for ns per body-step (the `thrpt` line gives body-steps per second).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::hint::black_box;
use tumble::sim::integrators::{IntegratorKind, VariationalSettings};
use tumble::sim::{Bodies, BodyInit};

/// `n` differently initialised asymmetric bodies (deterministic pseudo-random spread).
pub fn batch(n: usize) -> Vec<BodyInit> {
    (0..n)
        .map(|i| {
            let s = i as f64;
            let f = |k: f64| ((s * 0.618_033_988_7 + k) % 1.0) * 2.0 - 1.0;
            BodyInit {
                mass: 1.0 + 0.5 * f(0.1),
                principal_moments: Vector3::new(1.0, 2.0 + 0.3 * f(0.2), 3.5 + 0.3 * f(0.3)),
                world_from_body: Isometry3::from_parts(
                    Translation3::new(f(0.4), f(0.5), 1.0 + f(0.6)),
                    UnitQuaternion::from_euler_angles(3.0 * f(0.7), 1.5 * f(0.8), 3.0 * f(0.9)),
                ),
                linvel_world: Vector3::new(f(0.11), f(0.12), f(0.13)),
                angvel_world: Vector3::new(2.0 * f(0.14), 5.0 * f(0.15), 2.0 * f(0.16)),
            }
        })
        .collect()
}

fn step(c: &mut Criterion) {
    let dt = 0.001;
    let g = Vector3::new(0.0, 0.0, -9.81);
    let mut group = c.benchmark_group("step");
    for &kind in IntegratorKind::ALL {
        for n in [1usize, 100, 10_000] {
            let mut bodies = Bodies::new(&batch(n));
            let mut integrator = kind.build(dt, &VariationalSettings::default());
            integrator.init(&bodies);
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |b, _| {
                b.iter(|| integrator.step(black_box(&mut bodies), &g))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
