//! Forward kinematics of a [`TreeModel`]: the bodies' poses from the base pose and the joint
//! coordinates ([`forward`], the formulas of [`super::model`]), and each joint's motion as a
//! spatial vector ([`JointAxis`]).
//!
//! Spatial vectors are world-aligned and taken about one reference point `o` per step (the
//! root body's centre of mass at `q_k`): a twist is `(ω, v_o)`, a wrench `(n_o, f)`, so a
//! subtree's wrench is a plain sum and no frame changes appear in the passes; positions enter
//! only as `c − o`, of the size of the robot wherever it stands.

use super::model::{TreeJointKind, TreeModel};
use crate::sim::mechanism::BodyPose;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// One body's pose: rotation (quaternion and matrix) and centre of mass, world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub quat: UnitQuaternion<f64>,
    pub rot: Matrix3<f64>,
    pub com: Vector3<f64>,
}

impl Pose {
    pub fn new(quat: UnitQuaternion<f64>, com: Vector3<f64>) -> Self {
        Self {
            quat,
            rot: quat.to_rotation_matrix().into_inner(),
            com,
        }
    }

    pub fn of_body(pose: &BodyPose) -> Self {
        Self::new(UnitQuaternion::from_matrix(&pose.rot), pose.com)
    }
}

/// A joint's motion at a pose: the world axis `u_w = R_a u_a` and the joint's point
/// `x = c_b + R_b a_b` (world).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointAxis {
    pub axis: Vector3<f64>,
    pub point: Vector3<f64>,
}

impl JointAxis {
    /// The joint's unit twist about `o`: a hinge `(u_w, (x − o) × u_w)`, a slider `(0, u_w)`.
    #[inline]
    pub fn twist(&self, kind: TreeJointKind, o: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        match kind {
            TreeJointKind::Hinge => (self.axis, (self.point - o).cross(&self.axis)),
            TreeJointKind::Slider => (Vector3::zeros(), self.axis),
        }
    }

    /// The generalized force of the wrench `(n_o, f)` on this joint: the twist's pairing.
    #[inline]
    pub fn force(
        &self,
        kind: TreeJointKind,
        o: &Vector3<f64>,
        n: &Vector3<f64>,
        f: &Vector3<f64>,
    ) -> f64 {
        match kind {
            TreeJointKind::Hinge => self.axis.dot(&(n - (self.point - o).cross(f))),
            TreeJointKind::Slider => self.axis.dot(f),
        }
    }
}

/// The bodies' poses at `q` (`base`: the floating root's pose, ignored for a fixed base;
/// `theta` per joint), into `poses`, and the joints' axes into `axes`. `world` is the pose
/// joints on the world hang from.
pub fn forward(
    tree: &TreeModel,
    world: &Pose,
    base: &Pose,
    theta: &[f64],
    poses: &mut [Pose],
    axes: &mut [JointAxis],
) {
    if tree.floating {
        poses[0] = *base;
    }
    for (j, joint) in tree.joints.iter().enumerate() {
        let parent = match joint.parent {
            Some(p) => poses[p],
            None => *world,
        };
        let (relative, offset) = match joint.kind {
            TreeJointKind::Hinge => {
                let (s, c) = (0.5 * theta[j]).sin_cos();
                let q = joint.rest.into_inner() * c + joint.axis_rest * s;
                (UnitQuaternion::new_unchecked(q), joint.anchor_parent)
            }
            TreeJointKind::Slider => (
                joint.rest,
                joint.anchor_parent + joint.axis_parent * theta[j],
            ),
        };
        let quat = parent.quat * relative;
        let rot = quat.to_rotation_matrix().into_inner();
        let point = parent.com + parent.rot * offset;
        poses[joint.child] = Pose {
            quat,
            rot,
            com: point - rot * joint.anchor_child,
        };
        axes[j] = JointAxis {
            axis: parent.rot * joint.axis_parent,
            point,
        };
    }
}
