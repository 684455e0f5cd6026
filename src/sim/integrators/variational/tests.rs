//! Tests of the variational integrator: the one-body solves, and the batched lanes against
//! one-body steps bit for bit.

use super::*;
use crate::sim::loads::Loads;
use crate::sim::so3::{self, Coefficients};
use crate::sim::{Bodies, Integrator};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
#[test]
fn solve3_inverts() {
    let a = Matrix3::new(4.0, 1.0, -2.0, 0.5, 3.0, 1.0, -1.0, 2.0, 5.0);
    let x = Vector3::new(0.3, -1.7, 2.2);
    let b = a * x;
    // Measured 4e-16.
    assert!((solve3(&a, &b).unwrap() - x).amax() < 1e-14);
    assert!(solve3(&Matrix3::zeros(), &b).is_none());
}

/// Analytic Newton converges quadratically: residual roughly squares each iteration, so a
/// cold start from `h Ω` at `h|Ω| = 0.5` needs only a few iterations.
#[test]
fn newton_converges_quadratically_from_cold_start() {
    let j = Vector3::new(1.0, 2.0, 3.0);
    let omega = Vector3::new(0.2, 0.25, 0.1); // |Ω| ≈ 0.34 rad/s
    let m = j.component_mul(&omega);
    let h = 1.0; // h|Ω| ≈ 0.34
    let settings = VariationalSettings {
        newton_tol: 1e-14,
        ..Default::default()
    };
    let solve = solve_xi(&j, &m, h, &(omega * h), &settings);
    assert!(solve.converged);
    // Measured 3 iterations; linear convergence at this ratio would need > 10.
    assert!(solve.iterations <= 4, "iterations = {}", solve.iterations);
    let k = Coefficients::new(solve.xi.norm_squared());
    let res = j.component_mul(&solve.xi) - so3::t_transpose_times(&solve.xi, &k, &(m * h));
    assert!(res.amax() < 1e-14 * (m * h).amax());

    let approx = VariationalSettings {
        jacobian: Jacobian::Approximate,
        newton_max_iters: 200,
        ..settings
    };
    let slow = solve_xi(&j, &m, h, &(omega * h), &approx);
    assert!(slow.converged);
    // The approximate Jacobian converges only linearly: measured 12 iterations.
    assert!(slow.iterations > solve.iterations);
    assert!((slow.xi - solve.xi).amax() < 1e-12);
}

use crate::sim::BodyInit;
use nalgebra::{Isometry3, Translation3};

fn body(moments: Vector3<f64>, euler: (f64, f64, f64), angvel: Vector3<f64>) -> BodyInit {
    BodyInit {
        mass: 1.5,
        principal_moments: moments,
        world_from_body: Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(euler.0, euler.1, euler.2),
        ),
        linvel_world: Vector3::new(0.5, 0.0, 1.0),
        angvel_world: angvel,
    }
}

/// Bodies covering every path: series regime with one update (the common path), a slow
/// spinner (`h|Ω|` ≈ 3e-4), a fast one above `SERIES_THETA` at h = 1 ms (`sin_cos`, two
/// updates, lane-by-lane coefficients), one at rest (zero residual at the start).
fn mixed_bodies() -> Vec<BodyInit> {
    vec![
        body(
            Vector3::new(1.0, 2.0, 3.0),
            (0.2, 0.4, -0.3),
            Vector3::new(0.05, 3.0, 0.05),
        ),
        body(
            Vector3::new(0.5, 0.7, 0.9),
            (1.0, -0.4, 2.0),
            Vector3::new(0.1, -0.2, 0.2),
        ),
        body(
            Vector3::new(2.0, 1.0, 1.5),
            (-2.0, 0.1, 0.4),
            Vector3::new(30.0, -12.0, 8.0),
        ),
        body(
            Vector3::new(1.0, 1.2, 1.4),
            (0.0, 0.0, 0.0),
            Vector3::zeros(),
        ),
        body(
            Vector3::new(1.0, 3.0, 3.5),
            (0.3, 0.3, 0.3),
            Vector3::new(-2.0, 1.0, 4.0),
        ),
    ]
}

/// The batched path (four lanes, with a fallback to the lane-wise Newton loop when one body
/// leaves the common path) and the one-body path give bit-identical trajectories: the
/// arithmetic is the same code in the same order, and Rust never contracts to FMA.
#[test]
fn batched_lanes_match_one_body_steps_bit_for_bit() {
    let inits = mixed_bodies();
    let g = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let mut batch = Bodies::new(&inits);
    let mut batch_integ = Variational::new(0.001, VariationalSettings::default());
    batch_integ.init(&batch);
    let mut singles: Vec<(Bodies, Variational)> = inits
        .iter()
        .map(|init| {
            let bodies = Bodies::new(std::slice::from_ref(init));
            let mut integ = Variational::new(0.001, VariationalSettings::default());
            integ.init(&bodies);
            (bodies, integ)
        })
        .collect();
    let mut iters_max = 0;
    for _ in 0..500 {
        let stats = batch_integ.step(&mut batch, &g);
        assert_eq!(stats.newton_failures, 0);
        iters_max = iters_max.max(stats.newton_iters_max);
        for (bodies, integ) in &mut singles {
            integ.step(bodies, &g);
        }
    }
    // The fast spinner needs two updates (h|Ω| ≈ 0.034): the fallback path ran.
    assert_eq!(iters_max, 2);
    for (i, (single, integ)) in singles.iter().enumerate() {
        assert_eq!(
            batch.world_from_body[i], single.world_from_body[0],
            "body {i}"
        );
        assert_eq!(batch.angmom_body[i], single.angmom_body[0], "body {i}");
        assert_eq!(batch.com_world[i], single.com_world[0], "body {i}");
        assert_eq!(batch_integ.xi()[i], integ.xi()[0], "body {i}");
    }
}

