//! Integrator step cost in ns per body-step, for batches of 1, 100 and 10 000 bodies, and the same
//! free-body workload stepped by a peer engine, Rapier (`rapier3d-f64`), in the same run.
//!
//! `cargo bench --bench step`; criterion reports the time of one batch step and, from
//! `Throughput::Elements(n)`, body-steps per second: ns per body-step = time / n.
//! Benchmark ids: `step/<integrator>/<n>` for every [`IntegratorKind::ALL`], and
//! `peer/rapier3d-f64/<n>` (Rapier's default 4 substeps) and `peer/rapier3d-f64-1-substep/<n>`,
//! and `guard/check/<n>`, the per-step divergence check of `tumble simulate`.
//!
//! The workload: [`tumble::sim::workload::free_body_batch`] (`n` differently initialised asymmetric
//! bodies, principal moments within ±0.1 of (1, 1.5, 2) kg m², |Ω| up to 5.7 rad/s, h|Ω| ≤ 0.006
//! rad; the same bodies `tumble bench` steps), dt = 1 ms, uniform gravity, no contacts,
//! no colliders, no joints.
//!
//! What the peer computes differently (same bodies: mass, principal inertia along the same body
//! axes, pose, linear and angular velocity; checked before timing by [`check_same_problem`]):
//! - Rapier steps velocities then positions, symplectic (semi-implicit) Euler, with
//!   `num_solver_iterations` substeps per step (default 4, i.e. 4 × 0.25 ms; the `-1-substep`
//!   variant sets 1). Rotation: an explicit gyroscopic correction `ω ← ω - h J^-1 (ω × J ω)` in the
//!   principal frame, rescaled to keep |J ω| (`gyroscopic_corrected_angvel`), then
//!   `q ← exp(h ω) q`. First order, no Newton solve, the spatial momentum is not conserved (only
//!   the body momentum's magnitude is kept by the rescaling); tumble's variational step is second
//!   order, solves the implicit discrete Euler-Lagrange equations to a relative residual of 1e-12,
//!   and conserves the spatial momentum to round-off.
//! - Rapier's step is a full pipeline step (`PhysicsWorld::step` → `PhysicsPipeline::step`): it
//!   also updates the island manager (sleeping disabled here: `can_sleep(false)`), runs an empty
//!   broad and narrow phase, builds solver bodies from the rigid-body set (an arena of `RigidBody`
//!   structs, array of structures) and writes them back, and runs the (empty) constraint solver
//!   stages per substep. tumble's step only integrates the structure-of-arrays batch.
//! - Both single-threaded: `rapier3d-f64` is built without its `parallel` feature.
//!
//! Measured (medians, ns per body-step, 1 / 100 / 10 000 bodies, shared 2-core x86-64 VM):
//! `variational` 52 / 26 / 26; `rapier3d-f64` 1352 / 346 / 394; `rapier3d-f64-1-substep`
//! 1026 / 231 / 256. Rapier / variational at 10 000 bodies: 15x (default), 9.9x (one substep).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rapier3d_f64::math::{Pose, Rotation, Vector as RVector};
use rapier3d_f64::prelude::{MassProperties, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle};
use std::hint::black_box;
use tumble::sim::guard::Guard;
use tumble::sim::integrators::{IntegratorKind, Variational, VariationalSettings};
use tumble::sim::{Bodies, BodyInit, Integrator, Loads, StepStats};

const DT_SECS: f64 = 0.001;
const SIZES: [usize; 3] = [1, 100, 10_000];

fn gravity() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -9.81)
}

/// `n` differently initialised asymmetric bodies: the workload `tumble bench` steps too.
pub fn batch(n: usize) -> Vec<BodyInit> {
    tumble::sim::workload::free_body_batch(n)
}

fn rvec(v: &Vector3<f64>) -> RVector {
    RVector::new(v.x, v.y, v.z)
}

/// The same bodies in a Rapier world: principal frame = body frame (centre of mass at the body
/// origin, principal axes along the body axes), gravity, dt, no colliders.
fn rapier_world(inits: &[BodyInit], substeps: usize) -> (PhysicsWorld, Vec<RigidBodyHandle>) {
    let mut world = PhysicsWorld::new();
    world.gravity = rvec(&gravity());
    world.integration_parameters.dt = DT_SECS;
    world.integration_parameters.num_solver_iterations = substeps;
    let handles = inits
        .iter()
        .map(|b| {
            let q = b.world_from_body.rotation;
            let pose = Pose::from_parts(
                rvec(&b.world_from_body.translation.vector),
                Rotation::from_xyzw(q.i, q.j, q.k, q.w),
            );
            let mass = MassProperties::new(RVector::ZERO, b.mass, rvec(&b.principal_moments));
            world.insert_body(
                RigidBodyBuilder::dynamic()
                    .pose(pose)
                    .additional_mass_properties(mass)
                    .linvel(rvec(&b.linvel_world))
                    .angvel(rvec(&b.angvel_world))
                    .gyroscopic_forces_enabled(true)
                    .can_sleep(false),
            )
        })
        .collect();
    (world, handles)
}

