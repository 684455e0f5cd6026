//! A link's mass properties from its geometry: every shape of one set (`<collision>` or
//! `<visual>`) at a uniform density, placed by its `<origin>` and summed.
//!
//! ```text
//! part k in the link frame:  com_k = link_from_shape_k · com_shape_k,  I_k = R_k I_shape_k R_kᵀ
//! link:                       MassProperties::combine(parts)   (parallel-axis theorem)
//! ```
//!
//! Choice of set ([`GeometrySource`]): the preferred set when the link has at least one element
//! of it, the other set otherwise (a fallback, recorded in [`GeometryUsed::fallback`]). The
//! fallback is by presence only: when the preferred set exists but one of its shapes cannot give
//! mass properties (an unresolved or unreadable mesh, a zero dimension) that is an error, not a
//! silent switch to the other set.
//!
//! Shapes are summed as if disjoint: overlapping shapes (common in collision models) count the
//! shared volume twice.

use super::mesh::MeshError;
use super::mesh_io;
use super::primitives::{self, DimensionError};
use crate::model::policy::GeometrySource;
use crate::model::{Geometry, Link, MassProperties};
use nalgebra::Isometry3;
use std::path::PathBuf;

/// Which geometry a link's mass properties were computed from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GeometryUsed {
    /// The set the shapes came from.
    pub set: GeometrySource,
    /// `true` when `set` is not the one asked for (the link had none of that set).
    pub fallback: bool,
    /// Number of shapes summed.
    pub shapes: usize,
    /// Uniform density, kg/m^3.
    pub density_kg_per_m3: f64,
}

impl GeometryUsed {
    /// E.g. "2 collision shapes at 1000 kg/m^3" or "1 visual shape (no collision geometry) at
    /// 2700 kg/m^3".
    pub fn describe(&self) -> String {
        let set = set_name(self.set);
        let plural = if self.shapes == 1 { "" } else { "s" };
        let fallback = if self.fallback {
            format!(" (no {} geometry)", set_name(other(self.set)))
        } else {
            String::new()
        };
        format!(
            "{} {set} shape{plural}{fallback} at {} kg/m^3",
            self.shapes, self.density_kg_per_m3
        )
    }
}

/// Mass properties computed from a link's geometry, and what they were computed from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkGeometryMass {
    /// In the link frame (centre of mass in link coordinates, inertia about it in link axes).
    pub mass_properties: MassProperties,
    pub used: GeometryUsed,
}

/// Why a link's geometry gives no mass properties. Messages name the element
/// (`collision #0`, ``visual `arm` ``) but not the link or file: the caller adds them.
#[derive(Debug, thiserror::Error)]
pub enum GeometryError {
    #[error("it has no <collision> or <visual> geometry")]
    NoGeometry,
    #[error("density {0} kg/m^3 must be positive and finite")]
    Density(f64),
    #[error("{element}: {reason}")]
    Dimensions {
        element: String,
        reason: DimensionError,
    },
    #[error(
        "{element}: mesh `{uri}` not found (searched --package-path, ROS_PACKAGE_PATH and the \
         URDF's parent folders)"
    )]
    MeshNotFound { element: String, uri: String },
    /// A mesh URI refused for its form alone (malformed, or a `package://` path climbing out
    /// of its package: [`crate::model::package::uri_problem`]).
    #[error("{element}: mesh `{uri}`: {reason}")]
    MeshUri {
        element: String,
        uri: String,
        reason: crate::model::package::Unresolved,
    },
    #[error("{element}: mesh `{uri}` ({}): {reason}", .path.display())]
    Mesh {
        element: String,
        uri: String,
        path: PathBuf,
        reason: Box<MeshError>,
    },
    #[error("{element}: mass {mass_kg} kg is not a positive finite number")]
    Mass { element: String, mass_kg: f64 },
}

fn set_name(set: GeometrySource) -> &'static str {
    match set {
        GeometrySource::Collision => "collision",
        GeometrySource::Visual => "visual",
    }
}

fn other(set: GeometrySource) -> GeometrySource {
    match set {
        GeometrySource::Collision => GeometrySource::Visual,
        GeometrySource::Visual => GeometrySource::Collision,
    }
}

/// One shape of a link: its label in messages, its pose in the link frame, its geometry.
pub struct Shape<'a> {
    pub element: String,
    pub link_from_shape: &'a Isometry3<f64>,
    pub geometry: &'a Geometry,
}

