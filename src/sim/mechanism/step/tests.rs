//! Tests of the constrained step: a pendulum against its elliptic solution, the cold retry
//! and the substeps.

use super::super::rows::{BodyPose, JointRows, RowKind, normals};
use super::super::{Base, Coordinate, CoordinateKind, Mechanism, MechanismJoint, MechanismModel};
use super::*;
use crate::sim::BodyInit;
use crate::sim::reference::elliptic::{complete_k, jacobi_sn_cn_dn};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// A rod of mass `m`, centre of mass `d` below a pivot on the world at the origin,
/// turning about the world y axis, released from rest at `theta0`.
pub(crate) fn pendulum(theta0: f64) -> (Mechanism, Vec<BodyInit>, f64) {
    let (m, d, iyy) = (1.0, 1.0, 0.01);
    let rot = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), theta0);
    let init = BodyInit {
        mass: m,
        principal_moments: Vector3::new(iyy, iyy, 1e-4),
        world_from_body: Isometry3::from_parts(
            Translation3::from(rot * Vector3::new(0.0, 0.0, -d)),
            rot,
        ),
        linvel_world: Vector3::zeros(),
        angvel_world: Vector3::zeros(),
    };
    let y = Vector3::y();
    let shared = MechanismModel {
        body_count: 1,
        joints: vec![MechanismJoint {
            name: "pivot".into(),
            parent: None,
            child: 0,
            rows: JointRows {
                anchor_parent: Vector3::zeros(),
                anchor_child: Vector3::new(0.0, 0.0, d),
                kind: RowKind::Hinge {
                    axis_parent: y,
                    axis_child: y,
                    normals_parent: normals(&y),
                },
            },
            compound: None,
            parent_from_first: Isometry3::identity(),
            stage_origins: Vec::new(),
        }],
        coordinates: vec![Coordinate {
            name: "pivot".into(),
            joint: 0,
            kind: CoordinateKind::Hinge {
                axis_parent: y,
                ref_parent: Vector3::x(),
                ref_child: Vector3::x(),
            },
            limits: None,
            initial: theta0,
            is_linear: false,
        }],
        mimics: Vec::new(),
        drives: Vec::new(),
        stops: Vec::new(),
        base: Base::Fixed,
        length_scale: d,
    };
    shared.validate().unwrap();
    let model = Mechanism {
        name: "pendulum".into(),
        first_body: 0,
        world_pose: BodyPose::identity(),
        shared: std::sync::Arc::new(shared),
    };
    // ω0² = m g d / (I + m d²)
    let omega0 = (m * 9.81 * d / (iyy + m * d * d)).sqrt();
    (model, vec![init], omega0)
}

/// The angle of the exact pendulum released from rest: `sin(θ/2) = k sn(K − ω0 t | k²)`,
/// `k = sin(θ0/2)`.
pub(crate) fn exact_angle(theta0: f64, omega0: f64, t: f64) -> f64 {
    let k = (theta0 / 2.0).sin();
    let m = k * k;
    let (sn, _, _) = jacobi_sn_cn_dn(complete_k(m) - omega0 * t, m);
    2.0 * (k * sn).asin()
}

#[test]
fn pendulum_follows_the_elliptic_solution() {
    let theta0 = 2.0;
    let (model, inits, omega0) = pendulum(theta0);
    let mut bodies = Bodies::new(&inits);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    let g = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let settings = VariationalSettings::default();
    let h = 1e-3;
    let mut iters = 0;
    let mut worst: f64 = 0.0;
    for k in 1..=3000 {
        let stats = step(&model, &mut state, &mut warm, &mut bodies, h, &g, &settings);
        assert_eq!(stats.newton_failures, 0);
        iters = iters.max(stats.newton_iters_max);
        let pose = BodyPose {
            rot: bodies.world_from_body[0].to_rotation_matrix().into_inner(),
            com: bodies.com_world[0],
        };
        let theta = model.coordinates[0]
            .kind
            .value(&BodyPose::identity(), &pose, 0.0)
            .unwrap();
        worst = worst.max((theta - exact_angle(theta0, omega0, k as f64 * h)).abs());
    }
    // Order 2 at h = 1 ms over 3 s: measured 1.8e-5 rad, 2 Newton iterations per step.
    assert!(worst < 5e-5, "{worst:e}");
    assert!(iters <= 3, "{iters}");
}

/// A warm start gone bad (multipliers off by orders of magnitude, as after an impulse that
/// changed in one step) is retried cold: the step converges, no failure is counted, and the
/// result is the cold solve's.
#[test]
fn a_failed_warm_start_is_retried_cold() {
    let (model, inits, _) = pendulum(1.0);
    let g = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let settings = VariationalSettings::default();
    let h = 1e-2;
    let mut bodies = Bodies::new(&inits);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    step(&model, &mut state, &mut warm, &mut bodies, h, &g, &settings);
    let mut cold_bodies = bodies.clone();
    // The reference: the same step from a cold start.
    let mut cold_warm = Warm::new(&model);
    let mut cold_state = MechanismState::new(&model);
    step(
        &model,
        &mut cold_state,
        &mut cold_warm,
        &mut cold_bodies,
        h,
        &g,
        &settings,
    );
    for l in &mut warm.lambda {
        *l *= 1e6;
    }
    let direct = state
        .ws
        .attempt(&model, &bodies, h, &g, &settings, Some(&warm));
    assert!(
        direct.is_err(),
        "the poisoned warm start must fail alone: {direct:?}"
    );
    let stats = step(&model, &mut state, &mut warm, &mut bodies, h, &g, &settings);
    assert_eq!((stats.newton_failures, stats.substepped), (0, 0));
    // The retry is the cold solve, bit for bit: measured 0.
    let d = (bodies.com_world[0] - cold_bodies.com_world[0]).amax();
    assert_eq!(d, 0.0);
}

