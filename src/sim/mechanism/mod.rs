//! Articulated mechanisms: URDF joints kept as constraints in maximal coordinates, integrated
//! by the constrained discrete Euler-Lagrange equations on top of the per-body exp-map step.
//!
//! Every body of a mechanism keeps its free-body state in the [`crate::sim::Bodies`] batch
//! (principal frame, `R`, `c`, body angular momentum `M`, linear momentum `m v`); each joint adds
//! constraint rows `g(q) = 0` ([`rows`]) with multipliers `λ` (impulses). One step of `h`
//! ([`step`], as in Dojo.jl and trep; Marsden & West, "Discrete mechanics and variational
//! integrators", Acta Numerica 2001, §3.4):
//!
//! ```text
//! [M_i⁺; p_i⁺] = [M_i; p_i] + G_i(q_k)ᵀ λ        impulses at the start of the step
//! J_i ξ_i = h T(ξ_i)ᵀ M_i⁺                        the free-body step, unchanged
//! c_i' = c_i + (h/m_i) p_i⁺ + α h² g,   R_i' = R_i exp(ξ_i)
//! g(q_{k+1}) = 0                                 the constraints hold at the end
//! M_i ← exp(ξ_i)ᵀ M_i⁺,   p_i ← p_i⁺ + h m_i g
//! ```
//!
//! solved by Newton on `(ξ, λ)` together with the tree-structured direct solve of [`tree`].
//! Because every row is invariant under a rigid motion of the whole mechanism, the impulses
//! sum to zero force and torque for any `λ`: a free-floating mechanism's linear and angular
//! momentum are exact to round-off at any step and any Newton tolerance.
//!
//! Modules: [`rows`] (joint rows and Jacobians), [`tree`] (the linear-time solve), [`step`]
//! (the constrained step, its guards and substeps), [`project`] (velocities projected onto
//! the velocity constraints, RATTLE-style, and the reported totals), [`coords`] (joint
//! coordinates read back from the poses), [`init`] (forward velocity kinematics: body twists
//! from joint rates and the base twist), [`stepper`] (the [`crate::sim::Integrator`] that
//! steps free bodies and mechanisms together, and its compositions).
//!
//! A [`Mechanism`] is constant (built by the scene, [`crate::scene`]; copies of one table share
//! its [`MechanismModel`]); [`step::MechanismState`]
//! holds what changes (warm starts, workspaces). Nothing here knows URDF.

pub mod constrained;
pub mod coords;
pub mod drive;
pub mod init;
pub mod joint_space;
pub mod project;
pub mod rows;
pub mod step;
pub mod stepper;
pub mod stop;
pub mod tree;

pub use coords::{CompoundChain, CoordinateKind};
pub use drive::{Actuator, ActuatorKind, Effort, JointDrive};
pub use rows::{BodyPose, JointRows, RowKind};
pub use stepper::{Articulated, UnsupportedIntegrator};
pub use stop::{JointStop, StopMode};

use nalgebra::{Isometry3, Vector3};
use std::sync::Arc;

/// One mechanism of the batch: a placed instance of a [`MechanismModel`].
///
/// The model (joint rows in the bodies' principal frames, coordinates, mimics) does not depend
/// on where the mechanism stands, so the copies of one `[[model]]` table share it (one
/// [`Arc`]); an instance adds what differs: its name, its bodies' place in the batch and, for
/// a fixed base, the welded root's pose. It dereferences to its model.
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// The model's name (the scene's `name`, a copy's `<name>_<index>`, else the URDF
    /// `<robot name>`).
    pub name: String,
    /// Batch index of the mechanism's first body; its bodies are `first_body ..
    /// first_body + body_count`, parents before children (local index `i` = batch index
    /// `first_body + i`).
    pub first_body: usize,
    /// The world "body" pose that joints on the world (`parent: None`, fixed base) use: the
    /// welded root's principal frame in the world (identity for a floating base).
    pub world_pose: BodyPose,
    pub shared: Arc<MechanismModel>,
}

impl std::ops::Deref for Mechanism {
    type Target = MechanismModel;
    fn deref(&self) -> &MechanismModel {
        &self.shared
    }
}

/// What a mechanism is, wherever it stands: a tree of bodies and joints (shared by copies).
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismModel {
    pub body_count: usize,
    /// One joint per body that has a parent joint; `joints[j].child` are distinct and
    /// increasing, `joints[j].parent < joints[j].child`.
    pub joints: Vec<MechanismJoint>,
    /// The URDF joint coordinates recorded on `/joints` (one per moving URDF joint kept:
    /// hinge and slider joints, each stage of a compound joint).
    pub coordinates: Vec<Coordinate>,
    /// Mimic rows `θ_f − k θ_l − b = 0` on coordinates.
    pub mimics: Vec<Mimic>,
    /// What drives the coordinates (actuators, damping), at most one per coordinate, sorted by
    /// coordinate; each adds one row to its joint's block in the step ([`step`]).
    pub drives: Vec<JointDrive>,
    /// Limits and friction on the coordinates ([`stop`]), at most one per coordinate, sorted by
    /// coordinate; each adds one row to its joint's block (after the drives' rows).
    pub stops: Vec<JointStop>,
    /// `Fixed`: the root link is welded to the world (joints on it have no parent body).
    pub base: Base,
    /// A length typical of the mechanism (largest anchor distance from a centre of mass, ≥ 1 mm):
    /// the Newton tolerance on the gap rows is `newton_tol` times it.
    pub length_scale: f64,
}

/// Whether the root link moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Base {
    Floating,
    Fixed,
}

