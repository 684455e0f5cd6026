//! Kinematic tree of a URDF model and forward kinematics at a joint configuration.
//!
//! Frames: every joint `j` has a fixed `parent_from_joint` (its URDF `<origin>`); its motion
//! `joint_from_child(q)` is a rotation about (revolute, continuous) or a translation along
//! (prismatic) the unit `axis`, given in the joint frame. Then, from the root,
//!
//! ```text
//! model_from_child = model_from_parent · parent_from_joint · joint_from_child(q)
//! ```
//!
//! At `q = 0` every joint type (fixed, floating, planar, spherical included) reduces to its
//! origin. Floating, planar and spherical joints have several degrees of freedom and cannot be
//! set with one number: they stay at their origin.
//!
//! Mimic joints follow URDF: `q = multiplier · q_mimicked + offset` (multiplier 1, offset 0 by
//! default), so a mimic offset moves the joint even at the "zero" configuration.

use crate::budget::readable;
use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};
use std::collections::HashMap;

/// URDF joint types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    Revolute,
    Continuous,
    Prismatic,
    Fixed,
    Floating,
    Planar,
    Spherical,
}

impl JointKind {
    /// Whether one number (an angle or a distance) sets the joint.
    pub fn is_single_dof(self) -> bool {
        matches!(self, Self::Revolute | Self::Continuous | Self::Prismatic)
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Revolute => "revolute",
            Self::Continuous => "continuous",
            Self::Prismatic => "prismatic",
            Self::Fixed => "fixed",
            Self::Floating => "floating",
            Self::Planar => "planar",
            Self::Spherical => "spherical",
        }
    }
}

impl From<&urdf_rs::JointType> for JointKind {
    fn from(t: &urdf_rs::JointType) -> Self {
        match t {
            urdf_rs::JointType::Revolute => Self::Revolute,
            urdf_rs::JointType::Continuous => Self::Continuous,
            urdf_rs::JointType::Prismatic => Self::Prismatic,
            urdf_rs::JointType::Fixed => Self::Fixed,
            urdf_rs::JointType::Floating => Self::Floating,
            urdf_rs::JointType::Planar => Self::Planar,
            urdf_rs::JointType::Spherical => Self::Spherical,
        }
    }
}

/// `<mimic joint=... multiplier=... offset=...>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mimic {
    pub joint: String,
    pub multiplier: f64,
    pub offset: f64,
}

/// One joint of the tree, links referred to by index.
#[derive(Debug, Clone)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub parent: usize,
    pub child: usize,
    /// The URDF `<origin>`: pose of the joint frame in the parent link frame.
    pub parent_from_joint: Isometry3<f64>,
    /// The URDF `<axis>` as written, in the joint frame (normalised when used).
    pub axis: Vector3<f64>,
    pub mimic: Option<Mimic>,
    /// The `<limit lower upper>` range of a revolute or prismatic joint (rad or m), when it
    /// is a real interval (`upper > lower`; a missing `<limit>` reads as `[0, 0]`: no range).
    pub limits: Option<[f64; 2]>,
    /// The `<dynamics damping>` as written (N m s/rad, or N s/m for a prismatic joint); 0
    /// when absent. Not checked here: a scene that uses it checks it
    /// (`crate::scene` turns it into joint damping of articulated models).
    pub damping: f64,
    /// The `<dynamics friction>` as written (N m, or N for a prismatic joint); 0 when absent.
    /// Not checked here: a scene that uses it checks it (joint friction of articulated models).
    pub friction: f64,
    /// The `<limit effort>` as written (N m, or N for a prismatic joint), any joint type; 0
    /// when absent. Not checked here: an actuator that uses it as its clamp checks it.
    pub effort_limit: f64,
    /// The `<limit velocity>` as written (rad/s, or m/s for a prismatic joint); 0 when absent.
    /// Reported by `inspect`; the simulation does not use it.
    pub velocity_limit: f64,
}

