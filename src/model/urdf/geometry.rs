//! Visuals and collisions from urdf-rs's types: their geometry in SI units, their colours
//! (named `<material>`s), and their mesh URIs resolved ([`crate::model::package`]) and confined
//! ([`crate::model::confine`]), one [`MeshUse`] per `<mesh>`.

use crate::model::confine::{MeshAccess, MeshRoots, MeshStatus, MeshUse, Refusal};
use crate::model::{Collision, Geometry, Visual, kinematics, package};
use nalgebra::Vector3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A URDF colour (`rgba`, 0 to 1) as stored in a [`Visual`].
fn rgba(color: &urdf_rs::Color) -> [f32; 4] {
    color.rgba.0.map(|c| c as f32)
}

/// The named `<material>`s of the robot with a colour, by name (what a visual's
/// `<material name="..."/>` refers to).
pub(super) fn materials(robot: &urdf_rs::Robot) -> HashMap<&str, [f32; 4]> {
    robot
        .materials
        .iter()
        .filter_map(|m| Some((m.name.as_str(), rgba(m.color.as_ref()?))))
        .collect()
}

/// How a load resolves and confines mesh URIs, and what it found (one [`MeshUse`] per
/// `<mesh>`, in file order).
pub(super) struct Meshes<'a> {
    urdf_path: &'a Path,
    package_paths: &'a [PathBuf],
    ros_paths: Vec<PathBuf>,
    roots: MeshRoots,
    /// The link being read.
    pub(super) link: &'a str,
    pub(super) uses: Vec<MeshUse>,
}

impl<'a> Meshes<'a> {
    /// Resolution and confinement for the URDF at `urdf_path` (package paths first, then
    /// `ROS_PACKAGE_PATH`; the folders of [`MeshRoots`]), nothing found yet.
    pub(super) fn new(
        urdf_path: &'a Path,
        package_paths: &'a [PathBuf],
        access: &MeshAccess,
    ) -> Self {
        let ros_paths = package::ros_package_path();
        Meshes {
            urdf_path,
            package_paths,
            roots: MeshRoots::new(urdf_path, package_paths, &ros_paths, access),
            ros_paths,
            link: "",
            uses: Vec::new(),
        }
    }
}

/// A `<visual>` element, the `k`th of its link: its pose in the link frame, its geometry (what
/// is wrong with it, an unresolved mesh included, goes to the link's `problems`) and its colour,
/// its own or that of the robot's material it names.
pub(super) fn visual(
    v: &urdf_rs::Visual,
    k: usize,
    meshes: &mut Meshes,
    materials: &HashMap<&str, [f32; 4]>,
    problems: &mut Vec<String>,
) -> Visual {
    let label = match &v.name {
        Some(name) => format!("visual `{name}`"),
        None => format!("visual #{k}"),
    };
    let geometry = geometry(&v.geometry, &label, meshes, problems);
    let rgba = v.material.as_ref().and_then(|m| match &m.color {
        Some(c) => Some(rgba(c)),
        None => materials.get(m.name.as_str()).copied(),
    });
    Visual {
        name: v.name.clone(),
        link_from_visual: kinematics::isometry_from_pose(&v.origin),
        geometry,
        rgba,
    }
}

/// A `<collision>` element. Its geometry is used for mass properties (inertia policy
/// `geometry` or `auto`, `inspect --compare`) and for colliders (a scene's `collisions =
/// "urdf"`), so what is wrong with it (an unresolved mesh, a zero size) is reported when it is
/// used, not as a problem of the link at load time; a mesh refused by
/// [`crate::model::confine`] is a problem of the link all the same.
pub(super) fn collision(c: &urdf_rs::Collision, k: usize, meshes: &mut Meshes) -> Collision {
    let label = match &c.name {
        Some(name) => format!("collision `{name}`"),
        None => format!("collision #{k}"),
    };
    let mut unused = Vec::new();
    Collision {
        name: c.name.clone(),
        link_from_collision: kinematics::isometry_from_pose(&c.origin),
        geometry: geometry(&c.geometry, &label, meshes, &mut unused),
    }
}

