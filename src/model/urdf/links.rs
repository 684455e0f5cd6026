//! The [`Link`]s from urdf-rs's types: mass properties from `<inertial>` (or none), the
//! links' poses, their visuals and collisions ([`super::geometry`]) and their problems.

use super::geometry::{Meshes, collision, materials, visual};
use crate::model::kinematics;
use crate::model::{InertiaSource, Link, MassProperties};
use nalgebra::{Isometry3, Matrix3, Vector3};
use std::collections::{HashMap, HashSet};

/// The links in file order, each at its pose in `poses` (see [`link`]).
pub(super) fn links<'a>(
    robot: &'a urdf_rs::Robot,
    poses: Vec<Isometry3<f64>>,
    links_with_inertial: &HashSet<&str>,
    meshes: &mut Meshes<'a>,
) -> Vec<Link> {
    let materials = materials(robot);
    robot
        .links
        .iter()
        .zip(poses)
        .map(|(l, model_from_link)| {
            let has_inertial = links_with_inertial.contains(l.name.as_str());
            link(l, model_from_link, has_inertial, &materials, meshes)
        })
        .collect()
}

/// One link: its mass properties from `<inertial>` when it has one
/// ([`InertiaSource::Urdf`], validated: [`MassProperties::validate`]) or none
/// ([`InertiaSource::Missing`]), its visuals and collisions with their meshes resolved and
/// confined. Its problems: the validation's findings, a pose that is not finite, bad visual
/// geometry, unresolved visual meshes, refused meshes (visual or collision).
fn link<'a>(
    l: &'a urdf_rs::Link,
    model_from_link: Isometry3<f64>,
    has_inertial: bool,
    materials: &HashMap<&str, [f32; 4]>,
    meshes: &mut Meshes<'a>,
) -> Link {
    let mut problems = Vec::new();
    meshes.link = &l.name;
    let first_mesh = meshes.uses.len();
    let (inertial, source) = if has_inertial {
        let mp = mass_properties_from_urdf(&l.inertial);
        problems.extend(mp.validate());
        (Some(mp), InertiaSource::Urdf)
    } else {
        (None, InertiaSource::Missing)
    };
    if !pose_is_finite(&model_from_link) {
        problems.push(NON_FINITE_POSE.to_string());
    }
    let visuals = l
        .visual
        .iter()
        .enumerate()
        .map(|(k, v)| visual(v, k, meshes, materials, &mut problems))
        .collect();
    let collisions = l
        .collision
        .iter()
        .enumerate()
        .map(|(k, c)| collision(c, k, meshes))
        .collect();
    // A refused mesh, visual or collision, is a problem of its link.
    problems.extend(meshes.uses[first_mesh..].iter().filter_map(|m| {
        let why = m.refusal()?;
        Some(format!("{}: mesh `{}`: {why}", m.element, m.uri))
    }));
    Link {
        name: l.name.clone(),
        model_from_link,
        inertial,
        source,
        problems,
        visuals,
        collisions,
        urdf_inertial: inertial,
        geometry_used: None,
        notes: Vec::new(),
    }
}

pub(super) const NON_FINITE_POSE: &str = "pose in the model frame is not finite (a joint origin on the path from the root is NaN or infinite)";

pub(super) fn pose_is_finite(pose: &nalgebra::Isometry3<f64>) -> bool {
    pose.translation.vector.iter().all(|x| x.is_finite())
        && pose.rotation.coords.iter().all(|x| x.is_finite())
}

/// Mass properties in the link frame from a URDF `<inertial>`:
/// `com = xyz`, `I = R I' Rᵀ` with `R = Rz(y) Ry(p) Rx(r)` from the inertial origin's `rpy` and
///
/// ```text
///      | ixx ixy ixz |
/// I' = | ixy iyy iyz |
///      | ixz iyz izz |
/// ```
pub fn mass_properties_from_urdf(inertial: &urdf_rs::Inertial) -> MassProperties {
    let i = &inertial.inertia;
    #[rustfmt::skip]
    let local = Matrix3::new(
        i.ixx, i.ixy, i.ixz,
        i.ixy, i.iyy, i.iyz,
        i.ixz, i.iyz, i.izz,
    );
    let r = kinematics::rotation_from_rpy(inertial.origin.rpy.0).to_rotation_matrix();
    let r = r.matrix();
    MassProperties {
        mass: inertial.mass.value,
        com: Vector3::from(inertial.origin.xyz.0),
        inertia: r * local * r.transpose(),
    }
}
