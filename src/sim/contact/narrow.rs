//! The narrow phase: contact points of a pair of colliders, or of a collider and the ground,
//! from parry3d-f64's contact manifolds (the points of each touching feature pair within a
//! prediction distance, with their signed distances and feature ids).

use super::{Collider, Ground};
use nalgebra::{Isometry3, Vector3};
use parry3d_f64::math::{Pose, Rotation, Vector};
use parry3d_f64::query::{ContactManifold, DefaultQueryDispatcher, PersistentQueryDispatcher};
use parry3d_f64::shape::{HalfSpace, SharedShape};

/// A collider ready for queries: its parry shape and that shape's pose in the body's principal
/// frame (the collider's pose with parry's axis convention on top).
#[derive(Clone)]
pub struct Prepared {
    pub shape: SharedShape,
    pub body_from_parry: Isometry3<f64>,
    /// Distance from the body's centre of mass to the farthest point of the shape, m.
    pub reach_m: f64,
    /// Radius of a sphere about the shape's origin that holds it, m.
    pub radius_m: f64,
}

impl Prepared {
    /// `collider` for queries; `None` when parry cannot build its shape.
    pub fn new(collider: &Collider) -> Option<Self> {
        let shape = collider.shape.to_parry()?;
        let body_from_parry = collider.body_from_shape
            * Isometry3::from_parts(
                nalgebra::Translation3::identity(),
                collider.shape.shape_from_parry(),
            );
        let reach_m =
            collider.body_from_shape.translation.vector.norm() + collider.shape.bounding_radius();
        Some(Self {
            shape,
            body_from_parry,
            reach_m,
            radius_m: collider.shape.bounding_radius(),
        })
    }
}

/// A contact point found at the start of a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawContact {
    /// The point on `a`'s surface, world.
    pub point_a: Vector3<f64>,
    /// The point on `b`'s surface, world.
    pub point_b: Vector3<f64>,
    /// Unit normal from `b` toward `a`, world.
    pub normal: Vector3<f64>,
    /// Signed distance along the normal (negative: penetration), m.
    pub gap_m: f64,
    /// The touching features (for matching a contact with the previous step's).
    pub features: u64,
}

/// nalgebra's isometry as parry's pose.
pub fn to_pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let q = iso.rotation.quaternion();
    Pose::from_parts(
        Vector::new(t.x, t.y, t.z),
        Rotation::from_xyzw(q.i, q.j, q.k, q.w).normalize(),
    )
}

fn to_na(v: Vector) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}

/// Reused buffers of the queries.
#[derive(Default)]
pub struct Scratch {
    manifolds: Vec<ContactManifold<(), ()>>,
}

/// The contacts between `a` (at `world_from_a`, parry frame) and `b` (at `world_from_b`)
/// within `prediction_m`, appended to `out`.
pub fn pair(
    world_from_a: &Isometry3<f64>,
    a: &SharedShape,
    world_from_b: &Isometry3<f64>,
    b: &SharedShape,
    prediction_m: f64,
    scratch: &mut Scratch,
    out: &mut Vec<RawContact>,
) {
    // parry's first shape is `b`: its normal `n1` points from `b` toward `a`.
    let pos12 = to_pose(&(world_from_b.inverse() * world_from_a));
    manifolds(
        world_from_a,
        world_from_b,
        &pos12,
        b.as_ref(),
        a.as_ref(),
        prediction_m,
        scratch,
        out,
    );
}

/// The contacts of `a` (at `world_from_a`, parry frame) with the ground within `prediction_m`,
/// appended to `out`.
pub fn with_ground(
    world_from_a: &Isometry3<f64>,
    a: &SharedShape,
    ground: &Ground,
    prediction_m: f64,
    scratch: &mut Scratch,
    out: &mut Vec<RawContact>,
) {
    let n = ground.normal;
    let half_space = HalfSpace::new(Vector::new(n.x, n.y, n.z));
    let world_from_ground = Isometry3::translation(ground.point.x, ground.point.y, ground.point.z);
    let pos12 = to_pose(&(world_from_ground.inverse() * world_from_a));
    manifolds(
        world_from_a,
        &world_from_ground,
        &pos12,
        &half_space,
        a.as_ref(),
        prediction_m,
        scratch,
        out,
    );
}

#[allow(clippy::too_many_arguments)]
fn manifolds(
    world_from_a: &Isometry3<f64>,
    world_from_b: &Isometry3<f64>,
    pos12: &Pose,
    g1: &dyn parry3d_f64::shape::Shape,
    g2: &dyn parry3d_f64::shape::Shape,
    prediction_m: f64,
    scratch: &mut Scratch,
    out: &mut Vec<RawContact>,
) {
    scratch.manifolds.clear();
    let mut workspace = None;
    if DefaultQueryDispatcher
        .contact_manifolds(
            pos12,
            g1,
            g2,
            prediction_m,
            &mut scratch.manifolds,
            &mut workspace,
        )
        .is_err()
    {
        return;
    }
    for m in &scratch.manifolds {
        let normal = world_from_b.rotation * to_na(m.local_n1);
        for p in &m.points {
            if p.dist > prediction_m {
                continue;
            }
            let point_b = world_from_b * nalgebra::Point3::from(to_na(p.local_p1));
            let point_a = world_from_a * nalgebra::Point3::from(to_na(p.local_p2));
            out.push(RawContact {
                point_a: point_a.coords,
                point_b: point_b.coords,
                normal,
                gap_m: p.dist,
                features: ((m.subshape1 as u64) << 48)
                    ^ ((m.subshape2 as u64) << 40)
                    ^ ((p.fid1.0 as u64) << 20)
                    ^ (p.fid2.0 as u64),
            });
        }
    }
}
