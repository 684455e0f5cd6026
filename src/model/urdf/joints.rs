//! The robot's kinematic structure from urdf-rs's types: the links' indices, the
//! [`Joint`]s, and the tree they form with the links' poses at a joint configuration.

use super::ModelError;
use crate::model::kinematics::{self, Joint, JointKind, KinematicsError, Mimic};
use nalgebra::{Isometry3, Vector3};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Each link's index in file order, checking that there is at least one link
/// ([`ModelError::NoLinks`]) and that no name is used twice ([`ModelError::DuplicateLink`]).
pub(super) fn link_indices<'r>(
    robot: &'r urdf_rs::Robot,
    path: &Path,
) -> Result<HashMap<&'r str, usize>, ModelError> {
    if robot.links.is_empty() {
        return Err(ModelError::NoLinks {
            path: path.to_path_buf(),
        });
    }
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (i, link) in robot.links.iter().enumerate() {
        if index.insert(link.name.as_str(), i).is_some() {
            return Err(ModelError::DuplicateLink {
                path: path.to_path_buf(),
                link: link.name.clone(),
            });
        }
    }
    Ok(index)
}

/// A `<mimic>` dropped because the joint it mimics does not exist: (joint, mimicked joint).
pub(super) type DroppedMimic<'r> = (&'r str, &'r str);

/// The joints in file order, their links by index: checks that no joint name is used twice
/// ([`ModelError::DuplicateJoint`]) and that parent and child are links of the robot
/// ([`ModelError::UnknownLink`]). Limits are kept for revolute and prismatic joints whose
/// upper bound is above the lower; `<dynamics damping friction>` and `<limit effort>` are kept as
/// written (0 when absent), for every joint type. In lenient mode a `<mimic>` of a joint that does not exist
/// is dropped and returned as a (joint, mimicked) pair for its warning.
pub(super) fn joints<'r>(
    robot: &'r urdf_rs::Robot,
    index: &HashMap<&str, usize>,
    lenient: bool,
    path: &Path,
) -> Result<(Vec<Joint>, Vec<DroppedMimic<'r>>), ModelError> {
    let all_joint_names: HashSet<&str> = robot.joints.iter().map(|j| j.name.as_str()).collect();
    let mut joint_names = HashSet::new();
    let mut missing_mimics = Vec::new();
    let mut joints = Vec::with_capacity(robot.joints.len());
    for j in &robot.joints {
        if !joint_names.insert(j.name.as_str()) {
            return Err(ModelError::DuplicateJoint {
                path: path.to_path_buf(),
                joint: j.name.clone(),
            });
        }
        let find = |role: &'static str, name: &str| {
            index
                .get(name)
                .copied()
                .ok_or_else(|| ModelError::UnknownLink {
                    path: path.to_path_buf(),
                    joint: j.name.clone(),
                    role,
                    link: name.to_string(),
                })
        };
        joints.push(Joint {
            name: j.name.clone(),
            kind: JointKind::from(&j.joint_type),
            parent: find("parent", &j.parent.link)?,
            child: find("child", &j.child.link)?,
            parent_from_joint: kinematics::isometry_from_pose(&j.origin),
            axis: Vector3::from(j.axis.xyz.0),
            mimic: j
                .mimic
                .as_ref()
                .filter(|m| {
                    let keep = !lenient || all_joint_names.contains(m.joint.as_str());
                    if !keep {
                        missing_mimics.push((j.name.as_str(), m.joint.as_str()));
                    }
                    keep
                })
                .map(|m| Mimic {
                    joint: m.joint.clone(),
                    multiplier: m.multiplier.unwrap_or(1.0),
                    offset: m.offset.unwrap_or(0.0),
                }),
            limits: matches!(
                j.joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic
            )
            .then_some([j.limit.lower, j.limit.upper])
            .filter(|[lo, hi]| hi > lo),
            damping: j.dynamics.as_ref().map_or(0.0, |d| d.damping),
            friction: j.dynamics.as_ref().map_or(0.0, |d| d.friction),
            effort_limit: j.limit.effort,
            velocity_limit: j.limit.velocity,
        });
    }
    Ok((joints, missing_mimics))
}

/// The root link's index and every link's pose in the model (root link) frame at
/// `joint_positions`: checks that the joints form a tree with one root
/// ([`ModelError::SeveralParents`], [`ModelError::SeveralRoots`], [`ModelError::Cycle`]) and
/// that the configuration names joints that exist and can take it
/// ([`ModelError::Configuration`]).
pub(super) fn place_links(
    robot: &urdf_rs::Robot,
    joints: &[Joint],
    joint_positions: &HashMap<String, f64>,
    path: &Path,
) -> Result<(usize, Vec<Isometry3<f64>>), ModelError> {
    let file = || path.to_path_buf();
    let names: Vec<String> = robot.links.iter().map(|l| l.name.clone()).collect();
    let tree_error = |e: KinematicsError| match e {
        KinematicsError::SeveralParents {
            link,
            first,
            second,
        } => ModelError::SeveralParents {
            path: file(),
            link,
            first,
            second,
        },
        KinematicsError::SeveralRoots { roots } => ModelError::SeveralRoots {
            path: file(),
            roots,
        },
        KinematicsError::Cycle { links } => ModelError::Cycle {
            path: file(),
            links,
        },
        error => ModelError::Configuration {
            path: file(),
            error,
        },
    };
    let (root_index, _) = kinematics::tree_order(&names, joints).map_err(tree_error)?;
    let poses =
        kinematics::forward_kinematics(&names, joints, joint_positions).map_err(tree_error)?;
    Ok((root_index, poses))
}