/// Why a set of joints is not a tree, or a configuration cannot be applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    #[error("link `{link}` is the child of more than one joint (`{first}` and `{second}`)")]
    SeveralParents {
        link: String,
        first: String,
        second: String,
    },
    #[error("more than one root link (a root is no joint's child): {}", .roots.join(", "))]
    SeveralRoots { roots: Vec<String> },
    #[error("the joints form a cycle through links {}", .links.join(" -> "))]
    Cycle { links: Vec<String> },
    #[error("joints.{joint}: no joint named `{joint}` (a position was given for it){suggestion}")]
    UnknownJoint {
        joint: String,
        /// `": did you mean `NAME`?"` ([`crate::message::did_you_mean`]), or empty.
        suggestion: String,
    },
    #[error("joint `{joint}` is {kind}: one number cannot set it")]
    NotSingleDof { joint: String, kind: &'static str },
    #[error("joint `{joint}`: position {value} is not finite")]
    NotFinite { joint: String, value: f64 },
    #[error(
        "joint `{joint}`: axis [{}, {}, {}] has no direction (it must be a non-zero vector of \
         finite numbers)",
        readable(.axis[0]), readable(.axis[1]), readable(.axis[2])
    )]
    ZeroAxis { joint: String, axis: [f64; 3] },
    #[error("joint `{joint}` mimics `{mimicked}`, which does not exist")]
    UnknownMimic { joint: String, mimicked: String },
    #[error(
        "joint `{joint}` mimics `{mimicked}` with multiplier {} and offset {}: \
         its position {value} is not finite",
        readable(*.multiplier), readable(*.offset)
    )]
    MimicNotFinite {
        joint: String,
        mimicked: String,
        multiplier: f64,
        offset: f64,
        value: f64,
    },
}

/// `R = Rz(yaw) Ry(pitch) Rx(roll)` for URDF `rpy = [roll, pitch, yaw]` (fixed axes x, y, z).
pub fn rotation_from_rpy(rpy: [f64; 3]) -> UnitQuaternion<f64> {
    let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), rpy[0]);
    let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), rpy[1]);
    let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rpy[2]);
    rz * ry * rx
}

/// The pose an URDF `<origin xyz rpy>` describes.
pub fn isometry_from_pose(pose: &urdf_rs::Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(pose.xyz[0], pose.xyz[1], pose.xyz[2]),
        rotation_from_rpy(pose.rpy.0),
    )
}

/// Root and a parent-before-child order of the links, checking the joints form one tree:
/// each link has at most one parent, exactly one link has none, and every link is reached
/// from it (otherwise the unreached links hang on a cycle).
///
/// Returns `(root, joint indices in parent-before-child order)`.
pub fn tree_order(
    link_names: &[String],
    joints: &[Joint],
) -> Result<(usize, Vec<usize>), KinematicsError> {
    let n = link_names.len();
    let mut parent_joint: Vec<Option<usize>> = vec![None; n];
    for (j, joint) in joints.iter().enumerate() {
        if let Some(first) = parent_joint[joint.child] {
            return Err(KinematicsError::SeveralParents {
                link: link_names[joint.child].clone(),
                first: joints[first].name.clone(),
                second: joint.name.clone(),
            });
        }
        parent_joint[joint.child] = Some(j);
    }
    let roots: Vec<usize> = (0..n).filter(|&i| parent_joint[i].is_none()).collect();
    if roots.len() > 1 {
        return Err(KinematicsError::SeveralRoots {
            roots: roots.iter().map(|&i| link_names[i].clone()).collect(),
        });
    }
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    for (j, joint) in joints.iter().enumerate() {
        children[joint.parent].push(j);
    }
    let mut reached = vec![false; n];
    let mut order = Vec::with_capacity(joints.len());
    if let Some(&root) = roots.first() {
        reached[root] = true;
        let mut stack = vec![root];
        while let Some(link) = stack.pop() {
            for &j in children[link].iter().rev() {
                let child = joints[j].child;
                if !reached[child] {
                    reached[child] = true;
                    order.push(j);
                    stack.push(child);
                }
            }
        }
    }
    if let Some(start) = (0..n).find(|&i| !reached[i]) {
        // Walk up the parents from an unreached link until a link repeats: that is the cycle.
        let mut seen = vec![false; n];
        let mut link = start;
        while !seen[link] {
            seen[link] = true;
            match parent_joint[link] {
                Some(j) => link = joints[j].parent,
                None => break,
            }
        }
        let mut cycle = vec![link_names[link].clone()];
        let first = link;
        while let Some(j) = parent_joint[link] {
            link = joints[j].parent;
            cycle.push(link_names[link].clone());
            if link == first || cycle.len() > n {
                break;
            }
        }
        cycle.reverse();
        return Err(KinematicsError::Cycle { links: cycle });
    }
    Ok((roots[0], order))
}

