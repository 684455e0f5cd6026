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

/// `(sin, cos)` of half the joint angles, exact or from a nearby angle's.
#[derive(Clone, Copy)]
pub enum HalfAngles<'a> {
    /// `sin_cos(θ/2)` of each angle.
    Exact,
    /// Near angles `theta0` whose `(sin, cos)(θ0/2)` are `half0`: `θ/2 = θ0/2 + d`, the
    /// functions of `d` by their series where `|d| ≤` [`SERIES_HALF_ANGLE`] (the Newton
    /// iterates of a step, a few hundredths of a radian from `θ_k`) and the addition
    /// formulas; round-off of a few ε, not carried from step to step (the accepted step's
    /// poses are recomputed exactly).
    Near {
        theta0: &'a [f64],
        half0: &'a [(f64, f64)],
    },
}

/// Largest half-angle increment whose sine and cosine [`HalfAngles::Near`] takes by series:
/// the first omitted terms, `d¹¹/11!` and `d¹²/12!`, are below 1e-21 there.
pub const SERIES_HALF_ANGLE: f64 = 0.05;

/// `(sin d, cos d)` by Taylor series (`|d| ≤ SERIES_HALF_ANGLE`).
#[inline(always)]
fn sin_cos_series(d: f64) -> (f64, f64) {
    let d2 = d * d;
    let sin = d
        * (1.0
            + d2 * (-1.0 / 6.0
                + d2 * (1.0 / 120.0 + d2 * (-1.0 / 5040.0 + d2 * (1.0 / 362880.0)))));
    let cos = 1.0
        + d2 * (-0.5
            + d2 * (1.0 / 24.0
                + d2 * (-1.0 / 720.0 + d2 * (1.0 / 40320.0 + d2 * (-1.0 / 3628800.0)))));
    (sin, cos)
}

impl HalfAngles<'_> {
    #[inline(always)]
    fn at(&self, j: usize, theta: f64) -> (f64, f64) {
        match self {
            HalfAngles::Exact => (0.5 * theta).sin_cos(),
            HalfAngles::Near { theta0, half0 } => {
                let d = 0.5 * (theta - theta0[j]);
                if d.abs() <= SERIES_HALF_ANGLE {
                    let (sd, cd) = sin_cos_series(d);
                    let (s0, c0) = half0[j];
                    (s0 * cd + c0 * sd, c0 * cd - s0 * sd)
                } else {
                    (0.5 * theta).sin_cos()
                }
            }
        }
    }
}

/// The bodies' poses at `q` (`base`: the floating root's pose, ignored for a fixed base;
/// `theta` per joint, their half angles' functions by `half`), into `poses`, and the joints'
/// axes into `axes`, the half angles' `(sin, cos)` into `half_out` (hinges). `world` is the
/// pose joints on the world hang from.
#[allow(clippy::too_many_arguments)]
pub fn forward(
    tree: &TreeModel,
    world: &Pose,
    base: &Pose,
    theta: &[f64],
    half: HalfAngles,
    poses: &mut [Pose],
    axes: &mut [JointAxis],
    half_out: &mut [(f64, f64)],
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
                let (s, c) = half.at(j, theta[j]);
                half_out[j] = (s, c);
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