/// Steps 100 bodies for 0.1 s with both engines and checks that they simulate the same motion,
/// up to Rapier's first-order error: centre of mass (Rapier's symplectic Euler lags the parabola
/// by `g t h_sub / 2` ≈ 1.2e-4 m), orientation and angular velocity (explicit gyroscopic term,
/// O(h t |Ω|^2)). Panics otherwise: a peer figure for a different problem would be meaningless.
fn check_same_problem() {
    let inits = batch(100);
    let mut bodies = Bodies::new(&inits);
    let mut integrator = Variational::new(DT_SECS, VariationalSettings::default());
    integrator.init(&bodies);
    let (mut world, handles) = rapier_world(&inits, 4);
    for _ in 0..100 {
        integrator.step(&mut bodies, &Loads::uniform_gravity(gravity()));
        world.step();
    }
    // Rapier folds the additional mass properties in during its first step (and stores 1/m).
    for (b, &h) in inits.iter().zip(&handles) {
        assert!((world.bodies[h].mass() - b.mass).abs() < 1e-12 * b.mass);
    }
    let (mut com, mut angle, mut angvel): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for (i, &h) in handles.iter().enumerate() {
        let rb = &world.bodies[h];
        let t = rb.translation();
        com = com.max((Vector3::new(t.x, t.y, t.z) - bodies.com_world[i]).norm());
        let r = rb.rotation();
        let q = UnitQuaternion::from_quaternion(Quaternion::new(r.w, r.x, r.y, r.z));
        angle = angle.max(q.angle_to(&bodies.world_from_body[i]));
        let w = rb.angvel();
        angvel = angvel.max((Vector3::new(w.x, w.y, w.z) - bodies.angvel_world(i)).norm());
    }
    eprintln!(
        "same problem, 100 bodies after 0.1 s: max |Δcom| = {com:.1e} m, max angle = {angle:.1e} rad, \
         max |Δω| = {angvel:.1e} rad/s"
    );
    assert!(
        com < 1e-3 && angle < 1e-2 && angvel < 1e-1,
        "the Rapier bodies do not follow the same motion"
    );
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for &kind in IntegratorKind::ALL {
        for n in SIZES {
            let mut bodies = Bodies::new(&batch(n));
            let mut integrator = kind.build(DT_SECS, &VariationalSettings::default());
            integrator.init(&bodies);
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new(kind.name(), n), &n, |b, _| {
                b.iter(|| {
                    integrator.step(black_box(&mut bodies), &Loads::uniform_gravity(gravity()))
                })
            });
        }
    }
    group.finish();
}

/// The variational step of 10 000 bodies on every vector unit this machine has
/// (`tumble::sim::simd`: the same bits on each; issue 34).
fn simd(c: &mut Criterion) {
    let mut group = c.benchmark_group("simd");
    let n = 10_000;
    for level in tumble::sim::simd::available() {
        let mut bodies = Bodies::new(&batch(n));
        let mut integrator =
            Variational::new(DT_SECS, VariationalSettings::default()).with_simd(level);
        integrator.init(&bodies);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new(level.name(), n), &n, |b, _| {
            b.iter(|| integrator.step(black_box(&mut bodies), &Loads::uniform_gravity(gravity())))
        });
    }
    group.finish();
}

fn peer(c: &mut Criterion) {
    check_same_problem();
    let mut group = c.benchmark_group("peer");
    for (name, substeps) in [("rapier3d-f64", 4), ("rapier3d-f64-1-substep", 1)] {
        for n in SIZES {
            let (mut world, _) = rapier_world(&batch(n), substeps);
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| black_box(&mut world).step())
            });
        }
    }
    group.finish();
}

/// The divergence guard's check ([`tumble::sim::guard::Guard::check`]), run by `tumble simulate`
/// after every step: `guard/check/<n>`. Its cost per body-step adds to the step's.
fn guard(c: &mut Criterion) {
    let mut group = c.benchmark_group("guard");
    for n in SIZES {
        let bodies = Bodies::new(&batch(n));
        let guard = Guard::new(&bodies, 100.0, Some(1024));
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("check", n), &n, |b, _| {
            b.iter(|| guard.check(black_box(&bodies), &StepStats::default(), 1))
        });
    }
    group.finish();
}

criterion_group!(benches, step, simd, peer, guard);
criterion_main!(benches);