/// The unit direction of a joint axis as written: `None` when it has none (a zero vector, or a
/// NaN or infinite component). Normalised after scaling by its largest component, so that any
/// non-zero finite vector has a direction (`[1e-200, 0, 0]` and `[1e200, 1e200, 0]` too, whose
/// squared norms underflow or overflow).
pub fn axis_direction(axis: &Vector3<f64>) -> Option<Unit<Vector3<f64>>> {
    let largest = axis.amax();
    if !(largest.is_finite() && largest > 0.0) || axis.iter().any(|x| !x.is_finite()) {
        return None;
    }
    Some(Unit::new_normalize(axis / largest))
}

/// Motion of a joint at position `q`: `joint_from_child(q)`.
pub fn joint_motion(joint: &Joint, q: f64) -> Result<Isometry3<f64>, KinematicsError> {
    if q == 0.0 || !joint.kind.is_single_dof() {
        return Ok(Isometry3::identity());
    }
    if !q.is_finite() {
        return Err(KinematicsError::NotFinite {
            joint: joint.name.clone(),
            value: q,
        });
    }
    let axis = axis_direction(&joint.axis).ok_or_else(|| KinematicsError::ZeroAxis {
        joint: joint.name.clone(),
        axis: joint.axis.into(),
    })?;
    Ok(match joint.kind {
        JointKind::Prismatic => Isometry3::from_parts(
            Translation3::from(axis.into_inner() * q),
            UnitQuaternion::identity(),
        ),
        _ => Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&axis, q),
        ),
    })
}

