//! Initial conditions: body twists from the base twist and the joint rates (forward velocity
//! kinematics), consistent with the joints, so that the first step's impulses stay O(h).
//! (Giving every body the same twist is not: the first impulses then remove part of the
//! kinetic energy at once, 6 % on a free chain: `design/joints.md`.)
//!
//! Down the tree, parent `a` before child `b`, with `P` the joint's anchor (world) and `u` the
//! joint axis in the world:
//!
//! ```text
//! hinge:     ω_b = ω_a + u θ̇,              v_b = v_P + ω_b × (c_b − P),   v_P = v_a + ω_a × (P − c_a)
//! slider:    ω_b = ω_a,                    v_b = v_a + ω_a × (c_b − c_a) + u ṡ
//! compound:  ω_b = ω_a + Σ_k u_k θ̇_k,      v_b = v_P + ω_b × (c_b − P)
//! ```
//!
//! (`v` the velocity of a body's centre of mass). The root of a floating base moves with the
//! given twist of the root link frame: `ω_0 = ω_root`, `v_0 = v_origin + ω_root × (c_0 − o)`;
//! a joint on the world starts from rest. The body momenta then follow from the continuous
//! Legendre transform (`M = J Ω`, `p = m v`: [`crate::sim::Bodies::new`]).

use super::rows::{BodyPose, RowKind};
use super::{CoordinateKind, Mechanism};
use nalgebra::{Isometry3, Vector3};

/// Twist of the root link frame: velocity of its origin `origin` and angular velocity, world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootTwist {
    pub origin: Vector3<f64>,
    pub linvel: Vector3<f64>,
    pub angvel: Vector3<f64>,
}

/// Per body `(velocity of the centre of mass, angular velocity)`, world, from the body poses
/// `world_from_body` (principal frames, the mechanism's local order), the root twist (floating
/// base) and one rate per coordinate (rad/s or m/s; mimic followers already at their rule).
pub fn body_twists(
    model: &Mechanism,
    world_from_body: &[Isometry3<f64>],
    root: Option<RootTwist>,
    rates: &[f64],
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let n = model.body_count;
    let mut twists = vec![(Vector3::zeros(), Vector3::zeros()); n];
    let pose = |i: usize| BodyPose {
        rot: world_from_body[i]
            .rotation
            .to_rotation_matrix()
            .into_inner(),
        com: world_from_body[i].translation.vector,
    };
    if let Some(r) = root {
        let c0 = world_from_body[0].translation.vector;
        twists[0] = (r.linvel + r.angvel.cross(&(c0 - r.origin)), r.angvel);
    }
    // Joints in child order are parent-before-child (children are increasing).
    let mut order: Vec<usize> = (0..model.joints.len()).collect();
    order.sort_by_key(|&j| model.joints[j].child);
    for j in order {
        let joint = &model.joints[j];
        let (a, (va, wa)) = match joint.parent {
            Some(p) => (pose(p), twists[p]),
            None => (joint.world_pose, (Vector3::zeros(), Vector3::zeros())),
        };
        let b = pose(joint.child);
        let anchor = a.com + a.rot * joint.rows.anchor_parent;
        let v_anchor = va + wa.cross(&(anchor - a.com));
        let coords = model
            .coordinates
            .iter()
            .enumerate()
            .filter(|(_, c)| c.joint == j);
        let mut omega_rel = Vector3::zeros();
        let mut slide = Vector3::zeros();
        for (k, c) in coords {
            match (&c.kind, &joint.rows.kind) {
                (CoordinateKind::Hinge { axis_parent, .. }, _) => {
                    omega_rel += a.rot * axis_parent * rates[k];
                }
                (CoordinateKind::Slider { axis_parent, .. }, _) => {
                    slide += a.rot * axis_parent * rates[k];
                }
                (CoordinateKind::Compound { stage }, _) => {
                    if let Some(chain) = &joint.compound {
                        let theta: Vec<f64> = model
                            .coordinates
                            .iter()
                            .filter(|c| c.joint == j)
                            .map(|c| c.initial)
                            .collect();
                        let (_, axes) = chain.product(&theta);
                        omega_rel += a.rot * (chain.parent_from_first * axes[*stage]) * rates[k];
                    }
                }
            }
        }
        let wb = wa + omega_rel;
        let vb = match joint.rows.kind {
            RowKind::Slider { .. } => va + wa.cross(&(b.com - a.com)) + slide,
            _ => v_anchor + wb.cross(&(b.com - anchor)),
        };
        twists[joint.child] = (vb, wb);
    }
    twists
}
