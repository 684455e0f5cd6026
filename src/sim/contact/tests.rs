//! Contact against closed forms (issue 31): the sliding stop, the slope, rolling and slipping,
//! rebounds, rest, stacks. Every case steps the bodies through [`Partitions`], as a run does.

use super::*;
use crate::sim::integrators::variational::VariationalSettings;
use crate::sim::loads::Loads;
use crate::sim::partition::Partitions;
use crate::sim::{BodyInit, IntegratorKind};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

const G: f64 = 9.81;

pub(super) fn gravity() -> Vector3<f64> {
    Vector3::new(0.0, 0.0, -G)
}

/// A level ground at z = 0 with `friction` and `restitution`.
pub(super) fn level(friction: f64, restitution: f64) -> Ground {
    Ground {
        normal: Vector3::z_axis(),
        point: Vector3::zeros(),
        friction,
        restitution,
    }
}

/// A ground through the origin tilted by `theta` about `y` (downhill is `+x`).
pub(super) fn slope(theta: f64, friction: f64) -> Ground {
    Ground {
        normal: nalgebra::Unit::new_normalize(Vector3::new(theta.sin(), 0.0, theta.cos())),
        point: Vector3::zeros(),
        friction,
        restitution: 0.0,
    }
}

/// A uniform box of `mass` and `size`, at rest unless `v` says otherwise.
pub(super) fn box_body(mass: f64, size: Vector3<f64>, pose: Isometry3<f64>, v: Vector3<f64>) -> BodyInit {
    let m12 = mass / 12.0;
    BodyInit {
        mass,
        principal_moments: Vector3::new(
            m12 * (size.y * size.y + size.z * size.z),
            m12 * (size.x * size.x + size.z * size.z),
            m12 * (size.x * size.x + size.y * size.y),
        ),
        world_from_body: pose,
        linvel_world: v,
        angvel_world: Vector3::zeros(),
    }
}

/// A solid ball (`I = 2/5 m r²`).
pub(super) fn ball_body(mass: f64, radius: f64, pose: Isometry3<f64>, v: Vector3<f64>) -> BodyInit {
    BodyInit {
        mass,
        principal_moments: Vector3::repeat(0.4 * mass * radius * radius),
        world_from_body: pose,
        linvel_world: v,
        angvel_world: Vector3::zeros(),
    }
}

pub(super) fn collider(body: usize, shape: Shape, friction: f64, restitution: f64) -> Collider {
    Collider {
        body,
        body_from_shape: Isometry3::identity(),
        shape,
        friction,
        restitution,
        group: body as u32,
        self_collision: false,
    }
}

/// The bodies `inits` with `model`, stepped by the variational integrator at `dt` on
/// `threads` threads.
pub(super) fn world(
    inits: &[BodyInit],
    model: ContactModel,
    dt: f64,
    threads: usize,
) -> Partitions<'static> {
    let integrators = (0..threads.max(1))
        .map(|_| IntegratorKind::Variational.build(dt, &VariationalSettings::default()))
        .collect();
    let mut parts = Partitions::new(inits, integrators, threads, f64::MAX, None).unwrap();
    parts.set_contact(model).unwrap();
    parts
}

/// A pose at `c` with rotation `r`.
pub(super) fn at(c: Vector3<f64>, r: UnitQuaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(c), r)
}

#[test]
fn a_box_resting_on_the_ground_neither_sinks_nor_creeps_in_1e5_steps() {
    let size = Vector3::new(0.4, 0.3, 0.2);
    let init = box_body(2.0, size, at(Vector3::new(0.0, 0.0, 0.1), UnitQuaternion::identity()), Vector3::zeros());
    let model = ContactModel {
        ground: Some(level(0.8, 0.0)),
        colliders: vec![collider(0, Shape::Box { half_extents: size / 2.0 }, 0.8, 0.0)],
        ..Default::default()
    };
    let loads = Loads::uniform_gravity(gravity());
    let mut w = world(&[init], model, 1e-3, 1);
    let mut worst_gap = 0.0f64;
    let mut max_sweeps = 0;
    for k in 0..100 {
        w.advance(k * 1000, (k + 1) * 1000, &loads);
        for c in w.contacts() {
            worst_gap = worst_gap.max(c.gap_m.abs());
        }
        max_sweeps = max_sweeps.max(w.contact_sweeps());
    }
    let (b, j) = w.body(0);
    let drift = (b.com_world[j] - Vector3::new(0.0, 0.0, 0.1)).norm();
    let turn = b.world_from_body[j].angle();
    // Measured: drift 0, turn 0, gaps ≤ 0 (exact: translation is linear in the impulse).
    assert!(drift <= 1e-12, "drift {drift:e}");
    assert!(turn <= 1e-12, "turn {turn:e}");
    assert!(worst_gap <= 1e-12, "gap {worst_gap:e}");
    assert!(w.contact_work().abs() <= 1e-9, "work {:e}", w.contact_work());
    eprintln!("rest: drift {drift:e} turn {turn:e} gap {worst_gap:e} sweeps {max_sweeps}");
}