/// With the Euler-equation predictor one Newton update meets the 1e-12 tolerance at every
/// step for `h|Ω|` ≈ 3e-3 (without it, 35 % of the steps need two: measured 7072 of 20000).
/// The step right after `init` needs none: `init` solved it already.
#[test]
fn predicted_warm_start_needs_one_newton_update() {
    let init = body(
        Vector3::new(1.0, 2.0, 3.0),
        (0.2, 0.4, -0.3),
        Vector3::new(0.5, 3.0, 0.5),
    );
    let mut bodies = Bodies::new(&vec![init; 5]);
    let mut integ = Variational::new(0.001, VariationalSettings::default());
    integ.init(&bodies);
    let g = Loads::none();
    assert_eq!(integ.step(&mut bodies, &g).newton_iters_max, 0);
    for _ in 0..20_000 {
        let stats = integ.step(&mut bodies, &g);
        assert_eq!((stats.newton_iters_max, stats.newton_failures), (1, 0));
    }
}

/// The cheap renormalisation `q (3 - |q|^2)/2` keeps the quaternion unit to round-off,
/// with no drift, over 1e5 steps of a fast, tumbling body.
#[test]
fn quaternion_norm_stays_at_round_off() {
    let init = body(
        Vector3::new(1.0, 2.0, 3.0),
        (0.2, 0.4, -0.3),
        Vector3::new(3.0, 20.0, 3.0),
    );
    let mut bodies = Bodies::new(&vec![init; 4]);
    let mut integ = Variational::new(0.001, VariationalSettings::default());
    integ.init(&bodies);
    let mut worst: f64 = 0.0;
    for _ in 0..100_000 {
        integ.step(&mut bodies, &Loads::none());
        worst = worst.max((bodies.world_from_body[0].coords.norm_squared() - 1.0).abs());
    }
    // Measured 4.4e-16 (2 ulp of 1).
    assert!(worst < 2e-15, "||q|^2 - 1| = {worst:e}");
}

/// A non-finite momentum is a Newton failure for that body only, not a panic, and does not
/// disturb the other bodies of its lane group.
#[test]
fn non_finite_body_fails_alone() {
    let inits = mixed_bodies();
    let mut bodies = Bodies::new(&inits);
    let mut integ = Variational::new(0.001, VariationalSettings::default());
    integ.init(&bodies);
    let mut reference = bodies.clone();
    let mut reference_integ = integ.clone();
    bodies.angmom_body[1] = Vector3::new(f64::NAN, 0.0, 0.0);
    let stats = integ.step(&mut bodies, &Loads::none());
    assert_eq!(stats.newton_failures, 1);
    reference_integ.step(&mut reference, &Loads::none());
    for i in [0, 2, 3, 4] {
        assert_eq!(bodies.world_from_body[i], reference.world_from_body[i]);
        assert_eq!(bodies.angmom_body[i], reference.angmom_body[i]);
    }
}

/// Every vector unit this machine has steps the same batch to the same bits (issue 34): 1003
/// tumbling bodies (lanes of 4 and 8 with a remainder of 3), a few spun hard enough to leave
/// the series regime and need several Newton updates, 300 steps under gravity.
#[test]
fn every_simd_path_steps_the_same_bits() {
    use crate::sim::simd::{Level, available};
    let mut inits = crate::sim::workload::free_body_batch(1003);
    for (i, b) in inits.iter_mut().enumerate().step_by(97) {
        // |h Ω| ≈ 0.6 rad: outside the series regime, several Newton updates.
        b.angvel_world = Vector3::new(600.0, -350.0, 120.0 + i as f64);
    }
    let loads = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let run = |level: Level| {
        let mut bodies = Bodies::new(&inits);
        let mut integrator =
            Variational::new(1e-3, VariationalSettings::default()).with_simd(level);
        assert_eq!(integrator.simd(), level);
        integrator.init(&bodies);
        let mut stats = crate::sim::StepStats::default();
        for _ in 0..300 {
            stats = stats.merge(integrator.step(&mut bodies, &loads));
        }
        let bits: Vec<u64> = (0..bodies.len())
            .flat_map(|i| {
                let q = bodies.world_from_body[i];
                [q.w, q.i, q.j, q.k]
                    .into_iter()
                    .chain(bodies.angmom_body[i].iter().copied())
                    .chain(bodies.com_world[i].iter().copied())
                    .chain(bodies.linvel_world[i].iter().copied())
            })
            .map(f64::to_bits)
            .collect();
        (bits, stats)
    };
    let levels = available();
    let (reference, stats) = run(Level::Sse2);
    // The hard bodies took the full Newton (more than the one update of the common path).
    assert!(stats.newton_iters_max > 1, "{stats:?}");
    assert_eq!(stats.newton_failures, 0);
    for level in levels {
        let (bits, level_stats) = run(level);
        assert_eq!(level_stats, stats, "{}", level.name());
        assert!(bits == reference, "{} differs from sse2", level.name());
    }
}