/// Pose of every link in the model (root link) frame at the configuration `joint_positions`
/// (joint name → angle in rad or distance in m; joints not in the map are at 0).
///
/// Errors when the joints are not a tree (see [`tree_order`]), a name in the map is not a joint
/// of the model, a position is given for a multi-DOF joint or is not finite, or a moving joint's
/// axis is zero.
pub fn forward_kinematics(
    link_names: &[String],
    joints: &[Joint],
    joint_positions: &HashMap<String, f64>,
) -> Result<Vec<Isometry3<f64>>, KinematicsError> {
    let (root, order) = tree_order(link_names, joints)?;
    let by_name: HashMap<&str, &Joint> = joints.iter().map(|j| (j.name.as_str(), j)).collect();
    for (name, &value) in joint_positions {
        let joint = by_name
            .get(name.as_str())
            .ok_or_else(|| KinematicsError::UnknownJoint {
                joint: name.clone(),
                suggestion: crate::message::did_you_mean(
                    name,
                    joints.iter().map(|j| j.name.as_str()),
                ),
            })?;
        if !joint.kind.is_single_dof() && value != 0.0 {
            return Err(KinematicsError::NotSingleDof {
                joint: name.clone(),
                kind: joint.kind.as_str(),
            });
        }
    }
    let position = |joint: &Joint| -> Result<f64, KinematicsError> {
        match &joint.mimic {
            Some(m) => {
                if !by_name.contains_key(m.joint.as_str()) {
                    return Err(KinematicsError::UnknownMimic {
                        joint: joint.name.clone(),
                        mimicked: m.joint.clone(),
                    });
                }
                let q = joint_positions.get(&m.joint).copied().unwrap_or(0.0);
                let value = m.multiplier * q + m.offset;
                if !value.is_finite() {
                    return Err(KinematicsError::MimicNotFinite {
                        joint: joint.name.clone(),
                        mimicked: m.joint.clone(),
                        multiplier: m.multiplier,
                        offset: m.offset,
                        value,
                    });
                }
                Ok(value)
            }
            None => Ok(joint_positions.get(&joint.name).copied().unwrap_or(0.0)),
        }
    };
    let mut poses = vec![Isometry3::identity(); link_names.len()];
    poses[root] = Isometry3::identity();
    for j in order {
        let joint = &joints[j];
        let q = position(joint)?;
        poses[joint.child] =
            poses[joint.parent] * joint.parent_from_joint * joint_motion(joint, q)?;
    }
    Ok(poses)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    fn joint(name: &str, kind: JointKind, parent: usize, child: usize, x: f64) -> Joint {
        Joint {
            name: name.into(),
            kind,
            parent,
            child,
            parent_from_joint: Isometry3::translation(x, 0.0, 0.0),
            axis: Vector3::z(),
            mimic: None,
            limits: None,
            damping: 0.0,
            friction: 0.0,
            effort_limit: 0.0,
            velocity_limit: 0.0,
        }
    }

    #[test]
    fn rpy_is_z_y_x() {
        let q = rotation_from_rpy([0.1, 0.2, 0.3]);
        let n = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
        // Two evaluations of the same product: measured 1e-16, bound 1e-14.
        assert!(q.angle_to(&n) < 1e-14);
        // Roll alone rotates y into z.
        let r = rotation_from_rpy([FRAC_PI_2, 0.0, 0.0]);
        assert!((r * Vector3::y() - Vector3::z()).amax() < 1e-15);
    }

    #[test]
    fn revolute_and_prismatic_move_the_child() {
        let links = names(&["a", "b", "c"]);
        let mut slide = joint("slide", JointKind::Prismatic, 1, 2, 1.0);
        slide.axis = Vector3::new(0.0, 2.0, 0.0); // not unit: normalised
        let joints = vec![joint("turn", JointKind::Revolute, 0, 1, 1.0), slide];
        let q = HashMap::from([("turn".to_string(), FRAC_PI_2), ("slide".to_string(), 0.5)]);
        let poses = forward_kinematics(&links, &joints, &q).unwrap();
        // b at x=1, turned 90° about z; c = b * (1, 0.5, 0) -> (1 - 0.5, 1, 0).
        assert!((poses[1].translation.vector - Vector3::new(1.0, 0.0, 0.0)).amax() < 1e-15);
        assert!((poses[2].translation.vector - Vector3::new(0.5, 1.0, 0.0)).amax() < 1e-15);
    }

    /// Any non-zero finite vector is a direction, whatever its size; zero, NaN and infinite
    /// components are none.
    #[test]
    fn axis_directions() {
        for (axis, unit) in [
            (Vector3::new(0.0, 2.0, 0.0), Vector3::y()),
            (Vector3::new(1e-300, 0.0, 0.0), Vector3::x()),
            (Vector3::new(0.0, 0.0, -5e-324), -Vector3::z()),
            (
                Vector3::new(1e200, 1e200, 0.0),
                Vector3::new(1.0, 1.0, 0.0) / 2f64.sqrt(),
            ),
            (Vector3::new(-3.0, 0.0, 4.0), Vector3::new(-0.6, 0.0, 0.8)),
        ] {
            let u = axis_direction(&axis).unwrap();
            // Normalisation of a scaled vector: measured 1.1e-16, bound 4 ulp.
            assert!((u.into_inner() - unit).amax() < 1e-15, "{axis:?}: {u:?}");
        }
        for axis in [
            Vector3::zeros(),
            Vector3::new(f64::NAN, 0.0, 0.0),
            Vector3::new(0.0, f64::INFINITY, 0.0),
            Vector3::new(1.0, 0.0, f64::NEG_INFINITY),
            Vector3::new(1.0, f64::NAN, 1.0),
        ] {
            assert_eq!(axis_direction(&axis), None, "{axis:?}");
        }
        // A moving joint needs one; the message says what the axis is, readably.
        let mut j = joint("j", JointKind::Revolute, 0, 1, 0.0);
        j.axis = Vector3::new(1e300, f64::NAN, 0.0);
        let e = joint_motion(&j, 0.5).unwrap_err().to_string();
        assert_eq!(
            e,
            "joint `j`: axis [1e300, NaN, 0] has no direction (it must be a non-zero vector of \
             finite numbers)"
        );
        assert!(joint_motion(&j, 0.0).is_ok());
    }

    #[test]
    fn tree_errors() {
        let links = names(&["a", "b", "c"]);
        let two_roots = vec![joint("j", JointKind::Fixed, 0, 1, 0.0)];
        assert!(matches!(
            tree_order(&links, &two_roots),
            Err(KinematicsError::SeveralRoots { .. })
        ));
        let cycle = vec![
            joint("ab", JointKind::Fixed, 0, 1, 0.0),
            joint("bc", JointKind::Fixed, 1, 2, 0.0),
            joint("ca", JointKind::Fixed, 2, 0, 0.0),
        ];
        let err = tree_order(&links, &cycle).unwrap_err();
        assert!(err.to_string().contains("cycle"), "{err}");
        let q = HashMap::from([("nope".to_string(), 1.0)]);
        let tree = vec![
            joint("ab", JointKind::Fixed, 0, 1, 0.0),
            joint("bc", JointKind::Fixed, 1, 2, 0.0),
        ];
        assert!(matches!(
            forward_kinematics(&links, &tree, &q),
            Err(KinematicsError::UnknownJoint { .. })
        ));
    }
}