/// One joint (or a compound of revolutes through one point) between two bodies.
#[derive(Debug, Clone, PartialEq)]
pub struct MechanismJoint {
    /// The URDF joint name (for a compound joint: the first joint's).
    pub name: String,
    /// Local index of the parent body; `None`: the world (fixed base), at the instance's
    /// [`Mechanism::world_pose`].
    pub parent: Option<usize>,
    pub child: usize,
    pub rows: JointRows,
    /// For a compound joint: its chain of revolutes (angles recorded per stage).
    pub compound: Option<CompoundChain>,
    /// For a compound joint: pose of the first joint's frame in the parent body's frame
    /// (interior link frames are placed from it).
    pub parent_from_first: Isometry3<f64>,
    /// For a compound joint: the interior (massless) links' frame poses in their joint frame
    /// chain: link `k` (`k < stages − 1`) is at `parent_from_first · Π_{i≤k} O_i Rot(u_i, θ_i)`
    /// with `O_i` these isometries (`O_0` identity).
    pub stage_origins: Vec<Isometry3<f64>>,
}

/// One recorded joint coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Coordinate {
    /// The URDF joint name.
    pub name: String,
    /// The mechanism joint it is read from.
    pub joint: usize,
    pub kind: CoordinateKind,
    /// The URDF `<limit>` range (revolute, prismatic; `None` when absent or empty).
    pub limits: Option<[f64; 2]>,
    /// The position at the start (rad or m), the first unwrapping reference.
    pub initial: f64,
    /// `prismatic` (m) rather than an angle (rad).
    pub is_linear: bool,
}

/// A mimic row on two coordinates: `θ_follower = multiplier θ_leader + offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mimic {
    pub follower: usize,
    pub leader: usize,
    pub multiplier: f64,
    pub offset: f64,
}

impl Mechanism {
    /// Local body range in the batch.
    pub fn bodies(&self) -> std::ops::Range<usize> {
        self.first_body..self.first_body + self.body_count
    }
}

impl MechanismModel {
    /// The tree structure for [`tree::TreeSolver`].
    pub fn topology(&self) -> tree::Topology {
        let mut parent_joint = vec![None; self.body_count];
        for (j, joint) in self.joints.iter().enumerate() {
            parent_joint[joint.child] = Some(j);
        }
        tree::Topology {
            parent_joint,
            joint_bodies: self.joints.iter().map(|j| (j.parent, j.child)).collect(),
            rows: self.joints.iter().map(|j| j.rows.count()).collect(),
        }
    }

    /// Checks the structural invariants (the builder's contract); a description of the first
    /// one broken.
    pub fn validate(&self) -> Result<(), String> {
        let mut has_parent = vec![false; self.body_count];
        for (j, joint) in self.joints.iter().enumerate() {
            if joint.child >= self.body_count || has_parent[joint.child] {
                return Err(format!(
                    "joint {j}: child body {} invalid or repeated",
                    joint.child
                ));
            }
            if joint.parent.is_some_and(|p| p >= joint.child) {
                return Err(format!("joint {j}: parent body not before its child"));
            }
            if joint.parent.is_none() && self.base == Base::Floating {
                return Err(format!("joint {j}: on the world with a floating base"));
            }
            has_parent[joint.child] = true;
        }
        let roots = has_parent.iter().filter(|&&p| !p).count();
        let expected = match self.base {
            Base::Floating => 1,
            Base::Fixed => 0,
        };
        if roots != expected || (self.base == Base::Floating && has_parent[0]) {
            return Err(format!(
                "{roots} bodies without a parent joint, expected {expected}"
            ));
        }
        for m in &self.mimics {
            if m.follower >= self.coordinates.len() || m.leader >= self.coordinates.len() {
                return Err("mimic on an unknown coordinate".into());
            }
        }
        let mut extra_rows = vec![0; self.joints.len()];
        for (k, d) in self.drives.iter().enumerate() {
            let Some(c) = self.coordinates.get(d.coordinate) else {
                return Err(format!("drive {k} on an unknown coordinate"));
            };
            if k > 0 && self.drives[k - 1].coordinate >= d.coordinate {
                return Err("drives not sorted by coordinate, or two on one".into());
            }
            if matches!(c.kind, CoordinateKind::Compound { .. })
                && self.joints[c.joint].compound.is_none()
            {
                return Err(format!("compound stage {:?} without its chain", c.name));
            }
            extra_rows[c.joint] += 1;
            if self.joints[c.joint].rows.count() + extra_rows[c.joint] > rows::MAX_ROWS {
                return Err(format!("joint {:?}: too many driven rows", c.name));
            }
        }
        for (k, s) in self.stops.iter().enumerate() {
            let Some(c) = self.coordinates.get(s.coordinate) else {
                return Err(format!("stop {k} on an unknown coordinate"));
            };
            if k > 0 && self.stops[k - 1].coordinate >= s.coordinate {
                return Err("stops not sorted by coordinate, or two on one".into());
            }
            if !(s.friction >= 0.0 && s.friction.is_finite())
                || s.limits
                    .is_some_and(|[lo, hi]| lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less))
            {
                return Err(format!("joint {:?}: invalid limit or friction", c.name));
            }
            if matches!(c.kind, CoordinateKind::Compound { .. })
                && self.joints[c.joint].compound.is_none()
            {
                return Err(format!("compound stage {:?} without its chain", c.name));
            }
            extra_rows[c.joint] += 1;
            if self.joints[c.joint].rows.count() + extra_rows[c.joint] > rows::MAX_ROWS {
                return Err(format!("joint {:?}: too many rows", c.name));
            }
        }
        Ok(())
    }
}

/// The translation part of a point in a pose, as used by the anchors.
pub fn transform_point(pose: &BodyPose, p: &Vector3<f64>) -> Vector3<f64> {
    pose.com + pose.rot * p
}