/// A step too large for Newton from any start (h|Ω| ≈ 3 rad per step) is split into
/// substeps; the joint holds afterwards and the stats say so.
#[test]
fn a_step_newton_cannot_solve_is_split_into_substeps() {
    let (model, mut inits, _) = pendulum(0.0);
    inits[0].angvel_world = Vector3::new(0.0, 30.0, 0.0);
    inits[0].linvel_world = Vector3::new(-30.0, 0.0, 0.0);
    let g = Loads::none();
    let settings = VariationalSettings::default();
    let mut bodies = Bodies::new(&inits);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    let stats = step(
        &model,
        &mut state,
        &mut warm,
        &mut bodies,
        0.1,
        &g,
        &settings,
    );
    assert_eq!(stats.newton_failures, 0, "{stats:?}");
    assert_eq!(stats.substepped, 1, "{stats:?}");
    assert!(stats.substep_factor_max >= 2, "{stats:?}");
    let pose = BodyPose {
        rot: bodies.world_from_body[0].to_rotation_matrix().into_inner(),
        com: bodies.com_world[0],
    };
    let gap = model.joints[0].rows.values(&BodyPose::identity(), &pose);
    // Split 4 ways (measured); the joint holds to the tolerance (1e-12 · 1 m) after the
    // split step: measured 1.2e-14 m.
    assert!(gap.amax() < 1e-12, "{gap}");
}

/// Issue 32: bodies at rest in equilibrium beside one that moves. A two-link chain hangs
/// straight down, its principal frames turned off the world axes, so the torques of its
/// hinges' rows on each link cancel to round-off while the pendulum beside it swings and needs
/// two Newton iterations. The free residual's tolerance relative to that cancelled sum alone
/// was below its round-off floor: every step failed, substeps too (the Allegro hands' fingers
/// standing up while the thumb falls, Alexander's pelvis between its legs).
#[test]
fn bodies_at_rest_in_equilibrium_beside_a_moving_one_converge() {
    let (pendulum_model, mut inits, _) = pendulum(1.0);
    let d = 0.3;
    let turns = [
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)),
            0.7,
        ),
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(-3.0, 1.0, 2.0)),
            1.1,
        ),
    ];
    let pivot = Vector3::new(2.0, 0.0, 0.0);
    let y = Vector3::y();
    let mut shared = (*pendulum_model.shared).clone();
    for (k, rot) in turns.iter().enumerate() {
        // Link k: centre of mass d below its pivot, its child's pivot d below the centre.
        let com = pivot - Vector3::new(0.0, 0.0, d * (2 * k + 1) as f64);
        inits.push(BodyInit {
            mass: 0.05,
            principal_moments: Vector3::new(1e-5, 2e-5, 1.5e-5),
            world_from_body: Isometry3::from_parts(Translation3::from(com), *rot),
            linvel_world: Vector3::zeros(),
            angvel_world: Vector3::zeros(),
        });
        let (parent, anchor_parent, axis_parent) = if k == 0 {
            (None, pivot, y)
        } else {
            let up = turns[k - 1].inverse();
            (Some(k), up * Vector3::new(0.0, 0.0, -d), up * y)
        };
        shared.joints.push(MechanismJoint {
            name: format!("resting_{k}"),
            parent,
            child: k + 1,
            rows: JointRows {
                anchor_parent,
                anchor_child: rot.inverse() * Vector3::new(0.0, 0.0, d),
                kind: RowKind::Hinge {
                    axis_parent,
                    axis_child: rot.inverse() * y,
                    normals_parent: normals(&axis_parent),
                },
            },
            compound: None,
            parent_from_first: Isometry3::identity(),
            stage_origins: Vec::new(),
        });
    }
    shared.body_count = 3;
    shared.validate().unwrap();
    let model = Mechanism {
        shared: std::sync::Arc::new(shared),
        ..pendulum_model
    };
    let g = Loads::uniform_gravity(Vector3::new(0.0, 0.0, -9.81));
    let settings = VariationalSettings::default();
    let mut bodies = Bodies::new(&inits);
    let mut state = MechanismState::new(&model);
    let mut warm = Warm::new(&model);
    let start = bodies.com_world[2];
    for _ in 0..1000 {
        let stats = step(
            &model,
            &mut state,
            &mut warm,
            &mut bodies,
            1e-3,
            &g,
            &settings,
        );
        assert_eq!(
            (stats.newton_failures, stats.substepped),
            (0, 0),
            "{stats:?}"
        );
        assert!(stats.newton_iters_max <= 3, "{stats:?}");
    }
    // The hanging chain stays at rest.
    let moved = (bodies.com_world[2] - start).amax();
    assert!(moved < 1e-12, "{moved:e}");
}