/// A URDF geometry in SI units, with `package://` and relative mesh paths resolved and
/// confined ([`crate::model::confine`]: a refused mesh gets no path); what is wrong with it goes
/// to `problems`, prefixed by `label` (refusals go to `meshes.uses` only).
fn geometry(
    g: &urdf_rs::Geometry,
    label: &str,
    meshes: &mut Meshes,
    problems: &mut Vec<String>,
) -> Geometry {
    let positive = |values: &[f64]| values.iter().all(|x| x.is_finite() && *x > 0.0);
    match g {
        urdf_rs::Geometry::Box { size } => {
            if !positive(&size.0) {
                problems.push(format!(
                    "{label}: box size {:?} must be positive and finite",
                    size.0
                ));
            }
            Geometry::Box {
                size: Vector3::from(size.0),
            }
        }
        urdf_rs::Geometry::Cylinder { radius, length } => {
            if !positive(&[*radius, *length]) {
                problems.push(format!(
                "{label}: cylinder radius {radius} and length {length} must be positive and finite"
            ));
            }
            Geometry::Cylinder {
                radius: *radius,
                length: *length,
            }
        }
        urdf_rs::Geometry::Capsule { radius, length } => {
            if !(positive(&[*radius]) && length.is_finite() && *length >= 0.0) {
                problems.push(format!(
                "{label}: capsule radius {radius} must be positive and length {length} non-negative"
            ));
            }
            Geometry::Capsule {
                radius: *radius,
                length: *length,
            }
        }
        urdf_rs::Geometry::Sphere { radius } => {
            if !positive(&[*radius]) {
                problems.push(format!(
                    "{label}: sphere radius {radius} must be positive and finite"
                ));
            }
            Geometry::Sphere { radius: *radius }
        }
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let scale = scale.map_or(Vector3::repeat(1.0), |s| Vector3::from(s.0));
            if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                problems.push(format!(
                    "{label}: mesh scale [{}, {}, {}] must be finite and non-zero",
                    scale.x, scale.y, scale.z
                ));
            }
            let (found, unresolved) = match package::resolve_detailed(
                filename,
                meshes.urdf_path,
                meshes.package_paths,
                &meshes.ros_paths,
            ) {
                Ok(path) => (Some(path), None),
                // A file that exists but must not be read (a device, a FIFO, over the size
                // cap) is kept, so that whoever reads it says why it cannot (`crate::input`),
                // unless it is outside the folders meshes are read from.
                Err(package::Unresolved::NotReadable { path, reason }) => (
                    Some(path.clone()),
                    Some(package::Unresolved::NotReadable { path, reason }),
                ),
                Err(why) => (None, Some(why)),
            };
            let mut unresolved_problem = || {
                unresolved.as_ref().map(|why| {
                    let sep = if *why == package::Unresolved::NotFound {
                        " "
                    } else {
                        ": "
                    };
                    problems.push(format!("{label}: mesh `{filename}`{sep}{why}"));
                    MeshStatus::Unresolved(why.to_string())
                })
            };
            let (path, real_path, status) = match found.as_ref().map(|p| meshes.roots.check(p)) {
                Some(Ok((real, root))) => {
                    let allowed = MeshStatus::Allowed {
                        root: root.to_string(),
                    };
                    let status = unresolved_problem().unwrap_or(allowed);
                    (found.clone(), Some(real), status)
                }
                Some(Err(refusal)) => {
                    let real = match &refusal {
                        Refusal::Outside { real_path, .. } => Some(real_path.clone()),
                        Refusal::NoRealPath { .. } => None,
                    };
                    (None, real, MeshStatus::Refused(refusal))
                }
                None => {
                    let status = unresolved_problem()
                        .unwrap_or_else(|| MeshStatus::Unresolved(String::new()));
                    (None, None, status)
                }
            };
            meshes.uses.push(MeshUse {
                link: meshes.link.to_string(),
                element: label.to_string(),
                uri: filename.clone(),
                path: found,
                real_path,
                status,
            });
            Geometry::Mesh {
                uri: filename.clone(),
                path,
                scale,
            }
        }
    }
}