/// The link's shapes of one set, labelled like the loader's messages (`collision #k` or
/// ``collision `name` ``).
pub fn shapes(link: &Link, set: GeometrySource) -> Vec<Shape<'_>> {
    let label = |kind: &str, name: &Option<String>, k: usize| match name {
        Some(name) => format!("{kind} `{name}`"),
        None => format!("{kind} #{k}"),
    };
    match set {
        GeometrySource::Collision => link
            .collisions
            .iter()
            .enumerate()
            .map(|(k, c)| Shape {
                element: label("collision", &c.name, k),
                link_from_shape: &c.link_from_collision,
                geometry: &c.geometry,
            })
            .collect(),
        GeometrySource::Visual => link
            .visuals
            .iter()
            .enumerate()
            .map(|(k, v)| Shape {
                element: label("visual", &v.name, k),
                link_from_shape: &v.link_from_visual,
                geometry: &v.geometry,
            })
            .collect(),
    }
}

/// Mass properties of one geometry in its own frame at `density_kg_per_m3`: closed forms for
/// the primitives ([`primitives`]), the mesh reader and integrator for meshes
/// ([`mesh_io::load_mesh`], scaled, then [`super::mesh::TriangleMesh::mass_properties`]).
pub fn geometry_mass_properties(
    element: &str,
    geometry: &Geometry,
    density_kg_per_m3: f64,
) -> Result<MassProperties, GeometryError> {
    let dimensions = |reason| GeometryError::Dimensions {
        element: element.to_string(),
        reason,
    };
    let mp = match geometry {
        Geometry::Box { size } => {
            primitives::cuboid(size, density_kg_per_m3).map_err(dimensions)?
        }
        Geometry::Cylinder { radius, length } => {
            primitives::cylinder(*radius, *length, density_kg_per_m3).map_err(dimensions)?
        }
        Geometry::Sphere { radius } => {
            primitives::sphere(*radius, density_kg_per_m3).map_err(dimensions)?
        }
        Geometry::Capsule { radius, length } => {
            primitives::capsule(*radius, *length, density_kg_per_m3).map_err(dimensions)?
        }
        Geometry::Mesh { uri, path, scale } => {
            let Some(path) = path else {
                if let Some(reason) = crate::model::package::uri_problem(uri) {
                    return Err(GeometryError::MeshUri {
                        element: element.to_string(),
                        uri: uri.clone(),
                        reason,
                    });
                }
                return Err(GeometryError::MeshNotFound {
                    element: element.to_string(),
                    uri: uri.clone(),
                });
            };
            let mesh_error = |reason| GeometryError::Mesh {
                element: element.to_string(),
                uri: uri.clone(),
                path: path.clone(),
                reason: Box::new(reason),
            };
            let mesh = mesh_io::load_mesh(path).map_err(mesh_error)?;
            mesh.scaled(scale)
                .mass_properties(density_kg_per_m3)
                .map_err(mesh_error)?
        }
    };
    if !(mp.mass.is_finite() && mp.mass > 0.0) {
        return Err(GeometryError::Mass {
            element: element.to_string(),
            mass_kg: mp.mass,
        });
    }
    Ok(mp)
}

/// The sum of `shapes` in the link frame, each placed by its pose (see the module docs).
/// `None` when there are no shapes.
pub fn shapes_mass_properties(
    shapes: &[Shape],
    density_kg_per_m3: f64,
) -> Result<Option<MassProperties>, GeometryError> {
    if !(density_kg_per_m3.is_finite() && density_kg_per_m3 > 0.0) {
        return Err(GeometryError::Density(density_kg_per_m3));
    }
    let parts = shapes
        .iter()
        .map(|s| {
            geometry_mass_properties(&s.element, s.geometry, density_kg_per_m3)
                .map(|mp| mp.transformed(s.link_from_shape))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(MassProperties::combine(&parts))
}

/// The link's mass properties from its geometry: the `prefer`red set, or the other one when the
/// link has none of the preferred set (see the module docs).
pub fn link_mass_properties(
    link: &Link,
    prefer: GeometrySource,
    density_kg_per_m3: f64,
) -> Result<LinkGeometryMass, GeometryError> {
    let (set, fallback, shapes) = match shapes(link, prefer) {
        preferred if !preferred.is_empty() => (prefer, false, preferred),
        _ => (other(prefer), true, shapes(link, other(prefer))),
    };
    if shapes.is_empty() {
        return Err(GeometryError::NoGeometry);
    }
    let mass_properties =
        shapes_mass_properties(&shapes, density_kg_per_m3)?.ok_or(GeometryError::NoGeometry)?;
    Ok(LinkGeometryMass {
        mass_properties,
        used: GeometryUsed {
            set,
            fallback,
            shapes: shapes.len(),
            density_kg_per_m3,
        },
    })
}
