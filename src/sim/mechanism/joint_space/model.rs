//! A mechanism as a kinematic tree in joint coordinates: per joint, what forward kinematics
//! needs (the joint's place in both bodies' principal frames, its axis, the relative rotation
//! at the zero position), read from the maximal-coordinate description the scene built
//! ([`crate::sim::mechanism::MechanismModel`]), so that both steppers share one model.
//!
//! With `a` the parent body (or, for a fixed base, the welded world pose), `b` the child,
//! `a_a`, `a_b` the anchors, `u_a` the axis (parent frame) and `W₀` the child's rotation in
//! the parent's frame at the zero position:
//!
//! ```text
//! hinge:  R_b = R_a Rot(u_a, θ) W₀,   c_b = c_a + R_a a_a − R_b a_b
//! slider: R_b = R_a W₀,               c_b = c_a + R_a (a_a + s u_a) − R_b a_b
//! ```
//!
//! the exact inverse of the coordinates [`crate::sim::mechanism::coords`] reads back from the
//! poses (`θ = atan2((u_a × w_a)·m, w_a·m)` with `m = W w_b`, `W₀ w_b = w_a`; `s = u_a·d`).

use super::super::{Base, CoordinateKind, Mechanism, RowKind};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// How a tree joint moves its child.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TreeJointKind {
    Hinge,
    Slider,
}

/// One joint of the tree (see the module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct TreeJoint {
    /// Local index of the parent body; `None`: the world, at the mechanism's `world_pose`.
    pub parent: Option<usize>,
    pub child: usize,
    pub kind: TreeJointKind,
    /// `u_a`, unit, in the parent's principal frame.
    pub axis_parent: Vector3<f64>,
    /// `W₀`.
    pub rest: UnitQuaternion<f64>,
    /// `(0, u_a) ⊗ W₀`: `Rot(u_a, θ) W₀ = cos(θ/2) W₀ + sin(θ/2) (0, u_a) ⊗ W₀`.
    pub axis_rest: Quaternion<f64>,
    pub anchor_parent: Vector3<f64>,
    pub anchor_child: Vector3<f64>,
    /// The mechanism coordinate this joint's angle or displacement is (`MechanismModel::coordinates`).
    pub coordinate: usize,
}

/// A mechanism the joint-space step can take (see [`TreeModel::of`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TreeModel {
    /// Same order as the mechanism's joints (children increasing: parents before children).
    pub joints: Vec<TreeJoint>,
    /// Per local body, the joint whose child it is (`None`: a floating base's root).
    pub body_joint: Vec<Option<usize>>,
    pub floating: bool,
    /// Per coordinate, the joint it is read from.
    pub coordinate_joint: Vec<usize>,
}

/// Why a mechanism stays on the maximal-coordinate step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NotATree {
    /// A compound joint (two or three revolutes through one point).
    Compound,
    /// Mimic rows.
    Mimic,
}

impl TreeModel {
    /// The tree of `mechanism`, or why it has none yet: every joint a hinge or a slider with
    /// one coordinate, no mimic (limits and friction are taken: `super::stops`).
    pub fn of(mechanism: &Mechanism) -> Result<Self, NotATree> {
        if !mechanism.mimics.is_empty() {
            return Err(NotATree::Mimic);
        }
        let mut coordinate_of = vec![None; mechanism.joints.len()];
        for (k, c) in mechanism.coordinates.iter().enumerate() {
            if matches!(c.kind, CoordinateKind::Compound { .. }) || coordinate_of[c.joint].is_some()
            {
                return Err(NotATree::Compound);
            }
            coordinate_of[c.joint] = Some(k);
        }
        let mut body_joint = vec![None; mechanism.body_count];
        let mut joints = Vec::with_capacity(mechanism.joints.len());
        for (j, joint) in mechanism.joints.iter().enumerate() {
            if joint.compound.is_some() {
                return Err(NotATree::Compound);
            }
            let coordinate = coordinate_of[j].ok_or(NotATree::Compound)?;
            let rows = &joint.rows;
            let (kind, axis_parent, rest) =
                match (&rows.kind, &mechanism.coordinates[coordinate].kind) {
                    (
                        RowKind::Hinge {
                            axis_parent,
                            axis_child,
                            ..
                        },
                        CoordinateKind::Hinge {
                            ref_parent,
                            ref_child,
                            ..
                        },
                    ) => (
                        TreeJointKind::Hinge,
                        *axis_parent,
                        frame(axis_parent, ref_parent) * frame(axis_child, ref_child).transpose(),
                    ),
                    (
                        RowKind::Slider {
                            axis_parent, lock, ..
                        },
                        CoordinateKind::Slider { .. },
                    ) => {
                        // `W₀ = Σ_k t_k s_kᵀ` (`s_k = W₀ᵀ t_k`, `(t_1, t_2, t_3)` orthonormal):
                        // the lock rows pair them cyclically shifted, `lock = [(t_2, s_3),
                        // (t_3, s_1), (t_1, s_2)]` (`super::super::rows`).
                        let w0: Matrix3<f64> = lock[2].0 * lock[1].1.transpose()
                            + lock[0].0 * lock[2].1.transpose()
                            + lock[1].0 * lock[0].1.transpose();
                        (TreeJointKind::Slider, *axis_parent, w0)
                    }
                    _ => return Err(NotATree::Compound),
                };
            let rest = UnitQuaternion::from_matrix(&rest);
            let u = Quaternion::from_imag(axis_parent);
            body_joint[joint.child] = Some(j);
            joints.push(TreeJoint {
                parent: joint.parent,
                child: joint.child,
                kind,
                axis_parent,
                rest,
                axis_rest: u * rest.into_inner(),
                anchor_parent: rows.anchor_parent,
                anchor_child: rows.anchor_child,
                coordinate,
            });
        }
        Ok(Self {
            coordinate_joint: mechanism.coordinates.iter().map(|c| c.joint).collect(),
            joints,
            body_joint,
            floating: mechanism.base == Base::Floating,
        })
    }

    /// Generalized coordinates before the joints': 6 for a floating base (`η` body frame,
    /// `δc` world), else 0.
    pub fn base_dofs(&self) -> usize {
        if self.floating { 6 } else { 0 }
    }

    /// Number of generalized coordinates.
    pub fn dofs(&self) -> usize {
        self.base_dofs() + self.joints.len()
    }
}

/// The rotation whose columns are `u`, `w` (made orthogonal to `u`), `u × w`.
fn frame(u: &Vector3<f64>, w: &Vector3<f64>) -> Matrix3<f64> {
    let u = u.normalize();
    let w = (w - u * u.dot(w)).normalize();
    Matrix3::from_columns(&[u, w, u.cross(&w)])
}
